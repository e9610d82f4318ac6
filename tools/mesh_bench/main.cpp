// mesh_bench: raylife's BVH over a triangle mesh, measured: the build's time (on every core) and memory, and the
// speed of closest-hit queries for camera rays and for diffuse bounce rays, one thread. Built with Embree (the `embree`
// preset, `./setup.sh --embree`), it traces the very same rays through Embree 3's rtcIntersect1, side by side in
// the same run, and reports the ratio and how often the two agree. Embree is a yardstick here, nothing more: no
// chapter uses it.
//
// usage: mesh_bench MESH.ply|MESH.obj|SCENE.json [--size WxH] [--seconds S] [--seed N] [--build-rounds R]
//                   [--no-embree] [--embree-isa ISA] [--embree-robust] [--check]
//                   [--passes N camera|bounce|embree-camera|embree-bounce]
//   Rays: a camera looking at the mesh from outside its bounding sphere, one ray through each pixel (W×H, default
//   512x512), and from every camera hit one ray in a cosine-distributed direction about the surface's normal (the
//   rays a diffuse bounce makes). A scene: its triangles (every mesh, placed as the scene places it; its spheres
//   left out) seen through its own camera, one ray through each pixel. Each query set is timed for about S seconds
//   (default 1), best of three rounds; beside Embree, raylife's and Embree's queries in turns, ten rounds of S/10
//   seconds each, and the ratio is the median of the rounds' ratios (the Mrays/s printed are each one's best round).
//   The builds are timed again on one thread and on every core, best of R rounds (default 2), raylife's and
//   Embree's each on its best thread count, and their ratio printed: the queries run on one thread, a build may not.
//   --embree-isa ISA: the widest instruction set Embree's kernels may use (sse2, sse4.2, avx, avx2 or avx512; its
//   max_isa), where by default Embree takes the widest the CPU has. Its widest is not always its fastest: on an AMD
//   Zen 4, whose AVX-512 runs in halves of 256 bits, Embree's AVX2 kernels trace these rays faster than its AVX-512
//   ones, so a fair yardstick there is `--embree-isa avx2`. The line "Embree's kernels" says which set they use.
//   --embree-robust: Embree's scene built with RTC_SCENE_FLAG_ROBUST, its mode without its default one's shortcuts:
//   a robust box test, and its Plücker triangle test in place of Möller and Trumbore's, through which a ray can slip
//   between neighbouring triangles. raylife never takes those shortcuts (its box test is conservative, its triangle
//   test watertight), so this is the nearest yardstick Embree offers. By default Embree runs its fast mode.
//   --check: exit 1 if raylife and Embree disagree (hit, or distance) on more than 0.1 % of the rays, or if raylife
//   lets one of the edge rays (below) through.
//   Edge rays: beside Embree, 100,000 more rays, each aimed at a random point of an edge that two triangles share,
//   from a direction in which the two lie on either side of it (not the mesh's silhouette there), starting 1 % of the
//   mesh's size before it. Such a ray must hit one of the two or something before them; a query that finds nothing
//   there lets it through a crack a watertight test does not have. The line "edge rays" counts them for each.
//   --passes N SET: instead of the timings, N passes of one set of rays through one of the two (raylife's by
//   default, Embree's for embree-…), then exit: a fixed amount of work for a profiler. The difference between two
//   runs with different N is what the queries alone cost, e.g. instructions a query from
//     valgrind --tool=callgrind --toggle-collect='*queryEight<false, false>*' mesh_bench M.ply --passes 5 bounce
#include "bench_build.h"
#include "core/rng.h"
#include "core/sampling.h"
#include "core/frame.h"
#include "geometry/bvh.h"
#include "scene/mesh_file.h"
#include "scene/scene.h"

#if RAYLIFE_EMBREE
#include "../embree_ray.h"
#endif

#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <functional>
#include <limits>
#include <string>
#include <thread>
#include <vector>

using namespace raylife;

namespace {

using Clock = std::chrono::steady_clock;

double seconds(Clock::time_point since) { return std::chrono::duration<double>(Clock::now() - since).count(); }

// CPU time of this process so far (all its threads), in seconds: on a busy machine the wall clock also counts the
// time other programs took.
double cpuSeconds()
{
  timespec t{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return double(t.tv_sec) + 1e-9 * double(t.tv_nsec);
}

// Peak resident memory of this process so far, in MB.
double peakMegabytes()
{
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return double(usage.ru_maxrss) / 1024.0;
}

// Resident memory of this process now, in MB (Linux's /proc/self/statm).
double residentMegabytes()
{
  std::FILE* f = std::fopen("/proc/self/statm", "r");
  long pages = 0, resident = 0;
  if (f) {
    if (std::fscanf(f, "%ld %ld", &pages, &resident) != 2)
      resident = 0;
    std::fclose(f);
  }
  return double(resident) * double(sysconf(_SC_PAGESIZE)) / (1024.0 * 1024.0);
}

// Rays per second of `query` over `rays`, in as many passes as fill about `span` seconds.
double rate(const std::vector<Ray>& rays, double span, const std::function<void(const Ray&)>& query)
{
  const auto start = Clock::now();
  std::size_t traced = 0;
  do {
    for (const Ray& r : rays)
      query(r);
    traced += rays.size();
  } while (seconds(start) < span);
  return double(traced) / seconds(start);
}

// Rays per second of `query` over `rays`: about `budget` seconds in all, best of three rounds.
double raysPerSecond(const std::vector<Ray>& rays, double budget, const std::function<void(const Ray&)>& query)
{
  double best = 0;
  for (int round = 0; round < 3; ++round)
    best = std::max(best, rate(rays, budget / 3, query));
  return best;
}

#if RAYLIFE_EMBREE
// Two queries over the same rays, timed in turns: `rounds` rounds, in each of which both get about budget/rounds
// seconds, one after the other (which goes first alternates). A change in the machine's load (these machines are
// shared) then falls on both alike, and each round's ratio compares the two under the same load.
struct Turns {
  double ours = 0, theirs = 0; // the best rays per second of each
  std::vector<double> ratios;  // each round's ours / theirs, sorted
  double median() const { return ratios[ratios.size() / 2]; } // (of an even count, the upper of the middle two)
};
Turns inTurns(const std::vector<Ray>& rays, double budget, int rounds, const std::function<void(const Ray&)>& ours,
              const std::function<void(const Ray&)>& theirs)
{
  Turns turns;
  for (int round = 0; round < rounds; ++round) {
    const double slice = budget / rounds;
    double a, b;
    if (round % 2 == 0) {
      a = rate(rays, slice, ours);
      b = rate(rays, slice, theirs);
    } else {
      b = rate(rays, slice, theirs);
      a = rate(rays, slice, ours);
    }
    turns.ours = std::max(turns.ours, a);
    turns.theirs = std::max(turns.theirs, b);
    turns.ratios.push_back(a / b);
  }
  std::sort(turns.ratios.begin(), turns.ratios.end());
  return turns;
}
#endif

struct Options {
  std::string mesh;
  int width = 512, height = 512;
  double budget = 1;
  std::uint64_t seed = 1;
  int buildRounds = 2; // each build timed this many times on one thread and on every core, the best kept
  bool embree = true;
  std::string embreeIsa; // --embree-isa: Embree's max_isa; empty: Embree's own choice, the widest the CPU has
  bool embreeRobust = false; // --embree-robust: Embree's scene in its robust mode (RTC_SCENE_FLAG_ROBUST)
  bool check = false; // exit 1 when raylife and Embree disagree on more than 0.1 % of the rays
  // --passes N SET: only N passes of one query set (camera or bounce, raylife's; embree-camera or embree-bounce),
  // untimed, then exit: a fixed amount of work for a profiler. 0: off.
  int passes = 0;
  std::string passSet;
};

bool parse(int argc, char** argv, Options& o)
{
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--size" && i + 1 < argc) {
      if (std::sscanf(argv[++i], "%dx%d", &o.width, &o.height) != 2 || o.width < 1 || o.height < 1 ||
          o.width > 8192 || o.height > 8192)
        return false;
    } else if (arg == "--seconds" && i + 1 < argc) {
      o.budget = std::atof(argv[++i]);
      if (!(o.budget > 0 && o.budget < 1000))
        return false;
    } else if (arg == "--seed" && i + 1 < argc) {
      o.seed = std::strtoull(argv[++i], nullptr, 10);
    } else if (arg == "--build-rounds" && i + 1 < argc) {
      o.buildRounds = std::atoi(argv[++i]);
      if (o.buildRounds < 1 || o.buildRounds > 100)
        return false;
    } else if (arg == "--passes" && i + 2 < argc) {
      o.passes = std::atoi(argv[++i]);
      o.passSet = argv[++i];
      if (o.passes < 1 || o.passes > 1000000 ||
          (o.passSet != "camera" && o.passSet != "bounce" && o.passSet != "embree-camera" &&
           o.passSet != "embree-bounce"))
        return false;
    } else if (arg == "--check") {
      o.check = true;
    } else if (arg == "--no-embree") {
      o.embree = false;
    } else if (arg == "--embree-robust") {
      o.embreeRobust = true;
    } else if (arg == "--embree-isa" && i + 1 < argc) {
      // (Embree takes a name it does not know as SSE without a word: only its own names get through.)
      o.embreeIsa = argv[++i];
      if (o.embreeIsa != "sse2" && o.embreeIsa != "sse4.2" && o.embreeIsa != "avx" && o.embreeIsa != "avx2" &&
          o.embreeIsa != "avx512") {
        std::fprintf(stderr, "mesh_bench: --embree-isa %s: not one of Embree's names sse2, sse4.2, avx, avx2, avx512\n",
                     o.embreeIsa.c_str());
        return false;
      }
    } else if (!arg.empty() && arg[0] != '-' && o.mesh.empty()) {
      o.mesh = arg;
    } else {
      return false;
    }
  }
  return !o.mesh.empty();
}

} // namespace

// How far before its edge an edge ray starts, as a share of the mesh's size (`size`, its bounding sphere's radius).
constexpr Real kEdgeRayLead = Real(0.01);

// Rays through the shared edges of a mesh (see "Edge rays" above): `count` of them, each starting kEdgeRayLead · size
// before the point of the edge it is aimed at.
std::vector<Ray> edgeRays(const std::vector<Vec3>& positions, const std::vector<Triangle>& triangles, Real size,
                          std::size_t count, Pcg32& rng)
{
  // The edges two triangles share: (lower vertex, higher vertex, triangle), sorted, then the runs of exactly two.
  std::vector<std::array<std::uint32_t, 3>> sides;
  sides.reserve(3 * triangles.size());
  for (std::size_t t = 0; t < triangles.size(); ++t)
    for (int k = 0; k < 3; ++k) {
      const std::uint32_t a = triangles[t].v[std::size_t(k)], b = triangles[t].v[std::size_t((k + 1) % 3)];
      sides.push_back({std::min(a, b), std::max(a, b), std::uint32_t(t)});
    }
  std::sort(sides.begin(), sides.end());
  std::vector<std::size_t> shared; // index of the first of each pair
  for (std::size_t i = 0; i + 1 < sides.size();) {
    std::size_t j = i + 1;
    while (j < sides.size() && sides[j][0] == sides[i][0] && sides[j][1] == sides[i][1])
      ++j;
    if (j - i == 2 && sides[i][0] != sides[i][1])
      shared.push_back(i);
    i = j;
  }
  std::vector<Ray> rays;
  if (shared.empty())
    return rays;
  auto uniform = [&rng] { return Real(rng.nextUint()) * Real(0x1p-32); };
  auto third = [&](std::uint32_t t, std::uint32_t a, std::uint32_t b) {
    for (const std::uint32_t v : triangles[t].v)
      if (v != a && v != b)
        return positions[v];
    return positions[a];
  };
  for (std::size_t tries = 0; rays.size() < count && tries < 20 * count; ++tries) {
    const auto& e = sides[shared[std::size_t(rng.nextUint()) % shared.size()]];
    const auto& f = sides[&e - sides.data() + 1];
    const Vec3 a = positions[e[0]], b = positions[e[1]];
    const Vec3 edge = b - a, c1 = third(e[2], e[0], e[1]) - a, c2 = third(f[2], e[0], e[1]) - a;
    // A direction in which the two triangles lie clearly on either side of the edge, neither seen edge on.
    const Vec3 d = glm::normalize(Vec3(uniform() - Real(0.5), uniform() - Real(0.5), uniform() - Real(0.5)));
    const Real s1 = glm::dot(glm::cross(edge, c1), d), s2 = glm::dot(glm::cross(edge, c2), d);
    const Real scale = glm::length(edge) * std::max(glm::length(c1), glm::length(c2));
    if (!(s1 * s2 < 0) || std::abs(s1) < Real(0.05) * scale || std::abs(s2) < Real(0.05) * scale)
      continue;
    const Vec3 target = a + edge * (Real(0.05) + Real(0.9) * uniform());
    rays.push_back(Ray{target - d * (kEdgeRayLead * size), d, 0, kInfinity});
  }
  return rays;
}

int main(int argc, char** argv)
{
  Options o;
  if (!parse(argc, argv, o)) {
    std::fprintf(stderr, "usage: mesh_bench MESH.ply|MESH.obj|SCENE.json [--size WxH] [--seconds S] [--seed N] "
                         "[--build-rounds R] [--no-embree] [--embree-isa sse2|sse4.2|avx|avx2|avx512] "
                         "[--embree-robust] [--check] [--passes N camera|bounce|embree-camera|embree-bounce]\n");
    return 2;
  }
  reportBenchBuild("mesh_bench");
  bool embree = false; // Embree's queries measured too
#if RAYLIFE_EMBREE
  embree = o.embree;
#endif
  if (o.passes > 0 && o.check) {
    std::fprintf(stderr, "mesh_bench: --passes and --check do not go together: --passes only runs the queries\n");
    return 2;
  }
  if (!o.embreeIsa.empty() && !embree) {
    std::fprintf(stderr,
                 "mesh_bench: --embree-isa %s needs Embree: built with the embree preset, without --no-embree\n",
                 o.embreeIsa.c_str());
    return 2;
  }
  if (o.embreeRobust && !embree) {
    std::fprintf(stderr,
                 "mesh_bench: --embree-robust needs Embree: built with the embree preset, without --no-embree\n");
    return 2;
  }
  if (o.passSet.rfind("embree", 0) == 0 && !embree) {
    std::fprintf(stderr, "mesh_bench: --passes %d %s needs Embree: built with the embree preset, without --no-embree\n",
                 o.passes, o.passSet.c_str());
    return 2;
  }
  const double baseline = peakMegabytes();
  MeshData mesh;
  std::vector<Triangle> triangles;
  std::optional<Camera> sceneCamera; // a scene's own camera
  const auto loadStart = Clock::now();
  const bool isScene = o.mesh.size() >= 5 && o.mesh.compare(o.mesh.size() - 5, 5, ".json") == 0;
  try {
    if (isScene) {
      Scene scene = loadScene(o.mesh);
      mesh.positions = scene.vertices;
      triangles = scene.triangles;
      sceneCamera = scene.makeCamera(o.width, o.height);
      if (!scene.spheres.empty())
        std::printf("mesh_bench: %s: its %zu spheres left out (the triangles are measured)\n", o.mesh.c_str(),
                    scene.spheres.size());
    } else {
      mesh = readMeshFile(o.mesh);
      triangles.reserve(mesh.triangles.size());
      for (const auto& t : mesh.triangles)
        triangles.push_back(Triangle{t, 0, 0});
    }
  } catch (const MeshError& e) {
    std::fprintf(stderr, "mesh_bench: %s\n", e.what());
    return 1;
  } catch (const SceneError& e) {
    std::fprintf(stderr, "mesh_bench: %s\n", e.what());
    return 1;
  }
  if (triangles.empty()) {
    std::fprintf(stderr, "mesh_bench: %s: no triangles to measure\n", o.mesh.c_str());
    return 1;
  }
  const double loadSeconds = seconds(loadStart);
  // (The file is parsed in a child process: the peak here is this process's own.)
  std::printf("mesh: %s, %zu triangles, %zu vertices, loaded in %.2f s (peak memory while loading: %.0f MB, of "
              "which %.0f before; held after: %.0f MB)\n",
              o.mesh.c_str(), triangles.size(), mesh.positions.size(), loadSeconds, peakMegabytes(), baseline,
              residentMegabytes());

  // ---- raylife's build ----------------------------------------------------------------------------------------
  const auto buildStart = Clock::now();
  const double buildCpuStart = cpuSeconds();
  const Bvh bvh(std::span<const Sphere>(), mesh.positions, triangles);
  const double buildSeconds = seconds(buildStart), buildCpu = cpuSeconds() - buildCpuStart;
  std::printf("raylife BVH: built in %.2f s (on every core; %.2f s of CPU time), %zu wide nodes, depth %d; peak "
              "memory %.0f MB, held after the build %.0f MB\n",
              buildSeconds, buildCpu, bvh.wideNodes().size(), bvh.depth(), peakMegabytes(), residentMegabytes());
  // Bytes a triangle: the mesh as a scene holds it (its vertices and triangles) and what the queries use of the tree.
  const double meshBytes =
      double(mesh.positions.size() * sizeof(Vec3) + triangles.size() * sizeof(Triangle));
  std::printf("memory: mesh %.1f + tree %.1f = %.1f bytes a triangle\n", meshBytes / double(triangles.size()),
              double(bvh.memoryBytes()) / double(triangles.size()),
              (meshBytes + double(bvh.memoryBytes())) / double(triangles.size()));

  // The build again on one thread and on every core, best of the rounds, and the tree's SAH cost (the binary tree
  // kept for it). The trees must be the same whatever the threads.
  const int cores = int(std::max(1u, std::thread::hardware_concurrency()));
  double ourBuild[2] = {1e30, 1e30}; // one thread, every core: best wall-clock seconds
  double ourCpu[2] = {1e30, 1e30};   // and least CPU time (on a busy machine the steadier figure)
  double sah = 0;
  bool sameTree = true;
  for (int round = 0; round < o.buildRounds; ++round)
    for (int k = 0; k < 2; ++k) {
      BvhBuildOptions options;
      options.buildThreads = k == 0 ? 1 : cores;
      options.keepBinaryTree = true;
      const auto start = Clock::now();
      const double cpuStart = cpuSeconds();
      const Bvh again(std::span<const Sphere>(), mesh.positions, triangles, options);
      ourBuild[k] = std::min(ourBuild[k], seconds(start));
      ourCpu[k] = std::min(ourCpu[k], cpuSeconds() - cpuStart);
      sah = again.sahCost();
      sameTree = sameTree && again.wideNodes().size() == bvh.wideNodes().size() &&
                 std::memcmp(again.wideNodes().data(), bvh.wideNodes().data(),
                             bvh.wideNodes().size() * sizeof(BvhWideNode)) == 0;
    }
  [[maybe_unused]] const int ourBest = ourBuild[1] < ourBuild[0] ? 1 : 0;
  // A fingerprint of the tree (FNV-1a over the wide nodes' bytes), to tell two builders' trees apart.
  std::uint64_t fingerprint = 0xcbf29ce484222325ull;
  const auto* bytes = reinterpret_cast<const unsigned char*>(bvh.wideNodes().data());
  for (std::size_t i = 0; i < bvh.wideNodes().size() * sizeof(BvhWideNode); ++i)
    fingerprint = (fingerprint ^ bytes[i]) * 0x100000001b3ull;
  std::printf("raylife BVH build, best of %d: %.3f s on 1 thread (CPU %.3f s), %.3f s on %d (CPU %.3f s); SAH cost "
              "%.4f; the same wide nodes whatever the threads: %s (fingerprint %016llx)\n",
              o.buildRounds, ourBuild[0], ourCpu[0], ourBuild[1], cores, ourCpu[1], double(sah),
              sameTree ? "yes" : "NO", static_cast<unsigned long long>(fingerprint));

  // ---- The rays ---------------------------------------------------------------------------------------------
  Vec3 lo(kInfinity), hi(-kInfinity);
  for (const Vec3& p : mesh.positions) {
    lo = glm::min(lo, p);
    hi = glm::max(hi, p);
  }
  const Vec3 centre = (lo + hi) / Real(2);
  const Real radius = glm::length(hi - lo) / 2;
  const Vec3 eye = centre + Vec3(Real(0.3), Real(0.4), 1) * (Real(2.2) * radius);
  const Vec3 w = glm::normalize(eye - centre), u = glm::normalize(glm::cross(Vec3(0, 1, 0), w)), v = glm::cross(w, u);
  const Real half = Real(0.45); // tan of half the field of view: the mesh fills most of the image
  std::vector<Ray> cameraRays, bounceRays;
  Pcg32 rng(o.seed, 77);
  auto uniform = [&rng] { return Real(rng.nextUint()) * Real(0x1p-32); };
  for (int y = 0; y < o.height; ++y)
    for (int x = 0; x < o.width; ++x) {
      const Real fx = Real(x) + uniform();
      const Real fy = Real(y) + uniform();
      if (sceneCamera) {
        cameraRays.push_back(sceneCamera->ray(Vec2(fx, fy)));
      } else {
        const Real px = (2 * fx / Real(o.width) - 1) * half;
        const Real py = (1 - 2 * fy / Real(o.height)) * half;
        cameraRays.push_back(Ray{eye, glm::normalize(u * px + v * py - w), 0, kInfinity});
      }
    }
  for (const Ray& r : cameraRays)
    if (const std::optional<BvhHit> h = bvh.intersect(r)) {
      const Triangle& t = triangles[std::size_t(h->primitive)];
      const Vec3 &p0 = mesh.positions[t.v[0]], &p1 = mesh.positions[t.v[1]], &p2 = mesh.positions[t.v[2]];
      const auto b = intersectTriangle(r.origin, r.direction, p0, p1, p2, r.tmin, r.tmax);
      const TrianglePoint<Real> tp = trianglePoint(p0, p1, p2, b->b0, b->b1, b->b2);
      Vec3 n = triangleNormal(p0, p1, p2);
      if (glm::dot(n, r.direction) > 0)
        n = -n;
      // (One draw a statement, y first: C++ leaves the order of a call's arguments unspecified, GCC evaluating them
      // right to left and clang left to right; y first is GCC's order from when both were one call's arguments.)
      const Real uy = uniform();
      const Real ux = uniform();
      const Vec3 dir = Frame::fromNormal(n).toWorld(sampleCosineHemisphere(Vec2(ux, uy)));
      // tmin: Embree works in float, where the origin's rounding (about 1e-7 of the mesh's size) would let it find
      // the triangle the ray leaves; both queries skip the first 1e-5 of the mesh's size.
      bounceRays.push_back(Ray{offsetRayOrigin(tp.point, tp.error, n, dir), dir, Real(1e-5) * radius, kInfinity});
    }
  std::printf("rays: %zu camera rays (%zu hit the mesh), %zu diffuse bounce rays\n", cameraRays.size(),
              bounceRays.size(), bounceRays.size());

  // ---- raylife's queries --------------------------------------------------------------------------------------
  for (const auto& [set, what] : {std::pair{&cameraRays, "camera"}, std::pair{&bounceRays, "bounce"}}) {
    double boxes = 0, primitives = 0;
    for (const Ray& r : *set) {
      const BvhWork work = bvh.intersectWithWork(r).work;
      boxes += work.nodesVisited;
      primitives += work.primitivesTested;
    }
    std::printf("work per %s ray: %.1f boxes, %.1f triangles tested\n", what, boxes / double(set->size()),
                primitives / double(set->size()));
  }
  std::size_t sink = 0;
  auto ours = [&](const Ray& r) { sink += bvh.intersect(r).has_value(); };
  // N untimed passes of one set, for a profiler.
  auto passes = [&](const std::vector<Ray>& rays, const std::function<void(const Ray&)>& query) {
    for (int p = 0; p < o.passes; ++p)
      for (const Ray& r : rays)
        query(r);
    std::printf("%d passes of %zu %s rays (%zu hits in all)\n", o.passes, rays.size(), o.passSet.c_str(), sink);
  };
  if (o.passSet == "camera" || o.passSet == "bounce") {
    passes(o.passSet == "camera" ? cameraRays : bounceRays, ours);
    return 0;
  }
  if (!embree) { // (beside Embree, the two are timed in turns below)
    const double ourCamera = raysPerSecond(cameraRays, o.budget, ours);
    const double ourBounce = raysPerSecond(bounceRays, o.budget, ours);
    std::printf("raylife Bvh::intersect: camera rays %.2f Mrays/s, bounce rays %.2f Mrays/s\n", ourCamera / 1e6,
                ourBounce / 1e6);
  }

#if RAYLIFE_EMBREE
  if (o.embree) {
    // ---- Embree: the same triangles (in float, as Embree stores them), the same rays ----------------------------
    // The scene is built, timed only, on a device of every core, then on one of one thread, whose scene the queries
    // use (one thread, as raylife's): best of the rounds on each. (One device at a time: while a device of every
    // core lived, the one-thread device's builds took two cores' CPU time.)
    auto makeScene = [&](RTCDevice on) {
      RTCScene made = rtcNewScene(on);
      if (o.embreeRobust)
        rtcSetSceneFlags(made, RTC_SCENE_FLAG_ROBUST);
      RTCGeometry geometry = rtcNewGeometry(on, RTC_GEOMETRY_TYPE_TRIANGLE);
      auto* vertices = static_cast<float*>(rtcSetNewGeometryBuffer(geometry, RTC_BUFFER_TYPE_VERTEX, 0,
                                                                   RTC_FORMAT_FLOAT3, 3 * sizeof(float),
                                                                   mesh.positions.size()));
      for (std::size_t i = 0; i < mesh.positions.size(); ++i)
        for (int c = 0; c < 3; ++c)
          vertices[3 * i + std::size_t(c)] = float(mesh.positions[i][c]);
      auto* indices = static_cast<unsigned*>(rtcSetNewGeometryBuffer(geometry, RTC_BUFFER_TYPE_INDEX, 0,
                                                                     RTC_FORMAT_UINT3, 3 * sizeof(unsigned),
                                                                     triangles.size()));
      for (std::size_t i = 0; i < triangles.size(); ++i)
        for (int c = 0; c < 3; ++c)
          indices[3 * i + std::size_t(c)] = triangles[i].v[std::size_t(c)];
      rtcCommitGeometry(geometry);
      rtcAttachGeometry(made, geometry);
      rtcReleaseGeometry(geometry);
      return made;
    };
    double theirBuild[2] = {1e30, 1e30}; // one thread, every core
    double theirCpu[2] = {1e30, 1e30};   // least CPU seconds
    RTCDevice device = nullptr;
    RTCScene scene = nullptr;
    for (int k = 1; k >= 0; --k) {
      std::string config = "threads=" + std::to_string(k == 0 ? 1 : cores);
      if (!o.embreeIsa.empty())
        config += ",max_isa=" + o.embreeIsa; // (max_isa, not isa: never wider than the CPU has)
      device = rtcNewDevice(config.c_str());
      for (int round = 0; round < o.buildRounds; ++round) {
        RTCScene made = makeScene(device);
        const auto start = Clock::now();
        const double cpuStart = cpuSeconds();
        rtcCommitScene(made);
        theirBuild[k] = std::min(theirBuild[k], seconds(start));
        theirCpu[k] = std::min(theirCpu[k], cpuSeconds() - cpuStart);
        if (k == 0 && !scene)
          scene = made; // the one-thread device's scene answers the rays
        else
          rtcReleaseScene(made);
      }
      if (k == 1)
        rtcReleaseDevice(device);
    }
    const int theirBest = theirBuild[1] < theirBuild[0] ? 1 : 0;
    // Embree 3 names no instruction set, but its native packets say which kernels it took: sixteen-ray packets are
    // native in its AVX-512 kernels only, eight-ray ones in its AVX and AVX2 kernels.
    const char* kernels = rtcGetDeviceProperty(device, RTC_DEVICE_PROPERTY_NATIVE_RAY16_SUPPORTED) ? "AVX-512"
                          : rtcGetDeviceProperty(device, RTC_DEVICE_PROPERTY_NATIVE_RAY8_SUPPORTED) ? "AVX or AVX2"
                                                                                                    : "SSE";
    std::printf("Embree's kernels: %s (%s), %s mode\n", kernels,
                o.embreeIsa.empty() ? "its own choice for this CPU" : ("at most " + o.embreeIsa + ", as asked").c_str(),
                o.embreeRobust ? "robust (RTC_SCENE_FLAG_ROBUST)" : "its default, fast");
    std::printf("Embree BVH, default quality, best of %d: %.3f s on 1 thread (CPU %.3f s), %.3f s on %d (CPU %.3f s)\n",
                o.buildRounds, theirBuild[0], theirCpu[0], theirBuild[1], cores, theirCpu[1]);
    std::printf("build, each on its best thread count: raylife %.3f s (%d thread%s) / Embree %.3f s (%d thread%s) = "
                "%.2f\n",
                ourBuild[ourBest], ourBest ? cores : 1, ourBest && cores > 1 ? "s" : "", theirBuild[theirBest],
                theirBest ? cores : 1, theirBest && cores > 1 ? "s" : "", ourBuild[ourBest] / theirBuild[theirBest]);
    auto embreeHit = [&](const Ray& r) { return embreeIntersect(scene, r, float(r.tmin)); };
    auto theirs = [&](const Ray& r) { sink += embreeHit(r).hit.geomID != RTC_INVALID_GEOMETRY_ID; };
    if (o.passes > 0) {
      passes(o.passSet == "embree-camera" ? cameraRays : bounceRays, theirs);
      rtcReleaseScene(scene);
      rtcReleaseDevice(device);
      return 0;
    }
    // Both queries over each set of rays, in turns: S seconds each a set, in ten rounds.
    constexpr int kRounds = 10;
    const Turns camera = inTurns(cameraRays, o.budget, kRounds, ours, theirs);
    const Turns bounce = inTurns(bounceRays, o.budget, kRounds, ours, theirs);
    std::printf("raylife Bvh::intersect: camera rays %.2f Mrays/s, bounce rays %.2f Mrays/s\n", camera.ours / 1e6,
                bounce.ours / 1e6);
    std::printf("Embree rtcIntersect1: camera rays %.2f Mrays/s, bounce rays %.2f Mrays/s\n", camera.theirs / 1e6,
                bounce.theirs / 1e6);
    std::printf("raylife / Embree: camera rays %.2f, bounce rays %.2f (the median of %d rounds timed in turns; ranges "
                "%.2f-%.2f and %.2f-%.2f)\n",
                camera.median(), bounce.median(), kRounds, camera.ratios.front(), camera.ratios.back(),
                bounce.ratios.front(), bounce.ratios.back());
    // Agreement: the same hit or miss, and the same distance within float's precision of the mesh's size.
    std::size_t agree = 0, total = 0;
    for (const std::vector<Ray>* set : {&cameraRays, &bounceRays})
      for (const Ray& r : *set) {
        const std::optional<BvhHit> a = bvh.intersect(r);
        const RTCRayHit b = embreeHit(r);
        const bool theyHit = b.hit.geomID != RTC_INVALID_GEOMETRY_ID;
        agree += a.has_value() == theyHit &&
                 (!theyHit || std::abs(double(a->t) - double(b.ray.tfar)) <= 1e-4 * double(radius));
        ++total;
      }
    std::printf("agreement: %zu of %zu rays (%.4f%%) have the same hit or miss and distance (within 1e-4 of the "
                "mesh's size)\n",
                agree, total, 100.0 * double(agree) / double(total));
    // Edge rays: a hit up to the edge (with float's slack), or the ray went through a crack.
    const std::vector<Ray> edges = edgeRays(mesh.positions, triangles, radius, 100000, rng);
    const Real before = (kEdgeRayLead + Real(1e-4)) * radius; // the edge, with float's slack
    std::size_t ourLeaks = 0, theirLeaks = 0;
    for (const Ray& r : edges) {
      const std::optional<BvhHit> a = bvh.intersect(r);
      ourLeaks += !(a && a->t <= before);
      const RTCRayHit b = embreeHit(r);
      theirLeaks += !(b.hit.geomID != RTC_INVALID_GEOMETRY_ID && double(b.ray.tfar) <= double(before));
    }
    std::printf("edge rays: of %zu rays through edges that two triangles share, raylife lets %zu through, Embree "
                "(%s mode) %zu\n",
                edges.size(), ourLeaks, o.embreeRobust ? "robust" : "default", theirLeaks);
    rtcReleaseScene(scene);
    rtcReleaseDevice(device);
    // Float against double, and Embree's test is not watertight: a few rays in a hundred thousand may differ on an
    // edge. Fewer than 99.9 % in agreement is a bug in one of the two.
    if (o.check && double(agree) < 0.999 * double(total)) {
      std::fprintf(stderr, "mesh_bench: raylife and Embree disagree on %zu of %zu rays\n", total - agree, total);
      return 1;
    }
    if (o.check && ourLeaks > 0) {
      std::fprintf(stderr, "mesh_bench: raylife lets %zu of %zu edge rays through\n", ourLeaks, edges.size());
      return 1;
    }
  }
#else
  if (o.embree)
    std::printf("Embree: not built in (./setup.sh --embree, then cmake --preset embree)\n");
#endif
  std::printf("(%zu hits counted while timing)\n", sink); // the count keeps the queries from being optimised away
  return 0;
}

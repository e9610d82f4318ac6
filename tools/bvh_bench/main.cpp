// bvh_bench: measures the BVH against the flat list of spheres, on one thread, and draws heat maps of the work.
//
//   bvh_bench speed [SCENE.json] [--repeat R]
//       Mrays/s of the closest-hit query (camera rays) and of the any-hit query (shadow rays towards the point
//       lights), through the flat loop (one sphere at a time, as chapter 2 writes it), through the flat list four
//       spheres at a time (sphere_lanes.h, where the CPU has AVX2) and through the BVH, side by side, best of R
//       interleaved runs, each lasting about as long as one pass of the loop.
//   bvh_bench crossover [SCENE.json] [--repeat R]
//       The same for the N spheres nearest the focal point (the ground sphere always among them), N = 1 … 64:
//       where the tree starts to pay (Scene's kFlatListMaxPrimitives).
//   bvh_bench interleave [SCENE.json] [--repeat R]
//       Mrays/s of the closest-hit query through the tree one ray at a time, and with the walks of 2 and 4 rays
//       taken a node at a time in turn (Bvh::intersectInterleaved), on camera rays and on diffuse bounce rays from
//       where they hit: how much of a ray's time is spent waiting, which another ray's work can fill.
//   bvh_bench embree [SCENE.json] [--repeat R] [--check]
//       The yardstick: Mrays/s of raylife's closest-hit query through the scene (the primitives outside the tree,
//       then the tree, as the chapters ask it) and of Embree 3's, one ray at a time (rtcIntersect1) and eight
//       (rtcIntersect8), on the same spheres (Embree's own, in float) and the same camera and diffuse bounce rays,
//       side by side, best of R interleaved runs; and how often the two find the same sphere. Built with the
//       `embree` preset (./setup.sh --embree); --check exits 1 when they agree on fewer than 99.9 % of the rays.
//   bvh_bench heatmap [SCENE.json] --split sah|midpoint -o FILE.png|FILE.pfm [--width W] [--height H]
//       The work per pixel (camera ray and shadow rays, as in chapter 9's right image) with a tree built by the
//       given split; prints the tree's SAH cost and the mean work per pixel.
//
// The default scene is scenes/random_spheres.json. Times are the thread's CPU time (best of R runs), which a shared
// machine disturbs less than wall-clock time; still, compare ratios measured in one run.
#include "bench_build.h"
#include "render/heat_map.h"
#include "render/image_io.h"
#include "core/frame.h"
#include "core/rng.h"
#include "core/sampling.h"
#include "render/runner.h"
#include "scene/scene.h"
#include "shading/shading.h"

#include <algorithm>
#include <ctime>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <string>
#include <vector>

#if RAYLIFE_EMBREE
#include "../embree_ray.h"
#endif

using namespace raylife;

namespace {

// CPU time of this thread, in seconds: on a shared machine it leaves out the time other processes had the core,
// which wall-clock time does not.
double threadSeconds()
{
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec);
}

struct Rays {
  std::vector<Ray> camera; // one per pixel, through its centre
  std::vector<Ray> shadow; // from each camera hit towards each light in front of the surface
};

Rays makeRays(const Scene& scene, int width, int height)
{
  Rays rays;
  const Camera camera = scene.makeCamera(width, height);
  for (int y = 0; y < camera.height(); ++y)
    for (int x = 0; x < camera.width(); ++x) {
      const Ray ray = camera.ray(Vec2(Real(x) + Real(0.5), Real(y) + Real(0.5)));
      rays.camera.push_back(ray);
      if (const std::optional<Hit> hit = scene.intersect(ray)) {
        const Vec3 N = facingNormal(*hit, ray.direction);
        for (const PointLight& light : scene.lights)
          if (auto in = light.arrivalAt(hit->point); in && glm::dot(in->direction, N) > 0)
            rays.shadow.push_back(spawnRayTo(*hit, light.position));
      }
    }
  return rays;
}

// Seconds for `passes` passes of the closest-hit query over `rays`, and its hits in one (returned so that nothing
// is optimised out).
std::pair<double, std::size_t> timeClosest(const Scene& scene, const std::vector<Ray>& rays, int passes = 1)
{
  const double start = threadSeconds();
  std::size_t hits = 0;
  for (int p = 0; p < passes; ++p)
    for (const Ray& ray : rays)
      hits += scene.intersect(ray).has_value();
  return {threadSeconds() - start, hits / std::size_t(passes)};
}

std::pair<double, std::size_t> timeAny(const Scene& scene, const std::vector<Ray>& rays, int passes = 1)
{
  const double start = threadSeconds();
  std::size_t blocked = 0;
  for (int p = 0; p < passes; ++p)
    for (const Ray& ray : rays)
      blocked += scene.occluded(ray);
  return {threadSeconds() - start, blocked / std::size_t(passes)};
}

// Mrays/s of the three ways to search the spheres: the loop one by one, the flat list four at a time, the tree.
struct Speeds {
  double flatClosest, lanesClosest, bvhClosest, flatAny, lanesAny, bvhAny;
};

// The same scene three times: searched by the one-by-one loop, by the flat list four at a time (or, without AVX2,
// one by one again), and through a BVH (built whatever the sphere count).
struct Searches {
  Scene flat, lanes, tree;
};
Searches searches(const Scene& scene, BvhSplit split = BvhSplit::Sah)
{
  Searches s{scene, scene, scene};
  s.flat.accelerator = Bvh();
  s.flat.lanes = SphereLanes();
  s.lanes.accelerator = Bvh();
  s.lanes.lanes = SphereLanes(scene.spheres, fastestLaneTest());
  BvhBuildOptions options{split};
  options.keepBinaryTree = true; // the SAH cost it prints
  s.tree.accelerator = Bvh(s.tree.spheres, options);
  return s;
}

// Best of `repeat` interleaved runs of each query through each search (the best run is the least disturbed). Each
// run of a faster search makes as many passes over the rays as it takes to last about as long as one pass of the
// loop: the best of short runs dodges the machine's disturbances more often than the best of long ones, and
// would flatter the faster search.
Speeds measure(const Searches& s, const Rays& rays, int repeat)
{
  const Scene* scenes[3] = {&s.flat, &s.lanes, &s.tree};
  const std::vector<Ray>* queryRays[2] = {&rays.camera, &rays.shadow};
  auto run = [&](int query, int k, int passes) {
    return query == 0 ? timeClosest(*scenes[k], *queryRays[0], passes) : timeAny(*scenes[k], *queryRays[1], passes);
  };
  int passes[2][3];
  std::size_t counts[2] = {0, 0}; // the loop's hits and blocked rays, which the others must match
  for (int query = 0; query < 2; ++query) {
    const auto loop = run(query, 0, 1);
    counts[query] = loop.second;
    for (int k = 0; k < 3; ++k) {
      const double once = k == 0 ? loop.first : run(query, k, 1).first;
      passes[query][k] = int(std::clamp(loop.first / std::max(once, 1e-9), 1.0, 1000.0));
    }
  }
  double best[2][3] = {{1e30, 1e30, 1e30}, {1e30, 1e30, 1e30}};
  for (int r = 0; r < repeat; ++r)
    for (int k = 0; k < 3; ++k)
      for (int query = 0; query < 2; ++query) {
        const auto [seconds, count] = run(query, k, passes[query][k]);
        if (count != counts[query]) {
          std::fprintf(stderr, "bvh_bench: the searches disagree (%zu against %zu %s)\n", count, counts[query],
                       query == 0 ? "hits" : "blocked rays");
          std::exit(1);
        }
        best[query][k] = std::min(best[query][k], seconds / passes[query][k]);
      }
  const double n[2] = {double(rays.camera.size()) / 1e6, double(rays.shadow.size()) / 1e6};
  auto rate = [&](int query, int k) { return n[query] / std::max(best[query][k], 1e-12); };
  return Speeds{rate(0, 0), rate(0, 1), rate(0, 2), rate(1, 0), rate(1, 1), rate(1, 2)};
}

// One diffuse bounce from each camera hit: a cosine-distributed direction about the surface's facing normal, as
// chapter 6's first bounce off a diffuse surface draws it (random directions, so incoherent rays).
std::vector<Ray> bounceRays(const Scene& scene, const std::vector<Ray>& camera)
{
  std::vector<Ray> rays;
  Sampler sampler(1, 0, 0, 0);
  for (const Ray& ray : camera)
    if (const std::optional<Hit> hit = scene.intersect(ray)) {
      const Frame frame = Frame::fromNormal(facingNormal(*hit, ray.direction));
      const Vec2 u = sampler.next2D();
      rays.push_back(spawnRay(*hit, frame.toWorld(sampleCosineHemisphere(u))));
    }
  return rays;
}

// The interleave mode: Mrays/s one ray at a time (intersect) and with 1, 2 and 4 walks in flight, best of `repeat`
// interleaved runs of several passes each; every answer checked against intersect's.
void measureInterleaving(const Scene& tree, const std::vector<Ray>& rays, const char* what, int repeat)
{
  const Bvh& bvh = tree.accelerator;
  std::vector<std::optional<BvhHit>> one(rays.size()), out(rays.size());
  for (std::size_t i = 0; i < rays.size(); ++i)
    one[i] = bvh.intersect(rays[i]);
  const int passes = std::max(1, int(2e6 / double(std::max<std::size_t>(rays.size(), 1))));
  double best[4] = {1e30, 1e30, 1e30, 1e30}; // one at a time, then 1, 2 and 4 in flight
  const int inFlight[4] = {0, 1, 2, 4};
  for (int r = 0; r < repeat; ++r)
    for (int k = 0; k < 4; ++k) {
      const double start = threadSeconds();
      for (int p = 0; p < passes; ++p) {
        if (inFlight[k] == 0)
          for (std::size_t i = 0; i < rays.size(); ++i)
            out[i] = bvh.intersect(rays[i]);
        else
          bvh.intersectInterleaved(rays, out, inFlight[k]);
      }
      best[k] = std::min(best[k], (threadSeconds() - start) / passes);
      for (std::size_t i = 0; i < rays.size(); ++i)
        if (out[i].has_value() != one[i].has_value() ||
            (out[i] && (out[i]->primitive != one[i]->primitive || out[i]->t != one[i]->t))) {
          std::fprintf(stderr, "bvh_bench: the interleaved walk disagrees with intersect on ray %zu\n", i);
          std::exit(1);
        }
    }
  const double n = double(rays.size()) / 1e6;
  std::printf("%-13s %8zu rays: one at a time %6.2f Mrays/s; in flight 1: %6.2f, 2: %6.2f, 4: %6.2f "
              "(x%.2f, x%.2f, x%.2f the one at a time)\n",
              what, rays.size(), n / best[0], n / best[1], n / best[2], n / best[3], best[0] / best[1],
              best[0] / best[2], best[0] / best[3]);
}

#if RAYLIFE_EMBREE
// The embree mode: raylife's query and Embree's on the same spheres and rays. Returns false when --check was asked
// and the two disagree on more than 0.1 % of the rays.
bool measureAgainstEmbree(const Scene& scene, const std::vector<Ray>& camera, const std::vector<Ray>& bounces,
                          int repeat, bool check)
{
  RTCDevice device = rtcNewDevice("threads=1");
  if (!device)
    throw std::runtime_error("Embree could not start (rtcNewDevice failed)");
  RTCScene embree = rtcNewScene(device);
  RTCGeometry geometry = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_SPHERE_POINT);
  auto* points = static_cast<float*>(rtcSetNewGeometryBuffer(geometry, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT4,
                                                             4 * sizeof(float), scene.spheres.size()));
  for (std::size_t i = 0; i < scene.spheres.size(); ++i) {
    const Sphere& s = scene.spheres[i];
    for (int c = 0; c < 3; ++c)
      points[4 * i + std::size_t(c)] = float(s.center[c]);
    points[4 * i + 3] = float(s.radius);
  }
  rtcCommitGeometry(geometry);
  rtcAttachGeometry(embree, geometry);
  rtcReleaseGeometry(geometry);
  rtcSetSceneBuildQuality(embree, RTC_BUILD_QUALITY_HIGH); // Embree's best tree (raylife's is a full SAH build)
  rtcCommitScene(embree);

  // Embree works in float: its origin is raylife's rounded, and its sphere test's error grows with the radius (on
  // the random spheres' ground, of radius 1000, a ray leaving it met it again up to 7e-4 along). So Embree's rays
  // start 2e-6 of the largest radius along (2e-3 there); raylife's start where they do in the chapters.
  Real largest = 0;
  for (const Sphere& s : scene.spheres)
    largest = std::max(largest, s.radius);
  const float embreeStart = float(2e-6 * double(largest));
  auto tnear = [&](const Ray& r) { return std::max(float(r.tmin), embreeStart); };
  auto embreeHit = [&](const Ray& r) { return embreeIntersect(embree, r, tnear(r)); };

  // Embree's packets: eight rays at a time through rtcIntersect8, in the order given (camera rays along a row of
  // pixels: coherent; bounce rays from neighbouring pixels: near each other, in random directions). What tracing
  // several rays at once buys, before anything of raylife's is written that way. Returns the number of hits.
  auto embreeEight = [&](const std::vector<Ray>& rays, bool coherent) {
    RTCIntersectContext context;
    rtcInitIntersectContext(&context);
    context.flags = coherent ? RTC_INTERSECT_CONTEXT_FLAG_COHERENT : RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT;
    std::size_t hits = 0;
    for (std::size_t first = 0; first < rays.size(); first += 8) {
      alignas(32) RTCRayHit8 rh{};
      alignas(32) int valid[8];
      for (std::size_t k = 0; k < 8; ++k) {
        const bool used = first + k < rays.size();
        valid[k] = used ? -1 : 0;
        const Ray& r = rays[used ? first + k : first];
        rh.ray.org_x[k] = float(r.origin.x);
        rh.ray.org_y[k] = float(r.origin.y);
        rh.ray.org_z[k] = float(r.origin.z);
        rh.ray.dir_x[k] = float(r.direction.x);
        rh.ray.dir_y[k] = float(r.direction.y);
        rh.ray.dir_z[k] = float(r.direction.z);
        rh.ray.tnear[k] = tnear(r);
        rh.ray.tfar[k] = std::numeric_limits<float>::infinity();
        rh.ray.mask[k] = ~0u;
        rh.hit.geomID[k] = RTC_INVALID_GEOMETRY_ID;
      }
      rtcIntersect8(valid, embree, &context, &rh);
      for (std::size_t k = 0; k < 8 && first + k < rays.size(); ++k)
        hits += rh.hit.geomID[k] != RTC_INVALID_GEOMETRY_ID;
    }
    return hits;
  };

  bool agreed = true;
  for (const auto& [rays, what] : {std::pair{&camera, "camera rays"}, std::pair{&bounces, "bounce rays"}}) {
    // The queries in turn, each for about the same time, best of `repeat`: raylife's BVH query (the hit's distance
    // and number), the same with the hit record the chapters make from it (Scene::intersect: the point, the
    // normal, the material), Embree's one ray at a time (distance, number and normal), and Embree's eight at a time.
    const bool coherent = rays == &camera;
    const int passes = std::max(1, int(1e6 / double(std::max<std::size_t>(rays->size(), 1))));
    double best[4] = {1e30, 1e30, 1e30, 1e30};
    std::size_t sink = 0;
    for (int r = 0; r < repeat; ++r)
      for (int k = 0; k < 4; ++k) {
        const double start = threadSeconds();
        for (int p = 0; p < passes; ++p)
          if (k == 3)
            sink += embreeEight(*rays, coherent);
          else
            for (const Ray& ray : *rays)
              sink += k == 0   ? scene.accelerator.intersect(ray).has_value()
                      : k == 1 ? scene.intersect(ray).has_value()
                               : embreeHit(ray).hit.geomID != RTC_INVALID_GEOMETRY_ID;
        best[k] = std::min(best[k], (threadSeconds() - start) / passes);
      }
    // Agreement: both miss, or both hit the same sphere.
    std::size_t agree = 0, embreeHits = 0;
    for (const Ray& ray : *rays) {
      const std::optional<BvhHit> ours = scene.accelerator.intersect(ray);
      const RTCRayHit theirs = embreeHit(ray);
      const bool theyHit = theirs.hit.geomID != RTC_INVALID_GEOMETRY_ID;
      embreeHits += theyHit;
      agree += ours.has_value() == theyHit && (!theyHit || unsigned(ours->primitive) == theirs.hit.primID);
    }
    const double n = double(rays->size()) / 1e6;
    std::printf("%-12s %8zu rays: raylife %6.2f Mrays/s (%6.2f with the hit record); Embree %6.2f, eight at a time "
                "%6.2f\n",
                what, rays->size(), n / best[0], n / best[1], n / best[2], n / best[3]);
    std::printf("%-12s %8s       raylife / Embree %.2f (%.2f with the hit record), against eight at a time %.2f; "
                "the same sphere or miss for %.3f%% of the rays (%zu hits counted)\n",
                "", "", best[2] / best[0], best[2] / best[1], best[3] / best[0],
                100.0 * double(agree) / double(std::max<std::size_t>(rays->size(), 1)), sink);
    // Float against double: a ray grazing a sphere's rim, or two spheres at nearly the same distance, may go either
    // way in one of a few thousand rays. More than 0.1 % is a bug in one of the two.
    agreed = agreed && double(agree) >= 0.999 * double(rays->size());
    if (const std::size_t eight = embreeEight(*rays, coherent); eight != embreeHits)
      std::printf("(Embree eight at a time found %zu hits, one at a time %zu)\n", eight, embreeHits);
  }
  rtcReleaseScene(embree);
  rtcReleaseDevice(device);
  if (check && !agreed)
    std::fprintf(stderr, "bvh_bench: raylife and Embree disagree on more than 0.1 %% of the rays\n");
  return !check || agreed;
}
#endif

int usage()
{
  std::cerr << "usage: bvh_bench speed [SCENE.json] [--repeat R]\n"
               "       bvh_bench crossover [SCENE.json] [--repeat R]\n"
               "       bvh_bench interleave [SCENE.json] [--repeat R]\n"
               "       bvh_bench embree [SCENE.json] [--repeat R] [--check]\n"
               "       bvh_bench heatmap [SCENE.json] --split sah|midpoint -o FILE [--width W] [--height H]\n";
  return 2;
}

} // namespace

int main(int argc, char** argv)
{
  if (argc < 2)
    return usage();
  const std::string mode = argv[1];
  std::string scenePath = sceneDirectory() + "/random_spheres.json", output, splitName = "sah";
  int repeat = 5, width = 0, height = 0;
  bool check = false;
  for (int i = 2; i < argc; ++i) {
    const std::string arg = argv[i];
    if (i + 1 < argc && arg == "--repeat")
      repeat = std::max(1, std::atoi(argv[++i]));
    else if (i + 1 < argc && arg == "--width")
      width = std::max(1, std::atoi(argv[++i]));
    else if (i + 1 < argc && arg == "--height")
      height = std::max(1, std::atoi(argv[++i]));
    else if (i + 1 < argc && arg == "-o")
      output = argv[++i];
    else if (i + 1 < argc && arg == "--split")
      splitName = argv[++i];
    else if (arg == "--check")
      check = true;
    else if (!arg.empty() && arg[0] != '-')
      scenePath = arg;
    else
      return usage();
  }
  if (mode != "heatmap")
    reportBenchBuild("bvh_bench");
  try {
    const Scene scene = loadScene(scenePath);
    if (mode == "speed") {
      const Searches search = searches(scene);
      const Scene& tree = search.tree;
      const Rays rays = makeRays(search.flat, width, height);
      const Speeds s = measure(search, rays, repeat);
      std::printf("%s: %zu spheres, %zu camera rays, %zu shadow rays, one thread, best of %d\n", scenePath.c_str(),
                  scene.spheres.size(), rays.camera.size(), rays.shadow.size(), repeat);
      std::printf("closest hit: flat %.3f Mrays/s, BVH %.3f Mrays/s, BVH/flat %.1f; flat four at a time %.3f, "
                  "BVH/that %.1f\n",
                  s.flatClosest, s.bvhClosest, s.bvhClosest / s.flatClosest, s.lanesClosest,
                  s.bvhClosest / s.lanesClosest);
      std::printf("any hit:     flat %.3f Mrays/s, BVH %.3f Mrays/s, BVH/flat %.1f; flat four at a time %.3f, "
                  "BVH/that %.1f\n",
                  s.flatAny, s.bvhAny, s.bvhAny / s.flatAny, s.lanesAny, s.bvhAny / s.lanesAny);
      if (search.lanes.lanes.test() != LaneTest::FourAtOnce)
        std::printf("(this CPU has no AVX2: \"four at a time\" tested them one by one)\n");
      // The work behind those figures: boxes (a node's eight count as eight) and spheres tested per ray.
      BvhWork camera, shadow;
      for (const Ray& ray : rays.camera)
        camera = camera + tree.intersectWithWork(ray).work;
      for (const Ray& ray : rays.shadow)
        shadow = shadow + tree.occludedWithWork(ray).work;
      std::printf("per camera ray: %.1f boxes, %.1f spheres; per shadow ray: %.1f boxes, %.1f spheres\n",
                  double(camera.nodesVisited) / double(rays.camera.size()),
                  double(camera.primitivesTested) / double(rays.camera.size()),
                  double(shadow.nodesVisited) / double(std::max<std::size_t>(1, rays.shadow.size())),
                  double(shadow.primitivesTested) / double(std::max<std::size_t>(1, rays.shadow.size())));
      std::printf("tree: %zu nodes (%zu bytes), depth %d, SAH cost %.2f; walked as %zu nodes of up to %d children "
                  "(%zu bytes), their boxes tested %s at a time\n",
                  tree.accelerator.nodes().size(), tree.accelerator.nodes().size() * sizeof(BvhNode),
                  tree.accelerator.depth(), double(tree.accelerator.sahCost()), tree.accelerator.wideNodes().size(),
                  BvhWideNode::kWidth, tree.accelerator.wideNodes().size() * sizeof(BvhWideNode),
                  tree.accelerator.eightAtOnce() ? "eight" : "four");
    } else if (mode == "crossover") {
      // The N spheres nearest the focal point, the ground (the largest sphere) always first.
      std::vector<Sphere> ordered = scene.spheres;
      std::stable_sort(ordered.begin(), ordered.end(), [&](const Sphere& a, const Sphere& b) {
        if (a.radius != b.radius && (a.radius > 100 || b.radius > 100))
          return a.radius > b.radius;
        return glm::length(a.center - scene.camera.focal) < glm::length(b.center - scene.camera.focal);
      });
      std::printf("N spheres | closest hit Mrays/s: flat  four   BVH  BVH/four | any hit Mrays/s: flat  four   BVH  "
                  "BVH/four\n");
      for (std::size_t n : {1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 12, 14, 16, 20, 24, 32, 48, 64}) {
        if (n > ordered.size())
          break;
        Scene part = scene;
        part.spheres.assign(ordered.begin(), ordered.begin() + std::ptrdiff_t(n));
        const Searches search = searches(part);
        const Rays rays = makeRays(search.flat, width, height);
        const Speeds s = measure(search, rays, repeat);
        std::printf("%9zu | %26.2f %5.2f %5.2f %8.2f | %22.2f %5.2f %5.2f %8.2f\n", n, s.flatClosest, s.lanesClosest,
                    s.bvhClosest, s.bvhClosest / s.lanesClosest, s.flatAny, s.lanesAny, s.bvhAny,
                    s.bvhAny / s.lanesAny);
      }
    } else if (mode == "interleave") {
      Scene tree = scene;
      tree.accelerator = Bvh(tree.spheres); // the tree whatever the count (as "speed" measures it)
      const Rays rays = makeRays(tree, width, height);
      const std::vector<Ray> bounces = bounceRays(tree, rays.camera);
      std::printf("%s: %zu spheres, one thread, best of %d, boxes tested %s at a time\n", scenePath.c_str(),
                  scene.spheres.size(), repeat, tree.accelerator.eightAtOnce() ? "eight" : "four");
      measureInterleaving(tree, rays.camera, "camera rays", repeat);
      measureInterleaving(tree, bounces, "bounce rays", repeat);
    } else if (mode == "embree") {
#if RAYLIFE_EMBREE
      // The scene as the chapters have it (its tree, and the primitives it keeps outside), and chapter 6's first
      // two kinds of ray: camera rays through the pixels' centres and a diffuse bounce from where they hit.
      if (!scene.triangles.empty() || scene.hasMotion())
        throw std::invalid_argument(scenePath + ": the embree mode takes still spheres only (no triangles, no motion)");
      if (!scene.usesAccelerator())
        throw std::invalid_argument(scenePath + ": keeps a flat list (too few primitives for a tree); the embree mode "
                                    "compares trees");
      const Rays rays = makeRays(scene, width, height);
      const std::vector<Ray> bounces = bounceRays(scene, rays.camera);
      std::printf("%s: %zu spheres through the BVH, one thread, best of %d\n", scenePath.c_str(),
                  scene.spheres.size(), repeat);
      if (!measureAgainstEmbree(scene, rays.camera, bounces, repeat, check))
        return 1;
#else
      (void)check;
      std::fprintf(stderr, "bvh_bench: Embree is not built in (./setup.sh --embree, then cmake --preset embree)\n");
      return 1;
#endif
    } else if (mode == "heatmap") {
      if (output.empty() || (splitName != "sah" && splitName != "midpoint"))
        return usage();
      const Scene tree = searches(scene, splitName == "sah" ? BvhSplit::Sah : BvhSplit::Midpoint).tree;
      const Camera camera = tree.makeCamera(width, height);
      Image image(camera.width(), camera.height());
      double total = 0;
      for (int y = 0; y < camera.height(); ++y)
        for (int x = 0; x < camera.width(); ++x) {
          // The work of the camera ray and its shadow rays, as chapter 9's right image counts it.
          const Ray ray = camera.ray(Vec2(Real(x) + Real(0.5), Real(y) + Real(0.5)));
          const TracedHit traced = tree.intersectWithWork(ray);
          BvhWork work = traced.work;
          if (traced.hit) {
            const Vec3 N = facingNormal(*traced.hit, ray.direction);
            for (const PointLight& light : tree.lights)
              if (auto in = light.arrivalAt(traced.hit->point); in && glm::dot(in->direction, N) > 0)
                work = work + tree.occludedWithWork(spawnRayTo(*traced.hit, light.position)).work;
          }
          const Color c = heatColor(workCost(work));
          total += double(workCost(work));
          for (int k = 0; k < 3; ++k)
            image.at(x, y, k) = float(c[k]);
        }
      writeImage(image, output);
      std::printf("%s split: SAH cost %.2f, depth %d, mean work per pixel %.1f (boxes + 2 x spheres) -> %s\n",
                  splitName.c_str(), double(tree.accelerator.sahCost()), tree.accelerator.depth(),
                  total / double(image.width * image.height), output.c_str());
    } else {
      return usage();
    }
  } catch (const std::exception& e) {
    std::cerr << "bvh_bench: " << e.what() << "\n";
    return 1;
  }
  return 0;
}

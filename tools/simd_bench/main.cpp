// simd_bench [--rays N] [--rounds R]: chooses chapter 16's SIMD library by measurement (docs/benchmarks.md).
//
// Two kernels, lanes across rays, each written in Google Highway, xsimd and std::experimental::simd and run on every
// target the CPU has (SSE4, AVX2, AVX-512), beside a plain scalar loop: the closest hit of N rays against a flat
// list of spheres (smallpt's room, 9 spheres; 32 random spheres), and a shading-like step (a cosine-weighted
// direction about the normal, the throughput times the albedo). Each configuration is timed in R interleaved rounds
// (the order reversed every other round), one thread; the table gives the medians, the ratio to the scalar loop and
// how far each result is from the scalar loop's.
#include "kernels.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <numbers>
#include <random>
#include <string>
#include <vector>

using namespace raylife::simd_bench;

namespace {

struct RayData {
  std::vector<float> ox, oy, oz, dx, dy, dz, tmin, tmax;
  Rays view() const {
    return {ox.data(), oy.data(), oz.data(), dx.data(), dy.data(), dz.data(), tmin.data(), tmax.data(),
            static_cast<int64_t>(ox.size())};
  }
};

struct SphereData {
  std::vector<float> cx, cy, cz, r;
  void add(float radius, float x, float y, float z) {
    r.push_back(radius), cx.push_back(x), cy.push_back(y), cz.push_back(z);
  }
  Spheres view() const { return {cx.data(), cy.data(), cz.data(), r.data(), static_cast<int32_t>(r.size())}; }
};

struct HitData {
  std::vector<float> t;
  std::vector<int32_t> id;
  explicit HitData(size_t n) : t(n), id(n) {}
  Hits view() { return {t.data(), id.data()}; }
};

struct RecordData {
  std::vector<float> nx, ny, nz, u1, u2, ar, ag, ab, tr, tg, tb;
  HitRecords view() const {
    return {nx.data(), ny.data(), nz.data(), u1.data(), u2.data(), ar.data(), ag.data(),
            ab.data(), tr.data(), tg.data(), tb.data(), static_cast<int64_t>(nx.size())};
  }
};

struct BounceData {
  std::vector<float> dx, dy, dz, tr, tg, tb;
  explicit BounceData(size_t n) : dx(n), dy(n), dz(n), tr(n), tg(n), tb(n) {}
  Bounces view() { return {dx.data(), dy.data(), dz.data(), tr.data(), tg.data(), tb.data()}; }
};

// A uniform direction on the sphere.
void uniformDirection(std::mt19937& rng, float& x, float& y, float& z) {
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  const float cosTheta = 1.0f - 2.0f * u(rng), phi = 2.0f * std::numbers::pi_v<float> * u(rng);
  const float sinTheta = std::sqrt(std::max(0.0f, 1.0f - cosTheta * cosTheta));
  x = sinTheta * std::cos(phi), y = sinTheta * std::sin(phi), z = cosTheta;
}

// N rays from uniform points of the box [lo, hi]^3 (per axis), in uniform directions.
RayData randomRays(size_t n, const float lo[3], const float hi[3], float tmin, uint32_t seed) {
  std::mt19937 rng(seed);
  RayData rays;
  for (size_t i = 0; i < n; ++i) {
    float p[3], d[3];
    for (int k = 0; k < 3; ++k) p[k] = std::uniform_real_distribution<float>(lo[k], hi[k])(rng);
    uniformDirection(rng, d[0], d[1], d[2]);
    rays.ox.push_back(p[0]), rays.oy.push_back(p[1]), rays.oz.push_back(p[2]);
    rays.dx.push_back(d[0]), rays.dy.push_back(d[1]), rays.dz.push_back(d[2]);
    rays.tmin.push_back(tmin), rays.tmax.push_back(1e20f);
  }
  return rays;
}

// smallpt's room: five walls and a floor of radius 1e5, two balls, the lamp.
SphereData smallptRoom() {
  SphereData s;
  s.add(1e5f, 1e5f + 1, 40.8f, 81.6f);   // left
  s.add(1e5f, -1e5f + 99, 40.8f, 81.6f); // right
  s.add(1e5f, 50, 40.8f, 1e5f);          // back
  s.add(1e5f, 50, 40.8f, -1e5f + 170);   // front
  s.add(1e5f, 50, 1e5f, 81.6f);          // bottom
  s.add(1e5f, 50, -1e5f + 81.6f, 81.6f); // top
  s.add(16.5f, 27, 16.5f, 47);           // mirror
  s.add(16.5f, 73, 16.5f, 78);           // glass
  s.add(600, 50, 681.6f - .27f, 81.6f);  // lamp
  return s;
}

SphereData randomSpheres(int count, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> centre(-10.0f, 10.0f), radius(0.5f, 2.0f);
  SphereData s;
  for (int i = 0; i < count; ++i) {
    const float x = centre(rng), y = centre(rng), z = centre(rng);
    s.add(radius(rng), x, y, z);
  }
  return s;
}

RecordData randomRecords(size_t n, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  RecordData r;
  for (size_t i = 0; i < n; ++i) {
    float x, y, z;
    uniformDirection(rng, x, y, z);
    r.nx.push_back(x), r.ny.push_back(y), r.nz.push_back(z);
    r.u1.push_back(u(rng)), r.u2.push_back(u(rng));
    r.ar.push_back(u(rng)), r.ag.push_back(u(rng)), r.ab.push_back(u(rng));
    r.tr.push_back(u(rng)), r.tg.push_back(u(rng)), r.tb.push_back(u(rng));
  }
  return r;
}

const char* targetName(Target t) {
  switch (t) {
  case Target::sse4: return "SSE4";
  case Target::avx2: return "AVX2";
  case Target::avx512: return "AVX-512";
  }
  return "?";
}

struct Config {
  std::string library, target;
  std::function<void()> run;  // one pass over the N rays (records)
  std::function<std::string()> check; // how far the last pass's result is from the scalar loop's
  std::function<void()> enter = [] {}, leave = [] {}; // around each batch of passes (Highway: force the target)
};

double secondsOf(const std::function<void()>& f, int repeats) {
  const auto start = std::chrono::steady_clock::now();
  for (int i = 0; i < repeats; ++i) f();
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() / repeats;
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.size() % 2 ? v[v.size() / 2] : 0.5 * (v[v.size() / 2 - 1] + v[v.size() / 2]);
}

// Runs each configuration once (the check), sizes its repeats to about 50 ms, then times `rounds` rounds, the order
// reversed every other round, and prints one table row per configuration.
void measure(const char* kernel, const char* scene, const std::vector<Config>& configs, int rounds, size_t n) {
  std::vector<std::string> checks;
  std::vector<int> repeats;
  for (const Config& c : configs) {
    c.enter();
    c.run();
    checks.push_back(c.check());
    repeats.push_back(std::max(1, static_cast<int>(0.05 / std::max(secondsOf(c.run, 1), 1e-9))));
    c.leave();
  }
  std::vector<std::vector<double>> seconds(configs.size()); // per pass, one per round
  for (int round = 0; round < rounds; ++round) {
    for (size_t i = 0; i < configs.size(); ++i) {
      const size_t k = round % 2 ? configs.size() - 1 - i : i;
      configs[k].enter();
      configs[k].run(); // a first call (Highway: it sets up the dispatch) is not timed
      seconds[k].push_back(secondsOf(configs[k].run, repeats[k]));
      configs[k].leave();
    }
  }
  const double scalar = median(seconds.front());
  for (size_t k = 0; k < configs.size(); ++k) {
    const double s = median(seconds[k]);
    std::printf("| %s | %s | %s | %s | %.1f | %.2f | %s |\n", kernel, scene, configs[k].library.c_str(),
                configs[k].target.c_str(), static_cast<double>(n) / s * 1e-6, scalar / s, checks[k].c_str());
  }
  std::fflush(stdout);
}

// Hit index identical, t within a relative tolerance (the FMA targets round differently from the scalar loop).
// Where the index differs, the same loop in double says which of the two float results is right.
constexpr float hitTolerance = 1e-4f;
std::string compareHits(const HitData& reference, const HitData& got, const HitData& exact) {
  size_t idDiffers = 0, gotRight = 0, tDiffers = 0;
  float worst = 0.0f;
  for (size_t i = 0; i < reference.t.size(); ++i) {
    if (reference.id[i] != got.id[i]) {
      ++idDiffers;
      gotRight += got.id[i] == exact.id[i];
      continue;
    }
    const float rel = std::fabs(got.t[i] - reference.t[i]) / std::max(1.0f, std::fabs(reference.t[i]));
    worst = std::max(worst, rel);
    if (!(rel <= hitTolerance)) ++tDiffers;
  }
  char text[160];
  if (idDiffers + tDiffers == 0)
    std::snprintf(text, sizeof text, "ok (t within %.0e)", static_cast<double>(worst));
  else
    std::snprintf(text, sizeof text, "DIFFERS: %zu ids (%zu of them right in double), t max rel %.0e", idDiffers,
                  gotRight, static_cast<double>(worst));
  return text;
}

// Directions within an absolute tolerance (the libraries' sin and cos are not libm's), throughput bit for bit.
constexpr float directionTolerance = 1e-5f;
std::string compareBounces(const BounceData& reference, const BounceData& got) {
  float worst = 0.0f;
  size_t throughputDiffers = 0;
  for (size_t i = 0; i < reference.dx.size(); ++i) {
    worst = std::max({worst, std::fabs(got.dx[i] - reference.dx[i]), std::fabs(got.dy[i] - reference.dy[i]),
                      std::fabs(got.dz[i] - reference.dz[i])});
    throughputDiffers += got.tr[i] != reference.tr[i] || got.tg[i] != reference.tg[i] || got.tb[i] != reference.tb[i];
  }
  char text[128];
  std::snprintf(text, sizeof text, "%s (direction within %.0e)",
                worst <= directionTolerance && throughputDiffers == 0 ? "ok" : "DIFFERS", static_cast<double>(worst));
  return text;
}

struct Library {
  const char* name;
  bool (*supports)(Target);
  void (*closestHit)(Target, const Rays&, const Spheres&, const Hits&);
  void (*shade)(Target, const HitRecords&, const Bounces&);
  void (*enter)(Target);
  void (*leave)();
};

const Library libraries[] = {
    {"Highway 1.0.3", highwaySupports,
     [](Target, const Rays& rays, const Spheres& spheres, const Hits& hits) { closestHitHighway(rays, spheres, hits); },
     [](Target, const HitRecords& records, const Bounces& out) { shadeHighway(records, out); }, highwayForceTarget,
     highwayReleaseTarget},
    {"xsimd 8.1", xsimdSupports, closestHitXsimd, shadeXsimd, [](Target) {}, [] {}},
    {"std::experimental::simd", stdSimdSupports, closestHitStdSimd, shadeStdSimd, [](Target) {}, [] {}},
};
const Target targets[] = {Target::sse4, Target::avx2, Target::avx512};

void benchClosestHit(const char* scene, const RayData& rayData, const SphereData& sphereData, int rounds) {
  const Rays rays = rayData.view();
  const Spheres spheres = sphereData.view();
  const size_t n = rayData.ox.size();
  HitData reference(n), exact(n), got(n);
  closestHitScalar(rays, spheres, reference.view());
  closestHitScalarDouble(rays, spheres, exact.view());
  std::vector<Config> configs;
  configs.push_back({"scalar loop", "generic x86-64", [&] { closestHitScalar(rays, spheres, got.view()); },
                     [&] { return compareHits(reference, got, exact); }});
  for (const Library& lib : libraries)
    for (Target t : targets)
      if (lib.supports(t))
        configs.push_back({lib.name, targetName(t), [&, t] { lib.closestHit(t, rays, spheres, got.view()); },
                           [&] { return compareHits(reference, got, exact); }, [&, t] { lib.enter(t); }, lib.leave});
  configs.push_back({"Highway 1.0.3, not forced", highwayBestTarget(),
                     [&] { closestHitHighway(rays, spheres, got.view()); },
                     [&] { return compareHits(reference, got, exact); }});
  // xsimd's own dispatch, as its users would call it, checked once (Highway's is the row "not forced").
  closestHitXsimdBest(rays, spheres, got.view());
  std::fprintf(stderr, "simd_bench: xsimd::dispatch (%s)\n", compareHits(reference, got, exact).c_str());
  measure("closest hit", scene, configs, rounds, n);
}

void benchShade(const RecordData& recordData, int rounds) {
  const HitRecords records = recordData.view();
  const size_t n = recordData.nx.size();
  BounceData reference(n), got(n);
  shadeScalar(records, reference.view());
  std::vector<Config> configs;
  configs.push_back({"scalar loop", "generic x86-64", [&] { shadeScalar(records, got.view()); },
                     [&] { return compareBounces(reference, got); }});
  for (const Library& lib : libraries)
    for (Target t : targets)
      if (lib.supports(t))
        configs.push_back({lib.name, targetName(t), [&, t] { lib.shade(t, records, got.view()); },
                           [&] { return compareBounces(reference, got); }, [&, t] { lib.enter(t); }, lib.leave});
  configs.push_back({"Highway 1.0.3, not forced", highwayBestTarget(), [&] { shadeHighway(records, got.view()); },
                     [&] { return compareBounces(reference, got); }});
  measure("shade", "random records", configs, rounds, n);
}

} // namespace

int main(int argc, char** argv) {
  size_t n = 65536;
  int rounds = 7;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--rays" && i + 1 < argc)
      n = static_cast<size_t>(std::atol(argv[++i]));
    else if (arg == "--rounds" && i + 1 < argc)
      rounds = std::atoi(argv[++i]);
    else {
      std::fprintf(stderr, "usage: simd_bench [--rays N] [--rounds R]  (N a multiple of 16)\n");
      return 2;
    }
  }
  if (n == 0 || n % 16 != 0 || rounds < 1) {
    std::fprintf(stderr, "simd_bench: N must be a positive multiple of 16, R at least 1\n");
    return 2;
  }
  std::printf("%zu rays (records), medians of %d interleaved rounds, one thread; M/s: million rays (records) per "
              "second\n\n",
              n, rounds);
  std::printf("| kernel | scene | library | target | M/s | x scalar | against the scalar loop (t relative, %.0e; "
              "direction absolute, %.0e) |\n",
              static_cast<double>(hitTolerance), static_cast<double>(directionTolerance));
  std::printf("|---|---|---|---|---:|---:|---|\n");
  const float roomLo[3] = {1, 0, 0}, roomHi[3] = {99, 81.6f, 170};
  benchClosestHit("smallpt, 9 spheres", randomRays(n, roomLo, roomHi, 1e-2f, 1), smallptRoom(), rounds);
  const float boxLo[3] = {-12, -12, -12}, boxHi[3] = {12, 12, 12};
  benchClosestHit("32 random spheres", randomRays(n, boxLo, boxHi, 1e-3f, 2), randomSpheres(32, 3), rounds);
  benchShade(randomRecords(n, 4), rounds);
  return 0;
}

// roofline: the measured roofline of this machine, for one thread, and chapter 16's stream kernels on it.
//
//   roofline [--quick] [--plot FILE.png]
//
// Prints Markdown tables (docs/benchmarks.md, "The roofline of this machine"):
//   1. read bandwidth: a sum over an array of Real of 512 MiB (memory), 256 KiB (the L2 cache) and 16 KiB (L1);
//   2. the peak rate of multiplies and adds (none fused: the build says -ffp-contract=off, as the kernels do) in
//      each instruction set the kernels run here (simdTargets(), forced in turn);
//   2b. the price of a gather (a vector of lanes loaded from scattered places in a table in the L1 cache) against a
//      contiguous load, in each instruction set: what a walk of a tree with one ray per lane would pay at each step;
//   3. nearestSpheres (smallpt's nine spheres; rays from random points of the room in random directions) and
//      diffuseBounces (random normals and directions, uniform numbers) in each instruction set: rays per second,
//      the floating-point operations and bytes per ray counted from the kernels' source, hence the arithmetic
//      intensity, the achieved GFLOP/s and the roofline's bound min(peak, intensity × bandwidth), for a stream that
//      lives in memory (4M rays) and one that lives in the L2 cache (4096 rays, run many times).
// --plot FILE.png draws the roofline with gnuplot (./setup.sh --bench installs it; without it the plot is skipped).
// --quick: small arrays and one run each (a smoke test); by default each figure is the best of runs lasting about
// two seconds in all. Times are the thread's CPU time, which a shared machine disturbs less than wall-clock time.
#include "roofline/peak.h"

#include "geometry/sphere.h"
#include "render/ray_stream.h"

#include <hwy/aligned_allocator.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <fstream>
#include <iostream>
#include <random>
#include <string>
#include <vector>

using namespace raylife;

namespace {

double cpuSeconds()
{
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec);
}

// The shortest time `run` takes, over runs lasting `budget` seconds in all (at least `minRuns` of them).
template <class F> double bestSeconds(F run, double budget, int minRuns)
{
  double best = 1e300, total = 0;
  for (int r = 0; r < minRuns || total < budget; ++r) {
    const double start = cpuSeconds();
    run();
    const double s = cpuSeconds() - start;
    best = std::min(best, s);
    total += s;
  }
  return best;
}

volatile Real gSink = 0; // results land here, so that no measured work is left out

struct Settings {
  bool quick = false;
  double budget = 2.0; // seconds per figure
  int minRuns = 3;
};

// --- 1. Bandwidth -------------------------------------------------------------------------------------------------

// GB/s reading an array of `bytes` bytes, summed `passes` times per run.
double readBandwidth(std::size_t bytes, const Settings& s)
{
  const std::size_t n = bytes / sizeof(Real);
  hwy::AlignedFreeUniquePtr<Real[]> v = hwy::AllocateAligned<Real>(n);
  for (std::size_t i = 0; i < n; ++i)
    v[i] = Real(i % 7) * Real(0.25);
  // About 256 MiB read per run whatever the size, so that the timer's grain does not matter.
  const std::size_t passes = std::max<std::size_t>(1, (std::size_t(256) << 20) / bytes / (s.quick ? 16 : 1));
  const double seconds = bestSeconds(
    [&] {
      Real sum = 0;
      for (std::size_t p = 0; p < passes; ++p)
        sum += roofline::sumArray(v.get(), n);
      gSink = sum;
    },
    s.budget, s.minRuns);
  return double(bytes) * double(passes) / seconds * 1e-9;
}

// --- 2. Peak arithmetic -------------------------------------------------------------------------------------------

double peakGflops(const Settings& s)
{
  const std::size_t iterations = s.quick ? 1'000'000 : 20'000'000;
  const double seconds = bestSeconds([&] { gSink = roofline::mulAddChains(iterations); }, s.budget, s.minRuns);
  return roofline::flopsPerIteration() * double(iterations) / seconds * 1e-9;
}

// --- 2b. Gathers --------------------------------------------------------------------------------------------------

// Nanoseconds a gather of one vector takes and a contiguous load of one vector (the sum over an array), both from a
// table of 16 KiB (the L1 cache), in the instruction set in use: what a walk of a tree with one ray per lane pays
// at each step for each number of its nodes (their boxes lie wherever the rays' nodes are), against a load of rays
// stored side by side.
struct GatherCost {
  double gather = 0, load = 0; // nanoseconds a vector
};
GatherCost gatherCost(const Settings& s)
{
  const std::size_t tableSize = (16 << 10) / sizeof(Real);
  const std::size_t n = s.quick ? (std::size_t(1) << 16) : (std::size_t(1) << 20);
  hwy::AlignedFreeUniquePtr<Real[]> table = hwy::AllocateAligned<Real>(tableSize);
  hwy::AlignedFreeUniquePtr<roofline::GatherIndex[]> index = hwy::AllocateAligned<roofline::GatherIndex>(n);
  for (std::size_t i = 0; i < tableSize; ++i)
    table[i] = Real(i % 7) * Real(0.25);
  std::mt19937_64 rng(3);
  for (std::size_t k = 0; k < n; ++k)
    index[k] = roofline::GatherIndex(rng() % tableSize);
  const double vectors = double(n) / double(roofline::gatherLanes());
  GatherCost cost;
  cost.gather = bestSeconds([&] { gSink = roofline::gatherSum(table.get(), index.get(), n); }, s.budget, s.minRuns) /
                vectors * 1e9;
  const std::size_t passes = n / tableSize;
  cost.load = bestSeconds(
                [&] {
                  Real sum = 0;
                  for (std::size_t p = 0; p < passes; ++p)
                    sum += roofline::sumArray(table.get(), tableSize);
                  gSink = sum;
                },
                s.budget, s.minRuns) /
              (double(passes * tableSize) / double(roofline::gatherLanes())) * 1e9;
  return cost;
}

// --- 3. The kernels -----------------------------------------------------------------------------------------------

// smallpt's spheres (scenes/smallpt.json, in its order): six walls of radius 1e5, the mirror, the glass, the lamp.
std::vector<Sphere> smallptSpheres()
{
  auto sphere = [](double x, double y, double z, double r) {
    Sphere s;
    s.center = Vec3(Real(x), Real(y), Real(z));
    s.radius = Real(r);
    return s;
  };
  return {sphere(100001, 40.8, 81.6, 100000),  sphere(-99901, 40.8, 81.6, 100000), sphere(50, 40.8, 100000, 100000),
          sphere(50, 40.8, -99830, 100000),    sphere(50, 100000, 81.6, 100000),  sphere(50, -99918.4, 81.6, 100000),
          sphere(27, 16.5, 47, 16.5),          sphere(73, 16.5, 78, 16.5),        sphere(50, 681.33, 81.6, 600)};
}

Vec3 randomUnit(std::mt19937_64& rng)
{
  std::uniform_real_distribution<Real> u(0, 1);
  const Real z = 1 - 2 * u(rng), phi = 2 * std::numbers::pi_v<Real> * u(rng);
  const Real r = std::sqrt(std::max(Real(0), 1 - z * z));
  return Vec3(r * std::cos(phi), r * std::sin(phi), z);
}

// Rays from random points of the room (x in [1, 99], y in [0, 81.6], z in [0, 170]: inside the six walls) in
// random directions, going on forever.
RayStream roomRays(std::size_t n, std::uint64_t seed)
{
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<Real> x(1, 99), y(0, Real(81.6)), z(0, 170);
  RayStream rays;
  rays.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    Ray ray;
    ray.origin = Vec3(x(rng), y(rng), z(rng));
    ray.direction = randomUnit(rng);
    ray.tmin = 0;
    ray.tmax = kInfinity;
    rays.set(i, ray);
  }
  return rays;
}

// Floating-point operations per ray and sphere of firstRoot (ray_stream.cpp), counted from its source: adds,
// subtracts, multiplies, divides and square roots; negations, CopySign, comparisons and selects not counted.
//   f = o − c: 3 Sub; r²: 1 Mul; |f|²: 3 Mul 2 Add; b = −f·d: 3 Mul 2 Add; l = f + b·d: 3 Mul 3 Add;
//   Δ = r² − |l|²: 3 Mul 2 Add 1 Sub                                          = 26, always done;
//   q = b + sign(b)·√Δ: 1 Sqrt 1 Add; c = |f|² − r²: 1 Sub; c/q: 1 Div          = 4 more, unless no lane can hit.
constexpr double kRootFlopsAlways = 26, kRootFlopsRest = 4;
// Bytes per ray of nearestSpheres: it reads o, d and tmax (7 Reals) and writes t (a Real) and the sphere (int32).
constexpr double kNearestBytes = 8 * sizeof(Real) + sizeof(std::int32_t);

// The floating-point operations the lanes of nearestSpheres do per ray, at `lanes` rays a vector: 26 per sphere, and
// 4 more for every sphere of a group of lanes where some lane may hit it (firstRoot's early exit is taken by a whole
// vector or not at all). Found with the same arithmetic in scalar code (the same IEEE operations).
double nearestFlopsPerRay(const SphereList& spheres, const RayStream& rays, std::size_t count, std::size_t lanes)
{
  double flops = 0;
  for (std::size_t i = 0; i < count; i += lanes)
    for (std::size_t k = 0; k < spheres.size(); ++k) {
      bool any = false;
      for (std::size_t j = i; j < std::min(count, i + lanes) && !any; ++j) {
        const Real fx = rays.ox[j] - spheres.cx[k], fy = rays.oy[j] - spheres.cy[k], fz = rays.oz[j] - spheres.cz[k];
        const Real rr = spheres.radius[k] * spheres.radius[k];
        const Real ff = fx * fx + fy * fy + fz * fz;
        const Real b = -(fx * rays.dx[j] + fy * rays.dy[j] + fz * rays.dz[j]);
        const Real lx = fx + b * rays.dx[j], ly = fy + b * rays.dy[j], lz = fz + b * rays.dz[j];
        const Real disc = rr - (lx * lx + ly * ly + lz * lz);
        any = !(ff > rr && b <= 0) && disc >= 0;
      }
      flops += double(lanes) * (kRootFlopsAlways + (any ? kRootFlopsRest : 0));
    }
  return flops / double(count);
}

// Floating-point operations per bounce of DiffuseBounces (ray_stream.cpp), counted the same way:
//   the frame: a = −1/(sign + n_z) 1 Div 1 Add; b 2 Mul; s_x 3 Mul 1 Add; s_y, s_z 2 Mul; t_y 2 Mul 1 Add   = 13;
//   wo_z = −d·n 3 Mul 2 Add; r = √u₁ 1 Sqrt                                                              = 6;
//   sinCos2Pi: 8u 1 Mul; f = 4u − q 1 Mul 1 Sub; w = f² 1 Mul; the sine f·P(w) (Horner, 7 coefficients in
//   double, 4 in float) 7 Mul 6 Add (4 and 3); the cosine 1 − w·Q(w) 7 Mul 6 Add 1 Sub (4, 3, 1); the turn by
//   quarter turns 4 Mul 1 Add 1 Sub                                                           = 37 (double), 25 (float);
//   wi_x, wi_y 2 Mul; √(1 − u₁) 1 Sub 1 Sqrt; wo_z·wi_z 1 Mul; the pdf 1 Mul; to world space 9 Mul 6 Add = 21.
constexpr double kBounceFlops = 13 + 6 + (sizeof(Real) == 8 ? 37 : 25) + 21;
// Bytes per bounce: it reads n, d, u₁, u₂ (8 Reals) and writes w, cosθ, pdf (5 Reals).
constexpr double kBounceBytes = 13 * sizeof(Real);

struct BounceData {
  std::vector<Real> nx, ny, nz, dx, dy, dz, u1, u2, wx, wy, wz, cosTheta, pdf;
  explicit BounceData(std::size_t n, std::uint64_t seed)
  {
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<Real> u(0, 1);
    for (std::vector<Real>* v : {&nx, &ny, &nz, &dx, &dy, &dz, &u1, &u2, &wx, &wy, &wz, &cosTheta, &pdf})
      v->resize(n);
    for (std::size_t i = 0; i < n; ++i) {
      const Vec3 normal = randomUnit(rng), d = randomUnit(rng);
      nx[i] = normal.x, ny[i] = normal.y, nz[i] = normal.z;
      dx[i] = d.x, dy[i] = d.y, dz[i] = d.z;
      u1[i] = u(rng), u2[i] = u(rng);
    }
  }
  DiffuseBounceInput in() const { return {nx, ny, nz, dx, dy, dz, u1, u2}; }
  DiffuseBounceOutput out() { return {wx, wy, wz, cosTheta, pdf}; }
};

struct KernelRow {
  std::string kernel, target, stream;
  double raysPerSecond = 0, flopsPerRay = 0, bytesPerRay = 0, peak = 0, bandwidth = 0;
  double intensity() const { return flopsPerRay / bytesPerRay; }
  double gflops() const { return raysPerSecond * flopsPerRay * 1e-9; }
  double bound() const { return std::min(peak, intensity() * bandwidth); }
  bool computeBound() const { return peak <= intensity() * bandwidth; }
};

// Rays per second through `kernel(count)`, run `repeats` times per timed run.
template <class F> double raysPerSecond(F kernel, std::size_t count, std::size_t repeats, const Settings& s)
{
  const double seconds = bestSeconds(
    [&] {
      for (std::size_t r = 0; r < repeats; ++r)
        kernel();
    },
    s.budget, s.minRuns);
  return double(count) * double(repeats) / seconds;
}

std::string fixed(double x, int digits)
{
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, "%.*f", digits, x);
  return buffer;
}

// A number with three significant figures, without an exponent for the sizes printed here.
std::string sig3(double x)
{
  const double a = std::fabs(x);
  return fixed(x, a >= 100 ? 0 : a >= 10 ? 1 : a >= 1 ? 2 : 3);
}

std::string shellQuote(const std::string& s)
{
  std::string out = "'";
  for (char ch : s)
    out += ch == '\'' ? std::string("'\\''") : std::string(1, ch);
  return out + "'";
}

// The roofline as a gnuplot script: log–log, intensity on x and GFLOP/s on y; the memory and L2 slopes, a ceiling
// per instruction set, the kernels as points (filled: the stream in memory; open: in the cache).
void plot(const std::string& png, double memory, double l2, const std::vector<std::pair<std::string, double>>& peaks,
          const std::vector<KernelRow>& rows)
{
  const std::string script = png + ".gp";
  std::ofstream gp(script);
  gp << "# Drawn by roofline; run with: gnuplot THIS_FILE\n"
     << "set terminal pngcairo size 900,600 noenhanced font 'Sans,10'\nset output \"" << png << "\"\n"
     << "set logscale xy\nset xrange [0.05:64]\nset yrange [1:" << fixed(12 * peaks.front().second, 1) << "]\n"
     << "set grid xtics ytics mxtics mytics lc rgb '#dddddd'\nset key top left box opaque\nset samples 400\n"
     << "set xlabel \"arithmetic intensity (FLOP/byte)\"\nset ylabel \"GFLOP/s (one thread, " << sizeof(Real) * 8
     << "-bit Real)\"\nmin(a, b) = a < b ? a : b\n";
  // The points of the stream in memory are labelled; those in the cache (open circles) lie at the same intensity.
  for (std::size_t k = 0; k < rows.size(); ++k) {
    const KernelRow& r = rows[k];
    if (r.stream == "memory")
      gp << "set label " << k + 1 << " \"" << (r.kernel == "nearestSpheres" ? "nearest " : "bounce ") << r.target
         << "\" at " << r.intensity() << "," << r.gflops() << " offset 0.8,0 font 'Sans,8'\n";
  }
  gp << "$mem << EOD\n";
  for (const KernelRow& r : rows)
    if (r.stream == "memory")
      gp << r.intensity() << " " << r.gflops() << "\n";
  gp << "EOD\n$l2 << EOD\n";
  for (const KernelRow& r : rows)
    if (r.stream != "memory")
      gp << r.intensity() << " " << r.gflops() << "\n";
  gp << "EOD\nplot ";
  int colour = 1;
  for (const auto& [name, peak] : peaks) {
    gp << "min(" << peak << ", x * " << memory << ") with lines lw 2 lc " << colour << " title \"" << name
       << " peak " << fixed(peak, 1) << " GFLOP/s, memory " << fixed(memory, 1) << " GB/s\", \\\n     ";
    gp << "min(" << peak << ", x * " << l2 << ") with lines lw 1 dt 2 lc " << colour << " notitle, \\\n     ";
    ++colour;
  }
  gp << "$mem using 1:2 with points pt 7 ps 1.2 lc rgb 'black' title \"kernels, stream in memory\", \\\n"
     << "     $l2 using 1:2 with points pt 6 ps 1.2 lc rgb 'black' title \"kernels, stream in L2 (dashed: L2 "
     << fixed(l2, 0) << " GB/s)\"\n";
  gp.close();
  if (std::system("command -v gnuplot >/dev/null 2>&1") != 0) {
    std::cout << "\nPlot not drawn: gnuplot is missing (./setup.sh --bench installs gnuplot-nox); the script is " << script
              << ".\n";
    return;
  }
  if (std::system(("gnuplot " + shellQuote(script)).c_str()) != 0)
    std::cout << "\ngnuplot failed on " << script << ".\n";
  else
    std::cout << "\nPlot: " << png << " (script " << script << ").\n";
}

void usage(std::ostream& os)
{
  os << "usage: roofline [--quick] [--plot FILE.png]\n"
        "  --quick          small arrays, one run per figure (a smoke test; the figures mean little)\n"
        "  --plot FILE.png  draw the roofline with gnuplot (skipped, with a message, when gnuplot is missing)\n";
}

} // namespace

int main(int argc, char** argv)
{
  Settings s;
  std::string png;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--quick") {
      s.quick = true;
      s.budget = 0;
      s.minRuns = 1;
    } else if (a == "--plot" && i + 1 < argc) {
      png = argv[++i];
    } else if (a == "--help" || a == "-h") {
      usage(std::cout);
      return 0;
    } else {
      std::cerr << "roofline: unknown argument '" << a << "'\n";
      usage(std::cerr);
      return 2;
    }
  }

  const std::vector<SimdTarget> targets = simdTargets();
  std::cout << "# The roofline of this machine, one thread (Real = " << (sizeof(Real) == 8 ? "double" : "float")
            << ")\n\n";

  // 1. Bandwidth, with the best instruction set.
  const std::size_t bigBytes = s.quick ? (std::size_t(32) << 20) : (std::size_t(512) << 20);
  const double memory = readBandwidth(bigBytes, s), l2 = readBandwidth(256 << 10, s), l1 = readBandwidth(16 << 10, s);
  std::cout << "## Read bandwidth (a sum over an array, " << targets.front().name << ")\n\n"
            << "| array | GB/s |\n|---|---:|\n"
            << "| " << (bigBytes >> 20) << " MiB (memory) | " << sig3(memory) << " |\n"
            << "| 256 KiB (L2) | " << sig3(l2) << " |\n"
            << "| 16 KiB (L1) | " << sig3(l1) << " |\n\n";

  // 2. Peak multiplies and adds, per instruction set.
  std::vector<std::pair<std::string, double>> peaks;
  std::cout << "## Peak arithmetic (independent multiplies and adds, none fused)\n\n"
            << "| instruction set | lanes | GFLOP/s | per lane |\n|---|---:|---:|---:|\n";
  for (const SimdTarget& t : targets) {
    forceSimdTarget(t.id);
    const double peak = peakGflops(s);
    peaks.emplace_back(t.name, peak);
    std::cout << "| " << t.name << " | " << t.lanes << " | " << sig3(peak) << " | " << sig3(peak / t.lanes)
              << " |\n";
  }
  forceSimdTarget(0);
  std::cout << "\n(Real is " << (sizeof(Real) == 8 ? "double" : "float") << "; in "
            << (sizeof(Real) == 8 ? "float (cmake --preset float) every vector holds twice the lanes"
                                  : "double every vector holds half the lanes")
            << ".)\n\n";

  // 2b. Gathers, per instruction set.
  std::cout << "## Gathers (a vector of lanes loaded from scattered places in a 16 KiB table, the L1 cache)\n\n"
            << "| instruction set | lanes | ns a gather | ns a contiguous load | gather / load |\n"
               "|---|---:|---:|---:|---:|\n";
  for (const SimdTarget& t : targets) {
    forceSimdTarget(t.id);
    const GatherCost g = gatherCost(s);
    std::cout << "| " << t.name << " | " << t.lanes << " | " << sig3(g.gather) << " | " << sig3(g.load) << " | "
              << sig3(g.gather / g.load) << " |\n";
  }
  forceSimdTarget(0);
  std::cout << "\n";

  // 3. The kernels, in memory and in the cache.
  const SphereList spheres = SphereList::from(smallptSpheres());
  const std::size_t big = s.quick ? (std::size_t(1) << 16) : (std::size_t(1) << 22), small = 4096;
  std::vector<KernelRow> rows;
  for (int inMemory = 1; inMemory >= 0; --inMemory) {
    const std::size_t count = inMemory ? big : small;
    // About as many rays a timed run in the cache as in memory.
    const std::size_t repeats = inMemory ? 1 : big / small;
    const std::string stream = inMemory ? "memory" : "L2";
    const double bandwidth = inMemory ? memory : l2;
    {
      const RayStream rays = roomRays(count, 1);
      std::vector<Real> t(count);
      std::vector<std::int32_t> which(count);
      for (std::size_t k = 0; k < targets.size(); ++k) {
        forceSimdTarget(targets[k].id);
        KernelRow row{"nearestSpheres", targets[k].name, stream};
        row.raysPerSecond = raysPerSecond([&] { nearestSpheres(spheres, rays, count, t, which); }, count, repeats, s);
        row.flopsPerRay = nearestFlopsPerRay(spheres, rays, count, std::size_t(targets[k].lanes));
        row.bytesPerRay = kNearestBytes;
        row.peak = peaks[k].second;
        row.bandwidth = bandwidth;
        rows.push_back(row);
      }
    }
    {
      BounceData data(count, 2);
      const DiffuseBounceInput in = data.in();
      const DiffuseBounceOutput out = data.out();
      for (std::size_t k = 0; k < targets.size(); ++k) {
        forceSimdTarget(targets[k].id);
        KernelRow row{"diffuseBounces", targets[k].name, stream};
        row.raysPerSecond = raysPerSecond([&] { diffuseBounces(in, count, out); }, count, repeats, s);
        row.flopsPerRay = kBounceFlops;
        row.bytesPerRay = kBounceBytes;
        row.peak = peaks[k].second;
        row.bandwidth = bandwidth;
        rows.push_back(row);
      }
    }
  }
  forceSimdTarget(0);

  std::cout << "## The kernels on the roofline\n\n"
            << "Stream in memory: " << big << " rays; in L2: " << small << " rays, run " << big / small
            << " times. Bound = min(peak, intensity × bandwidth), the bandwidth of memory (" << sig3(memory)
            << " GB/s) or of L2 (" << sig3(l2) << " GB/s).\n\n"
            << "| kernel | stream | set | Mrays/s | FLOP/ray | bytes/ray | FLOP/byte | GFLOP/s | bound GFLOP/s | "
               "bound by | of bound |\n"
            << "|---|---|---|---:|---:|---:|---:|---:|---:|---|---:|\n";
  for (const KernelRow& r : rows)
    std::cout << "| " << r.kernel << " | " << r.stream << " | " << r.target << " | " << sig3(r.raysPerSecond * 1e-6)
              << " | " << sig3(r.flopsPerRay) << " | " << r.bytesPerRay << " | " << sig3(r.intensity()) << " | "
              << sig3(r.gflops()) << " | " << sig3(r.bound()) << " | " << (r.computeBound() ? "compute" : "bandwidth")
              << " | " << fixed(100 * r.gflops() / r.bound(), 0) << " % |\n";
  std::cout << "\nFLOP counts adds, subtracts, multiplies, divides and square roots per lane (from ray_stream.cpp; "
               "not negations, comparisons, selects or conversions); nearestSpheres' count is the lanes' work, "
               "firstRoot's last 4 operations included where some lane of the vector may hit the sphere. Bytes are "
               "the arrays read and written once (the writes' cache-line fills not counted).\n";

  if (!png.empty())
    plot(png, memory, l2, peaks, rows);
  return 0;
}

// The guided light sampler (LightSampler's LightGuiding constructor, chapters 7 and 8) and its quadtree density
// (core/sample_tree.h): each sampler against its pdf by chi-square, the pdf integrating to one, the pdf MIS uses
// equal to the pdf of the sample, guiding at work where a lamp is mostly hidden, and what is learned the same on
// every run. Fixed seeds, so each run draws the same numbers; the significance of each chi-square test is 1%.
#include "../statistics/chi_square.h"

#include "core/frame.h"
#include "core/sample_tree.h"
#include "scene/light_sampling.h"
#include "scene/scene.h"

#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

using namespace raylife;
using namespace raylife::test;

namespace {

constexpr double kSignificance = 0.01;
const std::string kScenes = RAYLIFE_SCENES;

// Points crowded into a few small regions of the square, as a lamp's visible part crowds a cone's samples.
std::vector<Vec2> clusteredPoints(int count, std::uint64_t seed)
{
  Sampler rng(seed, 0, 0, 0);
  std::vector<Vec2> points;
  for (int i = 0; i < count; ++i) {
    const Vec2 u = rng.next2D();
    const Real pick = rng.next1D();
    if (pick < Real(0.5))
      points.emplace_back(Real(0.03) * u.x, u.y); // a thin strip (the cap under the lamp)
    else if (pick < Real(0.8))
      points.emplace_back(Real(0.6) + Real(0.05) * u.x, Real(0.2) + Real(0.1) * u.y); // a small blob
    else
      points.push_back(u); // spread everywhere
  }
  return points;
}

} // namespace

TEST_CASE("sample tree: few points give the uniform density - many give a deep tree")
{
  CHECK(SampleTree::fromPoints(clusteredPoints(7, 1), 8, 0.01, 8).uniform());
  const SampleTree tree = SampleTree::fromPoints(clusteredPoints(20000, 1), 8, 0.01, 8);
  CHECK(!tree.uniform());
  CHECK(tree.depth() >= 5);
  CHECK(tree.leafCount() > 20);
  // Where the points crowd, the density is high; where few fell, low.
  CHECK(tree.pdf(Vec2(Real(0.01), Real(0.5))) > 10);
  CHECK(tree.pdf(Vec2(Real(0.3), Real(0.7))) < 1);
}

TEST_CASE("sample tree: its samples follow its pdf (chi-square), and the pdf integrates to one")
{
  // Depth at most 6: the leaves are unions of the 64 × 64 grid's cells, so the pdf is constant on each cell.
  const SampleTree tree = SampleTree::fromPoints(clusteredPoints(20000, 2), 6, 0.01, 8);
  REQUIRE(!tree.uniform());
  constexpr int kGrid = 64, kDraws = 400000;
  std::vector<double> observed(kGrid * kGrid, 0), expected(kGrid * kGrid, 0);
  double integral = 0;
  for (int y = 0; y < kGrid; ++y)
    for (int x = 0; x < kGrid; ++x) {
      const double p = double(tree.pdf(Vec2((Real(x) + Real(0.5)) / kGrid, (Real(y) + Real(0.5)) / kGrid)));
      expected[std::size_t(y * kGrid + x)] = p / (kGrid * kGrid) * kDraws;
      integral += p / (kGrid * kGrid);
    }
  CHECK(integral == Approx(1).epsilon(1e-5));
  Sampler rng(3, 0, 0, 0);
  for (int i = 0; i < kDraws; ++i) {
    const Vec2 p = tree.sample(rng.next2D());
    REQUIRE(p.x >= 0);
    REQUIRE(p.x < 1);
    REQUIRE(p.y >= 0);
    REQUIRE(p.y < 1);
    observed[std::size_t(std::min(kGrid - 1, int(p.y * kGrid)) * kGrid + std::min(kGrid - 1, int(p.x * kGrid)))] += 1;
  }
  // Pool the cells expected fewer than 5 draws; a draw where the pdf is 0 fails outright.
  double statistic = 0, pooledO = 0, pooledE = 0;
  int cells = 0;
  for (std::size_t k = 0; k < observed.size(); ++k) {
    if (expected[k] == 0)
      REQUIRE(observed[k] == 0);
    if (expected[k] < 5) {
      pooledO += observed[k];
      pooledE += expected[k];
      continue;
    }
    statistic += (observed[k] - expected[k]) * (observed[k] - expected[k]) / expected[k];
    ++cells;
  }
  if (pooledE > 0) {
    statistic += (pooledO - pooledE) * (pooledO - pooledE) / pooledE;
    ++cells;
  }
  INFO("chi2 = " << statistic << " with " << cells - 1 << " dof");
  CHECK(statistic <= chiSquareQuantile(cells - 1, kSignificance));
}

TEST_CASE("sphere cone coordinates invert sampleSphereCone")
{
  const Vec3 ref(Real(0.3), Real(-0.2), Real(0.1)), c(Real(1), Real(2), Real(-3));
  const Real r = Real(1.5);
  Sampler rng(4, 0, 0, 0);
  for (int i = 0; i < 1000; ++i) {
    const Vec2 u = rng.next2D();
    const Vec2 back = sphereConeCoordinates(ref, c, r, sampleSphereCone(ref, c, r, u));
    CHECK(double(back.x) == Approx(double(u.x)).margin(sizeof(Real) == 4 ? 1e-3 : 1e-7));
    // φ wraps around at 1.
    const double dy = std::abs(double(back.y) - double(u.y));
    CHECK(std::min(dy, 1 - dy) < (sizeof(Real) == 4 ? 1e-3 : 1e-7));
  }
}

namespace {

// The shaded points of the guided-sampler tests: on the floors and walls of scenes whose lamp is mostly hidden.
struct Place {
  std::string scene;
  Vec3 point;
};
const std::vector<Place> kPlaces = {
    {"smallpt.json", Vec3(50, Real(0.01), 81)},    {"smallpt.json", Vec3(Real(1.5), 30, 60)},
    {"smallpt.json", Vec3(20, Real(0.01), 120)},   {"smallpt.json", Vec3(Real(98.5), 50, 40)},
    {"lamp_recess.json", Vec3(1, Real(0.01), 1)},  {"lamp_recess.json", Vec3(2, Real(0.01), -2)},
    {"lamp_slit.json", Vec3(1, Real(0.01), 1)},    {"lampshade.json", Vec3(Real(2.5), Real(0.01), Real(2.5))}};

// The sampler's tests learn wherever a light is partly hidden (guideBelow 0.8), from twice the samples, so that the
// guide is at work at every place; by default it learns only where fewer than one sample in ten is of use.
const LightGuiding kEager{.samplesPerPoint = 64, .guideBelow = Real(0.8)};

// The one sphere light of a scene.
int sphereLight(const Scene& scene)
{
  for (std::size_t i = 0; i < scene.spheres.size(); ++i)
    if (scene.materials[std::size_t(scene.spheres[i].material)].isEmissive())
      return int(i);
  return -1;
}

} // namespace

TEST_CASE("guided light sampler: directions follow its pdf (chi-square), the pdf MIS reads is the sample's")
{
  // The test is made in the cone's own numbers u (sphereConeCoordinates), where the unguided sampler is uniform:
  // the guided sampler's density there is p_guided(ω(u)) / p_uniform. The tree's leaves are at least 2⁻¹⁰ of a
  // side, so that density is constant on the 1024 × 1024 grid of cells whose midpoints integrate it exactly.
  //
  // Each place draws kRuns independent runs, each from a stream of its own (Sampler(seed, place, run)): a stream
  // shared between places makes their statistics move together (the same uniform numbers through similar warps:
  // correlation about 0.6 over 16 seeds), and one unlucky stream then lifts them all at once. That was the "5%
  // above the expectation" once seen here: with one shared stream (seed 5) the 8 statistics averaged 1093 against
  // 1023 degrees of freedom, with seed 7 975; over 64 independent streams per place the means were 1009 to 1031
  // (± 5), and 4·10⁷ draws at one place (a hundred times this test's) gave no excess either (924 to 1021).
  // Checked: each place's pooled histogram at 1%; the mean of all the runs' statistics against the degrees of
  // freedom (two-sided, 1%); and the test's power, by the pooled histogram rejecting a pdf whose mixture weight is
  // off by 5%.
  constexpr int kBins = 32, kFine = 1024, kRuns = 8, kDraws = 100000;
  std::vector<double> statistics;
  int dof = 0, guidedPlaces = 0;
  for (std::size_t placeIndex = 0; placeIndex < kPlaces.size(); ++placeIndex) {
    const Place& place = kPlaces[placeIndex];
    const Scene scene = loadScene(kScenes + "/" + place.scene);
    const LightSampler guided(scene, kEager), plain(scene);
    const int light = sphereLight(scene);
    REQUIRE(light >= 0);
    const Sphere& s = scene.spheres[std::size_t(light)];
    const Vec3 ref = place.point;
    const auto ratioAt = [&](Vec2 u) {
      const Vec3 w = sampleSphereCone(ref, s.center, s.radius, u);
      const std::optional<SphereRoots<Real>> roots = intersectSphereRoots(ref, w, s.center, s.radius);
      const Real t = roots ? (roots->t0 >= 0 ? roots->t0 : roots->t1) : glm::dot(s.center - ref, w);
      return double(guided.pdf(ref, light, ref + t * w)) / double(plain.pdf(ref, light, ref + t * w));
    };
    // Each bin's probability.
    std::vector<double> probability(kBins * kBins, 0);
    for (int y = 0; y < kFine; ++y)
      for (int x = 0; x < kFine; ++x) {
        const Vec2 u((Real(x) + Real(0.5)) / kFine, (Real(y) + Real(0.5)) / kFine);
        probability[std::size_t(y * kBins / kFine * kBins + x * kBins / kFine)] +=
            ratioAt(u) / (double(kFine) * kFine);
      }
    const auto chiSquare = [&](const std::vector<double>& observed, double draws, double wrongWeight = 0) {
      double statistic = 0;
      for (std::size_t k = 0; k < observed.size(); ++k) {
        // wrongWeight > 0: the pdf the sampler would report with its uniform share off by that much.
        const double e = draws * ((1 - wrongWeight) * probability[k] + wrongWeight / double(kBins * kBins));
        statistic += (observed[k] - e) * (observed[k] - e) / e;
      }
      return statistic;
    };
    double worstMismatch = 0;
    int mismatches = 0;
    std::vector<double> pooled(kBins * kBins, 0);
    for (int run = 0; run < kRuns; ++run) {
      std::vector<double> observed(kBins * kBins, 0);
      Sampler rng(5, int(placeIndex), 0, std::uint64_t(run));
      for (int i = 0; i < kDraws; ++i) {
        const Real uLight = rng.next1D();
        const std::optional<LightSample> ls = guided.sample(ref, uLight, rng.next2D());
        REQUIRE(ls.has_value());
        // The pdf MIS reads for this direction (LightSampler::pdf) is the one the sample carries.
        const double mismatch = std::abs(double(guided.pdf(ref, light, ls->target) / ls->pdf) - 1);
        worstMismatch = std::max(worstMismatch, mismatch);
        mismatches += mismatch > 1e-2;
        const Vec2 u = sphereConeCoordinates(ref, s.center, s.radius, ls->wi);
        observed[std::size_t(std::min(kBins - 1, int(u.y * kBins)) * kBins + std::min(kBins - 1, int(u.x * kBins)))] +=
            1;
      }
      statistics.push_back(chiSquare(observed, kDraws));
      for (std::size_t k = 0; k < pooled.size(); ++k)
        pooled[k] += observed[k];
    }
    for (const double p : probability)
      REQUIRE(p * kDraws > 5); // the uniform share alone (at least 0.15) expects 0.15 × 100000 / 1024 ≈ 15
    dof = kBins * kBins - 1;
    const double statistic = chiSquare(pooled, double(kRuns) * kDraws);
    const double wrong = chiSquare(pooled, double(kRuns) * kDraws, 0.05);
    INFO(place.scene << " at (" << ref.x << ", " << ref.y << ", " << ref.z << "): pooled chi2 = " << statistic
                     << " with " << dof << " dof (against the mixture weight off by 5%: " << wrong << "); "
                     << mismatches << " pdfs differ by over 1%, the worst by " << worstMismatch);
    CHECK(statistic <= chiSquareQuantile(dof, kSignificance));
    // Where the guide learned nothing (in float, at the slit's point) the pdf is uniform, and so is the wrong one.
    const bool guidedHere = *std::max_element(probability.begin(), probability.end()) * kBins * kBins > 1.5;
    if (guidedHere)
      CHECK(wrong > chiSquareQuantile(dof, kSignificance));
    guidedPlaces += guidedHere;
    // In double the two pdfs agree to rounding. In float, a direction drawn within rounding of a tree leaf's edge
    // can map back (sphereConeCoordinates) into the neighbouring leaf, whose density differs: rare, and counted.
    if constexpr (sizeof(Real) == 4)
      CHECK(mismatches <= kRuns * kDraws / 10000);
    else
      CHECK(worstMismatch < 1e-6);
  }
  // The statistics of independent runs average to the degrees of freedom (exactly, for a multinomial): a density
  // that differs from the pdf by a little everywhere lifts the mean long before it fails any one run.
  double mean = 0, spread = 0;
  for (const double x : statistics)
    mean += x / double(statistics.size());
  for (const double x : statistics)
    spread += (x - mean) * (x - mean) / double(statistics.size() - 1);
  const double standardError = std::sqrt(spread / double(statistics.size()));
  INFO("mean of " << statistics.size() << " chi2 statistics " << mean << " +- " << standardError << " against "
                  << dof << " dof");
  CHECK(std::abs(mean - dof) <= 2.576 * standardError); // two-sided at 1%
  CHECK(guidedPlaces >= int(kPlaces.size()) - (sizeof(Real) == 4 ? 1 : 0));
}

TEST_CASE("guided light sampler: its pdf integrates to one over the cone, and it is guided where the lamp hides")
{
  int places = 0, guidedPlaces = 0;
  for (const Place& place : kPlaces) {
    const Scene scene = loadScene(kScenes + "/" + place.scene);
    const LightSampler guided(scene, kEager), plain(scene);
    const int light = sphereLight(scene);
    const Sphere& s = scene.spheres[std::size_t(light)];
    const Vec3 ref = place.point;
    // ∫ p_guided dω = E over uniform cone directions of p_guided / p_uniform, which must be 1.
    Sampler rng(6, 0, 0, 0);
    constexpr int kDraws = 100000;
    double sum = 0, sum2 = 0, largest = 0;
    for (int i = 0; i < kDraws; ++i) {
      const Vec3 w = sampleSphereCone(ref, s.center, s.radius, rng.next2D());
      const std::optional<SphereRoots<Real>> roots = intersectSphereRoots(ref, w, s.center, s.radius);
      const Real t = roots ? (roots->t0 >= 0 ? roots->t0 : roots->t1) : glm::dot(s.center - ref, w);
      const double ratio = double(guided.pdf(ref, light, ref + t * w)) / double(plain.pdf(ref, light, ref + t * w));
      sum += ratio;
      sum2 += ratio * ratio;
      largest = std::max(largest, ratio);
    }
    const double mean = sum / kDraws, error = std::sqrt((sum2 / kDraws - mean * mean) / kDraws);
    INFO(place.scene << " at (" << ref.x << ", " << ref.y << ", " << ref.z << "): mean " << mean << " +- " << error);
    CHECK(std::abs(mean - 1) <= 4 * error + 1e-9);
    // Whether the guide learned something here: some directions far likelier than uniform ones.
    ++places;
    guidedPlaces += largest > 1.5;
    UNSCOPED_INFO(place.scene << " at (" << ref.x << ", " << ref.y << ", " << ref.z << "): largest ratio " << largest);
  }
  // Guided at every place in double. In float the pre-pass's held-out judgement declined the guide at the slit's
  // point (1, 0.01, 1), so there one place may go unguided.
  CHECK(guidedPlaces >= places - (sizeof(Real) == 4 ? 1 : 0));
  // By default, guided where the lamp is hidden most: smallpt's places (1.5% of the samples of use).
  const Scene smallpt = loadScene(kScenes + "/smallpt.json");
  const LightSampler byDefault(smallpt, LightGuiding{}), plain(smallpt);
  const int light = sphereLight(smallpt);
  const Sphere& s = smallpt.spheres[std::size_t(light)];
  for (const Place& place : kPlaces) {
    if (place.scene != "smallpt.json")
      continue;
    Sampler rng(8, 0, 0, 0);
    double largest = 0;
    for (int i = 0; i < 10000; ++i) {
      const Vec3 w = sampleSphereCone(place.point, s.center, s.radius, rng.next2D());
      const std::optional<SphereRoots<Real>> roots = intersectSphereRoots(place.point, w, s.center, s.radius);
      const Real t = roots ? (roots->t0 >= 0 ? roots->t0 : roots->t1) : glm::dot(s.center - place.point, w);
      const Vec3 hit = place.point + t * w;
      largest = std::max(largest, double(byDefault.pdf(place.point, light, hit) / plain.pdf(place.point, light, hit)));
    }
    INFO("smallpt at (" << place.point.x << ", " << place.point.y << ", " << place.point.z << "), by default");
    CHECK(largest > 1.5);
  }
}

TEST_CASE("guided light sampler: what it learns is the same on every run, and it reports it")
{
  const Scene scene = loadScene(kScenes + "/smallpt.json");
  const LightSampler a(scene, LightGuiding{}), b(scene, LightGuiding{});
  CHECK(a.describeGuide() == b.describeGuide());
  REQUIRE(a.describeGuide().size() == 3);
  CHECK(a.describeGuide()[1].find("sphere 8: samples of use") != std::string::npos);
  Sampler rng(7, 0, 0, 0);
  for (int i = 0; i < 1000; ++i) {
    // One draw a statement (C++ leaves the order of a call's arguments unspecified; GCC evaluates them right to
    // left, clang left to right), in the order GCC drew them as arguments of one call: z, y, x.
    const Real pz = rng.next1D();
    const Real py = rng.next1D();
    const Real px = rng.next1D();
    const Vec3 ref(Real(1) + 98 * px, Real(81.5) * py, 170 * pz);
    const Real uLight = rng.next1D();
    const Vec2 u = rng.next2D();
    const std::optional<LightSample> x = a.sample(ref, uLight, u), y = b.sample(ref, uLight, u);
    REQUIRE(x.has_value() == y.has_value());
    if (x) {
      CHECK(x->wi == y->wi);
      CHECK(x->pdf == y->pdf);
    }
  }
  // Unguided, it learns nothing and says nothing.
  CHECK(LightSampler(scene).describeGuide().empty());
}

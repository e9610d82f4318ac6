// Golden tests of chapters 5 and 6 against the references in this folder (tools/make_reference.sh renders them).
//
// Chapter 5 is deterministic for a given seed: a per-pixel tolerance. Chapter 6 is Monte Carlo: a fresh render
// (another seed, 256 spp) is compared with a 4096-spp reference by a per-pixel z-test,
//   z = (a − b)/√(var_a + var_b),
// with var_b the variance of the reference's mean (its sample variance) and var_a the variance a correct render
// of 256 spp has, var_b · 4096/256. A channel fails when
// |z| > 3.29 (two-sided significance 0.001); the render passes when at most 1% of the channels fail (about 0.1% do
// for a correct render; heavy-tailed pixels, such as caustics seen at few samples, make a few more) and the image
// mean, per channel, lies within 4 standard errors of the reference's. So a correct change of random sequence
// passes, and a biased estimator fails: the tests below show both, with copies of chapter 6's path tracing loop
// that each make one classic mistake.
#include "../../analytic/run_chapter.h"

#include "shading/bsdf.h"
#include "core/frame.h"
#include "render/image_compare.h"
#include "render/runner.h"
#include "core/sampling.h"

#include <catch2/catch.hpp>

#include <iostream>

using namespace raylife;
using namespace raylife::test;

namespace {

const std::string kGolden = RAYLIFE_GOLDEN_MC;
const std::string kScenes = RAYLIFE_SCENES;

constexpr double kCritical = 3.29;
constexpr double kMaxFailedShare = 0.01;
constexpr double kMaxMeanZ = 4;
constexpr int kSpp = 256;
constexpr int kReferenceSpp = 4096; // tools/make_reference.sh
// Keeps z defined where both variances are 0 (pixels that are exactly known, e.g. black).
constexpr double kVarianceFloor = 1e-10;

struct McVerdict {
  double failedShare = 0;
  double worstMeanZ = 0;
  bool passed() const { return failedShare <= kMaxFailedShare && std::abs(worstMeanZ) <= kMaxMeanZ; }
};

McVerdict judge(const Image& mean, const std::string& what)
{
  const Image ref = readPfm(kGolden + "/step06_cornell_64x48.pfm");
  const Image refVar = readPfm(kGolden + "/step06_cornell_64x48_variance.pfm");
  REQUIRE(mean.width == ref.width);
  REQUIRE(mean.height == ref.height);
  // The variance the render under test would have if it were correct: the reference's, scaled to kSpp samples.
  // (Not the render's own sample variance: a biased estimator often has a heavier tail too, and would hide its
  // bias behind it.)
  Image variance = refVar;
  for (float& v : variance.pixels)
    v *= float(kReferenceSpp) / float(kSpp);
  McVerdict v;
  v.failedShare = zTestImages(mean, variance, ref, refVar, kCritical, kVarianceFloor).failedShare;
  // The image mean, one channel at a time (the channels of a pixel are correlated).
  for (int c = 0; c < 3; ++c) {
    double diff = 0, var = 0;
    for (int y = 0; y < ref.height; ++y)
      for (int x = 0; x < ref.width; ++x) {
        diff += double(mean.at(x, y, c)) - double(ref.at(x, y, c));
        var += double(variance.at(x, y, c)) + double(refVar.at(x, y, c)) + kVarianceFloor;
      }
    const double z = diff / std::sqrt(var);
    if (std::abs(z) > std::abs(v.worstMeanZ))
      v.worstMeanZ = z;
  }
  std::cout << what << ": failed channels " << 100 * v.failedShare << "% (bound " << 100 * kMaxFailedShare
            << "%), worst channel's image mean off by z = " << v.worstMeanZ << " (bound " << kMaxMeanZ << ")\n";
  return v;
}

// The ways to get chapter 6's loop wrong that the test must catch.
enum class Mistake {
  None,             // chapter 6's loop as it is (a control for this copy)
  LostCosine,       // the weight f/pdf without |cosθi|
  RouletteNoDivide, // Russian roulette that does not divide by the survival probability
};

// A copy of chapter 6's trace (steps/06_path_tracer/main.cpp) with one mistake switched in.
Color traceWith(Mistake mistake, const Scene& scene, const Ray& primary, Sampler& sampler, int maxDepth)
{
  Color L(0), beta(1);
  Ray ray = primary;
  for (int bounce = 0;; ++bounce) {
    const std::optional<Hit> hit = scene.intersect(ray);
    if (!hit) {
      L += beta * scene.background;
      break;
    }
    const Material& m = scene.materials[std::size_t(hit->material)];
    L += beta * m.emission;
    if (bounce == maxDepth)
      break;
    const Frame frame = Frame::fromNormal(hit->normal);
    const Vec3 wo = frame.toLocal(-ray.direction);
    const Real uChoice = sampler.next1D(); // in chapter 6's order
    const Vec2 u = sampler.next2D();
    const std::optional<BsdfSample> bs = bsdfSample(m, wo, u, uChoice);
    if (!bs)
      break;
    beta *= mistake == Mistake::LostCosine ? bs->f / bs->pdf : bs->f * std::abs(bs->wi.z) / bs->pdf;
    if (beta == Color(0))
      break;
    if (bounce >= kRouletteMinBounces) {
      const Real q = rouletteSurvival(beta);
      if (sampler.next1D() >= q)
        break;
      if (mistake != Mistake::RouletteNoDivide)
        beta /= q;
    }
    ray = spawnRay(*hit, frame.toWorld(bs->wi));
  }
  return L;
}

RenderResult renderWith(Mistake mistake, std::uint64_t seed)
{
  const Scene scene = loadScene(kScenes + "/cornell.json");
  RenderSettings settings;
  settings.spp = kSpp;
  settings.seed = seed;
  settings.pixelSampling = PixelSampling::Jittered;
  return render(scene, scene.makeCamera(64, 48), settings,
                [mistake](const Scene& s, const Ray& r, Sampler& sampler, int depth) {
                  return traceWith(mistake, s, r, sampler, depth);
                });
}

} // namespace

TEST_CASE("golden: chapter 5 matches its reference within a per-pixel tolerance")
{
  const ChapterRender r = runChapterBinary(RAYLIFE_STEP05, kScenes + "/whitted.json",
                                           "--width 160 --height 120 --seed 0", "golden5");
  const Image ref = readPfm(kGolden + "/step05_whitted_160x120.pfm");
  REQUIRE(r.mean.width == ref.width);
  // The reference is rendered in double, where the render matches it exactly. A float build (RAYLIFE_REAL=float)
  // rounds differently along chains of up to 10 refractions, and a few rays near silhouettes and the critical angle
  // take the other branch: it gets a looser tolerance, stated here.
  const bool isFloat = sizeof(Real) == 4;
  const double tolerance = isFloat ? 1e-2 : 1e-3, maxShare = isFloat ? 0.01 : 0.002, maxRmse = isFloat ? 3e-3 : 1e-3;
  const ImageDifference d = compareImages(r.mean, ref, tolerance);
  std::cout << "chapter 5 golden: largest difference " << d.maxAbs << ", share over " << tolerance << ": "
            << d.overTolerance << ", rmse " << d.rmse << "\n";
  CHECK(d.overTolerance <= maxShare);
  CHECK(d.rmse < maxRmse);
}

TEST_CASE("golden: chapter 6 with another seed passes the z-test against its reference")
{
  const ChapterRender r = runChapterBinary(RAYLIFE_STEP06, kScenes + "/cornell.json",
                                           "--width 64 --height 48 --spp 256 --seed 1234", "golden6");
  CHECK(statsValue(r.stats, "bad_samples") == 0);
  CHECK(judge(r.mean, "chapter 6, seed 1234").passed());
}

TEST_CASE("golden: the test's copy of the loop, unchanged, passes (the control for the mistakes below)")
{
  const RenderResult r = renderWith(Mistake::None, 99);
  CHECK(r.badSamples == 0);
  CHECK(judge(r.film.mean(), "copy of chapter 6, seed 99").passed());
}

TEST_CASE("golden: a lost cosine fails the z-test")
{
  const RenderResult r = renderWith(Mistake::LostCosine, 99);
  CHECK_FALSE(judge(r.film.mean(), "lost cosine").passed());
}

TEST_CASE("golden: Russian roulette without its division fails the z-test")
{
  const RenderResult r = renderWith(Mistake::RouletteNoDivide, 99);
  CHECK_FALSE(judge(r.film.mean(), "roulette without division").passed());
}

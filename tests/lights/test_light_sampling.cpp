// Light sampling (common/scene/light_sampling.h): the cone sampler of a spherical light against its pdf (chi-square), the
// sampled directions all hitting the light, 1 − cosθmax without cancellation in float and double, the inside of a
// light, the choice of a light by power, and the MIS heuristics' weights summing to one.
// Fixed seeds, so each run draws the same numbers; the significance of each chi-square test is 1%.
#include "../statistics/chi_square.h"

#include "shading/bsdf.h"
#include "core/frame.h"
#include "scene/light_sampling.h"
#include "scene/scene.h"

#include <catch2/catch.hpp>

#include <cmath>
#include <string>
#include <vector>

using namespace raylife;
using namespace raylife::test;

namespace {

constexpr double kSignificance = 0.01;
constexpr int kSamples = 200000;
// Relative tolerance of a few operations in the renderer's scalar (the float build is tested too).
constexpr double kTolerance = sizeof(Real) == 4 ? 1e-5 : 1e-9;

// True when the ray from `ref` along unit `w` meets the sphere in front of it (t ≥ 0), in scalar T.
template <class T> bool hitsSphere(const TVec3<T>& ref, const TVec3<T>& w, const TVec3<T>& c, T r)
{
  const auto roots = intersectSphereRoots(ref, w, c, r);
  return roots && roots->t1 >= 0;
}

// The density of sampleSphereCone over the whole sphere of directions: sphereConePdf where the ray hits, 0 elsewhere.
double conePdfOrZero(const Vec3& ref, const Vec3& c, Real r, const Vec3& w)
{
  return hitsSphere(ref, w, c, r) ? double(sphereConePdf(ref, c, r)) : 0.0;
}

// A random number log-uniform in [10^lo, 10^hi].
double logUniform(Sampler& rng, double lo, double hi) { return std::pow(10.0, lo + (hi - lo) * double(rng.next1D())); }

// The random numbers below are drawn one statement at a time, never two in one call: C++ leaves the order of a call's
// arguments unspecified (GCC evaluates them right to left, clang left to right), and the draws must not depend on the
// compiler. Where a call once made several draws, the statements make them in the order GCC did, last argument first,
// so the tests keep the samples their thresholds were set on.

} // namespace

// ---- The cone sampler against its pdf --------------------------------------------------------------------------

TEST_CASE("chi-square: directions towards a spherical light are uniform in its cone, from near, far and inside")
{
  // The light's centre lies along +x, so its cone spreads over many cells of the (cosθ, φ) grid.
  const Vec3 c(0), ref0(0);
  struct Case {
    const char* what;
    Real distance; // of the shaded point from the centre, in radii
  };
  for (const Case& k : {Case{"near (d = 1.2 r)", Real(1.2)}, Case{"d = 2 r", Real(2)}, Case{"far (d = 5 r)", Real(5)},
                        Case{"inside (d = 0.5 r)", Real(0.5)}, Case{"at the centre", Real(0)}}) {
    const Vec3 ref = ref0 - Vec3(k.distance, 0, 0);
    auto r = chiSquareTest([&](Vec2 u, Real) { return std::optional<Vec3>(sampleSphereCone(ref, c, Real(1), u)); },
                           [&](const Vec3& w) { return conePdfOrZero(ref, c, 1, w); }, kSamples, 11, kSignificance, 40,
                           80, 4);
    INFO(k.what << ": " << r.summary());
    CHECK(r.passed);
  }
}

TEST_CASE("chi-square: the small-angle form sin²θ = u sin²θmax used for a large cone fails (the test can fail)")
{
  // pbrt-v4 switches to this form only below sin²θmax ≈ 7·10⁻⁴; used at d = 2 r it is visibly wrong.
  const Vec3 c(0), ref(-2, 0, 0);
  const Real sin2Max = Real(0.25);
  auto wrong = chiSquareTest(
      [&](Vec2 u, Real) {
        const Real sin2 = u.x * sin2Max;
        const Real cosT = std::sqrt(1 - sin2), sinT = std::sqrt(sin2), phi = 2 * kPi * u.y;
        const Frame f = Frame::fromNormal(Vec3(1, 0, 0));
        return std::optional<Vec3>(f.toWorld(Vec3(sinT * std::cos(phi), sinT * std::sin(phi), cosT)));
      },
      [&](const Vec3& w) { return conePdfOrZero(ref, c, 1, w); }, kSamples, 12, kSignificance, 40, 80, 4);
  INFO(wrong.summary());
  CHECK_FALSE(wrong.passed);
}

TEST_CASE("every sampled direction towards a spherical light hits it, near and far, in float and double")
{
  // Random shaded points at distances from just outside the light to 10⁶ radii (double) or 10³ radii (float), in
  // random directions, with random centres and radii. (In float, past 10³ radii a few directions in 10⁵, at the cone's
  // very edge, miss by rounding: the direction and the intersection test each carry an error of about 10⁻⁷, a visible
  // share of a cone that narrow. Chapters 7 and 8 then trace the shadow ray and find nothing: a sample lost, never a
  // NaN.)
  auto run = [](auto scalar, double maxLogDistance) {
    using T = decltype(scalar);
    Sampler rng(21, 0, 0, 0);
    int misses = 0, total = 0;
    for (int config = 0; config < 2000; ++config) {
      const T r = T(logUniform(rng, -2, 2));
      const Real cz = rng.next1D();
      const Real cy = rng.next1D();
      const Real cx = rng.next1D();
      const TVec3<T> c(T(cx * 20 - 10), T(cy * 20 - 10), T(cz * 20 - 10));
      const Vec3 dir = sampleUniformSphere(rng.next2D());
      const T d = r * T(1 + logUniform(rng, -5, maxLogDistance));
      const TVec3<T> ref = c + d * TVec3<T>(dir);
      for (int s = 0; s < 200; ++s) {
        const Vec2 u = rng.next2D();
        const TVec3<T> w = sampleSphereCone(ref, c, r, glm::vec<2, T>(u));
        misses += !hitsSphere(ref, w, c, r);
        ++total;
      }
    }
    INFO(sizeof(T) * 8 << "-bit: " << misses << " of " << total << " directions missed");
    CHECK(misses == 0);
  };
  run(double(0), 6);
  run(float(0), 3);
}

// ---- 1 − cosθmax and the pdf ------------------------------------------------------------------------------------

TEST_CASE("1 − cosθmax keeps full precision for small and distant lights, in float and double")
{
  // Reference: long double, by the series s/2 + s²/8 + s³/16 + 5s⁴/128 where s = sin²θmax is small (its error is
  // below 10⁻¹⁹ relative for s < 10⁻⁴) and by the direct form elsewhere (no cancellation once s is not small).
  auto reference = [](long double s) {
    if (s < 1e-4L)
      return s / 2 + s * s / 8 + s * s * s / 16 + 5 * s * s * s * s / 128;
    return 1 - std::sqrt(1 - s);
  };
  double worstFloat = 0, worstDouble = 0;
  for (int e = -300; e <= 0; ++e)
    for (double m : {1.0, 2.5, 7.3}) {
      const double s = m * std::pow(10.0, e);
      if (s > 1)
        continue;
      const long double ref = reference(static_cast<long double>(s));
      worstDouble = std::max(worstDouble, double(std::abs((oneMinusCosConeAngle(s) - ref) / ref)));
      if (s >= 1e-37) { // within float's normal range
        const float sf = float(s);
        const long double reff = reference(static_cast<long double>(sf));
        worstFloat = std::max(worstFloat, double(std::abs((oneMinusCosConeAngle(sf) - reff) / reff)));
      }
    }
  INFO("worst relative error: float " << worstFloat << ", double " << worstDouble);
  CHECK(worstFloat < 4 * 6e-8);
  CHECK(worstDouble < 4 * 1.2e-16);
  // The control: the direct form 1 − √(1 − s) loses everything in float at s = 10⁻⁸ (a light 10⁴ radii away).
  const float s = 1e-8f;
  CHECK(1.0f - std::sqrt(1.0f - s) == 0.0f);
  CHECK(oneMinusCosConeAngle(s) > 0.0f);
}

TEST_CASE("the cone pdf is finite and positive on, inside and far outside the light, in float and double")
{
  auto run = [](auto scalar) {
    using T = decltype(scalar);
    const TVec3<T> c(T(1), T(2), T(3));
    const T r = T(0.5);
    for (T d : {T(0), r / 2, std::nextafter(r, T(0)), r, std::nextafter(r, T(2) * r), T(2) * r, T(1e6) * r,
                T(1e18) * r}) {
      const TVec3<T> ref = c + d * TVec3<T>(T(0.6), T(0), T(0.8));
      const T pdf = sphereConePdf(ref, c, r);
      INFO(sizeof(T) * 8 << "-bit, d = " << d << ": pdf " << pdf);
      CHECK(std::isfinite(pdf));
      CHECK(pdf > 0);
      for (Vec2 u : {Vec2(0, 0), Vec2(Real(0.5), Real(0.5)), Vec2(Real(0.999999), Real(0.999999))}) {
        const TVec3<T> w = sampleSphereCone(ref, c, r, glm::vec<2, T>(u));
        CHECK(isFinite(w));
        CHECK(std::abs(glm::length(w) - 1) < T(1e-5));
      }
    }
  };
  run(double(0));
  run(float(0));
}

// ---- Choosing a light ---------------------------------------------------------------------------------------------

TEST_CASE("lights are chosen in proportion to their power and the pdf for a direction matches the sampler's")
{
  // Power: π·Le·4πr² for a sphere, 4π·I for a point light (luminance): 4π²·1·1, 4π²·4·0.25 and 4π·π/4: 1 : 1 : 0.25.
  const Scene scene = parseScene(R"({
    "camera": { "eye": [0, 0, 10], "focal": [0, 0, 0], "up": [0, 1, 0], "vfov": 40, "width": 8, "height": 8 },
    "materials": { "a": { "type": "diffuse", "color": [0, 0, 0], "emission": [1, 1, 1] },
                   "b": { "type": "diffuse", "color": [0, 0, 0], "emission": [4, 4, 4] },
                   "wall": { "type": "diffuse", "color": [0.5, 0.5, 0.5] } },
    "spheres": [ { "center": [-3, 0, 0], "radius": 1, "material": "a" },
                 { "center": [0, -100, 0], "radius": 90, "material": "wall" },
                 { "center": [3, 0, 0], "radius": 0.5, "material": "b" } ],
    "lights": [ { "type": "point", "position": [0, 5, 0], "intensity": [0.785398163397448, 0.785398163397448, 0.785398163397448] } ]
  })",
                                 "inline");
  const LightSampler lights(scene);
  REQUIRE_FALSE(lights.empty());
  CHECK(lights.probability(0) == Approx(1 / 2.25).epsilon(1e-6));
  CHECK(lights.probability(1) == 0);
  CHECK(lights.probability(2) == Approx(1 / 2.25).epsilon(1e-6));

  Sampler rng(31, 0, 0, 0);
  const Vec3 ref(0, 0, 0);
  int count[3] = {0, 0, 0};
  const int n = 90000;
  for (int i = 0; i < n; ++i) {
    const Vec2 uPoint = rng.next2D();
    const Real uLight = rng.next1D();
    const std::optional<LightSample> ls = lights.sample(ref, uLight, uPoint);
    REQUIRE(ls);
    CHECK(ls->pdf > 0);
    if (ls->delta) {
      ++count[2];
      CHECK(ls->pdf == Approx(0.25 / 2.25).epsilon(1e-6));
      CHECK(ls->Li.r == Approx(std::numbers::pi / 4 / 25).epsilon(1e-6)); // I/d²
      continue;
    }
    ++count[ls->primitive == 0 ? 0 : 1];
    // The pdf MIS asks for a direction that hits this sphere is the one the sampler used.
    CHECK(lights.pdf(ref, ls->primitive, ls->target) == Approx(ls->pdf).epsilon(kTolerance));
    const Sphere& s = scene.spheres[std::size_t(ls->primitive)];
    CHECK(hitsSphere(ref, ls->wi, s.center, s.radius));
    CHECK(glm::length(ls->target - s.center) == Approx(s.radius).epsilon(kTolerance));
  }
  // Counts against the probabilities 4/9, 4/9, 1/9 (chi-square, 2 degrees of freedom, 1%: 9.21).
  const double p[3] = {4.0 / 9, 4.0 / 9, 1.0 / 9};
  double chi2 = 0;
  for (int k = 0; k < 3; ++k)
    chi2 += (count[k] - n * p[k]) * (count[k] - n * p[k]) / (n * p[k]);
  INFO("counts " << count[0] << ", " << count[1] << ", " << count[2] << ": chi2 = " << chi2);
  CHECK(chi2 < 9.21);
}

// ---- Visibility of a light sample -------------------------------------------------------------------------------

namespace {

// A room (the inside of a large sphere) with two lamps that also reflect (so points on a lamp are shaded, and some of
// their light samples leave the lamp's own surface) and blockers between them; `extra` small blockers more. Above
// kFlatListMaxPrimitives spheres the scene is searched through its BVH.
Scene visibilityScene(int extra)
{
  std::string spheres = R"({ "center": [0, 0, 0], "radius": 50, "material": "wall" },
      { "center": [0, 8, 0], "radius": 2, "material": "lamp" },
      { "center": [6, 3, 2], "radius": 0.5, "material": "lamp" },
      { "center": [0, 3, 0], "radius": 1.5, "material": "wall" },
      { "center": [-2, 5, 1], "radius": 1, "material": "wall" })";
  for (int i = 0; i < extra; ++i)
    spheres += ", { \"center\": [" + std::to_string(-6 + 2 * i) + ", " + std::to_string(1 + (i % 3) * 2) +
               ", -1], \"radius\": 0.6, \"material\": \"wall\" }";
  return parseScene(R"({
    "camera": { "eye": [0, 0, 30], "focal": [0, 0, 0], "up": [0, 1, 0], "vfov": 40, "width": 8, "height": 8 },
    "materials": { "wall": { "type": "diffuse", "color": [0.5, 0.5, 0.5] },
                   "lamp": { "type": "diffuse", "color": [0.5, 0.5, 0.5], "emission": [4, 4, 4] } },
    "spheres": [ )" + spheres + R"( ] })",
                    "visibility");
}

} // namespace

TEST_CASE("a light sample is visible exactly when the first sphere its shadow ray meets is the light")
{
  // lightVisible answers with a sphere test and an any-hit query; its definition is the closest-hit query below (what
  // a BSDF-sampled ray in that direction would find, which chapter 8's weights rely on). Shaded points are where
  // random rays from random points of the room (some inside a lamp) first hit something: walls, blockers, and the
  // lamps themselves from outside and inside. The two must agree on every sample (only an exact tie of distances
  // could part them). The control is the shortcut of an any-hit query straight towards the sampled point on the
  // light: from a point on a lamp, a direction that leaves its surface outwards has its "point on the light" at the
  // shaded point itself, so nothing blocks it, though the ray never meets the light. It must disagree, and does.
  for (const int extra : {0, 8}) {
    const Scene scene = visibilityScene(extra);
    REQUIRE(scene.usesAccelerator() == (extra > 0));
    const LightSampler lights(scene);
    Sampler rng(41, extra, 0, 0);
    int visible = 0, blocked = 0, onLamp = 0, disagree = 0, shortcutWrong = 0;
    for (int i = 0; i < 100000; ++i) {
      const bool insideLamp = i % 10 == 0;
      Vec3 from;
      if (insideLamp) {
        const Real scale = rng.next1D();
        const Vec2 u = rng.next2D();
        from = Vec3(0, 8, 0) + Real(1.9) * sampleUniformSphere(u) * scale;
      } else {
        const Real z = rng.next1D();
        const Real y = rng.next1D();
        const Real x = rng.next1D();
        from = Vec3(x * 20 - 10, y * 20 - 10, z * 20 - 10);
      }
      const std::optional<Hit> hit = scene.intersect(Ray{from, sampleUniformSphere(rng.next2D()), 0, kInfinity});
      REQUIRE(hit);
      const Vec2 uPoint = rng.next2D();
      const Real uLight = rng.next1D();
      const std::optional<LightSample> ls = lights.sample(hit->point, uLight, uPoint);
      REQUIRE(ls);
      const std::optional<Hit> seen = scene.intersect(spawnRay(*hit, ls->wi));
      const bool expected = seen && seen->primitive == ls->primitive;
      const bool got = lightVisible(scene, *hit, *ls);
      disagree += got != expected;
      (expected ? visible : blocked)++;
      onLamp += scene.materials[std::size_t(hit->material)].isEmissive();
      shortcutWrong += !scene.occluded(spawnRayTo(*hit, ls->target)) != expected;
    }
    INFO(extra << " extra blockers: " << visible << " visible, " << blocked << " blocked, " << onLamp
               << " shaded points on a lamp; " << disagree << " disagreements; the shortcut wrong " << shortcutWrong
               << " times");
    CHECK(disagree == 0);
    CHECK(visible > 10000);
    CHECK(blocked > 5000);
    CHECK(onLamp > 5000);
    CHECK(shortcutWrong > 100); // the control
  }
}

TEST_CASE("a scene without lights has nothing to sample")
{
  const Scene scene = parseScene(R"({
    "camera": { "eye": [0, 0, 10], "focal": [0, 0, 0], "up": [0, 1, 0], "vfov": 40, "width": 8, "height": 8 },
    "background": [1, 1, 1],
    "materials": { "wall": { "type": "diffuse", "color": [0.5, 0.5, 0.5] } },
    "spheres": [ { "center": [0, 0, 0], "radius": 1, "material": "wall" } ]
  })",
                                 "inline");
  const LightSampler lights(scene);
  CHECK(lights.empty());
  CHECK_FALSE(lights.sample(Vec3(0, 2, 0), Real(0.5), Vec2(Real(0.5))));
  CHECK(lights.pdf(Vec3(0, 2, 0), 0, Vec3(0, 1, 0)) == 0);
}

// ---- MIS weights --------------------------------------------------------------------------------------------------

TEST_CASE("MIS: the power and balance heuristics' weights over the two strategies sum to one")
{
  Sampler rng(41, 0, 0, 0);
  for (int i = 0; i < 100000; ++i) {
    // pdfs over 60 orders of magnitude, with zeros and infinities now and then.
    auto draw = [&] {
      const double u = double(rng.next1D());
      if (u < 0.05)
        return Real(0);
      if (u < 0.07)
        return kInfinity;
      return Real(logUniform(rng, -30, 30));
    };
    const Real p = draw(), q = draw();
    if (p == 0 && q == 0)
      continue; // no strategy can produce the direction: no weight is defined
    INFO("p = " << p << ", q = " << q);
    const Real power = powerHeuristic(p, q) + powerHeuristic(q, p);
    const Real balance = balanceHeuristic(p, q) + balanceHeuristic(q, p);
    CHECK(std::abs(power - 1) < 1e-6);
    CHECK(std::abs(balance - 1) < 1e-6);
    CHECK(powerHeuristic(p, q) >= 0);
    CHECK(balanceHeuristic(p, q) >= 0);
  }
  CHECK(powerHeuristic(1, 0) == 1);
  CHECK(powerHeuristic(0, 1) == 0);
  CHECK(powerHeuristic(3, 1) == Approx(0.9));
  CHECK(balanceHeuristic(3, 1) == Approx(0.75));
}

TEST_CASE("MIS: for random glossy and diffuse surfaces under random sphere lights, the weights of both strategies "
          "for each sampled direction sum to one")
{
  // A light at random, a shaded point and a material at random; each strategy draws a direction, and for it both
  // strategies' pdfs are computed as chapter 8 computes them (light: LightSampler::pdf, BSDF: bsdfPdf).
  Sampler rng(42, 0, 0, 0);
  int checked = 0;
  for (int config = 0; config < 2000; ++config) {
    const Real radius = Real(logUniform(rng, -2, 1));
    Scene scene;
    Material lamp;
    lamp.emission = Color(Real(logUniform(rng, -1, 3)));
    lamp.color = Color(0);
    Material surface;
    surface.type = rng.next1D() < Real(0.5) ? MaterialType::Glossy : MaterialType::Diffuse;
    surface.roughness = Real(logUniform(rng, -2, 0));
    scene.materials = {lamp, surface};
    scene.spheres = {Sphere{Vec3(0), radius, 0}};
    const LightSampler lights(scene);
    const Vec3 refDirection = sampleUniformSphere(rng.next2D());
    const Vec3 ref = Real(radius * logUniform(rng, 0.01, 3)) * refDirection;
    const Frame frame = Frame::fromNormal(sampleUniformSphere(rng.next2D()));
    Vec3 wo = sampleUniformHemisphere(rng.next2D());
    for (int s = 0; s < 20; ++s) {
      // The light strategy's direction.
      const Vec2 uPoint = rng.next2D();
      const Real uLight = rng.next1D();
      const std::optional<LightSample> ls = lights.sample(ref, uLight, uPoint);
      REQUIRE(ls);
      const Real pb = bsdfPdf(surface, wo, frame.toLocal(ls->wi));
      CHECK(std::abs(powerHeuristic(ls->pdf, pb) + powerHeuristic(pb, ls->pdf) - 1) < kTolerance);
      // The BSDF strategy's direction, where it hits the light.
      const Real uChoice = rng.next1D();
      const Vec2 u = rng.next2D();
      if (const std::optional<BsdfSample> bs = bsdfSample(surface, wo, u, uChoice)) {
        const Vec3 wi = frame.toWorld(bs->wi);
        if (!hitsSphere(ref, wi, Vec3(0), radius))
          continue;
        const Real pl = lights.pdf(ref, 0, ref + wi);
        CHECK(pl > 0);
        CHECK(std::abs(balanceHeuristic(bs->pdf, pl) + balanceHeuristic(pl, bs->pdf) - 1) < kTolerance);
        CHECK(std::abs(powerHeuristic(bs->pdf, pl) + powerHeuristic(pl, bs->pdf) - 1) < kTolerance);
        ++checked;
      }
    }
  }
  INFO(checked << " BSDF-sampled directions hit the light");
  CHECK(checked > 500);
}

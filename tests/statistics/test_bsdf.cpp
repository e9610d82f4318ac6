// Every sampler against its pdf (chi-square), and every BSDF for energy conservation and reciprocity.
// Fixed seeds, so each run draws the same numbers; the significance of each chi-square test is 1%.
#include "shading/bsdf.h"
#include "chi_square.h"
#include "estimate.h"
#include "core/frame.h"
#include "core/rng.h"
#include "core/sampling.h"

#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <limits>

using namespace raylife;
using namespace raylife::test;

namespace {

constexpr double kSignificance = 0.01;
constexpr int kSamples = 200000;

// A unit direction at polar angle theta (radians) from +z, in the xz-plane (wo for the BSDF tests).
Vec3 polar(double theta) { return Vec3(Real(std::sin(theta)), 0, Real(std::cos(theta))); }

// Relative tolerance of one evaluation in the renderer's scalar.
const double kRel = sizeof(Real) == 4 ? 1e-5 : 1e-12;

} // namespace

// ---- Chi-square: sampler against pdf ------------------------------------------------------------------------

TEST_CASE("chi-square: uniform sphere and hemisphere samplers match their pdfs")
{
  auto sphere = chiSquareTest([](Vec2 u, Real) { return std::optional<Vec3>(sampleUniformSphere(u)); },
                              [](const Vec3&) { return double(uniformSpherePdf()); }, kSamples, 1, kSignificance);
  INFO(sphere.summary());
  CHECK(sphere.passed);
  auto hemi = chiSquareTest([](Vec2 u, Real) { return std::optional<Vec3>(sampleUniformHemisphere(u)); },
                            [](const Vec3& w) { return double(uniformHemispherePdf(w)); }, kSamples, 2, kSignificance);
  INFO(hemi.summary());
  CHECK(hemi.passed);
}

TEST_CASE("chi-square: cosine-weighted hemisphere sampler matches cosθ/π")
{
  auto r = chiSquareTest([](Vec2 u, Real) { return std::optional<Vec3>(sampleCosineHemisphere(u)); },
                         [](const Vec3& w) { return double(cosineHemispherePdf(w)); }, kSamples, 3, kSignificance);
  INFO(r.summary());
  CHECK(r.passed);
}

TEST_CASE("chi-square: Phong lobe sampler matches (n+1)/(2π) cosⁿα")
{
  for (Real n : {Real(0), Real(5), Real(50)}) {
    auto r = chiSquareTest([n](Vec2 u, Real) { return std::optional<Vec3>(samplePhongLobe(u, n)); },
                           [n](const Vec3& w) { return double(phongLobePdf(w.z, n)); }, kSamples, 4, kSignificance);
    INFO("n = " << n << ": " << r.summary());
    CHECK(r.passed);
  }
}

TEST_CASE("chi-square: the Lambertian BSDF's sampler matches its pdf, from either side")
{
  const Color albedo(Real(0.7));
  for (double theta : {0.3, 2.5}) { // wo outside, and wo inside the sphere (z < 0)
    const Vec3 wo = polar(theta);
    auto r = chiSquareTest(
        [&](Vec2 u, Real) -> std::optional<Vec3> {
          if (auto s = lambertianSample(albedo, wo, u))
            return s->wi;
          return std::nullopt;
        },
        [&](const Vec3& wi) { return double(lambertianPdf(wo, wi)); }, kSamples, 5, kSignificance);
    INFO("theta_o = " << theta << ": " << r.summary());
    CHECK(r.passed);
  }
}

TEST_CASE("chi-square: the glossy (Phong) BSDF's sampler matches its pdf, lobe cut by the horizon included")
{
  const Color albedo(Real(0.9));
  for (Real roughness : {Real(0.25), Real(0.6)})
    for (double theta : {0.0, 1.0, 1.45, 2.2}) { // normal, oblique, grazing (mass below the surface), inside
      const Real n = phongExponent(roughness);
      const Vec3 wo = polar(theta);
      auto r = chiSquareTest(
          [&](Vec2 u, Real) -> std::optional<Vec3> {
            if (auto s = phongSample(albedo, n, wo, u))
              return s->wi;
            return std::nullopt;
          },
          [&](const Vec3& wi) { return double(phongPdf(n, wo, wi)); }, kSamples, 6, kSignificance);
      INFO("roughness " << roughness << ", theta_o = " << theta << ": " << r.summary());
      CHECK(r.passed);
    }
}

TEST_CASE("chi-square: a wrong pdf fails (the test can fail)")
{
  // Cosine-weighted samples tested against the uniform hemisphere's pdf.
  auto wrong = chiSquareTest([](Vec2 u, Real) { return std::optional<Vec3>(sampleCosineHemisphere(u)); },
                             [](const Vec3& w) { return double(uniformHemispherePdf(w)); }, kSamples, 7, kSignificance);
  INFO(wrong.summary());
  CHECK_FALSE(wrong.passed);
  // A Phong lobe of exponent 20 tested against the pdf of exponent 16: a subtler mistake.
  auto subtle = chiSquareTest([](Vec2 u, Real) { return std::optional<Vec3>(samplePhongLobe(u, 20)); },
                              [](const Vec3& w) { return double(phongLobePdf(w.z, 16)); }, kSamples, 8, kSignificance);
  INFO(subtle.summary());
  CHECK_FALSE(subtle.passed);
}

// ---- Energy conservation: directional albedo ≤ 1 -------------------------------------------------------------

TEST_CASE("energy: the Lambertian BRDF of albedo 1 reflects exactly all light, from every direction")
{
  const Color white(1);
  for (double theta : {0.0, 0.8, 1.4, 1.55}) {
    const Vec3 wo = polar(theta);
    // Estimated with uniform hemisphere directions, independently of the BSDF's own sampler.
    const Estimate a = estimate(100000, 11, [&](Sampler& rng) {
      const Vec3 wi = sampleUniformHemisphere(rng.next2D());
      return double(lambertianEval(white, wo, wi).r * wi.z / uniformHemispherePdf(wi));
    });
    INFO("theta_o = " << theta << ": albedo " << a.mean << " ± " << a.stdError);
    CHECK(std::abs(a.mean - 1) < 4 * a.stdError);
    // The sampler's weight is the albedo itself, sample by sample.
    Sampler rng(12, 0, 0, 0);
    for (int i = 0; i < 1000; ++i) {
      const auto s = lambertianSample(Color(Real(0.3), Real(0.6), Real(0.9)), wo, rng.next2D());
      REQUIRE(s);
      CHECK(s->weight().g == Approx(0.6).epsilon(1e-5));
    }
  }
}

TEST_CASE("energy: the glossy BRDF's directional albedo is at most 1 (and exactly 1 at normal incidence)")
{
  const Color white(1);
  for (Real roughness : {Real(0.1), Real(0.25), Real(0.5), Real(1)})
    for (double theta : {0.0, 0.5, 1.0, 1.3, 1.5}) {
      const Real n = phongExponent(roughness);
      const Vec3 wo = polar(theta);
      // Two independent estimates: the BSDF's own importance sampling, and uniform directions with eval.
      const Estimate byImportance = estimate(100000, 21, [&](Sampler& rng) {
        const auto s = phongSample(white, n, wo, rng.next2D());
        return s ? double(s->weight().r) : 0.0;
      });
      const Estimate byUniform = estimate(400000, 22, [&](Sampler& rng) {
        const Vec3 wi = sampleUniformHemisphere(rng.next2D());
        return double(phongEval(white, n, wo, wi).r * wi.z / uniformHemispherePdf(wi));
      });
      INFO("roughness " << roughness << ", theta_o " << theta << ": albedo " << byImportance.mean << " ± "
                        << byImportance.stdError << " (importance), " << byUniform.mean << " ± " << byUniform.stdError
                        << " (uniform)");
      CHECK(byImportance.mean <= 1 + 4 * byImportance.stdError);
      CHECK(byUniform.mean <= 1 + 4 * byUniform.stdError);
      const double sigma = std::hypot(byImportance.stdError, byUniform.stdError);
      CHECK(std::abs(byImportance.mean - byUniform.mean) < 4 * sigma + 1e-9);
      if (theta == 0.0)
        CHECK(std::abs(byImportance.mean - 1) < 4 * byImportance.stdError + 1e-9);
    }
}

TEST_CASE("glossy: as roughness goes to 0 the lobe becomes the mirror of weight ρ cosθ, and stays finite below")
{
  // The lobe's weight is ρ (n + 2)/(n + 1) cosθi, so its limit is the mirror with weight ρ cosθo. Below
  // kMinPhongRoughness raylife takes that limit; without it, roughness 1e-10 gave f = pdf = ∞ and a NaN weight
  // (a cosine rounded above 1, raised to n ≈ 2·10²⁰), and below 1e-154 n itself is infinite.
  const Color albedo(Real(0.9), Real(0.6), Real(0.3));
  Material glossy;
  glossy.type = MaterialType::Glossy;
  glossy.color = albedo;
  for (double theta : {0.0, 0.6, 1.2}) {
    const Vec3 wo = polar(theta), mirror(-wo.x, -wo.y, wo.z);
    // Just above the threshold: still the lobe, a milliradian wide, with the limit's mean weight.
    const Real r = kMinPhongRoughness * Real(1.01);
    int deltas = 0, missing = 0;
    double widest = 0;
    const Estimate weight = estimate(20000, 23, [&](Sampler& rng) {
      const auto s = phongSample(albedo, phongExponent(r), wo, rng.next2D());
      if (!s) {
        ++missing;
        return 0.0;
      }
      deltas += s->specular;
      widest = std::max(widest, std::acos(std::min(1.0, double(glm::dot(s->wi, mirror)))));
      return double(s->weight().g);
    });
    INFO("theta_o " << theta << ": mean weight " << weight.mean << " ± " << weight.stdError << ", widest angle "
                    << widest);
    CHECK(missing == 0);
    CHECK(deltas == 0);
    CHECK(widest < 5 * double(r));
    CHECK(weight.mean == Approx(double(albedo.g) * wo.z).epsilon(0.002));
    // At and below it: the mirror, finite down to the smallest roughness a scene can give.
    for (Real tiny : {kMinPhongRoughness * Real(0.99), Real(1e-6), Real(1e-10), Real(1e-30),
                      std::numeric_limits<Real>::denorm_min()}) {
      INFO("roughness " << tiny);
      glossy.roughness = tiny;
      const auto s = bsdfSample(glossy, wo, Vec2(Real(0.3), Real(0.7)), Real(0.5));
      REQUIRE(s);
      CHECK(s->specular);
      CHECK(glm::length(s->wi - mirror) < 1e-6);
      const Color w = s->weight();
      CHECK(std::isfinite(w.r));
      CHECK(w.b == Approx(double(albedo.b) * wo.z).epsilon(1e-5));
      CHECK(bsdfEval(glossy, wo, mirror) == Color(0));
      CHECK(bsdfPdf(glossy, wo, mirror) == 0);
    }
  }
}

TEST_CASE("energy: glass splits light into F reflected and 1 − F refracted, chosen with those probabilities")
{
  const Color tint(1);
  const Real eta = Real(1.5);
  for (double theta : {0.0, 0.7, 1.3, 1.55, 2.0, 2.6, 3.1}) { // outside, and inside (some beyond the critical angle)
    const Vec3 wo = polar(theta);
    const Real F = fresnelDielectric(wo.z, eta);
    REQUIRE(F >= 0);
    REQUIRE(F <= 1);
    Sampler rng(31, 0, 0, 0);
    int reflected = 0;
    const int n = 20000;
    for (int i = 0; i < n; ++i) {
      const auto s = dielectricSample(tint, eta, wo, rng.next1D());
      REQUIRE(s);
      CHECK(s->specular);
      CHECK(s->weight().r == Approx(1).epsilon(1e-6)); // every sample carries exactly the tint: no energy made
      CHECK(glm::length(s->wi) == Approx(1).epsilon(1e-6));
      reflected += s->wi.z * wo.z > 0;
    }
    const double p = double(F), sd = std::sqrt(p * (1 - p) / n);
    INFO("theta_o " << theta << ": F = " << F << ", reflected share " << double(reflected) / n);
    CHECK(std::abs(double(reflected) / n - p) <= 4 * sd + 1e-12);
  }
}

TEST_CASE("energy: the mirror reflects its tint, in the mirror direction")
{
  const Vec3 wo = glm::normalize(Vec3(Real(0.3), Real(-0.4), Real(0.8)));
  const auto s = mirrorSample(Color(Real(0.9)), wo);
  REQUIRE(s);
  CHECK(s->weight().r == Approx(0.9).epsilon(1e-6));
  CHECK(s->wi.x == Approx(-wo.x));
  CHECK(s->wi.y == Approx(-wo.y));
  CHECK(s->wi.z == Approx(wo.z));
}

// ---- Reciprocity: f(wo, wi) = f(wi, wo) ---------------------------------------------------------------------

TEST_CASE("reciprocity: Lambertian and glossy BRDFs are symmetric")
{
  Sampler rng(41, 0, 0, 0);
  for (int i = 0; i < 10000; ++i) {
    const Vec3 a = sampleUniformSphere(rng.next2D()), b = sampleUniformSphere(rng.next2D());
    const Color c(Real(0.8), Real(0.5), Real(0.2));
    CHECK(lambertianEval(c, a, b).r == lambertianEval(c, b, a).r);
    for (Real roughness : {Real(0.2), Real(0.7)}) {
      const Real n = phongExponent(roughness);
      const double f1 = phongEval(c, n, a, b).g, f2 = phongEval(c, n, b, a).g;
      CHECK(f1 == Approx(f2).epsilon(kRel).margin(1e-300));
    }
  }
}

TEST_CASE("reciprocity: Fresnel transmits the same share in both directions of a refracted pair")
{
  const Real eta = Real(1.5);
  for (double theta = 0; theta < 1.57; theta += 0.05) {
    const Vec3 wo = polar(theta);
    const auto wt = refract(wo, Vec3(0, 0, 1), eta);
    REQUIRE(wt);
    // Light coming back along the refracted ray, from inside, sees the same reflectance.
    CHECK(fresnelDielectric(wo.z, eta) == Approx(fresnelDielectric(wt->z, eta)).margin(1e-9));
  }
}

// ---- Snell's law, Fresnel, total internal reflection, the frame --------------------------------------------

TEST_CASE("refraction follows Snell's law from outside and from inside")
{
  const Real eta = Real(1.5);
  for (double theta = 0; theta < 1.57; theta += 0.1) {
    const Vec3 wo = polar(theta);
    const auto wt = refract(wo, Vec3(0, 0, 1), eta);
    REQUIRE(wt);
    CHECK(glm::length(*wt) == Approx(1).epsilon(1e-6));
    CHECK(wt->z < 0); // through the surface
    const double sinT = std::hypot(double(wt->x), double(wt->y));
    CHECK(std::sin(theta) == Approx(1.5 * sinT).margin(1e-6)); // η_i sinθ_i = η_t sinθ_t
    CHECK(wt->x * wo.x <= 0);                                    // the tangential part keeps its direction
    // And back out again: light going the other way, seen from inside along wt, leaves along wo.
    // Leaving glass near the critical angle divides the rounding of cos²θ by cos²θ_o (≈ 0.005 at θ = 1.5), so
    // the way back is good to about 200 units of rounding: 1e-6 holds in double, float needs 3e-5.
    const auto back = refract(*wt, Vec3(0, 0, 1), eta);
    REQUIRE(back);
    const double margin = sizeof(Real) == 4 ? 3e-5 : 1e-6;
    CHECK(back->x == Approx(wo.x).margin(margin));
    CHECK(back->z == Approx(wo.z).margin(margin));
  }
}

TEST_CASE("total internal reflection: past the critical angle inside glass nothing is refracted")
{
  const Real eta = Real(1.5);
  const double critical = std::asin(1 / 1.5);
  // Inside the sphere wo points inwards (z < 0): theta measured from −z.
  const Vec3 below = Vec3(Real(std::sin(critical - 0.01)), 0, Real(-std::cos(critical - 0.01)));
  const Vec3 beyond = Vec3(Real(std::sin(critical + 0.01)), 0, Real(-std::cos(critical + 0.01)));
  CHECK(refract(below, Vec3(0, 0, 1), eta).has_value());
  CHECK(fresnelDielectric(below.z, eta) < 1);
  CHECK_FALSE(refract(beyond, Vec3(0, 0, 1), eta).has_value());
  CHECK(fresnelDielectric(beyond.z, eta) == 1);
}

TEST_CASE("Fresnel: known values")
{
  // Normal incidence: ((η − 1)/(η + 1))², the same from either side.
  CHECK(fresnelDielectric(1, Real(1.5)) == Approx(0.04).epsilon(1e-6));
  CHECK(fresnelDielectric(-1, Real(1.5)) == Approx(0.04).epsilon(1e-6));
  // Grazing incidence reflects everything; Brewster's angle zeroes the parallel part (R = R_perp / 2).
  CHECK(fresnelDielectric(Real(1e-9), Real(1.5)) == Approx(1).epsilon(1e-6));
  const double brewster = std::atan(1.5), cosB = std::cos(brewster), cosT = std::sqrt(1 - std::pow(std::sin(brewster) / 1.5, 2));
  const double rPerp = (cosB - 1.5 * cosT) / (cosB + 1.5 * cosT);
  CHECK(fresnelDielectric(Real(cosB), Real(1.5)) == Approx(rPerp * rPerp / 2).epsilon(1e-5));
  // η = 1: no interface, nothing reflected, the ray goes straight on.
  for (double theta : {0.0, 0.5, 1.2, 2.0}) {
    CHECK(fresnelDielectric(polar(theta).z, 1) == Approx(0).margin(1e-12));
    const auto wt = refract(polar(theta), Vec3(0, 0, 1), 1);
    REQUIRE(wt);
    CHECK(glm::length(*wt + polar(theta)) == Approx(0).margin(1e-6));
  }
}

TEST_CASE("the shading frame is orthonormal and right-handed for every normal, the poles included")
{
  Sampler rng(51, 0, 0, 0);
  std::vector<Vec3> normals = {Vec3(0, 0, 1), Vec3(0, 0, -1), Vec3(1, 0, 0), Vec3(0, -1, 0)};
  for (int i = 0; i < 1000; ++i)
    normals.push_back(sampleUniformSphere(rng.next2D()));
  for (const Vec3& n : normals) {
    const Frame f = Frame::fromNormal(n);
    CHECK(glm::length(f.s) == Approx(1).epsilon(1e-6));
    CHECK(glm::length(f.t) == Approx(1).epsilon(1e-6));
    CHECK(glm::dot(f.s, f.t) == Approx(0).margin(1e-6));
    CHECK(glm::dot(f.s, n) == Approx(0).margin(1e-6));
    CHECK(glm::length(glm::cross(f.s, f.t) - n) == Approx(0).margin(1e-6));
    const Vec3 w = glm::normalize(Vec3(Real(0.2), Real(-0.5), Real(0.7)));
    CHECK(glm::length(f.toWorld(f.toLocal(w)) - w) == Approx(0).margin(1e-6));
    CHECK(f.toLocal(n).z == Approx(1).epsilon(1e-6));
  }
}

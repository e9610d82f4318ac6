// The GGX metal (chapter 11): its visible-normal sampler against its pdf (chi-square), the pdf's integral, its
// reciprocity, its energy (white furnace, with the loss of single scattering reported against roughness), and the
// limit roughness → 0, the mirror. Fixed seeds; significance 1% as in test_bsdf.cpp.
#include "chi_square.h"
#include "estimate.h"
#include "core/rng.h"
#include "core/sampling.h"
#include "shading/bsdf.h"

#include <catch2/catch.hpp>

#include <cmath>
#include <iostream>

using namespace raylife;
using namespace raylife::test;

namespace {

constexpr double kSignificance = 0.01;
constexpr int kSamples = 200000;

Vec3 polar(double theta) { return Vec3(Real(std::sin(theta)), 0, Real(std::cos(theta))); }

} // namespace

TEST_CASE("GGX: D's projected area integrates to 1, and the visible normals' density to 1, for every view")
{
  for (Real alpha : {Real(0.05), Real(0.2), Real(0.5), Real(1)}) {
    // ∫ D(h) cosθh dh by uniform directions on the hemisphere (2π/N Σ).
    const Estimate projected = estimate(400000, 1, [&](Sampler& rng) {
      const Vec3 h = sampleUniformHemisphere(rng.next2D());
      return double(ggxD(h, alpha) * h.z) / double(uniformHemispherePdf(h));
    });
    INFO("alpha " << alpha << ": ∫ D cos = " << projected.mean << " ± " << projected.stdError);
    CHECK(std::abs(projected.mean - 1) < 4 * projected.stdError + 1e-3);
    for (double theta : {0.0, 0.7, 1.4}) {
      const Vec3 wo = polar(theta);
      const Estimate visible = estimate(400000, 2, [&](Sampler& rng) {
        const Vec3 h = sampleUniformHemisphere(rng.next2D());
        const double dwo = double(ggxG1(wo, alpha) * std::max(Real(0), glm::dot(wo, h)) * ggxD(h, alpha) / wo.z);
        return dwo / double(uniformHemispherePdf(h));
      });
      INFO("alpha " << alpha << ", theta_o " << theta << ": ∫ D_wo = " << visible.mean << " ± " << visible.stdError);
      CHECK(std::abs(visible.mean - 1) < 4 * visible.stdError + 1e-3);
    }
  }
}

TEST_CASE("chi-square: the GGX metal's sampler (visible normals) matches its pdf, the horizon's cut included")
{
  const Color f0(Real(0.9));
  for (Real alpha : {Real(0.3), Real(0.6), Real(1)})
    for (double theta : {0.0, 0.8, 1.35, 2.3}) { // normal, oblique, grazing (mass below the surface), inside
      const Vec3 wo = polar(theta);
      auto r = chiSquareTest(
          [&](Vec2 u, Real) -> std::optional<Vec3> {
            if (auto s = metalSample(f0, alpha, wo, u))
              return s->wi;
            return std::nullopt;
          },
          [&](const Vec3& wi) { return double(metalPdf(alpha, wo, wi)); }, kSamples, 61, kSignificance, 20, 40, 4);
      INFO("alpha " << alpha << ", theta_o = " << theta << ": " << r.summary());
      CHECK(r.passed);
    }
  // The control: samples of α = 0.3 against the pdf of α = 0.36 fail.
  const Vec3 wo = polar(0.5);
  auto wrong = chiSquareTest(
      [&](Vec2 u, Real) -> std::optional<Vec3> {
        if (auto s = metalSample(f0, Real(0.3), wo, u))
          return s->wi;
        return std::nullopt;
      },
      [&](const Vec3& wi) { return double(metalPdf(Real(0.36), wo, wi)); }, kSamples, 62, kSignificance, 20, 40, 4);
  INFO(wrong.summary());
  CHECK_FALSE(wrong.passed);
}

TEST_CASE("GGX: the pdf integrates, over the directions above the surface, to the share of samples that land there")
{
  for (Real alpha : {Real(0.1), Real(0.5), Real(1)})
    for (double theta : {0.2, 1.2, 1.5}) {
      const Vec3 wo = polar(theta);
      const Estimate integral = estimate(400000, 71, [&](Sampler& rng) {
        const Vec3 wi = sampleCosineHemisphere(rng.next2D());
        return double(metalPdf(alpha, wo, wi) / cosineHemispherePdf(wi));
      });
      Sampler rng(72, 0, 0, 0);
      int landed = 0;
      const int n = 200000;
      for (int i = 0; i < n; ++i)
        landed += metalSample(Color(1), alpha, wo, rng.next2D()).has_value();
      const double share = double(landed) / n, sd = std::sqrt(share * (1 - share) / n);
      INFO("alpha " << alpha << ", theta_o " << theta << ": ∫ pdf = " << integral.mean << " ± " << integral.stdError
                    << ", samples above " << share);
      CHECK(std::abs(integral.mean - share) < 4 * std::hypot(integral.stdError, sd) + 1e-3);
      CHECK(integral.mean <= 1 + 4 * integral.stdError);
    }
}

TEST_CASE("reciprocity: the GGX metal is symmetric in wo and wi")
{
  Sampler rng(81, 0, 0, 0);
  const Color f0(Real(0.95), Real(0.64), Real(0.54));
  for (int i = 0; i < 20000; ++i) {
    const Vec3 a = sampleUniformSphere(rng.next2D()), b = sampleUniformSphere(rng.next2D());
    for (Real alpha : {Real(0.05), Real(0.3), Real(0.9)}) {
      const double f1 = metalEval(f0, alpha, a, b).g, f2 = metalEval(f0, alpha, b, a).g;
      CHECK(f1 == Approx(f2).epsilon(sizeof(Real) == 4 ? 1e-4 : 1e-10).margin(1e-300));
    }
  }
}

TEST_CASE("energy: the GGX metal of F0 = 1 reflects at most all light (white furnace), its loss printed against roughness")
{
  std::cout << "GGX white furnace (F0 = 1): directional albedo, by importance sampling\n   alpha:";
  const Real alphas[] = {Real(0.05), Real(0.2), Real(0.4), Real(0.6), Real(0.8), Real(1)};
  for (Real alpha : alphas)
    std::cout << "  " << alpha;
  std::cout << "\n";
  for (double theta : {0.0, 0.8, 1.3, 1.5}) {
    const Vec3 wo = polar(theta);
    std::cout << "  theta_o " << theta << ":";
    for (Real alpha : alphas) {
      const Estimate byImportance = estimate(100000, 91, [&](Sampler& rng) {
        const auto s = metalSample(Color(1), alpha, wo, rng.next2D());
        return s ? double(s->weight().r) : 0.0;
      });
      const Estimate byCosine = estimate(400000, 92, [&](Sampler& rng) {
        const Vec3 wi = sampleCosineHemisphere(rng.next2D());
        return double(metalEval(Color(1), alpha, wo, wi).r * wi.z / cosineHemispherePdf(wi));
      });
      std::cout << " " << byImportance.mean;
      INFO("alpha " << alpha << ", theta_o " << theta << ": " << byImportance.mean << " ± " << byImportance.stdError
                    << " (importance), " << byCosine.mean << " ± " << byCosine.stdError << " (cosine)");
      CHECK(byImportance.mean <= 1 + 4 * byImportance.stdError);
      // Two independent estimators agree (the weight f·cos/pdf is right, not only the direction's density).
      CHECK(std::abs(byImportance.mean - byCosine.mean) < 4 * std::hypot(byImportance.stdError, byCosine.stdError) +
                                                               (alpha < Real(0.1) ? 0.02 : 1e-3));
      // Smooth metal loses almost nothing (away from grazing). At α = 1, D = 1/π and, at normal incidence,
      // G2 = 2cosθi/(1 + cosθi), so the albedo is ½·∫₀¹ 2c/(1 + c) dc = 1 − ln 2: a closed form to hit.
      if (alpha == Real(0.05) && theta < 1.4)
        CHECK(byImportance.mean > 0.97);
      if (alpha == Real(1) && theta == 0.0)
        CHECK(std::abs(byImportance.mean - (1 - std::log(2.0))) < 4 * byImportance.stdError);
    }
    std::cout << "\n";
  }
}

TEST_CASE("GGX: as roughness goes to 0 the metal becomes the mirror, Schlick's Fresnel included")
{
  const Color f0(Real(0.9), Real(0.6), Real(0.3));
  for (double theta : {0.0, 0.6, 1.2}) {
    const Vec3 wo = polar(theta), mirror(-wo.x, -wo.y, wo.z);
    double previousSpread = 1e9;
    for (Real alpha : {Real(0.2), Real(0.05), Real(0.01), Real(0.002)}) {
      Sampler rng(101, 0, 0, 0);
      double spread = 0, weight = 0;
      const int n = 20000;
      for (int i = 0; i < n; ++i) {
        const auto s = metalSample(f0, alpha, wo, rng.next2D());
        if (!s)
          continue;
        spread += std::acos(std::clamp(double(glm::dot(s->wi, mirror)), -1.0, 1.0));
        weight += s->weight().g;
      }
      spread /= n;
      weight /= n;
      INFO("theta_o " << theta << ", alpha " << alpha << ": mean angle to the mirror direction " << spread
                      << ", mean weight " << weight);
      CHECK(spread < previousSpread);
      previousSpread = spread;
      if (alpha <= Real(0.01)) {
        CHECK(spread < 4 * double(alpha));
        CHECK(weight == Approx(double(schlickFresnel(f0, wo.z).g)).epsilon(0.01));
      }
    }
    // Below kMinGgxAlpha: the mirror itself, a delta lobe of weight F(cosθo).
    const auto s = metalSample(f0, 0, wo, Vec2(Real(0.3), Real(0.7)));
    REQUIRE(s);
    CHECK(s->specular);
    CHECK(glm::length(s->wi - mirror) < 1e-12);
    CHECK(s->weight().b == Approx(double(schlickFresnel(f0, wo.z).b)).epsilon(1e-5));
    CHECK(metalEval(f0, 0, wo, mirror) == Color(0));
    CHECK(metalPdf(0, wo, mirror) == 0);
  }
}

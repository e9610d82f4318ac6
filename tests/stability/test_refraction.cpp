// Case 5 — refraction and total internal reflection.
//
// Setup: a surface with normal +z; the angle of incidence θ sweeps 0° to 90° in 20,001 steps for η (incident
// index over transmitted index, the issue's convention) in {1.5, 1/1.5, 1/1.33, 1}. raylife's refract and
// fresnelDielectric take η_inside/η_outside of the sphere and work out the side from wo, so the incident side is
// put outside and their eta is 1/η. Pass criterion, in the build's scalar (the float build runs it in float):
// every refracted direction is finite and unit length (|len − 1| ≤ 8 ulp); total internal reflection happens
// exactly where η·sinθ > 1 — no disagreement with a long-double reference except where |η·sinθ − 1| lies within
// 64 ulp of the build's scalar (the boundary itself is a rounding question); η = 1 leaves the direction unchanged
// (to 4 ulp); the Fresnel reflectance lies in [0, 1] and is exactly 1 under total internal reflection.
// Naive, for contrast: the textbook formula without the TIR test (√ of a negative number: NaN; and at η = 1 its
// 1 − (1 − cos²θ) bends grazing rays), and Schlick's approximation evaluated with the incident cosine (it never
// reaches 1 under TIR when light leaves glass).
#include "scene/scene.h"
#include "shading/bsdf.h"
#include "support.h"

#include <catch2/catch.hpp>

#include <cmath>
#include <iomanip>
#include <numbers>
#include <sstream>

using namespace raylife;
using namespace raylife::stability;

namespace {

constexpr int kSteps = 20001;
const Real kUlp = std::numeric_limits<Real>::epsilon();

// The textbook refraction, with no total internal reflection test (wo on the +z side, η incident/transmitted).
Vec3 naiveRefract(const Vec3& wo, const Vec3& n, Real eta)
{
  const Real cosI = glm::dot(wo, n);
  const Real cosT = std::sqrt(1 - eta * eta * (1 - cosI * cosI));
  return eta * -wo + (eta * cosI - cosT) * n;
}

// Schlick's approximation with the incident cosine (correct only when light enters the denser medium).
Real naiveSchlick(Real cosI, Real eta)
{
  const Real r0 = (eta - 1) / (eta + 1);
  return r0 * r0 + (1 - r0 * r0) * std::pow(1 - cosI, Real(5));
}

} // namespace

TEST_CASE("stability 5: refraction is finite and unit with TIR exactly where eta sin(theta) > 1", "[stability][refraction]")
{
  const Vec3 n(0, 0, 1);
  for (const long double eta : {1.5L, 1 / 1.5L, 1 / 1.33L, 1.0L}) {
    int naiveNaN = 0, nonUnit = 0, tirMismatch = 0, boundary = 0, fresnelOut = 0, fresnelNotOne = 0, changed = 0;
    int schlickBelowOne = 0, naiveChanged = 0, tirCount = 0;
    for (int i = 0; i < kSteps; ++i) {
      const long double theta = (std::numbers::pi_v<long double> / 2) * i / (kSteps - 1);
      const Vec3 wo(Real(std::sin(theta)), 0, Real(std::cos(theta)));
      if (!(wo.z > 0))
        continue; // exactly tangent (cos 90° rounds to ±1e-17 or so): no side to come from
      const Real param = Real(1 / eta); // raylife's eta: transmitted over incident, with wo outside
      const std::optional<Vec3> wt = refract(wo, n, param);
      const Real F = fresnelDielectric(wo.z, param);
      tirCount += !wt.has_value();

      // The reference decision, from the rounded wo the routine actually saw, in long double.
      const long double sinT = eta * std::sqrt(1.0L - (long double)wo.z * wo.z);
      const bool tir = sinT > 1;
      if (std::abs(sinT - 1) <= 64 * (long double)kUlp) {
        ++boundary; // the decision rests on rounding here; either answer is right
      } else if (tir != !wt.has_value()) {
        ++tirMismatch;
        UNSCOPED_INFO("TIR decision differs at theta = " << double(theta) << " rad: reference " << tir);
      }
      if (wt) {
        if (!isFinite(*wt) || std::abs(glm::length(*wt) - 1) > 8 * kUlp)
          ++nonUnit;
        if (eta == 1.0L && glm::length(*wt + wo) > 4 * kUlp)
          ++changed;
      }
      if (!(F >= 0 && F <= 1))
        ++fresnelOut;
      if (!wt && F != 1)
        ++fresnelNotOne;

      const Vec3 naive = naiveRefract(wo, n, Real(eta));
      naiveNaN += !isFinite(naive);
      if (eta == 1.0L && isFinite(naive) && glm::length(glm::normalize(naive) + wo) > 4 * kUlp)
        ++naiveChanged; // 1 − (1 − cos²θ) loses a grazing ray's cos²θ: the naive formula bends it
      if (tir && naiveSchlick(wo.z, Real(eta)) < 1)
        ++schlickBelowOne;
    }
    INFO("eta = " << double(eta) << " (" << scalarName<Real>() << ")");
    CHECK(tirMismatch == 0);
    CHECK(nonUnit == 0);
    CHECK(changed == 0);
    CHECK(fresnelOut == 0);
    CHECK(fresnelNotOne == 0);
    if (eta <= 1.0L)
      CHECK(tirCount == 0); // into a denser medium, or none: never total internal reflection, at any angle
    if (eta > 1) {
      // Leaving the denser medium: the naive routines fail past the critical angle.
      CHECK(naiveNaN > 0);
      CHECK(schlickBelowOne > 0);
    } else {
      CHECK(naiveNaN == 0); // no TIR possible: the naive formula makes no NaN here
    }
    if (eta == 1.0L)
      CHECK(naiveChanged > 0);
    printFigure("refraction " + std::string(scalarName<Real>()) + " eta " + std::to_string(double(eta)) + ": " +
                std::to_string(kSteps) + " angles, TIR mismatches " + std::to_string(tirMismatch) + " (" + std::to_string(boundary) +
                " within 64 ulp of the critical angle), naive NaN " + std::to_string(naiveNaN) +
                ", naive Schlick < 1 under TIR " + std::to_string(schlickBelowOne) +
                ", naive directions bent at eta 1: " + std::to_string(naiveChanged) + ", robust: " + std::to_string(changed));
  }
}

TEST_CASE("stability 5: refraction and Fresnel stay finite at the largest index the loader takes, which refuses more",
          "[stability][refraction]")
{
  // The Fresnel equations square the index: an ior of 1e20, accepted by the float build before kMaxIor had a float
  // bound, gave bad samples in ten chapters of it (stability case 12, 400 scenes). At the bound, in the build's own
  // scalar, every direction and reflectance is finite, from either side and at every angle swept here.
  for (const Real eta : {Real(kMaxIor), Real(1) / Real(kMaxIor)})
    for (int i = 0; i <= 1000; ++i) {
      const Real theta = Real(i) / 1000 * Real(std::numbers::pi / 2);
      const Vec3 wo(std::sin(theta), 0, std::cos(theta));
      const Real F = fresnelDielectric(wo.z, eta);
      INFO("eta " << eta << ", theta " << theta);
      REQUIRE(std::isfinite(F));
      CHECK((F >= 0 && F <= 1));
      if (const std::optional<Vec3> t = refract(wo, Vec3(0, 0, 1), eta)) {
        REQUIRE(std::isfinite(t->x));
        REQUIRE(std::isfinite(t->z));
      }
    }
  auto scene = [](const std::string& ior) {
    return R"({"camera": {"eye": [0, 0, 3], "focal": [0, 0, 0], "up": [0, 1, 0], "vfov": 40, "width": 4, "height": 3},
      "materials": {"g": {"type": "glass", "ior": )" + ior + R"(}},
      "spheres": [{"center": [0, 0, 0], "radius": 1, "material": "g"}]})";
  };
  std::ostringstream bound, past;
  bound << std::setprecision(17) << kMaxIor;
  past << std::setprecision(17) << kMaxIor * 10;
  CHECK(parseScene(scene(bound.str()), "ior.json").materials[0].ior == Real(kMaxIor));
  try {
    parseScene(scene(past.str()), "ior.json");
    FAIL("an index of refraction ten times kMaxIor was accepted");
  } catch (const SceneError& e) {
    CHECK(std::string(e.what()).find("/materials/g/ior: the index of refraction must be at most") != std::string::npos);
  }
}

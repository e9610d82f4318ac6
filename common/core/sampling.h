/// @file sampling.h
/// @brief Samplers that turn uniform numbers in [0, 1)² into directions, each with its pdf beside it.
///
/// Every direction is a unit vector in the local frame (frame.h), where the hemisphere is z ≥ 0 and cosθ = z.
/// Every pdf is a density with respect to solid angle (per steradian), and integrates to 1 over its domain:
/// that is what the chi-square tests in tests/statistics check, sampler against pdf.
#pragma once

#include "core/math.h"

#include <algorithm>
#include <cmath>

namespace raylife {

/// A uniformly distributed direction on the unit sphere. @param u uniform in [0, 1)².
inline Vec3 sampleUniformSphere(Vec2 u)
{
  const Real z = 1 - 2 * u.x;
  const Real r = std::sqrt(std::max(Real(0), 1 - z * z));
  const SinCos<Real> phi = sinCos2Pi(u.y);
  return Vec3(r * phi.cos, r * phi.sin, z);
}

/// The pdf of sampleUniformSphere: 1/(4π) per steradian everywhere.
inline Real uniformSpherePdf() { return 1 / (4 * kPi); }

/// A uniformly distributed direction on the hemisphere z ≥ 0. @param u uniform in [0, 1)².
inline Vec3 sampleUniformHemisphere(Vec2 u)
{
  const Real z = u.x;
  const Real r = std::sqrt(std::max(Real(0), 1 - z * z));
  const SinCos<Real> phi = sinCos2Pi(u.y);
  return Vec3(r * phi.cos, r * phi.sin, z);
}

/// The pdf of sampleUniformHemisphere: 1/(2π) per steradian on z ≥ 0, and 0 below.
inline Real uniformHemispherePdf(const Vec3& w) { return w.z >= 0 ? 1 / (2 * kPi) : 0; }

// [concentricDisk]
/// A uniformly distributed point on the unit disk by Shirley and Chiu's concentric mapping: the square [−1, 1]² is
/// mapped ring by ring onto the disk, so that neighbouring points stay neighbours and the square's strata stay
/// compact on the disk (a thin lens's samples, chapter 11). Its pdf is 1/π per unit area.
/// @param u uniform in [0, 1)². @return a point with |p| ≤ 1.
inline Vec2 sampleConcentricDisk(Vec2 u)
{
  const Vec2 o = Real(2) * u - Vec2(1);
  if (o.x == 0 && o.y == 0)
    return Vec2(0);
  // The square's rings: |o.x| ≥ |o.y| in the left and right quarters, the other way in the top and bottom ones.
  Real r, theta;
  if (std::abs(o.x) > std::abs(o.y)) {
    r = o.x;
    theta = kPi / 4 * (o.y / o.x);
  } else {
    r = o.y;
    theta = kPi / 2 - kPi / 4 * (o.x / o.y);
  }
  return r * Vec2(std::cos(theta), std::sin(theta));
}
// [concentricDisk]

// [cosine]
/// A cosine-distributed direction on the hemisphere z ≥ 0 (pdf cosθ/π), by Malley's method: a uniform point
/// on the unit disk (radius √u₁, angle 2πu₂) lifted straight up onto the hemisphere. @param u uniform in [0, 1)².
inline Vec3 sampleCosineHemisphere(Vec2 u)
{
  const Real r = std::sqrt(u.x);
  const SinCos<Real> phi = sinCos2Pi(u.y);
  return Vec3(r * phi.cos, r * phi.sin, std::sqrt(std::max(Real(0), 1 - u.x)));
}

/// The pdf of sampleCosineHemisphere: cosθ/π per steradian on z ≥ 0, and 0 below.
inline Real cosineHemispherePdf(const Vec3& w) { return w.z > 0 ? w.z * kInvPi : 0; }
// [cosine]

// [phong]
/// A direction around the +z axis distributed as cosⁿα (α the angle to +z) over the whole sphere, the lobe of
/// the normalised Phong BRDF. @param u uniform in [0, 1)². @param exponent n ≥ 0 (0 gives the uniform hemisphere).
inline Vec3 samplePhongLobe(Vec2 u, Real exponent)
{
  // Invert the cdf of cosα, 1 − cos^(n+1)α, and choose the azimuth uniformly.
  const Real cosAlpha = std::pow(1 - u.x, 1 / (exponent + 1));
  const Real sinAlpha = std::sqrt(std::max(Real(0), 1 - cosAlpha * cosAlpha));
  const SinCos<Real> phi = sinCos2Pi(u.y);
  return Vec3(sinAlpha * phi.cos, sinAlpha * phi.sin, cosAlpha);
}

/// The pdf of samplePhongLobe at a direction whose cosine with the lobe's axis is `cosAlpha`:
/// (n + 1)/(2π) cosⁿα per steradian where cosα > 0, and 0 elsewhere.
inline Real phongLobePdf(Real cosAlpha, Real exponent)
{
  return cosAlpha > 0 ? (exponent + 1) / (2 * kPi) * std::pow(cosAlpha, exponent) : 0;
}
// [phong]

// [roulette]
/// Russian roulette starts after this many bounces: the first bounces carry most of the light, so they are
/// always traced.
inline constexpr int kRouletteMinBounces = 3;
/// The largest survival probability Russian roulette uses: even a bright path ends with probability 1/20 per
/// bounce, so no path is infinite (a white furnace reflects forever otherwise).
inline constexpr Real kRouletteMaxSurvival = Real(0.95);

/// The probability q with which Russian roulette lets a path of throughput `beta` (≥ 0 per channel) go on:
/// min(kRouletteMaxSurvival, max component of beta), in [0, 0.95]. A path that goes on must divide its
/// throughput by q to stay unbiased: E[X/q · 1(survive)] = X.
inline Real rouletteSurvival(const Color& beta) { return std::min(kRouletteMaxSurvival, maxComponent(beta)); }
// [roulette]

} // namespace raylife

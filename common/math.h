/// @file math.h
/// @brief GLM aliases, the renderer's scalar type and every named numerical constant raylife uses.
///
/// No other file holds a bare epsilon: tolerances live here, each with the reason for its value.
#pragma once

#include <glm/glm.hpp>

#include <bit>
#include <cmath>
#include <cstdint>
#include <type_traits>
#include <limits>
#include <numbers>

/// Everything raylife's shared library defines: the building blocks every chapter uses (see the pages for the
/// chapters that introduce each one).
namespace raylife {

/// The renderer's scalar type: `double` unless the build sets RAYLIFE_REAL_IS_FLOAT (`-DRAYLIFE_REAL=float`).
#ifdef RAYLIFE_REAL_IS_FLOAT
using Real = float;
#else
using Real = double;
#endif

/// A 3-vector of scalar T (a point, a direction or a colour).
template <class T> using TVec3 = glm::vec<3, T, glm::defaultp>;
/// A point or direction in world space, in scene units.
using Vec3 = TVec3<Real>;
/// Linear RGB radiance (or reflectance, in [0, 1] per channel, where a material says so).
using Color = TVec3<Real>;
/// A 2-vector of the renderer's scalar (image-plane positions, 2-D samples).
using Vec2 = glm::vec<2, Real, glm::defaultp>;

/// π in the renderer's scalar.
inline constexpr Real kPi = std::numbers::pi_v<Real>;
/// 1/π in the renderer's scalar.
inline constexpr Real kInvPi = std::numbers::inv_pi_v<Real>;
/// +∞ in the renderer's scalar: the tmax of a ray that is not bounded.
inline constexpr Real kInfinity = std::numeric_limits<Real>::infinity();

/// Machine epsilon of T halved: the unit roundoff u, the bound on the relative error of one IEEE operation.
template <class T> inline constexpr T kUnitRoundoff = std::numeric_limits<T>::epsilon() * T(0.5);

/// γ(n) = n·u / (1 − n·u), the bound on the relative error of n chained floating-point operations
/// (Higham, "Accuracy and Stability of Numerical Algorithms", §3.1; pbrt uses the same bound).
template <class T> constexpr T gamma(int n)
{
  return T(n) * kUnitRoundoff<T> / (T(1) - T(n) * kUnitRoundoff<T>);
}

/// A shadow ray towards a point light stops this fraction short of it, so that a light placed exactly on a
/// surface is not shadowed by that surface. Relative, so it does not depend on scene scale.
inline constexpr Real kShadowRayShorten = Real(1e-4);

/// The camera refuses an up vector whose sine with the view direction is below this: the basis would be
/// dominated by rounding (u = up × w loses all its significant bits as |up × w| approaches the unit roundoff).
inline constexpr Real kMinUpSine = Real(1e-6);

/// Relative margin by which the BVH (bvh.h) widens each sphere's bounding box and each box's ray interval
/// [tNear, tFar], so that the tree never culls a sphere the brute-force loop would report. It must cover the
/// rounding of the slab test (2γ(3), pbrt 3rd ed. §3.9.2) and the error of the t intersectSphere returns for a
/// hit on a box's face (a few γ(1) of the distance from the ray's origin to the centre); γ(32) covers both with
/// room to spare. Widening costs an extra box visit now and then, never a different answer.
template <class T> inline constexpr T kBoxMargin = gamma<T>(32);

/// The next representable value above finite or +∞ `v` (pbrt's NextFloatUp): one ulp up by integer increment of
/// its bits, without the libm call of std::nextafter (which showed as 6% of a path tracer's instructions).
template <class T> inline T nextUp(T v)
{
  using Bits = std::conditional_t<sizeof(T) == 4, std::uint32_t, std::uint64_t>;
  if (std::isinf(v) && v > 0)
    return v;
  if (v == T(0))
    v = T(0); // −0 becomes +0, whose successor is the smallest positive subnormal
  Bits bits = std::bit_cast<Bits>(v);
  bits = v >= 0 ? bits + 1 : bits - 1;
  return std::bit_cast<T>(bits);
}

/// The next representable value below finite or −∞ `v` (pbrt's NextFloatDown); see nextUp.
template <class T> inline T nextDown(T v)
{
  using Bits = std::conditional_t<sizeof(T) == 4, std::uint32_t, std::uint64_t>;
  if (std::isinf(v) && v < 0)
    return v;
  if (v == T(0))
    v = T(-0.0);
  Bits bits = std::bit_cast<Bits>(v);
  bits = v > 0 ? bits - 1 : bits + 1;
  return std::bit_cast<T>(bits);
}

/// Luminance of linear Rec.709 RGB (used to weight colours, e.g. Russian roulette, light power).
inline Real luminance(const Color& c) { return Real(0.2126) * c.r + Real(0.7152) * c.g + Real(0.0722) * c.b; }

/// Largest component of a vector.
template <class T> inline T maxComponent(const TVec3<T>& v) { return std::fmax(v.x, std::fmax(v.y, v.z)); }

/// True when every component is finite (neither NaN nor ±∞).
template <class T> inline bool isFinite(const TVec3<T>& v)
{
  return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z);
}

/// The unit vector along v, or `fallback` when v has no direction: v is zero or has a component that is not
/// finite.
///
/// glm::normalize squares the components, so |v|² underflows to 0 for |v| below about 1e-154 in double and
/// 1e-19 in float (it then returns ±∞ or NaN), and overflows above about 1e154 and 1e19 (it then returns 0).
/// This divides by the largest magnitude first, so every finite, non-zero v, subnormal ones included, gives
/// a vector of length 1 to within a few ulps. Use it wherever a vector may legitimately degenerate (a sampled
/// direction that cancels the normal, say); fallback should itself be unit.
template <class T> TVec3<T> safeNormalize(const TVec3<T>& v, const TVec3<T>& fallback)
{
  if (!isFinite(v))
    return fallback;
  const T scale = std::fmax(std::fabs(v.x), std::fmax(std::fabs(v.y), std::fabs(v.z)));
  if (!(scale > 0))
    return fallback;
  const TVec3<T> w = v / scale; // its largest component is ±1: no under- or overflow in the length
  return w / glm::length(w);
}

} // namespace raylife

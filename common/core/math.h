/// @file math.h
/// @brief GLM aliases, the renderer's scalar type and every named numerical constant raylife uses.
///
/// No other file holds a bare epsilon: tolerances live here, each with the reason for its value.
#pragma once

#include <glm/glm.hpp>

#include <algorithm>
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
/// A signed integer as wide as Real (64 bits with double, 32 with float): an index by which SIMD lanes of Real can
/// gather (the stream kernels of render/ray_stream.h).
using LaneIndex = std::conditional_t<sizeof(Real) == 8, std::int64_t, std::int32_t>;

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

/// Relative margin by which culling widens a sphere (a camera block's pyramid, PinholeFrustum; a light buffer's
/// cells, LightBuffer): 10⁻⁴ of the distances involved. The rounding it must cover, of a ray's direction, of the
/// cell or side a ray is tested against and of intersectSphere's closest approach, is a few γ(1) of those distances:
/// about 6·10⁻⁸ each in float, 10⁻¹⁶ in double. So a culled sphere is one no ray could have hit, in either.
inline constexpr Real kCullMargin = Real(1e-4);

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

/// |v| per component, the same bits as glm::abs(v) (−0 stays −0), written as max(v, −v) so that it compiles to
/// a max instruction rather than a branch on each sign (glm::abs does branch, and the signs of a hit's offset from
/// the centre or of a normal are random from one ray to the next). tests/unit/test_offset_ray_origin.cpp checks
/// the bits against glm::abs.
template <class T> inline TVec3<T> absBranchFree(const TVec3<T>& v) { return glm::max(v, -v); }

/// `v` moved one ulp in the direction of the sign of `direction`: the bits of nextUp(v) where direction > 0, of
/// nextDown(v) where direction < 0, and of v itself where direction is ±0 or NaN, for every v. Unlike an
/// if/else over nextUp and nextDown it has no branch on the signs of v and direction, which are random on a path
/// tracer's rays; its one branch, taken by ±0, ±∞ and NaN (rarely if ever on a rendered ray), calls those two.
template <class T> inline T nextAlong(T v, T direction)
{
  using Bits = std::conditional_t<sizeof(T) == 4, std::uint32_t, std::uint64_t>;
  constexpr int kSignShift = sizeof(T) * 8 - 1;
  const Bits bits = std::bit_cast<Bits>(v);
  // ±0, ±∞ and NaN: a magnitude of 0, or of at least ∞'s (0 − 1 wraps around to the largest Bits).
  const Bits magnitude = bits & ~(Bits(1) << kSignShift);
  if (magnitude - 1 >= std::bit_cast<Bits>(std::numeric_limits<T>::infinity()) - 1) [[unlikely]]
    return direction > 0 ? nextUp(v) : direction < 0 ? nextDown(v) : v;
  // Finite and non-zero, v's bits below the sign count its magnitude: one step is +1 where direction has v's sign
  // (|v| grows) and −1 where it has the other; none where direction is ±0 or NaN.
  const Bits moves = std::fabs(direction) > 0;
  const Bits against = ((bits ^ std::bit_cast<Bits>(direction)) >> kSignShift) & moves;
  return std::bit_cast<T>(Bits(bits + moves - 2 * against));
}

/// The sine and cosine of one angle, returned together by sinCos2Pi.
template <class T> struct SinCos {
  T sin; ///< sin of the angle.
  T cos; ///< cos of the angle.
};

// [sinCos2Pi]
/// sin(2πu) and cos(2πu) together, for the azimuth φ = 2πu of the samplers: about a third of the instructions of
/// libm's sincos, which must first reduce an arbitrary angle modulo 2π.
///
/// The reduction works on u itself, where it is exact: 4u = q + f with q the nearest quarter turn and
/// |f| ≤ 1/2, both found without rounding, so 2πu = q·π/2 + f·π/2 loses nothing, not even near the zeros of sin
/// and cos (at u = 1/2, say, where sin(2πu) of the rounded 2πu is 1.2e-16, not 0). Then sin and cos of f·π/2
/// (|f·π/2| ≤ π/4) come from near-minimax polynomials in f² (degree 13 and 14 in f for double, 7 and 8 for
/// float), whose error with their coefficients rounded to T is below 2⁻⁵⁴ in double and 2⁻²⁴·⁷ in float,
/// relative (mostly that of π/2 rounded); the quarter turns are one exact rotation.
///
/// @param u in [0, 1] (the samplers' uniform numbers; 1 gives sin 0, cos 1); outside it the result is
/// unspecified. @return {sin 2πu, cos 2πu}, each within 2 ulps of the true value in float and in double
/// (tests/unit/test_sin_cos.cpp measures at most 1.5 in double and 1.7 in float over a million u), and exact at
/// the quarter turns (0 or ±1). So sin² + cos² = 1 to within 2 epsilon, and a direction built from them is unit
/// to rounding, as intersectSphere's contract needs.
template <class T> inline SinCos<T> sinCos2Pi(T u)
{
  static_assert(std::is_same_v<T, float> || std::is_same_v<T, double>, "sinCos2Pi: float or double");
  // Reduce: the octant floor(8u) (8u is exact), its nearest quarter turn q, and f = 4u − q in [−1/2, 1/2], exact
  // by Sterbenz's lemma (4u and q are within a factor 2 of each other, or q = 0).
  const int octant = static_cast<int>(u * 8);
  const int quarter = (octant + 1) >> 1;
  const T f = u * 4 - T(quarter);
  const T w = f * f;
  // sin(fπ/2) = f·P(f²) and cos(fπ/2) = 1 − f²·Q(f²), by Horner's scheme: P and Q near-minimax on f² in
  // [0, 1/4] (Chebyshev fits, mpmath's chebyfit at 60 digits, rounded to T).
  T s, c;
  if constexpr (std::is_same_v<T, double>) {
    constexpr double p0 = 1.5707963267948966, p1 = -6.4596409750624432e-1, p2 = 7.9692626246043003e-2,
                     p3 = -4.681754132340976e-3, p4 = 1.6044115074219091e-4, p5 = -3.5986433529823097e-6,
                     p6 = 5.633933781537854e-8;
    constexpr double q0 = 1.2337005501361698, q1 = -2.5366950790104782e-1, q2 = 2.0863480763340773e-2,
                     q3 = -9.1926027454684462e-4, q4 = 2.5202039028029176e-5, q5 = -4.7106784055052271e-7,
                     q6 = 6.3293963449674235e-9;
    s = f * (p0 + w * (p1 + w * (p2 + w * (p3 + w * (p4 + w * (p5 + w * p6))))));
    c = 1 - w * (q0 + w * (q1 + w * (q2 + w * (q3 + w * (q4 + w * (q5 + w * q6))))));
  } else {
    constexpr float p0 = 1.57079632f, p1 = -6.45963478e-1f, p2 = 7.96802176e-2f, p3 = -4.60214921e-3f;
    constexpr float q0 = 1.23370055f, q1 = -2.5366941e-1f, q2 = 2.08615283e-2f, q3 = -9.06739898e-4f;
    s = f * (p0 + w * (p1 + w * (p2 + w * p3)));
    c = 1 - w * (q0 + w * (q1 + w * (q2 + w * q3)));
  }
  // Rotate by q quarter turns: (cos qπ/2, sin qπ/2) is (1, 0), (0, 1), (−1, 0) or (0, −1), so the products and
  // sums below are exact and no branch depends on the random u.
  static constexpr T kQuarterCos[4] = {1, 0, -1, 0};
  const T a = kQuarterCos[quarter & 3];
  const T b = kQuarterCos[(quarter + 3) & 3];
  return SinCos<T>{a * s + b * c, a * c - b * s};
}
// [sinCos2Pi]

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
/// Where |v|² is comfortably inside the normal range (the usual case) this is v/|v|; elsewhere it divides by the
/// largest magnitude first. So every finite, non-zero v, subnormal ones included, gives a vector of length 1 to
/// within a few ulps. Use it wherever a vector may legitimately degenerate (a sampled direction that cancels the
/// normal, say); fallback should itself be unit.
template <class T> TVec3<T> safeNormalize(const TVec3<T>& v, const TVec3<T>& fallback)
{
  // The usual case: |v|² far from underflow and overflow (a NaN or ∞ in v fails the test and goes the long way).
  const T length2 = glm::dot(v, v);
  if (length2 > std::numeric_limits<T>::min() * T(1 << 20) && length2 < std::numeric_limits<T>::max() / T(1 << 20))
    return v / std::sqrt(length2);
  if (!isFinite(v))
    return fallback;
  // (std::max, not std::fmax: the components are finite here, where the two agree, and fmax is a call into libm.)
  const T scale = std::max(std::fabs(v.x), std::max(std::fabs(v.y), std::fabs(v.z)));
  if (!(scale > 0))
    return fallback;
  const TVec3<T> w = v / scale; // its largest component is ±1: no under- or overflow in the length
  return w / glm::length(w);
}

} // namespace raylife

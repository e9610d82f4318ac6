/// @file support.h
/// @brief What the stability tests share: a seeded random source, direction samplers, the naive routines each
/// case is measured against, and reference answers computed in long double.
///
/// The naive routines live here, in the tests, and nowhere in the renderer: they are what a first ray tracer
/// writes, kept so that every test can show them failing beside the robust code of common/ passing.
#pragma once

#include "core/math.h"
#include "core/rng.h"
#include "geometry/sphere.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <numbers>
#include <optional>
#include <string>
#include <utility>

namespace raylife::stability {

/// Name of a scalar type, for tables.
template <class T> constexpr const char* scalarName() { return sizeof(T) == 4 ? "float" : "double"; }

/// A seeded stream of uniform numbers for test setups (not the renderer's per-pixel Sampler).
class TestRng {
public:
  explicit TestRng(std::uint64_t seed) : rng_(seed, 0x2545f4914f6cdd1dULL) {}
  /// Uniform in [0, 1), 53 random bits.
  double uniform()
  {
    const std::uint64_t hi = rng_.nextUint() >> 5, lo = rng_.nextUint() >> 6;
    return double((hi << 26) | lo) * 0x1p-53;
  }
  /// Uniform in [a, b).
  double uniform(double a, double b) { return a + (b - a) * uniform(); }
  /// Log-uniform in [a, b), a > 0.
  double logUniform(double a, double b) { return std::exp(uniform(std::log(a), std::log(b))); }

private:
  Pcg32 rng_;
};

/// A uniformly distributed unit vector, in double (rounded to T by the caller).
inline glm::dvec3 uniformSphere(TestRng& rng)
{
  const double z = rng.uniform(-1, 1);
  const double phi = 2 * std::numbers::pi * rng.uniform();
  const double s = std::sqrt(std::max(0.0, 1 - z * z));
  return {s * std::cos(phi), s * std::sin(phi), z};
}

/// A uniformly distributed unit vector in the hemisphere around unit n (grazing directions included).
inline glm::dvec3 uniformHemisphere(TestRng& rng, const glm::dvec3& n)
{
  const glm::dvec3 w = uniformSphere(rng);
  return glm::dot(w, n) >= 0 ? w : -w;
}

/// A vector of T from a double vector (rounded once per component).
template <class T> TVec3<T> toT(const glm::dvec3& v) { return TVec3<T>(T(v.x), T(v.y), T(v.z)); }

/// A vector of T rounded to unit length in T.
template <class T> TVec3<T> unitT(const glm::dvec3& v) { return glm::normalize(toT<T>(v)); }

/// The schoolbook ray–sphere intersection: a·t² + b·t + c = 0 with a = d·d, b = 2 f·d, c = f·f − r²,
/// Δ = b² − 4ac, t = (−b ∓ √Δ)/2a. What the lecture's equation gives when typed in directly.
template <class T>
std::optional<SphereRoots<T>> naiveSphereRoots(const TVec3<T>& o, const TVec3<T>& d, const TVec3<T>& c, T r)
{
  const TVec3<T> f = o - c;
  const T a = glm::dot(d, d);
  const T b = 2 * glm::dot(f, d);
  const T cc = glm::dot(f, f) - r * r;
  const T disc = b * b - 4 * a * cc;
  if (disc < 0)
    return std::nullopt;
  const T s = std::sqrt(disc);
  return SphereRoots<T>{(-b - s) / (2 * a), (-b + s) / (2 * a)};
}

/// The nearest schoolbook root in [tmin, tmax), or nothing.
template <class T>
std::optional<T> naiveIntersectSphere(const TVec3<T>& o, const TVec3<T>& d, const TVec3<T>& c, T r, T tmin, T tmax)
{
  const auto roots = naiveSphereRoots(o, d, c, r);
  if (!roots)
    return std::nullopt;
  if (roots->t0 >= tmin && roots->t0 < tmax)
    return roots->t0;
  if (roots->t1 >= tmin && roots->t1 < tmax)
    return roots->t1;
  return std::nullopt;
}

// [naiveTriangle]
/// The Möller–Trumbore ray–triangle test as it is usually written (Möller and Trumbore 1997): barycentric u and v
/// from the ray's own cross products, each triangle deciding "inside" from its own edge vectors and its own
/// rounding. Correct on the whole, but not watertight: a ray through an edge shared by two triangles can be
/// judged outside both (u or v a hair below 0 in one, u + v a hair above 1 in the other) and slip through.
template <class T>
std::optional<T> naiveIntersectTriangle(const TVec3<T>& o, const TVec3<T>& d, const TVec3<T>& p0, const TVec3<T>& p1,
                                        const TVec3<T>& p2, T tmin, T tmax)
{
  const TVec3<T> e1 = p1 - p0, e2 = p2 - p0;
  const TVec3<T> pvec = glm::cross(d, e2);
  const T det = glm::dot(e1, pvec);
  if (det == 0)
    return std::nullopt;
  const T invDet = 1 / det;
  const TVec3<T> tvec = o - p0;
  const T u = glm::dot(tvec, pvec) * invDet;
  if (u < 0 || u > 1)
    return std::nullopt;
  const TVec3<T> qvec = glm::cross(tvec, e1);
  const T v = glm::dot(d, qvec) * invDet;
  if (v < 0 || u + v > 1)
    return std::nullopt;
  const T t = glm::dot(e2, qvec) * invDet;
  if (t >= tmin && t < tmax)
    return t;
  return std::nullopt;
}
// [naiveTriangle]

using LongVec3 = glm::vec<3, long double, glm::defaultp>;

/// The exact-input reference: the line o + t·d (the T values taken exactly, |d| not assumed 1) against the
/// sphere, solved in long double (64-bit significand: 11 bits more than double, 40 more than float) by the
/// closest-approach form and the stable quadratic.
struct ReferenceRoots {
  long double t0 = 0, t1 = 0; ///< Roots, t0 ≤ t1.
  long double missDistance = 0; ///< Distance from the centre to the line, minus r (< 0: the line hits).
};

template <class T> ReferenceRoots referenceRoots(const TVec3<T>& o, const TVec3<T>& d, const TVec3<T>& c, T r)
{
  const LongVec3 O(o), D(d), C(c);
  const long double R = r;
  const LongVec3 f = O - C;
  const long double a = glm::dot(D, D);
  const long double b = -glm::dot(f, D); // t of closest approach is b / a
  const LongVec3 l = f + (b / a) * D;
  const long double lLength = std::sqrt(glm::dot(l, l));
  ReferenceRoots ref;
  ref.missDistance = lLength - R;
  const long double disc = (R - lLength) * (R + lLength); // r² − |l|²
  if (disc < 0)
    return ref;
  const long double q = b + std::copysign(std::sqrt(a * disc), b);
  const long double fLength = std::sqrt(glm::dot(f, f));
  const long double cTerm = (fLength - R) * (fLength + R);
  long double t0 = q != 0 ? cTerm / q : b / a;
  long double t1 = q / a;
  if (t0 > t1)
    std::swap(t0, t1);
  ref.t0 = t0;
  ref.t1 = t1;
  return ref;
}

/// |computed − reference| / |reference|, in long double.
inline long double relativeError(long double computed, long double reference)
{
  return std::fabs(computed - reference) / std::fabs(reference);
}

/// The shared header line of the figures the tests print, so that `stability_tests` output can be quoted.
inline void printFigure(const std::string& line) { std::printf("[stability] %s\n", line.c_str()); }

} // namespace raylife::stability

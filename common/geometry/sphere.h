/// @file sphere.h
/// @brief Ray–sphere intersection in a numerically careful form, templated on the scalar for the stability tests.
///
/// Which form, and why. Solving 0 = |o + t·d − c|² − r² as the schoolbook quadratic (b² − 4ac) fails in two
/// ways: for a small sphere far away, b² and c = |o − c|² − r² are huge and nearly equal, so the discriminant
/// loses the radius (in float, past about 4096 radii every nearby ray "hits"); and the root (−b ± √Δ)/2a
/// cancels when one root is much smaller than the other. raylife uses the form of Ray Tracing Gems, chapter 7
/// ("Precision Improvements for Ray/Sphere Intersection", Haines et al.):
///  - the discriminant is taken from the closest approach, Δ = r² − |f + b·d|² with f = o − c and b = −f·d,
///    which never forms the huge, cancelling b² − c;
///  - the roots are q = b + sign(b)·√Δ and c/q (a = 1 as d is unit), which never subtract nearly equal numbers.
#pragma once

#include "core/math.h"

#include <algorithm>
#include <optional>

namespace raylife {

/// The centre at time t of a sphere with centre `center` at time 0 and `velocity` per shutter interval: `center`
/// itself, bit for bit, when the velocity is 0 (so a still sphere is met exactly as before motion existed).
inline Vec3 sphereCenterAt(const Vec3& center, const Vec3& velocity, Real t)
{
  return velocity != Vec3(0) ? center + t * velocity : center;
}

/// A sphere: centre in world space, radius > 0 in scene units, and an index into the scene's materials. A sphere
/// with a velocity moves during the shutter interval (chapter 11: motion blur).
struct Sphere {
  Vec3 center{0};  ///< Centre at time 0, world space.
  Real radius = 1; ///< Radius, > 0.
  int material = 0; ///< Index into Scene::materials.
  Vec3 velocity{0}; ///< Scene units per shutter interval: the centre at time t ∈ [0, 1) is center + t·velocity.

  /// True when the sphere moves (a non-zero velocity).
  bool moving() const { return velocity != Vec3(0); }
  /// The centre at time t ∈ [0, 1): `center` itself, bit for bit, for a sphere that does not move.
  Vec3 centerAt(Real t) const { return sphereCenterAt(center, velocity, t); }
};

/// The two parameters where a line meets a sphere, t0 ≤ t1 (either may be negative: behind the origin).
template <class T> struct SphereRoots {
  T t0; ///< Nearer root.
  T t1; ///< Farther root.
};

// [intersectSphereRoots]
/// Where the line o + t·d meets the sphere |p − c| = r, in the robust form described in the file comment.
///
/// @param o the line's origin. @param d its unit direction. @param c the sphere's centre. @param r radius > 0.
/// @return both roots (a tangent gives t0 == t1), or nothing when the line misses. Ignores any ray interval.
template <class T>
std::optional<SphereRoots<T>> intersectSphereRoots(const TVec3<T>& o, const TVec3<T>& d, const TVec3<T>& c, T r)
{
  // Closest approach: b is the t nearest the centre, l the vector from the centre to that point.
  const TVec3<T> f = o - c;
  const T b = -glm::dot(f, d);
  const TVec3<T> l = f + b * d;
  // Discriminant from the closest approach: Δ = r² − |l|² (a = 1). No square root yet, so a miss costs none.
  const T disc = r * r - glm::dot(l, l);
  if (disc < 0)
    return std::nullopt;

  // Solve the quadratic without cancellation: q has the sign of b, so |q| ≥ |b|.
  const T q = b + std::copysign(std::sqrt(disc), b);
  if (q == 0) // tangent through the origin: both roots are b (= 0)
    return SphereRoots<T>{b, b};
  const T cTerm = glm::dot(f, f) - r * r;
  T t0 = cTerm / q;
  T t1 = q;
  if (t0 > t1)
    std::swap(t0, t1);
  return SphereRoots<T>{t0, t1};
}
// [intersectSphereRoots]

/// The nearest root of the line with the sphere inside [tmin, tmax), or nothing. Contract: d unit length,
/// r > 0, 0 ≤ tmin (a ray looks forward only; the bounds below rely on it).
template <class T>
std::optional<T> intersectSphere(const TVec3<T>& o, const TVec3<T>& d, const TVec3<T>& c, T r, T tmin, T tmax)
{
  // Bound the roots before solving: where no root can lie in [tmin, tmax), skip the square root and the
  // division. With f = o − c, b = −f·d and c = |f|² − r², the roots are q = b ± √Δ and c/q, and √Δ ≤ r.
  const TVec3<T> f = o - c;
  const T ff = glm::dot(f, f);
  const T rr = r * r;
  const T b = -glm::dot(f, d);
  // Outside (|f|² > r²) and heading away from the centre (b ≤ 0): both roots lie behind the origin (their
  // product c is > 0 and their sum 2b ≤ 0). About half of all misses end here.
  if (ff > rr && b <= 0)
    return std::nullopt;
  // Inside (|f|² < r²), centre ahead (b > 0): the only root ahead is q = b + √Δ, which is ≥ b also after
  // rounding, so none counts when b ≥ tmax. In a box of huge wall spheres (the Cornell box) a ray is inside every
  // wall, and this holds for the walls behind it once a nearer hit has set tmax.
  if (ff < rr && b >= tmax)
    return std::nullopt;
  // Inside, centre behind (b ≤ 0): the root ahead is c/q with c < 0 and |q| ≤ |b| + r, so it is at least
  // (r² − |f|²)/(r − b); the margin γ(16) keeps that a lower bound of the rounded root. The far walls of the box.
  if (ff < rr && b <= 0 && (rr - ff) * (1 - gamma<T>(16)) >= tmax * (r - b))
    return std::nullopt;
  // Solve (the compiler merges the terms above with the same ones inside intersectSphereRoots).
  const auto roots = intersectSphereRoots(o, d, c, r);
  if (!roots)
    return std::nullopt;
  if (roots->t0 >= tmin && roots->t0 < tmax)
    return roots->t0;
  if (roots->t1 >= tmin && roots->t1 < tmax)
    return roots->t1;
  return std::nullopt;
}

/// A point on a sphere's surface with a bound on its floating-point error.
template <class T> struct SurfacePoint {
  TVec3<T> point;  ///< The point, re-projected onto the sphere.
  TVec3<T> normal; ///< Outward unit normal n = (p − c)/r, the lecture's n̂.
  TVec3<T> error;  ///< Per-component bound on |point − true surface point|, ≥ 0.
};

// [sphereSurfacePoint]
/// Re-projects o + t·d onto the sphere and bounds the result's error.
///
/// o + t·d carries the error of t times |d|, which can be large; moving the point to c + r·(p − c)/|p − c|
/// leaves only the rounding of that expression: γ(5)·|p − c| for the re-projection (pbrt, 3rd ed., §3.9.4)
/// plus γ(2)·|p| for forming it relative to c and adding c back. The bound is what lets a new ray leave the
/// surface without a fixed epsilon (offsetRayOrigin).
template <class T>
SurfacePoint<T> sphereSurfacePoint(const TVec3<T>& o, const TVec3<T>& d, T t, const TVec3<T>& c, T r)
{
  const TVec3<T> local = (o + t * d) - c;
  const T len = glm::length(local);
  // A degenerate hit exactly at the centre cannot happen for r > 0; guard anyway so no NaN escapes.
  const TVec3<T> n = len > 0 ? local / len : TVec3<T>(0, 0, 1);
  const TVec3<T> onSphere = n * r;
  const TVec3<T> p = c + onSphere;
  const TVec3<T> err = gamma<T>(5) * absBranchFree(onSphere) + gamma<T>(2) * absBranchFree(p);
  return SurfacePoint<T>{p, n, err};
}
// [sphereSurfacePoint]

// [offsetRayOrigin]
/// Moves a point p with error bound `error` off its surface (normal n) to the side that direction w leaves
/// through, far enough that no rounding can put the new origin on the wrong side of the surface.
///
/// The offset along n is |n|·error (the error box's extent along n), then each coordinate is rounded one
/// ulp further away. From pbrt, 3rd ed., §3.9.5. The result is to be used with tmin = 0.
///
/// Written without a branch on a sign, as the signs of n and w are random from one ray to the next:
/// tests/unit/test_offset_ray_origin.cpp checks it gives the same bits as the if/else form it replaced.
template <class T>
TVec3<T> offsetRayOrigin(const TVec3<T>& p, const TVec3<T>& error, const TVec3<T>& n, const TVec3<T>& w)
{
  // |n|·error, negated where w leaves against n.
  const T distance = glm::dot(absBranchFree(n), error);
  const T side = T(1 - 2 * int(glm::dot(w, n) < 0));
  const TVec3<T> offset = (side * distance) * n;
  const TVec3<T> po = p + offset;
  // One ulp further along the offset, coordinate by coordinate: nextUp where it is > 0, nextDown where < 0.
  return TVec3<T>(nextAlong(po.x, offset.x), nextAlong(po.y, offset.y), nextAlong(po.z, offset.z));
}
// [offsetRayOrigin]

} // namespace raylife

/// @file hit.h
/// @brief The record of a ray's nearest hit, and the rays that leave it.
#pragma once

#include "core/math.h"
#include "geometry/ray.h"
#include "geometry/sphere.h"

namespace raylife {

/// What a ray hit: returned by value from Scene::intersect.
struct Hit {
  Real t = 0;          ///< Distance along the ray (the ray's direction is unit).
  Vec3 point{0};       ///< The hit point, on the surface (re-projected onto a sphere; from the barycentrics on a
                       ///< triangle).
  /// The unit normal shading uses: a sphere's outward normal (whatever side the ray came from), a triangle's
  /// front-side normal, or, on a smooth mesh, the vertex normals interpolated there (on the front side).
  Vec3 normal{0, 0, 1};
  /// The surface's own unit normal: out of a sphere, or a triangle's front side ((p1 − p0) × (p2 − p0)). Equal
  /// to `normal` except on smooth meshes. New rays leave the surface along it (spawnRay).
  Vec3 geometricNormal{0, 0, 1};
  Vec3 pointError{0};  ///< Per-component bound on the floating-point error of `point`.
  int primitive = -1;  ///< What was hit: sphere i is i, triangle j is Scene::spheres.size() + j.
  int material = -1;   ///< Index into Scene::materials.
  Real time = 0;       ///< The time of the ray that made the hit (Ray::time); the rays that leave it keep it.

  /// True when the ray arrived from the front: from outside a sphere, or on a triangle's front side (its
  /// direction opposes the geometric normal).
  bool frontFace(const Vec3& rayDirection) const { return glm::dot(rayDirection, geometricNormal) < 0; }
};

/// A ray leaving the hit point in unit direction `dir`, its origin moved off the surface by the point's error
/// bound to the side `dir` leaves through, so it cannot hit the same surface at t ≈ 0 (tmin = 0).
inline Ray spawnRay(const Hit& hit, const Vec3& dir)
{
  return Ray{offsetRayOrigin(hit.point, hit.pointError, hit.geometricNormal, dir), dir, 0, kInfinity, hit.time};
}

// [spawnRayTo]
/// A ray from the hit point towards `target` (a point light, say), stopping just short of it: tmax is the
/// distance shortened by the relative kShadowRayShorten, so a surface through the target does not block it.
inline Ray spawnRayTo(const Hit& hit, const Vec3& target)
{
  const Vec3 toTarget = target - hit.point;
  const Real distance = glm::length(toTarget);
  if (!(distance > 0)) // the target is the hit point itself: an empty ray, which nothing can block
    return Ray{hit.point, hit.geometricNormal, 0, 0, hit.time};
  const Vec3 dir = toTarget / distance;
  const Vec3 origin = offsetRayOrigin(hit.point, hit.pointError, hit.geometricNormal, dir);
  return Ray{origin, dir, 0, glm::length(target - origin) * (1 - kShadowRayShorten), hit.time};
}
// [spawnRayTo]

/// A ray from one hit point towards another (bidirectional path tracing's connection of two vertices), stopping
/// just short of it. Both ends are moved off their surfaces by their error bounds, the origin to the side the ray
/// leaves through, the target to the side the ray comes from (as pbrt-v4's two-point SpawnRayTo), and tmax is that
/// distance shortened by kShadowRayShorten. The target's surface then cannot block the ray, however large its error
/// bound against the distance: with the target point itself, a hit on a sphere of radius 10⁵ in the float build is
/// off by some 10⁻², beyond what the relative shortening of 10⁻⁴ covers across a room of 50 units.
inline Ray spawnRayTo(const Hit& from, const Hit& to)
{
  const Vec3 toTarget = to.point - from.point;
  if (!(glm::length(toTarget) > 0)) // the same point: an empty ray, which nothing can block
    return Ray{from.point, from.geometricNormal, 0, 0, from.time};
  const Vec3 origin = offsetRayOrigin(from.point, from.pointError, from.geometricNormal, toTarget);
  const Vec3 target = offsetRayOrigin(to.point, to.pointError, to.geometricNormal, origin - to.point);
  const Vec3 toEnd = target - origin;
  const Real distance = glm::length(toEnd);
  if (!(distance > 0))
    return Ray{origin, from.geometricNormal, 0, 0, from.time};
  return Ray{origin, toEnd / distance, 0, distance * (1 - kShadowRayShorten), from.time};
}

} // namespace raylife

// The benches' yardstick: a raylife ray as Embree 3 takes it (tools/mesh_bench, tools/bvh_bench's embree mode).
// Built only with RAYLIFE_EMBREE (the `embree` preset); Embree is never a chapter's.
#pragma once

#include "geometry/ray.h"

#include <embree3/rtcore.h>

#include <limits>

namespace raylife {

/// `r` for rtcIntersect1, in float (as Embree works), from `tnear` on and unbounded beyond: no hit yet.
inline RTCRayHit embreeRayHit(const Ray& r, float tnear)
{
  RTCRayHit rh{};
  rh.ray.org_x = float(r.origin.x);
  rh.ray.org_y = float(r.origin.y);
  rh.ray.org_z = float(r.origin.z);
  rh.ray.dir_x = float(r.direction.x);
  rh.ray.dir_y = float(r.direction.y);
  rh.ray.dir_z = float(r.direction.z);
  rh.ray.tnear = tnear;
  rh.ray.tfar = std::numeric_limits<float>::infinity();
  rh.ray.mask = ~0u;
  rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
  return rh;
}

/// The nearest hit of `r` in `scene` by rtcIntersect1, from `tnear` on: hit.geomID is RTC_INVALID_GEOMETRY_ID for
/// a miss, and ray.tfar the hit's distance otherwise.
inline RTCRayHit embreeIntersect(RTCScene scene, const Ray& r, float tnear)
{
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  RTCRayHit rh = embreeRayHit(r, tnear);
  rtcIntersect1(scene, &context, &rh);
  return rh;
}

} // namespace raylife

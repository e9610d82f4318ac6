/// @file shading.h
/// @brief The lecture's local shading model (chapters 3 to 5): Lambert's law and the ambient term.
#pragma once

#include "hit.h"
#include "light.h"
#include "math.h"
#include "scene.h"

#include <algorithm>

namespace raylife {

/// Lambert's law, the lecture's I_D = (L·N) C I_L: light arriving along L on a diffuse surface of colour C
/// with unit normal N. Light from behind the surface (L·N < 0) contributes nothing, hence max(0, L·N).
inline Color lambert(const Color& C, const Vec3& N, const LightArrival& light)
{
  return std::max(Real(0), glm::dot(light.direction, N)) * C * light.intensity;
}

/// The normal on the side of the surface the ray came from: shading a sphere seen from inside uses −n.
inline Vec3 facingNormal(const Hit& hit, const Vec3& rayDirection)
{
  return hit.frontFace(rayDirection) ? hit.normal : -hit.normal;
}

// [directLighting]
/// Chapter 4's local shading as one call, for the chapters that build on it (chapter 5 shades its diffuse hits
/// with it): ambient·C plus Lambert's law for every point light that the shadow ray finds unblocked.
///
/// @param hit the shaded point. @param N the unit normal facing the viewer (facingNormal). @param C colour in
///        [0, 1]. @return radiance, ≥ 0. Traces one shadow ray per light in front of the surface.
inline Color directLighting(const Scene& scene, const Hit& hit, const Vec3& N, const Color& C)
{
  Color I = scene.ambient * C;
  for (const PointLight& light : scene.lights) {
    const std::optional<LightArrival> in = light.arrivalAt(hit.point);
    if (!in || glm::dot(in->direction, N) <= 0 || scene.occluded(spawnRayTo(hit, light.position)))
      continue;
    I += lambert(C, N, *in);
  }
  return I;
}
// [directLighting]

} // namespace raylife

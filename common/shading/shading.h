/// @file shading.h
/// @brief The lecture's local shading model (chapters 3 to 5): Lambert's law and the ambient term.
#pragma once

#include "geometry/hit.h"
#include "shading/light.h"
#include "core/math.h"

#include <algorithm>

namespace raylife {

// [lambert]
/// Lambert's law, the lecture's I_D = (L·N) C I_L: light arriving along L on a diffuse surface of colour C
/// with unit normal N. Light from behind the surface (L·N < 0) contributes nothing, hence max(0, L·N).
inline Color lambert(const Color& C, const Vec3& N, const LightArrival& light)
{
  return std::max(Real(0), glm::dot(light.direction, N)) * C * light.intensity;
}
// [lambert]

// [facingNormal]
/// The normal on the side of the surface the ray came from: shading a sphere seen from inside uses −n.
inline Vec3 facingNormal(const Hit& hit, const Vec3& rayDirection)
{
  return hit.frontFace(rayDirection) ? hit.normal : -hit.normal;
}
// [facingNormal]

} // namespace raylife

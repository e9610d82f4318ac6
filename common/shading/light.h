/// @file light.h
/// @brief Point lights. (Emissive spheres are the other kind of light: see Material::emission.)
#pragma once

#include "core/math.h"

#include <optional>

namespace raylife {

/// The light a point light delivers to a point: where it comes from, how far, how much.
struct LightArrival {
  Vec3 direction;  ///< L: unit vector from the shaded point towards the light.
  Real distance;   ///< Distance to the light, > 0.
  Color intensity; ///< I_L: the irradiance at the point on a surface facing the light, I / distance².
};

/// An isotropic point light.
///
/// `intensity` is radiant intensity I per channel (radiance-units · area, ≥ 0). The irradiance it delivers
/// at distance r facing the light is I / r² (the inverse-square law); this is the lecture's I_L.
struct PointLight {
  Vec3 position{0};   ///< World space.
  Color intensity{1}; ///< Radiant intensity, ≥ 0 per channel.

  // [arrivalAt]
  /// The light arriving at `point` from this light, or nothing when the point is the light's own position
  /// (where direction and I_L are undefined).
  std::optional<LightArrival> arrivalAt(const Vec3& point) const
  {
    const Vec3 toLight = position - point;
    const Real distance = glm::length(toLight);
    if (!(distance > 0))
      return std::nullopt;
    return LightArrival{toLight / distance, distance, intensity / (distance * distance)};
  }
  // [arrivalAt]
};

} // namespace raylife

/// @file ray.h
/// @brief A ray p(t) = o + t·d that carries its own valid interval [tmin, tmax].
#pragma once

#include "core/math.h"

namespace raylife {

/// A ray p(t) = origin + t·direction, valid for t in [tmin, tmax].
///
/// Contract: `direction` is unit length, so t is a distance in scene units. Secondary rays leave surfaces
/// from an origin already pushed off the surface by its error bound (see Hit::spawnRay), so their tmin is 0:
/// no ray in raylife depends on a fixed epsilon in tmin.
struct Ray {
  Vec3 origin{0};        ///< o, world space.
  Vec3 direction{0, 0, -1}; ///< d, unit length.
  Real tmin = 0;         ///< Smallest accepted t (inclusive), ≥ 0.
  Real tmax = kInfinity; ///< Largest accepted t (exclusive); shrinks as nearer hits are found.
  /// The moment in the shutter interval the ray travels at, in [0, 1) (chapter 11: motion blur): moving spheres are
  /// met where they are at this time. Rays spawned from a hit keep it (Hit::time). 0 for a still scene.
  Real time = 0;

  /// The point at parameter t.
  Vec3 at(Real t) const { return origin + t * direction; }
};

} // namespace raylife

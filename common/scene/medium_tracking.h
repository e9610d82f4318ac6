/// @file medium_tracking.h
/// @brief Which medium a ray is in, and the transmittance of a shadow ray through any number of media boundaries
/// (chapter 15).
///
/// A ray's medium is carried along the path, never found by a point-in-shape test: it starts as
/// Scene::cameraMedium, and changes only where the ray crosses a shape that names media, to the medium on the side
/// its new direction leaves towards (MediumInterface::after). So a ray that starts on a boundary knows its side from
/// its direction alone, and non-convex or nested closed shapes need nothing more.
///
/// One more rule makes a ray that starts exactly on a boundary safe whatever rounding does (the camera on a ball's
/// surface: its rays may or may not find the boundary at t ≈ 0): a segment that ends on a shape naming media
/// travels in the medium that shape names on the side the ray arrives from (segmentMedium). The carried medium
/// decides only the segments that end on shapes without media or in the sky.
#pragma once

#include "core/rng.h"
#include "geometry/hit.h"
#include "scene/light_sampling.h"
#include "scene/scene.h"

namespace raylife {

/// Most boundaries one shadow ray, or one path between two scattering events, may cross (interfaces do not count
/// as bounces, so this is what stops a path in a pathological scene: thousands of nested shells). Far more than
/// any real scene has along one ray.
inline constexpr int kMaxMediumCrossings = 1024;

/// The transmittance of medium `medium` (kVacuum: 1) over [0, t) of `ray`, per channel: exp(−σt·t) for a
/// homogeneous medium; an unbiased estimate by ratio tracking (drawing from `sampler`) for a heterogeneous one.
Color segmentTransmittance(const Scene& scene, int medium, const Ray& ray, Real t, Sampler& sampler);

/// The medium that a ray leaving `hit` along `direction` travels in, `current` being the one it arrived in.
inline int mediumAfter(const Scene& scene, const Hit& hit, const Vec3& direction, int current)
{
  return scene.mediumInterface(hit.primitive).after(hit.geometricNormal, direction, current);
}

/// The medium of the segment of `ray` that ends at `hit`: the one the hit's shape names on the side the ray arrives
/// from, when the shape names media; else `current` (also with no hit: the segment runs to the sky).
inline int segmentMedium(const Scene& scene, const std::optional<Hit>& hit, const Ray& ray, int current)
{
  return hit ? scene.mediumInterface(hit->primitive).after(hit->geometricNormal, -ray.direction, current) : current;
}

/// The fraction of the light sample's radiance that reaches surface point `hit` (in medium `medium` on the side
/// ls.wi leaves towards): 0 when a surface other than an interface blocks it, else the product of the media's
/// transmittances between the boundaries it crosses. The shadow ray stops where it meets the sampled emitter (or
/// just short of a point light), as lightVisible does.
Color shadowTransmittance(const Scene& scene, const Hit& hit, int medium, const LightSample& ls, Sampler& sampler);

/// As above, from a point `p` inside medium `medium` (a scattering event, not on a surface).
Color shadowTransmittance(const Scene& scene, const Vec3& p, Real time, int medium, const LightSample& ls,
                          Sampler& sampler);

} // namespace raylife

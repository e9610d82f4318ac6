#include "scene/medium_tracking.h"

namespace raylife {

Color mediumTransmittance(const Scene& scene, int medium, Real d)
{
  if (medium == kVacuum)
    return Color(1);
  return transmittance(scene.media[std::size_t(medium)].sigmaT(), d);
}

namespace {
// Follows the shadow ray `ray` (already leaving its start point) towards the light of `ls`, across interfaces.
Color walkShadowRay(const Scene& scene, Ray ray, int medium, const LightSample& ls)
{
  Color tr(1);
  for (int crossing = 0; crossing <= kMaxMediumCrossings; ++crossing) {
    if (!ls.delta) { // end where the ray meets the sampled emitter, from this segment's own origin
      const std::optional<Real> t = scene.intersectPrimitive(ray, ls.primitive);
      if (!t)
        return Color(0);
      ray.tmax = *t;
    }
    const std::optional<Hit> hit = scene.intersect(ray);
    medium = segmentMedium(scene, hit, ray, medium);
    if (!hit)
      return tr * mediumTransmittance(scene, medium, ray.tmax);
    if (scene.materials[std::size_t(hit->material)].type != MaterialType::Interface)
      return Color(0); // a surface blocks the light
    tr *= mediumTransmittance(scene, medium, hit->t);
    if (tr == Color(0))
      return tr;
    medium = mediumAfter(scene, *hit, ray.direction, medium);
    ray = ls.delta ? spawnRayTo(*hit, ls.target) : spawnRay(*hit, ray.direction);
  }
  return Color(0); // more boundaries than any scene should have: count it as blocked
}
} // namespace

Color shadowTransmittance(const Scene& scene, const Hit& hit, int medium, const LightSample& ls)
{
  return walkShadowRay(scene, ls.delta ? spawnRayTo(hit, ls.target) : spawnRay(hit, ls.wi), medium, ls);
}

Color shadowTransmittance(const Scene& scene, const Vec3& p, Real time, int medium, const LightSample& ls)
{
  const Real tMax = ls.delta ? glm::length(ls.target - p) * (1 - kShadowRayShorten) : kInfinity;
  return walkShadowRay(scene, Ray{p, ls.wi, 0, tMax, time}, medium, ls);
}

} // namespace raylife

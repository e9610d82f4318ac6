#include "scene/medium_tracking.h"

namespace raylife {

Color segmentTransmittance(const Scene& scene, int medium, const Ray& ray, Real t, Sampler& sampler)
{
  if (medium == kVacuum)
    return Color(1);
  const Medium& m = scene.media[std::size_t(medium)];
  if (m.density)
    return ratioTrack(*m.density, m.globalMajorant, m.sigmaT(), ray, t, sampler);
  return transmittance(m.sigmaT(), t);
}

namespace {
// Follows the shadow ray `ray` (already leaving its start point) towards the light of `ls`, across interfaces.
Color walkShadowRay(const Scene& scene, Ray ray, int medium, const LightSample& ls, Sampler& sampler)
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
      return tr * segmentTransmittance(scene, medium, ray, ray.tmax, sampler);
    if (scene.materials[std::size_t(hit->material)].type != MaterialType::Interface)
      return Color(0); // a surface blocks the light
    tr *= segmentTransmittance(scene, medium, ray, hit->t, sampler);
    if (tr == Color(0))
      return tr;
    medium = mediumAfter(scene, *hit, ray.direction, medium);
    ray = ls.delta ? spawnRayTo(*hit, ls.target) : spawnRay(*hit, ray.direction);
  }
  return Color(0); // more boundaries than any scene should have: count it as blocked
}
} // namespace

Color shadowTransmittance(const Scene& scene, const Hit& hit, int medium, const LightSample& ls, Sampler& sampler)
{
  return walkShadowRay(scene, ls.delta ? spawnRayTo(hit, ls.target) : spawnRay(hit, ls.wi), medium, ls, sampler);
}

Color shadowTransmittance(const Scene& scene, const Vec3& p, Real time, int medium, const LightSample& ls,
                          Sampler& sampler)
{
  const Real tMax = ls.delta ? glm::length(ls.target - p) * (1 - kShadowRayShorten) : kInfinity;
  return walkShadowRay(scene, Ray{p, ls.wi, 0, tMax, time}, medium, ls, sampler);
}

} // namespace raylife

#include "scene/light_sampling.h"

#include <algorithm>

namespace raylife {

LightSampler::LightSampler(const Scene& scene) : scene_(scene)
{
  // Each light's power Φ (its luminance): π·Le·A for an emitter of area A (4πr² for a sphere), 4π·I for a point light.
  std::vector<Real> power;
  for (std::size_t i = 0; i < scene.primitiveCount(); ++i) {
    const Material& m = scene.materials[std::size_t(scene.materialOf(int(i)))];
    if (!m.isEmissive())
      continue;
    Real phi = 0;
    if (i < scene.spheres.size()) {
      const Real r = scene.spheres[i].radius;
      phi = luminance(m.emission) * kPi * 4 * kPi * r * r;
    } else {
      const auto [p0, p1, p2] = scene.triangleVertices(i - scene.spheres.size());
      phi = luminance(m.emission) * kPi * (triangleDoubleArea(p0, p1, p2) / 2);
    }
    if (phi > 0) {
      lights_.push_back(int(i));
      power.push_back(phi);
    }
  }
  for (std::size_t i = 0; i < scene.lights.size(); ++i) {
    const Real phi = 4 * kPi * luminance(scene.lights[i].intensity);
    if (phi > 0) {
      lights_.push_back(-int(i) - 1);
      power.push_back(phi);
    }
  }
  // The cumulative distribution, normalised; the last entry is exactly 1 so that every u < 1 finds a light.
  Real total = 0;
  for (Real p : power)
    total += p;
  if (!(total > 0)) {
    lights_.clear();
    return;
  }
  Real running = 0;
  for (std::size_t k = 0; k < power.size(); ++k) {
    running += power[k];
    cdf_.push_back(running / total);
    if (lights_[k] >= 0)
      emitters_.emplace_back(lights_[k], power[k] / total); // in increasing primitive order
  }
  cdf_.back() = 1;
}

Real LightSampler::probability(int primitive) const
{
  const auto it = std::lower_bound(emitters_.begin(), emitters_.end(), primitive,
                                   [](const std::pair<int, Real>& e, int p) { return e.first < p; });
  return it != emitters_.end() && it->first == primitive ? it->second : 0;
}

std::pair<std::size_t, Real> LightSampler::choose(Real uLight) const
{
  // Choose a light by inverting the cumulative distribution of power.
  const std::size_t k = std::size_t(std::upper_bound(cdf_.begin(), cdf_.end(), uLight) - cdf_.begin());
  const std::size_t chosen = std::min(k, cdf_.size() - 1);
  return {chosen, cdf_[chosen] - (chosen > 0 ? cdf_[chosen - 1] : 0)};
}

Real LightSampler::area(int primitive) const
{
  if (std::size_t(primitive) < scene_.spheres.size()) {
    const Real r = scene_.spheres[std::size_t(primitive)].radius;
    return 4 * kPi * r * r;
  }
  const auto [p0, p1, p2] = scene_.triangleVertices(std::size_t(primitive) - scene_.spheres.size());
  return triangleDoubleArea(p0, p1, p2) / 2;
}

Vec3 LightSampler::normalAt(int primitive, const Vec3& point) const
{
  if (std::size_t(primitive) < scene_.spheres.size()) {
    const Sphere& s = scene_.spheres[std::size_t(primitive)];
    return safeNormalize(point - s.center, Vec3(0, 0, 1));
  }
  const auto [p0, p1, p2] = scene_.triangleVertices(std::size_t(primitive) - scene_.spheres.size());
  return triangleNormal(p0, p1, p2);
}

std::optional<EmitterPoint> LightSampler::sampleEmitterPoint(Real uLight, Vec2 u) const
{
  if (cdf_.empty())
    return std::nullopt;
  const auto [chosen, choice] = choose(uLight);
  const int light = lights_[chosen];
  if (light < 0)
    return std::nullopt; // a point light: no surface to start from
  EmitterPoint e;
  e.hit.primitive = light;
  e.hit.material = scene_.materialOf(light);
  e.Le = scene_.materials[std::size_t(e.hit.material)].emission;
  e.pdfArea = choice / area(light);
  if (std::size_t(light) < scene_.spheres.size()) {
    // Uniform on the sphere: a uniform direction from the centre, re-projected with its error bound.
    const Sphere& s = scene_.spheres[std::size_t(light)];
    const SurfacePoint<Real> sp = sphereSurfacePoint(s.center, sampleUniformSphere(u), s.radius, s.center, s.radius);
    e.hit.point = sp.point;
    e.hit.pointError = sp.error;
    e.hit.normal = e.hit.geometricNormal = sp.normal;
  } else {
    // Uniform on the triangle: b0 = 1 − √u₀, b1 = √u₀·(1 − u₁), b2 = √u₀·u₁.
    const auto [p0, p1, p2] = scene_.triangleVertices(std::size_t(light) - scene_.spheres.size());
    const Real su = std::sqrt(u.x);
    const TrianglePoint<Real> tp = trianglePoint(p0, p1, p2, 1 - su, su * (1 - u.y), su * u.y);
    e.hit.point = tp.point;
    e.hit.pointError = tp.error;
    e.hit.normal = e.hit.geometricNormal = triangleNormal(p0, p1, p2);
  }
  return e;
}

// [sample]
std::optional<LightSample> LightSampler::sample(const Vec3& ref, Real uLight, Vec2 u, Real time) const
{
  if (cdf_.empty())
    return std::nullopt;
  const auto [chosen, choice] = choose(uLight);
  const int light = lights_[chosen];

  // A point light: the one direction towards it, with the inverse-square law; a delta light has no density.
  if (light < 0) {
    const PointLight& p = scene_.lights[std::size_t(-light - 1)];
    const std::optional<LightArrival> in = p.arrivalAt(ref);
    if (!in)
      return std::nullopt;
    return LightSample{in->direction, p.position, in->intensity, choice, -1, true};
  }

  const Color& Le = scene_.materials[std::size_t(scene_.materialOf(light))].emission;
  if (std::size_t(light) >= scene_.spheres.size()) {
    // An emissive triangle: a direction uniform in its solid angle (or on its area), and the point where it meets
    // the triangle's plane.
    const auto [p0, p1, p2] = scene_.triangleVertices(std::size_t(light) - scene_.spheres.size());
    const std::optional<TriangleLightSample<Real>> ts = sampleTriangleLight(ref, p0, p1, p2, u);
    if (!ts)
      return std::nullopt;
    const Vec3 n = triangleNormal(p0, p1, p2);
    const Real along = glm::dot(ts->wi, n);
    const Real t = along != 0 ? glm::dot(p0 - ref, n) / along : 0;
    const Vec3 target = ref + std::max(Real(0), t) * ts->wi;
    return LightSample{ts->wi, target, Le, choice * ts->pdf, light, false};
  }

  // An emissive sphere: a direction uniform in the cone it subtends, and the point it first hits on the sphere.
  const Sphere& s = scene_.spheres[std::size_t(light)];
  const Vec3 center = s.centerAt(time);
  const Vec3 wi = sampleSphereCone(ref, center, s.radius, u);
  const Real pdf = choice * sphereConePdf(ref, center, s.radius);
  const std::optional<SphereRoots<Real>> roots = intersectSphereRoots(ref, wi, center, s.radius);
  // A direction at the cone's very edge may graze past by rounding: take the closest approach, which is on the
  // sphere to within that rounding. From inside, the far root is the one in front.
  Real t = glm::dot(center - ref, wi);
  if (roots)
    t = roots->t0 >= 0 ? roots->t0 : roots->t1;
  const Vec3 target = ref + std::max(Real(0), t) * wi;
  return LightSample{wi, target, Le, pdf, light, false};
}
// [sample]

// [visibleImpl]
bool lightVisible(const Scene& scene, const Hit& hit, const LightSample& ls)
{
  if (ls.delta)
    return !scene.occluded(spawnRayTo(hit, ls.target));
  // Where the shadow ray first meets the light, from the ray's own origin (the test Scene::intersect makes).
  // Nowhere ahead: the direction leaves the light's own surface, or grazes past its edge by rounding.
  Ray ray = spawnRay(hit, ls.wi);
  const std::optional<Real> t = scene.intersectPrimitive(ray, ls.primitive);
  if (!t)
    return false;
  // Nothing may be met before it: an any-hit query over [0, t), which the light's own root t does not enter.
  ray.tmax = *t;
  return !scene.occluded(ray);
}
// [visibleImpl]

Real LightSampler::pdf(const Vec3& ref, int primitive, const Vec3& point, Real time) const
{
  const Real choice = probability(primitive);
  if (!(choice > 0))
    return 0;
  if (std::size_t(primitive) >= scene_.spheres.size()) {
    const auto [p0, p1, p2] = scene_.triangleVertices(std::size_t(primitive) - scene_.spheres.size());
    return choice * triangleLightPdf(ref, p0, p1, p2, point);
  }
  const Sphere& s = scene_.spheres[std::size_t(primitive)];
  return choice * sphereConePdf(ref, s.centerAt(time), s.radius);
}

} // namespace raylife

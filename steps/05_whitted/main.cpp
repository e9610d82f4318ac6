// Chapter 5 — Whitted ray tracing: mirrors, glass, recursion and anti-aliasing.
//
// Turner Whitted (1980) let a ray that hits a shiny surface go on: a mirror sends it on in the reflected
// direction, glass splits it into a reflected and a refracted ray, and what those rays bring back, weighted,
// is the colour of the point. So trace calls itself. The split at glass follows physics: Snell's law bends
// the refracted ray (η_i sinθ_i = η_t sinθ_t), the Fresnel equations say how much light each ray carries
// (F is reflected, 1 − F transmitted), and past the critical angle inside the glass nothing is transmitted
// at all (total internal reflection). Those building blocks live in common/shading/bsdf.h, because the path tracer of
// chapter 6 uses them again. Diffuse surfaces keep chapter 4's local shading, except that a shadow ray now
// passes through glass, dimmed by Fresnel; glossy surfaces are shaded as diffuse here. A ray that has bounced --max-depth times returns
// black. Each pixel averages --spp rays at stratified jittered positions inside it: anti-aliasing.
#include "shading/bsdf.h"
#include "render/runner.h"
#include "shading/shading.h"

using namespace raylife;

/// [shadow]
// How much of a point light's light reaches `hit` along the straight shadow ray towards it. An opaque sphere in
// the way blocks it (chapter 4); glass lets through, at each surface the ray crosses, the share 1 − F that the
// Fresnel equations transmit, tinted by the glass's colour. This is Whitted's approximation: the shadow ray is
// not bent, so glass casts a lighter shadow rather than a caustic (chapter 6 finds the caustic).
Color shadowTransmittance(const Scene& scene, const Hit& hit, const Vec3& lightPosition)
{
  Color T(1);
  Ray ray = spawnRayTo(hit, lightPosition);
  while (const std::optional<Hit> blocker = scene.intersect(ray)) {
    const Material& m = scene.materials[std::size_t(blocker->material)];
    if (m.type != MaterialType::Glass)
      return Color(0);
    // Fresnel at the crossing, taken as seen from outside (a refracted ray would see the same share).
    T *= m.color * (1 - fresnelDielectric(std::abs(glm::dot(ray.direction, blocker->normal)), m.ior));
    if (T == Color(0))
      return T;
    ray = spawnRayTo(*blocker, lightPosition);
  }
  return T;
}
/// [shadow]

/// [trace]
// The radiance arriving along `ray`, following at most `depthLeft` more reflections or refractions.
Color trace(const Scene& scene, const Ray& ray, Sampler& sampler, int depthLeft)
{
  const std::optional<Hit> hit = scene.intersect(ray);
  if (!hit)
    return scene.escaped(ray.direction);
  const Material& m = scene.materials[std::size_t(hit->material)];

  // Diffuse surfaces (and glossy and metal ones, taken as diffuse): chapter 4's local shading, ambient plus
  // Lambert's law for each light, with the shadow ray now letting light through glass.
  if (m.type == MaterialType::Diffuse || m.type == MaterialType::Glossy || m.type == MaterialType::Metal) {
    const Vec3 N = facingNormal(*hit, ray.direction);
    Color I = m.emission + scene.ambient * m.color;
    for (const PointLight& light : scene.lights) {
      const std::optional<LightArrival> in = light.arrivalAt(hit->point);
      if (in && glm::dot(in->direction, N) > 0)
        I += lambert(m.color, N, *in) * shadowTransmittance(scene, *hit, light.position);
    }
    return I;
  }

  // Mirror and glass send the ray on, unless it has bounced often enough.
  if (depthLeft == 0)
    return m.emission;
  const int next = depthLeft > 0 ? depthLeft - 1 : depthLeft; // −1 stays unlimited
  const Vec3 wo = -ray.direction;
  const Vec3 mirrored = reflect(wo, hit->normal);

  // An ideal mirror: all light comes from the mirror direction, tinted by the mirror's colour.
  if (m.type == MaterialType::Mirror)
    return m.emission + m.color * trace(scene, spawnRay(*hit, mirrored), sampler, next);

  // Glass: the Fresnel reflectance F splits the light between the reflected and the refracted ray; under
  // total internal reflection F = 1 and refract finds no direction, so only the reflected ray is traced.
  const Real F = fresnelDielectric(glm::dot(wo, hit->normal), m.ior);
  Color L(0);
  if (F > 0)
    L += F * trace(scene, spawnRay(*hit, mirrored), sampler, next);
  if (const std::optional<Vec3> refracted = refract(wo, hit->normal, m.ior))
    L += (1 - F) * trace(scene, spawnRay(*hit, *refracted), sampler, next);
  return m.emission + m.color * L;
}
/// [trace]

int main(int argc, char** argv)
{
  /// [chapter]
  const ChapterInfo chapter{.binary = "step05_whitted",
                            .defaultScene = "whitted.json",
                            .uses = kUsesSpheres | kUsesColors | kUsesPointLights | kUsesAmbient | kUsesBackground |
                                    kUsesEnvironment |
                                    kUsesEmission | kUsesMirror | kUsesGlass | kUsesMaxDepth | kShadowRays |
                                    kUsesLens | kUsesMotion,
                            .pixelSampling = PixelSampling::Jittered,
                            .defaultSpp = 16,
                            .defaultMaxDepth = 10,
                            .maxDepthLimit = 1000}; // trace calls itself: its chain of calls fits the stack
  /// [chapter]
  return runChapter(argc, argv, chapter, trace);
}

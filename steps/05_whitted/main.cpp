// Chapter 5 — Whitted ray tracing: mirrors, glass, recursion and anti-aliasing.
//
// Turner Whitted (1980) let a ray that hits a shiny surface go on: a mirror sends it on in the reflected
// direction, glass splits it into a reflected and a refracted ray, and what those rays bring back, weighted,
// is the colour of the point. So trace calls itself. The split at glass follows physics: Snell's law bends
// the refracted ray (η_i sinθ_i = η_t sinθ_t), the Fresnel equations say how much light each ray carries
// (F is reflected, 1 − F transmitted), and past the critical angle inside the glass nothing is transmitted
// at all (total internal reflection). Those building blocks live in common/bsdf.h, because the path tracer of
// chapter 6 uses them again. Diffuse surfaces keep chapter 4's local shading (common/shading.h,
// directLighting); glossy ones are shaded as diffuse here. A ray that has bounced --max-depth times returns
// black. Each pixel averages --spp rays at stratified jittered positions inside it: anti-aliasing.
#include "bsdf.h"
#include "render_loop.h"
#include "shading.h"

using namespace raylife;

/// [trace]
// The radiance arriving along `ray`, following at most `depthLeft` more reflections or refractions.
Color trace(const Scene& scene, const Ray& ray, Sampler& sampler, int depthLeft)
{
  const std::optional<Hit> hit = scene.intersect(ray);
  if (!hit)
    return scene.background;
  const Material& m = scene.materials[std::size_t(hit->material)];

  // Diffuse surfaces (and glossy ones, taken as diffuse): chapter 4's ambient, shadow rays and Lambert.
  if (m.type == MaterialType::Diffuse || m.type == MaterialType::Glossy)
    return m.emission + directLighting(scene, *hit, facingNormal(*hit, ray.direction), m.color);

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
                                    kUsesEmission | kUsesMirror | kUsesGlass | kUsesMaxDepth,
                            .pixelSampling = PixelSampling::Jittered,
                            .defaultSpp = 16,
                            .defaultMaxDepth = 10};
  /// [chapter]
  return runChapter(argc, argv, chapter, trace);
}

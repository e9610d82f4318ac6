// Chapter 4 — the shadow path.
//
// A light counts only if nothing stands between it and the point: trace a shadow ray from the hit point towards
// the light and ask whether anything blocks it (Scene::occluded). The ray must not hit the very surface it
// leaves ("shadow acne"): instead of a fixed epsilon, spawnRayTo (common/geometry/hit.h) moves its origin off the surface
// by a bound on the hit point's floating-point error, which works at every scale. The ambient term keeps the
// shadows from going pitch black.
#include "render/runner.h"
#include "shading/shading.h"

using namespace raylife;

/// [trace]
Color trace(const Scene& scene, const Ray& ray, Sampler& /*sampler*/)
{
  const std::optional<Hit> hit = scene.intersect(ray);
  if (!hit)
    return scene.escaped(ray.direction);

  const Color C = scene.materials[std::size_t(hit->material)].color;
  const Vec3 N = facingNormal(*hit, ray.direction);

  Color I = scene.ambient * C;
  for (const PointLight& light : scene.lights) {
    const std::optional<LightArrival> in = light.arrivalAt(hit->point);
    if (!in || glm::dot(in->direction, N) <= 0)
      continue; // the light is behind the surface: no shadow ray needed
    // The shadow path: is anything between the point and the light?
    if (scene.occluded(spawnRayTo(*hit, light.position)))
      continue;
    I += lambert(C, N, *in);
  }
  return I;
}
/// [trace]

int main(int argc, char** argv)
{
  const ChapterInfo chapter{.binary = "step04_shadows",
                            .defaultScene = "spheres.json",
                            .uses = kUsesSpheres | kUsesColors | kUsesPointLights | kUsesAmbient | kUsesBackground |
                                    kUsesEnvironment |
                                    kShadowRays};
  return runChapter(argc, argv, chapter, trace);
}

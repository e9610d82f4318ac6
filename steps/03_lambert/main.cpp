// Chapter 3 — the surface's colour, and the dot product with the light.
//
// A diffuse (Lambertian) surface looks equally bright from every direction; how bright depends on how squarely
// the light falls on it. The lecture writes this as I_D = (L·N) C I_L: the cosine between the direction to the
// light L and the normal N, times the surface colour C, times the light arriving, I_L (common/shading/shading.h,
// lambert). Add every light's share, and an ambient term for the light that comes from everywhere else.
// Here every light is taken to reach every point: shadows come in chapter 4.
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

  // Ambient term, then Lambert's law summed over the lights.
  Color I = scene.ambient * C;
  for (const PointLight& light : scene.lights)
    if (const std::optional<LightArrival> in = light.arrivalAt(hit->point))
      I += lambert(C, N, *in);
  return I;
}
/// [trace]

int main(int argc, char** argv)
{
  const ChapterInfo chapter{.binary = "step03_lambert",
                            .defaultScene = "spheres.json",
                            .uses = kUsesSpheres | kUsesColors | kUsesPointLights | kUsesAmbient | kUsesBackground |
                                    kUsesEnvironment};
  return runChapter(argc, argv, chapter, trace);
}

// Chapter 11 — distributed ray tracing (Cook, Porter and Carpenter, 1984).
//
// Whitted's rays (chapter 5) are sharp in every way: one ray through the centre of a pinhole, at one instant, to
// one point on each light, in the one mirror direction. Cook's idea is to spread each ray over the dimension it
// was sharp in, and to let each of a pixel's samples pick its own point in every such dimension:
//   - a point on the lens     -> depth of field (the shared camera: Camera::ray(film, lens), a thin lens);
//   - a time in the shutter   -> motion blur (the shared render loop draws Ray::time; a moving sphere is where it
//                                is at that time, in the BVH and in the flat list alike);
//   - a point on an area light -> soft shadows (one light sample per shading point, light_sampling.h);
//   - a direction in the lobe  -> glossy reflection (bsdfSample: the GGX metal, or the Phong glossy lobe).
// The first two happen before trace() is called and apply to every chapter that takes several samples a pixel
// (5 to 8, and this one); the last two are this chapter's trace. Averaged over the pixel's samples, each blur comes
// out right, and no dimension needs more samples than the pixel already takes: the cost is one random number or
// two per dimension, not a grid of rays per effect.
//
// What it is not: a path tracer. A diffuse surface takes its light from the lights directly (plus the ambient
// term standing in for everything else), as in chapter 4; only mirrors, glass and glossy surfaces send a ray on.
#include "core/frame.h"
#include "render/runner.h"
#include "scene/light_sampling.h"
#include "scene/scene_plan.h"
#include "shading/bsdf.h"

using namespace raylife;

/// [trace]
// The radiance arriving along `ray`, following at most `depthLeft` more reflections or refractions (−1: no limit).
Color trace(const LightSampler& lights, const Scene& scene, const Ray& ray, Sampler& sampler, int depthLeft)
{
  const std::optional<Hit> hit = scene.intersect(ray);
  if (!hit)
    return scene.escaped(ray.direction);
  const Material& m = scene.materials[std::size_t(hit->material)];
  const Frame frame = Frame::fromNormal(hit->normal);
  const Vec3 wo = frame.toLocal(-ray.direction);
  // Emission is counted wherever a ray finds it: only the rays below a diffuse surface never look for it.
  Color L = m.emission;

  // A diffuse surface: the ambient term, and the light of one point on one light (chosen by power, a point uniform
  // in the solid angle an area light fills): across the pixel's samples, the points cover the light, and a shadow
  // that covers part of it comes out soft.
  if (m.type == MaterialType::Diffuse) {
    L += scene.ambient * m.color;
    const Real uLight = sampler.next1D();
    const Vec2 uPoint = sampler.next2D();
    if (const std::optional<LightSample> ls = lights.sample(hit->point, uLight, uPoint, hit->time)) {
      const Vec3 wi = frame.toLocal(ls->wi);
      const Color f = bsdfEval(m, wo, wi);
      if (f != Color(0) && lightVisible(scene, *hit, *ls))
        L += f * std::abs(wi.z) * ls->Li / ls->pdf;
    }
    return L;
  }

  // Mirrors, glass, glossy and metal surfaces: one direction from their lobe (the mirror direction itself for a
  // mirror; reflection or refraction chosen by Fresnel for glass; around the mirror direction for a rough surface),
  // weighted by f·cosθ/pdf, and followed. Across the samples, the directions fill the lobe: a blurred reflection.
  if (depthLeft == 0)
    return L;
  const Real uChoice = sampler.next1D();
  const Vec2 u = sampler.next2D();
  const std::optional<BsdfSample> bs = bsdfSample(m, wo, u, uChoice);
  if (!bs)
    return L;
  const int next = depthLeft > 0 ? depthLeft - 1 : depthLeft;
  return L + bs->weight() * trace(lights, scene, spawnRay(*hit, frame.toWorld(bs->wi)), sampler, next);
}
/// [trace]

int main(int argc, char** argv)
{
  /// [chapter]
  const ChapterInfo chapter{.binary = "step11_distributed",
                            .defaultScene = "distributed.json",
                            .uses = kUsesSpheres | kUsesColors | kUsesPointLights | kUsesAmbient | kUsesBackground |
                                    kUsesEnvironment |
                                    kUsesEmission | kUsesMirror | kUsesGlass | kUsesGlossy | kUsesMetal |
                                    kUsesMaxDepth | kUsesLens | kUsesMotion | kSamplesLights,
                            .pixelSampling = PixelSampling::Jittered,
                            .defaultSpp = 64,
                            .defaultMaxDepth = 10,
                            .maxDepthLimit = 1000}; // trace calls itself: its chain of calls fits the stack
  /// [chapter]
  // The light sampler is built once per scene and shared, read-only, by every thread.
  return runChapter(argc, argv, chapter, [](const Scene& scene) -> TraceFunction {
    return [lights = LightSampler(scene)](const Scene& s, const Ray& ray, Sampler& sampler, int maxDepth) {
      return trace(lights, s, ray, sampler, maxDepth);
    };
  });
}

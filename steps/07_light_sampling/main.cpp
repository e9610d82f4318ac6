// Chapter 7 — explicit light sampling (next-event estimation).
//
// Chapter 6 finds light only when a path happens to hit an emitter. A small light is hit rarely, so most paths
// bring back nothing and a few bring back a lot: noise. But at every bounce we know where the lights are, so ask
// them directly. Split the light arriving at x into what comes straight from the emitters (direct lighting) and
// what comes after another bounce (indirect), and estimate each with the sampler that suits it:
//   direct:   pick a point on a light, trace a shadow ray to it, and if nothing blocks it add
//             f_r(x, ωi → ωo) Le cosθi / p(ωi)   (p the density with which the light sampler chose ωi);
//   indirect: go on with the BSDF-sampled direction, as in chapter 6.
// The light sampler (common/scene/light_sampling.h) chooses one light with probability ∝ its power, then a direction
// uniform in the cone the emissive sphere subtends: every such direction sees the light, so an unblocked shadow
// ray always brings back Le, and p is just 1/(solid angle of the light) times the choice probability. A point
// light is a delta light: its one direction, with the inverse-square law, I/r².
// Nothing may be counted twice: light that a BSDF-sampled ray hits is direct light that the light sampler has
// already counted at the previous vertex, so emission is added only where light sampling could not have found it:
// on the camera ray, and after a specular bounce (a mirror or glass has no non-zero f for a sampled direction).
// The background is not sampled as a light, so it is still counted by whatever ray escapes.
#include "shading/bsdf.h"
#include "core/frame.h"
#include "scene/light_sampling.h"
#include "render/guided_lights.h"
#include "render/runner.h"
#include "core/sampling.h"
#include "scene/scene_plan.h"

using namespace raylife;

/// [trace]
// One path's estimate of the radiance arriving along `primary`, of at most `maxDepth` bounces (−1: no limit).
Color trace(const LightSampler& lights, bool sampleLights, const Scene& scene, const Ray& primary, Sampler& sampler,
            int maxDepth)
{
  Color L(0);    // the radiance this path has gathered
  Color beta(1); // its throughput: the product of f·|cosθi|/pdf of the bounces so far
  bool countEmission = true; // the camera ray, or a specular bounce: light sampling could not have found this light
  Ray ray = primary;
  for (int bounce = 0;; ++bounce) {
    // Follow the ray. A ray that leaves the scene sees the background (never light-sampled, so always counted).
    const std::optional<Hit> hit = scene.intersect(ray);
    if (!hit) {
      L += beta * scene.escaped(ray.direction);
      break;
    }
    const Material& m = scene.materials[std::size_t(hit->material)];

    // Le(x, ωo), only where next-event estimation at the previous vertex could not have counted it.
    if (countEmission)
      L += beta * m.emission;
    if (bounce == maxDepth)
      break;
    const Frame frame = Frame::fromNormal(hit->normal);
    const Vec3 wo = frame.toLocal(-ray.direction);

    // Next-event estimation: direct light from one light sample, through a shadow ray (not for delta BSDFs, whose
    // f is 0 for every direction chosen any other way).
    const bool specularSurface = m.type == MaterialType::Mirror || m.type == MaterialType::Glass;
    if (!specularSurface) {
      const Real uLight = sampler.next1D();
      const Vec2 uDirection = sampler.next2D();
      // (The plan: with no light to sample, skip it; the numbers are drawn all the same, so the path is unchanged.)
      if (const std::optional<LightSample> ls =
              sampleLights ? lights.sample(hit->point, uLight, uDirection, hit->time) : std::nullopt) {
        const Vec3 wi = frame.toLocal(ls->wi);
        const Color f = bsdfEval(m, wo, wi);
        if (f != Color(0) && lightVisible(scene, *hit, *ls))
          L += beta * f * std::abs(wi.z) * ls->Li / ls->pdf;
      }
    }

    // The indirect light: choose ωi from the BSDF, as in chapter 6.
    const Real uChoice = sampler.next1D(); // drawn in this order, as in chapter 6
    const Vec2 u = sampler.next2D();
    const std::optional<BsdfSample> bs = bsdfSample(m, wo, u, uChoice);
    if (!bs)
      break;
    beta *= bs->f * std::abs(bs->wi.z) / bs->pdf;
    if (beta == Color(0))
      break; // nothing more can reach the eye along this path
    countEmission = bs->specular;

    // Russian roulette: go on with probability q, and divide by q so that the expectation is unchanged.
    if (bounce >= kRouletteMinBounces) {
      const Real q = rouletteSurvival(beta);
      if (sampler.next1D() >= q)
        break;
      beta /= q;
    }
    ray = spawnRay(*hit, frame.toWorld(bs->wi));
  }
  return L;
}
/// [trace]

int main(int argc, char** argv)
{
  /// [chapter]
  const ChapterInfo chapter{.binary = "step07_light_sampling",
                            .defaultScene = "cornell.json",
                            .uses = kUsesSpheres | kUsesColors | kUsesPointLights | kUsesBackground |
                                    kUsesEnvironment | kUsesEmission |
                                    kUsesMirror | kUsesGlass | kUsesGlossy | kUsesMaxDepth | kSamplesLights |
                                    kUsesMetal | kUsesLens | kUsesMotion,
                            .pixelSampling = PixelSampling::Jittered,
                            .defaultSpp = 64,
                            .defaultMaxDepth = -1,
                            .adaptiveSampling = true,
                            .options = {kGuideOption}};
  /// [chapter]
  // The light sampler is built once per scene, before the render, and shared (read-only) by every thread. By
  // default it first learns where each light is seen (a short pre-pass, the same for every --seed and --threads),
  // so that a lamp mostly hidden behind something is sampled where it shows (docs/07_light_sampling.md).
  // The plan (scene_plan.h): with no emitter and no point light there is nothing to sample, so the trace does BSDF
  // sampling only (exact: the image is the same, bit for bit).
  return runChapter(argc, argv, chapter, [&chapter](const Scene& scene, const ChapterOptions& options) {
    return [lights = makeLightSampler(chapter.binary, scene, options),
            sampleLights = planScene(scene, chapter.uses).lightSampling()](const Scene& s, const Ray& ray,
                                                                           Sampler& sampler, int maxDepth) {
      return trace(lights, sampleLights, s, ray, sampler, maxDepth);
    };
  });
}

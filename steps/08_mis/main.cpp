// Chapter 8 — multiple importance sampling: BRDF sampling against luminaire sampling.
//
// Chapters 6 and 7 each estimate direct light with one strategy, and each fails somewhere. Sampling the BRDF
// (chapter 6) is good on a near-mirror, whose narrow lobe points where the light comes from, and bad under a small
// light, which a rough BRDF's wide lobe rarely finds. Sampling the light (chapter 7) is the opposite: good for a
// small light seen by a rough surface, bad for a large light seen by a near-mirror, where almost every direction
// picked on the light has f ≈ 0 and the few that hit the lobe carry huge weights f/p.
// Veach's multiple importance sampling takes both samples at every non-specular vertex and weights each by how
// well its strategy could produce it. A direction ωi that strategy s drew with pdf p_s, and that the other strategy
// would have drawn with pdf p_t, counts with weight w_s = p_s²/(p_s² + p_t²) (the power heuristic; with --heuristic
// balance, p_s/(p_s + p_t)). For every direction the weights of the two strategies sum to 1, so the sum of the two
// weighted estimates is still unbiased, and each direction is counted mostly by the strategy that samples it well:
//   light sample:   f Le cosθi / p_light · w_light(p_light, p_bsdf)      (a shadow ray, as in chapter 7)
//   BSDF sample:    the path goes on as in chapter 6; if it hits an emitter, add β Le · w_bsdf(p_bsdf, p_light).
// p_light of a BSDF-sampled direction is the pdf the light sampler would have had for it (LightSampler::pdf);
// p_bsdf of a light-sampled direction is the BSDF's own pdf (bsdfPdf). Point lights and the specular BSDFs (mirror,
// glass) are deltas that only one strategy can find, so their samples keep weight 1, as does the background (which
// only BSDF sampling finds, as in chapter 7).
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
Color trace(const LightSampler& lights, bool sampleLights, MisHeuristic heuristic, const Scene& scene,
            const Ray& primary, Sampler& sampler, int maxDepth)
{
  Color L(0);    // the radiance this path has gathered
  Color beta(1); // its throughput: the product of f·|cosθi|/pdf of the bounces so far
  bool specularBounce = true; // the camera ray or a delta lobe: only this path could find what it hits
  Real bsdfPdfPrev = 0;       // the pdf with which the previous vertex's BSDF chose this ray's direction
  Vec3 previousPoint(0);      // that vertex
  Ray ray = primary;
  for (int bounce = 0;; ++bounce) {
    // Follow the ray. A ray that leaves the scene sees the background (only BSDF sampling finds it: weight 1).
    const std::optional<Hit> hit = scene.intersect(ray);
    if (!hit) {
      L += beta * scene.escaped(ray.direction);
      break;
    }
    const Material& m = scene.materials[std::size_t(hit->material)];

    // Le(x, ωo), found by BSDF sampling: weighted against the chance that light sampling found it too.
    if (m.isEmissive()) {
      if (specularBounce)
        L += beta * m.emission;
      else
        L += beta * m.emission *
             misWeight(heuristic, bsdfPdfPrev, lights.pdf(previousPoint, hit->primitive, hit->point, hit->time));
    }
    if (bounce == maxDepth)
      break;
    const Frame frame = Frame::fromNormal(hit->normal);
    const Vec3 wo = frame.toLocal(-ray.direction);

    // Light sampling, as in chapter 7, weighted against the chance that the BSDF chose the same direction.
    const bool specularSurface = m.type == MaterialType::Mirror || m.type == MaterialType::Glass;
    if (!specularSurface) {
      const Real uLight = sampler.next1D();
      const Vec2 uDirection = sampler.next2D();
      // (The plan: with no light to sample, skip it; the numbers are drawn all the same, so the path is unchanged.)
      if (const std::optional<LightSample> ls =
              sampleLights ? lights.sample(hit->point, uLight, uDirection, hit->time) : std::nullopt) {
        const Vec3 wi = frame.toLocal(ls->wi);
        const Color f = bsdfEval(m, wo, wi);
        if (f != Color(0) && lightVisible(scene, *hit, *ls)) {
          const Real weight = ls->delta ? 1 : misWeight(heuristic, ls->pdf, bsdfPdf(m, wo, wi));
          L += beta * f * std::abs(wi.z) * ls->Li * (weight / ls->pdf);
        }
      }
    }

    // BSDF sampling: the path goes on, and remembers the pdf for the emitter it may hit next.
    const Real uChoice = sampler.next1D(); // drawn in this order, as in chapter 6
    const Vec2 u = sampler.next2D();
    const std::optional<BsdfSample> bs = bsdfSample(m, wo, u, uChoice);
    if (!bs)
      break;
    beta *= bs->f * std::abs(bs->wi.z) / bs->pdf;
    if (beta == Color(0))
      break; // nothing more can reach the eye along this path
    specularBounce = bs->specular;
    bsdfPdfPrev = bs->pdf;
    previousPoint = hit->point;

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
  const ChapterInfo chapter{.binary = "step08_mis",
                            .defaultScene = "mis.json",
                            .uses = kUsesSpheres | kUsesColors | kUsesPointLights | kUsesBackground |
                                    kUsesEnvironment | kUsesEmission |
                                    kUsesMirror | kUsesGlass | kUsesGlossy | kUsesMaxDepth | kSamplesLights |
                                    kUsesMetal | kUsesLens | kUsesMotion,
                            .pixelSampling = PixelSampling::Jittered,
                            .defaultSpp = 64,
                            .defaultMaxDepth = -1,
                            .adaptiveSampling = true,
                            .options = {kHeuristicOption, kGuideOption}};
  /// [chapter]
  // The light sampler is built once per scene, before the render, and shared (read-only) by every thread.
  // The plan (scene_plan.h): with no emitter and no point light there is nothing to sample, so the trace does BSDF
  // sampling only (exact: the image is the same, bit for bit).
  auto makeTrace = [&chapter](const Scene& scene, const ChapterOptions& options) -> TraceFunction {
    const MisHeuristic heuristic = heuristicOption(options);
    return [heuristic, lights = makeLightSampler(chapter.binary, scene, options),
            sampleLights = planScene(scene, chapter.uses).lightSampling()](const Scene& s, const Ray& ray,
                                                                           Sampler& sampler, int maxDepth) {
      return trace(lights, sampleLights, heuristic, s, ray, sampler, maxDepth);
    };
  };
  return runChapter(argc, argv, chapter, makeTrace);
}

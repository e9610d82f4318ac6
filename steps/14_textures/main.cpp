// Chapter 14 — textures and environment maps: the surface colour from an image, the sky as a light.
//
// The lecture's third step in the life of a ray is "get surface colour". Until now a material had one colour. Here
// a material's colour (and emission) may be a texture: an image or a checkerboard looked up at the hit's (u, v)
// (Scene::colorAt; the conventions in shading/environment.h and scene.h). An image seen from afar has many texels
// under one pixel, and picking one of them at random is aliasing (moiré): so each ray carries a cone, whose width
// at a hit picks the mip-map level whose texels are that wide (Akenine-Möller et al., Ray Tracing Gems ch. 20).
//
// The second idea: the environment map, the radiance arriving from every direction, is a light like the others.
// A ray that leaves the scene sees it (as chapters 5 to 13 do), and at every vertex the light sample may be drawn
// from it, in proportion to its luminance × sin θ (EnvironmentMap::sample), which finds a small bright sun that BSDF
// sampling almost never hits. It is chosen against the scene's other lights in proportion to power, and weighted
// against BSDF sampling by MIS exactly as chapter 8 weighs an area light:
//   light sample from the map:   f Le cosθi / (c·p_env) · w(c·p_env, p_bsdf), if the shadow ray escapes
//   BSDF sample that escapes:    β Le · w(p_bsdf, c·p_env)
// with c the probability of choosing the map. Everything else is chapter 8's estimator.
#include "shading/bsdf.h"
#include "core/frame.h"
#include "scene/light_sampling.h"
#include "render/guided_lights.h"
#include "render/runner.h"
#include "core/sampling.h"

#include <cmath>

using namespace raylife;

/// [cone]
// A ray cone (Ray Tracing Gems ch. 20): its width at the ray's origin and its spread angle (radians). From the
// camera the width is 0 and the spread one pixel's angle; at each hit the width grows by the spread times the
// distance, and a curved surface widens the spread by twice its curvature times the width (a convex mirror spreads
// a beam). The footprint on the surface is the width over |cos| of the incidence, in texture units the footprint
// times the texture's scale there (Scene::textureScale).
struct Cone {
  Real width = 0;
  Real spread = 0;
};
/// [cone]

// What the trace needs besides the scene: the lights, the environment and the probability of choosing it.
struct Lights {
  const LightSampler* sampler = nullptr;
  const EnvironmentMap* environment = nullptr;
  Real environmentChoice = 0; // the probability that a light sample is drawn from the map
  bool sampleOthers = false;  // whether the scene has other lights to sample
};

/// [trace]
// One path's estimate of the radiance arriving along `primary`, of at most `maxDepth` bounces (−1: no limit).
Color trace(const Lights& lights, MisHeuristic heuristic, Real pixelSpread, const Scene& scene, const Ray& primary,
            Sampler& sampler, int maxDepth)
{
  Color L(0), beta(1);
  bool specularBounce = true;
  Real bsdfPdfPrev = 0;
  Vec3 previousPoint(0);
  Cone cone{0, pixelSpread};
  const Real pickEnv = lights.environmentChoice, pickOther = 1 - pickEnv;
  Ray ray = primary;
  for (int bounce = 0;; ++bounce) {
    const std::optional<Hit> hit = scene.intersect(ray);
    // A ray that leaves the scene sees the environment: weighted against the chance that light sampling drew it.
    if (!hit) {
      if (!lights.environment) {
        L += beta * scene.background;
      } else {
        const Color Le = lights.environment->radiance(ray.direction);
        L += beta * Le *
             (specularBounce ? 1
                             : misWeight(heuristic, bsdfPdfPrev, pickEnv * lights.environment->pdf(ray.direction)));
      }
      break;
    }
    const Material& m = scene.materials[std::size_t(hit->material)];

    // The cone reaches the hit: its footprint there picks the texture's mip-map level.
    cone.width += cone.spread * hit->t;
    const Real cosIncidence = std::max(std::abs(glm::dot(ray.direction, hit->normal)), Real(1e-3));
    const Real footprint = cone.width / cosIncidence * scene.textureScale(hit->primitive, hit->point, hit->time);
    const Color color = scene.colorAt(m, *hit, footprint);

    if (m.isEmissive()) {
      const Color Le = scene.emissionAt(hit->primitive, hit->point, hit->time);
      L += beta * Le *
           (specularBounce ? 1
                           : misWeight(heuristic, bsdfPdfPrev,
                                       pickOther * lights.sampler->pdf(previousPoint, hit->primitive, hit->point,
                                                                       hit->time)));
    }
    if (bounce == maxDepth)
      break;
    const Frame frame = Frame::fromNormal(hit->normal);
    const Vec3 wo = frame.toLocal(-ray.direction);

    // Light sampling: the map with probability pickEnv, else one of the other lights as in chapter 8.
    const bool specularSurface = m.type == MaterialType::Mirror || m.type == MaterialType::Glass;
    if (!specularSurface) {
      const Real uLight = sampler.next1D();
      const Vec2 uDirection = sampler.next2D();
      if (uLight < pickEnv) {
        if (const std::optional<EnvironmentSample> es = lights.environment->sample(uDirection)) {
          const Vec3 wi = frame.toLocal(es->wi);
          const Color f = bsdfEval(m, color, wo, wi);
          const Real pdf = pickEnv * es->pdf;
          if (f != Color(0) && !scene.occluded(spawnRay(*hit, es->wi)))
            L += beta * f * std::abs(wi.z) * es->Le * (misWeight(heuristic, pdf, bsdfPdf(m, wo, wi)) / pdf);
        }
      } else if (lights.sampleOthers) {
        const Real uOther = std::min((uLight - pickEnv) / pickOther, std::nextafter(Real(1), Real(0)));
        if (std::optional<LightSample> ls = lights.sampler->sample(hit->point, uOther, uDirection, hit->time)) {
          ls->pdf *= pickOther;
          if (ls->primitive >= 0) // a textured emitter: its emission where the sample lands
            ls->Li = scene.emissionAt(ls->primitive, ls->target, hit->time);
          const Vec3 wi = frame.toLocal(ls->wi);
          const Color f = bsdfEval(m, color, wo, wi);
          if (f != Color(0) && lightVisible(scene, *hit, *ls)) {
            const Real weight = ls->delta ? 1 : misWeight(heuristic, ls->pdf, bsdfPdf(m, wo, wi));
            L += beta * f * std::abs(wi.z) * ls->Li * (weight / ls->pdf);
          }
        }
      }
    }

    // BSDF sampling: the path goes on, with the textured colour.
    const Real uChoice = sampler.next1D();
    const Vec2 u = sampler.next2D();
    const std::optional<BsdfSample> bs = bsdfSample(m, color, wo, u, uChoice);
    if (!bs)
      break;
    beta *= bs->f * std::abs(bs->wi.z) / bs->pdf;
    if (beta == Color(0))
      break;
    specularBounce = bs->specular;
    bsdfPdfPrev = bs->pdf;
    previousPoint = hit->point;
    cone.spread += 2 * scene.curvature(hit->primitive) * cone.width; // a curved surface spreads the cone

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

namespace {

// The radius of a sphere around the scene's surfaces (centred on their bounding box): an environment map sends
// π R² ∫L dω of power into it, which is what it is weighed by against the scene's own lights.
Real sceneRadius(const Scene& scene)
{
  Vec3 lo(kInfinity), hi(-kInfinity);
  for (const Sphere& s : scene.spheres) {
    lo = glm::min(lo, s.center - Vec3(s.radius));
    hi = glm::max(hi, s.center + Vec3(s.radius));
  }
  for (const Vec3& v : scene.vertices) {
    lo = glm::min(lo, v);
    hi = glm::max(hi, v);
  }
  return glm::length(hi - lo) / 2;
}

} // namespace

int main(int argc, char** argv)
{
  /// [chapter]
  const ChapterInfo chapter{.binary = "step14_textures",
                            .defaultScene = "textures.json",
                            .uses = kUsesSpheres | kUsesColors | kUsesPointLights | kUsesBackground |
                                    kUsesEnvironment | kUsesTextures | kUsesEmission | kUsesMirror | kUsesGlass |
                                    kUsesGlossy | kUsesMaxDepth | kSamplesLights | kUsesMetal | kUsesLens |
                                    kUsesMotion,
                            .pixelSampling = PixelSampling::Jittered,
                            .defaultSpp = 16,
                            .defaultMaxDepth = -1,
                            .options = {kHeuristicOption,
                                        {"--texture-filter", OptionKind::Choice,
                                         "cones: mip-map levels chosen by ray cones; texel: the finest level only",
                                         "", "cones", {"cones", "texel"}}}};
  /// [chapter]
  auto makeTrace = [](const Scene& scene, const ChapterOptions& options) -> TraceFunction {
    auto sampler = std::make_shared<const LightSampler>(scene);
    Lights lights{sampler.get(), scene.environment.get(), 0, !sampler->empty()};
    if (lights.environment && lights.environment->luminanceIntegral() > 0) {
      // Power: the map's into the scene's bounding sphere against the scene's lights'.
      const Real radius = sceneRadius(scene);
      const Real environmentPower = kPi * radius * radius * lights.environment->luminanceIntegral();
      lights.environmentChoice = environmentPower / (environmentPower + sampler->totalPower());
    }
    // One pixel's angle: the camera's vertical field of view over the scene's image height.
    const Real pixelSpread = options.choice("--texture-filter") == "cones"
                                 ? 2 * std::tan(scene.camera.vfovDeg * kPi / 360) / Real(scene.camera.height)
                                 : 0;
    return [lights, sampler, heuristic = heuristicOption(options), pixelSpread](
               const Scene& s, const Ray& ray, Sampler& rng, int maxDepth) {
      return trace(lights, heuristic, pixelSpread, s, ray, rng, maxDepth);
    };
  };
  return runChapter(argc, argv, chapter, makeTrace);
}

// Chapter 15 — participating media: light that scatters in fog, smoke and milk, not only at surfaces.
//
// Until now light travelled through vacuum between surfaces. In a medium it is absorbed (σa), scattered away
// (σs; together the extinction σt = σa + σs) and scattered in from other directions by the phase function p. The
// radiative transfer equation adds, along a ray of length up to the surface at distance s,
//   L(x, ω) = Tr(x, x_s) L_surface(x_s, −ω) + ∫₀ˢ Tr(x, x_t) σs ∫ p(ω, ω') L(x_t, ω') dω' dt,
// Tr = exp(−σt·t) being Beer–Lambert's transmittance. A path tracer estimates it with one more kind of vertex:
//   - free flight: sample a distance t with density ∝ σt e^{−σt t} (sampleFreeFlight, medium.h). If t comes before
//     the surface, the path scatters there (a medium vertex, one bounce); else it reaches the surface. The weights
//     make both cases unbiased, also for coloured media (one channel chosen, its pdf averaged over the three);
//   - at a medium vertex, next-event estimation exactly as at a surface, with the phase function in the place of
//     f·cosθ and the shadow ray's transmittance through every medium it crosses in the place of visibility;
//     MIS against sampling the phase function (which is how the path goes on);
//   - a shape whose material is an `interface` is no surface at all: crossing it changes only the medium. It is
//     not a bounce. Glass with a medium inside (a glass of milk) refracts at its surface and scatters inside.
// The medium a ray travels in is carried along the path (medium_tracking.h): the camera's, then at each crossing
// the one on the side the new direction leaves towards.
// The surface estimator is chapter 8's, unchanged: a scene without media renders as chapter 8 renders it.
#include "shading/bsdf.h"
#include "core/frame.h"
#include "scene/light_sampling.h"
#include "scene/medium_tracking.h"
#include "render/guided_lights.h"
#include "render/runner.h"
#include "core/sampling.h"

using namespace raylife;

/// [trace]
// One path's estimate of the radiance arriving along `primary`, of at most `maxDepth` bounces (−1: no limit); a
// bounce is a surface vertex or a scattering event. `mediumLights` false samples the phase function alone at
// scattering events (no light sampling there), for comparison.
Color trace(const LightSampler& lights, MisHeuristic heuristic, bool mediumLights, const Scene& scene,
            const Ray& primary, Sampler& sampler, int maxDepth)
{
  Color L(0);    // the radiance this path has gathered
  Color beta(1); // its throughput
  bool specularBounce = true; // the camera ray or a delta lobe: only this path could find what it hits
  Real pdfPrev = 0;           // the solid-angle pdf with which the previous vertex chose this ray's direction
  Vec3 previousPoint(0);      // that vertex (on a surface or in a medium)
  int medium = scene.cameraMedium; // the medium the ray travels in
  int crossings = 0;          // interfaces crossed since the last vertex
  Ray ray = primary;
  for (int depth = 0;;) {
    const std::optional<Hit> hit = scene.intersect(ray);
    medium = segmentMedium(scene, hit, ray, medium); // the side of the boundary it arrives at (medium_tracking.h)

    // In a medium, free flight decides whether the ray scatters before the surface (or the sky).
    if (medium != kVacuum) {
      const Medium& md = scene.media[std::size_t(medium)];
      const Real tSurface = hit ? hit->t : kInfinity;
      FreeFlight flight;
      if (md.density) { // heterogeneous: delta tracking against the majorants (density_grid.h)
        const TrackedFlight tracked = deltaTrack(*md.density, md.globalMajorant, md.sigmaA, md.sigmaS, ray, tSurface, sampler);
        flight = FreeFlight{tracked.scattered, tracked.t, tracked.weight};
      } else {
        const Real uChannel = sampler.next1D();
        flight = sampleFreeFlight(md.sigmaA, md.sigmaS, tSurface, uChannel, sampler.next1D());
      }
      beta *= flight.weight;
      if (beta == Color(0))
        break;
      if (flight.scattered) {
        if (depth == maxDepth)
          break; // a scattering event is a bounce, and the path has made all it may
        const Vec3 p = ray.at(flight.t);
        // Light sampling from the medium point: the phase function in the place of f·cosθ, transmittance in the
        // place of visibility, MIS against phase sampling.
        const Real uLight = sampler.next1D();
        const Vec2 uDirection = sampler.next2D();
        if (mediumLights)
          if (const std::optional<LightSample> ls = lights.sample(p, uLight, uDirection, ray.time)) {
            const Real phase = hgPhase(glm::dot(ray.direction, ls->wi), md.g);
            const Color tr = shadowTransmittance(scene, p, ray.time, medium, *ls, sampler);
            if (tr != Color(0)) {
              const Real weight = ls->delta ? 1 : misWeight(heuristic, ls->pdf, phase);
              L += beta * tr * phase * ls->Li * (weight / ls->pdf);
            }
          }
        // Phase sampling: the path goes on; p/pdf = 1, so the throughput keeps its value.
        const PhaseSample ps = sampleHg(ray.direction, md.g, sampler.next2D());
        specularBounce = !mediumLights; // without light sampling here, an emitter found next keeps weight 1
        pdfPrev = ps.pdf;
        previousPoint = p;
        if (depth >= kRouletteMinBounces) {
          const Real q = rouletteSurvival(beta);
          if (sampler.next1D() >= q)
            break;
          beta /= q;
        }
        ++depth;
        crossings = 0;
        ray = Ray{p, ps.wi, 0, kInfinity, ray.time};
        continue;
      }
    }

    // The ray reached the surface (or left the scene) through its medium.
    if (!hit) {
      L += beta * scene.escaped(ray.direction); // (the environment map where the scene has one)
      break;
    }
    const Material& m = scene.materials[std::size_t(hit->material)];
    if (m.type == MaterialType::Interface) {
      // Not a surface: the ray goes on in the medium on the far side, and it is not a bounce.
      if (++crossings > kMaxMediumCrossings)
        break;
      medium = mediumAfter(scene, *hit, ray.direction, medium);
      ray = spawnRay(*hit, ray.direction);
      continue;
    }
    crossings = 0;

    // From here on, chapter 8's surface vertex, with transmittance in the place of visibility.
    if (m.isEmissive()) {
      if (specularBounce)
        L += beta * m.emission;
      else
        L += beta * m.emission *
             misWeight(heuristic, pdfPrev, lights.pdf(previousPoint, hit->primitive, hit->point, hit->time));
    }
    if (depth == maxDepth)
      break;
    const Frame frame = Frame::fromNormal(hit->normal);
    const Vec3 wo = frame.toLocal(-ray.direction);

    const bool specularSurface = m.type == MaterialType::Mirror || m.type == MaterialType::Glass;
    if (!specularSurface) {
      const Real uLight = sampler.next1D();
      const Vec2 uDirection = sampler.next2D();
      if (const std::optional<LightSample> ls = lights.sample(hit->point, uLight, uDirection, hit->time)) {
        const Vec3 wi = frame.toLocal(ls->wi);
        const Color f = bsdfEval(m, wo, wi);
        if (f != Color(0)) {
          const Color tr = shadowTransmittance(scene, *hit, mediumAfter(scene, *hit, ls->wi, medium), *ls, sampler);
          if (tr != Color(0)) {
            const Real weight = ls->delta ? 1 : misWeight(heuristic, ls->pdf, bsdfPdf(m, wo, wi));
            L += beta * tr * f * std::abs(wi.z) * ls->Li * (weight / ls->pdf);
          }
        }
      }
    }

    const Real uChoice = sampler.next1D();
    const Vec2 u = sampler.next2D();
    const std::optional<BsdfSample> bs = bsdfSample(m, wo, u, uChoice);
    if (!bs)
      break;
    beta *= bs->f * std::abs(bs->wi.z) / bs->pdf;
    if (beta == Color(0))
      break;
    specularBounce = bs->specular;
    pdfPrev = bs->pdf;
    previousPoint = hit->point;
    if (depth >= kRouletteMinBounces) {
      const Real q = rouletteSurvival(beta);
      if (sampler.next1D() >= q)
        break;
      beta /= q;
    }
    ++depth;
    const Vec3 wi = frame.toWorld(bs->wi);
    medium = mediumAfter(scene, *hit, wi, medium); // refracted into a glass of milk: in the milk now
    ray = spawnRay(*hit, wi);
  }
  return L;
}
/// [trace]

int main(int argc, char** argv)
{
  /// [chapter]
  const ChapterOption mediumSampling{.name = "--medium-sampling",
                                     .kind = OptionKind::Choice,
                                     .help = "at a scattering event, sample the lights and the phase function with "
                                             "MIS (mis), or the phase function alone (phase)",
                                     .defaultValue = "mis",
                                     .choices = {"mis", "phase"}};
  const ChapterInfo chapter{.binary = "step15_volumes",
                            .defaultScene = "volumes.json",
                            .uses = kUsesSpheres | kUsesColors | kUsesPointLights | kUsesBackground | kUsesEmission |
                                    kUsesMirror | kUsesGlass | kUsesGlossy | kUsesMaxDepth | kSamplesLights |
                                    kUsesMetal | kUsesLens | kUsesMotion | kUsesMedia | kUsesEnvironment,
                            .pixelSampling = PixelSampling::Jittered,
                            .defaultSpp = 64,
                            .defaultMaxDepth = -1,
                            .options = {kHeuristicOption, mediumSampling}};
  /// [chapter]
  // The light sampler (unguided: chapter 8's guide learns from paths that know no media) is built once per scene.
  auto makeTrace = [](const Scene& scene, const ChapterOptions& options) -> TraceFunction {
    return [heuristic = heuristicOption(options), mediumLights = options.choice("--medium-sampling") == "mis",
            lights = LightSampler(scene)](const Scene& s, const Ray& ray, Sampler& sampler, int maxDepth) {
      return trace(lights, heuristic, mediumLights, s, ray, sampler, maxDepth);
    };
  };
  return runChapter(argc, argv, chapter, makeTrace);
}

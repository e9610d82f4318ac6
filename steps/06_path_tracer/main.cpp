// Chapter 6 — the path tracer: the rendering equation solved by Monte Carlo.
//
// The light leaving a point x towards ωo is what x emits plus what it reflects of the light arriving from
// every direction of the hemisphere:
//   L(x, ωo) = Le(x, ωo) + ∫ f_r(x, ωi → ωo) L(x', ωi) cosθi dωi,
// where x' is the first surface seen from x along ωi (the lecture's G and V: with the integral over solid
// angle, the geometry term is the cosine, and visibility is built in, because L(x', ωi) comes from whatever
// the ray along ωi hits first). The integral has L on both sides, so estimate it by Monte Carlo: pick one
// direction ωi with probability density p(ωi), trace a ray there, and weight what it brings back by
// f_r·cosθi / p. Repeating that at each hit builds a path from the eye, and the path's throughput β is the
// product of those weights. The BSDFs, their samplers and pdfs (Lambertian, mirror, glass, normalised Phong)
// are in common/shading/bsdf.h; each is sampled in proportion to (nearly) f·cosθ, so the weight stays near the albedo.
// Light enters the estimate only where a path hits an emitter (an emissive sphere: an area light, so shadows
// are soft) or leaves the scene (the background is an environment that emits). Point lights are not used:
// a path can never hit a point. Russian roulette ends long paths at random without bias, so the default
// --max-depth is unlimited.
#include "shading/bsdf.h"
#include "core/frame.h"
#include "render/runner.h"
#include "core/sampling.h"

using namespace raylife;

/// [trace]
// One path's estimate of the radiance arriving along `primary`, of at most `maxDepth` bounces (−1: no limit).
Color trace(const Scene& scene, const Ray& primary, Sampler& sampler, int maxDepth)
{
  Color L(0);    // the radiance this path has gathered
  Color beta(1); // its throughput: the product of f·|cosθi|/pdf of the bounces so far
  Ray ray = primary;
  for (int bounce = 0;; ++bounce) {
    // Follow the ray. A ray that leaves the scene sees the background, an environment that emits.
    const std::optional<Hit> hit = scene.intersect(ray);
    if (!hit) {
      L += beta * scene.escaped(ray.direction);
      break;
    }
    const Material& m = scene.materials[std::size_t(hit->material)];

    // Le(x, ωo): what the surface emits towards the path (on both sides, so the inside of a lamp glows too).
    L += beta * m.emission;
    if (bounce == maxDepth)
      break;

    // The integral, by one sample: choose ωi from the BSDF, in the local frame around the outward normal.
    const Frame frame = Frame::fromNormal(hit->normal);
    const Vec3 wo = frame.toLocal(-ray.direction);
    // Its random numbers are drawn one statement at a time: C++ leaves the order in which a call's arguments are
    // evaluated open (GCC and clang differ), and the image must not depend on the compiler.
    const Real uChoice = sampler.next1D();
    const Vec2 u = sampler.next2D();
    const std::optional<BsdfSample> bs = bsdfSample(m, wo, u, uChoice);
    if (!bs)
      break;
    beta *= bs->f * std::abs(bs->wi.z) / bs->pdf;
    if (beta == Color(0))
      break; // nothing more can reach the eye along this path

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
  const ChapterInfo chapter{.binary = "step06_path_tracer",
                            .defaultScene = "cornell_large_lamp.json",
                            .uses = kUsesSpheres | kUsesColors | kUsesBackground |
                                    kUsesEnvironment | kUsesEmission | kUsesMirror |
                                    kUsesGlass | kUsesGlossy | kUsesMaxDepth | kUsesMetal |
                                    kUsesLens | kUsesMotion,
                            .pixelSampling = PixelSampling::Jittered,
                            .defaultSpp = 128,
                            .defaultMaxDepth = -1,
                            .adaptiveSampling = true};
  /// [chapter]
  return runChapter(argc, argv, chapter, trace);
}

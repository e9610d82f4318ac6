// Chapter 12 — ambient occlusion.
//
// Chapter 3's ambient term lights every point alike: a crevice as much as an open floor. The path tracer
// (chapter 6) knows better, at a price: light arrives at x from every direction of its hemisphere, from whatever
// the ray in that direction meets. Ambient occlusion keeps one part of that answer, the cheap part: how much of
// the hemisphere is open. With the sky a uniform white of radiance 1 and every surface black, the light reflected
// by a white Lambertian point is exactly
//   AO(x) = (1/π) ∫ V(x, ω) cosθ dω    over the hemisphere around the normal,
// V(x, ω) = 1 when the ray from x in direction ω escapes (or, with --ao-distance D, meets nothing closer than D)
// and 0 when it is blocked. An open plane gives 1, a point in a corner less, a point inside a closed sphere 0.
// It is estimated like any integral of chapter 6: with directions drawn in proportion to cosθ (pdf cosθ/π), each
// sample's weight (1/π)·V·cosθ / (cosθ/π) is just V, so each sample is one shadow ray, and the pixel averages them.
// Renderers multiply it into the ambient term (a darker ambient where little sky is seen); here it is the image.
#include "core/frame.h"
#include "core/sampling.h"
#include "render/runner.h"

#include <limits>

using namespace raylife;

/// [trace]
// The ambient occlusion seen along `ray`: a miss shows the background, a hit the share of its hemisphere (cosine
// weighted) that is open within `maxDistance`, as grey.
Color trace(Real maxDistance, const Scene& scene, const Ray& ray, Sampler& sampler)
{
  const std::optional<Hit> hit = scene.intersect(ray);
  if (!hit)
    return scene.escaped(ray.direction);
  // The hemisphere on the side the ray came from (a sphere's inside, seen from inside, is occluded from inside).
  const Vec3 n = glm::dot(hit->normal, ray.direction) < 0 ? hit->normal : -hit->normal;
  // One direction, cosine-weighted, and its shadow ray: the sample is V itself.
  const Vec3 wi = Frame::fromNormal(n).toWorld(sampleCosineHemisphere(sampler.next2D()));
  // (D counts from the hit point, not from the ray's origin, which sits off the surface by the point's error bound:
  // some 0.03 units on a sphere of radius 10⁵ in the float build.)
  Ray probe = spawnRay(*hit, wi);
  probe.tmax = maxDistance - glm::dot(probe.origin - hit->point, wi);
  return scene.occluded(probe) ? Color(0) : Color(1);
}
/// [trace]

int main(int argc, char** argv)
{
  /// [chapter]
  const ChapterInfo chapter{.binary = "step12_ambient_occlusion",
                            .defaultScene = "meshes.json",
                            .uses = kUsesSpheres | kUsesBackground | kUsesEnvironment | kUsesLens | kUsesMotion,
                            .pixelSampling = PixelSampling::Jittered,
                            .defaultSpp = 64,
                            .options = {{.name = "--ao-distance",
                                         .kind = OptionKind::Number,
                                         .help = "only what lies within D scene units occludes (inf: all)",
                                         .metavar = "D",
                                         .defaultValue = "inf",
                                         .min = 1e-9, // (a distance > 0)
                                         .max = std::numeric_limits<double>::infinity()}}};
  /// [chapter]
  return runChapter(argc, argv, chapter, [](const Scene&, const ChapterOptions& options) -> TraceFunction {
    const Real maxDistance = Real(options.number("--ao-distance"));
    return [maxDistance](const Scene& scene, const Ray& ray, Sampler& sampler, int) {
      return trace(maxDistance, scene, ray, sampler);
    };
  });
}

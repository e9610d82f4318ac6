// Chapter 2 — intersect the ray with the spheres.
//
// A ray p = o + t·d meets a sphere (p − c)² = r² where (o + t·d − c)² − r² = 0, a quadratic in t
// (common/geometry/sphere.h solves it in a numerically careful form). The nearest hit with t in the ray's interval wins
// (Scene::intersect), and its unit normal is n = (p − c)/r. This chapter paints each pixel with the normal of
// what its ray hits first.
#include "render/runner.h"

using namespace raylife;

/// [trace]
Color trace(const Scene& scene, const Ray& ray, Sampler& /*sampler*/)
{
  const std::optional<Hit> hit = scene.intersect(ray);
  if (!hit)
    return scene.background; // the ray left the scene

  // The outward unit normal has components in [−1, 1]; (n + 1)/2 shows them as colour.
  return (hit->normal + Real(1)) / Real(2);
}
/// [trace]

int main(int argc, char** argv)
{
  const ChapterInfo chapter{
      .binary = "step02_sphere", .defaultScene = "spheres.json", .uses = kUsesSpheres | kUsesBackground};
  return runChapter(argc, argv, chapter, trace);
}

// Chapter 9 — acceleration structures: a bounding volume hierarchy.
//
// Until now every ray was tested against every sphere: N tests per ray, fine for five spheres and hopeless for
// half a million. A bounding volume hierarchy (common/geometry/bvh.h) puts the spheres in boxes, the boxes in bigger
// boxes, up to one box around the scene; a ray that misses a box skips all it holds. The tree is built with the
// surface area heuristic, which prices each way of splitting a node's spheres in two by the chance that a ray
// hitting the node hits each half (the ratio of their surface areas) and takes the cheapest; the nodes are
// flattened into one array, visited front to back, and a shadow ray stops at its first blocker.
//
// The scene uses the tree from here on, in every chapter: Scene::intersect and Scene::occluded answer through it
// when the scene has more than kFlatListMaxPrimitives spheres (below that a plain loop is faster), with exactly the
// answers of the loop, so no earlier chapter's image changes.
//
// This chapter's picture is the work itself: on the left the scene as chapter 4 shades it, on the right each
// pixel's work, the boxes and spheres its camera ray and shadow rays tested, on a logarithmic colour scale
// (common/render/heat_map.h): black is one test, pale yellow four thousand, as the scale drawn under it says.
#include "render/heat_map.h"
#include "render/runner.h"
#include "shading/shading.h"

using namespace raylife;

/// [shade]
// The left image: chapter 4's shading (ambient plus Lambert for every light the shadow ray finds unblocked),
// standing in for the path tracer until chapter 6 is in place.
Color shade(const Scene& scene, const Ray& ray, Sampler& /*sampler*/)
{
  const std::optional<Hit> hit = scene.intersect(ray);
  if (!hit)
    return scene.escaped(ray.direction);
  const Color C = scene.materials[std::size_t(hit->material)].color;
  const Vec3 N = facingNormal(*hit, ray.direction);
  Color I = scene.ambient * C;
  for (const PointLight& light : scene.lights) {
    const std::optional<LightArrival> in = light.arrivalAt(hit->point);
    if (in && glm::dot(in->direction, N) > 0 && !scene.occluded(spawnRayTo(*hit, light.position)))
      I += lambert(C, N, *in);
  }
  return I;
}
/// [shade]

/// [work]
// The right image: the same rays as the left, traced through the queries that also count their work. The
// camera ray asks for the nearest hit; each shadow ray only asks whether anything is in the way, and stops at
// the first sphere that is.
Color work(const Scene& scene, const Ray& ray, Sampler& /*sampler*/)
{
  const TracedHit camera = scene.intersectWithWork(ray);
  BvhWork total = camera.work;
  if (camera.hit) {
    const Vec3 N = facingNormal(*camera.hit, ray.direction);
    for (const PointLight& light : scene.lights) {
      const std::optional<LightArrival> in = light.arrivalAt(camera.hit->point);
      if (in && glm::dot(in->direction, N) > 0)
        total = total + scene.occludedWithWork(spawnRayTo(*camera.hit, light.position)).work;
    }
  }
  return heatColor(workCost(total));
}
/// [work]

int main(int argc, char** argv)
{
  const ChapterInfo chapter{.binary = "step09_bvh",
                            .defaultScene = "random_diffuse.json",
                            .uses = kUsesSpheres | kUsesColors | kUsesPointLights | kUsesAmbient | kUsesBackground |
                                    kUsesEnvironment |
                                    kShadowRays,
                            .besideTrace = [](const Scene& s, const Ray& r, Sampler& sampler, int) {
                              return work(s, r, sampler);
                            },
                            // The heat map's colour scale, under the right image.
                            .annotate = [](Image& image) { drawHeatLegend(image, image.width / 2, image.width); }};
  return runChapter(argc, argv, chapter, shade);
}

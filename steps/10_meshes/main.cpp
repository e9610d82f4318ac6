// Chapter 10 — triangle meshes.
//
// Real models are not spheres: they are meshes, thousands of triangles sharing their edges and corners, read from
// files (OBJ, PLY). What a triangle brings is in common/, where every chapter uses it from now on:
//  - the watertight ray–triangle test (common/geometry/triangle.h): the ray is moved to the origin and sheared into
//    the z axis, and "is it inside" becomes three 2-D edge functions whose signs two triangles that share an edge
//    compute from the same two corners, so no ray slips through a closed mesh between them;
//  - the hit's barycentric coordinates (b0, b1, b2): where in the triangle the ray struck, which give the point
//    (with its error bound) and, on a smooth mesh, the normal interpolated from the corners' normals;
//  - a BVH over the triangles (and spheres) of the scene, and triangle lights sampled by the solid angle they fill.
//
// This chapter's picture shows what a mesh is made of and how it is shaded: on the left every triangle in a colour
// of its own, lit by its flat, geometric normal, so the facets show; on the right the same rays shaded with the
// normal the hit reports, interpolated across each triangle of a smooth mesh, so the facets melt into a surface.
// Both are lit by a lamp at the eye (the light falls as the cosine between the normal and the ray): the shapes,
// not the lighting, are the point here. Chapters 6 to 8 path trace the same scene (the chapter's page shows it).
#include "render/runner.h"

#include <cstdint>

using namespace raylife;

namespace {

// A colour for triangle `index` (an index into Scene::triangles): a hash spread over the hues, pale enough to mix
// with the material's colour. (The golden ratio's steps keep neighbouring indices' hues far apart.)
Color triangleColor(std::size_t index)
{
  const Real hue = std::fmod(Real(index) * Real(0.6180339887498949), Real(1));
  const SinCos<Real> a = sinCos2Pi(hue);
  return Color(Real(0.6) + Real(0.4) * a.cos, Real(0.6) + Real(0.4) * a.sin, Real(0.6) - Real(0.4) * a.cos);
}

// The lamp at the eye: the material's colour (white for an emitter) times the cosine between `normal` and the ray,
// with a floor so that surfaces seen edge on do not vanish.
Color headlight(const Scene& scene, const Hit& hit, const Vec3& normal, const Vec3& direction)
{
  const Material& m = scene.materials[std::size_t(hit.material)];
  const Color C = m.isEmissive() ? Color(1) : m.color;
  return C * (Real(0.15) + Real(0.85) * std::abs(glm::dot(normal, direction)));
}

} // namespace

/// [facets]
// The left image: each triangle its own colour, shaded with its geometric normal, the same for the whole triangle.
Color facets(const Scene& scene, const Ray& ray, Sampler& /*sampler*/)
{
  const std::optional<Hit> hit = scene.intersect(ray);
  if (!hit)
    return scene.escaped(ray.direction);
  const Color shade = headlight(scene, *hit, hit->geometricNormal, ray.direction);
  // A sphere is one piece; a triangle (numbered after the spheres) gets its colour.
  if (std::size_t(hit->primitive) < scene.spheres.size())
    return shade;
  return shade * triangleColor(std::size_t(hit->primitive) - scene.spheres.size());
}
/// [facets]

/// [smooth]
// The right image: the same rays shaded with the hit's shading normal, which on a smooth mesh is interpolated from
// its corners' normals by the barycentric coordinates of the hit (Scene::intersect does it, for every chapter).
Color smooth(const Scene& scene, const Ray& ray, Sampler& /*sampler*/)
{
  const std::optional<Hit> hit = scene.intersect(ray);
  if (!hit)
    return scene.escaped(ray.direction);
  return headlight(scene, *hit, hit->normal, ray.direction);
}
/// [smooth]

int main(int argc, char** argv)
{
  const ChapterInfo chapter{.binary = "step10_meshes",
                            .defaultScene = "meshes.json",
                            .uses = kUsesSpheres | kUsesColors | kUsesBackground | kUsesEnvironment | kUsesEmission,
                            .besideTrace = [](const Scene& s, const Ray& r, Sampler& sampler, int) {
                              return smooth(s, r, sampler);
                            }};
  return runChapter(argc, argv, chapter, facets);
}

#include "scene/scene.h"
#include "shading/shading.h"

#include <catch2/catch.hpp>

using namespace raylife;

TEST_CASE("Lambert's law: I_D = max(0 - L·N) C I_L with I_L = I / r²")
{
  const PointLight light{Vec3(0, 4, 3), Color(50, 25, 100)};
  const auto in = light.arrivalAt(Vec3(0));
  REQUIRE(in);
  CHECK(in->distance == Approx(5));
  CHECK(glm::length(in->direction - Vec3(0, 0.8, 0.6)) < 1e-6);
  CHECK(in->intensity.r == Approx(2)); // 50 / 25
  const Color C(0.5, 0.2, 1.0);
  const Vec3 N(0, 1, 0);
  const Color I = lambert(C, N, *in);
  CHECK(I.r == Approx(0.8 * 0.5 * 2));
  CHECK(I.g == Approx(0.8 * 0.2 * 1));
  CHECK(I.b == Approx(0.8 * 1.0 * 4));
  // Light from behind the surface contributes nothing.
  CHECK(lambert(C, -N, *in) == Color(0));
  // A light at the shaded point itself has no direction: no arrival, not a NaN.
  CHECK_FALSE(light.arrivalAt(light.position));
}

TEST_CASE("the facing normal turns towards the viewer")
{
  Hit hit;
  hit.normal = Vec3(0, 0, 1);
  CHECK(facingNormal(hit, Vec3(0, 0, -1)) == Vec3(0, 0, 1)); // seen from outside
  CHECK(facingNormal(hit, Vec3(0, 0, 1)) == Vec3(0, 0, -1)); // seen from inside
}

TEST_CASE("a shadow ray is blocked by a sphere between the point and the light and only then")
{
  Scene scene;
  scene.materials.push_back(Material{});
  scene.spheres.push_back(Sphere{Vec3(0, -100, 0), 100, 0}); // the ground, its top at y = 0
  const auto hit = scene.intersect(Ray{Vec3(0, 5, 0), Vec3(0, -1, 0)});
  REQUIRE(hit);
  const Vec3 light(0, 10, 0);
  CHECK_FALSE(scene.occluded(spawnRayTo(*hit, light))); // nothing in the way, and no self-shadowing

  scene.spheres.push_back(Sphere{Vec3(0, 5, 0), 1, 0}); // a ball between the ground and the light
  CHECK(scene.occluded(spawnRayTo(*hit, light)));
  // A ball beyond the light does not shadow.
  scene.spheres.back().center = Vec3(0, 20, 0);
  CHECK_FALSE(scene.occluded(spawnRayTo(*hit, light)));
  // A ball beside the path does not shadow.
  scene.spheres.back().center = Vec3(3, 5, 0);
  CHECK_FALSE(scene.occluded(spawnRayTo(*hit, light)));
  // A light exactly on a sphere's surface is not shadowed by that sphere (the ray stops short of it).
  scene.spheres.back().center = Vec3(0, 11, 0);
  CHECK_FALSE(scene.occluded(spawnRayTo(*hit, light)));
}

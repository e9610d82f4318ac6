#include "scene.h"
#include "sphere.h"

#include <catch2/catch.hpp>

using namespace raylife;

namespace {
Scene oneSphere(const Vec3& c, Real r)
{
  Scene scene;
  scene.materials.push_back(Material{});
  scene.spheres.push_back(Sphere{c, r, 0});
  return scene;
}
const Real kTol = 1e3 * std::numeric_limits<Real>::epsilon();
} // namespace

TEST_CASE("a ray through the centre hits the near side at the expected distance")
{
  const Scene scene = oneSphere(Vec3(0, 0, -10), 2);
  const auto hit = scene.intersect(Ray{Vec3(0), Vec3(0, 0, -1)});
  REQUIRE(hit);
  CHECK(hit->t == Approx(8).epsilon(kTol));
  CHECK(glm::length(hit->point - Vec3(0, 0, -8)) < kTol);
  CHECK(glm::length(hit->normal - Vec3(0, 0, 1)) < kTol); // n = (p − c)/r
  CHECK(hit->sphere == 0);
  CHECK(hit->frontFace(Vec3(0, 0, -1)));
}

TEST_CASE("the normal is (p − c)/r - unit length - at off-centre hits")
{
  const Vec3 c(1, 2, -7);
  const Real r = 3;
  const Scene scene = oneSphere(c, r);
  const Vec3 d = glm::normalize(Vec3(0.1, 0.25, -1));
  const auto hit = scene.intersect(Ray{Vec3(0), d});
  REQUIRE(hit);
  CHECK(glm::length(hit->normal) == Approx(1).epsilon(kTol));
  CHECK(glm::length(hit->normal - (hit->point - c) / r) < kTol);
  CHECK(glm::length(hit->point - c) == Approx(r).epsilon(kTol));
  CHECK(glm::length(hit->point - d * hit->t) < kTol * 10);
}

TEST_CASE("misses - a sphere behind the ray and the ray's interval")
{
  const Scene scene = oneSphere(Vec3(0, 0, -10), 1);
  CHECK_FALSE(scene.intersect(Ray{Vec3(0), glm::normalize(Vec3(0, 1, -5))})); // passes above
  CHECK_FALSE(scene.intersect(Ray{Vec3(0), Vec3(0, 0, 1)}));                  // sphere behind
  CHECK_FALSE(scene.intersect(Ray{Vec3(0), Vec3(0, 0, -1), 0, 8}));           // tmax before the sphere
  const auto far = scene.intersect(Ray{Vec3(0), Vec3(0, 0, -1), 9.5, kInfinity}); // tmin past the near side
  REQUIRE(far);
  CHECK(far->t == Approx(11));
}

TEST_CASE("a tangent ray touches the sphere once - a ray just outside misses")
{
  const auto roots = intersectSphereRoots<double>(glm::dvec3(-5, 1, 0), glm::dvec3(1, 0, 0), glm::dvec3(0), 1.0);
  REQUIRE(roots);
  CHECK(roots->t0 == Approx(5));
  CHECK(roots->t1 == Approx(5));
  CHECK_FALSE(intersectSphereRoots<double>(glm::dvec3(-5, 1 + 1e-9, 0), glm::dvec3(1, 0, 0), glm::dvec3(0), 1.0));
  CHECK(intersectSphereRoots<double>(glm::dvec3(-5, 1 - 1e-9, 0), glm::dvec3(1, 0, 0), glm::dvec3(0), 1.0));
}

TEST_CASE("a ray starting inside the sphere hits its far side - from inside")
{
  const Scene scene = oneSphere(Vec3(0), 2);
  const auto hit = scene.intersect(Ray{Vec3(0.5, 0, 0), Vec3(1, 0, 0)});
  REQUIRE(hit);
  CHECK(hit->t == Approx(1.5));
  CHECK_FALSE(hit->frontFace(Vec3(1, 0, 0)));
  CHECK(glm::length(hit->normal - Vec3(1, 0, 0)) < kTol); // still the outward normal
}

TEST_CASE("the nearest of several spheres wins - whatever their order")
{
  Scene scene = oneSphere(Vec3(0, 0, -20), 1);
  scene.spheres.push_back(Sphere{Vec3(0, 0, -5), 1, 0});
  scene.spheres.push_back(Sphere{Vec3(0, 0, -12), 1, 0});
  const auto hit = scene.intersect(Ray{Vec3(0), Vec3(0, 0, -1)});
  REQUIRE(hit);
  CHECK(hit->sphere == 1);
  CHECK(hit->t == Approx(4));
}

TEST_CASE("the hit point's error bound covers the distance to the true surface")
{
  const Vec3 c(3e3, -2e3, 1e3);
  const Real r = 7;
  const Scene scene = oneSphere(c, r);
  const auto hit = scene.intersect(Ray{Vec3(0), glm::normalize(c + Vec3(1, 2, 3))});
  REQUIRE(hit);
  const long double distance = std::abs(std::sqrt((long double)(hit->point.x - c.x) * (hit->point.x - c.x) +
                                                  (long double)(hit->point.y - c.y) * (hit->point.y - c.y) +
                                                  (long double)(hit->point.z - c.z) * (hit->point.z - c.z)) -
                                        (long double)r);
  CHECK(distance <= (long double)glm::length(hit->pointError));
  CHECK(glm::length(hit->pointError) > 0);
}

#include "scene/scene.h"
#include "core/rng.h"
#include "geometry/sphere.h"

#include <bit>
#include <cstdint>

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
  CHECK(hit->primitive == 0);
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
  CHECK(hit->primitive == 1);
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

// intersectSphere skips the square root where a bound proves no root can lie in [tmin, tmax). Those skips must
// never change an answer: compare, bit for bit, with the plain selection from intersectSphereRoots, on rays
// inside and outside spheres from tiny to huge (the Cornell box's walls have radius 1e5), with tmax set near the
// root itself, where a bound without its rounding margin would cut a hit.
TEST_CASE("intersectSphere's early exits never change its answer")
{
  Sampler sampler(7, 0, 0, 0);
  const auto plain = [](const Vec3& o, const Vec3& d, const Vec3& c, Real r, Real tmax) -> std::optional<Real> {
    const auto roots = intersectSphereRoots(o, d, c, r);
    if (!roots)
      return std::nullopt;
    if (roots->t0 >= 0 && roots->t0 < tmax)
      return roots->t0;
    if (roots->t1 >= 0 && roots->t1 < tmax)
      return roots->t1;
    return std::nullopt;
  };
  int skippedNearRoot = 0, compared = 0;
  for (int i = 0; i < 200000; ++i) {
    const Real r = std::pow(Real(10), Real(-2) + 7 * sampler.next1D());
    const Vec3 c(0);
    // Origins from deep inside to well outside, directions uniform.
    const Vec2 u = sampler.next2D();
    const Real z = 1 - 2 * u.x, s = std::sqrt(std::max(Real(0), 1 - z * z)), phi = 2 * kPi * u.y;
    // (One draw a statement, z first: C++ leaves the order of a call's arguments unspecified, GCC evaluating them
    // right to left and clang left to right; z first is GCC's order from when the three were one call's arguments.)
    const Real oz = sampler.next1D();
    const Real oy = sampler.next1D();
    const Real ox = sampler.next1D();
    const Vec3 o = r * Real(2.5) * (Vec3(ox, oy, oz) - Real(0.5)) * Real(2);
    // A quarter of the rays pass through the centre, where the bounds are tight (√Δ = r) and only their
    // rounding margin keeps them below the root.
    Vec3 d = glm::normalize(Vec3(s * std::cos(phi), s * std::sin(phi), z));
    if (i % 4 == 0 && glm::length(o - c) > 0)
      d = glm::normalize((i % 8 == 0 ? c - o : o - c));
    const auto reference = plain(o, d, c, r, kInfinity);
    // tmax: unbounded, far, or within a few ulps either side of the root the unbounded query returns.
    Real tmax = kInfinity;
    const Real pick = sampler.next1D();
    if (reference && pick < Real(0.6))
      tmax = *reference * (1 + (pick - Real(0.3)) * Real(1e-14));
    else if (pick < Real(0.8))
      tmax = r * 3 * sampler.next1D();
    const auto expected = plain(o, d, c, r, tmax);
    const auto got = intersectSphere(o, d, c, r, Real(0), tmax);
    ++compared;
    if (reference && !expected)
      ++skippedNearRoot;
    REQUIRE(got.has_value() == expected.has_value());
    if (got)
      REQUIRE(std::bit_cast<std::uint64_t>(double(*got)) == std::bit_cast<std::uint64_t>(double(*expected)));
  }
  INFO(compared << " rays, " << skippedNearRoot << " with tmax just below the root");
  CHECK(skippedNearRoot > 5000); // the interval really did cut roots close to tmax
}

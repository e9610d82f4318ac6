// The sphere lanes (common/geometry/sphere_lanes.h) against the brute-force loop: four spheres at once and one by one give
// the same sphere and the same t, bit for bit, on every kind of ray over every kind of scene, ties included; and
// the scene uses them for its flat list with hit records identical to the loop's.
#include "random_scenes.h"
#include "scene/scene.h"
#include "geometry/sphere_lanes.h"

#include <catch2/catch.hpp>

#include <cmath>
#include <cstring>

using namespace raylife;
using namespace raylife::testing;

namespace {

bool sameBits(Real a, Real b) { return std::memcmp(&a, &b, sizeof(Real)) == 0; }

// The tests available on this machine: one by one always, four at once where the CPU has AVX2.
std::vector<LaneTest> laneTests()
{
  std::vector<LaneTest> tests{LaneTest::OneByOne};
  if (laneTestAvailable(LaneTest::FourAtOnce))
    tests.push_back(LaneTest::FourAtOnce);
  else
    WARN("this CPU has no AVX2: only the one-by-one test of the lanes is checked here");
  return tests;
}

const char* name(LaneTest test) { return test == LaneTest::OneByOne ? "one by one" : "four at once"; }

// Random rays through the lanes against the loop.
void checkLanes(const std::vector<Sphere>& spheres, std::size_t rays, std::uint64_t seed, Real extent)
{
  const std::vector<SphereGroup> groups = groupSpheres(spheres);
  for (const LaneTest test : laneTests()) {
    INFO("lane test: " << name(test) << ", " << spheres.size() << " spheres");
    Random random(seed);
    std::size_t wrong = 0, wrongAny = 0, hits = 0;
    std::string first;
    for (std::size_t i = 0; i < rays; ++i) {
      const Ray ray = randomRay(random, spheres, extent);
      const std::optional<Reference> expected = bruteForce(spheres, ray);
      const std::optional<SphereHit> got = nearestInGroups(groups, ray, test);
      const bool same = expected.has_value() == got.has_value() &&
                        (!expected || (expected->sphere == got->sphere && sameBits(expected->t, got->t)));
      if (!same && first.empty())
        first = describe(ray) + ": loop " + (expected ? std::to_string(expected->sphere) : std::string("miss")) +
                ", lanes " + (got ? std::to_string(got->sphere) : std::string("miss"));
      wrong += !same;
      wrongAny += anyInGroups(groups, ray, test) != expected.has_value();
      hits += expected.has_value();
    }
    INFO("first disagreement: " << first);
    CHECK(wrong == 0);
    CHECK(wrongAny == 0);
    CHECK(hits > rays / 10); // the rays do meet the spheres
    CHECK(hits < rays);      // and some miss
  }
}

// The Cornell box as scenes/cornell.json builds it: a ray inside six huge wall spheres.
std::vector<Sphere> cornellBox()
{
  return {Sphere{Vec3(100001, 40.8, 81.6), 100000, 0}, Sphere{Vec3(-99901, 40.8, 81.6), 100000, 0},
          Sphere{Vec3(50, 40.8, 100000), 100000, 0},   Sphere{Vec3(50, 40.8, -99830), 100000, 0},
          Sphere{Vec3(50, 100000, 81.6), 100000, 0},   Sphere{Vec3(50, -99918.4, 81.6), 100000, 0},
          Sphere{Vec3(27, 16.5, 47), 16.5, 0},         Sphere{Vec3(73, 16.5, 78), 16.5, 0},
          Sphere{Vec3(50, 66, 81.6), 10, 0}};
}

} // namespace

TEST_CASE("the lanes find exactly the brute-force hit - four at once and one by one")
{
  Random random(77);
  SECTION("the Cornell box, from inside")
  {
    // Rays from inside the room, which is inside all six walls (spheres of radius 1e5).
    const std::vector<Sphere> box = cornellBox();
    const std::vector<Sphere> small(box.begin() + 6, box.end());
    const std::vector<SphereGroup> groups = groupSpheres(box);
    std::size_t wrong = 0, unbounded = 0, unboundedHits = 0;
    for (const LaneTest test : laneTests()) {
      Random rays(5);
      for (int i = 0; i < 200000; ++i) {
        Ray ray = randomRay(rays, small, 40); // about the balls and the lamp: inside them, grazing them, ...
        const bool inRoom = glm::all(glm::greaterThan(ray.origin, Vec3(1.5, 0.5, 0.5))) &&
                            glm::all(glm::lessThan(ray.origin, Vec3(98.5, 81, 169)));
        if (!inRoom) { // ... or from anywhere in the room (z drawn first, as GCC drew them; see random_scenes.h)
          const Real z = rays.uniform(Real(0.5), 169);
          const Real y = rays.uniform(Real(0.5), 81);
          const Real x = rays.uniform(Real(1.5), Real(98.5));
          ray.origin = Vec3(x, y, z);
        }
        const std::optional<Reference> expected = bruteForce(box, ray);
        const std::optional<SphereHit> got = nearestInGroups(groups, ray, test);
        wrong += expected.has_value() != got.has_value() ||
                 (expected && (expected->sphere != got->sphere || !sameBits(expected->t, got->t)));
        unbounded += ray.tmax == kInfinity;
        unboundedHits += ray.tmax == kInfinity && got.has_value();
      }
    }
    CHECK(wrong == 0);
    CHECK(unboundedHits == unbounded); // an unbounded ray inside the box always hits a wall
  }
  SECTION("uniform spheres") { checkLanes(uniformScene(random, 9), 200000, 1, 12); }
  SECTION("clusters of spheres of very different sizes") { checkLanes(clusteredScene(random, 40), 100000, 2, 55); }
  SECTION("a huge ground sphere under small ones") { checkLanes(groundScene(random, 9), 200000, 5, 12); }
  SECTION("a lattice of touching spheres") { checkLanes(latticeScene(2), 100000, 4, 3); }
  SECTION("every count from 1 to 13: full and part-filled groups")
  {
    for (std::size_t n = 1; n <= 13; ++n)
      checkLanes(uniformScene(random, int(n)), 20000, 10 + n, 12);
  }
  SECTION("duplicate and concentric spheres: ties within a group and across groups go to the lowest index")
  {
    // duplicateScene puts copies both before and after their originals, so equal t meet in every arrangement.
    checkLanes(duplicateScene(random, 16), 100000, 20, 12);
    checkLanes(duplicateScene(random, 30), 100000, 21, 12);
  }
}

TEST_CASE("lanes: NaN and infinite rays - empty lanes - empty lists - miss as the loop does")
{
  Random random(3);
  const std::vector<Sphere> spheres = uniformScene(random, 5); // two groups, the second with three empty lanes
  const std::vector<SphereGroup> groups = groupSpheres(spheres);
  REQUIRE(groups.size() == 2);
  CHECK(groups[1].radius[0] == spheres[4].radius);
  CHECK(std::isnan(groups[1].radius[1])); // empty lanes
  CHECK(std::isnan(groups[1].centerX[3]));
  for (const LaneTest test : laneTests()) {
    INFO("lane test: " << name(test));
    for (const Ray& ray : nonFiniteRays(random, 12)) {
      const std::optional<Reference> expected = bruteForce(spheres, ray);
      const std::optional<SphereHit> got = nearestInGroups(groups, ray, test);
      REQUIRE(got.has_value() == expected.has_value());
      CHECK(anyInGroups(groups, ray, test) == expected.has_value());
    }
    // From (0, 0, 40) straight at each sphere's centre: always a hit (that sphere or one in front of it), and
    // never on an empty lane.
    for (const Sphere& s : spheres) {
      const Ray ray{Vec3(0, 0, 40), glm::normalize(s.center - Vec3(0, 0, 40))};
      const std::optional<SphereHit> got = nearestInGroups(groups, ray, test);
      REQUIRE(got);
      CHECK(got->sphere >= 0);
      CHECK(got->sphere < int(spheres.size()));
    }
    CHECK_FALSE(nearestInGroups({}, Ray{}, test));
    CHECK_FALSE(anyInGroups({}, Ray{}, test));
  }
}

TEST_CASE("lanes: a ray exactly tangent to a sphere meets it, and a hit exactly at tmax is none, as in the loop")
{
  // One sphere of radius 1 at (0, 0, -5), its group's other lanes empty. A ray down -z from (1, 0, 0) touches it at
  // t = 5 exactly (discriminant 0: the lanes' early exit must not take that for a miss); one from the origin meets
  // it at t = 4 exactly, which counts for a ray ending just beyond and not for one ending there ([tmin, tmax)).
  // Random rays meet neither tie.
  const std::vector<Sphere> spheres = {Sphere{Vec3(0, 0, -5), 1, 0}};
  const std::vector<SphereGroup> groups = groupSpheres(spheres);
  for (const LaneTest test : laneTests()) {
    INFO("lane test: " << name(test));
    const Ray tangent{Vec3(1, 0, 0), Vec3(0, 0, -1)};
    const std::optional<Reference> expected = bruteForce(spheres, tangent);
    REQUIRE(expected);
    CHECK(expected->t == 5);
    const std::optional<SphereHit> got = nearestInGroups(groups, tangent, test);
    REQUIRE(got);
    CHECK(sameBits(got->t, expected->t));
    CHECK(anyInGroups(groups, tangent, test));
    for (const Real tmax : {Real(4), std::nextafter(Real(4), kInfinity)}) {
      const Ray ray{Vec3(0), Vec3(0, 0, -1), 0, tmax};
      const bool meets = tmax > 4;
      CHECK(bruteForce(spheres, ray).has_value() == meets);
      CHECK(nearestInGroups(groups, ray, test).has_value() == meets);
      CHECK(anyInGroups(groups, ray, test) == meets);
    }
  }
}

TEST_CASE("the scene's flat list goes through the lanes where the CPU tests four at once - with identical hits")
{
  Random random(8);
  Scene lanes;
  lanes.materials.push_back(Material{});
  lanes.spheres = groundScene(random, int(kFlatListMaxPrimitives));
  Scene loop = lanes;
  lanes.buildAccelerator();
  REQUIRE_FALSE(lanes.usesAccelerator());
  CHECK(lanes.usesLanes() == laneTestAvailable(LaneTest::FourAtOnce));
  CHECK_FALSE(loop.usesLanes()); // never built: the one-by-one loop
  for (int i = 0; i < 50000; ++i) {
    const Ray ray = randomRay(random, lanes.spheres, 12);
    const std::optional<Hit> a = loop.intersect(ray), b = lanes.intersect(ray);
    REQUIRE(a.has_value() == b.has_value());
    if (a) {
      REQUIRE(sameBits(a->t, b->t));
      REQUIRE(a->primitive == b->primitive);
      REQUIRE(a->point == b->point);
      REQUIRE(a->normal == b->normal);
      REQUIRE(a->pointError == b->pointError);
    }
    REQUIRE(loop.occluded(ray) == lanes.occluded(ray));
  }
  // Stale: a sphere added after the build is seen (through the loop), as with the BVH.
  lanes.spheres.push_back(Sphere{Vec3(0, 50, 0), 1, 0});
  CHECK_FALSE(lanes.usesLanes());
  const std::optional<Hit> hit = lanes.intersect(Ray{Vec3(0, 60, 0), Vec3(0, -1, 0)});
  REQUIRE(hit);
  CHECK(hit->primitive == int(lanes.spheres.size()) - 1);
  // A scene below kLanesMinSpheres keeps no lanes, nor does one the BVH takes.
  Scene few;
  few.materials.push_back(Material{});
  few.spheres = groundScene(random, int(kLanesMinSpheres) - 1);
  few.buildAccelerator();
  CHECK_FALSE(few.usesLanes());
  CHECK_FALSE(few.usesAccelerator());
  Scene big;
  big.materials.push_back(Material{});
  big.spheres = groundScene(random, int(kFlatListMaxPrimitives) + 1);
  big.buildAccelerator();
  CHECK(big.usesAccelerator());
  CHECK_FALSE(big.usesLanes());
  CHECK(big.lanes.size() == 0);
}

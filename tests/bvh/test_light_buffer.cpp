// The light buffer (common/geometry/light_buffer.h) against the brute-force loop: shadow rays towards a point light,
// from anywhere, from spheres' surfaces, grazing spheres' outlines as the light sees them, and along the cube's edges
// and its cells' borders, in the scenes the BVH is tested on, near the origin and far from it.
#include "random_scenes.h"
#include "geometry/light_buffer.h"

#include <catch2/catch.hpp>

using namespace raylife;
using namespace raylife::testing;

namespace {

// A shadow ray from `origin` to the light at `light`, as chapter 16's point lights make them: a unit direction,
// stopped kShadowRayShorten short of the light.
Ray towards(const Vec3& origin, const Vec3& light)
{
  const Vec3 to = light - origin;
  const Real distance = glm::length(to);
  return Ray{origin, to / distance, 0, distance * (1 - kShadowRayShorten)};
}

bool blockedByLoop(const std::vector<Sphere>& spheres, const Ray& ray)
{
  for (const Sphere& s : spheres)
    if (intersectSphere(ray.origin, ray.direction, s.center, s.radius, ray.tmin, ray.tmax))
      return true;
  return false;
}

// A unit vector at right angles to unit `axis`, turned by a random angle about it.
Vec3 perpendicular(Random& random, const Vec3& axis)
{
  const Vec3 helper = std::abs(axis.x) < Real(0.6) ? Vec3(1, 0, 0) : Vec3(0, 1, 0);
  const Vec3 a = glm::normalize(glm::cross(axis, helper)), b = glm::cross(axis, a);
  const Real phi = 2 * kPi * random.uniform();
  return std::cos(phi) * a + std::sin(phi) * b;
}

// Where a shadow ray to `light` starts, of kind `kind` (0 to 4).
Vec3 origin(Random& random, const std::vector<Sphere>& spheres, const Vec3& light, Real extent, int kind)
{
  const Sphere& s = spheres[random.index(spheres.size())];
  const Vec3 q = s.center - light;
  const Real distance = glm::length(q);
  switch (kind) {
  case 0: // anywhere near the light (inside spheres too)
    return light + random.inBox(-extent, extent);
  case 1: // on a sphere (the rounded point, a hair inside or outside)
    return s.center + s.radius * random.direction();
  case 2: { // on a line from the light that grazes a sphere's outline, by a relative 10⁻¹² to 10⁻², in or out
    if (!(distance > s.radius))
      return light + random.inBox(-extent, extent);
    const Real edge = std::asin(s.radius / distance);
    const Real nudge = std::pow(Real(10), random.uniform(-12, -2)) * (random.uniform() < Real(0.5) ? -1 : 1);
    const Real angle = edge * (1 + nudge);
    const Vec3 axis = q / distance;
    const Vec3 u = std::cos(angle) * axis + std::sin(angle) * perpendicular(random, axis);
    return light + u * (distance * random.uniform(Real(0.3), Real(3)));
  }
  case 3: { // along a cube edge or a cell's border (as the buffers below cut the faces), a hair either side
    const Real cells = Real(1 << random.index(8));
    const Real border = Real(2) * Real(random.index(std::size_t(cells) + 1)) / cells - 1;
    const Real hair = std::pow(Real(10), random.uniform(-9, -3)) * (random.uniform() < Real(0.5) ? -1 : 1);
    Vec3 v(random.uniform() < Real(0.5) ? -1 : 1, border + (random.index(2) ? hair : 0), random.uniform(-1, 1));
    const std::size_t turn = random.index(3);
    v = turn == 0 ? v : turn == 1 ? Vec3(v.z, v.x, v.y) : Vec3(v.y, v.z, v.x);
    return light + v * (extent * random.uniform(Real(0.01), Real(1)));
  }
  default: // behind a sphere, seen from the light
    return light + q / distance * (distance + s.radius * random.uniform(0, 5));
  }
}

} // namespace

TEST_CASE("a light buffer blocks exactly the shadow rays the loop over every sphere blocks")
{
  Random random(42);
  struct Case {
    const char* name;
    std::vector<Sphere> spheres;
    Vec3 light;
    Real extent; // rays start within this of the light, in each coordinate
  };
  std::vector<Case> cases;
  cases.push_back({"uniform, the light among the spheres", uniformScene(random, 300), Vec3(0.3, 0.2, -0.1), 15});
  cases.push_back({"clustered, the light in a cluster", clusteredScene(random, 400), Vec3(0), 60});
  cases.back().light = cases.back().spheres[7].center + Vec3(0.01, 0, 0);
  cases.push_back({"duplicates and concentric spheres", duplicateScene(random, 200), Vec3(0, 12, 0), 25});
  cases.push_back({"a lattice of touching spheres, the light where four touch", latticeScene(6), Vec3(2.5, 2.5, 3),
                   8});
  cases.push_back({"the tutorial's ground, the light high", groundScene(random, 300), Vec3(-30, 50, 30), 70});
  cases.push_back({"the tutorial's ground, the light low", groundScene(random, 300), Vec3(20, 15, -10), 30});
  cases.push_back({"smallpt's room, the light inside its lamp", roomScene(random, 60), Vec3(50, 81, 81.6), 120});
  cases.push_back({"uniform, the light inside a sphere", uniformScene(random, 100), Vec3(0), 15});
  cases.back().light = cases.back().spheres[3].center;

  std::size_t rays = 0, answered = 0, blocked = 0;
  double share = 0; // with 128 cells a side: the sum over rays of the share of the spheres each tests
  std::size_t shared = 0;
  for (const Case& c : cases)
    for (const Real offset : {Real(0), Real(1e3), Real(1e5)})
      for (const int cells : {1, 7, 32, 128}) {
        // The scene and its light moved far from the origin, where every coordinate has fewer bits left.
        std::vector<Sphere> spheres = c.spheres;
        const Vec3 shift = offset * Vec3(1, Real(0.7), Real(-0.3));
        for (Sphere& s : spheres)
          s.center += shift;
        const Vec3 light = c.light + shift;
        const LightBuffer buffer(light, spheres, cells, Real(2) * c.extent);
        for (std::size_t r = 0; r < raysToSend(4000); ++r) {
          const Vec3 o = origin(random, spheres, light, c.extent, int(r % 5));
          if (o == light)
            continue;
          const Ray ray = towards(o, light);
          ++rays;
          if (!buffer.answers(o))
            continue;
          ++answered;
          if (cells == 128)
            share += double(buffer.candidates(o)) / double(spheres.size()), ++shared;
          const bool expected = blockedByLoop(spheres, ray);
          blocked += expected;
          if (buffer.occluded(ray) != expected) {
            INFO(c.name << ", offset " << offset << ", " << cells << " cells a side, ray " << r << ": "
                        << describe(ray) << (expected ? " blocked by the loop" : " free by the loop"));
            CHECK(false);
          }
        }
      }
  INFO(answered << " of " << rays << " rays answered, " << blocked << " blocked; with 128 cells a side a ray tests "
                << 100 * share / double(shared) << " % of the spheres");
  CHECK(answered > rays * 9 / 10);
  CHECK(blocked > answered / 5);
  CHECK(blocked < answered * 4 / 5);
  // The buffer does cull: with 128 cells a side a ray tests a few of the scene's spheres.
  CHECK(share < 0.05 * double(shared));
}

TEST_CASE("a light buffer tests everywhere what holds the light or fills many cells, and answers only in range")
{
  Random random(5);
  std::vector<Sphere> spheres = groundScene(random, 50);
  spheres.push_back(Sphere{Vec3(0, 3, 0), 1, 0}); // holds the light
  const Vec3 light(0, 3.5, 0);
  const LightBuffer buffer(light, spheres, 64, 20);
  CHECK(buffer.everywhere().size() == 2); // the ground and the sphere around the light
  CHECK(!buffer.listed().empty());
  CHECK(buffer.memoryBytes() > 0);
  // Every ray from outside that sphere is blocked by it, and the loop agrees.
  for (int r = 0; r < 200; ++r) {
    const Vec3 o = light + random.inBox(-10, 10);
    if (glm::length(o - spheres.back().center) <= 1.01 || !buffer.answers(o))
      continue;
    const Ray ray = towards(o, light);
    CHECK(blockedByLoop(spheres, ray));
    CHECK(buffer.occluded(ray));
  }
  // Only rays from within the range are answered; an empty buffer, or one without range or cells, answers none.
  CHECK(buffer.answers(light + Vec3(0, 0, 19.9)));
  CHECK_FALSE(buffer.answers(light + Vec3(0, 0, 20.1)));
  CHECK_FALSE(buffer.answers(light + Vec3(std::numeric_limits<Real>::quiet_NaN(), 0, 0)));
  CHECK_FALSE(LightBuffer().answers(light));
  CHECK_FALSE(LightBuffer(light, spheres, 64, 0).answers(light + Vec3(1, 0, 0)));
  CHECK_FALSE(LightBuffer(light, spheres, 0, 20).answers(light + Vec3(1, 0, 0)));
}

TEST_CASE("a light buffer keeps a sphere in a cell it pokes into by a hair")
{
  // A cell's borders are the planes v_u = a·|v_m| through the light (m the face's axis, u another, a = 2i/N − 1 for
  // N cells a side). Each sphere here lies on the near side of such a plane but for a cap 10⁻⁹ to 10⁻³ of its radius
  // thick, and rays cross that cap: they lie in the next cell, and only the sphere blocks them.
  Random random(11);
  for (const Real offset : {Real(0), Real(1e3)})
    for (const int cells : {4, 32, 128}) {
      const Vec3 light = Vec3(Real(0.25), Real(-0.5), Real(2)) + offset * Vec3(Real(-0.6), 1, Real(0.2));
      std::vector<Sphere> spheres;
      std::vector<Vec3> caps; // a point in each sphere's cap, across the border
      for (int k = 0; k < 60; ++k) {
        const int m = int(random.index(3)), u = (m + 1 + int(random.index(2))) % 3, v = 3 - m - u;
        const Real side = random.uniform() < Real(0.5) ? -1 : 1;
        const Real a = Real(2) * Real(1 + random.index(std::size_t(cells) - 1)) / Real(cells) - 1;
        Vec3 along(0), normal(0); // a direction in the border plane, and the plane's normal towards larger v_u
        along[m] = side, along[u] = a, along[v] = random.uniform(Real(-0.9), Real(0.9));
        normal[u] = 1, normal[m] = -a * side;
        const Vec3 n = glm::normalize(normal);
        const Real t = random.uniform(2, 20), r = t * random.uniform(Real(0.001), Real(0.05));
        const Real hair = r * std::pow(Real(10), random.uniform(-9, -3));
        const Vec3 c = light + t * glm::normalize(along) - (r - hair) * n;
        spheres.push_back(Sphere{c, r, 0});
        caps.push_back(c + (r - hair / 2) * n);
      }
      const LightBuffer buffer(light, spheres, cells, 100);
      int blocked = 0;
      for (std::size_t k = 0; k < caps.size(); ++k)
        for (const Real beyond : {Real(1), Real(1.5), Real(3)}) {
          const Vec3 o = light + (caps[k] - light) * beyond;
          const Ray ray = towards(o, light);
          REQUIRE(buffer.answers(o));
          const bool expected = blockedByLoop(spheres, ray);
          blocked += expected;
          INFO("offset " << offset << ", " << cells << " cells a side, sphere " << k << ": " << describe(ray));
          CHECK(buffer.occluded(ray) == expected);
        }
      CHECK(blocked > 90); // (of 180: in float, a cap thinner than a coordinate's rounding may let a ray by)
    }
}

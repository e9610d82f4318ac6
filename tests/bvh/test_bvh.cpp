// The BVH against the brute-force loop: the same hit (sphere and t, bit for bit) on over a million random rays
// over random scenes, the any-hit query in agreement, a deterministic build, and the SAH beating a midpoint split.
#include "geometry/bvh.h"
#include "render/heat_map.h"
#include "random_scenes.h"
#include "scene/scene.h"
#include "core/simd.h"

#include <catch2/catch.hpp>

#include <cstring>
#include <functional>
#include <span>
#include <sstream>

using namespace raylife;
using namespace raylife::testing;

namespace {

// Traces `rays` random rays through the tree and the loop; returns how many disagreed, and describes the first.
struct Disagreements {
  std::size_t closest = 0;   // different closest hit (presence, sphere or t)
  std::size_t anyHit = 0;    // occluded() disagrees with the closest hit's presence
  std::size_t withWork = 0;  // the counting queries disagree with the plain ones
  std::size_t boxTests = 0;  // eight boxes at a time and four at a time differ (hit, t or work)
  std::size_t hits = 0;      // rays that hit something (so the test is not all misses)
  std::string first;
};

bool sameWork(const BvhWork& a, const BvhWork& b)
{
  return a.nodesVisited == b.nodesVisited && a.primitivesTested == b.primitivesTested;
}

Disagreements compare(const std::vector<Sphere>& spheres, std::size_t rays, std::uint64_t seed, Real extent)
{
  const Bvh bvh(spheres); // eight boxes at a time where the CPU has AVX2
  BvhBuildOptions fourOptions;
  fourOptions.eightAtOnce = false;
  const Bvh four(spheres, fourOptions);
  Random random(seed);
  Disagreements d;
  for (std::size_t i = 0; i < rays; ++i) {
    const Ray ray = randomRay(random, spheres, extent);
    const std::optional<Reference> expected = bruteForce(spheres, ray);
    const std::optional<BvhHit> got = bvh.intersect(ray);
    const bool same = expected.has_value() == got.has_value() &&
                      (!expected || (expected->sphere == got->primitive &&
                                     std::memcmp(&expected->t, &got->t, sizeof(Real)) == 0));
    if (!same) {
      if (d.first.empty())
        d.first = describe(ray) + ": brute force " +
                  (expected ? "sphere " + std::to_string(expected->sphere) + " t " + std::to_string(expected->t)
                            : std::string("miss")) +
                  ", BVH " +
                  (got ? "sphere " + std::to_string(got->primitive) + " t " + std::to_string(got->t)
                       : std::string("miss"));
      ++d.closest;
    }
    d.hits += expected.has_value();
    if (bvh.occluded(ray) != expected.has_value())
      ++d.anyHit;
    const BvhTracedHit counted = bvh.intersectWithWork(ray);
    if (counted.hit.has_value() != got.has_value() || (got && counted.hit->primitive != got->primitive) ||
        bvh.occludedWithWork(ray).occluded != expected.has_value())
      ++d.withWork;
    // The two box tests do the same float operations in lanes of different widths: the same hit, the same t
    // to the bit, and the same boxes and spheres tested.
    const BvhTracedHit byFour = four.intersectWithWork(ray);
    const BvhTracedOcclusion blockedByEight = bvh.occludedWithWork(ray), blockedByFour = four.occludedWithWork(ray);
    if (byFour.hit.has_value() != counted.hit.has_value() ||
        (byFour.hit && (byFour.hit->primitive != counted.hit->primitive ||
                        std::memcmp(&byFour.hit->t, &counted.hit->t, sizeof(Real)) != 0)) ||
        !sameWork(byFour.work, counted.work) || blockedByFour.occluded != blockedByEight.occluded ||
        !sameWork(blockedByFour.work, blockedByEight.work))
      ++d.boxTests;
  }
  return d;
}

void checkAgreement(const std::vector<Sphere>& spheres, std::size_t allRays, std::uint64_t seed, Real extent)
{
  const std::size_t rays = raysToSend(allRays);
  const Disagreements d = compare(spheres, rays, seed, extent);
  INFO("first disagreement: " << d.first);
  CHECK(d.closest == 0);
  CHECK(d.anyHit == 0);
  CHECK(d.withWork == 0);
  CHECK(d.boxTests == 0);
  CHECK(d.hits > rays / 10); // the rays do meet the spheres
  CHECK(d.hits < rays);      // and some miss
}

} // namespace

TEST_CASE("the BVH finds exactly the brute-force hit for a million random rays")
{
  // Over a million rays in all: every kind of ray (inside, grazing, axis-aligned, zero components, from
  // surfaces, from afar, bounded intervals) over every kind of scene.
  Random random(2024);
  SECTION("uniform spheres") { checkAgreement(uniformScene(random, 300), 250000, 1, 12); }
  SECTION("clusters of spheres of very different sizes") { checkAgreement(clusteredScene(random, 600), 200000, 2, 55); }
  SECTION("duplicate and concentric spheres") { checkAgreement(duplicateScene(random, 300), 200000, 3, 12); }
  SECTION("a lattice of touching spheres") { checkAgreement(latticeScene(7), 150000, 4, 8); }
  SECTION("a huge ground sphere under small ones") { checkAgreement(groundScene(random, 200), 150000, 5, 12); }
  SECTION("huge walls and a huge lamp over clutter (smallpt's room)")
  {
    checkAgreement(roomScene(random, 400), 150000, 6, 150);
  }
  SECTION("tiny scenes")
  {
    for (int n : {1, 2, 3, 5, 9, 17})
      checkAgreement(uniformScene(random, n), 20000, std::uint64_t(10 + n), 12);
  }
}

TEST_CASE("a node's boxes are tested eight at a time where the CPU has AVX2 - four at a time otherwise or when asked")
{
  Random random(3);
  const std::vector<Sphere> spheres = uniformScene(random, 50);
  BvhBuildOptions four;
  four.eightAtOnce = false;
  CHECK(Bvh(spheres).eightAtOnce() == cpuHasAvx2());
  CHECK_FALSE(Bvh(spheres, four).eightAtOnce());
  if (!cpuHasAvx2())
    WARN("this CPU has no AVX2: only the box test four at a time is checked here");
}

TEST_CASE("ties at the same t go to the lowest index as in the brute-force loop")
{
  // Three copies of one sphere, among others: every ray that hits it hits all three at the same t.
  Random random(7);
  std::vector<Sphere> spheres = uniformScene(random, 40);
  const Sphere twin{Vec3(1, 2, 3), 2, 0};
  spheres.insert(spheres.begin() + 5, twin);
  spheres.push_back(twin);
  spheres.insert(spheres.begin() + 20, twin);
  const Bvh bvh(spheres);
  for (int i = 0; i < 2000; ++i) {
    const Vec3 from = twin.center + random.direction() * Real(30);
    const Ray ray{from, glm::normalize(twin.center + random.inBox(-1, 1) - from)};
    const auto expected = bruteForce(spheres, ray);
    const auto got = bvh.intersect(ray);
    REQUIRE(expected);
    REQUIRE(got);
    REQUIRE(got->primitive == expected->sphere);
    REQUIRE(got->t == expected->t);
  }
}

TEST_CASE("intervals that end just past a hit or begin exactly at one - where a sphere touches its box")
{
  // A sphere touches its box at six points, where the box's faces are tangent to it. A ray through one of them
  // crosses the box's face and the sphere at almost the same t; if its interval ends just past that t (entering
  // there) or begins exactly at it (leaving there), the box test has the least room to spare: an entry rounded
  // late or an exit rounded early may cull the sphere. Oblique rays (so 1/d is not exact), near the origin and
  // far from it (where a float origin is coarse).
  for (const Real offset : {Real(0), Real(3e4)}) {
    Random random(19);
    std::vector<Sphere> spheres = uniformScene(random, 200);
    for (Sphere& s : spheres)
      s.center += Vec3(offset, -offset, offset);
    const Bvh bvh(spheres);
    std::size_t checked = 0;
    for (int i = 0; i < 40000; ++i) {
      const Sphere& s = spheres[random.index(spheres.size())];
      const int axis = int(random.index(3));
      const Real side = random.index(2) ? 1 : -1;
      Vec3 touch = s.center;
      touch[axis] += side * s.radius;
      Vec3 d = random.direction();
      d[axis] = -side * std::max(std::abs(d[axis]), Real(0.2)); // inwards through the touching point
      d = glm::normalize(d);
      Ray ray{touch - d * random.uniform(Real(0.5), 20), d};
      const bool entering = random.index(2) == 0;
      if (!entering) // from inside (somewhere along the chord d cuts), leaving through the touching point
        ray = Ray{touch + d * (2 * s.radius * std::abs(d[axis]) * random.uniform(Real(0.1), Real(0.9))), -d};
      const std::optional<SphereRoots<Real>> roots = intersectSphereRoots(ray.origin, ray.direction, s.center, s.radius);
      if (!roots || (entering ? roots->t0 : roots->t1) < 0)
        continue;
      if (entering)
        ray.tmax = nextUp(roots->t0); // the interval ends just past the entry
      else
        ray.tmin = roots->t1; // it begins exactly at the exit
      const std::optional<Reference> expected = bruteForce(spheres, ray);
      const std::optional<BvhHit> got = bvh.intersect(ray);
      INFO(describe(ray));
      REQUIRE(expected.has_value() == got.has_value());
      if (expected) {
        REQUIRE(got->primitive == expected->sphere);
        REQUIRE(std::memcmp(&got->t, &expected->t, sizeof(Real)) == 0);
      }
      REQUIRE(bvh.occluded(ray) == expected.has_value());
      checked += expected.has_value();
    }
    CHECK(checked > 30000); // the rays do hit, at the touching point or (rarely) a neighbour in front of it
  }

  // Leaving from the origin of coordinates, inside every sphere: a float origin there is exact, so no rounding
  // of it leaves the box test room to spare either.
  Random random(23);
  std::vector<Sphere> spheres;
  for (int i = 0; i < 300; ++i) {
    const Vec3 c = random.inBox(-1, 1);
    spheres.push_back(Sphere{c, glm::length(c) + random.uniform(Real(0.01), 10), 0});
  }
  const Bvh bvh(spheres);
  for (const Sphere& s : spheres)
    for (int face = 0; face < 6; ++face) {
      Vec3 touch = s.center;
      touch[face % 3] += face < 3 ? -s.radius : s.radius;
      Ray ray{Vec3(0), glm::normalize(touch)};
      const std::optional<SphereRoots<Real>> roots = intersectSphereRoots(ray.origin, ray.direction, s.center, s.radius);
      REQUIRE(roots);
      ray.tmin = roots->t1;
      const std::optional<Reference> expected = bruteForce(spheres, ray);
      INFO(describe(ray));
      REQUIRE(expected);
      const std::optional<BvhHit> got = bvh.intersect(ray);
      REQUIRE(got);
      REQUIRE(got->primitive == expected->sphere);
      REQUIRE(std::memcmp(&got->t, &expected->t, sizeof(Real)) == 0);
      REQUIRE(bvh.occluded(ray));
    }
}

TEST_CASE("the any-hit query agrees with the closest hit about occlusion inside the interval")
{
  // Shadow-ray-like rays: bounded by the distance to a point, from just off a surface.
  Random random(11);
  const std::vector<Sphere> spheres = groundScene(random, 300);
  const Bvh bvh(spheres);
  std::size_t blocked = 0;
  const std::size_t n = 100000;
  for (std::size_t i = 0; i < n; ++i) {
    const Vec3 from = random.inBox(-12, 12) * Vec3(1, 0.2, 1) + Vec3(0, 0.5, 0);
    const Vec3 to = random.inBox(-12, 12) + Vec3(0, 12, 0);
    const Real distance = glm::length(to - from);
    const Ray ray{from, (to - from) / distance, 0, distance};
    const bool occluded = bvh.occluded(ray);
    REQUIRE(occluded == bruteForce(spheres, ray).has_value());
    blocked += occluded;
  }
  CHECK(blocked > n / 20);
  CHECK(blocked < n - n / 20);
}

TEST_CASE("the build is deterministic")
{
  Random random(3);
  const std::vector<Sphere> spheres = clusteredScene(random, 5000);
  BvhBuildOptions keep;
  keep.keepBinaryTree = true;
  const Bvh a(spheres, keep), b(spheres, keep);
  REQUIRE(!a.nodes().empty());
  REQUIRE(a.nodes().size() == b.nodes().size());
  CHECK(std::memcmp(a.nodes().data(), b.nodes().data(), a.nodes().size() * sizeof(BvhNode)) == 0);
  CHECK(a.depth() == b.depth());
  CHECK(a.sahCost() == b.sahCost());
}

TEST_CASE("the tree is well formed - every sphere in one leaf - every box holds its spheres")
{
  Random random(5);
  const std::vector<Sphere> spheres = groundScene(random, 2000);
  BvhBuildOptions keep;
  keep.keepBinaryTree = true;
  const Bvh bvh(spheres, keep);
  const std::vector<BvhNode>& nodes = bvh.nodes();
  REQUIRE(!nodes.empty());
  // The ground is kept out of the tree (its box is far more than four times the small spheres'); the tree holds
  // every other sphere once.
  REQUIRE(bvh.outsidePrimitives() == std::vector<int>{0});
  const std::size_t inTree = spheres.size() - 1;
  // Walk the tree from the root, checking each child lies inside its parent and each leaf's spheres are covered.
  std::vector<int> seen(inTree, 0);
  std::function<void(std::uint32_t, int)> walk = [&](std::uint32_t i, int level) {
    REQUIRE(i < nodes.size());
    REQUIRE(level <= Bvh::kMaxDepth);
    const BvhNode& n = nodes[i];
    if (n.count > 0) {
      REQUIRE(std::size_t(n.offset) + n.count <= inTree);
      for (std::uint32_t k = n.offset; k < n.offset + n.count; ++k)
        seen[k] += 1;
      return;
    }
    for (std::uint32_t child : {i + 1, n.offset}) {
      for (int a = 0; a < 3; ++a) {
        REQUIRE(nodes[child].bounds[0][a] >= n.bounds[0][a]);
        REQUIRE(nodes[child].bounds[1][a] <= n.bounds[1][a]);
      }
      walk(child, level + 1);
    }
  };
  walk(0, 1);
  for (int s : seen)
    REQUIRE(s == 1);
  // The root box holds every sphere of the tree.
  for (const Sphere& s : std::span(spheres).subspan(1))
    for (int a = 0; a < 3; ++a) {
      REQUIRE(Real(nodes[0].bounds[0][a]) <= s.center[a] - s.radius);
      REQUIRE(Real(nodes[0].bounds[1][a]) >= s.center[a] + s.radius);
    }
}

TEST_CASE("the wide tree holds every leaf of the built tree once - with its box - and empty slots that are empty")
{
  Random random(5);
  for (const std::vector<Sphere>& spheres : {groundScene(random, 2000), uniformScene(random, 1), uniformScene(random, 3)}) {
    BvhBuildOptions keep;
    keep.keepBinaryTree = true;
    const Bvh bvh(spheres, keep);
    const std::vector<BvhNode>& nodes = bvh.nodes();
    const std::vector<BvhWideNode>& wide = bvh.wideNodes();
    REQUIRE(!wide.empty());
    // The built tree's leaves, by first primitive, with their boxes.
    std::vector<int> leafOf(spheres.size(), -1);
    for (std::size_t i = 0; i < nodes.size(); ++i)
      if (nodes[i].count > 0)
        leafOf[nodes[i].offset] = int(i);
    std::vector<int> seen(nodes.size(), 0);
    std::function<void(std::uint32_t, int)> walk = [&](std::uint32_t index, int level) {
      REQUIRE(level < Bvh::kMaxDepth);
      const BvhWideNode& n = wide[index];
      REQUIRE(n.boxes >= (wide.size() == 1 ? 1u : 2u));
      REQUIRE(n.boxes <= std::uint32_t(BvhWideNode::kWidth));
      for (int k = 0; k < BvhWideNode::kWidth; ++k) {
        if (k >= int(n.boxes)) { // an empty slot: an empty box
          for (int a = 0; a < 3; ++a) {
            REQUIRE(n.bound(0, a, k) == std::numeric_limits<float>::infinity());
            REQUIRE(n.bound(1, a, k) == -std::numeric_limits<float>::infinity());
          }
          continue;
        }
        if (n.child[k] & BvhWideNode::kLeaf) { // a leaf of the built tree, with the box it had there
          const std::uint32_t first = n.child[k] & ~BvhWideNode::kLeaf;
          REQUIRE(first < spheres.size());
          REQUIRE(leafOf[first] >= 0);
          seen[std::size_t(leafOf[first])] += 1;
          for (int a = 0; a < 3; ++a) {
            REQUIRE(n.bound(0, a, k) == nodes[std::size_t(leafOf[first])].bounds[0][a]);
            REQUIRE(n.bound(1, a, k) == nodes[std::size_t(leafOf[first])].bounds[1][a]);
          }
        } else { // an interior node, after its parent, inside the box its parent holds for it
          REQUIRE(n.child[k] > index);
          REQUIRE(n.child[k] < wide.size());
          const BvhWideNode& c = wide[n.child[k]];
          for (int j = 0; j < int(c.boxes); ++j)
            for (int a = 0; a < 3; ++a) {
              REQUIRE(c.bound(0, a, j) >= n.bound(0, a, k));
              REQUIRE(c.bound(1, a, j) <= n.bound(1, a, k));
            }
          walk(n.child[k], level + 1);
        }
      }
    };
    walk(0, 1);
    for (std::size_t i = 0; i < nodes.size(); ++i)
      REQUIRE(seen[i] == (nodes[i].count > 0 ? 1 : 0));
  }
}

TEST_CASE("the SAH builds a cheaper tree than a midpoint split on a clustered scene - and it does less work")
{
  Random random(9);
  const std::vector<Sphere> spheres = clusteredScene(random, 3000);
  BvhBuildOptions sahOptions, midpointOptions;
  sahOptions.keepBinaryTree = midpointOptions.keepBinaryTree = true;
  midpointOptions.split = BvhSplit::Midpoint;
  const Bvh sah(spheres, sahOptions);
  const Bvh midpoint(spheres, midpointOptions);
  CHECK(sah.sahCost() < midpoint.sahCost());
  // The cost model predicts the work rays really do: count it over the same random rays.
  std::uint64_t workSah = 0, workMidpoint = 0;
  for (int i = 0; i < 20000; ++i) {
    const Ray ray = randomRay(random, spheres, 55);
    const BvhWork a = sah.intersectWithWork(ray).work, b = midpoint.intersectWithWork(ray).work;
    workSah += a.nodesVisited + 2 * a.primitivesTested;
    workMidpoint += b.nodesVisited + 2 * b.primitivesTested;
  }
  CHECK(workSah < workMidpoint);
}

TEST_CASE("degenerate inputs: identical centres and exponentially spaced spheres keep the depth bounded")
{
  std::vector<Sphere> same(3000, Sphere{Vec3(1, 1, 1), 1, 0});
  const Bvh a(same);
  CHECK(a.depth() < Bvh::kMaxDepth);
  const auto hit = a.intersect(Ray{Vec3(1, 1, -10), Vec3(0, 0, 1)});
  REQUIRE(hit);
  CHECK(hit->primitive == 0);
  CHECK(hit->t == 10);

  std::vector<Sphere> spread;
  for (int i = 0; i < 200; ++i)
    spread.push_back(Sphere{Vec3(std::ldexp(Real(1), i % 120), 0, 0), Real(0.25), 0});
  const Bvh b(spread);
  CHECK(b.depth() < Bvh::kMaxDepth);
  checkAgreement(spread, 20000, 77, 100);
}

TEST_CASE("an empty tree misses everything")
{
  const Bvh empty;
  CHECK_FALSE(empty.intersect(Ray{}));
  CHECK_FALSE(empty.occluded(Ray{}));
  CHECK(empty.primitiveCount() == 0);
}

TEST_CASE("rays with a NaN or an infinity in them get what the brute-force loop gives")
{
  // Outside Ray's contract, but such a ray must not hang or crash the traversal: a NaN makes every box test
  // pass, and the tree must then visit only real children, not the empty slots of its nodes.
  Random random(29);
  const std::vector<Sphere> spheres = uniformScene(random, 100);
  BvhBuildOptions four;
  four.eightAtOnce = false;
  const Bvh trees[2] = {Bvh(spheres), Bvh(spheres, four)}; // eight boxes at a time (with AVX2) and four
  const std::vector<Ray> rays = nonFiniteRays(random, 12);
  for (const Bvh& bvh : trees)
    for (const Ray& ray : rays) {
      INFO(describe(ray) << (bvh.eightAtOnce() ? ", eight boxes at a time" : ", four boxes at a time"));
      const std::optional<Reference> expected = bruteForce(spheres, ray);
      const std::optional<BvhHit> got = bvh.intersect(ray);
      REQUIRE(got.has_value() == expected.has_value());
      if (expected)
        CHECK(got->primitive == expected->sphere);
      CHECK(bvh.occluded(ray) == expected.has_value());
    }
}

TEST_CASE("the scene uses the BVH above the threshold - the loop below it or when stale - with identical hits")
{
  Random random(13);
  Scene flat, tree;
  flat.materials.push_back(Material{});
  flat.spheres = groundScene(random, 400);
  for (std::size_t i = 0; i < flat.spheres.size(); ++i)
    flat.spheres[i].material = 0;
  tree = flat;
  tree.buildAccelerator();
  CHECK_FALSE(flat.usesAccelerator());
  REQUIRE(tree.usesAccelerator());
  for (int i = 0; i < 50000; ++i) {
    const Ray ray = randomRay(random, flat.spheres, 12);
    const std::optional<Hit> a = flat.intersect(ray), b = tree.intersect(ray);
    REQUIRE(a.has_value() == b.has_value());
    if (a) {
      REQUIRE(a->t == b->t);
      REQUIRE(a->primitive == b->primitive);
      REQUIRE(a->point == b->point);
      REQUIRE(a->normal == b->normal);
      REQUIRE(a->pointError == b->pointError);
    }
    REQUIRE(flat.occluded(ray) == tree.occluded(ray));
    const TracedHit counted = tree.intersectWithWork(ray);
    REQUIRE(counted.hit.has_value() == a.has_value());
    REQUIRE(tree.occludedWithWork(ray).occluded == flat.occluded(ray));
    REQUIRE(flat.intersectWithWork(ray).work.primitivesTested == flat.spheres.size());
  }

  // Stale: a sphere added after the build, in front of the camera; the scene must see it (through the loop).
  tree.spheres.push_back(Sphere{Vec3(0, 50, 0), 1, 0});
  CHECK_FALSE(tree.usesAccelerator());
  const auto hit = tree.intersect(Ray{Vec3(0, 60, 0), Vec3(0, -1, 0)});
  REQUIRE(hit);
  CHECK(hit->primitive == int(tree.spheres.size()) - 1);

  // The threshold: at most kFlatListMaxPrimitives spheres are searched one by one.
  Scene small;
  small.spheres = std::vector<Sphere>(kFlatListMaxPrimitives, Sphere{});
  small.buildAccelerator();
  CHECK_FALSE(small.usesAccelerator());
  small.spheres.push_back(Sphere{});
  small.buildAccelerator();
  CHECK(small.usesAccelerator());
}

TEST_CASE("the loader builds the accelerator")
{
  std::string text = R"({ "camera": { "eye": [0, 0, 5], "focal": [0, 0, 0] },
                          "materials": { "m": { "type": "diffuse" } }, "spheres": [)";
  for (std::size_t i = 0; i <= kFlatListMaxPrimitives; ++i)
    text += (i ? ", " : "") + std::string(R"({ "center": [)") + std::to_string(i) + R"(, 0, 0], "radius": 0.25, "material": "m" })";
  text += "] }";
  const Scene scene = parseScene(text, "many.json");
  CHECK(scene.usesAccelerator());
}

TEST_CASE("the heat map: dark for little work - brighter for more - the same beyond its maximum")
{
  CHECK(luminance(heatColor(0)) < Real(0.001));
  Real previous = -1;
  for (Real cost = 1; cost <= kHeatMapMaxCost; cost *= 2) {
    const Real l = luminance(heatColor(cost));
    CHECK(l > previous);
    previous = l;
  }
  CHECK(heatColor(kHeatMapMaxCost * 4) == heatColor(kHeatMapMaxCost));
  CHECK(workCost(BvhWork{10, 3}) == 10 * BvhCosts{}.traversal + 3 * BvhCosts{}.intersection);
}

TEST_CASE("the tree does a fraction of the flat loop's work on a large scene")
{
  Random random(17);
  Scene scene;
  scene.materials.push_back(Material{});
  scene.spheres = groundScene(random, 1000);
  Scene flat = scene;
  scene.buildAccelerator();
  REQUIRE(scene.usesAccelerator());
  std::uint64_t tree = 0, loop = 0;
  for (int i = 0; i < 2000; ++i) {
    const Ray ray = randomRay(random, scene.spheres, 12);
    tree += std::uint64_t(workCost(scene.intersectWithWork(ray).work));
    loop += std::uint64_t(workCost(flat.intersectWithWork(ray).work));
  }
  CHECK(loop == 2000u * 1000u * std::uint64_t(BvhCosts{}.intersection));
  CHECK(tree * 10 < loop);
}

TEST_CASE("huge primitives stay out of the tree - walls, a lamp, a ground sphere - and nothing else does")
{
  Random random(8);
  // Smallpt's six walls (their boxes hold the room and the clutter many times over) are kept out, with its lamp
  // when the clutter reaches its box (just below the ceiling); the balls and the clutter stay in.
  const std::vector<Sphere> room = roomScene(random, 300);
  const std::vector<int> walls{0, 1, 2, 3, 4, 5}, wallsAndLamp{0, 1, 2, 3, 4, 5, 8};
  CHECK((Bvh(room).outsidePrimitives() == walls || Bvh(room).outsidePrimitives() == wallsAndLamp));
  std::vector<Sphere> roomUnderLamp = room;
  roomUnderLamp.push_back(Sphere{Vec3(50, 81, 81.6), Real(0.5), 0}); // touching the lamp's box
  CHECK(Bvh(roomUnderLamp).outsidePrimitives() == wallsAndLamp);
  CHECK(Bvh(room).primitiveCount() == room.size());
  // The tutorial's ground sphere.
  CHECK(Bvh(groundScene(random, 500)).outsidePrimitives() == std::vector<int>{0});
  // Spheres of like sizes: none (the biggest is far from four times the area of the box of the others).
  CHECK(Bvh(uniformScene(random, 300)).outsidePrimitives().empty());
  CHECK(Bvh(clusteredScene(random, 300)).outsidePrimitives().empty());
  CHECK(Bvh(latticeScene(5)).outsidePrimitives().empty());
  // One sphere four times the area of the box of the rest is out; a little less than that is in.
  std::vector<Sphere> pair = uniformScene(random, 20);
  for (Sphere& s : pair)
    s = Sphere{s.center * Real(0.1), Real(0.05), 0}; // all inside [−1.05, 1.05]³
  // Two at opposite corners, so that their box is that cube whatever the draws (with others, the spheres can span
  // less, and the ratios below are then larger).
  pair[0].center = Vec3(-1), pair[1].center = Vec3(1);
  pair.push_back(Sphere{Vec3(0), Real(2.2), 0});      // a box 4.4 wide: (4.4 / 2.1)² ≈ 4.4 times the area
  CHECK(Bvh(pair).outsidePrimitives() == std::vector<int>{20});
  pair.back().radius = Real(1.9); // (3.8 / 2.1)² ≈ 3.3
  CHECK(Bvh(pair).outsidePrimitives().empty());
  // A big sphere away from the others, not over them, stays in.
  pair.back() = Sphere{Vec3(10, 0, 0), Real(5), 0};
  CHECK(Bvh(pair).outsidePrimitives().empty());
  // At most kMaxOutside, and at most a quarter of the primitives.
  std::vector<Sphere> nested;
  for (int i = 0; i < 80; ++i)
    nested.push_back(Sphere{Vec3(0), std::pow(Real(3), Real(i)), 0});
  CHECK(Bvh(nested).outsidePrimitives().size() == std::size_t(kMaxOutside));
  nested.resize(40);
  CHECK(Bvh(nested).outsidePrimitives().size() == 10);
  const std::vector<Sphere> four{Sphere{Vec3(0), 1000, 0}, Sphere{Vec3(0), 1, 0}, Sphere{Vec3(1), 1, 0},
                                 Sphere{Vec3(2), 1, 0}};
  CHECK(Bvh(four).outsidePrimitives() == std::vector<int>{0});
  CHECK(Bvh(std::vector<Sphere>(four.begin(), four.begin() + 3)).outsidePrimitives().empty());
  // Off, the tree holds everything, with the same hits.
  BvhBuildOptions all;
  all.hugeOutside = false;
  const Bvh inside(room, all), outside(room);
  CHECK(inside.outsidePrimitives().empty());
  Random rays(9);
  for (int i = 0; i < 20000; ++i) {
    const Ray ray = randomRay(rays, room, 150);
    const std::optional<BvhHit> a = inside.intersect(ray), b = outside.intersect(ray);
    REQUIRE(a.has_value() == b.has_value());
    if (a) {
      REQUIRE(a->primitive == b->primitive);
      REQUIRE(std::memcmp(&a->t, &b->t, sizeof(Real)) == 0);
    }
    REQUIRE(inside.occluded(ray) == outside.occluded(ray));
  }
}

TEST_CASE("rays walked side by side (bvh_bench's experiment) get intersect's answers bit for bit")
{
  Random random(41);
  BvhBuildOptions four;
  four.eightAtOnce = false;
  const std::vector<Sphere> scenes[] = {uniformScene(random, 300), groundScene(random, 200), roomScene(random, 500),
                                        clusteredScene(random, 400), {Sphere{Vec3(0), 1, 0}}};
  for (const std::vector<Sphere>& spheres : scenes)
    for (const Bvh& bvh : {Bvh(spheres), Bvh(spheres, four)}) {
      std::vector<Ray> rays;
      for (int i = 0; i < 20000; ++i)
        rays.push_back(randomRay(random, spheres, 150));
      for (const Ray& ray : nonFiniteRays(random, 12))
        rays.push_back(ray);
      for (const int inFlight : {1, 2, 4}) {
        INFO(spheres.size() << " spheres, " << inFlight << " in flight, "
                            << (bvh.eightAtOnce() ? "eight" : "four") << " boxes at a time");
        std::vector<std::optional<BvhHit>> out(rays.size(), BvhHit{-1, -7}); // not what any query answers
        bvh.intersectInterleaved(rays, out, inFlight);
        std::size_t differ = 0, hits = 0;
        for (std::size_t i = 0; i < rays.size(); ++i) {
          const std::optional<BvhHit> one = bvh.intersect(rays[i]);
          hits += one.has_value();
          differ += one.has_value() != out[i].has_value() ||
                    (one && (one->primitive != out[i]->primitive || std::memcmp(&one->t, &out[i]->t, sizeof(Real))));
        }
        CHECK(differ == 0);
        CHECK(hits > rays.size() / 20);
      }
    }
  // An empty tree and a short answer array.
  std::vector<std::optional<BvhHit>> out(3, BvhHit{1, 1});
  const std::vector<Ray> rays(3, Ray{});
  Bvh().intersectInterleaved(rays, out, 2);
  CHECK_FALSE((out[0] || out[1] || out[2]));
  CHECK_THROWS_AS(Bvh().intersectInterleaved(rays, std::span(out).first(2), 2), std::invalid_argument);
  CHECK_THROWS_AS(Bvh().intersectInterleaved(rays, out, 3), std::invalid_argument);
}

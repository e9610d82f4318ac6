// Triangles: the watertight test's answers on simple cases, and the BVH over spheres and triangles against the
// brute-force loop (the same primitive and the same t, bit for bit) on over a million rays aimed at vertices, edges,
// faces, planes and spheres; the scene's flat list and tree in agreement; a leaf holding one kind only.
#include "geometry/bvh.h"
#include "random_meshes.h"
#include "scene/scene.h"

#include <catch2/catch.hpp>

#include <cstring>

using namespace raylife;
using namespace raylife::testing;

namespace {

// A scene's geometry for the tree: spheres, vertices, triangles.
struct Mixed {
  std::vector<Sphere> spheres;
  std::vector<Vec3> vertices;
  std::vector<Triangle> triangles;

  void add(const TestMesh<Real>& m)
  {
    const auto base = std::uint32_t(vertices.size());
    vertices.insert(vertices.end(), m.vertices.begin(), m.vertices.end());
    for (const auto& t : m.triangles)
      triangles.push_back(Triangle{{base + t[0], base + t[1], base + t[2]}, 0, 0});
  }
};

// A ray of one of the awkward kinds for triangles, or, one time in four, randomRay's kinds for the spheres. (Its
// draws are made one statement at a time, as random_scenes.h says why, in the order GCC made them before.)
Ray triangleRay(Random& random, const Mixed& s, Real extent)
{
  if (!s.spheres.empty() && random.index(4) == 0)
    return randomRay(random, s.spheres, extent);
  const Triangle& tri = s.triangles[random.index(s.triangles.size())];
  const Vec3 p[3] = {s.vertices[tri.v[0]], s.vertices[tri.v[1]], s.vertices[tri.v[2]]};
  Ray ray;
  ray.origin = random.inBox(-extent, extent);
  Vec3 target;
  switch (random.index(6)) {
  case 0: // exactly at a vertex
    target = p[random.index(3)];
    break;
  case 1: { // at a point of an edge
    const std::size_t e = random.index(3);
    target = p[e] + (p[(e + 1) % 3] - p[e]) * random.uniform();
    break;
  }
  case 2: { // at a point inside the face
    const Real a = random.uniform(), b = random.uniform() * (1 - a);
    target = p[0] + (p[1] - p[0]) * a + (p[2] - p[0]) * b;
    break;
  }
  case 3: { // in the triangle's own plane (grazing: parallel to the face)
    const Vec3 e1 = p[1] - p[0], e2 = p[2] - p[0];
    const Real originAlong2 = random.uniform(-1, 2);
    const Real originAlong1 = random.uniform(-1, 2);
    ray.origin = p[0] + e1 * originAlong1 + e2 * originAlong2;
    const Real targetAlong2 = random.uniform(-1, 2);
    const Real targetAlong1 = random.uniform(-1, 2);
    target = p[0] + e1 * targetAlong1 + e2 * targetAlong2;
    break;
  }
  case 4: { // from a point on the face (an unshifted secondary ray), any direction
    const Real a = random.uniform(), b = random.uniform() * (1 - a);
    ray.origin = p[0] + (p[1] - p[0]) * a + (p[2] - p[0]) * b;
    target = ray.origin + random.direction();
    break;
  }
  default: { // axis-aligned through a vertex's coordinates
    const int axis = int(random.index(3));
    ray.origin = p[random.index(3)];
    ray.origin[axis] = random.uniform(-extent, extent);
    target = ray.origin;
    target[axis] += random.index(2) ? Real(1) : Real(-1);
    break;
  }
  }
  ray.direction = safeNormalize(target - ray.origin, Vec3(0, 0, 1));
  if (random.index(4) == 0) {
    ray.tmin = random.uniform(0, extent);
    ray.tmax = ray.tmin + random.uniform(0, 2 * extent);
  }
  return ray;
}

struct Agreement {
  std::size_t rays = 0, hits = 0, triangleHits = 0, closest = 0, anyHit = 0, boxTests = 0;
  std::string first;
};

Agreement compare(const Mixed& s, std::size_t rays, std::uint64_t seed, Real extent)
{
  const Bvh bvh(s.spheres, s.vertices, s.triangles);
  BvhBuildOptions fourOptions;
  fourOptions.eightAtOnce = false;
  const Bvh four(s.spheres, s.vertices, s.triangles, fourOptions);
  // Leaves priced by their packs of four, as a big tree's are: full packs, every lane in use.
  BvhBuildOptions packedOptions;
  packedOptions.packPricedFrom = 0;
  const Bvh packed(s.spheres, s.vertices, s.triangles, packedOptions);
  // And every leaf priced by its triangles (in a tree this small, no node priced by packs for being small).
  BvhBuildOptions byTrianglesOptions;
  byTrianglesOptions.packPricedFrom = 1 << 30;
  byTrianglesOptions.packPricedBelowArea = 0;
  const Bvh byTriangles(s.spheres, s.vertices, s.triangles, byTrianglesOptions);
  Random random(seed);
  Agreement a;
  for (std::size_t i = 0; i < rays; ++i) {
    const Ray ray = triangleRay(random, s, extent);
    const std::optional<Reference> expected = bruteForce(s.spheres, s.vertices, s.triangles, ray);
    const std::optional<BvhHit> got = bvh.intersect(ray);
    auto agrees = [&expected](const std::optional<BvhHit>& h) {
      return expected.has_value() == h.has_value() &&
             (!expected || (expected->sphere == h->primitive && std::memcmp(&expected->t, &h->t, sizeof(Real)) == 0));
    };
    const bool same = agrees(got) && agrees(packed.intersect(ray)) && agrees(byTriangles.intersect(ray));
    if (!same && a.first.empty())
      a.first = describe(ray) + ": brute force " +
                (expected ? std::to_string(expected->sphere) + " at " + std::to_string(expected->t) : "miss") +
                ", BVH " + (got ? std::to_string(got->primitive) + " at " + std::to_string(got->t) : "miss");
    a.closest += !same;
    a.anyHit += bvh.occluded(ray) != expected.has_value() || packed.occluded(ray) != expected.has_value() ||
                byTriangles.occluded(ray) != expected.has_value();
    const BvhTracedHit byFour = four.intersectWithWork(ray), byEight = bvh.intersectWithWork(ray);
    a.boxTests += byFour.hit.has_value() != byEight.hit.has_value() ||
                  (byFour.hit && byFour.hit->primitive != byEight.hit->primitive) ||
                  byFour.work.nodesVisited != byEight.work.nodesVisited ||
                  byFour.work.primitivesTested != byEight.work.primitivesTested;
    a.hits += expected.has_value();
    a.triangleHits += expected && std::size_t(expected->sphere) >= s.spheres.size();
    ++a.rays;
  }
  return a;
}

void checkAgreement(const Mixed& s, std::size_t allRays, std::uint64_t seed, Real extent)
{
  const std::size_t rays = raysToSend(allRays);
  const Agreement a = compare(s, rays, seed, extent);
  INFO(a.rays << " rays, " << a.hits << " hits (" << a.triangleHits << " on triangles); first disagreement: "
              << a.first);
  CHECK(a.closest == 0);
  CHECK(a.anyHit == 0);
  CHECK(a.boxTests == 0);
  CHECK(a.triangleHits > rays / 10); // the rays do meet the triangles
  CHECK(a.hits < rays);              // and some miss
}

} // namespace

// ---- The watertight test on simple cases ------------------------------------------------------------------------

TEST_CASE("a ray through a triangle's face hits it at the right t, with barycentrics that give the point")
{
  const Vec3 p0(0, 0, 0), p1(2, 0, 0), p2(0, 2, 0);
  const Vec3 o(Real(0.5), Real(0.25), 3), d(0, 0, -1);
  const auto h = intersectTriangle(o, d, p0, p1, p2, Real(0), kInfinity);
  REQUIRE(h);
  CHECK(h->t == Approx(3));
  CHECK(h->b0 + h->b1 + h->b2 == Approx(1));
  const TrianglePoint<Real> tp = trianglePoint(p0, p1, p2, h->b0, h->b1, h->b2);
  CHECK(tp.point.x == Approx(0.5));
  CHECK(tp.point.y == Approx(0.25));
  CHECK(std::abs(tp.point.z) <= tp.error.z + 1e-300);
  // From behind too: a triangle has two faces.
  CHECK(intersectTriangle(Vec3(Real(0.5), Real(0.25), -3), Vec3(0, 0, 1), p0, p1, p2, Real(0), kInfinity));
  // The geometric normal is the counter-clockwise side.
  CHECK(triangleNormal(p0, p1, p2).z == Approx(1));
}

TEST_CASE("a triangle is missed outside its edges, behind the ray, beyond tmax, before tmin, edge on, or degenerate")
{
  const Vec3 p0(0, 0, 0), p1(2, 0, 0), p2(0, 2, 0);
  CHECK_FALSE(intersectTriangle(Vec3(Real(1.5), Real(1.5), 3), Vec3(0, 0, -1), p0, p1, p2, Real(0), kInfinity));
  CHECK_FALSE(intersectTriangle(Vec3(Real(0.5), Real(0.5), 3), Vec3(0, 0, 1), p0, p1, p2, Real(0), kInfinity));
  CHECK_FALSE(intersectTriangle(Vec3(Real(0.5), Real(0.5), 3), Vec3(0, 0, -1), p0, p1, p2, Real(0), Real(2.9)));
  CHECK_FALSE(intersectTriangle(Vec3(Real(0.5), Real(0.5), 3), Vec3(0, 0, -1), p0, p1, p2, Real(3.1), kInfinity));
  CHECK_FALSE(intersectTriangle(Vec3(-1, Real(0.5), 0), Vec3(1, 0, 0), p0, p1, p2, Real(0), kInfinity)); // in plane
  CHECK_FALSE(intersectTriangle(Vec3(Real(0.5), 0, 3), Vec3(0, 0, -1), p0, p1, Vec3(1, 0, 0), Real(0), kInfinity));
  // tmax is exclusive and tmin inclusive, as for spheres.
  CHECK(intersectTriangle(Vec3(Real(0.5), Real(0.5), 3), Vec3(0, 0, -1), p0, p1, p2, Real(3), kInfinity));
  CHECK_FALSE(intersectTriangle(Vec3(Real(0.5), Real(0.5), 3), Vec3(0, 0, -1), p0, p1, p2, Real(0), Real(3)));
}

TEST_CASE("a ray leaving a triangle through spawnRay's offset never finds the same triangle, and without it some do")
{
  // A ray arrives at the triangle; a new ray leaves where it hit, in a random direction. Robust: the point from the
  // hit's barycentrics with its error bound (trianglePoint), moved off the face by offsetRayOrigin to the side the
  // new direction leaves through. The control, as a naive renderer does it: the point o + t·d, which carries the
  // error of t times the distance travelled, and no offset.
  Random random(17);
  int rays = 0, offsetHits = 0, naiveHits = 0;
  for (int i = 0; i < 100000; ++i) {
    const Real scale = std::pow(Real(10), random.uniform(-2, 5));
    // One draw a statement (see random_scenes.h), in the order GCC made them when some shared an expression.
    const Vec3 p0 = random.inBox(-scale, scale);
    const Real length1 = random.uniform(Real(0.01), 10);
    const Vec3 p1 = p0 + random.direction() * length1 * scale;
    const Real length2 = random.uniform(Real(0.01), 10);
    const Vec3 p2 = p0 + random.direction() * length2 * scale;
    const Real b1 = random.uniform(), b2 = random.uniform() * (1 - b1);
    const Vec3 aim = p0 + (p1 - p0) * b1 + (p2 - p0) * b2;
    const Real distance = random.uniform(1, 100);
    const Vec3 from = aim + random.direction() * (scale * distance);
    const Vec3 d = glm::normalize(aim - from);
    const auto h = intersectTriangle(from, d, p0, p1, p2, Real(0), kInfinity);
    if (!h)
      continue;
    ++rays;
    const Vec3 dir = random.direction();
    const TrianglePoint<Real> on = trianglePoint(p0, p1, p2, h->b0, h->b1, h->b2);
    const Vec3 origin = offsetRayOrigin(on.point, on.error, triangleNormal(p0, p1, p2), dir);
    offsetHits += intersectTriangle(origin, dir, p0, p1, p2, Real(0), kInfinity).has_value();
    naiveHits += intersectTriangle(from + h->t * d, dir, p0, p1, p2, Real(0), kInfinity).has_value();
  }
  INFO(offsetHits << " of " << rays << " offset rays and " << naiveHits
                  << " unshifted ones from o + t·d hit their own triangle again");
  CHECK(rays > 90000);
  CHECK(offsetHits == 0);
  CHECK(naiveHits > 100); // the control: the offset is what prevents it
}

// ---- The BVH over spheres and triangles ---------------------------------------------------------------------------

TEST_CASE("the BVH over triangles and spheres finds exactly the brute-force hit for a million random rays")
{
  Random random(77);
  SECTION("a closed jittered sphere mesh")
  {
    Mixed s;
    s.add(jitteredSphere<Real>(random, glm::dvec3(0), 5, 10, 20, 0.8));
    checkAgreement(s, 250000, 1, 8);
  }
  SECTION("grids of shared edges, and a sphere mesh far from the origin")
  {
    Mixed s;
    s.add(grid(8, 6));
    s.add(jitteredSphere<Real>(random, glm::dvec3(1e3, 2e3, -1e3), 50, 8, 16, 0.5));
    checkAgreement(s, 200000, 2, 2500);
  }
  SECTION("a soup of triangles of every size, slivers and duplicates")
  {
    Mixed s;
    s.add(triangleSoup(random, 300, 10));
    checkAgreement(s, 250000, 3, 12);
  }
  SECTION("a mesh whose corners are all floats: its packs hold floats, in fewer bytes, with the same hits")
  {
    Mixed s;
    s.add(jitteredSphere<Real>(random, glm::dvec3(0), 5, 10, 20, 0.8));
    s.add(triangleSoup(random, 300, 10));
    const std::size_t doubleBytes = Bvh(s.spheres, s.vertices, s.triangles).memoryBytes();
    // (Through a volatile float: GCC 12 at -O2 and above, vectorising this loop, dropped the rounding to float.)
    for (Vec3& v : s.vertices)
      for (int axis = 0; axis < 3; ++axis) {
        const volatile float rounded = float(v[axis]);
        v[axis] = Real(rounded);
      }
    if constexpr (!std::is_same_v<Real, float>)
      CHECK(Bvh(s.spheres, s.vertices, s.triangles).memoryBytes() < doubleBytes);
    checkAgreement(s, 200000, 5, 12);
  }
  SECTION("spheres and triangles together")
  {
    Mixed s;
    s.spheres = groundScene(random, 100);
    s.add(jitteredSphere<Real>(random, glm::dvec3(0, 2, 0), 1.5, 8, 16, 0.7));
    s.add(triangleSoup(random, 150, 11));
    checkAgreement(s, 250000, 4, 12);
  }
  SECTION("a huge floor quad through a flat layer of triangles and spheres, kept out of the tree")
  {
    // The layer is 20 wide and about 1 high; the floor (two triangles, one of them twice) crosses it: its box, 800
    // wide, covers over half the layer's.
    Mixed s;
    s.spheres = uniformScene(random, 20);
    for (Sphere& sphere : s.spheres) {
      sphere.center.y *= Real(0.05);
      sphere.radius *= Real(0.05);
    }
    TestMesh<Real> room;
    const Real w = 400;
    room.vertices = {Vec3(-w, 0, -w), Vec3(w, 0, -w), Vec3(w, 0, w), Vec3(-w, 0, w)};
    room.triangles = {{0, 2, 1}, {0, 3, 2}, {0, 3, 2}};
    s.add(room);
    TestMesh<Real> soup = triangleSoup(random, 200, 10);
    for (Vec3& v : soup.vertices)
      v.y *= Real(0.05);
    s.add(soup);
    REQUIRE(Bvh(s.spheres, s.vertices, s.triangles).outsidePrimitives() == std::vector<int>{20, 21, 22});
    checkAgreement(s, 200000, 5, 12);
  }
  SECTION("copies of a grid: each triangle four times over, side by side in a leaf's lanes, the lowest number wins")
  {
    Mixed s;
    const TestMesh<Real> g = grid(6, 3);
    for (int copy = 0; copy < 4; ++copy)
      s.add(g);
    checkAgreement(s, 50000, 6, 4);
  }
  SECTION("tiny scenes")
  {
    for (int n : {1, 2, 3, 5, 9}) {
      Mixed s;
      s.add(triangleSoup(random, n, 3));
      if (n > 2)
        s.spheres = uniformScene(random, n / 2);
      checkAgreement(s, 20000, std::uint64_t(10 + n), 4);
    }
  }
}

TEST_CASE("rays with a NaN or an infinity in them get the brute-force answer over triangles too")
{
  // A ray with a NaN "hits" every box (see test_bvh.cpp), so it reaches every leaf, and its NaNs every lane of the
  // triangles' test: whatever the lanes refuse early or late, they must end where the scalar test does.
  Random random(31);
  Mixed s;
  s.spheres = uniformScene(random, 20);
  s.add(jitteredSphere<Real>(random, glm::dvec3(0), 5, 10, 20, 0.8));
  s.add(triangleSoup(random, 200, 10));
  Mixed floats = s; // corners that are floats: packs of floats
  for (Vec3& v : floats.vertices)
    for (int axis = 0; axis < 3; ++axis) {
      const volatile float rounded = float(v[axis]); // (as in the million rays' test above)
      v[axis] = Real(rounded);
    }
  BvhBuildOptions four;
  four.eightAtOnce = false;
  for (const Mixed* scene : {&s, &floats}) {
    const Bvh trees[2] = {Bvh(scene->spheres, scene->vertices, scene->triangles),
                          Bvh(scene->spheres, scene->vertices, scene->triangles, four)};
    for (int round = 0; round < 50; ++round)
      for (const Ray& ray : nonFiniteRays(random, 12))
        for (const Bvh& bvh : trees) {
          INFO(describe(ray) << (bvh.eightAtOnce() ? ", eight boxes at a time" : ", four boxes at a time"));
          const std::optional<Reference> expected = bruteForce(scene->spheres, scene->vertices, scene->triangles, ray);
          const std::optional<BvhHit> got = bvh.intersect(ray);
          REQUIRE(got.has_value() == expected.has_value());
          if (expected) {
            CHECK(got->primitive == expected->sphere);
            CHECK(std::memcmp(&got->t, &expected->t, sizeof(Real)) == 0);
          }
          CHECK(bvh.occluded(ray) == expected.has_value());
        }
  }
}

TEST_CASE("a leaf of the BVH holds spheres or triangles, never both, and the tree counts both")
{
  Random random(5);
  Mixed s;
  s.spheres = uniformScene(random, 40);
  s.add(triangleSoup(random, 60, 10));
  BvhBuildOptions keep;
  keep.keepBinaryTree = true;
  const Bvh bvh(s.spheres, s.vertices, s.triangles, keep);
  REQUIRE(!bvh.nodes().empty());
  CHECK(bvh.primitiveCount() == 100 + 60 / 7 + 1);
  std::size_t spheresInLeaves = 0, trianglesInLeaves = 0;
  for (const BvhNode& n : bvh.nodes())
    (n.triangles ? trianglesInLeaves : spheresInLeaves) += n.count;
  CHECK(spheresInLeaves == s.spheres.size());
  CHECK(trianglesInLeaves == s.triangles.size());
}

TEST_CASE("in a small tree, nodes small against the scene are priced by their packs, a room's walls by triangles")
{
  BvhBuildOptions byArea, byTriangles, byPacks;
  byTriangles.packPricedBelowArea = 0;
  byPacks.packPricedFrom = 0;
  // A model alone, seen from outside: below the triangles' threshold, but nearly all of its nodes are small against
  // the whole, so its leaves fill their packs, as a big tree's do.
  Random random(12);
  Mixed model;
  model.add(jitteredSphere<Real>(random, glm::dvec3(0, 0, 0), 1, 30, 60, 0.7));
  REQUIRE(model.triangles.size() < std::size_t(byArea.packPricedFrom));
  const Bvh area(model.spheres, model.vertices, model.triangles, byArea);
  const Bvh triangles(model.spheres, model.vertices, model.triangles, byTriangles);
  const Bvh packs(model.spheres, model.vertices, model.triangles, byPacks);
  INFO("wide nodes: " << area.wideNodes().size() << " (by packs where small), " << triangles.wideNodes().size()
                      << " (by triangles), " << packs.wideNodes().size() << " (by packs)");
  CHECK(area.wideNodes().size() < triangles.wideNodes().size() * 2 / 3);
  CHECK(area.wideNodes().size() < packs.wideNodes().size() * 11 / 10);
  CHECK(area.memoryBytes() < triangles.memoryBytes());

  // A room's six walls, two triangles each: every node spans a good part of the room (a wall is a third of its
  // surface), so the tree is the one priced by triangles, node for node.
  Mixed room;
  room.vertices = {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(1, 1, 0), Vec3(0, 1, 0),
                   Vec3(0, 0, 1), Vec3(1, 0, 1), Vec3(1, 1, 1), Vec3(0, 1, 1)};
  const std::uint32_t quads[6][4] = {{0, 1, 2, 3}, {4, 5, 6, 7}, {0, 1, 5, 4}, {3, 2, 6, 7}, {0, 3, 7, 4}, {1, 2, 6, 5}};
  for (const auto& q : quads) {
    room.triangles.push_back(Triangle{{q[0], q[1], q[2]}, 0, 0});
    room.triangles.push_back(Triangle{{q[0], q[2], q[3]}, 0, 0});
  }
  const Bvh roomByArea(room.spheres, room.vertices, room.triangles, byArea);
  const Bvh roomByTriangles(room.spheres, room.vertices, room.triangles, byTriangles);
  const Bvh roomByPacks(room.spheres, room.vertices, room.triangles, byPacks);
  REQUIRE(roomByArea.wideNodes().size() == roomByTriangles.wideNodes().size());
  CHECK(std::memcmp(roomByArea.wideNodes().data(), roomByTriangles.wideNodes().data(),
                    roomByArea.wideNodes().size() * sizeof(BvhWideNode)) == 0);
  // (Priced by packs in every node, the walls are merged into fuller leaves: a different tree.)
  CHECK(roomByPacks.memoryBytes() != roomByTriangles.memoryBytes());
}

TEST_CASE("the scene's flat list and its tree give the same hits over triangles")
{
  // The same geometry in a scene below kFlatListMaxPrimitives (a flat loop) and, with far-away filler added after
  // it, in a tree: every ray that the filler cannot reach gets the same hit record either way.
  Random random(9);
  Scene small;
  small.materials.push_back(Material{});
  const TestMesh<Real> soup = triangleSoup(random, 3, 2);
  small.vertices = soup.vertices;
  for (const auto& t : soup.triangles)
    small.triangles.push_back(Triangle{{t[0], t[1], t[2]}, 0, 0});
  small.meshes.push_back(Mesh{"inline", 0, false, 0, std::uint32_t(small.triangles.size())});
  small.spheres = {Sphere{Vec3(0, 0, 0), Real(0.5), 0}, Sphere{Vec3(1, 1, 0), Real(0.3), 0}};
  small.buildAccelerator();
  REQUIRE_FALSE(small.usesAccelerator());
  Scene big = small;
  for (int i = 0; i < 20; ++i)
    big.spheres.push_back(Sphere{Vec3(1000 + 3 * i, 1000, 1000), 1, 0});
  // (The filler spheres come after the first two, so the triangles' numbers move by 20 in the big scene.)
  big.buildAccelerator();
  REQUIRE(big.usesAccelerator());
  int hits = 0;
  for (int i = 0; i < 20000; ++i) {
    // Half the rays aimed at a vertex of the soup or near a sphere, so that many hit.
    const Vec3 from = random.inBox(-3, 3);
    const Vec3 at = i % 2 ? small.vertices[random.index(small.vertices.size())] : random.inBox(-1, 1);
    const Ray ray{from, i % 4 == 3 ? random.direction() : safeNormalize(at - from, Vec3(0, 0, 1)), 0, kInfinity};
    const std::optional<Hit> a = small.intersect(ray), b = big.intersect(ray);
    REQUIRE(a.has_value() == b.has_value());
    REQUIRE(small.occluded(ray) == a.has_value());
    REQUIRE(big.occluded(ray) == b.has_value());
    if (!a)
      continue;
    ++hits;
    const int shift = a->primitive >= 2 ? 20 : 0;
    REQUIRE(a->primitive + shift == b->primitive);
    REQUIRE(std::memcmp(&a->t, &b->t, sizeof(Real)) == 0);
    REQUIRE(a->point == b->point);
    REQUIRE(a->normal == b->normal);
    REQUIRE(small.intersectPrimitive(ray, a->primitive) == a->t);
  }
  CHECK(hits > 5000);
}

namespace {

// A packet of camera-like rays: from points near `eye` (a lens of `aperture`) through a small patch of an image
// plane looking at `target`, `count` of them; with `spread` 0 they share one origin.
std::vector<Ray> bundle(Random& random, const Vec3& eye, const Vec3& target, Real patch, Real aperture, int count)
{
  std::vector<Ray> rays;
  const Vec3 centre = target + random.inBox(-patch * 20, patch * 20);
  for (int i = 0; i < count; ++i) {
    Ray ray;
    ray.origin = eye + random.inBox(-aperture, aperture);
    ray.direction = glm::normalize(centre + random.inBox(-patch, patch) - ray.origin);
    rays.push_back(ray);
  }
  return rays;
}

} // namespace

TEST_CASE("packets of rays walk the tree together and get intersect's answers bit for bit")
{
  Random random(91);
  Mixed spheresOnly, mesh, mixed, ground;
  spheresOnly.spheres = clusteredScene(random, 400);
  mesh.add(jitteredSphere<Real>(random, glm::dvec3(0), 5, 12, 24, 0.8));
  mesh.add(grid(6, 9));
  mixed.add(triangleSoup(random, 300, 10));
  mixed.spheres = uniformScene(random, 200);
  ground.spheres = groundScene(random, 300); // a huge sphere kept outside the tree
  BvhBuildOptions four;
  four.eightAtOnce = false;
  for (const Mixed* s : {&spheresOnly, &mesh, &mixed, &ground})
    for (const Bvh& bvh : {Bvh(s->spheres, s->vertices, s->triangles), Bvh(s->spheres, s->vertices, s->triangles, four)}) {
      std::vector<Ray> rays;
      // Coherent packets (the case they are for): pinhole and lens bundles, narrow and wide, from near and far.
      for (int p = 0; p < 300; ++p) {
        const Vec3 eye = random.inBox(-40, 40), target = random.inBox(-3, 3);
        const Real patch = p % 3 == 0 ? Real(1e-3) : p % 3 == 1 ? Real(0.05) : Real(2);
        for (const Ray& ray : bundle(random, eye, target, patch, p % 2 == 0 ? Real(0) : Real(0.3), 16))
          rays.push_back(ray);
      }
      // Incoherent ones (signs differ: each walks alone), axis-aligned directions (a zero component), intervals
      // that start late or end early, and rays with a NaN or an infinity in them.
      for (int i = 0; i < 3000; ++i)
        rays.push_back(!s->triangles.empty() && (s->spheres.empty() || i % 2) ? triangleRay(random, *s, 12)
                                                                              : randomRay(random, s->spheres, 12));
      for (int i = 0; i < 64; ++i) {
        Ray ray;
        ray.origin = random.inBox(-1, 1) + Vec3(0, 0, 30);
        ray.direction = Vec3(0, 0, -1);
        if (i % 4 == 1)
          ray.direction = glm::normalize(Vec3(0, random.uniform(0, Real(0.1)), -1));
        if (i % 8 == 3)
          ray.tmin = 25, ray.tmax = 40;
        rays.push_back(ray);
      }
      for (const Ray& ray : nonFiniteRays(random, 12))
        rays.push_back(ray);
      std::vector<std::optional<BvhHit>> out(rays.size(), BvhHit{-1, -7}); // not what any query answers
      bvh.intersectPacket(rays, out);
      std::size_t differ = 0, hits = 0;
      for (std::size_t i = 0; i < rays.size(); ++i) {
        const std::optional<BvhHit> one = bvh.intersect(rays[i]);
        hits += one.has_value();
        differ += one.has_value() != out[i].has_value() ||
                  (one && (one->primitive != out[i]->primitive || std::memcmp(&one->t, &out[i]->t, sizeof(Real))));
      }
      INFO(s->spheres.size() << " spheres, " << s->triangles.size() << " triangles, "
                             << (bvh.eightAtOnce() ? "eight" : "four") << " boxes at a time, " << hits << " hits");
      CHECK(differ == 0);
      CHECK(hits > rays.size() / 10);
      CHECK(hits < rays.size());
    }
  std::vector<std::optional<BvhHit>> out(3, BvhHit{1, 1});
  const std::vector<Ray> rays(3, Ray{});
  Bvh().intersectPacket(rays, out);
  CHECK_FALSE((out[0] || out[1] || out[2]));
  CHECK_THROWS_AS(Bvh().intersectPacket(rays, std::span(out).first(2)), std::invalid_argument);
}

TEST_CASE("the build on any number of threads gives the one-thread tree, node for node")
{
  Random random(9);
  Mixed s;
  s.spheres = clusteredScene(random, 3000);
  s.add(jitteredSphere<Real>(random, glm::dvec3(0, 2, 0), 1.5, 100, 200, 0.7)); // some 40,000 triangles
  s.add(triangleSoup(random, 5000, 11));
  // Leaves priced by their packs (as a big tree's are), by their triangles, and by their packs in small nodes only.
  for (const auto& [packPricedFrom, packPricedBelowArea] :
       {std::pair{0, 0.0}, std::pair{1 << 30, 0.0}, std::pair{1 << 30, BvhBuildOptions{}.packPricedBelowArea}}) {
    INFO("packPricedFrom " << packPricedFrom << ", packPricedBelowArea " << packPricedBelowArea);
    BvhBuildOptions options;
    options.keepBinaryTree = true;
    options.buildThreads = 1;
    options.packPricedFrom = packPricedFrom;
    options.packPricedBelowArea = packPricedBelowArea;
    const Bvh serial(s.spheres, s.vertices, s.triangles, options);
    REQUIRE(serial.nodes().size() > 10000);
    for (int threads : {2, 3, 8}) {
      INFO(threads << " threads");
      options.buildThreads = threads;
      const Bvh parallel(s.spheres, s.vertices, s.triangles, options);
      REQUIRE(parallel.nodes().size() == serial.nodes().size());
      CHECK(std::memcmp(parallel.nodes().data(), serial.nodes().data(),
                        serial.nodes().size() * sizeof(BvhNode)) == 0);
      REQUIRE(parallel.wideNodes().size() == serial.wideNodes().size());
      CHECK(std::memcmp(parallel.wideNodes().data(), serial.wideNodes().data(),
                        serial.wideNodes().size() * sizeof(BvhWideNode)) == 0);
      CHECK(parallel.depth() == serial.depth());
      CHECK(parallel.sahCost() == serial.sahCost());
      CHECK(parallel.memoryBytes() == serial.memoryBytes());
    }
  }
}

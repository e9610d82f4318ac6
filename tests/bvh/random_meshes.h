// Triangle meshes for the tests of triangles (tests/bvh, tests/stability): a closed, jittered, tessellated sphere,
// grids of shared edges, boxes, random soups; rays aimed exactly at their vertices and edges; and the brute-force
// loop over spheres and triangles that the BVH and the scene must agree with, written out here.
#pragma once

#include "random_scenes.h"

#include "geometry/triangle.h"

#include <array>
#include <vector>

namespace raylife::testing {

// Vertices and triangles (counter-clockwise seen from outside, for the closed ones).
template <class T> struct TestMesh {
  std::vector<TVec3<T>> vertices;
  std::vector<std::array<std::uint32_t, 3>> triangles;
};

// A sphere of radius r about c, tessellated by latitude and longitude (`rings` × `segments`, poles shared), every
// vertex but the poles moved at random by up to `jitter` of the spacing: a closed mesh whose triangles meet at
// shared edges and vertices at all angles. Built in double, then rounded to T (vertices shared bit for bit).
template <class T>
TestMesh<T> jitteredSphere(Random& random, const glm::dvec3& c, double r, int rings, int segments, double jitter)
{
  TestMesh<T> m;
  const double step = std::numbers::pi / rings;
  auto add = [&](const glm::dvec3& p) { m.vertices.push_back(TVec3<T>(c + p)); };
  add(glm::dvec3(0, r, 0)); // north pole: vertex 0
  for (int i = 1; i < rings; ++i)
    for (int j = 0; j < segments; ++j) {
      const double theta = (i + jitter * double(random.uniform(-1, 1)) * 0.5) * step;
      const double phi = (j + jitter * double(random.uniform(-1, 1)) * 0.5) * 2 * std::numbers::pi / segments;
      add(r * glm::dvec3(std::sin(theta) * std::cos(phi), std::cos(theta), -std::sin(theta) * std::sin(phi)));
    }
  add(glm::dvec3(0, -r, 0)); // south pole
  const auto south = std::uint32_t(m.vertices.size() - 1);
  auto at = [&](int i, int j) { return std::uint32_t(1 + (i - 1) * segments + (j % segments)); };
  for (int j = 0; j < segments; ++j) {
    m.triangles.push_back({0, at(1, j), at(1, j + 1)});
    m.triangles.push_back({south, at(rings - 1, j + 1), at(rings - 1, j)});
  }
  for (int i = 1; i + 1 < rings; ++i)
    for (int j = 0; j < segments; ++j) {
      m.triangles.push_back({at(i, j), at(i + 1, j), at(i + 1, j + 1)});
      m.triangles.push_back({at(i, j), at(i + 1, j + 1), at(i, j + 1)});
    }
  return m;
}

// A flat n × n grid of squares, each cut in two, in the plane y = 0 over [−s, s]²: edges shared in a plane.
inline TestMesh<Real> grid(int n, Real s)
{
  TestMesh<Real> m;
  for (int i = 0; i <= n; ++i)
    for (int j = 0; j <= n; ++j)
      m.vertices.emplace_back(-s + 2 * s * Real(i) / Real(n), 0, -s + 2 * s * Real(j) / Real(n));
  auto at = [n](int i, int j) { return std::uint32_t(i * (n + 1) + j); };
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      m.triangles.push_back({at(i, j), at(i, j + 1), at(i + 1, j + 1)});
      m.triangles.push_back({at(i, j), at(i + 1, j + 1), at(i + 1, j)});
    }
  return m;
}

// `n` random triangles in [−extent, extent]³, of sizes over three orders of magnitude, some slivers, some duplicates.
inline TestMesh<Real> triangleSoup(Random& random, int n, Real extent)
{
  TestMesh<Real> m;
  for (int k = 0; k < n; ++k) {
    const Vec3 a = random.inBox(-extent, extent);
    const Real size = std::pow(Real(10), random.uniform(-2, 1));
    Vec3 b = a + random.direction() * size, c = a + random.direction() * size;
    // A sliver: its width a millionth of its length in double; in float that is below the coordinates' precision
    // (the triangle comes out degenerate, and a scene of it alone is never hit), so there a ten-thousandth.
    constexpr Real kSliver = sizeof(Real) == 4 ? Real(1e-4) : Real(1e-6);
    if (k % 10 == 0) { // (the direction drawn first, as GCC drew it when both draws were in one expression)
      const Vec3 across = random.direction();
      const Real along = random.uniform(0, 1);
      c = a + (b - a) * along + across * (size * kSliver);
    }
    const auto first = std::uint32_t(m.vertices.size());
    m.vertices.insert(m.vertices.end(), {a, b, c});
    m.triangles.push_back({first, first + 1, first + 2});
    if (k % 7 == 0)
      m.triangles.push_back({first, first + 1, first + 2}); // the same triangle again: a tie, to the lower number
  }
  return m;
}

// The brute-force loop over spheres then triangles (sphere i is primitive i, triangle j is spheres + j): the
// nearest hit in [tmin, tmax), the lowest number on a tie.
inline std::optional<Reference> bruteForce(const std::vector<Sphere>& spheres, const std::vector<Vec3>& vertices,
                                           const std::vector<Triangle>& triangles, const Ray& ray)
{
  std::optional<Reference> nearest = bruteForce(spheres, ray); // the spheres first, as numbered
  for (std::size_t j = 0; j < triangles.size(); ++j) {
    const Triangle& tri = triangles[j];
    if (auto h = intersectTriangle(ray.origin, ray.direction, vertices[tri.v[0]], vertices[tri.v[1]],
                                   vertices[tri.v[2]], ray.tmin, nearest ? nearest->t : ray.tmax))
      nearest = Reference{h->t, int(spheres.size() + j)};
  }
  return nearest;
}

} // namespace raylife::testing

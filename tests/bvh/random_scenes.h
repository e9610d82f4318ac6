// Random scenes and rays of every awkward kind, and the brute-force loop they are checked against: shared by the
// tests of the BVH and of the sphere lanes (tests/bvh).
#pragma once

#include "../sanitizers.h"
#include "geometry/ray.h"
#include "core/rng.h"
#include "geometry/sphere.h"

#include <cmath>
#include <limits>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

namespace raylife::testing {

// ---- How many rays a check sends ------------------------------------------------------------------------------
// The rays an agreement check sends: all of them, or a tenth under AddressSanitizer. There the million-ray checks of
// the tree against the brute-force loop are about six times slower and took half of CI's sanitizer tests (190 of
// 383 s); a tenth still walks every kind of scene and ray through the instrumented code, and the release suite sends
// them all. Counts of 10,000 or fewer are sent whole.
constexpr std::size_t raysToSend(std::size_t rays)
{
  return kUnderAddressSanitizer && rays > 10000 ? rays / 10 : rays;
}

// ---- Random numbers for scenes and rays (raylife's own generator, so every platform draws the same) ----------
// Draws are made one statement at a time, never two in one call: C++ leaves the order of a call's arguments (and of
// an overloaded operator's operands) unspecified, GCC evaluating them right to left and clang left to right, and the
// scenes and rays must not depend on the compiler. Where one call used to make several draws, the statements make
// them in the order GCC did (the last argument first), so the tests keep the scenes and rays they had.
class Random {
public:
  explicit Random(std::uint64_t seed) : rng_(seed, 0x853c49e6748fea9bULL) {}
  Real uniform() { return Real(rng_.nextUint()) * Real(0x1p-32); }                 // [0, 1)
  Real uniform(Real lo, Real hi) { return lo + (hi - lo) * uniform(); }            // [lo, hi)
  std::size_t index(std::size_t n) { return std::size_t(rng_.nextUint()) % n; }    // [0, n)
  Vec3 inBox(Real lo, Real hi)
  {
    const Real z = uniform(lo, hi);
    const Real y = uniform(lo, hi);
    const Real x = uniform(lo, hi);
    return Vec3(x, y, z);
  }
  Vec3 direction() // uniform on the unit sphere
  {
    const Real z = uniform(-1, 1), phi = 2 * kPi * uniform();
    const Real s = std::sqrt(std::max(Real(0), 1 - z * z));
    return Vec3(s * std::cos(phi), s * std::sin(phi), z);
  }

private:
  Pcg32 rng_;
};

// ---- The reference: the brute-force loop, written out here so it cannot share a bug with the scene's ----------
struct Reference {
  Real t;
  int sphere;
};

inline std::optional<Reference> bruteForce(const std::vector<Sphere>& spheres, const Ray& ray)
{
  Real tNearest = ray.tmax;
  int nearest = -1;
  for (std::size_t i = 0; i < spheres.size(); ++i)
    if (auto t = intersectSphere(ray.origin, ray.direction, spheres[i].center, spheres[i].radius, ray.tmin, tNearest)) {
      tNearest = *t;
      nearest = int(i);
    }
  if (nearest < 0)
    return std::nullopt;
  return Reference{tNearest, nearest};
}

// ---- Scenes ---------------------------------------------------------------------------------------------------
inline std::vector<Sphere> uniformScene(Random& random, int n)
{
  std::vector<Sphere> s;
  for (int i = 0; i < n; ++i)
    s.push_back(Sphere{random.inBox(-10, 10), random.uniform(Real(0.05), Real(1.5)), 0});
  return s;
}

// Dense clusters of spheres of sizes over three orders of magnitude, far apart.
inline std::vector<Sphere> clusteredScene(Random& random, int n)
{
  std::vector<Sphere> s;
  std::vector<Vec3> centres;
  for (int c = 0; c < 6; ++c)
    centres.push_back(random.inBox(-50, 50));
  for (int i = 0; i < n; ++i) {
    const Vec3 offset = random.inBox(-2, 2);
    const Vec3 c = centres[random.index(centres.size())] + offset;
    s.push_back(Sphere{c, std::pow(Real(10), random.uniform(-3, 0)), 0});
  }
  return s;
}

// Exact duplicates and concentric spheres: hits at identical t, which must go to the lowest index.
inline std::vector<Sphere> duplicateScene(Random& random, int n)
{
  std::vector<Sphere> s = uniformScene(random, n / 2);
  const std::size_t originals = s.size();
  for (std::size_t i = 0; i < originals; ++i) {
    const Sphere& o = s[random.index(originals)];
    if (i % 3 == 0)
      s.push_back(Sphere{o.center, o.radius * Real(0.5), 0}); // concentric
    else
      s.push_back(o); // the same sphere again
  }
  // A few duplicates placed *before* their originals too.
  for (int i = 0; i < 10; ++i)
    s.insert(s.begin(), s[random.index(s.size())]);
  return s;
}

// Equal spheres on a lattice, touching: axis-aligned rays through their centres meet them on their boxes' faces,
// and leave one sphere where they enter the next.
inline std::vector<Sphere> latticeScene(int side)
{
  std::vector<Sphere> s;
  for (int x = 0; x < side; ++x)
    for (int y = 0; y < side; ++y)
      for (int z = 0; z < side; ++z)
        s.push_back(Sphere{Vec3(x, y, z), Real(0.5), 0});
  return s;
}

// The tutorial's ground: one huge sphere under many small ones.
inline std::vector<Sphere> groundScene(Random& random, int n)
{
  std::vector<Sphere> s{Sphere{Vec3(0, -1000, 0), 1000, 0}};
  for (int i = 1; i < n; ++i) {
    const Real r = random.uniform(Real(0.1), Real(0.4));
    const Real z = random.uniform(-11, 11);
    const Real x = random.uniform(-11, 11);
    s.push_back(Sphere{Vec3(x, r, z), r, 0});
  }
  return s;
}

// Smallpt's room: six walls of radius 1e5, its lamp of radius 600 mostly above the ceiling and two balls (spheres
// 0 to 8), then n small spheres, nine in ten behind the back wall (z < 0), the others in the room.
inline std::vector<Sphere> roomScene(Random& random, int n)
{
  std::vector<Sphere> s{Sphere{Vec3(1e5 + 1, 40.8, 81.6), 1e5, 0},     Sphere{Vec3(-1e5 + 99, 40.8, 81.6), 1e5, 0},
                        Sphere{Vec3(50, 40.8, 1e5), 1e5, 0},           Sphere{Vec3(50, 40.8, -1e5 + 170), 1e5, 0},
                        Sphere{Vec3(50, 1e5, 81.6), 1e5, 0},           Sphere{Vec3(50, -1e5 + 81.6, 81.6), 1e5, 0},
                        Sphere{Vec3(27, 16.5, 47), 16.5, 0},           Sphere{Vec3(73, 16.5, 78), 16.5, 0},
                        Sphere{Vec3(50, 681.6 - 0.27, 81.6), 600, 0}};
  for (int i = 0; i < n; ++i) {
    const bool behind = i % 10 != 0;
    const Real z = behind ? random.uniform(-60, -2) : random.uniform(5, 165);
    const Real y = random.uniform(0, 80);
    const Real x = random.uniform(0, 100);
    const Vec3 c(x, y, z);
    s.push_back(Sphere{c, random.uniform(Real(0.3), Real(1.5)), 0});
  }
  return s;
}

// ---- Rays of every awkward kind -------------------------------------------------------------------------------
inline Ray randomRay(Random& random, const std::vector<Sphere>& spheres, Real extent)
{
  const Sphere& s = spheres[random.index(spheres.size())];
  Ray ray;
  ray.direction = random.direction();
  switch (random.index(8)) {
  case 0: // anywhere around the scene, any direction
    ray.origin = random.inBox(-extent, extent);
    break;
  case 1: { // from inside a sphere
    const Real depth = random.uniform(0, Real(0.999));
    ray.origin = s.center + random.direction() * (s.radius * depth);
    break;
  }
  case 2: { // grazing: tangent to a sphere, or within a hair of it
    Vec3 side = glm::cross(ray.direction, random.direction());
    side = glm::normalize(side);
    const Real offset = s.radius * (1 + random.uniform(-1, 1) * Real(1e-9));
    ray.origin = s.center + side * offset - ray.direction * random.uniform(0, 3 * extent);
    break;
  }
  case 3: { // axis-aligned, through a sphere's centre line or near it
    const int axis = int(random.index(3));
    ray.direction = Vec3(0);
    ray.direction[axis] = random.index(2) ? 1 : -1;
    ray.origin = s.center + (random.index(2) ? Vec3(0) : random.inBox(-s.radius, s.radius));
    ray.origin[axis] = random.uniform(-extent, extent);
    break;
  }
  case 4: { // a direction with one zero component, from anywhere
    const int axis = int(random.index(3));
    ray.direction[axis] = 0;
    ray.direction = glm::normalize(ray.direction);
    ray.origin = random.inBox(-extent, extent);
    ray.origin[axis] = s.center[axis] + (random.index(2) ? 0 : s.radius); // in a centre's plane or a face's
    break;
  }
  case 5: // from a point on a sphere's surface (an unshifted secondary ray)
    ray.origin = s.center + random.direction() * s.radius;
    break;
  case 6: // from far away, aimed at a sphere
    ray.origin = random.direction() * (extent * 1000);
    ray.direction = glm::normalize(s.center + random.inBox(-s.radius, s.radius) - ray.origin);
    break;
  default: // aimed at a sphere from inside the scene
    ray.origin = random.inBox(-extent, extent);
    ray.direction = glm::normalize(s.center + random.inBox(-s.radius, s.radius) - ray.origin);
    break;
  }
  if (!isFinite(ray.direction) || glm::length(ray.direction) == 0)
    ray.direction = Vec3(0, 0, 1);
  if (random.index(4) == 0) { // a bounded interval, as shadow rays and later bounces have
    ray.tmin = random.uniform(0, extent);
    ray.tmax = ray.tmin + random.uniform(0, 2 * extent);
  }
  return ray;
}

// Eight rays outside Ray's contract, from random points in [−extent, extent)³: a NaN in each coordinate of the origin
// and of the direction, a NaN tmax, and an origin at infinity.
inline std::vector<Ray> nonFiniteRays(Random& random, Real extent)
{
  const Real nan = std::numeric_limits<Real>::quiet_NaN();
  std::vector<Ray> rays;
  for (int c = 0; c < 8; ++c) {
    Ray ray{random.inBox(-extent, extent), random.direction()};
    if (c < 3)
      ray.origin[c] = nan;
    else if (c < 6)
      ray.direction[c - 3] = nan;
    else if (c == 6)
      ray.tmax = nan;
    else
      ray.origin = Vec3(kInfinity, -kInfinity, kInfinity);
    rays.push_back(ray);
  }
  return rays;
}

inline std::string describe(const Ray& ray)
{
  std::ostringstream out;
  out.precision(17);
  out << "origin (" << ray.origin.x << ", " << ray.origin.y << ", " << ray.origin.z << ") direction ("
      << ray.direction.x << ", " << ray.direction.y << ", " << ray.direction.z << ") interval [" << ray.tmin << ", "
      << ray.tmax << ")";
  return out.str();
}

} // namespace raylife::testing

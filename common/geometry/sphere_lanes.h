/// @file sphere_lanes.h
/// @brief Spheres in groups of four, stored by coordinate, so that one ray is tested against four spheres at once
/// in the lanes of a SIMD register: the flat list of a small scene. (The BVH's leaves stay one by one: tried in
/// lanes, its shadow rays ran at about 0.7 times the speed, as docs/measurements/09_bvh.md tells.)
///
/// Why. A sphere test is a short chain of arithmetic and, in the one-by-one loop, several branches on the data
/// (behind the ray? inside? beyond the nearest hit so far?) that no predictor guesses well: in the Cornell box a
/// path tracer's ray mispredicts about five of them. Four lanes do the four tests together and decide with
/// masks instead of branches, so the loop over nine spheres becomes three passes of straight-line code.
///
/// The contract is the one-by-one loop's: each lane computes exactly what intersectSphere computes, operation for
/// operation, so every query returns the same sphere and the same t, bit for bit, as the loop over the same
/// spheres (the nearest hit in [ray.tmin, ray.tmax), the lowest index on a tie). tests/bvh checks this on millions
/// of rays. Four at a time needs AVX2 (x86-64 CPUs since 2013). Elsewhere the queries can test the lanes one by
/// one with intersectSphere (LaneTest::OneByOne), but the scene does not build lanes there and keeps its own loop;
/// either way a scene renders the same image on every machine.
#pragma once

#include "core/math.h"
#include "geometry/ray.h"
#include "geometry/sphere.h"

#include <optional>
#include <span>
#include <vector>

namespace raylife {

/// Four spheres side by side, stored by coordinate: lane k of group g is sphere 4g + k of the list. A lane without
/// a sphere (at the end of the last group) holds NaN, which no ray hits: NaN fails every comparison.
struct alignas(32) SphereGroup {
  /// Spheres in a group: four doubles fill one AVX2 register.
  static constexpr int kWidth = 4;
  Real centerX[kWidth]; ///< Centres' x, world space.
  Real centerY[kWidth]; ///< Centres' y.
  Real centerZ[kWidth]; ///< Centres' z.
  Real radius[kWidth];  ///< Radii, > 0 (NaN in an empty lane).
};

/// How a query tests a group.
enum class LaneTest {
  OneByOne,  ///< intersectSphere on each lane in turn: any CPU.
  FourAtOnce ///< The four lanes together (AVX2); only where laneTestAvailable(LaneTest::FourAtOnce).
};

/// True when this build and this CPU can run `test` (OneByOne always; FourAtOnce on x86-64 with AVX2).
bool laneTestAvailable(LaneTest test);

/// The fastest test this CPU runs: FourAtOnce where available, else OneByOne. Both give the same answers.
LaneTest fastestLaneTest();

/// `spheres`, in order, in groups of four (the last group padded with empty lanes).
std::vector<SphereGroup> groupSpheres(const std::vector<Sphere>& spheres);

/// The nearest sphere a ray hits: its index (as stored in its lane) and the distance.
struct SphereHit {
  Real t = 0;      ///< Ray parameter of the hit, in [ray.tmin, ray.tmax).
  int sphere = -1; ///< The sphere's index in the list: 4g + k for lane k of group g.
};

/// The nearest hit among the groups' spheres inside [ray.tmin, ray.tmax), exactly as the loop
/// `for each sphere, in order: t = intersectSphere(..., ray.tmin, tNearest)` finds it: the smallest t, and on a
/// tie the lowest index. Nothing when no sphere is hit. Contract as intersectSphere's: unit direction, tmin ≥ 0;
/// `test` must be available (laneTestAvailable).
std::optional<SphereHit> nearestInGroups(std::span<const SphereGroup> groups, const Ray& ray, LaneTest test);

/// True when any of the groups' spheres is hit inside [ray.tmin, ray.tmax) (the shadow-ray query): exactly when
/// nearestInGroups finds a hit. May stop at the first group with a hit.
bool anyInGroups(std::span<const SphereGroup> groups, const Ray& ray, LaneTest test);

/// A flat list of spheres in groups of four, with the test its queries use: a small scene's spheres (Scene).
/// Immutable after construction, so any number of threads may query it at once.
class SphereLanes {
public:
  /// An empty list: every query misses.
  SphereLanes() = default;
  /// All of `spheres`, in order (a copy of their geometry), tested by `test` (which must be available).
  explicit SphereLanes(const std::vector<Sphere>& spheres, LaneTest test = fastestLaneTest());

  /// nearestInGroups over the list: the sphere's index in the vector the list was made from.
  std::optional<SphereHit> intersect(const Ray& ray) const { return nearestInGroups(groups_, ray, test_); }
  /// anyInGroups over the list.
  bool occluded(const Ray& ray) const { return anyInGroups(groups_, ray, test_); }

  /// Spheres in the list.
  std::size_t size() const { return size_; }
  /// The test the queries use.
  LaneTest test() const { return test_; }

private:
  std::vector<SphereGroup> groups_;
  std::size_t size_ = 0;
  LaneTest test_ = LaneTest::OneByOne;
};

} // namespace raylife

// Case 2 — a huge sphere near the ray origin.
//
// Setup: the walls of the Cornell box as smallpt builds them, spheres of radius R = 1e5 whose centres lie 1e5
// away and which are seen from inside; and the same sphere seen from outside (a ground "plane"). Ray origins
// lie h = 1, 10 and 100 from the surface, 50 units across it; directions cover the hemisphere facing it,
// down to 84° from the normal (cos ≥ 0.1; closer to grazing, the far ground's silhouette makes t ill-conditioned for any method). Naive: the schoolbook quadratic. Robust:
// intersectSphereRoots. Reference: long double on the same inputs.
//
// What limits both. Forming f = o − c rounds each component by u·R, which moves the surface by u·R along the
// ray's view of it, so no method that starts from f in T can do better than a relative error of t about
// u·R/h. Both forms stay within a small multiple of that: here the robust form is no cure, and the measured
// figures say so. The cure is precision: the case's criterion for the renderer is a relative error of t of at
// most 1e-6 (1e-4 units at 100 units), which double meets with five orders to spare and float misses by four
// (u·R/h = 6e-3 at h = 1). This case is why raylife's Real is double.
#include "support.h"

#include <catch2/catch.hpp>

#include <algorithm>
#include <cstdio>

using namespace raylife;
using namespace raylife::stability;

namespace {

constexpr double kWallRadius = 1e5;

/// The bound asserted on the robust relative error of t, in units of u·R/h (see the file comment: the
/// rounding of f = o − c alone gives about 1; the closest-approach and c terms add a few more).
constexpr double kMaxErrorInUnitsOfURoverH = 4;

/// Directions closer to grazing than this cosine with the surface normal are not measured (file comment).
constexpr double kMinCosine = 0.1;

/// What the renderer needs of t near a wall: a relative error of at most a millionth.
constexpr double kRendererTolerance = 1e-6;

struct Wall {
  const char* name;
  glm::dvec3 centre;  // smallpt's Cornell box
  bool inside;        // the box is inside the sphere (a wall) or outside it (a ground)
};

struct HugeSphereFigures {
  double naiveMax = 0, robustMax = 0; // largest relative error of the forward hit's t
  int naiveMisses = 0, robustMisses = 0; // forward rays at a surface 1 to 100 away that found nothing
};

template <class T> HugeSphereFigures measureHugeSphere(const Wall& wall, double height, int rays, std::uint64_t seed)
{
  TestRng rng(seed);
  HugeSphereFigures fig;
  const double R = kWallRadius;
  // The surface point nearest the box, and the unit vector from it to the side the origins lie on: towards
  // the centre for a wall seen from inside, away from it for a ground seen from outside.
  const glm::dvec3 boxCentre(50, 40.8, 81.6);
  const glm::dvec3 toBox = glm::normalize(boxCentre - wall.centre);
  const glm::dvec3 surface = wall.centre + R * toBox;
  const glm::dvec3 side = wall.inside ? -toBox : toBox;
  const glm::dvec3 tangent1 = glm::normalize(glm::cross(side, glm::dvec3(0.36, 0.48, 0.8)));
  const glm::dvec3 tangent2 = glm::cross(side, tangent1);
  const T r = T(R);
  const TVec3<T> c = toT<T>(wall.centre);
  for (int i = 0; i < rays; ++i) {
    // (One draw a statement, the second tangent's first: C++ leaves the order of an overloaded operator's operands
    // unspecified, GCC evaluating them right to left and clang left to right; this is GCC's order from when both
    // draws were in one expression, so the test keeps its rays.)
    const double along2 = rng.uniform(-50, 50);
    const double along1 = rng.uniform(-50, 50);
    const glm::dvec3 origin = surface + height * side + along1 * tangent1 + along2 * tangent2;
    const glm::dvec3 dir = uniformHemisphere(rng, -side); // towards the surface
    if (glm::dot(dir, -side) < kMinCosine)
      continue;
    const TVec3<T> o = toT<T>(origin);
    const TVec3<T> d = unitT<T>(dir);
    const ReferenceRoots ref = referenceRoots(o, d, c, r);
    if (!(ref.missDistance < 0))
      continue; // a grazing ray that passes the ground sphere: no forward hit to measure
    const long double tRef = ref.t0 > 0 ? ref.t0 : ref.t1; // the forward hit
    if (!(tRef > 0))
      continue;
    const auto naive = naiveSphereRoots(o, d, c, r);
    const auto robust = intersectSphereRoots(o, d, c, r);
    auto forward = [&](const auto& roots) -> std::optional<long double> {
      if (!roots)
        return std::nullopt;
      // The root on the same side as the reference's: inside, the far root t1; outside, the near root t0.
      return ref.t0 > 0 ? roots->t0 : roots->t1;
    };
    if (const auto t = forward(naive))
      fig.naiveMax = std::max(fig.naiveMax, double(relativeError(*t, tRef)));
    else
      ++fig.naiveMisses;
    if (const auto t = forward(robust))
      fig.robustMax = std::max(fig.robustMax, double(relativeError(*t, tRef)));
    else
      ++fig.robustMisses;
  }
  return fig;
}

} // namespace

TEMPLATE_TEST_CASE("stability 2: a huge sphere near the ray origin", "[stability][huge-sphere]", float, double)
{
  constexpr int kRays = 20000;
  const Wall walls[] = {
      {"left wall (inside)", {1e5 + 1, 40.8, 81.6}, true},
      {"floor (inside)", {50, 1e5, 81.6}, true},
      {"ground (outside)", {50, -1e5, 81.6}, false},
  };
  const double u = double(kUnitRoundoff<TestType>);
  double robustWorst = 0, naiveWorst = 0;
  for (const Wall& wall : walls)
    for (const double h : {1.0, 10.0, 100.0}) {
      const HugeSphereFigures fig = measureHugeSphere<TestType>(wall, h, kRays, 77 + std::uint64_t(h));
      const double unit = u * kWallRadius / h; // u·R/h
      char line[256];
      std::snprintf(line, sizeof line,
                    "huge sphere %-6s %-18s h=%-4g max rel. error of t: naive %.3g (%.3g u·R/h) robust %.3g "
                    "(%.3g u·R/h)  misses naive %d robust %d",
                    scalarName<TestType>(), wall.name, h, fig.naiveMax, fig.naiveMax / unit, fig.robustMax,
                    fig.robustMax / unit, fig.naiveMisses, fig.robustMisses);
      printFigure(line);
      INFO(line);
      CHECK(fig.robustMisses == 0);
      CHECK(fig.robustMax <= kMaxErrorInUnitsOfURoverH * unit);
      robustWorst = std::max(robustWorst, fig.robustMax);
      naiveWorst = std::max(naiveWorst, fig.naiveMax);
    }
  INFO("worst relative error of t: naive " << naiveWorst << ", robust " << robustWorst);
  if constexpr (sizeof(TestType) == 8) {
    CHECK(robustWorst <= kRendererTolerance);
  } else {
    // Float is what fails here, with either form: shown, so that the case can fail.
    CHECK(robustWorst > kRendererTolerance);
    CHECK(naiveWorst > kRendererTolerance);
  }
}

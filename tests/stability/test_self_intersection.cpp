// Case 4 — self-intersection (and issue 2's test of it through the renderer's own path).
//
// Setup: spheres of radius 1e-4 to 1e4 whose centres lie 0 to 1e6 from the world origin. A ray from outside
// (1.5 to 5 radii from the centre) reaches the surface the way the renderer's do (intersect, then the surface
// point); a new ray then leaves it, 100,000 per case:
//  - outward, uniformly over the hemisphere of the normal (grazing included). Leaving a convex sphere outward,
//    the ray can never meet it again: any hit is a self-hit;
//  - inward (the refraction side), at up to 84° from −n (cos ≥ 0.1: a refracted ray is never more grazing
//    than that for an index of refraction up to 10). It must meet the far side: t of at least half the chord
//    2r·cosθ, not t ≈ 0 on the near side.
// Naive: the schoolbook quadratic, the point o + t·d, and a fixed t_min (1e-3, 1e-6 or 1e-9): no single value
// serves all scales (too large skips the far side of a small sphere; too small lets rounding below a large or
// distant surface hit it again). Robust: intersectSphere, sphereSurfacePoint (re-projected point and its
// error bound) and offsetRayOrigin with t_min = 0.
// Pass criterion: zero self-hits outward and zero wrong inward hits, in float and in double, wherever the
// sphere is representable (see kResolvableUlps).
#include "scene/scene.h"
#include "support.h"

#include <catch2/catch.hpp>

#include <array>
#include <cstdio>
#include <type_traits>

using namespace raylife;
using namespace raylife::stability;

namespace {

/// An inward ray must travel at least this fraction of the chord 2r·cosθ to count as meeting the far side.
constexpr double kMinChordFraction = 0.5;
/// Inward directions are sampled with cosθ ≥ this (see the file comment).
constexpr double kMinInwardCosine = 0.1;
/// A sphere is judged for inward rays when its radius is at least this many unit roundoffs of its centre's
/// distance from the origin: below that the centre's own rounding is a sizeable part of the radius, and in
/// float a sphere of radius 1e-4 at 1e6 (where the spacing of floats is 0.06) is not a sphere at all.
constexpr double kResolvableUlps = 1024;

constexpr std::array<double, 3> kFixedTmins{1e-3, 1e-6, 1e-9};

struct SelfHitFigures {
  int rays = 0;
  int robustOutward = 0, robustInward = 0;  // self-hits outward; wrong (near-side or missing) hits inward
  std::array<int, 3> naiveOutward{}, naiveInward{};
};

template <class T> SelfHitFigures measureSelfHits(double radius, double centreDistance, int rays, std::uint64_t seed)
{
  TestRng rng(seed);
  SelfHitFigures fig;
  const glm::dvec3 centreD = centreDistance * uniformSphere(rng);
  const TVec3<T> c = toT<T>(centreD);
  const T r = T(radius);
  for (int attempt = 0; fig.rays < rays && attempt < 4 * rays; ++attempt) {
    // A ray from outside towards a random point of the sphere it can see.
    const glm::dvec3 m = uniformSphere(rng);
    const glm::dvec3 from = centreD + rng.uniform(1.5, 5) * radius * m;
    const glm::dvec3 target = centreD + radius * uniformHemisphere(rng, m);
    const TVec3<T> o = toT<T>(from);
    const TVec3<T> d = unitT<T>(target - from);
    const auto t = intersectSphere(o, d, c, r, T(0), std::numeric_limits<T>::infinity());
    const auto naiveRoots = naiveSphereRoots(o, d, c, r);
    if (!t || !naiveRoots || !(naiveRoots->t0 > 0))
      continue; // a near-tangent ray one of the two missed: not this case
    ++fig.rays;
    const SurfacePoint<T> sp = sphereSurfacePoint(o, d, *t, c, r);
    const TVec3<T> naivePoint = o + naiveRoots->t0 * d;
    const glm::dvec3 n(sp.normal);

    // Outward: any hit at all is a self-hit.
    const TVec3<T> out = unitT<T>(uniformHemisphere(rng, n));
    if (glm::dot(out, sp.normal) > 0) {
      const TVec3<T> origin = offsetRayOrigin(sp.point, sp.error, sp.normal, out);
      fig.robustOutward += bool(intersectSphere(origin, out, c, r, T(0), std::numeric_limits<T>::infinity()));
      for (std::size_t k = 0; k < kFixedTmins.size(); ++k)
        fig.naiveOutward[k] += bool(naiveIntersectSphere(naivePoint, out, c, r, T(kFixedTmins[k]),
                                                         std::numeric_limits<T>::infinity()));
    }

    // Inward: the nearest hit must be the far side.
    glm::dvec3 in = -uniformHemisphere(rng, n);
    while (glm::dot(in, -n) < kMinInwardCosine)
      in = -uniformHemisphere(rng, n);
    const TVec3<T> inT = unitT<T>(in);
    const double chord = 2 * radius * double(glm::dot(-inT, sp.normal));
    auto farSide = [&](const std::optional<T>& hit) { return hit && double(*hit) >= kMinChordFraction * chord; };
    const TVec3<T> inOrigin = offsetRayOrigin(sp.point, sp.error, sp.normal, inT);
    fig.robustInward += !farSide(intersectSphere(inOrigin, inT, c, r, T(0), std::numeric_limits<T>::infinity()));
    for (std::size_t k = 0; k < kFixedTmins.size(); ++k)
      fig.naiveInward[k] += !farSide(naiveIntersectSphere(naivePoint, inT, c, r, T(kFixedTmins[k]),
                                                          std::numeric_limits<T>::infinity()));
  }
  return fig;
}

} // namespace

TEMPLATE_TEST_CASE("stability 4: rays leaving a sphere never hit it again at t ~ 0", "[stability][self-hit]", float,
                   double)
{
  constexpr int kRays = 100000;
  std::array<int, 3> naiveOutwardTotal{}, naiveInwardTotal{};
  for (const double radius : {1e-4, 1e-2, 1.0, 1e2, 1e4})
    for (const double centre : {0.0, 1e2, 1e4, 1e6}) {
      const SelfHitFigures fig =
          measureSelfHits<TestType>(radius, centre, kRays, std::uint64_t(1e3 * std::log(radius * 1e5 + centre + 1)));
      const bool resolvable = radius >= kResolvableUlps * double(kUnitRoundoff<TestType>) * centre;
      char line[300];
      std::snprintf(line, sizeof line,
                    "self-hit %-6s r=%-6g |c|=%-6g%s out/in failures of %d: offset origin %d/%d, t_min=1e-3 %d/%d, "
                    "1e-6 %d/%d, 1e-9 %d/%d",
                    scalarName<TestType>(), radius, centre, resolvable ? "" : " (unresolvable)", fig.rays,
                    fig.robustOutward, fig.robustInward, fig.naiveOutward[0], fig.naiveInward[0], fig.naiveOutward[1],
                    fig.naiveInward[1], fig.naiveOutward[2], fig.naiveInward[2]);
      printFigure(line);
      INFO(line);
      CHECK(fig.robustOutward == 0);
      if (resolvable) {
        CHECK(fig.robustInward == 0);
        for (std::size_t k = 0; k < kFixedTmins.size(); ++k) {
          naiveOutwardTotal[k] += fig.naiveOutward[k];
          naiveInwardTotal[k] += fig.naiveInward[k];
        }
      }
    }
  // Every fixed t_min fails somewhere on the same spheres: shown, so that the case can fail.
  for (std::size_t k = 0; k < kFixedTmins.size(); ++k) {
    INFO("fixed t_min " << kFixedTmins[k] << ": outward self-hits " << naiveOutwardTotal[k] << ", inward failures "
                        << naiveInwardTotal[k]);
    CHECK(naiveOutwardTotal[k] + naiveInwardTotal[k] > 0);
  }
}

TEST_CASE("stability 4 (chapter 13): a ray between two hit points is blocked by neither end's surface",
          "[stability][self-hit]")
{
  // A floor and a wall meeting at a corner, each a sphere of radius R: 10^5 in float (the Cornell box's walls), 10^13
  // in double, where each places its points to some 10^-2 units (γ(5)·R). Points on the floor and on the wall,
  // found by Scene::intersect, are joined through the open corner between them. spawnRayTo(from, to) must reach
  // every target; stopping short of the bare target point by the relative kShadowRayShorten alone (the one-point
  // form) leaves the target's own surface in the way for many.
  const Real R = std::is_same_v<Real, float> ? Real(1e5) : Real(1e13);
  Scene scene;
  scene.spheres = {Sphere{Vec3(0, -R, 0), R, 0}, Sphere{Vec3(0, 0, -R), R, 0}};
  TestRng rng(4242);
  int pairs = 0, blocked = 0, blockedOnePoint = 0;
  for (int k = 0; k < 20000; ++k) {
    const Real fx = Real(rng.uniform(-20, 20));
    const Real fz = Real(rng.uniform(0.5, 30));
    const Real wx = Real(rng.uniform(-20, 20));
    const Real wy = Real(rng.uniform(0.5, 30));
    const std::optional<Hit> floor = scene.intersect(Ray{Vec3(fx, 10, fz), Vec3(0, -1, 0), 0, kInfinity});
    const std::optional<Hit> wall = scene.intersect(Ray{Vec3(wx, wy, 10), Vec3(0, 0, -1), 0, kInfinity});
    REQUIRE(floor);
    REQUIRE(wall);
    REQUIRE(floor->primitive == 0);
    REQUIRE(wall->primitive == 1);
    ++pairs;
    blocked += scene.occluded(spawnRayTo(*floor, *wall)) + scene.occluded(spawnRayTo(*wall, *floor));
    blockedOnePoint +=
        scene.occluded(spawnRayTo(*floor, wall->point)) + scene.occluded(spawnRayTo(*wall, floor->point));
  }
  INFO(pairs << " pairs joined both ways: blocked " << blocked << ", with the one-point form " << blockedOnePoint);
  printFigure("chapter 13's connections (" + std::string(scalarName<Real>()) + " Real, walls of radius " +
              (std::is_same_v<Real, float> ? "1e5" : "1e13") + "): " + std::to_string(2 * pairs) +
              " rays between hit points, blocked " + std::to_string(blocked) + "; with the one-point spawnRayTo " +
              std::to_string(blockedOnePoint));
  CHECK(blockedOnePoint > 0); // the far end's offset is what makes the difference: shown
  CHECK(blocked == 0);
}

TEST_CASE("stability 4 (issue 2): no self-hits through Scene::intersect and spawnRay and spawnRayTo",
          "[stability][self-hit]")
{
  // The renderer's own path in Real: 100,000 random spheres (radius log-uniform in [1e-3, 1e4], centre uniform
  // in the ball of radius 1e4), each reached by a ray from outside through Scene::intersect, then left
  // outward by spawnRay (any hit is a self-hit), towards a point outside by spawnRayTo (nothing may block it),
  // and inward by spawnRay (the hit must be the same sphere's far side, at least half the chord away).
  constexpr int kRays = 100000;
  TestRng rng(2024);
  Scene scene;
  scene.spheres = {Sphere{}};
  int rays = 0, outwardSelfHits = 0, blockedShadowRays = 0, wrongInward = 0, judgedInward = 0;
  int naiveSelfHits = 0; // the same outward rays from the re-projected point without the offset, t_min = 0
  for (int attempt = 0; rays < kRays && attempt < 4 * kRays; ++attempt) {
    const double radius = rng.logUniform(1e-3, 1e4);
    // (Draws one statement at a time: C++ leaves the order of an overloaded operator's operands unspecified, GCC
    // evaluating them right to left and clang left to right. Where two shared an expression, they are made in GCC's
    // order, the right operand's first, so the test keeps its cases.)
    const glm::dvec3 centreDirection = uniformSphere(rng);
    const glm::dvec3 centre = std::cbrt(rng.uniform()) * 1e4 * centreDirection;
    scene.spheres[0] = Sphere{toT<Real>(centre), Real(radius), 0};
    const glm::dvec3 m = uniformSphere(rng);
    const glm::dvec3 from = centre + rng.uniform(1.5, 5) * radius * m;
    const glm::dvec3 target = centre + radius * uniformHemisphere(rng, m);
    const std::optional<Hit> hit = scene.intersect(Ray{toT<Real>(from), unitT<Real>(target - from), 0, kInfinity});
    if (!hit)
      continue; // a near-tangent ray that missed
    ++rays;
    const glm::dvec3 n(hit->normal);

    const Vec3 out = unitT<Real>(uniformHemisphere(rng, n));
    if (glm::dot(out, hit->normal) > 0) {
      outwardSelfHits += bool(scene.intersect(spawnRay(*hit, out)));
      naiveSelfHits += bool(scene.intersect(Ray{hit->point, out, 0, kInfinity}));
    }

    const Vec3 toLight = unitT<Real>(uniformHemisphere(rng, n));
    const Vec3 light = hit->point + Real(rng.logUniform(1e-3, 1e4)) * toLight;
    if (glm::dot(light - hit->point, hit->normal) > 0)
      blockedShadowRays += scene.occluded(spawnRayTo(*hit, light));

    glm::dvec3 in = -uniformHemisphere(rng, n);
    while (glm::dot(in, -n) < kMinInwardCosine)
      in = -uniformHemisphere(rng, n);
    const Vec3 inR = unitT<Real>(in);
    // Judged where the sphere is representable in Real (always in double; in float not for the smallest
    // spheres far out, see kResolvableUlps).
    if (radius >= kResolvableUlps * double(kUnitRoundoff<Real>) * glm::length(centre)) {
      ++judgedInward;
      const std::optional<Hit> farSide = scene.intersect(spawnRay(*hit, inR));
      const double chord = 2 * radius * double(glm::dot(-inR, hit->normal));
      wrongInward += !(farSide && double(farSide->t) >= kMinChordFraction * chord);
    }
  }
  INFO("rays " << rays << ": outward self-hits " << outwardSelfHits << ", blocked shadow rays " << blockedShadowRays
               << ", wrong inward hits " << wrongInward << " of " << judgedInward << "; without the offset "
               << naiveSelfHits << " self-hits");
  printFigure("issue 2 (" + std::string(scalarName<Real>()) + " Real): " + std::to_string(rays) +
              " rays: outward self-hits " + std::to_string(outwardSelfHits) + ", blocked shadow rays " +
              std::to_string(blockedShadowRays) + ", wrong inward hits " + std::to_string(wrongInward) + " of " +
              std::to_string(judgedInward) + "; without the offset: " + std::to_string(naiveSelfHits) +
              " outward self-hits");
  REQUIRE(rays == kRays);
  CHECK(naiveSelfHits > 0); // the offset is what makes the difference: shown
  CHECK(outwardSelfHits == 0);
  CHECK(blockedShadowRays == 0);
  CHECK(wrongInward == 0);
  if constexpr (sizeof(Real) == 8) {
    CHECK(judgedInward == rays); // every sphere of the range is representable in double
  }
}

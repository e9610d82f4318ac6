// Case 13 — participating media (chapter 15): huge optical depths and grazing boundaries.
//
// Setup: free flight (sampleFreeFlight, common/shading/medium.h) in coloured media whose extinction spans 1e-3 to
// 1e6 per unit, over surfaces at 1e-6 to 1e6 units and at infinity, with uniform numbers up to the largest below 1;
// transmittance at optical depths up to 1e12 and along chords of rays that graze a ball (tangent to 1 ulp), in
// float and in double. Pass criterion: every weight and transmittance is finite and ≥ 0, a transmittance of optical
// depth ≥ 1e6 is exactly 0, and each channel's weight stays below 3 (passing a surface: Tr_i / mean_j Tr_j ≤ 3) or
// σs,i / (mean_j σt,j e^{...}) bounds (scattering: finite).
// Naive, for contrast: the passing weight written as e^{−σt,i d} / (⅓ Σ e^{−σt,j d}) directly is 0/0 = NaN as soon
// as every channel underflows: in float past an optical depth of about 104 in the thinnest channel, in double
// past about 745.
// Also, in the build's own precision: delta and ratio tracking (density_grid.h) through a density grid seen from so
// far away that the majorant's mean free path is below the spacing of t's numbers there. Pass criterion: both end,
// with the exact answer where the density is 0 (no collision, weight and transmittance 1) and finite weights where
// it is not. Before each step was made to move t on, a step below half an ulp left t where it was, and at a point
// of zero density the null collisions repeated there for ever.
#include "shading/density_grid.h"
#include "shading/medium.h"
#include "geometry/sphere.h"
#include "support.h"

#include <catch2/catch.hpp>

#include <chrono>
#include <future>
#include <thread>

using namespace raylife;
using namespace raylife::stability;

namespace {

template <class T> TVec3<T> naivePassWeight(const TVec3<T>& sigmaT, T d)
{
  const TVec3<T> tr(std::exp(-sigmaT.x * d), std::exp(-sigmaT.y * d), std::exp(-sigmaT.z * d));
  return tr / ((tr.x + tr.y + tr.z) / 3);
}

template <class T> bool finiteNonNegative(const TVec3<T>& v)
{
  return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z) && v.x >= 0 && v.y >= 0 && v.z >= 0;
}

} // namespace

TEMPLATE_TEST_CASE("stability 13: free flight and transmittance stay finite at optical depths up to 1e12",
                   "[stability][media]", float, double)
{
  using T = TestType;
  const T belowOne = std::nextafter(T(1), T(0));
  std::size_t cases = 0, naiveNaN = 0;
  for (const T dense : {T(1e-3), T(1), T(1e3), T(1e6)})
    for (const T tMax : {T(1e-6), T(1), T(1e6), std::numeric_limits<T>::infinity()})
      for (const T u : {T(0), T(0.5), belowOne})
        for (const T uChannel : {T(0), T(0.5), belowOne}) {
          const TVec3<T> sigmaA(T(0), dense * T(0.5), dense);
          const TVec3<T> sigmaS(dense, dense * T(2), T(0));
          const FreeFlightOf<T> f = sampleFreeFlight(sigmaA, sigmaS, tMax, uChannel, u);
          INFO(scalarName<T>() << ": sigma " << dense << " tMax " << tMax << " u " << u << " channel " << uChannel);
          REQUIRE(finiteNonNegative(f.weight));
          if (!f.scattered)
            CHECK(std::max({f.weight.x, f.weight.y, f.weight.z}) <= T(3) * (1 + T(1e-5)));
          ++cases;
          if (std::isfinite(tMax) && !finiteNonNegative(naivePassWeight(sigmaA + sigmaS, tMax)))
            ++naiveNaN;
        }
  // Transmittance: exactly 0 beyond any representable optical depth, 1 for an empty channel even at d = ∞.
  for (const T depth : {T(1e6), T(1e12)})
    CHECK(transmittance(TVec3<T>(depth), T(1)) == TVec3<T>(0));
  CHECK(transmittance(TVec3<T>(0, 1, 1e6), std::numeric_limits<T>::infinity()) == TVec3<T>(1, 0, 0));
  std::printf("[stability] %s media: %zu free-flight cases finite; the naive passing weight is NaN or infinite in "
              "%zu of them\n",
              scalarName<T>(), cases, naiveNaN);
  CHECK(naiveNaN > 0); // the contrast is real: the direct ratio fails where the robust one does not
}

TEMPLATE_TEST_CASE("stability 13: chords of rays that graze a ball give a transmittance in [0, 1]",
                   "[stability][media]", float, double)
{
  using T = TestType;
  TestRng rng(13);
  const TVec3<T> centre(T(0.25), T(-0.5), T(3));
  const T radius = T(1.7);
  std::size_t hits = 0;
  for (int i = 0; i < 100000; ++i) {
    // A ray from far away aimed at a point within a few ulps of the silhouette.
    const glm::dvec3 axis = uniformSphere(rng);
    const glm::dvec3 side = glm::normalize(glm::cross(axis, uniformSphere(rng)));
    const double miss = double(radius) * (1 + rng.uniform(-4, 4) * double(std::numeric_limits<T>::epsilon()));
    const glm::dvec3 origin = glm::dvec3(centre) + side * miss - axis * rng.logUniform(2, 1e4);
    const TVec3<T> o(origin), d(glm::normalize(glm::dvec3(centre) + side * miss - origin));
    const auto roots = intersectSphereRoots(o, d, centre, radius);
    if (!roots)
      continue;
    ++hits;
    const T chord = roots->t1 - roots->t0;
    REQUIRE(chord >= 0);
    for (const T sigma : {T(1), T(1e6)}) {
      const TVec3<T> tr = transmittance(TVec3<T>(sigma), chord);
      REQUIRE(finiteNonNegative(tr));
      REQUIRE(tr.x <= 1);
    }
  }
  std::printf("[stability] %s media: %zu of 100000 grazing rays met the ball, every chord's transmittance in [0, 1]\n",
              scalarName<T>(), hits);
  CHECK(hits > 0);
}

TEST_CASE("stability 13: delta and ratio tracking end where a step is below the spacing of t's numbers",
          "[stability][media]")
{
  // Two cells along x, densities 0 and 1, in the unit box: below x = 0.25 the density is 0, beyond 0.75 it is 1.
  DensityGrid grid;
  grid.nx = 2;
  grid.lo = Vec3(0), grid.hi = Vec3(1);
  grid.values = {0.0f, 1.0f};
  grid.buildMajorants(32);
  // The box seen from D away along −z, with t's spacing there about 1e-4: 1e4 numbers across it. A rate of 1e9 makes
  // the mean step 1e-9, far below that spacing.
  const Real D = Real(1) / (std::numeric_limits<Real>::epsilon() * Real(1e4));
  const Color sigmaS(Real(1e9)), sigmaA(0);
  struct Outcome {
    TrackedFlight flight;
    Color transmittance;
  };
  for (const bool global : {true, false})
    for (const Real x : {Real(0.1), Real(0.23), Real(0.9)}) {
      const Ray ray{Vec3(x, Real(0.5), D), Vec3(0, 0, -1)};
      const Real tMax = D + 1;
      // Each in a thread of its own (with copies of what it reads), given a minute for what takes milliseconds: a
      // loop that does not end must fail the test rather than hold it (the thread is left behind, and ends with the
      // process).
      std::promise<Outcome> promise;
      std::future<Outcome> answer = promise.get_future();
      std::thread([grid, ray, global, tMax, sigmaA, sigmaS, p = std::move(promise)]() mutable {
        Sampler sampler(13, 0, 0, 0);
        const TrackedFlight f = deltaTrack(grid, global, sigmaA, sigmaS, ray, tMax, sampler);
        const Color tr = ratioTrack(grid, global, sigmaA + sigmaS, ray, tMax, sampler);
        p.set_value(Outcome{f, tr});
      }).detach();
      INFO("global majorant " << global << ", x " << x << ", D " << D);
      REQUIRE(answer.wait_for(std::chrono::minutes(1)) == std::future_status::ready);
      const Outcome o = answer.get();
      CHECK(std::isfinite(o.flight.weight.r));
      CHECK(std::isfinite(o.flight.t));
      CHECK(o.transmittance.r >= 0);
      CHECK(o.transmittance.r <= 1);
      if (x < Real(0.25)) { // no density on the whole chord: exactly nothing to meet
        CHECK_FALSE(o.flight.scattered);
        CHECK(o.flight.weight == Color(1));
        CHECK(o.transmittance == Color(1));
      } else if (x > Real(0.75)) { // density 1 at the majorant: the first tentative collision is real
        CHECK(o.flight.scattered);
        CHECK(o.flight.weight == Color(1));
        CHECK(o.transmittance == Color(0));
      }
    }
}

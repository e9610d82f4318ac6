// Case 8 — sampling a distant spherical light.
//
// Setup: a light of radius 1 at distances 1e2, 1e3, 1e4 and 1e5 from the shaded point, 100,000 directions each
// from sampleSphereCone (common/scene/light_sampling.h), in float and in double. Pass criterion: at least 99.99% of the
// sampled directions hit the sphere (intersectSphere from the same point), and the cone's pdf is within 1e-3 of a
// long-double reference. With the shaded point inside the light (at its centre, halfway out, just inside its
// surface) the directions are finite and unit and the pdf finite and positive: no NaN.
// Where float stops: a unit direction in float carries about 6e-8 rad of rounding, and the cone of a unit sphere
// 1e4 radii away is only 1e-4 rad wide, so directions at its very edge start to miss (measured: 99.988% hit at
// 1e4, 99.75% at 1e5). No sampling routine can cure that in float; double hits 100% at every distance here. So
// the 99.99% criterion is asserted in double at 1e2..1e5 and in float up to 1e3, and float's figures beyond are
// printed and asserted not to fall below 99%: the suite records where float stops agreeing, and why.
// Naive, for contrast: 1 − cosθmax as 1 − √(1 − sin²θmax). In float, past about 4,000 radii sin²θmax is below
// half an ulp of 1, the difference is 0 and the pdf 1/(2π·0) is infinite: the light would count for nothing.
// (In double the same happens only past about 10⁸ radii, so at these distances the naive form passes in double,
// and the test says so.)
#include "scene/light_sampling.h"
#include "geometry/sphere.h"
#include "support.h"

#include <catch2/catch.hpp>

using namespace raylife;
using namespace raylife::stability;

namespace {

template <class T> T naivePdf(T distance, T r)
{
  const T sin2 = (r * r) / (distance * distance);
  return T(1) / (2 * std::numbers::pi_v<T> * (1 - std::sqrt(1 - sin2)));
}

long double referencePdf(long double distance, long double r)
{
  const long double sin2 = (r * r) / (distance * distance);
  const long double oneMinusCos = sin2 / (1 + std::sqrt(1 - sin2)); // exact rewriting, in long double
  return 1 / (2 * std::numbers::pi_v<long double> * oneMinusCos);
}

} // namespace

TEMPLATE_TEST_CASE("stability 8: directions towards a distant spherical light hit it", "[stability][light]", float,
                   double)
{
  using T = TestType;
  const T r = 1;
  Sampler rng(88, 0, 0, 0);
  for (const T distance : {T(1e2), T(1e3), T(1e4), T(1e5)}) {
    // A light in a random direction, the shaded point near (but not at) the origin.
    const TVec3<T> ref = TVec3<T>(T(0.25), T(-0.5), T(0.125));
    const TVec3<T> dir = toT<T>(glm::dvec3(sampleUniformSphere(rng.next2D())));
    const TVec3<T> c = ref + distance * glm::normalize(dir);
    const T actualDistance = glm::length(c - ref);
    int hits = 0;
    const int n = 100000;
    for (int i = 0; i < n; ++i) {
      const TVec3<T> w = sampleSphereCone(ref, c, r, glm::vec<2, T>(rng.next2D()));
      REQUIRE(isFinite(w));
      hits += intersectSphere(ref, w, c, r, T(0), std::numeric_limits<T>::infinity()).has_value();
    }
    const long double reference = referencePdf(actualDistance, r);
    const long double robustError = std::abs(sphereConePdf(ref, c, r) - reference) / reference;
    const T naive = naivePdf(actualDistance, r);
    const long double naiveError = std::isfinite(naive) ? std::abs(naive - reference) / reference : INFINITY;
    INFO(scalarName<T>() << " at " << double(distance) << " radii: " << hits << " of " << n << " hit");
    if (sizeof(T) == 8 || distance <= T(1e3))
      CHECK(double(hits) >= 0.9999 * n);
    else
      CHECK(double(hits) >= 0.99 * n); // float's rounding of a direction, not the sampler (see the file comment)
    CHECK(robustError < 1e-3L);
    if (sizeof(T) == 4 && distance >= T(1e4))
      CHECK(!(naiveError < 1e-3L)); // the naive pdf is infinite (or far off) here
    printFigure(std::string("distant light ") + scalarName<T>() + " at " + std::to_string(double(distance)) +
                " radii: " + std::to_string(hits) + "/" + std::to_string(n) + " hit, pdf error robust " +
                std::to_string(double(robustError)) + ", naive " + std::to_string(double(naiveError)));
  }
}

TEMPLATE_TEST_CASE("stability 8: sampling a light from inside it gives no NaN", "[stability][light]", float, double)
{
  using T = TestType;
  const TVec3<T> c(T(3), T(-2), T(5));
  const T r = T(2);
  Sampler rng(89, 0, 0, 0);
  for (const T fraction : {T(0), T(0.5), T(1) - T(1e-6), T(1)}) { // centre, halfway, just inside, on the surface
    const TVec3<T> ref = c + fraction * r * TVec3<T>(0, 0, 1);
    const T pdf = sphereConePdf(ref, c, r);
    CHECK(std::isfinite(pdf));
    CHECK(pdf > 0);
    for (int i = 0; i < 1000; ++i) {
      const TVec3<T> w = sampleSphereCone(ref, c, r, glm::vec<2, T>(rng.next2D()));
      REQUIRE(isFinite(w));
      REQUIRE(std::abs(glm::length(w) - T(1)) < 16 * std::numeric_limits<T>::epsilon());
    }
  }
}

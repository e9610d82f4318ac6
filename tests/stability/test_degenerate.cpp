// Case 6 — degenerate vectors.
//
// Setup: vectors of length 1e-170 (double) and 1e-23 (float), below where their squared length underflows;
// vectors of length 1e170 and 1e23, where it overflows; subnormal components; and a sampled direction that
// cancels the normal exactly (the "n + random unit vector" cosine sampler of Ray Tracing in One Weekend, when
// the random vector is −n). Naive: glm::normalize. Robust: safeNormalize (math.h), which scales by the largest
// component first and returns a stated fallback for a zero or non-finite vector.
// Pass criterion: the result is finite and of length 1 within 4 ulps, or exactly the fallback where the input
// has no direction.
#include "support.h"

#include <catch2/catch.hpp>

#include <vector>

using namespace raylife;
using namespace raylife::stability;

namespace {

template <class T> bool isUnit(const TVec3<T>& v)
{
  // |v| of a correctly normalised vector differs from 1 by a few roundings of the division and the length.
  return isFinite(v) && std::fabs(double(glm::length(TVec3<double>(v))) - 1) <= 4 * double(kUnitRoundoff<T>);
}

} // namespace

TEMPLATE_TEST_CASE("stability 6: tiny and huge and cancelling vectors normalise to unit length or a fallback",
                   "[stability][degenerate]", float, double)
{
  using T = TestType;
  using V = TVec3<T>;
  const T tiny = sizeof(T) == 4 ? T(1e-23) : T(1e-170);
  const T huge = sizeof(T) == 4 ? T(1e23) : T(1e170);
  const T sub = std::numeric_limits<T>::denorm_min() * T(3);
  const std::vector<V> directed{V(tiny, tiny, 0), V(tiny, -2 * tiny, 3 * tiny), V(0, 0, tiny), V(huge, huge, huge),
                                V(-huge, 0, huge / 2), V(sub, 0, 0), V(sub, sub, sub)};
  int naiveBad = 0;
  for (const V& v : directed) {
    const V naive = glm::normalize(v);
    naiveBad += !isUnit(naive);
    const V robust = safeNormalize(v, V(0, 0, 1));
    INFO("v = (" << v.x << ", " << v.y << ", " << v.z << ") -> safe (" << robust.x << ", " << robust.y << ", "
                 << robust.z << "), naive (" << naive.x << ", " << naive.y << ", " << naive.z << ")");
    CHECK(isUnit(robust));
    // It points the same way: each component has v's sign.
    for (int i = 0; i < 3; ++i)
      CHECK((robust[i] > 0) == (v[i] > 0));
  }
  printFigure(std::string("degenerate ") + scalarName<T>() + ": glm::normalize gives a non-unit or non-finite result for " +
              std::to_string(naiveBad) + " of " + std::to_string(directed.size()) +
              " tiny/huge/subnormal vectors; safeNormalize for 0");
  CHECK(naiveBad == int(directed.size())); // every one of them defeats the naive form

  // A cosine-sampled direction n + s (s a random unit vector) that cancels the normal: s = −n.
  const V n = glm::normalize(V(T(0.36), T(-0.48), T(0.8)));
  const V sampled = n + (-n);
  const V naive = glm::normalize(sampled);
  CHECK_FALSE(isFinite(naive)); // 0/0: NaN, which would reach the film
  CHECK(safeNormalize(sampled, n) == n); // the stated fallback: the normal itself
  // Non-finite input also takes the fallback.
  CHECK(safeNormalize(V(std::numeric_limits<T>::quiet_NaN(), 0, 1), n) == n);
  CHECK(safeNormalize(V(std::numeric_limits<T>::infinity(), 0, 1), n) == n);
}

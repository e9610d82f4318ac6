// offsetRayOrigin (sphere.h) and nextAlong (math.h), written without branches on signs, against the if/else form
// they replaced, kept here: the same bits for every input, float and double in every build. The inputs cover
// ±0, subnormals, the smallest normals, huge values, ±∞ and NaN, offsets of both signs and of zero, and points
// the offset takes exactly to ±0. A NaN result only has to be NaN on both sides: C++ does not fix which NaN an
// operation with NaN operands returns, so the compiler's choice of operand order may change its sign or payload.
#include "geometry/sphere.h"

#include <catch2/catch.hpp>

#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <vector>

using namespace raylife;

namespace {

/// offsetRayOrigin as sphere.h had it before it lost its branches.
template <class T>
TVec3<T> offsetRayOriginWithBranches(const TVec3<T>& p, const TVec3<T>& error, const TVec3<T>& n, const TVec3<T>& w)
{
  const T distance = glm::dot(glm::abs(n), error);
  TVec3<T> offset = distance * n;
  if (glm::dot(w, n) < 0)
    offset = -offset;
  TVec3<T> po = p + offset;
  for (int i = 0; i < 3; ++i) {
    if (offset[i] > 0)
      po[i] = nextUp(po[i]);
    else if (offset[i] < 0)
      po[i] = nextDown(po[i]);
  }
  return po;
}

/// The per-coordinate step of that loop, which nextAlong replaces.
template <class T> T nextAlongWithBranches(T v, T direction)
{
  if (direction > 0)
    return nextUp(v);
  if (direction < 0)
    return nextDown(v);
  return v;
}

template <class T> using Bits = std::conditional_t<sizeof(T) == 4, std::uint32_t, std::uint64_t>;

/// The same bits, or NaN both.
template <class T> bool sameBits(T a, T b)
{
  return std::bit_cast<Bits<T>>(a) == std::bit_cast<Bits<T>>(b) || (std::isnan(a) && std::isnan(b));
}

/// Values where the bit patterns have their edges: zeros, subnormals, the normal range's ends, ±∞, NaN.
template <class T> std::vector<T> specialValues()
{
  using L = std::numeric_limits<T>;
  const std::vector<T> magnitudes = {T(0),          L::denorm_min(), T(2) * L::denorm_min(), L::min() - L::denorm_min(),
                                     L::min(),      T(1) / 3,        T(1),                   nextDown(T(1)),
                                     T(1e6),        L::max() / 2,    nextDown(L::max()),     L::max(),
                                     L::infinity(), L::quiet_NaN()};
  std::vector<T> values;
  for (const T m : magnitudes) {
    values.push_back(m);
    values.push_back(-m);
  }
  return values;
}

/// One coordinate from anywhere in T: a special value, any finite bit pattern (subnormals and huge ones
/// included), or a value of a rendered scene's size.
template <class T> T anyValue(std::mt19937_64& gen)
{
  static const std::vector<T> specials = specialValues<T>();
  switch (gen() % 4) {
  case 0: return specials[gen() % specials.size()];
  case 1: {
    const T v = std::bit_cast<T>(Bits<T>(gen()));
    return std::isfinite(v) ? v : T(0.5);
  }
  case 2: { // subnormal or just above the smallest normal
    const T v = std::bit_cast<T>(Bits<T>(gen() % (Bits<T>(1) << (std::numeric_limits<T>::digits + 1))));
    return gen() % 2 ? v : -v;
  }
  default: return T(std::uniform_real_distribution<double>(-600, 600)(gen));
  }
}

// The random inputs are drawn one statement at a time, never two in one call: C++ leaves the order of a call's
// arguments unspecified (GCC evaluates them right to left, clang left to right), and the inputs must not depend on
// the compiler. The statements draw in GCC's order from when the draws were one call's arguments (the last first),
// so the tests keep their inputs.
template <class T> TVec3<T> anyVector(std::mt19937_64& gen)
{
  const T z = anyValue<T>(gen);
  const T y = anyValue<T>(gen);
  const T x = anyValue<T>(gen);
  return TVec3<T>(x, y, z);
}

/// An input as the renderer makes it: a point on a sphere, its error bound, the unit normal there, and a unit
/// direction on either side.
template <class T> std::array<TVec3<T>, 4> renderedInput(std::mt19937_64& gen)
{
  std::uniform_real_distribution<double> coordinate(-1, 1);
  auto inCube = [&] { // [−1, 1)³
    const T z = T(coordinate(gen));
    const T y = T(coordinate(gen));
    const T x = T(coordinate(gen));
    return TVec3<T>(x, y, z);
  };
  const TVec3<T> n = glm::normalize(inCube());
  const TVec3<T> w = glm::normalize(inCube());
  const T radius = T(std::exp2(std::uniform_real_distribution<double>(-10, 12)(gen)));
  const TVec3<T> centre = T(100) * inCube();
  const TVec3<T> p = centre + radius * n;
  const TVec3<T> error = gamma<T>(5) * glm::abs(radius * n) + gamma<T>(2) * glm::abs(p);
  return {p, error, n, w};
}

} // namespace

TEMPLATE_TEST_CASE("nextAlong gives the bits of nextUp, nextDown or v for every pair of special values and 10^6 "
                   "random ones",
                   "[offset]", float, double)
{
  using T = TestType;
  const std::vector<T> specials = specialValues<T>();
  int differ = 0;
  for (const T v : specials)
    for (const T direction : specials)
      differ += !sameBits(nextAlong(v, direction), nextAlongWithBranches(v, direction));
  std::mt19937_64 gen(4);
  for (int i = 0; i < 1000000; ++i) {
    const T v = anyValue<T>(gen), direction = anyValue<T>(gen);
    differ += !sameBits(nextAlong(v, direction), nextAlongWithBranches(v, direction));
  }
  CHECK(differ == 0);
}

TEMPLATE_TEST_CASE("absBranchFree(v) is glm::abs(v) bit for bit, -0 included (offsetRayOrigin and sphereSurfacePoint "
                   "use it for |v| without a branch on v's sign)",
                   "[offset]", float, double)
{
  using T = TestType;
  const auto absByMax = [](T v) { return absBranchFree(TVec3<T>(v)).x; };
  const auto absByGlm = [](T v) { return glm::abs(TVec3<T>(v)).x; };
  int differ = 0, differFabs = 0;
  std::vector<T> values = specialValues<T>();
  std::mt19937_64 gen(5);
  for (int i = 0; i < 1000000; ++i)
    values.push_back(anyValue<T>(gen));
  for (const T v : values) {
    differ += !sameBits(absByMax(v), absByGlm(v));
    differFabs += !sameBits(T(std::fabs(v)), absByGlm(v));
  }
  CHECK(differ == 0);
  // The control: std::fabs, which makes −0 into +0, is told apart (so the comparison can fail).
  CHECK(differFabs > 0);
}

TEMPLATE_TEST_CASE("offsetRayOrigin gives the same bits as its form with branches, over 4·10^6 inputs", "[offset]",
                   float, double)
{
  using T = TestType;
  std::mt19937_64 gen(2026);
  int differ = 0, inputs = 0;
  int zeroCoordinates = 0, subnormalCoordinates = 0, hugeCoordinates = 0, nonFiniteCoordinates = 0;
  const auto check = [&](const TVec3<T>& p, const TVec3<T>& error, const TVec3<T>& n, const TVec3<T>& w) {
    const TVec3<T> got = offsetRayOrigin(p, error, n, w);
    const TVec3<T> want = offsetRayOriginWithBranches(p, error, n, w);
    ++inputs;
    for (int i = 0; i < 3; ++i) {
      differ += !sameBits(got[i], want[i]);
      const T magnitude = std::fabs(want[i]);
      zeroCoordinates += magnitude == 0;
      subnormalCoordinates += magnitude > 0 && magnitude < std::numeric_limits<T>::min();
      hugeCoordinates += magnitude > std::numeric_limits<T>::max() / 4 && std::isfinite(magnitude);
      nonFiniteCoordinates += !std::isfinite(magnitude);
    }
  };
  for (int i = 0; i < 1000000; ++i) {
    // As rendered, but now and then with a point the offset takes to ±0, or a zero error bound.
    auto [p, error, n, w] = renderedInput<T>(gen);
    check(p, error, n, w);
    const T distance = glm::dot(glm::abs(n), error);
    const TVec3<T> offset = glm::dot(w, n) < 0 ? -distance * n : distance * n;
    check(-offset, error, n, w);
    check(p, TVec3<T>(0), n, w);
  }
  for (int i = 0; i < 1000000; ++i) { // anything at all, coordinate by coordinate (the last argument drawn first)
    const TVec3<T> w = anyVector<T>(gen);
    const TVec3<T> n = anyVector<T>(gen);
    const TVec3<T> error = anyVector<T>(gen);
    const TVec3<T> p = anyVector<T>(gen);
    check(p, error, n, w);
  }
  INFO(inputs << " inputs; result coordinates ±0: " << zeroCoordinates << ", subnormal: " << subnormalCoordinates
              << ", above max/4: " << hugeCoordinates << ", ±∞ or NaN: " << nonFiniteCoordinates);
  CHECK(differ == 0);
  // The inputs reach every kind of coordinate, so the comparison means something for each.
  CHECK(zeroCoordinates > 1000);
  CHECK(subnormalCoordinates > 1000);
  CHECK(hugeCoordinates > 1000);
  CHECK(nonFiniteCoordinates > 1000);
}

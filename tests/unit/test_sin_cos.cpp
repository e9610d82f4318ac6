// sinCos2Pi (math.h) against long double sin and cos: its error in ulps over a million u, sin² + cos² = 1, the
// exact values at the quarter turns, and a control showing that the error measure catches a polynomial one term
// short. Float and double in every build, whatever Real is.
#include "core/math.h"

#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numbers>
#include <random>
#include <vector>

using namespace raylife;

namespace {

/// The bound the tests hold sinCos2Pi to, in ulps of T (the largest error measured is about 1.5 in double and 1.7
/// in float: rounding of the polynomial's last two operations and of π/2 in its leading coefficient).
constexpr double kMaxUlps = 2;

/// The bound on |sin² + cos² − 1|, in units of T's machine epsilon (measured: about 1.5 in double, 1.8 in float).
constexpr double kMaxNormEps = 2;

/// The spacing of T's values at y's magnitude: 2^(e − p + 1) for |y| in [2^e, 2^(e+1)), p the precision;
/// the subnormal spacing below the smallest normal.
template <class T> long double ulpOf(long double y)
{
  y = std::fabs(y);
  if (y < std::numeric_limits<T>::min())
    return std::numeric_limits<T>::denorm_min();
  return std::ldexp(1.0L, std::ilogb(y) - (std::numeric_limits<T>::digits - 1));
}

/// sin(2πu) and cos(2πu) in long double (64-bit significand). The argument is reduced on u first, r = u − k/4
/// with |r| ≤ 1/8 (std::remainder is exact), so 2πr keeps its relative precision even where 2πu itself would
/// lose sin's zeros (u near 1/2 or 1); the rotation by k quarter turns is exact.
SinCos<long double> reference(long double u)
{
  const long double r = std::remainder(u, 0.25L);
  const long k = std::lround((u - r) * 4) & 3;
  const long double angle = 2 * std::numbers::pi_v<long double> * r;
  const long double s = std::sin(angle), c = std::cos(angle);
  switch (k) {
  case 0: return {s, c};
  case 1: return {c, -s};
  case 2: return {-s, -c};
  default: return {-c, s};
  }
}

/// A million and some u in [0, 1]: uniform ones with every bit random, ones on the renderer's 32-bit grid, tiny
/// ones down to the subnormals, and the 2000 values of T around every multiple of 1/8 (0 and 1 included, so the
/// values just below 1 and just above 0).
template <class T> std::vector<T> testInputs()
{
  std::vector<T> us;
  std::mt19937_64 gen(20261123);
  std::uniform_real_distribution<double> uniform(0, 1);
  for (int i = 0; i < 600000; ++i) {
    const T u = T(uniform(gen));
    us.push_back(u < 1 ? u : T(0));
  }
  const int gridBits = sizeof(T) == 4 ? 24 : 32; // Sampler::next1D's resolution
  for (int i = 0; i < 300000; ++i)
    us.push_back(T(std::ldexp(double(gen() >> (64 - gridBits)), -gridBits)));
  const int minExponent = std::numeric_limits<T>::min_exponent - std::numeric_limits<T>::digits;
  std::uniform_real_distribution<double> exponent(minExponent, 0);
  for (int i = 0; i < 100000; ++i)
    us.push_back(T(std::exp2(exponent(gen))));
  for (int k = 0; k <= 8; ++k) {
    T up = T(k) / 8, down = T(k) / 8;
    for (int j = 0; j < 1000; ++j) {
      if (up <= 1)
        us.push_back(up);
      if (down >= 0)
        us.push_back(down);
      up = std::nextafter(up, T(2));
      down = std::nextafter(down, T(-1));
    }
  }
  return us;
}

/// The largest error of sinCos(u) against the reference over `us`, in ulps of T, sin and cos alike.
template <class T, class F> double maxUlpError(const std::vector<T>& us, F&& sinCos)
{
  double worst = 0;
  for (const T u : us) {
    const SinCos<T> got = sinCos(u);
    const SinCos<long double> want = reference(u);
    worst = std::max(worst, double(std::fabs(got.sin - want.sin) / ulpOf<T>(want.sin)));
    worst = std::max(worst, double(std::fabs(got.cos - want.cos) / ulpOf<T>(want.cos)));
  }
  return worst;
}

/// The control: sinCos2Pi's reduction with the last term of each polynomial left off (degree 11 and 12 in f
/// instead of 13 and 14 for double; 5 and 6 instead of 7 and 8 for float).
template <class T> SinCos<T> truncatedSinCos2Pi(T u)
{
  const int quarter = (static_cast<int>(u * 8) + 1) >> 1;
  const T f = u * 4 - T(quarter);
  const T w = f * f;
  T s, c;
  if constexpr (std::is_same_v<T, double>) {
    constexpr double p0 = 1.5707963267948966, p1 = -6.4596409750624432e-1, p2 = 7.9692626246043003e-2,
                     p3 = -4.681754132340976e-3, p4 = 1.6044115074219091e-4, p5 = -3.5986433529823097e-6;
    constexpr double q0 = 1.2337005501361698, q1 = -2.5366950790104782e-1, q2 = 2.0863480763340773e-2,
                     q3 = -9.1926027454684462e-4, q4 = 2.5202039028029176e-5, q5 = -4.7106784055052271e-7;
    s = f * (p0 + w * (p1 + w * (p2 + w * (p3 + w * (p4 + w * p5)))));
    c = 1 - w * (q0 + w * (q1 + w * (q2 + w * (q3 + w * (q4 + w * q5)))));
  } else {
    constexpr float p0 = 1.57079632f, p1 = -6.45963478e-1f, p2 = 7.96802176e-2f;
    constexpr float q0 = 1.23370055f, q1 = -2.5366941e-1f, q2 = 2.08615283e-2f;
    s = f * (p0 + w * (p1 + w * p2));
    c = 1 - w * (q0 + w * (q1 + w * q2));
  }
  constexpr T kQuarterCos[4] = {1, 0, -1, 0};
  const T a = kQuarterCos[quarter & 3];
  const T b = kQuarterCos[(quarter + 3) & 3];
  return SinCos<T>{a * s + b * c, a * c - b * s};
}

} // namespace

TEMPLATE_TEST_CASE("sinCos2Pi is within 2 ulps of sin 2πu and cos 2πu over a million u in [0, 1]", "[sincos]", float,
                   double)
{
  const std::vector<TestType> us = testInputs<TestType>();
  REQUIRE(us.size() > 1000000);
  const double worst = maxUlpError(us, [](TestType u) { return sinCos2Pi(u); });
  INFO("largest error " << worst << " ulp");
  CHECK(worst <= kMaxUlps);
}

TEMPLATE_TEST_CASE("sinCos2Pi keeps sin² + cos² within 2 epsilon of 1, so a direction built from it is unit",
                   "[sincos]", float, double)
{
  double worst = 0;
  for (const TestType u : testInputs<TestType>()) {
    const SinCos<TestType> sc = sinCos2Pi(u);
    const long double norm = (long double)sc.sin * sc.sin + (long double)sc.cos * sc.cos;
    worst = std::max(worst, double(std::fabs(norm - 1)) / std::numeric_limits<TestType>::epsilon());
  }
  INFO("largest |sin² + cos² − 1| " << worst << " epsilon");
  CHECK(worst <= kMaxNormEps);
}

TEMPLATE_TEST_CASE("sinCos2Pi is exact at the quarter turns", "[sincos]", float, double)
{
  using T = TestType;
  const T quarters[5][3] = {{0, 0, 1}, {T(0.25), 1, 0}, {T(0.5), 0, -1}, {T(0.75), -1, 0}, {1, 0, 1}};
  for (const auto& q : quarters) {
    const SinCos<T> sc = sinCos2Pi(q[0]);
    INFO("u = " << q[0]);
    CHECK(sc.sin == q[1]);
    CHECK(sc.cos == q[2]);
  }
}

TEMPLATE_TEST_CASE("control: the error measure fails a polynomial one term short", "[sincos]", float, double)
{
  const double worst = maxUlpError(testInputs<TestType>(), [](TestType u) { return truncatedSinCos2Pi(u); });
  INFO("largest error of the truncated polynomial " << worst << " ulp");
  CHECK(worst > kMaxUlps);
}

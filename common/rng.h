/// @file rng.h
/// @brief Random numbers drawn per (seed, pixel, sample): the same seed gives the same image on any thread count.
#pragma once

#include "math.h"

#include <cstdint>

namespace raylife {

/// SplitMix64's finaliser: a bijective 64-bit mix whose outputs for consecutive inputs are uncorrelated.
constexpr std::uint64_t mix64(std::uint64_t z)
{
  z += 0x9e3779b97f4a7c15ULL;
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
  return z ^ (z >> 31);
}

/// PCG32 (O'Neill, pcg-random.org, "XSH RR" output): a small, fast generator of 32-bit integers with period 2⁶⁴
/// per stream. Owned by one pixel sample at a time; never shared between threads.
class Pcg32 {
public:
  /// Seeds the state and selects the stream (any 64-bit values).
  constexpr Pcg32(std::uint64_t seed, std::uint64_t stream) : inc_((stream << 1u) | 1u)
  {
    nextUint();
    state_ += seed;
    nextUint();
  }

  /// A uniformly distributed 32-bit integer.
  constexpr std::uint32_t nextUint()
  {
    const std::uint64_t old = state_;
    state_ = old * 6364136223846793005ULL + inc_;
    const auto xorshifted = std::uint32_t(((old >> 18u) ^ old) >> 27u);
    const auto rot = std::uint32_t(old >> 59u);
    return (xorshifted >> rot) | (xorshifted << ((32u - rot) & 31u));
  }

private:
  std::uint64_t state_ = 0;
  std::uint64_t inc_;
};

/// The random numbers of one pixel sample. Seeded from (seed, pixel x, pixel y, sample index) alone, so the
/// numbers a sample sees do not depend on which thread renders it or in which order.
class Sampler {
public:
  /// @param seed the render's seed (--seed). @param x,y the pixel. @param sampleIndex 0-based, per pixel.
  Sampler(std::uint64_t seed, int x, int y, std::uint64_t sampleIndex)
      : rng_(mix64(seed ^ mix64(std::uint64_t(std::uint32_t(x)) | (std::uint64_t(std::uint32_t(y)) << 32))),
             mix64(sampleIndex ^ 0x5851f42d4c957f2dULL))
  {
  }

  /// A uniform number in [0, 1): 24 random bits for float, 32 for double (never exactly 1).
  Real next1D()
  {
    if constexpr (sizeof(Real) == 4)
      return Real(rng_.nextUint() >> 8) * Real(0x1p-24);
    else
      return Real(rng_.nextUint()) * Real(0x1p-32);
  }

  /// Two uniform numbers in [0, 1)².
  Vec2 next2D()
  {
    const Real a = next1D();
    return Vec2(a, next1D());
  }

private:
  Pcg32 rng_;
};

} // namespace raylife

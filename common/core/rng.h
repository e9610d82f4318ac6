/// @file rng.h
/// @brief Random numbers drawn per (seed, pixel, sample): the same seed gives the same image on any thread count.
#pragma once

#include "core/math.h"

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

  /// The generator whose state and increment (odd) are these: what state() and increment() return, so that
  /// fromState(g.state(), g.increment()) draws what g draws next. (Chapter 16 makes many at once.)
  static constexpr Pcg32 fromState(std::uint64_t state, std::uint64_t increment)
  {
    Pcg32 g;
    g.state_ = state, g.inc_ = increment;
    return g;
  }
  /// The state: the next number's 64 bits before the output permutation.
  constexpr std::uint64_t state() const { return state_; }
  /// The increment of the linear congruential step: the stream, odd.
  constexpr std::uint64_t increment() const { return inc_; }

  /// The linear congruential step's multiplier: state ← state · kMultiplier + increment (mod 2⁶⁴).
  static constexpr std::uint64_t kMultiplier = 6364136223846793005ULL;

  /// A uniformly distributed 32-bit integer.
  constexpr std::uint32_t nextUint()
  {
    const std::uint64_t old = state_;
    state_ = old * kMultiplier + inc_;
    const auto xorshifted = std::uint32_t(((old >> 18u) ^ old) >> 27u);
    const auto rot = std::uint32_t(old >> 59u);
    return (xorshifted >> rot) | (xorshifted << ((32u - rot) & 31u));
  }

private:
  constexpr Pcg32() : inc_(1) {}
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

  /// The sampler that draws from `rng` (Pcg32::fromState): the same as Sampler(seed, x, y, sampleIndex) where
  /// `rng` is that sampler's generator().
  explicit Sampler(const Pcg32& rng) : rng_(rng) {}

  /// The generator the numbers come from, as it stands (the next number not yet drawn).
  const Pcg32& generator() const { return rng_; }

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

/// Points in the pixel's square [0, 1)² for sample counts not known in advance (adaptive sampling, --time):
/// Sobol's first two dimensions (a (0, 2)-sequence), Owen-scrambled with seeds of this pixel's own.
///
/// Jittered strata need the count up front; this sequence is stratified at every count that matters instead:
/// for each k, each aligned block of 2^k points (points j·2^k … (j + 1)·2^k − 1) is a (0, k, 2)-net, so
/// that every box [a/2^i, (a + 1)/2^i) × [b/2^(k−i), (b + 1)/2^(k−i)) holds exactly one of its points (in
/// particular, each block of 16 puts one point in each cell of a 4 × 4 grid). The scramble (nested uniform
/// scrambling, by Laine and Karras's hash as Burley, "Practical Hash-based Owen Scrambling", 2020, writes it)
/// keeps those properties and makes each point uniform on the square, so an estimate from it is unbiased;
/// pixels get independent scrambles. Drawn from (seed, x, y) alone: the same for every sample of a pixel.
class PixelSequence {
public:
  /// @param seed the render's seed. @param x,y the pixel.
  PixelSequence(std::uint64_t seed, int x, int y)
  {
    const std::uint64_t h =
        mix64(seed ^ mix64(std::uint64_t(std::uint32_t(x)) | (std::uint64_t(std::uint32_t(y)) << 32)) ^
              0x2545f4914f6cdd1dULL); // a stream apart from the Sampler's
    scrambleX_ = std::uint32_t(h);
    scrambleY_ = std::uint32_t(h >> 32);
  }

  /// Point `index` of the pixel's sequence, in [0, 1)² (never exactly 1): 24 bits a coordinate for float,
  /// 32 for double, as Sampler::next1D.
  Vec2 point(std::uint32_t index) const
  {
    // Both coordinates are built with their bits reversed (the lowest bit is the fraction's first), where the
    // scramble works: reversed, van der Corput's first dimension is the index itself.
    return Vec2(toUnit(reverseBits(scrambleReversed(index, scrambleX_))),
                toUnit(reverseBits(scrambleReversed(sobolSecondReversed(index), scrambleY_))));
  }

  /// Sobol's second dimension of point `index`, unscrambled, as 32 bits of a binary fraction, with its bits
  /// reversed. The generator matrix is Pascal's triangle mod 2: bit r of the result is the parity of the index's
  /// bits c with C(c, r) odd, which (Lucas) are the c that contain r's bits. That sum over supersets takes one
  /// step per bit of r, without a loop over the index's bits.
  static constexpr std::uint32_t sobolSecondReversed(std::uint32_t index)
  {
    index ^= (index >> 1) & 0x55555555u;
    index ^= (index >> 2) & 0x33333333u;
    index ^= (index >> 4) & 0x0f0f0f0fu;
    index ^= (index >> 8) & 0x00ff00ffu;
    index ^= (index >> 16) & 0x0000ffffu;
    return index;
  }

  /// The bits of x in reverse order.
  static constexpr std::uint32_t reverseBits(std::uint32_t x)
  {
    x = ((x >> 1) & 0x55555555u) | ((x & 0x55555555u) << 1);
    x = ((x >> 2) & 0x33333333u) | ((x & 0x33333333u) << 2);
    x = ((x >> 4) & 0x0f0f0f0fu) | ((x & 0x0f0f0f0fu) << 4);
    x = ((x >> 8) & 0x00ff00ffu) | ((x & 0x00ff00ffu) << 8);
    return (x >> 16) | (x << 16);
  }

  /// Nested uniform (Owen) scrambling of a binary fraction given with its bits reversed: each bit is flipped by
  /// a hash of `seed` and of the bits before it in the fraction, so points that share their leading bits stay
  /// together (the nets survive). Laine and Karras's hash, which carries only from low bits to high ones.
  static constexpr std::uint32_t scrambleReversed(std::uint32_t x, std::uint32_t seed)
  {
    x += seed;
    x ^= x * 0x6c50b47cu;
    x ^= x * 0xb82f1e52u;
    x ^= x * 0xc7afe638u;
    x ^= x * 0x8d22f6e6u;
    return x;
  }

private:
  static Real toUnit(std::uint32_t bits)
  {
    if constexpr (sizeof(Real) == 4)
      return Real(bits >> 8) * Real(0x1p-24);
    else
      return Real(bits) * Real(0x1p-32);
  }

  std::uint32_t scrambleX_ = 0, scrambleY_ = 0;
};

} // namespace raylife

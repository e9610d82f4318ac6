/// @file film.h
/// @brief The film: per-pixel sums of radiance samples, exact in any order, their mean and the variance of that
/// mean.
#pragma once

#include "core/math.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <vector>

namespace raylife {

/// A linear RGB image of float pixels, row 0 at the top. The in-memory form of PFM files and film output.
struct Image {
  int width = 0;                 ///< Pixels, ≥ 0.
  int height = 0;                ///< Pixels, ≥ 0.
  std::vector<float> pixels;     ///< width·height·3 floats, row-major from the top row, RGB interleaved.

  Image() = default;
  /// A black image of the given size.
  Image(int w, int h) : width(w), height(h), pixels(std::size_t(w) * std::size_t(h) * 3, 0.0f) {}

  /// Channel c (0..2) of pixel (x, y).
  float& at(int x, int y, int c) { return pixels[(std::size_t(y) * std::size_t(width) + std::size_t(x)) * 3 + std::size_t(c)]; }
  /// Channel c (0..2) of pixel (x, y).
  float at(int x, int y, int c) const
  {
    return pixels[(std::size_t(y) * std::size_t(width) + std::size_t(x)) * 3 + std::size_t(c)];
  }
};

/// An unsigned 128-bit fixed-point number: the value (hi·2⁶⁴ + lo)·2^−F, with F fraction bits fixed by its use.
/// Integer addition is associative, so a sum of them is the same bits in any order and any grouping: the reason
/// the film holds its sums in this form (docs/beyond-one-machine.md).
struct Fixed128 {
  std::uint64_t lo = 0; ///< Low 64 bits.
  std::uint64_t hi = 0; ///< High 64 bits.

  /// Adds `b` (modulo 2¹²⁸: the film's bounds, kFilmMaxSample and kMaxSamplesPerPixel, keep sums below it).
  Fixed128& operator+=(const Fixed128& b)
  {
    lo += b.lo;
    hi += b.hi + (lo < b.lo ? 1 : 0); // the carry out of the low word
    return *this;
  }
  /// Bitwise equality.
  bool operator==(const Fixed128&) const = default;
};

/// `v` (finite, ≥ 0, v·2^F < 2¹²⁸) as a Fixed128 with F = `fractionBits`, rounded to the nearest multiple of 2^−F
/// (ties to even). Exact for every v whose last significant bit is at or above 2^−F.
inline Fixed128 toFixed(double v, int fractionBits)
{
  // v = mantissa · 2^(exponent − 1075), the mantissa with its implicit leading bit (none for a subnormal).
  const std::uint64_t bits = std::bit_cast<std::uint64_t>(v);
  const int biased = int(bits >> 52);
  const std::uint64_t mantissa = (bits & ((std::uint64_t(1) << 52) - 1)) | (biased ? std::uint64_t(1) << 52 : 0);
  const int shift = std::max(biased, 1) - 1075 + fractionBits; // v·2^F = mantissa · 2^shift
  if (shift >= 64)
    return {0, mantissa << (shift - 64)};
  if (shift > 0)
    return {mantissa << shift, mantissa >> (64 - shift)};
  if (shift == 0)
    return {mantissa, 0};
  // Below the last fraction bit: round to nearest, ties to even. (The mantissa is < 2⁵³, so beyond 53 places it
  // is less than half a step.)
  const int right = -shift;
  if (right > 53)
    return {};
  const std::uint64_t quotient = mantissa >> right;
  const std::uint64_t remainder = mantissa & ((std::uint64_t(1) << right) - 1);
  const std::uint64_t half = std::uint64_t(1) << (right - 1);
  // (Bitwise, not ||: a short-circuit is a branch on the sample's low bits, mispredicted half the time.)
  return {quotient + (std::uint64_t(remainder > half) | (std::uint64_t(remainder == half) & quotient & 1)), 0};
}
/// The value of `f` (F = `fractionBits`, at most 1022) as the nearest double, give or take one rounding of the low
/// word.
inline double toDouble(const Fixed128& f, int fractionBits)
{
  // hi·2⁶⁴ + lo is 0 or at least 1, so scaling it by 2^−F (F ≤ 1022) is exact: a product, not a call to ldexp
  // (std::ldexp(1.0, −F) is folded where F is a constant).
  return (double(f.hi) * 0x1p64 + double(f.lo)) * std::ldexp(1.0, -fractionBits);
}

/// Samples of radiance must lie below this (2³², about 4.3·10⁹) to be added to a film: the render loop counts
/// a larger one as bad and adds black, as it does a NaN. With kMaxSamplesPerPixel samples, sums stay below 2⁵⁶
/// and sums of squares below 2⁸⁸, which the film's fixed point holds without overflow.
inline constexpr double kFilmMaxSample = 4294967296.0;
/// The most samples one pixel of a film may hold (2²⁴, the largest --spp): the bound behind kFilmMaxSample.
inline constexpr std::uint32_t kMaxSamplesPerPixel = std::uint32_t(1) << 24;
/// Fraction bits of a film's sums: steps of 2⁻⁶⁴ (5.4·10⁻²⁰), finer than a double's last bit for every
/// sample above 2⁻¹² and far below anything a float pixel shows.
inline constexpr int kFilmSumFractionBits = 64;
/// Fraction bits of a film's sums of squares: steps of 2⁻⁴⁰ (9.1·10⁻¹³), so that 2²⁴ squares of samples up to
/// 2³² fit in 128 bits; they feed only variance estimates.
inline constexpr int kFilmSquareFractionBits = 40;

/// Accumulates radiance samples per pixel: for each pixel the sum of its samples, the sum of their squares (per
/// channel) and their count. Sums are kept in 128-bit fixed point (Fixed128), so adding samples, or whole films
/// (merge), gives the same bits in any order: a render split over threads, processes or machines by sample index
/// is bit-identical to the one-process render. Each pixel is written by one thread at a time (the render loop
/// hands out disjoint tiles).
class Film {
public:
  /// One pixel's sums: per channel, the sum of the samples (F = kFilmSumFractionBits) and of their squares
  /// (F = kFilmSquareFractionBits).
  struct Sums {
    Fixed128 sum[3];     ///< Σ L per channel.
    Fixed128 squares[3]; ///< Σ L² per channel.
  };

  /// A film of width × height pixels (each ≥ 1), all sums zero.
  Film(int width, int height);
  /// A film of width × height pixels with the given sums and counts (width·height of each), as read from a .film
  /// file or received from another process. @throws std::invalid_argument when the sizes disagree.
  Film(int width, int height, std::vector<Sums> sums, std::vector<std::uint32_t> counts);

  /// Whether a sample of radiance `L` may be added: finite, ≥ 0 and < kFilmMaxSample in every channel.
  static bool holds(const Color& L)
  {
    return isFinite(L) && L.r >= 0 && L.g >= 0 && L.b >= 0 && L.r < kFilmMaxSample && L.g < kFilmMaxSample &&
           L.b < kFilmMaxSample;
  }

  /// Adds one sample of radiance L to pixel (x, y). L must pass holds() (the render loop guards this).
  void add(int x, int y, const Color& L)
  {
    const std::size_t i = index(x, y);
    Sums& p = sums_[i];
    for (int c = 0; c < 3; ++c) {
      const double v = double(L[c]);
      p.sum[c] += toFixed(v, kFilmSumFractionBits);
      p.squares[c] += toFixed(v * v, kFilmSquareFractionBits);
    }
    counts_[i] += 1;
  }

  /// Adds every sum and count of `other` (of the same size; std::invalid_argument otherwise) to this film. Exact:
  /// films merged in any order and grouping give the same bits.
  void merge(const Film& other);

  /// The mean radiance of each pixel (black where a pixel has no sample).
  Image mean() const;

  /// The estimated variance of each pixel's mean, s²/n with s² the unbiased sample variance (0 for n < 2).
  Image varianceOfMean() const;

  /// The estimated relative standard error of pixel (x, y)'s mean: the largest over the channels of
  /// sqrt(s²/n) / max(mean, floor), with s² the unbiased sample variance; `floor` (> 0, radiance) keeps dark
  /// pixels from needing endless samples. +infinity for n < 2, and while every sample has been black (nothing
  /// is known yet: a black pixel of a path tracer may not have found the light).
  double relativeError(int x, int y, double floor) const;
  /// Samples taken in pixel (x, y).
  std::uint32_t samples(int x, int y) const { return counts_[index(x, y)]; }

  /// Width in pixels.
  int width() const { return width_; }
  /// Height in pixels.
  int height() const { return height_; }
  /// Every pixel's sums, row-major from the top row (what a .film file and an MPI reduce carry).
  const std::vector<Sums>& sums() const { return sums_; }
  /// Every pixel's sample count, row-major from the top row.
  const std::vector<std::uint32_t>& counts() const { return counts_; }

private:
  std::size_t index(int x, int y) const { return std::size_t(y) * std::size_t(width_) + std::size_t(x); }
  // Pixel i's sums as doubles: mean, and the unbiased variance s² per channel (n ≥ 2).
  struct Moments {
    glm::dvec3 mean;
    glm::dvec3 variance;
  };
  Moments moments(std::size_t i) const;

  int width_;
  int height_;
  std::vector<Sums> sums_;
  std::vector<std::uint32_t> counts_;
};

/// Two films of one height side by side, `left` then `right` (chapter 9 puts its heat map beside its image).
Film sideBySide(const Film& left, const Film& right);

} // namespace raylife

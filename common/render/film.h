/// @file film.h
/// @brief The film: per-pixel sums of radiance samples, their mean and the variance of that mean.
#pragma once

#include "core/math.h"

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

/// Accumulates radiance samples per pixel. Each pixel is written by one thread at a time (the render loop
/// hands out disjoint tiles), and samples are added in sample-index order, so sums are bit-reproducible.
class Film {
public:
  /// A film of width × height pixels (each ≥ 1), all sums zero.
  Film(int width, int height);

  /// Adds one sample of radiance L to pixel (x, y). L must be finite and ≥ 0 (the render loop guards this).
  void add(int x, int y, const Color& L)
  {
    Pixel& p = pixels_[index(x, y)];
    p.sum += glm::dvec3(L);
    p.sumSquares += glm::dvec3(L) * glm::dvec3(L);
    p.count += 1;
  }

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
  std::uint32_t samples(int x, int y) const { return pixels_[index(x, y)].count; }

  /// Width in pixels.
  int width() const { return width_; }
  /// Height in pixels.
  int height() const { return height_; }

private:
  struct Pixel {
    glm::dvec3 sum{0};        // sums in double whatever Real is: thousands of samples must not lose bits
    glm::dvec3 sumSquares{0};
    std::uint32_t count = 0;
  };
  std::size_t index(int x, int y) const { return std::size_t(y) * std::size_t(width_) + std::size_t(x); }

  int width_;
  int height_;
  std::vector<Pixel> pixels_;
};

} // namespace raylife

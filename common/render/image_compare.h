/// @file image_compare.h
/// @brief The metrics the golden tests and the teachers' compare tool share.
#pragma once

#include "render/film.h"

#include <string>

namespace raylife {

/// How two images of the same size differ, over every pixel and channel.
struct ImageDifference {
  double maxAbs = 0;        ///< Largest |a − b| of any channel.
  double rmse = 0;          ///< √(mean of (a − b)²).
  double psnr = 0;          ///< 10·log10(1 / mse), in dB, peak 1 (+∞ for identical images).
  double relativeMse = 0;   ///< Mean of (a − b)² / (b² + 0.01), b being the reference (docs/benchmarks.md).
  double overTolerance = 0; ///< Share of pixels, in [0, 1], with any channel's |a − b| > the tolerance.
  int worstX = 0;           ///< Pixel of the largest difference.
  int worstY = 0;           ///< Pixel of the largest difference.
};

/// Compares `image` with `reference` (same size, checked by the caller); `tolerance` ≥ 0 per channel.
ImageDifference compareImages(const Image& image, const Image& reference, double tolerance);

/// |a − b| per channel, scaled by `gain` (so small differences show), for looking at.
Image differenceImage(const Image& image, const Image& reference, double gain);

/// Per-pixel statistical comparison of a Monte Carlo render against a reference with known variance.
struct ZTestResult {
  double failedShare = 0;    ///< Share of pixel channels with |z| > the critical value.
  double meanZ = 0;          ///< Mean z over channels (≈ 0 for an unbiased render): a bias detector.
  double totalZ = 0;         ///< z of the difference of the image means, over all channels.
  std::size_t channels = 0;  ///< Channels tested (those with a defined z).
};

/// z = (a − b) / √(varA + varB + floor) per channel, where var are variances of the means (Film::varianceOfMean).
/// `floor` keeps z defined where both variances are zero (the pixel is exactly known, e.g. background).
/// A channel fails when |z| > `critical`. For an unbiased image the failed share is ≈ the two-sided
/// significance of `critical` (e.g. 0.0027 for 3).
ZTestResult zTestImages(const Image& image, const Image& imageVariance, const Image& reference,
                        const Image& referenceVariance, double critical, double floor);

} // namespace raylife

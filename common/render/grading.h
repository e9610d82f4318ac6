/// @file grading.h
/// @brief Grading a chapter's image against its golden (raylife_check, docs/golden-tests.md): exactly, in the
/// image's own domain, for the deterministic chapters; by a per-pixel z-test and an image-mean test for the Monte
/// Carlo ones.
#pragma once

#include "render/film.h"

#include <string>
#include <vector>

namespace raylife {

/// A channel of a pixel that failed, for the report; coordinates are the graded image's.
struct FailedChannel {
  int x = 0;            ///< Column of the pixel (for a downsampled image: the block's first column).
  int y = 0;            ///< Row of the pixel, 0 at the top (for a downsampled image: the block's first row).
  int channel = 0;      ///< 0 red, 1 green, 2 blue.
  double value = 0;     ///< The image's value (an 8-bit code for an exact PNG, else linear radiance).
  double expected = 0;  ///< The golden's value, in the same unit.
  double score = 0;     ///< How far out: |difference| / allowed (exact), or z (statistical).
};

/// The outcome of grading one image: the verdict and the figures behind it.
struct Grade {
  bool pass = false;                 ///< True when the image passes.
  std::string verdict;               ///< One line: PASS or FAIL and the deciding figures.
  std::vector<std::string> figures;  ///< More figures, one line each.
  std::vector<FailedChannel> worst;  ///< Up to 8 failed channels, the worst first.
  std::size_t failedPixels = 0;      ///< Pixels (of the graded size) with at least one failed channel.
  std::size_t pixels = 0;            ///< Pixels graded.
  int boxX0 = 0;                     ///< Bounding box of the failed pixels, in the image's coordinates:
  int boxY0 = 0;                     ///< first column and row, ...
  int boxX1 = -1;                    ///< ... last column and row (boxX1 < boxX0 when none failed).
  int boxY1 = -1;                    ///< (Last row.)
  Image difference;                  ///< For looking at: the error per channel, 1 = at the allowed limit.
};

/// The 8-bit code the chapters write into a PNG for a linear value: clamped to [0, 1], sRGB-encoded, rounded
/// (NaN gives 0). Equal to what encodePng writes.
int srgbCode(float linear);

/// Grades a PNG of a deterministic chapter: each channel's code against the golden's, the golden encoded exactly
/// as the chapters encode PNGs (srgbCode). Passes when no channel is more than `codes` away (rounding of the
/// linear values before the encoding can move a code by one).
/// @param image  the PNG, decoded to linear (readPng); its codes are recovered exactly.
/// @param golden the golden in linear radiance, same size (checked by the caller).
/// @param codes  allowed difference in codes, ≥ 0.
Grade gradePngExactly(const Image& image, const Image& golden, int codes);

/// Grades a linear image (PFM, EXR) of a deterministic chapter: passes when every channel has
/// |a − b| ≤ relative·|b| + absolute, b the golden's value (same size, checked by the caller).
/// @param image    the image in linear radiance.
/// @param golden   the golden in linear radiance.
/// @param relative relative tolerance, ≥ 0.
/// @param absolute absolute tolerance in radiance, ≥ 0 (for black pixels).
Grade gradeLinearExactly(const Image& image, const Image& golden, double relative, double absolute);

/// What the statistical grading needs to know of the image and of the reference.
struct StatisticalSetup {
  int spp = 1;                 ///< Samples per pixel of the image under test, ≥ 1.
  int referenceSpp = 1;        ///< Samples per pixel of the reference, ≥ 1.
  bool fromPng = false;        ///< The image was an 8-bit PNG: account for rounding, treat code 255 as "≥ 1".
  int cell = 1;                ///< Grade cells of cell×cell reference pixels (≥ 1, dividing its width and height).
  double critical = 3.29;      ///< A channel fails when |z| > critical (two-sided significance 0.001 for 3.29).
  double falseFailure = 1e-4;  ///< Probability with which the share bound fails a correct image (a binomial tail).
  double meanCritical = 4;     ///< The image mean fails, per channel, when its |z| > this.
};

/// Grades a Monte Carlo image against a reference with the variance of each of its pixel means.
///
/// The image may be k times the reference's size in each direction (k ≥ 1, an integer). It is graded in cells of
/// setup.cell × setup.cell reference pixels: the image's pixels over a cell are averaged, which estimates the
/// reference's cell mean without bias, since both are box-filtered (cells larger than a pixel give each one more
/// samples, so that the paths that rarely find a light, whose few samples make a pixel's mean skewed, do not
/// make a correct image fail). Per cell and channel,
///   z = (a − b) / √(σa² + σb² + q² + floor),
/// with σb² the variance of the reference's cell mean, σa² = σb²·referenceSpp/(spp·k²) the variance a correct image
/// with those samples has (not the image's own: a biased estimator often has a heavier tail, which would hide its
/// bias), q the PNG's rounding (half a code, in linear) and a tiny floor for exactly known pixels. A PNG channel at
/// code 255 only says "at least 1": it can fail for being too bright, never for being too dark. The image-mean test
/// of a PNG leaves out the cells whose reference is ≥ 1 and takes the image's other clamped values as 1, a lower
/// bound: when there are any, the mean can only fail for being too bright. A cell fails when any of its channels
/// has |z| > critical; for a correct image that happens with probability α = 1 − (1 − α₁)³ (Šidák over the channels, α₁ the two-sided significance of
/// `critical`). The image passes when the failed cells are no more than the (1 − falseFailure) quantile of
/// Binomial(cells, α), and each channel's image mean is within meanCritical standard errors.
/// Grade::pixels and Grade::failedPixels then count cells; the difference image has one pixel per cell.
/// @param image             the image, linear (a PNG decoded by readPng), k times the reference's size.
/// @param reference         the reference's mean, linear.
/// @param referenceVariance the variance of each of the reference's pixel means (Film::varianceOfMean).
/// @param setup             samples, the PNG flag and the thresholds.
Grade gradeStatistically(const Image& image, const Image& reference, const Image& referenceVariance,
                         const StatisticalSetup& setup);

/// The smallest k with P(X > k) ≤ `tail` for X ~ Binomial(n, p): the most failures a correct image may show.
/// @param n    trials, ≥ 0.
/// @param p    probability of each, in [0, 1].
/// @param tail the allowed probability of exceeding k, in (0, 1).
std::size_t binomialBound(std::size_t n, double p, double tail);

} // namespace raylife

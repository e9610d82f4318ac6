#include "render/grading.h"

#include "render/image_io.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace raylife {

namespace {

std::string format(const char* pattern, double a, double b = 0, double c = 0, double d = 0)
{
  char line[256];
  std::snprintf(line, sizeof line, pattern, a, b, c, d);
  return line;
}

// Keeps the worst failed channels and the box around the failed pixels while grading goes over the image.
class FailureLog {
public:
  explicit FailureLog(Grade& grade) : grade_(grade) {}

  void add(const FailedChannel& f)
  {
    grade_.worst.push_back(f);
    std::sort(grade_.worst.begin(), grade_.worst.end(),
              [](const FailedChannel& a, const FailedChannel& b) { return std::abs(a.score) > std::abs(b.score); });
    if (grade_.worst.size() > 8)
      grade_.worst.pop_back();
  }
  void pixelFailed(int x0, int y0, int x1, int y1)
  {
    ++grade_.failedPixels;
    grade_.boxX0 = grade_.boxX1 < grade_.boxX0 ? x0 : std::min(grade_.boxX0, x0);
    grade_.boxY0 = grade_.boxY1 < grade_.boxY0 ? y0 : std::min(grade_.boxY0, y0);
    grade_.boxX1 = std::max(grade_.boxX1, x1);
    grade_.boxY1 = std::max(grade_.boxY1, y1);
  }

private:
  Grade& grade_;
};

const char* const kChannel[3] = {"red", "green", "blue"};

// "where": the box of the failed pixels and the channels that failed most.
void describeWhere(Grade& g, const char* unit)
{
  if (g.failedPixels == 0)
    return;
  g.figures.push_back(format("failed pixels lie in columns %.0f to %.0f, rows %.0f to %.0f (row 0 at the top)",
                             g.boxX0, g.boxX1, g.boxY0, g.boxY1));
  for (const FailedChannel& f : g.worst)
    g.figures.push_back("  pixel (" + std::to_string(f.x) + ", " + std::to_string(f.y) + ") " + kChannel[f.channel] +
                        ": " + format("%.6g, expected %.6g", f.value, f.expected) + " (" + unit +
                        format(" %.3g)", f.score));
}

} // namespace

int srgbCode(float linear)
{
  return int(std::lround((std::isnan(linear) ? 0.0f : linearToSrgb(linear)) * 255.0f));
}

namespace {

// One channel compared exactly: the two values (in the unit of the comparison), how far out (1: at the allowed
// limit) and whether it fails.
struct ChannelVerdict {
  double value, expected, score;
  bool failed;
};

// Compares every channel of `image` with `golden` by `compare` (x, y, c → ChannelVerdict), filling in the failed
// pixels, the worst channels and the difference image of `g`.
template <class Compare>
void compareChannels(Grade& g, const Image& image, Compare compare)
{
  FailureLog log(g);
  g.pixels = std::size_t(image.width) * std::size_t(image.height);
  g.difference = Image(image.width, image.height);
  for (int y = 0; y < image.height; ++y)
    for (int x = 0; x < image.width; ++x) {
      bool failed = false;
      for (int c = 0; c < 3; ++c) {
        const ChannelVerdict v = compare(x, y, c);
        g.difference.at(x, y, c) = float(std::min(v.score, 1e6));
        if (v.failed) {
          failed = true;
          log.add({x, y, c, v.value, v.expected, v.score});
        }
      }
      if (failed)
        log.pixelFailed(x, y, x, y);
    }
  g.pass = g.failedPixels == 0;
}

} // namespace

Grade gradePngExactly(const Image& image, const Image& golden, int codes)
{
  Grade g;
  int largest = 0;
  compareChannels(g, image, [&](int x, int y, int c) {
    const int a = srgbCode(image.at(x, y, c)), b = srgbCode(golden.at(x, y, c));
    const int d = std::abs(a - b);
    largest = std::max(largest, d);
    return ChannelVerdict{double(a), double(b), double(d) / std::max(codes, 1), d > codes};
  });
  g.verdict = std::string(g.pass ? "PASS" : "FAIL") +
              format(": %.0f of %.0f pixels differ from the golden by more than %.0f code(s) (largest: %.0f)",
                     double(g.failedPixels), double(g.pixels), codes, largest);
  g.figures.push_back("compared as PNG codes: the golden clamped, sRGB-encoded and rounded to 8 bits, as the "
                      "chapters write PNGs");
  describeWhere(g, "codes over the allowed, x");
  return g;
}

Grade gradeLinearExactly(const Image& image, const Image& golden, double relative, double absolute)
{
  Grade g;
  double largest = 0;
  compareChannels(g, image, [&](int x, int y, int c) {
    const double a = image.at(x, y, c), b = golden.at(x, y, c);
    // A NaN is never within tolerance.
    const double allowed = relative * std::abs(b) + absolute;
    const double score = std::isnan(a) || std::isnan(b) ? INFINITY : std::abs(a - b) / allowed;
    largest = std::max(largest, std::abs(a - b));
    return ChannelVerdict{a, b, score, !(score <= 1)};
  });
  g.verdict = std::string(g.pass ? "PASS" : "FAIL") +
              format(": %.0f of %.0f pixels differ from the golden by more than %g relative (+ %g)",
                     double(g.failedPixels), double(g.pixels), relative, absolute);
  g.figures.push_back(format("largest absolute difference %.3g", largest));
  describeWhere(g, "times the allowed difference:");
  return g;
}

std::size_t binomialBound(std::size_t n, double p, double tail)
{
  if (p <= 0)
    return 0;
  if (p >= 1)
    return n;
  // P(X = k) by the recurrence P(k+1) = P(k)·(n−k)/(k+1)·p/(1−p), from P(0) = (1−p)^n in logarithms.
  double logTerm = double(n) * std::log1p(-p), cumulative = 0;
  for (std::size_t k = 0; k <= n; ++k) {
    cumulative += std::exp(logTerm);
    if (1 - cumulative <= tail)
      return k;
    logTerm += std::log(double(n - k)) - std::log(double(k + 1)) + std::log(p) - std::log1p(-p);
  }
  return n;
}

Grade gradeStatistically(const Image& image, const Image& reference, const Image& referenceVariance,
                         const StatisticalSetup& setup)
{
  constexpr double kFloor = 1e-10; // keeps z defined where both variances are 0 (exactly known pixels)
  Grade g;
  FailureLog log(g);
  // The reference in cells of b×b pixels: their means, and the variance of those means, Σ var / b⁴.
  const int b = std::max(setup.cell, 1);
  Image cells(reference.width / b, reference.height / b), cellVariance(reference.width / b, reference.height / b);
  for (int y = 0; y < cells.height * b; ++y)
    for (int x = 0; x < cells.width * b; ++x)
      for (int c = 0; c < 3; ++c) {
        cells.at(x / b, y / b, c) += float(double(reference.at(x, y, c)) / (b * b));
        cellVariance.at(x / b, y / b, c) += float(double(referenceVariance.at(x, y, c)) / (b * b * b * b));
      }
  const int k = (reference.width > 0 ? image.width / reference.width : 1) * b; // image pixels per cell, across
  const double blockSpp = double(setup.spp) * k * k, cellReferenceSpp = double(setup.referenceSpp) * b * b;
  g.pixels = std::size_t(cells.width) * std::size_t(cells.height);
  g.difference = Image(cells.width, cells.height);
  double sumDiff[3] = {0, 0, 0}, sumVar[3] = {0, 0, 0};
  std::size_t clamped = 0;
  bool clampedInMean = false;
  for (int y = 0; y < cells.height; ++y)
    for (int x = 0; x < cells.width; ++x) {
      bool failed = false;
      for (int c = 0; c < 3; ++c) {
        // The block's mean, and for a PNG its rounding and whether any of it was clamped.
        double sum = 0, rounding = 0;
        bool atLeast = false;
        for (int j = 0; j < k; ++j)
          for (int i = 0; i < k; ++i) {
            const float v = image.at(x * k + i, y * k + j, c);
            sum += v;
            if (setup.fromPng) {
              const int code = srgbCode(v);
              atLeast |= code == 255;
              rounding += (srgbToLinear(std::min(float(code) + 0.5f, 255.0f) / 255.0f) -
                           srgbToLinear(std::max(float(code) - 0.5f, 0.0f) / 255.0f)) / 2;
            }
          }
        const double a = sum / (k * k), q = rounding / (k * k);
        const double r = cells.at(x, y, c), varB = cellVariance.at(x, y, c);
        const double varA = varB * cellReferenceSpp / blockSpp;
        const double var = varA + varB + q * q + kFloor;
        double z = (a - r) / std::sqrt(var);
        if (std::isnan(z))
          z = INFINITY; // a NaN in either image fails, never passes
        if (atLeast) {
          ++clamped;
          z = std::max(z, 0.0); // only "too bright" can be told from a clamped value
        }
        // The image mean leaves out what the reference says is clamped (≥ 1); chosen by the reference, never by
        // the image, so that leaving out is no bias. What the image clamped elsewhere (a bright sample) enters as 1,
        // a lower bound, and the mean can then only be told to be too bright.
        if (r < 1 || !setup.fromPng) {
          sumDiff[c] += a - r;
          sumVar[c] += var;
          clampedInMean |= atLeast;
        }
        g.difference.at(x, y, c) = float(std::min(std::abs(z) / setup.critical, 1e6));
        if (!(std::abs(z) <= setup.critical)) {
          failed = true;
          log.add({x * k, y * k, c, a, r, z});
        }
      }
      if (failed)
        log.pixelFailed(x * k, y * k, x * k + k - 1, y * k + k - 1);
    }
  // Šidák: a pixel of a correct image fails with probability 1 − (1 − α₁)³.
  const double alpha1 = std::erfc(setup.critical / std::sqrt(2.0));
  const double alphaPixel = 1 - std::pow(1 - alpha1, 3);
  const std::size_t allowed = binomialBound(g.pixels, alphaPixel, setup.falseFailure);
  // The image mean's test: two-sided, or, where the PNG clamped some of what enters the mean (which can only make
  // it darker), one-sided: only a channel too bright fails, so the highest z decides.
  double worstMeanZ = clampedInMean ? -INFINITY : 0;
  std::string means;
  for (int c = 0; c < 3; ++c) {
    double z = sumVar[c] > 0 ? sumDiff[c] / std::sqrt(sumVar[c]) : 0;
    if (std::isnan(z))
      z = INFINITY;
    if (clampedInMean ? z > worstMeanZ : !(std::abs(z) <= std::abs(worstMeanZ)))
      worstMeanZ = z;
    if (c) // (appended in two steps: GCC 12's link-time optimisation warns falsely on "literal" + string)
      means += ", ";
    means += format("%+.2f", z);
  }
  const bool sharePass = g.failedPixels <= allowed;
  const bool meanPass = clampedInMean ? worstMeanZ <= setup.meanCritical : std::abs(worstMeanZ) <= setup.meanCritical;
  g.pass = sharePass && meanPass;
  // (What is counted: the image's pixels, or the cells of several that they are graded in.)
  const std::string unit = k == 1 ? "pixels" : "cells";
  g.verdict = std::string(g.pass ? "PASS" : "FAIL") +
              format(": %.0f of %.0f ", double(g.failedPixels), double(g.pixels)) + unit +
              format(" fail the z-test (allowed %.0f)", double(allowed)) +
              (clampedInMean
                   ? format("; the image mean's highest z is %+.2f (fails above %+.2g: one-sided, as the PNG "
                            "clamped some channels, which can only darken it)",
                            worstMeanZ, setup.meanCritical)
                   : format("; the image mean's worst z is %+.2f (fails beyond +-%.2g)", worstMeanZ,
                            setup.meanCritical));
  g.figures.push_back(format("per channel: fails when |z| > %.3g (two-sided %.2g); per ", setup.critical, alpha1) +
                      unit.substr(0, unit.size() - 1) + format(", Sidak over 3 channels: %.2g", alphaPixel));
  g.figures.push_back("allowed failed " + unit +
                      format(": the 1 - %.0e quantile of Binomial(%.0f, %.2g)", setup.falseFailure,
                             double(g.pixels), alphaPixel));
  g.figures.push_back("image mean, z per channel (red, green, blue): " + means);
  g.figures.push_back(format("image %.0fx%.0f graded in %.0fx%.0f cells", image.width, image.height, cells.width,
                             cells.height) +
                      format(" (%.0fx%.0f of its pixels each); %.0f spp against the reference's %.0f", k, k,
                             setup.spp, setup.referenceSpp) +
                      format(" (%.0fx%.0f of its pixels each)", b, b));
  if (setup.fromPng)
    g.figures.push_back(format("from a PNG: rounding counted in the variance; %.0f channels clamped at 255 (tested "
                               "only for being too bright)",
                               double(clamped)) +
                        (clampedInMean ? "; so the image mean too (grade the PFM for the full test)" : ""));
  if (!sharePass)
    g.figures.push_back("too many " + unit + " far from the reference: a wrong value there, or fewer samples than "
                        "stated (give --spp N)");
  if (!meanPass)
    g.figures.push_back("the whole image is brighter or darker than the reference: a bias");
  describeWhere(g, "z");
  return g;
}

} // namespace raylife

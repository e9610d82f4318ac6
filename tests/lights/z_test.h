// The per-pixel z-test of two Monte Carlo images that the chapters' agreement tests share (tests/lights): per pixel
// channel z = (a − b)/√(var_a + var_b), var being the variance of each image's pixel mean from its own samples; a
// channel fails when |z| > 3.29 (two-sided significance 0.001), and at most 2% of the channels may fail; the image
// mean of each channel must agree within 4 standard errors. See test_lights_render.cpp for why these bounds.
#pragma once

#include "render/film.h"

#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <iostream>
#include <string>
#include <vector>

namespace raylife::test {

constexpr double kCritical = 3.29;
constexpr double kMaxFailedShare = 0.02;
constexpr double kMaxTotalZ = 4;
constexpr double kVarianceFloor = 1e-10; // keeps z defined where both images know a pixel exactly (black)


struct Verdict {
  double failedShare = 0; // share of channels with |z| > kCritical
  double worstTotalZ = 0; // the channel whose image mean differs most, in standard errors
  bool passed() const { return failedShare <= kMaxFailedShare && std::abs(worstTotalZ) <= kMaxTotalZ; }
};

// Compares two Monte Carlo images (or an image and an expectation with zero variance) over the pixels `use` marks,
// per pixel channel, or per channel of blocks of block × block pixels (z of the block's summed difference).
inline Verdict compare(const Image& a, const Image& varA, const Image& b, const Image& varB, const std::string& what,
                       const std::vector<bool>* use = nullptr, int block = 1, double systematic = 0)
{
  REQUIRE(a.width == b.width);
  REQUIRE(a.height == b.height);
  Verdict v;
  std::size_t failed = 0, tests = 0;
  double sumDiff[3] = {0, 0, 0}, sumVar[3] = {0, 0, 0}, sumB[3] = {0, 0, 0};
  for (int by = 0; by < a.height; by += block)
    for (int bx = 0; bx < a.width; bx += block)
      for (int c = 0; c < 3; ++c) {
        double diff = 0, var = 0;
        int pixels = 0;
        for (int y = by; y < std::min(by + block, a.height); ++y)
          for (int x = bx; x < std::min(bx + block, a.width); ++x) {
            if (use && !(*use)[std::size_t(y * a.width + x)])
              continue;
            diff += double(a.at(x, y, c)) - double(b.at(x, y, c));
            sumB[c] += std::abs(double(b.at(x, y, c)));
            var += double(varA.at(x, y, c)) + double(varB.at(x, y, c)) + kVarianceFloor;
            ++pixels;
          }
        if (pixels == 0)
          continue;
        failed += !(std::abs(diff / std::sqrt(var)) <= kCritical);
        ++tests;
        sumDiff[c] += diff;
        sumVar[c] += var;
      }
  v.failedShare = double(failed) / double(tests);
  for (int c = 0; c < 3; ++c) {
    // A known systematic error (relative to the image mean) is allowed before the difference counts against z.
    const double excess = std::max(0.0, std::abs(sumDiff[c]) - systematic * sumB[c]);
    const double z = std::copysign(excess, sumDiff[c]) / std::sqrt(sumVar[c]);
    if (std::abs(z) > std::abs(v.worstTotalZ))
      v.worstTotalZ = z;
  }
  std::cout << what << ": failed " << (block == 1 ? "pixel channels " : "block channels ") << 100 * v.failedShare
            << "% of " << tests << " (bound " << 100 * kMaxFailedShare
            << "%), worst channel's image mean off by z = " << v.worstTotalZ << " (bound " << kMaxTotalZ << ")\n";
  return v;
}

} // namespace raylife::test

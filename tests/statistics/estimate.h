// A Monte Carlo estimate with its standard error, drawn from raylife's own sampler with a fixed seed: the energy
// tests of the BSDFs (test_bsdf.cpp, test_ggx.cpp).
#pragma once

#include "core/rng.h"

#include <algorithm>
#include <cmath>
#include <cstdint>

namespace raylife::test {

// Mean and standard error of a Monte Carlo estimate.
struct Estimate {
  double mean = 0;
  double stdError = 0;
};

// The mean of n values of sampleValue(rng), with its standard error.
template <class F> Estimate estimate(int n, std::uint64_t seed, F&& sampleValue)
{
  Sampler rng(seed, 1, 2, 3);
  double sum = 0, sumSq = 0;
  for (int i = 0; i < n; ++i) {
    const double v = sampleValue(rng);
    sum += v;
    sumSq += v * v;
  }
  const double mean = sum / n;
  return Estimate{mean, std::sqrt(std::max(0.0, sumSq / n - mean * mean) / (n - 1))};
}

} // namespace raylife::test

// A chi-square goodness-of-fit test of a direction sampler against its pdf (in the spirit of Nori's and pbrt's).
//
// The sphere of directions is cut into cells of equal width in cosθ and in φ (equal solid angle each, as
// dω = dcosθ dφ). The expected count of a cell is N times the integral of the pdf over it, taken numerically on a
// fine grid inside the cell; samples the sampler declines (it returned nothing) form one more cell, expected
// N·(1 − ∫pdf). Cells expected fewer than 5 samples are pooled, and the statistic Σ(O − E)²/E is compared with the
// chi-square quantile for the remaining degrees of freedom at the stated significance (Wilson–Hilferty).
#pragma once

#include "core/math.h"
#include "core/rng.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

namespace raylife::test {

/// The outcome of one chi-square test.
struct ChiSquareResult {
  double statistic = 0; ///< Σ (O − E)² / E over the pooled cells.
  int dof = 0;          ///< Degrees of freedom: pooled cells − 1.
  double threshold = 0; ///< The chi-square quantile at 1 − significance.
  bool passed = false;  ///< statistic ≤ threshold.
  std::string summary() const
  {
    std::ostringstream s;
    s << "chi2 = " << statistic << " with " << dof << " dof, threshold " << threshold;
    return s.str();
  }
};

/// The (1 − alpha) quantile of the chi-square distribution with k degrees of freedom, by the Wilson–Hilferty
/// approximation χ² ≈ k (1 − 2/(9k) + z √(2/(9k)))³, z the standard normal quantile (accurate to about 1% for k ≥ 10).
inline double chiSquareQuantile(int k, double alpha)
{
  // Standard normal quantile for the upper tail alpha, by bisection on erfc (no tables needed).
  double lo = -10, hi = 10;
  for (int i = 0; i < 200; ++i) {
    const double mid = (lo + hi) / 2;
    if (0.5 * std::erfc(mid / std::sqrt(2.0)) > alpha)
      lo = mid;
    else
      hi = mid;
  }
  const double z = (lo + hi) / 2, kk = double(k);
  const double c = 1 - 2 / (9 * kk) + z * std::sqrt(2 / (9 * kk));
  return kk * c * c * c;
}

/// A direction sampler: uniform numbers in, a unit direction (or nothing: the sample is declined) out.
using DirectionSampler = std::function<std::optional<Vec3>(Vec2 u, Real uChoice)>;
/// A pdf per steradian over the whole sphere.
using DirectionPdf = std::function<double(const Vec3& w)>;

/// Runs the test with `samples` draws (fixed `seed`) on a grid of cosBins × phiBins cells.
inline ChiSquareResult chiSquareTest(const DirectionSampler& sample, const DirectionPdf& pdf, int samples,
                                     std::uint64_t seed, double significance, int cosBins = 20, int phiBins = 40,
                                     int subdivisions = 2)
{
  const int cells = cosBins * phiBins;
  std::vector<double> observed(std::size_t(cells) + 1, 0.0), expected(std::size_t(cells) + 1, 0.0);
  auto cellOf = [&](const Vec3& w) {
    const double z = std::clamp(double(w.z), -1.0, 1.0);
    double phi = std::atan2(double(w.y), double(w.x));
    if (phi < 0)
      phi += 2 * std::numbers::pi;
    const int i = std::min(cosBins - 1, int((z + 1) / 2 * cosBins));
    const int j = std::min(phiBins - 1, int(phi / (2 * std::numbers::pi) * phiBins));
    return std::size_t(i * phiBins + j);
  };

  // Observed counts, from a sampler seeded once.
  Sampler rng(seed, 0, 0, 0);
  for (int n = 0; n < samples; ++n) {
    const Vec2 u = rng.next2D();
    const Real uc = rng.next1D();
    if (const std::optional<Vec3> w = sample(u, uc))
      observed[cellOf(*w)] += 1;
    else
      observed[std::size_t(cells)] += 1;
  }

  // Expected counts: the pdf integrated over each cell by 8-point Gauss–Legendre on a grid of sub-cells (accurate
  // enough that 1 − ∫pdf, the expected share of declined samples, is not swamped by quadrature error).
  static constexpr double kNodes[8] = {-0.9602898564975363, -0.7966664774136267, -0.5255324099163290,
                                       -0.1834346424956498, 0.1834346424956498,  0.5255324099163290,
                                       0.7966664774136267,  0.9602898564975363};
  static constexpr double kWeights[8] = {0.1012285362903763, 0.2223810344533745, 0.3137066458778873,
                                         0.3626837833783620, 0.3626837833783620, 0.3137066458778873,
                                         0.2223810344533745, 0.1012285362903763};
  const double dz = 2.0 / cosBins, dphi = 2 * std::numbers::pi / phiBins;
  const double hz = dz / subdivisions, hphi = dphi / subdivisions;
  double total = 0;
  for (int i = 0; i < cosBins; ++i)
    for (int j = 0; j < phiBins; ++j) {
      double integral = 0;
      for (int a = 0; a < subdivisions; ++a)
        for (int b = 0; b < subdivisions; ++b)
          for (int ka = 0; ka < 8; ++ka)
            for (int kb = 0; kb < 8; ++kb) {
              const double z = -1 + dz * i + hz * (a + (kNodes[ka] + 1) / 2);
              const double phi = dphi * j + hphi * (b + (kNodes[kb] + 1) / 2);
              const double r = std::sqrt(std::max(0.0, 1 - z * z));
              integral += kWeights[ka] * kWeights[kb] / 4 *
                          pdf(Vec3(Real(r * std::cos(phi)), Real(r * std::sin(phi)), Real(z)));
            }
      integral *= hz * hphi;
      expected[std::size_t(i * phiBins + j)] = integral * samples;
      total += integral;
    }
  expected[std::size_t(cells)] = std::max(0.0, 1 - total) * samples;

  // Pool the cells expected fewer than 5 samples (sorted by expectation), then sum the statistic.
  std::vector<std::size_t> order(expected.size());
  for (std::size_t k = 0; k < order.size(); ++k)
    order[k] = k;
  std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return expected[a] < expected[b]; });
  ChiSquareResult r;
  double pooledO = 0, pooledE = 0;
  int used = 0;
  for (std::size_t k : order) {
    if (expected[k] == 0 && observed[k] > 0)
      r.statistic = INFINITY; // a sample where the pdf says none can fall
    if (expected[k] < 5 || pooledE < 5) { // pool the small cells until the pool expects at least 5
      pooledO += observed[k];
      pooledE += expected[k];
      continue;
    }
    r.statistic += (observed[k] - expected[k]) * (observed[k] - expected[k]) / expected[k];
    ++used;
  }
  if (pooledE > 0) {
    r.statistic += (pooledO - pooledE) * (pooledO - pooledE) / pooledE;
    ++used;
  }
  r.dof = std::max(1, used - 1);
  r.threshold = chiSquareQuantile(r.dof, significance);
  r.passed = r.statistic <= r.threshold;
  return r;
}

} // namespace raylife::test

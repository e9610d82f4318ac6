/// @file heat_map.h
/// @brief Chapter 9's picture of work: the cost of a pixel's queries (boxes and spheres tested) as a colour.
#pragma once

#include "geometry/bvh.h"
#include "render/image_io.h"
#include "core/math.h"

#include <algorithm>
#include <array>
#include <cmath>

namespace raylife {

/// The work a heat map shows: boxes tested plus spheres tested, each weighed by its cost in the SAH (BvhCosts),
/// so the number is the SAH's C = N_boxes·C_trav + N_spheres·C_isect, in units of one box test.
inline Real workCost(const BvhWork& work, const BvhCosts& costs = {})
{
  return Real(work.nodesVisited) * costs.traversal + Real(work.primitivesTested) * costs.intersection;
}

/// Work at which the heat map saturates (white-yellow): above it every pixel looks the same.
inline constexpr Real kHeatMapMaxCost = 4096;

/// The colour of `cost` (≥ 0) on a logarithmic scale from 1 (black) to kHeatMapMaxCost (pale yellow), through
/// the "inferno" colour map (perceptually uniform, readable in grey): each doubling of the work moves the colour
/// by the same step, so a tree's log N and a list's N both fit on one scale. Returns linear RGB in [0, 1], so a
/// PNG shows the colour map's own sRGB values.
inline Color heatColor(Real cost)
{
  // Inferno at 0, ¼, ½, ¾, 1 (matplotlib's values, sRGB).
  static constexpr std::array<std::array<float, 3>, 5> kStops{{{0.001f, 0.000f, 0.014f},
                                                                {0.341f, 0.062f, 0.429f},
                                                                {0.735f, 0.216f, 0.330f},
                                                                {0.978f, 0.557f, 0.035f},
                                                                {0.988f, 0.998f, 0.645f}}};
  const Real x = std::clamp(std::log2(1 + std::max(Real(0), cost)) / std::log2(1 + kHeatMapMaxCost), Real(0),
                            Real(1)) * Real(kStops.size() - 1);
  const std::size_t i = std::min(std::size_t(x), kStops.size() - 2);
  const float f = float(x - Real(i));
  Color c;
  for (int k = 0; k < 3; ++k) {
    const float srgb = kStops[i][std::size_t(k)] * (1 - f) + kStops[i + 1][std::size_t(k)] * f;
    c[k] = Real(srgbToLinear(srgb));
  }
  return c;
}

} // namespace raylife

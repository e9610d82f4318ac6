/// @file heat_map.h
/// @brief Chapter 9's picture of work: the cost of a pixel's queries (boxes and spheres tested) as a colour.
#pragma once

#include "geometry/bvh.h"
#include "render/image_io.h"
#include "core/math.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <string>

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

/// Draws the heat map's colour scale across the bottom of columns [x0, x1) of `image`: a bar from 1 to
/// kHeatMapMaxCost on heatColor's logarithmic scale, with the work values 1, 8, 64, 512 and 4096 written under
/// their places, white on black (digits of 3 × 5 pixels, scaled up once the image is 180 pixels tall). An image
/// too small to hold it (under 48 × 24 pixels for the columns given) is left as it is.
/// @param image The image to draw on (linear RGB).
/// @param x0 The first column of the heat map, ≥ 0.
/// @param x1 One past its last column, ≤ image.width.
inline void drawHeatLegend(Image& image, int x0, int x1)
{
  static constexpr const char* kDigits[10][5] = {
      {"###", "# #", "# #", "# #", "###"}, {" # ", "## ", " # ", " # ", "###"}, {"###", "  #", "###", "#  ", "###"},
      {"###", "  #", "###", "  #", "###"}, {"# #", "# #", "###", "  #", "  #"}, {"###", "#  ", "###", "  #", "###"},
      {"###", "#  ", "###", "# #", "###"}, {"###", "  #", "  #", "  #", "  #"}, {"###", "# #", "###", "# #", "###"},
      {"###", "# #", "###", "  #", "###"}};
  const int s = std::max(1, image.height / 90); // pixels per font pixel
  const int margin = 2 * s, barHeight = 4 * s, strip = margin + barHeight + s + 5 * s + margin;
  if (x1 - x0 < 48 || image.height < 24 + strip)
    return;
  const int y0 = image.height - strip, left = x0 + margin + 8 * s, right = x1 - margin - 8 * s;
  auto put = [&](int x, int y, const Color& c) {
    for (int k = 0; k < 3; ++k)
      image.at(x, y, k) = float(c[k]);
  };
  for (int y = y0; y < image.height; ++y)
    for (int x = x0; x < x1; ++x)
      put(x, y, Color(0));
  const Real logMax = std::log2(1 + kHeatMapMaxCost);
  for (int x = left; x < right; ++x) {
    const Real t = (Real(x - left) + Real(0.5)) / Real(right - left);
    for (int y = y0 + margin; y < y0 + margin + barHeight; ++y)
      put(x, y, heatColor(std::exp2(t * logMax) - 1));
  }
  for (const int value : {1, 8, 64, 512, 4096}) {
    const std::string text = std::to_string(value);
    const int centre = left + int(std::lround(std::log2(1.0 + value) / double(logMax) * (right - left)));
    const int width = int(text.size()) * 4 * s - s;
    const int start = std::clamp(centre - width / 2, x0 + margin, x1 - margin - width);
    for (std::size_t i = 0; i < text.size(); ++i)
      for (int row = 0; row < 5; ++row)
        for (int col = 0; col < 3; ++col)
          if (kDigits[text[i] - '0'][row][col] == '#')
            for (int dy = 0; dy < s; ++dy)
              for (int dx = 0; dx < s; ++dx)
                put(start + int(i) * 4 * s + col * s + dx, y0 + margin + barHeight + s + row * s + dy, Color(1));
  }
}

} // namespace raylife

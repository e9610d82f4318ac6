#include "render/film.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace raylife {

Film::Film(int width, int height)
    : width_(width), height_(height), pixels_(std::size_t(width) * std::size_t(height))
{
}

Image Film::mean() const
{
  Image image(width_, height_);
  for (int y = 0; y < height_; ++y)
    for (int x = 0; x < width_; ++x) {
      const Pixel& p = pixels_[index(x, y)];
      const glm::dvec3 m = p.count ? p.sum / double(p.count) : glm::dvec3(0);
      for (int c = 0; c < 3; ++c)
        image.at(x, y, c) = float(m[c]);
    }
  return image;
}

Image Film::varianceOfMean() const
{
  Image image(width_, height_);
  for (int y = 0; y < height_; ++y)
    for (int x = 0; x < width_; ++x) {
      const Pixel& p = pixels_[index(x, y)];
      if (p.count < 2)
        continue;
      const double n = double(p.count);
      for (int c = 0; c < 3; ++c) {
        const double mean = p.sum[c] / n;
        const double s2 = std::max(0.0, (p.sumSquares[c] - n * mean * mean) / (n - 1)); // rounding can go below 0
        image.at(x, y, c) = float(s2 / n);
      }
    }
  return image;
}

double Film::relativeError(int x, int y, double floor) const
{
  const Pixel& p = pixels_[index(x, y)];
  // A pixel whose every sample was black shows no variance, but that only says nothing reached it yet (a path
  // tracer's pixel in a dim corner may take many samples to find the light): it is not known to be black.
  if (p.count < 2 || p.sum == glm::dvec3(0))
    return std::numeric_limits<double>::infinity();
  const double n = double(p.count);
  double worst = 0;
  for (int c = 0; c < 3; ++c) {
    const double mean = p.sum[c] / n;
    const double s2 = std::max(0.0, (p.sumSquares[c] - n * mean * mean) / (n - 1));
    worst = std::max(worst, std::sqrt(s2 / n) / std::max(mean, floor));
  }
  return worst;
}

} // namespace raylife

#include "render/film.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace raylife {

Film::Film(int width, int height)
    : width_(width), height_(height), sums_(std::size_t(width) * std::size_t(height)),
      counts_(std::size_t(width) * std::size_t(height), 0)
{
}

Film::Film(int width, int height, std::vector<Sums> sums, std::vector<std::uint32_t> counts)
    : width_(width), height_(height), sums_(std::move(sums)), counts_(std::move(counts))
{
  const std::size_t n = std::size_t(width) * std::size_t(height);
  if (width < 1 || height < 1 || sums_.size() != n || counts_.size() != n)
    throw std::invalid_argument("a film of " + std::to_string(width) + "x" + std::to_string(height) +
                                " pixels needs as many sums and counts");
}

void Film::merge(const Film& other)
{
  if (other.width_ != width_ || other.height_ != height_)
    throw std::invalid_argument("cannot merge a film of " + std::to_string(other.width_) + "x" +
                                std::to_string(other.height_) + " into one of " + std::to_string(width_) + "x" +
                                std::to_string(height_));
  for (std::size_t i = 0; i < sums_.size(); ++i) {
    for (int c = 0; c < 3; ++c) {
      sums_[i].sum[c] += other.sums_[i].sum[c];
      sums_[i].squares[c] += other.sums_[i].squares[c];
    }
    counts_[i] += other.counts_[i];
  }
}

Film::Moments Film::moments(std::size_t i) const
{
  Moments m{glm::dvec3(0), glm::dvec3(0)};
  const std::uint32_t count = counts_[i];
  if (count == 0)
    return m;
  const double n = double(count);
  for (int c = 0; c < 3; ++c) {
    m.mean[c] = toDouble(sums_[i].sum[c], kFilmSumFractionBits) / n;
    if (count >= 2) {
      const double squares = toDouble(sums_[i].squares[c], kFilmSquareFractionBits);
      m.variance[c] = std::max(0.0, (squares - n * m.mean[c] * m.mean[c]) / (n - 1)); // rounding can go below 0
    }
  }
  return m;
}

Image Film::mean() const
{
  Image image(width_, height_);
  for (int y = 0; y < height_; ++y)
    for (int x = 0; x < width_; ++x) {
      const glm::dvec3 m = moments(index(x, y)).mean;
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
      const std::size_t i = index(x, y);
      if (counts_[i] < 2)
        continue;
      const glm::dvec3 s2 = moments(i).variance;
      for (int c = 0; c < 3; ++c)
        image.at(x, y, c) = float(s2[c] / double(counts_[i]));
    }
  return image;
}

double Film::relativeError(int x, int y, double floor) const
{
  const std::size_t i = index(x, y);
  // A pixel whose every sample was black shows no variance, but that only says nothing reached it yet (a path
  // tracer's pixel in a dim corner may take many samples to find the light): it is not known to be black.
  const Sums& p = sums_[i];
  const bool black = p.sum[0] == Fixed128{} && p.sum[1] == Fixed128{} && p.sum[2] == Fixed128{};
  if (counts_[i] < 2 || black)
    return std::numeric_limits<double>::infinity();
  const Moments m = moments(i);
  double worst = 0;
  for (int c = 0; c < 3; ++c)
    worst = std::max(worst, std::sqrt(m.variance[c] / double(counts_[i])) / std::max(m.mean[c], floor));
  return worst;
}

Film sideBySide(const Film& left, const Film& right)
{
  if (left.height() != right.height())
    throw std::invalid_argument("films side by side need one height");
  const int width = left.width() + right.width(), height = left.height();
  std::vector<Film::Sums> sums;
  std::vector<std::uint32_t> counts;
  sums.reserve(std::size_t(width) * std::size_t(height));
  counts.reserve(sums.capacity());
  for (int y = 0; y < height; ++y)
    for (const Film* film : {&left, &right}) {
      const std::size_t row = std::size_t(y) * std::size_t(film->width());
      const auto w = std::ptrdiff_t(film->width());
      sums.insert(sums.end(), film->sums().begin() + std::ptrdiff_t(row), film->sums().begin() + std::ptrdiff_t(row) + w);
      counts.insert(counts.end(), film->counts().begin() + std::ptrdiff_t(row),
                    film->counts().begin() + std::ptrdiff_t(row) + w);
    }
  return Film(width, height, std::move(sums), std::move(counts));
}

} // namespace raylife

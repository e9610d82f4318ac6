#include "shading/environment.h"

#include <algorithm>
#include <cmath>

namespace raylife {

// ---- The 1D distribution ---------------------------------------------------------------------------------------

Distribution1D::Distribution1D(std::vector<double> weights) : weights_(std::move(weights))
{
  for (double w : weights_)
    total_ += w;
  if (!(total_ > 0)) { // all zero: uniform
    std::fill(weights_.begin(), weights_.end(), 1.0);
    total_ = double(weights_.size());
  }
  cdf_.resize(weights_.size() + 1);
  cdf_[0] = 0;
  double running = 0;
  for (std::size_t i = 0; i < weights_.size(); ++i) {
    running += weights_[i];
    cdf_[i + 1] = running / total_;
  }
  cdf_.back() = 1;
}

std::pair<Real, int> Distribution1D::sample(Real u) const
{
  // The bin i with cdf[i] ≤ u < cdf[i + 1] (never one of weight 0), then the place within it.
  const auto it = std::upper_bound(cdf_.begin(), cdf_.end(), double(u));
  int i = std::clamp(int(it - cdf_.begin()) - 1, 0, size() - 1);
  while (weights_[std::size_t(i)] == 0 && i + 1 < size()) // u exactly at an empty bin's edge
    ++i;
  const double within = (double(u) - cdf_[std::size_t(i)]) / (cdf_[std::size_t(i) + 1] - cdf_[std::size_t(i)]);
  const Real x = Real((double(i) + std::clamp(within, 0.0, 1.0)) / double(size()));
  return {std::min(x, std::nextafter(Real(1), Real(0))), i};
}

Real Distribution1D::pdf(Real x) const
{
  const int i = std::clamp(int(x * Real(size())), 0, size() - 1);
  return Real(weights_[std::size_t(i)] * double(size()) / total_);
}

// ---- Directions and (u, v) ------------------------------------------------------------------------------------

// [uv]
Vec2 directionToUv(const Vec3& d)
{
  const Real u = Real(0.5) + std::atan2(d.x, -d.z) / (2 * kPi);
  const Real v = std::acos(std::clamp(d.y, Real(-1), Real(1))) / kPi;
  return Vec2(std::clamp(u, Real(0), Real(1)), v);
}

Vec3 uvToDirection(Vec2 uv)
{
  const Real phi = 2 * kPi * (uv.x - Real(0.5)), theta = kPi * uv.y;
  const Real sinTheta = std::sin(theta);
  return Vec3(sinTheta * std::sin(phi), std::cos(theta), -sinTheta * std::cos(phi));
}

// Seen from outside, the sphere's x runs the other way across the screen from the sky's: mirror it.
Vec2 sphereUv(const Vec3& n) { return directionToUv(Vec3(-n.x, n.y, n.z)); }
// [uv]

Vec3 rotateAboutY(const Vec3& d, SinCos<Real> r)
{
  return Vec3(d.x * r.cos + d.z * r.sin, d.y, -d.x * r.sin + d.z * r.cos);
}

// ---- The map ---------------------------------------------------------------------------------------------------

EnvironmentMap::EnvironmentMap(std::shared_ptr<const TexelImage> image, Real scale, Real rotateDegrees)
    : image_(std::move(image)), scale_(scale)
{
  const Real angle = rotateDegrees * kPi / 180;
  rotation_ = SinCos<Real>{std::sin(angle), std::cos(angle)};
  const int w = image_->width, h = image_->height;
  // [distribution]
  // Each texel's weight: luminance × sin θ at its row's centre (the Jacobian of (u, v) → direction).
  std::vector<double> rowSums(std::size_t(h), 0.0);
  double integral = 0;
  Color radianceIntegral(0);
  cols_.reserve(std::size_t(h));
  const double texelArea = 2 * double(kPi) * double(kPi) / (double(w) * double(h)); // (du dv) × 2π²
  for (int j = 0; j < h; ++j) {
    const double sinTheta = std::sin(double(kPi) * (j + 0.5) / h);
    std::vector<double> row(static_cast<std::size_t>(w));
    for (int i = 0; i < w; ++i) {
      const Color L = image_->texel(i, j) * scale_;
      row[std::size_t(i)] = double(luminance(L)) * sinTheta;
      rowSums[std::size_t(j)] += row[std::size_t(i)];
      radianceIntegral += L * Real(sinTheta * texelArea);
    }
    integral += rowSums[std::size_t(j)] * texelArea;
    cols_.emplace_back(std::move(row));
  }
  rows_ = Distribution1D(std::move(rowSums));
  // [distribution]
  luminanceIntegral_ = Real(integral);
  meanRadiance_ = radianceIntegral / (4 * kPi);
}

Vec2 EnvironmentMap::uvOf(const Vec3& d) const
{
  return directionToUv(rotateAboutY(d, SinCos<Real>{-rotation_.sin, rotation_.cos}));
}

Vec3 EnvironmentMap::directionOf(Vec2 uv) const { return rotateAboutY(uvToDirection(uv), rotation_); }

Color EnvironmentMap::radiance(const Vec3& d) const
{
  const Vec2 uv = uvOf(d);
  const int w = image_->width, h = image_->height;
  const int i = std::clamp(int(uv.x * Real(w)), 0, w - 1), j = std::clamp(int(uv.y * Real(h)), 0, h - 1);
  return image_->texel(i, j) * scale_;
}

// [sample]
std::optional<EnvironmentSample> EnvironmentMap::sample(Vec2 u) const
{
  if (!(luminanceIntegral_ > 0))
    return std::nullopt;
  // A row from the marginal, a texel in it from the row's conditional, a point in the texel uniformly.
  const auto [v, row] = rows_.sample(u.y);
  const auto [uu, col] = cols_[std::size_t(row)].sample(u.x);
  const Real pdfUv = rows_.pdf(v) * cols_[std::size_t(row)].pdf(uu);
  const Real sinTheta = std::sin(kPi * v);
  if (!(pdfUv > 0 && sinTheta > 0))
    return std::nullopt;
  const Vec3 wi = directionOf(Vec2(uu, v));
  return EnvironmentSample{wi, image_->texel(col, row) * scale_, pdfUv / (2 * kPi * kPi * sinTheta)};
}

Real EnvironmentMap::pdf(const Vec3& d) const
{
  if (!(luminanceIntegral_ > 0))
    return 0;
  const Vec2 uv = uvOf(d);
  const Real sinTheta = std::sin(kPi * uv.y);
  if (!(sinTheta > 0))
    return 0;
  const int row = std::clamp(int(uv.y * Real(image_->height)), 0, image_->height - 1);
  return rows_.pdf(uv.y) * cols_[std::size_t(row)].pdf(uv.x) / (2 * kPi * kPi * sinTheta);
}
// [sample]

} // namespace raylife

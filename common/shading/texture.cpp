#include "shading/texture.h"

#include <algorithm>
#include <cmath>

namespace raylife {

Color TexelImage::mean() const
{
  double sum[3] = {0, 0, 0};
  for (std::size_t k = 0; k < rgb.size(); k += 3)
    for (std::size_t c = 0; c < 3; ++c)
      sum[c] += double(rgb[k + c]);
  const double n = double(std::max<std::size_t>(1, rgb.size() / 3));
  return Color(Real(sum[0] / n), Real(sum[1] / n), Real(sum[2] / n));
}

const std::array<float, 256>& srgbDecodeTable()
{
  static const std::array<float, 256> table = [] {
    std::array<float, 256> t{};
    for (int i = 0; i < 256; ++i) {
      const double e = i / 255.0;
      t[std::size_t(i)] = float(e <= 0.04045 ? e / 12.92 : std::pow((e + 0.055) / 1.055, 2.4));
    }
    return t;
  }();
  return table;
}

namespace {

// The next level down: half the size (rounded down, at least 1), each texel the mean of the 2×2 (or, along an odd
// or unit side, fewer) texels above it.
TexelImage halve(const TexelImage& a)
{
  TexelImage b;
  b.width = std::max(1, a.width / 2);
  b.height = std::max(1, a.height / 2);
  b.rgb.assign(std::size_t(b.width) * std::size_t(b.height) * 3, 0.0f);
  const int fx = a.width / b.width, fy = a.height / b.height; // 1 or 2 (an odd side drops its last texel)
  for (int y = 0; y < b.height; ++y)
    for (int x = 0; x < b.width; ++x) {
      Color sum(0);
      for (int dy = 0; dy < fy; ++dy)
        for (int dx = 0; dx < fx; ++dx)
          sum += a.texel(x * fx + dx, y * fy + dy);
      sum /= Real(fx * fy);
      const std::size_t k = (std::size_t(y) * std::size_t(b.width) + std::size_t(x)) * 3;
      for (int c = 0; c < 3; ++c)
        b.rgb[k + std::size_t(c)] = float(sum[c]);
    }
  return b;
}

// i modulo n, in [0, n).
int wrap(int i, int n)
{
  const int r = i % n;
  return r < 0 ? r + n : r;
}

} // namespace

Texture::Texture(std::shared_ptr<const TexelImage> image, TextureFilter filter, bool mipmaps) : filter_(filter)
{
  mean_ = image->mean();
  levels_.push_back(std::move(image));
  while (mipmaps && (levels_.back()->width > 1 || levels_.back()->height > 1))
    levels_.push_back(std::make_shared<const TexelImage>(halve(*levels_.back())));
}

Texture::Texture(const Checker& checker) : checker_(checker), mean_((checker.even + checker.odd) / Real(2)) {}

glm::ivec2 Texture::size() const
{
  return levels_.empty() ? glm::ivec2(0) : glm::ivec2(levels_[0]->width, levels_[0]->height);
}

std::size_t Texture::bytes() const
{
  std::size_t n = 0;
  for (const auto& level : levels_)
    n += level->bytes();
  return n;
}

// [lookup]
Color Texture::lookupLevel(std::size_t level, Vec2 st, bool clampT) const
{
  const TexelImage& image = *levels_[level];
  const int w = image.width, h = image.height;
  // The row index: repeated, or clamped to the image (a sphere's poles).
  auto row = [&](int y) { return clampT ? std::clamp(y, 0, h - 1) : wrap(y, h); };
  const Real x = st.x * Real(w), y = st.y * Real(h); // in texels; texel (i, j) spans [i, i + 1) × [j, j + 1)
  if (filter_ == TextureFilter::Nearest)
    return image.texel(wrap(int(std::floor(x)), w), row(int(std::floor(y))));
  // Bilinear: the four texels whose centres (i + ½, j + ½) surround (x, y), weighted by the distances to them.
  const Real fx = x - Real(0.5), fy = y - Real(0.5);
  const Real x0 = std::floor(fx), y0 = std::floor(fy);
  const Real ax = fx - x0, ay = fy - y0;
  const int i0 = int(x0), j0 = int(y0);
  const int ia = wrap(i0, w), ib = wrap(i0 + 1, w), ja = row(j0), jb = row(j0 + 1);
  return (1 - ay) * ((1 - ax) * image.texel(ia, ja) + ax * image.texel(ib, ja)) +
         ay * ((1 - ax) * image.texel(ia, jb) + ax * image.texel(ib, jb));
}

Color Texture::eval(const TextureLookup& at) const
{
  if (levels_.empty()) { // the checkerboard
    const auto s = long(std::floor(at.st.x * checker_.scale)), t = long(std::floor(at.st.y * checker_.scale));
    return ((s + t) & 1) == 0 ? checker_.even : checker_.odd;
  }
  if (!(at.footprint > 0) || levels_.size() == 1)
    return lookupLevel(0, at.st, at.clampT);
  // Mip-mapping: the level whose texels are as wide as the footprint, λ = log2(footprint · size), between two levels
  // linearly (trilinear filtering).
  const Real texels = at.footprint * Real(std::max(levels_[0]->width, levels_[0]->height));
  const Real lambda = std::clamp(std::log2(std::max(texels, Real(1))), Real(0), Real(levels_.size() - 1));
  const auto lo = std::size_t(lambda);
  const Real frac = lambda - Real(lo);
  const Color a = lookupLevel(lo, at.st, at.clampT);
  if (frac == 0 || lo + 1 >= levels_.size())
    return a;
  return (1 - frac) * a + frac * lookupLevel(lo + 1, at.st, at.clampT);
}
// [lookup]

} // namespace raylife

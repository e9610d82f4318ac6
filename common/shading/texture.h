/// @file texture.h
/// @brief Textures (chapter 14): a surface's colour looked up at its (u, v) in an image, filtered (nearest texel,
/// bilinear, or trilinear between mip-map levels chosen by a ray cone's footprint), or computed by a procedure (a
/// checkerboard).
///
/// Coordinates. A lookup takes (s, t) in image space: s = 0 is the image's left edge and s = 1 its right edge, t = 0
/// its top row and t = 1 its bottom row (row 0 of the file). A texel (x, y) covers [x/w, (x + 1)/w) × [y/h, (y + 1)/h)
/// and has its centre at ((x + ½)/w, (y + ½)/h). The surfaces turn their (u, v) into (s, t) (scene.h,
/// Scene::textureCoordinates): a sphere's and the environment's v runs from the top, so t = v; a triangle's from
/// the bottom (OBJ's convention), so t = 1 − v. The image repeats in s (the sphere's seam at s = 0 and 1 joins) and,
/// unless the lookup clamps it (a sphere's poles), in t.
#pragma once

#include "core/math.h"

#include <array>
#include <cstddef>
#include <memory>
#include <vector>

namespace raylife {

/// An image of linear RGB texels as floats (8-bit sRGB files are decoded once, when they are read).
struct TexelImage {
  int width = 0;            ///< Texels, ≥ 1 once read.
  int height = 0;           ///< Texels, ≥ 1 once read.
  std::vector<float> rgb;   ///< width·height·3 floats, row 0 first (the top), RGB interleaved; finite, ≥ 0.

  /// Texel (x, y), x in [0, width), y in [0, height).
  Color texel(int x, int y) const
  {
    const std::size_t k = (std::size_t(y) * std::size_t(width) + std::size_t(x)) * 3;
    return Color(Real(rgb[k]), Real(rgb[k + 1]), Real(rgb[k + 2]));
  }
  /// The mean of all texels (each texel weighs the same).
  Color mean() const;
  /// Bytes its texels take.
  std::size_t bytes() const { return rgb.size() * sizeof(float); }
};

/// The decoded value of each 8-bit sRGB code, 0 to 255 (IEC 61966-2-1): the table an 8-bit image is decoded by.
const std::array<float, 256>& srgbDecodeTable();

/// How an image texture is filtered.
enum class TextureFilter {
  Nearest,  ///< The texel that contains (s, t).
  Bilinear, ///< The four texels around (s, t), weighted by distance to their centres.
};

/// Where a texture is looked up: image coordinates and, for mip-mapping, the footprint there.
struct TextureLookup {
  Vec2 st{0};         ///< (s, t): s = 0 the left edge, t = 0 the top row (see the file comment); any real values.
  /// The width of the ray cone's footprint in (s, t) units (fractions of the image), ≥ 0; 0 when no cone is traced
  /// (then the finest level is used).
  Real footprint = 0;
  bool clampT = false; ///< True: t is clamped to [0, 1] (a sphere's poles); false: the image repeats in t.
};

/// The checkerboard: squares of side 1/scale in (s, t), `even` where ⌊s·scale⌋ + ⌊t·scale⌋ is even, else `odd`.
struct Checker {
  Real scale = 8;     ///< Squares per unit of s and of t, > 0.
  Color even{1};      ///< Colour of the even squares (the one at (0, 0)).
  Color odd{0};       ///< Colour of the odd squares.
};

/// A texture: an image (with its filter and mip-maps) or a checkerboard. Immutable once made; shared by the
/// materials that name the same image file.
class Texture {
public:
  /// An image texture. `mipmaps`: build the levels (each half the size of the one above, box-filtered, down to 1×1),
  /// used by lookups with a footprint > 0 (trilinear: two levels, each filtered as `filter` says).
  Texture(std::shared_ptr<const TexelImage> image, TextureFilter filter, bool mipmaps = true);
  /// A checkerboard texture.
  explicit Texture(const Checker& checker);

  /// The colour at `at` (linear RGB, ≥ 0).
  Color eval(const TextureLookup& at) const;
  /// The texture's mean colour: the image's mean, or the two squares' average. What a chapter before 14 shades with.
  Color mean() const { return mean_; }
  /// True for an image texture (false: a checkerboard).
  bool isImage() const { return !levels_.empty(); }
  /// The finest level's size in texels (0 × 0 for a checkerboard).
  glm::ivec2 size() const;
  /// Bytes the texels take, every mip-map level included (0 for a checkerboard).
  std::size_t bytes() const;
  /// Mip-map levels (1: the image alone; 0 for a checkerboard).
  std::size_t levelCount() const { return levels_.size(); }
  /// The filter of an image texture.
  TextureFilter filter() const { return filter_; }

private:
  Color lookupLevel(std::size_t level, Vec2 st, bool clampT) const;
  std::vector<std::shared_ptr<const TexelImage>> levels_; // level 0 the image, then halves
  TextureFilter filter_ = TextureFilter::Bilinear;
  Checker checker_;
  Color mean_{0};
};

/// A material's colour (or emission): a constant, or a texture whose mean stands in for it where no (u, v) is known.
using TexturePtr = std::shared_ptr<const Texture>;

} // namespace raylife

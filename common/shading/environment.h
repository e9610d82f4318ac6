/// @file environment.h
/// @brief The environment map (chapter 14): an equirectangular (latitude–longitude) image of the radiance arriving
/// from every direction, looked up where a ray leaves the scene, and sampled in proportion to its luminance as a
/// light.
///
/// Convention (docs/scene-format.md, the contract): a unit direction d has
///   u = ½ + atan2(d.x, −d.z)/(2π),   v = acos(d.y)/π,
/// so v = 0 is straight up (+y, the image's top row), the image's centre column looks along −z, and u grows towards
/// +x from there. The map is turned `rotate` degrees about +y: what the unrotated map shows along d, the rotated one
/// shows along R(rotate)·d.
///
/// Sampling. Each texel (i, j) weighs f = luminance × sin θj (θj at its row's centre): the sin θ is the Jacobian
/// of the map from (u, v) ∈ [0, 1)² to directions, dω = 2π² sin θ du dv, so that directions are drawn in proportion
/// to luminance per solid angle. The weights form a piecewise-constant 2D distribution over (u, v): a row is chosen
/// from the marginal (the rows' sums), then a texel in it from the row's conditional, then a point uniformly within
/// the texel. The direction's pdf in solid angle is p(u, v) / (2π² sin θ). Lookups take the nearest texel, so the
/// radiance is constant where the pdf is, and L/pdf is the same for every direction of a texel.
#pragma once

#include "core/math.h"
#include "shading/texture.h"

#include <memory>
#include <optional>
#include <vector>

namespace raylife {

/// A piecewise-constant 1D distribution over [0, 1) in n equal bins, with its pdf beside it.
class Distribution1D {
public:
  Distribution1D() = default;
  /// From the bins' weights (each ≥ 0, finite). A distribution whose weights sum to 0 is uniform.
  explicit Distribution1D(std::vector<double> weights);
  /// x in [0, 1) drawn from the distribution by `u` ∈ [0, 1), and its bin.
  std::pair<Real, int> sample(Real u) const;
  /// The density at x in [0, 1) (bin weight × n / total).
  Real pdf(Real x) const;
  /// The sum of the weights.
  double total() const { return total_; }
  /// Number of bins.
  int size() const { return int(weights_.size()); }
  /// The probability of bin i (weight / total).
  Real binProbability(int i) const { return Real(weights_[std::size_t(i)] / total_); }

private:
  std::vector<double> weights_;
  std::vector<double> cdf_; // cdf_[i] = sum of the first i weights / total; cdf_[n] = 1
  double total_ = 0;
};

/// A direction drawn from an environment map.
struct EnvironmentSample {
  Vec3 wi{0, 0, 1}; ///< Unit direction towards the environment, world space.
  Color Le{0};      ///< The radiance along it (scale and all).
  Real pdf = 0;     ///< Its density in solid angle, > 0.
};

/// An environment map. Immutable once made; shared by the threads.
class EnvironmentMap {
public:
  /// From a linear-radiance image in the convention of the file comment, multiplied by `scale` (≥ 0) and turned
  /// `rotateDegrees` about +y. Builds the sampling distribution (one pass over the texels).
  EnvironmentMap(std::shared_ptr<const TexelImage> image, Real scale, Real rotateDegrees);

  /// Radiance arriving along −d, i.e. seen looking along unit direction `d` (nearest texel).
  Color radiance(const Vec3& d) const;
  /// A direction drawn with density ∝ luminance (see the file comment), by `u` ∈ [0, 1)²; nothing when the map is
  /// black (every texel's luminance 0).
  std::optional<EnvironmentSample> sample(Vec2 u) const;
  /// The solid-angle density with which sample() draws unit direction `d`.
  Real pdf(const Vec3& d) const;
  /// ∫ luminance(L(ω)) dω over the sphere, in luminance × sr (its power onto a disc of area A facing every way:
  /// A times this).
  Real luminanceIntegral() const { return luminanceIntegral_; }
  /// The image (linear radiance before `scale`).
  const TexelImage& image() const { return *image_; }
  /// The mean radiance over the sphere (∫L dω / 4π), scale included.
  Color meanRadiance() const { return meanRadiance_; }
  /// The map's scale factor.
  Real scale() const { return scale_; }
  /// The map's turn about +y: the sine and cosine of its `rotate` angle (uvOf turns a direction back by it).
  SinCos<Real> rotation() const { return rotation_; }

  /// (u, v) of unit world direction `d`, rotation applied (the contract's u and v, each in [0, 1]).
  Vec2 uvOf(const Vec3& d) const;
  /// The unit world direction of (u, v), rotation applied (the inverse of uvOf).
  Vec3 directionOf(Vec2 uv) const;

private:
  std::shared_ptr<const TexelImage> image_;
  Real scale_ = 1;
  SinCos<Real> rotation_{0, 1};
  Distribution1D rows_;              // the marginal over v
  std::vector<Distribution1D> cols_; // each row's conditional over u
  Real luminanceIntegral_ = 0;
  Color meanRadiance_{0};
};

/// (u, v) of unit direction `d` in the environment's convention (no rotation): u = ½ + atan2(d.x, −d.z)/(2π),
/// v = acos(d.y)/π, each in [0, 1]. The sky is seen from inside: looking along −z with +y up, +x is on the right,
/// so u grows to the right and the image reads the right way round. Not for spheres: see sphereUv.
Vec2 directionToUv(const Vec3& d);
/// (u, v) of a sphere's unit outward normal `n` (no rotation): u = ½ + atan2(−n.x, −n.z)/(2π), v = acos(n.y)/π,
/// each in [0, 1]; directionToUv of n mirrored in x. The centre column still faces −z and row 0 is still the top
/// (+y), but a sphere is seen from *outside*: looking at it along +z with +y up, −x is on the right. directionToUv
/// would run u to the left there and show every sphere texture mirrored (a globe's continents reversed east–west);
/// with the sign of x flipped u grows to the viewer's right, as pbrt's and Mitsuba's spheres do, so a sphere reads
/// its image un-mirrored from outside just as the sky does from inside.
Vec2 sphereUv(const Vec3& n);
/// The unit direction of (u, v), the inverse of directionToUv.
Vec3 uvToDirection(Vec2 uv);
/// `d` turned by `rotation` (sine and cosine of the angle) about +y, right-handed: +z goes towards +x.
Vec3 rotateAboutY(const Vec3& d, SinCos<Real> rotation);

} // namespace raylife

/// @file density_grid.h
/// @brief A heterogeneous medium's density (chapter 15): a grid of values interpolated trilinearly, the coarse grid
/// of their maxima (majorants) walked by a 3D-DDA, and delta and ratio tracking against it.
///
/// The density scales the medium's σa and σs at each point: σ(x) = d(x)·σ. Values sit at the centres of the
/// nx × ny × nz cells that divide the box [lo, hi]; between centres d is trilinear, beyond the outermost centres (but
/// inside the box) it is the nearest centres' interpolation, and outside the box it is 0.
#pragma once

#include "core/math.h"
#include "core/rng.h"
#include "geometry/ray.h"

#include <cstddef>
#include <vector>

namespace raylife {

/// A density grid and its majorants. Immutable once built; shared by every thread.
struct DensityGrid {
  int nx = 1; ///< Cells along x, ≥ 1.
  int ny = 1; ///< Cells along y, ≥ 1.
  int nz = 1; ///< Cells along z, ≥ 1.
  Vec3 lo{0};                 ///< The box's low corner, world space.
  Vec3 hi{1};                 ///< Its high corner (each coordinate > lo's).
  std::vector<float> values;  ///< nx·ny·nz densities ≥ 0, x fastest, then y, then z.

  int mx = 1; ///< Majorant cells (the coarse grid of maxima) along x, ≥ 1; set by buildMajorants.
  int my = 1; ///< Majorant cells along y, ≥ 1; set by buildMajorants.
  int mz = 1; ///< Majorant cells along z, ≥ 1; set by buildMajorants.
  /// The largest density that trilinear interpolation can give inside each majorant cell (x fastest); ≥ 0.
  std::vector<Real> majorants;
  Real globalMajorant = 0; ///< The largest value of all.

  /// The density at `p`, world space: trilinear inside the box, 0 outside; ≥ 0.
  Real density(const Vec3& p) const;

  /// Fills `majorants` with a grid of `cells` cells along the longest axis (fewer along the others, at least 1),
  /// each the maximum of the values that interpolation may reach inside it, and `globalMajorant`.
  void buildMajorants(int cells);

  /// The box's diagonal, in scene units (> 0 for a box with lo < hi), the longest chord a ray can have in it. Its
  /// sides are scaled by the longest before they are squared, so a box 1e-300 across does not come out 0.
  double diagonal() const;
};

/// One stretch of a ray over which the majorant density is constant.
struct MajorantSegment {
  Real t0 = 0;      ///< Where it starts along the ray.
  Real t1 = 0;      ///< Where it ends, > t0.
  Real density = 0; ///< Its majorant density, ≥ every density on it.
};

/// Walks the segments of the ray's stretch [0, tMax) that lie in the grid's box, in order along the ray, one at a
/// time: one per majorant cell crossed (a 3D-DDA, Amanatides and Woo), or one for the whole box with the global
/// majorant when `global`. Lazy, so a tracking loop that stops at a collision walks no further, and allocates
/// nothing. Cells whose majorant is 0 come back too (they cost a tracking loop one comparison).
/// Contract: the ray's direction is unit; tMax may be infinite; the grid outlives the walker.
class MajorantWalker {
public:
  /// Clips the ray to the box and finds the cell it enters.
  MajorantWalker(const DensityGrid& grid, bool global, const Ray& ray, Real tMax);
  /// The next segment, with t1 > t0; false (and `s` untouched) when the ray has left the box or reached tMax.
  bool next(MajorantSegment& s);

private:
  const Real* majorants_ = nullptr; // the grid's majorants; null: the global one
  Real global_ = 0;                 // the global majorant
  Real t_ = 0, tExit_ = 0;          // where the next segment starts; where the ray leaves the box (or tMax)
  std::ptrdiff_t cell_ = 0;         // the current majorant cell's index
  int index_[3] = {0, 0, 0};        // its coordinates
  int cells_[3] = {1, 1, 1};        // majorant cells along each axis
  int step_[3] = {0, 0, 0};         // ±1 (or 0: parallel to the axis)
  std::ptrdiff_t stride_[3] = {0, 0, 0}; // how far `cell_` moves for one step along each axis
  Real tNext_[3] = {0, 0, 0};       // where the ray crosses the cell's next wall along each axis
  Real tDelta_[3] = {0, 0, 0};      // the distance between two walls along each axis
};

/// Every segment MajorantWalker gives, in a vector (for tests and for looking at).
std::vector<MajorantSegment> majorantSegments(const DensityGrid& grid, bool global, const Ray& ray, Real tMax);

/// Delta tracking's answer: as FreeFlight (medium.h).
struct TrackedFlight {
  bool scattered = false; ///< True: a real collision that scatters, at `t`.
  Real t = 0;             ///< Its distance, else tMax.
  Color weight{1};        ///< The throughput factor, finite and ≥ 0.
};

// [deltaTracking]
/// Delta (Woodcock) tracking along `ray` up to tMax in a medium of coefficients d(x)·σa, d(x)·σs: tentative
/// collisions at rate σ̄ = max channel of σt × the segment's majorant density; at each, a real collision with
/// probability P = mean(σt(x))/σ̄, weighted σs(x)/mean(σt(x)) (absorption is in the weight), else a null
/// collision weighted (σ̄ − σt(x))/(σ̄ − mean(σt(x))) per channel. Unbiased for every channel of a coloured medium
/// (with a grey one the weights are the albedo and 1: classic delta tracking). Each tentative collision moves t on by
/// at least one representable number, so a segment takes at most about σ̄ × its length steps, or its length in
/// ulps of t if fewer. Contract: 3·σ̄ is finite (the scene loader also bounds σ̄ × the box's diagonal by 1e9).
TrackedFlight deltaTrack(const DensityGrid& grid, bool globalMajorant, const Color& sigmaA, const Color& sigmaS,
                         const Ray& ray, Real tMax, Sampler& sampler);

/// Ratio tracking: an unbiased estimate of the transmittance exp(−∫ d(x)σt dt) over [0, tMax) of the ray, the
/// product over tentative collisions (rate σ̄, as deltaTrack) of 1 − σt(x)/σ̄ per channel; in [0, 1].
Color ratioTrack(const DensityGrid& grid, bool globalMajorant, const Color& sigmaT, const Ray& ray, Real tMax,
                 Sampler& sampler);
// [deltaTracking]

} // namespace raylife

/// @file light_buffer.h
/// @brief Haines and Greenberg's light buffer: the spheres a point light may see, by the direction they lie in.
#pragma once

#include "core/math.h"
#include "geometry/ray.h"
#include "geometry/sphere.h"

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

namespace raylife {

/// The still spheres around one point light, sorted into the cells of a cube around it (Haines and Greenberg's
/// light buffer, 1986). A shadow ray towards the light runs along one line through it, so only the spheres whose
/// directions from the light come near that line's can block it: those of the cell the line's direction falls in.
///
/// Contract: occluded(ray) is exactly the loop `for each sphere: intersectSphere(o, d, c, r, tmin, tmax)` (true when
/// one hits) for any ray that answers() accepts. A cell holds every sphere that comes within its reach of the
/// cell's pyramid of directions, the reach being the radius plus 10⁻⁴ of the sphere's distance from the light plus
/// its radius, plus 10⁻⁴ of the buffer's range: far beyond the rounding of a shadow ray's direction, of the cell it
/// is sorted into and of intersectSphere, in float as in double, from anywhere within the range.
class LightBuffer {
public:
  /// An empty buffer: it answers no ray.
  LightBuffer() = default;
  /// The buffer of the light at `light` over `spheres` (still: their centres as given), with `cells` × `cells` cells
  /// on each face of the cube (≥ 1), for rays that start within `range` of the light (scene units, > 0). With no
  /// cells or no range it is empty.
  LightBuffer(const Vec3& light, std::span<const Sphere> spheres, int cells, Real range);

  /// Whether occluded() may answer a shadow ray from `origin` to the light: when it starts within the range.
  bool answers(const Vec3& origin) const
  {
    const Vec3 v = origin - light_;
    return cells_ > 0 && glm::dot(v, v) <= range_ * range_;
  }
  /// Whether some sphere blocks `ray`, a shadow ray towards the light that answers() accepts: its origin, its
  /// unit direction towards the light, and tmax at most its distance from the light (tmin ≥ 0).
  bool occluded(const Ray& ray) const;

  /// How many spheres a shadow ray from `origin` may test: those of its cell and those tested everywhere (for
  /// tests and measurements).
  std::size_t candidates(const Vec3& origin) const { return cellOf(origin).size() + everywhere_.size(); }

  /// Where a cell's spheres lie in listed(): entries [first, first + size).
  struct CellRange {
    LaneIndex first = 0; ///< The cell's first entry.
    LaneIndex size = 0;  ///< Its entries, ≥ 0.
  };
  /// The spheres of the cell the direction from the light to `origin` lies in, nearest the light first: a shadow
  /// ray from `origin` that answers() accepts is blocked exactly when one of them or of everywhere() is hit.
  CellRange cellRange(const Vec3& origin) const
  {
    const std::span<const LaneIndex> c = cellOf(origin);
    return c.empty() ? CellRange{} : CellRange{LaneIndex(c.data() - entries_.data()), LaneIndex(c.size())};
  }
  /// Every cell's sphere numbers (indices into the spheres the buffer was built over), back to back.
  std::span<const LaneIndex> listed() const { return entries_; }
  /// The numbers of the spheres every ray tests, nearest the light first: those that would fill more than a quarter
  /// of a face (the ground below the light, one that holds it), and the largest of the others where the cells would
  /// hold more than kEntriesPerCell each.
  std::span<const LaneIndex> everywhere() const { return everywhere_; }
  /// The buffer's memory, in bytes.
  std::size_t memoryBytes() const;

  /// The most sphere numbers the cells hold, on average a cell: 8 (with 128 cells a side, 6 MB at most in double).
  static constexpr std::size_t kEntriesPerCell = 8;

private:
  // The part of a face that holds spheres: columns [i0, i0 + w) by rows [j0, j0 + h), whose cells' lists start at
  // first_[base + (j − j0)·w + (i − i0)].
  struct FaceCells {
    int i0 = 0, j0 = 0, w = 0, h = 0;
    std::size_t base = 0;
  };
  Vec3 light_{0};
  Real range_ = 0;  // rays start within this distance of the light
  Real margin_ = 0; // kCullMargin of the range: what the rounding of a ray's line can add to a sphere's reach
  int cells_ = 0;
  std::vector<Vec3> center_; // the spheres, by number
  std::vector<Real> radius_;
  std::vector<Real> nearest_; // how near to the light each sphere, with its reach, comes
  std::vector<LaneIndex> everywhere_; // the spheres every ray tests, nearest first
  FaceCells face_[6];
  std::vector<std::uint32_t> first_; // the faces' cells' lists: entries_[first_[c], first_[c + 1])
  std::vector<LaneIndex> entries_;

  // The spheres of the cell the direction from the light to `origin` lies in (none outside its face's part).
  std::span<const LaneIndex> cellOf(const Vec3& origin) const;
};

} // namespace raylife

#include "geometry/light_buffer.h"

#include <algorithm>
#include <array>
#include <utility>
#include <numeric>

namespace raylife {

namespace {

// The cube's faces: face 2m + 1 looks down axis m's negative half, face 2m its positive one. On a face, a and b are
// the coordinates along the next two axes, u = (m + 1) mod 3 and v = (m + 2) mod 3, over the distance along m:
// both in [−1, 1], cut into `cells` columns (a) and rows (b).
struct Face {
  int m, u, v;
  Real s; // +1 or −1: the half of axis m the face looks down
};
Face faceNumber(int f) { return Face{f / 2, (f / 2 + 1) % 3, (f / 2 + 2) % 3, f % 2 ? Real(-1) : Real(1)}; }

} // namespace

// [build]
LightBuffer::LightBuffer(const Vec3& light, std::span<const Sphere> spheres, int cells, Real range)
    : light_(light), range_(range), margin_(kCullMargin * range), cells_(cells)
{
  if (cells < 1 || !(range > 0)) {
    cells_ = 0;
    return;
  }
  const std::size_t n = spheres.size();
  center_.resize(n), radius_.resize(n), nearest_.resize(n);
  std::vector<Real> reach(n);
  for (std::size_t k = 0; k < n; ++k) {
    center_[k] = spheres[k].center, radius_[k] = spheres[k].radius;
    const Real distance = glm::length(center_[k] - light_);
    // How far from the sphere a ray's line may pass and still hit it once rounded: its radius, the rounding of
    // intersectSphere and of the line's direction near the sphere, and that of a line from anywhere in range.
    reach[k] = radius_[k] + kCullMargin * (distance + radius_[k]) + margin_;
    nearest_[k] = distance - reach[k];
  }
  // The spheres nearest the light first, so that occluded() can stop at the first one beyond a ray's origin.
  std::vector<std::uint32_t> order(n);
  std::iota(order.begin(), order.end(), 0u);
  std::stable_sort(order.begin(), order.end(),
                   [&](std::uint32_t a, std::uint32_t b) { return nearest_[a] < nearest_[b]; });

  // A cell's directions fill a pyramid from the light: column i holds the directions with a in [a_i, a_(i+1)],
  // a_i = 2i/cells − 1, between the planes through the light with inward normals e_u − a_i·s·e_m and
  // a_(i+1)·s·e_m − e_u (and rows likewise in b). A sphere may meet the pyramid unless it lies wholly outside one of
  // those planes by its reach. Two of the tests are on the column, two on the row, so the cells a sphere may meet on
  // a face are every admitted column by every admitted row: sphere k takes the rectangle met[k][f] on face f, from
  // the first admitted column and row to the last.
  struct Range {
    int first = 0, last = -1;
    int size() const { return last - first + 1; }
  };
  std::vector<Real> boundary(std::size_t(cells) + 1), length(std::size_t(cells) + 1); // a_i, and |normal| there
  for (std::size_t i = 0; i <= std::size_t(cells); ++i)
    boundary[i] = Real(2 * i) / Real(cells) - 1, length[i] = std::sqrt(1 + boundary[i] * boundary[i]);
  auto admitted = [&](const Vec3& q, Real r, const Face& f, int along) {
    Range out{cells, -1};
    for (std::size_t i = 0; i < std::size_t(cells); ++i)
      if (q[along] - boundary[i] * f.s * q[f.m] >= -r * length[i] &&
          boundary[i + 1] * f.s * q[f.m] - q[along] >= -r * length[i + 1])
        out.first = std::min(out.first, int(i)), out.last = int(i);
    return out;
  };
  std::vector<std::array<std::pair<Range, Range>, 6>> met(n);
  std::vector<std::size_t> fills(n, 0);
  for (std::size_t k = 0; k < n; ++k) {
    const Vec3 q = center_[k] - light_;
    std::size_t filled = 0;
    for (int f = 0; f < 6; ++f) {
      const Face face = faceNumber(f);
      if (face.s * q[face.m] < -reach[k]) // wholly behind the light, seen from this face
        continue;
      const Range columns = admitted(q, reach[k], face, face.u), rows = admitted(q, reach[k], face, face.v);
      if (columns.size() > 0 && rows.size() > 0)
        met[k][std::size_t(f)] = {columns, rows}, filled += std::size_t(columns.size()) * std::size_t(rows.size());
    }
    fills[k] = filled;
  }
  // A sphere that fills more than a quarter of a face (the ground under the light, a wall, one that holds the light)
  // is tested by every ray rather than written into each of its cells; so are the largest of the others once the
  // cells would hold more than kEntriesPerCell each on average (a crowd of spheres around the light).
  const std::size_t perFace = std::size_t(cells) * std::size_t(cells);
  std::vector<char> wide(n, 1);
  std::vector<std::uint32_t> bySize(n);
  std::iota(bySize.begin(), bySize.end(), 0u);
  std::stable_sort(bySize.begin(), bySize.end(), [&](std::uint32_t a, std::uint32_t b) { return fills[a] < fills[b]; });
  std::size_t written = 0;
  for (const std::uint32_t k : bySize) {
    if (fills[k] * 4 > perFace || written + fills[k] > kEntriesPerCell * 6 * perFace)
      break;
    wide[k] = 0, written += fills[k];
  }
  // Each face keeps the rectangle of cells its spheres meet (the wide ones aside); nothing outside it.
  std::size_t total = 0;
  for (int f = 0; f < 6; ++f) {
    Range columns{cells, -1}, rows{cells, -1};
    for (std::size_t k = 0; k < n; ++k) {
      const auto& [c, r] = met[k][std::size_t(f)];
      if (wide[k] || c.size() <= 0)
        continue;
      columns = {std::min(columns.first, c.first), std::max(columns.last, c.last)};
      rows = {std::min(rows.first, r.first), std::max(rows.last, r.last)};
    }
    FaceCells& face = face_[f];
    face = columns.size() > 0 ? FaceCells{columns.first, rows.first, columns.size(), rows.size(), total} : FaceCells{};
    face.base = total;
    total += std::size_t(face.w) * std::size_t(face.h);
  }
  // Counted, then written: the lists of every cell, back to back, each nearest first.
  std::vector<std::uint32_t> count(total + 1, 0);
  auto each = [&](auto&& visit) {
    for (const std::uint32_t k : order) {
      if (wide[k])
        continue;
      for (int f = 0; f < 6; ++f) {
        const auto& [c, r] = met[k][std::size_t(f)];
        const FaceCells& face = face_[f];
        for (int j = r.first; j <= r.last; ++j)
          for (int i = c.first; i <= c.last; ++i)
            visit(face.base + std::size_t(j - face.j0) * std::size_t(face.w) + std::size_t(i - face.i0), k);
      }
    }
  };
  each([&](std::size_t cell, std::uint32_t) { ++count[cell + 1]; });
  std::partial_sum(count.begin(), count.end(), count.begin());
  first_ = count;
  entries_.resize(first_.back());
  each([&](std::size_t cell, std::uint32_t k) { entries_[count[cell]++] = LaneIndex(k); });
  for (const std::uint32_t k : order)
    if (wide[k])
      everywhere_.push_back(LaneIndex(k));
}
// [build]

std::span<const LaneIndex> LightBuffer::cellOf(const Vec3& origin) const
{
  const Vec3 v = origin - light_;
  const Vec3 a = glm::abs(v);
  const int m = a.x >= a.y && a.x >= a.z ? 0 : a.y >= a.z ? 1 : 2;
  if (!(a[m] > 0)) // the light itself (no direction), or NaN
    return {};
  const int f = 2 * m + (v[m] < 0 ? 1 : 0);
  const Face axes = faceNumber(f);
  const FaceCells& face = face_[f];
  // a = v_u / |v_m| in [−1, 1] to a column, (a + 1)·cells/2, and b to a row likewise.
  const Real scale = Real(cells_) / (2 * a[m]);
  auto index = [&](Real x) { return std::clamp(int((x + a[m]) * scale), 0, cells_ - 1); };
  const int i = index(v[axes.u]) - face.i0, j = index(v[axes.v]) - face.j0;
  if (i < 0 || i >= face.w || j < 0 || j >= face.h)
    return {};
  const std::size_t cell = face.base + std::size_t(j) * std::size_t(face.w) + std::size_t(i);
  return std::span(entries_).subspan(first_[cell], first_[cell + 1] - first_[cell]);
}

// [occluded]
[[gnu::flatten]] bool LightBuffer::occluded(const Ray& ray) const
{
  // The line from the origin runs straight to the light: only spheres that come nearer the light than the origin
  // (with the margin for the line's rounding) can lie across it.
  const Real within = glm::length(ray.origin - light_) + margin_;
  auto blocks = [&](std::span<const LaneIndex> spheres) {
    for (const LaneIndex number : spheres) {
      const std::size_t k = std::size_t(number);
      if (nearest_[k] > within)
        return false;
      if (intersectSphere(ray.origin, ray.direction, center_[k], radius_[k], ray.tmin, ray.tmax))
        return true;
    }
    return false;
  };
  return blocks(cellOf(ray.origin)) || blocks(everywhere_);
}
// [occluded]

std::size_t LightBuffer::memoryBytes() const
{
  return center_.size() * (sizeof(Vec3) + 2 * sizeof(Real)) + first_.size() * sizeof(std::uint32_t) +
         (everywhere_.size() + entries_.size()) * sizeof(LaneIndex);
}

} // namespace raylife

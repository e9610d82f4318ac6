#include "shading/density_grid.h"

#include <algorithm>
#include <cmath>

namespace raylife {

Real DensityGrid::density(const Vec3& p) const
{
  const int n[3] = {nx, ny, nz};
  int i0[3], i1[3];
  Real f[3];
  for (int a = 0; a < 3; ++a) {
    if (!(p[a] >= lo[a] && p[a] <= hi[a]))
      return 0;
    const Real g = (p[a] - lo[a]) / (hi[a] - lo[a]) * Real(n[a]) - Real(0.5); // in cell-centre coordinates
    const Real fl = std::floor(g);
    f[a] = g - fl;
    i0[a] = std::clamp(int(fl), 0, n[a] - 1);
    i1[a] = std::clamp(int(fl) + 1, 0, n[a] - 1);
  }
  auto v = [&](int x, int y, int z) {
    return Real(values[(std::size_t(z) * std::size_t(ny) + std::size_t(y)) * std::size_t(nx) + std::size_t(x)]);
  };
  const Real c00 = v(i0[0], i0[1], i0[2]) * (1 - f[0]) + v(i1[0], i0[1], i0[2]) * f[0];
  const Real c10 = v(i0[0], i1[1], i0[2]) * (1 - f[0]) + v(i1[0], i1[1], i0[2]) * f[0];
  const Real c01 = v(i0[0], i0[1], i1[2]) * (1 - f[0]) + v(i1[0], i0[1], i1[2]) * f[0];
  const Real c11 = v(i0[0], i1[1], i1[2]) * (1 - f[0]) + v(i1[0], i1[1], i1[2]) * f[0];
  const Real c0 = c00 * (1 - f[1]) + c10 * f[1], c1 = c01 * (1 - f[1]) + c11 * f[1];
  return std::max(Real(0), c0 * (1 - f[2]) + c1 * f[2]);
}

double DensityGrid::diagonal() const
{
  const glm::dvec3 side = glm::dvec3(hi) - glm::dvec3(lo);
  const double longest = std::max({side.x, side.y, side.z});
  return longest > 0 ? longest * glm::length(side / longest) : 0;
}

void DensityGrid::buildMajorants(int cells)
{
  const Vec3 extent = hi - lo;
  const Real longest = std::max({extent.x, extent.y, extent.z});
  const int n[3] = {nx, ny, nz};
  int m[3];
  for (int a = 0; a < 3; ++a)
    m[a] = std::max(1, int(std::lround(Real(cells) * extent[a] / longest)));
  mx = m[0], my = m[1], mz = m[2];
  majorants.assign(std::size_t(mx) * std::size_t(my) * std::size_t(mz), 0);
  globalMajorant = 0;
  // The values a point of majorant cell c may interpolate: grid coordinates g ∈ [c·n/m − ½, (c+1)·n/m − ½] use
  // the values floor(g) .. floor(g) + 1, clamped to the grid.
  auto range = [&](int a, int c) {
    const Real from = Real(c) * Real(n[a]) / Real(m[a]) - Real(0.5), to = Real(c + 1) * Real(n[a]) / Real(m[a]) - Real(0.5);
    return std::pair<int, int>(std::clamp(int(std::floor(from)), 0, n[a] - 1),
                               std::clamp(int(std::floor(to)) + 1, 0, n[a] - 1));
  };
  for (int cz = 0; cz < mz; ++cz)
    for (int cy = 0; cy < my; ++cy)
      for (int cx = 0; cx < mx; ++cx) {
        const auto [x0, x1] = range(0, cx);
        const auto [y0, y1] = range(1, cy);
        const auto [z0, z1] = range(2, cz);
        Real most = 0;
        for (int z = z0; z <= z1; ++z)
          for (int y = y0; y <= y1; ++y)
            for (int x = x0; x <= x1; ++x)
              most = std::max(most, Real(values[(std::size_t(z) * std::size_t(ny) + std::size_t(y)) * std::size_t(nx) +
                                                std::size_t(x)]));
        majorants[(std::size_t(cz) * std::size_t(my) + std::size_t(cy)) * std::size_t(mx) + std::size_t(cx)] = most;
        globalMajorant = std::max(globalMajorant, most);
      }
}

// [dda]
MajorantWalker::MajorantWalker(const DensityGrid& grid, bool global, const Ray& ray, Real tMax)
    : majorants_(global ? nullptr : grid.majorants.data()), global_(grid.globalMajorant)
{
  // Clip the ray to the box (slabs). An empty stretch leaves t_ ≥ tExit_, and next() gives nothing.
  Real tEnter = 0, tExit = tMax;
  for (int a = 0; a < 3; ++a) {
    if (ray.direction[a] == 0) {
      if (!(ray.origin[a] >= grid.lo[a] && ray.origin[a] <= grid.hi[a]))
        tExit = -1;
      continue;
    }
    const Real inv = 1 / ray.direction[a];
    Real tNear = (grid.lo[a] - ray.origin[a]) * inv, tFar = (grid.hi[a] - ray.origin[a]) * inv;
    if (tNear > tFar)
      std::swap(tNear, tFar);
    tEnter = std::max(tEnter, tNear);
    tExit = std::min(tExit, tFar);
  }
  t_ = tEnter;
  tExit_ = tExit;
  if (!(tEnter < tExit) || global)
    return;
  // The cell where the ray enters, and where it meets each axis's next wall (Amanatides and Woo).
  cells_[0] = grid.mx, cells_[1] = grid.my, cells_[2] = grid.mz;
  const std::ptrdiff_t stride[3] = {1, grid.mx, std::ptrdiff_t(grid.mx) * grid.my};
  const Vec3 entry = ray.at(tEnter);
  for (int a = 0; a < 3; ++a) {
    const Real cell = (grid.hi[a] - grid.lo[a]) / Real(cells_[a]);
    index_[a] = std::clamp(int(std::floor((entry[a] - grid.lo[a]) / cell)), 0, cells_[a] - 1);
    cell_ += index_[a] * stride[a];
    if (ray.direction[a] > 0) {
      step_[a] = 1;
      tNext_[a] = tEnter + (grid.lo[a] + Real(index_[a] + 1) * cell - entry[a]) / ray.direction[a];
      tDelta_[a] = cell / ray.direction[a];
    } else if (ray.direction[a] < 0) {
      step_[a] = -1;
      tNext_[a] = tEnter + (grid.lo[a] + Real(index_[a]) * cell - entry[a]) / ray.direction[a];
      tDelta_[a] = -cell / ray.direction[a];
    } else {
      tNext_[a] = kInfinity;
      tDelta_[a] = kInfinity;
    }
    stride_[a] = step_[a] * stride[a];
  }
}

bool MajorantWalker::next(MajorantSegment& s)
{
  while (t_ < tExit_) {
    if (!majorants_) { // the global majorant: the whole stretch at once
      s = MajorantSegment{t_, tExit_, global_};
      t_ = tExit_;
      return true;
    }
    // The wall the ray meets first ends this cell's segment; the walk then steps through it.
    const int a = tNext_[0] < tNext_[1] ? (tNext_[0] < tNext_[2] ? 0 : 2) : (tNext_[1] < tNext_[2] ? 1 : 2);
    const Real start = t_, end = std::min(tNext_[a], tExit_);
    const Real density = majorants_[cell_];
    t_ = std::max(t_, end);
    index_[a] += step_[a];
    if (index_[a] < 0 || index_[a] >= cells_[a])
      tExit_ = t_; // it leaves the box (rounding may have put tExit a hair further)
    cell_ += stride_[a];
    tNext_[a] += tDelta_[a];
    if (end > start) {
      s = MajorantSegment{start, end, density};
      return true;
    }
  }
  return false;
}
// [dda]

std::vector<MajorantSegment> majorantSegments(const DensityGrid& grid, bool global, const Ray& ray, Real tMax)
{
  std::vector<MajorantSegment> out;
  MajorantWalker walk(grid, global, ray, tMax);
  for (MajorantSegment s; walk.next(s);)
    out.push_back(s);
  return out;
}

namespace {

// The next tentative collision, `step` beyond t: at least the next number after t (towards `end`). A step smaller
// than half of t's spacing (a rate above about 1/ulp(t)) would leave t where it is, and at a point of zero density
// null collisions would then repeat there for ever; so each moves on, and a segment takes at most about
// rate × its length steps, or its length in ulps, whichever is fewer.
Real stepFrom(Real t, Real step, Real end)
{
  const Real next = t + step;
  return next > t ? next : std::nextafter(t, end);
}

} // namespace

TrackedFlight deltaTrack(const DensityGrid& grid, bool globalMajorant, const Color& sigmaA, const Color& sigmaS,
                         const Ray& ray, Real tMax, Sampler& sampler)
{
  const Color sigmaT = sigmaA + sigmaS;
  const Real sMax = std::max({sigmaT.r, sigmaT.g, sigmaT.b});
  Color weight(1);
  if (!(sMax > 0))
    return TrackedFlight{false, tMax, weight};
  Real target = -std::log1p(-sampler.next1D()); // the optical thickness, at the majorant, to the next collision
  MajorantWalker walk(grid, globalMajorant, ray, tMax);
  for (MajorantSegment s; walk.next(s);) {
    const Real rate = sMax * s.density;
    if (!(rate > 0))
      continue; // an empty cell: nothing to collide with, and no thickness used up
    Real t = s.t0;
    for (;;) {
      if (t + target / rate >= s.t1) { // no collision in this segment: carry the rest of the thickness on
        target -= rate * (s.t1 - t);
        break;
      }
      t = stepFrom(t, target / rate, s.t1);
      const Real d = grid.density(ray.at(t));
      const Color st = d * sigmaT;
      const Real mean = (st.r + st.g + st.b) / 3;
      if (sampler.next1D() * rate < mean) // a real collision, probability mean/rate
        return TrackedFlight{true, t, weight * (d * sigmaS) / mean};
      // A null collision: the path goes on, weighted (rate − σt)/(rate − mean) per channel (each ≤ 3).
      weight *= glm::max(Color(rate) - st, Color(0)) / (rate - mean);
      target = -std::log1p(-sampler.next1D());
    }
  }
  return TrackedFlight{false, tMax, weight};
}

Color ratioTrack(const DensityGrid& grid, bool globalMajorant, const Color& sigmaT, const Ray& ray, Real tMax,
                 Sampler& sampler)
{
  const Real sMax = std::max({sigmaT.r, sigmaT.g, sigmaT.b});
  Color tr(1);
  if (!(sMax > 0))
    return tr;
  MajorantWalker walk(grid, globalMajorant, ray, tMax);
  for (MajorantSegment s; walk.next(s);) {
    const Real rate = sMax * s.density;
    if (!(rate > 0))
      continue;
    for (Real t = s.t0 - std::log1p(-sampler.next1D()) / rate; t < s.t1;
         t = stepFrom(t, -std::log1p(-sampler.next1D()) / rate, s.t1)) {
      tr *= glm::max(Color(1) - grid.density(ray.at(t)) * sigmaT / rate, Color(0));
      if (tr == Color(0))
        return tr;
    }
  }
  return tr;
}

} // namespace raylife

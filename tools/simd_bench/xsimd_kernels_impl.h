// The two kernels in xsimd 8.1, lanes across rays: included only by the per-architecture units, which instantiate
// them for the architecture their flags enable.
#pragma once

#include "xsimd_kernels.h"

namespace raylife::simd_bench {

template <class Arch>
void ClosestHitXsimd::operator()(Arch, const Rays& rays, const Spheres& spheres, const Hits& hits) const {
  using V = xsimd::batch<float, Arch>;
  for (int64_t i = 0; i < rays.n; i += static_cast<int64_t>(V::size)) {
    const V ox = V::load_unaligned(rays.ox + i), oy = V::load_unaligned(rays.oy + i), oz = V::load_unaligned(rays.oz + i);
    const V dx = V::load_unaligned(rays.dx + i), dy = V::load_unaligned(rays.dy + i), dz = V::load_unaligned(rays.dz + i);
    const V tmin = V::load_unaligned(rays.tmin + i);
    V bestT = V::load_unaligned(rays.tmax + i);
    V bestId(-1.0f);
    for (int32_t s = 0; s < spheres.n; ++s) {
      // oc = o - c; b = oc . d; c = oc . oc - r^2; disc = b^2 - c (d is unit)
      const V ocx = ox - V(spheres.cx[s]), ocy = oy - V(spheres.cy[s]), ocz = oz - V(spheres.cz[s]);
      const V b = xsimd::fma(ocz, dz, xsimd::fma(ocy, dy, ocx * dx));
      const V c = xsimd::fma(ocz, ocz, xsimd::fma(ocy, ocy, ocx * ocx)) - V(spheres.r[s] * spheres.r[s]);
      const V disc = xsimd::fms(b, b, c);
      // The first root inside the interval
      const V root = xsimd::sqrt(xsimd::max(disc, V(0.0f)));
      const V t0 = -b - root, t1 = root - b;
      const V t = xsimd::select(t0 > tmin, t0, t1);
      const auto hit = (disc >= V(0.0f)) & (t > tmin) & (t < bestT);
      bestT = xsimd::select(hit, t, bestT);
      bestId = xsimd::select(hit, V(static_cast<float>(s)), bestId);
    }
    bestT.store_unaligned(hits.t + i);
    xsimd::batch_cast<int32_t>(bestId).store_unaligned(hits.id + i);
  }
}

template <class Arch>
void ShadeXsimd::operator()(Arch, const HitRecords& records, const Bounces& out) const {
  using V = xsimd::batch<float, Arch>;
  const V one(1.0f);
  for (int64_t i = 0; i < records.n; i += static_cast<int64_t>(V::size)) {
    const V nx = V::load_unaligned(records.nx + i), ny = V::load_unaligned(records.ny + i),
            nz = V::load_unaligned(records.nz + i);
    const V u1 = V::load_unaligned(records.u1 + i);
    // Cosine-weighted direction in the local frame
    const V r = xsimd::sqrt(u1);
    const V phi = V(2.0f * 3.14159265358979f) * V::load_unaligned(records.u2 + i);
    const V lx = r * xsimd::cos(phi), ly = r * xsimd::sin(phi);
    const V lz = xsimd::sqrt(xsimd::max(V(0.0f), one - u1));
    // Orthonormal frame about n (Duff et al. 2017, branchless)
    const V sign = xsimd::copysign(one, nz);
    const V a = -(one / (sign + nz));
    const V b = nx * ny * a;
    const V b1x = xsimd::fma(sign * (nx * nx), a, one), b1y = sign * b, b1z = -(sign * nx);
    const V b2x = b, b2y = xsimd::fma(ny * ny, a, sign), b2z = -ny;
    // Local to world
    xsimd::fma(lz, nx, xsimd::fma(ly, b2x, lx * b1x)).store_unaligned(out.dx + i);
    xsimd::fma(lz, ny, xsimd::fma(ly, b2y, lx * b1y)).store_unaligned(out.dy + i);
    xsimd::fma(lz, nz, xsimd::fma(ly, b2z, lx * b1z)).store_unaligned(out.dz + i);
    (V::load_unaligned(records.tr + i) * V::load_unaligned(records.ar + i)).store_unaligned(out.tr + i);
    (V::load_unaligned(records.tg + i) * V::load_unaligned(records.ag + i)).store_unaligned(out.tg + i);
    (V::load_unaligned(records.tb + i) * V::load_unaligned(records.ab + i)).store_unaligned(out.tb + i);
  }
}

} // namespace raylife::simd_bench

// The two kernels in GCC 12's std::experimental::simd, lanes across rays. native_simd<float> is as wide as the
// unit's flags allow, so each per-target unit (stdsimd_sse4_2.cpp, stdsimd_avx2.cpp, stdsimd_avx512.cpp) includes
// this and instantiates the kernels for its own native_simd<float>: a different type in each, so no two units share
// an instantiation.
#pragma once

#include "kernels.h"

#include <experimental/simd>

namespace raylife::simd_bench {
namespace stdx = std::experimental;

template <class V>
void closestHitStd(const Rays& rays, const Spheres& spheres, const Hits& hits) {
  constexpr auto aligned = stdx::element_aligned;
  for (int64_t i = 0; i < rays.n; i += static_cast<int64_t>(V::size())) {
    const V ox(rays.ox + i, aligned), oy(rays.oy + i, aligned), oz(rays.oz + i, aligned);
    const V dx(rays.dx + i, aligned), dy(rays.dy + i, aligned), dz(rays.dz + i, aligned);
    const V tmin(rays.tmin + i, aligned);
    V bestT(rays.tmax + i, aligned);
    V bestId = -1.0f;
    for (int32_t s = 0; s < spheres.n; ++s) {
      // oc = o - c; b = oc . d; c = oc . oc - r^2; disc = b^2 - c (d is unit)
      const V ocx = ox - spheres.cx[s], ocy = oy - spheres.cy[s], ocz = oz - spheres.cz[s];
      const V b = ocx * dx + ocy * dy + ocz * dz;
      const V c = ocx * ocx + ocy * ocy + ocz * ocz - spheres.r[s] * spheres.r[s];
      const V disc = b * b - c;
      // The first root inside the interval
      const V root = stdx::sqrt(stdx::max(disc, V(0.0f)));
      const V t0 = -b - root;
      V t = root - b;
      stdx::where(t0 > tmin, t) = t0;
      const auto hit = disc >= 0.0f && t > tmin && t < bestT;
      stdx::where(hit, bestT) = t;
      stdx::where(hit, bestId) = static_cast<float>(s);
    }
    bestT.copy_to(hits.t + i, aligned);
    stdx::static_simd_cast<stdx::rebind_simd_t<int32_t, V>>(bestId).copy_to(hits.id + i, aligned);
  }
}

template <class V>
void shadeStd(const HitRecords& records, const Bounces& out) {
  constexpr auto aligned = stdx::element_aligned;
  for (int64_t i = 0; i < records.n; i += static_cast<int64_t>(V::size())) {
    const V nx(records.nx + i, aligned), ny(records.ny + i, aligned), nz(records.nz + i, aligned);
    const V u1(records.u1 + i, aligned), u2(records.u2 + i, aligned);
    // Cosine-weighted direction in the local frame
    const V r = stdx::sqrt(u1);
    const V phi = 2.0f * 3.14159265358979f * u2;
    const V lx = r * stdx::cos(phi), ly = r * stdx::sin(phi);
    const V lz = stdx::sqrt(stdx::max(V(0.0f), 1.0f - u1));
    // Orthonormal frame about n (Duff et al. 2017, branchless)
    const V sign = stdx::copysign(V(1.0f), nz);
    const V a = -1.0f / (sign + nz);
    const V b = nx * ny * a;
    const V b1x = 1.0f + sign * nx * nx * a, b1y = sign * b, b1z = -sign * nx;
    const V b2x = b, b2y = sign + ny * ny * a, b2z = -ny;
    // Local to world
    (lx * b1x + ly * b2x + lz * nx).copy_to(out.dx + i, aligned);
    (lx * b1y + ly * b2y + lz * ny).copy_to(out.dy + i, aligned);
    (lx * b1z + ly * b2z + lz * nz).copy_to(out.dz + i, aligned);
    (V(records.tr + i, aligned) * V(records.ar + i, aligned)).copy_to(out.tr + i, aligned);
    (V(records.tg + i, aligned) * V(records.ag + i, aligned)).copy_to(out.tg + i, aligned);
    (V(records.tb + i, aligned) * V(records.ab + i, aligned)).copy_to(out.tb + i, aligned);
  }
}

} // namespace raylife::simd_bench

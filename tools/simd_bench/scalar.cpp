// The baseline: one ray (record) at a time, as chapters 1 to 15 write it, compiled for generic x86-64.
#include "kernels.h"

#include <cmath>
#include <numbers>

namespace raylife::simd_bench {

namespace {
// In Real: float for the baseline, double for the arbiter of the rays where float results disagree.
template <class Real>
void closestHitIn(const Rays& rays, const Spheres& spheres, const Hits& hits) {
  for (int64_t i = 0; i < rays.n; ++i) {
    const Real ox = rays.ox[i], oy = rays.oy[i], oz = rays.oz[i];
    const Real dx = rays.dx[i], dy = rays.dy[i], dz = rays.dz[i];
    const Real tmin = rays.tmin[i];
    Real bestT = rays.tmax[i];
    int32_t bestId = -1;
    for (int32_t s = 0; s < spheres.n; ++s) {
      // oc = o - c; b = oc . d; c = oc . oc - r^2; disc = b^2 - c (d is unit)
      const Real ocx = ox - spheres.cx[s], ocy = oy - spheres.cy[s], ocz = oz - spheres.cz[s];
      const Real r = spheres.r[s];
      const Real b = ocx * dx + ocy * dy + ocz * dz;
      const Real c = ocx * ocx + ocy * ocy + ocz * ocz - r * r;
      const Real disc = b * b - c;
      if (disc < 0) continue;
      // The first root inside the interval
      const Real root = std::sqrt(disc);
      Real t = -b - root;
      if (!(t > tmin)) t = root - b;
      if (t > tmin && t < bestT) {
        bestT = t;
        bestId = s;
      }
    }
    hits.t[i] = static_cast<float>(bestT);
    hits.id[i] = bestId;
  }
}
} // namespace

void closestHitScalar(const Rays& rays, const Spheres& spheres, const Hits& hits) {
  closestHitIn<float>(rays, spheres, hits);
}

void closestHitScalarDouble(const Rays& rays, const Spheres& spheres, const Hits& hits) {
  closestHitIn<double>(rays, spheres, hits);
}

void shadeScalar(const HitRecords& records, const Bounces& out) {
  for (int64_t i = 0; i < records.n; ++i) {
    const float nx = records.nx[i], ny = records.ny[i], nz = records.nz[i];
    // Cosine-weighted direction in the local frame
    const float r = std::sqrt(records.u1[i]);
    const float phi = 2.0f * std::numbers::pi_v<float> * records.u2[i];
    const float lx = r * std::cos(phi), ly = r * std::sin(phi);
    const float lz = std::sqrt(std::fmax(0.0f, 1.0f - records.u1[i]));
    // Orthonormal frame about n (Duff et al. 2017, branchless)
    const float sign = std::copysign(1.0f, nz);
    const float a = -1.0f / (sign + nz);
    const float b = nx * ny * a;
    const float b1x = 1.0f + sign * nx * nx * a, b1y = sign * b, b1z = -sign * nx;
    const float b2x = b, b2y = sign + ny * ny * a, b2z = -ny;
    // Local to world
    out.dx[i] = lx * b1x + ly * b2x + lz * nx;
    out.dy[i] = lx * b1y + ly * b2y + lz * ny;
    out.dz[i] = lx * b1z + ly * b2z + lz * nz;
    out.tr[i] = records.tr[i] * records.ar[i];
    out.tg[i] = records.tg[i] * records.ag[i];
    out.tb[i] = records.tb[i] * records.ab[i];
  }
}

} // namespace raylife::simd_bench

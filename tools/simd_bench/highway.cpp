// The two kernels in Google Highway 1.0.3, with its run-time dispatch.
//
// foreach_target.h re-includes this file once per target in HWY_TARGETS (for a generic x86-64 build: EMU128,
// SSSE3, SSE4, AVX2, AVX3), each time with HWY_NAMESPACE naming that target (N_SSE4, N_AVX2, N_AVX3...) and the
// code between HWY_BEFORE_NAMESPACE and HWY_AFTER_NAMESPACE compiled for it (a target pragma: no per-file flags).
// The part under HWY_ONCE is compiled once: HWY_EXPORT makes a table of the per-target functions and
// HWY_DYNAMIC_DISPATCH calls the best one the CPU supports.
#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "highway.cpp" // this file, found through the target's include directory
#include <hwy/foreach_target.h>          // must come before highway.h
#include <hwy/highway.h>
#include <hwy/contrib/math/math-inl.h> // Sin, Cos (header only)

#include "kernels.h"

HWY_BEFORE_NAMESPACE();
namespace raylife::simd_bench::HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

// Lanes across rays: each lane follows one ray through every sphere.
void closestHit(const Rays& rays, const Spheres& spheres, const Hits& hits) {
  const hn::ScalableTag<float> d;
  const hn::RebindToSigned<decltype(d)> di;
  const auto zero = hn::Zero(d);
  for (int64_t i = 0; i < rays.n; i += static_cast<int64_t>(hn::Lanes(d))) {
    const auto ox = hn::LoadU(d, rays.ox + i), oy = hn::LoadU(d, rays.oy + i), oz = hn::LoadU(d, rays.oz + i);
    const auto dx = hn::LoadU(d, rays.dx + i), dy = hn::LoadU(d, rays.dy + i), dz = hn::LoadU(d, rays.dz + i);
    const auto tmin = hn::LoadU(d, rays.tmin + i);
    auto bestT = hn::LoadU(d, rays.tmax + i);
    auto bestId = hn::Set(d, -1.0f);
    for (int32_t s = 0; s < spheres.n; ++s) {
      // oc = o - c; b = oc . d; c = oc . oc - r^2; disc = b^2 - c (d is unit)
      const auto ocx = hn::Sub(ox, hn::Set(d, spheres.cx[s]));
      const auto ocy = hn::Sub(oy, hn::Set(d, spheres.cy[s]));
      const auto ocz = hn::Sub(oz, hn::Set(d, spheres.cz[s]));
      const auto b = hn::MulAdd(ocz, dz, hn::MulAdd(ocy, dy, hn::Mul(ocx, dx)));
      const auto c = hn::Sub(hn::MulAdd(ocz, ocz, hn::MulAdd(ocy, ocy, hn::Mul(ocx, ocx))),
                           hn::Set(d, spheres.r[s] * spheres.r[s]));
      const auto disc = hn::MulSub(b, b, c);
      // The first root inside the interval
      const auto root = hn::Sqrt(hn::Max(disc, zero));
      const auto t0 = hn::Sub(hn::Neg(b), root), t1 = hn::Sub(root, b);
      const auto t = hn::IfThenElse(hn::Gt(t0, tmin), t0, t1);
      const auto hit = hn::And(hn::Ge(disc, zero), hn::And(hn::Gt(t, tmin), hn::Lt(t, bestT)));
      bestT = hn::IfThenElse(hit, t, bestT);
      bestId = hn::IfThenElse(hit, hn::Set(d, static_cast<float>(s)), bestId);
    }
    hn::StoreU(bestT, d, hits.t + i);
    hn::StoreU(hn::ConvertTo(di, bestId), di, hits.id + i);
  }
}

void shade(const HitRecords& records, const Bounces& out) {
  const hn::ScalableTag<float> d;
  const auto one = hn::Set(d, 1.0f);
  for (int64_t i = 0; i < records.n; i += static_cast<int64_t>(hn::Lanes(d))) {
    const auto nx = hn::LoadU(d, records.nx + i), ny = hn::LoadU(d, records.ny + i), nz = hn::LoadU(d, records.nz + i);
    const auto u1 = hn::LoadU(d, records.u1 + i);
    // Cosine-weighted direction in the local frame
    const auto r = hn::Sqrt(u1);
    const auto phi = hn::Mul(hn::Set(d, 2.0f * 3.14159265358979f), hn::LoadU(d, records.u2 + i));
    const auto lx = hn::Mul(r, hn::Cos(d, phi)), ly = hn::Mul(r, hn::Sin(d, phi));
    const auto lz = hn::Sqrt(hn::Max(hn::Zero(d), hn::Sub(one, u1)));
    // Orthonormal frame about n (Duff et al. 2017, branchless)
    const auto sign = hn::CopySign(one, nz);
    const auto a = hn::Neg(hn::Div(one, hn::Add(sign, nz)));
    const auto b = hn::Mul(hn::Mul(nx, ny), a);
    const auto b1x = hn::MulAdd(hn::Mul(sign, hn::Mul(nx, nx)), a, one), b1y = hn::Mul(sign, b), b1z = hn::Neg(hn::Mul(sign, nx));
    const auto b2x = b, b2y = hn::MulAdd(hn::Mul(ny, ny), a, sign), b2z = hn::Neg(ny);
    // Local to world
    hn::StoreU(hn::MulAdd(lz, nx, hn::MulAdd(ly, b2x, hn::Mul(lx, b1x))), d, out.dx + i);
    hn::StoreU(hn::MulAdd(lz, ny, hn::MulAdd(ly, b2y, hn::Mul(lx, b1y))), d, out.dy + i);
    hn::StoreU(hn::MulAdd(lz, nz, hn::MulAdd(ly, b2z, hn::Mul(lx, b1z))), d, out.dz + i);
    hn::StoreU(hn::Mul(hn::LoadU(d, records.tr + i), hn::LoadU(d, records.ar + i)), d, out.tr + i);
    hn::StoreU(hn::Mul(hn::LoadU(d, records.tg + i), hn::LoadU(d, records.ag + i)), d, out.tg + i);
    hn::StoreU(hn::Mul(hn::LoadU(d, records.tb + i), hn::LoadU(d, records.ab + i)), d, out.tb + i);
  }
}

} // namespace raylife::simd_bench::HWY_NAMESPACE
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace raylife::simd_bench {

HWY_EXPORT(closestHit);
HWY_EXPORT(shade);

namespace {
int64_t highwayTarget(Target target) {
  switch (target) {
  case Target::sse4: return HWY_SSE4;
  case Target::avx2: return HWY_AVX2;
  case Target::avx512: return HWY_AVX3;
  }
  return 0;
}

} // namespace

bool highwaySupports(Target target) { return (hwy::SupportedTargets() & HWY_TARGETS & highwayTarget(target)) != 0; }

// The CPU seems to support `target` alone, so that HWY_DYNAMIC_DISPATCH picks it (Highway's own tests do the same).
void highwayForceTarget(Target target) { hwy::SetSupportedTargetsForTest(highwayTarget(target)); }
void highwayReleaseTarget() { hwy::SetSupportedTargetsForTest(0); }

void closestHitHighway(const Rays& rays, const Spheres& spheres, const Hits& hits) {
  HWY_DYNAMIC_DISPATCH(closestHit)(rays, spheres, hits);
}

void shadeHighway(const HitRecords& records, const Bounces& out) { HWY_DYNAMIC_DISPATCH(shade)(records, out); }

const char* highwayBestTarget() {
  const int64_t targets = hwy::SupportedTargets() & HWY_TARGETS;
  return hwy::TargetName(targets & -targets); // the lowest bit is the best target
}

} // namespace raylife::simd_bench
#endif // HWY_ONCE

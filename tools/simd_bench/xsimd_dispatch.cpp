// xsimd's kernels, chosen at run time. xsimd::dispatch (8.1) walks XsimdArchs, best first, and calls the functor
// with the first architecture the CPU supports; to force one, the bench calls the functor with that architecture's
// tag directly, after asking xsimd whether the CPU has it.
#include "xsimd_kernels.h"

namespace raylife::simd_bench {

bool xsimdSupports(Target target) {
  const auto cpu = xsimd::available_architectures();
  switch (target) {
  case Target::sse4: return cpu.sse4_2;
  case Target::avx2: return cpu.fma3_avx2;
  case Target::avx512: return cpu.avx512f && cpu.avx512cd && cpu.avx512dq && cpu.avx512bw;
  }
  return false;
}

void closestHitXsimd(Target target, const Rays& rays, const Spheres& spheres, const Hits& hits) {
  switch (target) {
  case Target::sse4: ClosestHitXsimd{}(xsimd::sse4_2{}, rays, spheres, hits); break;
  case Target::avx2: ClosestHitXsimd{}(xsimd::fma3<xsimd::avx2>{}, rays, spheres, hits); break;
  case Target::avx512: ClosestHitXsimd{}(xsimd::avx512bw{}, rays, spheres, hits); break;
  }
}

void shadeXsimd(Target target, const HitRecords& records, const Bounces& out) {
  switch (target) {
  case Target::sse4: ShadeXsimd{}(xsimd::sse4_2{}, records, out); break;
  case Target::avx2: ShadeXsimd{}(xsimd::fma3<xsimd::avx2>{}, records, out); break;
  case Target::avx512: ShadeXsimd{}(xsimd::avx512bw{}, records, out); break;
  }
}

void closestHitXsimdBest(const Rays& rays, const Spheres& spheres, const Hits& hits) {
  xsimd::dispatch<XsimdArchs>(ClosestHitXsimd{})(rays, spheres, hits);
}

} // namespace raylife::simd_bench

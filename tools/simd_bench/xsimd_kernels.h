// The two kernels in xsimd 8.1, as the functors its dispatch calls: operator() takes the architecture as its first
// argument. Declared here for xsimd_dispatch.cpp; defined in xsimd_kernels_impl.h and instantiated once per
// architecture, each in its own unit compiled with that architecture's flags (xsimd_sse4_2.cpp, xsimd_avx2.cpp,
// xsimd_avx512.cpp).
#pragma once

#include "kernels.h"

#include <xsimd/xsimd.hpp>

namespace raylife::simd_bench {

struct ClosestHitXsimd {
  template <class Arch>
  void operator()(Arch, const Rays& rays, const Spheres& spheres, const Hits& hits) const;
};

struct ShadeXsimd {
  template <class Arch>
  void operator()(Arch, const HitRecords& records, const Bounces& out) const;
};

// The architectures instantiated, best first (the order xsimd::dispatch walks).
using XsimdArchs = xsimd::arch_list<xsimd::avx512bw, xsimd::fma3<xsimd::avx2>, xsimd::sse4_2>;

#define RAYLIFE_XSIMD_INSTANTIATIONS(EXTERN, ARCH)                                                                    \
  EXTERN template void ClosestHitXsimd::operator()<ARCH>(ARCH, const Rays&, const Spheres&, const Hits&) const;       \
  EXTERN template void ShadeXsimd::operator()<ARCH>(ARCH, const HitRecords&, const Bounces&) const;

RAYLIFE_XSIMD_INSTANTIATIONS(extern, xsimd::sse4_2)
RAYLIFE_XSIMD_INSTANTIATIONS(extern, xsimd::fma3<xsimd::avx2>)
RAYLIFE_XSIMD_INSTANTIATIONS(extern, xsimd::avx512bw)

} // namespace raylife::simd_bench

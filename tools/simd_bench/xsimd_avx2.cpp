// xsimd's kernels for xsimd::fma3<xsimd::avx2> (this unit's flags, set in CMakeLists.txt: -mavx2 -mfma).
#include "xsimd_kernels_impl.h"

namespace raylife::simd_bench {
RAYLIFE_XSIMD_INSTANTIATIONS(, xsimd::fma3<xsimd::avx2>)
} // namespace raylife::simd_bench

// xsimd's kernels for xsimd::avx512bw (this unit's flags, set in CMakeLists.txt: -mavx512f -mavx512cd -mavx512dq
// -mavx512bw -mavx512vl -mfma).
#include "xsimd_kernels_impl.h"

namespace raylife::simd_bench {
RAYLIFE_XSIMD_INSTANTIATIONS(, xsimd::avx512bw)
} // namespace raylife::simd_bench

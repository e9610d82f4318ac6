// xsimd's kernels for xsimd::sse4_2 (this unit's flags, set in CMakeLists.txt: -msse4.2).
#include "xsimd_kernels_impl.h"

namespace raylife::simd_bench {
RAYLIFE_XSIMD_INSTANTIATIONS(, xsimd::sse4_2)
} // namespace raylife::simd_bench

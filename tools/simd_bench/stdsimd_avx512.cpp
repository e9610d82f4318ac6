// std::experimental::simd's kernels for avx512 (this unit's flags, set in CMakeLists.txt: -mavx512f -mavx512cd
// -mavx512dq -mavx512bw -mavx512vl -mfma).
#include "stdsimd_kernels.h"

namespace raylife::simd_bench {

using V = stdx::native_simd<float>;
static_assert(V::size() == 16, "compiled without this target's flags");

void closestHitStdAvx512(const Rays& rays, const Spheres& spheres, const Hits& hits) {
  closestHitStd<V>(rays, spheres, hits);
}
void shadeStdAvx512(const HitRecords& records, const Bounces& out) {
  shadeStd<V>(records, out);
}

} // namespace raylife::simd_bench

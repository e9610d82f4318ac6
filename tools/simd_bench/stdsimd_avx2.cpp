// std::experimental::simd's kernels for avx2 (this unit's flags, set in CMakeLists.txt: -mavx2 -mfma).
#include "stdsimd_kernels.h"

namespace raylife::simd_bench {

using V = stdx::native_simd<float>;
static_assert(V::size() == 8, "compiled without this target's flags");

void closestHitStdAvx2(const Rays& rays, const Spheres& spheres, const Hits& hits) {
  closestHitStd<V>(rays, spheres, hits);
}
void shadeStdAvx2(const HitRecords& records, const Bounces& out) {
  shadeStd<V>(records, out);
}

} // namespace raylife::simd_bench

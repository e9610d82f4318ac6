// std::experimental::simd's kernels for sse4_2 (this unit's flags, set in CMakeLists.txt: -msse4.2).
#include "stdsimd_kernels.h"

namespace raylife::simd_bench {

using V = stdx::native_simd<float>;
static_assert(V::size() == 4, "compiled without this target's flags");

void closestHitStdSse4(const Rays& rays, const Spheres& spheres, const Hits& hits) {
  closestHitStd<V>(rays, spheres, hits);
}
void shadeStdSse4(const HitRecords& records, const Bounces& out) {
  shadeStd<V>(records, out);
}

} // namespace raylife::simd_bench

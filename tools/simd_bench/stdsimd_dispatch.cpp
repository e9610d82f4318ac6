// std::experimental::simd has no dispatch of its own: the per-target units are chosen here, by what the CPU says it
// supports (__builtin_cpu_supports), as a user would do it.
#include "kernels.h"

namespace raylife::simd_bench {

// Defined in stdsimd_sse4_2.cpp, stdsimd_avx2.cpp and stdsimd_avx512.cpp.
void closestHitStdSse4(const Rays& rays, const Spheres& spheres, const Hits& hits);
void closestHitStdAvx2(const Rays& rays, const Spheres& spheres, const Hits& hits);
void closestHitStdAvx512(const Rays& rays, const Spheres& spheres, const Hits& hits);
void shadeStdSse4(const HitRecords& records, const Bounces& out);
void shadeStdAvx2(const HitRecords& records, const Bounces& out);
void shadeStdAvx512(const HitRecords& records, const Bounces& out);

bool stdSimdSupports(Target target) {
  switch (target) {
  case Target::sse4: return __builtin_cpu_supports("sse4.2");
  case Target::avx2: return __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
  case Target::avx512:
    return __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512cd") &&
           __builtin_cpu_supports("avx512dq") && __builtin_cpu_supports("avx512bw") &&
           __builtin_cpu_supports("avx512vl");
  }
  return false;
}

void closestHitStdSimd(Target target, const Rays& rays, const Spheres& spheres, const Hits& hits) {
  switch (target) {
  case Target::sse4: closestHitStdSse4(rays, spheres, hits); break;
  case Target::avx2: closestHitStdAvx2(rays, spheres, hits); break;
  case Target::avx512: closestHitStdAvx512(rays, spheres, hits); break;
  }
}

void shadeStdSimd(Target target, const HitRecords& records, const Bounces& out) {
  switch (target) {
  case Target::sse4: shadeStdSse4(records, out); break;
  case Target::avx2: shadeStdAvx2(records, out); break;
  case Target::avx512: shadeStdAvx512(records, out); break;
  }
}

} // namespace raylife::simd_bench

// simd_bench's two kernels, the data they read and write, and one entry point per library and target.
//
// Every SIMD translation unit includes this header, whatever flags it is compiled with, so it holds plain structs
// and declarations only: an inline function here, compiled with -mavx512f in one unit, could be the copy the linker
// keeps for all of them (an ODR trap of per-target compilation).
#pragma once

#include <cstdint>

namespace raylife::simd_bench {

// N rays as structure of arrays. N is a multiple of 16, the widest lane count, so no kernel has a tail.
struct Rays {
  const float *ox, *oy, *oz; // origin
  const float *dx, *dy, *dz; // unit direction
  const float *tmin, *tmax;  // the open interval searched
  int64_t n;
};

// Spheres as structure of arrays, broadcast one at a time to all lanes.
struct Spheres {
  const float *cx, *cy, *cz, *r;
  int32_t n;
};

// Per ray: the nearest t in (tmin, tmax) and its sphere's index; tmax and -1 on a miss.
struct Hits {
  float* t;
  int32_t* id;
};

// N hit records: the unit normal, two uniform numbers, the albedo and the throughput so far.
struct HitRecords {
  const float *nx, *ny, *nz;
  const float *u1, *u2;
  const float *ar, *ag, *ab; // albedo
  const float *tr, *tg, *tb; // throughput
  int64_t n;
};

// Per record: a cosine-weighted direction about the normal, and the throughput times the albedo.
struct Bounces {
  float *dx, *dy, *dz;
  float *tr, *tg, *tb;
};

enum class Target { sse4, avx2, avx512 };

// The baseline: plain loops, one ray (record) at a time, compiled for generic x86-64 (scalar.cpp).
void closestHitScalar(const Rays& rays, const Spheres& spheres, const Hits& hits);
void shadeScalar(const HitRecords& records, const Bounces& out);
// The same closest hit in double: which float result is right where two disagree.
void closestHitScalarDouble(const Rays& rays, const Spheres& spheres, const Hits& hits);

// Google Highway (highway.cpp): HWY_DYNAMIC_DISPATCH, which calls the best target the CPU supports, or the one
// forced by highwayForceTarget until highwayReleaseTarget. Forcing costs nothing measurable; the first plain call
// after a release reads the CPU's features again (CPUID, about 8 us in this virtual machine), as the first call of a
// process does.
bool highwaySupports(Target target);
void highwayForceTarget(Target target);
void highwayReleaseTarget();
void closestHitHighway(const Rays& rays, const Spheres& spheres, const Hits& hits);
void shadeHighway(const HitRecords& records, const Bounces& out);
const char* highwayBestTarget();

// xsimd 8.1 (xsimd_dispatch.cpp; kernels in xsimd_kernels.h, one unit per architecture).
bool xsimdSupports(Target target);
void closestHitXsimd(Target target, const Rays& rays, const Spheres& spheres, const Hits& hits);
void shadeXsimd(Target target, const HitRecords& records, const Bounces& out);
// The same through xsimd::dispatch over the three architectures: the best the CPU supports.
void closestHitXsimdBest(const Rays& rays, const Spheres& spheres, const Hits& hits);

// GCC 12's std::experimental::simd (stdsimd_kernels.h, one unit per target, stdsimd_dispatch.cpp).
bool stdSimdSupports(Target target);
void closestHitStdSimd(Target target, const Rays& rays, const Spheres& spheres, const Hits& hits);
void shadeStdSimd(Target target, const HitRecords& records, const Bounces& out);

} // namespace raylife::simd_bench

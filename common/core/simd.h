/// @file simd.h
/// @brief What the queries' vector code needs from the compiler and the CPU: a way to build one function for
/// AVX2 while the rest of the program is built for any x86-64, and whether the CPU it runs on has AVX2.
///
/// The library is built for the x86-64 baseline (SSE2), so its binaries run on any such CPU. Where a query has a
/// faster form on AVX2 (four doubles or eight floats to a register), that form is a function marked RAYLIFE_AVX2,
/// and the query calls it only when cpuHasAvx2() says so: one build, the best code for the machine.
///
/// A contract for such functions: no vector of 32 bytes is passed or returned by value between a function built
/// for AVX2 and one built without it (the two pass it differently); pass it by reference.
#pragma once

#if defined(__x86_64__) && defined(__GNUC__)
/// 1 where functions can be built for AVX2 beside the baseline (x86-64, with GCC or clang); 0 elsewhere.
#define RAYLIFE_HAS_AVX2 1
/// Builds the function it marks for AVX2 (it may then run only where cpuHasAvx2() is true), with BMI1 and BMI2,
/// whose bit operations every processor with AVX2 has (Intel's from Haswell on, AMD's from Excavator on): the walks'
/// masks of boxes and lanes then take one instruction each (bzhi, blsr) where they took up to four.
#define RAYLIFE_AVX2 [[gnu::target("avx2,bmi,bmi2")]]
/// RAYLIFE_AVX2, and always inlined into its (AVX2) callers: for the small helpers of such a function.
#define RAYLIFE_AVX2_INLINE [[gnu::target("avx2,bmi,bmi2"), gnu::always_inline]] inline
#else
/// 0: this compiler or target cannot build functions for AVX2; every query keeps its baseline code.
#define RAYLIFE_HAS_AVX2 0
#endif

namespace raylife {

/// True when the CPU running the program has AVX2, BMI1 and BMI2, so that RAYLIFE_AVX2 functions may be called
/// (a virtual machine may hide BMI while it shows AVX2: then the baseline code runs); false wherever
/// RAYLIFE_HAS_AVX2 is 0. Cheap (flag reads): call it where a query chooses its code.
inline bool cpuHasAvx2()
{
#if RAYLIFE_HAS_AVX2
  return __builtin_cpu_supports("avx2") && __builtin_cpu_supports("bmi") && __builtin_cpu_supports("bmi2");
#else
  return false;
#endif
}

} // namespace raylife

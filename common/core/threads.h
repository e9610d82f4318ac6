/// @file threads.h
/// @brief How many threads a render or a pre-pass takes: what --threads asks, else OpenMP's default, capped.
#pragma once

#include <omp.h>

#include <algorithm>

namespace raylife {

/// The most threads a render or a pre-pass runs on: the largest --threads accepts, and the cap on OpenMP's default.
/// (libgomp starts a team with a buffer on the stack per thread: OMP_NUM_THREADS=100000 overflowed the stack of
/// every chapter in GOMP_parallel, before any of its threads ran.)
inline constexpr int kMaxThreads = 1024;

/// The threads a parallel loop takes: `asked` where it is positive (--threads, already within 1 to kMaxThreads),
/// else OpenMP's default (OMP_NUM_THREADS, else one per core) capped at kMaxThreads; at least 1.
inline int threadCount(int asked) { return asked > 0 ? asked : std::clamp(omp_get_max_threads(), 1, kMaxThreads); }

} // namespace raylife

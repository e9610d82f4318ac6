/// @file peak.h
/// @brief The two ceilings of a roofline, measured with the instruction set the stream kernels use now
/// (forceSimdTarget in render/ray_stream.h picks it): the rate of independent multiplies and adds, and the rate a
/// sum reads an array at.
#pragma once

#include "core/math.h"

#include <cstddef>

namespace raylife::roofline {

/// Multiplies and adds in every lane, none fused: kMulAddChains chains of multiplies and as many of adds, each
/// vector independent of the others, `iterations` times round. Returns the sum of the chains (so nothing is left
/// out by the compiler); the work is flopsPerIteration() · `iterations` floating-point operations.
Real mulAddChains(std::size_t iterations);
/// The operations one iteration of mulAddChains does, all lanes counted.
double flopsPerIteration();

/// The sum of v[0 .. n), read once, in vectors (several partial sums, so that the adds do not wait on each other).
/// `n` is a multiple of 64 and `v` is aligned to 64 bytes.
Real sumArray(const Real* v, std::size_t n);

} // namespace raylife::roofline

/// @file peak.h
/// @brief The two ceilings of a roofline, measured with the instruction set the stream kernels use now
/// (forceSimdTarget in render/ray_stream.h picks it): the rate of independent multiplies and adds, and the rate a
/// sum reads an array at; and the price of lanes loaded from scattered places (a gather), which a walk of a tree
/// with one ray per lane would pay at every step.
#pragma once

#include "core/math.h"

#include <cstddef>
#include <cstdint>
#include <type_traits>

namespace raylife::roofline {

/// An index of gatherSum: as wide as Real.
using GatherIndex = std::conditional_t<sizeof(Real) == 8, std::int64_t, std::int32_t>;

/// Multiplies and adds in every lane, none fused: kMulAddChains chains of multiplies and as many of adds, each
/// vector independent of the others, `iterations` times round. Returns the sum of the chains (so nothing is left
/// out by the compiler); the work is flopsPerIteration() · `iterations` floating-point operations.
Real mulAddChains(std::size_t iterations);
/// The operations one iteration of mulAddChains does, all lanes counted.
double flopsPerIteration();

/// The sum of v[0 .. n), read once, in vectors (several partial sums, so that the adds do not wait on each other).
/// `n` is a multiple of 64 and `v` is aligned to 64 bytes.
Real sumArray(const Real* v, std::size_t n);

/// Lanes loaded from scattered places: the sum of table[index[k]] over k in [0, n), a vector of lanes at a time,
/// each vector one gather (independent of the others). `n` is a multiple of 64, every index lies in the table, and
/// `index` is aligned to 64 bytes. (Indices of the width Highway gathers Real with: 64 bits for double, 32 for float.)
Real gatherSum(const Real* table, const GatherIndex* index, std::size_t n);
/// Lanes in one vector of the instruction set in use: Reals one gather loads.
std::size_t gatherLanes();

} // namespace raylife::roofline

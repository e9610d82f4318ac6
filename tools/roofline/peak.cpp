// The ceilings of peak.h, compiled once per instruction set by Highway (foreach_target.h includes this file again
// for each target) and chosen at run time, as render/ray_stream.cpp's kernels are: forceSimdTarget picks both.
#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "roofline/peak.cpp"
#include <hwy/foreach_target.h> // must come before highway.h

#include <hwy/highway.h>

#include "roofline/peak.h"

HWY_BEFORE_NAMESPACE();
namespace raylife::roofline {
namespace HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

using D = hn::ScalableTag<Real>;
using V = hn::Vec<D>;

// Chains of each kind. A multiply or an add waits a few cycles for the one before it in its chain, and a core
// starts more than one of each per cycle, so the chains must be several to keep the pipes busy. 6 + 6 accumulators
// and 3 constants fit the 16 registers of SSE4 and AVX2; 8 + 8 spill there (measured: AVX2 at 2/3 of the rate),
// 4 + 4 are too few (AVX3 at 2/3), and 8 + 8 give AVX3 no more than 6 + 6 within the noise.
constexpr int kChains = 6;

// Per iteration, chain i of the first kind becomes (m_i · f) · g, chain i of the second (a_i + h) − h: two
// multiplies and two adds a chain, the values bounded (f · g ≈ 1, h − h = 0 up to rounding) however long it runs.
// f, g and h come from the caller, so that the compiler cannot work the loop out (with constants it does).
Real MulAddChains(std::size_t iterations, Real fValue, Real gValue, Real hValue)
{
  const D d;
  const V f = hn::Set(d, fValue), g = hn::Set(d, gValue), h = hn::Set(d, hValue);
  V m[kChains], a[kChains];
  for (int i = 0; i < kChains; ++i) {
    m[i] = hn::Set(d, Real(1 + i));
    a[i] = hn::Set(d, Real(i));
  }
  for (std::size_t k = 0; k < iterations; ++k) {
    for (int i = 0; i < kChains; ++i)
      m[i] = hn::Mul(m[i], f);
    for (int i = 0; i < kChains; ++i)
      a[i] = hn::Add(a[i], h);
    for (int i = 0; i < kChains; ++i)
      m[i] = hn::Mul(m[i], g);
    for (int i = 0; i < kChains; ++i)
      a[i] = hn::Sub(a[i], h);
  }
  V sum = hn::Zero(d);
  for (int i = 0; i < kChains; ++i)
    sum = hn::Add(sum, hn::Add(m[i], a[i]));
  return hn::GetLane(hn::SumOfLanes(d, sum));
}

Real FlopsPerIteration() { return Real(4 * kChains * hn::Lanes(D())); }

// Eight partial sums, so that each add waits for the one eight loads before it, not the one before.
Real SumArray(const Real* v, std::size_t n)
{
  const D d;
  const std::size_t lanes = hn::Lanes(d);
  V s[8];
  for (V& x : s)
    x = hn::Zero(d);
  for (std::size_t i = 0; i < n; i += 8 * lanes)
    for (std::size_t j = 0; j < 8; ++j)
      s[j] = hn::Add(s[j], hn::Load(d, v + i + j * lanes));
  for (std::size_t j = 1; j < 8; ++j)
    s[0] = hn::Add(s[0], s[j]);
  return hn::GetLane(hn::SumOfLanes(d, s[0]));
}

// Four partial sums, so that a gather's add waits for the one four gathers before it; the gathers themselves
// depend on nothing but their indices.
Real GatherSum(const Real* table, const GatherIndex* index, std::size_t n)
{
  const D d;
  const hn::RebindToSigned<D> di;
  const std::size_t lanes = hn::Lanes(d);
  V s[4];
  for (V& x : s)
    x = hn::Zero(d);
  for (std::size_t i = 0; i < n; i += 4 * lanes)
    for (std::size_t j = 0; j < 4; ++j)
      s[j] = hn::Add(s[j], hn::GatherIndex(d, table, hn::Load(di, index + i + j * lanes)));
  for (std::size_t j = 1; j < 4; ++j)
    s[0] = hn::Add(s[0], s[j]);
  return hn::GetLane(hn::SumOfLanes(d, s[0]));
}

std::size_t GatherLanes() { return hn::Lanes(D()); }

} // namespace HWY_NAMESPACE
} // namespace raylife::roofline
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace raylife::roofline {

HWY_EXPORT(MulAddChains);
HWY_EXPORT(FlopsPerIteration);
HWY_EXPORT(SumArray);
HWY_EXPORT(GatherSum);
HWY_EXPORT(GatherLanes);

namespace {
// The constants of the chains, read through a volatile: the compiler cannot know them.
volatile Real gF = Real(1.0009765625), gG = Real(1) / Real(1.0009765625), gH = Real(0.5);
} // namespace

Real mulAddChains(std::size_t iterations) { return HWY_DYNAMIC_DISPATCH(MulAddChains)(iterations, gF, gG, gH); }
double flopsPerIteration() { return double(HWY_DYNAMIC_DISPATCH(FlopsPerIteration)()); }
Real sumArray(const Real* v, std::size_t n) { return HWY_DYNAMIC_DISPATCH(SumArray)(v, n); }
Real gatherSum(const Real* table, const GatherIndex* index, std::size_t n)
{
  return HWY_DYNAMIC_DISPATCH(GatherSum)(table, index, n);
}
std::size_t gatherLanes() { return HWY_DYNAMIC_DISPATCH(GatherLanes)(); }

} // namespace raylife::roofline
#endif

#include "geometry/bvh.h"
#include "core/simd.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <thread>
#include <type_traits>

#ifdef __linux__
#include <sys/mman.h> // madvise
#endif

#if RAYLIFE_HAS_AVX2
#include <immintrin.h> // _mm_movemask_ps (SSE, which every x86-64 has) and _mm256_movemask_ps (AVX)
#elif defined(__SSE__)
#include <xmmintrin.h> // _mm_movemask_ps
#endif

namespace raylife {

namespace {

// ---- Bounds ---------------------------------------------------------------------------------------------------

// A sphere's box, widened by kBoxMargin relative to the size of its coordinates (see math.h for why). A moving
// sphere's is the union of its boxes at times 0 and 1: its centre moves along a straight line, so the box holds it
// at every time in the shutter interval.
Bounds3 sphereBounds(const Sphere& s)
{
  auto at = [&s](const Vec3& center) {
    const Real margin = kBoxMargin<Real> * (maxComponent(glm::abs(center)) + s.radius);
    const Vec3 extent(s.radius + margin);
    return Bounds3{center - extent, center + extent};
  };
  return s.moving() ? at(s.center).merged(at(s.center + s.velocity)) : at(s.center);
}

// The float at or below x (and at or above, for roundUp): a float box rounded outwards holds the exact box.
float roundDown(Real x)
{
  constexpr Real kFloatMax = Real(std::numeric_limits<float>::max());
  if (x > kFloatMax)
    return std::numeric_limits<float>::max();
  if (x < -kFloatMax)
    return -std::numeric_limits<float>::infinity();
  const float f = float(x);
  if (!(Real(f) > x))
    return f;
  // The float just below f, which is finite and above −FLT_MAX: one step of its bits, away from 0 for a negative f
  // and towards it for a positive one (std::nextafter's answer, without its call: 4 % of the build's instructions in
  // callgrind).
  if (f == 0)
    return -std::numeric_limits<float>::denorm_min();
  const auto bits = std::bit_cast<std::uint32_t>(f);
  return std::bit_cast<float>(f > 0 ? bits - 1 : bits + 1);
}

float roundUp(Real x) { return -roundDown(-x); }

// A triangle's box, widened as a sphere's is: by kBoxMargin relative to the size of its coordinates.
Bounds3 triangleBounds(const Vec3& p0, const Vec3& p1, const Vec3& p2)
{
  const Bounds3 exact = Bounds3{p0, p0}.merged(p1).merged(p2);
  const Real size = std::max(maxComponent(glm::abs(exact.lo)), maxComponent(glm::abs(exact.hi)));
  const Vec3 margin(kBoxMargin<Real> * size);
  return Bounds3{exact.lo - margin, exact.hi + margin};
}

// ---- Lanes: four or eight boxes at a time ---------------------------------------------------------------------

// Four or eight floats, and as many lanes' yes (all bits set) or no: GCC's vector extensions, which clang builds
// too, so that the box test reads as arithmetic on one float. Four are one SSE register, the x86-64 baseline
// (elsewhere, whatever the target has); eight are one AVX register, used where the CPU has AVX2 (simd.h), so a
// node's eight boxes are tested by one instruction per step instead of two.
typedef float Float4 __attribute__((vector_size(16)));
typedef std::int32_t Mask4 __attribute__((vector_size(16)));
typedef float Float8 __attribute__((vector_size(32)));
typedef std::int32_t Mask8 __attribute__((vector_size(32)));
typedef double Double4 __attribute__((vector_size(32)));
typedef std::int64_t Mask64x4 __attribute__((vector_size(32)));
static_assert(BvhWideNode::kWidth % 8 == 0 && BvhWideNode::kWidth < 32, "a node's boxes: whole eights, one bit each");

// Lane k's answer as bit k. (By reference, as simd.h asks of eight lanes.)
unsigned bitMask(const Mask4& m)
{
#if defined(__SSE__)
  return unsigned(_mm_movemask_ps(__m128(m)));
#else
  return unsigned((m[0] & 1) | (m[1] & 2) | (m[2] & 4) | (m[3] & 8));
#endif
}
#if RAYLIFE_HAS_AVX2
RAYLIFE_AVX2 unsigned bitMask(const Mask8& m) { return unsigned(_mm256_movemask_ps(__m256(m))); }
#endif
#if RAYLIFE_HAS_AVX2 && !defined(RAYLIFE_REAL_IS_FLOAT)
// Four 64-bit lanes' answers, for the eight-lane walk only (AVX).
RAYLIFE_AVX2 unsigned bitMaskEight(const Mask64x4& m) { return unsigned(_mm256_movemask_pd(__m256d(m))); }
#endif

// ---- Building -------------------------------------------------------------------------------------------------

// Fewest indices a share of parallelFor's work has (fewer are not worth a thread's start).
constexpr std::size_t kMinShare = 4096;
// Fewest binary nodes whose collapse is worth a thread of its own (some 32,000: a third of a millisecond's work,
// from 15 ms for a million triangles' 1.3 million nodes).
constexpr std::size_t kCollapseAsideMin = std::size_t(1) << 15;

// How many shares parallelFor cuts [0, n) into on up to `threads` threads.
std::size_t shareCount(std::size_t n, int threads)
{
  return std::clamp<std::size_t>(n / kMinShare, 1, std::size_t(std::max(threads, 1)));
}
// Calls work(share, first, last) for share k of shareCount(n, threads): consecutive shares [first, last) of [0, n),
// on up to `threads` threads, this one among them, and returns when all are done.
template <class Work> void parallelShares(std::size_t n, int threads, const Work& work)
{
  const std::size_t shares = shareCount(n, threads);
  std::vector<std::thread> workers;
  for (std::size_t k = 1; k < shares; ++k)
    workers.emplace_back([&work, n, k, shares] { work(k, n * k / shares, n * (k + 1) / shares); });
  work(std::size_t(0), std::size_t(0), n / shares);
  for (std::thread& worker : workers)
    worker.join();
}
// The same, calling work(first, last). For work whose every index writes only its own places: then the result is
// the same whatever the number of threads.
template <class Work> void parallelFor(std::size_t n, int threads, const Work& work)
{
  parallelShares(n, threads, [&work](std::size_t, std::size_t first, std::size_t last) { work(first, last); });
}

// Asks Linux to back the room `v` has reserved with 2 MB pages where it can (the whole 2 MB pages inside it), before
// anything is written there. The build writes some 200 MB for a million triangles (its items, nodes and packs, each
// array written once); each 4 KB page's first write is a page fault, and in a virtual machine those 50,000 faults
// were a third of the build's time (perf). Advice only: the same bytes either way, nothing elsewhere.
// releasePages: the same whole 2 MB pages of a temporary array handed back just before it is freed (its contents are
// never read again). A freed block that malloc keeps for later (in a thread's arena, or below the top of its heap)
// stayed resident, in 2 MB pages: 16 MB more held after a million triangles' build, 7 MB with this.
template <class T> void advisePages([[maybe_unused]] const std::vector<T>& v, [[maybe_unused]] int advice)
{
#ifdef __linux__
  constexpr std::uintptr_t kHuge = std::uintptr_t(2) << 20;
  const auto first = reinterpret_cast<std::uintptr_t>(v.data());
  const std::uintptr_t lo = (first + kHuge - 1) & ~(kHuge - 1), hi = (first + v.capacity() * sizeof(T)) & ~(kHuge - 1);
  if (hi > lo)
    madvise(reinterpret_cast<void*>(lo), hi - lo, advice);
#endif
}
#ifdef __linux__
template <class T> void adviseHugePages(const std::vector<T>& v) { advisePages(v, MADV_HUGEPAGE); }
template <class T> void releasePages(const std::vector<T>& v) { advisePages(v, MADV_DONTNEED); }
#else
template <class T> void adviseHugePages(const std::vector<T>&) {}
template <class T> void releasePages(const std::vector<T>&) {}
#endif

// A primitive while the tree is built: its box in floats, rounded outwards from the scene's scalar (roundDown,
// roundUp), and its number (spheres first, then triangles). Why float: the nodes' boxes are float anyway, and
// rounding outwards keeps order, so the float box of a union of boxes is the union of their float boxes: the nodes
// come out the same as from boxes in the scene's scalar. And the items are 32 bytes where they were 56 in double,
// for the passes over a million of them that do not fit in the cache, and binned four lanes at a time.
struct BuildItem {
  float lo[3];
  std::int32_t index;
  float hi[3];
  std::int32_t unused = 0;
};
static_assert(sizeof(BuildItem) == 32, "two build items to a cache line");

BuildItem buildItem(const Bounds3& b, int index)
{
  return BuildItem{{roundDown(b.lo.x), roundDown(b.lo.y), roundDown(b.lo.z)},
                   index,
                   {roundUp(b.hi.x), roundUp(b.hi.y), roundUp(b.hi.z)}};
}

constexpr float kLargestFloat = std::numeric_limits<float>::max();
constexpr float kInfinityF = std::numeric_limits<float>::infinity();
constexpr Float4 kEmptyLo = {kInfinityF, kInfinityF, kInfinityF, 0}, kEmptyHi = -kEmptyLo;

// An item's corners as lanes x, y, z (lane 3 is 0: the index's bits masked off, as a float they would be a
// subnormal, which some CPUs take a hundred cycles to multiply).
Float4 lower(const BuildItem& item)
{
  Float4 v;
  std::memcpy(&v, item.lo, sizeof v);
  return (Float4)((Mask4)v & Mask4{-1, -1, -1, 0});
}
Float4 upper(const BuildItem& item)
{
  Float4 v;
  std::memcpy(&v, item.hi, sizeof v); // (`unused`, 0, is lane 3)
  return v;
}
// Lane by lane, a < b ? a : b, and a > b ? a : b (SSE's minps and maxps, which GCC does not always find in them).
Float4 minLanes(Float4 a, Float4 b)
{
#if defined(__SSE__)
  return Float4(_mm_min_ps(__m128(a), __m128(b)));
#else
  return a < b ? a : b;
#endif
}
Float4 maxLanes(Float4 a, Float4 b)
{
#if defined(__SSE__)
  return Float4(_mm_max_ps(__m128(a), __m128(b)));
#else
  return a > b ? a : b;
#endif
}

// The centre of an item's box, where the splits sort it. A side beyond the largest float (a scene may place things
// up to 10^308, whose float box is infinite there) counts as the largest float, so that every centre is finite and
// the bins' arithmetic sees no NaN.
Float4 center(Float4 lo, Float4 hi)
{
  const Float4 most = {kLargestFloat, kLargestFloat, kLargestFloat, 0};
  return maxLanes(-most, lo) * 0.5f + minLanes(most, hi) * 0.5f;
}

// A box of float lanes in the scene's scalar (exactly: every float is one).
Bounds3 toBounds(Float4 lo, Float4 hi) { return Bounds3{Vec3(lo[0], lo[1], lo[2]), Vec3(hi[0], hi[1], hi[2])}; }

// What a node's items add up to: the box of their boxes, the box of their centres, and which kinds they are.
struct ItemsInfo {
  Float4 lo = kEmptyLo, hi = kEmptyHi;
  Float4 centerLo = kEmptyLo, centerHi = kEmptyHi;
  bool anySphere = false, anyTriangle = false;

  void add(const BuildItem& item, int spheres)
  {
    const Float4 l = lower(item), h = upper(item);
    add(l, h, center(l, h), item.index < spheres);
  }
  // An item's box l–h, its centre c, and whether it is a sphere.
  void add(Float4 l, Float4 h, Float4 c, bool sphere)
  {
    lo = minLanes(lo, l);
    hi = maxLanes(hi, h);
    centerLo = minLanes(centerLo, c);
    centerHi = maxLanes(centerHi, c);
    anySphere |= sphere;
    anyTriangle |= !sphere;
  }
  void add(const ItemsInfo& o)
  {
    lo = minLanes(lo, o.lo);
    hi = maxLanes(hi, o.hi);
    centerLo = minLanes(centerLo, o.centerLo);
    centerHi = maxLanes(centerHi, o.centerHi);
    anySphere |= o.anySphere;
    anyTriangle |= o.anyTriangle;
  }
  // Half the surface area of the items' box, as the SAH's sweeps measure their sides.
  double halfArea() const { return double(toBounds(lo, hi).surfaceArea()) / 2; }
};

// Items [begin, end) added up, in one pass (min and max: the same whatever the order, so on any number of threads).
ItemsInfo summarize(const std::vector<BuildItem>& items, std::size_t begin, std::size_t end, int spheres)
{
  ItemsInfo info;
  for (std::size_t i = begin; i < end; ++i)
    info.add(items[i], spheres);
  return info;
}
// All the items, on up to `threads` threads (each adds up its share; then the shares are added up).
ItemsInfo summarize(const std::vector<BuildItem>& items, int spheres, int threads)
{
  std::vector<ItemsInfo> shares(shareCount(items.size(), threads));
  parallelShares(items.size(), threads, [&](std::size_t k, std::size_t first, std::size_t last) {
    shares[k] = summarize(items, first, last, spheres);
  });
  for (std::size_t k = 1; k < shares.size(); ++k)
    shares[0].add(shares[k]);
  return shares[0];
}

// Where to split a node's items [begin, end): items [begin, mid) go to the first child, [mid, end) to the second;
// and what each side's items add up to.
struct Split {
  std::size_t mid;
  ItemsInfo first, second;
};

// A built node's surface area, in scene units².
Real nodeArea(const BvhNode& n) { return Bounds3{Vec3(n.bounds[0]), Vec3(n.bounds[1])}.surfaceArea(); }

int ceilLog2(std::size_t n) { return n <= 1 ? 0 : int(std::bit_width(n - 1)); }

int longestAxis(const Bounds3& b)
{
  const Vec3 d = b.hi - b.lo;
  return d.x >= d.y && d.x >= d.z ? 0 : (d.y >= d.z ? 1 : 2);
}

constexpr int kMaxBins = 64;

// The three axes' bins of a centre, over bins from `origin` on, `scale` bins per scene unit, `bins` of them (lane
// 3: 0). (Clamped in float, then truncated: no overflow converting a far centre. A centre is finite and the scale
// positive or 0, so no lane is NaN, but a difference beyond the largest float is +∞, which clamps to the last.)
Mask4 binsOf(Float4 center, Float4 origin, Float4 scale, int bins)
{
  const float last = float(bins - 1);
  const Float4 at = minLanes(maxLanes((center - origin) * scale, Float4{}), Float4{last, last, last, last});
  return __builtin_convertvector(at, Mask4);
}

// The SAH's bins over a node's items: on each axis, how many centres fall in each bin (one axis to a lane), and the
// box of their primitives (an empty box for none).
struct Bins {
  std::array<Mask4, kMaxBins> count;                  // [bin][axis]
  std::array<std::array<Float4, 3>, kMaxBins> lo, hi; // [bin][axis]

  // Bins 0 to bins − 1 emptied. (Only those: emptied whole, all kMaxBins of them at every node, they were a fifth
  // of the SAH's time on a mesh of a million triangles, whose nodes are mostly small.)
  void clear(int bins)
  {
    for (std::size_t b = 0; b < std::size_t(bins); ++b) {
      count[b] = Mask4{};
      lo[b] = {kEmptyLo, kEmptyLo, kEmptyLo};
      hi[b] = {kEmptyHi, kEmptyHi, kEmptyHi};
    }
  }
  // Items [begin, end) sorted in, on the three axes at once (binsOf).
  void add(const std::vector<BuildItem>& items, std::size_t begin, std::size_t end, Float4 origin, Float4 scale,
           int bins)
  {
    for (std::size_t i = begin; i < end; ++i) {
      const Float4 l = lower(items[i]), h = upper(items[i]);
      const Mask4 b = binsOf(center(l, h), origin, scale, bins);
      for (std::size_t axis = 0; axis < 3; ++axis) {
        const auto at = std::size_t(b[axis]);
        ++count[at][axis];
        lo[at][axis] = minLanes(lo[at][axis], l);
        hi[at][axis] = maxLanes(hi[at][axis], h);
      }
    }
  }
  // Another's bins 0 to bins − 1 added in (sums and unions: the same whatever the order).
  void add(const Bins& o, int bins)
  {
    for (std::size_t b = 0; b < std::size_t(bins); ++b) {
      count[b] += o.count[b];
      for (std::size_t axis = 0; axis < 3; ++axis) {
        lo[b][axis] = minLanes(lo[b][axis], o.lo[b][axis]);
        hi[b][axis] = maxLanes(hi[b][axis], o.hi[b][axis]);
      }
    }
  }
};

class Builder {
public:
  // Subtrees a thread: the root's builder is given this many for each thread, so that a lopsided split near the
  // root leaves no core idle for long.
  static constexpr int kSubtreesPerThread = 4;

  // `spheres`: items numbered below it are spheres, the others triangles. `threads`: how many may build at once
  // (≥ 1). The items are the caller's, rearranged in place.
  Builder(std::vector<BuildItem>& items, int spheres, const BvhBuildOptions& options, int threads)
      : items_(items), spheres_(spheres), options_(options), threads_(std::max(threads, 1)),
        packPriced_(items.size() - std::size_t(spheres) >= std::size_t(options.packPricedFrom))
  {
    options_.bins = std::clamp(options_.bins, 2, kMaxBins);
    options_.maxLeafSize = std::clamp(options_.maxLeafSize, 1, 255);
    options_.maxTriangleLeafSize = std::clamp(options_.maxTriangleLeafSize, 1, 255);
    options_.packPricedBelowArea = std::clamp(options_.packPricedBelowArea, 0.0, 1.0); // (a NaN stays NaN: none)
  }

  std::vector<BvhNode> nodes;
  int depth = 0;

  // Builds the subtree over items [begin, end) at `level` (root 1), appending its nodes depth first. `info`: what
  // the items add up to (summarize), which the split that made them works out on its way.
  void build(std::size_t begin, std::size_t end, int level, const ItemsInfo& info)
  {
    const std::size_t nodeIndex = nodes.size();
    nodes.push_back(BvhNode{});
    depth = std::max(depth, level);
    if (level == 1) // (before any subtree is handed to a thread)
      packPricedArea_ = info.halfArea() * options_.packPricedBelowArea;
    for (int a = 0; a < 3; ++a) {
      nodes[nodeIndex].bounds[0][a] = info.lo[a];
      nodes[nodeIndex].bounds[1][a] = info.hi[a];
    }

    std::optional<Split> split = chooseSplit(begin, end, info, level);
    if (!split && info.anySphere && info.anyTriangle)
      split = byKind(begin, end); // a leaf holds one kind of primitive: split a mixed one, spheres first
    if (!split) {
      // A leaf: its primitives are items [begin, end), which is where they stay in the final order.
      nodes[nodeIndex].offset = std::uint32_t(begin);
      nodes[nodeIndex].count = std::uint16_t(end - begin);
      return;
    }
    // An interior node: the first child follows it, the second comes after the first's whole subtree.
    nodes[nodeIndex].count = 0;
    if (threads_ > 1 && end - begin >= kParallelMin) {
      nodes[nodeIndex].offset = buildInParallel(begin, *split, end, level + 1);
      return;
    }
    build(begin, split->mid, level + 1, split->first);
    const std::size_t second = nodes.size();
    build(split->mid, end, level + 1, split->second);
    nodes[nodeIndex].offset = std::uint32_t(second);
  }

private:
  // Fewest items whose two halves are worth building on two threads (a thread's start costs some 20 µs, the
  // subtree of 4096 triangles about a millisecond).
  static constexpr std::size_t kParallelMin = 4096;
  // Fewest items a node bins on more than one core (a share is then half a millisecond or more of work).
  static constexpr std::size_t kParallelBinsMin = std::size_t(1) << 16;

  /// [parallel]
  // The two children's subtrees over [begin, mid) and [mid, end): the first built here, as the serial build would,
  // while a builder of its own builds the second on a new thread (the threads shared out between them); then the
  // second's nodes are appended after the first's, their children's indices shifted by where they land. The halves'
  // items are disjoint ranges of the one array, and every split depends on its own range only, so the tree is the
  // serial build's, node for node, whatever the number of threads.
  // Returns the index of the second child.
  std::uint32_t buildInParallel(std::size_t begin, const Split& split, std::size_t end, int level)
  {
    Builder second(items_, spheres_, options_, threads_ - threads_ / 2);
    second.packPricedArea_ = packPricedArea_; // (the root's, which its builder set)
    // (Its room reserved at once, as the root's is: grown by doubling, the copies left behind stayed in the
    // thread's heap after the build, 40 MB of a million triangles'.)
    second.nodes.reserve(2 * (end - split.mid) - 1);
    adviseHugePages(second.nodes);
    std::thread worker([&] { second.build(split.mid, end, level, split.second); });
    const int threads = threads_;
    threads_ /= 2;
    build(begin, split.mid, level, split.first);
    threads_ = threads;
    worker.join();
    const auto base = std::uint32_t(nodes.size());
    for (BvhNode n : second.nodes) {
      if (n.count == 0)
        n.offset += base;
      nodes.push_back(n);
    }
    depth = std::max(depth, second.depth);
    releasePages(second.nodes);
    return base;
  }
  /// [parallel]

  // A split at `mid` of items that some rearrangement has just put there, each side added up in a pass.
  Split summarized(std::size_t begin, std::size_t mid, std::size_t end) const
  {
    return Split{mid, summarize(items_, begin, mid, spheres_), summarize(items_, mid, end, spheres_)};
  }

  // Items [begin, end) split into their spheres and their triangles, or nothing when they are all of one kind.
  std::optional<Split> byKind(std::size_t begin, std::size_t end)
  {
    const auto first = items_.begin() + std::ptrdiff_t(begin), last = items_.begin() + std::ptrdiff_t(end);
    const auto midIt =
        std::stable_partition(first, last, [this](const BuildItem& item) { return item.index < spheres_; });
    const std::size_t mid = std::size_t(midIt - items_.begin());
    if (mid == begin || mid == end)
      return std::nullopt;
    return summarized(begin, mid, end);
  }

  std::optional<Split> chooseSplit(std::size_t begin, std::size_t end, const ItemsInfo& info, int level)
  {
    const std::size_t n = end - begin;
    if (n == 1)
      return std::nullopt;
    const Bounds3 centers = toBounds(info.centerLo, info.centerHi);
    // Near the depth limit, halve by count: that reaches single spheres in ceil(log2 n) more levels.
    if (level + ceilLog2(n) + 1 >= Bvh::kMaxDepth)
      return equalCounts(begin, end, longestAxis(centers));
    if (options_.split == BvhSplit::Midpoint)
      return midpoint(begin, end, centers);
    return sah(begin, end, info);
  }

  // Halves the items by count along `axis` (centre order, then index, so the result is fully determined).
  Split equalCounts(std::size_t begin, std::size_t end, int axis)
  {
    const std::size_t mid = begin + (end - begin) / 2;
    std::nth_element(items_.begin() + std::ptrdiff_t(begin), items_.begin() + std::ptrdiff_t(mid),
                     items_.begin() + std::ptrdiff_t(end), [axis](const BuildItem& a, const BuildItem& b) {
                       const float ca = center(lower(a), upper(a))[axis], cb = center(lower(b), upper(b))[axis];
                       return ca < cb || (ca == cb && a.index < b.index);
                     });
    return summarized(begin, mid, end);
  }

  // The bad split, for comparison: the middle of the centres' longest axis, whatever it costs.
  std::optional<Split> midpoint(std::size_t begin, std::size_t end, const Bounds3& centers)
  {
    if (end - begin <= std::size_t(options_.maxLeafSize))
      return std::nullopt;
    const int axis = longestAxis(centers);
    const Real middle = (centers.lo[axis] + centers.hi[axis]) / 2;
    const auto midIt =
        std::partition(items_.begin() + std::ptrdiff_t(begin), items_.begin() + std::ptrdiff_t(end),
                       [&](const BuildItem& item) { return Real(center(lower(item), upper(item))[axis]) < middle; });
    const std::size_t mid = std::size_t(midIt - items_.begin());
    if (mid == begin || mid == end) // every centre on one side (all equal): split by count instead
      return equalCounts(begin, end, axis);
    return summarized(begin, mid, end);
  }

  // Half the surface areas of three boxes of float lanes (lo[a], hi[a]: one box each), into lanes 0–2 of `out`
  // (lane 3: 0), in scene units²; 0 for an empty box. In double, for boxes whose areas may be beyond float's range;
  // in float, for the rest (the three differences turned on their side, so that one product serves all three).
  // (Written into `out`, not returned: a vector of four doubles is returned in memory without AVX.)
  static void halfAreas(const Float4 (&lo)[3], const Float4 (&hi)[3], Double4& out)
  {
    out = Double4{};
    for (int a = 0; a < 3; ++a) {
      Double4 d = __builtin_convertvector(hi[a], Double4) - __builtin_convertvector(lo[a], Double4);
      d = d > 0 ? d : Double4{}; // (an empty box: −∞ − ∞, taken as 0)
      out[a] = d[0] * (d[1] + d[2]) + d[1] * d[2];
    }
  }
  static void halfAreas(const Float4 (&lo)[3], const Float4 (&hi)[3], Float4& out)
  {
    Float4 d[3];
    for (int a = 0; a < 3; ++a)
      d[a] = maxLanes(hi[a] - lo[a], Float4{}); // (an empty box: −∞ − ∞, taken as 0)
    const Float4 zero{};
    const Float4 xy01 = __builtin_shufflevector(d[0], d[1], 0, 4, 1, 5);
    const Float4 xy2 = __builtin_shufflevector(d[2], zero, 0, 4, 1, 5);
    const Float4 zw01 = __builtin_shufflevector(d[0], d[1], 2, 6, 3, 7);
    const Float4 zw2 = __builtin_shufflevector(d[2], zero, 2, 6, 3, 7);
    const Float4 x = __builtin_shufflevector(xy01, xy2, 0, 1, 4, 5), y = __builtin_shufflevector(xy01, xy2, 2, 3, 6, 7);
    const Float4 z = __builtin_shufflevector(zw01, zw2, 0, 1, 4, 5);
    out = x * (y + z) + y * z;
  }

  /// [sweep]
  // sah's sweeps over its bins (bins_): the three axes side by side, one to a lane of V (four floats or four
  // doubles). From the right, the area and count of everything right of each boundary (bins 1 to bins − 1 are
  // written before they are read); then from the left, each boundary priced (left: bins 0..b, right: bins b+1..),
  // counting tests by packs of four when `byPacks`. Leaves in bestSum, bestAxis and bestBin the cheapest boundary,
  // A_L·N_L + A_R·N_R, if one is cheaper than bestSum: the first of equals, axis by axis, bin by bin (a boundary
  // after an empty bin splits the items as the one before it does, at the same price).
  template <class V> void sweep(int bins, bool byPacks, double& bestSum, int& bestAxis, int& bestBin) const
  {
    using Mask = decltype(V{} < V{});
    std::array<V, kMaxBins> rightArea;
    std::array<Mask4, kMaxBins> rightCount;
    Float4 sideLo[3] = {kEmptyLo, kEmptyLo, kEmptyLo}, sideHi[3] = {kEmptyHi, kEmptyHi, kEmptyHi};
    Mask4 sideCount{};
    for (std::size_t b = std::size_t(bins) - 1; b > 0; --b) {
      for (std::size_t axis = 0; axis < 3; ++axis) {
        sideLo[axis] = minLanes(sideLo[axis], bins_.lo[b][axis]);
        sideHi[axis] = maxLanes(sideHi[axis], bins_.hi[b][axis]);
      }
      sideCount += bins_.count[b];
      halfAreas(sideLo, sideHi, rightArea[b]);
      rightCount[b] = sideCount;
    }
    V best = std::numeric_limits<float>::infinity() - V{}, bestAt{}; // per axis: the cheapest sum, and its bin
    std::fill_n(sideLo, 3, kEmptyLo);
    std::fill_n(sideHi, 3, kEmptyHi);
    sideCount = Mask4{};
    for (std::size_t b = 0; b + 1 < std::size_t(bins); ++b) {
      for (std::size_t axis = 0; axis < 3; ++axis) {
        sideLo[axis] = minLanes(sideLo[axis], bins_.lo[b][axis]);
        sideHi[axis] = maxLanes(sideHi[axis], bins_.hi[b][axis]);
      }
      sideCount += bins_.count[b];
      V leftArea;
      halfAreas(sideLo, sideHi, leftArea);
      const Mask4 testsLeft = byPacks ? (sideCount + 3) >> 2 : sideCount;
      const Mask4 testsRight = byPacks ? (rightCount[b + 1] + 3) >> 2 : rightCount[b + 1];
      const V sum = leftArea * __builtin_convertvector(testsLeft, V) +
                    rightArea[b + 1] * __builtin_convertvector(testsRight, V);
      const Mask apart = __builtin_convertvector((sideCount > 0) & (rightCount[b + 1] > 0), Mask);
      const Mask cheaper = (sum < best) & apart;
      best = cheaper ? sum : best;
      bestAt = cheaper ? float(b) - V{} : bestAt;
    }
    for (int axis = 0; axis < 3; ++axis)
      if (double(best[axis]) < bestSum) {
        bestSum = double(best[axis]);
        bestAxis = axis;
        bestBin = int(bestAt[axis]);
      }
  }
  /// [sweep]

  /// [sah]
  // The surface area heuristic. A ray that hits a node's box hits a child's box with probability about
  // A_child / A_node (for rays from all directions), so splitting into L and R costs, per ray,
  //   C = C_trav + (A_L / A)·N_L·C_isect + (A_R / A)·N_R·C_isect,
  // against N·C_isect for keeping the node a leaf. The centres are sorted into a few bins per axis, and every
  // boundary between bins is priced; the cheapest wins.
  // Triangles are tested four at a time, a pack at a time: in a big tree (BvhBuildOptions::packPricedFrom), and in a
  // small one a node small against the root (packPricedBelowArea), N counts a node of triangles' packs of four,
  // ⌈N/4⌉, so that the SAH makes leaves of full packs where it can.
  std::optional<Split> sah(std::size_t begin, std::size_t end, const ItemsInfo& info)
  {
    const std::size_t n = end - begin;
    const BvhCosts costs;
    const int bins = options_.bins;
    const double nodeArea = info.halfArea();
    const bool triangles = !info.anySphere;
    const bool byPacks = triangles && (packPriced_ || nodeArea < packPricedArea_);
    const Real leafCost = Real(byPacks ? (n + 3) / 4 : n) * costs.intersection;
    const std::size_t maxLeaf = std::size_t(triangles ? options_.maxTriangleLeafSize : options_.maxLeafSize);

    // A node of triangles that fits one pack is a leaf, as in Embree (whose BVH8 over packs of four triangles leaves
    // any node of four or fewer unsplit). Splitting it would pay only where its two sides' areas add up to under
    // half its own (1 + 2·(A_L + A_R)/A < 2), which is rare: on a million triangles the SAH cost went from 63.4775
    // to 63.4848 (0.01 %), the work per ray did not change, and these nodes, half the binary tree's, had taken a
    // fifth of the SAH's time, in sweeps over mostly empty bins.
    if (byPacks && n <= std::min<std::size_t>(4, maxLeaf))
      return std::nullopt;

    // The cheapest boundary: on `bestAxis`, after bin `bestBin`, at A_L·N_L + A_R·N_R = bestSum.
    double bestSum = std::numeric_limits<double>::infinity();
    int bestAxis = -1, bestBin = -1;
    // Per axis, a centre c's bin is (c − origin)·scale, clamped to [0, bins − 1] and truncated. An axis that
    // cannot be split keeps origin 0 and scale 0: its items all fall in bin 0, where no boundary separates any.
    Float4 origin{}, scale{};
    if (nodeArea > 0 && nodeArea < std::numeric_limits<double>::infinity()) {
      for (int axis = 0; axis < 3; ++axis) {
        // (Every centre in one plane across an axis: nothing to split there. And a spread so small that
        // bins / spread overflows a float is as good as none.)
        const Real spread = Real(info.centerHi[axis]) - Real(info.centerLo[axis]);
        const float s = float(Real(bins) / spread);
        if (spread > 0 && std::isfinite(s) && s > 0) {
          origin[axis] = info.centerLo[axis];
          scale[axis] = s;
        }
      }
      // Sort the centres into bins on the three axes at once, in one pass over the items (which for a million
      // triangles do not fit in the cache). A node near the root, on every core its builder has: each bins its
      // share, and the shares' bins are added up (the same bins whatever the number of shares).
      const int cores = threads_ / kSubtreesPerThread;
      bins_.clear(bins);
      if (cores > 1 && n >= kParallelBinsMin) {
        std::vector<Bins> shares(shareCount(n, cores));
        parallelShares(n, cores, [&](std::size_t k, std::size_t first, std::size_t last) {
          shares[k].clear(bins);
          shares[k].add(items_, begin + first, begin + last, origin, scale, bins);
        });
        for (const Bins& share : shares)
          bins_.add(share, bins);
      } else {
        bins_.add(items_, begin, end, origin, scale, bins);
      }
      // The sweeps, in float where every sum they form is well inside float's range (a node under 2^46 scene
      // units across: its sums are at most 2·3·(2^46)²·n), and above 2^−40 across (so that its areas are not lost
      // to underflow); in double elsewhere.
      const Double4 extent = __builtin_convertvector(info.hi, Double4) - __builtin_convertvector(info.lo, Double4);
      const double widest = std::max({extent[0], extent[1], extent[2]});
      if (widest < 0x1p46 && widest > 0x1p-40)
        sweep<Float4>(bins, byPacks, bestSum, bestAxis, bestBin);
      else
        sweep<Double4>(bins, byPacks, bestSum, bestAxis, bestBin);
    }

    // Keep a leaf when no split pays for itself (and the leaf is small enough).
    const Real bestCost = costs.traversal + Real(bestSum / nodeArea) * costs.intersection;
    if (n <= maxLeaf && !(bestCost < leafCost))
      return std::nullopt;
    if (bestAxis < 0) // no boundary separates any centres: split by count
      return equalCounts(begin, end, longestAxis(toBounds(info.centerLo, info.centerHi)));
    Split split = partition(begin, end, origin, scale, bestAxis, bestBin);
    if (split.mid == begin || split.mid == end) // (never, as the bins were counted: but never an empty child)
      return equalCounts(begin, end, bestAxis);
    return split;
  }
  /// [sah]

  // Items [begin, end) rearranged: those whose centre's bin on `axis` is at most `lastBin` first, and each side added
  // up on the way (the pass that moves them reads them anyway).
  Split partition(std::size_t begin, std::size_t end, Float4 origin, Float4 scale, int axis, int lastBin)
  {
    Split split{};
    // An item goes first when its bin is at most lastBin, that is when (c − origin)·scale < lastBin + 1 (before
    // binsOf's clamps: lastBin + 1 ≤ bins − 1, and truncating a y ≥ 0 gives at most lastBin just when
    // y < lastBin + 1). The same product as binsOf's, so the same side as the bins counted it on.
    const float bound = float(lastBin + 1);
    const Float4 below = {bound, bound, bound, bound};
    struct Seen {
      Float4 lo, hi, center;
      bool first;
    };
    auto see = [&](const BuildItem& item) {
      Seen seen{lower(item), upper(item), {}, false};
      seen.center = center(seen.lo, seen.hi);
      seen.first = (bitMask((seen.center - origin) * scale < below) >> axis) & 1;
      return seen;
    };
    std::size_t i = begin, j = end;
    while (true) {
      Seen atI{}, atJ{}; // item i, and item j − 1, as last seen
      while (i < j && (atI = see(items_[i])).first) {
        split.first.add(atI.lo, atI.hi, atI.center, items_[i].index < spheres_);
        ++i;
      }
      while (i < j && !(atJ = see(items_[j - 1])).first) {
        split.second.add(atJ.lo, atJ.hi, atJ.center, items_[j - 1].index < spheres_);
        --j;
      }
      if (i == j)
        break;
      // Item i goes second and item j − 1 first: swapped, each now on its own side.
      std::swap(items_[i], items_[j - 1]);
      split.first.add(atJ.lo, atJ.hi, atJ.center, items_[i].index < spheres_);
      split.second.add(atI.lo, atI.hi, atI.center, items_[j - 1].index < spheres_);
      ++i;
      --j;
    }
    split.mid = i;
    return split;
  }

  std::vector<BuildItem>& items_;
  int spheres_;
  BvhBuildOptions options_;
  int threads_;
  bool packPriced_; // the tree has BvhBuildOptions::packPricedFrom triangles or more
  // Below this half surface area (ItemsInfo::halfArea), a node of triangles is priced by its packs
  // (BvhBuildOptions::packPricedBelowArea times the root's; set by the root's build).
  double packPricedArea_ = 0;
  // sah's bins (the builder's, so as not to make them afresh at every node).
  Bins bins_;
};

// ---- Huge primitives -----------------------------------------------------------------------------------------

/// [outside]
// The primitives to keep out of the tree (Bvh::outsidePrimitives), by number, increasing. Rank the kMaxOutside
// biggest boxes by surface area (the lower number first on a tie); the box of everything ranked after rank j is
// rest(j). Take the deepest rank j whose box has at least kHugeAreaRatio times rest(j)'s area and overlaps it:
// ranks 1..j go out (each is at least as big as rank j, and the tree keeps only rest(j)). At most a quarter of the
// primitives go out (each costs every ray a test, and a tree over a handful costs little anyway).
std::vector<int> chooseOutside(const std::vector<BuildItem>& items)
{
  const std::size_t n = items.size();
  const std::size_t k = std::min<std::size_t>(std::size_t(kMaxOutside), n / 4);
  if (k == 0)
    return {};
  // The k biggest, biggest first, in one pass (a million triangles: no sort, no copy).
  struct Ranked {
    Real area;
    std::size_t item;
  };
  std::vector<Ranked> top;
  top.reserve(k + 1);
  for (std::size_t i = 0; i < n; ++i) {
    const Real area = toBounds(lower(items[i]), upper(items[i])).surfaceArea();
    if (top.size() == k && !(area > top.back().area))
      continue;
    std::size_t at = top.size();
    while (at > 0 && area > top[at - 1].area)
      --at;
    top.insert(top.begin() + std::ptrdiff_t(at), Ranked{area, i});
    if (top.size() > k)
      top.pop_back();
  }
  // rest(k): everything but the ranked; then rest(j − 1) = rest(j) and rank j.
  std::vector<char> ranked(n, 0);
  for (const Ranked& r : top)
    ranked[r.item] = 1;
  Float4 restLo = kEmptyLo, restHi = kEmptyHi;
  for (std::size_t i = 0; i < n; ++i)
    if (!ranked[i]) {
      restLo = minLanes(restLo, lower(items[i]));
      restHi = maxLanes(restHi, upper(items[i]));
    }
  Bounds3 rest = toBounds(restLo, restHi);
  std::size_t out = 0;
  for (std::size_t j = top.size(); j >= 1; --j) {
    const BuildItem& item = items[top[j - 1].item];
    const Bounds3 box = toBounds(lower(item), upper(item));
    const bool empty = box.lo.x > rest.hi.x || box.lo.y > rest.hi.y || box.lo.z > rest.hi.z || rest.lo.x > box.hi.x ||
                       rest.lo.y > box.hi.y || rest.lo.z > box.hi.z; // the two boxes do not overlap
    if (top[j - 1].area >= kHugeAreaRatio * rest.surfaceArea() && !empty) {
      out = j;
      break;
    }
    rest = rest.merged(box);
  }
  std::vector<int> numbers;
  for (std::size_t j = 0; j < out; ++j)
    numbers.push_back(items[top[j].item].index);
  std::sort(numbers.begin(), numbers.end());
  return numbers;
}
/// [outside]

// ---- The box test ---------------------------------------------------------------------------------------------

// Floats on either side of x, for the per-ray constants: up to an ulp and a half looser than roundDown and
// roundUp, and without their branches. x is moved by more than the conversion to nearest can move it back (half
// an ulp: at most |x|·2^-24 for a normal float, 2^-150 for a subnormal), with room for the double arithmetic's
// own rounding; past the largest float, that float or ±∞, whichever is on the safe side. (With Real double, only
// the float build's branch of boxRayLanes calls floatBelow, and that branch is discarded: maybe_unused keeps clang
// from warning that the function is never emitted.)
[[maybe_unused]] float floatBelow(Real x)
{
  if constexpr (std::is_same_v<Real, float>)
    return float(x); // already a float
  constexpr Real kFloatMax = Real(std::numeric_limits<float>::max());
  return float(std::min(x - std::abs(x) * Real(0x1p-23) - Real(0x1p-149), kFloatMax));
}
float floatAbove(Real x)
{
  if constexpr (std::is_same_v<Real, float>)
    return float(x);
  constexpr Real kFloatMax = Real(std::numeric_limits<float>::max());
  return float(std::max(x + std::abs(x) * Real(0x1p-23) + Real(0x1p-149), -kFloatMax));
}

// A ray prepared for box tests, once per query: per axis, the row of BvhWideNode::bounds holding the face the
// ray meets first (lo for a positive direction, hi for a negative one) and the row holding the other, then the
// origin and 1/d as entries and as exits use them, in float, one copy per lane of V (Float4 or Float8).
template <class V> struct BoxRay {
  // Offsets in bytes into BvhWideNode::bounds (x, y, z, and one unused). (In floats, they were multiplied by four
  // at every query's start: six instructions.)
  std::uint32_t nearRow[4], farRow[4];
  V originNear[3], originFar[3];
  V invNear[3], invFar[3];
  V tmin, tmax; // the interval, rounded outwards; tmax shrinks to the nearest hit found so far
};
#if RAYLIFE_HAS_AVX2
// Every lane of eight set to x, in one vbroadcastss, for the eight-lane walk. (As x − Float8{}, GCC 12 built it as
// one broadcast or, depending on the code around it, lane by lane: with the rows below computed in lanes, a
// bounce ray's query spent 127 instructions on its broadcasts instead of 31.)
RAYLIFE_AVX2 void fillEight(Float8& v, float x) { v = Float8(_mm256_set1_ps(x)); }
#endif

// The lanes of row `rowBytes` (a BoxRay's nearRow or farRow) of a node's bounds, from child k on.
template <class V> void loadRow(const BvhWideNode& node, int k, std::uint32_t rowBytes, V& v)
{
  std::memcpy(&v, reinterpret_cast<const char*>(node.bounds + k) + rowBytes, sizeof v);
}

// Every lane of v set to x. (x − 0 is x for every float, −0 included; the scalar is broadcast to the lanes. Written
// without a function that returns a V, as simd.h asks.)
template <class V> void fill(V& v, float x)
{
#if RAYLIFE_HAS_AVX2
  if constexpr (std::is_same_v<V, Float8>) {
    fillEight(v, x);
    return;
  }
#endif
  v = x - V{};
}

/// [slab]
// The slab test, for four or eight boxes at once. A box is where the ray is inside all three slabs lo ≤ p ≤ hi:
// for t between the largest entry and the smallest exit. A direction with a zero component works out: 1/d = ±∞ gives
// entry −∞ and exit +∞ for an origin inside the slab, entry +∞ (a miss) outside; an origin exactly on a face
// gives 0·∞ = NaN, which min and max ignore (the box is kept, which is safe).
//
// It runs in float, on the float boxes, and it never culls a box the double ray touches: its interval holds the
// exact one widened by kBoxMargin (which covers the sphere test's error at a box's face). For that, everything
// is rounded to the safe side, so that an entry can only come out early and an exit late:
//  - the origin towards the face: lo − o cannot grow when o is rounded up (for d > 0; the other way for d < 0);
//  - 1/d scaled by 1 − w for entries and 1 + w for exits, w = kBoxMargin + γ(8) in float. An entry
//    E = (lo − o)/d > 0 is rounded six times on its way (in double: 1/d, the scale 1 − w, their product; then
//    the conversion to float, the subtraction and the product of hitsBoxes), each time by a factor at most
//    (1 + u), and (1 + u)^6 ≤ 1 + γ(6); so it comes out at most (1 − kBoxMargin − γ(8))(1 + γ(6))·E, which is
//    below (1 − kBoxMargin)·E. An exit likewise, the other way.
//  - An entry at or below 0 does not matter: tmin ≥ 0 (Ray's contract), and the rounding keeps its sign.
//    tmin itself is rounded down, and the nearest hit so far up.
// (Gradual underflow, below 2^-126, is outside this bound, as it is outside pbrt's: no distance in a scene
// comes near it.) So the test is wider than the exact one by some 5·10^-7 of the distance: now and then a box
// more, never a different hit.
//
// A ray's box-test constants, axis by axis in the lanes of four floats (x, y, z, and lane 3): what prepareBoxRay
// puts in every lane of a BoxRay, before it does. Lane 3 of originNear holds tmax rounded up, of originFar tmin
// rounded down; lanes 3 of the inverses are finite and positive. `negative`: lanes 0 to 2 all ones where d < 0,
// lane 3 zero.
struct BoxRayLanes {
  Float4 originNear, originFar, invNear, invFar;
  Mask4 negative;
};

// `tmax`: the far end of the interval, ray.tmax or a nearer hit already found (outside the tree).
[[gnu::always_inline]] inline BoxRayLanes boxRayLanes(const Ray& ray, Real tmax)
{
  constexpr Real kWiden = kBoxMargin<Real> + Real(gamma<float>(8));
  constexpr Real kFloatMax = Real(std::numeric_limits<float>::max());
  // Per axis, in the lanes of four floats (x, y, z, and lane 3): the origin rounded down and up, 1/d scaled for
  // entries and exits, and whether d is negative. Lane 3 of the origin rounded down holds tmin rounded down, of the
  // origin rounded up, tmax rounded up; the other lanes 3 are unused.
  Float4 originBelow, originAbove, invNear, invFar;
  Mask4 negative;
  if constexpr (std::is_same_v<Real, double>) {
    // The three axes at once, in the lanes of four doubles (one AVX register in the eight-lane traversal, two SSE
    // ones elsewhere): the same IEEE operations as the scalar code below (floatBelow, floatAbove, std::clamp), in
    // the same order, so the same floats. Why: without branches. One axis at a time, GCC made the choices below
    // (which face the ray meets first, and the clamps) branches on the signs of the direction, random from ray
    // to ray: valgrind's branch simulator counted 6.1 mispredictions a ray of chapter 6 on the random spheres
    // with them, 4.7 with this. The conversions to float too, four at once (the same rounding as one at a time):
    // a lane at a time, they and the choices were some 40 instructions of a query's setup.
    const Double4 one = {1, 1, 1, 1}, most = {kFloatMax, kFloatMax, kFloatMax, kFloatMax}, least = -most;
    // tmin and tmax in lane 3, rounded by floatBelow's and floatAbove's operations. (One at a time, the two were
    // some 20 instructions and two branches of a query.) No lane holds a constant 0: for one, GCC may clear the
    // lane with a register-to-register vmovq in the encoding valgrind 3.19 cannot decode, and callgrind stops at the
    // first query.
    const Double4 low = {ray.origin.x, ray.origin.y, ray.origin.z, ray.tmin};
    const Double4 high = {ray.origin.x, ray.origin.y, ray.origin.z, tmax};
    const Double4 d = {ray.direction.x, ray.direction.y, ray.direction.z, 1};
    const Double4 inv = one / d;
    constexpr std::int64_t kMagnitude = std::numeric_limits<std::int64_t>::max(); // all but the sign bit
    Double4 below = low - (Double4)((Mask64x4)low & kMagnitude) * 0x1p-23 - 0x1p-149;
    below = most < below ? most : below; // std::min(below, kFloatMax)
    Double4 above = high + (Double4)((Mask64x4)high & kMagnitude) * 0x1p-23 + 0x1p-149;
    above = above < least ? least : above; // std::max(above, −kFloatMax)
    Double4 near = inv * (1 - kWiden);
    near = near < least ? least : near; // std::clamp(near, −kFloatMax, kFloatMax)
    near = most < near ? most : near;
    const Double4 far = inv * (1 + kWiden);
    originBelow = __builtin_convertvector(below, Float4);
    originAbove = __builtin_convertvector(above, Float4);
    invNear = __builtin_convertvector(near, Float4);
    invFar = __builtin_convertvector(far, Float4);
    // d's sign, from invNear's sign bit, which is 1/d's (d = −0 included: 1/d = −∞, clamped to the lowest float; a
    // NaN keeps its sign through the clamps and the conversion). (Read from the four doubles, it took five more
    // instructions to narrow, as GCC 12 builds such a conversion.)
    negative = (Mask4)invNear < 0;
  } else {
    for (int a = 0; a < 3; ++a) {
      const Real inv = Real(1) / ray.direction[a];
      originBelow[a] = floatBelow(ray.origin[a]);
      originAbove[a] = floatAbove(ray.origin[a]);
      invNear[a] = float(std::clamp(inv * (1 - kWiden), -kFloatMax, kFloatMax));
      invFar[a] = float(inv * (1 + kWiden));
      negative[a] = std::signbit(inv) ? -1 : 0;
    }
    originBelow[3] = floatBelow(ray.tmin);
    originAbove[3] = floatAbove(tmax);
    invNear[3] = invFar[3] = 1;
    negative[3] = 0;
  }
  // A positive direction meets lo first: its entry (lo − o)/d is early when o is rounded up, its exit (hi − o)/d
  // late when o is rounded down. A negative direction the other way round. (Chosen by a mask, without a branch.)
  // |1/d| is made smaller for entries, larger for exits. The entries' stays finite: a float ∞ for a d too small
  // for float would put entries too late (and d = ±0 then gives the largest float, whose entries are early
  // enough). The exits' may overflow to ±∞, which is on the safe side.
  return BoxRayLanes{(Float4)((negative & (Mask4)originBelow) | (~negative & (Mask4)originAbove)),
                     (Float4)((negative & (Mask4)originAbove) | (~negative & (Mask4)originBelow)), invNear, invFar,
                     negative};
}

// The rows of BvhWideNode::bounds a ray with these signs meets first and last (BoxRay's nearRow and farRow): axis
// a's lo row is row a, its hi row a + 3. (For the three axes at once, in lanes: one by one, with the shifts and masks
// of each axis's sign, they were 45 instructions of a query.)
[[gnu::always_inline]] inline void boxRows(const Mask4& negative, std::uint32_t (&nearRow)[4],
                                           std::uint32_t (&farRow)[4])
{
  constexpr int kRowBytes = int(BvhWideNode::kWidth * sizeof(float));
  const Mask4 loRow = {0, kRowBytes, 2 * kRowBytes, 0}, flipRows = Mask4{} + 3 * kRowBytes;
  const Mask4 nearRows = loRow + (negative & flipRows), farRows = loRow + (~negative & flipRows);
  std::memcpy(nearRow, &nearRows, sizeof nearRow);
  std::memcpy(farRow, &farRows, sizeof farRow);
}

// The ray's box-test constants in every lane of `r`, which is filled in where it lies (returned by value and
// assigned, it was a copy of some 450 bytes a ray).
template <class V> void prepareBoxRay(const Ray& ray, Real tmax, BoxRay<V>& r)
{
  const BoxRayLanes lanes = boxRayLanes(ray, tmax);
  boxRows(lanes.negative, r.nearRow, r.farRow);
  for (int a = 0; a < 3; ++a) {
    fill(r.originNear[a], lanes.originNear[a]);
    fill(r.originFar[a], lanes.originFar[a]);
    fill(r.invNear[a], lanes.invNear[a]);
    fill(r.invFar[a], lanes.invFar[a]);
  }
  fill(r.tmin, lanes.originFar[3]);
  fill(r.tmax, lanes.originNear[3]);
}

// The children's boxes of `node` against the ray within [tmin, tmax], one box to a lane of V (two steps of four
// or one of eight): bit k of the result is set when child k's box is hit, and tEnter[k] is where the ray enters it.
template <class V>
unsigned hitsBoxes(const BvhWideNode& node, const BoxRay<V>& r, float (&tEnter)[BvhWideNode::kWidth])
{
  constexpr int kLanes = int(sizeof(V) / sizeof(float));
  unsigned hits = 0;
  for (int k = 0; k < BvhWideNode::kWidth; k += kLanes) {
    // Where the ray enters and leaves each slab, then the largest entry and the smallest exit (a NaN lane
    // leaves its slab unbounded: its comparison is false).
    V enter = r.tmin, exit = r.tmax;
    for (int a = 0; a < 3; ++a) {
      V faceNear, faceFar;
      loadRow(node, k, r.nearRow[a], faceNear);
      loadRow(node, k, r.farRow[a], faceFar);
      const V tNear = (faceNear - r.originNear[a]) * r.invNear[a];
      const V tFar = (faceFar - r.originFar[a]) * r.invFar[a];
      enter = tNear > enter ? tNear : enter;
      exit = tFar < exit ? tFar : exit;
    }
    std::memcpy(&tEnter[k], &enter, sizeof enter);
    hits |= bitMask(enter <= exit) << k;
  }
  return hits;
}
/// [slab]

// ---- Triangles, four at a time --------------------------------------------------------------------------------

/// [laneHits]
// Four of the scene's scalars, one triangle's coordinate to a lane (two SSE registers or one AVX one for doubles).
typedef Real RealLanes __attribute__((vector_size(4 * sizeof(Real))));
constexpr std::size_t kFloatRow = 4 * sizeof(float); // a row of a pack's corners (four lanes), in floats

// A ray prepared for the triangle test, once per query: intersectTriangle's permutation of the axes (z the
// direction's largest component) and its shear, and the origin in the permuted axes, each number already in every
// lane. (Kept as axis numbers and scalars, they were made again at every leaf the walk reached: with the walk's
// registers all taken, GCC computed the nine rows' offsets and the six lanes at a leaf's start and kept them on the
// stack. Made once, as here, a bounce ray's query on chapter 10's model alone ran 974 instructions, not 1,045, by
// callgrind.)
} // namespace
struct BvhTriangleRay {
  // The permutation, as the offsets in bytes of rows kx, ky and kz in a pack of floats (Bvh::FloatTrianglePack;
  // twice that in one of doubles): a corner's three rows are then at fixed distances from these, and the walk keeps
  // three numbers for the nine loads.
  std::size_t kx = 0, ky = kFloatRow, kz = 2 * kFloatRow;
  RealLanes sx{}, sy{}, sz{}; // as intersectTriangle computes them
  RealLanes ox{}, oy{}, oz{};
};
namespace {
using TriangleRay = BvhTriangleRay;

// (The magnitudes with std::abs, which clears the sign bit: glm::abs compares and chooses, and GCC made that
// branches on the direction's signs, random from ray to ray: 0.4 mispredictions a query on chapter 10's model
// alone by callgrind's branch simulator. The choice of axes stays a branch: made by arithmetic and indexing, or by
// dividing for all three choices and picking by masks, it put its cycles before every query's divisions, and
// coherent camera rays in the Cornell boxes ran at 1.19 to 1.36 of Embree's speed where they run at 1.39 to 1.49.)
void prepareTriangleRay(const Ray& ray, TriangleRay& r)
{
  // (Written out for each choice of z, so that the axes are constants: indexed by a variable, glm's vector is a
  // switch, some 20 instructions of a bounce ray's query on chapter 10's model alone, by callgrind: 779 against 759.)
  auto permuted = [&ray, &r](int kx, int ky, int kz) __attribute__((always_inline)) {
    r.kx = std::size_t(kx) * kFloatRow;
    r.ky = std::size_t(ky) * kFloatRow;
    r.kz = std::size_t(kz) * kFloatRow;
    // (Each in every lane as x − 0, which is x for −0 too.)
    r.sx = -ray.direction[kx] / ray.direction[kz] - RealLanes{};
    r.sy = -ray.direction[ky] / ray.direction[kz] - RealLanes{};
    r.sz = 1 / ray.direction[kz] - RealLanes{};
    r.ox = ray.origin[kx] - RealLanes{};
    r.oy = ray.origin[ky] - RealLanes{};
    r.oz = ray.origin[kz] - RealLanes{};
  };
  const Real ax = std::abs(ray.direction.x), ay = std::abs(ray.direction.y), az = std::abs(ray.direction.z);
  // z is the axis of the largest magnitude (on a tie, the later axis), x and y the two after it in turn.
  if (ax > ay && ax > az)
    permuted(1, 2, 0);
  else if (!(ax > ay) && ay > az)
    permuted(2, 0, 1);
  else
    permuted(0, 1, 2);
}

// What the lanes of a pack found (laneHits): the lanes whose triangle the ray hits, at t no farther than the nearest
// hit so far, and in float the lanes the scalar test must decide. Bit k for lane k.
struct LaneHits {
  unsigned hit = 0;    // hit at t[k], exactly as intersectTriangle would report it
  unsigned retest = 0; // float only: an edge function was 0, which the scalar test decides again in double
  RealLanes t{}; // the hits' t (set once a lane survives the signs)
};

// The watertight test (intersectTriangle) on the four triangles of a pack (Bvh::TrianglePack::corner: row
// 3·corner + axis, each row aligned to its size), in lanes, with the same operations in the same order, so the same
// edge functions, the same t and the same refusal of a t too close to 0, to the last bit: a lane is a hit exactly
// where the scalar test gives one, at the same t. Lanes whose t lies beyond `nearest` are dropped (they lose to the
// hit found already). Lanes [0, count) only.
// T: the pack's corners' type, Real or float (converted to Real exactly as they are loaded).
// `p`, which the caller knows to be aligned to `N` bytes, said so to the compiler. (Not to clang: clang 14 crashes
// generating UBSan's check of the assumption, and only the sanitizer build is made with clang.)
template <std::size_t N, class U> [[gnu::always_inline]] inline const U* assumeAligned(const U* p)
{
#if defined(__clang__)
  return p;
#else
  return static_cast<const U*>(__builtin_assume_aligned(p, N));
#endif
}

#if RAYLIFE_HAS_AVX2 && !defined(RAYLIFE_REAL_IS_FLOAT)
// Four floats (aligned to 16 bytes) to four doubles, for the eight-lane walk: one instruction, built for AVX.
// (GCC 12 builds a __builtin_convertvector from four floats to four doubles as two halves of two floats, the upper
// one copied through the stack and the two joined, in the AVX2 walk too, and even in a function of its own built
// for AVX: 85 of the 1,150 instructions of a bounce ray's query on chapter 10's model alone, by callgrind.)
RAYLIFE_AVX2 void widenEight(const float* p, RealLanes& v)
{
  v = RealLanes(_mm256_cvtps_pd(_mm_load_ps(p)));
}
#endif

// kEight: called from the eight-lane (AVX2) walk.
template <bool kEight, class T>
[[gnu::always_inline]] inline LaneHits laneHits(const T (&corner)[9][4], std::uint32_t count, const TriangleRay& r,
                                                const Ray& ray, Real nearest)
{
  // Corner c moved to the ray's origin, axes permuted, x and y sheared, as intersectTriangle does. (Each row loaded
  // whole and aligned: GCC splits an unaligned load of 32 bytes in two, and a copy made that way and read back
  // whole stalled the processor, a third of a query on the Cornell box.)
  // (Corner c's row at `offset`, r.kx, r.ky or r.kz.)
  auto load = [&corner](int c, std::size_t offset, RealLanes& v) {
    const T* row = reinterpret_cast<const T*>(reinterpret_cast<const char*>(corner[3 * c]) +
                                              offset * (sizeof(T) / sizeof(float)));
    if constexpr (std::is_same_v<T, Real>) {
      std::memcpy(&v, assumeAligned<sizeof(RealLanes)>(row), sizeof v);
    } else {
#if RAYLIFE_HAS_AVX2 && !defined(RAYLIFE_REAL_IS_FLOAT)
      if constexpr (kEight) {
        widenEight(row, v);
        return;
      }
#endif
      typedef T Lanes __attribute__((vector_size(4 * sizeof(T))));
      Lanes narrow;
      std::memcpy(&narrow, assumeAligned<sizeof(Lanes)>(row), sizeof narrow);
      v = __builtin_convertvector(narrow, RealLanes);
    }
  };
  RealLanes x0, y0, z0, x1, y1, z1, x2, y2, z2;
  load(0, r.kx, x0);
  load(0, r.ky, y0);
  load(0, r.kz, z0);
  load(1, r.kx, x1);
  load(1, r.ky, y1);
  load(1, r.kz, z1);
  load(2, r.kx, x2);
  load(2, r.ky, y2);
  load(2, r.kz, z2);
  z0 = z0 - r.oz;
  z1 = z1 - r.oz;
  z2 = z2 - r.oz;
  x0 = (x0 - r.ox) + r.sx * z0;
  y0 = (y0 - r.oy) + r.sy * z0;
  x1 = (x1 - r.ox) + r.sx * z1;
  y1 = (y1 - r.oy) + r.sy * z1;
  x2 = (x2 - r.ox) + r.sx * z2;
  y2 = (y2 - r.oy) + r.sy * z2;
  const RealLanes e0 = x1 * y2 - y1 * x2;
  const RealLanes e1 = x2 * y0 - y2 * x0;
  const RealLanes e2 = x0 * y1 - y0 * x1;
  const RealLanes det = e0 + e1 + e2;
  z0 = z0 * r.sz;
  z1 = z1 * r.sz;
  z2 = z2 * r.sz;
  const RealLanes tScaled = e0 * z0 + e1 * z1 + e2 * z2;
  LaneHits out;
  // First what the signs decide: a ray that passes beside the triangle (edge functions of both signs), or meets its
  // plane behind the origin. Most packs stop here, the ray beside all four, before the division.
  // intersectTriangle asks (e0 < 0 || e1 < 0 || e2 < 0) && (e0 > 0 || …), then det == 0, then whether tScaled
  // has det's sign (refused: det < 0 && tScaled ≥ 0, or det > 0 && tScaled ≤ 0). For numbers, not NaNs, these are
  // the same questions as: the least e below 0 and the largest above 0; det 0; tScaled 0; tScaled's sign bit
  // other than det's. Asked so, in fewer instructions: 19 fewer a bounce ray's query on chapter 10's model alone.
  // (A NaN may be refused here or not; either way its t is a NaN, which the test of t's range below refuses, as the
  // scalar test's does.)
  using Bits = decltype(e0 < 0);
  const RealLanes least01 = e0 < e1 ? e0 : e1, most01 = e0 > e1 ? e0 : e1;
  const RealLanes least = least01 < e2 ? least01 : e2, most = most01 > e2 ? most01 : e2;
  auto refused = ((least < 0) & (most > 0)) | (det == 0) | (tScaled == 0) | (((Bits)det ^ (Bits)tScaled) < 0);
  const unsigned live = (1u << count) - 1;
  // Lane k's yes as bit k, and the lanes left, those not refused. (In the eight-lane walk one movemask of the
  // four doubles' lanes, built for AVX; elsewhere the lanes narrowed to four 32-bit ones for SSE's movemask. Taken
  // lane by lane, the bits cost 2.7 % of a query's instructions on a million triangles, by callgrind; the narrowing
  // costs five instructions more each time, as GCC 12 builds it, where AVX's movemask takes the four lanes as they
  // are.)
  auto bits = [live](const auto& mask) {
#if RAYLIFE_HAS_AVX2 && !defined(RAYLIFE_REAL_IS_FLOAT)
    if constexpr (kEight)
      return bitMaskEight(mask) & live;
#endif
    return bitMask(__builtin_convertvector(mask, Mask4)) & live;
  };
  auto left = [&bits, live](const auto& refusedLanes) { return ~bits(refusedLanes) & live; };
  if constexpr (std::is_same_v<Real, float>) {
    const auto zero = (e0 == 0) | (e1 == 0) | (e2 == 0);
    out.retest = bits(zero); // (its t comes from the edge functions in double: any t)
    refused |= zero;
  }
  if (left(refused) == 0) // (the usual case: no hit, and none of what follows)
    return out;
  const RealLanes invDet = Real(1) / det;
  out.t = tScaled * invDet;
  const auto& t = out.t;
  refused |= ~((t >= ray.tmin) & (t < ray.tmax)) | (t > nearest);
  if (left(refused) == 0)
    return out;
  // The bound on t's rounding error, as intersectTriangle computes it (std::max(a, b) is a < b ? b : a; the
  // magnitudes by clearing the sign bit, as std::fabs).
  // (In place, not in helper functions: a function that takes or returns an AVX vector would change the ABI of the
  // code built without AVX.)
  const auto magnitude = Bits{} + std::numeric_limits<std::remove_cvref_t<decltype(refused[0])>>::max();
#define RAYLIFE_ABS(v) ((RealLanes)((Bits)(v) & magnitude))
#define RAYLIFE_MAX(p, q) ((p) < (q) ? (q) : (p))
#define RAYLIFE_MAX_ABS(p, q, w) RAYLIFE_MAX(RAYLIFE_ABS(p), RAYLIFE_MAX(RAYLIFE_ABS(q), RAYLIFE_ABS(w)))
  const RealLanes maxZ = RAYLIFE_MAX_ABS(z0, z1, z2);
  const RealLanes maxX = RAYLIFE_MAX_ABS(x0, x1, x2);
  const RealLanes maxY = RAYLIFE_MAX_ABS(y0, y1, y2);
  const RealLanes deltaZ = gamma<Real>(3) * maxZ;
  const RealLanes deltaX = gamma<Real>(5) * (maxX + maxZ);
  const RealLanes deltaY = gamma<Real>(5) * (maxY + maxZ);
  const RealLanes deltaE = 2 * (gamma<Real>(2) * maxX * maxY + deltaY * maxX + deltaX * maxY);
  const RealLanes maxE = RAYLIFE_MAX_ABS(e0, e1, e2);
  const RealLanes deltaT = 3 * (gamma<Real>(3) * maxE * maxZ + deltaE * maxZ + deltaZ * maxE) * RAYLIFE_ABS(invDet);
#undef RAYLIFE_MAX_ABS
#undef RAYLIFE_MAX
#undef RAYLIFE_ABS
  out.hit = left(refused) & bits(t > deltaT);
  return out;
}
/// [laneHits]

// Corner c (0, 1, 2) of a pack's triangle in lane `lane`, as the scene gave it.
template <class T> [[gnu::always_inline]] inline Vec3 packCorner(const T (&corner)[9][4], int c, std::size_t lane)
{
  return Vec3(Real(corner[3 * c][lane]), Real(corner[3 * c + 1][lane]), Real(corner[3 * c + 2][lane]));
}

} // namespace

Bvh::Bvh(const std::vector<Sphere>& spheres, const BvhBuildOptions& options)
    : Bvh(std::span<const Sphere>(spheres), std::span<const Vec3>(), std::span<const Triangle>(), options)
{
}

Bvh::Bvh(std::span<const Sphere> spheres, std::span<const Vec3> vertices, std::span<const Triangle> triangles,
         const BvhBuildOptions& options)
{
  const std::size_t all = spheres.size() + triangles.size();
  if (all == 0)
    return;
  const int threads =
      options.buildThreads > 0 ? options.buildThreads : int(std::max(1u, std::thread::hardware_concurrency()));
  std::vector<BuildItem> items;
  items.reserve(all);
  adviseHugePages(items);
  items.resize(all);
  parallelFor(all, threads, [&](std::size_t first, std::size_t last) {
    for (std::size_t i = first; i < last; ++i)
      if (i < spheres.size()) {
        items[i] = buildItem(sphereBounds(spheres[i]), int(i));
      } else {
        const Triangle& tri = triangles[i - spheres.size()];
        items[i] = buildItem(triangleBounds(vertices[tri.v[0]], vertices[tri.v[1]], vertices[tri.v[2]]), int(i));
      }
  });
  eightAtOnce_ = options.eightAtOnce && cpuHasAvx2();

  // The huge primitives stay out of the tree, in their own short lists (numbers in increasing order: spheres
  // first, so the triangles' loop may keep the strict "nearer" of the brute-force loop).
  // (Not in a scene where something moves: the lists outside test spheres where they are at time 0.)
  const bool moving = std::any_of(spheres.begin(), spheres.end(), [](const Sphere& s) { return s.moving(); });
  if (options.hugeOutside && !moving)
    outside_ = chooseOutside(items);
  if (!outside_.empty()) {
    std::vector<Sphere> outsideSpheres;
    for (const int index : outside_)
      if (std::size_t(index) < spheres.size()) {
        const Sphere& sphere = spheres[std::size_t(index)];
        outsideSpheres.push_back(sphere);
        outsideSpheres_.push_back(SpherePrimitive{sphere.center, sphere.radius, index, false});
        outsideSphereIndex_.push_back(index);
      } else {
        const Triangle& tri = triangles[std::size_t(index) - spheres.size()];
        outsideTriangles_.push_back(
            OutsideTriangle{{vertices[tri.v[0]], vertices[tri.v[1]], vertices[tri.v[2]]}, index});
      }
    if (outsideSpheres.size() >= kOutsideLanesMin && laneTestAvailable(LaneTest::FourAtOnce)) {
      outsideLanes_ = SphereLanes(outsideSpheres, LaneTest::FourAtOnce);
      outsideSpheres_.clear();
    }
    std::erase_if(items, [this](const BuildItem& item) {
      return std::binary_search(outside_.begin(), outside_.end(), item.index);
    });
  }
  const std::size_t count = items.size();
  // The primitives' numbers in the order the build left them (leaf by leaf); the builder, and its items, go as soon
  // as the nodes are made, before the primitives' own copies are (the build's memory peak for a big mesh).
  std::vector<int> order(count);
  {
    Builder builder(items, int(spheres.size()), options, threads > 1 ? Builder::kSubtreesPerThread * threads : 1);
    // Room for the most nodes a tree of `count` primitives can have (2·count − 1, leaves of one), reserved at once:
    // the pages never written are never resident, so this holds what the tree uses, where growing by doubling held
    // the old array and the new one, twice as large and written by the copy, at once (a million triangles make 1.3
    // million nodes: the doubling from 2^20 to 2^21 of them was the build's memory peak). (Not shrunk to fit: the
    // copy would be the peak.)
    builder.nodes.reserve(std::max<std::size_t>(2 * count, 2) - 1);
    adviseHugePages(builder.nodes);
    builder.build(0, count, 1, summarize(items, int(spheres.size()), threads));
    nodes_ = std::move(builder.nodes);
    depth_ = builder.depth;
    for (std::size_t k = 0; k < count; ++k)
      order[k] = items[k].index;
    releasePages(items);
    std::vector<BuildItem>().swap(items);
  }

  // The primitives in leaf order: the spheres in their list, so that a leaf's spheres lie side by side (a leaf's
  // offset becomes its first sphere's place there), the triangles four to a pack (a leaf's offset becomes its
  // first pack's index).
  // (A still scene keeps no velocities: its queries never look at one.)
  spheres_.reserve(spheres.size());
  std::size_t packCount = 0, interior = 0;
  for (BvhNode& n : nodes_)
    if (n.count > 0) {
      n.triangles = std::size_t(order[n.offset]) >= spheres.size() ? 1 : 0;
      packCount += n.triangles ? (n.count + 3u) / 4u : 0;
    } else {
      ++interior;
    }
  // Corners that are all floats exactly are kept as floats: the same values in half the bytes. (In a float build
  // packs_ holds floats already.)
  // (The rounded value through a volatile float: GCC 12, vectorising a loop of such round trips, dropped the
  // rounding, in a test.)
  bool floatCorners = !std::is_same_v<Real, float> && packCount > 0;
  for (std::size_t v = 0; floatCorners && v < vertices.size(); ++v)
    for (int axis = 0; axis < 3; ++axis) {
      const volatile float rounded = float(vertices[v][axis]);
      floatCorners = floatCorners && Real(rounded) == vertices[v][axis];
    }
  // The leaves in order: a leaf of spheres gets its spheres appended to spheres_ here, a leaf of triangles the
  // index of its first pack, its packs filled afterwards on every core (the same bytes whatever the threads: each
  // leaf writes only its own packs).
  struct PackedLeaf {
    std::size_t first, count, pack; // its triangles [first, first + count) of `order`; its first pack
  };
  std::vector<PackedLeaf> packed;
  std::size_t packNext = 0;
  for (BvhNode& n : nodes_) {
    if (n.count == 0)
      continue;
    const std::size_t first = n.offset;
    if (!n.triangles) {
      n.offset = std::uint32_t(spheres_.size());
      for (std::size_t k = first; k < first + n.count; ++k) {
        const auto index = std::size_t(order[k]);
        const Sphere& s = spheres[index];
        spheres_.push_back(SpherePrimitive{s.center, s.radius, int(index), false});
        if (moving)
          velocities_.push_back(s.velocity);
      }
      continue;
    }
    n.offset = std::uint32_t(packNext);
    packed.push_back(PackedLeaf{first, n.count, packNext});
    packNext += (n.count + 3u) / 4u;
  }
  // A leaf's triangles into its packs, four to a pack, in order.
  auto fillPacks = [&](auto& packs) {
    using Pack = typename std::remove_reference_t<decltype(packs)>::value_type;
    using T = std::remove_all_extents_t<decltype(Pack::corner)>;
    packs.reserve(packCount);
    adviseHugePages(packs);
    packs.resize(packCount); // (zeros: the lanes past a pack's count stay so)
    parallelFor(packed.size(), threads, [&](std::size_t firstLeaf, std::size_t lastLeaf) {
      for (std::size_t l = firstLeaf; l < lastLeaf; ++l) {
        const PackedLeaf& leaf = packed[l];
        for (std::size_t k = 0; k < leaf.count; ++k) {
          Pack& pack = packs[leaf.pack + k / 4];
          const std::size_t lane = k % 4;
          const int index = order[leaf.first + k];
          const Triangle& tri = triangles[std::size_t(index) - spheres.size()];
          for (int corner = 0; corner < 3; ++corner)
            for (int axis = 0; axis < 3; ++axis)
              pack.corner[3 * corner + axis][lane] = T(vertices[tri.v[std::size_t(corner)]][axis]);
          pack.index[lane] = index;
          pack.count = std::uint32_t(lane + 1);
        }
        packs[leaf.pack + (leaf.count - 1) / 4].count |= kLastPack;
      }
    });
  };

  // The tree the queries walk: up to eight children to a node. Its array is allocated once, with room for as many
  // wide nodes as there are binary interior nodes (each wide node takes one's place; or one, a root over a single
  // leaf): some four times what it uses, but the pages never written are never resident. (Grown by doubling, it
  // held up to twice what it uses, and its last copy was the build's memory peak: 125 MB for a million triangles.
  // Counted exactly first, the count was as long as the collapse.)
  wideNodes_.reserve(std::max<std::size_t>(interior, 1));
  adviseHugePages(wideNodes_);
  {
    // Collapsed on a thread of its own while the packs are filled: the collapse reads the binary tree and writes
    // the wide nodes (and the spheres' last-in-leaf marks), the packs' filling reads `packed` and `order` and
    // writes the packs. (Serial, after the packs, it was some 15 ms of a million triangles' 200 ms build on two
    // cores. Not for a small tree, whose whole collapse takes less than starting a thread.)
    const bool aside = threads > 1 && nodes_.size() >= kCollapseAsideMin;
    struct Joined {
      std::thread thread;
      ~Joined()
      {
        if (thread.joinable())
          thread.join();
      }
    } collapser;
    if (aside)
      collapser.thread = std::thread([this] { collapse(0); });
    if (floatCorners)
      fillPacks(floatPacks_);
    else if (packCount > 0)
      fillPacks(packs_);
    if (!aside)
      collapse(0);
  }
  std::vector<int>().swap(order);
  if (!options.keepBinaryTree) {
    releasePages(nodes_);
    std::vector<BvhNode>().swap(nodes_);
  }
  primitiveCount_ = all;
}

/// [collapse]
// Why collapse: a ray visits the nodes of a path one after the other, each visit waiting for the box test before
// it knows where to go next, so fewer, wider nodes are faster, as long as their boxes are tested together.
//
// A wide node takes the place of a binary node and of up to three levels below it. It starts from the node's two
// children and, while it has fewer than kWidth, opens the interior child with the largest box (the one a ray is
// likeliest to enter, by the SAH's argument) into that child's two children. Returns the new node's index; its
// interior children follow it.
int Bvh::wideChildren(std::uint32_t node, std::uint32_t (&children)[BvhWideNode::kWidth]) const
{
  constexpr int kWidth = BvhWideNode::kWidth;
  int n = 0;
  if (nodes_[node].count > 0) {
    children[n++] = node; // the whole tree is one leaf: a root with one child
    return n;
  }
  // Each child's area, or −1 for a leaf (never opened).
  Real area[kWidth];
  auto take = [&](int k, std::uint32_t child) {
    children[k] = child;
    area[k] = nodes_[child].count == 0 ? nodeArea(nodes_[child]) : Real(-1);
  };
  take(n++, node + 1);
  take(n++, nodes_[node].offset);
  while (n < kWidth) {
    int widest = -1;
    Real widestArea = -1;
    for (int k = 0; k < n; ++k)
      if (area[k] > widestArea) {
        widest = k;
        widestArea = area[k];
      }
    if (widest < 0)
      break; // every child a leaf
    const std::uint32_t opened = children[widest];
    take(widest, opened + 1);
    take(n++, nodes_[opened].offset);
  }
  return n;
}

std::uint32_t Bvh::collapse(std::uint32_t node)
{
  constexpr int kWidth = BvhWideNode::kWidth;
  std::uint32_t children[kWidth];
  const int n = wideChildren(node, children);

  // Take the node's place before its children take theirs; fill it in once they have (the vector may move).
  const auto index = std::uint32_t(wideNodes_.size());
  wideNodes_.emplace_back();
  BvhWideNode wide{};
  wide.boxes = std::uint32_t(n);
  for (int k = 0; k < kWidth; ++k)
    for (int a = 0; a < 3; ++a) {
      // The child's box, or an empty one in a slot without a child.
      wide.bounds[a * kWidth + k] = k < n ? nodes_[children[k]].bounds[0][a] : kInfinityF;
      wide.bounds[(3 + a) * kWidth + k] = k < n ? nodes_[children[k]].bounds[1][a] : -kInfinityF;
    }
  for (int k = 0; k < n; ++k) {
    const BvhNode& child = nodes_[children[k]];
    if (child.count > 0 && child.triangles) {
      wide.child[k] = BvhWideNode::kLeaf | BvhWideNode::kTriangles | child.offset;
    } else if (child.count > 0) {
      wide.child[k] = BvhWideNode::kLeaf | child.offset;
      spheres_[child.offset + child.count - 1u].lastInLeaf = true;
    } else {
      wide.child[k] = collapse(children[k]);
    }
  }
  wideNodes_[index] = wide;
  return index;
}
/// [collapse]

/// [traverse]
// One ray's walk through the tree: the box test's constants, the nearest hit so far as a float, and the stack of
// what is still to visit (at most kWidth − 1 entries per level), each entry with where the ray enters its box.
template <class V> struct BvhWalk {
  struct Entry {
    std::uint32_t child; // as BvhWideNode::child
    float tEnter;
  };
  BoxRay<V> boxRay;
  TriangleRay triangleRay;  // set at the first leaf of triangles the walk reaches
  bool triangleRayReady = false;
  float tNearest;            // the nearest hit so far, rounded up to a float: a box entered beyond it is skipped
  std::uint32_t current = 0; // the node (or leaf) to visit next: the root first
  int stackSize = 0;
  // The caller's array of kStackSize entries. (Not a member array: with the array inside the walk, chapter 6's
  // query made 2.5 % more instructions, by callgrind.)
  Entry* stack = nullptr;
  static constexpr int kStackSize = (BvhWideNode::kWidth - 1) * Bvh::kMaxDepth + 1;

  // Starts the walk of `ray` at the root, boxes beyond `tmax` skipped. (The triangles' preparation, three
  // divisions, waits for a leaf of triangles: most camera rays at a model miss it and never reach one.)
  void start(const Ray& ray, Real tmax)
  {
    prepareBoxRay<V>(ray, tmax, boxRay);
    triangleRayReady = false;
    tNearest = boxRay.tmax[0];
    current = 0;
    stackSize = 0;
  }
};

// (flatten: inline the sphere and triangle tests into the loops, as they are in the scene's flat loop; a call per
// primitive costs more than the test.)
template <bool kAnyHit, bool kCountWork, class V>
[[gnu::flatten]] void Bvh::traverse(const Ray& ray, Traversal& found) const
{
  if (wideNodes_.empty())
    return;
  // (found.t is ray.tmax, or the nearest hit outside the tree: boxes beyond it are skipped. No branch on which:
  // whether a ray hits the ground sphere, say, is random from ray to ray.)
  BvhWalk<V> walk;
  typename BvhWalk<V>::Entry stack[BvhWalk<V>::kStackSize];
  walk.stack = stack;
  walk.start(ray, found.t);
  // Depth first, a node at a time.
  while (visit<kAnyHit, kCountWork, V>(ray, walk, found)) {
  }
}

// The triangles of a leaf, packs[first] on, a pack of four at a time: the lanes give the hits, as the scalar test
// would (in float, a lane with an edge function of 0 gets the scalar test itself). As testLeaf.
template <bool kAnyHit, bool kCountWork, bool kEight, class Pack>
[[gnu::always_inline]] inline bool Bvh::testPacks(const std::vector<Pack>& packs, std::uint32_t first,
                                                  const Ray& ray, const TriangleRay& triangleRay,
                                                  Traversal& found) const
{
  bool changed = false;
  auto take = [&found, &changed](Real t, int index) {
    if (kAnyHit || t < found.t || (t == found.t && index < found.primitive)) {
      found.t = t;
      found.primitive = index;
      changed = true;
    }
  };
  for (std::uint32_t i = first;; ++i) {
    const Pack& pack = packs[i];
    if constexpr (kCountWork)
      found.work.primitivesTested += pack.count & ~kLastPack;
    const LaneHits lanes = laneHits<kEight>(pack.corner, pack.count & ~kLastPack, triangleRay, ray, found.t);
    for (unsigned hits = lanes.hit; hits != 0; hits &= hits - 1) {
      const auto lane = std::size_t(std::countr_zero(hits));
      take(lanes.t[lane], pack.index[lane]);
      if (kAnyHit)
        return true;
    }
    // (Float: a lane with an edge function of 0, decided by the scalar test. Never in double.)
    for (unsigned retest = lanes.retest; retest != 0; retest &= retest - 1) {
      const auto lane = std::size_t(std::countr_zero(retest));
      const std::optional<TriangleHit<Real>> h = intersectTriangle(
          ray.origin, ray.direction, packCorner(pack.corner, 0, lane), packCorner(pack.corner, 1, lane),
          packCorner(pack.corner, 2, lane), ray.tmin, ray.tmax);
      if (h) {
        take(h->t, pack.index[lane]);
        if (kAnyHit)
          return true;
      }
    }
    if (pack.count & kLastPack)
      return changed;
  }
}

// The primitives of leaf `leaf` (a BvhWideNode::child with kLeaf set) against `ray`, into `found`. Closest hit: keep
// the nearer hit, or on a tie the lower number (as the brute-force loop's strict "nearer" does), so the answer does
// not depend on the order of the tree; true when `found` changed. Any hit: true at the first blocker.
// `triangleRay`: the ray prepared for the triangles (prepareTriangleRay), when the tree has some.
template <bool kAnyHit, bool kCountWork, bool kEight>
[[gnu::always_inline]] inline bool Bvh::testLeaf(const Ray& ray, std::uint32_t leaf, const TriangleRay& triangleRay,
                                                 Traversal& found) const
{
  if (leaf & BvhWideNode::kTriangles) {
    const std::uint32_t first = leaf & BvhWideNode::kIndexMask;
    return floatPacks_.empty() ? testPacks<kAnyHit, kCountWork, kEight>(packs_, first, ray, triangleRay, found)
                               : testPacks<kAnyHit, kCountWork, kEight>(floatPacks_, first, ray, triangleRay, found);
  }
  bool changed = false;
  for (std::uint32_t i = leaf & BvhWideNode::kIndexMask;; ++i) {
    const SpherePrimitive& p = spheres_[i];
    if constexpr (kCountWork)
      found.work.primitivesTested += 1;
    // (A moving sphere where it is at the ray's time; a still scene has no velocities.)
    const Vec3 center = velocities_.empty() ? p.center : sphereCenterAt(p.center, velocities_[i], ray.time);
    const std::optional<Real> t = intersectSphere(ray.origin, ray.direction, center, p.radius, ray.tmin, ray.tmax);
    if (t && (kAnyHit || *t < found.t || (*t == found.t && p.index < found.primitive))) {
      found.t = *t;
      found.primitive = p.index;
      if constexpr (kAnyHit)
        return true;
      changed = true;
    }
    if (p.lastInLeaf)
      return changed;
  }
}

// Asks the memory for a child the walk puts on its stack (a node, or a leaf's first pack or sphere): by the time
// the walk comes back to it, it is in the cache. Every child the ray enters is then fetched side by side with the
// others, where the walk would wait for each in turn (as Embree's walk does). On a tree bigger than the caches a
// query's time goes mostly on those waits. (Not the child visited next: its load comes at once anyway.)
[[gnu::always_inline]] inline void Bvh::prefetchChild(std::uint32_t child) const
{
  const std::uint32_t index = child & BvhWideNode::kIndexMask;
  const char* p;
  int lines;
  if ((child & BvhWideNode::kLeaf) == 0) {
    p = reinterpret_cast<const char*>(&wideNodes_[index]);
    lines = int(sizeof(BvhWideNode) / 64);
  } else if (child & BvhWideNode::kTriangles) {
    if (floatPacks_.empty()) {
      p = reinterpret_cast<const char*>(&packs_[index]);
      lines = int(sizeof(TrianglePack) / 64);
    } else {
      p = reinterpret_cast<const char*>(&floatPacks_[index]);
      lines = int(sizeof(FloatTrianglePack) / 64);
    }
  } else {
    p = reinterpret_cast<const char*>(&spheres_[index]);
    lines = 1;
  }
  for (int line = 0; line < lines; ++line)
    __builtin_prefetch(p + 64 * line);
}

// Visits walk.current and chooses what to visit next; false when the walk is over (its answer in `found`).
template <bool kAnyHit, bool kCountWork, class V>
[[gnu::always_inline]] inline bool Bvh::visit(const Ray& ray, BvhWalk<V>& walk, Traversal& found) const
{
  using Entry = typename BvhWalk<V>::Entry;
  const std::uint32_t current = walk.current;
  if ((current & BvhWideNode::kLeaf) == 0) {
    // An interior node: test its children's boxes together. (The mask keeps empty slots out even for a ray
    // with a NaN in it, which "hits" every box.)
    const BvhWideNode& node = wideNodes_[current];
    if constexpr (kCountWork)
      found.work.nodesVisited += node.boxes;
    float t[BvhWideNode::kWidth];
    unsigned hits = hitsBoxes<V>(node, walk.boxRay, t) & ((1u << node.boxes) - 1);
    if (hits != 0) {
      // Go on to a child the ray enters and push the others. The nearer first, so that a closest-hit query
      // finds a near hit early and then skips what lies beyond it; a shadow ray takes any blocker, and
      // ordering does not pay for itself there. One child hit and two are the usual cases: no sorting.
      unsigned k = unsigned(std::countr_zero(hits));
      hits &= hits - 1;
      if (hits == 0) {
        walk.current = node.child[k];
        return true;
      }
      unsigned k2 = unsigned(std::countr_zero(hits));
      hits &= hits - 1;
      if (hits == 0) {
        const bool swap = !kAnyHit && t[k2] < t[k];
        const unsigned nearer = swap ? k2 : k, farther = swap ? k : k2;
        walk.stack[walk.stackSize++] = Entry{node.child[farther], t[farther]};
        prefetchChild(node.child[farther]);
        walk.current = node.child[nearer];
        return true;
      }
      // Three or more: push them all, sort them by entry (nearest on top), and take the top.
      const int first = walk.stackSize;
      Entry* stack = walk.stack;
      int stackSize = walk.stackSize;
      stack[stackSize++] = Entry{node.child[k], t[k]};
      stack[stackSize++] = Entry{node.child[k2], t[k2]};
      for (; hits != 0; hits &= hits - 1) {
        k = unsigned(std::countr_zero(hits));
        stack[stackSize++] = Entry{node.child[k], t[k]};
      }
      for (int i = first; i < stackSize; ++i)
        prefetchChild(stack[i].child);
      if constexpr (!kAnyHit)
        for (int i = first + 1; i < stackSize; ++i) {
          const Entry e = stack[i];
          int j = i;
          for (; j > first && stack[j - 1].tEnter < e.tEnter; --j)
            stack[j] = stack[j - 1];
          stack[j] = e;
        }
      walk.current = stack[--stackSize].child;
      walk.stackSize = stackSize;
      return true;
    }
  } else {
    if ((current & BvhWideNode::kTriangles) && !walk.triangleRayReady) {
      prepareTriangleRay(ray, walk.triangleRay);
      walk.triangleRayReady = true;
    }
    if (testLeaf<kAnyHit, kCountWork, sizeof(V) == sizeof(Float8)>(ray, current, walk.triangleRay, found)) {
      if constexpr (kAnyHit) // a shadow ray needs no more than one blocker
        return false;
      walk.tNearest = floatAbove(found.t);
      fill(walk.boxRay.tmax, walk.tNearest);
    }
  }
  // Next from the stack, skipping what the ray enters only beyond a hit found since it was pushed.
  do {
    if (walk.stackSize == 0)
      return false;
    --walk.stackSize;
  } while (walk.stack[walk.stackSize].tEnter > walk.tNearest);
  walk.current = walk.stack[walk.stackSize].child;
  return true;
}
/// [traverse]

/// [testOutside]
// The primitives outside the tree, before it: the spheres (four at a time when there are enough), then the
// triangles one by one. The
// nearest of them (or any, for a shadow ray) is where the tree's walk starts from: its boxes beyond it are skipped.
template <bool kAnyHit, bool kCountWork> void Bvh::testOutside(const Ray& ray, Traversal& found) const
{
  if (outsideLanes_.size() > 0) {
    if constexpr (kCountWork)
      found.work.primitivesTested += std::uint32_t(outsideLanes_.size());
    if constexpr (kAnyHit) {
      if (outsideLanes_.occluded(ray)) {
        found.primitive = outsideSphereIndex_[0]; // some blocker: which one does not matter
        return;
      }
    } else if (const std::optional<SphereHit> h = outsideLanes_.intersect(ray)) {
      found.t = h->t;
      found.primitive = outsideSphereIndex_[std::size_t(h->sphere)];
    }
  }
  for (const SpherePrimitive& p : outsideSpheres_) { // (the brute-force loop's own: nearer ones shrink the interval)
    if constexpr (kCountWork)
      found.work.primitivesTested += 1;
    if (const std::optional<Real> t =
            intersectSphere(ray.origin, ray.direction, p.center, p.radius, ray.tmin, found.t)) {
      found.t = *t;
      found.primitive = p.index;
      if constexpr (kAnyHit)
        return;
    }
  }
  for (const OutsideTriangle& p : outsideTriangles_) {
    if constexpr (kCountWork)
      found.work.primitivesTested += 1;
    // (Up to found.t: a triangle's number is above every sphere's, so on a tie the sphere stays.)
    const std::optional<TriangleHit<Real>> h = intersectTriangle(
        ray.origin, ray.direction, p.corner[0], p.corner[1], p.corner[2], ray.tmin, found.t);
    if (h) {
      found.t = h->t;
      found.primitive = p.index;
      if constexpr (kAnyHit)
        return;
    }
  }
}
/// [testOutside]

// The whole query: the primitives outside the tree, then the tree, from the nearest of them.
template <bool kAnyHit, bool kCountWork, class V> Bvh::Traversal Bvh::query(const Ray& ray) const
{
  Traversal found{ray.tmax, -1, BvhWork{}};
  if (!outside_.empty()) {
    testOutside<kAnyHit, kCountWork>(ray, found);
    if (kAnyHit && found.primitive >= 0)
      return found;
  }
  traverse<kAnyHit, kCountWork, V>(ray, found);
  return found;
}

#if RAYLIFE_HAS_AVX2
// The query with a node's eight boxes in one register, built for AVX2 (flatten: all of it, the tests of the
// primitives outside the tree and in its leaves too, is inlined and built so). The same float operations as four at
// a time, so the same boxes, bit for bit. (With the primitives outside the tree tested before this function, in
// the baseline code, and the tree's walk called from there, the query was about 15 % slower on the random spheres:
// `bvh_bench interleave`, one at a time against one in flight, which was built this way.)
template <bool kAnyHit, bool kCountWork>
RAYLIFE_AVX2 [[gnu::flatten]] Bvh::Traversal Bvh::queryEight(const Ray& ray) const
{
  return query<kAnyHit, kCountWork, Float8>(ray);
}
#endif

template <bool kAnyHit, bool kCountWork> Bvh::Traversal Bvh::dispatch(const Ray& ray) const
{
#if RAYLIFE_HAS_AVX2
  if (eightAtOnce_)
    return queryEight<kAnyHit, kCountWork>(ray);
#endif
  return query<kAnyHit, kCountWork, Float4>(ray);
}

/// [interleave]
// kInFlight walks side by side: each turn visits one node of every walk still going, and a walk that ends hands its
// place to the next ray. The walks are independent, so the processor may overlap one's loads and box tests with
// another's (a branch mispredicted in one still throws away the work begun on all of them).
template <int kInFlight, class V>
[[gnu::flatten]] void Bvh::interleave(std::span<const Ray> rays, std::span<std::optional<BvhHit>> out) const
{
  BvhWalk<V> walks[kInFlight];
  typename BvhWalk<V>::Entry stacks[kInFlight][BvhWalk<V>::kStackSize];
  for (int k = 0; k < kInFlight; ++k)
    walks[k].stack = stacks[k];
  Traversal found[kInFlight];
  std::size_t which[kInFlight];
  bool going[kInFlight];
  std::size_t next = 0;
  // Starts the next ray that needs the tree in place k (a ray the primitives outside the tree answer for gets its
  // answer at once); false when none is left.
  auto start = [&](int k) {
    for (; next < rays.size(); ++next) {
      const Ray& ray = rays[next];
      found[k] = Traversal{ray.tmax, -1, BvhWork{}};
      if (!outside_.empty())
        testOutside<false, false>(ray, found[k]);
      if (wideNodes_.empty()) {
        out[next] = found[k].hit();
        continue;
      }
      walks[k].start(ray, found[k].t);
      which[k] = next++;
      return true;
    }
    return false;
  };
  int goingCount = 0;
  for (int k = 0; k < kInFlight; ++k)
    goingCount += going[k] = start(k);
  while (goingCount > 0)
    for (int k = 0; k < kInFlight; ++k)
      if (going[k] && !visit<false, false, V>(rays[which[k]], walks[k], found[k])) {
        out[which[k]] = found[k].hit();
        going[k] = start(k);
        goingCount -= !going[k];
      }
}
/// [interleave]

#if RAYLIFE_HAS_AVX2
template <int kInFlight>
RAYLIFE_AVX2 [[gnu::flatten]] void Bvh::interleaveEight(std::span<const Ray> rays,
                                                         std::span<std::optional<BvhHit>> out) const
{
  interleave<kInFlight, Float8>(rays, out);
}
#endif

/// [packet]
// A packet of rays as one ray with intervals for its numbers: per axis the smallest and largest of the rays' box-test
// constants (boxRayLanes'), for rays that meet the faces in the same order (the same signs).
template <class V> struct PacketBoxRay {
  std::uint32_t nearRow[4], farRow[4]; // as BoxRay's (the first ray's)
  V originNear[2][3], originFar[2][3]; // [0] the smallest, [1] the largest
  V invNear[2][3], invFar[2][3];
  V tmin, tmax; // the smallest tmin; the largest of the rays' nearest hits so far
};

// The slab test of a packet: a box is kept when any of its rays may enter it. Each entry (face − o)·(1/d) is a rounded
// product of a rounded difference, so it only grows or only shrinks with o and with 1/d: its smallest value over the
// intervals is at one of their four corners, and no ray of the packet enters earlier. Exits likewise the other way.
// So the packet's test keeps every box that one of its rays' own tests keeps. (No NaN arises: the packet is made
// only of rays whose constants are all finite; see intersectPacket.)
template <class V>
unsigned hitsBoxesPacket(const BvhWideNode& node, const PacketBoxRay<V>& r, float (&tEnter)[BvhWideNode::kWidth])
{
  constexpr int kLanes = int(sizeof(V) / sizeof(float));
  unsigned hits = 0;
  for (int k = 0; k < BvhWideNode::kWidth; k += kLanes) {
    V enter = r.tmin, exit = r.tmax;
    for (int a = 0; a < 3; ++a) {
      V faceNear, faceFar;
      loadRow(node, k, r.nearRow[a], faceNear);
      loadRow(node, k, r.farRow[a], faceFar);
      // (The smallest and largest of four, without a function that returns a V, as simd.h asks.)
      const V n0 = faceNear - r.originNear[0][a], n1 = faceNear - r.originNear[1][a];
      const V e00 = n0 * r.invNear[0][a], e01 = n0 * r.invNear[1][a], e10 = n1 * r.invNear[0][a],
              e11 = n1 * r.invNear[1][a];
      const V e0 = e00 < e01 ? e00 : e01, e1 = e10 < e11 ? e10 : e11;
      const V tNear = e0 < e1 ? e0 : e1;
      const V f0 = faceFar - r.originFar[0][a], f1 = faceFar - r.originFar[1][a];
      const V x00 = f0 * r.invFar[0][a], x01 = f0 * r.invFar[1][a], x10 = f1 * r.invFar[0][a],
              x11 = f1 * r.invFar[1][a];
      const V x0 = x00 > x01 ? x00 : x01, x1 = x10 > x11 ? x10 : x11;
      const V tFar = x0 > x1 ? x0 : x1;
      enter = tNear > enter ? tNear : enter;
      exit = tFar < exit ? tFar : exit;
    }
    std::memcpy(&tEnter[k], &enter, sizeof enter);
    hits |= bitMask(enter <= exit) << k;
  }
  return hits;
}

// Up to kPacket rays through the tree together: one walk, each node's boxes tested once for the packet, each leaf's
// primitives for every ray that may still find something there. Rays whose signs differ from the first's, or whose
// constants are not all finite, walk alone.
template <class V>
[[gnu::flatten]] void Bvh::packet(std::span<const Ray> rays, std::span<std::optional<BvhHit>> out) const
{
  const std::size_t n = rays.size();
  Traversal found[kPacket];
  float nearest[kPacket]; // each ray's nearest hit so far, rounded up: a box it enters beyond that is none of its
  TriangleRay triangleRays[kPacket];
  for (std::size_t i = 0; i < n; ++i) {
    found[i] = Traversal{rays[i].tmax, -1, BvhWork{}};
    if (!outside_.empty())
      testOutside<false, false>(rays[i], found[i]);
    if (!packs_.empty() || !floatPacks_.empty())
      prepareTriangleRay(rays[i], triangleRays[i]);
  }
  // The packet's intervals, from each ray's own constants: the smallest and the largest of each, the three axes
  // and lane 3 (tmax in originNear's, tmin in originFar's) at once. (Made ray by ray as a whole BoxRay, each
  // number then taken apart, they made the packets take half as long again: perf, chapter 16 on the random spheres.)
  bool together = !wideNodes_.empty() && n > 0;
  BoxRayLanes low{}, high{};
  Mask4 finite = ~Mask4{}; // lanes 0 to 2: every ray's four constants finite on that axis so far
  for (std::size_t i = 0; i < n && together; ++i) {
    const BoxRayLanes c = boxRayLanes(rays[i], found[i].t);
    nearest[i] = c.originNear[3];
    if (i == 0) {
      low = high = c;
    } else {
      together = bitMask(c.negative == low.negative) == 0xf; // the same signs as the first ray
      // (minLanes(v, m) is std::min(m, v) lane by lane, maxLanes(v, m) std::max(m, v): the same numbers as one at a
      // time.)
      low.originNear = minLanes(c.originNear, low.originNear);
      high.originNear = maxLanes(c.originNear, high.originNear);
      low.originFar = minLanes(c.originFar, low.originFar), high.originFar = maxLanes(c.originFar, high.originFar);
      low.invNear = minLanes(c.invNear, low.invNear), high.invNear = maxLanes(c.invNear, high.invNear);
      low.invFar = minLanes(c.invFar, low.invFar), high.invFar = maxLanes(c.invFar, high.invFar);
    }
    // |x| < ∞, without a branch: false for ±∞ and NaN.
    auto isFinite = [](const Float4& v) { return (Mask4)((Float4)((Mask4)v & 0x7fffffff) < kInfinityF); };
    finite &= isFinite(c.originNear) & isFinite(c.originFar) & isFinite(c.invNear) & isFinite(c.invFar);
  }
  together = together && (bitMask(finite) & 0x7) == 0x7;
  if (!together) {
    for (std::size_t i = 0; i < n; ++i) {
      traverse<false, false, V>(rays[i], found[i]);
      out[i] = found[i].hit();
    }
    return;
  }
  PacketBoxRay<V> packet;
  boxRows(low.negative, packet.nearRow, packet.farRow);
  for (int a = 0; a < 3; ++a) {
    fill(packet.originNear[0][a], low.originNear[a]), fill(packet.originNear[1][a], high.originNear[a]);
    fill(packet.originFar[0][a], low.originFar[a]), fill(packet.originFar[1][a], high.originFar[a]);
    fill(packet.invNear[0][a], low.invNear[a]), fill(packet.invNear[1][a], high.invNear[a]);
    fill(packet.invFar[0][a], low.invFar[a]), fill(packet.invFar[1][a], high.invFar[a]);
  }
  fill(packet.tmin, low.originFar[3]);
  float tmax = high.originNear[3];
  fill(packet.tmax, tmax);

  // The walk: depth first, the nearer child first (by where the packet enters it), as a single ray's.
  using Entry = typename BvhWalk<V>::Entry;
  Entry stack[BvhWalk<V>::kStackSize];
  int stackSize = 0;
  Entry current{0, -kInfinityF};
  for (;;) {
    if ((current.child & BvhWideNode::kLeaf) == 0) {
      const BvhWideNode& node = wideNodes_[current.child];
      float t[BvhWideNode::kWidth];
      unsigned hits = hitsBoxesPacket<V>(node, packet, t) & ((1u << node.boxes) - 1);
      if (hits != 0) {
        const int first = stackSize;
        for (; hits != 0; hits &= hits - 1) {
          const unsigned k = unsigned(std::countr_zero(hits));
          Entry e{node.child[k], t[k]};
          int j = stackSize++;
          for (; j > first && stack[j - 1].tEnter < e.tEnter; --j)
            stack[j] = stack[j - 1];
          stack[j] = e;
        }
        current = stack[--stackSize];
        continue;
      }
    } else {
      bool changed = false;
      for (std::size_t i = 0; i < n; ++i)
        if (!(current.tEnter > nearest[i]) &&
            testLeaf<false, false, sizeof(V) == sizeof(Float8)>(rays[i], current.child, triangleRays[i], found[i])) {
          nearest[i] = floatAbove(found[i].t);
          changed = true;
        }
      if (changed) {
        tmax = *std::max_element(nearest, nearest + n);
        fill(packet.tmax, tmax);
      }
    }
    do {
      if (stackSize == 0) {
        for (std::size_t i = 0; i < n; ++i)
          out[i] = found[i].hit();
        return;
      }
      --stackSize;
    } while (stack[stackSize].tEnter > tmax);
    current = stack[stackSize];
  }
}

#if RAYLIFE_HAS_AVX2
RAYLIFE_AVX2 [[gnu::flatten]] void Bvh::packetEight(std::span<const Ray> rays, std::span<std::optional<BvhHit>> out) const
{
  packet<Float8>(rays, out);
}
#endif

void Bvh::intersectPacket(std::span<const Ray> rays, std::span<std::optional<BvhHit>> out) const
{
  if (out.size() < rays.size())
    throw std::invalid_argument("Bvh::intersectPacket: out is shorter than rays");
  for (std::size_t i = 0; i < rays.size(); i += kPacket) {
    const std::size_t n = std::min(kPacket, rays.size() - i);
#if RAYLIFE_HAS_AVX2
    if (eightAtOnce_) {
      packetEight(rays.subspan(i, n), out.subspan(i, n));
      continue;
    }
#endif
    packet<Float4>(rays.subspan(i, n), out.subspan(i, n));
  }
}
/// [packet]

void Bvh::intersectInterleaved(std::span<const Ray> rays, std::span<std::optional<BvhHit>> out, int inFlight) const
{
  if (out.size() < rays.size() || (inFlight != 1 && inFlight != 2 && inFlight != 4))
    throw std::invalid_argument("Bvh::intersectInterleaved: out is shorter than rays, or inFlight is not 1, 2 or 4");
#if RAYLIFE_HAS_AVX2
  if (eightAtOnce_) {
    if (inFlight == 1)
      interleaveEight<1>(rays, out);
    else if (inFlight == 2)
      interleaveEight<2>(rays, out);
    else
      interleaveEight<4>(rays, out);
    return;
  }
#endif
  if (inFlight == 1)
    interleave<1, Float4>(rays, out);
  else if (inFlight == 2)
    interleave<2, Float4>(rays, out);
  else
    interleave<4, Float4>(rays, out);
}

std::optional<BvhHit> Bvh::intersect(const Ray& ray) const
{
  return dispatch<false, false>(ray).hit();
}

bool Bvh::occluded(const Ray& ray) const { return dispatch<true, false>(ray).primitive >= 0; }

BvhTracedHit Bvh::intersectWithWork(const Ray& ray) const
{
  const Traversal r = dispatch<false, true>(ray);
  return BvhTracedHit{r.hit(), r.work};
}

BvhTracedOcclusion Bvh::occludedWithWork(const Ray& ray) const
{
  const Traversal r = dispatch<true, true>(ray);
  return BvhTracedOcclusion{r.primitive >= 0, r.work};
}

std::size_t Bvh::memoryBytes() const
{
  return wideNodes_.size() * sizeof(BvhWideNode) + packs_.size() * sizeof(TrianglePack) +
         floatPacks_.size() * sizeof(FloatTrianglePack) + spheres_.size() * sizeof(SpherePrimitive) +
         velocities_.size() * sizeof(Vec3) + outside_.size() * sizeof(int) +
         outsideSpheres_.size() * sizeof(SpherePrimitive) + outsideSphereIndex_.size() * sizeof(int) +
         outsideTriangles_.size() * sizeof(OutsideTriangle) + outsideLanes_.size() * 4 * sizeof(Real);
}

Real Bvh::sahCost(const BvhCosts& costs) const
{
  if (nodes_.empty())
    return 0;
  const Real rootArea = nodeArea(nodes_[0]);
  Real cost = 0;
  for (const BvhNode& n : nodes_) {
    const Real share = rootArea > 0 ? nodeArea(n) / rootArea : Real(1);
    cost += n.count > 0 ? share * Real(n.count) * costs.intersection : share * costs.traversal;
  }
  return cost;
}

std::vector<std::uint32_t> Bvh::leafPrimitives(bool triangles) const
{
  std::vector<std::uint32_t> list;
  auto add = [&list](const auto& primitives) {
    for (const auto& p : primitives)
      list.push_back(std::uint32_t(p.index) | (p.lastInLeaf ? kLastInLeaf : 0u));
  };
  if (!triangles) {
    add(spheres_);
    return list;
  }
  // Four entries a pack, so that a leaf child's pack index k starts at entry 4k; a pack's lanes past its count
  // repeat its last triangle (tested again, it changes nothing: the same t loses the tie to itself).
  auto addPacks = [&list](const auto& packs) {
    for (const auto& pack : packs) {
      const std::uint32_t count = pack.count & ~kLastPack;
      for (std::uint32_t lane = 0; lane < 4; ++lane) {
        const bool last = (pack.count & kLastPack) != 0 && lane == 3;
        list.push_back(std::uint32_t(pack.index[std::min(lane, count - 1)]) | (last ? kLastInLeaf : 0u));
      }
    }
  };
  addPacks(packs_);
  addPacks(floatPacks_);
  return list;
}

} // namespace raylife

#include "bvh.h"

#include <algorithm>
#include <array>
#include <bit>
#include <limits>

namespace raylife {

namespace {

// ---- Bounds ---------------------------------------------------------------------------------------------------

// A sphere's box, widened by kBoxMargin relative to the size of its coordinates (see math.h for why).
Bounds3 sphereBounds(const Sphere& s)
{
  const Real margin = kBoxMargin<Real> * (maxComponent(glm::abs(s.center)) + s.radius);
  const Vec3 extent(s.radius + margin);
  return Bounds3{s.center - extent, s.center + extent};
}

// The float at or below x (and at or above, for roundUp): a float box rounded outwards holds the exact box.
float roundDown(Real x)
{
  constexpr Real kFloatMax = Real(std::numeric_limits<float>::max());
  if (x > kFloatMax)
    return std::numeric_limits<float>::max();
  if (x < -kFloatMax)
    return -std::numeric_limits<float>::infinity();
  float f = float(x);
  if (Real(f) > x)
    f = std::nextafter(f, -std::numeric_limits<float>::infinity());
  return f;
}

float roundUp(Real x) { return -roundDown(-x); }

// ---- Building -------------------------------------------------------------------------------------------------

// A sphere while the tree is built: its box, the centre of that box (what the splits sort by), its index.
struct BuildItem {
  Bounds3 bounds;
  Vec3 centroid;
  int index;
};

// Where to split a node's items [begin, end): items [begin, mid) go to the first child, [mid, end) to the second.
struct Split {
  std::size_t mid;
  int axis;
};

int ceilLog2(std::size_t n) { return n <= 1 ? 0 : int(std::bit_width(n - 1)); }

int longestAxis(const Bounds3& b)
{
  const Vec3 d = b.hi - b.lo;
  return d.x >= d.y && d.x >= d.z ? 0 : (d.y >= d.z ? 1 : 2);
}

class Builder {
public:
  Builder(std::vector<BuildItem> items, const BvhBuildOptions& options) : items_(std::move(items)), options_(options)
  {
    options_.bins = std::clamp(options_.bins, 2, kMaxBins);
    options_.maxLeafSize = std::clamp(options_.maxLeafSize, 1, 255);
  }

  std::vector<BvhNode> nodes;
  int depth = 0;

  // Builds the subtree over items [begin, end) at `level` (root 1), appending its nodes depth first.
  void build(std::size_t begin, std::size_t end, int level)
  {
    const std::size_t nodeIndex = nodes.size();
    nodes.push_back(BvhNode{});
    depth = std::max(depth, level);

    // Bound the node's spheres, and their centroids (the splits choose among centroids).
    Bounds3 bounds, centroids;
    for (std::size_t i = begin; i < end; ++i) {
      bounds = bounds.merged(items_[i].bounds);
      centroids = centroids.merged(items_[i].centroid);
    }
    for (int a = 0; a < 3; ++a) {
      nodes[nodeIndex].bounds[0][a] = roundDown(bounds.lo[a]);
      nodes[nodeIndex].bounds[1][a] = roundUp(bounds.hi[a]);
    }

    const std::optional<Split> split = chooseSplit(begin, end, bounds, centroids, level);
    if (!split) {
      // A leaf: its spheres are items [begin, end), which is where they stay in the final order.
      nodes[nodeIndex].offset = std::uint32_t(begin);
      nodes[nodeIndex].count = std::uint16_t(end - begin);
      nodes[nodeIndex].axis = 0;
      return;
    }
    // An interior node: the first child follows it, the second comes after the first's whole subtree.
    build(begin, split->mid, level + 1);
    const std::size_t second = nodes.size();
    build(split->mid, end, level + 1);
    nodes[nodeIndex].offset = std::uint32_t(second);
    nodes[nodeIndex].count = 0;
    nodes[nodeIndex].axis = std::uint8_t(split->axis);
  }

  const std::vector<BuildItem>& items() const { return items_; }

private:
  static constexpr int kMaxBins = 64;

  std::optional<Split> chooseSplit(std::size_t begin, std::size_t end, const Bounds3& bounds,
                                   const Bounds3& centroids, int level)
  {
    const std::size_t n = end - begin;
    if (n == 1)
      return std::nullopt;
    // Near the depth limit, halve by count: that reaches single spheres in ceil(log2 n) more levels.
    if (level + ceilLog2(n) + 1 >= Bvh::kMaxDepth)
      return equalCounts(begin, end, longestAxis(centroids));
    if (options_.split == BvhSplit::Midpoint)
      return midpoint(begin, end, centroids);
    return sah(begin, end, bounds, centroids);
  }

  // Halves the items by count along `axis` (centroid order, then index, so the result is fully determined).
  Split equalCounts(std::size_t begin, std::size_t end, int axis)
  {
    const std::size_t mid = begin + (end - begin) / 2;
    std::nth_element(items_.begin() + std::ptrdiff_t(begin), items_.begin() + std::ptrdiff_t(mid),
                     items_.begin() + std::ptrdiff_t(end), [axis](const BuildItem& a, const BuildItem& b) {
                       return a.centroid[axis] < b.centroid[axis] ||
                              (a.centroid[axis] == b.centroid[axis] && a.index < b.index);
                     });
    return Split{mid, axis};
  }

  // The bad split, for comparison: the middle of the centroids' longest axis, whatever it costs.
  std::optional<Split> midpoint(std::size_t begin, std::size_t end, const Bounds3& centroids)
  {
    if (end - begin <= std::size_t(options_.maxLeafSize))
      return std::nullopt;
    const int axis = longestAxis(centroids);
    const Real middle = (centroids.lo[axis] + centroids.hi[axis]) / 2;
    const auto midIt = std::partition(items_.begin() + std::ptrdiff_t(begin), items_.begin() + std::ptrdiff_t(end),
                                      [&](const BuildItem& item) { return item.centroid[axis] < middle; });
    const std::size_t mid = std::size_t(midIt - items_.begin());
    if (mid == begin || mid == end) // every centroid on one side (all equal): split by count instead
      return equalCounts(begin, end, axis);
    return Split{mid, axis};
  }

  /// [sah]
  // The surface area heuristic. A ray that hits a node's box hits a child's box with probability about
  // A_child / A_node (for rays from all directions), so splitting into L and R costs, per ray,
  //   C = C_trav + (A_L / A)·N_L·C_isect + (A_R / A)·N_R·C_isect,
  // against N·C_isect for keeping the node a leaf. The centroids are sorted into a few bins per axis, and every
  // boundary between bins is priced; the cheapest wins.
  std::optional<Split> sah(std::size_t begin, std::size_t end, const Bounds3& bounds, const Bounds3& centroids)
  {
    const std::size_t n = end - begin;
    const BvhCosts costs;
    const int bins = options_.bins;
    const Real area = bounds.surfaceArea();
    const Real leafCost = Real(n) * costs.intersection;

    Real bestCost = kInfinity;
    int bestAxis = -1, bestBin = -1;
    if (area > 0 && area < kInfinity) {
      for (int axis = 0; axis < 3; ++axis) {
        const Real lo = centroids.lo[axis], extent = centroids.hi[axis] - lo;
        if (!(extent > 0 && extent < kInfinity))
          continue; // every centroid in one plane across this axis: nothing to split
        // Sort the centroids into bins: each bin's count and the box of its spheres.
        std::array<std::size_t, kMaxBins> count{};
        std::array<Bounds3, kMaxBins> box{};
        for (std::size_t i = begin; i < end; ++i) {
          const int b = binOf(items_[i].centroid[axis], lo, extent);
          count[std::size_t(b)] += 1;
          box[std::size_t(b)] = box[std::size_t(b)].merged(items_[i].bounds);
        }
        // Sweep from the right to know, for each boundary, the area and count of everything to its right.
        std::array<Real, kMaxBins> rightArea{};
        std::array<std::size_t, kMaxBins> rightCount{};
        Bounds3 right;
        std::size_t nRight = 0;
        for (int b = bins - 1; b > 0; --b) {
          right = right.merged(box[std::size_t(b)]);
          nRight += count[std::size_t(b)];
          rightArea[std::size_t(b)] = right.surfaceArea();
          rightCount[std::size_t(b)] = nRight;
        }
        // Sweep from the left and price each boundary (left: bins 0..b, right: bins b+1..).
        Bounds3 left;
        std::size_t nLeft = 0;
        for (int b = 0; b + 1 < bins; ++b) {
          left = left.merged(box[std::size_t(b)]);
          nLeft += count[std::size_t(b)];
          const std::size_t nR = rightCount[std::size_t(b + 1)];
          if (nLeft == 0 || nR == 0)
            continue;
          const Real cost = costs.traversal + (left.surfaceArea() * Real(nLeft) +
                                               rightArea[std::size_t(b + 1)] * Real(nR)) / area * costs.intersection;
          if (cost < bestCost) {
            bestCost = cost;
            bestAxis = axis;
            bestBin = b;
          }
        }
      }
    }

    // Keep a leaf when no split pays for itself (and the leaf is small enough).
    if (n <= std::size_t(options_.maxLeafSize) && !(bestCost < leafCost))
      return std::nullopt;
    if (bestAxis < 0) // no boundary separates any centroids: split by count
      return equalCounts(begin, end, longestAxis(centroids));
    const Real lo = centroids.lo[bestAxis], extent = centroids.hi[bestAxis] - lo;
    const auto midIt = std::partition(
        items_.begin() + std::ptrdiff_t(begin), items_.begin() + std::ptrdiff_t(end),
        [&](const BuildItem& item) { return binOf(item.centroid[bestAxis], lo, extent) <= bestBin; });
    return Split{std::size_t(midIt - items_.begin()), bestAxis};
  }
  /// [sah]

  int binOf(Real c, Real lo, Real extent) const
  {
    const int b = int(Real(options_.bins) * ((c - lo) / extent));
    return std::clamp(b, 0, options_.bins - 1);
  }

  std::vector<BuildItem> items_;
  BvhBuildOptions options_;
};

// ---- Traversal ------------------------------------------------------------------------------------------------

// A ray prepared for box tests: 1/d per axis (±∞ where d is ±0), and per axis which corner of a box (0: lo,
// 1: hi) holds the face the ray meets first.
struct BoxRay {
  Vec3 origin;
  Vec3 invDir;
  int nearCorner[3];
};

/// [slab]
// The slab test: the ray is inside the box where it is inside all three slabs lo ≤ p ≤ hi, i.e. for t between
// the largest entry and the smallest exit. Robust where d has a zero component: 1/d = ±∞ gives entry −∞ and
// exit +∞ for an origin inside the slab, +∞ (a miss) outside; an origin exactly on the plane gives 0·∞ = NaN,
// which the comparisons below ignore (the box is kept, which is safe). The interval is then widened by
// kBoxMargin so that rounding never culls a box the ray touches.
inline bool hitsBox(const BvhNode& node, const BoxRay& r, Real tmin, Real tmax)
{
  // Entry and exit of each slab; the near face is lo for a positive direction, hi for a negative one.
  const Real txNear = (Real(node.bounds[r.nearCorner[0]].x) - r.origin.x) * r.invDir.x;
  const Real txFar = (Real(node.bounds[1 - r.nearCorner[0]].x) - r.origin.x) * r.invDir.x;
  const Real tyNear = (Real(node.bounds[r.nearCorner[1]].y) - r.origin.y) * r.invDir.y;
  const Real tyFar = (Real(node.bounds[1 - r.nearCorner[1]].y) - r.origin.y) * r.invDir.y;
  const Real tzNear = (Real(node.bounds[r.nearCorner[2]].z) - r.origin.z) * r.invDir.z;
  const Real tzFar = (Real(node.bounds[1 - r.nearCorner[2]].z) - r.origin.z) * r.invDir.z;
  // The largest entry and the smallest exit; a NaN never wins a comparison, so it leaves the slab unbounded.
  Real tEnter = -kInfinity;
  tEnter = txNear > tEnter ? txNear : tEnter;
  tEnter = tyNear > tEnter ? tyNear : tEnter;
  tEnter = tzNear > tEnter ? tzNear : tEnter;
  Real tExit = kInfinity;
  tExit = txFar < tExit ? txFar : tExit;
  tExit = tyFar < tExit ? tyFar : tExit;
  tExit = tzFar < tExit ? tzFar : tExit;
  // Widen for rounding (by scaling, which keeps ±∞ as they are), then intersect with the ray's own interval.
  tEnter *= tEnter > 0 ? 1 - kBoxMargin<Real> : 1 + kBoxMargin<Real>;
  tExit *= tExit > 0 ? 1 + kBoxMargin<Real> : 1 - kBoxMargin<Real>;
  return (tEnter > tmin ? tEnter : tmin) <= (tExit < tmax ? tExit : tmax);
}
/// [slab]

} // namespace

Bvh::Bvh(const std::vector<Sphere>& spheres, const BvhBuildOptions& options)
{
  if (spheres.empty())
    return;
  std::vector<BuildItem> items(spheres.size());
  for (std::size_t i = 0; i < spheres.size(); ++i) {
    const Bounds3 b = sphereBounds(spheres[i]);
    items[i] = BuildItem{b, (b.lo + b.hi) / Real(2), int(i)};
  }
  Builder builder(std::move(items), options);
  builder.nodes.reserve(2 * spheres.size());
  builder.build(0, spheres.size(), 1);
  nodes_ = std::move(builder.nodes);
  nodes_.shrink_to_fit();
  depth_ = builder.depth;

  // The spheres in leaf order, so that a leaf's spheres lie side by side in memory.
  primitives_.reserve(spheres.size());
  for (const BuildItem& item : builder.items()) {
    const Sphere& s = spheres[std::size_t(item.index)];
    primitives_.push_back(Primitive{s.center, s.radius, item.index});
  }
}

/// [traverse]
// (flatten: inline the sphere test into the loop, as it is in the scene's flat loop; a call per sphere costs more
// than the test.)
template <bool kAnyHit, bool kCountWork> [[gnu::flatten]] Bvh::Traversal Bvh::traverse(const Ray& ray) const
{
  Traversal found{ray.tmax, -1, BvhWork{}};
  if (nodes_.empty())
    return found;
  const Vec3 invDir = Real(1) / ray.direction;
  const BoxRay boxRay{ray.origin, invDir, {int(invDir.x < 0), int(invDir.y < 0), int(invDir.z < 0)}};

  // Depth first, from a small stack of nodes still to visit; the nearer child always first.
  std::uint32_t stack[kMaxDepth];
  int stackSize = 0;
  std::uint32_t current = 0;
  while (true) {
    const BvhNode& node = nodes_[current];
    if constexpr (kCountWork)
      found.work.nodesVisited += 1;
    // Skip the node when the ray misses its box, or meets it only beyond the nearest hit so far.
    if (hitsBox(node, boxRay, ray.tmin, found.t)) {
      if (node.count > 0) {
        // A leaf: test its spheres. Keep the nearer hit, or on a tie the lower index (as the brute-force
        // loop's strict "nearer" does), so the answer does not depend on the order of the tree.
        if constexpr (kCountWork)
          found.work.primitivesTested += node.count;
        for (std::uint32_t i = node.offset; i < node.offset + node.count; ++i) {
          const Primitive& p = primitives_[i];
          const std::optional<Real> t =
              intersectSphere(ray.origin, ray.direction, p.center, p.radius, ray.tmin, ray.tmax);
          if (!t)
            continue;
          if constexpr (kAnyHit)
            return Traversal{*t, p.index, found.work}; // a shadow ray needs no more than one blocker
          if (*t < found.t || (*t == found.t && p.index < found.primitive)) {
            found.t = *t;
            found.primitive = p.index;
          }
        }
      } else {
        // An interior node: go on to the child on the ray's side of the split; remember the other.
        if (boxRay.nearCorner[node.axis]) {
          stack[stackSize++] = current + 1;
          current = node.offset;
        } else {
          stack[stackSize++] = node.offset;
          current = current + 1;
        }
        continue;
      }
    }
    if (stackSize == 0)
      break;
    current = stack[--stackSize];
  }
  return found;
}
/// [traverse]

std::optional<BvhHit> Bvh::intersect(const Ray& ray) const
{
  const Traversal r = traverse<false, false>(ray);
  if (r.primitive < 0)
    return std::nullopt;
  return BvhHit{r.t, r.primitive};
}

bool Bvh::occluded(const Ray& ray) const { return traverse<true, false>(ray).primitive >= 0; }

BvhTracedHit Bvh::intersectWithWork(const Ray& ray) const
{
  const Traversal r = traverse<false, true>(ray);
  if (r.primitive < 0)
    return BvhTracedHit{std::nullopt, r.work};
  return BvhTracedHit{BvhHit{r.t, r.primitive}, r.work};
}

BvhTracedOcclusion Bvh::occludedWithWork(const Ray& ray) const
{
  const Traversal r = traverse<true, true>(ray);
  return BvhTracedOcclusion{r.primitive >= 0, r.work};
}

Real Bvh::sahCost(const BvhCosts& costs) const
{
  if (nodes_.empty())
    return 0;
  auto area = [](const BvhNode& n) {
    return Bounds3{Vec3(n.bounds[0]), Vec3(n.bounds[1])}.surfaceArea();
  };
  const Real rootArea = area(nodes_[0]);
  Real cost = 0;
  for (const BvhNode& n : nodes_) {
    const Real share = rootArea > 0 ? area(n) / rootArea : Real(1);
    cost += n.count > 0 ? share * Real(n.count) * costs.intersection : share * costs.traversal;
  }
  return cost;
}

} // namespace raylife

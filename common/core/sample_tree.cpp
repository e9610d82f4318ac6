#include "core/sample_tree.h"

#include <algorithm>
#include <cmath>

namespace raylife {

namespace {

// The largest Real below 1: every coordinate the tree returns stays in [0, 1).
const Real kBelowOne = std::nextafter(Real(1), Real(0));

// The quadrant (0 to 3, as SampleTree::Node orders them) of `p` in its node's own square [0, 1)², and `p` moved
// into that quadrant's own square (×2 and −1 are exact in binary floating point).
int quadrant(Vec2& p)
{
  const int qx = p.x >= Real(0.5) ? 1 : 0, qy = p.y >= Real(0.5) ? 1 : 0;
  p = Vec2(std::min(2 * p.x - Real(qx), kBelowOne), std::min(2 * p.y - Real(qy), kBelowOne));
  return qx + 2 * qy;
}

} // namespace

SampleTree SampleTree::fromPoints(const std::vector<Vec2>& points, int maxDepth, double splitShare, int minSplit)
{
  SampleTree tree;
  const std::size_t total = points.size();
  if (maxDepth < 1 || total < std::size_t(std::max(1, minSplit)))
    return tree;
  maxDepth = std::min(maxDepth, 20);
  // Each point in its node's own square; the points of one node lie together in `local`, split in place.
  std::vector<Vec2> local;
  local.reserve(total);
  for (const Vec2& p : points)
    local.emplace_back(std::clamp(p.x, Real(0), kBelowOne), std::clamp(p.y, Real(0), kBelowOne));
  const double splitCount = std::max(double(minSplit), splitShare * double(total));

  // Builds the node over local[begin, end) at `depth` and returns its index (its children first filled in).
  auto build = [&](auto&& self, std::size_t begin, std::size_t end, int depth) -> std::int32_t {
    const auto index = std::int32_t(tree.nodes_.size());
    tree.nodes_.emplace_back();
    // Sort the node's points by quadrant (a stable counting sort, so the order never depends on ties).
    std::array<std::vector<Vec2>, 4> byQuadrant;
    for (std::size_t i = begin; i < end; ++i) {
      Vec2 p = local[i];
      byQuadrant[std::size_t(quadrant(p))].push_back(p);
    }
    std::size_t at = begin;
    std::array<std::size_t, 5> bounds{};
    for (std::size_t q = 0; q < 4; ++q) {
      bounds[q] = at;
      std::copy(byQuadrant[q].begin(), byQuadrant[q].end(), local.begin() + std::ptrdiff_t(at));
      at += byQuadrant[q].size();
    }
    bounds[4] = at;
    const Real count = Real(end - begin);
    for (std::size_t q = 0; q < 4; ++q) {
      const std::size_t n = bounds[q + 1] - bounds[q];
      tree.nodes_[std::size_t(index)].share[q] = Real(n) / count;
      if (depth + 1 < maxDepth && double(n) >= splitCount) {
        const std::int32_t child = self(self, bounds[q], bounds[q + 1], depth + 1);
        tree.nodes_[std::size_t(index)].child[q] = child;
      }
    }
    return index;
  };
  build(build, 0, total, 0);
  return tree;
}

int SampleTree::leafCount() const
{
  if (nodes_.empty())
    return 1;
  int leaves = 0;
  for (const Node& n : nodes_)
    for (std::int32_t c : n.child)
      leaves += c < 0;
  return leaves;
}

int SampleTree::depth() const
{
  if (nodes_.empty())
    return 0;
  // Children always come after their parent, so one pass from the root gives every node's depth.
  std::vector<int> depthOf(nodes_.size(), 1);
  int deepest = 1;
  for (std::size_t i = 0; i < nodes_.size(); ++i)
    for (std::int32_t c : nodes_[i].child)
      if (c >= 0) {
        depthOf[std::size_t(c)] = depthOf[i] + 1;
        deepest = std::max(deepest, depthOf[std::size_t(c)]);
      }
  return deepest;
}

// [sampleTree]
Vec2 SampleTree::sample(Vec2 u) const
{
  if (nodes_.empty())
    return u;
  // Hierarchical warping: at each node, u.x chooses the column of quadrants by their shares and u.y the quadrant
  // in it; each is then stretched back over [0, 1) to choose inside the quadrant, down to a leaf.
  Vec2 offset(0);
  Real size = 1;
  std::int32_t node = 0;
  for (;;) {
    const std::array<Real, 4>& s = nodes_[std::size_t(node)].share;
    const Real left = s[0] + s[2], right = s[1] + s[3];
    const int qx = u.x < left || !(right > 0) ? 0 : 1; // (shares sum to 1 only to rounding)
    u.x = qx == 0 ? u.x / left : (u.x - left) / right;
    const Real bottom = s[std::size_t(qx)], column = qx == 0 ? left : right;
    const Real pBottom = bottom / column;
    const int qy = u.y < pBottom || !(column > bottom) ? 0 : 1;
    u.y = qy == 0 ? u.y / pBottom : (u.y - pBottom) / (1 - pBottom);
    u = Vec2(std::clamp(u.x, Real(0), kBelowOne), std::clamp(u.y, Real(0), kBelowOne));
    size /= 2;
    offset += size * Vec2(Real(qx), Real(qy));
    const std::int32_t child = nodes_[std::size_t(node)].child[std::size_t(qx + 2 * qy)];
    if (child < 0)
      break;
    node = child;
  }
  const Vec2 p = offset + size * u;
  return Vec2(std::min(p.x, kBelowOne), std::min(p.y, kBelowOne));
}

Real SampleTree::pdf(Vec2 p) const
{
  if (nodes_.empty())
    return 1;
  // The product, down to p's leaf, of each quadrant's share over its quarter of the parent's area.
  p = Vec2(std::clamp(p.x, Real(0), kBelowOne), std::clamp(p.y, Real(0), kBelowOne));
  Real density = 1;
  std::int32_t node = 0;
  while (node >= 0) {
    const std::size_t q = std::size_t(quadrant(p));
    density *= 4 * nodes_[std::size_t(node)].share[q];
    node = nodes_[std::size_t(node)].child[q];
  }
  return density;
}
// [sampleTree]

MixtureSample SampleTree::sampleMixture(Vec2 u, Real alpha) const
{
  const Vec2 p = u.x < alpha ? Vec2(u.x / alpha, u.y)
                             : sample(Vec2(std::min((u.x - alpha) / (1 - alpha), kBelowOne), u.y));
  return {p, alpha + (1 - alpha) * pdf(p)};
}

SampleForestIndex SampleTree::appendTo(SampleForest& forest) const
{
  if (nodes_.empty())
    return -1;
  const auto first = SampleForestIndex(forest.share.size() / 4);
  for (const Node& node : nodes_) {
    for (std::size_t q = 0; q < 4; ++q) {
      forest.share.push_back(node.share[q]);
      forest.child.push_back(node.child[q] < 0 ? -1 : first + SampleForestIndex(node.child[q]));
    }
    // (As sample() computes them: left, right, and bottom / column.)
    const Real left = node.share[0] + node.share[2], right = node.share[1] + node.share[3];
    forest.column.push_back(left), forest.column.push_back(right);
    forest.bottom.push_back(node.share[0] / left), forest.bottom.push_back(node.share[1] / right);
  }
  return first;
}

} // namespace raylife

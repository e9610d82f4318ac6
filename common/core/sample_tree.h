/// @file sample_tree.h
/// @brief A piecewise-constant density on the unit square [0, 1)², held in a quadtree and learned from points:
/// where the points are dense the tree is deep and the density high. It warps uniform numbers into points of its
/// density (sample) and gives that density for any point (pdf), so a sampler that maps the square onto
/// directions (the cone of a sphere light, light_sampling.h) can be steered towards where the points were.
///
/// Its nodes split the square into four equal quadrants, as Müller et al.'s "Practical Path Guiding" (2017) does
/// for directions: a node is split while it holds more than a set share of the points, so the leaves hold about
/// equal numbers of them and the density adapts to regions of any size, down to 2⁻ᵐᵃˣᴰᵉᵖᵗʰ of a side.
#pragma once

#include "core/math.h"

#include <array>
#include <cstdint>
#include <type_traits>
#include <vector>

namespace raylife {

/// A node index in a SampleForest: a signed integer as wide as Real, so that SIMD lanes of Real can gather by it.
using SampleForestIndex = LaneIndex;

/// The nodes of many SampleTrees in one table (SampleTree::appendTo), for walking many points at once through
/// different trees, one per SIMD lane (chapter 16's guidedWarps, render/ray_stream.h). Node k's quadrant q (0 to 3,
/// in the order of SampleTree's nodes): its share of the node's points share[4k + q], and its child node
/// child[4k + q] (an index k' into this table), or −1 for a leaf. Its columns c (0: x < ½, 1: x ≥ ½), computed once
/// with the arithmetic sample() does per point: their share column[2k + c] (share[c] + share[c + 2]) and the share
/// of the lower quadrant within each, bottom[2k + c] (share[c] ÷ column[2k + c]).
struct SampleForest {
  std::vector<Real> share;                ///< 4 per node: each quadrant's share of its node's points, in [0, 1].
  std::vector<SampleForestIndex> child;   ///< 4 per node: each quadrant's node in this table, or −1 (a leaf).
  std::vector<Real> column;               ///< 2 per node: each column's share of the node's points.
  std::vector<Real> bottom;               ///< 2 per node: the lower quadrant's share of its column's points.
};

/// A point drawn from a SampleTree mixed with the uniform density (SampleTree::sampleMixture), and the mixture's
/// density there.
struct MixtureSample {
  Vec2 p{0};   ///< The point, in [0, 1)².
  Real pdf = 1; ///< α + (1 − α) × the tree's density at p: > 0 when α > 0.
};

/// A density on [0, 1)² that is constant on each leaf of a quadtree. Empty (default) is the uniform density 1.
/// Built once, then only read: threads share it.
class SampleTree {
public:
  /// The uniform density.
  SampleTree() = default;

  /// The density of `points` (each in [0, 1)², weight 1): a leaf's density is the share of the points in it over
  /// its area. A node is split while it holds at least `minSplit` points and more than `splitShare` of all of
  /// them, down to depth `maxDepth`. Fewer than `minSplit` points give the uniform density. Deterministic: the
  /// same points in any order give the same tree.
  /// @param points points in [0, 1)² (outside ones are clamped in). @param maxDepth ≥ 0, at most 20.
  /// @param splitShare in (0, 1]. @param minSplit ≥ 1.
  static SampleTree fromPoints(const std::vector<Vec2>& points, int maxDepth, double splitShare, int minSplit);

  /// True for the uniform density (nothing learned).
  bool uniform() const { return nodes_.empty(); }
  /// The number of leaves (1 for the uniform density).
  int leafCount() const;
  /// The depth of the deepest leaf (0 for the uniform density).
  int depth() const;

  /// Warps `u`, uniform in [0, 1)², into a point of this density, in [0, 1)².
  Vec2 sample(Vec2 u) const;
  /// The density at `p` in [0, 1)² (per unit area of the square; it integrates to 1 over it), ≥ 0.
  Real pdf(Vec2 p) const;
  /// A point of the mixture α × uniform + (1 − α) × this density, and the mixture's density there: u.x < α takes the
  /// uniform component (u.x stretched over [0, 1) by ÷ α), else this tree's (sample() of u.x stretched by (u.x − α)
  /// ÷ (1 − α), kept below 1). Either way the density is the mixture's, so the estimate does not depend on which
  /// component drew the point.
  /// @param u uniform in [0, 1)². @param alpha the uniform share, in (0, 1].
  MixtureSample sampleMixture(Vec2 u, Real alpha) const;
  /// Appends this tree's nodes to `forest` (their children renumbered into it) and returns the index of its root
  /// there, or −1 for the uniform density (which has no node: its points are the numbers as drawn).
  SampleForestIndex appendTo(SampleForest& forest) const;

private:
  // A node's four quadrants, in the order (x < ½, y < ½), (x ≥ ½, y < ½), (x < ½, y ≥ ½), (x ≥ ½, y ≥ ½): each
  // quadrant's share of the node's points, and its node (index into nodes_), or −1 for a leaf.
  struct Node {
    std::array<Real, 4> share{};
    std::array<std::int32_t, 4> child{-1, -1, -1, -1};
  };
  std::vector<Node> nodes_; // nodes_[0] is the root when not uniform
};

} // namespace raylife

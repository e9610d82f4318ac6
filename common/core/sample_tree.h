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
#include <vector>

namespace raylife {

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

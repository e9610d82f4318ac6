/// @file bvh.h
/// @brief A bounding volume hierarchy over spheres and triangles: built with the binned surface area heuristic,
/// collapsed to eight children per node, traversed front to back with the children's boxes tested together in float
/// (all eight in one instruction where the CPU has AVX2, four at a time elsewhere); closest-hit and any-hit (shadow
/// ray) queries.
///
/// The idea. Testing a ray against every primitive costs N tests. Group the primitives into boxes, the boxes
/// into bigger boxes, up to one box around everything: a ray that misses a box skips everything inside it, so a
/// ray typically pays for a few dozen box tests and a handful of primitive tests, about log N work instead of N.
///
/// The primitives are numbered as the scene numbers them: spheres first (sphere i is primitive i), then triangles
/// (triangle j is primitive S + j, with S spheres). A leaf holds primitives of one kind, so its loop tests spheres
/// or triangles without asking each one which it is.
///
/// The contract that makes it safe to use everywhere: a query returns exactly what the brute-force loop over the
/// same primitives returns (the same primitive, the same t to the last bit, ties at the same t going to the
/// lowest number as the loop's strict "nearer" does). Boxes are widened by kBoxMargin, and the float box test
/// rounds everything to the safe side, so that rounding can never cull a primitive the loop would hit.
/// tests/bvh checks this on millions of rays.
#pragma once

#include "core/math.h"
#include "geometry/ray.h"
#include "geometry/sphere.h"
#include "geometry/sphere_lanes.h"
#include "geometry/triangle.h"

#include <cstdint>
#include <optional>
#include <span>
#include <vector>

namespace raylife {

/// An axis-aligned box [lo, hi] in world space (empty when any lo > hi).
struct Bounds3 {
  Vec3 lo{kInfinity};  ///< Smallest corner.
  Vec3 hi{-kInfinity}; ///< Largest corner.

  /// The smallest box holding this box and `b`.
  Bounds3 merged(const Bounds3& b) const { return Bounds3{glm::min(lo, b.lo), glm::max(hi, b.hi)}; }
  /// The smallest box holding this box and the point `p`.
  Bounds3 merged(const Vec3& p) const { return Bounds3{glm::min(lo, p), glm::max(hi, p)}; }
  /// Surface area 2(dx·dy + dy·dz + dz·dx), in scene units²; 0 for an empty box or a point.
  Real surfaceArea() const
  {
    const Vec3 d = glm::max(hi - lo, Vec3(0));
    return 2 * (d.x * d.y + d.y * d.z + d.z * d.x);
  }
};

/// One node of the tree as the builder makes it (binary): 32 bytes, so two share a 64-byte cache line.
///
/// The nodes are stored depth first: an interior node's first child is the next node in the array and
/// `offset` is the index of its second child; a leaf of spheres holds spheres [offset, offset + count) of the tree's
/// list, in the tree's order; a leaf of triangles (`triangles` 1) holds its count triangles four to a pack, in
/// ⌈count/4⌉ packs from pack `offset` on.
/// Bounds are float, rounded outwards from the scene's scalar, so they hold everything the exact box holds.
struct alignas(32) BvhNode {
  glm::vec3 bounds[2];        ///< Box: [0] its smallest corner (rounded down), [1] its largest (rounded up).
  std::uint32_t offset;       ///< Leaf: first sphere, or first pack of triangles. Interior: index of the second child.
  std::uint16_t count;        ///< Leaf: number of primitives, ≥ 1. Interior: 0.
  std::uint16_t triangles = 0; ///< Leaf: 1 when its primitives are triangles, 0 for spheres. Interior: 0.
};
static_assert(sizeof(BvhNode) == 32, "a BvhNode is meant to be 32 bytes");

/// One node of the tree the queries walk: the binary tree collapsed so that a node holds up to eight
/// children, whose boxes are tested together (eight or four at a time). 256 bytes: four cache lines.
///
/// The boxes are stored by coordinate: row 3·face + axis (face 0 lo, 1 hi; axis 0 x, 1 y, 2 z) holds that
/// coordinate of all the children's boxes side by side, so that eight (or four) boxes' worth is one load. A slot
/// without a child holds an empty box (lo = +∞, hi = −∞). The boxes are BvhNode's, unchanged.
struct alignas(64) BvhWideNode {
  /// Most children a node holds (a multiple of eight: the box test's widest lanes).
  static constexpr int kWidth = 8;
  /// Set in `child` for a leaf.
  static constexpr std::uint32_t kLeaf = 0x80000000u;
  /// Set in `child`, with kLeaf, for a leaf of triangles.
  static constexpr std::uint32_t kTriangles = 0x40000000u;
  /// The bits of `child` below the flags: a node's or a first primitive's index.
  static constexpr std::uint32_t kIndexMask = 0x3fffffffu;

  float bounds[6 * kWidth]; ///< Child k's box: coordinate (face, axis) at [(3·face + axis)·kWidth + k].
  /// Per child: an interior child's index in Bvh::wideNodes(), or kLeaf | the index of a leaf's first sphere in
  /// the tree's list of spheres, or kLeaf | kTriangles | the index of a leaf's first pack of four triangles (a
  /// leaf's spheres, or its packs, lie side by
  /// side). 0 in an empty slot.
  std::uint32_t child[kWidth];
  std::uint32_t boxes;       ///< Children, in slots [0, boxes): 2 to kWidth (1 in the root of a one-leaf tree).
  std::uint32_t pad[7] = {}; ///< Unused; keeps the node 256 bytes and its bytes defined.

  /// Child k's box: its smallest (face 0) or largest (face 1) coordinate on `axis` (0 x, 1 y, 2 z).
  float bound(int face, int axis, int k) const { return bounds[(3 * face + axis) * kWidth + k]; }
};
static_assert(sizeof(BvhWideNode) == 256, "a BvhWideNode is meant to be 256 bytes");

/// How the builder chooses where to split a node's primitives.
enum class BvhSplit {
  Sah,      ///< The surface area heuristic over binned centroids (the good split; the default).
  Midpoint, ///< Halve the centroids' box on its longest axis, ignoring cost (the bad split, for comparison).
};

/// The builder's settings.
struct BvhBuildOptions {
  BvhSplit split = BvhSplit::Sah; ///< Splitting rule.
  int bins = 12;                  ///< SAH bins per axis over the centroids' box, in [2, 64].
  int maxLeafSize = 4;            ///< A node with more primitives than this is always split, in [1, 255].
  /// The same for a node of triangles only, in [1, 255]. (8, two packs a leaf, made a third fewer wide nodes but
  /// slower camera rays on a million triangles: mesh_bench, 0.60 against 0.75 of Embree's speed in one noisy run.)
  int maxTriangleLeafSize = 4;
  /// From this many triangles on, the SAH prices a leaf of triangles by its packs of four (⌈n/4⌉: a pack is tested
  /// at once), below it by its triangles (but see packPricedBelowArea), ≥ 0. A big tree's time goes on cache misses,
  /// one a node and one a pack whatever the pack holds, and leaves of full packs take half the bytes (a million
  /// triangles: 105 bytes a triangle against 267, and faster rays); on a 60,000-triangle blob mesh_bench's rays were
  /// a third faster priced by packs.
  int packPricedFrom = 1 << 14;
  /// In a tree below packPricedFrom, a node of triangles whose box's surface area is below this fraction of the
  /// root's is priced by its packs too, in [0, 1] (0: none is). Packs win where the triangles are small against the
  /// scene, a model seen from outside; they lose on a room's walls, whose nodes span the scene: merged into packs,
  /// the walls' boxes are the room's, and every ray from inside it tests them. Priced by packs in every node,
  /// chapter 10's model alone ran its bounce rays at 0.88 of Embree 3's speed instead of 0.73, but the original
  /// Cornell box its camera rays at 1.19 instead of 1.47 (mesh_bench); with this fraction, the model gets the first
  /// and the Cornell box keeps its tree, node for node.
  double packPricedBelowArea = 1.0 / 32;
  /// Test a node's eight boxes in one AVX2 instruction where the CPU has AVX2; false, or a CPU without it: four
  /// at a time (SSE). Either way the same hits and the same work, bit for bit; only the speed differs.
  bool eightAtOnce = true;
  /// Threads the build may use, ≥ 1, or 0 for every core. The top levels' subtrees are built side by side; the tree
  /// is the same, node for node, whatever the number.
  int buildThreads = 0;
  /// Keep the binary tree (nodes(), sahCost()) after the wide tree is made from it. Off, it is freed: the queries
  /// never use it, and it is 32 bytes a node (about 42 MB for a million triangles).
  bool keepBinaryTree = false;
  /// Keep huge primitives out of the tree (see Bvh::outsidePrimitives): walls, floors, a ground or sky sphere, whose
  /// box would hold most of the others'. They are tested one after the other before the tree is walked. Off: every
  /// primitive goes into the tree. Either way the same hits, bit for bit.
  bool hugeOutside = true;
};

/// A primitive stays out of the tree when its box's surface area is at least this many times that of the box of
/// everything smaller than it that goes into the tree (twice as wide), and overlaps that box (see
/// Bvh::outsidePrimitives).
inline constexpr Real kHugeAreaRatio = 4;

/// Most primitives kept out of the tree: each costs every ray one primitive test.
inline constexpr int kMaxOutside = 16;

/// The relative costs the SAH weighs (only their ratio matters): one box test, and one primitive test (a sphere
/// and a triangle cost about the same).
/// On the random-spheres scene the speed barely depends on the ratio (tools/bvh_bench speed: the same within the
/// noise for C_isect / C_trav from 0.5 to 4); 2 favours small leaves, which suits spheres of similar size.
struct BvhCosts {
  Real traversal = 1;    ///< C_trav: visiting a node (a box test).
  Real intersection = 2; ///< C_isect: testing one primitive.
};

/// The work one query did: the numbers chapter 9 paints as a heat map.
struct BvhWork {
  std::uint32_t nodesVisited = 0;     ///< Boxes tested.
  std::uint32_t primitivesTested = 0; ///< Primitives (spheres and triangles) tested.

  /// The sum of two queries' work.
  BvhWork operator+(const BvhWork& o) const
  {
    return BvhWork{nodesVisited + o.nodesVisited, primitivesTested + o.primitivesTested};
  }
};

/// The nearest primitive a ray hits: its number (see the file comment), and the distance.
struct BvhHit {
  Real t = 0;        ///< The ray parameter of the hit, in [ray.tmin, ray.tmax).
  int primitive = -1; ///< Sphere i is i; triangle j is spheres + j (the numbering of the Bvh constructor).
};

/// A closest-hit query's answer with the work it took.
struct BvhTracedHit {
  std::optional<BvhHit> hit; ///< As Bvh::intersect.
  BvhWork work;              ///< Boxes and primitives tested.
};

/// An any-hit query's answer with the work it took.
struct BvhTracedOcclusion {
  bool occluded = false; ///< As Bvh::occluded.
  BvhWork work;          ///< Nodes visited and primitives tested until the answer was known.
};

template <class V> struct BvhWalk; // one ray's walk through the tree (bvh.cpp)
struct BvhTriangleRay;              // a ray prepared for the triangles' test (bvh.cpp)

/// A bounding volume hierarchy over a fixed set of spheres and triangles. Immutable after construction, so any
/// number of threads may query it at once.
class Bvh {
public:
  /// An empty tree: every query misses.
  Bvh() = default;

  /// Builds the tree over `spheres` (each with a finite centre and radius > 0; a moving sphere is bounded over the
  /// whole shutter interval, and met where it is at the ray's time). The tree keeps its own copy of
  /// the spheres' geometry; it does not follow later changes to `spheres`. The build is deterministic: the
  /// same spheres and options give the same nodes, byte for byte.
  explicit Bvh(const std::vector<Sphere>& spheres, const BvhBuildOptions& options = {});

  /// Builds the tree over `spheres` and `triangles` (whose indices point into `vertices`; every vertex finite).
  /// Sphere i is primitive i and triangle j primitive spheres.size() + j. Like the sphere-only constructor, the
  /// tree keeps its own copy of the geometry and the build is deterministic.
  Bvh(std::span<const Sphere> spheres, std::span<const Vec3> vertices, std::span<const Triangle> triangles,
      const BvhBuildOptions& options = {});

  /// The nearest primitive hit inside [ray.tmin, ray.tmax), exactly as the brute-force loop finds it: for every
  /// sphere its first root in the interval (intersectSphere), for every triangle its hit (intersectTriangle), and
  /// of those the smallest t, the lowest number on a tie. Nothing when nothing is hit. As Ray requires,
  /// ray.tmin ≥ 0 (the box test relies on it).
  std::optional<BvhHit> intersect(const Ray& ray) const;

  /// True when any primitive is hit inside [ray.tmin, ray.tmax): the shadow-ray query. Stops at the first one
  /// found, so it is cheaper than intersect; it is true exactly when intersect finds a hit. ray.tmin ≥ 0.
  bool occluded(const Ray& ray) const;

  /// intersect for each ray of `rays` (out[i] the answer for rays[i]; out.size() ≥ rays.size()), the same answers
  /// bit for bit, with the walks of `inFlight` rays (1, 2 or 4) taken a node at a time in turn: while one ray
  /// waits for its box test, the processor can work on another's. An experiment for tools/bvh_bench (how much of
  /// a ray's time is waiting); the chapters trace one ray at a time.
  void intersectInterleaved(std::span<const Ray> rays, std::span<std::optional<BvhHit>> out, int inFlight) const;

  /// intersect for each ray of `rays` (out[i] the answer for rays[i]; out.size() ≥ rays.size()), the same answers
  /// bit for bit, the rays taken kPacket at a time as packets that walk the tree together: each node's boxes are
  /// tested once for a whole packet, against intervals holding all its rays' origins and directions (rounded to the
  /// safe side, so that no box one of them enters is skipped), and each leaf's primitives for each of its rays.
  /// Pays for coherent rays, neighbouring pixels' camera rays: they enter nearly the same boxes. A packet whose
  /// rays' directions differ in sign on some axis (they meet the faces in another order) walks a ray at a time.
  void intersectPacket(std::span<const Ray> rays, std::span<std::optional<BvhHit>> out) const;
  /// Rays in one packet of intersectPacket.
  static constexpr std::size_t kPacket = 16;

  /// intersect, also counting the work (for heat maps; the plain query pays nothing for the counting).
  BvhTracedHit intersectWithWork(const Ray& ray) const;
  /// occluded, also counting the work.
  BvhTracedOcclusion occludedWithWork(const Ray& ray) const;

  /// Primitives (spheres and triangles) the tree was built over, those kept outside it included (0 for an empty
  /// tree).
  std::size_t primitiveCount() const { return primitiveCount_; }
  /// The huge primitives kept out of the tree (BvhBuildOptions::hugeOutside), by number, in increasing order: tested
  /// one after the other by every query, before the tree. They are the largest set of the biggest primitives (by
  /// the surface area of their boxes, at most kMaxOutside and a quarter of all) in which the smallest one's box has
  /// at least kHugeAreaRatio times the area of the box of everything the tree keeps, and overlaps it. Such a box
  /// dwarfs the tree's contents: in the tree it would widen every node above them, and most rays would walk down to
  /// it; outside, it costs one test. (Smallpt's walls and lamp, the tutorial's ground sphere, a sky sphere, a floor
  /// under a model; never one primitive among others of its size, nor a big one away from the rest.) Empty when the
  /// tree holds everything.
  const std::vector<int>& outsidePrimitives() const { return outside_; }
  /// The tree as built (binary), root first; empty for an empty tree, or unless built with
  /// BvhBuildOptions::keepBinaryTree.
  const std::vector<BvhNode>& nodes() const { return nodes_; }
  /// The tree the queries walk (up to BvhWideNode::kWidth children per node), root first, every node before
  /// its children (empty for an empty tree).
  const std::vector<BvhWideNode>& wideNodes() const { return wideNodes_; }
  /// The tree's primitives of one kind in the order its leaves hold them, by number, with kLastInLeaf set on the
  /// last entry of each leaf. Spheres: a leaf child of a wide node (BvhWideNode::child) indexes this list. Triangles:
  /// four entries per pack of four (a leaf child's pack index k starts at entry 4k), the lanes past a pack's count
  /// repeating its last triangle. For a walk of the tree
  /// written elsewhere (chapter 17's kernels). @param triangles The triangles' list; false: the spheres'.
  std::vector<std::uint32_t> leafPrimitives(bool triangles) const;
  /// Set in a leafPrimitives entry on the last primitive of its leaf.
  static constexpr std::uint32_t kLastInLeaf = 0x80000000u;
  /// True when the queries test a node's boxes eight at a time (BvhBuildOptions::eightAtOnce, on a CPU with AVX2).
  bool eightAtOnce() const { return eightAtOnce_; }
  /// The bytes the queries use: the wide nodes, the leaves' spheres and triangle packs, the primitives outside the
  /// tree (not the binary tree, which only BvhBuildOptions::keepBinaryTree keeps). mesh_bench's bytes a triangle.
  std::size_t memoryBytes() const;
  /// Deepest level of the tree (the root is level 1; 0 for an empty tree). Always below kMaxDepth.
  int depth() const { return depth_; }

  /// The expected cost of a ray by the surface area heuristic, summed over the whole tree:
  /// Σ over interior nodes of (A_node / A_root)·C_trav + Σ over leaves of (A_leaf / A_root)·N_leaf·C_isect.
  /// Lower is better; compares trees built over the same primitives. Needs the binary tree
  /// (BvhBuildOptions::keepBinaryTree): 0 without it.
  Real sahCost(const BvhCosts& costs = {}) const;

  /// Deepest tree the builder makes (the wide tree is never deeper): it bounds the traversal's stack.
  static constexpr int kMaxDepth = 64;

private:
  /// A sphere as the tree stores it: geometry in traversal order, and its number.
  struct SpherePrimitive {
    Vec3 center;
    Real radius;
    int index;
    bool lastInLeaf; // its leaf's primitives end here
  };
  /// The triangles of a leaf as the tree stores them: four to a pack, their corners side by side by coordinate (row
  /// 3·corner + axis holds that coordinate of the four triangles), so that one load brings a coordinate of all four
  /// and the watertight test runs in lanes. The corners are copies (the leaf's data in one place: the
  /// walk reaches them with one dependent load, where indices into a vertex array took two, and on a million
  /// triangles those two misses were half a query's time), and their primitive numbers. Lanes past `count` are
  /// zero and never reported. A pack starts a cache line (and its rows are aligned: one aligned load each). T: the
  /// corners' type, Real, or float where every corner is a float (below).
  template <class T> struct alignas(64) TrianglePackOf {
    T corner[9][4];
    int index[4];
    std::uint32_t count; // triangles in the pack, 1 to 4; kLastPack set in the leaf's last pack
  };
  using TrianglePack = TrianglePackOf<Real>;
  /// A pack whose corners are floats: what the tree keeps, in a double build, when every corner of the scene is a
  /// float exactly (a mesh read from a file of floats and placed as it was). The lanes load them as Real, the same
  /// values, so the same hits to the last bit, in 192 bytes a pack (three cache lines) where doubles take 320.
  using FloatTrianglePack = TrianglePackOf<float>;
  static constexpr std::uint32_t kLastPack = 0x80000000u;
  /// A triangle kept out of the tree: its corners and its number.
  struct OutsideTriangle {
    Vec3 corner[3];
    int index;
  };

  /// What one traversal found: the nearest hit (closest-hit) or any hit (any-hit), and the work if counted.
  struct Traversal {
    Real t;
    int primitive; // −1: nothing hit
    BvhWork work;  // zero unless counted
    std::optional<BvhHit> hit() const // as intersect answers
    {
      return primitive < 0 ? std::nullopt : std::optional<BvhHit>(BvhHit{t, primitive});
    }
  };
  // The tree's walk, with V the lanes of the box test (four or eight floats).
  // `found`: what the primitives outside the tree gave (the nearest hit so far, or the ray's tmax and −1).
  // (Answers by reference throughout: a Traversal passed and returned by value went through memory, written a field at
  // a time and read whole, and the processor cannot forward such stores to the load: a stall on every query.)
  template <bool kAnyHit, bool kCountWork, class V> void traverse(const Ray& ray, Traversal& found) const;
  // The primitives outside the tree, one after the other (the nearest hit, or any hit), into `found`, which holds
  // the ray's tmax and −1 on the way in.
  template <bool kAnyHit, bool kCountWork> void testOutside(const Ray& ray, Traversal& found) const;
  // The whole query: those primitives, then the tree; the eight-lane one built for AVX2; and the choice between
  // them.
  template <bool kAnyHit, bool kCountWork, class V> Traversal query(const Ray& ray) const;
  template <bool kAnyHit, bool kCountWork> Traversal queryEight(const Ray& ray) const;
  template <bool kAnyHit, bool kCountWork> Traversal dispatch(const Ray& ray) const;
  // One step of a walk: visits walk.current; false when the walk is over, its answer in `found`.
  template <bool kAnyHit, bool kCountWork, class V>
  bool visit(const Ray& ray, BvhWalk<V>& walk, Traversal& found) const;
  // intersectInterleaved with `kInFlight` walks, with V the lanes of the box test; the eight-lane one for AVX2.
  template <int kInFlight, class V>
  void interleave(std::span<const Ray> rays, std::span<std::optional<BvhHit>> out) const;
  template <int kInFlight> void interleaveEight(std::span<const Ray> rays, std::span<std::optional<BvhHit>> out) const;
  // A leaf's primitives against a ray, into `found`: true when it changed (closest hit) or at a blocker (any hit).
  // kEight: called from the eight-lane (AVX2) walk, and so free to use AVX.
  template <bool kAnyHit, bool kCountWork, bool kEight>
  bool testLeaf(const Ray& ray, std::uint32_t leaf, const BvhTriangleRay& triangleRay, Traversal& found) const;
  // testLeaf's leaf of triangles, its packs from packs[first] on.
  template <bool kAnyHit, bool kCountWork, bool kEight, class Pack>
  bool testPacks(const std::vector<Pack>& packs, std::uint32_t first, const Ray& ray,
                 const BvhTriangleRay& triangleRay, Traversal& found) const;
  // intersectPacket for one packet (at most kPacket rays), with V the lanes of the box test; the eight-lane one.
  template <class V> void packet(std::span<const Ray> rays, std::span<std::optional<BvhHit>> out) const;
  void packetEight(std::span<const Ray> rays, std::span<std::optional<BvhHit>> out) const;
  // Asks the memory for a node's child (BvhWideNode::child): its node, or its leaf's first pack or sphere.
  void prefetchChild(std::uint32_t child) const;
  // The binary nodes a wide node made from binary interior `node` takes as its children (see collapse).
  int wideChildren(std::uint32_t node, std::uint32_t (&children)[BvhWideNode::kWidth]) const;
  std::uint32_t collapse(std::uint32_t node);

  std::vector<BvhNode> nodes_;
  std::vector<BvhWideNode> wideNodes_;
  std::vector<SpherePrimitive> spheres_;
  std::vector<TrianglePack> packs_; // the leaves' triangles, a leaf's packs side by side
  std::vector<FloatTrianglePack> floatPacks_; // instead of packs_ where every corner is a float (Real double)
  std::vector<Vec3> velocities_; // per entry of spheres_ when some sphere moves; empty for a still scene
  std::vector<int> outside_;   // the primitives kept out of the tree, by number, increasing
  // Those of them that are spheres: four at a time where the CPU can (AVX2), from kOutsideLanesMin spheres;
  // fewer (a ground sphere alone) one by one, which is cheaper than a group of four with empty lanes.
  static constexpr std::size_t kOutsideLanesMin = 4;
  SphereLanes outsideLanes_;
  std::vector<SpherePrimitive> outsideSpheres_;
  std::vector<int> outsideSphereIndex_; // their numbers, by place in outsideLanes_
  std::vector<OutsideTriangle> outsideTriangles_; // those that are triangles
  // spheres_, the packs' triangles and outside_ together, counted once: every query of the scene asks (the sizes of
  // vectors of 40- and 20-byte records are a multiplication each).
  std::size_t primitiveCount_ = 0;
  int depth_ = 0;
  bool eightAtOnce_ = false; // the boxes eight at a time (AVX2)
};

} // namespace raylife

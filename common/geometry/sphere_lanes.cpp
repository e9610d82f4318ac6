#include "geometry/sphere_lanes.h"
#include "core/simd.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <type_traits>

#if RAYLIFE_HAS_AVX2
#include <immintrin.h> // _mm256_sqrt_pd, _mm_sqrt_ps: the one lane operation GCC's vector extensions lack
#endif

namespace raylife {

namespace {

// The one-by-one test: the scene's loop over the spheres, lane after lane (skipping empty lanes), each hit
// shrinking the interval so that a later sphere must be strictly nearer.
void nearestOneByOne(const SphereGroup& g, int first, const Ray& ray, SphereHit& best)
{
  for (int k = 0; k < SphereGroup::kWidth; ++k) {
    if (std::isnan(g.radius[k]))
      continue; // an empty lane
    const Vec3 center(g.centerX[k], g.centerY[k], g.centerZ[k]);
    const Real tmax = best.sphere < 0 ? ray.tmax : best.t;
    const std::optional<Real> t = intersectSphere(ray.origin, ray.direction, center, g.radius[k], ray.tmin, tmax);
    if (t)
      best = SphereHit{*t, first + k};
  }
}

bool anyOneByOne(const SphereGroup& g, const Ray& ray)
{
  for (int k = 0; k < SphereGroup::kWidth; ++k)
    if (!std::isnan(g.radius[k]) && intersectSphere(ray.origin, ray.direction,
                                                    Vec3(g.centerX[k], g.centerY[k], g.centerZ[k]), g.radius[k],
                                                    ray.tmin, ray.tmax))
      return true;
  return false;
}

#if RAYLIFE_HAS_AVX2
// ---- Four at once --------------------------------------------------------------------------------------------
// Four Reals, and four lanes' yes (all bits set) or no: GCC's vector extensions (which clang builds too), so the
// code below reads as the arithmetic of one sphere. Every function here is compiled for AVX2, where four doubles
// are one register; the queries call them only when the CPU has it.
typedef Real Real4 __attribute__((vector_size(SphereGroup::kWidth * sizeof(Real))));
using LaneInt = std::conditional_t<sizeof(Real) == 8, std::int64_t, std::int32_t>;
typedef LaneInt Mask4 __attribute__((vector_size(SphereGroup::kWidth * sizeof(Real))));

RAYLIFE_AVX2_INLINE Real4 splat(Real x) { return Real4{x, x, x, x}; }
RAYLIFE_AVX2_INLINE Real4 load(const Real* lanes)
{
  Real4 v;
  std::memcpy(&v, lanes, sizeof v);
  return v;
}
// √v per lane, correctly rounded as std::sqrt (NaN where v < 0).
RAYLIFE_AVX2_INLINE Real4 sqrt4(Real4 v)
{
#ifdef RAYLIFE_REAL_IS_FLOAT
  return Real4(_mm_sqrt_ps(__m128(v)));
#else
  return Real4(_mm256_sqrt_pd(__m256d(v)));
#endif
}
// std::copysign per lane: the magnitude of `magnitude`, the sign bit of `sign`.
RAYLIFE_AVX2_INLINE Real4 copySign(Real4 magnitude, Real4 sign)
{
  const Mask4 signBit = Mask4{} + (LaneInt(1) << (8 * sizeof(Real) - 1));
  return Real4((Mask4(magnitude) & ~signBit) | (Mask4(sign) & signBit));
}
// One bit a lane, bit k set where lane k's mask is: a sign-bit gather (movemask), not four extracts.
RAYLIFE_AVX2_INLINE unsigned laneBits(Mask4 m)
{
#ifdef RAYLIFE_REAL_IS_FLOAT
  return unsigned(_mm_movemask_ps(__m128(m)));
#else
  return unsigned(_mm256_movemask_pd(__m256d(m)));
#endif
}
RAYLIFE_AVX2_INLINE bool anyLane(Mask4 m) { return laneBits(m) != 0; }
// The least of the four lanes, in every lane (+∞ stays +∞; no lane is NaN here).
RAYLIFE_AVX2_INLINE Real4 minAcrossLanes(Real4 v)
{
  const Real4 halves = __builtin_shufflevector(v, v, 2, 3, 0, 1);
  const Real4 m = v < halves ? v : halves;
  const Real4 pairs = __builtin_shufflevector(m, m, 1, 0, 3, 2);
  return m < pairs ? m : pairs;
}

/// [fourAtOnce]
// The first root of each lane's sphere inside [tmin, tmax), or +∞: intersectSphereRoots and intersectSphere's
// choice of root, written for four lanes. Each lane does the same IEEE operations in the same order as the
// scalar code (and none fused: the build says -ffp-contract=off), so it gets the same bits.
struct LaneRay {
  Real4 ox, oy, oz, dx, dy, dz, tmin, tmax;
};
RAYLIFE_AVX2_INLINE LaneRay splatRay(const Ray& ray)
{
  return LaneRay{splat(ray.origin.x),    splat(ray.origin.y),    splat(ray.origin.z), splat(ray.direction.x),
                 splat(ray.direction.y), splat(ray.direction.z), splat(ray.tmin),     splat(ray.tmax)};
}
RAYLIFE_AVX2_INLINE Real4 firstRoots(const SphereGroup& g, const LaneRay& r)
{
  const Real4 inf = splat(kInfinity);
  // Closest approach: f = o − c, b = −f·d, l = f + b·d, and the discriminant Δ = r² − |l|².
  const Real4 fx = r.ox - load(g.centerX), fy = r.oy - load(g.centerY), fz = r.oz - load(g.centerZ);
  const Real4 radius = load(g.radius);
  const Real4 rr = radius * radius;
  const Real4 ff = (fx * fx + fy * fy) + fz * fz;
  const Real4 b = -((fx * r.dx + fy * r.dy) + fz * r.dz);
  const Real4 lx = fx + b * r.dx, ly = fy + b * r.dy, lz = fz + b * r.dz;
  const Real4 disc = rr - ((lx * lx + ly * ly) + lz * lz);
  // Four misses cost no square root, as one costs none in intersectSphere: a lane misses where Δ < 0, or where
  // the ray starts outside its sphere heading away from the centre (intersectSphere's first exit).
  if (!anyLane((disc >= 0) & ~((ff > rr) & (b <= 0))))
    return inf;
  // The roots q = b + sign(b)·√Δ and c/q, c = |f|² − r²; both b on a tangent through the origin (q = 0). Where
  // Δ < 0 (a miss) √Δ is NaN, and so is every root: NaN fails each comparison below, so a miss picks no root.
  const Real4 q = b + copySign(sqrt4(disc), b);
  const Real4 c = ff - rr;
  const Mask4 tangent = q == 0;
  const Real4 r0 = tangent ? b : c / q, r1 = tangent ? b : q;
  const Mask4 swap = r0 > r1;
  const Real4 t0 = swap ? r1 : r0, t1 = swap ? r0 : r1;
  // The nearer root if it lies in [tmin, tmax), else the farther one if it does, else none (+∞).
  const Mask4 in0 = (t0 >= r.tmin) & (t0 < r.tmax), in1 = (t1 >= r.tmin) & (t1 < r.tmax);
  return in0 ? t0 : (in1 ? t1 : inf);
}

RAYLIFE_AVX2 std::optional<SphereHit> nearestFourAtOnce(std::span<const SphereGroup> groups, const Ray& ray)
{
  const LaneRay r = splatRay(ray);
  // Per lane, the nearest hit over the groups and the group it is in (a later group, holding higher indices, must
  // be strictly nearer); then the nearest over the lanes, the lowest index on a tie.
  Real4 best = splat(kInfinity);
  Mask4 bestGroup = Mask4{} - 1;
  for (std::size_t g = 0; g < groups.size(); ++g) {
    const Real4 t = firstRoots(groups[g], r);
    const Mask4 nearer = t < best;
    best = nearer ? t : best;
    bestGroup = nearer ? Mask4{} + LaneInt(g) : bestGroup;
  }
  const Real4 tMin = minAcrossLanes(best);
  if (!(tMin[0] < kInfinity))
    return std::nullopt;
  // The lowest index at the minimum. Almost always one lane holds it; which one is random from ray to ray, so it
  // is found from the lanes' bits rather than by a branch on each lane.
  unsigned atMin = laneBits(best == tMin);
  int lane = std::countr_zero(atMin);
  int index = int(bestGroup[lane]) * SphereGroup::kWidth + lane;
  for (atMin &= atMin - 1; atMin != 0; atMin &= atMin - 1) { // a tie between lanes
    const int k = std::countr_zero(atMin), other = int(bestGroup[k]) * SphereGroup::kWidth + k;
    lane = other < index ? k : lane;
    index = std::min(index, other);
  }
  // The lane's own t: equal to the minimum, but of its own sign should the tie be −0 against +0.
  const SphereHit hit{best[lane], index};
  return hit;
}

RAYLIFE_AVX2 bool anyFourAtOnce(std::span<const SphereGroup> groups, const Ray& ray)
{
  const LaneRay r = splatRay(ray);
  for (const SphereGroup& g : groups)
    if (anyLane(firstRoots(g, r) < splat(kInfinity)))
      return true;
  return false;
}
/// [fourAtOnce]
#endif

} // namespace

bool laneTestAvailable(LaneTest test)
{
  if (test == LaneTest::OneByOne)
    return true;
  return cpuHasAvx2();
}

LaneTest fastestLaneTest()
{
  return laneTestAvailable(LaneTest::FourAtOnce) ? LaneTest::FourAtOnce : LaneTest::OneByOne;
}

std::vector<SphereGroup> groupSpheres(const std::vector<Sphere>& spheres)
{
  constexpr Real kNaN = std::numeric_limits<Real>::quiet_NaN();
  std::vector<SphereGroup> groups((spheres.size() + SphereGroup::kWidth - 1) / SphereGroup::kWidth);
  for (std::size_t i = 0; i < groups.size() * SphereGroup::kWidth; ++i) {
    const Sphere s = i < spheres.size() ? spheres[i] : Sphere{Vec3(kNaN), kNaN, 0}; // an empty lane: NaN
    SphereGroup& g = groups[i / SphereGroup::kWidth];
    const std::size_t k = i % SphereGroup::kWidth;
    g.centerX[k] = s.center.x;
    g.centerY[k] = s.center.y;
    g.centerZ[k] = s.center.z;
    g.radius[k] = s.radius;
  }
  return groups;
}

std::optional<SphereHit> nearestInGroups(std::span<const SphereGroup> groups, const Ray& ray, LaneTest test)
{
#if RAYLIFE_HAS_AVX2
  if (test == LaneTest::FourAtOnce)
    return nearestFourAtOnce(groups, ray);
#endif
  (void)test;
  SphereHit best;
  for (std::size_t g = 0; g < groups.size(); ++g)
    nearestOneByOne(groups[g], int(g) * SphereGroup::kWidth, ray, best);
  return best.sphere < 0 ? std::nullopt : std::optional<SphereHit>(best);
}

SphereLanes::SphereLanes(const std::vector<Sphere>& spheres, LaneTest test)
    : groups_(groupSpheres(spheres)), size_(spheres.size()), test_(test)
{
}

bool anyInGroups(std::span<const SphereGroup> groups, const Ray& ray, LaneTest test)
{
#if RAYLIFE_HAS_AVX2
  if (test == LaneTest::FourAtOnce)
    return anyFourAtOnce(groups, ray);
#endif
  (void)test;
  return std::any_of(groups.begin(), groups.end(), [&](const SphereGroup& g) { return anyOneByOne(g, ray); });
}

} // namespace raylife

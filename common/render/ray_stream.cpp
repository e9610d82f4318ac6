// The stream kernels of ray_stream.h, compiled once per instruction set by Highway (foreach_target.h includes this
// file again for each target) and chosen at run time.
#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "render/ray_stream.cpp"
#include <hwy/foreach_target.h> // must come before highway.h

#include <hwy/highway.h>

#include "render/ray_stream.h"
#include "core/rng.h"
#include "shading/bsdf.h"
#include "scene/light_sampling.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

HWY_BEFORE_NAMESPACE();
namespace raylife {
namespace HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

using D = hn::ScalableTag<Real>;
using V = hn::Vec<D>;
using M = hn::Mask<D>;

// Lanes i .. i + L − 1 of `v` (L = Lanes(d)), of which the first n are in the array: the last group of a stream
// may be short, and its missing lanes repeat the last entry (a real ray or hit, so nothing undefined is computed).
HWY_INLINE V loadLanes(D d, const Real* v, std::size_t i, std::size_t n)
{
  if (n == hn::Lanes(d))
    return hn::LoadU(d, v + i);
  HWY_ALIGN Real buffer[hn::MaxLanes(d)];
  for (std::size_t j = 0; j < hn::Lanes(d); ++j)
    buffer[j] = v[i + std::min(j, n - 1)];
  return hn::Load(d, buffer);
}
// Stores the first n lanes of x at v + i.
HWY_INLINE void storeLanes(D d, V x, Real* v, std::size_t i, std::size_t n)
{
  if (n == hn::Lanes(d))
    return hn::StoreU(x, d, v + i);
  HWY_ALIGN Real buffer[hn::MaxLanes(d)];
  hn::Store(x, d, buffer);
  std::copy(buffer, buffer + n, v + i);
}

// std::max(Real(0), x), the same bits: (0 < x) ? x : 0 (so −0 and NaN give +0, where a max instruction differs).
HWY_INLINE V maxZero(D d, V x) { return hn::IfThenElse(hn::Lt(hn::Zero(d), x), x, hn::Zero(d)); }

// |v|, the same bits as absBranchFree (math.h): glm::max(v, −v) = (v < −v) ? −v : v, so −0 stays −0.
HWY_INLINE V absLanes(V v) { return hn::IfThenElse(hn::Lt(v, hn::Neg(v)), hn::Neg(v), v); }

// nextAlong (math.h), lane by lane: v moved one ulp towards the sign of `direction` (not at all where it is ±0).
// Its rare cases (v ±0, ±∞ or NaN) go to the scalar function, lane by lane.
HWY_INLINE V nextAlongLanes(D d, V v, V direction)
{
  const hn::RebindToUnsigned<D> du;
  using U = hn::TFromD<decltype(du)>;
  constexpr int kSignShift = int(sizeof(Real)) * 8 - 1;
  const auto special = hn::Or(hn::Eq(v, hn::Zero(d)), hn::Not(hn::IsFinite(v)));
  if (!hn::AllFalse(d, special)) {
    HWY_ALIGN Real value[hn::MaxLanes(d)], along[hn::MaxLanes(d)];
    hn::Store(v, d, value);
    hn::Store(direction, d, along);
    for (std::size_t j = 0; j < hn::Lanes(d); ++j)
      value[j] = nextAlong(value[j], along[j]);
    return hn::Load(d, value);
  }
  const auto bits = hn::BitCast(du, v);
  const auto moves = hn::IfThenElseZero(hn::RebindMask(du, hn::Gt(hn::Abs(direction), hn::Zero(d))), hn::Set(du, U(1)));
  const auto against = hn::And(hn::ShiftRight<kSignShift>(hn::Xor(bits, hn::BitCast(du, direction))), moves);
  return hn::BitCast(d, hn::Sub(hn::Add(bits, moves), hn::Add(against, against)));
}

/// [nearestSpheres]
// The first root of sphere (c, r) inside [0, tmax) for the lanes' rays, or +∞: intersectSphere, lane by lane, the
// same operations in the same order (as sphere_lanes.cpp's four spheres for one ray, turned around: here one
// sphere for many rays). Where Δ < 0 the square root is NaN and so is every root, which no comparison accepts.
HWY_INLINE V firstRoot(D d, V ox, V oy, V oz, V dx, V dy, V dz, V tmax, V cx, V cy, V cz, V radius)
{
  const V inf = hn::Set(d, kInfinity);
  const V zero = hn::Zero(d);
  // Closest approach: f = o − c, b = −f·d, l = f + b·d, and the discriminant Δ = r² − |l|².
  const V fx = hn::Sub(ox, cx), fy = hn::Sub(oy, cy), fz = hn::Sub(oz, cz);
  const V rr = hn::Mul(radius, radius);
  const V ff = hn::Add(hn::Add(hn::Mul(fx, fx), hn::Mul(fy, fy)), hn::Mul(fz, fz));
  const V b = hn::Neg(hn::Add(hn::Add(hn::Mul(fx, dx), hn::Mul(fy, dy)), hn::Mul(fz, dz)));
  const V lx = hn::Add(fx, hn::Mul(b, dx)), ly = hn::Add(fy, hn::Mul(b, dy)), lz = hn::Add(fz, hn::Mul(b, dz));
  const V disc = hn::Sub(rr, hn::Add(hn::Add(hn::Mul(lx, lx), hn::Mul(ly, ly)), hn::Mul(lz, lz)));
  // No lane can hit (Δ < 0, or outside and heading away): no square root, as intersectSphere's early exit.
  const M possible = hn::AndNot(hn::And(hn::Gt(ff, rr), hn::Le(b, zero)), hn::Ge(disc, zero));
  if (hn::AllFalse(d, possible))
    return inf;
  // The roots q = b + sign(b)·√Δ and c/q, c = |f|² − r²; both b on a tangent through the origin (q = 0).
  const V q = hn::Add(b, hn::CopySign(hn::Sqrt(disc), b));
  const V c = hn::Sub(ff, rr);
  const M tangent = hn::Eq(q, zero);
  const V r0 = hn::IfThenElse(tangent, b, hn::Div(c, q)), r1 = hn::IfThenElse(tangent, b, q);
  const M swap = hn::Gt(r0, r1);
  const V t0 = hn::IfThenElse(swap, r1, r0), t1 = hn::IfThenElse(swap, r0, r1);
  // The nearer root if it lies in [0, tmax), else the farther one if it does, else none.
  const M in0 = hn::And(hn::Ge(t0, zero), hn::Lt(t0, tmax)), in1 = hn::And(hn::Ge(t1, zero), hn::Lt(t1, tmax));
  return hn::IfThenElse(in0, t0, hn::IfThenElse(in1, t1, inf));
}

void NearestSpheres(const SphereList& spheres, const RayStream& rays, std::size_t first, std::size_t count,
                    Real* tOut, std::int32_t* sphereOut)
{
  const D d;
  const std::size_t lanes = hn::Lanes(d);
  HWY_ALIGN Real index[hn::MaxLanes(d)];
  const std::size_t end = first + count;
  for (std::size_t i = first; i < end; i += lanes) {
    // The last group of lanes may run past the end: it repeats the last ray there, and stores only what is in.
    const std::size_t n = std::min(lanes, end - i);
    auto load = [&](const std::vector<Real>& v) { return loadLanes(d, v.data(), i, n); };
    const V ox = load(rays.ox), oy = load(rays.oy), oz = load(rays.oz);
    const V dx = load(rays.dx), dy = load(rays.dy), dz = load(rays.dz);
    // Per lane, the nearest hit so far (the ray's tmax, then each hit's t: a later sphere must be strictly
    // nearer) and its sphere (−1: none).
    V nearest = load(rays.tmax);
    V which = hn::Set(d, Real(-1));
    for (std::size_t k = 0; k < spheres.size(); ++k) {
      const V t = firstRoot(d, ox, oy, oz, dx, dy, dz, nearest, hn::Set(d, spheres.cx[k]), hn::Set(d, spheres.cy[k]),
                            hn::Set(d, spheres.cz[k]), hn::Set(d, spheres.radius[k]));
      const M hit = hn::Lt(t, nearest); // a root found is < nearest; +∞ is not
      nearest = hn::IfThenElse(hit, t, nearest);
      which = hn::IfThenElse(hit, hn::Set(d, Real(k)), which);
    }
    storeLanes(d, nearest, tOut, i, n);
    hn::Store(which, d, index);
    for (std::size_t j = 0; j < n; ++j)
      sphereOut[i + j] = std::int32_t(index[j]);
  }
}
/// [nearestSpheres]

void AnySpheres(const SphereList& spheres, const RayStream& rays, std::size_t count, std::uint8_t* occluded)
{
  const D d;
  const std::size_t lanes = hn::Lanes(d);
  for (std::size_t i = 0; i < count; i += lanes) {
    const std::size_t n = std::min(lanes, count - i);
    auto load = [&](const std::vector<Real>& v) { return loadLanes(d, v.data(), i, n); };
    const V ox = load(rays.ox), oy = load(rays.oy), oz = load(rays.oz);
    const V dx = load(rays.dx), dy = load(rays.dy), dz = load(rays.dz);
    const V tmax = load(rays.tmax);
    M blocked = hn::FirstN(d, 0);
    for (std::size_t k = 0; k < spheres.size(); ++k) {
      const V t = firstRoot(d, ox, oy, oz, dx, dy, dz, tmax, hn::Set(d, spheres.cx[k]), hn::Set(d, spheres.cy[k]),
                            hn::Set(d, spheres.cz[k]), hn::Set(d, spheres.radius[k]));
      blocked = hn::Or(blocked, hn::Lt(t, tmax));
      if (hn::AllTrue(d, hn::Or(blocked, hn::Not(hn::FirstN(d, n)))))
        break; // every ray of the group is blocked: no need to test further spheres
    }
    HWY_ALIGN Real flags[hn::MaxLanes(d)];
    hn::Store(hn::IfThenElseZero(blocked, hn::Set(d, Real(1))), d, flags);
    for (std::size_t j = 0; j < n; ++j)
      occluded[i + j] = flags[j] != 0;
  }
}

/// [anySpheresListed]
void AnySpheresListed(const SphereLists& in, const RayStream& rays, std::size_t begin, std::size_t count,
                      std::uint8_t* occluded)
{
  const D d;
  const hn::RebindToSigned<D> di;
  using VI = hn::Vec<decltype(di)>;
  const std::size_t lanes = hn::Lanes(d);
  const SphereList& s = in.spheres;
  const std::size_t end = begin + count;
  for (std::size_t i = begin; i < end; i += lanes) {
    const std::size_t n = std::min(lanes, end - i);
    auto load = [&](const std::vector<Real>& v) { return loadLanes(d, v.data(), i, n); };
    const V ox = load(rays.ox), oy = load(rays.oy), oz = load(rays.oz);
    const V dx = load(rays.dx), dy = load(rays.dy), dz = load(rays.dz);
    const V tmax = load(rays.tmax);
    HWY_ALIGN LaneIndex firstLanes[hn::MaxLanes(di)], sizeLanes[hn::MaxLanes(di)];
    for (std::size_t j = 0; j < lanes; ++j) // (past the end, no list)
      firstLanes[j] = j < n ? in.first[i + j] : 0, sizeLanes[j] = j < n ? in.size[i + j] : 0;
    const VI first = hn::Load(di, firstLanes), size = hn::Load(di, sizeLanes);
    M blocked = hn::FirstN(d, 0);
    // Each lane's own list, one sphere of it a step, until every lane's list is done or its ray blocked.
    for (LaneIndex k = 0;; ++k) {
      const VI step = hn::Set(di, k);
      const M active = hn::AndNot(blocked, hn::RebindMask(d, hn::Lt(step, size)));
      if (hn::AllFalse(d, active))
        break;
      const VI sphere = hn::GatherIndex(di, in.listed.data(),
                                        hn::IfThenElseZero(hn::RebindMask(di, active), hn::Add(first, step)));
      const V t = firstRoot(d, ox, oy, oz, dx, dy, dz, tmax, hn::GatherIndex(d, s.cx.data(), sphere),
                            hn::GatherIndex(d, s.cy.data(), sphere), hn::GatherIndex(d, s.cz.data(), sphere),
                            hn::GatherIndex(d, s.radius.data(), sphere));
      blocked = hn::Or(blocked, hn::And(active, hn::Lt(t, tmax)));
    }
    // Then the spheres every ray tests, one for all the lanes at a time (as AnySpheres).
    const M past = hn::Not(hn::FirstN(d, n));
    for (const LaneIndex number : in.everywhere) {
      if (hn::AllTrue(d, hn::Or(blocked, past)))
        break;
      const std::size_t k = std::size_t(number);
      const V t = firstRoot(d, ox, oy, oz, dx, dy, dz, tmax, hn::Set(d, s.cx[k]), hn::Set(d, s.cy[k]),
                            hn::Set(d, s.cz[k]), hn::Set(d, s.radius[k]));
      blocked = hn::Or(blocked, hn::Lt(t, tmax));
    }
    HWY_ALIGN Real flags[hn::MaxLanes(d)];
    hn::Store(hn::IfThenElseZero(blocked, hn::Set(d, Real(1))), d, flags);
    for (std::size_t j = 0; j < n; ++j)
      occluded[i + j] = flags[j] != 0;
  }
}
/// [anySpheresListed]

// The tangents s and t of the frame around unit n, by Duff et al.'s construction without a branch: Frame::fromNormal
// and coneAxisFrame, lane by lane, the same operations.
struct Tangents {
  V sx, sy, sz, tx, ty, tz;
};
HWY_INLINE Tangents tangentsAround(D d, V nx, V ny, V nz)
{
  const V one = hn::Set(d, Real(1));
  const V sign = hn::CopySign(one, nz);
  const V a = hn::Div(hn::Set(d, Real(-1)), hn::Add(sign, nz));
  const V b = hn::Mul(hn::Mul(nx, ny), a);
  return Tangents{hn::Add(one, hn::Mul(hn::Mul(hn::Mul(sign, nx), nx), a)), hn::Mul(sign, b),
                  hn::Mul(hn::Neg(sign), nx), b, hn::Add(sign, hn::Mul(hn::Mul(ny, ny), a)), hn::Neg(ny)};
}

// c[0] + w·(c[1] + w·(c[2] + … + w·c[N − 1])) by Horner's scheme, innermost first: math.h's polynomials' order.
template <std::size_t N> HWY_INLINE V horner(D d, V w, const Real (&c)[N])
{
  V r = hn::Set(d, c[N - 1]);
  for (std::size_t k = N - 1; k-- > 0;)
    r = hn::Add(hn::Set(d, c[k]), hn::Mul(w, r));
  return r;
}

/// [diffuseBounces]
// sinCos2Pi (math.h), lane by lane: the octant of u, its nearest quarter turn q, f = 4u − q, the two polynomials
// in f², and the rotation by q quarter turns, whose factors (0 or ±1) make it exact.
HWY_INLINE void sinCos2PiLanes(D d, V u, V& sinOut, V& cosOut)
{
  const hn::RebindToSigned<D> di;
  using VI = hn::Vec<decltype(di)>;
  const VI octant = hn::ConvertTo(di, hn::Mul(u, hn::Set(d, Real(8)))); // truncation, as static_cast<int>
  const VI quarter = hn::ShiftRight<1>(hn::Add(octant, hn::Set(di, 1)));
  const V f = hn::Sub(hn::Mul(u, hn::Set(d, Real(4))), hn::ConvertTo(d, quarter));
  const V w = hn::Mul(f, f);
  V s, co;
  if constexpr (sizeof(Real) == 8) {
    static constexpr Real p[] = {1.5707963267948966,     -6.4596409750624432e-1, 7.9692626246043003e-2,
                                 -4.681754132340976e-3,  1.6044115074219091e-4,  -3.5986433529823097e-6,
                                 5.633933781537854e-8};
    static constexpr Real q[] = {1.2337005501361698,     -2.5366950790104782e-1, 2.0863480763340773e-2,
                                 -9.1926027454684462e-4, 2.5202039028029176e-5,  -4.7106784055052271e-7,
                                 6.3293963449674235e-9};
    s = hn::Mul(f, horner(d, w, p));
    co = hn::Sub(hn::Set(d, Real(1)), hn::Mul(w, horner(d, w, q)));
  } else {
    static constexpr Real p[] = {1.57079632f, -6.45963478e-1f, 7.96802176e-2f, -4.60214921e-3f};
    static constexpr Real q[] = {1.23370055f, -2.5366941e-1f, 2.08615283e-2f, -9.06739898e-4f};
    s = hn::Mul(f, horner(d, w, p));
    co = hn::Sub(hn::Set(d, Real(1)), hn::Mul(w, horner(d, w, q)));
  }
  // (cos qπ/2, sin qπ/2): a = {1, 0, −1, 0}[q & 3] and b = {1, 0, −1, 0}[(q + 3) & 3].
  const VI q3 = hn::And(quarter, hn::Set(di, 3));
  auto table = [&](VI k) {
    const V one = hn::Set(d, Real(1)), minusOne = hn::Set(d, Real(-1)), zero = hn::Zero(d);
    return hn::IfThenElse(hn::RebindMask(d, hn::Eq(k, hn::Set(di, 0))), one,
                          hn::IfThenElse(hn::RebindMask(d, hn::Eq(k, hn::Set(di, 2))), minusOne, zero));
  };
  const V a = table(q3);
  const V b = table(hn::And(hn::Add(quarter, hn::Set(di, 3)), hn::Set(di, 3)));
  sinOut = hn::Add(hn::Mul(a, s), hn::Mul(b, co));
  cosOut = hn::Sub(hn::Mul(a, co), hn::Mul(b, s));
}

// Local direction (x, y, z) in the frame (s, t, n) to world space, x·s + y·t + z·n (Frame::toWorld), stored as a
// bounce's direction.
HWY_INLINE void storeWorld(D d, V x, V y, V z, const Tangents& f, V nx, V ny, V nz, const DiffuseBounceOutput& out,
                           std::size_t i, std::size_t n)
{
  storeLanes(d, hn::Add(hn::Add(hn::Mul(x, f.sx), hn::Mul(y, f.tx)), hn::Mul(z, nx)), out.wx.data(), i, n);
  storeLanes(d, hn::Add(hn::Add(hn::Mul(x, f.sy), hn::Mul(y, f.ty)), hn::Mul(z, ny)), out.wy.data(), i, n);
  storeLanes(d, hn::Add(hn::Add(hn::Mul(x, f.sz), hn::Mul(y, f.tz)), hn::Mul(z, nz)), out.wz.data(), i, n);
}

void DiffuseBounces(const DiffuseBounceInput& in, std::size_t count, const DiffuseBounceOutput& out)
{
  const D d;
  const std::size_t lanes = hn::Lanes(d);
  const V zero = hn::Zero(d), one = hn::Set(d, Real(1));
  for (std::size_t i = 0; i < count; i += lanes) {
    const std::size_t n = std::min(lanes, count - i);
    auto load = [&](std::span<const Real> v) { return loadLanes(d, v.data(), i, n); };
    const V nx = load(in.nx), ny = load(in.ny), nz = load(in.nz);
    // The frame (Frame::fromNormal: Duff et al., without a branch).
    const Tangents f = tangentsAround(d, nx, ny, nz);
    // wo.z = (−d)·n.
    const V woz = hn::Add(hn::Add(hn::Mul(hn::Neg(load(in.dx)), nx), hn::Mul(hn::Neg(load(in.dy)), ny)),
                          hn::Mul(hn::Neg(load(in.dz)), nz));
    // sampleCosineHemisphere: radius √u₁, angle 2πu₂, lifted onto the hemisphere; turned to wo's side.
    const V u1 = load(in.u1);
    const V r = hn::Sqrt(u1);
    V sinPhi, cosPhi;
    sinCos2PiLanes(d, load(in.u2), sinPhi, cosPhi);
    const V wix = hn::Mul(r, cosPhi), wiy = hn::Mul(r, sinPhi);
    const V up = hn::Sqrt(maxZero(d, hn::Sub(one, u1)));
    const V wiz = hn::IfThenElse(hn::Lt(woz, zero), hn::Neg(up), up);
    // The pdf |cosθ|/π where wo and wi are on one side (and wo is not in the surface), else 0: no sample.
    const M valid = hn::And(hn::Ne(woz, zero), hn::Gt(hn::Mul(woz, wiz), zero));
    const V pdf = hn::IfThenElseZero(valid, hn::Mul(hn::Abs(wiz), hn::Set(d, kInvPi)));
    storeWorld(d, wix, wiy, wiz, f, nx, ny, nz, out, i, n);
    storeLanes(d, wiz, out.cosTheta.data(), i, n);
    storeLanes(d, pdf, out.pdf.data(), i, n);
  }
}
/// [diffuseBounces]

/// [sphereHitPoints]
void SphereHitPoints(const SphereHitInput& in, std::size_t count, const SphereHitOutput& out)
{
  const D d;
  const std::size_t lanes = hn::Lanes(d);
  const V zero = hn::Zero(d), one = hn::Set(d, Real(1));
  const V gamma5 = hn::Set(d, gamma<Real>(5)), gamma2 = hn::Set(d, gamma<Real>(2));
  for (std::size_t i = 0; i < count; i += lanes) {
    const std::size_t n = std::min(lanes, count - i);
    auto load = [&](std::span<const Real> v) { return loadLanes(d, v.data(), i, n); };
    const V t = load(in.t), cx = load(in.cx), cy = load(in.cy), cz = load(in.cz), r = load(in.radius);
    // sphereSurfacePoint: the point o + t·d relative to the centre, projected onto the sphere, and its error.
    const V lx = hn::Sub(hn::Add(load(in.ox), hn::Mul(t, load(in.dx))), cx);
    const V ly = hn::Sub(hn::Add(load(in.oy), hn::Mul(t, load(in.dy))), cy);
    const V lz = hn::Sub(hn::Add(load(in.oz), hn::Mul(t, load(in.dz))), cz);
    const V len = hn::Sqrt(hn::Add(hn::Add(hn::Mul(lx, lx), hn::Mul(ly, ly)), hn::Mul(lz, lz)));
    const auto away = hn::Gt(len, zero);
    const V nx = hn::IfThenElse(away, hn::Div(lx, len), zero), ny = hn::IfThenElse(away, hn::Div(ly, len), zero),
            nz = hn::IfThenElse(away, hn::Div(lz, len), one);
    const V sx = hn::Mul(nx, r), sy = hn::Mul(ny, r), sz = hn::Mul(nz, r);
    const V px = hn::Add(cx, sx), py = hn::Add(cy, sy), pz = hn::Add(cz, sz);
    storeLanes(d, px, out.px.data(), i, n);
    storeLanes(d, py, out.py.data(), i, n);
    storeLanes(d, pz, out.pz.data(), i, n);
    storeLanes(d, nx, out.nx.data(), i, n);
    storeLanes(d, ny, out.ny.data(), i, n);
    storeLanes(d, nz, out.nz.data(), i, n);
    storeLanes(d, hn::Add(hn::Mul(gamma5, absLanes(sx)), hn::Mul(gamma2, absLanes(px))), out.ex.data(), i, n);
    storeLanes(d, hn::Add(hn::Mul(gamma5, absLanes(sy)), hn::Mul(gamma2, absLanes(py))), out.ey.data(), i, n);
    storeLanes(d, hn::Add(hn::Mul(gamma5, absLanes(sz)), hn::Mul(gamma2, absLanes(pz))), out.ez.data(), i, n);
  }
}
/// [sphereHitPoints]

/// [sphereLightDirections]
void SphereLightDirections(const SphereLightInput& in, std::size_t count, const SphereLightOutput& out)
{
  const D d;
  const std::size_t lanes = hn::Lanes(d);
  const V zero = hn::Zero(d), one = hn::Set(d, Real(1)), two = hn::Set(d, Real(2));
  const V pi = hn::Set(d, std::numbers::pi_v<Real>);
  for (std::size_t i = 0; i < count; i += lanes) {
    const std::size_t n = std::min(lanes, count - i);
    auto load = [&](std::span<const Real> v) { return loadLanes(d, v.data(), i, n); };
    const V r = load(in.radius), u1 = load(in.u1);
    // The axis towards the centre, and how far it is.
    const V tx = hn::Sub(load(in.cx), load(in.px)), ty = hn::Sub(load(in.cy), load(in.py)),
            tz = hn::Sub(load(in.cz), load(in.pz));
    const V d2 = hn::Add(hn::Add(hn::Mul(tx, tx), hn::Mul(ty, ty)), hn::Mul(tz, tz));
    const V rr = hn::Mul(r, r);
    const auto inside = hn::Le(d2, rr);
    V sinPhi, cosPhi;
    sinCos2PiLanes(d, load(in.u2), sinPhi, cosPhi);
    // Outside: 1 − cosθ = u·(1 − cosθmax), 1 − cosθmax = s²/(1 + √(1 − s²)) with s² = r²/d² clamped to [0, 1].
    const V s2raw = hn::Div(rr, d2);
    const V s2 = hn::IfThenElse(hn::Lt(s2raw, zero), zero, hn::IfThenElse(hn::Lt(one, s2raw), one, s2raw));
    const V oneMinusCosMax = hn::Div(s2, hn::Add(one, hn::Sqrt(hn::Sub(one, s2))));
    const V oneMinusCos = hn::Mul(u1, oneMinusCosMax);
    const V cosTheta = hn::Sub(one, oneMinusCos);
    const V sinTheta = hn::Sqrt(maxZero(d, hn::Mul(oneMinusCos, hn::Sub(two, oneMinusCos))));
    const V distance = hn::Sqrt(d2);
    const V ax = hn::Div(tx, distance), ay = hn::Div(ty, distance), az = hn::Div(tz, distance);
    // The frame around the axis (coneAxisFrame: Duff et al.).
    const Tangents frame = tangentsAround(d, ax, ay, az);
    const V sx = frame.sx, sy = frame.sy, sz = frame.sz, fx = frame.tx, fy = frame.ty, fz = frame.tz;
    const V c1 = hn::Mul(sinTheta, cosPhi), c2 = hn::Mul(sinTheta, sinPhi);
    const V vx = hn::Add(hn::Add(hn::Mul(c1, sx), hn::Mul(c2, fx)), hn::Mul(cosTheta, ax));
    const V vy = hn::Add(hn::Add(hn::Mul(c1, sy), hn::Mul(c2, fy)), hn::Mul(cosTheta, ay));
    const V vz = hn::Add(hn::Add(hn::Mul(c1, sz), hn::Mul(c2, fz)), hn::Mul(cosTheta, az));
    const V inv = hn::Div(one, hn::Sqrt(hn::Add(hn::Add(hn::Mul(vx, vx), hn::Mul(vy, vy)), hn::Mul(vz, vz))));
    // Inside (or on) the light: uniform over the whole sphere of directions.
    const V z = hn::Sub(one, hn::Mul(two, u1));
    const V s = hn::Sqrt(maxZero(d, hn::Mul(hn::Sub(one, z), hn::Add(one, z))));
    storeLanes(d, hn::IfThenElse(inside, hn::Mul(s, cosPhi), hn::Mul(vx, inv)), out.wx.data(), i, n);
    storeLanes(d, hn::IfThenElse(inside, hn::Mul(s, sinPhi), hn::Mul(vy, inv)), out.wy.data(), i, n);
    storeLanes(d, hn::IfThenElse(inside, z, hn::Mul(vz, inv)), out.wz.data(), i, n);
    // The pdf: choice · (1/(4π) inside, 1/(2π(1 − cosθmax)) outside) · guide.
    const V cone = hn::IfThenElse(inside, hn::Div(one, hn::Mul(hn::Set(d, Real(4)), pi)),
                                  hn::Div(one, hn::Mul(hn::Mul(two, pi), oneMinusCosMax)));
    storeLanes(d, hn::Mul(hn::Mul(load(in.choice), cone), load(in.guide)), out.pdf.data(), i, n);
  }
}
/// [sphereLightDirections]

/// [triangleLightDirections]
// Three vectors' worth of lanes, x, y and z, for the triangle light's algebra.
struct Vec3Lanes {
  V x, y, z;
};
HWY_INLINE V dotLanes(const Vec3Lanes& a, const Vec3Lanes& b) // glm::dot: (x + y) + z
{
  return hn::Add(hn::Add(hn::Mul(a.x, b.x), hn::Mul(a.y, b.y)), hn::Mul(a.z, b.z));
}
// w in the frame (s, t, n): Frame::toLocal, (w·s, w·t, w·n).
HWY_INLINE Vec3Lanes toLocalLanes(const Vec3Lanes& w, const Tangents& f, V nx, V ny, V nz)
{
  return {dotLanes(w, {f.sx, f.sy, f.sz}), dotLanes(w, {f.tx, f.ty, f.tz}), dotLanes(w, {nx, ny, nz})};
}
HWY_INLINE Vec3Lanes crossLanes(const Vec3Lanes& a, const Vec3Lanes& b) // glm::cross
{
  return {hn::Sub(hn::Mul(a.y, b.z), hn::Mul(b.y, a.z)), hn::Sub(hn::Mul(a.z, b.x), hn::Mul(b.z, a.x)),
          hn::Sub(hn::Mul(a.x, b.y), hn::Mul(b.x, a.y))};
}
HWY_INLINE Vec3Lanes scaleAdd(V s, const Vec3Lanes& a, V t, const Vec3Lanes& b) // s·a + t·b
{
  return {hn::Add(hn::Mul(s, a.x), hn::Mul(t, b.x)), hn::Add(hn::Mul(s, a.y), hn::Mul(t, b.y)),
          hn::Add(hn::Mul(s, a.z), hn::Mul(t, b.z))};
}
HWY_INLINE Vec3Lanes minusScaled(const Vec3Lanes& a, V s, const Vec3Lanes& b) // a − s·b
{
  return {hn::Sub(a.x, hn::Mul(s, b.x)), hn::Sub(a.y, hn::Mul(s, b.y)), hn::Sub(a.z, hn::Mul(s, b.z))};
}
HWY_INLINE Vec3Lanes divLanes(const Vec3Lanes& a, V s) { return {hn::Div(a.x, s), hn::Div(a.y, s), hn::Div(a.z, s)}; }
// std::clamp(v, lo, hi): v < lo ? lo : (hi < v ? hi : v), so a NaN stays a NaN.
HWY_INLINE V clampLanes(V v, V lo, V hi)
{
  return hn::IfThenElse(hn::Lt(v, lo), lo, hn::IfThenElse(hn::Lt(hi, v), hi, v));
}
// safeNormalize(v, ·)'s usual branch, v/√(v·v); `rare` gets the lanes whose v·v is outside its range (they take
// the scalar function).
HWY_INLINE Vec3Lanes normalizeLanes(D d, const Vec3Lanes& v, M& rare)
{
  const V length2 = dotLanes(v, v);
  const V low = hn::Set(d, std::numeric_limits<Real>::min() * Real(1 << 20));
  const V high = hn::Set(d, std::numeric_limits<Real>::max() / Real(1 << 20));
  rare = hn::Or(rare, hn::Not(hn::And(hn::Gt(length2, low), hn::Lt(length2, high))));
  return divLanes(v, hn::Sqrt(length2));
}
// f(x) lane by lane through a scalar function (libm's, for the scalar code's bits).
template <class F> HWY_INLINE V laneByLane(D d, V x, F f)
{
  HWY_ALIGN Real buffer[hn::MaxLanes(d)];
  hn::Store(x, d, buffer);
  for (std::size_t j = 0; j < hn::Lanes(d); ++j)
    buffer[j] = f(buffer[j]);
  return hn::Load(d, buffer);
}

// f(k) for each lane k of [i, i + n) that `rare` holds: the lanes the scalar code decides.
template <class F> HWY_INLINE void forRareLanes(D d, M rare, std::size_t i, std::size_t n, F f)
{
  if (hn::AllFalse(d, rare))
    return;
  HWY_ALIGN Real flag[hn::MaxLanes(d)];
  hn::Store(hn::IfThenElseZero(rare, hn::Set(d, Real(1))), d, flag);
  for (std::size_t j = 0; j < n; ++j)
    if (flag[j] != 0)
      f(i + j);
}

void TriangleLightDirections(const TriangleLightInput& in, std::size_t count, const TriangleLightOutput& out)
{
  const D d;
  const std::size_t lanes = hn::Lanes(d);
  const V zero = hn::Zero(d), one = hn::Set(d, Real(1)), two = hn::Set(d, Real(2)), minusOne = hn::Set(d, Real(-1));
  const V minArea = hn::Set(d, Real(kMinSphericalTriangleArea)), maxArea = hn::Set(d, Real(kMaxSphericalTriangleArea));
  for (std::size_t i = 0; i < count; i += lanes) {
    const std::size_t n = std::min(lanes, count - i);
    auto load = [&](std::span<const Real> v) { return loadLanes(d, v.data(), i, n); };
    const V px = load(in.px), py = load(in.py), pz = load(in.pz);
    // sphericalTriangle: the unit directions towards the corners, and the solid angle
    // 2·atan2(|a·(b × c)|, 1 + a·b + b·c + c·a).
    const Vec3Lanes da{hn::Sub(load(in.ax), px), hn::Sub(load(in.ay), py), hn::Sub(load(in.az), pz)};
    const Vec3Lanes db{hn::Sub(load(in.bx), px), hn::Sub(load(in.by), py), hn::Sub(load(in.bz), pz)};
    const Vec3Lanes dc{hn::Sub(load(in.cx), px), hn::Sub(load(in.cy), py), hn::Sub(load(in.cz), pz)};
    const V la = hn::Sqrt(dotLanes(da, da)), lb = hn::Sqrt(dotLanes(db, db)), lc = hn::Sqrt(dotLanes(dc, dc));
    M rare = hn::Not(hn::And(hn::And(hn::Gt(la, zero), hn::Gt(lb, zero)), hn::Gt(lc, zero)));
    const Vec3Lanes a = divLanes(da, la), b = divLanes(db, lb), c = divLanes(dc, lc);
    const V ab = dotLanes(a, b);
    const V numerator = hn::Abs(dotLanes(a, crossLanes(b, c)));
    const V denominator = hn::Add(hn::Add(hn::Add(one, ab), dotLanes(b, c)), dotLanes(c, a));
    HWY_ALIGN Real num[hn::MaxLanes(d)], den[hn::MaxLanes(d)];
    hn::Store(numerator, d, num);
    hn::Store(denominator, d, den);
    for (std::size_t j = 0; j < lanes; ++j)
      num[j] = std::atan2(num[j], den[j]);
    const V area = hn::Mul(two, hn::Load(d, num));
    // Sampled by area where the solid angle is out of Arvo's range: the scalar function.
    rare = hn::Or(rare, hn::Not(hn::And(hn::Ge(area, minArea), hn::Le(area, maxArea))));

    // sampleSphericalTriangle (Arvo): the angle α at A, ...
    const Vec3Lanes nab = crossLanes(a, b), nac = crossLanes(a, c);
    const V lab = hn::Sqrt(dotLanes(nab, nab)), lac = hn::Sqrt(dotLanes(nac, nac));
    rare = hn::Or(rare, hn::Not(hn::And(hn::And(hn::Gt(area, zero), hn::Gt(lab, zero)), hn::Gt(lac, zero))));
    const V cosAlpha = clampLanes(hn::Div(dotLanes(nab, nac), hn::Mul(lab, lac)), minusOne, one);
    const V alpha = laneByLane(d, cosAlpha, [](Real x) { return std::acos(x); });
    const V sinAlpha = hn::Sqrt(maxZero(d, hn::Mul(hn::Sub(one, cosAlpha), hn::Add(one, cosAlpha))));
    // ... the corner C' of the sub-triangle of area u₀·Ω on the arc from A to C, ...
    const V angle = hn::Sub(hn::Mul(load(in.u1), area), alpha);
    // (Sine and cosine in one loop, which GCC makes one sincos call a lane, as it does in the scalar code.)
    HWY_ALIGN Real sines[hn::MaxLanes(d)], cosines[hn::MaxLanes(d)];
    hn::Store(angle, d, sines);
    for (std::size_t j = 0; j < lanes; ++j) {
      cosines[j] = std::cos(sines[j]);
      sines[j] = std::sin(sines[j]);
    }
    const V s = hn::Load(d, sines), t = hn::Load(d, cosines);
    const V uu = hn::Sub(t, cosAlpha);
    const V vv = hn::Add(s, hn::Mul(sinAlpha, ab));
    const V q = clampLanes(hn::Div(hn::Sub(hn::Mul(hn::Sub(hn::Mul(vv, t), hn::Mul(uu, s)), cosAlpha), vv),
                                   hn::Mul(hn::Add(hn::Mul(vv, s), hn::Mul(uu, t)), sinAlpha)),
                           minusOne, one);
    const Vec3Lanes cPerp = normalizeLanes(d, minusScaled(c, dotLanes(c, a), a), rare);
    const Vec3Lanes cPrime = scaleAdd(q, a, hn::Sqrt(maxZero(d, hn::Sub(one, hn::Mul(q, q)))), cPerp);
    // ... and the direction on the arc from B to C', at cosine z to B.
    const V z = clampLanes(hn::Sub(one, hn::Mul(load(in.u2), hn::Sub(one, dotLanes(cPrime, b)))), minusOne, one);
    const Vec3Lanes bPerp = normalizeLanes(d, minusScaled(cPrime, dotLanes(cPrime, b), b), rare);
    const Vec3Lanes wi = normalizeLanes(d, scaleAdd(z, b, hn::Sqrt(maxZero(d, hn::Sub(one, hn::Mul(z, z)))), bPerp),
                                        rare);
    storeLanes(d, wi.x, out.wx.data(), i, n);
    storeLanes(d, wi.y, out.wy.data(), i, n);
    storeLanes(d, wi.z, out.wz.data(), i, n);
    storeLanes(d, hn::Div(one, area), out.pdf.data(), i, n);
    forRareLanes(d, rare, i, n, [&](std::size_t k) {
      const std::optional<TriangleLightSample<Real>> ts =
          sampleTriangleLight(Vec3(in.px[k], in.py[k], in.pz[k]), Vec3(in.ax[k], in.ay[k], in.az[k]),
                              Vec3(in.bx[k], in.by[k], in.bz[k]), Vec3(in.cx[k], in.cy[k], in.cz[k]),
                              Vec2(in.u1[k], in.u2[k]));
      out.wx[k] = ts ? ts->wi.x : 0, out.wy[k] = ts ? ts->wi.y : 0, out.wz[k] = ts ? ts->wi.z : 0;
      out.pdf[k] = ts ? ts->pdf : 0;
    });
  }
}
/// [triangleLightDirections]

/// [shadowRaysToSpheres]
// offsetRayOrigin, lane by lane: |n|·error along n, to the side w leaves through, then one ulp further.
struct OriginLanes {
  V x, y, z;
};
HWY_INLINE OriginLanes offsetOriginLanes(D d, V px, V py, V pz, V ex, V ey, V ez, V gx, V gy, V gz, V wx, V wy, V wz)
{
  const V zero = hn::Zero(d), one = hn::Set(d, Real(1)), two = hn::Set(d, Real(2));
  const V distance =
      hn::Add(hn::Add(hn::Mul(absLanes(gx), ex), hn::Mul(absLanes(gy), ey)), hn::Mul(absLanes(gz), ez));
  const V wn = hn::Add(hn::Add(hn::Mul(wx, gx), hn::Mul(wy, gy)), hn::Mul(wz, gz));
  const V side = hn::IfThenElse(hn::Lt(wn, zero), hn::Sub(one, two), one);
  const V along = hn::Mul(side, distance);
  const V offX = hn::Mul(along, gx), offY = hn::Mul(along, gy), offZ = hn::Mul(along, gz);
  return {nextAlongLanes(d, hn::Add(px, offX), offX), nextAlongLanes(d, hn::Add(py, offY), offY),
          nextAlongLanes(d, hn::Add(pz, offZ), offZ)};
}

// The origins of shadow rays [i, i + n) of `in` (a ShadowSpawnInput or a TriangleShadowInput: the points, their
// errors and normals, the directions), stored in `out` and returned.
template <class In>
HWY_INLINE OriginLanes spawnLanes(D d, const In& in, std::size_t i, std::size_t n, const ShadowSpawnOutput& out)
{
  auto load = [&](std::span<const Real> v) { return loadLanes(d, v.data(), i, n); };
  const OriginLanes o = offsetOriginLanes(d, load(in.px), load(in.py), load(in.pz), load(in.ex), load(in.ey),
                                          load(in.ez), load(in.gx), load(in.gy), load(in.gz), load(in.wx),
                                          load(in.wy), load(in.wz));
  storeLanes(d, o.x, out.ox.data(), i, n);
  storeLanes(d, o.y, out.oy.data(), i, n);
  storeLanes(d, o.z, out.oz.data(), i, n);
  return o;
}

void ShadowRaysToSpheres(const ShadowSpawnInput& in, std::size_t count, const ShadowSpawnOutput& out)
{
  const D d;
  const std::size_t lanes = hn::Lanes(d);
  for (std::size_t i = 0; i < count; i += lanes) {
    const std::size_t n = std::min(lanes, count - i);
    auto load = [&](std::span<const Real> v) { return loadLanes(d, v.data(), i, n); };
    const V wx = load(in.wx), wy = load(in.wy), wz = load(in.wz);
    const auto [ox, oy, oz] = spawnLanes(d, in, i, n, out);
    // Where the ray first meets its sphere, in [0, ∞).
    const V t = firstRoot(d, ox, oy, oz, wx, wy, wz, hn::Set(d, kInfinity), load(in.cx), load(in.cy), load(in.cz),
                          load(in.radius));
    storeLanes(d, t, out.t.data(), i, n);
  }
}
/// [shadowRaysToSpheres]

/// [shadowRaysToTriangles]
// v's axes as intersectTriangle permutes them, so that the direction's largest component comes last: (y, z, x)
// where that is x, (z, x, y) where it is y, (x, y, z) where it is z.
HWY_INLINE Vec3Lanes permuteLanes(M zIsX, M zIsY, const Vec3Lanes& v)
{
  return {hn::IfThenElse(zIsX, v.y, hn::IfThenElse(zIsY, v.z, v.x)),
          hn::IfThenElse(zIsX, v.z, hn::IfThenElse(zIsY, v.x, v.y)),
          hn::IfThenElse(zIsX, v.x, hn::IfThenElse(zIsY, v.y, v.z))};
}
// std::max(|x|, std::max(|y|, |z|)), with std::max(a, b) = a < b ? b : a.
HWY_INLINE V maxAbsLanes(V x, V y, V z)
{
  const V ax = hn::Abs(x), ay = hn::Abs(y), az = hn::Abs(z);
  const V yz = hn::IfThenElse(hn::Lt(ay, az), az, ay);
  return hn::IfThenElse(hn::Lt(ax, yz), yz, ax);
}
// What intersectTriangle finds, lane by lane: t and the barycentrics, and the lanes where it refuses the hit.
struct TriangleLanes {
  V t, b0, b1, b2;
  M refused;
};
// intersectTriangle(o, w, p0, p1, p2, 0, tmax), one ray and one triangle a lane: the same operations in the same
// order, every refusal asked of every lane. `rare` gets the lanes the scalar test must decide (float only: an edge
// function of exactly 0, which it works out again in double).
HWY_INLINE TriangleLanes triangleLanes(D d, const Vec3Lanes& o, const Vec3Lanes& w, const Vec3Lanes& p0,
                                       const Vec3Lanes& p1, const Vec3Lanes& p2, V tmax, M& rare)
{
  const V zero = hn::Zero(d), one = hn::Set(d, Real(1)), two = hn::Set(d, Real(2)), three = hn::Set(d, Real(3));
  // The vertices moved to the ray's origin, the axes permuted, x and y sheared.
  const V adx = hn::Abs(w.x), ady = hn::Abs(w.y), adz = hn::Abs(w.z);
  const M xOverY = hn::Gt(adx, ady);
  const M zIsX = hn::And(xOverY, hn::Gt(adx, adz)), zIsY = hn::AndNot(xOverY, hn::Gt(ady, adz));
  const Vec3Lanes dp = permuteLanes(zIsX, zIsY, w);
  Vec3Lanes a = permuteLanes(zIsX, zIsY, {hn::Sub(p0.x, o.x), hn::Sub(p0.y, o.y), hn::Sub(p0.z, o.z)});
  Vec3Lanes b = permuteLanes(zIsX, zIsY, {hn::Sub(p1.x, o.x), hn::Sub(p1.y, o.y), hn::Sub(p1.z, o.z)});
  Vec3Lanes c = permuteLanes(zIsX, zIsY, {hn::Sub(p2.x, o.x), hn::Sub(p2.y, o.y), hn::Sub(p2.z, o.z)});
  const V sx = hn::Div(hn::Neg(dp.x), dp.z), sy = hn::Div(hn::Neg(dp.y), dp.z), sz = hn::Div(one, dp.z);
  for (Vec3Lanes* v : {&a, &b, &c}) {
    v->x = hn::Add(v->x, hn::Mul(sx, v->z));
    v->y = hn::Add(v->y, hn::Mul(sy, v->z));
  }
  // The edge functions, their signs, det, and t scaled by det.
  const V e0 = hn::Sub(hn::Mul(b.x, c.y), hn::Mul(b.y, c.x));
  const V e1 = hn::Sub(hn::Mul(c.x, a.y), hn::Mul(c.y, a.x));
  const V e2 = hn::Sub(hn::Mul(a.x, b.y), hn::Mul(a.y, b.x));
  if constexpr (std::is_same_v<Real, float>)
    rare = hn::Or(rare, hn::Or(hn::Or(hn::Eq(e0, zero), hn::Eq(e1, zero)), hn::Eq(e2, zero)));
  M refused = hn::And(hn::Or(hn::Or(hn::Lt(e0, zero), hn::Lt(e1, zero)), hn::Lt(e2, zero)),
                      hn::Or(hn::Or(hn::Gt(e0, zero), hn::Gt(e1, zero)), hn::Gt(e2, zero)));
  const V det = hn::Add(hn::Add(e0, e1), e2);
  refused = hn::Or(refused, hn::Eq(det, zero));
  a.z = hn::Mul(a.z, sz), b.z = hn::Mul(b.z, sz), c.z = hn::Mul(c.z, sz);
  const V tScaled = hn::Add(hn::Add(hn::Mul(e0, a.z), hn::Mul(e1, b.z)), hn::Mul(e2, c.z));
  refused = hn::Or(refused, hn::Or(hn::And(hn::Lt(det, zero), hn::Ge(tScaled, zero)),
                                   hn::And(hn::Gt(det, zero), hn::Le(tScaled, zero))));
  const V invDet = hn::Div(one, det);
  const V t = hn::Mul(tScaled, invDet);
  refused = hn::Or(refused, hn::Not(hn::And(hn::Ge(t, zero), hn::Lt(t, tmax))));
  // t only where it is greater than 0 beyond its rounding error.
  const V maxZ = maxAbsLanes(a.z, b.z, c.z), maxX = maxAbsLanes(a.x, b.x, c.x), maxY = maxAbsLanes(a.y, b.y, c.y);
  const V deltaZ = hn::Mul(hn::Set(d, gamma<Real>(3)), maxZ);
  const V deltaX = hn::Mul(hn::Set(d, gamma<Real>(5)), hn::Add(maxX, maxZ));
  const V deltaY = hn::Mul(hn::Set(d, gamma<Real>(5)), hn::Add(maxY, maxZ));
  const V deltaE = hn::Mul(two, hn::Add(hn::Add(hn::Mul(hn::Mul(hn::Set(d, gamma<Real>(2)), maxX), maxY),
                                                hn::Mul(deltaY, maxX)),
                                        hn::Mul(deltaX, maxY)));
  const V maxE = maxAbsLanes(e0, e1, e2);
  const V deltaT = hn::Mul(hn::Mul(three, hn::Add(hn::Add(hn::Mul(hn::Mul(hn::Set(d, gamma<Real>(3)), maxE), maxZ),
                                                          hn::Mul(deltaE, maxZ)),
                                                  hn::Mul(deltaZ, maxE))),
                           hn::Abs(invDet));
  refused = hn::Or(refused, hn::Not(hn::Gt(t, deltaT)));
  return {t, hn::Mul(e0, invDet), hn::Mul(e1, invDet), hn::Mul(e2, invDet), refused};
}

void ShadowRaysToTriangles(const TriangleShadowInput& in, std::size_t count, const ShadowSpawnOutput& out)
{
  const D d;
  const std::size_t lanes = hn::Lanes(d);
  const V zero = hn::Zero(d);
  for (std::size_t i = 0; i < count; i += lanes) {
    const std::size_t n = std::min(lanes, count - i);
    auto load = [&](std::span<const Real> v) { return loadLanes(d, v.data(), i, n); };
    const V wx = load(in.wx), wy = load(in.wy), wz = load(in.wz);
    const auto [ox, oy, oz] = spawnLanes(d, in, i, n, out);
    M rare = hn::Ne(zero, zero);
    const TriangleLanes h = triangleLanes(d, {ox, oy, oz}, {wx, wy, wz}, {load(in.ax), load(in.ay), load(in.az)},
                                          {load(in.bx), load(in.by), load(in.bz)},
                                          {load(in.cx), load(in.cy), load(in.cz)}, hn::Set(d, kInfinity), rare);
    storeLanes(d, hn::IfThenElse(h.refused, hn::Set(d, kInfinity), h.t), out.t.data(), i, n);
    forRareLanes(d, rare, i, n, [&](std::size_t k) {
      const std::optional<TriangleHit<Real>> scalar = intersectTriangle(
          Vec3(out.ox[k], out.oy[k], out.oz[k]), Vec3(in.wx[k], in.wy[k], in.wz[k]), Vec3(in.ax[k], in.ay[k], in.az[k]),
          Vec3(in.bx[k], in.by[k], in.bz[k]), Vec3(in.cx[k], in.cy[k], in.cz[k]), Real(0), kInfinity);
      out.t[k] = scalar ? scalar->t : kInfinity;
    });
  }
}
/// [shadowRaysToTriangles]

/// [triangleHitPoints]
void TriangleHitPoints(const TriangleHitInput& in, std::size_t count, const TriangleHitOutput& out)
{
  const D d;
  const std::size_t lanes = hn::Lanes(d);
  const V zero = hn::Zero(d), third = hn::Set(d, Real(1) / 3), gamma7 = hn::Set(d, gamma<Real>(7));
  for (std::size_t i = 0; i < count; i += lanes) {
    const std::size_t n = std::min(lanes, count - i);
    auto load = [&](std::span<const Real> v) { return loadLanes(d, v.data(), i, n); };
    const Vec3Lanes p0{load(in.ax), load(in.ay), load(in.az)}, p1{load(in.bx), load(in.by), load(in.bz)},
        p2{load(in.cx), load(in.cy), load(in.cz)};
    M rare = hn::Ne(zero, zero);
    const TriangleLanes h = triangleLanes(d, {load(in.ox), load(in.oy), load(in.oz)},
                                          {load(in.dx), load(in.dy), load(in.dz)}, p0, p1, p2, load(in.tmax), rare);
    const V b0 = hn::IfThenElse(h.refused, third, h.b0), b1 = hn::IfThenElse(h.refused, third, h.b1),
            b2 = hn::IfThenElse(h.refused, third, h.b2);
    // trianglePoint: b0·p0 + b1·p1 + b2·p2, and γ(7)·(|b0·p0| + |b1·p1| + |b2·p2|).
    const Vec3Lanes q0{hn::Mul(b0, p0.x), hn::Mul(b0, p0.y), hn::Mul(b0, p0.z)};
    const Vec3Lanes q1{hn::Mul(b1, p1.x), hn::Mul(b1, p1.y), hn::Mul(b1, p1.z)};
    const Vec3Lanes q2{hn::Mul(b2, p2.x), hn::Mul(b2, p2.y), hn::Mul(b2, p2.z)};
    storeLanes(d, hn::Add(hn::Add(q0.x, q1.x), q2.x), out.px.data(), i, n);
    storeLanes(d, hn::Add(hn::Add(q0.y, q1.y), q2.y), out.py.data(), i, n);
    storeLanes(d, hn::Add(hn::Add(q0.z, q1.z), q2.z), out.pz.data(), i, n);
    auto error = [&](V a, V b, V c) {
      return hn::Mul(gamma7, hn::Add(hn::Add(absLanes(a), absLanes(b)), absLanes(c)));
    };
    storeLanes(d, error(q0.x, q1.x, q2.x), out.ex.data(), i, n);
    storeLanes(d, error(q0.y, q1.y, q2.y), out.ey.data(), i, n);
    storeLanes(d, error(q0.z, q1.z, q2.z), out.ez.data(), i, n);
    // triangleNormal: (p1 − p0) × (p2 − p0), normalised.
    const Vec3Lanes g = normalizeLanes(
        d,
        crossLanes({hn::Sub(p1.x, p0.x), hn::Sub(p1.y, p0.y), hn::Sub(p1.z, p0.z)},
                   {hn::Sub(p2.x, p0.x), hn::Sub(p2.y, p0.y), hn::Sub(p2.z, p0.z)}),
        rare);
    storeLanes(d, g.x, out.gx.data(), i, n);
    storeLanes(d, g.y, out.gy.data(), i, n);
    storeLanes(d, g.z, out.gz.data(), i, n);
    storeLanes(d, b0, out.b0.data(), i, n);
    storeLanes(d, b1, out.b1.data(), i, n);
    storeLanes(d, b2, out.b2.data(), i, n);
    forRareLanes(d, rare, i, n, [&](std::size_t k) {
      const Vec3 a(in.ax[k], in.ay[k], in.az[k]), b(in.bx[k], in.by[k], in.bz[k]), c(in.cx[k], in.cy[k], in.cz[k]);
      const std::optional<TriangleHit<Real>> th = intersectTriangle(
          Vec3(in.ox[k], in.oy[k], in.oz[k]), Vec3(in.dx[k], in.dy[k], in.dz[k]), a, b, c, Real(0), in.tmax[k]);
      const Real w0 = th ? th->b0 : Real(1) / 3, w1 = th ? th->b1 : Real(1) / 3, w2 = th ? th->b2 : Real(1) / 3;
      const TrianglePoint<Real> tp = trianglePoint(a, b, c, w0, w1, w2);
      const Vec3 normal = triangleNormal(a, b, c);
      out.px[k] = tp.point.x, out.py[k] = tp.point.y, out.pz[k] = tp.point.z;
      out.ex[k] = tp.error.x, out.ey[k] = tp.error.y, out.ez[k] = tp.error.z;
      out.gx[k] = normal.x, out.gy[k] = normal.y, out.gz[k] = normal.z;
      out.b0[k] = w0, out.b1[k] = w1, out.b2[k] = w2;
    });
  }
}
/// [triangleHitPoints]

/// [pinholeDirections]
// Camera::ray(film) through a pinhole, lane by lane: the film position, the image plane's point u·x + v·y − w at
// z = 1, and glm::normalize (v · 1/√(v·v)).
void PinholeDirections(const Camera& camera, const FilmInput& in, std::size_t count, const DirectionOutput& out)
{
  const D d;
  const std::size_t lanes = hn::Lanes(d);
  const V one = hn::Set(d, Real(1)), two = hn::Set(d, Real(2));
  const V width = hn::Set(d, Real(camera.width())), height = hn::Set(d, Real(camera.height()));
  const V halfWidth = hn::Set(d, camera.halfWidth()), halfHeight = hn::Set(d, camera.halfHeight());
  const CameraBasis& b = camera.basis();
  for (std::size_t i = 0; i < count; i += lanes) {
    const std::size_t n = std::min(lanes, count - i);
    auto load = [&](std::span<const Real> v) { return loadLanes(d, v.data(), i, n); };
    const V strata = load(in.strata);
    const V filmX = hn::Add(load(in.x), hn::Div(load(in.offsetX), strata));
    const V filmY = hn::Add(load(in.y), hn::Div(load(in.offsetY), strata));
    // (2·film.x / width − 1)·halfWidth, (1 − 2·film.y / height)·halfHeight: row 0 at the top.
    const V x = hn::Mul(hn::Sub(hn::Div(hn::Mul(two, filmX), width), one), halfWidth);
    const V y = hn::Mul(hn::Sub(one, hn::Div(hn::Mul(two, filmY), height)), halfHeight);
    auto axis = [&](Real u, Real v, Real w) {
      return hn::Sub(hn::Add(hn::Mul(hn::Set(d, u), x), hn::Mul(hn::Set(d, v), y)), hn::Set(d, w));
    };
    const V vx = axis(b.u.x, b.v.x, b.w.x), vy = axis(b.u.y, b.v.y, b.w.y), vz = axis(b.u.z, b.v.z, b.w.z);
    const V inv = hn::Div(one, hn::Sqrt(hn::Add(hn::Add(hn::Mul(vx, vx), hn::Mul(vy, vy)), hn::Mul(vz, vz))));
    storeLanes(d, hn::Mul(vx, inv), out.dx.data(), i, n);
    storeLanes(d, hn::Mul(vy, inv), out.dy.data(), i, n);
    storeLanes(d, hn::Mul(vz, inv), out.dz.data(), i, n);
  }
}
/// [pinholeDirections]

/// [pointLightRays]
void PointLightRays(const PointLightInput& in, std::size_t count, const PointLightOutput& out)
{
  const D d;
  const std::size_t lanes = hn::Lanes(d);
  const V zero = hn::Zero(d), one = hn::Set(d, Real(1)), shorten = hn::Set(d, Real(1) - kShadowRayShorten);
  for (std::size_t i = 0; i < count; i += lanes) {
    const std::size_t n = std::min(lanes, count - i);
    auto load = [&](std::span<const Real> v) { return loadLanes(d, v.data(), i, n); };
    const V px = load(in.px), py = load(in.py), pz = load(in.pz);
    const V lx = load(in.lx), ly = load(in.ly), lz = load(in.lz);
    // arrivalAt: the direction towards the light and the inverse-square law (nothing where the distance is not > 0).
    const V tx = hn::Sub(lx, px), ty = hn::Sub(ly, py), tz = hn::Sub(lz, pz);
    const V distance = hn::Sqrt(hn::Add(hn::Add(hn::Mul(tx, tx), hn::Mul(ty, ty)), hn::Mul(tz, tz)));
    const V wx = hn::Div(tx, distance), wy = hn::Div(ty, distance), wz = hn::Div(tz, distance);
    const V r2 = hn::Mul(distance, distance);
    storeLanes(d, wx, out.wx.data(), i, n);
    storeLanes(d, wy, out.wy.data(), i, n);
    storeLanes(d, wz, out.wz.data(), i, n);
    storeLanes(d, hn::Div(load(in.iR), r2), out.liR.data(), i, n);
    storeLanes(d, hn::Div(load(in.iG), r2), out.liG.data(), i, n);
    storeLanes(d, hn::Div(load(in.iB), r2), out.liB.data(), i, n);
    storeLanes(d, hn::IfThenElseZero(hn::Gt(distance, zero), one), out.arrives.data(), i, n);
    // spawnRayTo: the origin off the surface towards the light, and the distance from there, a little short.
    const auto [ox, oy, oz] = offsetOriginLanes(d, px, py, pz, load(in.ex), load(in.ey), load(in.ez), load(in.gx),
                                                load(in.gy), load(in.gz), wx, wy, wz);
    storeLanes(d, ox, out.ox.data(), i, n);
    storeLanes(d, oy, out.oy.data(), i, n);
    storeLanes(d, oz, out.oz.data(), i, n);
    const V sx = hn::Sub(lx, ox), sy = hn::Sub(ly, oy), sz = hn::Sub(lz, oz);
    const V left = hn::Sqrt(hn::Add(hn::Add(hn::Mul(sx, sx), hn::Mul(sy, sy)), hn::Mul(sz, sz)));
    storeLanes(d, hn::Mul(left, shorten), out.t.data(), i, n);
  }
}
/// [pointLightRays]

// std::pow(x, y) lane by lane, in the lanes `which` holds (0 in the others): libm's pow, whose bits no polynomial of
// ours would give, as the scalar code calls it.
HWY_INLINE V powLanes(D d, V x, V y, M which)
{
  if (hn::AllFalse(d, which))
    return hn::Zero(d);
  HWY_ALIGN Real base[hn::MaxLanes(d)], power[hn::MaxLanes(d)], flag[hn::MaxLanes(d)];
  hn::Store(x, d, base);
  hn::Store(y, d, power);
  hn::Store(hn::IfThenElseZero(which, hn::Set(d, Real(1))), d, flag);
  for (std::size_t j = 0; j < hn::Lanes(d); ++j)
    base[j] = flag[j] != 0 ? std::pow(base[j], power[j]) : Real(0);
  return hn::Load(d, base);
}

// The normalised Phong lobe at wo and wi (shading frame) in the lanes `which` holds: phongEval's factor of ρ_s,
// (n + 2)/(2π) cosⁿα, and phongPdf, (n + 1)/(2π) cosⁿα, with cosα = wi·reflectLocal(wo); both 0 where wo and wi lie
// on two sides, where cosα ≤ 0, where n is above kMaxPhongExponent, and outside `which`.
struct PhongLanes {
  V fScale, pdf;
};
HWY_INLINE PhongLanes phongLanes(D d, const Vec3Lanes& wo, const Vec3Lanes& wi, V exponent, M which)
{
  const V zero = hn::Zero(d), twoPi = hn::Set(d, 2 * kPi);
  const V cosAlpha = dotLanes(wi, {hn::Neg(wo.x), hn::Neg(wo.y), wo.z});
  const M lobe = hn::And(hn::And(which, hn::Le(exponent, hn::Set(d, kMaxPhongExponent))),
                         hn::And(hn::Gt(hn::Mul(wo.z, wi.z), zero), hn::Gt(cosAlpha, zero)));
  const V power = powLanes(d, cosAlpha, exponent, lobe);
  return {hn::IfThenElseZero(lobe, hn::Mul(hn::Div(hn::Add(exponent, hn::Set(d, Real(2))), twoPi), power)),
          hn::IfThenElseZero(lobe, hn::Mul(hn::Div(hn::Add(exponent, hn::Set(d, Real(1))), twoPi), power))};
}

/// [glossyBounces]
void GlossyBounces(const GlossyBounceInput& glossy, std::size_t count, const GlossyBounceOutput& out)
{
  const D d;
  const std::size_t lanes = hn::Lanes(d);
  const V zero = hn::Zero(d), one = hn::Set(d, Real(1));
  const DiffuseBounceInput& in = glossy.hit;
  for (std::size_t i = 0; i < count; i += lanes) {
    const std::size_t n = std::min(lanes, count - i);
    auto load = [&](std::span<const Real> v) { return loadLanes(d, v.data(), i, n); };
    const V nx = load(in.nx), ny = load(in.ny), nz = load(in.nz), exponent = load(glossy.exponent);
    const Tangents f = tangentsAround(d, nx, ny, nz);
    const Vec3Lanes minusD{hn::Neg(load(in.dx)), hn::Neg(load(in.dy)), hn::Neg(load(in.dz))};
    const Vec3Lanes wo = toLocalLanes(minusD, f, nx, ny, nz);
    // samplePhongLobe: cosα = (1 − u₁)^(1/(n + 1)), sinα, and the azimuth 2πu₂, around r = reflectLocal(wo).
    const V cosAlpha = powLanes(d, hn::Sub(one, load(in.u1)), hn::Div(one, hn::Add(exponent, one)), hn::Eq(one, one));
    const V sinAlpha = hn::Sqrt(maxZero(d, hn::Sub(one, hn::Mul(cosAlpha, cosAlpha))));
    V sinPhi, cosPhi;
    sinCos2PiLanes(d, load(in.u2), sinPhi, cosPhi);
    const V lx = hn::Mul(sinAlpha, cosPhi), ly = hn::Mul(sinAlpha, sinPhi);
    const Vec3Lanes r{hn::Neg(wo.x), hn::Neg(wo.y), wo.z};
    const Tangents g = tangentsAround(d, r.x, r.y, r.z);
    // Frame::fromNormal(r).toWorld, then glm::normalize: v·(1/√(v·v)).
    const Vec3Lanes v{hn::Add(hn::Add(hn::Mul(lx, g.sx), hn::Mul(ly, g.tx)), hn::Mul(cosAlpha, r.x)),
                      hn::Add(hn::Add(hn::Mul(lx, g.sy), hn::Mul(ly, g.ty)), hn::Mul(cosAlpha, r.y)),
                      hn::Add(hn::Add(hn::Mul(lx, g.sz), hn::Mul(ly, g.tz)), hn::Mul(cosAlpha, r.z))};
    const V inv = hn::Div(one, hn::Sqrt(dotLanes(v, v)));
    const Vec3Lanes wi{hn::Mul(v.x, inv), hn::Mul(v.y, inv), hn::Mul(v.z, inv)};
    // phongPdf and phongEval's factor; no sample where wo lies in the surface or the pdf is not > 0.
    const PhongLanes phong = phongLanes(d, wo, wi, exponent, hn::Ne(wo.z, zero));
    const M valid = hn::And(hn::Ne(wo.z, zero), hn::Gt(phong.pdf, zero));
    storeWorld(d, wi.x, wi.y, wi.z, f, nx, ny, nz, out.bounce, i, n);
    storeLanes(d, wi.z, out.bounce.cosTheta.data(), i, n);
    storeLanes(d, hn::IfThenElseZero(valid, phong.pdf), out.bounce.pdf.data(), i, n);
    storeLanes(d, phong.fScale, out.fScale.data(), i, n);
  }
}
/// [glossyBounces]

/// [pixelSamplers]
using DU64 = hn::ScalableTag<std::uint64_t>;
using VU64 = hn::Vec<DU64>;

// The low 64 bits of a·b, lane by lane: one instruction with AVX-512 (and in the scalar target), else from the
// 32-bit halves, aL·bL + ((aH·bL + aL·bH) << 32).
HWY_INLINE VU64 mul64(VU64 a, VU64 b)
{
#if HWY_TARGET <= HWY_AVX3 || HWY_TARGET == HWY_SCALAR || HWY_TARGET == HWY_EMU128
  return hn::Mul(a, b);
#else
  const hn::Repartition<std::uint32_t, DU64> d32;
  auto low = [&](VU64 x, VU64 y) { return hn::MulEven(hn::BitCast(d32, x), hn::BitCast(d32, y)); };
  const VU64 cross = hn::Add(low(hn::ShiftRight<32>(a), b), low(a, hn::ShiftRight<32>(b)));
  return hn::Add(low(a, b), hn::ShiftLeft<32>(cross));
#endif
}

// mix64 (rng.h), lane by lane.
HWY_INLINE VU64 mix64Lanes(DU64 du, VU64 z)
{
  z = hn::Add(z, hn::Set(du, 0x9e3779b97f4a7c15ULL));
  z = mul64(hn::Xor(z, hn::ShiftRight<30>(z)), hn::Set(du, 0xbf58476d1ce4e5b9ULL));
  z = mul64(hn::Xor(z, hn::ShiftRight<27>(z)), hn::Set(du, 0x94d049bb133111ebULL));
  return hn::Xor(z, hn::ShiftRight<31>(z));
}

void PixelSamplers(std::uint64_t seed, const PixelSampleColumns& in, std::size_t count, const GeneratorColumns& out)
{
  const DU64 du;
  const hn::Rebind<std::uint32_t, DU64> du32;
  const hn::Rebind<std::int32_t, DU64> di32;
  const hn::Rebind<std::int64_t, DU64> di64;
  const std::size_t lanes = hn::Lanes(du);
  std::size_t i = 0;
  for (; i + lanes <= count; i += lanes) {
    // The pixel as std::uint32_t(x) | std::uint32_t(y) << 32, and the sample's index widened as std::uint64_t(s).
    auto unsigned32 = [&](std::span<const std::int32_t> v) {
      return hn::PromoteTo(du, hn::BitCast(du32, hn::LoadU(di32, v.data() + i)));
    };
    const VU64 pixel = hn::Or(unsigned32(in.x), hn::ShiftLeft<32>(unsigned32(in.y)));
    const VU64 sample = hn::BitCast(du, hn::PromoteTo(di64, hn::LoadU(di32, in.sample.data() + i)));
    // Sampler's seeding: Pcg32(mix64(seed ^ mix64(pixel)), mix64(sample ^ k)), whose constructor sets the increment
    // 2·stream + 1, steps once from state 0 (to the increment), adds the seed and steps again.
    const VU64 start = mix64Lanes(du, hn::Xor(hn::Set(du, seed), mix64Lanes(du, pixel)));
    const VU64 stream = mix64Lanes(du, hn::Xor(sample, hn::Set(du, 0x5851f42d4c957f2dULL)));
    const VU64 increment = hn::Or(hn::ShiftLeft<1>(stream), hn::Set(du, 1));
    const VU64 state = hn::Add(mul64(hn::Add(increment, start), hn::Set(du, Pcg32::kMultiplier)), increment);
    hn::StoreU(state, du, out.state.data() + i);
    hn::StoreU(increment, du, out.increment.data() + i);
  }
  for (; i < count; ++i) { // (the last, short group: one at a time)
    const Pcg32 g = Sampler(seed, in.x[i], in.y[i], std::uint64_t(in.sample[i])).generator();
    out.state[i] = g.state(), out.increment[i] = g.increment();
  }
}
/// [pixelSamplers]

/// [specularBounces]
void SpecularBounces(const SpecularBounceInput& in, std::size_t count, const DiffuseBounceOutput& out)
{
  const D d;
  const std::size_t lanes = hn::Lanes(d);
  const V zero = hn::Zero(d), one = hn::Set(d, Real(1));
  for (std::size_t i = 0; i < count; i += lanes) {
    const std::size_t n = std::min(lanes, count - i);
    auto load = [&](std::span<const Real> v) { return loadLanes(d, v.data(), i, n); };
    const V nx = load(in.nx), ny = load(in.ny), nz = load(in.nz), eta = load(in.eta);
    const Tangents f = tangentsAround(d, nx, ny, nz);
    const Vec3Lanes minusD{hn::Neg(load(in.dx)), hn::Neg(load(in.dy)), hn::Neg(load(in.dz))};
    const Vec3Lanes wo = toLocalLanes(minusD, f, nx, ny, nz);
    // From inside (wo.z < 0) the light leaves the glass: η becomes 1/η, and the cosine and the normal turn over.
    const M inside = hn::Lt(wo.z, zero);
    const V etaSide = hn::IfThenElse(inside, hn::Div(one, eta), eta);
    // cosTransmittedSquared: ((η − 1)(η + 1) + cos²θi)/η², ≤ 0 for total internal reflection.
    auto cos2T = [&](V cosI) {
      return hn::Div(hn::Add(hn::Mul(hn::Sub(etaSide, one), hn::Add(etaSide, one)), hn::Mul(cosI, cosI)),
                     hn::Mul(etaSide, etaSide));
    };
    // fresnelDielectric(wo.z, η), of the cosine clamped to [−1, 1]; 1 for a mirror (it always reflects).
    const V clamped = hn::Min(hn::Max(wo.z, hn::Set(d, Real(-1))), one);
    const V cosI = hn::IfThenElse(inside, hn::Neg(clamped), clamped);
    const V c2 = cos2T(cosI);
    const V cosT = hn::Sqrt(maxZero(d, c2));
    const V rParallel = hn::Div(hn::Sub(hn::Mul(etaSide, cosI), cosT), hn::Add(hn::Mul(etaSide, cosI), cosT));
    const V rPerpendicular = hn::Div(hn::Sub(cosI, hn::Mul(etaSide, cosT)), hn::Add(cosI, hn::Mul(etaSide, cosT)));
    const V fresnel = hn::Div(hn::Add(hn::Mul(rParallel, rParallel), hn::Mul(rPerpendicular, rPerpendicular)),
                              hn::Set(d, Real(2)));
    const V F = hn::IfThenElse(hn::Or(hn::Eq(eta, zero), hn::Le(c2, zero)), one, fresnel);
    // Reflection with probability F: reflectLocal(wo).
    const M reflect = hn::Lt(load(in.uChoice), F);
    // refract(wo, (0, 0, 1), η) (its cosine wo.z, not clamped): −wo/η + (cosθi/η − cosθt)·n on wo's side, made unit
    // as glm::normalize makes it, v·(1/√(v·v)).
    const V cosIr = hn::Abs(wo.z);
    const V c2r = cos2T(cosIr);
    const V k = hn::Sub(hn::Div(cosIr, etaSide), hn::Sqrt(maxZero(d, c2r)));
    const V nSide = hn::IfThenElse(inside, hn::Set(d, Real(-0.0)), zero); // the facing normal's x and y: ±0
    const Vec3Lanes v{hn::Add(hn::Div(hn::Neg(wo.x), etaSide), hn::Mul(k, nSide)),
                      hn::Add(hn::Div(hn::Neg(wo.y), etaSide), hn::Mul(k, nSide)),
                      hn::Add(hn::Div(hn::Neg(wo.z), etaSide), hn::Mul(k, hn::IfThenElse(inside, hn::Neg(one), one)))};
    const V inv = hn::Div(one, hn::Sqrt(dotLanes(v, v)));
    const Vec3Lanes wi{hn::IfThenElse(reflect, hn::Neg(wo.x), hn::Mul(v.x, inv)),
                       hn::IfThenElse(reflect, hn::Neg(wo.y), hn::Mul(v.y, inv)),
                       hn::IfThenElse(reflect, wo.z, hn::Mul(v.z, inv))};
    // No sample where wo lies in the surface, or the refraction has none (or lies in the surface).
    const M refracts = hn::And(hn::Gt(c2r, zero), hn::Ne(wi.z, zero));
    const M valid = hn::And(hn::Ne(wo.z, zero), hn::Or(reflect, refracts));
    storeWorld(d, wi.x, wi.y, wi.z, f, nx, ny, nz, out, i, n);
    storeLanes(d, wi.z, out.cosTheta.data(), i, n);
    storeLanes(d, hn::IfThenElseZero(valid, hn::IfThenElse(reflect, F, hn::Sub(one, F))), out.pdf.data(), i, n);
  }
}
/// [specularBounces]

/// [surfaceLightSamples]
// (kGlossy: some surfaces may be glossy. Without, the loop is Lambert's alone, as lean as before glossy surfaces
// came into the lanes.)
template <bool kGlossy>
HWY_INLINE void surfaceLightLoop(const SurfaceLightInput& in, std::size_t count, const SurfaceLightOutput& out)
{
  const D d;
  const std::size_t lanes = hn::Lanes(d);
  const V zero = hn::Zero(d), one = hn::Set(d, Real(1)), invPi = hn::Set(d, kInvPi);
  for (std::size_t i = 0; i < count; i += lanes) {
    const std::size_t n = std::min(lanes, count - i);
    auto load = [&](std::span<const Real> v) { return loadLanes(d, v.data(), i, n); };
    const V nx = load(in.nx), ny = load(in.ny), nz = load(in.nz);
    // cosθ of wo = −d and of wi in the shading frame (Frame::toLocal's z: the dot product with n).
    const V woz = hn::Add(hn::Add(hn::Mul(hn::Neg(load(in.dx)), nx), hn::Mul(hn::Neg(load(in.dy)), ny)),
                          hn::Mul(hn::Neg(load(in.dz)), nz));
    const V wiz = hn::Add(hn::Add(hn::Mul(load(in.wx), nx), hn::Mul(load(in.wy), ny)), hn::Mul(load(in.wz), nz));
    // Lambert: f = ρ/π and pdf |cosθi|/π where wo and wi are on one side, else 0.
    const auto sameSide = hn::Gt(hn::Mul(woz, wiz), zero);
    const V absCos = hn::Abs(wiz);
    V fR = hn::IfThenElseZero(sameSide, hn::Mul(load(in.rhoR), invPi));
    V fG = hn::IfThenElseZero(sameSide, hn::Mul(load(in.rhoG), invPi));
    V fB = hn::IfThenElseZero(sameSide, hn::Mul(load(in.rhoB), invPi));
    V bsdfPdf = hn::IfThenElseZero(sameSide, hn::Mul(absCos, invPi));
    // Phong where the surface is glossy: wo and wi in the whole shading frame, f = ρ_s·fScale and phongPdf.
    if constexpr (kGlossy) {
      const V exponent = load(in.exponent);
      const M glossy = hn::Ge(exponent, zero);
      if (!hn::AllFalse(d, glossy)) {
        const Tangents f = tangentsAround(d, nx, ny, nz);
        const Vec3Lanes s{f.sx, f.sy, f.sz}, t{f.tx, f.ty, f.tz};
        const Vec3Lanes minusD{hn::Neg(load(in.dx)), hn::Neg(load(in.dy)), hn::Neg(load(in.dz))};
        const Vec3Lanes w{load(in.wx), load(in.wy), load(in.wz)};
        const PhongLanes phong = phongLanes(d, {dotLanes(minusD, s), dotLanes(minusD, t), woz},
                                            {dotLanes(w, s), dotLanes(w, t), wiz}, exponent, glossy);
        fR = hn::IfThenElse(glossy, hn::Mul(load(in.rhoR), phong.fScale), fR);
        fG = hn::IfThenElse(glossy, hn::Mul(load(in.rhoG), phong.fScale), fG);
        fB = hn::IfThenElse(glossy, hn::Mul(load(in.rhoB), phong.fScale), fB);
        bsdfPdf = hn::IfThenElse(glossy, phong.pdf, bsdfPdf);
      }
    }
    // The MIS weight of the light's pdf p against the BSDF's q: 1/(1 + (q/p)²) or 1/(1 + q/p) (light_sampling.h,
    // whose cases p = 0 and p = ∞ do not arise here: a light sample's pdf is finite and > 0, and 1 where p = ∞).
    const V pdf = load(in.pdf);
    const V ratio = hn::Div(bsdfPdf, pdf);
    V weight = hn::Div(one, hn::Add(one, in.power ? hn::Mul(ratio, ratio) : ratio));
    weight = hn::IfThenElse(hn::IsInf(pdf), hn::IfThenElse(hn::IsInf(bsdfPdf), hn::Set(d, Real(0.5)), one), weight);
    weight = hn::IfThenElseZero(hn::Gt(pdf, zero), weight);
    if (in.delta) // a point light: no other strategy finds it
      weight = one;
    const V scale = hn::Div(weight, pdf);
    storeLanes(d, hn::Mul(hn::Mul(hn::Mul(hn::Mul(load(in.betaR), fR), absCos), load(in.leR)), scale),
               out.lightR.data(), i, n);
    storeLanes(d, hn::Mul(hn::Mul(hn::Mul(hn::Mul(load(in.betaG), fG), absCos), load(in.leG)), scale),
               out.lightG.data(), i, n);
    storeLanes(d, hn::Mul(hn::Mul(hn::Mul(hn::Mul(load(in.betaB), fB), absCos), load(in.leB)), scale),
               out.lightB.data(), i, n);
    const auto useful = hn::Or(hn::Or(hn::Ne(fR, zero), hn::Ne(fG, zero)), hn::Ne(fB, zero));
    storeLanes(d, hn::IfThenElseZero(useful, one), out.useful.data(), i, n);
  }
}
void SurfaceLightSamples(const SurfaceLightInput& in, std::size_t count, const SurfaceLightOutput& out)
{
  if (in.exponent.empty())
    surfaceLightLoop<false>(in, count, out);
  else
    surfaceLightLoop<true>(in, count, out);
}
/// [surfaceLightSamples]

void GuideCells(const GuideCellGrid& grid, const Real* px, const Real* py, const Real* pz, std::size_t count,
                SampleForestIndex* cell)
{
  const D d;
  const hn::RebindToSigned<D> di;
  const std::size_t lanes = hn::Lanes(d);
  // cellOf: each coordinate (p − min) × scale, clamped as std::min(size − 1, std::max(0, c)) and truncated.
  auto coordinate = [&](const Real* p, std::size_t i, std::size_t n, int axis) {
    const V c = hn::Mul(hn::Sub(loadLanes(d, p, i, n), hn::Set(d, grid.min[axis])), hn::Set(d, grid.scale[axis]));
    const V top = hn::Set(d, Real(grid.size[axis] - 1)), m = maxZero(d, c);
    return hn::Trunc(hn::IfThenElse(hn::Lt(m, top), m, top));
  };
  for (std::size_t i = 0; i < count; i += lanes) {
    const std::size_t n = std::min(lanes, count - i);
    HWY_ALIGN SampleForestIndex lanesOut[hn::MaxLanes(di)];
    if (grid.cell.empty()) {
      std::fill(cell + i, cell + i + n, SampleForestIndex(-1));
      continue;
    }
    // (Whole numbers below 2⁵³, or 2²⁴ in a float build: exact in Real.)
    const V number = hn::Add(hn::Mul(hn::Add(hn::Mul(coordinate(pz, i, n, 2), hn::Set(d, Real(grid.size.y))),
                                             coordinate(py, i, n, 1)),
                                     hn::Set(d, Real(grid.size.x))),
                             coordinate(px, i, n, 0));
    hn::Store(hn::GatherIndex(di, grid.cell.data(), hn::ConvertTo(di, number)), di, lanesOut);
    std::copy(lanesOut, lanesOut + n, cell + i);
  }
}

/// [guidedWarps]
void GuidedWarps(const SampleForest& forest, const GuideWarpInput& in, std::size_t count, const GuideWarpOutput& out)
{
  const D d;
  const hn::RebindToSigned<D> di;
  using VI = hn::Vec<decltype(di)>;
  const std::size_t lanes = hn::Lanes(d);
  const V zero = hn::Zero(d), one = hn::Set(d, Real(1)), two = hn::Set(d, Real(2)), four = hn::Set(d, Real(4));
  const V half = hn::Set(d, Real(0.5)), belowOne = hn::Set(d, std::nextafter(Real(1), Real(0)));
  const VI minusOneI = hn::Set(di, -1), oneI = hn::Set(di, 1), twoI = hn::Set(di, 2);
  const Real *share = forest.share.data(), *column = forest.column.data(), *bottom = forest.bottom.data();
  const SampleForestIndex* child = forest.child.data();
  // std::min(v, 1⁻) and std::clamp(v, 0, 1⁻), the same bits (NaN passes through, as there).
  auto belowOneOf = [&](V v) { return hn::IfThenElse(hn::Lt(belowOne, v), belowOne, v); };
  auto clamped = [&](V v) { return hn::IfThenElse(hn::Lt(v, zero), zero, belowOneOf(v)); };

  // One group of lanes on its way down: each lane's node, and what sample() and pdf() carry from level to level.
  struct Walk {
    V alpha, ux0, uy0, ux, uy, offsetX, offsetY, size, x, y, density;
    M guided, uniformPart, active;
    VI root, node;
  };
  // Each lane's next node is a gather that waits for the last: a walk is a chain of memory latencies. Four groups
  // walk side by side, so that the processor has four chains to overlap.
  constexpr std::size_t kGroups = 4;
  Walk walk[kGroups];
  // One level down for every group with a lane still on its way (`step` takes one group a level), until none is.
  auto walkDown = [&](std::size_t groups, auto&& step) {
    for (bool any = true; any;) {
      any = false;
      for (std::size_t g = 0; g < groups; ++g)
        if (!hn::AllFalse(d, walk[g].active)) {
          step(walk[g]);
          any = true;
        }
    }
  };
  for (std::size_t first = 0; first < count; first += kGroups * lanes) {
    const std::size_t groups = std::min(kGroups, (count - first + lanes - 1) / lanes);
    for (std::size_t g = 0; g < groups; ++g) {
      Walk& w = walk[g];
      const std::size_t i = first + g * lanes, n = std::min(lanes, count - i);
      HWY_ALIGN SampleForestIndex rootLanes[hn::MaxLanes(di)];
      for (std::size_t j = 0; j < lanes; ++j)
        rootLanes[j] = in.root[i + std::min(j, n - 1)];
      w.root = hn::Load(di, rootLanes);
      w.alpha = loadLanes(d, in.alpha.data(), i, n), w.ux0 = loadLanes(d, in.u1.data(), i, n);
      w.uy0 = loadLanes(d, in.u2.data(), i, n);
      w.guided = hn::RebindMask(d, hn::Lt(minusOneI, w.root));
      w.uniformPart = hn::Lt(w.ux0, w.alpha);
      // The tree's component: SampleTree::sample of ((u.x − α)/(1 − α) kept below 1, u.y), down each lane's tree.
      w.ux = belowOneOf(hn::Div(hn::Sub(w.ux0, w.alpha), hn::Sub(one, w.alpha))), w.uy = w.uy0;
      w.offsetX = zero, w.offsetY = zero, w.size = one;
      w.active = hn::AndNot(w.uniformPart, w.guided);
      w.node = hn::IfThenElseZero(hn::RebindMask(di, w.active), w.root);
    }
    walkDown(groups, [&](Walk& w) {
      // Column, then quadrant in it (each division as sample() does it: only the one its branch takes).
      const VI at = hn::ShiftLeft<2>(w.node), at2 = hn::ShiftLeft<1>(w.node);
      const V left = hn::GatherIndex(d, column, at2), right = hn::GatherIndex(d, column, hn::Add(at2, oneI));
      const M qx = hn::AndNot(hn::Lt(w.ux, left), hn::Lt(zero, right));
      const VI qxI = hn::IfThenElseZero(hn::RebindMask(di, qx), oneI);
      const V columnShare = hn::IfThenElse(qx, right, left);
      const V nx = hn::Div(hn::Sub(w.ux, hn::IfThenElseZero(qx, left)), columnShare);
      const V bottomShare = hn::GatherIndex(d, share, hn::Add(at, qxI));
      const V pBottom = hn::GatherIndex(d, bottom, hn::Add(at2, qxI));
      const M qy = hn::AndNot(hn::Lt(w.uy, pBottom), hn::Lt(bottomShare, columnShare));
      const V ny = hn::Div(hn::Sub(w.uy, hn::IfThenElseZero(qy, pBottom)),
                           hn::IfThenElse(qy, hn::Sub(one, pBottom), pBottom));
      const V nextSize = hn::Mul(w.size, half); // (exactly size / 2)
      w.ux = hn::IfThenElse(w.active, clamped(nx), w.ux);
      w.uy = hn::IfThenElse(w.active, clamped(ny), w.uy);
      w.offsetX = hn::IfThenElse(w.active, hn::Add(w.offsetX, hn::Mul(nextSize, hn::IfThenElseZero(qx, one))),
                                 w.offsetX);
      w.offsetY = hn::IfThenElse(w.active, hn::Add(w.offsetY, hn::Mul(nextSize, hn::IfThenElseZero(qy, one))),
                                 w.offsetY);
      w.size = hn::IfThenElse(w.active, nextSize, w.size);
      const VI quadrant = hn::Add(qxI, hn::IfThenElseZero(hn::RebindMask(di, qy), twoI));
      const VI next = hn::GatherIndex(di, child, hn::Add(at, quadrant));
      w.active = hn::And(w.active, hn::RebindMask(d, hn::Lt(minusOneI, next)));
      w.node = hn::IfThenElseZero(hn::RebindMask(di, w.active), next);
    });
    for (std::size_t g = 0; g < groups; ++g) {
      Walk& w = walk[g];
      // The point: the uniform component's u.x ÷ α, or the leaf's corner plus its size times the numbers left.
      w.ux = hn::IfThenElse(w.uniformPart, hn::Div(w.ux0, w.alpha),
                            belowOneOf(hn::Add(w.offsetX, hn::Mul(w.size, w.ux))));
      w.uy = hn::IfThenElse(w.uniformPart, w.uy0, belowOneOf(hn::Add(w.offsetY, hn::Mul(w.size, w.uy))));
      // Then the mixture's density there: α + (1 − α) × SampleTree::pdf, the product down to the point's leaf of
      // each quadrant's share over its quarter of the area.
      w.x = clamped(w.ux), w.y = clamped(w.uy), w.density = one;
      w.active = w.guided;
      w.node = hn::IfThenElseZero(hn::RebindMask(di, w.active), w.root);
    }
    walkDown(groups, [&](Walk& w) {
      const M qx = hn::Ge(w.x, half), qy = hn::Ge(w.y, half);
      const VI quadrant = hn::Add(hn::IfThenElseZero(hn::RebindMask(di, qx), oneI),
                                  hn::IfThenElseZero(hn::RebindMask(di, qy), twoI));
      const VI at = hn::Add(hn::ShiftLeft<2>(w.node), quadrant);
      w.density =
          hn::IfThenElse(w.active, hn::Mul(w.density, hn::Mul(four, hn::GatherIndex(d, share, at))), w.density);
      w.x = hn::IfThenElse(w.active, belowOneOf(hn::Sub(hn::Mul(two, w.x), hn::IfThenElseZero(qx, one))), w.x);
      w.y = hn::IfThenElse(w.active, belowOneOf(hn::Sub(hn::Mul(two, w.y), hn::IfThenElseZero(qy, one))), w.y);
      const VI next = hn::GatherIndex(di, child, at);
      w.active = hn::And(w.active, hn::RebindMask(d, hn::Lt(minusOneI, next)));
      w.node = hn::IfThenElseZero(hn::RebindMask(di, w.active), next);
    });
    for (std::size_t g = 0; g < groups; ++g) {
      const Walk& w = walk[g];
      const std::size_t i = first + g * lanes, n = std::min(lanes, count - i);
      storeLanes(d, hn::IfThenElse(w.guided, w.ux, w.ux0), out.u1.data(), i, n);
      storeLanes(d, hn::IfThenElse(w.guided, w.uy, w.uy0), out.u2.data(), i, n);
      storeLanes(d, hn::IfThenElse(w.guided, hn::Add(w.alpha, hn::Mul(hn::Sub(one, w.alpha), w.density)), one),
                 out.pdf.data(), i, n);
    }
  }
}
/// [guidedWarps]

Real LanesOf() { return Real(hn::Lanes(D())); }

} // namespace HWY_NAMESPACE
} // namespace raylife
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace raylife {

HWY_EXPORT(NearestSpheres);
HWY_EXPORT(AnySpheres);
HWY_EXPORT(AnySpheresListed);
HWY_EXPORT(DiffuseBounces);
HWY_EXPORT(SphereHitPoints);
HWY_EXPORT(SphereLightDirections);
HWY_EXPORT(TriangleLightDirections);
HWY_EXPORT(ShadowRaysToSpheres);
HWY_EXPORT(ShadowRaysToTriangles);
HWY_EXPORT(TriangleHitPoints);
HWY_EXPORT(SurfaceLightSamples);
HWY_EXPORT(GlossyBounces);
HWY_EXPORT(SpecularBounces);
HWY_EXPORT(PixelSamplers);
HWY_EXPORT(PointLightRays);
HWY_EXPORT(PinholeDirections);
HWY_EXPORT(GuidedWarps);
HWY_EXPORT(GuideCells);
HWY_EXPORT(LanesOf);

void RayStream::resize(std::size_t n)
{
  for (std::vector<Real>* v : {&ox, &oy, &oz, &dx, &dy, &dz, &tmax})
    v->resize(n);
}

SphereList SphereList::from(std::span<const Sphere> spheres)
{
  SphereList list;
  for (const Sphere& s : spheres) {
    list.cx.push_back(s.center.x);
    list.cy.push_back(s.center.y);
    list.cz.push_back(s.center.z);
    list.radius.push_back(s.radius);
  }
  return list;
}

void nearestSpheres(const SphereList& spheres, const RayStream& rays, std::size_t count, std::span<Real> t,
                    std::span<std::int32_t> sphere)
{
  HWY_DYNAMIC_DISPATCH(NearestSpheres)(spheres, rays, 0, count, t.data(), sphere.data());
}

void nearestSpheres(const SphereList& spheres, const RayStream& rays, std::size_t first, std::size_t count,
                    std::span<Real> t, std::span<std::int32_t> sphere)
{
  HWY_DYNAMIC_DISPATCH(NearestSpheres)(spheres, rays, first, count, t.data(), sphere.data());
}

void anySpheres(const SphereList& spheres, const RayStream& rays, std::size_t count,
                std::span<std::uint8_t> occluded)
{
  HWY_DYNAMIC_DISPATCH(AnySpheres)(spheres, rays, count, occluded.data());
}

void anySpheresListed(const SphereLists& lists, const RayStream& rays, std::size_t first, std::size_t count,
                      std::span<std::uint8_t> occluded)
{
  HWY_DYNAMIC_DISPATCH(AnySpheresListed)(lists, rays, first, count, occluded.data());
}

void diffuseBounces(const DiffuseBounceInput& in, std::size_t count, const DiffuseBounceOutput& out)
{
  HWY_DYNAMIC_DISPATCH(DiffuseBounces)(in, count, out);
}

namespace {
std::int64_t gForcedTarget = 0; // forceSimdTarget's choice (0: none); only tests and benchmarks set it
} // namespace

void sphereHitPoints(const SphereHitInput& in, std::size_t count, const SphereHitOutput& out)
{
  HWY_DYNAMIC_DISPATCH(SphereHitPoints)(in, count, out);
}

void sphereLightDirections(const SphereLightInput& in, std::size_t count, const SphereLightOutput& out)
{
  HWY_DYNAMIC_DISPATCH(SphereLightDirections)(in, count, out);
}

void triangleLightDirections(const TriangleLightInput& in, std::size_t count, const TriangleLightOutput& out)
{
  HWY_DYNAMIC_DISPATCH(TriangleLightDirections)(in, count, out);
}

void surfaceLightSamples(const SurfaceLightInput& in, std::size_t count, const SurfaceLightOutput& out)
{
  HWY_DYNAMIC_DISPATCH(SurfaceLightSamples)(in, count, out);
}

void glossyBounces(const GlossyBounceInput& in, std::size_t count, const GlossyBounceOutput& out)
{
  HWY_DYNAMIC_DISPATCH(GlossyBounces)(in, count, out);
}

void specularBounces(const SpecularBounceInput& in, std::size_t count, const DiffuseBounceOutput& out)
{
  HWY_DYNAMIC_DISPATCH(SpecularBounces)(in, count, out);
}

void pointLightRays(const PointLightInput& in, std::size_t count, const PointLightOutput& out)
{
  HWY_DYNAMIC_DISPATCH(PointLightRays)(in, count, out);
}

void pinholeDirections(const Camera& camera, const FilmInput& in, std::size_t count, const DirectionOutput& out)
{
  HWY_DYNAMIC_DISPATCH(PinholeDirections)(camera, in, count, out);
}

void pixelSamplers(std::uint64_t seed, const PixelSampleColumns& in, std::size_t count, const GeneratorColumns& out)
{
  HWY_DYNAMIC_DISPATCH(PixelSamplers)(seed, in, count, out);
}

void shadowRaysToSpheres(const ShadowSpawnInput& in, std::size_t count, const ShadowSpawnOutput& out)
{
  HWY_DYNAMIC_DISPATCH(ShadowRaysToSpheres)(in, count, out);
}

void shadowRaysToTriangles(const TriangleShadowInput& in, std::size_t count, const ShadowSpawnOutput& out)
{
  HWY_DYNAMIC_DISPATCH(ShadowRaysToTriangles)(in, count, out);
}

void triangleHitPoints(const TriangleHitInput& in, std::size_t count, const TriangleHitOutput& out)
{
  HWY_DYNAMIC_DISPATCH(TriangleHitPoints)(in, count, out);
}

void guideCells(const GuideCellGrid& grid, std::span<const Real> px, std::span<const Real> py,
                std::span<const Real> pz, std::size_t count, std::span<SampleForestIndex> cell)
{
  HWY_DYNAMIC_DISPATCH(GuideCells)(grid, px.data(), py.data(), pz.data(), count, cell.data());
}

void guidedWarps(const SampleForest& forest, const GuideWarpInput& in, std::size_t count, const GuideWarpOutput& out)
{
  HWY_DYNAMIC_DISPATCH(GuidedWarps)(forest, in, count, out);
}

std::vector<SimdTarget> simdTargets()
{
  std::vector<SimdTarget> targets;
  hwy::SetSupportedTargetsForTest(0);
  // Highway's targets are bits, the better ones the lower bits: the list comes best first.
  for (const std::int64_t target : hwy::SupportedAndGeneratedTargets()) {
    hwy::SetSupportedTargetsForTest(target);
    targets.push_back(SimdTarget{target, hwy::TargetName(target), int(HWY_DYNAMIC_DISPATCH(LanesOf)())});
  }
  hwy::SetSupportedTargetsForTest(gForcedTarget);
  return targets;
}

void forceSimdTarget(std::int64_t id)
{
  gForcedTarget = id;
  hwy::SetSupportedTargetsForTest(id);
}

SimdTarget currentSimdTarget()
{
  for (const SimdTarget& t : simdTargets())
    if (gForcedTarget == 0 || t.id == gForcedTarget)
      return t;
  return SimdTarget{};
}

} // namespace raylife
#endif

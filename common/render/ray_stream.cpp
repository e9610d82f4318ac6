// The stream kernels of ray_stream.h, compiled once per instruction set by Highway (foreach_target.h includes this
// file again for each target) and chosen at run time.
#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "render/ray_stream.cpp"
#include <hwy/foreach_target.h> // must come before highway.h

#include <hwy/highway.h>

#include "render/ray_stream.h"

#include <algorithm>
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

void NearestSpheres(const SphereList& spheres, const RayStream& rays, std::size_t count, Real* tOut,
                    std::int32_t* sphereOut)
{
  const D d;
  const std::size_t lanes = hn::Lanes(d);
  HWY_ALIGN Real index[hn::MaxLanes(d)];
  for (std::size_t i = 0; i < count; i += lanes) {
    // The last group of lanes may run past `count`: it repeats the last ray there, and stores only what is in.
    const std::size_t n = std::min(lanes, count - i);
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
    const V sx = f.sx, sy = f.sy, sz = f.sz, tx = f.tx, ty = f.ty, tz = f.tz;
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
    // To world space: x·s + y·t + z·n.
    storeLanes(d, hn::Add(hn::Add(hn::Mul(wix, sx), hn::Mul(wiy, tx)), hn::Mul(wiz, nx)), out.wx.data(), i, n);
    storeLanes(d, hn::Add(hn::Add(hn::Mul(wix, sy), hn::Mul(wiy, ty)), hn::Mul(wiz, ny)), out.wy.data(), i, n);
    storeLanes(d, hn::Add(hn::Add(hn::Mul(wix, sz), hn::Mul(wiy, tz)), hn::Mul(wiz, nz)), out.wz.data(), i, n);
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

void ShadowRaysToSpheres(const ShadowSpawnInput& in, std::size_t count, const ShadowSpawnOutput& out)
{
  const D d;
  const std::size_t lanes = hn::Lanes(d);
  for (std::size_t i = 0; i < count; i += lanes) {
    const std::size_t n = std::min(lanes, count - i);
    auto load = [&](std::span<const Real> v) { return loadLanes(d, v.data(), i, n); };
    const V wx = load(in.wx), wy = load(in.wy), wz = load(in.wz);
    const auto [ox, oy, oz] = offsetOriginLanes(d, load(in.px), load(in.py), load(in.pz), load(in.ex), load(in.ey),
                                                load(in.ez), load(in.gx), load(in.gy), load(in.gz), wx, wy, wz);
    storeLanes(d, ox, out.ox.data(), i, n);
    storeLanes(d, oy, out.oy.data(), i, n);
    storeLanes(d, oz, out.oz.data(), i, n);
    // Where the ray first meets its sphere, in [0, ∞).
    const V t = firstRoot(d, ox, oy, oz, wx, wy, wz, hn::Set(d, kInfinity), load(in.cx), load(in.cy), load(in.cz),
                          load(in.radius));
    storeLanes(d, t, out.t.data(), i, n);
  }
}
/// [shadowRaysToSpheres]

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

/// [diffuseLightSamples]
void DiffuseLightSamples(const DiffuseLightInput& in, std::size_t count, const DiffuseLightOutput& out)
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
    const V fR = hn::IfThenElseZero(sameSide, hn::Mul(load(in.rhoR), invPi));
    const V fG = hn::IfThenElseZero(sameSide, hn::Mul(load(in.rhoG), invPi));
    const V fB = hn::IfThenElseZero(sameSide, hn::Mul(load(in.rhoB), invPi));
    const V bsdfPdf = hn::IfThenElseZero(sameSide, hn::Mul(absCos, invPi));
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
/// [diffuseLightSamples]

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
HWY_EXPORT(DiffuseBounces);
HWY_EXPORT(SphereHitPoints);
HWY_EXPORT(SphereLightDirections);
HWY_EXPORT(ShadowRaysToSpheres);
HWY_EXPORT(DiffuseLightSamples);
HWY_EXPORT(PointLightRays);
HWY_EXPORT(GuidedWarps);
HWY_EXPORT(GuideCells);
HWY_EXPORT(LanesOf);

void RayStream::resize(std::size_t n)
{
  for (std::vector<Real>* v : {&ox, &oy, &oz, &dx, &dy, &dz, &tmax})
    v->resize(n);
}

void RayStream::set(std::size_t i, const Ray& ray)
{
  ox[i] = ray.origin.x;
  oy[i] = ray.origin.y;
  oz[i] = ray.origin.z;
  dx[i] = ray.direction.x;
  dy[i] = ray.direction.y;
  dz[i] = ray.direction.z;
  tmax[i] = ray.tmax;
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
  HWY_DYNAMIC_DISPATCH(NearestSpheres)(spheres, rays, count, t.data(), sphere.data());
}

void anySpheres(const SphereList& spheres, const RayStream& rays, std::size_t count,
                std::span<std::uint8_t> occluded)
{
  HWY_DYNAMIC_DISPATCH(AnySpheres)(spheres, rays, count, occluded.data());
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

void diffuseLightSamples(const DiffuseLightInput& in, std::size_t count, const DiffuseLightOutput& out)
{
  HWY_DYNAMIC_DISPATCH(DiffuseLightSamples)(in, count, out);
}

void pointLightRays(const PointLightInput& in, std::size_t count, const PointLightOutput& out)
{
  HWY_DYNAMIC_DISPATCH(PointLightRays)(in, count, out);
}

void shadowRaysToSpheres(const ShadowSpawnInput& in, std::size_t count, const ShadowSpawnOutput& out)
{
  HWY_DYNAMIC_DISPATCH(ShadowRaysToSpheres)(in, count, out);
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

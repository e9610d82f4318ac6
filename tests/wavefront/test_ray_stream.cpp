// The stream kernels of chapter 16 (render/ray_stream.h) against the scalar code they vectorise, in every instruction
// set this machine runs (each forced in turn), bit for bit: the nearest and any sphere of a flat list against the loop
// over intersectSphere, the hit records against sphereSurfacePoint (and intersectTriangle, trianglePoint and
// triangleNormal), the directions towards spherical lights against sampleSphereCone and sphereConePdf, those towards
// triangle lights against sampleTriangleLight, the shadow rays against offsetRayOrigin and intersectSphere or
// intersectTriangle, the diffuse, glossy, mirror and glass bounces against lambertianSample, phongSample, mirrorSample
// and dielectricSample in Frame, the light samples' worth against bsdfEval, bsdfPdf and the MIS weights, the light
// guide's cells and warps against LightSampler::cellOf and SampleTree::sampleMixture, the samples' generators against
// Sampler, the pinhole camera's rays against PrimaryRays::make; on random rays, hits and numbers, with stream lengths
// that are not a multiple of the lanes.
#include "core/frame.h"
#include "core/rng.h"
#include "geometry/hit.h"
#include "geometry/light_buffer.h"
#include "render/ray_stream.h"
#include "render/render_loop.h"
#include "shading/material.h"
#include "scene/light_sampling.h"
#include "scene/scene.h"
#include "shading/bsdf.h"

#include <catch2/catch.hpp>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <iostream>
#include <limits>
#include <string>
#include <vector>

using namespace raylife;

namespace {

// The same bits (so +0 and −0 differ, and NaN equals the same NaN).
bool sameBits(Real a, Real b) { return std::memcmp(&a, &b, sizeof a) == 0; }

// A random unit vector.
Vec3 randomDirection(Pcg32& rng)
{
  auto u = [&] { return Real(rng.nextUint()) * Real(0x1p-32); };
  const Real z = 1 - 2 * u();
  const Real r = std::sqrt(std::max(Real(0), 1 - z * z));
  const Real phi = 2 * kPi * u();
  return glm::normalize(Vec3(r * std::cos(phi), r * std::sin(phi), z));
}

// Spheres like a path tracer's scenes: smallpt's huge walls (radius 1e5, the camera inside none of them but near),
// balls of radius 1 to 20, and small ones; rays from inside the room, some starting on a sphere.
struct Case {
  std::vector<Sphere> spheres;
  RayStream rays;
};

Case randomCase(std::uint64_t seed, std::size_t rayCount)
{
  Pcg32 rng(seed, 17);
  auto u = [&] { return Real(rng.nextUint()) * Real(0x1p-32); };
  Case c;
  const double walls[6][4] = {{1e5 + 1, 40.8, 81.6, 1e5},  {-1e5 + 99, 40.8, 81.6, 1e5}, {50, 40.8, 1e5, 1e5},
                              {50, 40.8, -1e5 + 170, 1e5}, {50, 1e5, 81.6, 1e5},         {50, -1e5 + 81.6, 81.6, 1e5}};
  for (const auto& w : walls)
    c.spheres.push_back(Sphere{Vec3(Real(w[0]), Real(w[1]), Real(w[2])), Real(w[3]), 0, Vec3(0)});
  for (int k = 0; k < 10; ++k)
    c.spheres.push_back(Sphere{Vec3(10 + 80 * u(), 5 + 70 * u(), 10 + 150 * u()), Real(0.5) + 20 * u(), 0, Vec3(0)});
  c.rays.resize(rayCount);
  for (std::size_t i = 0; i < rayCount; ++i) {
    Vec3 o(2 + 95 * u(), 1 + 80 * u(), 1 + 168 * u());
    const Vec3 d = randomDirection(rng);
    if (i % 7 == 0) { // on a sphere's surface (as a spawned ray's origin nearly is)
      const Sphere& s = c.spheres[6 + i % 10];
      o = s.center + s.radius * randomDirection(rng);
    }
    const Real tmax = i % 3 == 0 ? kInfinity : Real(1) + 200 * u();
    c.rays.set(i, Ray{o, d, 0, tmax, 0});
  }
  return c;
}

// The loop the kernels must equal: Scene's flat list, one sphere after the other.
std::pair<Real, int> nearestByLoop(const std::vector<Sphere>& spheres, const Ray& ray)
{
  Real nearest = ray.tmax;
  int which = -1;
  for (std::size_t k = 0; k < spheres.size(); ++k)
    if (const auto t = intersectSphere(ray.origin, ray.direction, spheres[k].center, spheres[k].radius, ray.tmin,
                                       nearest)) {
      nearest = *t;
      which = int(k);
    }
  return {nearest, which};
}

// Runs `body` once for every instruction set the kernels run here, that set forced; then the best again.
template <class F> void forEachTarget(F body)
{
  const std::vector<SimdTarget> targets = simdTargets();
  REQUIRE(!targets.empty());
  for (const SimdTarget& target : targets) {
    forceSimdTarget(target.id);
    REQUIRE(currentSimdTarget().id == target.id);
    INFO("instruction set " << target.name << " (" << target.lanes << " lanes)");
    body(target);
  }
  forceSimdTarget(0);
}

} // namespace

TEST_CASE("stream kernels: the machine runs several instruction sets and each can be forced")
{
  const std::vector<SimdTarget> targets = simdTargets();
  std::cout << "stream kernels run here on:";
  for (const SimdTarget& t : targets)
    std::cout << " " << t.name << " (" << t.lanes << " lanes)";
  std::cout << "\n";
  // Every x86-64 CPU runs at least the portable one and SSE4's; the best is the default.
  CHECK(targets.size() >= 2);
  CHECK(currentSimdTarget().id == targets.front().id);
  forceSimdTarget(targets.back().id);
  CHECK(currentSimdTarget().id == targets.back().id);
  forceSimdTarget(0);
  CHECK(currentSimdTarget().id == targets.front().id);
}

TEST_CASE("stream kernels: nearestSpheres and anySpheres equal the loop over intersectSphere, bit for bit")
{
  forEachTarget([](const SimdTarget&) {
    for (const std::size_t count : {std::size_t(1), std::size_t(7), std::size_t(33), std::size_t(20000)}) {
      const Case c = randomCase(count, count);
      const SphereList list = SphereList::from(c.spheres);
      std::vector<Real> t(count);
      std::vector<std::int32_t> sphere(count);
      std::vector<std::uint8_t> occluded(count);
      nearestSpheres(list, c.rays, count, t, sphere);
      anySpheres(list, c.rays, count, occluded);
      std::size_t wrong = 0, hits = 0;
      for (std::size_t i = 0; i < count; ++i) {
        const auto [tLoop, which] = nearestByLoop(c.spheres, c.rays.get(i));
        hits += which >= 0;
        wrong += sphere[i] != which || !sameBits(t[i], tLoop) || occluded[i] != (which >= 0);
      }
      INFO(count << " rays, " << hits << " hit");
      CHECK(wrong == 0);
      // A range of the rays alone: its entries the same, the others untouched.
      if (count > 3) {
        const std::size_t first = count / 3, part = count / 2;
        std::vector<Real> tPart(count, Real(-7));
        std::vector<std::int32_t> spherePart(count, -7);
        nearestSpheres(list, c.rays, first, part, tPart, spherePart);
        std::size_t wrongPart = 0;
        for (std::size_t i = 0; i < count; ++i) {
          const bool in = i >= first && i < first + part;
          wrongPart += in ? (spherePart[i] != sphere[i] || !sameBits(tPart[i], t[i]))
                          : (spherePart[i] != -7 || tPart[i] != Real(-7));
        }
        CHECK(wrongPart == 0);
      }
    }
  });
}

TEST_CASE("stream kernels: anySpheresListed equals the loop over each ray's list and the common one, bit for bit")
{
  // Lists of every length from none to 24 (so a group's lanes finish at different steps), numbers repeated, a
  // common list or none; and a light buffer's cells, whose answer is LightBuffer::occluded's.
  forEachTarget([](const SimdTarget&) {
    for (const std::size_t count : {std::size_t(1), std::size_t(7), std::size_t(33), std::size_t(5000)}) {
      const Case c = randomCase(count + 100, count);
      const SphereList list = SphereList::from(c.spheres);
      Pcg32 rng(count, 3);
      auto pick = [&](std::size_t n) { return std::size_t(rng.nextUint()) % n; };
      std::vector<LaneIndex> listed(300), first(count), size(count), everywhere;
      for (LaneIndex& k : listed)
        k = LaneIndex(pick(c.spheres.size()));
      for (std::size_t i = 0; i < count; ++i)
        size[i] = LaneIndex(i % 5 == 0 ? 0 : pick(25)), first[i] = LaneIndex(pick(listed.size() - 24));
      if (count % 2 == 1)
        everywhere = {3, LaneIndex(c.spheres.size() - 1), 0};
      std::vector<std::uint8_t> occluded(count, 7);
      anySpheresListed({list, listed, first, size, everywhere}, c.rays, 0, count, occluded);
      std::size_t wrong = 0, blocked = 0;
      for (std::size_t i = 0; i < count; ++i) {
        const Ray ray = c.rays.get(i);
        bool expected = false;
        auto test = [&](LaneIndex k) {
          const Sphere& sphere = c.spheres[std::size_t(k)];
          expected = expected || intersectSphere(ray.origin, ray.direction, sphere.center, sphere.radius, Real(0),
                                                 ray.tmax).has_value();
        };
        for (LaneIndex j = 0; j < size[i]; ++j)
          test(listed[std::size_t(first[i] + j)]);
        for (const LaneIndex k : everywhere)
          test(k);
        blocked += expected;
        wrong += occluded[i] != std::uint8_t(expected);
      }
      INFO(count << " rays, " << blocked << " blocked");
      CHECK(wrong == 0);
      if (count > 100)
        CHECK((blocked > count / 10 && blocked < count * 9 / 10));
      // A range of the rays alone: its entries the same, the others untouched.
      if (count > 3) {
        const std::size_t from = count / 3, part = count / 2;
        std::vector<std::uint8_t> partly(count, 7);
        anySpheresListed({list, listed, first, size, everywhere}, c.rays, from, part, partly);
        std::size_t wrongPart = 0;
        for (std::size_t i = 0; i < count; ++i)
          wrongPart += i >= from && i < from + part ? partly[i] != occluded[i] : partly[i] != 7;
        CHECK(wrongPart == 0);
      }
    }
    // A light buffer's cells: shadow rays to a light among 400 spheres, from anywhere around it.
    Pcg32 rng(5, 9);
    auto u = [&] { return Real(rng.nextUint()) * Real(0x1p-32); };
    std::vector<Sphere> spheres{Sphere{Vec3(0, -1000, 0), 1000, 0, Vec3(0)}};
    for (int k = 0; k < 400; ++k)
      spheres.push_back(Sphere{Vec3(20 * u() - 10, 4 * u(), 20 * u() - 10), Real(0.05) + Real(0.5) * u(), 0, Vec3(0)});
    const Vec3 light(1, 6, -2);
    const LightBuffer buffer(light, spheres, 32, 40);
    const std::size_t count = 3000;
    RayStream rays;
    rays.resize(count);
    std::vector<LaneIndex> first(count), size(count);
    for (std::size_t i = 0; i < count; ++i) {
      const Sphere& on = spheres[1 + i % 400]; // (every other ray starts on a sphere)
      const Vec3 o = i % 2 ? Vec3(30 * u() - 15, 5 * u(), 30 * u() - 15) : on.center + on.radius * randomDirection(rng);
      const Real distance = glm::length(light - o);
      rays.set(i, Ray{o, (light - o) / distance, 0, distance * (1 - kShadowRayShorten), 0});
      const LightBuffer::CellRange cell = buffer.cellRange(o);
      first[i] = cell.first, size[i] = cell.size;
    }
    std::vector<std::uint8_t> occluded(count);
    anySpheresListed({SphereList::from(spheres), buffer.listed(), first, size, buffer.everywhere()}, rays, 0, count,
                     occluded);
    std::size_t wrong = 0, blocked = 0;
    for (std::size_t i = 0; i < count; ++i) {
      REQUIRE(buffer.answers(rays.get(i).origin));
      const bool expected = buffer.occluded(rays.get(i));
      blocked += expected;
      wrong += occluded[i] != std::uint8_t(expected);
    }
    INFO(blocked << " of " << count << " shadow rays blocked");
    CHECK(wrong == 0);
    CHECK((blocked > count / 10 && blocked < count * 9 / 10));
  });
}

TEST_CASE("stream kernels: on a tie the lowest index wins, and a hit at tmax does not count")
{
  // Two coincident spheres: both are hit at t = 4, and the loop keeps the first (a later one must be nearer).
  std::vector<Sphere> twins = {Sphere{Vec3(0, 0, -5), 1, 0, Vec3(0)}, Sphere{Vec3(0, 0, -5), 1, 1, Vec3(0)}};
  RayStream rays;
  rays.resize(1);
  rays.set(0, Ray{Vec3(0), Vec3(0, 0, -1), 0, kInfinity, 0});
  std::vector<Real> t(1);
  std::vector<std::int32_t> sphere(1);
  nearestSpheres(SphereList::from(twins), rays, 1, t, sphere);
  CHECK(sphere[0] == 0);
  CHECK(t[0] == Real(4));
  // A ray that ends before the sphere misses it.
  rays.set(0, Ray{Vec3(0), Vec3(0, 0, -1), 0, Real(4), 0});
  nearestSpheres(SphereList::from(twins), rays, 1, t, sphere);
  CHECK(sphere[0] == -1);
  CHECK(t[0] == Real(4));
}

TEST_CASE("stream kernels: diffuseBounces equals lambertianSample in Frame::fromNormal, bit for bit")
{
  forEachTarget([](const SimdTarget&) {
    for (const std::size_t count : {std::size_t(1), std::size_t(5), std::size_t(17), std::size_t(50000)}) {
      Pcg32 rng(count, 3);
      auto u = [&] { return Real(rng.nextUint()) * Real(0x1p-32); };
      std::vector<Real> nx(count), ny(count), nz(count), dx(count), dy(count), dz(count), u1(count), u2(count);
      for (std::size_t i = 0; i < count; ++i) {
        Vec3 n = randomDirection(rng), d = randomDirection(rng);
        if (i % 11 == 0)
          n = Vec3(0, 0, i % 22 == 0 ? 1 : -1); // the frame's special axis
        if (i % 13 == 0)
          d = glm::normalize(glm::cross(n, randomDirection(rng))); // in the surface: wo.z = 0 (or nearly)
        nx[i] = n.x, ny[i] = n.y, nz[i] = n.z, dx[i] = d.x, dy[i] = d.y, dz[i] = d.z;
        u1[i] = i % 17 == 0 ? Real(0) : u(), u2[i] = i % 19 == 0 ? Real(0.5) : u();
      }
      std::vector<Real> wx(count), wy(count), wz(count), cosTheta(count), pdf(count);
      diffuseBounces({nx, ny, nz, dx, dy, dz, u1, u2}, count, {wx, wy, wz, cosTheta, pdf});
      std::size_t wrong = 0, none = 0;
      for (std::size_t i = 0; i < count; ++i) {
        const Frame frame = Frame::fromNormal(Vec3(nx[i], ny[i], nz[i]));
        const Vec3 wo = frame.toLocal(-Vec3(dx[i], dy[i], dz[i]));
        const std::optional<BsdfSample> bs = lambertianSample(Color(1), wo, Vec2(u1[i], u2[i]));
        if (!bs) {
          ++none;
          wrong += pdf[i] != 0;
          continue;
        }
        const Vec3 w = frame.toWorld(bs->wi);
        wrong += !sameBits(wx[i], w.x) || !sameBits(wy[i], w.y) || !sameBits(wz[i], w.z) ||
                 !sameBits(cosTheta[i], bs->wi.z) || !sameBits(pdf[i], bs->pdf);
      }
      INFO(count << " hits, " << none << " without a sample");
      CHECK(wrong == 0);
    }
  });
}

TEST_CASE("stream kernels: sphereHitPoints equals sphereSurfacePoint, bit for bit")
{
  forEachTarget([](const SimdTarget&) {
    for (const std::size_t count : {std::size_t(3), std::size_t(9), std::size_t(20000)}) {
      const Case c = randomCase(count + 100, count);
      std::vector<Real> ox, oy, oz, dx, dy, dz, t, cx, cy, cz, r;
      std::vector<int> sphereOf;
      for (std::size_t i = 0; i < count; ++i) {
        const Ray ray = c.rays.get(i);
        const auto [tHit, which] = nearestByLoop(c.spheres, ray);
        if (which < 0)
          continue;
        const Sphere& s = c.spheres[std::size_t(which)];
        ox.push_back(ray.origin.x), oy.push_back(ray.origin.y), oz.push_back(ray.origin.z);
        dx.push_back(ray.direction.x), dy.push_back(ray.direction.y), dz.push_back(ray.direction.z);
        t.push_back(tHit), cx.push_back(s.center.x), cy.push_back(s.center.y), cz.push_back(s.center.z);
        r.push_back(s.radius);
      }
      const std::size_t m = t.size();
      REQUIRE(m > 0);
      std::vector<Real> px(m), py(m), pz(m), nx(m), ny(m), nz(m), ex(m), ey(m), ez(m);
      sphereHitPoints({ox, oy, oz, dx, dy, dz, t, cx, cy, cz, r}, m, {px, py, pz, nx, ny, nz, ex, ey, ez});
      std::size_t wrong = 0;
      for (std::size_t k = 0; k < m; ++k) {
        const SurfacePoint<Real> sp = sphereSurfacePoint(Vec3(ox[k], oy[k], oz[k]), Vec3(dx[k], dy[k], dz[k]), t[k],
                                                         Vec3(cx[k], cy[k], cz[k]), r[k]);
        wrong += !sameBits(px[k], sp.point.x) || !sameBits(py[k], sp.point.y) || !sameBits(pz[k], sp.point.z) ||
                 !sameBits(nx[k], sp.normal.x) || !sameBits(ny[k], sp.normal.y) || !sameBits(nz[k], sp.normal.z) ||
                 !sameBits(ex[k], sp.error.x) || !sameBits(ey[k], sp.error.y) || !sameBits(ez[k], sp.error.z);
      }
      INFO(m << " hits");
      CHECK(wrong == 0);
    }
  });
}

namespace {

// A triangle in a plane z = const with corners on whole numbers, wound either way (by i), and a ray straight down
// z through the midpoint of an edge (i % 19 == 0) or through a corner: one or two edge functions exactly 0, which
// the watertight test counts as inside whichever way the triangle winds. The lanes must decide those as it does.
void throughEdgeOrCorner(std::size_t i, Vec3& p0, Vec3& p1, Vec3& p2, Vec3& origin, Vec3& direction)
{
  const Vec3 corner(Real(int(i % 7) - 3), Real(int(i % 5) - 2), Real(int(i % 3) - 1));
  p0 = corner, p1 = corner + Vec3(2, 0, 0), p2 = corner + Vec3(0, 2, 0);
  if (i % 38 < 19)
    std::swap(p1, p2);
  origin = (i % 19 == 0 ? corner + Vec3(1, 0, 0) : corner) + Vec3(0, 0, 3);
  direction = Vec3(0, 0, -1);
}

} // namespace

TEST_CASE("stream kernels: triangleHitPoints equals intersectTriangle, trianglePoint and triangleNormal, bit for bit")
{
  forEachTarget([](const SimdTarget&) {
    const std::size_t count = 30005;
    Pcg32 rng(9, 12);
    auto u = [&] { return Real(rng.nextUint()) * Real(0x1p-32); };
    std::vector<Real> ox(count), oy(count), oz(count), dx(count), dy(count), dz(count), tmax(count), ax(count),
        ay(count), az(count), bx(count), by(count), bz(count), cx(count), cy(count), cz(count);
    for (std::size_t i = 0; i < count; ++i) {
      // A triangle of size 1e-9 to 10 (the smallest with a cross product too short for safeNormalize's usual
      // branch), some degenerate (no normal), most far from the origin; a ray from up to 50 away aimed at a point
      // of it, at a corner, or past it (the test refuses: the record's 1/3 each), some along an axis.
      const Vec3 centre(200 * u() - 100, 200 * u() - 100, 200 * u() - 100);
      const Real size = i % 13 == 0 ? Real(1e-9) : Real(0.1) + 10 * u();
      Vec3 p0 = centre + size * randomDirection(rng), p1 = centre + size * randomDirection(rng);
      Vec3 p2 = centre + size * randomDirection(rng);
      if (i % 31 == 0)
        p2 = p0 + Real(2) * (p1 - p0); // in line: no area, no normal
      const Real b1 = u(), b2 = u() * (1 - b1);
      const Vec3 target = i % 11 == 0 ? p1 : (1 - b1 - b2) * p0 + b1 * p1 + b2 * p2;
      Vec3 o = target + (1 + 50 * u()) * randomDirection(rng);
      if (i % 17 == 0)
        o = target + Vec3(0, 0, 1 + 10 * u()); // straight down the z axis
      Vec3 d = glm::normalize(target - o);
      if (i % 7 == 0)
        d = randomDirection(rng);
      if (i % 19 < 2)
        throughEdgeOrCorner(i, p0, p1, p2, o, d);
      ox[i] = o.x, oy[i] = o.y, oz[i] = o.z, dx[i] = d.x, dy[i] = d.y, dz[i] = d.z;
      tmax[i] = i % 5 == 0 ? Real(1) + 10 * u() : kInfinity;
      if (i % 19 < 2 && i % 3 == 0)
        tmax[i] = 3; // (those rays meet their triangle at t = 3 exactly: a hit at tmax is none)
      ax[i] = p0.x, ay[i] = p0.y, az[i] = p0.z, bx[i] = p1.x, by[i] = p1.y, bz[i] = p1.z;
      cx[i] = p2.x, cy[i] = p2.y, cz[i] = p2.z;
    }
    std::vector<Real> px(count), py(count), pz(count), ex(count), ey(count), ez(count), gx(count), gy(count), gz(count),
        w0(count), w1(count), w2(count);
    triangleHitPoints({ox, oy, oz, dx, dy, dz, tmax, ax, ay, az, bx, by, bz, cx, cy, cz}, count,
                      {px, py, pz, ex, ey, ez, gx, gy, gz, w0, w1, w2});
    std::size_t wrong = 0, hits = 0;
    for (std::size_t i = 0; i < count; ++i) {
      const Vec3 p0(ax[i], ay[i], az[i]), p1(bx[i], by[i], bz[i]), p2(cx[i], cy[i], cz[i]);
      const std::optional<TriangleHit<Real>> h =
          intersectTriangle(Vec3(ox[i], oy[i], oz[i]), Vec3(dx[i], dy[i], dz[i]), p0, p1, p2, Real(0), tmax[i]);
      hits += h.has_value();
      const Real b0 = h ? h->b0 : Real(1) / 3, b1 = h ? h->b1 : Real(1) / 3, b2 = h ? h->b2 : Real(1) / 3;
      const TrianglePoint<Real> tp = trianglePoint(p0, p1, p2, b0, b1, b2);
      const Vec3 n = triangleNormal(p0, p1, p2);
      wrong += !sameBits(px[i], tp.point.x) || !sameBits(py[i], tp.point.y) || !sameBits(pz[i], tp.point.z) ||
               !sameBits(ex[i], tp.error.x) || !sameBits(ey[i], tp.error.y) || !sameBits(ez[i], tp.error.z) ||
               !sameBits(gx[i], n.x) || !sameBits(gy[i], n.y) || !sameBits(gz[i], n.z) || !sameBits(w0[i], b0) ||
               !sameBits(w1[i], b1) || !sameBits(w2[i], b2);
    }
    INFO(hits << " of " << count << " rays hit their triangle");
    CHECK(hits > count / 2);
    CHECK(hits < count);
    CHECK(wrong == 0);
  });
}

TEST_CASE("stream kernels: sphereLightDirections equals sampleSphereCone and its pdf, from outside and inside")
{
  forEachTarget([](const SimdTarget&) {
    const std::size_t count = 30001;
    Pcg32 rng(5, 9);
    auto u = [&] { return Real(rng.nextUint()) * Real(0x1p-32); };
    std::vector<Real> px(count), py(count), pz(count), cx(count), cy(count), cz(count), r(count), u1(count),
        u2(count), choice(count), guide(count);
    for (std::size_t i = 0; i < count; ++i) {
      const Vec3 c(100 * u() - 50, 100 * u() - 50, 100 * u() - 50);
      const Real radius = i % 5 == 0 ? Real(1e-3) : Real(0.1) + 10 * u();
      // Near, far (a tiny cone), inside, and on the surface.
      const Real distance = i % 7 == 0 ? radius * u() : i % 7 == 1 ? radius : radius * (1 + Real(1e4) * u() * u());
      const Vec3 p = c + distance * randomDirection(rng);
      px[i] = p.x, py[i] = p.y, pz[i] = p.z, cx[i] = c.x, cy[i] = c.y, cz[i] = c.z, r[i] = radius;
      u1[i] = i % 11 == 0 ? Real(0) : u(), u2[i] = u(), choice[i] = Real(0.25) + u() / 2;
      guide[i] = i % 2 ? Real(1) : Real(0.1) + 3 * u();
    }
    std::vector<Real> wx(count), wy(count), wz(count), pdf(count);
    sphereLightDirections({px, py, pz, cx, cy, cz, r, u1, u2, choice, guide}, count, {wx, wy, wz, pdf});
    std::size_t wrong = 0;
    for (std::size_t i = 0; i < count; ++i) {
      const Vec3 p(px[i], py[i], pz[i]), c(cx[i], cy[i], cz[i]);
      const Vec3 w = sampleSphereCone(p, c, r[i], Vec2(u1[i], u2[i]));
      const Real expected = choice[i] * sphereConePdf(p, c, r[i]) * guide[i];
      wrong += !sameBits(wx[i], w.x) || !sameBits(wy[i], w.y) || !sameBits(wz[i], w.z) || !sameBits(pdf[i], expected);
    }
    CHECK(wrong == 0);
  });
}

TEST_CASE("stream kernels: triangleLightDirections equals sampleTriangleLight, by solid angle and by area")
{
  forEachTarget([](const SimdTarget&) {
    const std::size_t count = 30001;
    Pcg32 rng(7, 3);
    auto u = [&] { return Real(rng.nextUint()) * Real(0x1p-32); };
    std::vector<Real> px(count), py(count), pz(count), ax(count), ay(count), az(count), bx(count), by(count),
        bz(count), cx(count), cy(count), cz(count), u1(count), u2(count);
    std::size_t bySolidAngle = 0, byArea = 0, none = 0;
    for (std::size_t i = 0; i < count; ++i) {
      // A triangle of size 0.01 to 10 somewhere in a room, seen from near (a large solid angle, some past Arvo's
      // range), from far (a tiny one, sampled by area), from its own plane, from a corner, or degenerate.
      const Vec3 centre(100 * u() - 50, 100 * u() - 50, 100 * u() - 50);
      const Real size = i % 3 == 0 ? Real(0.01) : Real(0.1) + 10 * u();
      const Vec3 p0 = centre + size * randomDirection(rng), p1 = centre + size * randomDirection(rng);
      Vec3 p2 = centre + size * randomDirection(rng);
      if (i % 97 == 0)
        p2 = p0 + Real(0.5) * (p1 - p0); // on the edge p0 p1: no area
      const Real distance = i % 7 == 0 ? Real(1e-3) * size : i % 7 == 1 ? Real(1e3) * size : size * 4 * u();
      Vec3 p = centre + distance * randomDirection(rng);
      if (i % 89 == 0)
        p = p0; // on a corner
      if (i % 83 == 0)
        p = p0 + u() * (p1 - p0) + u() * (p2 - p0) * Real(0.25); // in the triangle's plane
      px[i] = p.x, py[i] = p.y, pz[i] = p.z, ax[i] = p0.x, ay[i] = p0.y, az[i] = p0.z, bx[i] = p1.x, by[i] = p1.y;
      bz[i] = p1.z, cx[i] = p2.x, cy[i] = p2.y, cz[i] = p2.z;
      u1[i] = i % 11 == 0 ? Real(0) : u(), u2[i] = i % 13 == 0 ? Real(0) : u();
    }
    std::vector<Real> wx(count), wy(count), wz(count), pdf(count);
    triangleLightDirections({px, py, pz, ax, ay, az, bx, by, bz, cx, cy, cz, u1, u2}, count, {wx, wy, wz, pdf});
    std::size_t wrong = 0;
    for (std::size_t i = 0; i < count; ++i) {
      const Vec3 p(px[i], py[i], pz[i]), p0(ax[i], ay[i], az[i]), p1(bx[i], by[i], bz[i]), p2(cx[i], cy[i], cz[i]);
      const std::optional<TriangleLightSample<Real>> ts = sampleTriangleLight(p, p0, p1, p2, Vec2(u1[i], u2[i]));
      if (!ts) {
        ++none;
        wrong += !sameBits(pdf[i], 0) || !sameBits(wx[i], 0) || !sameBits(wy[i], 0) || !sameBits(wz[i], 0);
        continue;
      }
      (sampledBySolidAngle(triangleSolidAngle(p, p0, p1, p2)) ? bySolidAngle : byArea) += 1;
      wrong += !sameBits(wx[i], ts->wi.x) || !sameBits(wy[i], ts->wi.y) || !sameBits(wz[i], ts->wi.z) ||
               !sameBits(pdf[i], ts->pdf);
    }
    CHECK(wrong == 0);
    // Every branch taken, the lanes' one most of all.
    CHECK(bySolidAngle > count / 2);
    CHECK(byArea > 1000);
    CHECK(none > 50);
  });
}

TEST_CASE("stream kernels: shadowRaysToSpheres equals offsetRayOrigin and intersectSphere, bit for bit")
{
  forEachTarget([](const SimdTarget&) {
    const std::size_t count = 30002;
    Pcg32 rng(6, 10);
    auto u = [&] { return Real(rng.nextUint()) * Real(0x1p-32); };
    std::vector<Real> px(count), py(count), pz(count), ex(count), ey(count), ez(count), gx(count), gy(count),
        gz(count), wx(count), wy(count), wz(count), cx(count), cy(count), cz(count), r(count);
    for (std::size_t i = 0; i < count; ++i) {
      // A point on a unit sphere far from the origin (so its error bound is not tiny), a direction to either side,
      // and a light sphere ahead, behind or around it.
      const Vec3 n = randomDirection(rng);
      const Vec3 p = Vec3(1e3, -2e2, 5e2) + n;
      const Vec3 e = gamma<Real>(5) * absBranchFree(n) + gamma<Real>(2) * absBranchFree(p);
      Vec3 w = randomDirection(rng);
      if (i % 9 == 0)
        w = glm::normalize(glm::cross(n, randomDirection(rng))); // along the surface: the offset's side at w·n ≈ 0
      const Vec3 c = p + (2 + 20 * u()) * randomDirection(rng);
      px[i] = p.x, py[i] = p.y, pz[i] = p.z, ex[i] = e.x, ey[i] = e.y, ez[i] = e.z;
      gx[i] = n.x, gy[i] = n.y, gz[i] = n.z, wx[i] = w.x, wy[i] = w.y, wz[i] = w.z;
      cx[i] = c.x, cy[i] = c.y, cz[i] = c.z, r[i] = i % 3 == 0 ? Real(30) : Real(0.5) + 3 * u();
      if (i % 13 == 0) // exact zeros: the scalar path of nextAlong
        px[i] = 0, gx[i] = 0;
    }
    std::vector<Real> ox(count), oy(count), oz(count), t(count);
    shadowRaysToSpheres({px, py, pz, ex, ey, ez, gx, gy, gz, wx, wy, wz, cx, cy, cz, r}, count, {ox, oy, oz, t});
    std::size_t wrong = 0, met = 0;
    for (std::size_t i = 0; i < count; ++i) {
      const Vec3 w(wx[i], wy[i], wz[i]);
      const Vec3 o =
          offsetRayOrigin(Vec3(px[i], py[i], pz[i]), Vec3(ex[i], ey[i], ez[i]), Vec3(gx[i], gy[i], gz[i]), w);
      const std::optional<Real> root = intersectSphere(o, w, Vec3(cx[i], cy[i], cz[i]), r[i], Real(0), kInfinity);
      met += root.has_value();
      wrong += !sameBits(ox[i], o.x) || !sameBits(oy[i], o.y) || !sameBits(oz[i], o.z) ||
               !sameBits(t[i], root ? *root : kInfinity);
    }
    INFO(met << " of " << count << " rays meet their sphere");
    CHECK(met > count / 10);
    CHECK(met < count);
    CHECK(wrong == 0);
  });
}

TEST_CASE("stream kernels: shadowRaysToTriangles equals offsetRayOrigin and intersectTriangle, bit for bit")
{
  forEachTarget([](const SimdTarget&) {
    const std::size_t count = 30003;
    Pcg32 rng(8, 11);
    auto u = [&] { return Real(rng.nextUint()) * Real(0x1p-32); };
    std::vector<Real> px(count), py(count), pz(count), ex(count), ey(count), ez(count), gx(count), gy(count),
        gz(count), wx(count), wy(count), wz(count), ax(count), ay(count), az(count), bx(count), by(count), bz(count),
        cx(count), cy(count), cz(count);
    for (std::size_t i = 0; i < count; ++i) {
      // A point on a unit sphere far from the origin, and a triangle near it; the ray aimed at a point of the
      // triangle (most), at one of its corners or edges, or anywhere; some directions along an axis or with two
      // components of one magnitude (the choice of axes' ties), some triangles seen edge on.
      Vec3 n = randomDirection(rng);
      Vec3 p = Vec3(1e3, -2e2, 5e2) + n;
      Vec3 e = gamma<Real>(5) * absBranchFree(n) + gamma<Real>(2) * absBranchFree(p);
      const Vec3 centre = p + (2 + 20 * u()) * randomDirection(rng);
      const Real size = Real(0.1) + 5 * u();
      Vec3 p0 = centre + size * randomDirection(rng), p1 = centre + size * randomDirection(rng);
      Vec3 p2 = centre + size * randomDirection(rng);
      if (i % 17 == 0)
        p2 = p + (p1 - p) * Real(2); // p1 and p2 in line with p: the triangle edge on from some rays
      const Real b1 = u(), b2 = u() * (1 - b1);
      const Vec3 target = i % 11 == 0 ? p0 : i % 11 == 1 ? p0 + u() * (p1 - p0)
                                                          : (1 - b1 - b2) * p0 + b1 * p1 + b2 * p2;
      Vec3 w = i % 7 == 0 ? randomDirection(rng) : glm::normalize(target - p);
      if (i % 23 == 0)
        w = Vec3(0, i % 2 ? 1 : -1, 0);
      if (i % 29 == 0)
        w = glm::normalize(Vec3(1, i % 2 ? 1 : -1, Real(0.5)));
      if (i % 19 < 2) { // (from a point with no error, so that the ray leaves from it exactly)
        throughEdgeOrCorner(i, p0, p1, p2, p, w);
        n = Vec3(0, 0, 1), e = Vec3(0);
      }
      px[i] = p.x, py[i] = p.y, pz[i] = p.z, ex[i] = e.x, ey[i] = e.y, ez[i] = e.z;
      gx[i] = n.x, gy[i] = n.y, gz[i] = n.z, wx[i] = w.x, wy[i] = w.y, wz[i] = w.z;
      ax[i] = p0.x, ay[i] = p0.y, az[i] = p0.z, bx[i] = p1.x, by[i] = p1.y, bz[i] = p1.z;
      cx[i] = p2.x, cy[i] = p2.y, cz[i] = p2.z;
    }
    std::vector<Real> ox(count), oy(count), oz(count), t(count);
    shadowRaysToTriangles({px, py, pz, ex, ey, ez, gx, gy, gz, wx, wy, wz, ax, ay, az, bx, by, bz, cx, cy, cz}, count,
                          {ox, oy, oz, t});
    std::size_t wrong = 0, met = 0;
    for (std::size_t i = 0; i < count; ++i) {
      const Vec3 w(wx[i], wy[i], wz[i]);
      const Vec3 o =
          offsetRayOrigin(Vec3(px[i], py[i], pz[i]), Vec3(ex[i], ey[i], ez[i]), Vec3(gx[i], gy[i], gz[i]), w);
      const std::optional<TriangleHit<Real>> h = intersectTriangle(
          o, w, Vec3(ax[i], ay[i], az[i]), Vec3(bx[i], by[i], bz[i]), Vec3(cx[i], cy[i], cz[i]), Real(0), kInfinity);
      met += h.has_value();
      wrong += !sameBits(ox[i], o.x) || !sameBits(oy[i], o.y) || !sameBits(oz[i], o.z) ||
               !sameBits(t[i], h ? h->t : kInfinity);
    }
    INFO(met << " of " << count << " rays meet their triangle");
    CHECK(met > count / 2);
    CHECK(met < count);
    CHECK(wrong == 0);
  });
}

TEST_CASE("stream kernels: surfaceLightSamples equals Lambert's or Phong's f, its pdf and the MIS weight, bit for bit")
{
  forEachTarget([](const SimdTarget&) {
    for (const bool power : {true, false}) {
      const std::size_t random = 20003, count = random + 150; // (the last ones in the surface: below)
      Pcg32 rng(7, power ? 11 : 12);
      auto u = [&] { return Real(rng.nextUint()) * Real(0x1p-32); };
      std::vector<Real> nx(count), ny(count), nz(count), dx(count), dy(count), dz(count), wx(count), wy(count),
          wz(count), pdf(count), bR(count), bG(count), bB(count), rR(count), rG(count), rB(count), lR(count),
          lG(count), lB(count), exponent(count), roughness(count);
      for (std::size_t i = 0; i < count; ++i) {
        Vec3 n = randomDirection(rng), d = randomDirection(rng);
        Vec3 w = randomDirection(rng);
        // A third Lambertian, the rest glossy: roughness 1 (exponent 0), the smallest, and between (exponents
        // 0 to 2·10⁶); half of the glossy ones' light comes from near the mirror direction, inside the lobe.
        roughness[i] = i % 3 == 0   ? 0
                       : i % 19 == 1 ? 1
                       : i % 19 == 2 ? kMinPhongRoughness
                                     : std::max(kMinPhongRoughness, std::exp(-7 * u()));
        exponent[i] = i % 3 == 0 ? -1 : phongExponent(roughness[i]);
        if (i % 3 != 0 && i % 2 == 0)
          w = glm::normalize(glm::reflect(d, n) + Real(0.3) * u() * randomDirection(rng));
        // The last ones exactly in the surface (a normal along z makes the local z exactly the world one): the
        // light's direction, or the direction the surface is seen from. Neither lights it; the lanes must say so too.
        if (i >= random) {
          n = Vec3(0, 0, 1);
          (i % 2 == 0 ? w : d) = glm::normalize(Vec3(u() - Real(0.5), u() - Real(0.5), 0));
        }
        nx[i] = n.x, ny[i] = n.y, nz[i] = n.z, dx[i] = d.x, dy[i] = d.y, dz[i] = d.z, wx[i] = w.x, wy[i] = w.y;
        wz[i] = w.z;
        // Light pdfs from tiny to huge (a small far lamp), one infinite; albedos with a black channel.
        pdf[i] = i % 101 == 0 ? kInfinity : std::exp(40 * u() - 20);
        bR[i] = u(), bG[i] = 2 * u(), bB[i] = u() / 3, rR[i] = u(), rG[i] = i % 5 == 0 ? 0 : u(), rB[i] = u();
        lR[i] = 12, lG[i] = 12 * u(), lB[i] = 0.5;
      }
      for (const bool glossy : {false, true}) { // all Lambertian (no exponents), then the mix
        std::vector<Real> outR(count), outG(count), outB(count), useful(count);
        surfaceLightSamples({nx, ny, nz, dx, dy, dz, wx, wy, wz, pdf, bR, bG, bB, rR, rG, rB, lR, lG, lB, power,
                             false, glossy ? std::span<const Real>(exponent) : std::span<const Real>()},
                            count, {outR, outG, outB, useful});
        std::size_t wrong = 0, lit = 0, glossyLit = 0;
        for (std::size_t i = 0; i < count; ++i) {
          const Frame frame = Frame::fromNormal(Vec3(nx[i], ny[i], nz[i]));
          const Vec3 wo = frame.toLocal(-Vec3(dx[i], dy[i], dz[i])), wi = frame.toLocal(Vec3(wx[i], wy[i], wz[i]));
          Material m;
          m.color = Color(rR[i], rG[i], rB[i]);
          if (glossy && exponent[i] >= 0)
            m.type = MaterialType::Glossy, m.roughness = roughness[i];
          const Color f = bsdfEval(m, wo, wi);
          const Real q = bsdfPdf(m, wo, wi);
          const Real weight = power ? powerHeuristic(pdf[i], q) : balanceHeuristic(pdf[i], q);
          const Color L = Color(bR[i], bG[i], bB[i]) * f * std::abs(wi.z) * Color(lR[i], lG[i], lB[i]) *
                          (weight / pdf[i]);
          const bool isLit = f != Color(0);
          lit += isLit;
          glossyLit += isLit && m.type == MaterialType::Glossy;
          wrong += (useful[i] != 0) != isLit ||
                   (isLit && (!sameBits(outR[i], L.r) || !sameBits(outG[i], L.g) || !sameBits(outB[i], L.b)));
        }
        INFO((power ? "power" : "balance") << " heuristic, " << (glossy ? "glossy and Lambertian, " : "Lambertian, ")
                                           << lit << " of " << count << " lit, " << glossyLit << " glossy");
        CHECK(lit > random / 4);
        if (glossy)
          CHECK(glossyLit > random / 4);
        else
          CHECK(glossyLit == 0);
        CHECK(wrong == 0);
      }
    }
  });
}

TEST_CASE("stream kernels: glossyBounces equals phongSample in Frame::fromNormal, bit for bit")
{
  forEachTarget([](const SimdTarget&) {
    const std::size_t count = 20011;
    Pcg32 rng(9, 14);
    auto u = [&] { return Real(rng.nextUint()) * Real(0x1p-32); };
    std::vector<Real> nx(count), ny(count), nz(count), dx(count), dy(count), dz(count), u1(count), u2(count),
        exponent(count), roughness(count);
    for (std::size_t i = 0; i < count; ++i) {
      const Vec3 n = randomDirection(rng);
      // Some arrive in the surface (wo.z = 0: no sample); some numbers at 0 (the lobe's axis, the azimuth 0).
      const Vec3 d = i % 97 == 0 ? Frame::fromNormal(n).s : randomDirection(rng);
      roughness[i] = i % 23 == 0   ? 1
                     : i % 23 == 1 ? kMinPhongRoughness
                                   : std::max(kMinPhongRoughness, std::exp(-7 * u()));
      exponent[i] = phongExponent(roughness[i]);
      nx[i] = n.x, ny[i] = n.y, nz[i] = n.z, dx[i] = d.x, dy[i] = d.y, dz[i] = d.z;
      u1[i] = i % 31 == 0 ? 0 : u(), u2[i] = i % 37 == 0 ? 0 : u();
    }
    std::vector<Real> wx(count), wy(count), wz(count), cosTheta(count), pdf(count), fScale(count);
    glossyBounces({{nx, ny, nz, dx, dy, dz, u1, u2}, exponent}, count, {{wx, wy, wz, cosTheta, pdf}, fScale});
    std::size_t wrong = 0, sampled = 0;
    for (std::size_t i = 0; i < count; ++i) {
      const Frame frame = Frame::fromNormal(Vec3(nx[i], ny[i], nz[i]));
      const Vec3 wo = frame.toLocal(-Vec3(dx[i], dy[i], dz[i]));
      Material m;
      m.type = MaterialType::Glossy, m.roughness = roughness[i], m.color = Color(Real(0.9), Real(0.5), 0);
      const std::optional<BsdfSample> bs = bsdfSample(m, wo, Vec2(u1[i], u2[i]), u());
      sampled += bs.has_value();
      if (bs.has_value() != (pdf[i] > 0)) {
        ++wrong;
        continue;
      }
      if (!bs)
        continue;
      const Vec3 w = frame.toWorld(bs->wi);
      const Color f = m.color * fScale[i];
      wrong += bs->specular || !sameBits(pdf[i], bs->pdf) || !sameBits(cosTheta[i], bs->wi.z) ||
               !sameBits(wx[i], w.x) || !sameBits(wy[i], w.y) || !sameBits(wz[i], w.z) || !sameBits(f.r, bs->f.r) ||
               !sameBits(f.g, bs->f.g) || !sameBits(f.b, bs->f.b);
    }
    INFO(sampled << " of " << count << " bounces sampled");
    CHECK(sampled > count / 2);
    CHECK(sampled < count);
    CHECK(wrong == 0);
  });
}

TEST_CASE("stream kernels: specularBounces equals mirrorSample and dielectricSample in Frame::fromNormal, bit for bit")
{
  forEachTarget([](const SimdTarget&) {
    const std::size_t count = 20021;
    Pcg32 rng(10, 15);
    auto u = [&] { return Real(rng.nextUint()) * Real(0x1p-32); };
    std::vector<Real> nx(count), ny(count), nz(count), dx(count), dy(count), dz(count), uChoice(count), eta(count);
    for (std::size_t i = 0; i < count; ++i) {
      // Some arrive in the surface (wo.z = 0: no sample); half from inside the glass (wo.z < 0), where grazing rays
      // are reflected whole; mirrors (η 0), glass of index 1 (no bend), and choices at 0. Some normals along z, as on
      // a box's walls, with directions in the yz plane (wo.x is then ±0).
      const Vec3 r = randomDirection(rng);
      const bool plane = i % 13 == 0;
      const Vec3 n = plane ? Vec3(0, 0, i % 2 == 0 ? 1 : -1) : randomDirection(rng);
      const Vec3 d = i % 97 == 0 ? Frame::fromNormal(n).s : plane ? glm::normalize(Vec3(0, r.y, r.z)) : r;
      eta[i] = i % 5 == 0 ? 0 : i % 11 == 0 ? 1 : i % 3 == 0 ? Real(2.4) : Real(1.5);
      nx[i] = n.x, ny[i] = n.y, nz[i] = n.z, dx[i] = d.x, dy[i] = d.y, dz[i] = d.z;
      uChoice[i] = i % 31 == 0 ? 0 : u();
    }
    std::vector<Real> wx(count), wy(count), wz(count), cosTheta(count), pdf(count);
    specularBounces({nx, ny, nz, dx, dy, dz, uChoice, eta}, count, {wx, wy, wz, cosTheta, pdf});
    std::size_t wrong = 0, sampled = 0, reflected = 0, refracted = 0, whole = 0;
    for (std::size_t i = 0; i < count; ++i) {
      const Frame frame = Frame::fromNormal(Vec3(nx[i], ny[i], nz[i]));
      const Vec3 wo = frame.toLocal(-Vec3(dx[i], dy[i], dz[i]));
      Material m;
      m.type = eta[i] == 0 ? MaterialType::Mirror : MaterialType::Glass;
      m.ior = eta[i] == 0 ? Real(1.5) : eta[i], m.color = Color(Real(0.9), Real(0.5), Real(0.25));
      const std::optional<BsdfSample> bs = bsdfSample(m, wo, Vec2(u(), u()), uChoice[i]);
      sampled += bs.has_value();
      if (bs.has_value() != (pdf[i] > 0)) {
        ++wrong;
        continue;
      }
      if (!bs)
        continue;
      reflected += bs->wi.z * wo.z > 0, refracted += bs->wi.z * wo.z < 0, whole += eta[i] > 0 && bs->pdf == 1;
      const Vec3 w = frame.toWorld(bs->wi);
      const Color f = m.color * pdf[i] / std::abs(cosTheta[i]);
      wrong += !bs->specular || !sameBits(pdf[i], bs->pdf) || !sameBits(cosTheta[i], bs->wi.z) ||
               !sameBits(wx[i], w.x) || !sameBits(wy[i], w.y) || !sameBits(wz[i], w.z) || !sameBits(f.r, bs->f.r) ||
               !sameBits(f.g, bs->f.g) || !sameBits(f.b, bs->f.b);
    }
    INFO(sampled << " of " << count << " bounces sampled: " << reflected << " reflected, " << refracted
                 << " refracted, " << whole << " wholly reflected by glass");
    CHECK(sampled < count);
    CHECK(reflected > count / 4);
    CHECK(refracted > count / 4);
    CHECK(whole > count / 100);
    CHECK(wrong == 0);
  });
}

TEST_CASE("stream kernels: pointLightRays equals arrivalAt and spawnRayTo, and point lights weigh 1, bit for bit")
{
  forEachTarget([](const SimdTarget&) {
    const std::size_t count = 20005;
    Pcg32 rng(8, 13);
    auto u = [&] { return Real(rng.nextUint()) * Real(0x1p-32); };
    std::vector<Real> px(count), py(count), pz(count), ex(count), ey(count), ez(count), gx(count), gy(count),
        gz(count), lx(count), ly(count), lz(count), iR(count), iG(count), iB(count);
    for (std::size_t i = 0; i < count; ++i) {
      // A point on a unit sphere far from the origin, its light near or far to any side, some exactly at the point
      // (no light arrives), some at a coordinate of 0 (the scalar path of nextAlong).
      const Vec3 n = randomDirection(rng);
      const Vec3 p = Vec3(-3e2, 7e1, 2e3) + n;
      const Vec3 e = gamma<Real>(5) * absBranchFree(n) + gamma<Real>(2) * absBranchFree(p);
      const Vec3 l = i % 17 == 0 ? p : p + std::exp(12 * u() - 6) * randomDirection(rng);
      px[i] = p.x, py[i] = p.y, pz[i] = p.z, ex[i] = e.x, ey[i] = e.y, ez[i] = e.z;
      gx[i] = n.x, gy[i] = n.y, gz[i] = n.z, lx[i] = l.x, ly[i] = l.y, lz[i] = l.z;
      iR[i] = 100 * u(), iG[i] = i % 7 == 0 ? 0 : 50, iB[i] = u();
      if (i % 13 == 0)
        px[i] = 0, gx[i] = 0;
    }
    std::vector<Real> wx(count), wy(count), wz(count), liR(count), liG(count), liB(count), ox(count), oy(count),
        oz(count), t(count), arrives(count);
    pointLightRays({px, py, pz, ex, ey, ez, gx, gy, gz, lx, ly, lz, iR, iG, iB}, count,
                   {wx, wy, wz, liR, liG, liB, ox, oy, oz, t, arrives});
    std::size_t wrong = 0, arrived = 0;
    for (std::size_t i = 0; i < count; ++i) {
      const PointLight light{Vec3(lx[i], ly[i], lz[i]), Color(iR[i], iG[i], iB[i])};
      Hit hit;
      hit.point = Vec3(px[i], py[i], pz[i]), hit.pointError = Vec3(ex[i], ey[i], ez[i]);
      hit.geometricNormal = hit.normal = Vec3(gx[i], gy[i], gz[i]);
      const std::optional<LightArrival> in = light.arrivalAt(hit.point);
      arrived += in.has_value();
      if ((arrives[i] != 0) != in.has_value()) {
        ++wrong;
        continue;
      }
      if (!in)
        continue;
      const Ray ray = spawnRayTo(hit, light.position);
      wrong += !sameBits(wx[i], in->direction.x) || !sameBits(wy[i], in->direction.y) ||
               !sameBits(wz[i], in->direction.z) || !sameBits(liR[i], in->intensity.r) ||
               !sameBits(liG[i], in->intensity.g) || !sameBits(liB[i], in->intensity.b) ||
               !sameBits(ox[i], ray.origin.x) || !sameBits(oy[i], ray.origin.y) || !sameBits(oz[i], ray.origin.z) ||
               !sameBits(t[i], ray.tmax) || !sameBits(wx[i], ray.direction.x) ||
               !sameBits(wy[i], ray.direction.y) || !sameBits(wz[i], ray.direction.z);
    }
    INFO(arrived << " of " << count << " points see their light");
    CHECK(arrived < count);
    CHECK(arrived > count / 2);
    CHECK(wrong == 0);

    // What such a sample brings at a Lambertian surface: the weight is 1 and the pdf the light's choice.
    std::vector<Real> nx(count), ny(count), nz(count), dx(count), dy(count), dz(count), choice(count), bR(count),
        bG(count), bB(count), rR(count), rG(count), rB(count);
    for (std::size_t i = 0; i < count; ++i) {
      const Vec3 nn = randomDirection(rng), d = randomDirection(rng);
      nx[i] = nn.x, ny[i] = nn.y, nz[i] = nn.z, dx[i] = d.x, dy[i] = d.y, dz[i] = d.z;
      choice[i] = Real(0.05) + u(), bR[i] = u(), bG[i] = 2 * u(), bB[i] = u(), rR[i] = u(), rG[i] = u(), rB[i] = 0;
    }
    std::vector<Real> outR(count), outG(count), outB(count), useful(count);
    surfaceLightSamples({nx, ny, nz, dx, dy, dz, wx, wy, wz, choice, bR, bG, bB, rR, rG, rB, liR, liG, liB, true,
                         true},
                        count, {outR, outG, outB, useful});
    std::size_t lit = 0;
    wrong = 0;
    for (std::size_t i = 0; i < count; ++i) {
      if (arrives[i] == 0)
        continue;
      const Frame frame = Frame::fromNormal(Vec3(nx[i], ny[i], nz[i]));
      const Vec3 wo = frame.toLocal(-Vec3(dx[i], dy[i], dz[i])), wi = frame.toLocal(Vec3(wx[i], wy[i], wz[i]));
      Material m;
      m.color = Color(rR[i], rG[i], rB[i]);
      const Color f = bsdfEval(m, wo, wi);
      const Color L = Color(bR[i], bG[i], bB[i]) * f * std::abs(wi.z) * Color(liR[i], liG[i], liB[i]) *
                      (Real(1) / choice[i]);
      const bool isLit = f != Color(0);
      lit += isLit;
      wrong += (useful[i] != 0) != isLit ||
               (isLit && (!sameBits(outR[i], L.r) || !sameBits(outG[i], L.g) || !sameBits(outB[i], L.b)));
    }
    INFO(lit << " lit");
    CHECK(lit > count / 4);
    CHECK(wrong == 0);
  });
}

namespace {

// Points crowded into a few small regions of the square (as a lamp's visible part crowds a cone's samples), so the
// trees are deep in places and shallow elsewhere.
std::vector<Vec2> crowdedPoints(int count, std::uint64_t seed)
{
  Pcg32 rng(seed, 3);
  auto u = [&] { return Real(rng.nextUint()) * Real(0x1p-32); };
  std::vector<Vec2> points;
  const Vec2 blob(u(), u());
  for (int i = 0; i < count; ++i) {
    const Real pick = u();
    if (pick < Real(0.5))
      points.emplace_back(Real(0.02) * u(), u()); // a thin strip
    else if (pick < Real(0.8))
      points.emplace_back(std::min(blob.x + Real(0.04) * u(), Real(0.99)), std::min(blob.y + Real(0.06) * u(), Real(0.99)));
    else
      points.emplace_back(u(), u());
  }
  return points;
}

} // namespace

TEST_CASE("stream kernels: guidedWarps equals SampleTree::sampleMixture, point and density, bit for bit")
{
  // A forest of trees of many shapes (and one uniform density, which has no root), as the light guide's cells hold.
  std::vector<SampleTree> trees;
  for (int k = 0; k < 12; ++k)
    trees.push_back(SampleTree::fromPoints(crowdedPoints(200 + 400 * k, std::uint64_t(k)), 2 + k, 0.02 + 0.01 * k, 8));
  trees.push_back(SampleTree());
  SampleForest forest;
  std::vector<SampleForestIndex> roots;
  for (const SampleTree& tree : trees)
    roots.push_back(tree.appendTo(forest));
  REQUIRE(roots.back() == -1);
  REQUIRE(std::count(roots.begin(), roots.end(), -1) == 1); // every other tree learned something
  forEachTarget([&](const SimdTarget&) {
    const std::size_t count = 20011;
    Pcg32 rng(12, 1);
    auto u = [&] { return Real(rng.nextUint()) * Real(0x1p-32); };
    const Real alphas[] = {Real(0.15), Real(0.3), Real(0.5), Real(0.7), Real(1)};
    std::vector<std::size_t> which(count);
    std::vector<SampleForestIndex> root(count);
    std::vector<Real> alpha(count), u1(count), u2(count);
    for (std::size_t i = 0; i < count; ++i) {
      which[i] = rng.nextUint() % trees.size();
      root[i] = roots[which[i]];
      alpha[i] = alphas[rng.nextUint() % 5];
      // The edges too: 0, just below 1, and u.x exactly at α (the first number of the tree's component).
      u1[i] = i % 13 == 0 ? Real(0) : i % 13 == 1 ? std::nextafter(Real(1), Real(0)) : i % 13 == 2 ? alpha[i] : u();
      u2[i] = i % 17 == 0 ? Real(0) : i % 17 == 1 ? std::nextafter(Real(1), Real(0)) : u();
    }
    std::vector<Real> w1(count), w2(count), pdf(count);
    guidedWarps(forest, {root, alpha, u1, u2}, count, {w1, w2, pdf});
    std::size_t wrong = 0, throughTree = 0;
    for (std::size_t i = 0; i < count; ++i) {
      const MixtureSample expected =
          root[i] < 0 ? MixtureSample{Vec2(u1[i], u2[i]), 1} : trees[which[i]].sampleMixture(Vec2(u1[i], u2[i]), alpha[i]);
      throughTree += root[i] >= 0 && !(u1[i] < alpha[i]);
      wrong += !sameBits(w1[i], expected.p.x) || !sameBits(w2[i], expected.p.y) || !sameBits(pdf[i], expected.pdf);
    }
    CHECK(wrong == 0);
    CHECK(throughTree > count / 3); // (the tree's component was taken often, not only the uniform one)
  });
}

TEST_CASE("stream kernels: guideCells equals LightSampler::cellOf, bit for bit, in the grid and outside it")
{
  const Scene smallpt = loadScene(std::string(RAYLIFE_SCENES) + "/smallpt.json");
  const LightSampler lights(smallpt, LightGuiding{.paths = 256, .threads = 1});
  const LightSampler::GuideGrid g = lights.guideGrid();
  REQUIRE(!g.learned.empty());
  std::vector<SampleForestIndex> table;
  for (std::size_t k = 0; k < g.learned.size(); ++k)
    table.push_back(g.learned[k] ? SampleForestIndex(k) : -1);
  REQUIRE(std::count(table.begin(), table.end(), -1) < std::ptrdiff_t(table.size())); // some cells learned
  const GuideCellGrid grid{g.min, g.scale, g.size, table};
  forEachTarget([&](const SimdTarget&) {
    const std::size_t count = 10007;
    Pcg32 rng(4, 4);
    auto u = [&] { return Real(rng.nextUint()) * Real(0x1p-32); };
    std::vector<Real> px(count), py(count), pz(count);
    for (std::size_t i = 0; i < count; ++i) {
      // The room and well beyond it on every side; a few points at infinity or NaN.
      Vec3 p(-50 + 200 * u(), -50 + 180 * u(), -50 + 270 * u());
      if (i % 101 == 0)
        p[int(i % 3)] = i % 2 ? kInfinity : -kInfinity;
      if (i % 103 == 0)
        p[int(i % 3)] = std::numeric_limits<Real>::quiet_NaN();
      px[i] = p.x, py[i] = p.y, pz[i] = p.z;
    }
    std::vector<SampleForestIndex> cell(count);
    guideCells(grid, px, py, pz, count, cell);
    std::size_t wrong = 0, learned = 0;
    for (std::size_t i = 0; i < count; ++i) {
      const int expected = lights.cellOf(Vec3(px[i], py[i], pz[i]));
      wrong += cell[i] != expected;
      learned += expected >= 0;
    }
    CHECK(wrong == 0);
    CHECK(learned > count / 40); // (points in learned cells, not only −1: about one in twenty here)
    // Without a guide every point's cell is −1.
    guideCells(GuideCellGrid{}, px, py, pz, count, cell);
    CHECK(std::count(cell.begin(), cell.end(), -1) == std::ptrdiff_t(count));
  });
}

TEST_CASE("stream kernels: pixelSamplers starts every Sampler(seed, x, y, sample)'s numbers, bit for bit")
{
  forEachTarget([](const SimdTarget&) {
    // Pixels and sample indices of every size (the largest an int holds among them), seeds of every size, and
    // counts that leave a short last group.
    Pcg32 rng(12, 3);
    for (const std::size_t count : {std::size_t(1), std::size_t(7), std::size_t(1000), std::size_t(4099)}) {
      const std::uint64_t seed = std::uint64_t(rng.nextUint()) << 32 | rng.nextUint();
      std::vector<std::int32_t> x(count), y(count), sample(count);
      for (std::size_t i = 0; i < count; ++i) {
        auto any = [&](std::uint32_t most) { return std::int32_t(rng.nextUint() % most); };
        x[i] = i % 11 == 0 ? std::numeric_limits<std::int32_t>::max() : any(i % 2 == 0 ? 4096 : 1u << 31);
        y[i] = i % 13 == 0 ? 0 : any(i % 3 == 0 ? 4096 : 1u << 31);
        sample[i] = i % 17 == 0 ? std::numeric_limits<std::int32_t>::max() : any(i % 5 == 0 ? 64 : 1u << 31);
      }
      std::vector<std::uint64_t> state(count), increment(count);
      pixelSamplers(seed, {x, y, sample}, count, {state, increment});
      std::size_t wrong = 0;
      for (std::size_t i = 0; i < count; ++i) {
        Sampler expected(seed, x[i], y[i], std::uint64_t(sample[i]));
        Sampler made(Pcg32::fromState(state[i], increment[i]));
        wrong += state[i] != expected.generator().state() || increment[i] != expected.generator().increment();
        for (int k = 0; k < 4; ++k) // (and the two draw the same numbers)
          wrong += !sameBits(made.next1D(), expected.next1D());
      }
      INFO(count << " samples");
      CHECK(wrong == 0);
    }
  });
}

TEST_CASE("stream kernels: pinholeSample and pinholeDirections make PrimaryRays::make's camera rays, bit for bit")
{
  // Cameras of several shapes and orientations; samples at the centre, jittered in strata (a square count, and one
  // whose last samples fall outside the grid), on the pixel's sequence (adaptive), with and without times.
  struct Setup {
    Vec3 eye, focal, up;
    Real vfov;
    int width, height;
  };
  const Setup cameras[] = {{Vec3(278, 273, -800), Vec3(278, 273, 0), Vec3(0, 1, 0), 39, 160, 120},
                           {Vec3(13, 2, 3), Vec3(0, 0, 0), Vec3(0, 1, 0), 20, 37, 91},
                           {Vec3(-1e3, 5e2, 3e-3), Vec3(2, -7, 1e3), Vec3(0.3, 0.2, 1), Real(151.5), 1, 1}};
  struct Sampling {
    PixelSampling mode;
    std::optional<int> spp;
    std::optional<double> adaptive;
    bool motion;
  };
  const Sampling samplings[] = {{PixelSampling::Centre, 4, std::nullopt, false},
                                {PixelSampling::Jittered, 16, std::nullopt, false},
                                {PixelSampling::Jittered, 7, std::nullopt, true},
                                {PixelSampling::Jittered, 1, std::nullopt, false},
                                {PixelSampling::Jittered, std::nullopt, 0.05, true}};
  forEachTarget([&](const SimdTarget&) {
    for (const Setup& c : cameras)
      for (const Sampling& sampling : samplings) {
        const auto basis = makeCameraBasis(c.eye, c.focal, c.up);
        REQUIRE(std::holds_alternative<CameraBasis>(basis));
        const Camera camera(std::get<CameraBasis>(basis), c.eye, c.vfov, c.width, c.height);
        RenderSettings settings;
        settings.spp = sampling.spp;
        settings.seed = 11;
        settings.pixelSampling = sampling.mode;
        settings.adaptive = sampling.adaptive;
        settings.motion = sampling.motion;
        const PrimaryRays primary(camera, settings);
        REQUIRE(primary.pinhole());
        const std::size_t count = 1003;
        Pcg32 rng(5, 21);
        std::vector<PixelSampleKey> keys(count);
        std::vector<Real> x(count), y(count), offsetX(count), offsetY(count), strata(count), dx(count), dy(count),
            dz(count);
        std::vector<PinholeSample> samples;
        std::vector<Sampler> samplers;
        for (std::size_t i = 0; i < count; ++i) {
          keys[i] = {int(rng.nextUint() % std::uint32_t(c.width)), int(rng.nextUint() % std::uint32_t(c.height)),
                     int(rng.nextUint() % 40)};
          samplers.emplace_back(primary.seed(), keys[i].x, keys[i].y, std::uint64_t(keys[i].sample));
          samples.push_back(primary.pinholeSample(keys[i], samplers.back()));
          x[i] = Real(keys[i].x), y[i] = Real(keys[i].y);
          offsetX[i] = samples[i].offset.numerator.x, offsetY[i] = samples[i].offset.numerator.y;
          strata[i] = samples[i].offset.strata;
        }
        pinholeDirections(camera, {x, y, offsetX, offsetY, strata}, count, {dx, dy, dz});
        std::size_t wrong = 0, stratified = 0;
        for (std::size_t i = 0; i < count; ++i) {
          PrimarySample expected = primary.make(keys[i]);
          stratified += strata[i] > 1;
          const Ray& r = expected.ray;
          wrong += !sameBits(dx[i], r.direction.x) || !sameBits(dy[i], r.direction.y) ||
                   !sameBits(dz[i], r.direction.z) || r.origin != c.eye || r.tmax != kInfinity ||
                   !sameBits(samples[i].time, r.time);
          // The two samplers go on with the same numbers.
          for (int k = 0; k < 3; ++k)
            wrong += !sameBits(samplers[i].next1D(), expected.sampler.next1D());
        }
        INFO("camera " << c.width << "x" << c.height << ", " << stratified << " samples in strata");
        CHECK(wrong == 0);
        CHECK((stratified > 0) == (sampling.mode == PixelSampling::Jittered && sampling.spp && *sampling.spp > 1));
      }
  });
}

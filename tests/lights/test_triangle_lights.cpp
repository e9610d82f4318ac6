// Triangle lights (common/scene/light_sampling.h): the spherical-triangle sampler against its pdf (chi-square), the
// solid angle against a closed form, every sampled direction hitting the triangle, area sampling's failure up close
// (its variance against the spherical sampler's), the choice of triangle lights by power, the pdf MIS asks for
// matching the sampler's, and the light visibility of a triangle sample.
#include "../statistics/chi_square.h"
#include "polygon_irradiance.h"

#include "core/frame.h"
#include "core/sampling.h"
#include "scene/light_sampling.h"
#include "scene/scene.h"

#include <catch2/catch.hpp>

#include <array>
#include <cmath>
#include <string>

using namespace raylife;
using namespace raylife::test;

namespace {

constexpr double kSignificance = 0.01;
constexpr int kSamples = 200000;
constexpr double kTolerance = sizeof(Real) == 4 ? 1e-4 : 1e-9;
// Closed forms computed in Real: a few of its last bits (the float build's are 6e-8 apart, double's 1e-16).
constexpr double kTight = sizeof(Real) == 4 ? 2e-5 : 1e-12;
constexpr double kClose = sizeof(Real) == 4 ? 1e-4 : 1e-9;
constexpr double kLoose = sizeof(Real) == 4 ? 1e-3 : 1e-6; // the same density by two routes

// True when the ray from `ref` along `w` meets the triangle (ahead, anywhere).
bool hitsTriangle(const Vec3& ref, const Vec3& w, const Vec3& p0, const Vec3& p1, const Vec3& p2)
{
  return intersectTriangle(ref, w, p0, p1, p2, Real(0), kInfinity).has_value();
}

struct Case {
  const char* what;
  Vec3 ref, p0, p1, p2;
};

// Triangles seen from near, at an angle, very large up close, and from behind; each within the solid-angle sampler's
// range (checked below), and wide enough for the chi-square grid (whose cells' integrals of a pdf that jumps at
// the triangle's edges are only approximate: a sliver or a far triangle is checked by its moments instead).
std::vector<Case> cases()
{
  return {
      {"ahead, moderate", Vec3(0), Vec3(-1, -1, 2), Vec3(1, -1, 2), Vec3(0, 1, 2)},
      {"close and wide", Vec3(0), Vec3(-1, -1, Real(0.6)), Vec3(1, -1, Real(0.6)), Vec3(0, 1, Real(0.6))},
      {"large, up close", Vec3(0, 0, Real(-0.8)), Vec3(-10, -10, 0), Vec3(10, -10, 0), Vec3(0, 10, 0)},
      {"behind the point (its back face)", Vec3(0), Vec3(-1, -1, -1), Vec3(0, 1, -1), Vec3(1, -1, -1)},
  };
}

} // namespace

TEST_CASE("the solid angle of a triangle is Van Oosterom and Strackee's, and sums to 4π over a closed polyhedron")
{
  // An octant of the sphere of directions: the triangle (1,0,0), (0,1,0), (0,0,1) seen from the origin is 4π/8.
  CHECK(triangleSolidAngle(Vec3(0), Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(0, 0, 1)) == Approx(kPi / 2).epsilon(kTight));
  // The faces of a tetrahedron around a point inside it cover every direction once: 4π.
  const Vec3 a(1, 1, 1), b(1, -1, -1), c(-1, 1, -1), d(-1, -1, 1);
  const Vec3 inside(Real(0.1), Real(-0.2), Real(0.15));
  const Real total = triangleSolidAngle(inside, a, b, c) + triangleSolidAngle(inside, a, b, d) +
                     triangleSolidAngle(inside, a, c, d) + triangleSolidAngle(inside, b, c, d);
  CHECK(total == Approx(4 * kPi).epsilon(kTight));
  // A point in the triangle's plane sees none of it (outside) or a half-sphere (inside the triangle).
  CHECK(triangleSolidAngle(Vec3(5, 0, 0), Vec3(0), Vec3(1, 0, 0), Vec3(0, 1, 0)) == Approx(0).margin(kTight));
  CHECK(triangleSolidAngle(Vec3(Real(0.2), Real(0.2), 0), Vec3(0), Vec3(1, 0, 0), Vec3(0, 1, 0)) ==
        Approx(2 * kPi).epsilon(kClose));
}

TEST_CASE("chi-square: directions towards a triangle light are uniform in its solid angle")
{
  for (const Case& k : cases()) {
    const Real omega = triangleSolidAngle(k.ref, k.p0, k.p1, k.p2);
    REQUIRE(sampledBySolidAngle(omega));
    auto r = chiSquareTest(
        [&](Vec2 u, Real) -> std::optional<Vec3> {
          const auto s = sampleSphericalTriangle(k.ref, k.p0, k.p1, k.p2, u);
          return s ? std::optional<Vec3>(s->wi) : std::nullopt;
        },
        [&](const Vec3& w) { return hitsTriangle(k.ref, w, k.p0, k.p1, k.p2) ? 1 / double(omega) : 0.0; }, kSamples,
        13, kSignificance, 40, 80, 8);
    INFO(k.what << " (" << omega << " sr): " << r.summary());
    CHECK(r.passed);
  }
}

TEST_CASE("slivers and small, far triangles: the sampler's moments match the integrals area sampling estimates")
{
  // For any f, E[f(ω)]·Ω over the spherical sampler's directions and E[f(ω)/pdf] over area sampling's both estimate
  // ∫ f dω over the triangle's solid angle: two independent estimators of the same number, no grid involved.
  const std::vector<Case> thin = {
      {"a sliver", Vec3(0), Vec3(-1, 0, 1), Vec3(1, Real(0.05), 1), Vec3(1, Real(-0.05), Real(1.02))},
      {"slanted and far", Vec3(0), Vec3(3, 0, 5), Vec3(4, 1, 7), Vec3(2, 2, 6)},
      {"a needle seen end on", Vec3(0), Vec3(0, 0, 1), Vec3(Real(0.2), 0, 3), Vec3(0, Real(0.2), 3)},
  };
  for (const Case& k : thin) {
    const Real omega = triangleSolidAngle(k.ref, k.p0, k.p1, k.p2);
    REQUIRE(sampledBySolidAngle(omega));
    const Vec3 axis = glm::normalize(k.p0 + k.p1 + k.p2 - Real(3) * k.ref);
    const Frame frame = Frame::fromNormal(axis);
    // f: the direction's coordinates across the triangle's axis, and the square of one (a second moment).
    auto moments = [&](const Vec3& w) {
      const Vec3 l = frame.toLocal(w);
      return std::array<double, 3>{double(l.x), double(l.y), double(l.x * l.x)};
    };
    constexpr int kCount = 400000;
    std::array<double, 3> sum{}, sum2{}, areaSum{}, areaSum2{};
    Sampler rng(31, 0, 0, 0);
    for (int i = 0; i < kCount; ++i) {
      const auto s = sampleSphericalTriangle(k.ref, k.p0, k.p1, k.p2, rng.next2D());
      const auto a = sampleTriangleArea(k.ref, k.p0, k.p1, k.p2, rng.next2D());
      REQUIRE(s);
      REQUIRE(a);
      const auto fs = moments(s->wi), fa = moments(a->wi);
      for (std::size_t m = 0; m < 3; ++m) {
        const double x = fs[m] * double(omega), y = fa[m] / double(a->pdf);
        sum[m] += x;
        sum2[m] += x * x;
        areaSum[m] += y;
        areaSum2[m] += y * y;
      }
    }
    for (std::size_t m = 0; m < 3; ++m) {
      const double a = sum[m] / kCount, b = areaSum[m] / kCount;
      const double va = (sum2[m] / kCount - a * a) / kCount, vb = (areaSum2[m] / kCount - b * b) / kCount;
      const double z = (a - b) / std::sqrt(va + vb);
      INFO(k.what << ", moment " << m << ": spherical " << a << ", area " << b << ", z = " << z);
      CHECK(std::abs(z) < 4);
    }
  }
}

TEST_CASE("chi-square: area sampling's density is d²/(|cosθ|·A) (the test of the naive form), and a wrong one fails")
{
  const Case k{"close and wide", Vec3(0), Vec3(-1, -1, Real(0.6)), Vec3(1, -1, Real(0.6)), Vec3(0, 1, Real(0.6))};
  auto areaPdf = [&](const Vec3& w) {
    const auto h = intersectTriangle(k.ref, w, k.p0, k.p1, k.p2, Real(0), kInfinity);
    if (!h)
      return 0.0;
    const Vec3 point = k.ref + h->t * w;
    const Real cosLight = std::abs(glm::dot(w, triangleNormal(k.p0, k.p1, k.p2)));
    return double(h->t * h->t / (cosLight * triangleDoubleArea(k.p0, k.p1, k.p2) / 2)) + 0 * point.x;
  };
  auto area = [&](Vec2 u, Real) -> std::optional<Vec3> {
    const auto s = sampleTriangleArea(k.ref, k.p0, k.p1, k.p2, u);
    return s ? std::optional<Vec3>(s->wi) : std::nullopt;
  };
  const ChiSquareResult right = chiSquareTest(area, areaPdf, kSamples, 14, kSignificance, 40, 80, 4);
  INFO(right.summary());
  CHECK(right.passed);
  // The control: area samples judged against the solid-angle pdf 1/Ω, which they do not follow.
  const Real omega = triangleSolidAngle(k.ref, k.p0, k.p1, k.p2);
  const ChiSquareResult wrong = chiSquareTest(
      area, [&](const Vec3& w) { return hitsTriangle(k.ref, w, k.p0, k.p1, k.p2) ? 1 / double(omega) : 0.0; },
      kSamples, 14, kSignificance, 40, 80, 4);
  INFO(wrong.summary());
  CHECK_FALSE(wrong.passed);
}

TEST_CASE("every sampled direction towards a triangle light hits it, and its pdf is the one triangleLightPdf gives")
{
  Sampler rng(5, 0, 0, 0);
  int misses = 0, total = 0, bySolidAngle = 0, byArea = 0;
  for (int config = 0; config < 3000; ++config) {
    const Real scale = std::pow(Real(10), Real(rng.next1D() * 6 - 3));
    // (Drawn one statement at a time: the order of a call's arguments is the compiler's choice, and clang and GCC
    // choose differently.)
    const Real x = rng.next1D(), y = rng.next1D(), z = rng.next1D();
    const Vec3 p0 = (Vec3(x, y, z) - Real(0.5)) * scale;
    const Vec3 p1 = p0 + sampleUniformSphere(rng.next2D()) * scale, p2 = p0 + sampleUniformSphere(rng.next2D()) * scale;
    // (The distance is drawn before the direction, the order in which GCC drew them as arguments of one call.)
    const Real distance = std::pow(Real(10), Real(rng.next1D() * 4 - 2));
    const Vec3 ref = p0 + sampleUniformSphere(rng.next2D()) * scale * distance;
    const bool spherical = sampledBySolidAngle(triangleSolidAngle(ref, p0, p1, p2));
    (spherical ? bySolidAngle : byArea)++;
    for (int s = 0; s < 50; ++s) {
      const auto ts = sampleTriangleLight(ref, p0, p1, p2, rng.next2D());
      if (!ts)
        continue;
      ++total;
      const auto h = intersectTriangle(ref, ts->wi, p0, p1, p2, Real(0), kInfinity);
      misses += !h;
      if (h) {
        const Real pdf = triangleLightPdf(ref, p0, p1, p2, ref + h->t * ts->wi);
        REQUIRE(pdf == Approx(ts->pdf).epsilon(spherical ? kTolerance : kLoose));
      }
    }
  }
  INFO(misses << " of " << total << " directions missed (" << bySolidAngle << " triangles by solid angle, " << byArea
              << " by area)");
  // At the very edges, by rounding: a direction is a few ulps from where it was aimed, so in float (ulps of 6e-8)
  // far more land just outside a small or distant triangle than in double (126 of 150,000 here against none).
  CHECK(misses <= total / (sizeof(Real) == 4 ? 500 : 10000));
  // Both samplers, many times each (about 2,500 and 500 of the 3,000 triangles).
  CHECK(bySolidAngle > 400);
  CHECK(byArea > 400);
}

TEST_CASE("area sampling fails up close to a large triangle light: its variance dwarfs the spherical sampler's")
{
  // Irradiance at a point 0.8 below the middle of a 20-wide triangle emitting Le = 1, facing it: E = ∫ cosθ dω, in
  // closed form by Lambert's formula. Both estimators are unbiased; area sampling puts most points far away, where
  // they matter little, and the few close ones carry huge weights.
  const Case k{"large, up close", Vec3(0, 0, Real(-0.8)), Vec3(-10, -10, 0), Vec3(10, -10, 0), Vec3(0, 10, 0)};
  const Vec3 n(0, 0, 1);
  const double exact = polygonIrradiance(glm::dvec3(k.ref), glm::dvec3(n),
                                         {glm::dvec3(k.p0), glm::dvec3(k.p1), glm::dvec3(k.p2)}, 1.0);
  auto estimate = [&](bool spherical, std::uint64_t seed) {
    Sampler rng(seed, 0, 0, 0);
    double sum = 0, sum2 = 0;
    const int count = 100000;
    for (int i = 0; i < count; ++i) {
      const auto s = spherical ? sampleSphericalTriangle(k.ref, k.p0, k.p1, k.p2, rng.next2D())
                               : sampleTriangleArea(k.ref, k.p0, k.p1, k.p2, rng.next2D());
      const double x = s ? double(std::max(Real(0), glm::dot(s->wi, n)) / s->pdf) : 0.0;
      sum += x;
      sum2 += x * x;
    }
    const double mean = sum / count;
    return std::pair<double, double>(mean, (sum2 / count - mean * mean) / count); // the mean and its variance
  };
  const auto [sphericalMean, sphericalVariance] = estimate(true, 1);
  const auto [areaMean, areaVariance] = estimate(false, 2);
  INFO("irradiance " << exact << ": spherical " << sphericalMean << " ± " << std::sqrt(sphericalVariance) << ", area "
                     << areaMean << " ± " << std::sqrt(areaVariance));
  CHECK(std::abs(sphericalMean - exact) < 4 * std::sqrt(sphericalVariance));
  CHECK(areaVariance > 10 * sphericalVariance);
}

TEST_CASE("triangle lights are chosen by power beside spheres, and MIS's pdf matches the sampler's")
{
  // A quad light of area 4 (two triangles) with Le = 1 and a sphere light of radius 0.5 with Le = 1: powers
  // π·4 and π·π, so the quad's two triangles are chosen with 2/(4 + π) each and the sphere with π/(4 + π).
  const Scene scene = parseScene(R"({
    "camera": { "eye": [0, 0, 10], "focal": [0, 0, 0], "up": [0, 1, 0], "vfov": 40, "width": 8, "height": 8 },
    "materials": { "lamp": { "type": "diffuse", "color": [0, 0, 0], "emission": [1, 1, 1] },
                   "wall": { "type": "diffuse", "color": [0.5, 0.5, 0.5] } },
    "spheres": [ { "center": [-3, 0, 0], "radius": 0.5, "material": "lamp" },
                 { "center": [0, -10, 0], "radius": 5, "material": "wall" } ],
    "meshes": [ { "material": "lamp", "vertices": [[-1, 2, -1], [1, 2, -1], [1, 2, 1], [-1, 2, 1]],
                  "triangles": [[0, 2, 1], [0, 3, 2]] } ]
  })",
                                 "inline");
  const LightSampler lights(scene);
  CHECK(lights.probability(0) == Approx(kPi / (4 + kPi)).epsilon(kClose));
  CHECK(lights.probability(1) == 0);
  CHECK(lights.probability(2) == Approx(2 / (4 + kPi)).epsilon(kClose));
  CHECK(lights.probability(3) == Approx(2 / (4 + kPi)).epsilon(kClose));
  Sampler rng(8, 0, 0, 0);
  int onTriangles = 0, visible = 0;
  for (int i = 0; i < 50000; ++i) {
    // One draw a statement, in the order GCC drew them as arguments of one call (the last argument first).
    const Real z = rng.next1D();
    const Real y = rng.next1D();
    const Real x = rng.next1D();
    const Vec3 ref(x * 4 - 2, y * 2 - 1, z * 4 - 2);
    const Vec2 uPoint = rng.next2D();
    const Real uLight = rng.next1D();
    const std::optional<LightSample> ls = lights.sample(ref, uLight, uPoint);
    REQUIRE(ls);
    if (ls->primitive < 2)
      continue;
    ++onTriangles;
    // The pdf MIS asks for the point where a ray along wi meets the light is the sampler's; the target is on it.
    CHECK(lights.pdf(ref, ls->primitive, ls->target) == Approx(ls->pdf).epsilon(kLoose));
    CHECK(ls->target.y == Approx(2).epsilon(kClose));
    CHECK(ls->Li == Color(1));
    // Visible exactly when a closest-hit query along wi finds that triangle first.
    Hit at;
    at.point = ref;
    at.geometricNormal = at.normal = Vec3(0, 1, 0);
    const std::optional<Hit> seen = scene.intersect(spawnRay(at, ls->wi));
    const bool expected = seen && seen->primitive == ls->primitive;
    CHECK(lightVisible(scene, at, *ls) == expected);
    visible += expected;
  }
  CHECK(onTriangles > 20000);
  CHECK(visible > 10000);
}

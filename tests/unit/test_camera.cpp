#include "scene/camera.h"
#include "core/rng.h"
#include "geometry/sphere.h"

#include <catch2/catch.hpp>

using namespace raylife;

namespace {
// A vector uniform in the cube [−scale, scale)³. Its coordinates are drawn one statement at a time, z first: C++ leaves
// the order of a call's arguments unspecified (GCC evaluates them right to left, clang left to right), and z first is
// GCC's order from when the three were one call's arguments, so the tests keep their cases.
Vec3 randomVector(Sampler& s, Real scale)
{
  const Real z = s.next1D();
  const Real y = s.next1D();
  const Real x = s.next1D();
  return Vec3(x - Real(0.5), y - Real(0.5), z - Real(0.5)) * (2 * scale);
}
const Real kTol = 64 * std::numeric_limits<Real>::epsilon();
} // namespace

TEST_CASE("the camera basis is orthonormal and right-handed for many random eye - focal and up")
{
  Sampler s(1, 0, 0, 0);
  int built = 0;
  for (int i = 0; i < 10000; ++i) {
    const Vec3 eye = randomVector(s, 100), focal = randomVector(s, 100), up = randomVector(s, 1);
    auto result = makeCameraBasis(eye, focal, up);
    if (std::holds_alternative<BasisError>(result))
      continue; // only for up nearly parallel to the view: checked below
    ++built;
    const CameraBasis b = std::get<CameraBasis>(result);
    INFO("case " << i);
    CHECK(glm::length(b.u) == Approx(1).margin(kTol));
    CHECK(glm::length(b.v) == Approx(1).margin(kTol));
    CHECK(glm::length(b.w) == Approx(1).margin(kTol));
    CHECK(std::abs(glm::dot(b.u, b.v)) < kTol);
    CHECK(std::abs(glm::dot(b.v, b.w)) < kTol);
    CHECK(std::abs(glm::dot(b.w, b.u)) < kTol);
    // Right-handed: u × v = w.
    CHECK(glm::length(glm::cross(b.u, b.v) - b.w) < kTol);
    // w points from the focal point to the eye; v leans towards up.
    CHECK(glm::dot(b.w, eye - focal) > 0);
    CHECK(glm::dot(b.v, up) >= 0);
  }
  CHECK(built > 9990);
}

TEST_CASE("the basis matches the lecture's formulas for a simple camera")
{
  const auto b = std::get<CameraBasis>(makeCameraBasis(Vec3(0, 0, 5), Vec3(0, 0, 0), Vec3(0, 1, 0)));
  CHECK(glm::length(b.w - Vec3(0, 0, 1)) < kTol); // w = (eye − focal)/|eye − focal|
  CHECK(glm::length(b.u - Vec3(1, 0, 0)) < kTol); // u = (up × w)/|up × w|
  CHECK(glm::length(b.v - Vec3(0, 1, 0)) < kTol); // v = w × u
}

TEST_CASE("bad cameras are refused with a reason - never a NaN basis")
{
  auto message = [](const Vec3& eye, const Vec3& focal, const Vec3& up) {
    auto r = makeCameraBasis(eye, focal, up);
    return std::holds_alternative<BasisError>(r) ? std::get<BasisError>(r).message : std::string();
  };
  CHECK_THAT(message(Vec3(1), Vec3(1), Vec3(0, 1, 0)), Catch::Contains("same point"));
  CHECK_THAT(message(Vec3(0, 0, 5), Vec3(0), Vec3(0)), Catch::Contains("zero length"));
  CHECK_THAT(message(Vec3(0, 5, 0), Vec3(0), Vec3(0, 1, 0)), Catch::Contains("parallel"));
  CHECK_THAT(message(Vec3(0, 5, 0), Vec3(0), Vec3(0, -3, 0)), Catch::Contains("parallel"));
  CHECK_THAT(message(Vec3(0, 0, kInfinity), Vec3(0), Vec3(0, 1, 0)), Catch::Contains("finite"));
}

TEST_CASE("primary directions are d = u·x + v·y − w·z - normalised - through pixel centres")
{
  const Vec3 eye(1, 2, 3), focal(-2, 0.5, -4), up(0.1, 1, 0.2);
  const auto b = std::get<CameraBasis>(makeCameraBasis(eye, focal, up));
  const int width = 64, height = 48;
  const Real vfov = 50;
  const Camera camera(b, eye, vfov, width, height);
  const Real halfH = std::tan(glm::radians(vfov) / 2), halfW = halfH * Real(width) / Real(height);

  struct Case { int px, py; };
  for (Case c : {Case{0, 0}, Case{63, 0}, Case{0, 47}, Case{63, 47}, Case{32, 24}, Case{10, 40}}) {
    const Real x = (2 * (Real(c.px) + Real(0.5)) / Real(width) - 1) * halfW;
    const Real y = (1 - 2 * (Real(c.py) + Real(0.5)) / Real(height)) * halfH;
    const Vec3 expected = glm::normalize(b.u * x + b.v * y - b.w * Real(1));
    const Ray ray = camera.ray(Vec2(Real(c.px) + Real(0.5), Real(c.py) + Real(0.5)));
    INFO("pixel " << c.px << ", " << c.py);
    CHECK(glm::length(ray.direction - expected) < kTol);
    CHECK(ray.origin == eye);
    CHECK(ray.tmin == 0);
  }
  // The image centre looks straight at the focal point; row 0 is the top (+v), column 0 the left (−u).
  const Ray centre = camera.ray(Vec2(Real(width) / 2, Real(height) / 2));
  CHECK(glm::length(centre.direction + b.w) < kTol);
  CHECK(glm::dot(camera.ray(Vec2(Real(0.5), Real(0.5))).direction, b.v) > 0);
  CHECK(glm::dot(camera.ray(Vec2(Real(0.5), Real(0.5))).direction, b.u) < 0);
  // The top edge's centre is exactly vfov/2 above the axis.
  const Ray top = camera.ray(Vec2(Real(width) / 2, 0));
  CHECK(std::acos(glm::dot(top.direction, -b.w)) == Approx(glm::radians(vfov) / 2).epsilon(1e-6));
}

TEST_CASE("a block's pyramid culls only spheres none of its rays meets, and culls most of the others")
{
  // Cameras looking every way, blocks of pixels anywhere on the film (a single pixel, 8 x 8, a whole row), and
  // spheres from tiny to huge, many of them just outside a side of the block's pyramid or behind the eye. Each
  // culled sphere must be missed by rays through random points of the block, its corners and edges included.
  Sampler s(7, 0, 0, 0);
  int culled = 0, kept = 0, keptAndMet = 0;
  for (int c = 0; c < 60; ++c) {
    const Vec3 eye = randomVector(s, 50), focal = eye + randomVector(s, 10);
    const auto basis = makeCameraBasis(eye, focal, Vec3(0, 1, 0));
    if (!std::holds_alternative<CameraBasis>(basis))
      continue;
    const int width = 40 + int(s.next1D() * 300), height = 30 + int(s.next1D() * 200);
    const Camera camera(std::get<CameraBasis>(basis), eye, 20 + 120 * s.next1D(), width, height);
    const int size = c % 3 == 0 ? 1 : 8;
    const int x0 = int(s.next1D() * Real(width - size)), y0 = int(s.next1D() * Real(height - size));
    const Vec2 lo{Real(x0), Real(y0)}, hi{Real(c % 5 == 0 ? width : x0 + size), Real(y0 + size)};
    const PinholeFrustum frustum = camera.frustum(lo, hi);
    for (int k = 0; k < 60; ++k) {
      // A sphere near a ray of the block: on it, or moved sideways by up to twice its radius (either side of a side).
      const Vec2 film(lo.x + (hi.x - lo.x) * s.next1D(), lo.y + (hi.y - lo.y) * s.next1D());
      const Ray aim = camera.ray(film);
      const Real radius = std::pow(Real(10), -3 + 6 * s.next1D());
      const Real distance = k % 10 == 0 ? -radius * (1 + s.next1D()) : radius * (1 + Real(1e3) * s.next1D());
      Vec3 center = aim.origin + distance * aim.direction + radius * (2 * s.next1D()) * randomVector(s, 1);
      if (k % 2 == 1) // or anywhere around the camera (most of these the block's thin pyramid misses)
        center = eye + randomVector(s, 100);
      int met = 0;
      for (int r = 0; r < 400; ++r) {
        const Real fx = r < 4 ? Real(r % 2) : s.next1D(), fy = r < 4 ? Real(r / 2) : s.next1D();
        const Ray ray = camera.ray(Vec2(lo.x + (hi.x - lo.x) * fx, lo.y + (hi.y - lo.y) * fy));
        met += intersectSphere(ray.origin, ray.direction, center, radius, Real(0), kInfinity).has_value();
      }
      if (!frustum.mayMeet(center, radius)) {
        ++culled;
        INFO("camera " << c << ", sphere " << k);
        CHECK(met == 0);
      } else {
        ++kept;
        keptAndMet += met > 0;
      }
    }
  }
  INFO(culled << " culled, " << kept << " kept, " << keptAndMet << " of those met");
  CHECK(culled > 1000);
  CHECK(keptAndMet > kept / 2);
}

// Case 7 — the camera looking along its up vector, and nudged 1e-7 away from it.
//
// Setup: view directions w (random, and axis-aligned) with up = w exactly, and up tilted from w by an angle
// of 1e-7 … 1e-2. Naive: the lecture's formula without a check, u = (up × w)/|up × w|, v = w × u. Robust:
// makeCameraBasis, which refuses a sine below kMinUpSine (1e-6) with a message, and the scene loader, which
// turns that into an error naming /camera/up.
// Pass criterion: either a clear error, or a basis that is orthonormal within kOrthonormalTolerance; never a
// NaN. The naive formula is shown giving NaN (parallel) and, in float, a basis that is not orthonormal (1e-7).
#include "scene/camera.h"
#include "render/runner.h"
#include "scene/scene.h"
#include "support.h"

#include <catch2/catch.hpp>

#include <cstdio>

using namespace raylife;
using namespace raylife::stability;

namespace {

/// A camera basis that is off by more than this in any dot product or length is visibly skewed (a pixel of
/// a 1000-pixel image is 1e-3 wide at unit distance); 1e-4 leaves a margin of ten.
constexpr double kOrthonormalTolerance = 1e-4;

template <class T> struct Frame {
  TVec3<T> u, v, w;
};

/// The lecture's basis with no check at all.
template <class T> Frame<T> naiveBasis(const TVec3<T>& eye, const TVec3<T>& focal, const TVec3<T>& up)
{
  Frame<T> f;
  f.w = glm::normalize(eye - focal);
  f.u = glm::normalize(glm::cross(up, f.w));
  f.v = glm::cross(f.w, f.u);
  return f;
}

/// The largest departure from orthonormality: max over |a·b| (a ≠ b) and ||a| − 1|; +∞ if any NaN.
template <class T> double orthonormalityError(const TVec3<T>& u, const TVec3<T>& v, const TVec3<T>& w)
{
  if (!isFinite(u) || !isFinite(v) || !isFinite(w))
    return std::numeric_limits<double>::infinity();
  const glm::dvec3 U(u), V(v), W(w);
  return std::max({std::fabs(glm::dot(U, V)), std::fabs(glm::dot(U, W)), std::fabs(glm::dot(V, W)),
                   std::fabs(glm::length(U) - 1), std::fabs(glm::length(V) - 1), std::fabs(glm::length(W) - 1)});
}

/// An up vector at angle `angle` from unit w, in a random plane through w.
glm::dvec3 tiltedUp(const glm::dvec3& w, double angle, TestRng& rng)
{
  const glm::dvec3 side = glm::normalize(glm::cross(w, uniformSphere(rng)));
  return std::cos(angle) * w + std::sin(angle) * side;
}

} // namespace

TEMPLATE_TEST_CASE("stability 7 (naive): the unchecked camera basis breaks near a parallel up vector",
                   "[stability][camera]", float, double)
{
  using T = TestType;
  TestRng rng(7);
  // Exactly parallel: 0/0.
  const Frame<T> parallel = naiveBasis(TVec3<T>(0, 6, 0), TVec3<T>(0), TVec3<T>(0, 1, 0));
  CHECK_FALSE(isFinite(parallel.u));
  // Tilted 1e-7 from a random view direction: up × w is of the size of its own rounding error in float.
  double worst = 0;
  for (int i = 0; i < 1000; ++i) {
    const glm::dvec3 w = uniformSphere(rng);
    const Frame<T> f = naiveBasis(toT<T>(5.0 * w), TVec3<T>(0), toT<T>(tiltedUp(w, 1e-7, rng)));
    worst = std::max(worst, orthonormalityError(f.u, f.v, f.w));
  }
  char line[160];
  std::snprintf(line, sizeof line, "camera %-6s naive basis, up 1e-7 from the view: worst orthonormality error %.3g",
                scalarName<T>(), worst);
  printFigure(line);
  INFO(line);
  if constexpr (sizeof(T) == 4) {
    CHECK(worst > kOrthonormalTolerance); // float cannot resolve a sine of 1e-7 (u ≈ 6e-8)
  } else {
    CHECK(worst < kOrthonormalTolerance); // double can (error ≈ u / 1e-7 ≈ 1e-9), but only by luck of precision
  }
}

TEST_CASE("stability 7: makeCameraBasis refuses a parallel or nearly parallel up and is orthonormal otherwise",
          "[stability][camera]")
{
  TestRng rng(77);
  // Parallel, along an axis and along a random direction: a clear error.
  CHECK(std::holds_alternative<BasisError>(makeCameraBasis(Vec3(0, 6, 0), Vec3(0), Vec3(0, 1, 0))));
  CHECK(std::holds_alternative<BasisError>(makeCameraBasis(Vec3(0, 6, 0), Vec3(0), Vec3(0, -3, 0))));
  int refusedNear = 0, nanBases = 0;
  double worstAccepted = 0;
  for (int i = 0; i < 1000; ++i) {
    const glm::dvec3 w = uniformSphere(rng);
    const Vec3 eye = toT<Real>(5.0 * w);
    // 1e-7 from the view: refused (the sine is below kMinUpSine).
    const auto near = makeCameraBasis(eye, Vec3(0), toT<Real>(tiltedUp(w, 1e-7, rng)));
    refusedNear += std::holds_alternative<BasisError>(near);
    // From just above kMinUpSine to well clear of it: accepted and orthonormal.
    for (const double angle : {2e-6, 1e-5, 1e-3, 1e-1}) {
      const auto basis = makeCameraBasis(eye, Vec3(0), toT<Real>(tiltedUp(w, angle, rng)));
      REQUIRE(std::holds_alternative<CameraBasis>(basis));
      const CameraBasis& b = std::get<CameraBasis>(basis);
      const double error = orthonormalityError(b.u, b.v, b.w);
      nanBases += !std::isfinite(error);
      worstAccepted = std::max(worstAccepted, error);
    }
  }
  char line[200];
  std::snprintf(line, sizeof line,
                "camera %-6s makeCameraBasis: refused %d of 1000 ups 1e-7 from the view; worst orthonormality error "
                "of accepted bases (sine >= 2e-6) %.3g",
                scalarName<Real>(), refusedNear, worstAccepted);
  printFigure(line);
  INFO(line);
  CHECK(refusedNear == 1000);
  CHECK(nanBases == 0);
  CHECK(worstAccepted <= kOrthonormalTolerance);
}

TEST_CASE("stability 7: a scene whose up vector is parallel to the view fails to load naming /camera/up",
          "[stability][camera]")
{
  for (const char* name : {"invalid_camera_up_parallel.json", "invalid_camera_up_nudged_1e-7.json"}) {
    const std::string path = sceneDirectory() + "/stress/" + name;
    INFO(path);
    try {
      loadScene(path);
      FAIL("the scene loaded");
    } catch (const SceneError& e) {
      const std::string message = e.what();
      INFO(message);
      CHECK(message.find(path) != std::string::npos);
      CHECK(message.find("/camera/up") != std::string::npos);
      CHECK(message.find("parallel") != std::string::npos);
    }
  }
  // Nudged 1e-3: loads, with an orthonormal basis.
  const Scene scene = loadScene(sceneDirectory() + "/stress/camera_up_nudged_1e-3.json");
  const CameraBasis& b = scene.camera.basis;
  CHECK(orthonormalityError(b.u, b.v, b.w) <= kOrthonormalTolerance);
}

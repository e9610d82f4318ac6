#include "camera.h"

#include <catch2/catch.hpp>

using namespace raylife;

TEST_CASE("the camera basis is orthonormal")
{
  auto b = std::get<CameraBasis>(makeCameraBasis(Vec3(0, 0, 5), Vec3(0), Vec3(0, 1, 0)));
  CHECK(glm::dot(b.u, b.v) == Approx(0).margin(1e-12));
}

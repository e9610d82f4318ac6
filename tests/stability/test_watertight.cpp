// Case 11 — rays through the shared edges and vertices of a closed mesh.
//
// Setup: a closed mesh, a sphere of radius 1 tessellated into 24 × 48 cells with every vertex jittered (so its
// triangles meet at all angles), centred at the origin, at 1e3 and at 1e5 from it. From points inside it, rays
// are aimed exactly at each of its vertices (2,258) and at points on each of its edges (the midpoint and a random
// point of each), in float and in double. Naive: Möller–Trumbore, each triangle deciding "inside" from its own
// edge vectors. Robust: intersectTriangle (Woop, Benthin and Wald's watertight test). Pass criterion: no ray from
// inside the closed mesh escapes it (hits none of its triangles) with the robust test; the naive test's escapes
// are counted and printed beside it. Then the image: chapter 2 with its camera inside a closed mesh shows no pixel
// of the (bright) background.
#include "../bvh/random_meshes.h"
#include "run_chapter.h"
#include "support.h"

#include <catch2/catch.hpp>

#include <cstdio>
#include <filesystem>
#include <fstream>

using namespace raylife;
using namespace raylife::stability;

namespace {

struct Escapes {
  int rays = 0;
  int naive = 0;  // rays that hit no triangle with Möller–Trumbore
  int robust = 0; // with the watertight test
};

template <class T> Escapes measureWatertight(double offset, std::uint64_t seed)
{
  testing::Random random(seed);
  const glm::dvec3 centre(offset, -0.5 * offset, 0.25 * offset);
  const testing::TestMesh<T> mesh = testing::jitteredSphere<T>(random, centre, 1.0, 24, 48, 0.8);
  auto escapes = [&](const TVec3<T>& o, const TVec3<T>& d, bool naive) {
    for (const auto& tri : mesh.triangles) {
      const TVec3<T>&a = mesh.vertices[tri[0]], &b = mesh.vertices[tri[1]], &c = mesh.vertices[tri[2]];
      if (naive ? naiveIntersectTriangle(o, d, a, b, c, T(0), std::numeric_limits<T>::infinity()).has_value()
                : intersectTriangle(o, d, a, b, c, T(0), std::numeric_limits<T>::infinity()).has_value())
        return false;
    }
    return true;
  };
  Escapes e;
  auto shoot = [&](const TVec3<T>& o, const TVec3<T>& target) {
    const TVec3<T> d = target - o;
    if (!(glm::length(d) > 0))
      return;
    const TVec3<T> unit = glm::normalize(d);
    ++e.rays;
    e.naive += escapes(o, unit, true);
    e.robust += escapes(o, unit, false);
  };
  for (int k = 0; k < 3; ++k) {
    // The centre, and two points well inside, rounded to T.
    const TVec3<T> o = toT<T>(centre + (k == 0 ? 0.0 : 0.4) * glm::dvec3(random.direction()));
    for (const TVec3<T>& v : mesh.vertices)
      shoot(o, v);
    for (const auto& tri : mesh.triangles)
      for (int edge = 0; edge < 3; ++edge) {
        const TVec3<T>&a = mesh.vertices[tri[std::size_t(edge)]], &b = mesh.vertices[tri[std::size_t((edge + 1) % 3)]];
        shoot(o, a + (b - a) * T(0.5));
        shoot(o, a + (b - a) * T(random.uniform()));
      }
  }
  return e;
}

} // namespace

TEST_CASE("stability 11: no ray aimed at a closed mesh's shared edges and vertices escapes it",
          "[stability][watertight]")
{
  int naiveTotal = 0;
  auto run = [&](auto scalar) {
    using T = decltype(scalar);
    for (double offset : {0.0, 1e3, 1e5}) {
      const Escapes e = measureWatertight<T>(offset, std::uint64_t(11 + offset));
      char line[200];
      std::snprintf(line, sizeof line,
                    "watertight %-6s offset %-6g: %d rays at vertices and edges, escaped: naive %d, robust %d",
                    scalarName<T>(), offset, e.rays, e.naive, e.robust);
      printFigure(line);
      INFO(line);
      CHECK(e.robust == 0);
      CHECK(e.rays > 40000);
      naiveTotal += e.naive;
    }
  };
  run(double(0));
  run(float(0));
  CHECK(naiveTotal > 0); // the control: the naive test does leak on the same rays
}

TEST_CASE("stability 11: a camera inside a closed mesh sees no background", "[stability][watertight]")
{
  // Chapter 2 (normals) inside the jittered sphere mesh, the background bright red: any red pixel is a leak.
  testing::Random random(3);
  const testing::TestMesh<Real> mesh = testing::jitteredSphere<Real>(random, glm::dvec3(0), 1.0, 24, 48, 0.8);
  const std::string path = std::string(RAYLIFE_STABILITY_OUT_DIR) + "/inside_mesh.json";
  {
    std::ofstream out(path);
    out.precision(17);
    out << R"({ "camera": { "eye": [0.1, 0.05, 0.2], "focal": [0.3, 0, -1], "up": [0, 1, 0], "vfov": 120,
                "width": 200, "height": 150 },
              "background": [1000, 0, 0],
              "materials": { "m": { "type": "diffuse", "color": [0.5, 0.5, 0.5] } },
              "meshes": [ { "material": "m", "vertices": [)";
    for (std::size_t v = 0; v < mesh.vertices.size(); ++v) {
      const Vec3& p = mesh.vertices[v];
      out << (v ? "," : "") << "[" << p.x << "," << p.y << "," << p.z << "]";
    }
    out << R"(], "triangles": [)";
    for (std::size_t t = 0; t < mesh.triangles.size(); ++t)
      out << (t ? "," : "") << "[" << mesh.triangles[t][0] << "," << mesh.triangles[t][1] << "," << mesh.triangles[t][2]
          << "]";
    out << "] } ] }\n";
  }
  const ChapterRun run = runChapter("step02_sphere", path, "inside_mesh");
  REQUIRE(run.status == 0);
  int background = 0;
  for (std::size_t i = 0; i < run.image.pixels.size(); i += 3)
    background += run.image.pixels[i] > 1.5f; // the normals' colours are in [0, 1]; the background is 1000
  INFO(background << " background pixels");
  CHECK(background == 0);
  CHECK(run.image.width * run.image.height == 200 * 150);
}

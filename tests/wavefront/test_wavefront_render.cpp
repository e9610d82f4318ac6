// Chapter 16 as students run it: the wavefront renders chapter 8's estimator, so on every scene chapter 8 renders
// it gives chapter 8's image - bit for bit in the same build, since each path draws the same random numbers and does
// the same arithmetic (the stream kernels are bit-exact) - and the same image by the z-test at other seeds. Its
// image does not depend on the wavefront's size; what it does not support it says.
#include "../analytic/run_chapter.h"
#include "../lights/compare_renders.h"
#include "core/rng.h"

#include <catch2/catch.hpp>

#include <cstdio>
#include <fstream>
#include <sstream>

using namespace raylife;
using namespace raylife::test;

namespace {

const std::string kScenes = RAYLIFE_SCENES;

std::string readBytes(const std::string& path)
{
  std::ifstream in(path, std::ios::binary);
  std::stringstream bytes;
  bytes << in.rdbuf();
  return bytes.str();
}

// Renders `binary` on `scene` with `args` into a PFM and returns its bytes.
std::string renderBytes(const std::string& binary, const std::string& scene, const std::string& args,
                        const std::string& tag)
{
  const std::string out = "/tmp/raylife_wavefront_" + std::to_string(::getpid()) + "_" + tag + ".pfm";
  const std::string command = "'" + binary + "' '" + scene + "' --quiet -o '" + out + "' " + args;
  REQUIRE(std::system(command.c_str()) == 0);
  const std::string bytes = readBytes(out);
  std::remove(out.c_str());
  REQUIRE(bytes.size() > 100);
  return bytes;
}

// One entry of a scene file's "spheres" list.
std::string sphereJson(double x, double y, double z, double r, const char* material)
{
  return "{\"center\": [" + std::to_string(x) + ", " + std::to_string(y) + ", " + std::to_string(z) +
         "], \"radius\": " + std::to_string(r) + ", \"material\": \"" + material + "\"}";
}

// Writes a 48 x 36 scene of `spheres` (a list's entries) under `camera` and `lights` (a scene file's values), with a
// diffuse "grey", a glossy "shiny" and a "glass" of index `ior`, and checks that chapter 16 renders chapter 8's
// image of it bit for bit, on one thread and on two with wavefronts of `wavefront` paths.
void checkChapter8Image(const std::string& tag, const std::string& camera, const std::string& lights, double ior,
                        const std::string& spheres, const std::string& args, int wavefront)
{
  const std::string path = "/tmp/raylife_wavefront_" + tag + "_" + std::to_string(::getpid()) + ".json";
  {
    std::ofstream out(path);
    out << R"({"camera": )" << camera << R"(, "background": [0.5, 0.7, 1.0],
               "materials": {"grey": {"type": "diffuse", "color": [0.6, 0.6, 0.6]},
                             "shiny": {"type": "glossy", "color": [0.8, 0.7, 0.5], "roughness": 0.2},
                             "glass": {"type": "glass", "color": [1, 1, 1], "ior": )"
        << ior << R"(}}, "lights": )" << lights << R"(, "spheres": [)" << spheres << "]}";
  }
  CHECK(renderBytes(RAYLIFE_STEP16, path, args, tag + "16") == renderBytes(RAYLIFE_STEP08, path, args, tag + "8"));
  CHECK(renderBytes(RAYLIFE_STEP16, path, args + " --threads 2 --wavefront " + std::to_string(wavefront),
                    tag + "16b") == renderBytes(RAYLIFE_STEP08, path, args, tag + "8b"));
  std::remove(path.c_str());
}

} // namespace

TEST_CASE("wavefront: chapter 16 renders chapter 8's image bit for bit on the scenes chapter 8 renders")
{
  // Flat lists of spheres (the stream kernels), BVHs over spheres and over triangles (one ray at a time), point
  // lights, glossy and metal lobes, glass, a lamp hidden in a recess (the light guide at work), the lens and motion,
  // and a sky from an environment map (turned and scaled), which chapter 8 looks up where a ray leaves the scene.
  for (const char* scene : {"cornell.json", "smallpt.json", "mis.json", "random_spheres.json", "cornell_original.json",
                            "meshes.json", "spheres.json", "lamp_recess.json", "cornell_glossy.json",
                            "distributed.json", "caustics.json", "sun_sky.json"}) {
    INFO(scene);
    const std::string args = "--width 40 --height 30 --spp 6 --seed 3";
    CHECK(renderBytes(RAYLIFE_STEP16, kScenes + "/" + scene, args, "16") ==
          renderBytes(RAYLIFE_STEP08, kScenes + "/" + scene, args, "8"));
  }
}

TEST_CASE("wavefront: the image is the same for any wavefront size, heuristic and adaptive sampling included")
{
  const std::string scene = kScenes + "/smallpt.json";
  const std::string args = "--width 37 --height 23 --spp 5 --seed 11";
  const std::string whole = renderBytes(RAYLIFE_STEP16, scene, args, "w4096");
  CHECK(renderBytes(RAYLIFE_STEP16, scene, args + " --wavefront 1", "w1") == whole);
  CHECK(renderBytes(RAYLIFE_STEP16, scene, args + " --wavefront 7", "w7") == whole);
  CHECK(renderBytes(RAYLIFE_STEP16, scene, args + " --wavefront 100000", "wbig") == whole);
  // The balance heuristic and adaptive sampling as chapter 8 has them.
  const std::string cornell = kScenes + "/cornell.json";
  CHECK(renderBytes(RAYLIFE_STEP16, cornell, args + " --heuristic balance", "b16") ==
        renderBytes(RAYLIFE_STEP08, cornell, args + " --heuristic balance", "b8"));
  const std::string adaptive = "--width 32 --height 24 --spp 64 --adaptive 0.2 --seed 2";
  CHECK(renderBytes(RAYLIFE_STEP16, kScenes + "/adaptive.json", adaptive, "a16") ==
        renderBytes(RAYLIFE_STEP08, kScenes + "/adaptive.json", adaptive, "a8"));
}

TEST_CASE("wavefront: camera rays by blocks of pixels give chapter 8's image, a crowded block through the packets")
{
  // A tree of spheres through a pinhole: camera rays go block by block, each against the spheres it may see. Here
  // 150 small spheres lie along the view axis, so the central blocks may see more than 32 and take the tree's
  // packets; the others see a few of 40 spheres scattered about, or only the ground; one sphere holds the eye.
  std::string spheres = R"({"center": [0, -1000, 0], "radius": 1000, "material": "grey"},
                           {"center": [0, 1, 10], "radius": 40, "material": "glass"})";
  Pcg32 rng(3, 5);
  auto u = [&] { return double(rng.nextUint()) * 0x1p-32; };
  for (int k = 0; k < 190; ++k) {
    const bool axis = k < 150;
    const double x = axis ? 0.1 * (u() - 0.5) : 8 * (u() - 0.5), y = axis ? 1 + 0.1 * (u() - 0.5) : 0.2 + 3 * u();
    const double z = axis ? 8 - 28 * u() : 4 - 12 * u(), r = axis ? 0.02 : 0.1 + 0.4 * u();
    spheres += ", " + sphereJson(x, y, z, r, k % 3 ? "grey" : "shiny");
  }
  checkChapter8Image("blocks", R"({"eye": [0, 1, 10], "focal": [0, 1, 0], "up": [0, 1, 0], "vfov": 30})",
                     R"([{"type": "point", "position": [-5, 20, 10], "intensity": [400, 400, 400]}])", 1.0, spheres,
                     "--width 48 --height 36 --spp 5 --seed 7", 9);
}

TEST_CASE("wavefront: shadow rays through the point lights' light buffers give chapter 8's image")
{
  // A tree of still spheres: each point light's shadow rays go through its light buffer when they start within four
  // times its distance from the eye. One light hangs among a crowd of small spheres (many fill several cells, the
  // ground a whole face), one is inside a glass ball (every ray from outside crosses it), one is far off, one is
  // close to the eye (its rays from most points are beyond its range: the tree answers them) and one is at the eye
  // itself (no range: no buffer).
  std::string spheres = R"({"center": [0, -1000, 0], "radius": 1000, "material": "grey"},
                           {"center": [3, 1.5, -2], "radius": 1, "material": "glass"})";
  Pcg32 rng(9, 2);
  auto u = [&] { return double(rng.nextUint()) * 0x1p-32; };
  for (int k = 0; k < 120; ++k) {
    const bool crowd = k < 60;
    const double x = crowd ? -2 + 2 * (u() - 0.5) : 12 * (u() - 0.5), y = crowd ? 2 + 2 * (u() - 0.5) : 0.3 * u();
    const double z = crowd ? 2 * (u() - 0.5) : 8 - 16 * u(), r = crowd ? 0.05 + 0.2 * u() : 0.1 + 0.3 * u();
    spheres += ", " + sphereJson(x, y, z, r, k % 3 ? "grey" : "shiny");
  }
  checkChapter8Image("lights", R"({"eye": [0, 3, 12], "focal": [0, 1, 0], "up": [0, 1, 0], "vfov": 40})",
                     R"([{"type": "point", "position": [-2, 2, 0], "intensity": [20, 20, 20]},
                         {"type": "point", "position": [3, 1.5, -2], "intensity": [30, 20, 10]},
                         {"type": "point", "position": [-300, 500, 300], "intensity": [2e5, 2e5, 2e5]},
                         {"type": "point", "position": [0.1, 3, 12], "intensity": [5, 5, 5]},
                         {"type": "point", "position": [0, 3, 12], "intensity": [5, 5, 5]}])",
                     1.5, spheres, "--width 48 --height 36 --spp 6 --seed 5", 13);
}

TEST_CASE("unbiased: chapter 16 and chapter 8 at other seeds render the same image by the z-test")
{
  // The scenes issue 40 names: the Cornell boxes (spheres, and the original's triangles), smallpt's room, the MIS
  // scene, the 500 spheres, and chapter 10's model.
  for (const char* scene : {"smallpt.json", "cornell.json", "cornell_original.json", "mis.json",
                            "random_spheres.json", "meshes.json"}) {
    INFO(scene);
    const ChapterRender c16 = run(RAYLIFE_STEP16, kScenes + "/" + scene, "--width 48 --height 36 --spp 128 --seed 61",
                                  std::string("z16") + scene);
    const ChapterRender c8 = run(RAYLIFE_STEP08, kScenes + "/" + scene, "--width 48 --height 36 --spp 128 --seed 81",
                                 std::string("z8") + scene);
    CHECK(compare(c16.mean, c16.variance, c8.mean, c8.variance, std::string(scene) + ": chapter 16 against 8")
              .passed());
  }
}

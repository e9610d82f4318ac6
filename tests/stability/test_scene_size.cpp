// Case 14 — a scene at the largest and at the smallest size the build takes.
//
// Setup: smallpt's room (spheres and a spherical lamp) and the original Cornell box (triangles and a triangle lamp),
// scaled up by a power of ten so that their largest coordinate or radius lies within a factor of ten of
// kMaxSceneExtent (10^30 in double, 10^8 in float), and down so that their smallest length (a radius, a triangle's
// size, the eye's distance to the focal point) lies within a factor of ten of kMinSceneLength (10^-30 and 10^-8),
// rendered by chapters 2, 5 to 11 and 13 to 16 (those that light them) at 40×30, 32 spp, and compared with the same
// chapter's image of the scene at its own size; then scaled 100 times further each way, which the loader must
// refuse.
// Why it can fail: the renderer squares lengths (a sphere's r² and |o − c|²), a triangle's area squares a squared
// length, and the watertight test's scaled distance is a cube of the size. Past float's range (3.4e38) a lamp's area
// was infinite (the Cornell box at 5.6e10 gave bad samples in chapters 7, 8, 11 and 13 to 16), and smallpt's walls
// at radius 1e20 rendered a wrong image without a word, before the float build had a bound of its own. Below the
// normal numbers rounding takes over: smallpt scaled down to 1e-160 in double, or 1e-22 in float, rendered a
// different image without a word, before the loader had a smallest length.
// In double the case found a cost, not a wrong image: the tree's boxes are float, and with the bound at 10^50 a
// scene beyond float's range got boxes that every ray enters. Chapter 9's picture, which shows the work, differed
// for the Cornell box at 8e49, and chapter 10's model at 8e39 rendered the same image 36 times slower. The double
// build's bound is now 10^30.
// Chapter 13's means move by about 1 % when a scene is scaled down: its light paths carry the lamp's area in their
// throughput, which its Russian roulette reads, so they end sooner (the Cornell box at 1e-3 in double: 186,579 rays
// against 262,975); unbiased, and noisier.
// Pass criterion: the scaled scene renders with no bad sample and its mean radiance lies within kMeanTolerance of
// the scene's at its own size (the same samples: in double the two means agree to four digits; in float rounding
// sends a few paths elsewhere); scaled beyond a bound, every chapter refuses it in one line naming the bound.
#include "run_chapter.h"
#include "scene_scale.h"
#include "render/runner.h"
#include "scene/scene.h"
#include "support.h"

#include <catch2/catch.hpp>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

using namespace raylife;
using namespace raylife::stability;
using namespace raylife::test;

namespace {

using Json = nlohmann::json;

/// The scaled image's mean radiance may differ from the unscaled one's by this share of it. The faults this case
/// found were far larger: a mean 92 % low, 442 % high, or black.
constexpr double kMeanTolerance = 0.1;

std::string write(const Json& j, const std::string& tag)
{
  const std::string path = std::string(RAYLIFE_STABILITY_OUT_DIR) + "/" + tag + ".scene.json";
  std::ofstream(path) << j.dump();
  return path;
}

double meanRadiance(const Image& image)
{
  double sum = 0;
  for (const float v : image.pixels)
    sum += v;
  return image.pixels.empty() ? 0 : sum / double(image.pixels.size());
}

// The chapters that light the two scenes, and how they render them.
constexpr const char* kChapters[] = {"step02_sphere",       "step05_whitted", "step06_path_tracer",
                                     "step07_light_sampling", "step08_mis",   "step09_bvh",
                                     "step10_meshes",       "step11_distributed", "step13_bdpt",
                                     "step14_textures",     "step15_volumes", "step16_wavefront"};
constexpr const char* kOptions = "--width 40 --height 30 --spp 32";

// Renders scene `name` scaled by `factor` (a power of ten that takes it to within 10× of one of the build's
// bounds) in every chapter of kChapters, against `own`, each chapter's mean at the scene's own size; and scaled by
// `beyond`, which must be refused naming `bound`.
void renderScaled(const char* name, const Json& scene, const std::vector<double>& own, double factor, double beyond,
                  const std::string& bound, const std::string& which)
{
  const std::string stem = std::string("size_") + name + "_" + which;
  const std::string atBound = write(scaledScene(scene, factor), stem + "_bound");
  const std::string past = write(scaledScene(scene, beyond), stem + "_beyond");
  for (std::size_t k = 0; k < std::size(kChapters); ++k) {
    const char* chapter = kChapters[k];
    const std::string tag = stem + "_" + chapter;
    const ChapterRun run = runChapter(chapter, atBound, tag + "_bound", kOptions);
    INFO(run.err);
    REQUIRE(run.status == 0);
    const double m0 = own[k], m1 = meanRadiance(run.image);
    char line[200];
    std::snprintf(line, sizeof line, "scene size %-6s %-17s %-24s x%.0e: mean %.5g against %.5g (%+.2f %%)",
                  scalarName<Real>(), name, chapter, factor, m1, m0, m0 > 0 ? 100 * (m1 / m0 - 1) : 0.0);
    printFigure(line);
    INFO(line);
    CHECK(run.badSamples == 0);
    CHECK(std::abs(m1 - m0) <= kMeanTolerance * m0);
    const ChapterRun refused = runChapter(chapter, past, tag + "_beyond", kOptions);
    INFO(refused.err);
    CHECK(refused.status == 1);
    CHECK(refused.image.pixels.empty());
    CHECK(refused.err.find(bound) != std::string::npos);
    CHECK(std::count(refused.err.begin(), refused.err.end(), '\n') == 1);
  }
}

} // namespace

TEST_CASE("stability 14: a scene at the largest and at the smallest size the build takes renders as at its own "
          "size, and beyond them is refused",
          "[stability][scene-size]")
{
  for (const char* name : {"smallpt", "cornell_original"}) {
    Json scene;
    std::ifstream(sceneDirectory() + "/" + name + ".json") >> scene;
    scene.erase("lights"); // (none in either: a point light's intensity would have to grow with the square)
    const std::string own = write(scene, std::string("size_") + name + "_own");
    std::vector<double> means;
    for (const char* chapter : kChapters) {
      const ChapterRun reference = runChapter(chapter, own, std::string("size_") + name + "_" + chapter, kOptions);
      REQUIRE(reference.status == 0);
      means.push_back(meanRadiance(reference.image));
    }
    // Up: the largest power of ten that keeps every coordinate and radius within the bound.
    double up = std::pow(10.0, std::floor(std::log10(kMaxSceneExtent / largestMagnitude(scene))));
    if (largestMagnitude(scaledScene(scene, up)) > kMaxSceneExtent)
      up /= 10;
    REQUIRE(largestMagnitude(scaledScene(scene, up)) <= kMaxSceneExtent);
    REQUIRE(largestMagnitude(scaledScene(scene, up)) > kMaxSceneExtent / 10);
    renderScaled(name, scene, means, up, up * 100, "raylife's bound on a scene's size", "up");
    // Down: the smallest power of ten that keeps every radius, triangle and the camera's distance above the
    // smallest length.
    double down = std::pow(10.0, std::ceil(std::log10(kMinSceneLength / smallestLength(scene))));
    if (smallestLength(scaledScene(scene, down)) < kMinSceneLength)
      down *= 10;
    REQUIRE(smallestLength(scaledScene(scene, down)) >= kMinSceneLength);
    REQUIRE(smallestLength(scaledScene(scene, down)) < kMinSceneLength * 10);
    renderScaled(name, scene, means, down, down / 100, "raylife's smallest length", "down");
  }
}

// Chapter 13 (bidirectional path tracing) as students run it: unbiased against chapter 6 by the z-test of
// compare_renders.h, on the Cornell box (mirror and glass balls), the caustic scene, the mirror corner and the glossy
// box; the weighted images of its strategies (--strategy s,t) sum to the full image; splats keep --time, --variance
// and --stats working.
#include "../analytic/run_chapter.h"
#include "compare_renders.h"

#include "render/image_io.h"

#include <catch2/catch.hpp>

#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

using namespace raylife;
using namespace raylife::test;

namespace {

const std::string kScenes = RAYLIFE_SCENES;


// Chapter 13 against chapter 6 on one scene, each with its own seed, per pixel or per block of pixels.
void checkAgainstChapter6(const std::string& scene, const std::string& size, int spp6, int spp13,
                          const std::string& tag, int block)
{
  const ChapterRender c6 =
      run(RAYLIFE_STEP06, scene, size + " --spp " + std::to_string(spp6) + " --seed 61", tag + "6");
  const ChapterRender c13 =
      run(RAYLIFE_STEP13, scene, size + " --spp " + std::to_string(spp13) + " --seed 131", tag + "13");
  CHECK(compare(c13.mean, c13.variance, c6.mean, c6.variance, tag + ": chapter 13 against chapter 6", nullptr, block)
            .passed());
}

// The glossy box with its glass ball made diffuse (no delta surface: every strategy can make every path), written to
// a file of its own: its path. `hugeWalls`: its six walls, spheres of radius 10^5, made 10^9 times as large (in
// double; the float build keeps them), so that each wall places its points to some 10^-2 units, as float does the
// box's own.
std::string noDeltaBox(const std::string& tag, bool hugeWalls)
{
  std::ifstream in(kScenes + "/cornell_glossy.json");
  std::stringstream buffer;
  buffer << in.rdbuf();
  std::string text = buffer.str();
  auto replace = [&text](const std::string& from, const std::string& to) {
    const std::size_t at = text.find(from);
    REQUIRE(at != std::string::npos);
    text.replace(at, from.size(), to);
  };
  replace(R"("type": "glass",   "color": [0.999, 0.999, 0.999], "ior": 1.5)",
          R"("type": "diffuse", "color": [0.6, 0.6, 0.6])");
  if (hugeWalls && !std::is_same_v<Real, float>) {
    for (const auto& [from, to] :
         {std::pair{"[100001, 40.8, 81.6]", "[100000000000001, 40.8, 81.6]"},
          {"[-99901, 40.8, 81.6]", "[-99999999999901, 40.8, 81.6]"},
          {"[50, 40.8, 100000]", "[50, 40.8, 100000000000000]"},
          {"[50, 40.8, -99830]", "[50, 40.8, -99999999999830]"},
          {"[50, 100000, 81.6]", "[50, 100000000000000, 81.6]"},
          {"[50, -99918.4, 81.6]", "[50, -99999999999918.4, 81.6]"}})
      replace(from, to);
    for (int wall = 0; wall < 6; ++wall)
      replace(R"("radius": 100000,)", R"("radius": 100000000000000,)");
  }
  const std::string path = (std::filesystem::temp_directory_path() /
                            ("raylife_bdpt_" + tag + "_" + std::to_string(::getpid()) + ".json"))
                               .string();
  std::ofstream(path) << text;
  return path;
}

} // namespace

TEST_CASE("unbiased: on the Cornell box (a mirror ball and a glass ball) chapter 13 renders chapter 6's image")
{
  checkAgainstChapter6(kScenes + "/cornell.json", "--width 32 --height 24", 1024, 64, "bdpt_cornell", 1);
}

TEST_CASE("unbiased: on the caustic scene (a glass ball under a small lamp) chapter 13 renders chapter 6's image")
{
  // Chapter 6 finds the caustic only when a path from the floor passes through the ball and hits the lamp: its
  // estimate there is heavy-tailed, so the comparison is per block of 2 x 2 pixels, as for the original box.
  checkAgainstChapter6(kScenes + "/caustics.json", "--width 32 --height 24", 4096, 64, "bdpt_caustics", 2);
}

TEST_CASE("unbiased: in the mirror corner (light on the floor by one and two mirror bounces) chapter 13 renders "
          "chapter 6's image")
{
  // Two mirror walls meet behind a small lamp: the floor is lit by the lamp and by its three images in the mirrors.
  // A path floor -> mirror (-> mirror) -> lamp has delta vertices between the floor and the lamp, so next-event
  // estimation and every connection miss it: only s = 0 (chapter 6's chance hits) and light tracing make it, and
  // their weights must know which strategies a delta vertex rules out. Per 2 x 2 block, as for the caustic.
  checkAgainstChapter6(kScenes + "/mirror_corner.json", "--width 32 --height 24", 4096, 512, "bdpt_mirror_corner", 2);
}

TEST_CASE("unbiased: on the glossy box chapter 13 renders chapter 6's image")
{
  checkAgainstChapter6(kScenes + "/cornell_glossy.json", "--width 32 --height 24", 1024, 64, "bdpt_glossy", 1);
}

TEST_CASE("the test can fail: chapter 13 without its splats (t = 1 left out) is refused")
{
  // Every strategy but light tracing, each with its weight: the weights of the missing strategy are missing light.
  const std::string scene = kScenes + "/caustics.json", size = "--width 32 --height 24 --max-depth 2 ";
  const ChapterRender full = run(RAYLIFE_STEP13, scene, size + "--spp 32 --seed 5", "bdpt_full");
  Image partial(full.mean.width, full.mean.height), variance = partial;
  for (const auto& [s, t] : {std::pair{0, 2}, {0, 3}, {1, 2}, {0, 4}, {1, 3}, {2, 2}}) {
    const ChapterRender r = run(RAYLIFE_STEP13, scene,
                                size + "--spp 32 --seed 6 --strategy " + std::to_string(s) + "," + std::to_string(t),
                                "bdpt_part");
    for (std::size_t i = 0; i < partial.pixels.size(); ++i) {
      partial.pixels[i] += r.mean.pixels[i];
      variance.pixels[i] += r.variance.pixels[i];
    }
  }
  CHECK_FALSE(compare(partial, variance, full.mean, full.variance, "chapter 13 without light tracing (must fail)")
                  .passed());
}

TEST_CASE("the weighted images of the strategies (--strategy s,t) sum to the full image")
{
  // Paths of at most 3 edges (--max-depth 2): the strategies (s, t) with s + t − 1 ≤ 3, t ≥ 1 (and (0, 1), (1, 1),
  // which make nothing: a pinhole eye is never hit, and a light seen directly is the camera's own strategy).
  // Each run draws the same random numbers (same seed) and keeps one strategy's weighted light, so the sum is the
  // full image up to float rounding.
  const std::string scene = kScenes + "/cornell.json", args = "--width 24 --height 18 --max-depth 2 --spp 4 --seed 9";
  const ChapterRender full = run(RAYLIFE_STEP13, scene, args, "bdpt_sum_full");
  Image sum(full.mean.width, full.mean.height);
  for (int k = 1; k <= 3; ++k)
    for (int s = 0; s <= k; ++s) {
      const int t = k + 1 - s;
      const ChapterRender r = run(RAYLIFE_STEP13, scene,
                                  args + " --strategy " + std::to_string(s) + "," + std::to_string(t), "bdpt_sum");
      double total = 0;
      for (std::size_t i = 0; i < sum.pixels.size(); ++i) {
        sum.pixels[i] += r.mean.pixels[i];
        total += r.mean.pixels[i];
      }
      INFO("strategy " << s << "," << t);
      if (s == 1 && t == 1)
        CHECK(total == 0);
      else
        CHECK(total > 0); // every other strategy brings light in this scene
    }
  double worst = 0, fullTotal = 0;
  for (std::size_t i = 0; i < sum.pixels.size(); ++i) {
    worst = std::max(worst, std::abs(double(sum.pixels[i]) - double(full.mean.pixels[i])) /
                                std::max(1e-3, double(full.mean.pixels[i])));
    fullTotal += full.mean.pixels[i];
  }
  std::cout << "strategies summed against the full image: largest relative difference " << worst << "\n";
  CHECK(fullTotal > 0);
  CHECK(worst < 1e-4);
}

TEST_CASE("analytic: a floor under a spherical light, and the inside of an emitting sphere, for chapter 13")
{
  // Chapter 6's analytic scenes, through the same comparison as chapters 7 and 8 (test_lights_render.cpp) but here
  // against chapter 6, which is itself checked against the closed forms there: light paths bring the floor's light
  // by three strategies, the sphere's inside by all of them.
  checkAgainstChapter6(kScenes + "/analytic/area_light.json", "", 1024, 64, "bdpt_area", 1);
  checkAgainstChapter6(kScenes + "/analytic/inside_sphere.json", "", 256, 64, "bdpt_inside", 1);
  checkAgainstChapter6(kScenes + "/analytic/furnace_half.json", "", 64, 16, "bdpt_furnace", 1);
}

TEST_CASE("splats keep --time, --variance and --stats: a time budget renders whole passes")
{
  const ChapterRender r = run(RAYLIFE_STEP13, kScenes + "/caustics.json", "--width 32 --height 24 --time 0.5 --seed 3",
                              "bdpt_time");
  const double spp = statsValue(r.stats, "spp");
  CHECK(spp >= 1);
  double light = 0, variance = 0;
  for (std::size_t i = 0; i < r.mean.pixels.size(); ++i) {
    light += r.mean.pixels[i];
    variance += r.variance.pixels[i];
  }
  CHECK(light > 0);
  if (spp >= 2)
    CHECK(variance > 0);
}

TEST_CASE("each strategy alone - unweighted - renders the same image of the paths it can make (no delta surfaces)")
{
  // The check before MIS: in a box of diffuse and glossy surfaces only, every strategy (s, t) of paths of k = 3
  // edges (one bounce between the lamp and the surface seen) can make every such path, so each one alone, without
  // its weight, is an unbiased estimate of the same image. Compared per 2 x 2 block with next-event estimation.
  const std::string path = noDeltaBox("no_delta", false);
  const std::string args = "--width 32 --height 24 --spp 256 --unweighted --strategy ";
  const ChapterRender nee = run(RAYLIFE_STEP13, path, args + "1,3 --seed 21", "bdpt_u13");
  for (const auto& [s, t] : {std::pair{0, 4}, {2, 2}, {3, 1}}) {
    const std::string name = std::to_string(s) + "," + std::to_string(t);
    const ChapterRender r = run(RAYLIFE_STEP13, path, args + name + " --seed " + std::to_string(22 + s),
                                "bdpt_u" + std::to_string(s));
    const Verdict v = compare(r.mean, r.variance, nee.mean, nee.variance, "unweighted (" + name + ") against (1,3)",
                              nullptr, 2);
    if (s == 2) {
      // Joining two surface points weighs G = cos cos / r², unbounded where surfaces meet (the floor under a ball,
      // the corners): unweighted, (2, 2) has infinite variance there, its sample variance says too little, and its
      // pixels there fall short but for rare huge samples (at 1024 spp 4% of channels, all below). MIS is what tames
      // it; here only its image mean, which sums enough of those samples, is compared.
      CHECK(std::abs(v.worstTotalZ) <= kMaxTotalZ);
    } else {
      CHECK(v.passed());
    }
  }
  std::filesystem::remove(path);
}

// (No colon late in the name: Catch2 indents a name's further lines past its first colon, and asserts when that
// leaves no width.)
TEST_CASE("unweighted (2,2) renders (1,3)'s image on walls that place their points to 10^-2 (both ends of a "
          "connection leave their surfaces)")
{
  // The box above with walls of radius 10^14 (in the float build its own, 10^5): each wall's points are placed to
  // some 10^-2 units, more than a shadow ray's shortening by 10^-4 covers across the room. With the far end of a
  // connection left on its surface (spawnRayTo to a point), that surface blocked it: (2,2) came out 29 % dark in
  // double, 12 % in float. Both ends moved off (spawnRayTo(from, to)), it matches (1,3).
  const std::string path = noDeltaBox("huge_walls", true);
  const std::string args = "--width 32 --height 24 --spp 256 --unweighted --strategy ";
  const ChapterRender nee = run(RAYLIFE_STEP13, path, args + "1,3 --seed 31", "bdpt_h13");
  const ChapterRender r = run(RAYLIFE_STEP13, path, args + "2,2 --seed 32", "bdpt_h22");
  const Verdict v = compare(r.mean, r.variance, nee.mean, nee.variance, "huge walls: unweighted (2,2) against (1,3)",
                            nullptr, 2);
  CHECK(std::abs(v.worstTotalZ) <= kMaxTotalZ); // (only the image mean: see the test above)
  std::filesystem::remove(path);
}

TEST_CASE("a bad --strategy or --unweighted alone exits with status 2 and writes nothing")
{
  namespace fs = std::filesystem;
  const fs::path out = fs::temp_directory_path() / ("raylife_bdpt_bad_" + std::to_string(::getpid()) + ".png");
  for (const char* args : {"--strategy 1", "--strategy 1,0", "--strategy -1,2", "--strategy 1,2x",
                           "--strategy a,b", "--unweighted", "--unweighted --strategy"}) {
    const std::string command = "'" + std::string(RAYLIFE_STEP13) + "' --width 8 --height 6 --quiet -o '" +
                                out.string() + "' " + std::string(args) + " 2>/dev/null";
    const int status = std::system(command.c_str());
    INFO(args);
    CHECK(WIFEXITED(status));
    CHECK(WEXITSTATUS(status) == 2);
    CHECK_FALSE(fs::exists(out));
  }
}

TEST_CASE("unbiased: on the original Cornell box (triangles - a quad lamp) chapter 13 renders chapter 6's image")
{
  // Triangle lights: light subpaths leave either face of the lamp's two triangles. Per 2 x 2 block, as chapters 7
  // and 8 are compared on this box: chapter 6 finds the small lamp rarely.
  checkAgainstChapter6(kScenes + "/cornell_original.json", "--width 32 --height 32", 2048, 64, "bdpt_original", 2);
}

// Chapters 11 and 12 as students run them (their executables, through run_chapter.h): ambient occlusion against
// its closed forms, velocity 0 and aperture 0 against the still pinhole render, and both chapters' goldens (a
// per-pixel z-test against a converged reference, as chapters 7 and 8's: tests/lights/compare_renders.h).
#include "../analytic/run_chapter.h"
#include "../lights/compare_renders.h"

#include <catch2/catch.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>

using namespace raylife;
using namespace raylife::test;

namespace {

const std::string kScenes = RAYLIFE_SCENES;
const std::string kGolden = RAYLIFE_DISTRIBUTED_GOLDEN;

// Ambient occlusion's image against a constant expectation: every pixel sees the surface whose AO is `expected`.
// Each sample is 0 or 1, so the image mean's standard error is √(AO(1 − AO)/samples).
void checkConstantAo(const std::string& scene, const std::string& args, double expected, const std::string& tag)
{
  const ChapterRender r = run(RAYLIFE_STEP12, kScenes + "/" + scene, args, tag);
  const int spp = int(statsValue(r.stats, "spp"));
  double sum = 0, lo = 1, hi = 0;
  for (float v : r.mean.pixels) {
    sum += v;
    lo = std::min(lo, double(v));
    hi = std::max(hi, double(v));
  }
  const double n = double(r.mean.pixels.size() / 3) * spp;
  const double mean = sum / double(r.mean.pixels.size());
  const double stdError = std::sqrt(std::max(expected * (1 - expected), 1e-12) / n);
  std::cout << tag << ": ambient occlusion " << mean << " (pixels " << lo << " to " << hi << "), expected " << expected
            << ", z = " << (mean - expected) / stdError << "\n";
  if (expected == 0 || expected == 1) { // exact: no sample may differ
    CHECK(lo == expected);
    CHECK(hi == expected);
  } else {
    CHECK(std::abs(mean - expected) < 4 * stdError);
  }
}

std::string readBytes(const std::string& path)
{
  std::ifstream in(path, std::ios::binary);
  std::stringstream bytes;
  bytes << in.rdbuf();
  return bytes.str();
}

} // namespace

// ---- Ambient occlusion: closed forms ----------------------------------------------------------------------------

TEST_CASE("ambient occlusion: an open plane is exactly 1, the inside of a closed sphere exactly 0")
{
  checkConstantAo("analytic/ao_plane.json", "--spp 16 --seed 1", 1, "ao plane");
  checkConstantAo("analytic/inside_sphere.json", "--width 32 --height 24 --spp 16 --seed 2", 0, "ao inside sphere");
}

TEST_CASE("ambient occlusion: a floor point beside an infinite wall (a huge sphere) is 0.5")
{
  checkConstantAo("analytic/ao_wall.json", "--spp 64 --seed 3", 0.5, "ao beside a wall");
}

// [double]: the float build places this scene's planes, spheres of radius 10^5, to some 10^-2 (its spacing there
// is 2^-7), and the share of directions that meet the ceiling within D moves by some z = 5 to 10 of this test's.
TEST_CASE("ambient occlusion: under a plane at height h, --ao-distance D gives (h/D)^2 (and 1 for D <= h)", "[double]")
{
  // A direction at angle θ from the normal meets the plane at distance h/cosθ: it counts as open when h/cosθ ≥ D,
  // i.e. cosθ ≤ h/D, and cosine-weighted directions have P(cosθ ≤ c) = c². Here h = 1.
  for (const double D : {1.25, 2.0, 4.0})
    checkConstantAo("analytic/ao_ceiling.json", "--spp 64 --seed 4 --ao-distance " + std::to_string(D),
                    (1 / D) * (1 / D), "ao under a plane, D = " + std::to_string(D));
  checkConstantAo("analytic/ao_ceiling.json", "--spp 16 --seed 5 --ao-distance 0.9", 1, "ao under a plane, D < h");
  // Unbounded: the plane closes the hemisphere (the huge sphere curves away only within ~5e-3 rad of the horizon,
  // a cosine-weighted share of ~2e-5).
  const ChapterRender r = run(RAYLIFE_STEP12, kScenes + "/analytic/ao_ceiling.json", "--spp 64 --seed 6", "ao closed");
  double sum = 0;
  for (float v : r.mean.pixels)
    sum += v;
  CHECK(sum / double(r.mean.pixels.size()) < 1e-3);
}

// ---- Nothing changes without a lens or motion ----------------------------------------------------------------

TEST_CASE("velocity 0 and aperture 0 render byte for byte as the scene without them (chapters 6 and 11)")
{
  namespace fs = std::filesystem;
  const fs::path dir = fs::temp_directory_path() / ("raylife_test_still_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  std::string text = readBytes(kScenes + "/cornell.json");
  const std::string plain = (dir / "plain.json").string(), zero = (dir / "zero.json").string();
  std::ofstream(plain) << text;
  // The same scene with "aperture": 0 and every sphere given "velocity": [0, 0, 0].
  std::string withZeros = text;
  withZeros.replace(withZeros.find("\"vfov\""), 6, "\"aperture\": 0, \"vfov\"");
  for (std::size_t at = withZeros.find("\"material\""); at != std::string::npos;
       at = withZeros.find("\"material\"", at + 40))
    withZeros.replace(at, 10, "\"velocity\": [0, 0, 0], \"material\"");
  std::ofstream(zero) << withZeros;
  for (const std::string& binary : {std::string(RAYLIFE_STEP06), std::string(RAYLIFE_STEP11)}) {
    const std::string a = (dir / "a.pfm").string(), b = (dir / "b.pfm").string();
    const std::string options = "' --quiet --width 32 --height 24 --spp 8 -o '";
    REQUIRE(std::system(("'" + binary + "' '" + plain + options + a + "'").c_str()) == 0);
    REQUIRE(std::system(("'" + binary + "' '" + zero + options + b + "'").c_str()) == 0);
    CHECK(readBytes(a) == readBytes(b));
  }
  fs::remove_all(dir);
}

// ---- Goldens ----------------------------------------------------------------------------------------------------

TEST_CASE("golden: chapter 11 on its scene with another seed passes the z-test against its reference")
{
  const ChapterRender r = run(RAYLIFE_STEP11, kScenes + "/distributed.json",
                              "--width 64 --height 48 --spp 256 --seed 1234", "golden11");
  CHECK(compare(r.mean, r.variance, readPfm(kGolden + "/step11_distributed_64x48.pfm"),
                readPfm(kGolden + "/step11_distributed_64x48_variance.pfm"), "golden, chapter 11")
            .passed());
}

TEST_CASE("golden: chapter 12 on its scene with another seed passes the z-test against its reference")
{
  const ChapterRender r = run(RAYLIFE_STEP12, kScenes + "/meshes.json", "--width 64 --height 64 --spp 256 --seed 1234",
                              "golden12");
  CHECK(compare(r.mean, r.variance, readPfm(kGolden + "/step12_ambient_occlusion_64x64.pfm"),
                readPfm(kGolden + "/step12_ambient_occlusion_64x64_variance.pfm"), "golden, chapter 12")
            .passed());
}

TEST_CASE("golden: the test fails chapter 11's scene without its lens, or without its motion (the test can fail)")
{
  namespace fs = std::filesystem;
  const fs::path dir = fs::temp_directory_path() / ("raylife_test_controls_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const std::string text = readBytes(kScenes + "/distributed.json");
  for (const auto& [key, what] : {std::pair{std::string("\"aperture\": 2.5"), std::string("aperture 0")},
                                  std::pair{std::string("\"velocity\": [16, 0, 0]"), std::string("velocity 0")}}) {
    std::string changed = text;
    const std::size_t at = changed.find(key);
    REQUIRE(at != std::string::npos);
    changed.replace(at, key.size(), key.substr(0, key.find(':')) + (what == "aperture 0" ? ": 0" : ": [0, 0, 0]"));
    const std::string scene = (dir / "control.json").string();
    std::ofstream(scene) << changed;
    const ChapterRender r = run(RAYLIFE_STEP11, scene, "--width 64 --height 48 --spp 256 --seed 1234", "control11");
    CHECK_FALSE(compare(r.mean, r.variance, readPfm(kGolden + "/step11_distributed_64x48.pfm"),
                        readPfm(kGolden + "/step11_distributed_64x48_variance.pfm"), "control, chapter 11 with " + what)
                    .passed());
  }
  fs::remove_all(dir);
  // Chapter 12 with a distance that cuts the occlusion.
  const ChapterRender cut = run(RAYLIFE_STEP12, kScenes + "/meshes.json",
                                "--width 64 --height 64 --spp 256 --seed 1234 --ao-distance 100", "control12");
  CHECK_FALSE(compare(cut.mean, cut.variance, readPfm(kGolden + "/step12_ambient_occlusion_64x64.pfm"),
                      readPfm(kGolden + "/step12_ambient_occlusion_64x64_variance.pfm"), "control, --ao-distance 100")
                  .passed());
}

// ---- The path tracers with a lens, motion and metal ----------------------------------------------------------

TEST_CASE("unbiased: with the lens, a moving sphere, a moving lamp and GGX metal, chapters 6 7 and 8 agree")
{
  // Chapter 6 finds the lamp only by BSDF sampling; chapter 7 samples it where it is at the ray's time, chapter 8
  // weighs the two by the metal's pdf and the light's. A sampler or a pdf at the wrong time or of the wrong lobe
  // shows as a difference.
  namespace fs = std::filesystem;
  std::string text = readBytes(kScenes + "/distributed.json");
  const std::string lamp = R"("radius": 9,      "material": "lamp" })";
  const std::size_t at = text.find(lamp);
  REQUIRE(at != std::string::npos);
  text.replace(at, lamp.size(), R"("radius": 9, "material": "lamp", "velocity": [-35, -10, 30] })");
  const fs::path path = fs::temp_directory_path() / ("raylife_distributed_" + std::to_string(::getpid()) + ".json");
  std::ofstream(path) << text;
  const std::string size = "--width 32 --height 24";
  const ChapterRender c6 = run(RAYLIFE_STEP06, path.string(), size + " --spp 1024 --seed 61", "dist6");
  const ChapterRender c7 = run(RAYLIFE_STEP07, path.string(), size + " --spp 256 --seed 71", "dist7");
  const ChapterRender c8 = run(RAYLIFE_STEP08, path.string(), size + " --spp 256 --seed 81", "dist8");
  // The control: the lamp left still (where a light sampler blind to time would look for it).
  const ChapterRender still = run(RAYLIFE_STEP07, kScenes + "/distributed.json", size + " --spp 256 --seed 72", "still7");
  fs::remove(path);
  CHECK(compare(c7.mean, c7.variance, c6.mean, c6.variance, "distributed: chapter 7 against chapter 6").passed());
  CHECK(compare(c8.mean, c8.variance, c6.mean, c6.variance, "distributed: chapter 8 against chapter 6").passed());
  CHECK(compare(c8.mean, c8.variance, c7.mean, c7.variance, "distributed: chapter 8 against chapter 7").passed());
  CHECK_FALSE(compare(still.mean, still.variance, c6.mean, c6.variance, "distributed: the lamp still, against chapter 6 "
                                                                        "(control, must fail)")
                  .passed());
}

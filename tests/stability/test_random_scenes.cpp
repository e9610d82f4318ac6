// Case 12 (every chapter) — random hostile scenes render cleanly or are refused in one line.
//
// Setup: 40 scenes drawn from a fixed seed, each at a scale of its own (10^±40 in double, 10^±6 in float: the same
// scene at another size, point lights' intensities scaled by the square so that the radiance stays the same), with
// what scene files can hold at its edges: glossy roughness down to 1e-300, metal roughness 0, indices of refraction
// from 1 to 1e40, subnormal and exactly 0 or 1 colours, fields of view of 1e-6 and 179.9 degrees, lenses, moving
// spheres, a floor 10^5 times the scene's size, slivers, degenerate and transformed meshes, cameras inside spheres;
// and in a tenth of them one value past a bound (a coordinate, a radius or an ior of 1e60). Every chapter (1 to 16)
// renders each at its own tiny size, 2 samples a pixel. Pass criterion: exit status 0 with no bad sample and no
// NaN, infinite or negative pixel, or exit status 1 with one line naming the file and nothing written; every chapter
// takes the same side for a scene (they share the loader), within 120 s. A first run of 1,000 such scenes through
// the sanitized build found glossy's NaN below roughness 1e-9 and the loader's missing bounds on size and ior
// (docs/robustness.md, case 12); on the code before those fixes this case fails on scene 18 (roughness 1e-300).
// A second set of 40 scenes carries media, in chapters 8, 13 and 15 (the last test below); in the float build its
// scene 27 gave chapter 13 NaN weights before its MIS sums were reckoned in double. 400 scenes of each kind (other
// seeds) found, in the float build, that an ior of 1e20 squared to infinity in ten chapters: the float build's bound
// on the index is now 1e10 (kMaxIorFloat).
#include "run_chapter.h"
#include "support.h"

#include <catch2/catch.hpp>

#include <algorithm>
#include <array>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <limits>
#include <regex>
#include <span>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

using namespace raylife;
using namespace raylife::stability;

namespace {

const std::array<const char*, 16> kChapters = {
    "step01_camera",         "step02_sphere", "step03_lambert", "step04_shadows",     "step05_whitted",
    "step06_path_tracer",    "step07_light_sampling",          "step08_mis",         "step09_bvh",
    "step10_meshes",         "step11_distributed",             "step12_ambient_occlusion",
    "step13_bdpt",           "step14_textures",                "step15_volumes",     "step16_wavefront"};
// The chapters that read media: chapter 15 renders them, chapters 8 and 13 say once that they ignore them.
const std::array<const char*, 3> kMediaChapters = {"step08_mis", "step13_bdpt", "step15_volumes"};

// Writes random scenes as JSON text. Every number is printed with 17 digits, so the file holds what was drawn.
class SceneWriter {
public:
  explicit SceneWriter(std::uint64_t seed) : rng_(seed) {}

  /// With media: scene k's density files are `stem` k "_f0.json", ... (beside the scene, which names them).
  SceneWriter(std::uint64_t seed, std::string stem) : rng_(seed), media_(true), stem_(std::move(stem)) {}

  std::string scene()
  {
    const bool single = sizeof(Real) == 4;
    scale_ = std::pow(10.0, rng_.uniform(single ? -6 : -40, single ? 6 : 40));
    std::ostringstream out;
    out << std::setprecision(17) << "{\n  \"camera\": " << camera() << ",\n";
    if (chance(0.6))
      out << "  \"background\": " << color() << ",\n";
    if (chance(0.4))
      out << "  \"ambient\": " << color() << ",\n";
    densityFiles_.clear();
    ++scenes_;
    const int materials = 1 + int(rng_.uniform() * 5);
    out << "  \"materials\": {";
    for (int m = 0; m < materials; ++m)
      out << (m ? ", " : "") << "\n    \"m" << m << "\": " << material();
    if (media_)
      out << ",\n    \"boundary\": { \"type\": \"interface\" }";
    out << "\n  },\n";
    media_count_ = media_ ? 1 + int(rng_.uniform() * 3) : 0;
    if (media_) {
      out << "  \"media\": {";
      for (int m = 0; m < media_count_; ++m)
        out << (m ? ", " : "") << "\n    \"f" << m << "\": " << medium(m);
      out << "\n  },\n";
      if (chance(0.2))
        out << "  \"medium\": \"f" << int(rng_.uniform() * media_count_) << "\",\n";
    }
    out << "  \"spheres\": [";
    static const int kSphereCounts[] = {1, 2, 3, 5, 12};
    const int spheres = kSphereCounts[int(rng_.uniform() * 5)];
    for (int s = 0; s < spheres; ++s)
      out << (s ? "," : "") << "\n    " << sphere(materials);
    out << "\n  ]";
    if (const int meshes = media_ ? 0 : int(rng_.uniform() * 3); meshes > 0) {
      out << ",\n  \"meshes\": [";
      for (int m = 0; m < meshes; ++m)
        out << (m ? "," : "") << "\n    " << mesh(materials);
      out << "\n  ]";
    }
    if (chance(0.4)) {
      out << ",\n  \"lights\": [";
      const int lights = 1 + int(rng_.uniform() * 2);
      for (int l = 0; l < lights; ++l)
        out << (l ? ", " : "") << "{ \"type\": \"point\", \"position\": " << point()
            << ", \"intensity\": " << uniformVec(0, 10, scale_ * scale_) << " }";
      out << "]";
    }
    out << "\n}\n";
    // A tenth of the scenes carry one value past a bound (when the scene has the key): the loader must refuse them.
    std::string text = out.str();
    if (chance(0.1)) {
      static const std::array<std::pair<const char*, const char*>, 3> kPast = {{
          {R"("radius": [^,}]+)", R"("radius": 1e60)"},
          {R"("ior": [^,}]+)", R"("ior": 1e60)"},
          {R"("center": \[[^\]]*\])", R"("center": [0, 1e60, 0])"},
      }};
      // With media: a phase function's g of 1, a negative coefficient, or a density grid too thick to cross.
      static const std::array<std::pair<const char*, const char*>, 3> kPastMedia = {{
          {R"("g": [^,}]+)", R"("g": 1)"},
          {R"("sigma_a": (\[[^\]]*\]|[^,}]+))", R"("sigma_a": -1)"},
          {R"("sigma_s": (\[[^\]]*\]|[^,}]+))", R"("sigma_s": 1e300)"}, // (refused where it has a density grid)
      }};
      const auto& [from, to] = media_ ? pick(kPastMedia) : pick(kPast);
      text = std::regex_replace(text, std::regex(from), to, std::regex_constants::format_first_only);
    }
    return text;
  }

  /// The density files the last scene names, as (path, JSON text).
  const std::vector<std::pair<std::string, std::string>>& densityFiles() const { return densityFiles_; }

private:
  bool chance(double p) { return rng_.uniform() < p; }
  template <class T, std::size_t N> T pick(const std::array<T, N>& values)
  {
    return values[std::size_t(rng_.uniform() * N)];
  }
  static std::string vec(double x, double y, double z)
  {
    std::ostringstream out;
    out << std::setprecision(17) << "[" << x << ", " << y << ", " << z << "]";
    return out.str();
  }
  // Three numbers uniform in [lo, hi) times `factor`, drawn in order (a call's arguments are evaluated in an order
  // C++ leaves open, and the scenes must not depend on the compiler).
  std::string uniformVec(double lo, double hi, double factor)
  {
    const double x = rng_.uniform(lo, hi) * factor, y = rng_.uniform(lo, hi) * factor;
    return vec(x, y, rng_.uniform(lo, hi) * factor);
  }
  // A point of the scene: within 10 of the origin, in scene sizes, or exactly at the origin.
  std::string point() { return chance(0.1) ? "[0, 0, 0]" : uniformVec(-10, 10, scale_); }
  double channel()
  {
    static constexpr std::array<double, 5> kEdges = {0, 1, 1 - 1e-16, 1e-300, std::numeric_limits<float>::denorm_min()};
    return chance(0.3) ? pick(kEdges) : rng_.uniform();
  }
  std::string color()
  {
    const double r = channel(), g = channel();
    return vec(r, g, channel());
  }

  std::string camera()
  {
    std::ostringstream out;
    out << std::setprecision(17);
    static constexpr std::array<const char*, 4> kUps = {"[0, 1, 0]", "[0, 0, 1]", "[1, 1e-3, 0]", "[0.3, 0.9, -0.2]"};
    static constexpr std::array<double, 4> kFov = {40, 1e-6, 179.9, 90};
    out << "{ \"eye\": " << point() << ", \"focal\": " << point() << ", \"up\": " << pick(kUps)
        << ", \"vfov\": " << (chance(0.5) ? rng_.uniform(1, 170) : pick(kFov))
        << ", \"width\": " << 1 + int(rng_.uniform() * 8) << ", \"height\": " << 1 + int(rng_.uniform() * 8);
    if (chance(0.3))
      out << ", \"aperture\": " << rng_.uniform(0, 2) * scale_;
    if (chance(0.2))
      out << ", \"focus\": " << rng_.logUniform(1e-3, 100) * scale_;
    if (media_ && chance(0.1))
      out << ", \"medium\": " << (chance(0.5) ? "null" : "\"f0\"");
    out << " }";
    return out.str();
  }

  std::string material()
  {
    static constexpr std::array<const char*, 6> kTypes = {"diffuse", "diffuse", "mirror", "glass", "glossy", "metal"};
    const std::string type = pick(kTypes);
    std::ostringstream out;
    out << std::setprecision(17) << "{ \"type\": \"" << type << "\", \"color\": " << color();
    if (chance(0.3))
      out << ", \"emission\": " << uniformVec(0, 10, 1);
    if (type == "glass") {
      static constexpr std::array<double, 7> kIor = {1, 1 + 1e-15, 1.5, 2.42, 1e3, 1e20, 1e40};
      out << ", \"ior\": " << (chance(0.3) ? rng_.uniform(1, 3) : pick(kIor));
    }
    if (type == "glossy" || type == "metal") {
      static constexpr std::array<double, 7> kRoughness = {1, 1e-3, 0.999e-3, 1e-10, 1e-30, 1e-300, 0.5};
      const double r = chance(0.3) ? rng_.uniform() : pick(kRoughness);
      out << ", \"roughness\": " << (type == "metal" && chance(0.2) ? 0.0 : (r > 0 ? r : 0.5));
    }
    out << " }";
    return out.str();
  }

  std::string sphere(int materials)
  {
    std::ostringstream out;
    out << std::setprecision(17);
    if (chance(0.15)) // a floor far larger than the rest
      out << "{ \"center\": " << vec(0, -1e5 * scale_, 0) << ", \"radius\": " << 1e5 * scale_;
    else
      out << "{ \"center\": " << point() << ", \"radius\": " << rng_.logUniform(1e-4, 1e2) * scale_;
    if (media_count_ > 0 && chance(0.5)) { // a medium's boundary: an interface, or a surface with media either side
      out << ", \"material\": \"";
      if (chance(0.7))
        out << "boundary";
      else
        out << "m" << int(rng_.uniform() * materials);
      out << "\", \"interior\": \"f" << int(rng_.uniform() * media_count_) << "\"";
      if (chance(0.3)) {
        out << ", \"exterior\": ";
        if (chance(0.3))
          out << "null";
        else
          out << "\"f" << int(rng_.uniform() * media_count_) << "\"";
      }
    } else {
      out << ", \"material\": \"m" << int(rng_.uniform() * materials) << "\"";
    }
    if (chance(0.1))
      out << ", \"velocity\": " << point();
    out << " }";
    return out.str();
  }

  std::string mesh(int materials)
  {
    const int vertices = 3 + int(rng_.uniform() * 6);
    const bool sliver = chance(0.2);
    std::ostringstream out;
    out << std::setprecision(17) << "{ \"material\": \"m" << int(rng_.uniform() * materials) << "\", \"vertices\": [";
    for (int v = 0; v < vertices; ++v) {
      // A sliver's corners lie within 1e-12 of the scene's size of a line.
      const double t = rng_.uniform(-10, 10), off = rng_.uniform(-1e-12, 1e-12);
      out << (v ? ", " : "") << (sliver ? vec(t * scale_, t * scale_ * (1 + off), 0.5 * scale_) : point());
    }
    out << "], \"triangles\": [";
    // Mostly three different corners; a fifth of the triangles are any three (degenerate when one repeats).
    const int triangles = 1 + int(rng_.uniform() * 6);
    for (int k = 0; k < triangles; ++k) {
      int a = int(rng_.uniform() * vertices), b = int(rng_.uniform() * vertices);
      int c = int(rng_.uniform() * vertices);
      if (chance(0.8)) {
        b = (a + 1 + int(rng_.uniform() * (vertices - 1))) % vertices;
        do
          c = int(rng_.uniform() * vertices);
        while (c == a || c == b);
      }
      out << (k ? ", " : "") << "[" << a << ", " << b << ", " << c << "]";
    }
    out << "]";
    if (chance(0.2)) {
      out << ", \"smooth\": true, \"normals\": [";
      for (int v = 0; v < vertices; ++v)
        out << (v ? ", " : "") << uniformVec(-1, 1, 1);
      out << "]";
    }
    if (chance(0.2)) {
      const double scale = rng_.logUniform(1e-3, 1e3);
      const std::string axis = uniformVec(-1, 1, 1);
      const double degrees = rng_.uniform(-720, 720);
      out << ", \"transform\": { \"scale\": " << scale << ", \"rotate\": { \"axis\": " << axis
          << ", \"degrees\": " << degrees << " }, \"translate\": " << point() << " }";
    }
    out << " }";
    return out.str();
  }

  // A coefficient per unit length: mostly an optical depth of 1e-3 to 1e3 across the scene's size (1e-3 to 1e2
  // under a density grid, whose tracking steps through it), sometimes 0, subnormal or 1e6 (not under a grid); a
  // number or a colour.
  std::string coefficient(bool gridded)
  {
    auto one = [&] {
      static constexpr std::array<double, 4> kEdges = {0, 1e-300, std::numeric_limits<float>::denorm_min(), 1e6};
      const double edge = pick(kEdges);
      const bool atEdge = chance(0.2) && !(gridded && edge > 1);
      return atEdge ? edge / scale_ : rng_.logUniform(1e-3, gridded ? 1e2 : 1e3) / scale_;
    };
    if (chance(0.5)) {
      std::ostringstream out;
      out << std::setprecision(17) << one();
      return out.str();
    }
    const double r = one(), g = one();
    return vec(r, g, one());
  }

  // Medium f<index>: coefficients, g at its edges or within them, and in half of them a density grid over a box
  // of the scene's size, whose file this writes (values 0, subnormal or up to 10; 1 to 5 cells an axis).
  std::string medium(int index)
  {
    static constexpr std::array<double, 5> kG = {0, 0.999999, -0.999999, 0.9, -0.5};
    const bool gridded = chance(0.5);
    std::ostringstream out;
    const std::string sigmaA = coefficient(gridded);
    out << std::setprecision(17) << "{ \"sigma_a\": " << sigmaA << ", \"sigma_s\": " << coefficient(gridded)
        << ", \"g\": " << (chance(0.5) ? pick(kG) : rng_.uniform(-0.99, 0.99));
    if (gridded) {
      const std::string file = stem_ + std::to_string(scenes_ - 1) + "_f" + std::to_string(index) + ".json";
      static constexpr std::array<const char*, 2> kMajorants = {"grid", "global"};
      out << ", \"density\": { \"file\": \"" << std::filesystem::path(file).filename().string()
          << "\", \"majorant\": \"" << pick(kMajorants) << "\", \"majorant_cells\": " << 1 + int(rng_.uniform() * 40)
          << " }";
      const int n[3] = {1 + int(rng_.uniform() * 5), 1 + int(rng_.uniform() * 5), 1 + int(rng_.uniform() * 5)};
      const double x = rng_.uniform(-10, 10) * scale_, y = rng_.uniform(-10, 10) * scale_;
      const double z = rng_.uniform(-10, 10) * scale_, half = rng_.logUniform(0.1, 10) * scale_;
      std::ostringstream grid;
      grid << std::setprecision(17) << "{\"resolution\": [" << n[0] << ", " << n[1] << ", " << n[2]
           << "], \"bounds\": [" << vec(x - half, y - half, z - half) << ", " << vec(x + half, y + half, z + half)
           << "], \"density\": [";
      static constexpr std::array<double, 4> kValues = {0, std::numeric_limits<float>::denorm_min(), 1e-30, 10};
      for (int k = 0; k < n[0] * n[1] * n[2]; ++k)
        grid << (k ? ", " : "") << (chance(0.3) ? pick(kValues) : rng_.uniform(0, 2));
      grid << "]}\n";
      densityFiles_.emplace_back(file, grid.str());
    }
    out << " }";
    return out.str();
  }

  TestRng rng_;
  double scale_ = 1;
  bool media_ = false;
  std::string stem_;
  int scenes_ = 0;
  int media_count_ = 0;
  std::vector<std::pair<std::string, std::string>> densityFiles_;
};

// Writes `count` scenes from `writer` into the output folder as NAME_k.json (a media writer's density files beside
// them) and renders each with every one of `chapters` at 2 samples a pixel. Each must exit 0 with no bad sample and
// no bad pixel, or 1 with, as its last line, one line naming the file and no image; every chapter takes the same side
// for a scene with the same message (they share the loader). Returns how many scenes rendered and were refused.
std::pair<int, int> renderRandomScenes(SceneWriter& writer, int count, const std::string& name,
                                       std::span<const char* const> chapters)
{
  int rendered = 0, refused = 0;
  for (int k = 0; k < count; ++k) {
    const std::string stem = std::string(RAYLIFE_STABILITY_OUT_DIR) + "/" + name + "_" + std::to_string(k);
    const std::string text = writer.scene();
    std::ofstream(stem + ".json") << text;
    for (const auto& [path, grid] : writer.densityFiles())
      std::ofstream(path) << grid;
    INFO("scene " << k << " (" << stem << ".json):\n" << text);
    int sceneStatus = -1;
    std::string firstMessage;
    for (const char* chapter : chapters) {
      const std::string tag = name + "_" + std::to_string(k) + "_" + chapter;
      const ChapterRun run = runChapter(chapter, stem + ".json", tag, "--spp 2");
      INFO(chapter << ": exit status " << run.status << ", standard error:\n" << run.err);
      REQUIRE((run.status == 0 || run.status == 1));
      if (sceneStatus == -1)
        sceneStatus = run.status;
      CHECK(run.status == sceneStatus);
      if (run.status == 1) {
        // One line naming the file (warnings before it are lines of their own), and no image.
        const std::string& err = run.err;
        const std::size_t last = err.rfind('\n', err.size() - 2);
        const std::string line = err.substr(last == std::string::npos ? 0 : last + 1);
        CHECK(line.rfind(std::string(chapter) + ": " + stem + ".json:", 0) == 0);
        CHECK(std::count(line.begin(), line.end(), '\n') == 1);
        CHECK_FALSE(std::filesystem::exists(std::filesystem::path(RAYLIFE_STABILITY_OUT_DIR) / (tag + ".pfm")));
        const std::string message = line.substr(line.find(": ") + 2);
        if (firstMessage.empty())
          firstMessage = message;
        CHECK(message == firstMessage);
      } else {
        CHECK(run.badSamples == 0);
        CHECK(badPixels(run.image) == 0);
      }
    }
    (sceneStatus == 0 ? rendered : refused) += 1;
  }
  return {rendered, refused};
}

} // namespace

TEST_CASE("stability 12: random hostile scenes render cleanly or are refused in one line, in every chapter",
          "[stability][random]")
{
  constexpr int kScenes = 40;
  SceneWriter writer(20261203);
  const auto [rendered, refused] = renderRandomScenes(writer, kScenes, "random", kChapters);
  printFigure("random scenes: " + std::to_string(kScenes) + " x " + std::to_string(kChapters.size()) +
              " chapters: " + std::to_string(rendered) + " rendered clean, " + std::to_string(refused) +
              " refused in one line");
  CHECK(rendered >= kScenes / 2); // the generator must mostly make scenes that load, or it tests only the loader
  CHECK(refused >= 2);
}

TEST_CASE("stability 12: random hostile scenes with media render cleanly or are refused in one line",
          "[stability][random][media]")
{
  // Scenes of the same kind from another seed, with media: one to three, homogeneous or over a density grid (its
  // file beside the scene), coefficients from 0 and subnormal to 1e6 per unit of the scene's size, g to within 1e-6
  // of ±1, spheres bounding them as interfaces or as surfaces, a medium everywhere, the camera in one; in a tenth,
  // g = 1, a negative coefficient or sigma_s = 1e300 (refused over a density grid, which could not be crossed).
  constexpr int kScenes = 40;
  SceneWriter writer(20261206, std::string(RAYLIFE_STABILITY_OUT_DIR) + "/random_media_");
  const auto [rendered, refused] = renderRandomScenes(writer, kScenes, "random_media", kMediaChapters);
  printFigure("random scenes with media: " + std::to_string(kScenes) + " x " + std::to_string(kMediaChapters.size()) +
              " chapters: " + std::to_string(rendered) + " rendered clean, " + std::to_string(refused) +
              " refused in one line");
  CHECK(rendered >= kScenes / 2);
  CHECK(refused >= 2);
}

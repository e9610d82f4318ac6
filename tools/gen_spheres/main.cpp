// gen_spheres: writes a random-spheres scene of N spheres, in the manner of the final scene of "Ray Tracing in One
// Weekend": a huge ground sphere, three big spheres (glass, diffuse, metal), and small spheres of mixed materials
// scattered over a grid of unit cells around them. The same N and SEED always give the same file.
//
// usage: gen_spheres N SEED [--diffuse] > scene.json      (N ≥ 1 spheres in all, the ground included)
//        gen_spheres clutter BASE.json N SEED X0 Y0 Z0 X1 Y1 Z1 > scene.json
//
// scenes/random_spheres.json is `gen_spheres 500 1`; the scaling runs of chapter 9 use N = 10 … 100,000.
// The second form writes BASE.json with N small diffuse spheres (radius 0.3 to 1.5) added, their centres uniform in
// the box [X0, X1] × [Y0, Y1] × [Z0, Z1]: clutter where the scene's rays may never go, such as 20,000 spheres behind
// smallpt's back wall (docs/09_bvh.md: huge primitives stay out of the tree):
//   gen_spheres clutter scenes/smallpt.json 20000 1 1 1 -100 99 80 -2 > /tmp/smallpt_clutter.json
#include "core/rng.h"

#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <cstdlib>
#include <string>
#include <vector>

using namespace raylife;

namespace {

class Random {
public:
  explicit Random(std::uint64_t seed) : rng_(seed, 0x2545f4914f6cdd1dULL) {}
  double uniform() { return double(rng_.nextUint()) * 0x1p-32; } // [0, 1)
  double uniform(double lo, double hi) { return lo + (hi - lo) * uniform(); }

private:
  Pcg32 rng_;
};

struct PaletteEntry {
  std::string json; // the material's value in the scene file
  bool used = false;
};

struct Ball {
  double x, y, z, r;
  int material;
};

bool parseCount(const char* text, long long lo, long long hi, long long& out)
{
  char* end = nullptr;
  out = std::strtoll(text, &end, 10);
  return *text && *end == '\0' && out >= lo && out <= hi;
}

std::string color(double r, double g, double b)
{
  char buffer[96];
  std::snprintf(buffer, sizeof buffer, "[%.3f, %.3f, %.3f]", r, g, b);
  return buffer;
}

// The second form (see the top of the file).
int clutter(int argc, char** argv)
{
  long long n = 0, seed = 0;
  double box[6];
  bool ok = argc == 11 && parseCount(argv[3], 1, 10000000, n) && parseCount(argv[4], 0, 1LL << 62, seed);
  for (int i = 0; ok && i < 6; ++i) {
    char* end = nullptr;
    box[i] = std::strtod(argv[5 + i], &end);
    ok = *argv[5 + i] && *end == '\0' && std::isfinite(box[i]);
  }
  if (!ok || box[0] > box[3] || box[1] > box[4] || box[2] > box[5]) {
    std::fprintf(stderr, "usage: gen_spheres clutter BASE.json N SEED X0 Y0 Z0 X1 Y1 Z1 > scene.json   (1 <= N, "
                         "X0 <= X1, Y0 <= Y1, Z0 <= Z1)\n");
    return 2;
  }
  std::ifstream in(argv[2]);
  nlohmann::ordered_json scene = nlohmann::ordered_json::parse(in, nullptr, false);
  if (!in || scene.is_discarded() || !scene.is_object() || !scene["materials"].is_object()) {
    std::fprintf(stderr, "gen_spheres: %s: cannot read it as a scene (JSON with \"materials\")\n", argv[2]);
    return 1;
  }
  scene["materials"]["clutter"] = {{"type", "diffuse"}, {"color", {0.5, 0.5, 0.5}}};
  Random random{std::uint64_t(seed)};
  for (long long i = 0; i < n; ++i) {
    const double x = random.uniform(box[0], box[3]), y = random.uniform(box[1], box[4]);
    const double z = random.uniform(box[2], box[5]), r = random.uniform(0.3, 1.5);
    scene["spheres"].push_back({{"center", {x, y, z}}, {"radius", r}, {"material", "clutter"}});
  }
  std::printf("%s\n", scene.dump(1).c_str());
  return 0;
}

} // namespace

int main(int argc, char** argv)
{
  const char* usage = "usage: gen_spheres N SEED [--diffuse] > scene.json   (1 <= N <= 10000000 spheres, SEED >= 0)\n"
                      "       gen_spheres clutter BASE.json N SEED X0 Y0 Z0 X1 Y1 Z1 > scene.json   (BASE.json with N "
                      "small spheres added in the box)\n";
  if (argc == 2 && (std::string(argv[1]) == "--help" || std::string(argv[1]) == "-h")) {
    std::fputs(usage, stdout);
    return 0;
  }
  if (argc > 1 && std::string(argv[1]) == "clutter")
    return clutter(argc, argv);
  long long n = 0, seed = 0;
  // --diffuse: every material diffuse (the glass, the mirror and the metals keep their colours), the spheres the
  // same: a scene that chapters of local shading (4, 9) render whole.
  const bool diffuse = argc == 4 && std::string(argv[3]) == "--diffuse";
  if ((argc != 3 && !diffuse) || !parseCount(argv[1], 1, 10000000, n) || !parseCount(argv[2], 0, 1LL << 62, seed)) {
    std::fputs(usage, stderr);
    return 2;
  }
  Random random{std::uint64_t(seed)};

  // A palette of materials, so that the file stays small however many spheres there are: 16 diffuse colours
  // (albedo rand·rand, as in the tutorial), 6 rough metals, 1 mirror, 1 glass. Only the used ones are written.
  std::vector<PaletteEntry> palette;
  palette.push_back({R"({ "type": "diffuse", "color": [0.5, 0.5, 0.5] })"});                  // 0: ground
  palette.push_back({diffuse ? R"({ "type": "diffuse", "color": [0.9, 0.9, 0.9] })"
                             : R"({ "type": "glass", "color": [1, 1, 1], "ior": 1.5 })"});          // 1: glass
  palette.push_back({R"({ "type": "diffuse", "color": [0.4, 0.2, 0.1] })"});                  // 2: brown
  palette.push_back({diffuse ? R"({ "type": "diffuse", "color": [0.7, 0.6, 0.5] })"
                             : R"({ "type": "mirror", "color": [0.7, 0.6, 0.5] })"});               // 3: mirror
  // A colour's channels are drawn blue first, one statement after another: scenes/random_spheres.json and
  // random_diffuse.json were written by GCC, which evaluated color()'s three arguments right to left; clang goes
  // left to right, so with the draws as arguments the same N and SEED gave another file. (The two factors of an
  // albedo may come in either order: their product is the same.)
  auto randomColor = [](auto draw) {
    const double b = draw(), g = draw(), r = draw();
    return color(r, g, b);
  };
  const int firstDiffuse = int(palette.size());
  for (int i = 0; i < 16; ++i)
    palette.push_back({"{ \"type\": \"diffuse\", \"color\": " +
                       randomColor([&random] { return random.uniform() * random.uniform(); }) + " }"});
  const int firstMetal = int(palette.size());
  for (int i = 0; i < 6; ++i) {
    char roughness[32];
    std::snprintf(roughness, sizeof roughness, "%.3f", random.uniform(0.02, 0.5));
    const std::string rgb = randomColor([&random] { return random.uniform(0.5, 1); });
    palette.push_back({diffuse ? "{ \"type\": \"diffuse\", \"color\": " + rgb + " }"
                               : "{ \"type\": \"glossy\", \"color\": " + rgb + ", \"roughness\": " + roughness + " }"});
  }

  // The ground and the three big spheres.
  std::vector<Ball> balls{{0, -1000, 0, 1000, 0}, {0, 1, 0, 1, 1}, {-4, 1, 0, 1, 2}, {4, 1, 0, 1, 3}};
  balls.resize(std::size_t(std::min<long long>(n, 4)));

  // Small spheres, one per unit cell of a square grid centred on the origin, row by row, skipping the cells
  // the big spheres stand on; as many as asked for.
  const long long small = n - (long long)balls.size();
  const long long side = small > 0 ? (long long)std::ceil(std::sqrt(double(small))) + 2 : 0;
  for (long long a = -side / 2; (long long)balls.size() < n; ++a)
    for (long long b = -side / 2; b < side - side / 2 && (long long)balls.size() < n; ++b) {
      const double x = double(a) + 0.9 * random.uniform(), z = double(b) + 0.9 * random.uniform();
      const double choose = random.uniform();
      bool nearBig = false;
      for (double bx : {-4.0, 0.0, 4.0})
        nearBig = nearBig || std::hypot(x - bx, z) < 1.3;
      if (nearBig)
        continue;
      // 80% diffuse, 15% metal, 5% glass, as in the tutorial.
      int material = 1;
      if (choose < 0.8)
        material = firstDiffuse + int(random.uniform() * 16);
      else if (choose < 0.95)
        material = firstMetal + int(random.uniform() * 6);
      balls.push_back({x, 0.2, z, 0.2, material});
    }

  for (const Ball& ball : balls)
    palette[std::size_t(ball.material)].used = true;
  std::vector<int> nameOf(palette.size(), -1);
  int names = 0;
  for (std::size_t i = 0; i < palette.size(); ++i)
    if (palette[i].used)
      nameOf[i] = names++;

  std::printf("{\n");
  std::printf("  \"camera\": { \"eye\": [13, 2, 3], \"focal\": [0, 0, 0], \"up\": [0, 1, 0], \"vfov\": 20, "
              "\"width\": 320, \"height\": 180 },\n");
  std::printf("  \"background\": [0.5, 0.7, 1.0],\n");
  std::printf("  \"ambient\": [0.1, 0.1, 0.12],\n");
  std::printf("  \"materials\": {\n");
  for (std::size_t i = 0, written = 0; i < palette.size(); ++i)
    if (palette[i].used)
      std::printf("    \"m%d\": %s%s\n", nameOf[i], palette[i].json.c_str(), ++written < std::size_t(names) ? "," : "");
  std::printf("  },\n");
  std::printf("  \"spheres\": [\n");
  for (std::size_t i = 0; i < balls.size(); ++i)
    std::printf("    { \"center\": [%.4f, %.4f, %.4f], \"radius\": %g, \"material\": \"m%d\" }%s\n", balls[i].x,
                balls[i].y, balls[i].z, balls[i].r, nameOf[std::size_t(balls[i].material)],
                i + 1 < balls.size() ? "," : "");
  std::printf("  ],\n");
  std::printf("  \"lights\": [\n");
  std::printf("    { \"type\": \"point\", \"position\": [-30, 50, 30], \"intensity\": [3000, 2900, 2700] },\n");
  std::printf("    { \"type\": \"point\", \"position\": [20, 15, -10], \"intensity\": [150, 170, 210] }\n");
  std::printf("  ]\n");
  std::printf("}\n");
  return 0;
}

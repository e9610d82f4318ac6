// Chapter 14: textures and environment maps. The image reader (formats, sRGB, bad files), the filters, the (u, v)
// conventions of scene-format.md checked pixel by pixel on rendered images (against the contract's formulas written
// out here again, not the renderer's code), the environment sampler (chi-square, normalisation, one bright texel),
// the irradiance from a one-patch map, the uniform map against the background, chapter 14 against chapter 6, and
// mip-mapping by ray cones on a checkerboard to the horizon.
#include "../analytic/run_chapter.h"
#include "../statistics/chi_square.h"

#include "render/image_io.h"
#include "scene/scene.h"
#include "scene/texture_file.h"
#include "shading/environment.h"
#include "shading/texture.h"

#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <string>
#include <tuple>
#include <type_traits>
#include <vector>

#include <sys/resource.h>

using namespace raylife;
using namespace raylife::test;
namespace fs = std::filesystem;

namespace {

const std::string kTextures = RAYLIFE_SCENES "/textures/";

// A folder of its own for a test's files, removed at the end.
struct TempDir {
  fs::path path;
  explicit TempDir(const std::string& tag)
      : path(fs::temp_directory_path() / ("raylife_tex_" + std::to_string(::getpid()) + "_" + tag))
  {
    fs::create_directories(path);
  }
  ~TempDir() { fs::remove_all(path); }
  std::string file(const std::string& name, const std::string& text) const
  {
    std::ofstream((path / name).string(), std::ios::binary) << text;
    return (path / name).string();
  }
};

// sRGB decoding by the standard's formula (IEC 61966-2-1), written out again.
double decode(int code)
{
  const double e = code / 255.0;
  return e <= 0.04045 ? e / 12.92 : std::pow((e + 0.055) / 1.055, 2.4);
}

// The 8-bit codes of scenes/textures/texels_4x2.png, row 0 (the top) first.
const int kTexels[2][4][3] = {{{255, 0, 0}, {0, 255, 0}, {0, 0, 255}, {255, 255, 0}},
                              {{0, 255, 255}, {255, 0, 255}, {128, 128, 128}, {255, 255, 255}}};

// The contract's (u, v) of a direction into the environment (scene-format.md), written out again.
std::pair<double, double> contractUv(double x, double y, double z)
{
  return {0.5 + std::atan2(x, -z) / (2 * std::numbers::pi), std::acos(std::clamp(y, -1.0, 1.0)) / std::numbers::pi};
}

// The contract's (u, v) of a sphere's outward normal (scene-format.md), written out again: the sign of x flipped,
// since a sphere is seen from outside.
std::pair<double, double> sphereContractUv(double x, double y, double z)
{
  return {0.5 + std::atan2(-x, -z) / (2 * std::numbers::pi), std::acos(std::clamp(y, -1.0, 1.0)) / std::numbers::pi};
}

// An image of `w` × `h` with every texel `c` except the block [x0, x1) × [y0, y1), which is `patch`.
Image mapWithPatch(int w, int h, float c, int x0, int x1, int y0, int y1, float patch)
{
  Image m(w, h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      for (int k = 0; k < 3; ++k)
        m.at(x, y, k) = (x >= x0 && x < x1 && y >= y0 && y < y1) ? patch : c;
  return m;
}

std::shared_ptr<const TexelImage> texels(const Image& image)
{
  auto t = std::make_shared<TexelImage>();
  t->width = image.width;
  t->height = image.height;
  t->rgb = image.pixels;
  return t;
}

} // namespace

// ---- Reading images --------------------------------------------------------------------------------------------

TEST_CASE("an 8-bit PNG is sRGB-decoded by the table, exactly as the standard's formula, or linear when asked")
{
  for (int code = 0; code < 256; ++code)
    REQUIRE(double(srgbDecodeTable()[std::size_t(code)]) == Approx(decode(code)).epsilon(1e-6));
  const TexelImage image = readTextureImage(kTextures + "texels_4x2.png", ImageEncoding::Srgb);
  REQUIRE(image.width == 4);
  REQUIRE(image.height == 2);
  const TexelImage linear = readTextureImage(kTextures + "texels_4x2.png", ImageEncoding::Linear);
  for (int y = 0; y < 2; ++y)
    for (int x = 0; x < 4; ++x)
      for (int c = 0; c < 3; ++c) {
        CHECK(double(image.texel(x, y)[c]) == Approx(decode(kTexels[y][x][c])).epsilon(1e-6));
        CHECK(double(linear.texel(x, y)[c]) == Approx(kTexels[y][x][c] / 255.0).epsilon(1e-6));
      }
}

TEST_CASE("bad image files: one message naming the file and the fault, as a scene error naming the scene and path")
{
  TempDir dir("bad");
  const std::string png = std::string("\x89PNG\r\n\x1a\n", 8);
  // A PNG header claiming a size: 13 bytes of IHDR (the CRC is not checked before the size).
  auto header = [&](std::uint32_t w, std::uint32_t h) {
    std::string s = png + std::string("\0\0\0\x0dIHDR", 8);
    for (std::uint32_t v : {w, h})
      for (int b = 3; b >= 0; --b)
        s += char((v >> (8 * b)) & 0xff);
    return s + std::string("\x08\x02\0\0\0\0\0\0\0", 9);
  };
  // Radiance files: 16 × 4 run-length encoded (each scanline 2, 2, 0, 16, then per channel one run of 16), and
  // 4 × 2 flat RGBE (a width below 8 is never run-length encoded); each whole, then cut short.
  const std::string radiance = "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n";
  std::string rle = radiance + "-Y 4 +X 16\n";
  for (int y = 0; y < 4; ++y)
    rle += std::string("\x02\x02\x00\x10", 4) + std::string("\x90\x80\x90\x40\x90\x20\x90\x81", 8);
  std::string flat = radiance + "-Y 2 +X 4\n";
  for (int i = 0; i < 8; ++i)
    flat += std::string("\x80\x40\x20\x81", 4);
  for (const auto& [name, bytes] : {std::pair{"rle.hdr", rle}, std::pair{"flat.hdr", flat}}) {
    CAPTURE(name);
    const TexelImage image = readTextureImage(dir.file(name, bytes), ImageEncoding::Srgb);
    CHECK(image.width == (name == std::string("rle.hdr") ? 16 : 4));
    // The last texel decoded, not zeros: red 128 × 2^(129 − 136) = 1 in each.
    CHECK(image.texel(image.width - 1, image.height - 1).r == Approx(1).epsilon(1e-6));
  }
  std::ifstream good(kTextures + "texels_4x2.png", std::ios::binary);
  const std::string whole((std::istreambuf_iterator<char>(good)), std::istreambuf_iterator<char>());
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"empty.png", ""},
      {"text.png", "not an image at all"},
      {"truncated.png", whole.substr(0, whole.size() / 2)},
      {"zero.png", header(0, 4)},
      {"ends_early.png", header(16, 16)},
      {"huge.png", header(100000, 100000)},
      {"jpeg.png", std::string("\xff\xd8\xff\xe0", 4) + "JFIF"},
      {"nosize.hdr", "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n"},
      {"truncated_rle.hdr", rle.substr(0, rle.size() - 5)},
      {"truncated_flat.hdr", flat.substr(0, flat.size() - 6)},
      {"bad.pfm", "PF\n4 4\n-1\n"},
      {"bad.exr", "v/1\x01 not really"},
      {"image.gif", "GIF89a"},
  };
  for (const auto& [name, bytes] : cases) {
    const std::string path = dir.file(name, bytes);
    CAPTURE(name);
    try {
      readTextureImage(path, ImageEncoding::Srgb);
      FAIL("no error");
    } catch (const ImageFileError& e) {
      // A reason after the colon, never an empty one (stb_image's for a PNG cut short after its header was empty).
      CHECK_FALSE(std::string(e.what()).ends_with(": "));
    }
    // Through a scene: scene file, JSON path, image file, one line.
    const std::string scene = dir.file("s.json", R"({"camera": {"eye": [0, 0, 5], "focal": [0, 0, 0]},
      "materials": {"m": {"type": "diffuse", "color": {"image": ")" + name + R"("}}},
      "spheres": [{"center": [0, 0, 0], "radius": 1, "material": "m"}]})");
    try {
      loadScene(scene);
      FAIL("no error");
    } catch (const SceneError& e) {
      const std::string what = e.what();
      INFO(what);
      CHECK(what.find("s.json:") != std::string::npos);
      CHECK(what.find("/materials/m/color/image") != std::string::npos);
      CHECK(what.find(name) != std::string::npos);
      CHECK(what.find('\n') == std::string::npos);
    }
  }
  CHECK_THROWS_AS(readTextureImage((dir.path / "missing.png").string(), ImageEncoding::Srgb), ImageFileError);
  CHECK_THROWS_AS(readTextureImage(dir.path.string(), ImageEncoding::Srgb), ImageFileError);
}

TEST_CASE("a short image file that claims 16384 x 16384 texels is refused before they are allocated (PNG, EXR, PFM)")
{
  // Each claims 2^28 texels, raylife's most, 3 GiB as floats, in a few bytes or kilobytes: allocated first, they
  // cost 3 GiB and 13 to 15 s before the reader found the file cut short (found by fuzzing the PNG reader). The
  // EXR whose chunk offsets all name one chunk cost 3 GB and 12 s as late as 2026-12-06: its pixels were zeroed
  // before they were read; they are now read in strips (and a file too small for its pixels is refused first).
  TempDir dir("short");
  std::string png = std::string("\x89PNG\r\n\x1a\n\0\0\0\x0dIHDR\0\0\x40\0\0\0\x40\0", 24);
  png += std::string("\x08\x02\0\0\0\0\0\0\0", 9); // 8-bit RGB; a CRC, and nothing after it
  // sky.exr with its windows made 16384 x 16384, and then a table of chunks that are not there (offsets of 0).
  std::ifstream sky(kTextures + "sky.exr", std::ios::binary);
  std::string exr((std::istreambuf_iterator<char>(sky)), std::istreambuf_iterator<char>());
  std::size_t at = 8; // past the magic and the version
  while (exr.at(at) != '\0') {
    const std::size_t nameEnd = exr.find('\0', at), typeEnd = exr.find('\0', nameEnd + 1);
    std::int32_t size = 0;
    std::memcpy(&size, &exr.at(typeEnd + 1), 4);
    const std::string name = exr.substr(at, nameEnd - at);
    if (name == "dataWindow" || name == "displayWindow") {
      const std::int32_t window[4] = {0, 0, 16383, 16383};
      std::memcpy(&exr.at(typeEnd + 5), window, sizeof window);
    }
    at = typeEnd + 5 + std::size_t(size);
  }
  // Then the same header over 1,024 chunk offsets (16384 rows, 16 a ZIP chunk) that all point to sky.exr's first
  // chunk, after them: the table is complete, so only reading the pixels finds the file wrong.
  std::uint64_t firstChunk = 0;
  std::memcpy(&firstChunk, &exr.at(at + 1), 8);
  std::uint64_t secondChunk = 0;
  std::memcpy(&secondChunk, &exr.at(at + 9), 8);
  const std::uint64_t shared = at + 1 + 1024 * 8;
  std::string offsets;
  for (int i = 0; i < 1024; ++i)
    offsets.append(reinterpret_cast<const char*>(&shared), 8);
  const std::string exrShared = exr.substr(0, at + 1) + offsets + exr.substr(firstChunk, secondChunk - firstChunk);
  exr = exr.substr(0, at + 1) + std::string(16384 * 8, '\0');
  // Each EXR padded at its end to 3.2 MB, what its 3 GiB of pixels need at ZIP's best (1,032 to 1), so that the
  // checks after that one are what refuse it; unpadded, that one refuses it first.
  const auto padded = [](const std::string& bytes) { return bytes + std::string(3'200'000 - bytes.size(), '\0'); };
  const std::string pfm = std::string("PF\n16384 16384\n-1.0\n") + std::string(64, '\0');
  const std::vector<std::tuple<std::string, std::string, std::string>> cases = {
      {"short.png", png, "its header claims 16384x16384 texels, more than a file of 33 bytes can hold"},
      {"short.exr", padded(exr), "the EXR is incomplete"},
      {"shared.exr", padded(exrShared), "cannot read the EXR"},
      {"unpadded.exr", exrShared, "the EXR is damaged: its 16384x16384 pixels are 3221225472 bytes, more than"},
      {"short.pfm", pfm, "the PFM file is truncated (16384x16384 pixels need 3221225472 bytes"},
  };
  for (const auto& [name, bytes, fault] : cases) {
    CAPTURE(name);
    try {
      readTextureImage(dir.file(name, bytes), ImageEncoding::Srgb);
      FAIL("no error");
    } catch (const ImageFileError& e) {
      CHECK_THAT(e.what(), Catch::Contains(fault));
    }
  }
  // And nothing near 3 GiB was ever held, here or in the PNG reader's child process.
  rusage self{}, children{};
  getrusage(RUSAGE_SELF, &self);
  getrusage(RUSAGE_CHILDREN, &children);
  CHECK(self.ru_maxrss < 1024 * 1024); // kilobytes: under 1 GiB
  CHECK(children.ru_maxrss < 1024 * 1024);
}

// ---- Filters ---------------------------------------------------------------------------------------------------

TEST_CASE("nearest and bilinear agree at texel centres, and bilinear is the average halfway between four texels")
{
  auto image = std::make_shared<const TexelImage>(readTextureImage(kTextures + "texels_4x2.png", ImageEncoding::Srgb));
  const Texture nearest(image, TextureFilter::Nearest), bilinear(image, TextureFilter::Bilinear);
  for (int y = 0; y < 2; ++y)
    for (int x = 0; x < 4; ++x) {
      const TextureLookup at{Vec2((x + 0.5) / 4, (y + 0.5) / 2), 0, false};
      CHECK(nearest.eval(at) == image->texel(x, y));
      const Color b = bilinear.eval(at);
      for (int c = 0; c < 3; ++c)
        CHECK(double(b[c]) == Approx(double(image->texel(x, y)[c])).margin(1e-6));
    }
  const Color corner = bilinear.eval(TextureLookup{Vec2(0.5, 0.5), 0, false});
  const Color average = (image->texel(1, 0) + image->texel(2, 0) + image->texel(1, 1) + image->texel(2, 1)) / Real(4);
  for (int c = 0; c < 3; ++c)
    CHECK(double(corner[c]) == Approx(double(average[c])).margin(1e-6));
}

TEST_CASE("a mip-mapped lookup whose footprint covers the image gives the image's mean")
{
  auto image = std::make_shared<const TexelImage>(readTextureImage(kTextures + "checker_64.png", ImageEncoding::Srgb));
  const Texture texture(image, TextureFilter::Bilinear);
  REQUIRE(texture.levelCount() == 7); // 64, 32, ..., 1
  const Color mean = texture.eval(TextureLookup{Vec2(0.3, 0.7), 1, false});
  CHECK(double(mean.r) == Approx(0.5).margin(1e-6));
  // A footprint of one texel is the finest level.
  CHECK(texture.eval(TextureLookup{Vec2(0.5 / 64, 0.5 / 64), Real(1) / 64, false}) == image->texel(0, 0));
}

// ---- The environment sampler -----------------------------------------------------------------------------------

TEST_CASE("environment: the contract's directions: -z is the centre column, +x at u = 3/4, +y the top row")
{
  CHECK(double(directionToUv(Vec3(0, 0, -1)).x) == Approx(0.5));
  CHECK(double(directionToUv(Vec3(1, 0, 0)).x) == Approx(0.75));
  CHECK(double(directionToUv(Vec3(-1, 0, 0)).x) == Approx(0.25));
  CHECK(double(directionToUv(Vec3(0, 1, 0)).y) == Approx(0).margin(1e-9));
  CHECK(double(directionToUv(Vec3(0, -1, 0)).y) == Approx(1));
  for (const Vec2 uv : {Vec2(0.1, 0.2), Vec2(0.7, 0.9), Vec2(0.5, 0.5)}) {
    const Vec2 back = directionToUv(uvToDirection(uv));
    CHECK(double(back.x) == Approx(double(uv.x)).margin(1e-9));
    CHECK(double(back.y) == Approx(double(uv.y)).margin(1e-9));
  }
  // Rotation: +z turns towards +x, so the map turned 90° shows its centre column (-z) along -x.
  const EnvironmentMap map(texels(mapWithPatch(8, 4, 1, 0, 1, 0, 1, 1)), 1, 90);
  CHECK(double(map.uvOf(Vec3(-1, 0, 0)).x) == Approx(0.5).margin(1e-9));
  CHECK(double(glm::length(map.directionOf(Vec2(0.5, 0.5)) - Vec3(-1, 0, 0))) <
        (std::is_same_v<Real, float> ? 1e-6 : 1e-9)); // (float keeps about seven digits)
}

TEST_CASE("a sphere reads its image un-mirrored from outside: its -z is the centre column, -x at u = 3/4")
{
  // A viewer at -z looking along +z (up +y) has -x on the right: u must grow that way, the sky's formula mirrored.
  CHECK(double(sphereUv(Vec3(0, 0, -1)).x) == Approx(0.5));
  CHECK(double(sphereUv(Vec3(-1, 0, 0)).x) == Approx(0.75));
  CHECK(double(sphereUv(Vec3(1, 0, 0)).x) == Approx(0.25));
  CHECK(double(sphereUv(Vec3(0, 1, 0)).y) == Approx(0).margin(1e-9));
  CHECK(double(sphereUv(Vec3(0, -1, 0)).y) == Approx(1));
  const Vec3 n = glm::normalize(Vec3(0.3, -0.4, 0.8));
  const Vec2 mirrored = directionToUv(Vec3(-n.x, n.y, n.z)), uv = sphereUv(n);
  CHECK(double(uv.x) == Approx(double(mirrored.x)));
  CHECK(double(uv.y) == Approx(double(mirrored.y)));
}

TEST_CASE("environment: the sampler's directions follow its pdf (chi-square), and the pdf integrates to 1")
{
  // A map with structure in both u and v: a bright band, a brighter patch, and black texels.
  Image m = mapWithPatch(32, 16, 0.2f, 20, 24, 3, 6, 40);
  for (int x = 0; x < 32; ++x)
    m.at(x, 12, 0) = m.at(x, 12, 1) = m.at(x, 12, 2) = 0;
  const EnvironmentMap map(texels(m), 2, 30);
  // A sample's pdf is its texel's; pdf(wi) looks the texel up again from the direction. The two agree to 10^-4 in
  // double. In float (seven digits) they agree to 10^-3, except in two places. Within rounding of a texel's edge,
  // wi may come back in the neighbour. And within a degree of a pole, sin θ (in the pdf's 1/sin θ) keeps few digits.
  // There, 11 samples of the 200,000 differed. Those are counted, and must stay that rare. In double, none seen.
  constexpr double kAgree = std::is_same_v<Real, float> ? 1e-3 : 1e-4;
  int illConditioned = 0;
  auto nearAnEdgeOrPole = [&map](const Vec3& wi) {
    const Vec2 uv = map.uvOf(wi);
    const double x = double(uv.x) * 32, y = double(uv.y) * 16;
    return std::min(std::abs(x - std::round(x)), std::abs(y - std::round(y))) < 1e-3 || std::abs(wi.y) > 0.9998;
  };
  const ChiSquareResult result = chiSquareTest(
      [&](Vec2 u, Real) -> std::optional<Vec3> {
        const auto s = map.sample(u);
        if (!s)
          return std::nullopt;
        if (std::is_same_v<Real, float> && nearAnEdgeOrPole(s->wi) &&
            !(double(s->pdf) == Approx(double(map.pdf(s->wi))).epsilon(kAgree)))
          ++illConditioned;
        else
          CHECK(double(s->pdf) == Approx(double(map.pdf(s->wi))).epsilon(kAgree));
        return s->wi;
      },
      [&](const Vec3& w) { return double(map.pdf(w)); }, 200000, 11, 1e-3);
  INFO(result.summary());
  CHECK(result.passed);
  INFO("float: samples at a texel's edge or a pole whose pdf differed: " << illConditioned);
  CHECK(illConditioned < 100); // (of 200,000)
  // ∫ pdf dω by a fine midpoint rule in (θ, φ) about +y, dω = sin θ dθ dφ.
  double integral = 0;
  const int n = 400;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < 2 * n; ++j) {
      const double theta = (i + 0.5) * std::numbers::pi / n, phi = (j + 0.5) * std::numbers::pi / n;
      const Vec3 w(Real(std::sin(theta) * std::cos(phi)), Real(std::cos(theta)), Real(std::sin(theta) * std::sin(phi)));
      integral += double(map.pdf(w)) * std::sin(theta) * (std::numbers::pi / n) * (std::numbers::pi / n);
    }
  INFO("integral " << integral);
  CHECK(integral == Approx(1).epsilon(2e-3));
}

TEST_CASE("environment: one bright texel is drawn as often as its share of luminance × sin θ")
{
  const int w = 16, h = 8, bx = 5, by = 2;
  const EnvironmentMap map(texels(mapWithPatch(w, h, 1, bx, bx + 1, by, by + 1, 100)), 1, 0);
  double total = 0;
  for (int y = 0; y < h; ++y)
    total += std::sin(std::numbers::pi * (y + 0.5) / h) * (w - 1 + (y == by ? 100 : 1));
  const double p = 100 * std::sin(std::numbers::pi * (by + 0.5) / h) / total;
  const int samples = 100000;
  int hits = 0;
  Sampler rng(3, 0, 0, 0);
  for (int k = 0; k < samples; ++k) {
    const auto s = map.sample(rng.next2D());
    REQUIRE(s);
    const auto [u, v] = contractUv(s->wi.x, s->wi.y, s->wi.z);
    hits += int(u * w) == bx && int(v * h) == by;
  }
  const double sigma = std::sqrt(samples * p * (1 - p));
  INFO("expected " << samples * p << " got " << hits);
  CHECK(std::abs(hits - samples * p) < 4 * sigma);
}

// ---- Rendered images ----------------------------------------------------------------------------------------

namespace {

// Renders `scene` with chapter 14 and returns its mean image.
ChapterRender render14(const std::string& scene, const std::string& args, const std::string& tag)
{
  return runChapterBinary(RAYLIFE_STEP14, scene, args, tag);
}

// The texel of texels_4x2.png at (s, t) (t = 0 the top row), decoded; and whether the pixel's four corners agree.
Color texelAt(double s, double t)
{
  const int x = std::clamp(int(std::floor((s - std::floor(s)) * 4)), 0, 3);
  const int y = std::clamp(int(std::floor(t * 2)), 0, 1);
  return Color(Real(decode(kTexels[y][x][0])), Real(decode(kTexels[y][x][1])), Real(decode(kTexels[y][x][2])));
}

} // namespace

namespace {

// Renders a quad in the plane z = 0 spanning [-2, 2] × [-1, 1], given by `mesh` (a "meshes" entry without its
// material), textured with texels_4x2.png (nearest) under a uniform sky of 1, and checks every pixel whose corners
// all see one texel: it must be that texel's decoded colour, the texel at (u, v) = ((x + 2)/4, (y + 1)/2) with v = 0
// the image's bottom row (OBJ's convention). Returns the number of pixels checked.
int checkQuad(const TempDir& dir, const std::string& mesh, const std::string& tag)
{
  const std::string scene = dir.file(tag + ".json", R"({
    "camera": {"eye": [0, 0, 4], "focal": [0, 0, 0], "vfov": 40, "width": 64, "height": 48},
    "background": [1, 1, 1],
    "materials": {"t": {"type": "diffuse", "color": {"image": "t.png", "filter": "nearest"}}},
    "meshes": [{"material": "t", )" + mesh + "}]}");
  const ChapterRender r = render14(scene, "--spp 4 --max-depth 1", tag);
  const Camera camera = loadScene(scene).makeCamera(64, 48);
  int tested = 0;
  for (int y = 0; y < 48; ++y)
    for (int x = 0; x < 64; ++x) {
      // The texel under each corner of the pixel, by the test's own ray–plane intersection.
      std::vector<Color> corners;
      bool onQuad = true;
      for (const Vec2 c : {Vec2(x, y), Vec2(x + 1, y), Vec2(x, y + 1), Vec2(x + 1, y + 1)}) {
        const Ray ray = camera.ray(c);
        const double t = -double(ray.origin.z) / double(ray.direction.z);
        const double px = ray.origin.x + t * ray.direction.x, py = ray.origin.y + t * ray.direction.y;
        onQuad = onQuad && std::abs(px) < 2 && std::abs(py) < 1;
        corners.push_back(texelAt((px + 2) / 4, 1 - (py + 1) / 2));
      }
      if (!onQuad || corners[0] != corners[1] || corners[0] != corners[2] || corners[0] != corners[3])
        continue;
      ++tested;
      CAPTURE(tag, x, y);
      for (int c = 0; c < 3; ++c)
        REQUIRE(double(r.mean.at(x, y, c)) == Approx(double(corners[0][c])).margin(1e-5));
    }
  return tested;
}

} // namespace

TEST_CASE("texels land where the conventions say: a quad with inline uvs, under a uniform sky of 1, is its texels")
{
  TempDir dir("quad");
  fs::copy_file(kTextures + "texels_4x2.png", dir.path / "t.png");
  CHECK(checkQuad(dir, R"("vertices": [[-2, -1, 0], [2, -1, 0], [2, 1, 0], [-2, 1, 0]],
    "triangles": [[0, 1, 2], [0, 2, 3]], "uvs": [[0, 0], [1, 0], [1, 1], [0, 1]])", "inline") > 1000);
}

TEST_CASE("texels land where the conventions say: a quad from an OBJ file's vt and a PLY file's u v and s t")
{
  TempDir dir("files");
  fs::copy_file(kTextures + "texels_4x2.png", dir.path / "t.png");
  dir.file("quad.obj", "v -2 -1 0\nv 2 -1 0\nv 2 1 0\nv -2 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n"
                       "f 1/1 2/2 3/3\nf 1/1 3/3 4/4\n");
  CHECK(checkQuad(dir, R"("file": "quad.obj")", "obj") > 1000);
  for (const std::string names : {"u v", "s t"}) {
    const std::string u = names.substr(0, 1), v = names.substr(2, 1);
    dir.file("quad_" + u + ".ply", "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\n"
                                   "property float z\nproperty float " + u + "\nproperty float " + v + "\n"
                                   "element face 2\nproperty list uchar int vertex_indices\nend_header\n"
                                   "-2 -1 0 0 0\n2 -1 0 1 0\n2 1 0 1 1\n-2 1 0 0 1\n3 0 1 2\n3 0 2 3\n");
    CHECK(checkQuad(dir, R"("file": "quad_)" + u + R"(.ply")", "ply_" + u) > 1000);
  }
}

TEST_CASE("texels land where the conventions say: a sphere from +x, -x, +z, -z and above is its texels, turned too")
{
  TempDir dir("sphere");
  fs::copy_file(kTextures + "texels_4x2.png", dir.path / "t.png");
  // The eye, and the sphere's "rotate" (degrees): the last view turns the texture 90°, +z towards +x.
  const std::vector<std::array<double, 4>> eyes = {{4, 0, 0, 0}, {-4, 0, 0, 0}, {0, 0, 4, 0}, {0, 0, -4, 0},
                                                   {0, 4, 0.001, 0}, {-4, 0, 0, 90}};
  int view = 0;
  for (const auto& eye : eyes) {
    const bool turned = eye[3] != 0;
    const std::string json = R"({"camera": {"eye": [)" + std::to_string(eye[0]) + ", " + std::to_string(eye[1]) +
                             ", " + std::to_string(eye[2]) + R"(], "focal": [0, 0, 0], "vfov": 35, "width": 48,
                             "height": 48}, "background": [1, 1, 1],
      "materials": {"t": {"type": "diffuse", "color": {"image": "t.png", "filter": "nearest"}}},
      "spheres": [{"center": [0, 0, 0], "radius": 1, "material": "t", "rotate": )" +
                             std::to_string(eye[3]) + "}]}";
    const std::string scene = dir.file("sphere" + std::to_string(view) + ".json", json);
    const ChapterRender r = render14(scene, "--spp 4 --max-depth 1", "sphere" + std::to_string(view));
    const Camera camera = loadScene(scene).makeCamera(48, 48);
    int tested = 0;
    for (int y = 0; y < 48; ++y)
      for (int x = 0; x < 48; ++x) {
        std::vector<Color> corners;
        bool onSphere = true;
        for (const Vec2 c : {Vec2(x, y), Vec2(x + 1, y), Vec2(x, y + 1), Vec2(x + 1, y + 1)}) {
          // The test's own ray–sphere intersection, and the contract's (u, v) of the normal (turned back by -90°
          // about +y when the texture is turned 90°: what it showed at n0 it now shows at R(90°)·n0).
          const Ray ray = camera.ray(c);
          const double b = glm::dot(ray.origin, ray.direction), cc = glm::dot(ray.origin, ray.origin) - 1;
          const double disc = b * b - cc;
          if (!(disc > 1e-3)) {
            onSphere = false;
            break;
          }
          const double t = -b - std::sqrt(disc);
          const Vec3 n = ray.origin + Real(t) * ray.direction;
          if (std::abs(n.y) > 0.95) { // near a pole every u meets in one pixel
            onSphere = false;
            break;
          }
          const auto [u, v] = turned ? sphereContractUv(-n.z, n.y, n.x) : sphereContractUv(n.x, n.y, n.z);
          corners.push_back(texelAt(u, v));
        }
        if (!onSphere || corners[0] != corners[1] || corners[0] != corners[2] || corners[0] != corners[3])
          continue;
        ++tested;
        CAPTURE(view, x, y);
        for (int c = 0; c < 3; ++c)
          REQUIRE(double(r.mean.at(x, y, c)) == Approx(double(corners[0][c])).margin(1e-5));
      }
    CHECK(tested > 300);
    ++view;
  }
}

TEST_CASE("a uniform environment map of value c renders exactly as background c (chapters 6, 8 and 12)")
{
  TempDir dir("uniform");
  writeImage(mapWithPatch(8, 4, 0.75f, 0, 0, 0, 0, 0), (dir.path / "c.pfm").string());
  const std::string body = R"("camera": {"eye": [0, 1, 4], "focal": [0, 0, 0], "width": 32, "height": 24},
    "materials": {"a": {"type": "diffuse", "color": [0.6, 0.5, 0.4]}, "g": {"type": "glossy", "roughness": 0.2}},
    "spheres": [{"center": [0, 0, 0], "radius": 1, "material": "a"}, {"center": [0, -101, 0], "radius": 100,
                 "material": "g"}]})";
  const std::string withMap = dir.file("map.json", R"({"environment": {"file": "c.pfm", "scale": 2}, )" + body);
  const std::string withBackground = dir.file("bg.json", R"({"background": [1.5, 1.5, 1.5], )" + body);
  for (const std::string binary : {RAYLIFE_STEP06, RAYLIFE_STEP08, RAYLIFE_STEP12}) {
    CAPTURE(binary);
    const ChapterRender a = runChapterBinary(binary, withMap, "--spp 4 --seed 5", "uni_a");
    const ChapterRender b = runChapterBinary(binary, withBackground, "--spp 4 --seed 5", "uni_b");
    CHECK(a.mean.pixels == b.mean.pixels);
  }
}

namespace {

// The irradiance on a surface of unit normal `n` from map `m` (scale 1), by a fine midpoint rule over each texel's
// own (u, v) rectangle, with the contract's direction of (u, v) written out here.
double irradiance(const Image& m, const Vec3& n)
{
  const int sub = 16;
  double e = 0;
  for (int y = 0; y < m.height; ++y)
    for (int x = 0; x < m.width; ++x) {
      const double L = double(m.at(x, y, 0));
      if (L == 0)
        continue;
      for (int a = 0; a < sub; ++a)
        for (int b = 0; b < sub; ++b) {
          const double u = (x + (a + 0.5) / sub) / m.width, v = (y + (b + 0.5) / sub) / m.height;
          const double theta = std::numbers::pi * v, phi = 2 * std::numbers::pi * (u - 0.5);
          const double d[3] = {std::sin(theta) * std::sin(phi), std::cos(theta), -std::sin(theta) * std::cos(phi)};
          const double cosine = d[0] * n.x + d[1] * n.y + d[2] * n.z;
          const double dOmega = 2 * std::numbers::pi * std::numbers::pi * std::sin(theta) / (m.width * m.height * sub * sub);
          e += L * std::max(0.0, cosine) * dOmega;
        }
    }
  return e;
}

} // namespace

TEST_CASE("a floor and a wall lit by a one-patch environment map are ρ/π times its irradiance (chapter 14)")
{
  TempDir dir("patch");
  // One bright patch above the horizon, towards +x and -z: a mirrored u would put it behind the wall (facing +x),
  // a flipped v below the floor.
  const Image m = mapWithPatch(16, 8, 0, 10, 12, 2, 3, 10);
  writeImage(m, (dir.path / "patch.pfm").string());
  const double rho = 0.5;
  struct Case {
    std::string name, vertices;
    Vec3 normal;
  };
  const std::vector<Case> cases = {
      {"floor", "[[-1, 0, -1], [-1, 0, 1], [1, 0, 1], [1, 0, -1]]", Vec3(0, 1, 0)},
      {"wall", "[[0, -1, -1], [0, 1, -1], [0, 1, 1], [0, -1, 1]]", Vec3(1, 0, 0)},
  };
  for (const Case& c : cases) {
    CAPTURE(c.name);
    const Vec3 eye = c.normal * Real(3) + Vec3(0.01, 0.01, 0.01);
    const std::string scene = dir.file(c.name + ".json", R"({"camera": {"eye": [)" + std::to_string(eye.x) + ", " +
                                                             std::to_string(eye.y) + ", " + std::to_string(eye.z) +
                                                             R"(], "focal": [0, 0, 0], "vfov": 20, "width": 16, "height": 16},
      "environment": {"file": "patch.pfm"},
      "materials": {"m": {"type": "diffuse", "color": [0.5, 0.5, 0.5]}},
      "meshes": [{"material": "m", "vertices": )" + c.vertices + R"(, "triangles": [[0, 1, 2], [0, 2, 3]]}]})");
    const ChapterRender r = render14(scene, "--spp 256 --max-depth 1 --seed 9", "patch_" + c.name);
    const double expected = rho / std::numbers::pi * irradiance(m, c.normal);
    REQUIRE(expected > 0.1);
    double sum = 0, var = 0;
    for (int y = 0; y < 16; ++y)
      for (int x = 0; x < 16; ++x) {
        sum += r.mean.at(x, y, 1);
        var += r.variance.at(x, y, 1);
      }
    const double mean = sum / 256, se = std::sqrt(var) / 256;
    INFO("mean " << mean << " expected " << expected << " standard error " << se);
    CHECK(std::abs(mean - expected) < 4 * se + 1e-3 * expected);
  }
}

TEST_CASE("chapter 14 agrees with chapter 6 by a per-pixel z-test on an environment-lit, textured scene")
{
  TempDir dir("agree");
  // A broad bright patch and a dimmer sky, over a textured sphere on a checker floor (chapter 6 can find the patch).
  writeImage(mapWithPatch(32, 16, 0.3f, 18, 24, 2, 6, 6), (dir.path / "sky.pfm").string());
  // Chapter 6 shades a texture as its mean colour, so the two are compared on constant colours: what differs is
  // the environment's importance sampling and MIS, which must not change the expectation.
  const std::string constant = dir.file("agree_constant.json", R"({
    "camera": {"eye": [0, 1.5, 4], "focal": [0, 0.5, 0], "vfov": 40, "width": 24, "height": 18},
    "environment": {"file": "sky.pfm", "rotate": 20},
    "materials": {"t": {"type": "diffuse", "color": [0.6, 0.3, 0.2]},
                  "f": {"type": "glossy", "color": [0.7, 0.7, 0.7], "roughness": 0.3}},
    "spheres": [{"center": [0, 0.8, 0], "radius": 0.8, "material": "t"}],
    "meshes": [{"material": "f", "vertices": [[-3, 0, -3], [3, 0, -3], [3, 0, 3], [-3, 0, 3]],
                "triangles": [[0, 2, 1], [0, 3, 2]]}]})");
  const ChapterRender a = render14(constant, "--spp 64 --seed 1", "agree14");
  const ChapterRender b = runChapterBinary(RAYLIFE_STEP06, constant, "--spp 512 --seed 2", "agree06");
  std::size_t failed = 0, channels = 0;
  for (std::size_t i = 0; i < a.mean.pixels.size(); ++i) {
    const double var = double(a.variance.pixels[i]) + double(b.variance.pixels[i]) + 1e-10;
    failed += std::abs(double(a.mean.pixels[i]) - double(b.mean.pixels[i])) / std::sqrt(var) > 3.29;
    ++channels;
  }
  INFO(failed << " of " << channels << " channels beyond |z| = 3.29");
  CHECK(double(failed) / double(channels) < 0.01);
}

TEST_CASE("mip-mapping by ray cones: a checkerboard to the horizon is its mean colour where squares are sub-pixel")
{
  TempDir dir("horizon");
  fs::copy_file(kTextures + "checker_64.png", dir.path / "c.png");
  // A floor of 400 × 400 units tiled by a 64-texel image of 8 × 8 squares, repeated once a unit (squares of 1/8).
  const std::string scene = dir.file("horizon.json", R"({
    "camera": {"eye": [0, 1, 0], "focal": [0, 0.8, -10], "vfov": 30, "width": 96, "height": 64},
    "background": [1, 1, 1],
    "materials": {"c": {"type": "diffuse", "color": {"image": "c.png"}}},
    "meshes": [{"material": "c", "vertices": [[-200, 0, 200], [200, 0, 200], [200, 0, -200], [-200, 0, -200]],
                "triangles": [[0, 1, 2], [0, 2, 3]], "uvs": [[0, 0], [400, 0], [400, 400], [0, 400]]}]})");
  const double mean = decode(255) / 2 + decode(0) / 2; // the checker's mean albedo (white and black)
  // Rows where a square (1/8 unit) is smaller than a pixel: a pixel's footprint on the floor at distance d along a
  // ray of elevation angle α is about d·(pixel angle)/sin α; take rows where it exceeds 2 squares.
  const Camera camera = loadScene(scene).makeCamera(96, 64);
  const double pixelAngle = 2 * std::tan(15 * std::numbers::pi / 180) / 64;
  auto error = [&](const std::string& filter) {
    const ChapterRender r = render14(scene, "--spp 1 --max-depth 1 --texture-filter " + filter, "hz_" + filter);
    double sq = 0;
    int n = 0;
    for (int y = 0; y < 64; ++y) {
      const Ray ray = camera.ray(Vec2(48, y + 0.5));
      if (!(ray.direction.y < 0))
        continue;
      const double d = 1 / -double(ray.direction.y);
      const double footprint = d * pixelAngle / -double(ray.direction.y);
      if (footprint < 2.0 / 8 || d > 100)
        continue; // squares wider than 2 pixels, and clear of the floor's far edge (200 away)
      for (int x = 0; x < 96; ++x) {
        const double e = double(r.mean.at(x, y, 1)) - mean;
        sq += e * e;
        ++n;
      }
    }
    REQUIRE(n > 200);
    return std::sqrt(sq / n);
  };
  const double cones = error("cones"), texel = error("texel");
  INFO("RMS error against the mean: cones " << cones << ", finest level " << texel);
  CHECK(cones < 0.03);
  CHECK(texel > 0.1); // the test can fail: without mip-maps the far floor is noise
}

TEST_CASE("material from-file maps an OBJ's MTL (Kd and map_Kd to diffuse and Ks and Ns to glossy and Ke to emission)")
{
  TempDir dir("mtl");
  fs::copy_file(kTextures + "texels_4x2.png", dir.path / "t.png");
  dir.file("quad.mtl", "newmtl paper\nKd 0.5 0.5 0.5\nmap_Kd t.png\n"
                       "newmtl shiny\nKd 0.05 0.05 0.05\nKs 0.9 0.8 0.7\nNs 198\n"
                       "newmtl lamp\nKd 0 0 0\nKe 4 4 4\n");
  dir.file("quad.obj", "mtllib quad.mtl\nv -2 -1 0\nv 2 -1 0\nv 2 1 0\nv -2 1 0\nv -2 -1 1\nv 2 -1 1\n"
                       "vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n"
                       "usemtl paper\nf 1/1 2/2 3/3\nusemtl shiny\nf 1/1 3/3 4/4\nusemtl lamp\nf 1 2 6\n");
  const std::string scene = dir.file("s.json", R"({"camera": {"eye": [0, 0, 5], "focal": [0, 0, 0]},
    "meshes": [{"file": "quad.obj", "material": "from-file"}]})");
  const Scene s = loadScene(scene);
  REQUIRE(s.triangles.size() == 3);
  auto materialOf = [&](std::size_t t) -> const Material& { return s.materials[std::size_t(s.triangles[t].material)]; };
  // Which triangle is which: by their materials' names (the reader may reorder the parts).
  int found = 0;
  for (std::size_t t = 0; t < 3; ++t) {
    const Material& m = materialOf(t);
    CAPTURE(m.name);
    if (m.name == "quad.obj:paper") {
      REQUIRE(m.colorTexture);
      CHECK(m.type == MaterialType::Diffuse);
      CHECK(m.colorTexture->size() == glm::ivec2(4, 2));
      ++found;
    } else if (m.name == "quad.obj:shiny") {
      CHECK(m.type == MaterialType::Glossy);
      CHECK(double(m.color.r) == Approx(0.9));
      CHECK(double(m.roughness) == Approx(std::sqrt(2.0 / 200)).epsilon(1e-5));
      ++found;
    } else if (m.name == "quad.obj:lamp") {
      CHECK(m.isEmissive());
      CHECK(double(m.emission.g) == Approx(4));
      ++found;
    }
  }
  CHECK(found == 3);
  REQUIRE(s.warnings.size() == 1);
  INFO(s.warnings[0]);
  CHECK(s.warnings[0].find("materials from quad.obj, approximated: 1 as glossy") != std::string::npos);
  // A map_Kd that is missing: one line naming the scene, the place, the material and the image.
  dir.file("quad.mtl", "newmtl paper\nmap_Kd missing.png\n");
  try {
    loadScene(scene);
    FAIL("no error");
  } catch (const SceneError& e) {
    const std::string what = e.what();
    CHECK(what.find("/meshes/0/material") != std::string::npos);
    CHECK(what.find("missing.png") != std::string::npos);
  }
}

// Replays every input under tests/fuzz/regressions/ (what the fuzzer once found) and every seed scene through
// the fuzzer's check, so a fixed fault stays fixed without a fuzzing build.
#include "scene_check.h"

#include <catch2/catch.hpp>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <vector>

namespace {

std::vector<std::filesystem::path> filesIn(const std::filesystem::path& folder)
{
  std::vector<std::filesystem::path> files;
  for (const auto& entry : std::filesystem::directory_iterator(folder))
    if (entry.is_regular_file() && entry.path().filename().string()[0] != '.')
      files.push_back(entry.path());
  std::sort(files.begin(), files.end());
  return files;
}

std::string readAll(const std::filesystem::path& path)
{
  std::ifstream in(path, std::ios::binary);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

} // namespace

TEST_CASE("every input the fuzzer found is handled")
{
  const auto files = filesIn(RAYLIFE_FUZZ_REGRESSIONS);
  REQUIRE(files.size() >= 1);
  for (const auto& file : files) {
    INFO(file.string());
    CHECK(raylife::fuzz::checkSceneText(readAll(file)) == "");
  }
}

TEST_CASE("every scene of the seed corpus is handled")
{
  std::vector<std::filesystem::path> files = filesIn(RAYLIFE_SCENES);
  if (std::filesystem::is_directory(std::filesystem::path(RAYLIFE_SCENES) / "stress"))
    for (const auto& f : filesIn(std::filesystem::path(RAYLIFE_SCENES) / "stress"))
      files.push_back(f);
  REQUIRE(files.size() >= 1);
  for (const auto& file : files) {
    INFO(file.string());
    CHECK(raylife::fuzz::checkSceneText(readAll(file)) == "");
  }
}

TEST_CASE("every image file the image fuzzer found or was seeded with is handled")
{
  // The fuzz target's input: the first byte chooses the encoding (even: sRGB, odd: linear), the rest is the file.
  const auto files = filesIn(RAYLIFE_FUZZ_IMAGE_REGRESSIONS);
  REQUIRE(files.size() >= 3);
  for (const auto& file : files) {
    INFO(file.string());
    const std::string bytes = readAll(file);
    REQUIRE_FALSE(bytes.empty());
    const auto encoding = static_cast<unsigned char>(bytes[0]) % 2 == 0 ? raylife::ImageEncoding::Srgb
                                                                        : raylife::ImageEncoding::Linear;
    CHECK(raylife::fuzz::checkImageBytes(std::string_view(bytes).substr(1), encoding) == "");
  }
}

TEST_CASE("every float image file the float image fuzzer found or was seeded with is handled")
{
  // The fuzz target's input: the first byte chooses the format (even: OpenEXR, odd: PFM), the rest is the file.
  const auto files = filesIn(RAYLIFE_FUZZ_FLOAT_IMAGE_REGRESSIONS);
  REQUIRE(files.size() >= 3);
  for (const auto& file : files) {
    INFO(file.string());
    const std::string bytes = readAll(file);
    REQUIRE_FALSE(bytes.empty());
    CHECK(raylife::fuzz::checkFloatImageBytes(std::string_view(bytes).substr(1),
                                              static_cast<unsigned char>(bytes[0]) % 2 == 0 ? ".exr" : ".pfm") == "");
  }
}

TEST_CASE("every partial film the film fuzzer found or was seeded with is handled")
{
  const auto files = filesIn(RAYLIFE_FUZZ_FILM_REGRESSIONS);
  REQUIRE(files.size() >= 3);
  for (const auto& file : files) {
    INFO(file.string());
    CHECK(raylife::fuzz::checkFilmBytes(readAll(file)) == "");
  }
}

TEST_CASE("every mesh file the mesh fuzzer found or was seeded with is handled")
{
  // The fuzz target's input: the first byte chooses the format (even: OBJ, odd: PLY), the rest is the file.
  const auto files = filesIn(RAYLIFE_FUZZ_MESH_REGRESSIONS);
  REQUIRE(files.size() >= 3);
  for (const auto& file : files) {
    INFO(file.string());
    const std::string bytes = readAll(file);
    REQUIRE_FALSE(bytes.empty());
    const auto format = static_cast<unsigned char>(bytes[0]) % 2 == 0 ? raylife::MeshFormat::Obj
                                                                      : raylife::MeshFormat::Ply;
    CHECK(raylife::fuzz::checkMeshBytes(std::string_view(bytes).substr(1), format) == "");
  }
}

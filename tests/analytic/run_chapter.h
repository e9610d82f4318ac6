// Runs a chapter's own executable on a scene and reads back its mean image and the variance of each pixel's mean,
// so the analytic and golden tests check the chapters exactly as students run them.
#pragma once

#include "render/film.h"
#include "render/image_io.h"

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <unistd.h>

namespace raylife::test {

/// A chapter's render as read back from its files.
struct ChapterRender {
  Image mean;     ///< Linear radiance (the PFM).
  Image variance; ///< Variance of each pixel's mean (--variance).
  std::string stats; ///< The --stats JSON.
};

/// Runs `binary` on `scene` with `arguments` (e.g. "--spp 64 --seed 3"), writing into a private temporary folder.
/// @throws std::runtime_error when the program fails.
inline ChapterRender runChapterBinary(const std::string& binary, const std::string& scene, const std::string& arguments,
                                      const std::string& tag)
{
  namespace fs = std::filesystem;
  const fs::path dir = fs::temp_directory_path() / ("raylife_test_" + std::to_string(::getpid()) + "_" + tag);
  fs::create_directories(dir);
  const std::string image = (dir / "image.pfm").string(), variance = (dir / "variance.pfm").string();
  const std::string stats = (dir / "stats.json").string();
  const std::string command = "'" + binary + "' '" + scene + "' --quiet -o '" + image + "' --variance '" + variance +
                              "' --stats '" + stats + "' " + arguments;
  if (std::system(command.c_str()) != 0)
    throw std::runtime_error("failed: " + command);
  ChapterRender r{readPfm(image), readPfm(variance), ""};
  std::ifstream in(stats);
  std::stringstream text;
  text << in.rdbuf();
  r.stats = text.str();
  fs::remove_all(dir);
  return r;
}

/// The number after `"key": ` in a flat JSON object (the --stats file), or −1 when absent.
inline double statsValue(const std::string& json, const std::string& key)
{
  const std::string needle = "\"" + key + "\": ";
  const std::size_t at = json.find(needle);
  return at == std::string::npos ? -1 : std::atof(json.c_str() + at + needle.size());
}

} // namespace raylife::test

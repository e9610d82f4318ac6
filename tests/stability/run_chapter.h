/// @file run_chapter.h
/// @brief Runs a built chapter binary on a scene and reads back its image and its figures, so that the
/// stability tests exercise the chapters themselves, not copies of their trace functions.
#pragma once

#include "render/image_io.h"

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>

#include <sys/wait.h> // WEXITSTATUS

namespace raylife::stability {

/// What one chapter run produced.
struct ChapterRun {
  int status = -1;           ///< The process's exit status (0: rendered).
  Image image;               ///< The PFM it wrote (linear radiance, unclamped).
  long long badSamples = -1; ///< RenderResult::badSamples from its --stats file; −1 if unreadable.
  std::string err;           ///< All it wrote to standard error (warnings, or the one line of a refusal).
};

/// The whole of a text file ("" if it cannot be read).
inline std::string readText(const std::string& path)
{
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

/// Runs `binary` (a chapter, e.g. "step04_shadows") on `scene` with one thread, writing into the test's output
/// folder under the file stem `tag` (unique per test, as ctest runs tests in parallel): the image `tag`.pfm (an
/// earlier one is removed first, so a run that fails leaves none), the figures `tag`.json and standard error
/// `tag`.err. `extra` is appended to the command line (e.g. a smaller size and spp for the Monte Carlo chapters).
/// A run longer than 120 s is stopped (status 124).
inline ChapterRun runChapter(const std::string& binary, const std::string& scene, const std::string& tag,
                             const std::string& extra = "")
{
  const std::string stem = std::string(RAYLIFE_STABILITY_OUT_DIR) + "/" + tag;
  std::remove((stem + ".pfm").c_str());
  std::ostringstream command;
  command << "timeout 120 \"" << RAYLIFE_STEP_DIR << "/" << binary << "\" \"" << scene << "\" -o \"" << stem
          << ".pfm\" --stats \"" << stem << ".json\" --threads 1 --quiet " << extra << " 2> \"" << stem << ".err\"";
  ChapterRun run;
  const int raw = std::system(command.str().c_str());
  run.status = raw == -1 ? -1 : WEXITSTATUS(raw);
  run.err = readText(stem + ".err");
  if (run.status != 0)
    return run;
  run.image = readPfm(stem + ".pfm");
  const std::string json = readText(stem + ".json");
  const std::string key = "\"bad_samples\": ";
  if (const std::size_t at = json.find(key); at != std::string::npos)
    run.badSamples = std::atoll(json.c_str() + at + key.size());
  return run;
}

/// Pixels with a channel that is NaN, infinite or negative.
inline int badPixels(const Image& image)
{
  int bad = 0;
  for (std::size_t i = 0; i < image.pixels.size(); i += 3) {
    bool ok = true;
    for (std::size_t c = 0; c < 3; ++c)
      ok = ok && std::isfinite(image.pixels[i + c]) && image.pixels[i + c] >= 0;
    bad += !ok;
  }
  return bad;
}

} // namespace raylife::stability

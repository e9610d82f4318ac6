/// @file options.h
/// @brief The command line every chapter shares (DESIGN.md, section 4), parsed into RenderOptions.
#pragma once

#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace raylife {

/// What the command line asked for. Zero or empty means "the chapter's or the scene's default".
struct RenderOptions {
  std::string scenePath;            ///< Scene file; empty: the chapter's default scene.
  std::vector<std::string> outputs; ///< Output files, one per format (.png, .pfm, .exr, .film); empty: out/BINARY.png.
  std::string variancePath;         ///< --variance: PFM or EXR of each pixel's variance of the mean; empty: none.
  std::string statsPath;            ///< --stats: a JSON file of the render's figures; empty: none.
  int width = 0;                    ///< --width, pixels; 0: the scene's.
  int height = 0;                   ///< --height, pixels; 0: the scene's.
  std::optional<int> spp;           ///< --spp: samples per pixel, ≥ 1.
  std::optional<double> seconds;    ///< --time: render until this many seconds have passed, > 0.
  /// --samples FIRST:COUNT: only sample indices FIRST .. FIRST + COUNT − 1 of --spp (which must hold them).
  std::optional<std::pair<int, int>> samples;
  std::uint64_t seed = 0;           ///< --seed.
  int threads = 0;                  ///< --threads, ≥ 1; 0: every core.
  std::optional<int> maxDepth;      ///< --max-depth: longest path in bounces, ≥ 0.
  bool quiet = false;               ///< --quiet: no progress bar, no summary line.
  bool help = false;                ///< --help was given.
  bool verbose = false;             ///< --verbose: print the render's plan (scene_plan.h) on standard error.
  /// --adaptive: a pixel stops taking samples once the estimated relative standard error of its mean falls below
  /// this (> 0, e.g. 0.02 for 2 %); honoured by the Monte Carlo chapters (6 to 8) only.
  std::optional<double> adaptive;
  /// --ao-distance: ambient occlusion counts only what lies closer than this (scene units, > 0); nothing: any
  /// distance. Honoured by chapter 12 only.
  std::optional<double> aoDistance;
};

/// A fault in the command line. what() says which argument and what is wrong.
class UsageError : public std::runtime_error {
public:
  using std::runtime_error::runtime_error;
};

/// Parses argv[1..argc). @throws UsageError on an unknown flag (suggesting the nearest known one), a missing or
/// malformed value, a value out of range, more than one scene, two outputs of one format, an output that is not
/// .png, .pfm, .exr or .film (.pfm or .exr for --variance), one file given as two outputs, both --spp and --time,
/// or --samples without --spp holding it (or with --adaptive).
RenderOptions parseCommandLine(int argc, const char* const* argv);

/// The --help text for a binary called `binary` whose default scene is `defaultScene`.
std::string usageText(const std::string& binary, const std::string& defaultScene);

} // namespace raylife

/// @file options.h
/// @brief The command line every chapter shares (docs/command-line.md), parsed into RenderOptions.
#pragma once

#include "render/image_io.h"

#include <cstdint>
#include <limits>
#include <map>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace raylife {

/// The kind of value a chapter's own option takes (ChapterOption).
enum class OptionKind {
  Flag,        ///< No value: given or not ("--unweighted").
  Choice,      ///< One word of ChapterOption::choices ("--heuristic balance").
  Integer,     ///< A whole number in [min, max] ("--bounces 3").
  Number,      ///< A finite real number in [min, max] ("--radius 0.5").
  IntegerList, ///< Whole numbers in [min, max], separated by commas ("--strategy 1,2").
};

/// An option of a chapter's own, beside the shared ones: the chapter lists them in ChapterInfo::options, and the
/// shared parser reads them (as "--name value" or "--name=value"), checks their values, puts them in --help and
/// hands them to the chapter (ChapterOptions). Example: {"--heuristic", OptionKind::Choice, "the MIS heuristic",
/// "power", {"power", "balance"}}.
struct ChapterOption {
  std::string name = {};              ///< "--" and a word, e.g. "--heuristic"; no shared option's name.
  OptionKind kind = OptionKind::Flag; ///< What value it takes.
  std::string help = {};              ///< One line for --help: what it does.
  /// The value's name in --help and in `help` ("D"); empty: N, X, N,N,... or the choices, by its kind.
  std::string metavar = {};
  /// The value when the option is not given, spelt as on the command line (it must pass the same checks);
  /// ignored for a flag, which is off unless given. Empty: none (the chapter asks ChapterOptions::given first;
  /// reading the value of an option with none and not given throws std::logic_error).
  std::string defaultValue = {};
  std::vector<std::string> choices = {};                       ///< Choice: the words allowed.
  double min = -std::numeric_limits<double>::max();           ///< Integer, Number, IntegerList: the least value.
  /// Integer, Number, IntegerList: the largest value. A Number whose max is +∞ also takes "inf" (no limit).
  double max = std::numeric_limits<double>::max();
};

/// The values of a chapter's own options after parsing, each its default when not given.
class ChapterOptions {
public:
  ChapterOptions() = default;
  /// @param specs The chapter's options. @param given Raw values by name (checked), "" for a flag given.
  /// @param verbose Whether --verbose was given (a chapter then says what it built for the scene).
  /// @param threads --threads (≥ 1), or 0 for every core: what work a chapter does before the render may use.
  ChapterOptions(std::vector<ChapterOption> specs, std::map<std::string, std::string> given, bool verbose = false,
                 int threads = 0)
      : specs_(std::move(specs)), given_(std::move(given)), verbose_(verbose), threads_(threads) {}
  /// Whether flag `name` was given. @throws std::logic_error if the chapter declared no such flag.
  bool flag(const std::string& name) const;
  /// The word of Choice `name`. @throws std::logic_error if the chapter declared no such choice.
  std::string choice(const std::string& name) const;
  /// The value of Integer `name`. @throws std::logic_error if the chapter declared no such option.
  long long integer(const std::string& name) const;
  /// The value of Number `name`. @throws std::logic_error if the chapter declared no such option.
  double number(const std::string& name) const;
  /// The values of IntegerList `name`. @throws std::logic_error if the chapter declared no such option.
  std::vector<long long> integers(const std::string& name) const;
  /// Whether option `name` was given on the command line (rather than taking its default).
  bool given(const std::string& name) const { return given_.count(name) > 0; }
  /// Whether --verbose was given: the chapter may then print, on standard error, what it built for the scene.
  bool verbose() const { return verbose_; }
  /// --threads (≥ 1), or 0 for every core: the threads a chapter's own work before the render (a pre-pass) may use.
  int threads() const { return threads_; }

private:
  const std::string& value(const std::string& name, OptionKind kind) const;
  std::vector<ChapterOption> specs_;
  std::map<std::string, std::string> given_;
  bool verbose_ = false;
  int threads_ = 0;
};

/// What the command line asked for. Zero or empty means "the chapter's or the scene's default".
struct RenderOptions {
  std::string scenePath;            ///< Scene file; empty: the chapter's default scene.
  std::vector<std::string> outputs; ///< Output files, one per format (.png, .pfm, .exr, .film); empty: out/BINARY.png.
  std::string variancePath;         ///< --variance: PFM or EXR of each pixel's variance of the mean; empty: none.
  std::string statsPath;            ///< --stats: a JSON file of the render's figures; empty: none.
  /// --preview: a PNG rewritten (atomically) every few seconds while the render runs, and at its end; empty: none.
  std::string previewPath;
  ToneMap toneMap = ToneMap::Clamp; ///< --tonemap: how PNG outputs (and the preview) map radiance into [0, 1].
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
  ChapterOptions chapter;           ///< The chapter's own options (ChapterInfo::options), defaults filled in.
};

/// A fault in the command line. what() says which argument and what is wrong.
class UsageError : public std::runtime_error {
public:
  using std::runtime_error::runtime_error;
};

/// Parses argv[1..argc): the shared options and the chapter's own (`chapterOptions`). Every option with a value
/// may be written "--name value" or "--name=value". @throws UsageError on an unknown flag (suggesting the nearest
/// known one), a missing or malformed value, a value out of range or not among a choice's words, a value given to
/// a flag, more than one scene, two outputs of one format, an output that is not .png, .pfm, .exr or .film (.pfm
/// or .exr for --variance; the extension in any case), one file given as two outputs, both --spp and --time, or
/// --samples without --spp holding it (or with --adaptive). @throws std::logic_error if a chapter's option is
/// malformed (a shared option's name, a default that fails its own checks).
RenderOptions parseCommandLine(int argc, const char* const* argv,
                               const std::vector<ChapterOption>& chapterOptions = {});

/// What --help says of a chapter: its binary, default scene and samples per pixel, and its own options.
struct UsageInfo {
  std::string binary;                 ///< e.g. "step08_mis".
  std::string defaultScene;           ///< The default scene's path.
  int defaultSpp = 1;                 ///< Samples per pixel without --spp or --time.
  bool adaptive = false;              ///< Whether the chapter honours --adaptive.
  /// What the chapter reads of a scene, as a phrase ("the camera, spheres and meshes, ..."); "" says nothing.
  std::string reads = {};
  std::vector<ChapterOption> options; ///< The chapter's own options.
  int maxDepthLimit = 0;              ///< The most --max-depth the chapter takes (ChapterInfo); 0: no own limit.
};

/// The --help text of a chapter.
std::string usageText(const UsageInfo& info);

} // namespace raylife

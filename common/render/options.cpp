#include "render/options.h"

#include "core/edit_distance.h"
#include "core/threads.h"
#include "render/image_io.h"
#include "scene/scene.h"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <iterator>
#include <sstream>
#include <stdexcept>

namespace raylife {

namespace {

long long parseInteger(const std::string& flag, const std::string& text, long long lo, long long hi)
{
  errno = 0;
  char* end = nullptr;
  const long long v = std::strtoll(text.c_str(), &end, 10);
  if (text.empty() || *end != '\0' || errno == ERANGE)
    throw UsageError(flag + " expects a whole number, got '" + text + "'");
  if (v < lo || v > hi)
    throw UsageError(flag + " must lie in [" + std::to_string(lo) + ", " + std::to_string(hi) + "], got " + text);
  return v;
}

double parsePositive(const std::string& flag, const std::string& text)
{
  errno = 0;
  char* end = nullptr;
  const double v = std::strtod(text.c_str(), &end);
  if (text.empty() || *end != '\0' || errno == ERANGE || !std::isfinite(v))
    throw UsageError(flag + " expects a number, got '" + text + "'");
  if (!(v > 0))
    throw UsageError(flag + " must be greater than 0, got " + text);
  return v;
}

// The shared options' names (and -h, -o, -q for three of them).
constexpr const char* kShared[] = {"--help",    "--output", "--variance",  "--stats", "--width",
                                   "--height",  "--spp",    "--time",      "--samples", "--seed",
                                   "--threads", "--max-depth", "--quiet",  "--verbose", "--adaptive",
                                   "--preview", "--tonemap"};

// The option nearest to `word` by edit distance, if it is close: for "did you mean".
std::string nearestFlag(const std::string& word, const std::vector<ChapterOption>& chapterOptions)
{
  std::vector<std::string> names;
  for (const char* name : kShared)
    names.push_back(name);
  for (const ChapterOption& o : chapterOptions)
    names.push_back(o.name);
  std::string best;
  std::size_t bestDistance = 3;
  for (const std::string& name : names)
    if (const std::size_t d = editDistance(word, name); d < bestDistance) {
      bestDistance = d;
      best = name;
    }
  return best;
}

// Checks `text` as a value of chapter option `o`; throws UsageError naming `o` if it is not one.
void checkChapterValue(const ChapterOption& o, const std::string& text)
{
  auto inRange = [&](double v, const std::string& shown) {
    if (v < o.min || v > o.max) {
      std::ostringstream range;
      // (Whole numbers' bounds as whole numbers: a stream writes 16777216 as 1.67772e+07.)
      if (o.kind == OptionKind::Integer || o.kind == OptionKind::IntegerList)
        range << o.name << " must lie in [" << (long long)(o.min) << ", " << (long long)(o.max) << "], got " << shown;
      else
        range << o.name << " must lie in [" << o.min << ", " << o.max << "], got " << shown;
      throw UsageError(range.str());
    }
  };
  auto whole = [&](const std::string& item) {
    errno = 0;
    char* end = nullptr;
    const long long v = std::strtoll(item.c_str(), &end, 10);
    if (item.empty() || *end != '\0' || errno == ERANGE)
      throw UsageError(o.name + " expects " + (o.kind == OptionKind::IntegerList ? "whole numbers separated by commas"
                                                                                  : "a whole number") +
                       ", got '" + text + "'");
    inRange(double(v), item);
  };
  switch (o.kind) {
  case OptionKind::Flag:
    return;
  case OptionKind::Choice: {
    if (std::find(o.choices.begin(), o.choices.end(), text) != o.choices.end())
      return;
    std::string words;
    for (std::size_t i = 0; i < o.choices.size(); ++i)
      words += (i == 0 ? "" : i + 1 == o.choices.size() ? " or " : ", ") + o.choices[i];
    throw UsageError(o.name + " must be " + words + ", got '" + text + "'");
  }
  case OptionKind::Integer:
    whole(text);
    return;
  case OptionKind::Number: {
    errno = 0;
    char* end = nullptr;
    const double v = std::strtod(text.c_str(), &end);
    // (inf is a value only of an option whose range is unbounded above: "no limit".)
    const bool unbounded = std::isinf(v) && v > 0 && std::isinf(o.max);
    if (text.empty() || *end != '\0' || (errno == ERANGE && !unbounded) || !(std::isfinite(v) || unbounded))
      throw UsageError(o.name + " expects a number, got '" + text + "'");
    inRange(v, text);
    return;
  }
  case OptionKind::IntegerList: {
    std::size_t from = 0;
    for (;;) {
      const std::size_t comma = text.find(',', from);
      whole(text.substr(from, comma == std::string::npos ? std::string::npos : comma - from));
      if (comma == std::string::npos)
        return;
      from = comma + 1;
    }
  }
  }
}

// Checks a chapter's declared options: a programming error, not the user's, if one is malformed.
void checkDeclarations(const std::vector<ChapterOption>& chapterOptions)
{
  for (std::size_t i = 0; i < chapterOptions.size(); ++i) {
    const ChapterOption& o = chapterOptions[i];
    const bool shared = std::any_of(std::begin(kShared), std::end(kShared),
                                    [&](const char* name) { return o.name == name; });
    if (o.name.size() < 3 || o.name.rfind("--", 0) != 0 || o.name.find('=') != std::string::npos || shared)
      throw std::logic_error("a chapter option needs a name of its own, '--' and a word: '" + o.name + "'");
    for (std::size_t j = 0; j < i; ++j)
      if (chapterOptions[j].name == o.name)
        throw std::logic_error("the chapter option " + o.name + " is declared twice");
    if (o.kind == OptionKind::Choice && o.choices.empty())
      throw std::logic_error("the chapter option " + o.name + " is a choice without words");
    try {
      if (o.kind != OptionKind::Flag && !o.defaultValue.empty()) // (empty: none; the chapter asks given())
        checkChapterValue(o, o.defaultValue);
    } catch (const UsageError& e) {
      throw std::logic_error(std::string("the default of a chapter option fails its checks: ") + e.what());
    }
  }
}

const ChapterOption* findOption(const std::vector<ChapterOption>& options, const std::string& name)
{
  for (const ChapterOption& o : options)
    if (o.name == name)
      return &o;
  return nullptr;
}

} // namespace

const std::string& ChapterOptions::value(const std::string& name, OptionKind kind) const
{
  const ChapterOption* o = findOption(specs_, name);
  if (!o || o->kind != kind)
    throw std::logic_error("the chapter reads an option it did not declare (or as another kind): " + name);
  const auto given = given_.find(name);
  const std::string& text = given != given_.end() ? given->second : o->defaultValue;
  if (kind != OptionKind::Flag && text.empty())
    throw std::logic_error("the chapter reads " + name + ", which has no default and was not given (ask given())");
  return text;
}

bool ChapterOptions::flag(const std::string& name) const
{
  value(name, OptionKind::Flag); // (checks the declaration)
  return given(name);
}

std::string ChapterOptions::choice(const std::string& name) const { return value(name, OptionKind::Choice); }

long long ChapterOptions::integer(const std::string& name) const
{
  return std::stoll(value(name, OptionKind::Integer));
}

double ChapterOptions::number(const std::string& name) const { return std::stod(value(name, OptionKind::Number)); }

std::vector<long long> ChapterOptions::integers(const std::string& name) const
{
  const std::string& text = value(name, OptionKind::IntegerList);
  std::vector<long long> out;
  for (std::size_t from = 0;;) {
    const std::size_t comma = text.find(',', from);
    out.push_back(std::stoll(text.substr(from, comma == std::string::npos ? std::string::npos : comma - from)));
    if (comma == std::string::npos)
      return out;
    from = comma + 1;
  }
}

RenderOptions parseCommandLine(int argc, const char* const* argv, const std::vector<ChapterOption>& chapterOptions)
{
  checkDeclarations(chapterOptions);
  RenderOptions o;
  std::map<std::string, std::string> chapterValues;
  for (int i = 1; i < argc; ++i) {
    const std::string word = argv[i];
    // "--name=value" is "--name value".
    const std::size_t equals = word.rfind("--", 0) == 0 ? word.find('=') : std::string::npos;
    const std::string arg = word.substr(0, equals);
    const std::optional<std::string> inlineValue =
        equals == std::string::npos ? std::nullopt : std::optional(word.substr(equals + 1));
    auto value = [&]() -> std::string {
      if (inlineValue)
        return *inlineValue;
      if (i + 1 >= argc)
        throw UsageError(arg + " expects a value");
      return argv[++i];
    };
    auto noValue = [&] {
      if (inlineValue)
        throw UsageError(arg + " takes no value, got '" + word + "'");
    };
    if (arg == "--help" || arg == "-h") {
      noValue();
      o.help = true;
    } else if (arg == "-o" || arg == "--output") {
      const std::string path = value();
      const std::string kind = fileExtension(path);
      if (kind != ".png" && kind != ".pfm" && kind != ".exr" && kind != ".film")
        throw UsageError(arg + " '" + path + "': unknown format (the output must end in .png, .pfm, .exr or .film)");
      for (const std::string& given : o.outputs) // (one file given twice is reported below)
        if (given != path && fileExtension(given) == kind)
          throw UsageError("-o is given two " + kind + " files; one of each format");
      o.outputs.push_back(path);
    } else if (arg == "--variance") {
      o.variancePath = value();
      if (fileExtension(o.variancePath) != ".pfm" && fileExtension(o.variancePath) != ".exr")
        throw UsageError("--variance '" + o.variancePath + "': the variance image must be a .pfm or .exr file");
    } else if (arg == "--stats") {
      o.statsPath = value();
      if (o.statsPath.empty())
        throw UsageError("--stats expects a file name");
    } else if (arg == "--preview") {
      o.previewPath = value();
      if (fileExtension(o.previewPath) != ".png")
        throw UsageError("--preview '" + o.previewPath + "': the preview must be a .png file");
    } else if (arg == "--tonemap") {
      const std::string curve = value();
      try {
        o.toneMap = parseToneMap(curve);
      } catch (const std::invalid_argument&) {
        throw UsageError("--tonemap '" + curve + "': expected clamp, reinhard or aces");
      }
    } else if (arg == "--width") {
      o.width = int(parseInteger(arg, value(), 1, kMaxPixels));
    } else if (arg == "--height") {
      o.height = int(parseInteger(arg, value(), 1, kMaxPixels));
    } else if (arg == "--spp") {
      o.spp = int(parseInteger(arg, value(), 1, 1 << 24));
    } else if (arg == "--samples") {
      const std::string text = value();
      const std::size_t colon = text.find(':');
      if (colon == std::string::npos)
        throw UsageError("--samples expects FIRST:COUNT (e.g. 0:64), got '" + text + "'");
      o.samples = std::pair(int(parseInteger("--samples' FIRST", text.substr(0, colon), 0, (1 << 24) - 1)),
                            int(parseInteger("--samples' COUNT", text.substr(colon + 1), 1, 1 << 24)));
    } else if (arg == "--time") {
      o.seconds = parsePositive(arg, value());
    } else if (arg == "--seed") {
      o.seed = std::uint64_t(parseInteger(arg, value(), 0, (1LL << 62)));
    } else if (arg == "--threads") {
      o.threads = int(parseInteger(arg, value(), 1, kMaxThreads));
    } else if (arg == "--max-depth") {
      o.maxDepth = int(parseInteger(arg, value(), 0, 1 << 20));
    } else if (arg == "--quiet" || arg == "-q") {
      noValue();
      o.quiet = true;
    } else if (arg == "--verbose") {
      noValue();
      o.verbose = true;
    } else if (arg == "--adaptive") {
      o.adaptive = parsePositive(arg, value());
    } else if (const ChapterOption* option = findOption(chapterOptions, arg)) {
      if (option->kind == OptionKind::Flag) {
        noValue();
        chapterValues[arg] = "";
      } else {
        const std::string text = value();
        checkChapterValue(*option, text);
        chapterValues[arg] = text;
      }
    } else if (arg.size() > 1 && arg[0] == '-') {
      const std::string near = nearestFlag(arg, chapterOptions);
      throw UsageError("unknown option '" + word + "'" + (near.empty() ? "" : " (did you mean '" + near + "'?)") +
                       "; see --help");
    } else {
      if (!o.scenePath.empty())
        throw UsageError("more than one scene given: '" + o.scenePath + "' and '" + arg + "'");
      o.scenePath = arg;
    }
  }
  o.chapter = ChapterOptions(chapterOptions, std::move(chapterValues), o.verbose, o.threads);
  if (o.spp && o.seconds)
    throw UsageError("give --spp or --time, not both");
  if (o.samples && !o.spp)
    throw UsageError("--samples takes a share of the samples of --spp N: give --spp");
  if (o.samples && std::int64_t(o.samples->first) + o.samples->second > *o.spp)
    throw UsageError("--samples " + std::to_string(o.samples->first) + ":" + std::to_string(o.samples->second) +
                     " reaches past --spp " + std::to_string(*o.spp) + " (sample indices are 0 to " +
                     std::to_string(*o.spp - 1) + ")");
  if (o.samples && o.adaptive)
    throw UsageError("--adaptive needs every sample of a pixel in one process; it cannot take --samples");
  // Every file written must be a different file: two renames onto one name would silently keep only one.
  std::vector<std::string> written = o.outputs;
  for (const std::string* extra : {&o.variancePath, &o.statsPath, &o.previewPath})
    if (!extra->empty())
      written.push_back(*extra);
  for (std::size_t i = 0; i < written.size(); ++i)
    for (std::size_t j = i + 1; j < written.size(); ++j)
      if (written[i] == written[j])
        throw UsageError("'" + written[i] + "' is given as two outputs; each output needs its own file");
  return o;
}

namespace {
// What an option's value looks like in --help.
std::string metavar(const ChapterOption& o)
{
  if (!o.metavar.empty() && o.kind != OptionKind::Flag)
    return o.metavar;
  switch (o.kind) {
  case OptionKind::Flag:
    return "";
  case OptionKind::Choice: {
    std::string words;
    for (std::size_t i = 0; i < o.choices.size(); ++i)
      words += (i == 0 ? "" : "|") + o.choices[i];
    return words;
  }
  case OptionKind::Integer:
    return "N";
  case OptionKind::Number:
    return "X";
  case OptionKind::IntegerList:
    return "N,N,...";
  }
  return "";
}
} // namespace

std::string usageText(const UsageInfo& info)
{
  const std::string& binary = info.binary;
  const std::string indent(8 + binary.size(), ' ');
  std::string own;
  for (const ChapterOption& o : info.options) {
    const std::string m = metavar(o);
    own += " [" + o.name + (m.empty() ? "" : " " + m) + "]";
  }
  std::string text =
      "usage: " + binary + " [SCENE.json] [-o FILE.png|.pfm|.exr|.film]... [--width W] [--height H]\n" + indent +
      "[--spp N | --time SECONDS] [--samples F:C] [--seed S] [--threads T] [--max-depth D]\n" + indent +
      "[--variance FILE] [--stats FILE] [--preview FILE.png] [--tonemap clamp|reinhard|aces]\n" + indent +
      "[--adaptive E] [--verbose] [--quiet] [--help]\n" +
      (own.empty() ? "" : indent + own.substr(1) + "\n") +
      "\n"
      "  SCENE.json         scene file (default: " + info.defaultScene + ")\n"
      "  -o FILE            output image, .png (clamped, sRGB), .pfm or .exr (linear, unclamped), or\n"
      "                     .film (exact sums, for raylife_merge); one of each (default: out/" + binary + ".png)\n"
      "                     (to look at a .pfm or .exr: raylife_image convert x.pfm x.png --exposure E)\n"
      "  --width W          image width in pixels (default: the scene's; given alone, the height follows\n"
      "                     the scene's aspect ratio)\n"
      "  --height H         image height in pixels (default: the scene's; likewise)\n"
      "  --spp N            samples per pixel (default: " + std::to_string(info.defaultSpp) + ")\n"
      "  --time SECONDS     render progressively until SECONDS have passed, then write\n"
      "  --samples F:C      only sample indices F to F+C-1 of --spp N (a job of an array; merge\n"
      "                     the .film outputs with raylife_merge)\n"
      "  --seed S           random seed; the same seed gives the same image on any thread count\n"
      "  --threads T        threads (default: every core)\n"
      "  --max-depth D      longest path, in bounces (chapters that recurse)\n" +
      (info.maxDepthLimit > 0 ? "                     (at most " + std::to_string(info.maxDepthLimit) +
                                    " here: each bounce is one call deeper on the stack)\n"
                              : std::string()) +
      "  --variance FILE    also write each pixel's variance of the mean, as PFM or EXR\n"
      "  --stats FILE       also write the render's figures as JSON\n"
      "  --preview FILE.png rewrite FILE.png with the image so far every few seconds while rendering\n"
      "                     (atomically: any image viewer can watch it converge)\n"
      "  --tonemap CURVE    how a PNG maps radiance into [0, 1]: clamp (default), reinhard (v/(1+v))\n"
      "                     or aces (a filmic curve); PFM and EXR stay linear\n"
      "  --adaptive E       stop sampling a pixel once the relative standard error of its mean is below E\n"
      "                     (0.05: 5 %); --spp N is then the most a pixel takes. It saves where much of\n"
      "                     the image settles fast (a sky: about half the time at E = 0.05) and little\n"
      "                     where every pixel stays noisy (the Cornell box at 128 spp: almost every pixel\n"
      "                     takes all 128 at E = 0.1). Biased a little; see docs/measurements/09_bvh.md" +
      std::string(info.adaptive ? "\n" : "\n                     (chapters 6 to 8 only: this one ignores it)\n") +
      "  --verbose          print the render's plan (what the scene lets it skip) on standard error\n"
      "  --quiet, -q        no progress bar and no summary line\n"
      "  --help, -h         this text\n";
  if (!info.options.empty()) {
    text += "\n" + binary + "'s own options:\n";
    for (const ChapterOption& o : info.options) {
      std::string left(2, ' '); // (built in steps: GCC 12 warns falsely on "  " + name)
      left += o.name;
      if (!metavar(o).empty())
        left += " " + metavar(o);
      left += left.size() < 21 ? std::string(21 - left.size(), ' ') : "\n" + std::string(21, ' ');
      text += left + o.help +
              (o.kind == OptionKind::Flag || o.defaultValue.empty() ? "" : " (default: " + o.defaultValue + ")") + "\n";
    }
  }
  if (!info.reads.empty())
    text += "\nreads from a scene: " + info.reads + "\n";
  text += "\n"
          "Options with a value may be written --name value or --name=value.\n"
          "exit status: 0 done, 1 bad input or a failed write, 2 bad command line, 130 interrupted\n";
  return text;
}

} // namespace raylife

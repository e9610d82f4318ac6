#include "render/options.h"

#include "scene/scene.h"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <iterator>

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

bool endsWith(const std::string& s, const std::string& suffix)
{
  return s.size() >= suffix.size() && s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

// The flag nearest to `arg` by edit distance (ignoring an "=value" tail), if it is close: for "did you mean".
std::string nearestFlag(const std::string& arg)
{
  const std::string word = arg.substr(0, arg.find('='));
  static const char* const flags[] = {"--help", "--output", "--variance", "--stats", "--width", "--height", "--spp",
                                      "--time", "--seed", "--threads", "--max-depth", "--quiet", "--samples",
                                      "--verbose", "--adaptive", "--ao-distance"};
  std::string best;
  std::size_t bestDistance = 3;
  for (const char* flag : flags) {
    const std::string f = flag;
    std::vector<std::size_t> row(f.size() + 1);
    for (std::size_t j = 0; j <= f.size(); ++j)
      row[j] = j;
    for (std::size_t i = 1; i <= word.size(); ++i) {
      std::size_t diagonal = row[0];
      row[0] = i;
      for (std::size_t j = 1; j <= f.size(); ++j) {
        const std::size_t above = row[j];
        row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (word[i - 1] == f[j - 1] ? 0 : 1)});
        diagonal = above;
      }
    }
    if (row[f.size()] < bestDistance) {
      bestDistance = row[f.size()];
      best = f;
    }
  }
  return best;
}

} // namespace

RenderOptions parseCommandLine(int argc, const char* const* argv)
{
  RenderOptions o;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc)
        throw UsageError(arg + " expects a value");
      return argv[++i];
    };
    if (arg == "--help" || arg == "-h") {
      o.help = true;
    } else if (arg == "-o" || arg == "--output") {
      const std::string path = value();
      const char* kinds[] = {".png", ".pfm", ".exr", ".film"};
      if (std::none_of(std::begin(kinds), std::end(kinds), [&](const char* k) { return endsWith(path, k); }))
        throw UsageError(arg + " '" + path + "': unknown format (the output must end in .png, .pfm, .exr or .film)");
      for (const std::string& given : o.outputs) // (one file given twice is reported below)
        if (given != path && given.substr(given.rfind('.')) == path.substr(path.rfind('.')))
          throw UsageError("-o is given two " + path.substr(path.rfind('.')) + " files; one of each format");
      o.outputs.push_back(path);
    } else if (arg == "--variance") {
      o.variancePath = value();
      if (!endsWith(o.variancePath, ".pfm") && !endsWith(o.variancePath, ".exr"))
        throw UsageError("--variance '" + o.variancePath + "': the variance image must be a .pfm or .exr file");
    } else if (arg == "--stats") {
      o.statsPath = value();
      if (o.statsPath.empty())
        throw UsageError("--stats expects a file name");
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
      o.threads = int(parseInteger(arg, value(), 1, 1024));
    } else if (arg == "--max-depth") {
      o.maxDepth = int(parseInteger(arg, value(), 0, 1 << 20));
    } else if (arg == "--quiet" || arg == "-q") {
      o.quiet = true;
    } else if (arg == "--verbose") {
      o.verbose = true;
    } else if (arg == "--adaptive") {
      o.adaptive = parsePositive(arg, value());
    } else if (arg == "--ao-distance") {
      o.aoDistance = parsePositive(arg, value());
    } else if (arg.size() > 1 && arg[0] == '-') {
      const std::string near = nearestFlag(arg);
      throw UsageError("unknown option '" + arg + "'" + (near.empty() ? "" : " (did you mean '" + near + "'?)") +
                       "; see --help");
    } else {
      if (!o.scenePath.empty())
        throw UsageError("more than one scene given: '" + o.scenePath + "' and '" + arg + "'");
      o.scenePath = arg;
    }
  }
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
  for (const std::string* extra : {&o.variancePath, &o.statsPath})
    if (!extra->empty())
      written.push_back(*extra);
  for (std::size_t i = 0; i < written.size(); ++i)
    for (std::size_t j = i + 1; j < written.size(); ++j)
      if (written[i] == written[j])
        throw UsageError("'" + written[i] + "' is given as two outputs; each output needs its own file");
  return o;
}

std::string usageText(const std::string& binary, const std::string& defaultScene)
{
  return "usage: " + binary +
         " [SCENE.json] [-o FILE.png|.pfm|.exr|.film] [--width W] [--height H]\n"
         "       [--spp N | --time SECONDS] [--seed S] [--threads T] [--max-depth D] [--quiet] [--help]\n"
         "\n"
         "  SCENE.json         scene file (default: " + defaultScene + ")\n"
         "  -o FILE            output image, .png (clamped, sRGB), .pfm or .exr (linear, unclamped), or\n"
         "                     .film (exact sums, for raylife_merge); one of each (default: out/" + binary + ".png)\n"
         "  --width W          image width in pixels (default: the scene's)\n"
         "  --height H         image height in pixels (default: the scene's)\n"
         "  --spp N            samples per pixel (default: the chapter's)\n"
         "  --time SECONDS     render progressively until SECONDS have passed, then write\n"
         "  --samples F:C      only sample indices F to F+C-1 of --spp N (a job of an array; merge\n"
         "                     the .film outputs with raylife_merge)\n"
         "  --seed S           random seed; the same seed gives the same image on any thread count\n"
         "  --threads T        threads (default: every core)\n"
         "  --max-depth D      longest path, in bounces (chapters that recurse)\n"
         "  --variance FILE    also write each pixel's variance of the mean, as PFM or EXR\n"
         "  --stats FILE       also write the render's figures as JSON\n"
         "  --quiet            no progress bar and no summary line\n"
         "  --verbose          print the render's plan (what the scene lets it skip) on standard error\n"
         "  --adaptive E       Monte Carlo chapters (6 to 8): a pixel stops taking samples once the relative\n"
         "                     standard error of its mean is below E (biased a little; see docs/09_bvh.md)\n"
         "  --ao-distance D    ambient occlusion (chapter 12): only what lies within D scene units occludes\n"
         "                     (default: unbounded)\n"
         "  --help             this text\n"
         "\n"
         "exit status: 0 done, 1 bad input or a failed write, 2 bad command line, 130 interrupted\n";
}

} // namespace raylife

// raylife_bench: run time against error (docs/benchmarks.md, issue 8).
//
// For each scene it makes sure a converged, checked reference exists (rendering what the cache lacks), then runs
// every Monte Carlo chapter at a ladder of spp budgets and of equal wall-clock budgets, several seeds each, on 1
// thread and on all, in the double build and (when built) the float build, and writes results.csv, the plots
// (gnuplot: SVG and PNG) and summary.md into <build>/bench/<mode>/. Not a test: timings are never asserted.
#include "bench.h"
#include "render/image_compare.h"
#include "render/image_io.h"
#include "render/locate.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>
#include <thread>

#include <sys/wait.h>


namespace fs = std::filesystem;
using namespace raylife;
using namespace raylife::bench;

namespace {

/// The budgets of one mode.
struct Plan {
  std::string mode = "quick";
  int width = 128, height = 96;
  std::vector<int> sppLadder = {1, 2, 4, 8, 16, 32, 64, 128};
  std::vector<double> timeBudgets = {0.5, 1, 2};
  int seeds = 3;
  int referenceSpp = 4096; // 32× the ladder's top: its own noise is about 3% of any measured error
  int checkSpp = 512;
  // The check compares cells of checkCell × checkCell pixels (1: every pixel). Larger cells pool more of the second
  // estimator's samples, for a scene where its per-pixel means are skewed (docs/benchmarks.md: the reference).
  int checkCell = 1;
  int threadsSpp = 16;   // the spp budget of the 1-thread runs and the float build's spp runs
  int threads = 0;       // the ladder's thread count; 0: every core
  // Adaptive sampling: --adaptive E at each threshold, at most adaptiveMaxSpp samples a pixel (0: the spp ladder's
  // top, so that no adaptive render spends more than the ladder's largest budget and the plain ladder brackets it
  // unless it does better than that budget).
  std::vector<double> adaptiveThresholds = {0.2, 0.1, 0.05};
  int adaptiveMaxSpp = 0;
  int adaptiveCap() const
  {
    return adaptiveMaxSpp > 0 ? adaptiveMaxSpp : *std::max_element(sppLadder.begin(), sppLadder.end());
  }
};

Plan fullPlan()
{
  Plan p;
  p.mode = "full";
  p.width = 320;
  p.height = 240;
  p.sppLadder = {1, 2, 4, 8, 16, 32, 64, 128, 256};
  p.timeBudgets = {1, 2, 4, 8, 16};
  p.seeds = 4;
  p.referenceSpp = 8192;
  p.checkSpp = 2048;
  p.threadsSpp = 64;
  p.adaptiveThresholds = {0.1, 0.05, 0.03, 0.02};
  return p;
}

// The significance of the reference check: a channel (of a pixel, or of a cell of pixels) fails at |z| > 3.29
// (two-sided 0.001); the reference is trusted when the total z is within it and no more than 1% of channels fail
// (10× the expected 0.1%: per-pixel variance estimates of path tracers are themselves noisy where rare bright paths
// are).
constexpr double kCritical = 3.29;
constexpr double kMaxFailedShare = 0.01;
constexpr double kVarianceFloor = 1e-12;
constexpr std::uint64_t kReferenceSeed = 1000003, kCheckSeed = 2000003;

const std::vector<std::string> kDefaultChapters = {"step06_path_tracer", "step07_light_sampling", "step08_mis"};
// adaptive.json: a plain sky behind three spheres, where adaptive sampling has the most to save. Not mis.json: its
// reference cannot pass the check (chapter 6's per-pixel variance there is all fireflies; docs/benchmarks.md), and
// an untrusted reference stops the run; name it with --scenes to see.
const std::vector<std::string> kDefaultScenes = {"cornell.json", "adaptive.json"};

struct Options {
  Plan plan;
  fs::path binDir, floatBinDir, outDir, referenceDir;
  bool floatGiven = false;
  std::vector<std::string> chapters, scenes;
  bool plots = true;
  std::string replot; // a results.csv to draw and summarise again, without rendering
  bool referencesOnly = false;
};

std::vector<std::string> splitList(const std::string& s)
{
  std::vector<std::string> out;
  std::stringstream in(s);
  std::string item;
  while (std::getline(in, item, ','))
    if (!item.empty())
      out.push_back(item);
  return out;
}

[[noreturn]] void usage(const std::string& message)
{
  if (!message.empty())
    std::cerr << "raylife_bench: " << message << "\n";
  std::cerr <<
      R"(usage: raylife_bench [--quick | --full] [options]
  --quick               small images, a short ladder, 3 seeds (the default; under 10 minutes on 2 cores)
  --full                larger images, longer ladders, 4 seeds (for the docs)
  --bin DIR             the chapter programs (default: the folder raylife_bench is in)
  --float-bin DIR       the float build's programs (default: <source>/build-float/bin when it exists)
  --no-float            skip the float build
  --chapters A,B,...    chapter programs, lowest first (default: those of step06_path_tracer,
                        step07_light_sampling, step08_mis that exist); the last one renders the reference
  --scenes A,B,...      scene files, as paths or names under scenes/ (default: those of cornell.json and
                        adaptive.json that exist)
  --out DIR             results (default: <bin>/../bench/<mode>)
  --references DIR      reference cache (default: <bin>/../bench/references)
  --size WxH            image size
  --spp A,B,...         the spp ladder
  --times A,B,...       the equal-time budgets in seconds
  --seeds N             seeds per budget
  --reference-spp N     spp of the reference
  --check-spp N         spp of the second estimator's render that checks it
  --check-cell N        compare the reference and the second render in cells of NxN pixels (default 1: per
                        pixel), where the second estimator's per-pixel means are skewed (rare, bright paths)
  --threads-spp N       spp budget of the 1-thread and float runs
  --threads N           the ladder's thread count (default: every core)
  --adaptive A,B,...    adaptive sampling's thresholds (--adaptive E of the chapters; quick 0.2,0.1,0.05,
                        full 0.1,0.05,0.03,0.02), each against the spp ladder at equal error
  --adaptive-max-spp N  the most samples a pixel takes in the adaptive runs (default: the spp ladder's top)
  --no-adaptive         no adaptive runs
  --no-plots            write the CSV and the summary only (no gnuplot)
  --references-only     render (or find in the cache) and check each scene's reference, then stop
  --replot FILE.csv     draw the plots and write the summary of an earlier results.csv again (into --out,
                        default: the CSV's folder), rendering nothing
)";
  std::exit(2);
}

std::vector<int> intList(const std::string& s)
{
  std::vector<int> out;
  for (const std::string& item : splitList(s)) {
    const int v = std::atoi(item.c_str());
    if (v < 1)
      usage("'" + item + "' is not a positive integer");
    out.push_back(v);
  }
  if (out.empty())
    usage("an empty list");
  return out;
}

// A comma-separated list of positive numbers (seconds, thresholds); `what` names one in the message.
std::vector<double> positiveList(const std::string& s, const std::string& what)
{
  std::vector<double> out;
  for (const std::string& item : splitList(s)) {
    const double v = std::atof(item.c_str());
    if (!(v > 0))
      usage("'" + item + "' is not a positive " + what);
    out.push_back(v);
  }
  return out;
}

Options parseOptions(int argc, char** argv)
{
  Options o;
  std::vector<std::pair<std::string, std::string>> later; // applied after --quick/--full
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc)
        usage(a + " needs a value");
      return argv[++i];
    };
    if (a == "--quick")
      o.plan = Plan{};
    else if (a == "--full")
      o.plan = fullPlan();
    else if (a == "--no-plots")
      o.plots = false;
    else if (a == "--references-only")
      o.referencesOnly = true;
    else if (a == "--no-adaptive")
      later.emplace_back(a, "");
    else if (a == "--no-float") {
      o.floatGiven = true;
      o.floatBinDir.clear();
    } else if (a == "--help" || a == "-h")
      usage("");
    else if (a == "--bin" || a == "--float-bin" || a == "--chapters" || a == "--scenes" || a == "--out" ||
             a == "--references" || a == "--size" || a == "--spp" || a == "--times" || a == "--seeds" ||
             a == "--reference-spp" || a == "--check-spp" || a == "--check-cell" || a == "--threads-spp" ||
             a == "--threads" ||
             a == "--replot" || a == "--adaptive" || a == "--adaptive-max-spp")
      later.emplace_back(a, value());
    else
      usage("unknown option '" + a + "'");
  }
  for (const auto& [a, v] : later) {
    if (a == "--bin")
      o.binDir = v;
    else if (a == "--float-bin") {
      o.floatBinDir = v;
      o.floatGiven = true;
    } else if (a == "--chapters")
      o.chapters = splitList(v);
    else if (a == "--scenes")
      o.scenes = splitList(v);
    else if (a == "--out")
      o.outDir = v;
    else if (a == "--references")
      o.referenceDir = v;
    else if (a == "--size") {
      if (std::sscanf(v.c_str(), "%dx%d", &o.plan.width, &o.plan.height) != 2 || o.plan.width < 1 ||
          o.plan.height < 1)
        usage("--size wants WxH, e.g. 128x96");
    } else if (a == "--spp")
      o.plan.sppLadder = intList(v);
    else if (a == "--times")
      o.plan.timeBudgets = positiveList(v, "number of seconds");
    else if (a == "--seeds")
      o.plan.seeds = intList(v)[0];
    else if (a == "--reference-spp")
      o.plan.referenceSpp = intList(v)[0];
    else if (a == "--check-spp")
      o.plan.checkSpp = intList(v)[0];
    else if (a == "--check-cell")
      o.plan.checkCell = intList(v)[0];
    else if (a == "--threads-spp")
      o.plan.threadsSpp = intList(v)[0];
    else if (a == "--threads")
      o.plan.threads = intList(v)[0];
    else if (a == "--replot")
      o.replot = v;
    else if (a == "--adaptive") {
      o.plan.adaptiveThresholds = positiveList(v, "threshold");
      if (o.plan.adaptiveThresholds.empty())
        usage("--adaptive needs a threshold (or --no-adaptive)");
    } else if (a == "--adaptive-max-spp")
      o.plan.adaptiveMaxSpp = intList(v)[0];
    else if (a == "--no-adaptive")
      o.plan.adaptiveThresholds.clear();
  }
  return o;
}

// ---- the machine and the builds -------------------------------------------------------------------------------

std::string cpuModel()
{
  std::ifstream in("/proc/cpuinfo");
  std::string line;
  while (std::getline(in, line))
    if (line.rfind("model name", 0) == 0) {
      const auto colon = line.find(':');
      if (colon != std::string::npos)
        return line.substr(colon + 2);
    }
  return "unknown CPU";
}

// The 1-minute load average, or "unknown": how busy the machine was, which every timing depends on.
std::string loadAverage()
{
  std::ifstream in("/proc/loadavg");
  std::string first;
  return in >> first ? first : std::string("unknown");
}

std::string utcNow()
{
  const std::time_t t = std::time(nullptr);
  char text[64];
  std::strftime(text, sizeof text, "%Y-%m-%d %H:%M UTC", std::gmtime(&t));
  return text;
}

// A CMake cache or compiler file's variable: `NAME:TYPE=value` or `set(NAME "value")`.
std::string cmakeValue(const fs::path& file, const std::string& name)
{
  std::ifstream in(file);
  std::string line;
  while (std::getline(in, line)) {
    if (line.rfind(name + ":", 0) == 0) {
      const auto eq = line.find('=');
      if (eq != std::string::npos)
        return line.substr(eq + 1);
    }
    const std::string set = "set(" + name + " \"";
    if (line.rfind(set, 0) == 0) {
      const std::string rest = line.substr(set.size());
      return rest.substr(0, rest.find('"'));
    }
  }
  return "";
}

/// A build's precision and its compiler and flags, read from the CMake cache beside its bin/ folder.
struct BuildInfo {
  std::string precision = "double";
  std::string description = "unknown build";
};

BuildInfo buildInfo(const fs::path& binDir)
{
  BuildInfo b;
  // The build folder is the nearest one above the programs that holds a CMake cache (build/bin -> build).
  fs::path build = binDir;
  while (!fs::exists(build / "CMakeCache.txt") && build.has_parent_path() && build != build.parent_path())
    build = build.parent_path();
  const fs::path cache = build / "CMakeCache.txt";
  if (!fs::exists(cache))
    return b;
  const std::string real = cmakeValue(cache, "RAYLIFE_REAL");
  b.precision = real.empty() ? "double" : real;
  const std::string type = cmakeValue(cache, "CMAKE_BUILD_TYPE");
  std::string upper = type;
  for (char& c : upper)
    c = char(std::toupper(static_cast<unsigned char>(c)));
  std::string flags = cmakeValue(cache, "CMAKE_CXX_FLAGS");
  const std::string typeFlags = upper.empty() ? "" : cmakeValue(cache, "CMAKE_CXX_FLAGS_" + upper);
  flags += (flags.empty() || typeFlags.empty() ? "" : " ") + typeFlags;
  std::string compiler = "unknown compiler";
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(build / "CMakeFiles", ec)) {
    const fs::path f = entry.path() / "CMakeCXXCompiler.cmake";
    if (fs::exists(f)) {
      compiler = cmakeValue(f, "CMAKE_CXX_COMPILER_ID") + " " + cmakeValue(f, "CMAKE_CXX_COMPILER_VERSION");
      break;
    }
  }
  b.description = b.precision + " " + compiler + " " + type + " " + flags;
  return b;
}

// ---- running a chapter ------------------------------------------------------------------------------------------

std::string shellQuote(const std::string& s)
{
  std::string out = "'";
  for (char c : s)
    out += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return out + "'";
}

struct RunResult {
  RenderStats stats;
  Image image;
  Image variance;
};

std::string readText(const fs::path& path)
{
  std::ifstream in(path, std::ios::binary);
  if (!in)
    throw std::runtime_error("cannot read " + path.string());
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

/// Runs `binary` on `scene` with `args`, writing its image (and variance) to `base`.pfm (.var.pfm) and its
/// stats to `base`.json, after `launcher` (e.g. "mpirun -np 4 "; empty: none). Standard error goes to `log`.
/// @throws std::runtime_error when the program fails.
RunResult runChapter(const fs::path& binary, const fs::path& scene, const Plan& plan, const std::vector<std::string>& args,
                     const fs::path& base, bool variance, const fs::path& log, const std::string& launcher = "")
{
  const fs::path image = base.string() + ".pfm", var = base.string() + ".var.pfm", stats = base.string() + ".json";
  std::string command = launcher + shellQuote(binary.string()) + " " + shellQuote(scene.string()) + " --width " +
                        std::to_string(plan.width) + " --height " + std::to_string(plan.height) + " --quiet -o " +
                        shellQuote(image.string()) + " --stats " + shellQuote(stats.string());
  if (variance)
    command.append(" --variance ").append(shellQuote(var.string()));
  for (const std::string& a : args)
    command.append(" ").append(shellQuote(a));
  {
    std::ofstream(log, std::ios::app) << "$ " << command << "\n";
  }
  const int status = std::system((command + " 2>>" + shellQuote(log.string())).c_str());
  if (status == -1 || !WIFEXITED(status) || WEXITSTATUS(status) != 0)
    throw std::runtime_error("this failed (see " + log.string() + "):\n  " + command);
  RunResult r;
  r.stats = parseStats(readText(stats));
  r.image = readPfm(image.string());
  if (variance)
    r.variance = readPfm(var.string());
  return r;
}

// ---- references --------------------------------------------------------------------------------------------------

struct Reference {
  Image image, variance;
  ReferenceCheck check;
};

/// The cached render of `key`, or a new one (cached). Returns the image and its variance.
RunResult cachedRender(const ReferenceKey& key, const Plan& plan, const fs::path& cacheDir, const fs::path& log,
                       bool& rendered)
{
  const std::string hash = hexHash(referenceHash(key));
  const fs::path base = cacheDir / (fs::path(key.scenePath).stem().string() + "-" +
                                    fs::path(key.binaryPath).filename().string() + "-" + hash);
  rendered = false;
  if (fs::exists(base.string() + ".pfm") && fs::exists(base.string() + ".var.pfm") &&
      fs::exists(base.string() + ".json")) {
    RunResult r;
    r.stats = parseStats(readText(base.string() + ".json"));
    r.image = readPfm(base.string() + ".pfm");
    r.variance = readPfm(base.string() + ".var.pfm");
    return r;
  }
  rendered = true;
  const fs::path tmp = cacheDir / ("partial-" + hash);
  // RAYLIFE_RANKS=N renders references over N MPI ranks (chapters of the MPI build: --bin build-mpi/bin): the same
  // bytes as one process (docs/beyond-one-machine.md), so the cache does not care.
  const char* ranks = std::getenv("RAYLIFE_RANKS");
  const std::string launcher = ranks && *ranks ? "mpirun -np " + shellQuote(ranks) + " " : "";
  RunResult r = runChapter(key.binaryPath, key.scenePath, plan,
                           {"--spp", std::to_string(key.spp), "--seed", std::to_string(key.seed)}, tmp, true, log,
                           launcher);
  // Only a whole set enters the cache: the stats file, written last, marks it complete.
  fs::rename(tmp.string() + ".pfm", base.string() + ".pfm");
  fs::rename(tmp.string() + ".var.pfm", base.string() + ".var.pfm");
  fs::rename(tmp.string() + ".json", base.string() + ".json");
  return r;
}

Reference makeReference(const fs::path& scene, const fs::path& best, const fs::path& second, const Plan& plan,
                        const fs::path& cacheDir, const fs::path& log)
{
  fs::create_directories(cacheDir);
  const ReferenceKey refKey{scene.string(), best.string(), plan.width, plan.height, plan.referenceSpp, kReferenceSeed};
  const ReferenceKey checkKey{scene.string(), second.string(), plan.width, plan.height, plan.checkSpp, kCheckSeed};
  const std::string refHash = hexHash(referenceHash(refKey)), checkHash = hexHash(referenceHash(checkKey));
  std::cout << "reference for " << scene.filename().string() << ": " << best.filename().string() << " at "
            << plan.referenceSpp << " spp (key " << refHash << ")" << std::flush;
  const auto start = std::chrono::steady_clock::now();
  bool rendered = false;
  RunResult ref = cachedRender(refKey, plan, cacheDir, log, rendered);
  std::cout << (rendered ? ", rendered" : ", from the cache") << "; checking against " << second.filename().string()
            << " at " << plan.checkSpp << " spp" << std::flush;
  RunResult check = cachedRender(checkKey, plan, cacheDir, log, rendered);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

  // Per cell: the sums of the means and of their variances over each cell give z of the cell's mean.
  const int cell = plan.checkCell;
  const ZTestResult z = zTestImages(cellSums(check.image, cell), cellSums(check.variance, cell),
                                    cellSums(ref.image, cell), cellSums(ref.variance, cell), kCritical, kVarianceFloor);
  Reference out{ref.image, ref.variance, {}};
  ReferenceCheck& c = out.check;
  c.scene = scene.filename().string();
  c.referenceChapter = best.filename().string();
  c.checkChapter = second.filename().string();
  c.referenceSpp = plan.referenceSpp;
  c.checkSpp = plan.checkSpp;
  c.cell = cell;
  c.referenceVariance = relativeVariancePerSample(ref.variance, plan.referenceSpp, ref.image);
  c.checkVariance = relativeVariancePerSample(check.variance, plan.checkSpp, ref.image);
  c.critical = kCritical;
  c.failedShare = z.failedShare;
  c.maxFailedShare = kMaxFailedShare;
  c.totalZ = z.totalZ;
  c.passed = std::abs(z.totalZ) <= kCritical && z.failedShare <= kMaxFailedShare;
  c.hash = refHash;
  std::cout << " (" << formatNumber(seconds, 3) << " s): " << formatNumber(z.failedShare * 100, 3) << "% of "
            << (cell > 1 ? std::to_string(cell) + "x" + std::to_string(cell) + " cells' " : std::string())
            << "channels over |z| " << kCritical << ", total z " << formatNumber(z.totalZ, 3) << " -> "
            << (c.passed ? "trusted" : "NOT TRUSTED") << "\n";
  nlohmann::json j = {{"reference", refHash},  {"check", checkHash},         {"failed_share", z.failedShare},
                      {"total_z", z.totalZ},   {"critical", kCritical},      {"passed", c.passed},
                      {"mean_z", z.meanZ},     {"max_failed_share", kMaxFailedShare}, {"cell", cell},
                      {"reference_variance_per_sample", c.referenceVariance},
                      {"check_variance_per_sample", c.checkVariance}};
  std::ofstream(cacheDir / ("check-" + refHash + "-" + checkHash + ".json")) << j.dump(2) << "\n";
  if (ref.stats.badSamples || check.stats.badSamples)
    std::cout << "  note: " << ref.stats.badSamples + check.stats.badSamples << " bad samples in the reference renders\n";
  return out;
}

// ---- the plots ---------------------------------------------------------------------------------------------------

std::string shortName(const std::string& chapter) { return chapter.substr(0, chapter.find('_')); }

void writePlots(const std::vector<Row>& rows, const std::vector<std::string>& scenes,
                const std::vector<std::string>& chapters, const fs::path& outDir, bool draw, std::vector<std::string>& notes)
{
  std::vector<PlotPanel> sppPanels, timePanels;
  const std::string precision = mainPrecision(rows);
  for (const std::string& scene : scenes) {
    PlotPanel bySpp{scene, {}, std::nullopt}, byTime{scene, {}, std::nullopt};
    for (const std::string& chapter : chapters) {
      const std::vector<LadderPoint> spp = ladder(rows, scene, chapter, RowKind::Spp, precision);
      // One colour per chapter: its plain ladder a line, its equal-time renders dots, its float build squares, its
      // adaptive renders a dashed line with open circles.
      const int color = int(&chapter - chapters.data()) + 1;
      Series s{chapter, {}, {}, false, false, color}, t{chapter, {}, {}, false, false, color};
      for (const LadderPoint& p : spp) {
        s.x.push_back(p.spp);
        s.y.push_back(p.relativeMse);
        t.x.push_back(p.seconds);
        t.y.push_back(p.relativeMse);
      }
      if (!s.x.empty()) {
        if (!bySpp.anchor)
          bySpp.anchor = std::pair{s.x.front(), s.y.front()};
        if (!byTime.anchor)
          byTime.anchor = std::pair{t.x.front(), t.y.front()};
        bySpp.series.push_back(s);
        byTime.series.push_back(t);
      }
      Series eq{shortName(chapter) + " equal time", {}, {}, true, false, color};
      for (const LadderPoint& p : ladder(rows, scene, chapter, RowKind::Time, precision)) {
        eq.x.push_back(p.seconds);
        eq.y.push_back(p.relativeMse);
      }
      if (!eq.x.empty())
        byTime.series.push_back(eq);
      Series fl{shortName(chapter) + " float build", {}, {}, true, false, color, 5};
      for (const LadderPoint& p : ladder(rows, scene, chapter, RowKind::Precision, "float")) {
        fl.x.push_back(p.seconds);
        fl.y.push_back(p.relativeMse);
      }
      if (!fl.x.empty())
        byTime.series.push_back(fl);
      // Adaptive sampling: error against seconds, and against the mean spp, threshold by threshold.
      std::vector<LadderPoint> adaptive = ladder(rows, scene, chapter, RowKind::Adaptive, precision);
      std::sort(adaptive.begin(), adaptive.end(),
                [](const LadderPoint& a, const LadderPoint& b) { return a.budget > b.budget; });
      Series at{shortName(chapter) + " adaptive", {}, {}, false, true, color};
      Series as = at;
      for (const LadderPoint& p : adaptive) {
        at.x.push_back(p.seconds);
        at.y.push_back(p.relativeMse);
        as.x.push_back(p.meanSpp);
        as.y.push_back(p.relativeMse);
      }
      if (!at.x.empty()) {
        byTime.series.push_back(at);
        bySpp.series.push_back(as);
      }
    }
    sppPanels.push_back(bySpp);
    timePanels.push_back(byTime);
  }
  const fs::path sppScript = outDir / "error_vs_spp.gp", timeScript = outDir / "error_vs_time.gp";
  std::ofstream(sppScript) << gnuplotScript(sppPanels, "samples per pixel", "relative MSE",
                                            (outDir / "error_vs_spp").string());
  std::ofstream(timeScript) << gnuplotScript(timePanels, "render seconds", "relative MSE",
                                             (outDir / "error_vs_time").string());
  if (!draw)
    return;
  if (std::system("command -v gnuplot >/dev/null 2>&1") != 0) {
    notes.push_back("Plots not drawn: gnuplot is missing (./setup.sh --bench installs gnuplot-nox); the scripts are "
                    "error_vs_spp.gp and error_vs_time.gp.");
    return;
  }
  for (const fs::path& script : {sppScript, timeScript})
    if (std::system(("gnuplot " + shellQuote(script.string())).c_str()) != 0)
      notes.push_back("gnuplot failed on " + script.filename().string());
}

} // namespace

int main(int argc, char** argv)
{
  Options o = parseOptions(argc, argv);
  Plan& plan = o.plan;
  try {
    if (!o.replot.empty()) {
      // Draw and summarise an earlier run again: the rows carry everything but the reference checks.
      const std::vector<Row> rows = parseCsv(readText(o.replot));
      if (rows.empty())
        throw std::runtime_error(o.replot + " has no rows");
      const fs::path out = o.outDir.empty() ? fs::absolute(o.replot).parent_path() : o.outDir;
      fs::create_directories(out);
      std::vector<std::string> scenes, chapters;
      for (const Row& r : rows) {
        if (std::find(scenes.begin(), scenes.end(), r.scene) == scenes.end())
          scenes.push_back(r.scene);
        if (std::find(chapters.begin(), chapters.end(), r.chapter) == chapters.end())
          chapters.push_back(r.chapter);
      }
      SummaryContext context;
      context.mode = rows.front().mode;
      context.date = "see " + o.replot + " (summary regenerated " + utcNow() + ")";
      context.machine = "not recorded in the CSV";
      context.build = rows.front().build;
      context.conditions = "as in the run that wrote the CSV; the reference checks are not repeated here";
      context.baselineChapter = std::find(chapters.begin(), chapters.end(), "step06_path_tracer") != chapters.end()
                                    ? "step06_path_tracer"
                                    : chapters.front();
      writePlots(rows, scenes, chapters, out, o.plots, context.notes);
      std::ofstream(out / "summary.md") << summaryMarkdown(rows, context);
      std::cout << "raylife_bench: redrew the plots and the summary of " << o.replot << " in " << out.string() << "\n";
      return 0;
    }
    if (o.binDir.empty())
      o.binDir = fs::canonical("/proc/self/exe").parent_path();
    o.binDir = fs::absolute(o.binDir);
    if (!o.floatGiven) {
      const fs::path f = projectRoot() / "build-float" / "bin";
      if (fs::is_directory(f) && fs::absolute(f) != o.binDir)
        o.floatBinDir = f;
    }
    if (o.outDir.empty())
      o.outDir = o.binDir.parent_path() / "bench" / plan.mode;
    if (o.referenceDir.empty())
      o.referenceDir = o.binDir.parent_path() / "bench" / "references";
    fs::create_directories(o.outDir);
    fs::create_directories(o.outDir / "runs");

    std::vector<std::string> chapters = o.chapters;
    if (chapters.empty())
      for (const std::string& c : kDefaultChapters)
        if (fs::exists(o.binDir / c))
          chapters.push_back(c);
    for (const std::string& c : chapters)
      if (!fs::exists(o.binDir / c))
        throw std::runtime_error("no chapter program " + (o.binDir / c).string());
    if (chapters.empty())
      throw std::runtime_error("no Monte Carlo chapter program (step06_path_tracer, step07_light_sampling, "
                               "step08_mis) in " + o.binDir.string() + ": build them first");

    std::vector<fs::path> scenes;
    const fs::path sceneDir = findSceneDirectory();
    auto resolveScene = [&](const std::string& s) -> fs::path {
      if (fs::exists(s))
        return fs::absolute(s);
      if (fs::exists(sceneDir / s))
        return sceneDir / s;
      return {};
    };
    if (o.scenes.empty()) {
      for (const std::string& s : kDefaultScenes)
        if (fs::path p = resolveScene(s); !p.empty())
          scenes.push_back(p);
      if (scenes.empty())
        throw std::runtime_error("no default scene (cornell.json) under " + sceneDir.string());
    } else
      for (const std::string& s : o.scenes) {
        const fs::path p = resolveScene(s);
        if (p.empty())
          throw std::runtime_error("no scene " + s + " (neither a path nor a file under " + sceneDir.string() + ")");
        scenes.push_back(p);
      }

    const BuildInfo main = buildInfo(o.binDir);
    std::optional<BuildInfo> floatBuild;
    if (!o.floatBinDir.empty())
      floatBuild = buildInfo(o.floatBinDir);
    const int threads = plan.threads > 0 ? plan.threads : int(std::max(1u, std::thread::hardware_concurrency()));
    const fs::path log = o.outDir / "runs.log";
    fs::remove(log);

    std::string conditions =
        std::to_string(plan.width) + "×" + std::to_string(plan.height) + " pixels; spp ladder " +
        [&] {
          std::string s;
          for (int n : plan.sppLadder)
            s += (s.empty() ? "" : ",") + std::to_string(n);
          return s;
        }() +
        "; equal-time budgets " +
        [&] {
          std::string s;
          for (double t : plan.timeBudgets)
            s += (s.empty() ? "" : ",") + formatNumber(t, 3);
          return s;
        }() +
        " s; " + std::to_string(plan.seeds) + " seeds each; " + std::to_string(threads) +
        " threads (thread scaling: 1 against " + std::to_string(threads) + " at " + std::to_string(plan.threadsSpp) +
        " spp); reference " + std::to_string(plan.referenceSpp) + " spp, check " + std::to_string(plan.checkSpp) +
        " spp" + (plan.checkCell > 1 ? " in cells of " + std::to_string(plan.checkCell) + "×" +
                          std::to_string(plan.checkCell) + " pixels" : std::string()) + "; adaptive " +
        [&] {
          std::string s;
          for (double e : plan.adaptiveThresholds)
            s.append(s.empty() ? "thresholds " : ",").append(formatNumber(e, 3));
          return s.empty() ? std::string("not run") : s + " up to " + std::to_string(plan.adaptiveCap()) + " spp";
        }();
    const char* waitPolicy = std::getenv("OMP_WAIT_POLICY");
    conditions += std::string("; OMP_WAIT_POLICY ") + (waitPolicy ? waitPolicy : "unset");
    SummaryContext context;
    context.mode = plan.mode;
    context.date = utcNow();
    context.machine = cpuModel() + ", " + std::to_string(std::thread::hardware_concurrency()) + " hardware threads";
    context.build = main.description;
    context.conditions = conditions;
    context.baselineChapter = std::find(chapters.begin(), chapters.end(), "step06_path_tracer") != chapters.end()
                                  ? "step06_path_tracer"
                                  : chapters.front();
    std::cout << "raylife_bench " << plan.mode << ": chapters";
    for (const std::string& c : chapters)
      std::cout << " " << c;
    std::cout << "; scenes";
    for (const fs::path& s : scenes)
      std::cout << " " << s.filename().string();
    std::cout << "\n  " << conditions << "\n  build: " << main.description << "\n  float build: "
              << (floatBuild ? o.floatBinDir.string() : std::string("none")) << "\n  results: " << o.outDir.string()
              << "\n";

    const std::string loadAtStart = loadAverage();
    std::vector<Row> rows;
    const fs::path csvPath = o.outDir / "results.csv";
    std::ofstream csv;
    if (!o.referencesOnly) // never truncate an earlier run's results for a references-only run
      csv.open(csvPath), csv << csvHeader() << "\n";
    int runIndex = 0;

    for (const fs::path& scene : scenes) {
      const std::string sceneName = scene.filename().string();
      const fs::path best = o.binDir / chapters.back();
      const fs::path second = o.binDir / (chapters.size() > 1 ? chapters.front() : chapters.back());
      const Reference ref = makeReference(scene, best, second, plan, o.referenceDir, log);
      context.checks.push_back(ref.check);
      if (!ref.check.passed)
        throw std::runtime_error("the reference of " + sceneName + " failed its check against " +
                                 ref.check.checkChapter + ": no figure is measured against an untrusted reference");
      if (o.referencesOnly)
        continue;

      auto measure = [&](const fs::path& binDir, const BuildInfo& build, const std::string& chapter, RowKind kind,
                         BudgetUnit unit, double budget, int threadCount, std::uint64_t seed) {
        std::vector<std::string> args = {"--seed", std::to_string(seed), "--threads", std::to_string(threadCount)};
        if (unit == BudgetUnit::Seconds)
          args.insert(args.end(), {"--time", formatNumber(budget, 6)});
        else if (unit == BudgetUnit::Spp)
          args.insert(args.end(), {"--spp", std::to_string(int(budget))});
        else
          args.insert(args.end(),
                      {"--adaptive", formatNumber(budget, 6), "--spp", std::to_string(plan.adaptiveCap())});
        const RunResult r =
            runChapter(binDir / chapter, scene, plan, args, o.outDir / "runs" / "run", false, log);
        Row row;
        row.mode = plan.mode;
        row.kind = kind;
        row.scene = sceneName;
        row.chapter = chapter;
        row.precision = build.precision;
        row.build = build.description;
        row.threads = r.stats.threads;
        row.seed = seed;
        row.budget = budget;
        row.unit = unit;
        row.spp = r.stats.spp;
        row.meanSpp = r.stats.meanSpp;
        row.seconds = r.stats.seconds;
        row.rays = r.stats.rays;
        row.badSamples = r.stats.badSamples;
        row.error = measureError(r.image, ref.image, ref.variance);
        rows.push_back(row);
        csv << csvLine(row) << "\n" << std::flush;
        std::printf("[%d] %s %s %s %s=%s seed %llu, %d thr: %s spp, %.3f s, rel. MSE %.4g\n", ++runIndex,
                    sceneName.c_str(), chapter.c_str(), toString(kind).c_str(), toString(unit).c_str(),
                    formatNumber(budget, 4).c_str(), static_cast<unsigned long long>(seed), row.threads,
                    formatNumber(row.meanSpp, 4).c_str(), row.seconds, row.error.relativeMse);
        std::fflush(stdout);
      };

      // Interleaved: seed by seed, budget by budget, the chapters (and each one's float build) one after the
      // other, so that a change in the machine's load during the run falls on every chapter alike and the ratios
      // between chapters, measured side by side, stay fair.
      std::vector<std::string> floatChapters;
      if (floatBuild)
        for (const std::string& chapter : chapters) {
          if (fs::exists(o.floatBinDir / chapter))
            floatChapters.push_back(chapter);
          else if (&scene == &scenes.front())
            context.notes.push_back("No float build of " + chapter + " in " + o.floatBinDir.string() + ".");
        }
      auto hasFloat = [&](const std::string& c) {
        return std::find(floatChapters.begin(), floatChapters.end(), c) != floatChapters.end();
      };
      const bool threadsSppOnLadder =
          std::find(plan.sppLadder.begin(), plan.sppLadder.end(), plan.threadsSpp) != plan.sppLadder.end();
      for (int s = 1; s <= plan.seeds; ++s) {
        const auto seed = std::uint64_t(s);
        for (int spp : plan.sppLadder)
          for (const std::string& chapter : chapters)
            measure(o.binDir, main, chapter, RowKind::Spp, BudgetUnit::Spp, spp, threads, seed);
        for (const std::string& chapter : chapters) {
          if (threads > 1) {
            // The ladder must hold the same budget for the comparison; add it when the ladder lacks it.
            if (!threadsSppOnLadder)
              measure(o.binDir, main, chapter, RowKind::Spp, BudgetUnit::Spp, plan.threadsSpp, threads, seed);
            measure(o.binDir, main, chapter, RowKind::Threads, BudgetUnit::Spp, plan.threadsSpp, 1, seed);
          }
          if (hasFloat(chapter))
            measure(o.floatBinDir, *floatBuild, chapter, RowKind::Precision, BudgetUnit::Spp, plan.threadsSpp, threads,
                    seed);
        }
        for (double t : plan.timeBudgets)
          for (const std::string& chapter : chapters) {
            measure(o.binDir, main, chapter, RowKind::Time, BudgetUnit::Seconds, t, threads, seed);
            if (hasFloat(chapter))
              measure(o.floatBinDir, *floatBuild, chapter, RowKind::Precision, BudgetUnit::Seconds, t, threads, seed);
          }
        for (double e : plan.adaptiveThresholds)
          for (const std::string& chapter : chapters)
            measure(o.binDir, main, chapter, RowKind::Adaptive, BudgetUnit::RelativeError, e, threads, seed);
      }
    }
    if (o.referencesOnly) {
      fs::remove_all(o.outDir / "runs");
      std::cout << "raylife_bench: every reference is in " << o.referenceDir.string() << " and passed its check\n";
      return 0;
    }
    context.notes.push_back("Load average (1 minute) at the start " + loadAtStart + ", at the end " + loadAverage() +
                            ", on " + std::to_string(std::thread::hardware_concurrency()) +
                            " hardware threads: above that count, other jobs were competing for the cores.");
    if (!floatBuild)
      context.notes.push_back("Float against double skipped: no float build (cmake --preset float && cmake --build "
                              "--preset float, or --float-bin DIR).");
    if (threads < 2)
      context.notes.push_back("Thread scaling skipped: one thread only.");
    csv.close();

    std::vector<std::string> sceneNames;
    for (const fs::path& s : scenes)
      sceneNames.push_back(s.filename().string());
    writePlots(rows, sceneNames, chapters, o.outDir, o.plots, context.notes);
    const std::string summary = summaryMarkdown(rows, context);
    std::ofstream(o.outDir / "summary.md") << summary;
    fs::remove_all(o.outDir / "runs");
    std::cout << "\n" << summary << "\nraylife_bench: wrote " << csvPath.string() << ", summary.md"
              << (o.plots ? ", error_vs_time.svg/.png, error_vs_spp.svg/.png" : "") << " in " << o.outDir.string()
              << "\n";
    for (const SlopeResult& s : fitSlopes(rows))
      if (!s.acceptable)
        std::cout << "raylife_bench: FLAGGED: " << s.scene << " " << s.chapter << " has slope "
                  << formatNumber(s.fit.slope, 4) << ", outside −1 ± " << kSlopeTolerance
                  << (s.fit.slope > kIdealSlope ? " (shallower: an error floor, as a bias gives, or a heavy tail)"
                                                : " (steeper: as stratified pixel positions give on edges)")
                  << "\n";
    for (const std::string& n : context.notes)
      if (n.rfind("Plots not drawn", 0) == 0 || n.rfind("gnuplot failed", 0) == 0)
        return 3;
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "raylife_bench: " << e.what() << "\n";
    return 1;
  }
}

#include "render_loop.h"

#include "image_io.h"
#include "scene_plan.h"

#include <omp.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstring>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>

#include <signal.h>
#include <unistd.h>

#ifndef RAYLIFE_SCENE_DIR
#error "RAYLIFE_SCENE_DIR must be defined by the build"
#endif

namespace raylife {

namespace {

using Clock = std::chrono::steady_clock;

constexpr int kTileSize = 16;
// A batch of samples is cut to about this long, so that Ctrl-C and a time budget are answered within it.
constexpr double kBatchSeconds = 0.25;

struct Tile {
  int x0, y0, x1, y1;
};

std::vector<Tile> makeTiles(int width, int height)
{
  std::vector<Tile> tiles;
  for (int y = 0; y < height; y += kTileSize)
    for (int x = 0; x < width; x += kTileSize)
      tiles.push_back({x, y, std::min(x + kTileSize, width), std::min(y + kTileSize, height)});
  return tiles;
}

// The side of the grid of strata the pixel's samples are spread over: √spp rounded down; 0 when the sample count
// is not known in advance (--time, adaptive sampling), for which the pixel's sequence stratifies instead.
int strataPerSide(std::optional<int> spp) { return spp ? int(std::sqrt(double(*spp))) : 0; }

// Where sample s of a pixel falls inside it, in [0, 1)²: jittered in its stratum when s < n², else anywhere; with
// n = 0, point s of the pixel's scrambled Sobol sequence, stratified at every power of two and in every aligned
// block of 16 samples (what a pixel takes between two adaptive checkpoints is whole such blocks).
Vec2 pixelOffset(PixelSampling mode, int s, int n, Sampler& sampler, const PixelSequence& sequence)
{
  if (mode == PixelSampling::Centre)
    return Vec2(Real(0.5));
  if (n == 0)
    return sequence.point(std::uint32_t(s));
  const Vec2 jitter = sampler.next2D();
  if (n == 1 || std::int64_t(s) >= std::int64_t(n) * n)
    return jitter;
  // Stratified: cell (s mod n, s div n) of an n × n grid, jittered inside the cell.
  const Real cx = Real(s % n), cy = Real(s / n);
  return Vec2((cx + jitter.x) / Real(n), (cy + jitter.y) / Real(n));
}

// The sample count at which adaptive sampling looks at the pixels again, after looking at `done`: a quarter more
// (in steps of kAdaptiveMinSamples), so that a pixel takes at most about 25 % more samples than it needed, and a
// long render has few checkpoints (each one a pass over the film and the end of a batch).
int adaptiveCheckpointAfter(int done)
{
  return done + std::max(kAdaptiveMinSamples, done / 4 / kAdaptiveMinSamples * kAdaptiveMinSamples);
}

// Two images of one height side by side: `left`, then `right`.
Image sideBySide(const Image& left, const Image& right)
{
  Image both(left.width + right.width, left.height);
  for (int y = 0; y < left.height; ++y)
    for (int c = 0; c < 3; ++c) {
      for (int x = 0; x < left.width; ++x)
        both.at(x, y, c) = left.at(x, y, c);
      for (int x = 0; x < right.width; ++x)
        both.at(left.width + x, y, c) = right.at(x, y, c);
    }
  return both;
}

void drawProgress(double fraction, double elapsed)
{
  const int width = 40;
  const int filled = int(std::clamp(fraction, 0.0, 1.0) * width);
  std::fprintf(stderr, "\r[%.*s%*s] %3d%%  %.1f s ", filled, "########################################",
               width - filled, "", int(fraction * 100), elapsed);
  std::fflush(stderr);
}

} // namespace

RenderResult render(const Scene& scene, const Camera& camera, const RenderSettings& settings,
                    const TraceFunction& trace)
{
  const int width = camera.width(), height = camera.height();
  RenderResult result{Film(width, height)};
  const std::vector<Tile> allTiles = makeTiles(width, height);
  std::vector<Tile> tiles = allTiles; // the work of a batch (adaptive sampling narrows it to the active pixels)
  const int threads = settings.threads > 0 ? settings.threads : omp_get_max_threads();
  const int target = settings.spp ? *settings.spp : (settings.seconds ? 0 : 1); // 0: until the time is spent
  const int strata = strataPerSide(settings.adaptive ? std::nullopt : settings.spp);

  const auto start = Clock::now();
  auto elapsed = [&] { return std::chrono::duration<double>(Clock::now() - start).count(); };
  double lastDraw = -1;

  // Samples are taken in batches: batch [s0, s1) gives every pixel samples s0 .. s1 − 1, in that order. A batch
  // is one OpenMP region, so a batch of many samples keeps the threads busy without a fork and join per sample
  // (which, on a loaded machine, costs more than the samples of a small image). Batches double in size, and are
  // cut to about kBatchSeconds (and to what is left of a time budget) so that a stop request is answered soon.
  int done = 0;
  // Adaptive sampling: which pixels still take samples (1) or have stopped (0), decided between batches.
  std::vector<unsigned char> active(std::size_t(width) * std::size_t(height), 1);
  std::size_t activeCount = active.size();
  std::uint64_t samplesTaken = 0;
  int nextCheckpoint = kAdaptiveMinSamples;
  while (target == 0 || done < target) {
    if (settings.adaptive && done == nextCheckpoint) {
      // A checkpoint: stop each pixel whose estimated relative error is below the threshold, and its eight
      // neighbours' too. (Alone, a pixel on an edge whose samples all happened to miss the object shows no
      // variance and would stop with its error; a neighbour that saw the edge keeps it going.)
      std::vector<unsigned char> below(active.size());
      for (int y = 0; y < height; ++y)
        for (int x = 0; x < width; ++x) {
          const double error = result.film.relativeError(x, y, kAdaptiveMeanFloor);
          // (+∞ at this count: every sample black; after kAdaptiveBlackSamples of them, taken as black.)
          const bool black = std::isinf(error) && result.film.samples(x, y) >= std::uint32_t(kAdaptiveBlackSamples);
          below[std::size_t(y) * std::size_t(width) + std::size_t(x)] = error < *settings.adaptive || black;
        }
      activeCount = 0;
      for (int y = 0; y < height; ++y)
        for (int x = 0; x < width; ++x) {
          unsigned char& a = active[std::size_t(y) * std::size_t(width) + std::size_t(x)];
          bool settled = true;
          for (int ny = std::max(0, y - 1); ny <= std::min(height - 1, y + 1); ++ny)
            for (int nx = std::max(0, x - 1); nx <= std::min(width - 1, x + 1); ++nx)
              settled = settled && below[std::size_t(ny) * std::size_t(width) + std::size_t(nx)];
          if (a && settled)
            a = 0;
          activeCount += a;
        }
      if (activeCount == 0)
        break;
      nextCheckpoint = adaptiveCheckpointAfter(done);
      // Hand out only the rows of tiles that still have active pixels, so that the threads share the work left
      // even when it gathers in a few tiles.
      tiles.clear();
      for (const Tile& t : allTiles)
        for (int y = t.y0; y < t.y1; ++y) {
          const auto row = active.begin() + std::ptrdiff_t(std::size_t(y) * std::size_t(width));
          if (std::find(row + t.x0, row + t.x1, 1) != row + t.x1)
            tiles.push_back({t.x0, y, t.x1, y + 1});
        }
    }
    if (done > 0 && settings.seconds && elapsed() >= *settings.seconds)
      break;
    if (done > 0 && settings.stop && settings.stop->load()) {
      result.interrupted = true;
      break;
    }
    int batch = std::max(1, done);
    if (done > 0) {
      const double perSample = elapsed() / done;
      double budget = kBatchSeconds;
      if (settings.seconds)
        budget = std::min(budget, *settings.seconds - elapsed());
      batch = std::clamp(int(budget / std::max(perSample, 1e-9)), 1, batch);
    }
    if (target > 0)
      batch = std::min(batch, target - done);
    if (settings.adaptive) // end the batch at the next checkpoint
      batch = std::min(batch, nextCheckpoint - done);
    const int s0 = done, s1 = done + batch;

    std::uint64_t rays = 0, bad = 0;
    std::atomic<int> tilesDone{0};
#pragma omp parallel num_threads(threads) reduction(+ : rays, bad)
    {
      const std::uint64_t raysBefore = rayCount();
#pragma omp for schedule(dynamic, 1)
      for (std::size_t t = 0; t < tiles.size(); ++t) {
        const Tile& tile = tiles[t];
        // [pixel_loop]
        for (int y = tile.y0; y < tile.y1; ++y)
          for (int x = tile.x0; x < tile.x1; ++x) {
            if (!active[std::size_t(y) * std::size_t(width) + std::size_t(x)])
              continue; // stopped by adaptive sampling
            const PixelSequence sequence(settings.seed, x, y);
            for (int s = s0; s < s1; ++s) {
              // One pixel sample: its own random numbers, a film position, the chapter's estimate.
              Sampler sampler(settings.seed, x, y, std::uint64_t(s));
              const Vec2 offset = pixelOffset(settings.pixelSampling, s, strata, sampler, sequence);
              const Ray ray = camera.ray(Vec2(Real(x), Real(y)) + offset);
              Color L = trace(scene, ray, sampler, settings.maxDepth);
              // Guard the film: a NaN, infinite or negative sample is counted and replaced by black.
              if (!isFinite(L) || L.r < 0 || L.g < 0 || L.b < 0) {
                ++bad;
                L = Color(0);
              }
              result.film.add(x, y, L);
            }
          }
        // [pixel_loop]
        const int tilesFinished = ++tilesDone;
        if (settings.progress && omp_get_thread_num() == 0) {
          const double now = elapsed();
          if (now - lastDraw > 0.1) {
            lastDraw = now;
            const double samples = s0 + double(batch) * tilesFinished / double(tiles.size());
            drawProgress(target > 0 ? samples / target : now / *settings.seconds, now);
          }
        }
      }
      rays += rayCount() - raysBefore;
    }
    result.rays += rays;
    result.badSamples += bad;
    done = s1;
    result.spp = done;
    samplesTaken += std::uint64_t(batch) * activeCount;
  }
  result.meanSpp = double(samplesTaken) / double(active.size());
  result.seconds = elapsed();
  if (settings.progress) {
    drawProgress(1.0, result.seconds);
    std::fprintf(stderr, "\n");
  }
  return result;
}

std::string describeIgnored(const Scene& scene, unsigned uses, bool maxDepthGiven)
{
  std::vector<std::string> parts;
  auto plural = [](std::size_t n, const std::string& one, const std::string& many) {
    return std::to_string(n) + " " + (n == 1 ? one : many);
  };
  if (!(uses & kUsesSpheres))
    parts.push_back(plural(scene.spheres.size(), "sphere", "spheres"));
  if (!(uses & kUsesColors) && (uses & kUsesSpheres))
    parts.push_back("material colours");
  if (!(uses & kUsesPointLights) && !scene.lights.empty())
    parts.push_back(plural(scene.lights.size(), "point light", "point lights"));
  if (!(uses & kUsesAmbient) && scene.ambient != Color(0))
    parts.push_back("the ambient term");
  if (!(uses & kUsesBackground) && scene.background != Color(0))
    parts.push_back("the background");
  if (uses & kUsesSpheres) {
    std::size_t emissive = 0, asDiffuse = 0;
    std::vector<bool> used(scene.materials.size(), false);
    for (const Sphere& s : scene.spheres)
      used[std::size_t(s.material)] = true;
    for (std::size_t i = 0; i < scene.materials.size(); ++i) {
      if (!used[i])
        continue; // an unused material is the loader's warning, not something the chapter ignores
      const Material& m = scene.materials[i];
      emissive += m.isEmissive() && !(uses & kUsesEmission);
      asDiffuse += (m.type == MaterialType::Mirror && !(uses & kUsesMirror)) ||
                   (m.type == MaterialType::Glass && !(uses & kUsesGlass)) ||
                   (m.type == MaterialType::Glossy && !(uses & kUsesGlossy));
    }
    if (emissive)
      parts.push_back("the emission of " + plural(emissive, "material", "materials"));
    if (asDiffuse)
      parts.push_back("the reflection and refraction of " + plural(asDiffuse, "material", "materials") +
                      " (shaded as diffuse)");
  }
  if (maxDepthGiven && !(uses & kUsesMaxDepth))
    parts.push_back("--max-depth (nothing here recurses)");
  std::string out;
  for (std::size_t i = 0; i < parts.size(); ++i)
    out += (i == 0 ? "" : (i + 1 == parts.size() ? " and " : ", ")) + parts[i];
  return out;
}

std::optional<double> applyPlanOptions(const std::string& name, const Scene& scene, const ChapterInfo& chapter,
                                       const RenderOptions& options)
{
  if (options.verbose)
    for (const std::string& line : describePlan(planScene(scene, chapter.uses)))
      std::cerr << name << ": " << line << "\n";
  if (options.adaptive && !chapter.adaptiveSampling) {
    if (!options.quiet)
      std::cerr << name << ": ignores --adaptive (only the Monte Carlo chapters 6 to 8 sample adaptively)\n";
    return std::nullopt;
  }
  if (options.verbose && options.adaptive)
    std::cerr << name << ": plan: adaptive sampling -> a pixel stops once its relative error < " << *options.adaptive
              << " (checked every " << kAdaptiveMinSamples << " samples)\n";
  return options.adaptive;
}

std::string sceneDirectory() { return RAYLIFE_SCENE_DIR; }

namespace {

// Ctrl-C (or SIGTERM) once: finish the pass in flight, write what there is, exit 130. Twice: stop at once and
// write nothing. The handler touches only lock-free atomics and _exit, which are async-signal-safe.
std::atomic<int> gSignals{0};            // SIGINT and SIGTERM received since the handlers were installed
std::atomic<bool> gStopRequested{false}; // the render loop stops after the pass in flight
std::atomic<bool> gWriting{false};       // the images are being written: a second signal cancels the write
std::atomic<bool> gCancelWrite{false};   // writeFilesAtomically removes its temporary files and gives up
static_assert(std::atomic<int>::is_always_lock_free && std::atomic<bool>::is_always_lock_free,
              "the signal handler may only touch lock-free atomics");

extern "C" void onInterrupt(int)
{
  if (gSignals.fetch_add(1) == 0) {
    gStopRequested.store(true);
    return;
  }
  if (gWriting.load()) {
    gCancelWrite.store(true); // the writer removes its temporary files; nothing is renamed into place
    return;
  }
  static const char message[] = "\ninterrupted twice: stopped without writing\n";
  [[maybe_unused]] const ssize_t ignored = ::write(STDERR_FILENO, message, sizeof message - 1);
  _exit(130);
}

// Installs onInterrupt for SIGINT and SIGTERM while it lives; puts the previous handlers back after.
class InterruptHandlers {
public:
  InterruptHandlers()
  {
    gSignals = 0;
    gStopRequested = false;
    gWriting = false;
    gCancelWrite = false;
    struct sigaction action{};
    action.sa_handler = onInterrupt;
    sigemptyset(&action.sa_mask);
    action.sa_flags = SA_RESTART; // a signal must not make a write() or read() fail with EINTR
    sigaction(SIGINT, &action, &previousInt_);
    sigaction(SIGTERM, &action, &previousTerm_);
  }
  ~InterruptHandlers()
  {
    sigaction(SIGINT, &previousInt_, nullptr);
    sigaction(SIGTERM, &previousTerm_, nullptr);
  }
  InterruptHandlers(const InterruptHandlers&) = delete;
  InterruptHandlers& operator=(const InterruptHandlers&) = delete;

private:
  struct sigaction previousInt_{};
  struct sigaction previousTerm_{};
};

// Checks, before any work, that a file can be written: its folder exists and is writable, and it is no folder.
void checkWritable(const std::string& path)
{
  namespace fs = std::filesystem;
  fs::path folder = fs::path(path).parent_path();
  if (folder.empty())
    folder = ".";
  std::error_code ec;
  if (!fs::is_directory(folder, ec))
    throw ImageIoError("cannot write " + path + ": the folder " + folder.string() + " does not exist");
  if (::access(folder.c_str(), W_OK) != 0)
    throw ImageIoError("cannot write " + path + ": the folder " + folder.string() + " is not writable (" +
                       std::strerror(errno) + ")");
  if (fs::is_directory(path, ec))
    throw ImageIoError("cannot write " + path + ": it is a folder");
}

std::string formatCount(std::uint64_t n)
{
  char buffer[32];
  if (n >= 1000000)
    std::snprintf(buffer, sizeof buffer, "%.1f M", double(n) / 1e6);
  else
    std::snprintf(buffer, sizeof buffer, "%llu", static_cast<unsigned long long>(n));
  return buffer;
}

} // namespace

int runChapter(int argc, char** argv, const ChapterInfo& chapter, const TraceFunction& trace)
{
  return runChapter(argc, argv, chapter, TraceFactory([&trace](const Scene&) { return trace; }));
}

int runChapter(int argc, char** argv, const ChapterInfo& chapter, const TraceFactory& makeTrace)
{
  const std::string name = chapter.binary;
  RenderOptions options;
  try {
    options = parseCommandLine(argc, argv);
  } catch (const UsageError& e) {
    std::cerr << name << ": " << e.what() << "\n" << "usage: " << name << " [SCENE.json] [options]; see --help\n";
    return 2;
  }
  const std::string defaultScene = sceneDirectory() + "/" + chapter.defaultScene;
  if (options.help) {
    std::cout << usageText(name, defaultScene);
    return 0;
  }

  try {
    // Load and check everything before any work: scene, size, outputs.
    const Scene scene = loadScene(options.scenePath.empty() ? defaultScene : options.scenePath);
    for (const std::string& w : scene.warnings)
      std::cerr << name << ": warning: " << w << "\n";
    const int width = options.width ? options.width : scene.camera.width;
    const int height = options.height ? options.height : scene.camera.height;
    if (std::int64_t(width) * height > kMaxPixels) {
      std::cerr << name << ": --width/--height: an image of " << width << "x" << height << " pixels is larger than the "
                << kMaxPixels << " pixels raylife allows\n";
      return 2;
    }
    std::vector<std::string> outputs = options.outputs;
    if (outputs.empty()) {
      std::filesystem::create_directories("out");
      outputs.push_back("out/" + name + ".png");
    }
    // (parseCommandLine has checked the extensions.)
    for (const std::string& path : outputs)
      checkWritable(path);
    if (!options.variancePath.empty())
      checkWritable(options.variancePath);
    if (!options.statsPath.empty())
      checkWritable(options.statsPath);
    if (const std::string ignored = describeIgnored(scene, chapter.uses, options.maxDepth.has_value());
        !ignored.empty() && !options.quiet)
      std::cerr << name << ": ignores in " << scene.fileName << ": " << ignored << "\n";

    RenderSettings settings;
    settings.spp = options.spp;
    settings.seconds = options.seconds;
    if (!settings.spp && !settings.seconds)
      settings.spp = chapter.defaultSpp;
    settings.seed = options.seed;
    settings.threads = options.threads;
    settings.maxDepth = options.maxDepth ? *options.maxDepth : chapter.defaultMaxDepth;
    settings.pixelSampling = chapter.pixelSampling;
    settings.progress = !options.quiet && ::isatty(STDERR_FILENO);
    settings.stop = &gStopRequested;
    settings.adaptive = applyPlanOptions(name, scene, chapter, options); // --verbose, --adaptive

    // Render, with Ctrl-C and SIGTERM turned into "stop after this pass" (until the images are written).
    const InterruptHandlers handlers;
    const Camera camera = scene.makeCamera(width, height);
    const TraceFunction trace = makeTrace(scene);
    RenderResult result = render(scene, camera, settings, trace);
    std::optional<RenderResult> beside; // the chapter's second image, with the samples the first one got
    if (chapter.besideTrace) {
      RenderSettings same = settings;
      same.spp = result.spp;
      same.seconds.reset();
      beside = render(scene, camera, same, chapter.besideTrace);
      result.rays += beside->rays;
      result.seconds += beside->seconds;
      result.badSamples += beside->badSamples;
      result.interrupted = result.interrupted || beside->interrupted;
    }

    // Write every image, all or nothing.
    std::vector<std::pair<std::string, std::vector<unsigned char>>> files;
    const Image mean = beside ? sideBySide(result.film.mean(), beside->film.mean()) : result.film.mean();
    for (const std::string& path : outputs)
      files.emplace_back(path, encodeImage(mean, path));
    if (!options.variancePath.empty())
      files.emplace_back(options.variancePath,
                         encodePfm(beside ? sideBySide(result.film.varianceOfMean(), beside->film.varianceOfMean())
                                          : result.film.varianceOfMean()));
    if (!options.statsPath.empty()) {
      std::ostringstream json;
      json << "{\"chapter\": \"" << name << "\", \"width\": " << mean.width << ", \"height\": " << height
           << ", \"spp\": " << result.spp << ", \"seconds\": " << result.seconds << ", \"rays\": " << result.rays
           << ", \"bad_samples\": " << result.badSamples << ", \"threads\": "
           << (settings.threads > 0 ? settings.threads : omp_get_max_threads())
           << ", \"interrupted\": " << (result.interrupted ? "true" : "false")
           << ", \"mean_spp\": " << result.meanSpp << ", \"adaptive\": " << (settings.adaptive ? "true" : "false")
           << "}\n";
      const std::string text = json.str();
      files.emplace_back(options.statsPath, std::vector<unsigned char>(text.begin(), text.end()));
    }
    gWriting = true; // from here a second signal cancels the write (before, it _exits: nothing to clean up)
    try {
      writeFilesAtomically(files, &gCancelWrite);
    } catch (const WriteCancelled&) {
      std::cerr << name << ": interrupted twice: stopped without writing\n";
      return 130;
    }
    gWriting = false;

    if (!options.quiet) {
      char line[256];
      const double mrays = result.seconds > 0 ? double(result.rays) / result.seconds / 1e6 : 0.0;
      std::snprintf(line, sizeof line, "%s: %dx%d, %d spp, %.2f s, %s rays, %.2f Mrays/s", name.c_str(), mean.width,
                    height, result.spp, result.seconds, formatCount(result.rays).c_str(), mrays);
      std::cerr << line;
      if (settings.adaptive)
        std::cerr << " (adaptive: at most " << result.spp << ", mean " << result.meanSpp << " spp)";
      if (result.badSamples)
        std::cerr << ", " << result.badSamples << " bad samples set to 0";
      if (result.interrupted)
        std::cerr << " (interrupted after " << result.spp << " spp)";
      std::cerr << " -> " << outputs[0];
      for (std::size_t i = 1; i < outputs.size(); ++i)
        std::cerr << ", " << outputs[i];
      std::cerr << "\n";
    }
    return result.interrupted ? 130 : 0;
  } catch (const SceneError& e) {
    std::cerr << name << ": " << e.what() << "\n";
  } catch (const ImageIoError& e) {
    std::cerr << name << ": " << e.what() << "; nothing was written\n";
  } catch (const std::filesystem::filesystem_error& e) {
    std::cerr << name << ": " << e.what() << "\n";
  } catch (const std::bad_alloc&) {
    std::cerr << name << ": out of memory; nothing was written\n";
  } catch (const std::exception& e) {
    std::cerr << name << ": internal error: " << e.what() << "; nothing was written (please report this)\n";
  }
  return 1;
}

int runChapter(int argc, char** argv, const ChapterInfo& chapter, SimpleTraceFunction trace)
{
  return runChapter(argc, argv, chapter,
                    [trace](const Scene& scene, const Ray& ray, Sampler& sampler, int) { return trace(scene, ray, sampler); });
}

} // namespace raylife

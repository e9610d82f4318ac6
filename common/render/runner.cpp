#include "render/runner.h"

#include "core/threads.h"
#include "render/film_file.h"
#include "render/image_io.h"
#include "render/locate.h"
#include "render/ranks.h"
#include "scene/scene_plan.h"

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <condition_variable>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <iostream>
#include <mutex>
#include <sstream>
#include <system_error>
#include <thread>

#include <signal.h>
#include <unistd.h>

namespace raylife {

std::string describeReads(unsigned uses)
{
  std::vector<std::string> parts{"the camera"};
  const std::pair<unsigned, const char*> features[] = {
      {kUsesSpheres, "spheres and meshes"}, {kUsesColors, "material colours"}, {kUsesPointLights, "point lights"},
      {kUsesAmbient, "the ambient term"},   {kUsesBackground, "the background"}, {kUsesEmission, "emission"},
      {kUsesMirror, "mirrors"},             {kUsesGlass, "glass"},              {kUsesGlossy, "glossy materials"},
      {kUsesMetal, "metals"},               {kUsesLens, "the camera's lens"},   {kUsesMotion, "the spheres' velocities"},
      {kUsesEnvironment, "the environment map"}, {kUsesTextures, "textures"},
      {kUsesMedia, "participating media"}};
  for (const auto& [flag, what] : features)
    if (uses & flag)
      parts.push_back(what);
  std::string out;
  for (std::size_t i = 0; i < parts.size(); ++i)
    out += (i == 0 ? "" : (i + 1 == parts.size() ? " and " : ", ")) + parts[i];
  const unsigned everyKind = kUsesMirror | kUsesGlass | kUsesGlossy | kUsesMetal;
  if ((uses & kUsesSpheres) && (uses & kUsesColors) && (uses & everyKind) != everyKind)
    out += " (the other kinds of material are shaded as diffuse)";
  return out;
}

std::string describeIgnored(const Scene& scene, unsigned uses)
{
  std::vector<std::string> parts;
  auto plural = [](std::size_t n, const std::string& one, const std::string& many) {
    return std::to_string(n) + " " + (n == 1 ? one : many);
  };
  if (!(uses & kUsesSpheres) && !scene.spheres.empty())
    parts.push_back(plural(scene.spheres.size(), "sphere", "spheres"));
  if (!(uses & kUsesSpheres) && !scene.triangles.empty())
    parts.push_back(plural(scene.meshes.size(), "mesh", "meshes") + " (" +
                    plural(scene.triangles.size(), "triangle", "triangles") + ")");
  if (!(uses & kUsesColors) && (uses & kUsesSpheres))
    parts.push_back("material colours");
  if (!(uses & kUsesPointLights) && !scene.lights.empty())
    parts.push_back(plural(scene.lights.size(), "point light", "point lights"));
  if (!(uses & kUsesAmbient) && scene.ambient != Color(0))
    parts.push_back("the ambient term");
  if (!(uses & kUsesBackground) && scene.background != Color(0))
    parts.push_back("the background");
  if (!(uses & kUsesEnvironment) && scene.environment)
    parts.push_back("the environment map (a ray that leaves the scene sees black)");
  if (!(uses & kUsesTextures) && std::any_of(scene.materials.begin(), scene.materials.end(), [](const Material& m) {
        return m.colorTexture || m.emissionTexture;
      }))
    parts.push_back("textures (each is shaded as its mean colour)");
  if (uses & kUsesSpheres) {
    std::size_t emissive = 0, asDiffuse = 0;
    std::vector<bool> used(scene.materials.size(), false);
    for (std::size_t i = 0; i < scene.primitiveCount(); ++i)
      used[std::size_t(scene.materialOf(int(i)))] = true;
    for (std::size_t i = 0; i < scene.materials.size(); ++i) {
      if (!used[i])
        continue; // an unused material is the loader's warning, not something the chapter ignores
      const Material& m = scene.materials[i];
      emissive += m.isEmissive() && !(uses & kUsesEmission);
      asDiffuse += (m.type == MaterialType::Mirror && !(uses & kUsesMirror)) ||
                   (m.type == MaterialType::Glass && !(uses & kUsesGlass)) ||
                   (m.type == MaterialType::Glossy && !(uses & kUsesGlossy)) ||
                   (m.type == MaterialType::Metal && !(uses & kUsesMetal));
    }
    if (emissive)
      parts.push_back("the emission of " + plural(emissive, "material", "materials"));
    if (asDiffuse)
      parts.push_back("the reflection and refraction of " + plural(asDiffuse, "material", "materials") +
                      " (shaded as diffuse)");
  }
  if (!(uses & kUsesMedia) && !scene.media.empty())
    parts.push_back(plural(scene.media.size(), "medium", "media") + " (interfaces are crossed as if absent)");
  if (!(uses & kUsesLens) && scene.camera.aperture > 0)
    parts.push_back("the camera's aperture (a pinhole here)");
  if (!(uses & kUsesMotion) && scene.hasMotion()) {
    const auto moving = std::size_t(
        std::count_if(scene.spheres.begin(), scene.spheres.end(), [](const Sphere& s) { return s.moving(); }));
    parts.push_back("the velocity of " + plural(moving, "sphere", "spheres") + " (drawn at time 0)");
  }
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

std::string sceneDirectory() { return findSceneDirectory().string(); }

std::pair<std::int64_t, std::int64_t> imageSize(int sceneWidth, int sceneHeight, int width, int height)
{
  // One side given: the other keeps the scene's aspect ratio, rounded to the nearest pixel, at least one.
  auto scaled = [](std::int64_t given, std::int64_t num, std::int64_t den) {
    return std::max<std::int64_t>(1, (given * num * 2 + den) / (2 * den));
  };
  if (width && height)
    return {width, height};
  if (width)
    return {width, scaled(width, sceneHeight, sceneWidth)};
  if (height)
    return {scaled(height, sceneWidth, sceneHeight), height};
  return {sceneWidth, sceneHeight};
}

namespace {

// Ctrl-C (or SIGTERM) once: stop at the next tile, write what there is, exit 130 (or, when no tile comes within
// kStopGraceSeconds, stop without writing: StopDeadline). Twice: stop at once and write nothing. The handler
// touches only lock-free atomics and _exit, which are async-signal-safe.
std::atomic<int> gSignals{0};            // SIGINT and SIGTERM received since the handlers were installed
std::atomic<bool> gStopRequested{false}; // the render loop stops at the next tile
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

// The first signal asks the render to stop at its next tile, which comes within a fraction of a second. A sample that
// never ends keeps it from getting there: chapter 5's ray tree through glass at a deep --max-depth doubles at every
// surface, and delta tracking through a cloud made billions of times denser than meant takes a step per unit of
// optical thickness. Then the first signal alone, which is all that `timeout` or a service manager sends, would
// never end the process. So a watch runs beside the render (from before the chapter's set-up, which can be long too:
// an OpenCL compile, the light guide's pre-pass): if the render has not returned kStopGraceSeconds after the first
// signal, it ends the process as a second signal does, without writing, with one line that says why.
constexpr int kStopGraceSeconds = 5;

class StopDeadline {
public:
  // `speaks`: whether this process says why it stopped (rank 0 of an MPI job, or the only process).
  StopDeadline(const std::string& name, bool speaks)
      : message_(speaks ? name + ": interrupted, but a sample was still running " +
                              std::to_string(kStopGraceSeconds) + " s later: stopped without writing\n"
                        : std::string())
  {
    try {
      watcher_ = std::thread([this] { watch(); });
    } catch (const std::system_error&) { // no thread to spare: the render runs unwatched, as before
    }
  }
  // The render has returned: the watch ends.
  ~StopDeadline()
  {
    {
      const std::lock_guard<std::mutex> lock(mutex_);
      ended_ = true;
    }
    wake_.notify_one();
    if (watcher_.joinable())
      watcher_.join();
  }
  StopDeadline(const StopDeadline&) = delete;
  StopDeadline& operator=(const StopDeadline&) = delete;

private:
  void watch()
  {
    std::unique_lock<std::mutex> lock(mutex_);
    // (A signal handler cannot notify a condition variable, so the request is looked at ten times a second.)
    while (!ended_ && !gStopRequested.load())
      wake_.wait_for(lock, std::chrono::milliseconds(100));
    if (wake_.wait_for(lock, std::chrono::seconds(kStopGraceSeconds), [this] { return ended_; }))
      return;
    [[maybe_unused]] const ssize_t ignored = ::write(STDERR_FILENO, message_.data(), message_.size());
    _exit(130);
  }

  const std::string message_;
  std::mutex mutex_;
  std::condition_variable wake_;
  bool ended_ = false;
  std::thread watcher_;
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

namespace {

// runChapter, runSplattingChapter and runWavefrontChapter: one of the three factories is set.
int runAnyChapter(int argc, char** argv, const ChapterInfo& chapter, const OptionsTraceFactory* makeTrace,
                  const SplatTraceFactory* makeSplatTrace, const WavefrontFactory* makeWavefront = nullptr)
{
  const std::string name = chapter.binary;
  // One process, or the ranks of an MPI job: every rank goes through the same steps, only rank 0 speaks and writes.
  Ranks ranks(argc, argv, &gSignals);
  RenderOptions options;
  try {
    options = parseCommandLine(argc, argv, chapter.options);
  } catch (const UsageError& e) {
    std::cerr << name << ": " << e.what() << "\n" << "usage: " << name << " [SCENE.json] [options]; see --help\n";
    return ranks.finish(2);
  }
  const std::string scenes = sceneDirectory();
  const std::string defaultScene = scenes.empty() ? chapter.defaultScene : scenes + "/" + chapter.defaultScene;
  if (options.help) {
    std::cout << usageText({name, defaultScene, chapter.defaultSpp, chapter.adaptiveSampling,
                            describeReads(chapter.uses), chapter.options, chapter.maxDepthLimit});
    return ranks.finish(0);
  }

  try {
    // Load and check everything before any work: scene, size, outputs.
    // (A chain of calls deeper than the thread's stack would end the process with a segmentation fault.)
    if (chapter.maxDepthLimit > 0 && options.maxDepth && *options.maxDepth > chapter.maxDepthLimit)
      throw UsageError("--max-depth " + std::to_string(*options.maxDepth) + " is more than this chapter takes, " +
                       std::to_string(chapter.maxDepthLimit) + ": its trace calls itself once a bounce, on a stack " +
                       "of a few megabytes");
    if (options.scenePath.empty() && scenes.empty())
      throw SceneError("cannot find the scenes folder for the default scene " + chapter.defaultScene +
                       ": there is no scenes/ above " + programDirectory().string() +
                       ", no source tree named beside it and no ../share/raylife/scenes; set RAYLIFE_SCENES");
    const std::string scenePath = options.scenePath.empty() ? defaultScene : options.scenePath;
    // A size on the command line replaces the scene's (even one too large to render).
    const Scene scene = loadScene(scenePath, options.width || options.height);
    for (const std::string& w : scene.warnings)
      std::cerr << name << ": warning: " << w << "\n";
    const auto [sizeX, sizeY] = imageSize(scene.camera.width, scene.camera.height, options.width, options.height);
    if (sizeX > kMaxPixels || sizeY > kMaxPixels || sizeX * sizeY > kMaxPixels) {
      std::cerr << name << ": --width/--height: an image of " << sizeX << "x" << sizeY << " pixels is larger than the "
                << kMaxPixels << " pixels raylife allows\n";
      return ranks.finish(2);
    }
    const int width = int(sizeX), height = int(sizeY);
    std::vector<std::string> outputs = options.outputs;
    if (outputs.empty()) {
      if (ranks.root())
        std::filesystem::create_directories("out");
      outputs.push_back("out/" + name + ".png");
    }
    // (parseCommandLine has checked the extensions.) Only rank 0 writes.
    for (const std::string& path : outputs)
      if (ranks.root())
        checkWritable(path);
    if (!options.variancePath.empty() && ranks.root())
      checkWritable(options.variancePath);
    if (!options.statsPath.empty() && ranks.root())
      checkWritable(options.statsPath);
    if (!options.previewPath.empty() && ranks.root())
      checkWritable(options.previewPath);
    if (const std::string ignored = describeIgnored(scene, chapter.uses); !ignored.empty() && !options.quiet)
      std::cerr << name << ": ignores in " << scene.fileName << ": " << ignored << "\n";
    if (options.maxDepth && !(chapter.uses & kUsesMaxDepth) && !options.quiet) // (the command line's, not the scene's)
      std::cerr << name << ": ignores --max-depth (nothing here recurses)\n";
    if (const std::string dark = describeDarkness(planScene(scene, chapter.uses)); !dark.empty() && !options.quiet)
      std::cerr << name << ": " << scene.fileName << " " << dark << "\n";

    RenderSettings settings;
    settings.spp = options.spp;
    settings.seconds = options.seconds;
    if (!settings.spp && !settings.seconds)
      settings.spp = chapter.defaultSpp;
    settings.seed = options.seed;
    settings.threads = options.threads;
    settings.maxDepth = options.maxDepth ? *options.maxDepth : chapter.defaultMaxDepth;
    settings.pixelSampling = chapter.pixelSampling;
    // A chapter that sends one ray through each pixel's centre would trace the very same ray for every sample:
    // more samples (--spp N > 1, --time) spread over the pixel instead, which anti-aliases its edges.
    const bool spread = chapter.pixelSampling == PixelSampling::Centre && settings.spp.value_or(2) > 1;
    if (spread)
      settings.pixelSampling = PixelSampling::Jittered;
    settings.lens = (chapter.uses & kUsesLens) && scene.camera.aperture > 0;
    settings.motion = (chapter.uses & kUsesMotion) && scene.hasMotion();
    settings.progress = !options.quiet && ::isatty(STDERR_FILENO);
    settings.stop = &gStopRequested;
    settings.adaptive = applyPlanOptions(name, scene, chapter, options); // --verbose, --adaptive
    if (spread && options.verbose)
      std::cerr << name << ": plan: " << (settings.spp ? "--spp " + std::to_string(*settings.spp) : "--time")
                << " -> samples spread over each pixel (anti-aliasing; 1 spp is a ray through its centre)\n";
    if (options.samples)
      settings.share.range = SampleRange{options.samples->first, options.samples->second};
    if (settings.adaptive && ranks.size() > 1)
      throw UsageError("--adaptive needs every sample of a pixel in one process; it cannot be split over " +
                       std::to_string(ranks.size()) + " ranks");
    // What a partial film (.film) says of this render; its key is also what the ranks must agree on.
    FilmHeader filmHeader;
    filmHeader.chapter = name;
    filmHeader.scene = std::filesystem::path(scenePath).filename().string();
    // The fingerprint covers the scene file and the geometry its mesh files gave (a mesh file that differs between
    // machines changes the scene without changing its file).
    filmHeader.sceneHash = hashFile(scenePath);
    for (const std::string_view loaded :
         {std::string_view(reinterpret_cast<const char*>(scene.vertices.data()), scene.vertices.size() * sizeof(Vec3)),
          std::string_view(reinterpret_cast<const char*>(scene.triangles.data()),
                           scene.triangles.size() * sizeof(Triangle))})
      if (!loaded.empty())
        filmHeader.sceneHash = filmHeader.sceneHash * 0x100000001b3ull ^ hashBytes(loaded);
    filmHeader.spp = settings.spp.value_or(0);
    filmHeader.seed = settings.seed;
    filmHeader.maxDepth = settings.maxDepth;
    filmHeader.height = height;
    filmHeader.width = chapter.besideTrace ? 2 * width : width;
    const std::string settingsKey = filmHeader.renderKey() + ", time " + std::to_string(settings.seconds.value_or(0));
    if (const int failed = ranks.checkpoint(0, filmHeader.sceneHash, hashBytes(settingsKey)))
      return failed;

    // Render, with Ctrl-C and SIGTERM turned into "stop at the next tile" (until the images are written).
    const InterruptHandlers handlers;
    const Camera camera = scene.makeCamera(width, height);
    settings.beside = chapter.besideTrace ? &chapter.besideTrace : nullptr; // its image in the same time budget
    if (!options.previewPath.empty() && ranks.root())
      settings.preview = [&](const Film& sofar) { // --preview: the image so far, for any viewer to reload
        try {
          writeFilesAtomically({{options.previewPath, encodePng(toneMapped(sofar.mean(), options.toneMap))}});
        } catch (const ImageIoError& e) {
          std::cerr << name << ": warning: no preview: " << e.what() << "\n";
        }
      };
    std::string device; // what a wavefront ran on (Wavefront::device), for --stats
    RenderResult result = [&] {
      const StopDeadline deadline(name, ranks.root());
      if (makeSplatTrace)
        return ranks.render(scene, camera, settings, (*makeSplatTrace)(scene, options.chapter));
      if (makeWavefront) {
        const Wavefront wavefront = (*makeWavefront)(scene, options.chapter);
        if (wavefront.threads > 0)
          settings.threads = wavefront.threads;
        settings.tileSize = wavefront.tileSize;
        device = wavefront.device;
        return ranks.render(scene, camera, settings, wavefront.workers, wavefront.size);
      }
      return ranks.render(scene, camera, settings, (*makeTrace)(scene, options.chapter));
    }();
    // A pass cut short leaves some pixels with more samples than the others: fine for an image, but a partial film
    // must hold whole passes (its header lists the sample indices every pixel holds).
    const bool cut = result.interrupted && (result.partialPass > 0 || result.spp == 0);
    if (cut && std::any_of(outputs.begin(), outputs.end(),
                           [](const std::string& p) { return fileExtension(p) == ".film"; })) {
      if (ranks.root())
        std::cerr << name << ": interrupted in the middle of a pass: a .film holds whole passes only; nothing was "
                     "written\n";
      return ranks.finish(130);
    }

    // Write every image, all or nothing (rank 0 only: it holds the whole film).
    if (!ranks.root())
      return ranks.finish(result.interrupted ? 130 : 0);
    std::vector<std::pair<std::string, std::vector<unsigned char>>> files;
    const Film film = std::move(result.film);
    // The most samples a pixel holds: spp, unless a cut batch (which may be many samples) gave some tiles more.
    const std::uint32_t maxSpp = film.counts().empty() ? 0 : *std::max_element(film.counts().begin(), film.counts().end());
    Image mean = film.mean();
    if (chapter.annotate)
      chapter.annotate(mean);
    for (const std::string& path : outputs) {
      if (fileExtension(path) == ".film") {
        filmHeader.samples = result.samples;
        filmHeader.rays = result.rays;
        filmHeader.badSamples = result.badSamples;
        filmHeader.seconds = result.seconds * ranks.size();
        files.emplace_back(path, encodeFilm({filmHeader, film}));
      } else {
        files.emplace_back(path, encodeImage(fileExtension(path) == ".png" ? toneMapped(mean, options.toneMap) : mean,
                                             path));
      }
    }
    if (!options.previewPath.empty()) // the preview ends as the final image
      files.emplace_back(options.previewPath, encodePng(toneMapped(mean, options.toneMap)));
    if (!options.variancePath.empty())
      files.emplace_back(options.variancePath, encodeImage(film.varianceOfMean(), options.variancePath));
    if (!options.statsPath.empty()) {
      std::ostringstream json;
      json << "{\"chapter\": \"" << name << "\", \"width\": " << mean.width << ", \"height\": " << height
           << ", \"spp\": " << result.spp << ", \"seconds\": " << result.seconds << ", \"rays\": " << result.rays
           << ", \"bad_samples\": " << result.badSamples << ", \"threads\": "
           << threadCount(settings.threads)
           << ", \"interrupted\": " << (result.interrupted ? "true" : "false")
           << ", \"mean_spp\": " << result.meanSpp << ", \"max_spp\": " << maxSpp << ", \"adaptive\": " << (settings.adaptive ? "true" : "false")
           << ", \"ranks\": " << ranks.size() << ", \"camera_rays\": " << result.cameraRays;
      if (!device.empty()) {
        json << ", \"device\": \"";
        for (const char c : device) // (a driver's name: printable, but escape what JSON needs)
          if (c == '"' || c == '\\')
            json << '\\' << c;
          else if (static_cast<unsigned char>(c) >= 0x20)
            json << c;
        json << '"';
      }
      json << "}\n";
      const std::string text = json.str();
      files.emplace_back(options.statsPath, std::vector<unsigned char>(text.begin(), text.end()));
    }
    gWriting = true; // from here a second signal cancels the write (before, it _exits: nothing to clean up)
    try {
      writeFilesAtomically(files, &gCancelWrite);
    } catch (const WriteCancelled&) {
      std::cerr << name << ": interrupted twice: stopped without writing\n";
      return ranks.finish(130);
    }
    gWriting = false;

    if (!options.quiet) {
      char line[256];
      // A chapter that traces no ray (chapter 1 only makes them) counts the camera rays it made.
      const bool traced = result.rays > 0;
      const std::uint64_t rays = traced ? result.rays : result.cameraRays;
      const double mrays = result.seconds > 0 ? double(rays) / result.seconds / 1e6 : 0.0;
      std::snprintf(line, sizeof line,
                    traced ? "%s: %dx%d, %d spp, %.2f s, %s rays, %.2f Mrays/s"
                           : "%s: %dx%d, %d spp, %.2f s, %s camera rays made (none traced), %.2f M/s",
                    name.c_str(), mean.width, height, result.spp, result.seconds, formatCount(rays).c_str(), mrays);
      std::cerr << line;
      if (options.samples)
        std::cerr << " (samples " << describeRanges(result.samples) << " of " << *settings.spp << ")";
      if (ranks.size() > 1) {
        std::snprintf(line, sizeof line, " (%d ranks; combining their films took %.3f s)", ranks.size(),
                      ranks.combineSeconds());
        std::cerr << line;
      }
      if (settings.adaptive)
        std::cerr << " (adaptive: at most " << result.spp << ", mean " << result.meanSpp << " spp)";
      if (result.badSamples)
        std::cerr << ", " << result.badSamples << " bad samples set to 0";
      if (result.interrupted && cut && int(maxSpp) > result.spp)
        std::cerr << " (interrupted after " << result.spp << " spp, and " << int(maxSpp) - result.spp
                  << " more in " << int(result.partialPass * 100) << "% of the tiles)";
      else if (result.interrupted)
        std::cerr << " (interrupted after " << result.spp << " spp)";
      std::cerr << " -> " << outputs[0];
      for (std::size_t i = 1; i < outputs.size(); ++i)
        std::cerr << ", " << outputs[i];
      std::cerr << "\n";
    }
    return ranks.finish(result.interrupted ? 130 : 0);
  } catch (const RanksStopped& stopped) {
    return stopped.status; // a rank failed; rank 0 has said why
  } catch (const UsageError& e) {
    std::cerr << name << ": " << e.what() << "\n";
    return ranks.finish(2);
  } catch (const ChapterError& e) {
    std::cerr << name << ": " << e.what() << "\n";
  } catch (const FilmError& e) {
    std::cerr << name << ": " << e.what() << "\n";
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
  return ranks.finish(1);
}

} // namespace

int runChapter(int argc, char** argv, const ChapterInfo& chapter, const TraceFactory& makeTrace)
{
  const OptionsTraceFactory withOptions = [&makeTrace](const Scene& scene, const ChapterOptions&) {
    return makeTrace(scene);
  };
  return runAnyChapter(argc, argv, chapter, &withOptions, nullptr);
}

int runChapter(int argc, char** argv, const ChapterInfo& chapter, const OptionsTraceFactory& makeTrace)
{
  return runAnyChapter(argc, argv, chapter, &makeTrace, nullptr);
}

int runSplattingChapter(int argc, char** argv, const ChapterInfo& chapter, const SplatTraceFactory& makeTrace)
{
  return runAnyChapter(argc, argv, chapter, nullptr, &makeTrace);
}

int runWavefrontChapter(int argc, char** argv, const ChapterInfo& chapter, const WavefrontFactory& makeWavefront)
{
  return runAnyChapter(argc, argv, chapter, nullptr, nullptr, &makeWavefront);
}

int runChapter(int argc, char** argv, const ChapterInfo& chapter, SimpleTraceFunction trace)
{
  return runChapter(argc, argv, chapter,
                    [trace](const Scene& scene, const Ray& ray, Sampler& sampler, int) { return trace(scene, ray, sampler); });
}

} // namespace raylife

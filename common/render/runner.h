/// @file runner.h
/// @brief The runner every chapter shares: command line, scene, render (render_loop.h), the images and the
/// summary line. A chapter supplies only its trace function and what the runner needs to know of it.
#pragma once

#include "render/options.h"
#include "render/render_loop.h"
#include "scene/scene_plan.h"

#include <functional>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace raylife {

/// What the runner needs to know of a chapter.
struct ChapterInfo {
  std::string binary;         ///< e.g. "step04_shadows"; names the default output out/BINARY.png.
  std::string defaultScene;   ///< File name under scenes/, e.g. "spheres.json".
  unsigned uses = 0;          ///< Feature flags.
  /// Where samples fall in a pixel. Centre (one ray through each pixel's centre) holds at one sample per pixel;
  /// with more (--spp N > 1, --time) the runner spreads them (Jittered), so that they are not the same ray.
  PixelSampling pixelSampling = PixelSampling::Centre;
  int defaultSpp = 1;         ///< Samples per pixel when neither --spp nor --time is given.
  int defaultMaxDepth = -1;   ///< --max-depth default; −1: unlimited.
  /// The most --max-depth the chapter takes; 0: the command line's own bound (2^20). A chapter whose trace calls
  /// itself once a bounce (5 and 11) sets it, so that its deepest chain of calls fits a thread's stack: a level
  /// took 0.4 to 0.8 KB in a release build and 1 to 3 KB under AddressSanitizer, of a thread's usual 8 MB.
  int maxDepthLimit = 0;
  /// Optional: a second estimator whose image the runner puts to the right of the first, rendered with the same
  /// camera, seed and samples per pixel, so the output is twice as wide (chapter 9 shows the work each pixel cost
  /// beside the rendered image). Empty: one image.
  TraceFunction besideTrace = {};
  /// Optional: draws on the rendered image before it is written as PNG, PFM or EXR (not on a .film or the
  /// variance), e.g. chapter 9's colour scale. Must depend only on the image's size, so that images stay
  /// reproducible. Empty: nothing drawn.
  std::function<void(Image& image)> annotate = {};
  /// True for the Monte Carlo chapters (6 to 8), which honour --adaptive; the others say they ignore it.
  bool adaptiveSampling = false;
  /// The chapter's own options beside the shared ones (options.h): the runner parses and checks them, lists them
  /// in --help, and hands their values to an OptionsTraceFactory.
  std::vector<ChapterOption> options = {};
};

/// What of a scene a chapter that reads `uses` (Feature flags) takes into account, as one phrase ("the camera,
/// spheres and meshes, material colours, ..."): for --help and the docs' table of what each chapter reads.
std::string describeReads(unsigned uses);

/// What in `scene` a chapter that reads only `uses` ignores, as one phrase ("2 point lights, ambient"), or "".
std::string describeIgnored(const Scene& scene, unsigned uses);

/// The scenes folder, where default scenes live: $RAYLIFE_SCENES, else the `scenes/` of the tree the program is
/// in (render/locate.h); "" when there is none.
std::string sceneDirectory();

/// The size of the image to render, in pixels: --width and --height where given (0: not given); with only one of
/// them, the other keeps the scene's aspect ratio (rounded, at least 1); with neither, the scene's size.
/// @param sceneWidth The scene's width, ≥ 1.
/// @param sceneHeight The scene's height, ≥ 1.
/// @param width --width, or 0.
/// @param height --height, or 0.
/// @return {width, height}, each ≥ 1; their product may exceed kMaxPixels (the caller refuses it).
std::pair<std::int64_t, std::int64_t> imageSize(int sceneWidth, int sceneHeight, int width, int height);

/// Makes a chapter's trace function for a loaded scene. runChapter calls it once, after the scene is loaded and
/// before the render, so that a chapter can build what depends only on the scene (chapter 7's light sampler) once,
/// and capture it in the trace function it returns, without global state. The scene outlives the trace function.
using TraceFactory = std::function<TraceFunction(const Scene& scene)>;
/// The same for a chapter with options of its own (ChapterInfo::options): it also receives their values.
using OptionsTraceFactory = std::function<TraceFunction(const Scene& scene, const ChapterOptions& options)>;

/// A chapter's whole main(): parses the command line, loads the scene, renders with `trace`, writes the images
/// (all or nothing) and prints the summary line. Returns the exit status: 0 done, 1 bad input or failed write,
/// 2 bad command line, 130 interrupted (the image so far was written).
int runChapter(int argc, char** argv, const ChapterInfo& chapter, const TraceFunction& trace);
/// Applies the options that shape the render's plan: prints the scene's plan (scene_plan.h) on standard error
/// with --verbose, and returns the adaptive-sampling threshold for RenderSettings::adaptive: --adaptive's if the
/// chapter honours it (ChapterInfo::adaptiveSampling), else nothing (and says it ignores it, unless --quiet).
std::optional<double> applyPlanOptions(const std::string& name, const Scene& scene, const ChapterInfo& chapter,
                                       const RenderOptions& options);
/// The same, for a trace function without a depth limit.
int runChapter(int argc, char** argv, const ChapterInfo& chapter, SimpleTraceFunction trace);
/// The same, for a chapter whose trace function is made per scene by `makeTrace` (called once, see TraceFactory).
int runChapter(int argc, char** argv, const ChapterInfo& chapter, const TraceFactory& makeTrace);
/// The same, for a chapter whose trace function depends on its own options' values (see OptionsTraceFactory).
int runChapter(int argc, char** argv, const ChapterInfo& chapter, const OptionsTraceFactory& makeTrace);
/// Makes a chapter's estimator that splats (SplatTraceFunction) for a loaded scene and its own options' values, as
/// OptionsTraceFactory.
using SplatTraceFactory = std::function<SplatTraceFunction(const Scene& scene, const ChapterOptions& options)>;
/// The same, for a chapter whose estimator splats (chapter 13), made per scene by `makeTrace`: rendered pass by
/// pass (render_loop.h). Not with ChapterInfo::besideTrace or ChapterInfo::adaptiveSampling.
int runSplattingChapter(int argc, char** argv, const ChapterInfo& chapter, const SplatTraceFactory& makeTrace);

/// A chapter's wavefront estimator (chapter 16) for a loaded scene, and the most pixel samples it takes in flight at
/// once (its wavefront, ≥ 1): the render loop hands each thread's estimator pieces of at most that many.
struct Wavefront {
  WavefrontWorkers workers; ///< Makes the estimator of each thread.
  std::size_t size = 1;     ///< Most pixel samples per call.
  /// Host threads that call the estimator (≥ 1); 0: --threads. A device that runs the paths itself (chapter 17)
  /// takes one.
  int threads = 0;
  int tileSize = 0;         ///< RenderSettings::tileSize; 0: the render loop's.
  std::string device = {};  ///< What the paths run on, for --stats ("device"); empty: the CPU's threads.
};
/// A fault a chapter finds in what it needs to render, before any work (chapter 17: no OpenCL device, a kernel the
/// driver does not build): the runner prints what() after the program's name and exits with status 1, having
/// written nothing.
class ChapterError : public std::runtime_error {
public:
  using std::runtime_error::runtime_error;
};

/// Makes a chapter's wavefront estimator for a loaded scene and its own options' values, as OptionsTraceFactory.
using WavefrontFactory = std::function<Wavefront(const Scene& scene, const ChapterOptions& options)>;
/// The same as runChapter, for a chapter whose estimator is a wavefront (chapter 16), made per scene by
/// `makeWavefront`: every promise of the command line holds as for the other chapters (render_loop.h).
/// Not with ChapterInfo::besideTrace.
int runWavefrontChapter(int argc, char** argv, const ChapterInfo& chapter, const WavefrontFactory& makeWavefront);

} // namespace raylife

/// @file render_loop.h
/// @brief The runner every chapter shares: command line, scene, render loop (tiles, threads, samples, time
/// budget, progress), and the images. A chapter supplies only its trace function.
#pragma once

#include "film.h"
#include "options.h"
#include "rng.h"
#include "scene.h"

#include <atomic>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>

namespace raylife {

/// A chapter's estimator: the radiance arriving along `ray` (a primary ray), using `sampler` for any random
/// decision and following paths of at most `maxDepth` bounces. Must be thread-safe (it is called concurrently
/// for different pixels) and must not keep state between calls.
using TraceFunction = std::function<Color(const Scene& scene, const Ray& ray, Sampler& sampler, int maxDepth)>;
/// The same for chapters that neither recurse nor bound their depth.
using SimpleTraceFunction = Color (*)(const Scene& scene, const Ray& ray, Sampler& sampler);

/// What of a scene a chapter reads, so the runner can say once what it ignores.
enum Feature : unsigned {
  kUsesSpheres = 1u << 0,       ///< Intersects the spheres.
  kUsesColors = 1u << 1,        ///< Reads material colours.
  kUsesPointLights = 1u << 2,   ///< Reads point lights.
  kUsesAmbient = 1u << 3,       ///< Reads the ambient term.
  kUsesBackground = 1u << 4,    ///< Returns the background on a miss.
  kUsesEmission = 1u << 5,      ///< Reads material emission.
  kUsesMirror = 1u << 6,        ///< Treats mirror materials as mirrors.
  kUsesGlass = 1u << 7,         ///< Treats glass materials as glass.
  kUsesGlossy = 1u << 8,        ///< Treats glossy materials as glossy.
  kUsesMaxDepth = 1u << 9,      ///< Honours --max-depth.
};

/// Where inside a pixel the samples fall.
enum class PixelSampling {
  Centre,    ///< Every sample through the pixel's centre (x + ½, y + ½): no anti-aliasing.
  /// Stratified jittered: sample s of N lies in cell s of a ⌊√N⌋² grid (uniform beyond it). Where N is not known
  /// in advance (adaptive sampling, --time), sample s is point s of the pixel's PixelSequence (rng.h) instead.
  Jittered,
};

/// What the runner needs to know of a chapter.
struct ChapterInfo {
  std::string binary;         ///< e.g. "step04_shadows"; names the default output out/BINARY.png.
  std::string defaultScene;   ///< File name under scenes/, e.g. "spheres.json".
  unsigned uses = 0;          ///< Feature flags.
  PixelSampling pixelSampling = PixelSampling::Centre; ///< Where samples fall in a pixel.
  int defaultSpp = 1;         ///< Samples per pixel when neither --spp nor --time is given.
  int defaultMaxDepth = -1;   ///< --max-depth default; −1: unlimited.
  /// Optional: a second estimator whose image the runner puts to the right of the first, rendered with the same
  /// camera, seed and samples per pixel, so the output is twice as wide (chapter 9 shows the work each pixel cost
  /// beside the rendered image). Empty: one image.
  TraceFunction besideTrace = {};
  /// True for the Monte Carlo chapters (6 to 8), which honour --adaptive; the others say they ignore it.
  bool adaptiveSampling = false;
};

/// How to render, resolved from the options and the chapter's defaults.
struct RenderSettings {
  std::optional<int> spp;          ///< Samples per pixel, or nothing with `seconds`.
  std::optional<double> seconds;   ///< Time budget, or nothing with `spp`.
  std::uint64_t seed = 0;          ///< Seed of every pixel sample's random numbers.
  int threads = 0;                 ///< OpenMP threads; 0: every core.
  int maxDepth = -1;               ///< Passed to the trace function; −1: unlimited.
  PixelSampling pixelSampling = PixelSampling::Centre; ///< Where samples fall.
  bool progress = false;           ///< Draw a progress bar on standard error.
  /// Set to true (from a signal handler, say) to stop after the pass in flight. May be null.
  const std::atomic<bool>* stop = nullptr;
  /// Adaptive sampling: a pixel stops taking samples once its Film::relativeError falls below this (> 0).
  /// Nothing: every pixel takes every sample. See render().
  std::optional<double> adaptive;
};

/// What a render produced and what it cost.
struct RenderResult {
  Film film;                    ///< The accumulated samples.
  int spp = 0;                  ///< Samples every pixel received.
  double seconds = 0;           ///< Wall-clock time of the render loop.
  std::uint64_t rays = 0;       ///< Rays traced (Scene::intersect and Scene::occluded calls).
  std::uint64_t badSamples = 0; ///< Samples that were NaN, infinite or negative: replaced by 0 and counted.
  bool interrupted = false;     ///< Stopped early through RenderSettings::stop.
  double meanSpp = 0;           ///< Mean samples per pixel (equal to spp unless sampling was adaptive).
};

/// Adaptive sampling looks at a pixel's error only once it has this many samples, and then again each time the
/// count has grown by a quarter, in multiples of this (16, 32, 48, 64, 80, 96, 112, 128, 160, ...: the same points
/// whatever the threads or the timing, so the image stays reproducible).
/// Fewer samples give too rough an estimate of the variance: a pixel whose first few samples happen to agree
/// (all missing a small light, say) would stop with a large error.
inline constexpr int kAdaptiveMinSamples = 16;
/// Samples after which adaptive sampling takes a pixel whose samples have all been black to be black (its error is
/// unknown until then: Film::relativeError): a path tracer's pixel in a dim corner may need many samples to find
/// the light, but a pixel that looks at a black background never will.
inline constexpr int kAdaptiveBlackSamples = 64;
/// Radiance below which adaptive sampling measures a pixel's error absolutely rather than relative to its mean:
/// 1/256 of white, about one 8-bit step, so that near-black pixels do not take samples without end.
inline constexpr double kAdaptiveMeanFloor = 1.0 / 256.0;

/// Renders `scene` through `camera` with `trace`.
///
/// The image is rendered in batches of samples over 16×16 tiles, spread over threads by OpenMP; a batch gives
/// every pixel the same samples, batches double in size and are cut to about a quarter of a second.
/// Sample s of pixel (x, y) draws its random numbers from Sampler(seed, x, y, s) and is added to the film in
/// the order of s, so the image is bit-identical for any thread count (and any batching). With `seconds`,
/// batches continue until the budget is spent (at least one sample), each cut to what is left of it; `stop`
/// is looked at between batches. Every pixel has the same number of samples, unless `settings.adaptive` is set:
/// then, at kAdaptiveMinSamples samples and at fixed counts after (multiples of 16), each pixel whose
/// Film::relativeError(kAdaptiveMeanFloor) is below the threshold, and whose eight neighbours' is too, stops
/// taking samples (batches end at these points, so which pixels go on depends only on the seed). Sample
/// positions then follow the pixel's PixelSequence (the grid of strata assumes every pixel takes every sample).
/// Biased, slightly: the stopping rule correlates with the samples.
/// The render ends when every pixel has stopped, or at `spp` (then the most any pixel took) or `seconds`.
RenderResult render(const Scene& scene, const Camera& camera, const RenderSettings& settings,
                    const TraceFunction& trace);

/// What in `scene` a chapter that reads only `uses` ignores, as one phrase ("2 point lights, ambient"), or "".
std::string describeIgnored(const Scene& scene, unsigned uses, bool maxDepthGiven);

/// The scenes/ folder of the source tree (compiled in), where default scenes live.
std::string sceneDirectory();

/// Makes a chapter's trace function for a loaded scene. runChapter calls it once, after the scene is loaded and
/// before the render, so that a chapter can build what depends only on the scene (chapter 7's light sampler) once,
/// and capture it in the trace function it returns, without global state. The scene outlives the trace function.
using TraceFactory = std::function<TraceFunction(const Scene& scene)>;

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

} // namespace raylife

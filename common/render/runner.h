/// @file runner.h
/// @brief The runner every chapter shares: command line, scene, render (render_loop.h), the images and the
/// summary line. A chapter supplies only its trace function and what the runner needs to know of it.
#pragma once

#include "render/options.h"
#include "render/render_loop.h"
#include "scene/scene_plan.h"

#include <functional>
#include <optional>
#include <string>

namespace raylife {

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

/// What in `scene` a chapter that reads only `uses` ignores, as one phrase ("2 point lights, ambient"), or "".
std::string describeIgnored(const Scene& scene, unsigned uses, bool maxDepthGiven);

/// The scenes folder, where default scenes live: $RAYLIFE_SCENES, else the `scenes/` of the tree the program is
/// in (render/locate.h); "" when there is none.
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

/// @file guided_lights.h
/// @brief The light sampler of chapters 7, 8 and 16 as the command line asks for it: guided (LightGuiding: a pre-pass
/// learns where each light is seen) unless `--guide off`, and with --verbose it says what it learned; and the MIS
/// heuristic of chapters 8 and 16 (`--heuristic`).
#pragma once

#include "render/options.h"
#include "scene/light_sampling.h"

#include <string>

namespace raylife {

/// The chapter option `--guide on|off` (default on): whether the light sampler learns where the lights are seen
/// before the render (LightSampler's guided constructor) or samples each light's cone uniformly.
extern const ChapterOption kGuideOption;

/// The chapter option `--heuristic power|balance` (default power): how MIS weighs light sampling against BSDF
/// sampling (chapters 8 and 16).
extern const ChapterOption kHeuristicOption;

/// The heuristic the chapter's `--heuristic` names (it must declare kHeuristicOption).
MisHeuristic heuristicOption(const ChapterOptions& options);

/// The light sampler for `scene`: guided unless the chapter's `--guide` is off; with --verbose the lines of
/// LightSampler::describeGuide go to standard error, each after "`name`: ".
/// @param name the chapter's binary, which starts each line. @param scene the scene, which must outlive the
/// sampler. @param options the chapter's options (it must declare kGuideOption).
LightSampler makeLightSampler(const std::string& name, const Scene& scene, const ChapterOptions& options);

} // namespace raylife

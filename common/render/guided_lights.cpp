#include "render/guided_lights.h"

#include <iostream>

namespace raylife {

const ChapterOption kGuideOption{.name = "--guide",
                                 .kind = OptionKind::Choice,
                                 .help = "learn where each light is seen before the render (on), or not (off)",
                                 .defaultValue = "on",
                                 .choices = {"on", "off"}};

const ChapterOption kHeuristicOption{.name = "--heuristic",
                                     .kind = OptionKind::Choice,
                                     .help = "how MIS weights the two strategies",
                                     .defaultValue = "power",
                                     .choices = {"power", "balance"}};

MisHeuristic heuristicOption(const ChapterOptions& options)
{
  return options.choice("--heuristic") == "power" ? MisHeuristic::Power : MisHeuristic::Balance;
}

LightSampler makeLightSampler(const std::string& name, const Scene& scene, const ChapterOptions& options)
{
  if (options.choice("--guide") == "off")
    return LightSampler(scene);
  LightGuiding guiding;
  guiding.threads = options.threads(); // --threads 1 means one thread for the pre-pass too
  LightSampler lights(scene, guiding);
  if (options.verbose())
    for (const std::string& line : lights.describeGuide())
      std::cerr << name << ": " << line << "\n";
  return lights;
}

} // namespace raylife

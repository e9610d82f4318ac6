// Chapter 6 with one mistake (MISTAKE, set by the build: None, LostCosine or RouletteNoDivide), as a chapter
// program: the same command line and files as step06_path_tracer, so raylife_check grades what it renders.
#include "path_mistakes.h"

using namespace raylife;

int main(int argc, char** argv)
{
  const ChapterInfo chapter{.binary = "step06_path_tracer",
                            .defaultScene = "cornell_large_lamp.json",
                            .uses = kUsesSpheres | kUsesColors | kUsesBackground | kUsesEmission | kUsesMirror |
                                    kUsesGlass | kUsesGlossy | kUsesMaxDepth,
                            .pixelSampling = PixelSampling::Jittered,
                            .defaultSpp = 128,
                            .defaultMaxDepth = -1};
  return runChapter(argc, argv, chapter, [](const Scene& s, const Ray& r, Sampler& sampler, int depth) {
    return test::traceWith(test::Mistake::MISTAKE, s, r, sampler, depth);
  });
}

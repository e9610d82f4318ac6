// libFuzzer target for the scene loader (build with tools/fuzz.sh). Every input must either load into a scene
// that keeps the loader's promises or be rejected with one SceneError line; anything else (a crash, a sanitizer
// report, another exception, a broken invariant) is a bug, and the input becomes a file in regressions/.
#include "scene_check.h"

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string_view>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size)
{
  const std::string problem =
      raylife::fuzz::checkSceneText(std::string_view(reinterpret_cast<const char*>(data), size));
  if (!problem.empty()) {
    std::fprintf(stderr, "scene fuzzer: %s\n", problem.c_str());
    std::abort();
  }
  return 0;
}

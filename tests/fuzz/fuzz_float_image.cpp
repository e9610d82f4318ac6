// libFuzzer target for the float image files that textures and the tools read in raylife's own process (build with
// tools/fuzz.sh): the first byte chooses the format (even: OpenEXR, odd: PFM), the rest is the file. Every input must
// decode into an image that keeps the reader's promises or be refused with one ImageFileError line; anything else
// (a crash, a hang, a sanitizer's report, memory past the limit) is a bug, and the input becomes a file in
// float_image_regressions/.
#include "scene_check.h"

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string_view>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size)
{
  if (size == 0)
    return 0;
  const std::string problem = raylife::fuzz::checkFloatImageBytes(
      std::string_view(reinterpret_cast<const char*>(data) + 1, size - 1), data[0] % 2 == 0 ? ".exr" : ".pfm");
  if (!problem.empty()) {
    std::fprintf(stderr, "float image fuzzer: %s\n", problem.c_str());
    std::abort();
  }
  return 0;
}

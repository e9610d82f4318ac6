// libFuzzer target for the texture images (build with tools/fuzz.sh): the first byte chooses the encoding (even:
// sRGB, odd: linear), the rest is the file, a PNG, JPEG or Radiance HDR for stb_image. Every input must decode into an
// image that keeps the reader's promises or be refused with one ImageFileError line; anything else is a bug, and the
// input becomes a file in image_regressions/. stb_image runs in the reader's child process: a fault of the library
// must come back as that line (its coverage is not seen here).
#include "scene_check.h"

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string_view>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size)
{
  if (size == 0)
    return 0;
  const auto encoding = data[0] % 2 == 0 ? raylife::ImageEncoding::Srgb : raylife::ImageEncoding::Linear;
  const std::string problem =
      raylife::fuzz::checkImageBytes(std::string_view(reinterpret_cast<const char*>(data) + 1, size - 1), encoding);
  if (!problem.empty()) {
    std::fprintf(stderr, "image fuzzer: %s\n", problem.c_str());
    std::abort();
  }
  return 0;
}

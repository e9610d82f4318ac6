// libFuzzer target for partial films (.film files, raylife_merge's input; build with tools/fuzz.sh): the input is the
// file. Every input must read into a film that keeps the reader's promises or be refused with one FilmError line;
// anything else is a bug, and the input becomes a file in film_regressions/.
#include "scene_check.h"

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string_view>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size)
{
  const std::string problem =
      raylife::fuzz::checkFilmBytes(std::string_view(reinterpret_cast<const char*>(data), size));
  if (!problem.empty()) {
    std::fprintf(stderr, "film fuzzer: %s\n", problem.c_str());
    std::abort();
  }
  return 0;
}

// libFuzzer target for the mesh files (build with tools/fuzz.sh): the first byte chooses the format (even: OBJ,
// odd: PLY), the rest is the file. Every input must load into a mesh that keeps the reader's promises or be refused
// with one MeshError line; anything else is a bug, and the input becomes a file in mesh_regressions/. Assimp runs in
// the loader's child process: a fault of the library must come back as that line (its coverage is not seen here).
#include "scene_check.h"

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string_view>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size)
{
  if (size == 0)
    return 0;
  const auto format = data[0] % 2 == 0 ? raylife::MeshFormat::Obj : raylife::MeshFormat::Ply;
  const std::string problem =
      raylife::fuzz::checkMeshBytes(std::string_view(reinterpret_cast<const char*>(data) + 1, size - 1), format);
  if (!problem.empty()) {
    std::fprintf(stderr, "mesh fuzzer: %s\n", problem.c_str());
    std::abort();
  }
  return 0;
}

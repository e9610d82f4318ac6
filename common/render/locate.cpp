#include "render/locate.h"

#include <cstdlib>
#include <system_error>

namespace raylife {

std::filesystem::path programDirectory()
{
  std::error_code ec;
  const std::filesystem::path self = std::filesystem::read_symlink("/proc/self/exe", ec);
  return ec ? std::filesystem::path() : self.parent_path();
}

std::filesystem::path projectRoot()
{
  std::error_code ec;
  for (std::filesystem::path dir = programDirectory(); !dir.empty(); dir = dir.parent_path()) {
    if (std::filesystem::is_directory(dir / "scenes", ec))
      return dir;
    if (dir == dir.parent_path())
      break;
  }
  return {};
}

std::filesystem::path findSceneDirectory()
{
  if (const char* given = std::getenv("RAYLIFE_SCENES"); given && *given)
    return given;
  const std::filesystem::path root = projectRoot();
  return root.empty() ? root : root / "scenes";
}

} // namespace raylife

#include "render/locate.h"

#include <cstdlib>
#include <fstream>
#include <string>
#include <system_error>

namespace raylife {

namespace fs = std::filesystem;

fs::path programDirectory()
{
  std::error_code ec;
  const fs::path self = fs::read_symlink("/proc/self/exe", ec);
  return ec ? fs::path() : self.parent_path();
}

fs::path projectRootFor(const fs::path& programDir)
{
  std::error_code ec;
  for (fs::path dir = programDir; !dir.empty(); dir = dir.parent_path()) {
    if (fs::is_directory(dir / "scenes", ec))
      return dir;
    if (dir == dir.parent_path())
      break;
  }
  // A build folder outside the source tree: its bin/ names the tree it was configured from.
  if (programDir.empty())
    return {};
  std::ifstream named(programDir / kSourceTreeFile);
  std::string line;
  if (named && std::getline(named, line) && !line.empty() && fs::is_directory(fs::path(line) / "scenes", ec))
    return line;
  return {};
}

fs::path projectRoot() { return projectRootFor(programDirectory()); }

fs::path installedDataFor(const fs::path& programDir)
{
  if (programDir.empty())
    return {};
  std::error_code ec;
  const fs::path data = programDir.parent_path() / "share" / "raylife";
  return fs::is_directory(data / "scenes", ec) ? data : fs::path();
}

fs::path findSceneDirectoryFor(const fs::path& programDir)
{
  if (const char* given = std::getenv("RAYLIFE_SCENES"); given && *given)
    return given;
  if (const fs::path root = projectRootFor(programDir); !root.empty())
    return root / "scenes";
  const fs::path installed = installedDataFor(programDir);
  return installed.empty() ? installed : installed / "scenes";
}

fs::path findSceneDirectory() { return findSceneDirectoryFor(programDirectory()); }

} // namespace raylife

// Where a program finds the scenes and goldens (render/locate.h, issue 43): the tree it lies in, the source tree a
// build folder elsewhere names beside its programs, or an installed layout. Laid out in a temporary folder.
#include "render/locate.h"

#include <catch2/catch.hpp>

#include <chrono>
#include <cstdlib>
#include <fstream>
#include <string>

#include <unistd.h>

namespace fs = std::filesystem;
using namespace raylife;

namespace {

// A fresh temporary folder, removed with everything in it at the end of the test.
class Layout {
public:
  Layout()
      : root_(fs::temp_directory_path() /
              ("raylife_locate_" + std::to_string(::getpid()) + "_" +
               std::to_string(std::chrono::steady_clock::now().time_since_epoch().count())))
  {
    fs::create_directories(root_);
  }
  ~Layout()
  {
    std::error_code ec;
    fs::remove_all(root_, ec);
  }
  Layout(const Layout&) = delete;
  Layout& operator=(const Layout&) = delete;
  fs::path make(const fs::path& relative) const
  {
    fs::create_directories(root_ / relative);
    return root_ / relative;
  }
  const fs::path& root() const { return root_; }

private:
  fs::path root_;
};

// Runs the test without RAYLIFE_SCENES, which would come first.
struct NoSceneVariable {
  NoSceneVariable()
  {
    if (const char* v = std::getenv("RAYLIFE_SCENES"))
      saved = v, had = true;
    ::unsetenv("RAYLIFE_SCENES");
  }
  ~NoSceneVariable()
  {
    if (had)
      ::setenv("RAYLIFE_SCENES", saved.c_str(), 1);
  }
  std::string saved;
  bool had = false;
};

} // namespace

TEST_CASE("locate: a build inside the source tree finds the tree's scenes above it")
{
  const NoSceneVariable clean;
  const Layout l;
  l.make("src/scenes");
  const fs::path bin = l.make("src/build/bin");
  CHECK(projectRootFor(bin) == l.root() / "src");
  CHECK(findSceneDirectoryFor(bin) == l.root() / "src" / "scenes");
}

TEST_CASE("locate: a build folder outside the source tree finds the scenes of the tree it names beside its programs")
{
  const NoSceneVariable clean;
  const Layout l;
  l.make("src/scenes");
  const fs::path bin = l.make("elsewhere/b/bin");
  CHECK(projectRootFor(bin).empty()); // nothing above it, nothing named
  CHECK(findSceneDirectoryFor(bin).empty());
  std::ofstream(bin / kSourceTreeFile) << (l.root() / "src").string() << "\n";
  CHECK(projectRootFor(bin) == l.root() / "src");
  CHECK(findSceneDirectoryFor(bin) == l.root() / "src" / "scenes");
  // A named tree that has no scenes (moved away since) is not taken.
  std::ofstream(bin / kSourceTreeFile) << (l.root() / "gone").string() << "\n";
  CHECK(projectRootFor(bin).empty());
}

TEST_CASE("locate: the tree a program lies in comes before the tree its build names (a copied checkout)")
{
  const NoSceneVariable clean;
  const Layout l;
  l.make("original/scenes");
  l.make("copy/scenes");
  const fs::path bin = l.make("copy/build/bin");
  std::ofstream(bin / kSourceTreeFile) << (l.root() / "original").string() << "\n";
  CHECK(projectRootFor(bin) == l.root() / "copy");
}

TEST_CASE("locate: an installed program finds PREFIX/share/raylife/scenes, and RAYLIFE_SCENES comes first")
{
  const NoSceneVariable clean;
  const Layout l;
  const fs::path bin = l.make("prefix/bin");
  CHECK(installedDataFor(bin).empty());
  l.make("prefix/share/raylife/scenes");
  CHECK(installedDataFor(bin) == l.root() / "prefix" / "share" / "raylife");
  CHECK(projectRootFor(bin).empty());
  CHECK(findSceneDirectoryFor(bin) == l.root() / "prefix" / "share" / "raylife" / "scenes");
  ::setenv("RAYLIFE_SCENES", "/somewhere/scenes", 1);
  CHECK(findSceneDirectoryFor(bin) == "/somewhere/scenes");
}

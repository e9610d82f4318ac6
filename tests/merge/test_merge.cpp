// Job arrays and OpenEXR (issue 24): chapters render shares of their sample indices (--samples FIRST:COUNT) into
// partial films, raylife_merge sums them in any order into the one-process image's very bytes, and refuses a
// missing or overlapping range or a share of another render; -o x.exr writes the floats of the PFM, which
// raylife_compare and OpenEXR's own exrheader read.
#include "process.h"

#include "render/image_io.h"

#include <catch2/catch.hpp>

#include <regex>

using namespace raylife::test;
namespace fs = std::filesystem;

namespace {

const std::string kMerge = RAYLIFE_MERGE;
const std::string kCompare = RAYLIFE_COMPARE;
const std::string kScenes = RAYLIFE_SCENES;

struct Chapter {
  std::string binary;
  std::string scene;
};
// (Chapter 13 splats: a share of the sample indices holds whole passes of light paths, splats and all.)
// (Chapter 16 renders a wavefront of pixel samples at a time: a share of the indices is still whole samples.)
const Chapter kChapters[] = {{STEP04, "spheres.json"}, {STEP06, "cornell.json"}, {STEP07, "cornell.json"},
                             {STEP13, "caustics.json"}, {STEP16, "smallpt.json"}};

// A .film file's exact sums: what follows its header (the header's seconds differ from run to run).
std::string sums(const fs::path& film)
{
  const std::string bytes = readFile(film);
  const std::size_t end = bytes.find("\nend\n");
  REQUIRE(end != std::string::npos);
  return bytes.substr(end + 5);
}

std::string name(const std::string& binary) { return fs::path(binary).filename().string(); }

// Renders `chapter` at 40x30, 24 spp, seed 5, with `extra` arguments, in `dir`; requires success.
void renderIn(const TempDir& dir, const Chapter& chapter, std::vector<std::string> extra)
{
  std::vector<std::string> args = {kScenes + "/" + chapter.scene, "--width", "40", "--height", "30", "--spp", "24",
                                   "--seed", "5", "--quiet"};
  args.insert(args.end(), extra.begin(), extra.end());
  const Outcome o = run(chapter.binary, args, dir.path());
  INFO(name(chapter.binary) << ": " << o.err);
  REQUIRE(o.status == 0);
}

} // namespace

TEST_CASE("partial films of chapters 4 - 6 - 7 - 13 and 16 merged in any order give the one-process bytes")
{
  for (const Chapter& chapter : kChapters) {
    INFO(name(chapter.binary));
    const TempDir dir;
    renderIn(dir, chapter, {"-o", "whole.pfm", "-o", "whole.png", "-o", "whole.film", "--variance", "whole_var.pfm"});
    // Three jobs of an array: uneven ranges, one with a single thread.
    renderIn(dir, chapter, {"--samples", "0:5", "-o", "a.film"});
    renderIn(dir, chapter, {"--samples", "5:13", "-o", "b.film", "--threads", "1"});
    renderIn(dir, chapter, {"--samples", "18:6", "-o", "c.film"});
    for (const std::vector<std::string>& order : {std::vector<std::string>{"a.film", "b.film", "c.film"},
                                                  {"c.film", "a.film", "b.film"}, {"b.film", "c.film", "a.film"}}) {
      std::vector<std::string> args = order;
      args.insert(args.end(), {"-o", "merged.pfm", "-o", "merged.png", "-o", "merged.film", "--variance",
                               "merged_var.pfm", "--quiet"});
      const Outcome o = run(kMerge, args, dir.path());
      INFO(o.err);
      REQUIRE(o.status == 0);
      CHECK(readFile(dir.path() / "merged.pfm") == readFile(dir.path() / "whole.pfm"));
      CHECK(readFile(dir.path() / "merged.png") == readFile(dir.path() / "whole.png"));
      CHECK(readFile(dir.path() / "merged_var.pfm") == readFile(dir.path() / "whole_var.pfm"));
      // The sums themselves, bit for bit (a float image could hide a difference in the sums' last bits).
      CHECK(sums(dir.path() / "merged.film") == sums(dir.path() / "whole.film"));
    }
    // Merged in two steps (a partial sum kept as a film, then the rest).
    REQUIRE(run(kMerge, {"c.film", "a.film", "-o", "ac.film", "--quiet"}, dir.path()).status == 0);
    REQUIRE(run(kMerge, {"b.film", "ac.film", "-o", "two_steps.pfm", "--quiet"}, dir.path()).status == 0);
    CHECK(readFile(dir.path() / "two_steps.pfm") == readFile(dir.path() / "whole.pfm"));
  }
}

TEST_CASE("a missing - overlapping or foreign share is refused with one message and nothing written")
{
  const Chapter& chapter = kChapters[1];
  const TempDir dir;
  renderIn(dir, chapter, {"--samples", "0:8", "-o", "a.film"});
  renderIn(dir, chapter, {"--samples", "16:8", "-o", "c.film"});
  renderIn(dir, chapter, {"--samples", "4:8", "-o", "overlap.film"});
  {
    const Outcome o = run(chapter.binary, {kScenes + "/" + chapter.scene, "--width", "40", "--height", "30", "--spp",
                                           "24", "--seed", "6", "--samples", "8:8", "-o", "seed6.film", "--quiet"},
                          dir.path());
    REQUIRE(o.status == 0);
  }
  const std::vector<std::string> before = entries(dir.path());
  auto refused = [&](std::vector<std::string> args, const std::string& message) {
    args.insert(args.end(), {"-o", "x.pfm", "-o", "x.film"});
    const Outcome o = run(kMerge, args, dir.path());
    CHECK(o.status == 1);
    CHECK(o.err == "raylife_merge: " + message + "\n");
    CHECK(entries(dir.path()) == before);
  };
  refused({"a.film", "c.film"}, "samples 8..15 of the render's 0..23 are in none of the films (they hold 0..7, 16..23); "
                                "an image needs them all (-o x.film keeps a partial sum)");
  refused({"a.film", "c.film", "overlap.film"}, "overlap.film and the films before it both hold samples 4..7: each "
                                                "sample index may be merged once");
  refused({"a.film", "seed6.film", "c.film"},
          "seed6.film is a share of another render than a.film: its seed is 6, not 5");
  refused({"a.film", "missing.film"}, "missing.film: cannot open: No such file or directory");
  // Only a partial film is asked for: a gap is fine.
  CHECK(run(kMerge, {"a.film", "c.film", "-o", "ac.film", "--quiet"}, dir.path()).status == 0);
}

TEST_CASE("a film of a scene whose file name holds a newline merges - the name escaped in its header")
{
  // The name is copied into the film's header, a line of its own: written as it was, the newline ended that line
  // early, and raylife_merge refused the film ("unknown key").
  const Chapter& chapter = kChapters[0];
  const TempDir dir;
  fs::copy_file(kScenes + "/" + chapter.scene, dir.path() / "a\nb.json");
  for (const char* share : {"0:4", "4:4"}) {
    const Outcome o = run(chapter.binary, {"a\nb.json", "--width", "8", "--height", "6", "--spp", "8", "--samples",
                                           share, "-o", std::string("s") + share[0] + ".film", "--quiet"},
                          dir.path());
    REQUIRE(o.status == 0);
  }
  CHECK(readFile(dir.path() / "s0.film").find("\nscene a\\nb.json\nend\n") != std::string::npos);
  const Outcome o = run(kMerge, {"s0.film", "s4.film", "-o", "x.pfm"}, dir.path());
  INFO(o.err);
  CHECK(o.status == 0);
  CHECK(o.err.find("on a\\nb.json:") != std::string::npos);
  CHECK(fs::exists(dir.path() / "x.pfm"));
}

TEST_CASE("a share of the samples is checked against the spp before any work")
{
  const Chapter& chapter = kChapters[1];
  const TempDir dir;
  auto usage = [&](std::vector<std::string> args, const std::string& message) {
    args.insert(args.begin(), kScenes + "/" + chapter.scene);
    const Outcome o = run(chapter.binary, args, dir.path());
    CHECK(o.status == 2);
    CHECK(o.err.rfind("step06_path_tracer: " + message + "\n", 0) == 0);
    CHECK(entries(dir.path()).empty());
  };
  usage({"--samples", "0:8", "-o", "a.film"}, "--samples takes a share of the samples of --spp N: give --spp");
  usage({"--spp", "16", "--samples", "8:9", "-o", "a.film"},
        "--samples 8:9 reaches past --spp 16 (sample indices are 0 to 15)");
  usage({"--spp", "16", "--samples", "8", "-o", "a.film"}, "--samples expects FIRST:COUNT (e.g. 0:64), got '8'");
  usage({"--spp", "16", "--samples", "0:16", "--adaptive", "0.1", "-o", "a.film"},
        "--adaptive needs every sample of a pixel in one process; it cannot take --samples");
  usage({"--spp", "16", "-o", "a.film", "-o", "b.film"}, "-o is given two .film files; one of each format");
}

TEST_CASE("an EXR output holds the PFM's floats - raylife_compare reads it and so does OpenEXR's exrheader")
{
  const TempDir dir;
  const Chapter& chapter = kChapters[1];
  renderIn(dir, chapter, {"-o", "x.pfm", "-o", "x.exr", "--variance", "v.exr"});
  renderIn(dir, chapter, {"--variance", "v.pfm", "-o", "y.png"});
  const raylife::Image pfm = raylife::readPfm((dir.path() / "x.pfm").string());
  const raylife::Image exr = raylife::readExr((dir.path() / "x.exr").string());
  CHECK(exr.width == 40);
  CHECK(exr.height == 30);
  CHECK(exr.pixels == pfm.pixels); // identical floats
  CHECK(raylife::readImage((dir.path() / "v.exr").string()).pixels ==
        raylife::readPfm((dir.path() / "v.pfm").string()).pixels);

  const Outcome compare = run(kCompare, {"x.exr", "x.pfm", "--tolerance", "0"}, dir.path());
  CHECK(compare.status == 0);
  CHECK(compare.out.find("max difference   0 ") != std::string::npos);

  // OpenEXR's own reader: three 32-bit float channels over the whole 40x30 window.
  const Outcome header = run(EXRHEADER, {"x.exr"}, dir.path());
  INFO(header.out << header.err);
  REQUIRE(header.status == 0);
  for (const char* line : {"R, 32-bit floating-point", "G, 32-bit floating-point", "B, 32-bit floating-point",
                           "dataWindow (type box2i): (0 0) - (39 29)"})
    CHECK(header.out.find(line) != std::string::npos);

  // A damaged EXR is one message, not a crash.
  writeFile(dir.path() / "bad.exr", readFile(dir.path() / "x.exr").substr(0, 200));
  const Outcome bad = run(kCompare, {"bad.exr", "x.pfm"}, dir.path());
  CHECK(bad.status == 2);
  CHECK(bad.err.rfind("raylife_compare: bad.exr: cannot read the EXR: ", 0) == 0);
}

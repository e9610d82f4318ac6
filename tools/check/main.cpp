// raylife_check: grades a chapter's image against its golden, for students and teachers (docs/golden-tests.md).
//   raylife_check CHAPTER            prints the command that renders the image it grades
//   raylife_check CHAPTER IMAGE      grades IMAGE: exit 0 pass, 1 fail, 2 bad usage or unreadable image
// Which chapter is graded how, at what size and with how many samples: chapters.h, one line each.
#include "chapters.h"

#include "render/grading.h"
#include "render/image_io.h"
#include "render/locate.h"

#include <nlohmann/json.hpp>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <string>
#include <vector>

using namespace raylife;
using namespace raylife::check;
namespace fs = std::filesystem;

namespace {

constexpr int kPngCodes = 1;          // a PNG's code may differ by one (the linear value rounded differently)
constexpr double kRelative = 1e-4;    // a PFM: |a − b| ≤ 1e-4·|b| + 1e-6 (rounding between compilers, libm: < 1e-6)
constexpr double kAbsolute = 1e-6;

// Bad usage or an unreadable file: exit 2, having said why.
struct Usage {
  std::string message;
};

void usage(std::ostream& out)
{
  out << "usage: raylife_check CHAPTER [IMAGE] [--spp N] [--diff FILE] [--golden DIR]\n"
         "       raylife_check --reference CHAPTER DIR    (the commands that render the golden into DIR)\n"
         "       raylife_check --list                     (the chapters it grades)\n"
         "  CHAPTER      its number or program: 4 or step04_shadows\n"
         "  IMAGE        a .png, .pfm or .exr of the chapter's default scene; without it, print the command that\n"
         "               renders the image raylife_check grades\n"
         "  --spp N      samples per pixel of IMAGE (Monte Carlo chapters; otherwise read from IMAGE's .json\n"
         "               beside it, written by --stats, or the chapter's default)\n"
         "  --diff FILE  where the difference image goes on failure (default: beside IMAGE, NAME-difference.png)\n"
         "  --golden DIR the goldens' folder (default: $RAYLIFE_GOLDEN, else tests/golden of this tree)\n"
         "exit status: 0 pass, 1 fail, 2 bad usage or unreadable image\n";
}

// `path` as the user would type it: relative to the working folder when it lies below it.
std::string shown(const fs::path& path)
{
  std::error_code ec;
  const fs::path relative = fs::relative(path, fs::current_path(ec), ec);
  const std::string s = !ec && !relative.empty() && *relative.begin() != ".." ? relative.string() : path.string();
  return s.find_first_of(" '\"") == std::string::npos ? s : "'" + s + "'";
}

fs::path goldenDirectory(const std::string& given)
{
  if (!given.empty())
    return given;
  if (const char* env = std::getenv("RAYLIFE_GOLDEN"); env && *env)
    return env;
  const fs::path root = projectRoot();
  if (!root.empty())
    return root / "tests" / "golden";
  if (const fs::path installed = installedDataFor(programDirectory()); !installed.empty())
    return installed / "golden";
  throw Usage{"cannot find the goldens: there is no scenes/ and tests/golden/ above " + programDirectory().string() +
              ", no source tree named beside it and no ../share/raylife; give --golden DIR"};
}

std::string sizeText(int w, int h) { return std::to_string(w) + "x" + std::to_string(h); }

// The chapter's program: beside raylife_check, or (for the raylife_check of the exercises' build, which builds no
// chapter) in build/bin of the same tree.
fs::path chapterProgram(const GradedChapter& c)
{
  const fs::path beside = programDirectory() / c.binary;
  std::error_code ec;
  if (fs::exists(beside, ec))
    return beside;
  const fs::path root = projectRoot();
  if (!root.empty() && fs::exists(root / "build" / "bin" / c.binary, ec))
    return root / "build" / "bin" / c.binary;
  return beside;
}

// The chapter's exercise (cmake --preset exercises): beside raylife_check, or in build-exercises/bin of the same
// tree; empty when there is no exercise build.
fs::path exerciseProgram(const GradedChapter& c)
{
  const std::string name = std::string(c.binary) + "_exercise";
  std::error_code ec;
  if (fs::exists(programDirectory() / name, ec))
    return programDirectory() / name;
  const fs::path root = projectRoot();
  if (!root.empty() && fs::exists(root / "build-exercises" / "bin" / name, ec))
    return root / "build-exercises" / "bin" / name;
  return {};
}

// The command that renders the image raylife_check grades (one line), in the working folder, with `program` (by
// default the chapter's).
std::string renderCommand(const GradedChapter& c, const fs::path& program = {})
{
  std::string cmd = shown(program.empty() ? chapterProgram(c) : program) + " --width " + std::to_string(c.width) +
                    " --height " + std::to_string(c.height);
  const std::string name = c.binary;
  if (c.grading == Grading::Statistical)
    cmd += " --spp " + std::to_string(c.spp) + " -o " + name + ".pfm --stats " + name + ".json";
  else
    cmd += " -o " + name + ".pfm";
  return cmd;
}

// What is graded how, for the person who asked for the command.
std::string explanation(const GradedChapter& c)
{
  const std::string name = c.binary;
  if (c.grading == Grading::Exact)
    return "then: raylife_check " + std::to_string(c.number) + " " + name + ".pfm\n" + name +
           " is deterministic: every channel must be within 1e-4 relative of the golden (a PFM or EXR at " +
           sizeText(c.width, c.height) + "), or within " + std::to_string(kPngCodes) +
           " code of it (a PNG at that size, or the chapter's default render, out/" + name + ".png, or a PFM or EXR of that "
           "render, encoded as the chapters encode PNGs)";
  return "then: raylife_check " + std::to_string(c.number) + " " + name + ".pfm\n" + name +
         " samples at random, so it is graded by a per-pixel z-test and an image-mean test against a reference of " +
         sizeText(c.width, c.height) + " pixels, " + std::to_string(c.referenceSpp) + " spp, seed " +
         std::to_string(kReferenceSeed) + "; any seed and any --spp >= " + std::to_string(c.spp) +
         " passes (the .json written by --stats tells raylife_check the spp), and so does an image k times as wide "
         "and high (the default render): a PNG too, its clamped channels tested only for being too bright";
}

// The commands that render the golden of `c` into `dir`, one a line (tools/update_goldens.sh runs them).
std::string referenceCommands(const GradedChapter& c, const fs::path& dir)
{
  const std::string bin = "'" + (programDirectory() / c.binary).string() + "'";
  const std::string out = "'" + (dir / c.binary).string();
  const std::string size = " --width " + std::to_string(c.width) + " --height " + std::to_string(c.height);
  if (c.grading == Grading::Exact)
    return bin + size + " --quiet -o " + out + ".pfm'\n" + bin + " --quiet -o " + out + ".png'\n";
  return bin + size + " --spp " + std::to_string(c.referenceSpp) + " --seed " + std::to_string(kReferenceSeed) +
         " --quiet -o " + out + ".pfm' -o " + out + ".png' --variance " + out + "_variance.pfm' --stats " + out +
         ".json'\n";
}

Image readOrUsage(const fs::path& path)
{
  try {
    return readImage(path.string());
  } catch (const ImageIoError& e) {
    throw Usage{e.what()};
  }
}

// The image's samples per pixel: --spp, else the --stats file beside it, else the chapter's default.
int studentSpp(const GradedChapter& c, const fs::path& image, int given, std::vector<std::string>& notes)
{
  if (given > 0) {
    notes.push_back("samples per pixel: " + std::to_string(given) + " (--spp)");
    return given;
  }
  fs::path sidecar = image;
  sidecar.replace_extension(".json");
  // Only a --stats file (it names its chapter) is read as one: a scene beside its render (b.json beside b.pfm) is
  // not, and is ignored with a word.
  nlohmann::json stats;
  if (fs::exists(sidecar)) {
    try {
      std::ifstream in(sidecar);
      stats = nlohmann::json::parse(in);
    } catch (const nlohmann::json::exception&) {
      stats = nullptr;
    }
    if (!stats.is_object() || !stats.contains("chapter")) {
      notes.push_back("samples per pixel: " + std::to_string(c.spp) + ", the chapter's default (" + sidecar.string() +
                      " beside the image is no --stats file: it has no \"chapter\" key, so it was not read)");
      return c.spp;
    }
  }
  if (fs::exists(sidecar)) {
    if (!stats.contains("spp") || !stats["spp"].is_number_integer() || stats["spp"] < 1 || stats["spp"] > (1 << 30))
      throw Usage{sidecar.string() + ": /spp: expected the samples per pixel, a whole number from 1 to 2^30"};
    if (stats.contains("chapter") && stats["chapter"] != c.binary)
      throw Usage{sidecar.string() + ": /chapter: it is " + stats["chapter"].dump() + "'s, not " + c.binary + "'s"};
    const int spp = stats["spp"];
    notes.push_back("samples per pixel: " + std::to_string(spp) + " (from " + sidecar.string() + ")");
    return spp;
  }
  notes.push_back("samples per pixel: " + std::to_string(c.spp) + ", the chapter's default (no --spp, no " +
                  sidecar.filename().string() + " beside the image)");
  return c.spp;
}

// The cells an image of `spp` samples per pixel, `k` times the reference's size, is graded in: the chapter's own,
// grown (doubled, while they divide the reference's size) until a cell pools as many samples as one of the chapter's
// default render does. A pixel's mean over a few samples of a path tracer is skewed (a rare bright path), so at few
// samples the z-test's normal approximation fails: a correct chapter 6 at 4 spp failed 36 to 45 of 3072 pixels
// (bound 22) at three seeds, at 8 spp 27 to 34. Pooled to the default's count a cell is as normal as the default's
// pixel, at the price of resolution: a fault smaller than a cell is averaged with its neighbours.
int cellsFor(const GradedChapter& c, int spp, int k, int referenceWidth, int referenceHeight,
             std::vector<std::string>& notes)
{
  const long long needed = (long long)c.spp * c.cell * c.cell;
  auto pooled = [&](int cell) { return (long long)spp * k * k * cell * cell; };
  int cell = c.cell;
  while (pooled(cell) < needed && referenceWidth % (2 * cell) == 0 && referenceHeight % (2 * cell) == 0)
    cell *= 2;
  if (cell != c.cell)
    notes.push_back("graded in cells of " + std::to_string(cell) + "x" + std::to_string(cell) +
                    " reference pixels, not " + std::to_string(c.cell) + "x" + std::to_string(c.cell) + ": at " +
                    std::to_string(spp) + " spp a cell then pools " + std::to_string(pooled(cell)) + " samples" +
                    (pooled(cell) < needed
                         ? ", fewer than the " + std::to_string(needed) + " a cell of the chapter's default render (" +
                               std::to_string(c.spp) + " spp) pools, and no larger cell divides the image: at so "
                               "few samples a correct image may fail"
                         : ", at least the " + std::to_string(needed) + " a cell of the chapter's default render (" +
                               std::to_string(c.spp) + " spp) pools; a fault smaller than a cell is averaged with its "
                               "neighbours"));
  return cell;
}

int parseCount(const std::string& flag, const std::string& text)
{
  char* end = nullptr;
  const long v = std::strtol(text.c_str(), &end, 10);
  if (text.empty() || *end != '\0' || v < 1 || v > (1 << 30))
    throw Usage{flag + " '" + text + "': expected a whole number from 1 to 2^30"};
  return int(v);
}

int run(int argc, char** argv)
{
  std::vector<std::string> positional;
  std::string diffPath, goldenGiven;
  int spp = 0;
  bool reference = false;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc)
        throw Usage{arg + " expects a value"};
      return argv[++i];
    };
    if (arg == "--help" || arg == "-h") {
      usage(std::cout);
      return 0;
    } else if (arg == "--spp")
      spp = parseCount(arg, value());
    else if (arg == "--diff")
      diffPath = value();
    else if (arg == "--golden")
      goldenGiven = value();
    else if (arg == "--reference")
      reference = true;
    else if (arg == "--list") {
      for (const GradedChapter& c : kGradedChapters)
        std::cout << c.binary << "\n";
      return 0;
    }
    else if (arg.size() > 1 && arg[0] == '-')
      throw Usage{"unknown option '" + arg + "'"};
    else
      positional.push_back(arg);
  }
  if (positional.empty() || positional.size() > 2)
    throw Usage{positional.empty() ? "no chapter given" : "more than one image given"};
  const GradedChapter* chapter = findChapter(positional[0]);
  if (!chapter) {
    std::string known;
    for (const GradedChapter& c : kGradedChapters)
      known += std::string(known.empty() ? "" : ", ") + std::to_string(c.number);
    throw Usage{"no chapter '" + positional[0] + "' (known: " + known + ", or their program names)"};
  }
  const GradedChapter& c = *chapter;
  if (reference) {
    if (positional.size() != 2)
      throw Usage{"--reference CHAPTER DIR: the folder to render the golden into is missing"};
    std::cout << referenceCommands(c, fs::absolute(positional[1]));
    return 0;
  }
  if (positional.size() == 1) {
    std::cout << renderCommand(c) << "\n";
    // The exercise renders the same image: its command too, when the exercises' build has it.
    if (const fs::path exercise = exerciseProgram(c); !exercise.empty())
      std::cerr << "your exercise renders it with: " << renderCommand(c, exercise) << "\n";
    std::cerr << explanation(c) << "\n";
    return 0;
  }

  const fs::path imagePath = positional[1];
  const std::string ext = imagePath.extension().string();
  if (ext != ".png" && ext != ".pfm" && ext != ".exr")
    throw Usage{imagePath.string() + ": expected a .png, .pfm or .exr image"};
  const Image image = readOrUsage(imagePath);
  const fs::path dir = goldenDirectory(goldenGiven);
  const fs::path goldenPath = dir / (std::string(c.binary) + ".pfm");
  if (!fs::exists(goldenPath))
    throw Usage{"no golden " + goldenPath.string() + " (tools/update_goldens.sh BUILD " + c.binary + " renders it)"};
  const Image golden = readOrUsage(goldenPath);
  const bool png = ext == ".png";
  const std::string wrongSize = imagePath.string() + " is " + sizeText(image.width, image.height) + ", ";

  Grade grade;
  std::vector<std::string> notes;
  if (c.grading == Grading::Exact) {
    if (image.width == golden.width && image.height == golden.height) {
      grade = png ? gradePngExactly(image, golden, kPngCodes) : gradeLinearExactly(image, golden, kRelative, kAbsolute);
      notes.push_back("golden: " + goldenPath.string());
    } else {
      const fs::path goldenPng = dir / (std::string(c.binary) + ".png");
      const Image defaultRender = fs::exists(goldenPng) ? readOrUsage(goldenPng) : Image();
      if (image.width != defaultRender.width || image.height != defaultRender.height)
        throw Usage{wrongSize + "but " + c.binary + "'s golden is " + sizeText(golden.width, golden.height) +
                    (defaultRender.width ? " (or a PNG of its default render, " +
                                               sizeText(defaultRender.width, defaultRender.height) + ")"
                                         : "") +
                    "; render it with: " + renderCommand(c)};
      if (png) {
        grade = gradePngExactly(image, defaultRender, kPngCodes);
      } else {
        // A PFM or EXR of the default render: its golden is a PNG, so the image is encoded as the chapters encode
        // PNGs and compared code by code (the PNG's codes are recovered exactly, whichever side they are on).
        grade = gradePngExactly(defaultRender, image, kPngCodes);
        grade.figures.front() = "compared as PNG codes: " + imagePath.filename().string() +
                                " clamped, sRGB-encoded and rounded to 8 bits, as the chapters write PNGs";
      }
      notes.push_back("golden: " + goldenPng.string() + " (the chapter's default render)");
    }
  } else {
    const int k = golden.width > 0 ? image.width / golden.width : 0;
    if (k < 1 || image.width != k * golden.width || image.height != k * golden.height)
      throw Usage{wrongSize + "but " + c.binary + "'s reference is " + sizeText(golden.width, golden.height) +
                  " (an image k times as wide and high passes too); render it with: " + renderCommand(c)};
    const fs::path variancePath = dir / (std::string(c.binary) + "_variance.pfm");
    if (!fs::exists(variancePath))
      throw Usage{"no reference variance " + variancePath.string() + " (tools/update_goldens.sh renders it)"};
    StatisticalSetup setup;
    setup.spp = studentSpp(c, imagePath, spp, notes);
    setup.referenceSpp = c.referenceSpp;
    setup.fromPng = png;
    setup.cell = cellsFor(c, setup.spp, k, golden.width, golden.height, notes);
    grade = gradeStatistically(image, golden, readOrUsage(variancePath), setup);
    notes.push_back("reference: " + goldenPath.string() + " and its variance");
  }

  std::cout << c.binary << ": " << grade.verdict << "\n";
  for (const std::string& line : grade.figures)
    std::cout << "  " << line << "\n";
  for (const std::string& line : notes)
    std::cout << "  " << line << "\n";
  if (!grade.pass) {
    fs::path diff = diffPath;
    if (diff.empty())
      diff = imagePath.parent_path() / (imagePath.stem().string() + "-difference.png");
    Image shownDifference = grade.difference;
    for (float& v : shownDifference.pixels)
      v *= 0.5f; // 0.5: at the allowed limit; white: twice over it or more
    try {
      writeImage(shownDifference, diff.string());
      std::cout << "  difference image: " << diff.string() << " (mid-grey: at the allowed limit; brighter: over; "
                << sizeText(grade.difference.width, grade.difference.height) << ")\n";
    } catch (const ImageIoError& e) {
      std::cerr << "raylife_check: no difference image: " << e.what() << "\n";
    }
  }
  return grade.pass ? 0 : 1;
}

} // namespace

int main(int argc, char** argv)
{
  try {
    return run(argc, argv);
  } catch (const Usage& u) {
    std::cerr << "raylife_check: " << u.message << "\n";
    if (u.message.find("usage") == std::string::npos && argc < 2)
      usage(std::cerr);
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "raylife_check: " << e.what() << "\n";
    return 2;
  }
}

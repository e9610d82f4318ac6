// raylife_compare: compares an image with a reference, for teachers and for the golden tests (same code:
// common/render/image_compare.h). Prints the metrics, optionally writes a difference image, and exits 0 when the
// image is within tolerance, 1 when it is not, 2 on bad usage or unreadable files.
#include "render/image_compare.h"
#include "render/image_io.h"

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <cmath>
#include <filesystem>
#include <iostream>
#include <string>

#include <unistd.h>

using namespace raylife;

namespace {

void usage()
{
  std::cerr << "usage: raylife_compare IMAGE REFERENCE [--tolerance T] [--max-share S] [--diff FILE] [--gain G]\n"
               "  IMAGE, REFERENCE  .png, .pfm or .exr files of the same size (PNG is decoded from sRGB to linear)\n"
               "  --tolerance T     per-channel absolute tolerance (default 0.002)\n"
               "  --max-share S     share of pixels allowed over the tolerance, in [0, 1] (default 0)\n"
               "  --diff FILE       write |IMAGE - REFERENCE| x gain as .png, .pfm or .exr\n"
               "  --gain G          scale of the difference image (default 10)\n"
               "exit status: 0 within tolerance, 1 not, 2 bad usage (a missing or unreadable image, images of two\n"
               "sizes, a share outside [0, 1], gain 0, a --diff that cannot be written)\n"
               "To grade a chapter's image against its golden, use raylife_check.\n";
}

bool parseNumber(const char* text, double& out)
{
  char* end = nullptr;
  out = std::strtod(text, &end);
  return *text && *end == '\0' && out >= 0 && std::isfinite(out);
}

} // namespace

int main(int argc, char** argv)
{
  std::string files[2];
  int nFiles = 0;
  double tolerance = 0.002, maxShare = 0, gain = 10;
  std::string diffPath;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    auto number = [&](double& out) {
      if (i + 1 >= argc || !parseNumber(argv[i + 1], out)) {
        std::cerr << "raylife_compare: " << arg << " expects a number >= 0\n";
        std::exit(2);
      }
      ++i;
    };
    if (arg == "--tolerance")
      number(tolerance);
    else if (arg == "--max-share")
      number(maxShare);
    else if (arg == "--gain")
      number(gain);
    else if (arg == "--diff") {
      if (i + 1 >= argc) {
        std::cerr << "raylife_compare: --diff expects a file (.png, .pfm or .exr)\n";
        return 2;
      }
      diffPath = argv[++i];
    }
    else if (arg == "--help" || arg == "-h") {
      usage();
      return 0;
    } else if (!arg.empty() && arg[0] == '-') {
      std::cerr << "raylife_compare: unknown option '" << arg << "'\n";
      usage();
      return 2;
    } else if (nFiles < 2)
      files[nFiles++] = arg;
    else {
      std::cerr << "raylife_compare: more than two images given\n";
      return 2;
    }
  }
  if (nFiles != 2) {
    usage();
    return 2;
  }
  // Every argument is checked before any work: a bad one is bad usage (2), never a failed comparison (1).
  if (maxShare > 1) {
    std::cerr << "raylife_compare: --max-share " << maxShare << ": a share of the pixels, in [0, 1]\n";
    return 2;
  }
  if (gain <= 0) {
    std::cerr << "raylife_compare: --gain " << gain << ": the difference image's scale must be > 0\n";
    return 2;
  }
  for (const std::string& f : files) {
    std::error_code ec;
    if (!std::filesystem::is_regular_file(f, ec)) {
      std::cerr << "raylife_compare: " << f << ": no such image file\n";
      return 2;
    }
  }
  if (!diffPath.empty()) {
    namespace fs = std::filesystem;
    std::error_code ec;
    const fs::path folder = fs::path(diffPath).parent_path().empty() ? fs::path(".") : fs::path(diffPath).parent_path();
    if (!isImagePath(diffPath)) {
      std::cerr << "raylife_compare: --diff " << diffPath << ": expected a .png, .pfm or .exr file\n";
      return 2;
    }
    if (!fs::is_directory(folder, ec) || ::access(folder.c_str(), W_OK) != 0 || fs::is_directory(diffPath, ec)) {
      std::cerr << "raylife_compare: --diff " << diffPath << ": cannot be written (is its folder there and "
                << "writable?)\n";
      return 2;
    }
  }
  try {
    const Image image = readImage(files[0]);
    const Image reference = readImage(files[1]);
    if (image.width != reference.width || image.height != reference.height) {
      std::cerr << "raylife_compare: " << files[0] << " is " << image.width << "x" << image.height << " but "
                << files[1] << " is " << reference.width << "x" << reference.height
                << ": only images of one size can be compared (to grade a chapter's image at any size it allows: "
                   "raylife_check)\n";
      return 2;
    }
    const ImageDifference d = compareImages(image, reference, tolerance);
    std::printf("max difference   %.6g (at pixel %d, %d)\n", d.maxAbs, d.worstX, d.worstY);
    std::printf("RMSE             %.6g\n", d.rmse);
    std::printf("PSNR             %.2f dB\n", d.psnr);
    std::printf("relative MSE     %.6g\n", d.relativeMse);
    std::printf("over tolerance   %.4f%% of pixels (tolerance %g, allowed %.4f%%)\n", 100 * d.overTolerance,
                tolerance, 100 * maxShare);
    if (!diffPath.empty())
      writeImage(differenceImage(image, reference, gain), diffPath);
    const bool pass = d.overTolerance <= maxShare;
    std::printf("%s\n", pass ? "PASS" : "FAIL");
    return pass ? 0 : 1;
  } catch (const ImageIoError& e) {
    std::cerr << "raylife_compare: " << e.what() << "\n";
    return 2;
  }
}

// raylife_image: small operations on raylife's images. `convert` makes a PFM or EXR (linear radiance, which few
// viewers show) into a PNG to look at, with an exposure: each channel times 2^E, then clamped and sRGB-encoded as
// the chapters write their PNGs. Any of PNG, PFM and EXR in and out (a PNG read is decoded from sRGB to linear).
// Exit status: 0 done, 1 an unreadable or unwritable file, 2 bad usage.
#include "render/image_io.h"

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <iostream>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

using namespace raylife;

namespace {

const char* const kUsage =
    "usage: raylife_image convert IN OUT [--exposure E] [--tonemap clamp|reinhard|aces]\n"
    "  IN, OUT          .png, .pfm or .exr (e.g. a chapter's -o x.pfm into x.png to look at it)\n"
    "  --exposure E     multiply every channel by 2^E first (E in stops, may be negative; default 0)\n"
    "  --tonemap CURVE  how a PNG OUT maps radiance into [0, 1], after the exposure: clamp (default),\n"
    "                   reinhard (v/(1+v)) or aces (a filmic curve), as the chapters' --tonemap\n"
    "exit status: 0 done, 1 unreadable input or failed write, 2 bad usage\n";

int usageError(const std::string& message)
{
  std::cerr << "raylife_image: " << message << "\n" << kUsage;
  return 2;
}

} // namespace

int main(int argc, char** argv)
{
  const std::vector<std::string> args(argv + 1, argv + argc);
  if (args.size() == 1 && (args[0] == "--help" || args[0] == "-h")) {
    std::cout << kUsage;
    return 0;
  }
  if (args.empty() || args[0] != "convert")
    return usageError(args.empty() ? "no command given" : "unknown command '" + args[0] + "' (the one is convert)");
  std::vector<std::string> files;
  double exposure = 0;
  ToneMap toneMap = ToneMap::Clamp;
  for (std::size_t i = 1; i < args.size(); ++i) {
    std::string arg = args[i], value;
    if (arg == "--tonemap" || arg.rfind("--tonemap=", 0) == 0) {
      if (arg.size() > 9)
        value = arg.substr(10);
      else if (i + 1 < args.size())
        value = args[++i];
      else
        return usageError("--tonemap expects clamp, reinhard or aces");
      try {
        toneMap = parseToneMap(value);
      } catch (const std::invalid_argument&) {
        return usageError("--tonemap '" + value + "': expected clamp, reinhard or aces");
      }
    } else if (arg.rfind("--exposure", 0) == 0) {
      if (arg.size() > 10 && arg[10] == '=')
        value = arg.substr(11);
      else if (arg.size() == 10 && i + 1 < args.size())
        value = args[++i];
      else if (arg.size() == 10)
        return usageError("--exposure expects a value");
      else
        return usageError("unknown option '" + arg + "'");
      errno = 0;
      char* end = nullptr;
      exposure = std::strtod(value.c_str(), &end);
      if (value.empty() || *end != '\0' || errno == ERANGE || !std::isfinite(exposure) || std::abs(exposure) > 64)
        return usageError("--exposure expects a number of stops in [-64, 64], got '" + value + "'");
    } else if (arg.size() > 1 && arg[0] == '-') {
      return usageError("unknown option '" + arg + "'");
    } else {
      files.push_back(arg);
    }
  }
  if (files.size() != 2)
    return usageError("convert takes an input and an output file");
  for (const std::string& f : files)
    if (!isImagePath(f))
      return usageError("'" + f + "': not a .png, .pfm or .exr file");
  try {
    Image image = readImage(files[0]);
    const float scale = float(std::exp2(exposure));
    for (float& v : image.pixels)
      v *= scale;
    if (fileExtension(files[1]) == ".png") // (PFM and EXR stay linear)
      image = toneMapped(std::move(image), toneMap);
    writeImage(image, files[1]);
  } catch (const ImageIoError& e) {
    std::cerr << "raylife_image: " << e.what() << "\n";
    return 1;
  }
  return 0;
}

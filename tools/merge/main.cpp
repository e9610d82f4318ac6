// raylife_merge: sums partial films (.film, written by a chapter with --samples FIRST:COUNT -o part.film) into the
// final images, exactly: films merged in any order give the bits of the one-process render (docs/beyond-one-
// machine.md). Writes all or nothing; exits 0 done, 1 bad or mismatched films or a missing or overlapping range, 2
// bad usage.
#include "render/film_file.h"
#include "render/image_io.h"

#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <string>
#include <vector>

using namespace raylife;

namespace {

void usage(std::ostream& out)
{
  out << "usage: raylife_merge PART.film... -o FILE [-o FILE...] [--variance FILE] [--quiet]\n"
         "  PART.film        partial films of one render (chapter, scene, size, spp, seed, depth), in any order\n"
         "  -o FILE          .png, .pfm or .exr: the image of every sample (the films must hold each sample\n"
         "                   index of --spp once); .film: the films summed, which may still be partial\n"
         "  --variance FILE  also write each pixel's variance of the mean (.pfm or .exr)\n"
         "  --quiet          no summary line\n"
         "exit status: 0 done, 1 bad films (unreadable, of different renders, overlapping or incomplete), 2 bad usage\n";
}

bool endsWith(const std::string& s, const std::string& suffix)
{
  return s.size() >= suffix.size() && s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

} // namespace

int main(int argc, char** argv)
{
  std::vector<std::string> inputs, outputs;
  std::string variancePath;
  bool quiet = false;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) {
        std::cerr << "raylife_merge: " << arg << " expects a file name\n";
        std::exit(2);
      }
      return argv[++i];
    };
    if (arg == "-o" || arg == "--output") {
      const std::string path = value();
      if (!isImagePath(path) && !endsWith(path, ".film")) {
        std::cerr << "raylife_merge: -o '" << path << "': unknown format (.png, .pfm, .exr or .film)\n";
        return 2;
      }
      outputs.push_back(path);
    } else if (arg == "--variance") {
      variancePath = value();
      if (!endsWith(variancePath, ".pfm") && !endsWith(variancePath, ".exr")) {
        std::cerr << "raylife_merge: --variance '" << variancePath << "': the variance image must be .pfm or .exr\n";
        return 2;
      }
    } else if (arg == "--quiet" || arg == "-q") {
      quiet = true;
    } else if (arg == "--help" || arg == "-h") {
      usage(std::cout);
      return 0;
    } else if (!arg.empty() && arg[0] == '-') {
      std::cerr << "raylife_merge: unknown option '" << arg << "'; see --help\n";
      return 2;
    } else {
      inputs.push_back(arg);
    }
  }
  if (inputs.empty() || outputs.empty()) {
    std::cerr << "raylife_merge: give at least one .film and one output (-o)\n";
    usage(std::cerr);
    return 2;
  }
  try {
    // Sum the films, checking that each is a share of the same render and that no sample index comes twice.
    PartialFilm total = readFilm(inputs[0]);
    for (std::size_t i = 1; i < inputs.size(); ++i)
      mergeFilm(total, i == 1 ? inputs[0] : "the films before it", readFilm(inputs[i]), inputs[i]);
    const FilmHeader& h = total.header;
    // An image needs every sample of a fixed spp (a time budget has no fixed set: any union will do).
    bool imageWanted = !variancePath.empty();
    for (const std::string& path : outputs)
      imageWanted = imageWanted || !endsWith(path, ".film");
    const SampleRange gap = firstGap(h.samples, h.spp);
    if (imageWanted && h.spp > 0 && gap.count > 0) {
      std::cerr << "raylife_merge: samples " << gap.first << ".." << gap.end() - 1 << " of the render's 0.."
                << h.spp - 1 << " are in none of the films (they hold " << describeRanges(h.samples)
                << "); an image needs them all (-o x.film keeps a partial sum)\n";
      return 1;
    }
    std::vector<std::pair<std::string, std::vector<unsigned char>>> files;
    const Image mean = total.film.mean();
    for (const std::string& path : outputs)
      files.emplace_back(path, endsWith(path, ".film") ? encodeFilm(total) : encodeImage(mean, path));
    if (!variancePath.empty())
      files.emplace_back(variancePath, encodeImage(total.film.varianceOfMean(), variancePath));
    writeFilesAtomically(files);
    if (!quiet) {
      std::fprintf(stderr, "raylife_merge: %zu film%s of %s on %s: %dx%d, %lld spp (samples %s), %.2f render s",
                   inputs.size(), inputs.size() == 1 ? "" : "s", h.chapter.c_str(), h.scene.c_str(), h.width, h.height, static_cast<long long>(h.sampleCount()),
                   describeRanges(h.samples).c_str(), h.seconds);
      std::cerr << " -> " << outputs[0];
      for (std::size_t i = 1; i < outputs.size(); ++i)
        std::cerr << ", " << outputs[i];
      std::cerr << "\n";
    }
    return 0;
  } catch (const FilmError& e) {
    std::cerr << "raylife_merge: " << e.what() << "\n";
  } catch (const ImageIoError& e) {
    std::cerr << "raylife_merge: " << e.what() << "; nothing was written\n";
  } catch (const std::bad_alloc&) {
    std::cerr << "raylife_merge: out of memory; nothing was written\n";
  }
  return 1;
}

// raylife_light_bench: equal-time efficiency of chapters 6, 7 and 8 with the light sampler unguided and guided
// (--guide off / on; docs/07_light_sampling.md, issue 25). For each scene it renders a reference (chapter 8,
// --guide off, many samples; cached beside the results), then every variant for the same wall-clock budget with
// several seeds, interleaved so that the machine's drift falls on all alike, and prints per scene each variant's
// relative MSE (less the reference's own share), its wall-clock and processor time (the whole process: loading, the
// guide's pre-pass, the render, the files) and its efficiency 1 / (seconds × relative MSE) by each, as a ratio to
// chapter 6's. On a machine shared with other work the processor time is the steadier measure of the work done.
// Not a test: timings are never asserted.
#include "bench.h"
#include "render/image_io.h"

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <map>

#include <sys/resource.h>
#include <string>
#include <vector>

namespace fs = std::filesystem;
using namespace raylife;

namespace {

struct Variant {
  std::string label, binary, args;
};

const std::vector<Variant> kVariants = {
    {"ch6", "step06_path_tracer", ""},
    {"ch7 unguided", "step07_light_sampling", "--guide off"},
    {"ch7 guided", "step07_light_sampling", "--guide on"},
    {"ch8 unguided", "step08_mis", "--guide off"},
    {"ch8 guided", "step08_mis", "--guide on"},
};

[[noreturn]] void usage(const std::string& message)
{
  if (!message.empty())
    std::cerr << "raylife_light_bench: " << message << "\n";
  std::cerr << "usage: raylife_light_bench [--bin DIR] [--out DIR] [--size WxH] [--time SECONDS] [--seeds N]\n"
               "                           [--reference-spp N] [--threads N] SCENE.json...\n";
  std::exit(2);
}

// The processor time (user and system) that the finished children of this process have used, in seconds.
double childrenCpuSeconds()
{
  rusage usage{};
  getrusage(RUSAGE_CHILDREN, &usage);
  return double(usage.ru_utime.tv_sec + usage.ru_stime.tv_sec) +
         1e-6 * double(usage.ru_utime.tv_usec + usage.ru_stime.tv_usec);
}

// What one run of a command took: wall-clock seconds, and processor seconds on all its threads.
struct Took {
  double wall = 0, cpu = 0;
};

// Runs `command` (its output to `log`) and returns what it took; exits on failure.
Took timed(const std::string& command, const fs::path& log)
{
  const auto start = std::chrono::steady_clock::now();
  const double cpuStart = childrenCpuSeconds();
  if (std::system((command + " >>'" + log.string() + "' 2>&1").c_str()) != 0) {
    std::cerr << "raylife_light_bench: failed: " << command << " (see " << log.string() << ")\n";
    std::exit(1);
  }
  return {std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(),
          childrenCpuSeconds() - cpuStart};
}

} // namespace

int main(int argc, char** argv)
{
  fs::path bin = fs::canonical(fs::path(argv[0])).parent_path(), out;
  std::string size = "96x72";
  double seconds = 2;
  int seeds = 3, referenceSpp = 2048, threads = 0;
  std::vector<std::string> scenes;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc)
        usage(a + " needs a value");
      return argv[++i];
    };
    if (a == "--bin")
      bin = value();
    else if (a == "--out")
      out = value();
    else if (a == "--size")
      size = value();
    else if (a == "--time")
      seconds = std::atof(value().c_str());
    else if (a == "--seeds")
      seeds = std::atoi(value().c_str());
    else if (a == "--reference-spp")
      referenceSpp = std::atoi(value().c_str());
    else if (a == "--threads")
      threads = std::atoi(value().c_str());
    else if (a == "--help" || a == "-h")
      usage("");
    else if (!a.empty() && a[0] == '-')
      usage("unknown option '" + a + "'");
    else
      scenes.push_back(a);
  }
  const auto x = size.find('x');
  if (scenes.empty() || !(seconds > 0) || seeds < 1 || referenceSpp < 1 || threads < 0 || x == std::string::npos)
    usage("give at least one scene, and positive values");
  const std::string dims = "--width " + size.substr(0, x) + " --height " + size.substr(x + 1);
  const std::string threadArg = threads > 0 ? " --threads " + std::to_string(threads) : "";
  if (out.empty())
    out = bin.parent_path() / "bench" / "lights";
  fs::create_directories(out);
  const fs::path log = out / "log.txt";

  std::cout << "| scene | estimator | relative MSE | wall s | CPU s | efficiency / chapter 6's, by wall | by CPU |\n"
               "|---|---|---|---|---|---|---|\n";
  for (const std::string& scene : scenes) {
    const std::string name = fs::path(scene).stem().string();
    // The reference: chapter 8 unguided, many samples, with its variance (cached by scene, size and spp).
    const fs::path ref = out / (name + "_" + size + "_" + std::to_string(referenceSpp) + "_ref.pfm");
    const fs::path refVar = out / (name + "_" + size + "_" + std::to_string(referenceSpp) + "_refvar.pfm");
    if (!fs::exists(ref) || !fs::exists(refVar))
      timed((bin / "step08_mis").string() + " '" + scene + "' " + dims + " --guide off --quiet --seed 999 --spp " +
                std::to_string(referenceSpp) + threadArg + " -o '" + ref.string() + "' --variance '" +
                refVar.string() + "'",
            log);
    const Image reference = readImage(ref.string()), variance = readImage(refVar.string());
    std::map<std::string, double> mse, wall, cpu;
    for (int seed = 1; seed <= seeds; ++seed)
      for (const Variant& v : kVariants) {
        const fs::path image = out / (name + "_run.pfm");
        const Took took = timed((bin / v.binary).string() + " '" + scene + "' " + dims + " " + v.args +
                                    " --quiet --seed " + std::to_string(seed) + " --time " +
                                    std::to_string(seconds) + threadArg + " -o '" + image.string() + "'",
                                log);
        wall[v.label] += took.wall / seeds;
        cpu[v.label] += took.cpu / seeds;
        const bench::ErrorMetrics e = bench::measureError(readImage(image.string()), reference, variance);
        mse[v.label] += (e.relativeMse - e.referenceRelativeMse) / seeds;
      }
    for (const Variant& v : kVariants) {
      std::printf("| %s | %s | %.4g | %.2f | %.2f | %.2f | %.2f |\n", name.c_str(), v.label.c_str(), mse[v.label],
                  wall[v.label], cpu[v.label], wall["ch6"] * mse["ch6"] / (wall[v.label] * mse[v.label]),
                  cpu["ch6"] * mse["ch6"] / (cpu[v.label] * mse[v.label]));
      std::fflush(stdout);
    }
  }
  return 0;
}

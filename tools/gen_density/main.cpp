// gen_density OUT.json [N] [SEED] [--threshold T] [--power P]: a procedural cloud for chapter 15's heterogeneous
// media, as a density file.
//
// The cloud is fractal (fBm) value noise, five octaves, shaped by a soft ellipsoid so that it thins out towards its
// edge and leaves most of its box empty (which is where a grid of majorants beats one global maximum): the density
// is 2.2 × max(0, fBm × shape − 0.12), the densest about 1. --threshold T cuts at T instead of 0.12 (higher: less
// cloud, more empty space) and --power P raises what is left to P (above 1: dense cores and thin, wispy edges);
// with either, the density is (max(0, fBm × shape − T) / its largest value)^P, the densest exactly 1. The file is
// the format docs/scene-format.md describes: {"resolution": [N, N/2, N], "bounds": [[-1, -0.5, -1], [1, 0.5, 1]],
// "density": [...]}, x fastest, then y, then z; values ≥ 0 (a medium's sigma_a and sigma_s scale them). The same
// arguments write the same file, byte for byte.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <string>
#include <vector>

namespace {

// A hash of a lattice point and the seed to [0, 1).
double lattice(int x, int y, int z, std::uint64_t seed)
{
  std::uint64_t h = seed * 0x9E3779B97F4A7C15ULL;
  h ^= std::uint64_t(std::uint32_t(x)) * 0xBF58476D1CE4E5B9ULL;
  h ^= std::uint64_t(std::uint32_t(y)) * 0x94D049BB133111EBULL;
  h ^= std::uint64_t(std::uint32_t(z)) * 0xD6E8FEB86659FD93ULL;
  h ^= h >> 31;
  h *= 0x9E3779B97F4A7C15ULL;
  h ^= h >> 29;
  return double(h >> 11) * 0x1p-53;
}

// Value noise: the lattice values interpolated with a smooth step, in [0, 1).
double noise(double x, double y, double z, std::uint64_t seed)
{
  const double fx = std::floor(x), fy = std::floor(y), fz = std::floor(z);
  const int ix = int(fx), iy = int(fy), iz = int(fz);
  auto smooth = [](double t) { return t * t * (3 - 2 * t); };
  const double u = smooth(x - fx), v = smooth(y - fy), w = smooth(z - fz);
  double sum = 0;
  for (int c = 0; c < 8; ++c) {
    const int dx = c & 1, dy = (c >> 1) & 1, dz = (c >> 2) & 1;
    sum += lattice(ix + dx, iy + dy, iz + dz, seed) * (dx ? u : 1 - u) * (dy ? v : 1 - v) * (dz ? w : 1 - w);
  }
  return sum;
}

} // namespace

// A number from the command line, or nothing when `text` is not one entirely.
bool parseNumber(const char* text, double& value)
{
  char* end = nullptr;
  value = std::strtod(text, &end);
  return end != text && *end == 0 && std::isfinite(value);
}

// A whole number in [lo, hi], all of `text`.
bool parseWhole(const char* text, long long lo, long long hi, long long& value)
{
  char* end = nullptr;
  value = std::strtoll(text, &end, 10);
  return end != text && *end == 0 && value >= lo && value <= hi;
}

int main(int argc, char** argv)
{
  const char* usageText = "usage: gen_density OUT.json [N (8..256, default 48)] [SEED (default 1)] [--threshold T "
                          "(0..1, default 0.12)] [--power P (0.25..8, default 1)]\n";
  auto usage = [usageText] {
    std::fputs(usageText, stderr);
    return 2;
  };
  std::vector<const char*> positional;
  double threshold = 0.12, power = 1;
  bool shaped = false; // --threshold or --power given: normalise to a densest value of 1
  for (int i = 1; i < argc; ++i) {
    if (std::strcmp(argv[i], "--help") == 0 || std::strcmp(argv[i], "-h") == 0) {
      std::fputs(usageText, stdout);
      return 0;
    }
    const bool isThreshold = std::strcmp(argv[i], "--threshold") == 0, isPower = std::strcmp(argv[i], "--power") == 0;
    if (argv[i][0] == '-' && !isThreshold && !isPower) { // (not an output file named like an option)
      std::fprintf(stderr, "gen_density: unknown option %s\n", argv[i]);
      return usage();
    }
    if (!isThreshold && !isPower) {
      positional.push_back(argv[i]);
      continue;
    }
    double v = 0;
    if (i + 1 >= argc || !parseNumber(argv[i + 1], v)) {
      std::fprintf(stderr, "gen_density: %s needs a number\n", argv[i]);
      return usage();
    }
    if (isThreshold && !(v >= 0 && v < 1)) {
      std::fprintf(stderr, "gen_density: --threshold must lie in [0, 1), got %s\n", argv[i + 1]);
      return 2;
    }
    if (isPower && !(v >= 0.25 && v <= 8)) {
      std::fprintf(stderr, "gen_density: --power must lie in [0.25, 8], got %s\n", argv[i + 1]);
      return 2;
    }
    (isThreshold ? threshold : power) = v;
    shaped = true;
    ++i;
  }
  if (positional.empty() || positional.size() > 3)
    return usage();
  long long n = 48, seedValue = 1;
  if (positional.size() > 1 && !parseWhole(positional[1], 8, 256, n)) {
    std::fprintf(stderr, "gen_density: N must be a whole number in [8, 256], got %s\n", positional[1]);
    return 2;
  }
  if (positional.size() > 2 && !parseWhole(positional[2], 0, 1LL << 62, seedValue)) {
    std::fprintf(stderr, "gen_density: SEED must be a whole number in [0, 2^62], got %s\n", positional[2]);
    return 2;
  }
  const std::uint64_t seed = std::uint64_t(seedValue);
  const int nx = int(n), ny = int(n) / 2, nz = int(n);
  std::vector<double> d;
  d.reserve(std::size_t(nx) * std::size_t(ny) * std::size_t(nz));
  for (int k = 0; k < nz; ++k)
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i) {
        // The cell's centre in the box [-1, 1] × [-0.5, 0.5] × [-1, 1].
        const double x = -1 + 2 * (i + 0.5) / nx, y = -0.5 + (j + 0.5) / ny, z = -1 + 2 * (k + 0.5) / nz;
        double fbm = 0, amplitude = 0.5, frequency = 3;
        for (int octave = 0; octave < 5; ++octave) {
          fbm += amplitude * noise(x * frequency, y * frequency, z * frequency, seed + std::uint64_t(octave));
          amplitude *= 0.5;
          frequency *= 2;
        }
        // A soft ellipsoid, flatter at the bottom, as a cumulus: 1 at its centre, 0 at its edge.
        const double r2 = x * x / 0.7 + (y + 0.1) * (y + 0.1) / 0.16 + z * z / 0.7;
        const double shape = std::max(0.0, 1 - r2);
        d.push_back(shaped ? std::max(0.0, fbm * shape - threshold) : std::max(0.0, 2.2 * (fbm * shape - 0.12)));
      }
  if (shaped) {
    const double most = *std::max_element(d.begin(), d.end());
    if (!(most > 0)) {
      std::fprintf(stderr, "gen_density: --threshold %g leaves no cloud at all\n", threshold);
      return 1;
    }
    for (double& v : d)
      v = std::pow(v / most, power);
  }
  const char* path = positional[0];
  std::FILE* out = std::fopen(path, "wb");
  if (!out) {
    std::perror(path);
    return 1;
  }
  std::fprintf(out, "{\"resolution\": [%d, %d, %d], \"bounds\": [[-1, -0.5, -1], [1, 0.5, 1]],\n \"density\": [", nx, ny,
               nz);
  for (std::size_t i = 0; i < d.size(); ++i)
    std::fprintf(out, "%s%s%.4g", i ? "," : "", i % 24 == 0 ? "\n" : "", d[i]);
  std::fprintf(out, "\n]}\n");
  const bool failed = std::ferror(out) != 0; // (asked before fclose, which closes the file either way)
  if (std::fclose(out) != 0 || failed) {
    std::perror(path);
    std::error_code ignored; // (a half-written file goes; a device or a pipe named as the output stays)
    if (std::filesystem::is_regular_file(path, ignored))
      std::remove(path);
    return 1;
  }
  return 0;
}

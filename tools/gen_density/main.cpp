// gen_density OUT.json [N] [SEED]: a procedural cloud for chapter 15's heterogeneous media, as a density file.
//
// The cloud is fractal (fBm) value noise, five octaves, shaped by a soft ellipsoid so that it thins out towards its
// edge and leaves most of its box empty (which is where a grid of majorants beats one global maximum). The file is
// the format docs/scene-format.md describes: {"resolution": [N, N/2, N], "bounds": [[-1, -0.5, -1], [1, 0.5, 1]],
// "density": [...]}, x fastest, then y, then z; values ≥ 0, the densest about 1 (a medium's sigma_a and sigma_s
// scale it). The same N and SEED write the same file, byte for byte.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
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

int main(int argc, char** argv)
{
  if (argc < 2 || argc > 4) {
    std::fprintf(stderr, "usage: gen_density OUT.json [N (8..256, default 48)] [SEED (default 1)]\n");
    return 2;
  }
  const int n = argc > 2 ? std::atoi(argv[2]) : 48;
  const std::uint64_t seed = argc > 3 ? std::strtoull(argv[3], nullptr, 10) : 1;
  if (n < 8 || n > 256) {
    std::fprintf(stderr, "gen_density: N must lie in [8, 256], got %s\n", argv[2]);
    return 2;
  }
  const int nx = n, ny = n / 2, nz = n;
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
        d.push_back(std::max(0.0, 2.2 * (fbm * shape - 0.12)));
      }
  std::FILE* out = std::fopen(argv[1], "wb");
  if (!out) {
    std::perror(argv[1]);
    return 1;
  }
  std::fprintf(out, "{\"resolution\": [%d, %d, %d], \"bounds\": [[-1, -0.5, -1], [1, 0.5, 1]],\n \"density\": [", nx, ny,
               nz);
  for (std::size_t i = 0; i < d.size(); ++i)
    std::fprintf(out, "%s%s%.4g", i ? "," : "", i % 24 == 0 ? "\n" : "", d[i]);
  std::fprintf(out, "\n]}\n");
  if (std::fclose(out) != 0) {
    std::perror(argv[1]);
    return 1;
  }
  return 0;
}

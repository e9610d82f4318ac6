// gen_mesh: writes a closed triangle mesh of about N triangles as a binary PLY file, for chapter 10's scaling runs
// and mesh_bench: a sphere tessellated by latitude and longitude, its radius displaced by a sum of smooth waves, so
// that it is bumpy at every scale like a scanned model (an asteroid, roughly), not a smooth ball. The same N and SEED
// give the same file; N = 1,000 and N = 1,000,000 are the same shape at two resolutions.
//
// usage: gen_mesh N SEED OUT.ply        (N from 8 to 100,000,000 triangles; about N are written)
#include "core/rng.h"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <numbers>
#include <string>
#include <vector>

using namespace raylife;

namespace {

bool parseCount(const char* text, long long lo, long long hi, long long& out)
{
  char* end = nullptr;
  out = std::strtoll(text, &end, 10);
  return *text && *end == '\0' && out >= lo && out <= hi;
}

// A smooth wave over the unit sphere: a direction k, a frequency and a phase.
struct Wave {
  double kx, ky, kz, amplitude, phase;
};

} // namespace

int main(int argc, char** argv)
{
  const char* usage = "usage: gen_mesh N SEED OUT.ply   (N triangles, 8 to 100000000; SEED a whole number >= 0)\n";
  if (argc == 2 && (std::strcmp(argv[1], "--help") == 0 || std::strcmp(argv[1], "-h") == 0)) {
    std::fputs(usage, stdout);
    return 0;
  }
  long long n = 0, seed = 0;
  if (argc != 4 || !parseCount(argv[1], 8, 100000000, n) || !parseCount(argv[2], 0, (1LL << 62), seed)) {
    std::fputs(usage, stderr);
    return 2;
  }
  // rings × segments cells, segments = 2·rings: 2·segments·(rings − 1) ≈ 4·rings² triangles.
  const int rings = std::max(2, int(std::lround(std::sqrt(double(n) / 4))));
  const int segments = 2 * rings;

  Pcg32 rng(std::uint64_t(seed), 0x6a09e667f3bcc909ULL);
  auto uniform = [&rng] { return double(rng.nextUint()) * 0x1p-32; };
  // Waves of frequencies 2 to 64 over the sphere, amplitudes falling as 1/frequency: bumps at every scale.
  std::vector<Wave> waves;
  for (int octave = 1; octave <= 5; ++octave)
    for (int k = 0; k < 6; ++k) {
      const double z = 2 * uniform() - 1, phi = 2 * std::numbers::pi * uniform(), s = std::sqrt(1 - z * z);
      const double frequency = std::pow(2.0, octave) * (1 + uniform());
      waves.push_back(Wave{frequency * s * std::cos(phi), frequency * s * std::sin(phi), frequency * z,
                           0.12 / std::pow(2.0, octave), 2 * std::numbers::pi * uniform()});
    }
  auto radius = [&waves](double x, double y, double z) {
    double r = 1;
    for (const Wave& w : waves)
      r += w.amplitude * std::sin(w.kx * x + w.ky * y + w.kz * z + w.phase);
    return r;
  };

  std::vector<float> vertices;
  auto add = [&](double theta, double phi) {
    const double x = std::sin(theta) * std::cos(phi), y = std::cos(theta), z = -std::sin(theta) * std::sin(phi);
    const double r = radius(x, y, z);
    vertices.insert(vertices.end(), {float(r * x), float(r * y), float(r * z)});
  };
  add(0, 0); // north pole
  for (int i = 1; i < rings; ++i)
    for (int j = 0; j < segments; ++j)
      add(std::numbers::pi * i / rings, 2 * std::numbers::pi * j / segments);
  add(std::numbers::pi, 0); // south pole
  const auto south = std::int32_t(vertices.size() / 3 - 1);
  auto at = [segments](int i, int j) { return std::int32_t(1 + (i - 1) * segments + (j % segments)); };
  std::vector<std::int32_t> faces; // counter-clockwise seen from outside
  for (int j = 0; j < segments; ++j) {
    faces.insert(faces.end(), {0, at(1, j), at(1, j + 1)});
    faces.insert(faces.end(), {south, at(rings - 1, j + 1), at(rings - 1, j)});
  }
  for (int i = 1; i + 1 < rings; ++i)
    for (int j = 0; j < segments; ++j) {
      faces.insert(faces.end(), {at(i, j), at(i + 1, j), at(i + 1, j + 1)});
      faces.insert(faces.end(), {at(i, j), at(i + 1, j + 1), at(i, j + 1)});
    }

  // Binary PLY, little-endian (the machines raylife runs on): float positions, faces as lists of three ints.
  FILE* out = std::fopen(argv[3], "wb");
  if (!out) {
    std::fprintf(stderr, "gen_mesh: cannot write %s: %s\n", argv[3], std::strerror(errno));
    return 1;
  }
  const std::size_t faceCount = faces.size() / 3;
  std::fprintf(out,
               "ply\nformat binary_little_endian 1.0\ncomment raylife gen_mesh %lld %lld\nelement vertex %zu\n"
               "property float x\nproperty float y\nproperty float z\nelement face %zu\n"
               "property list uchar int vertex_indices\nend_header\n",
               n, seed, vertices.size() / 3, faceCount);
  bool ok = std::fwrite(vertices.data(), sizeof(float), vertices.size(), out) == vertices.size();
  for (std::size_t f = 0; f < faceCount && ok; ++f) {
    const unsigned char three = 3;
    ok = std::fwrite(&three, 1, 1, out) == 1 && std::fwrite(&faces[3 * f], sizeof(std::int32_t), 3, out) == 3;
  }
  ok = std::fclose(out) == 0 && ok;
  if (!ok) {
    std::fprintf(stderr, "gen_mesh: writing %s failed\n", argv[3]);
    std::error_code ignored; // (a half-written file goes; a device or a pipe named as the output stays)
    if (std::filesystem::is_regular_file(argv[3], ignored))
      std::remove(argv[3]);
    return 1;
  }
  std::fprintf(stderr, "gen_mesh: %zu triangles, %zu vertices -> %s\n", faceCount, vertices.size() / 3, argv[3]);
  return 0;
}

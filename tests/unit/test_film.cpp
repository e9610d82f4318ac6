// The film's exact sums (film.h) and the shares of a render's samples (render_loop.h, SampleShare): any
// partition of the sample indices, rendered apart and merged in any order, gives the one-process film bit for bit
// (issue 24, docs/beyond-one-machine.md).
#include "render/film_file.h"
#include "render/render_loop.h"
#include "core/rng.h"
#include "small_scene.h"
#include "../sanitizers.h"

#include <catch2/catch.hpp>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <csignal>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <thread>

#include <fcntl.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

using namespace raylife;
using raylife::test::smallScene;

namespace {

// Samples of many magnitudes and full mantissas: sums of them in floating point depend on their order.
Color wideTrace(const Scene& scene, const Ray& ray, Sampler& sampler, int)
{
  const Real u = sampler.next1D(), v = sampler.next1D();
  const Real hit = scene.intersect(ray) ? 1 : 0;
  return Color(u * Real(1000) * v * v * v, hit * std::exp(Real(-20) * v), Real(1) / (Real(1) + u * Real(3)));
}

bool sameSums(const Film& a, const Film& b)
{
  return a.counts() == b.counts() &&
         std::memcmp(a.sums().data(), b.sums().data(), a.sums().size() * sizeof(Film::Sums)) == 0;
}

RenderSettings settingsFor(int spp)
{
  RenderSettings s;
  s.spp = spp;
  s.seed = 7;
  s.pixelSampling = PixelSampling::Jittered;
  s.threads = 2;
  return s;
}

} // namespace

TEST_CASE("toFixed is exact above its last fraction bit and rounds to nearest even below it")
{
  CHECK(toFixed(0.0, 64) == Fixed128{0, 0});
  CHECK(toFixed(1.0, 64) == Fixed128{0, 1});
  CHECK(toFixed(0.5, 64) == Fixed128{std::uint64_t(1) << 63, 0});
  CHECK(toFixed(3.0, 40) == Fixed128{std::uint64_t(3) << 40, 0});
  CHECK(toFixed(std::ldexp(1.0, -64), 64) == Fixed128{1, 0});
  // Half a step rounds to even (0), three halves to 2; a quarter to 0.
  CHECK(toFixed(std::ldexp(1.0, -65), 64) == Fixed128{0, 0});
  CHECK(toFixed(std::ldexp(3.0, -65), 64) == Fixed128{2, 0});
  CHECK(toFixed(std::ldexp(1.0, -66), 64) == Fixed128{0, 0});
  CHECK(toFixed(std::ldexp(5.0, -66), 64) == Fixed128{1, 0}); // 1.25 steps
  CHECK(toFixed(std::numeric_limits<double>::denorm_min(), 64) == Fixed128{0, 0});
  // Round trips for values of every magnitude a film holds.
  for (const double v : {0.001, 0.1, 0.75, 1.0 / 3.0, 12.0, 1e6, 4294967295.0})
    CHECK(toDouble(toFixed(v, kFilmSumFractionBits), kFilmSumFractionBits) == v);
  // The carry of Fixed128's addition.
  Fixed128 a{~std::uint64_t(0), 5};
  a += Fixed128{1, 2};
  CHECK(a == Fixed128{0, 8});
}

TEST_CASE("toDouble scales by a product what two calls to ldexp scaled, to the same bits")
{
  // hi·2^64 + lo is 0 or at least 1, so the product by 2^-F (F ≤ 1022) is exact, as ldexp is.
  std::mt19937_64 rng(5);
  int differ = 0;
  for (int i = 0; i < 100000; ++i) {
    // Words of every width, zero included, and every fraction the film uses or a merge might.
    const std::uint64_t loBits = rng(), loShift = rng() % 64, hiBits = rng(), hiShift = rng() % 64;
    const std::uint64_t lo = i % 11 == 0 ? 0 : loBits >> loShift;
    const std::uint64_t hi = i % 3 == 0 ? 0 : hiBits >> hiShift;
    const int f = std::array{0, 1, 40, 64, 100, 1000, 1022}[std::size_t(i) % 7];
    const Fixed128 x{lo, hi};
    const double byLdexp = std::ldexp(std::ldexp(double(hi), 64) + double(lo), -f);
    if (std::bit_cast<std::uint64_t>(toDouble(x, f)) != std::bit_cast<std::uint64_t>(byLdexp) && ++differ <= 5)
      FAIL_CHECK("toDouble({" << lo << ", " << hi << "}, " << f << ") = " << toDouble(x, f) << ", by ldexp "
                              << byLdexp);
  }
  CHECK(differ == 0);
}

TEST_CASE("the film holds samples below 2^32 only and the render loop counts larger ones as bad")
{
  // (The largest Real below 2^32: 2^32 − 2^−20 in double, 2^32 − 256 in float, where 2^32 − 1 rounds to 2^32.)
  CHECK(Film::holds(Color(0, 1, std::nextafter(Real(4294967296.0), Real(0)))));
  CHECK_FALSE(Film::holds(Color(0, Real(4294967296.0), 0)));
  CHECK_FALSE(Film::holds(Color(std::numeric_limits<Real>::quiet_NaN(), 0, 0)));
  CHECK_FALSE(Film::holds(Color(0, 0, Real(-1e-30))));
  const Scene scene = smallScene();
  RenderSettings settings = settingsFor(2);
  const RenderResult r = render(scene, scene.makeCamera(), settings,
                                [](const Scene&, const Ray&, Sampler&, int) { return Color(Real(1e10), 1, 1); });
  CHECK(r.badSamples == 2u * 37u * 23u);
  CHECK(r.film.mean().at(3, 4, 1) == 0.0f);
}

TEST_CASE("any partition of the sample indices merged in any order gives the one-process film bit for bit")
{
  const Scene scene = smallScene();
  const Camera camera = scene.makeCamera();
  const int spp = 40;
  const RenderResult whole = render(scene, camera, settingsFor(spp), wideTrace);
  REQUIRE(whole.samples == std::vector<SampleRange>{{0, spp}});

  // Cut [0, spp) at random points, render each range on its own (1 or 2 threads), merge in a shuffled order.
  std::mt19937 random(3);
  for (int trial = 0; trial < 4; ++trial) {
    std::vector<int> cuts = {0, spp};
    for (int i = 0; i < 1 + trial * 2; ++i)
      cuts.push_back(int(random() % std::uint32_t(spp)));
    std::sort(cuts.begin(), cuts.end());
    cuts.erase(std::unique(cuts.begin(), cuts.end()), cuts.end());
    std::vector<RenderResult> parts;
    for (std::size_t i = 0; i + 1 < cuts.size(); ++i) {
      RenderSettings settings = settingsFor(spp);
      settings.threads = 1 + int(i % 2);
      settings.share.range = SampleRange{cuts[i], cuts[i + 1] - cuts[i]};
      parts.push_back(render(scene, camera, settings, wideTrace));
      CHECK(parts.back().spp == cuts[i + 1] - cuts[i]);
    }
    std::shuffle(parts.begin(), parts.end(), random);
    Film merged(camera.width(), camera.height());
    for (const RenderResult& part : parts)
      merged.merge(part.film);
    INFO("cuts: " << cuts.size() - 1 << " ranges");
    CHECK(sameSums(merged, whole.film));
    CHECK(merged.mean().pixels == whole.film.mean().pixels);
    CHECK(merged.varianceOfMean().pixels == whole.film.varianceOfMean().pixels);
  }
}

TEST_CASE("a time budget shared by ranks takes blocks of 16 sample indices in turn")
{
  SampleShare share;
  share.rank = 1;
  share.ranks = 3;
  CHECK(share.index(0) == 16);
  CHECK(share.index(15) == 31);
  CHECK(share.index(16) == 64);
  CHECK(share.ranges(20) == std::vector<SampleRange>{{16, 16}, {64, 4}});
  share.rank = 0;
  share.ranks = 1;
  CHECK(share.ranges(40) == std::vector<SampleRange>{{0, 40}});
  SampleShare range;
  range.range = SampleRange{5, 10};
  CHECK(range.index(3) == 8);
  CHECK(range.ranges(7) == std::vector<SampleRange>{{5, 7}});

  // Three ranks' blocks together are the one-process render's first samples, exactly.
  const Scene scene = smallScene();
  const Camera camera = scene.makeCamera();
  RenderSettings settings;
  settings.seed = 9;
  settings.pixelSampling = PixelSampling::Jittered;
  settings.spp = 48;
  // Each rank's blocks of a time budget, rendered as ranges of the fixed-spp render, cover it once.
  const RenderResult whole = render(scene, camera, settings, wideTrace);
  Film merged(camera.width(), camera.height());
  for (int r = 0; r < 3; ++r) {
    SampleShare blocks;
    blocks.rank = r;
    blocks.ranks = 3;
    for (const SampleRange& run : blocks.ranges(16)) {
      RenderSettings part = settings;
      part.share.range = run;
      merged.merge(render(scene, camera, part, wideTrace).film);
    }
  }
  CHECK(sameSums(merged, whole.film));
}

TEST_CASE("adaptive sampling refuses a share of the samples")
{
  const Scene scene = smallScene();
  RenderSettings settings = settingsFor(32);
  settings.adaptive = 0.1;
  settings.share.range = SampleRange{0, 16};
  CHECK_THROWS_AS(render(scene, scene.makeCamera(), settings, wideTrace), std::invalid_argument);
  settings.share.range = SampleRange{20, 16}; // past spp, even without adaptive sampling
  settings.adaptive.reset();
  CHECK_THROWS_AS(render(scene, scene.makeCamera(), settings, wideTrace), std::invalid_argument);
}

TEST_CASE("a partial film survives its file bit for bit and a damaged file is refused with its fault")
{
  const Scene scene = smallScene();
  RenderSettings settings = settingsFor(12);
  settings.share.range = SampleRange{4, 5};
  const RenderResult r = render(scene, scene.makeCamera(), settings, wideTrace);
  PartialFilm film{{}, r.film};
  film.header.chapter = "step06_path_tracer";
  film.header.scene = "my scene.json";
  film.header.sceneHash = hashBytes("{ }");
  film.header.width = r.film.width();
  film.header.height = r.film.height();
  film.header.spp = 12;
  film.header.seed = 7;
  film.header.samples = r.samples;
  film.header.rays = r.rays;
  film.header.seconds = 0.125;
  const std::vector<unsigned char> bytes = encodeFilm(film);

  const std::filesystem::path path = std::filesystem::temp_directory_path() / "raylife_test_film.film";
  auto write = [&](const std::string& text) {
    std::ofstream(path, std::ios::binary) << text;
  };
  const std::string good(bytes.begin(), bytes.end());
  write(good);
  const PartialFilm back = readFilm(path.string());
  CHECK(back.header.renderKey() == film.header.renderKey());
  CHECK(back.header.scene == "my scene.json");
  CHECK(back.header.samples == std::vector<SampleRange>{{4, 5}});
  CHECK(back.header.rays == r.rays);
  CHECK(back.header.seconds == 0.125);
  CHECK(sameSums(back.film, r.film));

  auto refused = [&](const std::string& text, const std::string& fault) {
    write(text);
    try {
      readFilm(path.string());
      FAIL("accepted a film with " << fault);
    } catch (const FilmError& e) {
      CHECK_THAT(e.what(), Catch::Contains(fault));
    }
  };
  auto replaced = [&](const std::string& from, const std::string& to) {
    std::string text = good;
    REQUIRE(text.find(from) != std::string::npos);
    return text.replace(text.find(from), from.size(), to);
  };
  refused(good.substr(0, good.size() - 1), "(truncated)");
  refused(good + "x", "bytes");
  refused("P6\n", "not a raylife film");
  refused(replaced("seed 7\n", "sead 7\n"), "line 8: unknown key 'sead'");
  refused(replaced("seed 7\n", ""), "no 'seed' line");
  refused(replaced("samples 4:5\n", "samples 4:5 9:1\n"), "must be in order, apart");
  refused(replaced("samples 4:5\n", "samples 4:5 20:1\n"), "beyond the render's 12");
  refused(replaced("layers pixel\n", "layers pixel splat\n"), "reads only \"pixel\"");
  refused(replaced("width 37\n", "width 38\n"), "but a 38x23 film has");
  std::filesystem::remove(path);
}

TEST_CASE("a film is read a block at a time, from a file or a pipe, and a big file that is no film is refused at once")
{
  // A film of 211 × 97 pixels: its pixel data (2 MB) spans the header's first read and many blocks.
  std::mt19937_64 random(11);
  const int width = 211, height = 97;
  std::vector<Film::Sums> sums(std::size_t(width) * height);
  std::vector<std::uint32_t> counts(sums.size());
  for (std::size_t i = 0; i < sums.size(); ++i) {
    for (Fixed128* words : {sums[i].sum, sums[i].squares})
      for (int c = 0; c < 3; ++c)
        words[c] = Fixed128{random(), random()};
    counts[i] = std::uint32_t(random() % 1000);
  }
  PartialFilm film{{}, Film(width, height, sums, counts)};
  film.header.chapter = "step06_path_tracer";
  film.header.width = width;
  film.header.height = height;
  film.header.spp = 4;
  film.header.samples = {{0, 4}};
  const std::vector<unsigned char> bytes = encodeFilm(film);
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("raylife_test_film_blocks_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const std::string file = (dir / "big.film").string();
  std::ofstream(file, std::ios::binary)
      .write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
  CHECK(sameSums(readFilm(file).film, film.film));

  // Through a pipe (no size to ask for): read to its end.
  const std::string fifo = (dir / "pipe.film").string();
  REQUIRE(::mkfifo(fifo.c_str(), 0600) == 0);
  std::thread writer([&] {
    std::ofstream(fifo, std::ios::binary).write(reinterpret_cast<const char*>(bytes.data()),
                                                std::streamsize(bytes.size()));
  });
  const PartialFilm piped = readFilm(fifo);
  writer.join();
  CHECK(sameSums(piped.film, film.film));

  // Two inputs that no film reader should hold in memory, read by a process that may not take 256 MiB more (read
  // whole, both ran out): a 4 GiB file of zeros (sparse: it takes no disk), refused from its first line; and a pipe
  // whose film header is followed by bytes without end, refused a byte after the header's length. Not under
  // AddressSanitizer, whose shadow memory needs more address space than any such limit leaves.
  if (raylife::testing::kUnderAddressSanitizer) {
    std::filesystem::remove_all(dir);
    return;
  }
  const std::string zeros = (dir / "zeros.film").string();
  std::ofstream{zeros}.close();
  std::filesystem::resize_file(zeros, std::uintmax_t(4) << 30);
  const std::string endless = (dir / "endless.film").string();
  REQUIRE(::mkfifo(endless.c_str(), 0600) == 0);
  const pid_t child = ::fork();
  REQUIRE(child >= 0);
  if (child == 0) {
    rlimit limit{};
    std::size_t addressPages = 0;
    std::ifstream("/proc/self/statm") >> addressPages; // (its first number: the address space, in pages)
    limit.rlim_cur = limit.rlim_max = rlim_t(addressPages) * rlim_t(::sysconf(_SC_PAGESIZE)) + (rlim_t(256) << 20);
    ::setrlimit(RLIMIT_AS, &limit);
    // The endless pipe's writer: the film, then zeros until the reader hangs up (SIGPIPE ends it).
    const pid_t feeder = ::fork();
    if (feeder == 0) {
      const int fd = ::open(endless.c_str(), O_WRONLY);
      const std::vector<char> more(1 << 16, 0);
      bool open = fd >= 0 && ::write(fd, bytes.data(), bytes.size()) == ssize_t(bytes.size());
      while (open)
        open = ::write(fd, more.data(), more.size()) > 0;
      ::_exit(0);
    }
    auto refused = [](const std::string& path, const std::string& fault) {
      try {
        readFilm(path);
      } catch (const FilmError& e) {
        return std::string(e.what()).find(fault) != std::string::npos ? 0 : 2;
      } catch (...) {
        return 3;
      }
      return 1;
    };
    int code = refused(zeros, "not a raylife film");
    if (code == 0) {
      const int second = refused(endless, "the pixel data is longer than the");
      code = second == 0 ? 0 : 10 + second;
    }
    ::kill(feeder, SIGKILL); // (already ended by SIGPIPE, unless the first check failed and it waits for a reader)
    ::waitpid(feeder, nullptr, 0);
    ::_exit(code);
  }
  int status = 0;
  REQUIRE(::waitpid(child, &status, 0) == child);
  CHECK(WIFEXITED(status));
  CHECK(WEXITSTATUS(status) == 0);
  std::filesystem::remove_all(dir);
}

TEST_CASE("merging films checks that they are shares of one render and that no sample comes twice")
{
  Film film(2, 1);
  film.add(0, 0, Color(1, 2, 3));
  PartialFilm a{{}, film};
  a.header.chapter = "step06_path_tracer";
  a.header.width = 2;
  a.header.height = 1;
  a.header.spp = 10;
  a.header.samples = {{0, 4}};
  PartialFilm b = a;
  b.header.samples = {{4, 6}};
  PartialFilm total = a;
  mergeFilm(total, "a.film", b, "b.film");
  CHECK(total.header.samples == std::vector<SampleRange>{{0, 10}});
  CHECK(total.film.samples(0, 0) == 2u);
  CHECK(firstGap(total.header.samples, 10).count == 0);
  CHECK(firstGap({{0, 3}, {5, 5}}, 10) == SampleRange{3, 2});
  CHECK(firstGap({{0, 3}}, 10) == SampleRange{3, 7});

  PartialFilm overlap = a;
  overlap.header.samples = {{2, 3}};
  CHECK_THROWS_WITH(mergeFilm(total, "a.film", overlap, "c.film"), Catch::Contains("both hold samples 2..4"));
  PartialFilm otherSeed = b;
  otherSeed.header.seed = 1;
  PartialFilm fresh = a;
  CHECK_THROWS_WITH(mergeFilm(fresh, "a.film", otherSeed, "d.film"),
                    Catch::Contains("d.film is a share of another render than a.film: its seed is 1, not 0"));
  PartialFilm otherScene = b;
  otherScene.header.sceneHash = 1;
  CHECK_THROWS_WITH(mergeFilm(fresh, "a.film", otherScene, "e.film"), Catch::Contains("scene file"));
}

TEST_CASE("a scene's fingerprint: hashFile is hashBytes of the file across its blocks, and FNV-1a gives its own values")
{
  // FNV-1a's published 64-bit values: of nothing, the offset basis; of "a", 0xaf63dc4c8601ec8c.
  CHECK(hashBytes("") == 0xcbf29ce484222325ull);
  CHECK(hashBytes("a") == 0xaf63dc4c8601ec8cull);
  // hashFile reads a block of 64 KiB at a time: files shorter than a block, exactly one, and over three.
  const std::filesystem::path path =
      std::filesystem::temp_directory_path() / ("raylife_test_hash_file_" + std::to_string(::getpid()) + ".json");
  std::mt19937 random(5);
  for (const std::size_t size : {std::size_t(0), std::size_t(1), std::size_t(65535), std::size_t(65536),
                                 std::size_t(65537), std::size_t(200001)}) {
    std::string text(size, ' ');
    for (char& c : text)
      c = char(random() & 0xff);
    std::ofstream(path, std::ios::binary) << text;
    INFO(size << " bytes");
    CHECK(hashFile(path.string()) == hashBytes(text));
  }
  std::filesystem::remove(path);
  CHECK_THROWS_AS(hashFile(path.string()), FilmError);
}

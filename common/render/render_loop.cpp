#include "render/render_loop.h"

#include "core/threads.h"

#include <omp.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <stdexcept>

namespace raylife {

namespace {

using Clock = std::chrono::steady_clock;

constexpr int kTileSize = 16;
// A batch of samples is cut to about this long, so that Ctrl-C and a time budget are answered within it.
constexpr double kBatchSeconds = 0.25;

struct Tile {
  int x0, y0, x1, y1;
};

std::vector<Tile> makeTiles(int width, int height, int tileSize)
{
  std::vector<Tile> tiles;
  for (int y = 0; y < height; y += tileSize)
    for (int x = 0; x < width; x += tileSize)
      tiles.push_back({x, y, std::min(x + tileSize, width), std::min(y + tileSize, height)});
  return tiles;
}

// The side of the grid of strata the pixel's samples are spread over: √spp rounded down; 0 when the sample count
// is not known in advance (--time, adaptive sampling), for which the pixel's sequence stratifies instead.
int strataPerSide(std::optional<int> spp) { return spp ? int(std::sqrt(double(*spp))) : 0; }

// The sample count at which adaptive sampling looks at the pixels again, after looking at `done`: a quarter more
// (in steps of kAdaptiveMinSamples), so that a pixel takes at most about 25 % more samples than it needed, and a
// long render has few checkpoints (each one a pass over the film and the end of a batch).
int adaptiveCheckpointAfter(int done)
{
  return done + std::max(kAdaptiveMinSamples, done / 4 / kAdaptiveMinSamples * kAdaptiveMinSamples);
}

} // namespace

PrimaryRays::PrimaryRays(const Camera& camera, const RenderSettings& settings)
    : camera_(camera), seed_(settings.seed), pixelSampling_(settings.pixelSampling),
      strata_(strataPerSide(settings.adaptive ? std::nullopt : settings.spp)), lens_(settings.lens),
      motion_(settings.motion)
{
}

namespace {

void drawProgress(double fraction, double elapsed)
{
  const int width = 40;
  const int filled = int(std::clamp(fraction, 0.0, 1.0) * width);
  std::fprintf(stderr, "\r[%.*s%*s] %3d%%  %.1f s ", filled, "########################################",
               width - filled, "", int(fraction * 100), elapsed);
  std::fflush(stderr);
}

} // namespace

std::vector<SampleRange> SampleShare::ranges(int taken) const
{
  std::vector<SampleRange> out;
  for (int i = 0; i < taken;) {
    // A run of consecutive indices: the rest of the range, or of the block.
    const int run = range ? taken - i : std::min(taken - i, kSampleBlock - i % kSampleBlock);
    const int first = index(i);
    if (!out.empty() && out.back().end() == first)
      out.back().count += run;
    else
      out.push_back({first, run});
    i += run;
  }
  return out;
}

SplatSums::SplatSums(int width, int height) : words_(std::size_t(width) * std::size_t(height) * 6) {}

void SplatSums::add(std::size_t pixel, const Color& L)
{
  if (!Film::holds(L)) {
    bad_.fetch_add(1, std::memory_order_relaxed);
    return;
  }
  for (std::size_t c = 0; c < 3; ++c) {
    const Fixed128 v = toFixed(double(L[int(c)]), kFilmSumFractionBits);
    if (v == Fixed128{})
      continue;
    std::atomic<std::uint64_t>& lo = words_[pixel * 6 + 2 * c];
    std::atomic<std::uint64_t>& hi = words_[pixel * 6 + 2 * c + 1];
    // The low word's carry is known from the value it had just before this add: exact in any interleaving.
    const std::uint64_t before = lo.fetch_add(v.lo, std::memory_order_relaxed);
    const std::uint64_t carry = before + v.lo < before ? 1 : 0;
    if (v.hi + carry)
      hi.fetch_add(v.hi + carry, std::memory_order_relaxed);
  }
}

Color SplatSums::take(std::size_t pixel)
{
  Color sum(0);
  for (std::size_t c = 0; c < 3; ++c) {
    const Fixed128 f{words_[pixel * 6 + 2 * c].exchange(0, std::memory_order_relaxed),
                     words_[pixel * 6 + 2 * c + 1].exchange(0, std::memory_order_relaxed)};
    if (!(f == Fixed128{}))
      sum[int(c)] = Real(toDouble(f, kFilmSumFractionBits));
  }
  return sum;
}

namespace {

// The render loop of the three kinds of estimator: `trace` (one sample, one pixel), `splatTrace` or `workers`
// (a wavefront estimator per thread: many samples at once, in pieces of at most `maxKeys`); one of them is set.
RenderResult renderLoop(const Scene& scene, const Camera& camera, const RenderSettings& settings,
                        const TraceFunction* trace, const SplatTraceFunction* splatTrace,
                        const WavefrontWorkers* workers = nullptr, std::size_t maxKeys = 1)
{
  const SampleShare& share = settings.share;
  if (splatTrace && settings.adaptive)
    throw std::invalid_argument("adaptive sampling cannot stop a pixel that other pixels' samples splat into");
  if (settings.adaptive && (share.range || share.ranks > 1))
    throw std::invalid_argument("adaptive sampling needs every sample of every pixel in one process");
  if (settings.beside && (splatTrace || workers || settings.adaptive))
    throw std::invalid_argument("an image beside the render needs every pixel to take every sample, one at a time");
  if (share.range && (!settings.spp || share.range->first < 0 || share.range->count < 0 ||
                      std::int64_t(share.range->first) + share.range->count > *settings.spp))
    throw std::invalid_argument("a range of samples needs a fixed spp that holds it");
  const int width = camera.width(), height = camera.height();
  RenderResult result{Film(settings.beside ? 2 * width : width, height)};
  const std::vector<Tile> allTiles = makeTiles(width, height, settings.tileSize > 0 ? settings.tileSize : kTileSize);
  std::vector<Tile> tiles = allTiles; // the work of a batch (adaptive sampling narrows it to the active pixels)
  const int threads = threadCount(settings.threads);
  // The samples to take here; with a time budget, until the time is spent, but at most this process's share of
  // the most a pixel may hold.
  const bool untilTime = !settings.spp && settings.seconds;
  const int target = untilTime ? int(kMaxSamplesPerPixel / std::uint32_t(std::max(1, share.ranks)))
                               : settings.spp ? (share.range ? share.range->count : *settings.spp) : 1;
  const PrimaryRays primary(camera, settings);
  // With splats: each pixel's own light in the pass under way, and the splats it has received in it.
  std::vector<Color> own(splatTrace ? std::size_t(width) * std::size_t(height) : 0);
  std::optional<SplatSums> splatSums;
  if (splatTrace)
    splatSums.emplace(width, height);

  const auto start = Clock::now();
  auto elapsed = [&] { return std::chrono::duration<double>(Clock::now() - start).count(); };
  double lastDraw = -1;
  double lastPreview = 0;

  // Samples are taken in batches: batch [s0, s1) gives every pixel this process's samples s0 .. s1 − 1 (its i-th
  // is sample share.index(i) of the render; the film's sums do not depend on the order they come in). A batch
  // is one OpenMP region, so a batch of many samples keeps the threads busy without a fork and join per sample
  // (which, on a loaded machine, costs more than the samples of a small image). Batches double in size, and are
  // cut to about kBatchSeconds (and to what is left of a time budget) so that a stop request is answered soon.
  int done = 0;
  // Adaptive sampling: which pixels still take samples (1) or have stopped (0), decided between batches.
  std::vector<unsigned char> active(std::size_t(width) * std::size_t(height), 1);
  std::size_t activeCount = active.size();
  std::uint64_t samplesTaken = 0;
  // A wavefront estimator per thread, made by the thread that uses it in the first batch and kept for the others
  // (with its queues: the memory is allocated once per render, not once per batch).
  std::vector<WavefrontFunction> wavefronts(workers ? std::size_t(threads) : 0);
  int nextCheckpoint = kAdaptiveMinSamples;
  while (done < target) {
    if (settings.adaptive && done == nextCheckpoint) {
      // A checkpoint: stop each pixel whose estimated relative error is below the threshold, and its eight
      // neighbours' too. (Alone, a pixel on an edge whose samples all happened to miss the object shows no
      // variance and would stop with its error; a neighbour that saw the edge keeps it going.)
      std::vector<unsigned char> below(active.size());
      for (int y = 0; y < height; ++y)
        for (int x = 0; x < width; ++x) {
          const double error = result.film.relativeError(x, y, kAdaptiveMeanFloor);
          // (+∞ at this count: every sample black; after kAdaptiveBlackSamples of them, taken as black.)
          const bool black = std::isinf(error) && result.film.samples(x, y) >= std::uint32_t(kAdaptiveBlackSamples);
          below[std::size_t(y) * std::size_t(width) + std::size_t(x)] = error < *settings.adaptive || black;
        }
      activeCount = 0;
      for (int y = 0; y < height; ++y)
        for (int x = 0; x < width; ++x) {
          unsigned char& a = active[std::size_t(y) * std::size_t(width) + std::size_t(x)];
          bool settled = true;
          for (int ny = std::max(0, y - 1); ny <= std::min(height - 1, y + 1); ++ny)
            for (int nx = std::max(0, x - 1); nx <= std::min(width - 1, x + 1); ++nx)
              settled = settled && below[std::size_t(ny) * std::size_t(width) + std::size_t(nx)];
          if (a && settled)
            a = 0;
          activeCount += a;
        }
      if (activeCount == 0)
        break;
      nextCheckpoint = adaptiveCheckpointAfter(done);
      // Hand out only the rows of tiles that still have active pixels, so that the threads share the work left
      // even when it gathers in a few tiles.
      tiles.clear();
      for (const Tile& t : allTiles)
        for (int y = t.y0; y < t.y1; ++y) {
          const auto row = active.begin() + std::ptrdiff_t(std::size_t(y) * std::size_t(width));
          if (std::find(row + t.x0, row + t.x1, 1) != row + t.x1)
            tiles.push_back({t.x0, y, t.x1, y + 1});
        }
    }
    if (done > 0 && settings.seconds && elapsed() >= *settings.seconds)
      break;
    if (done > 0 && settings.stop && settings.stop->load()) {
      result.interrupted = true;
      break;
    }
    int batch = std::max(1, done);
    if (done > 0) {
      const double perSample = elapsed() / done;
      double budget = kBatchSeconds;
      if (settings.seconds)
        budget = std::min(budget, *settings.seconds - elapsed());
      batch = std::clamp(int(budget / std::max(perSample, 1e-9)), 1, batch);
    }
    batch = std::min(batch, target - done);
    if (settings.adaptive) // end the batch at the next checkpoint
      batch = std::min(batch, nextCheckpoint - done);
    const int s0 = done, s1 = done + batch;

    std::uint64_t rays = 0, bad = 0, pixelSamples = 0;
    std::atomic<int> tilesDone{0};
    auto showProgress = [&](double samples) {
      const double now = elapsed();
      if (now - lastDraw > 0.1) {
        lastDraw = now;
        drawProgress(untilTime ? now / *settings.seconds : samples / target, now);
      }
    };
    if (splatTrace) {
      // Pass by pass: every pixel's sample s (its own light in `own`, its splats into `splatSums`), then each pixel
      // adds its own light and the splats it received as one sample. (A stop request is answered between passes:
      // a pass cut short would leave splats of half a pass in the film.)
#pragma omp parallel num_threads(threads) reduction(+ : rays, bad)
      {
        const std::uint64_t raysBefore = rayCount();
        Splats splats(camera, *splatSums);
        for (int i = s0; i < s1; ++i) {
          const int s = share.index(i);
#pragma omp for schedule(dynamic, 1)
          for (std::size_t t = 0; t < tiles.size(); ++t) {
            const Tile& tile = tiles[t];
            for (int y = tile.y0; y < tile.y1; ++y)
              for (int x = tile.x0; x < tile.x1; ++x) {
                const PixelSequence sequence(settings.seed, x, y);
                Sampler sampler(settings.seed, x, y, std::uint64_t(s));
                const Ray ray = primary.ray(x, y, s, sampler, sequence);
                own[std::size_t(y) * std::size_t(width) + std::size_t(x)] =
                    (*splatTrace)(scene, ray, sampler, settings.maxDepth, splats);
              }
          }
          // (The implicit barrier: every splat of the pass has landed.)
#pragma omp for schedule(static)
          for (int y = 0; y < height; ++y)
            for (int x = 0; x < width; ++x) {
              const std::size_t p = std::size_t(y) * std::size_t(width) + std::size_t(x);
              Color L = own[p];
              if (!Film::holds(L)) {
                ++bad;
                L = Color(0);
              }
              L += splatSums->take(p);
              if (!Film::holds(L)) {
                ++bad;
                L = Color(0);
              }
              result.film.add(x, y, L);
            }
          if (settings.progress && omp_get_thread_num() == 0)
            showProgress(double(i + 1));
        }
        rays += rayCount() - raysBefore;
      }
      bad += splatSums->takeBad();
      pixelSamples += std::uint64_t(s1 - s0) * std::uint64_t(width) * std::uint64_t(height);
      tilesDone = int(tiles.size());
    } else if (workers) {
      // The tile's batch as keys (pixel by pixel, its samples in order), handed to the wavefront in pieces.
#pragma omp parallel num_threads(threads) reduction(+ : rays, bad, pixelSamples)
      {
        const std::uint64_t raysBefore = rayCount();
        WavefrontFunction& wavefront = wavefronts[std::size_t(omp_get_thread_num())];
        if (!wavefront)
          wavefront = (*workers)();
        std::vector<PixelSampleKey> keys;
        std::vector<Color> radiance;
#pragma omp for schedule(dynamic, 1)
        for (std::size_t t = 0; t < tiles.size(); ++t) {
          if (settings.stop && settings.stop->load(std::memory_order_relaxed))
            continue;
          const Tile& tile = tiles[t];
          keys.clear();
          for (int y = tile.y0; y < tile.y1; ++y)
            for (int x = tile.x0; x < tile.x1; ++x)
              if (active[std::size_t(y) * std::size_t(width) + std::size_t(x)])
                for (int i = s0; i < s1; ++i)
                  keys.push_back(PixelSampleKey{x, y, share.index(i)});
          radiance.assign(keys.size(), Color(0));
          for (std::size_t first = 0; first < keys.size(); first += maxKeys) {
            const std::size_t count = std::min(maxKeys, keys.size() - first);
            wavefront(scene, primary, std::span<const PixelSampleKey>(keys).subspan(first, count),
                         settings.maxDepth, std::span<Color>(radiance).subspan(first, count));
          }
          for (std::size_t k = 0; k < keys.size(); ++k) {
            Color L = radiance[k];
            if (!Film::holds(L)) { // guarded as a TraceFunction's sample is
              ++bad;
              L = Color(0);
            }
            result.film.add(keys[k].x, keys[k].y, L);
          }
          pixelSamples += keys.size();
          const int tilesFinished = ++tilesDone;
          if (settings.progress && omp_get_thread_num() == 0)
            showProgress(s0 + double(batch) * tilesFinished / double(tiles.size()));
        }
        rays += rayCount() - raysBefore;
      }
    } else {
#pragma omp parallel num_threads(threads) reduction(+ : rays, bad, pixelSamples)
      {
        const std::uint64_t raysBefore = rayCount();
#pragma omp for schedule(dynamic, 1)
        for (std::size_t t = 0; t < tiles.size(); ++t) {
          // A stop request is answered between tiles: a pass of a large image may take long.
          if (settings.stop && settings.stop->load(std::memory_order_relaxed))
            continue;
          const Tile& tile = tiles[t];
          // [pixel_loop]
          for (int y = tile.y0; y < tile.y1; ++y)
            for (int x = tile.x0; x < tile.x1; ++x) {
              if (!active[std::size_t(y) * std::size_t(width) + std::size_t(x)])
                continue; // stopped by adaptive sampling
              const PixelSequence sequence(settings.seed, x, y);
              for (int i = s0; i < s1; ++i) {
                // One pixel sample: its own random numbers, a film position, the chapter's estimate.
                const int s = share.index(i);
                Sampler sampler(settings.seed, x, y, std::uint64_t(s));
                const Ray ray = primary.ray(x, y, s, sampler, sequence);
                Color L = (*trace)(scene, ray, sampler, settings.maxDepth);
                // Guard the film: a NaN, infinite, negative or huge sample is counted and replaced by black.
                if (!Film::holds(L)) {
                  ++bad;
                  L = Color(0);
                }
                result.film.add(x, y, L);
                if (settings.beside) {
                  // The image beside: the same sample with the second estimator, from the same random numbers.
                  Sampler again(settings.seed, x, y, std::uint64_t(s));
                  Color B = (*settings.beside)(scene, primary.ray(x, y, s, again, sequence), again, settings.maxDepth);
                  if (!Film::holds(B)) {
                    ++bad;
                    B = Color(0);
                  }
                  result.film.add(x + width, y, B);
                }
              }
              pixelSamples += std::uint64_t(s1 - s0);
            }
          // [pixel_loop]
          const int tilesFinished = ++tilesDone;
          if (settings.progress && omp_get_thread_num() == 0)
            showProgress(s0 + double(batch) * tilesFinished / double(tiles.size()));
        }
        rays += rayCount() - raysBefore;
      }
    }
    result.rays += rays;
    result.badSamples += bad;
    samplesTaken += pixelSamples;
    if (std::size_t(tilesDone.load()) < tiles.size()) {
      // Stopped in the middle of the batch: the tiles done hold its samples, the others do not; spp counts the
      // samples every pixel has.
      result.interrupted = true;
      result.partialPass = double(tilesDone.load()) / double(tiles.size());
      break;
    }
    done = s1;
    result.spp = done;
    if (settings.preview && elapsed() - lastPreview >= settings.previewSeconds && done < target) {
      settings.preview(result.film);
      lastPreview = elapsed();
    }
  }
  result.meanSpp = double(samplesTaken) / double(active.size());
  result.cameraRays = settings.beside ? 2 * samplesTaken : samplesTaken;
  result.samples = share.ranges(done);
  result.seconds = elapsed();
  if (settings.progress) {
    drawProgress(1.0, result.seconds);
    std::fprintf(stderr, "\n");
  }
  return result;
}

} // namespace

RenderResult render(const Scene& scene, const Camera& camera, const RenderSettings& settings,
                    const TraceFunction& trace)
{
  return renderLoop(scene, camera, settings, &trace, nullptr);
}

RenderResult render(const Scene& scene, const Camera& camera, const RenderSettings& settings,
                    const SplatTraceFunction& trace)
{
  return renderLoop(scene, camera, settings, nullptr, &trace);
}

RenderResult render(const Scene& scene, const Camera& camera, const RenderSettings& settings,
                    const WavefrontWorkers& workers, std::size_t maxKeys)
{
  return renderLoop(scene, camera, settings, nullptr, nullptr, &workers, std::max<std::size_t>(1, maxKeys));
}

} // namespace raylife

/// @file render_loop.h
/// @brief The render loop: a scene through a camera with a chapter's trace function, over tiles, threads, samples, a
/// time budget and adaptive sampling, into a Film. The runner (runner.h) drives it from the command line.
#pragma once

#include "core/rng.h"
#include "render/film.h"
#include "scene/scene.h"

#include <atomic>
#include <cstdint>
#include <functional>
#include <optional>
#include <span>
#include <string>
#include <vector>

namespace raylife {

/// A chapter's estimator: the radiance arriving along `ray` (a primary ray), using `sampler` for any random
/// decision and following paths of at most `maxDepth` bounces. Must be thread-safe (it is called concurrently
/// for different pixels) and must not keep state between calls.
using TraceFunction = std::function<Color(const Scene& scene, const Ray& ray, Sampler& sampler, int maxDepth)>;
/// The same for chapters that neither recurse nor bound their depth.
using SimpleTraceFunction = Color (*)(const Scene& scene, const Ray& ray, Sampler& sampler);

/// The light that the samples of one pass (one sample index of every pixel) add to pixels other than their own:
/// bidirectional path tracing's light tracing (chapter 13), whose light paths land wherever they reach the camera.
/// Per pixel and channel a 128-bit fixed-point sum (F = kFilmSumFractionBits, as the film's) held in two 64-bit
/// atomic words, the low word's carry added to the high one: threads add in any order and the sums are the same
/// bits. The render loop adds each pixel's sum to that pixel's sample of the same index and clears it.
class SplatSums {
public:
  /// Sums for width × height pixels (each ≥ 1), all zero.
  SplatSums(int width, int height);
  /// Adds `L` to pixel `pixel` (row-major from the top row). Thread-safe. A splat that Film::holds refuses is
  /// dropped and counted as bad.
  void add(std::size_t pixel, const Color& L);
  /// The sum of pixel `pixel`, rounded once, and resets it to zero. Not to be called while another thread adds.
  Color take(std::size_t pixel);
  /// Splats dropped because Film::holds refused them (NaN, infinite, negative or too large), and resets the count.
  std::uint64_t takeBad() { return bad_.exchange(0); }

private:
  std::vector<std::atomic<std::uint64_t>> words_; // per pixel and channel: low word, high word
  std::atomic<std::uint64_t> bad_{0};
};

/// What an estimator that splats may do besides returning its own pixel's radiance: add light to any pixel of the
/// image, for the pass it belongs to. Handed by the render loop to a SplatTraceFunction, one per pixel sample.
class Splats {
public:
  /// Splats into `sums` for an image seen through `camera` (of the sums' size). Both outlive this.
  Splats(const Camera& camera, SplatSums& sums) : camera_(camera), sums_(sums) {}
  /// The render's camera: where a point projects (Camera::project), how large a pixel is.
  const Camera& camera() const { return camera_; }
  /// Adds radiance `L` (per channel ≥ 0) to the pixel that holds image position `film` (pixels, as Camera::ray and
  /// Camera::project use them). L is a contribution to that pixel's estimate as it stands, already divided by the
  /// number of samples that could make it (one per pixel in a pass): the render loop adds it as it is.
  void add(Vec2 film, const Color& L)
  {
    const int x = int(film.x), y = int(film.y);
    if (x < 0 || y < 0 || x >= camera_.width() || y >= camera_.height())
      return;
    sums_.add(std::size_t(y) * std::size_t(camera_.width()) + std::size_t(x), L);
  }

private:
  const Camera& camera_;
  SplatSums& sums_;
};

/// An estimator that splats (chapter 13): as TraceFunction, and `splats` takes the light this sample adds to other
/// pixels. Must be thread-safe and keep no state between calls.
using SplatTraceFunction =
    std::function<Color(const Scene& scene, const Ray& ray, Sampler& sampler, int maxDepth, Splats& splats)>;

/// Where inside a pixel the samples fall.
enum class PixelSampling {
  Centre,    ///< Every sample through the pixel's centre (x + ½, y + ½): no anti-aliasing.
  /// Stratified jittered: sample s of N lies in cell s of a ⌊√N⌋² grid (uniform beyond it). Where N is not known
  /// in advance (adaptive sampling, --time), sample s is point s of the pixel's PixelSequence (rng.h) instead.
  Jittered,
};

/// With a time budget, a share of the samples is made of aligned blocks of this many sample indices: a pixel's
/// PixelSequence (rng.h) is stratified in every such block, so each process's samples are spread well.
inline constexpr int kSampleBlock = 16;

/// A run of sample indices [first, first + count) of every pixel.
struct SampleRange {
  int first = 0; ///< The first sample index, ≥ 0.
  int count = 0; ///< How many, ≥ 0.
  /// One past the last.
  int end() const { return first + count; }
  /// Memberwise equality.
  bool operator==(const SampleRange&) const = default;
};

/// Which of a render's sample indices this process takes (job arrays, MPI ranks; docs/beyond-one-machine.md).
/// Sample s of pixel (x, y) depends only on (seed, x, y, s), so any partition of the indices, rendered anywhere
/// and merged (Film::merge), gives the image of the whole.
struct SampleShare {
  /// With a fixed spp: the indices taken, within [0, spp); nothing: all of them.
  std::optional<SampleRange> range;
  /// With a time budget: the processes sharing the samples (≥ 1) and this one's place among them (0 ≤ rank <
  /// ranks). Blocks of kSampleBlock indices go round: process r takes blocks r, r + ranks, r + 2·ranks, ...
  int rank = 0;
  int ranks = 1; ///< See rank.

  /// The global index of this process's i-th sample (i ≥ 0).
  int index(int i) const
  {
    if (range)
      return range->first + i;
    return ((i / kSampleBlock) * ranks + rank) * kSampleBlock + i % kSampleBlock;
  }
  /// The indices of this process's first `taken` samples, as sorted, disjoint, coalesced ranges.
  std::vector<SampleRange> ranges(int taken) const;
};

/// How to render, resolved from the options and the chapter's defaults.
struct RenderSettings {
  std::optional<int> spp;          ///< Samples per pixel, or nothing with `seconds`.
  std::optional<double> seconds;   ///< Time budget, or nothing with `spp`.
  std::uint64_t seed = 0;          ///< Seed of every pixel sample's random numbers.
  int threads = 0;                 ///< OpenMP threads; 0: every core.
  int maxDepth = -1;               ///< Passed to the trace function; −1: unlimited.
  PixelSampling pixelSampling = PixelSampling::Centre; ///< Where samples fall.
  bool progress = false;           ///< Draw a progress bar on standard error.
  /// Set to true (from a signal handler, say) to stop at the next tile. May be null.
  const std::atomic<bool>* stop = nullptr;
  /// Adaptive sampling: a pixel stops taking samples once its Film::relativeError falls below this (> 0).
  /// Nothing: every pixel takes every sample. See render().
  std::optional<double> adaptive;
  /// The sample indices this process takes (all, by default). Adaptive sampling needs them all.
  SampleShare share;
  /// Each sample also draws a point on the camera's lens (Camera::ray(film, lens)): set for a chapter that honours
  /// the lens, when the camera has an aperture. False: the pinhole ray, and no number drawn.
  bool lens = false;
  /// Each sample also draws a time in [0, 1) for its ray (Ray::time): set for a chapter that honours motion, when
  /// the scene has some (Scene::hasMotion). False: time 0, and no number drawn.
  bool motion = false;
  /// A second estimator whose image goes to the right of the first (ChapterInfo::besideTrace): every pixel sample
  /// is also taken with it, from its own Sampler(seed, x, y, s), into pixel (x + width, y) of a film twice as wide,
  /// so that one time budget holds both images. Not with a splatting estimator or adaptive sampling. May be null.
  const TraceFunction* beside = nullptr;
  /// A progressive preview: called between batches, at most every previewSeconds, with the film so far (every
  /// pixel's samples of the batches done). May be empty.
  std::function<void(const Film& film)> preview = {};
  double previewSeconds = 2; ///< See preview (> 0).
  /// The side of the square tiles the image is cut into, in pixels (≥ 1); 0: the loop's own (16). A device that
  /// runs many thousands of paths at once (chapter 17) takes larger tiles, so that each call has enough of them.
  /// The image does not depend on it: each pixel's samples are added in their order whatever the tiles.
  int tileSize = 0;
};

/// What a render produced and what it cost.
struct RenderResult {
  Film film;                    ///< The accumulated samples.
  int spp = 0;                  ///< Samples every pixel received.
  double seconds = 0;           ///< Wall-clock time of the render loop.
  std::uint64_t rays = 0;       ///< Rays traced (Scene::intersect and Scene::occluded calls).
  std::uint64_t cameraRays = 0; ///< Camera rays made: one per pixel sample taken (traced or not).
  std::uint64_t badSamples = 0; ///< Samples that were NaN, infinite or negative: replaced by 0 and counted.
  bool interrupted = false;     ///< Stopped early through RenderSettings::stop.
  /// Stopped in the middle of a batch of samples: the share of its tiles that took it, in [0, 1) (their pixels
  /// hold the whole batch, which may be many samples, more than spp: Film::samples says how many); 0 when every
  /// batch was whole.
  double partialPass = 0;
  /// Mean samples per pixel: equal to spp unless sampling was adaptive (then at most spp) or a batch was cut (then
  /// above spp, for the tiles that took the cut batch).
  double meanSpp = 0;
  std::vector<SampleRange> samples{}; ///< The sample indices taken (RenderSettings::share), coalesced.
};

/// One pixel sample of a wavefront (render() with a WavefrontFunction): the pixel, and the sample's index in the
/// render, which with (seed, x, y) keys its random numbers.
struct PixelSampleKey {
  int x = 0;      ///< The pixel's column, in [0, width).
  int y = 0;      ///< Its row, in [0, height), 0 at the top.
  int sample = 0; ///< The sample's index in the render (SampleShare::index), ≥ 0.
};

/// A pixel sample's random numbers and its primary ray, the sampler having drawn what the ray took.
struct PrimarySample {
  Ray ray;         ///< The camera ray, through the sample's point in the pixel (and on the lens, at its time).
  Sampler sampler; ///< The sample's random numbers from here on: the estimator's.
};

/// Where sample `s` of a pixel falls inside it, as a quotient: the offset in [0, 1)² is numerator / strata.
struct PixelOffsetParts {
  Vec2 numerator; ///< The offset, or (jittered in a stratum) the stratum's corner plus the jitter, in [0, strata)².
  Real strata;    ///< 1, or the strata a side (the stratum's numerator is divided by it), ≥ 1.
};

/// Where sample `s` of a pixel falls inside it, in [0, 1)², for a render whose samples fall by `mode`, as the
/// quotient pixelOffset divides out: the centre (PixelSampling::Centre); else, with `n` > 0 strata a side, jittered
/// in its stratum when s < n² and anywhere after; with n = 0, point s of the pixel's scrambled Sobol `sequence`,
/// stratified at every power of two and in every aligned block of 16 samples (what a pixel takes between two
/// adaptive checkpoints is whole such blocks). Draws two numbers from `sampler` where it jitters. (Chapter 16 divides
/// many at once; always inlined, so that pixelOffset's division by 1 folds away.)
[[gnu::always_inline]] inline PixelOffsetParts pixelOffsetParts(PixelSampling mode, int s, int n, Sampler& sampler,
                                                               const PixelSequence& sequence)
{
  if (mode == PixelSampling::Centre)
    return {Vec2(Real(0.5)), 1};
  if (n == 0)
    return {sequence.point(std::uint32_t(s)), 1};
  const Vec2 jitter = sampler.next2D();
  if (n == 1 || std::int64_t(s) >= std::int64_t(n) * n)
    return {jitter, 1};
  // Stratified: cell (s mod n, s div n) of an n × n grid, jittered inside the cell.
  const Real cx = Real(s % n), cy = Real(s / n);
  return {Vec2(cx + jitter.x, cy + jitter.y), Real(n)};
}

/// Where sample `s` of a pixel falls inside it, in [0, 1)²: pixelOffsetParts' quotient. (Always inlined: it runs
/// once per sample, and as a call chapter 6 made some 17 instructions a sample more.)
[[gnu::always_inline]] inline Vec2 pixelOffset(PixelSampling mode, int s, int n, Sampler& sampler,
                                               const PixelSequence& sequence)
{
  const PixelOffsetParts parts = pixelOffsetParts(mode, s, n, sampler, sequence);
  return parts.strata == 1 ? parts.numerator : parts.numerator / parts.strata;
}

/// A pixel sample of a camera without a lens, made in two halves (PrimaryRays::pinholeSample): where in its pixel
/// its ray goes and its time here, its ray's direction later (pinholeDirections in render/ray_stream.h, many at
/// once).
struct PinholeSample {
  PixelOffsetParts offset; ///< Where in its pixel its ray goes.
  Real time = 0;           ///< The ray's time in [0, 1) (0 in a still scene).
};

/// Makes pixel samples' primary rays exactly as render() makes them for every estimator: where in the pixel (its
/// stratum or its PixelSequence), then a point on the lens and a time where the settings ask for them. So a
/// wavefront's camera rays are those of any other chapter's, number for number.
class PrimaryRays {
public:
  /// For images through `camera`, rendered with `settings` (its seed, pixel sampling, lens, motion and, with a
  /// fixed spp, its strata). Both outlive this.
  PrimaryRays(const Camera& camera, const RenderSettings& settings);
  /// The sampler of `key` and its primary ray.
  PrimarySample make(const PixelSampleKey& key) const
  {
    Sampler sampler(seed_, key.x, key.y, std::uint64_t(key.sample));
    const PixelSequence sequence(seed_, key.x, key.y);
    const Ray ray = this->ray(key.x, key.y, key.sample, sampler, sequence);
    return PrimarySample{ray, sampler};
  }
  /// The primary ray of sample `s` of pixel (x, y), drawn from that sample's `sampler` and the pixel's
  /// `sequence` (made for the same seed and pixel): a film position, then a point on the lens and a time in the
  /// shutter interval (Cook's distributed ray tracing, chapter 11), drawn only where the camera and the scene have
  /// them, so that a still pinhole render keeps every random number where it was. (Inline: the render loop makes
  /// one a sample.)
  Ray ray(int x, int y, int s, Sampler& sampler, const PixelSequence& sequence) const
  {
    const Vec2 offset = pixelOffset(pixelSampling_, s, strata_, sampler, sequence);
    const Vec2 film = Vec2(Real(x), Real(y)) + offset;
    Ray ray = lens_ ? camera_.ray(film, sampler.next2D()) : camera_.ray(film);
    if (motion_)
      ray.time = sampler.next1D();
    return ray;
  }
  /// Whether the rays come through a pinhole (no point on a lens is drawn): then pinholeSample and
  /// Camera::ray(film) make what make does.
  bool pinhole() const { return !lens_; }
  /// make(key)'s first half, where pinhole() holds: where in the pixel the ray goes, and its time, drawn from
  /// `sampler`, the sample's Sampler(seed(), key.x, key.y, key.sample) as made (or one that draws the same numbers:
  /// pixelSamplers in render/ray_stream.h makes many at once), which then holds the estimator's numbers. The ray is
  /// camera().ray(film) with film = (x, y) + offset.numerator / offset.strata.
  PinholeSample pinholeSample(const PixelSampleKey& key, Sampler& sampler) const
  {
    PinholeSample p{pixelOffsetParts(pixelSampling_, key.sample, strata_, sampler, PixelSequence(seed_, key.x, key.y)),
                    0};
    if (motion_)
      p.time = sampler.next1D();
    return p;
  }
  /// The camera the rays come from.
  const Camera& camera() const { return camera_; }
  /// The render's seed (RenderSettings::seed).
  std::uint64_t seed() const { return seed_; }
  /// Where in a pixel the samples fall (RenderSettings::pixelSampling).
  PixelSampling pixelSampling() const { return pixelSampling_; }
  /// The side of the grid of strata jittered samples fall in (pixelOffset's n); 0: the pixel's PixelSequence.
  int strata() const { return strata_; }
  /// Whether each sample draws a point on the lens (RenderSettings::lens).
  bool lens() const { return lens_; }
  /// Whether each sample draws a time (RenderSettings::motion).
  bool motion() const { return motion_; }

private:
  const Camera& camera_;
  std::uint64_t seed_;
  PixelSampling pixelSampling_;
  int strata_; // the side of the grid of strata (0: the pixel's sequence)
  bool lens_, motion_;
};

/// A wavefront estimator (chapter 16): the radiance of every pixel sample of `keys` at once, added to out[i] for
/// keys[i] (out.size() == keys.size(); it arrives filled with 0), each sample's camera ray and random numbers made by `primary` (so sample s of pixel
/// (x, y) still depends on (seed, x, y, s) alone), paths of at most `maxDepth` bounces (−1: no limit). One is made
/// for each thread of the render (WavefrontWorkers) and called by that thread only, so it may keep its queues from
/// call to call; but what it returns must depend on its arguments alone.
using WavefrontFunction = std::function<void(const Scene& scene, const PrimaryRays& primary,
                                             std::span<const PixelSampleKey> keys, int maxDepth,
                                             std::span<Color> out)>;
/// Makes a wavefront estimator for one thread (thread-safe: called by every thread of the render at its start).
using WavefrontWorkers = std::function<WavefrontFunction()>;

/// Adaptive sampling looks at a pixel's error only once it has this many samples, and then again each time the
/// count has grown by a quarter, in multiples of this (16, 32, 48, 64, 80, 96, 112, 128, 160, ...: the same points
/// whatever the threads or the timing, so the image stays reproducible).
/// Fewer samples give too rough an estimate of the variance: a pixel whose first few samples happen to agree
/// (all missing a small light, say) would stop with a large error.
inline constexpr int kAdaptiveMinSamples = 16;
/// Samples after which adaptive sampling takes a pixel whose samples have all been black to be black (its error is
/// unknown until then: Film::relativeError): a path tracer's pixel in a dim corner may need many samples to find
/// the light, but a pixel that looks at a black background never will.
inline constexpr int kAdaptiveBlackSamples = 64;
/// Radiance below which adaptive sampling measures a pixel's error absolutely rather than relative to its mean:
/// 1/256 of white, about one 8-bit step, so that near-black pixels do not take samples without end.
inline constexpr double kAdaptiveMeanFloor = 1.0 / 256.0;

/// Renders `scene` through `camera` with `trace`.
///
/// The image is rendered in batches of samples over 16×16 tiles, spread over threads by OpenMP; a batch gives
/// every pixel the same samples, batches double in size and are cut to about a quarter of a second.
/// Sample s of pixel (x, y) draws its random numbers from Sampler(seed, x, y, s) and is added to the film in
/// the order of s, so the image is bit-identical for any thread count (and any batching). With `seconds`,
/// batches continue until the budget is spent (at least one sample), each cut to what is left of it; `stop`
/// is looked at between tiles, so that even one pass of a large image stops soon (RenderResult::partialPass). Every pixel has the same number of samples, unless `settings.adaptive` is set:
/// then, at kAdaptiveMinSamples samples and at fixed counts after (multiples of 16), each pixel whose
/// Film::relativeError(kAdaptiveMeanFloor) is below the threshold, and whose eight neighbours' is too, stops
/// taking samples (batches end at these points, so which pixels go on depends only on the seed). Sample
/// positions then follow the pixel's PixelSequence (the grid of strata assumes every pixel takes every sample).
/// Biased, slightly: the stopping rule correlates with the samples.
/// The render ends when every pixel has stopped, or at `spp` (then the most any pixel took) or `seconds`.
/// With a `share` of the samples, it takes only those: with `spp`, the range's indices (`spp` still sets the
/// strata); with `seconds`, its blocks; RenderResult::spp then counts the samples taken. A pixel takes at most
/// kMaxSamplesPerPixel samples (over all the shares). @throws std::invalid_argument for adaptive sampling with
/// a share, or a range outside [0, spp).
RenderResult render(const Scene& scene, const Camera& camera, const RenderSettings& settings,
                    const TraceFunction& trace);

/// Renders with a wavefront estimator (chapter 16), as render() with a TraceFunction (the same tiles, batches,
/// time budget, stop requests, adaptive sampling and shares, so the same images for any thread count), but each
/// tile's batch of pixel samples is handed whole to the wavefront estimator of the thread that takes the tile (made
/// by `workers`): its active pixels' samples s0 .. s1 − 1, pixel by pixel, in pieces of at most `maxKeys` (≥ 1).
RenderResult render(const Scene& scene, const Camera& camera, const RenderSettings& settings,
                    const WavefrontWorkers& workers, std::size_t maxKeys);

/// Renders with an estimator that splats (chapter 13), as render() with a TraceFunction, but pass by pass: for each
/// sample index s, every pixel takes its sample s (its radiance C, and splats into any pixel), then every pixel adds
/// C + (the splats it received in that pass) to the film as one sample. Passes are independent and identically
/// distributed, so the film's mean, variance of the mean and sample counts keep their meaning, a share of the
/// sample indices (--samples, MPI ranks) holds all the splats of its passes, and the splats' sums are exact
/// (SplatSums): the image is bit-identical for any thread count and any partition. A splat that is not finite,
/// negative or too large counts as a bad sample. No adaptive sampling (@throws std::invalid_argument).
RenderResult render(const Scene& scene, const Camera& camera, const RenderSettings& settings,
                    const SplatTraceFunction& trace);

} // namespace raylife

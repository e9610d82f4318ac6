/// @file bench.h
/// @brief The benchmark's own logic, apart from running programs: the error metric, the slope fit, the reference
/// cache key, the CSV rows, the render statistics, the summary table and the plot script (docs/benchmarks.md).
///
/// Everything here is a pure function of its inputs, so tests/bench checks it without rendering anything.
#pragma once

#include "render/film.h"

#include <cstdint>
#include <map>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

namespace raylife::bench {

/// The error of one render against a reference, over every pixel and channel.
struct ErrorMetrics {
  /// Mean of (x − ref)² / (ref² + 0.01): the relative MSE of docs/benchmarks.md (the same as compareImages()).
  double relativeMse = 0;
  /// √(mean of (x − ref)²), in units of radiance.
  double rmse = 0;
  /// Mean of var(ref) / (ref² + 0.01): the part of relativeMse that the reference's own noise contributes on
  /// average (the expectation of (x − ref)² is var(x) + bias² + var(ref) for an independent reference).
  double referenceRelativeMse = 0;
};

/// The error of `image` against `reference`, whose per-pixel variance of the mean is `referenceVariance`.
/// @throws std::invalid_argument when the three images differ in size.
ErrorMetrics measureError(const Image& image, const Image& reference, const Image& referenceVariance);

/// The sums of `image` over cells of `cell` × `cell` pixels (the last cells of a row or column may be smaller), one
/// pixel per cell. Summing both a render and its per-pixel variance of the mean gives each cell's total and the
/// variance of that total, so a z-test of cell sums compares cell means (docs/benchmarks.md: the reference check).
/// @param image the image (a mean or a variance of the mean per pixel).
/// @param cell  the cell's side in pixels, ≥ 1 (1 returns the image).
/// @throws std::invalid_argument when `cell` < 1.
Image cellSums(const Image& image, int cell);

/// The mean over pixels and channels of variance · spp / (reference² + 0.01): an estimator's relative variance per
/// sample, from a render of `spp` samples per pixel whose variance of the mean is `variance`. The estimator with the
/// least renders the reference (docs/benchmarks.md). Its own estimate: an estimator whose rare, bright samples its
/// render missed shows less than it has.
/// @param variance  the render's variance of each pixel mean.
/// @param spp       the render's samples per pixel, ≥ 1.
/// @param reference the reference (the relative measure's denominator), the size of `variance`.
/// @throws std::invalid_argument when the sizes differ.
double relativeVariancePerSample(const Image& variance, int spp, const Image& reference);

/// A straight line y = intercept + slope · x fitted by least squares.
struct LineFit {
  double slope = 0;     ///< dy/dx.
  double intercept = 0; ///< y at x = 0.
  double r2 = 0;        ///< Coefficient of determination, in [0, 1] (1 when every point is on the line).
  int points = 0;       ///< Points used.
};

/// Least-squares fit of log(y) against log(x) over the points with x > 0 and y > 0 (others are skipped).
/// @throws std::invalid_argument when fewer than two points with distinct x remain.
LineFit fitLogLog(const std::vector<double>& x, const std::vector<double>& y);

/// The slope an unbiased Monte Carlo estimator's MSE has against samples per pixel.
inline constexpr double kIdealSlope = -1.0;
/// How far a fitted slope may lie from kIdealSlope before the report flags it (issue 8).
inline constexpr double kSlopeTolerance = 0.15;
/// True when `slope` lies within kSlopeTolerance of kIdealSlope.
bool slopeAcceptable(double slope);
/// The summary's verdict on a slope: "within ±0.15 of −1", or "**FLAGGED**" with the direction and what it points
/// to: shallower than 1/N is an error floor, as a bias gives, or a heavy tail (rare, bright samples that small
/// budgets mostly miss, so that their error looks smaller than it is); steeper is what stratified pixel positions give
/// where edges carry the error (a scene of sky and silhouettes), which no bias does.
std::string slopeVerdict(double slope);

/// FNV-1a, 64 bits (Fowler, Noll, Vo): a stable, portable hash of bytes. Continue a hash by passing the
/// previous value as `hash`.
std::uint64_t fnv1a64(std::string_view bytes, std::uint64_t hash = 0xcbf29ce484222325ULL);
/// FNV-1a 64 of a file's bytes, continuing `hash`. @throws std::runtime_error when it cannot be read.
std::uint64_t fnv1a64File(const std::string& path, std::uint64_t hash = 0xcbf29ce484222325ULL);
/// The hash as 16 lower-case hexadecimal digits.
std::string hexHash(std::uint64_t hash);

/// What identifies a reference render: the cache key is a hash of all of it.
struct ReferenceKey {
  std::string scenePath;  ///< The scene file (its bytes are hashed, not its name).
  std::string binaryPath; ///< The chapter program (its bytes are hashed).
  int width = 0;          ///< Pixels.
  int height = 0;         ///< Pixels.
  int spp = 0;            ///< Samples per pixel.
  std::uint64_t seed = 0; ///< --seed.
};
/// FNV-1a 64 of the scene's bytes, the binary's bytes, and width, height, spp and seed.
/// @throws std::runtime_error when a file cannot be read.
std::uint64_t referenceHash(const ReferenceKey& key);

/// The figures a chapter writes with --stats (render_loop.cpp).
struct RenderStats {
  std::string chapter;      ///< The binary's name.
  int width = 0;            ///< Pixels.
  int height = 0;           ///< Pixels.
  int spp = 0;              ///< Samples every pixel received (with --adaptive: the most any pixel took).
  double meanSpp = 0;       ///< Mean samples per pixel (equal to spp unless `adaptive`; spp when not written).
  bool adaptive = false;    ///< Sampled adaptively (--adaptive; false when not written).
  double seconds = 0;       ///< Wall-clock time of the render loop (not process start or file writing).
  std::uint64_t rays = 0;   ///< Rays traced.
  std::uint64_t badSamples = 0; ///< Samples replaced by 0.
  int threads = 0;          ///< Threads used.
  bool interrupted = false; ///< Stopped early.
};
/// Parses a --stats JSON text; `mean_spp` and `adaptive` may be missing (stats written before adaptive sampling).
/// @throws std::runtime_error naming the missing or malformed field.
RenderStats parseStats(const std::string& json);

/// What a benchmark row measured.
enum class RowKind {
  Spp,       ///< A fixed samples-per-pixel budget (the spp ladder).
  Time,      ///< A fixed wall-clock budget (--time): equal-time comparisons.
  Threads,   ///< A fixed spp budget on a thread count other than the ladder's (thread scaling).
  Precision, ///< A fixed budget of a build of another precision (float against double).
  Adaptive,  ///< Adaptive sampling (--adaptive) at a threshold, up to a cap of spp.
};
/// "spp", "time", "threads", "precision" or "adaptive".
std::string toString(RowKind kind);
/// The inverse of toString(RowKind). @throws std::invalid_argument.
RowKind rowKindFromString(const std::string& text);

/// What a row's budget counts.
enum class BudgetUnit {
  Spp,           ///< Samples per pixel (--spp).
  Seconds,       ///< Wall-clock seconds (--time).
  RelativeError, ///< The relative standard error at which a pixel stops (--adaptive E).
};
/// "spp", "s" or "E": the CSV's budget_unit.
std::string toString(BudgetUnit unit);
/// The inverse of toString(BudgetUnit). @throws std::invalid_argument.
BudgetUnit budgetUnitFromString(const std::string& text);

/// One render of the benchmark: one line of results.csv.
struct Row {
  std::string mode;       ///< "quick" or "full".
  RowKind kind = RowKind::Spp; ///< What was measured.
  std::string scene;      ///< Scene file name, e.g. "cornell.json".
  std::string chapter;    ///< Binary name, e.g. "step06_path_tracer".
  std::string precision;  ///< "double" or "float".
  std::string build;      ///< Compiler, version and flags of the binary's build.
  int threads = 0;        ///< Threads used.
  std::uint64_t seed = 0; ///< --seed.
  double budget = 0;      ///< The budget asked for, in `unit`.
  BudgetUnit unit = BudgetUnit::Spp; ///< Seconds for --time, RelativeError for kind Adaptive, else spp.
  int spp = 0;            ///< Samples per pixel rendered (kind Adaptive: the most any pixel took).
  double meanSpp = 0;     ///< Mean samples per pixel (equal to spp unless the kind is Adaptive).
  double seconds = 0;     ///< Render seconds.
  std::uint64_t rays = 0; ///< Rays traced.
  std::uint64_t badSamples = 0; ///< Samples replaced by 0.
  ErrorMetrics error;     ///< Against the scene's reference.
  /// 1 / (seconds × relative MSE): the efficiency of docs/benchmarks.md (0 when either factor is 0).
  double efficiency() const;
};

/// The CSV header line (no newline): the column names, in order.
std::string csvHeader();
/// One CSV line (no newline) for `row`, fields quoted where they contain a comma, a quote or a line break.
std::string csvLine(const Row& row);
/// Splits one CSV line into fields (RFC 4180 quoting). @throws std::invalid_argument on an unterminated quote.
std::vector<std::string> splitCsvLine(const std::string& line);
/// Parses a whole CSV text written by csvHeader() and csvLine(), or by an earlier driver whose header lacked
/// mean_spp (it reads as spp). @throws std::invalid_argument on another header, a line that has not the header's
/// columns or a malformed number.
std::vector<Row> parseCsv(const std::string& text);

/// One line of a plot: a label and its (x, y) points, in drawing order.
struct Series {
  std::string label;           ///< Shown in the key.
  std::vector<double> x;       ///< Abscissae.
  std::vector<double> y;       ///< Ordinates.
  bool pointsOnly = false;     ///< Markers without a connecting line.
  bool dashed = false;         ///< A dashed line with open markers (a variant of another series of its colour).
  int color = 0;               ///< gnuplot line colour index, from 1; 0: the series' position in its panel.
  int pointType = 0;           ///< gnuplot point type; 0: filled circles (open ones when `dashed`).
};

/// The per-chapter means over seeds of one scene's rows of one kind: the points the plots and the fit use.
struct LadderPoint {
  double budget = 0;       ///< The budget, in `unit`.
  BudgetUnit unit = BudgetUnit::Spp; ///< What `budget` counts.
  double spp = 0;          ///< Mean spp rendered (kind Adaptive: the mean of the most any pixel took).
  double meanSpp = 0;      ///< Mean of the rows' mean spp per pixel.
  double rays = 0;         ///< Mean rays traced.
  double seconds = 0;      ///< Mean seconds.
  double relativeMse = 0;  ///< Mean relative MSE.
  double referenceRelativeMse = 0; ///< Mean reference share (see ErrorMetrics).
  double rmse = 0;         ///< Mean RMSE.
  int runs = 0;            ///< Seeds averaged.
};
/// Groups `rows` of `scene`, `chapter`, `kind` and `precision` by budget and averages them over seeds,
/// ordered by unit (spp, seconds, relative error), then budget ascending. Only rows on `threads` threads count
/// (any thread count when 0).
std::vector<LadderPoint> ladder(const std::vector<Row>& rows, const std::string& scene, const std::string& chapter,
                                RowKind kind, const std::string& precision, int threads = 0);

/// The slope of one chapter on one scene: log relative MSE (less the reference's share) against log spp.
struct SlopeResult {
  std::string scene;   ///< Scene.
  std::string chapter; ///< Chapter.
  LineFit fit;         ///< Of the reference-corrected error.
  LineFit rawFit;      ///< Of the relative MSE as measured.
  bool acceptable = false; ///< slopeAcceptable(fit.slope).
  double worstReferenceShare = 0; ///< Largest reference share / relative MSE over the ladder, in [0, 1].
};
/// The precision of the main measurements in `rows`: that of their spp ladder, the build of --bin ("double", or
/// "float" for the float build), which every table and plot reads but float against double; "double" when there
/// is no ladder.
std::string mainPrecision(const std::vector<Row>& rows);

/// Fits the spp ladder of each (scene, chapter) in `rows` (the main measurements' precision, mainPrecision).
std::vector<SlopeResult> fitSlopes(const std::vector<Row>& rows);

/// What the plain spp ladder needs for the error an adaptive render reached: its seconds and spp.
struct EqualError {
  /// How `seconds` and `spp` relate to what the ladder would need.
  enum class Bound {
    Interpolated, ///< Between two rungs whose errors bracket the target (log–log interpolation).
    AtLeast, ///< The target is below every rung's error: the rung of least error (most spp, normally), a lower bound.
    AtMost,  ///< The target is above every rung's error: the rung of largest error (fewest spp), an upper bound.
  };
  double seconds = 0; ///< Seconds of the plain renders (see `bound`).
  double spp = 0;     ///< Samples per pixel of the plain renders (see `bound`).
  Bound bound = Bound::Interpolated; ///< Exact to interpolation, or a bound.
};
/// The seconds and spp at which the spp ladder `ladder` (points of kind Spp, in spp order) reaches `relativeMse`:
/// interpolated linearly in log(relative MSE) between the first two consecutive rungs that bracket it (a noisy
/// ladder may cross the error more than once: the cheapest crossing, so that a saving is not overstated), else
/// the bound that the ladder's least or largest error gives. Nothing when the ladder is empty or `relativeMse` is
/// not positive.
std::optional<EqualError> plainAtEqualError(const std::vector<LadderPoint>& ladder, double relativeMse);

/// What the reference check found, for the summary.
struct ReferenceCheck {
  std::string scene;          ///< Scene.
  std::string referenceChapter; ///< The estimator of the reference.
  std::string checkChapter;   ///< The second estimator (may equal referenceChapter: a self-check only).
  int referenceSpp = 0;       ///< Samples per pixel of the reference.
  int checkSpp = 0;           ///< Samples per pixel of the second render.
  int cell = 1;               ///< Compared in cells of cell × cell pixels (1: per pixel).
  double referenceVariance = 0; ///< The reference estimator's relativeVariancePerSample().
  double checkVariance = 0;   ///< The second estimator's relativeVariancePerSample() (0 when not measured).
  double critical = 0;        ///< |z| above which a channel fails.
  double failedShare = 0;     ///< Share of (cell) channels over `critical`.
  double maxFailedShare = 0;  ///< The largest share allowed.
  double totalZ = 0;          ///< z of the difference of the image means.
  bool passed = false;        ///< |totalZ| ≤ critical and failedShare ≤ maxFailedShare.
  std::string hash;           ///< The reference's cache key.
};

/// Everything the summary needs besides the rows.
struct SummaryContext {
  std::string mode;            ///< "quick" or "full".
  std::string date;            ///< UTC date and time of the run.
  std::string machine;         ///< CPU model and core count.
  std::string conditions;      ///< Image size, ladder, seeds, budgets; anything a reader must know.
  std::string build;           ///< The double build's flags.
  std::string baselineChapter = "step06_path_tracer"; ///< Ratios are to this chapter.
  std::vector<ReferenceCheck> checks; ///< One per scene.
  std::vector<std::string> notes;     ///< Extra lines (skipped comparisons, say).
};

/// The Markdown summary: per scene the equal-time error and efficiency of each chapter with ratios to the
/// baseline chapter, the slopes (flagged outside ±kSlopeTolerance of −1), adaptive sampling against the spp
/// ladder at equal error (plainAtEqualError()), thread scaling, float against double, and the reference checks.
std::string summaryMarkdown(const std::vector<Row>& rows, const SummaryContext& context);

/// A gnuplot script drawing, per scene, log–log panels of `series` with the ideal 1/N slope through `anchor`
/// (a point of the panel's first series) into `outputBase`.svg and `outputBase`.png.
struct PlotPanel {
  std::string title;            ///< Panel title (the scene).
  std::vector<Series> series;   ///< Lines and markers.
  std::optional<std::pair<double, double>> anchor; ///< Where the ideal 1/N line passes.
};
/// The gnuplot script for `panels` side by side, `xLabel` against `yLabel`; data are inlined, so the script
/// stands alone.
std::string gnuplotScript(const std::vector<PlotPanel>& panels, const std::string& xLabel, const std::string& yLabel,
                          const std::string& outputBase);

/// `x` with %g-like formatting at `digits` significant digits.
std::string formatNumber(double x, int digits = 4);

} // namespace raylife::bench

// The benchmark's own logic (tools/bench/bench.h): metric, slope fit, cache key, stats, CSV, summary, plots.
#include "bench.h"
#include "render/image_compare.h"

#include <catch2/catch.hpp>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <random>

using namespace raylife;
using namespace raylife::bench;

namespace {

Image filled(int w, int h, float v)
{
  Image im(w, h);
  std::fill(im.pixels.begin(), im.pixels.end(), v);
  return im;
}

Row makeRow(const std::string& chapter, RowKind kind, double budget, bool isTime, int spp, double seconds, double mse,
            std::uint64_t seed = 1, int threads = 2, const std::string& precision = "double")
{
  Row r;
  r.mode = "quick";
  r.kind = kind;
  r.scene = "cornell.json";
  r.chapter = chapter;
  r.precision = precision;
  r.build = precision + " GNU 12.2.0 Release -O3 -DNDEBUG";
  r.threads = threads;
  r.seed = seed;
  r.budget = budget;
  r.unit = kind == RowKind::Adaptive ? BudgetUnit::RelativeError : isTime ? BudgetUnit::Seconds : BudgetUnit::Spp;
  r.spp = spp;
  r.meanSpp = spp;
  r.seconds = seconds;
  r.rays = std::uint64_t(spp) * 1000;
  r.error.relativeMse = mse;
  r.error.rmse = std::sqrt(mse);
  return r;
}

} // namespace

TEST_CASE("relative MSE is the mean of (x - ref)^2 / (ref^2 + 0.01)")
{
  Image ref(2, 1), x(2, 1), var(2, 1);
  ref.pixels = {0, 1, 2, 0.5f, 0.5f, 0.5f};
  x.pixels = {0.1f, 1, 2, 0.5f, 0.5f, 1.5f};
  var.pixels = {0.01f, 0, 0, 0, 0, 0.26f};
  const ErrorMetrics m = measureError(x, ref, var);
  const double expected = (0.01 / 0.01 + 1.0 / 0.26) / 6.0; // only channels 0 and 5 differ
  CHECK(m.relativeMse == Approx(expected).epsilon(1e-6));
  CHECK(m.rmse == Approx(std::sqrt((0.01 + 1.0) / 6.0)).epsilon(1e-6));
  CHECK(m.referenceRelativeMse == Approx((0.01 / 0.01 + 0.26 / 0.26) / 6.0).epsilon(1e-6));
  // The same metric as the compare tool's (common/render/image_compare.h defines it once).
  CHECK(m.relativeMse == Approx(compareImages(x, ref, 0).relativeMse).epsilon(1e-12));
  CHECK(measureError(ref, ref, var).relativeMse == 0);
}

TEST_CASE("measureError refuses images of different sizes")
{
  CHECK_THROWS_AS(measureError(Image(2, 2), Image(2, 1), Image(2, 1)), std::invalid_argument);
  CHECK_THROWS_AS(measureError(Image(2, 1), Image(2, 1), Image(1, 1)), std::invalid_argument);
}

TEST_CASE("the reference's share is what its own noise adds to the measured error")
{
  // x is exact and the reference carries noise of known variance: the measured relative MSE must match the
  // reference share on average (the driver subtracts it before fitting the slope).
  std::mt19937 rng(7);
  std::normal_distribution<double> noise(0, 0.01); // small beside the signal, as a converged reference's is
  const Image truth = filled(64, 64, 0.5f);
  Image ref = truth, var = filled(64, 64, 1e-4f);
  for (float& p : ref.pixels)
    p = float(0.5 + noise(rng));
  const ErrorMetrics m = measureError(truth, ref, var);
  CHECK(m.relativeMse == Approx(m.referenceRelativeMse).epsilon(0.1));
}

TEST_CASE("cellSums adds the pixels of each cell, the last cells of a row and a column being smaller")
{
  Image im(5, 3);
  for (int y = 0; y < 3; ++y)
    for (int x = 0; x < 5; ++x)
      for (int c = 0; c < 3; ++c)
        im.at(x, y, c) = float(1 + x + 10 * y + 100 * c);
  const Image cells = cellSums(im, 2);
  REQUIRE(cells.width == 3);
  REQUIRE(cells.height == 2);
  CHECK(cells.at(0, 0, 0) == 1 + 2 + 11 + 12);
  CHECK(cells.at(2, 0, 1) == 105 + 115);  // the last column: one pixel wide
  CHECK(cells.at(1, 1, 2) == 223 + 224);  // the last row: one pixel high
  CHECK(cells.at(2, 1, 0) == 25);         // the corner: one pixel
  CHECK(cellSums(im, 1).pixels == im.pixels);
  CHECK_THROWS_AS(cellSums(im, 0), std::invalid_argument);
}

TEST_CASE("in cells the reference check sees a regional bias that it misses per pixel, and keeps its total z")
{
  // The reference is 4% too bright over a 16 x 16 region, 0.67 standard errors per pixel: per pixel hardly a channel
  // fails, per cell of 8 x 8 pixels (8 times the signal over the noise: z about 5.3) the region's cells do.
  std::mt19937 rng(11);
  std::normal_distribution<double> unit(0, 1);
  const int w = 64, h = 48;
  const double value = 0.5, sigma = 0.03;
  Image check(w, h), ref(w, h), var = filled(w, h, float(sigma * sigma / 2));
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      for (int c = 0; c < 3; ++c) {
        check.at(x, y, c) = float(value + sigma / std::sqrt(2.0) * unit(rng));
        const double bias = x < 16 && y < 16 ? 0.04 * value : 0;
        ref.at(x, y, c) = float(value + bias + sigma / std::sqrt(2.0) * unit(rng));
      }
  const ZTestResult pixels = zTestImages(check, var, ref, var, 3.29, 1e-12);
  const ZTestResult cells =
      zTestImages(cellSums(check, 8), cellSums(var, 8), cellSums(ref, 8), cellSums(var, 8), 3.29, 1e-12);
  CHECK(pixels.failedShare < 0.01);       // the bench's per-pixel bound would trust it
  CHECK(cells.failedShare > 0.05);        // of 144 cell channels, 12 in the region: the bench refuses it
  CHECK(cells.totalZ == Approx(pixels.totalZ).epsilon(1e-3));
}

TEST_CASE("relative variance per sample: the variance of the mean times spp, over ref^2 + 0.01")
{
  Image var(2, 1), ref(2, 1);
  var.pixels = {0.01f, 0, 0, 0.002f, 0.002f, 0.002f};
  ref.pixels = {0, 1, 1, 1, 1, 1};
  CHECK(relativeVariancePerSample(var, 100, ref) ==
        Approx((0.01 * 100 / 0.01 + 3 * 0.002 * 100 / 1.01) / 6).epsilon(1e-6));
  CHECK_THROWS_AS(relativeVariancePerSample(var, 100, Image(1, 1)), std::invalid_argument);
}

TEST_CASE("the slope of an exact power law is its exponent")
{
  std::vector<double> x, y;
  for (int n = 1; n <= 1024; n *= 2) {
    x.push_back(n);
    y.push_back(0.3 / n);
  }
  const LineFit f = fitLogLog(x, y);
  CHECK(f.slope == Approx(-1).epsilon(1e-12));
  CHECK(std::exp(f.intercept) == Approx(0.3).epsilon(1e-12));
  CHECK(f.r2 == Approx(1).epsilon(1e-12));
  CHECK(f.points == 11);
  for (double& v : y)
    v = v * v; // 1/N²
  CHECK(fitLogLog(x, y).slope == Approx(-2).epsilon(1e-12));
}

TEST_CASE("the slope fit skips points that have no logarithm and refuses too few")
{
  CHECK(fitLogLog({1, 2, 0, 4, 8}, {1, 0.5, 3, 0.25, -1}).slope == Approx(-1).epsilon(1e-12));
  CHECK_THROWS_AS(fitLogLog({1, 2}, {1, 0}), std::invalid_argument);
  CHECK_THROWS_AS(fitLogLog({4, 4, 4}, {1, 2, 3}), std::invalid_argument);
  CHECK_THROWS_AS(fitLogLog({1, 2}, {1}), std::invalid_argument);
}

TEST_CASE("a Monte Carlo mean's squared error fits a slope near -1")
{
  // The error of a mean of N uniform samples, averaged over many trials: the estimator the benchmark checks.
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> u(0, 1);
  std::vector<double> x, y;
  for (int n = 1; n <= 256; n *= 2) {
    double sum = 0;
    const int trials = 4000;
    for (int t = 0; t < trials; ++t) {
      double mean = 0;
      for (int i = 0; i < n; ++i)
        mean += u(rng);
      mean /= n;
      sum += (mean - 0.5) * (mean - 0.5);
    }
    x.push_back(n);
    y.push_back(sum / trials);
  }
  const double slope = fitLogLog(x, y).slope;
  CHECK(slopeAcceptable(slope));
  CHECK(slope == Approx(-1).margin(0.05));
}

TEST_CASE("slopes outside -1 +- 0.15 are flagged")
{
  CHECK(slopeAcceptable(-1.0));
  CHECK(slopeAcceptable(-0.86));
  CHECK(slopeAcceptable(-1.14));
  CHECK_FALSE(slopeAcceptable(-0.8));
  CHECK_FALSE(slopeAcceptable(-1.2));
  CHECK_FALSE(slopeAcceptable(0.0));
  // The verdict says which way: a bias flattens the slope, stratification steepens it.
  CHECK(slopeVerdict(-1.1) == "within ±0.15 of −1");
  CHECK(slopeVerdict(-0.8).find("**FLAGGED**: shallower") == 0);
  CHECK(slopeVerdict(-1.2).find("**FLAGGED**: steeper") == 0);
}

TEST_CASE("FNV-1a 64 matches its published test vectors")
{
  CHECK(fnv1a64("") == 0xcbf29ce484222325ULL);
  CHECK(fnv1a64("a") == 0xaf63dc4c8601ec8cULL);
  CHECK(fnv1a64("foobar") == 0x85944171f73967e8ULL);
  // Continuing a hash is hashing the concatenation.
  CHECK(fnv1a64("bar", fnv1a64("foo")) == fnv1a64("foobar"));
  CHECK(hexHash(0xaf63dc4c8601ec8cULL) == "af63dc4c8601ec8c");
  CHECK(hexHash(1) == "0000000000000001");
}

TEST_CASE("the reference key changes with the scene bytes the binary bytes and the render settings")
{
  namespace fs = std::filesystem;
  const fs::path dir = fs::temp_directory_path() / ("raylife-bench-key-" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const fs::path scene = dir / "scene.json", binary = dir / "binary";
  std::ofstream(scene) << "{\"a\": 1}";
  std::ofstream(binary) << "program v1";
  ReferenceKey key{scene.string(), binary.string(), 128, 96, 4096, 1};
  const std::uint64_t h = referenceHash(key);
  CHECK(referenceHash(key) == h); // stable
  CHECK(fnv1a64File(scene.string()) == fnv1a64("{\"a\": 1}"));

  ReferenceKey other = key;
  other.spp = 2048;
  CHECK(referenceHash(other) != h);
  other = key;
  other.width = 129;
  CHECK(referenceHash(other) != h);
  other = key;
  other.seed = 2;
  CHECK(referenceHash(other) != h);
  // The same bytes under another name give the same key: names are not hashed.
  const fs::path copy = dir / "copy.json";
  fs::copy_file(scene, copy, fs::copy_options::overwrite_existing);
  other = key;
  other.scenePath = copy.string();
  CHECK(referenceHash(other) == h);
  // A changed scene or a rebuilt binary gives a new key.
  std::ofstream(scene) << "{\"a\": 2}";
  CHECK(referenceHash(key) != h);
  std::ofstream(scene) << "{\"a\": 1}";
  std::ofstream(binary) << "program v2";
  CHECK(referenceHash(key) != h);
  CHECK_THROWS_AS(fnv1a64File((dir / "missing").string()), std::runtime_error);
  fs::remove_all(dir);
}

TEST_CASE("the stats a chapter writes are read field by field")
{
  const RenderStats s = parseStats(R"({"chapter": "step06_path_tracer", "width": 128, "height": 96, "spp": 17,
      "seconds": 1.25, "rays": 123456789012, "bad_samples": 3, "threads": 2, "interrupted": false})");
  CHECK(s.chapter == "step06_path_tracer");
  CHECK(s.width == 128);
  CHECK(s.height == 96);
  CHECK(s.spp == 17);
  CHECK(s.seconds == 1.25);
  CHECK(s.rays == 123456789012ULL);
  CHECK(s.badSamples == 3);
  CHECK(s.threads == 2);
  CHECK_FALSE(s.interrupted);
  // Stats written before adaptive sampling have no mean_spp: it is the spp.
  CHECK(s.meanSpp == 17);
  CHECK_FALSE(s.adaptive);
  const RenderStats a = parseStats(R"({"chapter": "step06_path_tracer", "width": 128, "height": 96, "spp": 512,
      "seconds": 0.5, "rays": 1000, "bad_samples": 0, "threads": 2, "interrupted": false, "mean_spp": 20.25,
      "adaptive": true})");
  CHECK(a.spp == 512);
  CHECK(a.meanSpp == 20.25);
  CHECK(a.adaptive);
  CHECK_THROWS_AS(parseStats(R"({"chapter": "x", "width": 1})"), std::runtime_error);
  CHECK_THROWS_AS(parseStats("not json"), std::runtime_error);
  CHECK_THROWS_AS(parseStats(R"({"chapter": 5, "width": 1, "height": 1, "spp": 1, "seconds": 1, "rays": 1,
      "bad_samples": 0, "threads": 1, "interrupted": false})"),
                  std::runtime_error);
}

TEST_CASE("efficiency is 1 over seconds times relative MSE")
{
  Row r = makeRow("step06_path_tracer", RowKind::Spp, 4, false, 4, 2.0, 0.25);
  CHECK(r.efficiency() == Approx(2.0));
  r.seconds = 0;
  CHECK(r.efficiency() == 0);
}

TEST_CASE("a CSV line has the header's columns and reads back to the same row")
{
  Row r = makeRow("step06_path_tracer", RowKind::Time, 0.5, true, 37, 0.5123456789012345, 0.0123456789);
  r.build = "double GNU 12.2.0 Release -O3 -DNDEBUG, \"quoted\"";
  r.error.referenceRelativeMse = 1e-5;
  r.badSamples = 2;
  const std::string line = csvLine(r);
  CHECK(splitCsvLine(line).size() == splitCsvLine(csvHeader()).size());
  CHECK(csvHeader() == "mode,kind,scene,chapter,precision,build,threads,seed,budget,budget_unit,spp,mean_spp,seconds,"
                       "rays,bad_samples,rel_mse,rmse,ref_rel_mse,efficiency");
  const std::vector<Row> back = parseCsv(csvHeader() + "\n" + line + "\n");
  REQUIRE(back.size() == 1);
  const Row& b = back[0];
  CHECK(b.mode == r.mode);
  CHECK(b.kind == RowKind::Time);
  CHECK(b.build == r.build);
  CHECK(b.unit == BudgetUnit::Seconds);
  CHECK(b.budget == r.budget);
  CHECK(b.spp == 37);
  CHECK(b.seconds == r.seconds); // full precision
  CHECK(b.error.relativeMse == r.error.relativeMse);
  CHECK(b.error.referenceRelativeMse == r.error.referenceRelativeMse);
  CHECK(b.rays == r.rays);
  CHECK(b.badSamples == 2);
  CHECK(b.efficiency() == Approx(r.efficiency()));
}

TEST_CASE("an adaptive row keeps its threshold and mean spp through the CSV")
{
  Row r = makeRow("step06_path_tracer", RowKind::Adaptive, 0.05, false, 512, 0.25, 1e-5);
  r.meanSpp = 19.875;
  const std::vector<Row> back = parseCsv(csvHeader() + "\n" + csvLine(r) + "\n");
  REQUIRE(back.size() == 1);
  CHECK(back[0].kind == RowKind::Adaptive);
  CHECK(back[0].unit == BudgetUnit::RelativeError);
  CHECK(back[0].budget == 0.05);
  CHECK(back[0].spp == 512);
  CHECK(back[0].meanSpp == 19.875);
  CHECK(csvLine(r).find(",adaptive,") != std::string::npos);
  CHECK(csvLine(r).find(",0.050000000000000003,E,512,19.875,") != std::string::npos);
  CHECK(budgetUnitFromString("E") == BudgetUnit::RelativeError);
  CHECK_THROWS_AS(budgetUnitFromString("minutes"), std::invalid_argument);
  CHECK(rowKindFromString("adaptive") == RowKind::Adaptive);
}

TEST_CASE("a CSV written before mean_spp reads back with mean spp equal to spp")
{
  // The header and a line of the driver before adaptive sampling (no mean_spp column).
  const std::string old = "mode,kind,scene,chapter,precision,build,threads,seed,budget,budget_unit,spp,seconds,rays,"
                          "bad_samples,rel_mse,rmse,ref_rel_mse,efficiency\n"
                          "quick,time,cornell.json,step06_path_tracer,double,b,2,1,0.5,s,37,0.5,1000,0,0.1,0.3,"
                          "0.001,20\n";
  const std::vector<Row> rows = parseCsv(old);
  REQUIRE(rows.size() == 1);
  CHECK(rows[0].spp == 37);
  CHECK(rows[0].meanSpp == 37);
  CHECK(rows[0].unit == BudgetUnit::Seconds);
  CHECK(rows[0].error.relativeMse == 0.1);
  // A header with a column missing that is not optional, or one out of order, is refused.
  std::string noRays = old;
  noRays.replace(noRays.find(",rays"), 5, "");
  CHECK_THROWS_AS(parseCsv(noRays), std::invalid_argument);
  std::string swapped = old;
  swapped.replace(swapped.find("spp,seconds"), 11, "seconds,spp");
  CHECK_THROWS_AS(parseCsv(swapped), std::invalid_argument);
}

TEST_CASE("the plain ladder's time at an adaptive render's error is interpolated log-log or bounded")
{
  // MSE = 1/spp, seconds = spp / 10: a perfect ladder from 1 to 16 spp.
  std::vector<LadderPoint> plain;
  for (int n = 1; n <= 16; n *= 2) {
    LadderPoint p;
    p.budget = n;
    p.spp = n;
    p.seconds = 0.1 * n;
    p.relativeMse = 1.0 / n;
    plain.push_back(p);
  }
  // Between rungs 4 and 8: error 1/6 lies at spp 6 on the log-log line.
  const std::optional<EqualError> mid = plainAtEqualError(plain, 1.0 / 6);
  REQUIRE(mid);
  CHECK(mid->bound == EqualError::Bound::Interpolated);
  CHECK(mid->spp == Approx(6));
  CHECK(mid->seconds == Approx(0.6));
  // On a rung: that rung.
  const std::optional<EqualError> on = plainAtEqualError(plain, 0.25);
  REQUIRE(on);
  CHECK(on->spp == Approx(4));
  // Below every rung's error: at least the 16-spp rung; above: at most the 1-spp rung.
  const std::optional<EqualError> below = plainAtEqualError(plain, 0.01);
  REQUIRE(below);
  CHECK(below->bound == EqualError::Bound::AtLeast);
  CHECK(below->spp == 16);
  CHECK(below->seconds == Approx(1.6));
  const std::optional<EqualError> above = plainAtEqualError(plain, 3);
  REQUIRE(above);
  CHECK(above->bound == EqualError::Bound::AtMost);
  CHECK(above->spp == 1);
  // Nothing to compare with.
  CHECK_FALSE(plainAtEqualError({}, 0.1));
  CHECK_FALSE(plainAtEqualError(plain, 0));
  // A noisy ladder whose error rises between two rungs crosses 0.55 twice, between 1 and 2 spp and between 2
  // and 4: the cheaper crossing is taken, so that the time saved is not overstated.
  plain[2].relativeMse = 0.6; // 4 spp now worse than 2 spp (0.5)
  const std::optional<EqualError> noisy = plainAtEqualError(plain, 0.55);
  REQUIRE(noisy);
  CHECK(noisy->spp > 1);
  CHECK(noisy->spp < 2);
}

TEST_CASE("the summary sets each adaptive render against the plain ladder at equal error")
{
  std::vector<Row> rows;
  for (int n = 1; n <= 64; n *= 2)
    rows.push_back(makeRow("step06_path_tracer", RowKind::Spp, n, false, n, 0.01 * n, 1.0 / n));
  // Reaches the 32-spp error (1/32) in 0.08 s where the ladder takes 0.32 s: 75% saved.
  Row good = makeRow("step06_path_tracer", RowKind::Adaptive, 0.05, false, 256, 0.08, 1.0 / 32);
  good.meanSpp = 8.5;
  good.rays = 123456;
  rows.push_back(good);
  // Below the ladder's least error (1/64, 0.64 s) in 0.16 s: at least 75% saved.
  rows.push_back(makeRow("step06_path_tracer", RowKind::Adaptive, 0.01, false, 256, 0.16, 1.0 / 128));
  // Below the ladder's least error but slower than its top rung: the bound says nothing about the saving.
  rows.push_back(makeRow("step06_path_tracer", RowKind::Adaptive, 0.005, false, 256, 2.0, 1.0 / 256));
  // Worse than the cheapest rung, and slower: at most -100% saved (it costs more).
  rows.push_back(makeRow("step06_path_tracer", RowKind::Adaptive, 0.5, false, 256, 0.02, 2.0));
  SummaryContext c;
  c.mode = "quick";
  const std::string md = summaryMarkdown(rows, c);
  CAPTURE(md);
  CHECK(md.find("## Adaptive sampling") != std::string::npos);
  CHECK(md.find("| cornell.json | step06_path_tracer | 0.05 | 256 | 8.5 | 0.08 | 1.23e+05 | 0.03125 | 32 | 0.32 | "
                "75% |") != std::string::npos);
  CHECK(md.find("| 0.01 | 256 | 256 | 0.16 | 2.56e+05 | 0.007812 | ≥ 64 | ≥ 0.64 | ≥ 75% |") !=
        std::string::npos);
  CHECK(md.find("| 0.005 | 256 | 256 | 2 | 2.56e+05 | 0.003906 | ≥ 64 | ≥ 0.64 | beyond the ladder |") !=
        std::string::npos);
  CHECK(md.find("| 0.5 | 256 | 256 | 0.02 | 2.56e+05 | 2 | ≤ 1 | ≤ 0.01 | ≤ -100% |") != std::string::npos);
  // Without adaptive rows there is no such section.
  rows.resize(7);
  CHECK(summaryMarkdown(rows, c).find("## Adaptive sampling") == std::string::npos);
}

TEST_CASE("CSV fields with commas and quotes are quoted and split back")
{
  CHECK(splitCsvLine("a,\"b,c\",\"d \"\"e\"\"\",") == std::vector<std::string>{"a", "b,c", "d \"e\"", ""});
  CHECK_THROWS_AS(splitCsvLine("a,\"b"), std::invalid_argument);
  CHECK_THROWS_AS(parseCsv("not,the,header\n"), std::invalid_argument);
  CHECK_THROWS_AS(parseCsv(csvHeader() + "\nquick,spp,too,few\n"), std::invalid_argument);
  Row r = makeRow("c", RowKind::Spp, 1, false, 1, 1, 1);
  std::string line = csvLine(r);
  line.replace(line.find(",1,spp,"), 7, ",x,spp,"); // a malformed budget
  CHECK_THROWS_AS(parseCsv(csvHeader() + "\n" + line + "\n"), std::invalid_argument);
}

TEST_CASE("the ladder averages seeds per budget and keeps spp and time budgets apart")
{
  const std::vector<Row> rows = {
      makeRow("a", RowKind::Spp, 1, false, 1, 0.1, 0.4, 1),  makeRow("a", RowKind::Spp, 1, false, 1, 0.3, 0.6, 2),
      makeRow("a", RowKind::Spp, 2, false, 2, 0.4, 0.25, 1), makeRow("a", RowKind::Time, 1, true, 9, 1.0, 0.05, 1),
      makeRow("b", RowKind::Spp, 1, false, 1, 0.1, 0.9, 1),
      makeRow("a", RowKind::Threads, 2, false, 2, 0.8, 0.25, 1, 1)};
  const std::vector<LadderPoint> p = ladder(rows, "cornell.json", "a", RowKind::Spp, "double");
  REQUIRE(p.size() == 2);
  CHECK(p[0].budget == 1);
  CHECK(p[0].runs == 2);
  CHECK(p[0].seconds == Approx(0.2));
  CHECK(p[0].relativeMse == Approx(0.5));
  CHECK(p[1].budget == 2);
  CHECK(ladder(rows, "cornell.json", "a", RowKind::Time, "double").size() == 1);
  CHECK(ladder(rows, "cornell.json", "a", RowKind::Threads, "double", 2).empty());
  CHECK(ladder(rows, "cornell.json", "a", RowKind::Threads, "double", 1).size() == 1);
  CHECK(ladder(rows, "other.json", "a", RowKind::Spp, "double").empty());
}

TEST_CASE("fitSlopes fits each chapter's ladder less the reference share and flags a biased one")
{
  std::vector<Row> rows;
  for (int n = 1; n <= 64; n *= 2) {
    Row good = makeRow("step06_path_tracer", RowKind::Spp, n, false, n, 0.01 * n, 0.5 / n + 0.001);
    good.error.referenceRelativeMse = 0.001; // the reference's own noise, subtracted before the fit
    rows.push_back(good);
    // A biased estimator's error levels off at its bias²: its slope is far shallower than −1.
    rows.push_back(makeRow("step07_light_sampling", RowKind::Spp, n, false, n, 0.01 * n, 0.1 / n + 0.02));
  }
  const std::vector<SlopeResult> s = fitSlopes(rows);
  REQUIRE(s.size() == 2);
  CHECK(s[0].chapter == "step06_path_tracer");
  CHECK(s[0].fit.slope == Approx(-1).epsilon(1e-9));
  CHECK(s[0].rawFit.slope > -1);
  CHECK(s[0].acceptable);
  CHECK(s[0].worstReferenceShare == Approx(0.001 / (0.5 / 64 + 0.001)));
  CHECK_FALSE(s[1].acceptable);
}

TEST_CASE("the summary gives equal-time error and efficiency with ratios to chapter 6")
{
  std::vector<Row> rows;
  for (std::uint64_t seed = 1; seed <= 2; ++seed) {
    for (int n = 1; n <= 16; n *= 2) {
      rows.push_back(makeRow("step06_path_tracer", RowKind::Spp, n, false, n, 0.1 * n, 1.0 / n, seed));
      rows.push_back(makeRow("step07_light_sampling", RowKind::Spp, n, false, n, 0.2 * n, 0.1 / n, seed));
    }
    rows.push_back(makeRow("step06_path_tracer", RowKind::Time, 2, true, 20, 2.0, 0.05, seed));
    rows.push_back(makeRow("step07_light_sampling", RowKind::Time, 2, true, 10, 2.0, 0.01, seed));
    rows.push_back(makeRow("step06_path_tracer", RowKind::Threads, 16, false, 16, 3.0, 1.0 / 16, seed, 1));
    rows.push_back(makeRow("step06_path_tracer", RowKind::Precision, 16, false, 16, 1.2, 1.1 / 16, seed, 2, "float"));
  }
  SummaryContext c;
  c.mode = "quick";
  c.date = "2026-11-23 13:00 UTC";
  c.machine = "test CPU";
  c.conditions = "test";
  c.build = "double";
  ReferenceCheck k;
  k.scene = "cornell.json";
  k.referenceChapter = "step07_light_sampling";
  k.checkChapter = "step06_path_tracer";
  k.passed = true;
  k.cell = 8;
  k.referenceVariance = 0.34;
  k.checkVariance = 1.9;
  c.checks.push_back(k);
  const std::string md = summaryMarkdown(rows, c);
  CAPTURE(md);
  // Equal time: 0.05 against 0.01 → step07 has 0.2× the error and 5× the efficiency.
  CHECK(md.find("| step07_light_sampling | 10 | 2 | 0.01 | 0.2× | 50 | 5× |") != std::string::npos);
  CHECK(md.find("| step06_path_tracer | 20 | 2 | 0.05 | 1× | 10 | 1× |") != std::string::npos);
  CHECK(md.find("**trusted**") != std::string::npos);
  CHECK(md.find("in cells of 8×8 pixels") != std::string::npos);
  CHECK(md.find("step07_light_sampling 0.34, step06_path_tracer 1.9.") != std::string::npos);
  CHECK(md.find("should render the reference") == std::string::npos);
  CHECK(md.find("| cornell.json | step06_path_tracer | -1 | 1 | 5 |") != std::string::npos);
  // Thread scaling: 3 s on 1 thread against 1.6 s on 2 at 16 spp, identical errors.
  CHECK(md.find("| cornell.json | step06_path_tracer | 16 | 1 | 3 | 2 | 1.6 | 1.88× | yes |") != std::string::npos);
  CHECK(md.find("| cornell.json | step06_path_tracer | float | 16 spp | 16 | 1.2 |") != std::string::npos);
  CHECK(md.find("FLAGGED") == std::string::npos);

  // A thread run whose image differs from the ladder's (same seed) is reported.
  rows.push_back(makeRow("step06_path_tracer", RowKind::Threads, 16, false, 16, 3.0, 0.5, 3, 1));
  rows.push_back(makeRow("step06_path_tracer", RowKind::Spp, 16, false, 16, 1.6, 0.4, 3));
  CHECK(summaryMarkdown(rows, c).find("**NO**") != std::string::npos);
}

TEST_CASE("the plot script draws every series and the ideal 1/N line into SVG and PNG")
{
  PlotPanel p{"cornell.json", {{"step06_path_tracer", {1, 2, 4}, {0.8, 0.4, 0.2}, false},
                               {"step06 equal time", {2}, {0.1}, true}},
              std::pair{1.0, 0.8}};
  const std::string gp = gnuplotScript({p}, "samples per pixel", "relative MSE", "/tmp/out/error_vs_spp");
  CHECK(gp.find("set output \"/tmp/out/error_vs_spp.svg\"") != std::string::npos);
  CHECK(gp.find("set output \"/tmp/out/error_vs_spp.png\"") != std::string::npos);
  CHECK(gp.find("set logscale xy") != std::string::npos);
  CHECK(gp.find("0.8 / x with lines") != std::string::npos);
  CHECK(gp.find("title \"ideal 1/N\"") != std::string::npos);
  CHECK(gp.find("title \"step06_path_tracer\"") != std::string::npos);
  CHECK(gp.find("$d0_1 using 1:2 with points") != std::string::npos);
  CHECK(gp.find("4 0.2\n") != std::string::npos);
  // Series of one chapter share its colour; an adaptive one is dashed with open circles, a float one squares.
  PlotPanel q{"adaptive.json", {{"step07_light_sampling", {1, 2}, {0.8, 0.4}, false, false, 2},
                                {"step07 adaptive", {1.5}, {0.3}, false, true, 2},
                                {"step07 float build", {2}, {0.41}, true, false, 2, 5}},
              std::nullopt};
  const std::string gq = gnuplotScript({q}, "render seconds", "relative MSE", "/tmp/out/error_vs_time");
  CHECK(gq.find("$d0_0 using 1:2 with linespoints ps 0.8 lw 2 pt 7 lc 2 title") != std::string::npos);
  CHECK(gq.find("$d0_1 using 1:2 with linespoints ps 1.2 lw 2 dt 4 pt 6 lc 2 title \"step07 adaptive\"") !=
        std::string::npos);
  CHECK(gq.find("$d0_2 using 1:2 with points ps 1.2 pt 5 lc 2 title") != std::string::npos);
}

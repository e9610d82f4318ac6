#include "bench.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <set>
#include <sstream>
#include <tuple>

namespace raylife::bench {

ErrorMetrics measureError(const Image& image, const Image& reference, const Image& referenceVariance)
{
  if (image.width != reference.width || image.height != reference.height ||
      referenceVariance.width != reference.width || referenceVariance.height != reference.height)
    throw std::invalid_argument("measureError: the image, the reference and its variance differ in size");
  ErrorMetrics m;
  const std::size_t n = image.pixels.size();
  if (n == 0)
    return m;
  double sumSq = 0, sumRel = 0, sumRef = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const double x = image.pixels[i], r = reference.pixels[i];
    const double denominator = r * r + 0.01;
    const double d2 = (x - r) * (x - r);
    sumSq += d2;
    sumRel += d2 / denominator;
    sumRef += double(referenceVariance.pixels[i]) / denominator;
  }
  m.relativeMse = sumRel / double(n);
  m.rmse = std::sqrt(sumSq / double(n));
  m.referenceRelativeMse = sumRef / double(n);
  return m;
}

Image cellSums(const Image& image, int cell)
{
  if (cell < 1)
    throw std::invalid_argument("cellSums: a cell of " + std::to_string(cell) + " pixels");
  if (cell == 1)
    return image;
  Image out((image.width + cell - 1) / cell, (image.height + cell - 1) / cell);
  for (int y = 0; y < image.height; ++y)
    for (int x = 0; x < image.width; ++x)
      for (int c = 0; c < 3; ++c)
        out.at(x / cell, y / cell, c) += image.at(x, y, c);
  return out;
}

double relativeVariancePerSample(const Image& variance, int spp, const Image& reference)
{
  if (variance.width != reference.width || variance.height != reference.height)
    throw std::invalid_argument("relativeVariancePerSample: the variance and the reference differ in size");
  if (reference.pixels.empty())
    return 0;
  double sum = 0;
  for (std::size_t i = 0; i < reference.pixels.size(); ++i) {
    const double r = reference.pixels[i];
    sum += double(variance.pixels[i]) * spp / (r * r + 0.01);
  }
  return sum / double(reference.pixels.size());
}

LineFit fitLogLog(const std::vector<double>& x, const std::vector<double>& y)
{
  if (x.size() != y.size())
    throw std::invalid_argument("fitLogLog: x and y differ in length");
  std::vector<std::pair<double, double>> p;
  for (std::size_t i = 0; i < x.size(); ++i)
    if (x[i] > 0 && y[i] > 0 && std::isfinite(x[i]) && std::isfinite(y[i]))
      p.emplace_back(std::log(x[i]), std::log(y[i]));
  const double n = double(p.size());
  double mx = 0, my = 0;
  for (const auto& [a, b] : p) {
    mx += a;
    my += b;
  }
  if (p.size() < 2)
    throw std::invalid_argument("fitLogLog: fewer than two positive points");
  mx /= n;
  my /= n;
  double sxx = 0, sxy = 0, syy = 0;
  for (const auto& [a, b] : p) {
    sxx += (a - mx) * (a - mx);
    sxy += (a - mx) * (b - my);
    syy += (b - my) * (b - my);
  }
  if (sxx <= 0)
    throw std::invalid_argument("fitLogLog: every point has the same x");
  LineFit f;
  f.slope = sxy / sxx;
  f.intercept = my - f.slope * mx;
  f.r2 = syy > 0 ? (sxy * sxy) / (sxx * syy) : 1.0;
  f.points = int(p.size());
  return f;
}

bool slopeAcceptable(double slope) { return std::abs(slope - kIdealSlope) <= kSlopeTolerance; }

std::string slopeVerdict(double slope)
{
  if (slopeAcceptable(slope))
    return "within ±0.15 of −1";
  if (slope > kIdealSlope)
    return "**FLAGGED**: shallower than 1/N (an error floor, as a bias gives; or a heavy tail: rare, bright samples "
           "that the small budgets mostly miss raise the larger budgets' error)";
  return "**FLAGGED**: steeper than 1/N (as stratified pixel positions give where edges carry the error; a bias "
         "would make it shallower)";
}

std::uint64_t fnv1a64(std::string_view bytes, std::uint64_t hash)
{
  for (const char c : bytes) {
    hash ^= std::uint64_t(static_cast<unsigned char>(c));
    hash *= 0x100000001b3ULL;
  }
  return hash;
}

std::uint64_t fnv1a64File(const std::string& path, std::uint64_t hash)
{
  std::ifstream in(path, std::ios::binary);
  if (!in)
    throw std::runtime_error("cannot read " + path);
  std::vector<char> buffer(1 << 16);
  while (in) {
    in.read(buffer.data(), std::streamsize(buffer.size()));
    hash = fnv1a64(std::string_view(buffer.data(), std::size_t(in.gcount())), hash);
  }
  if (in.bad())
    throw std::runtime_error("cannot read " + path);
  return hash;
}

std::string hexHash(std::uint64_t hash)
{
  char text[17];
  std::snprintf(text, sizeof text, "%016llx", static_cast<unsigned long long>(hash));
  return text;
}

std::uint64_t referenceHash(const ReferenceKey& key)
{
  std::uint64_t h = fnv1a64File(key.scenePath);
  h = fnv1a64(std::string_view("\0scene-end\0", 11), h);
  h = fnv1a64File(key.binaryPath, h);
  std::string sizes = "|";
  sizes.append(std::to_string(key.width)).append("x").append(std::to_string(key.height));
  sizes.append("|spp=").append(std::to_string(key.spp)).append("|seed=").append(std::to_string(key.seed));
  return fnv1a64(sizes, h);
}

RenderStats parseStats(const std::string& text)
{
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(text);
  } catch (const nlohmann::json::exception& e) {
    throw std::runtime_error(std::string("stats: not JSON: ") + e.what());
  }
  auto field = [&](const char* name) -> const nlohmann::json& {
    if (!j.is_object() || !j.contains(name))
      throw std::runtime_error(std::string("stats: no field \"") + name + "\"");
    return j.at(name);
  };
  RenderStats s;
  try {
    s.chapter = field("chapter").get<std::string>();
    s.width = field("width").get<int>();
    s.height = field("height").get<int>();
    s.spp = field("spp").get<int>();
    s.seconds = field("seconds").get<double>();
    s.rays = field("rays").get<std::uint64_t>();
    s.badSamples = field("bad_samples").get<std::uint64_t>();
    s.threads = field("threads").get<int>();
    s.interrupted = field("interrupted").get<bool>();
    s.meanSpp = j.contains("mean_spp") ? j.at("mean_spp").get<double>() : double(s.spp);
    s.adaptive = j.contains("adaptive") && j.at("adaptive").get<bool>();
  } catch (const nlohmann::json::exception& e) {
    throw std::runtime_error(std::string("stats: a field has the wrong type: ") + e.what());
  }
  return s;
}

std::string toString(RowKind kind)
{
  switch (kind) {
  case RowKind::Spp: return "spp";
  case RowKind::Time: return "time";
  case RowKind::Threads: return "threads";
  case RowKind::Precision: return "precision";
  case RowKind::Adaptive: return "adaptive";
  }
  return "?";
}

RowKind rowKindFromString(const std::string& text)
{
  for (RowKind k : {RowKind::Spp, RowKind::Time, RowKind::Threads, RowKind::Precision, RowKind::Adaptive})
    if (toString(k) == text)
      return k;
  throw std::invalid_argument("unknown row kind '" + text + "'");
}

std::string toString(BudgetUnit unit)
{
  switch (unit) {
  case BudgetUnit::Spp: return "spp";
  case BudgetUnit::Seconds: return "s";
  case BudgetUnit::RelativeError: return "E";
  }
  return "?";
}

BudgetUnit budgetUnitFromString(const std::string& text)
{
  for (BudgetUnit u : {BudgetUnit::Spp, BudgetUnit::Seconds, BudgetUnit::RelativeError})
    if (toString(u) == text)
      return u;
  throw std::invalid_argument("CSV: budget_unit '" + text + "' is none of spp, s and E");
}

double Row::efficiency() const
{
  return seconds > 0 && error.relativeMse > 0 ? 1.0 / (seconds * error.relativeMse) : 0.0;
}

namespace {

const std::vector<std::string> kColumns = {
    "mode",        "kind", "scene",    "chapter", "precision",   "build",   "threads", "seed",        "budget",
    "budget_unit", "spp",  "mean_spp", "seconds", "rays",        "bad_samples", "rel_mse", "rmse", "ref_rel_mse",
    "efficiency"};
// The columns a CSV may lack, written by an earlier driver (mean_spp then reads as spp).
const std::vector<std::string> kOptionalColumns = {"mean_spp"};

std::string quoteField(const std::string& s)
{
  if (s.find_first_of(",\"\n\r") == std::string::npos)
    return s;
  std::string out = "\"";
  for (char c : s) {
    if (c == '"')
      out += '"';
    out += c;
  }
  return out + "\"";
}

// Full precision, so a CSV read back gives the same doubles.
std::string exact(double x)
{
  char text[40];
  std::snprintf(text, sizeof text, "%.17g", x);
  return text;
}

double toDouble(const std::string& s, const std::string& column)
{
  std::size_t used = 0;
  double v = 0;
  try {
    v = std::stod(s, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used != s.size() || s.empty())
    throw std::invalid_argument("CSV: column " + column + ": '" + s + "' is not a number");
  return v;
}

} // namespace

std::string csvHeader()
{
  std::string out;
  for (std::size_t i = 0; i < kColumns.size(); ++i)
    out += (i ? "," : "") + kColumns[i];
  return out;
}

std::string csvLine(const Row& r)
{
  const std::vector<std::string> fields = {
      r.mode,
      toString(r.kind),
      r.scene,
      r.chapter,
      r.precision,
      r.build,
      std::to_string(r.threads),
      std::to_string(r.seed),
      exact(r.budget),
      toString(r.unit),
      std::to_string(r.spp),
      exact(r.meanSpp),
      exact(r.seconds),
      std::to_string(r.rays),
      std::to_string(r.badSamples),
      exact(r.error.relativeMse),
      exact(r.error.rmse),
      exact(r.error.referenceRelativeMse),
      exact(r.efficiency())};
  std::string out;
  for (std::size_t i = 0; i < fields.size(); ++i) {
    if (i)
      out += ',';
    out += quoteField(fields[i]);
  }
  return out;
}

std::vector<std::string> splitCsvLine(const std::string& line)
{
  std::vector<std::string> fields(1);
  bool quoted = false;
  for (std::size_t i = 0; i < line.size(); ++i) {
    const char c = line[i];
    if (quoted) {
      if (c == '"' && i + 1 < line.size() && line[i + 1] == '"') {
        fields.back() += '"';
        ++i;
      } else if (c == '"') {
        quoted = false;
      } else {
        fields.back() += c;
      }
    } else if (c == '"') {
      quoted = true;
    } else if (c == ',') {
      fields.emplace_back();
    } else {
      fields.back() += c;
    }
  }
  if (quoted)
    throw std::invalid_argument("CSV: unterminated quote in: " + line);
  return fields;
}

std::vector<Row> parseCsv(const std::string& text)
{
  std::istringstream in(text);
  std::string line;
  if (!std::getline(in, line))
    throw std::invalid_argument("CSV: the first line is not the benchmark's header");
  // The header names the columns; every one of kColumns must be there, but those of kOptionalColumns.
  const std::vector<std::string> header = splitCsvLine(line);
  std::map<std::string, std::size_t> at;
  for (std::size_t i = 0; i < header.size(); ++i)
    at[header[i]] = i;
  std::vector<std::string> expected;
  for (const std::string& c : kColumns)
    if (at.count(c) || std::find(kOptionalColumns.begin(), kOptionalColumns.end(), c) == kOptionalColumns.end())
      expected.push_back(c);
  if (header != expected)
    throw std::invalid_argument("CSV: the first line is not the benchmark's header");
  std::vector<Row> rows;
  while (std::getline(in, line)) {
    if (line.empty())
      continue;
    const std::vector<std::string> f = splitCsvLine(line);
    if (f.size() != header.size())
      throw std::invalid_argument("CSV: a line has " + std::to_string(f.size()) + " fields, not " +
                                  std::to_string(header.size()) + ": " + line);
    auto field = [&](const std::string& column) -> const std::string& { return f[at.at(column)]; };
    auto number = [&](const std::string& column) { return toDouble(field(column), column); };
    Row r;
    r.mode = field("mode");
    r.kind = rowKindFromString(field("kind"));
    r.scene = field("scene");
    r.chapter = field("chapter");
    r.precision = field("precision");
    r.build = field("build");
    r.threads = int(number("threads"));
    r.seed = std::uint64_t(number("seed"));
    r.budget = number("budget");
    r.unit = budgetUnitFromString(field("budget_unit"));
    r.spp = int(number("spp"));
    r.meanSpp = at.count("mean_spp") ? number("mean_spp") : double(r.spp);
    r.seconds = number("seconds");
    r.rays = std::uint64_t(number("rays"));
    r.badSamples = std::uint64_t(number("bad_samples"));
    r.error.relativeMse = number("rel_mse");
    r.error.rmse = number("rmse");
    r.error.referenceRelativeMse = number("ref_rel_mse");
    rows.push_back(r);
  }
  return rows;
}

std::vector<LadderPoint> ladder(const std::vector<Row>& rows, const std::string& scene, const std::string& chapter,
                                RowKind kind, const std::string& precision, int threads)
{
  std::map<std::pair<BudgetUnit, double>, LadderPoint> groups;
  for (const Row& r : rows) {
    if (r.scene != scene || r.chapter != chapter || r.kind != kind || r.precision != precision)
      continue;
    if (threads > 0 && r.threads != threads)
      continue;
    LadderPoint& p = groups[{r.unit, r.budget}];
    p.budget = r.budget;
    p.unit = r.unit;
    p.spp += r.spp;
    p.meanSpp += r.meanSpp;
    p.rays += double(r.rays);
    p.seconds += r.seconds;
    p.relativeMse += r.error.relativeMse;
    p.referenceRelativeMse += r.error.referenceRelativeMse;
    p.rmse += r.error.rmse;
    p.runs += 1;
  }
  std::vector<LadderPoint> out;
  for (auto& [key, p] : groups) {
    const double n = p.runs;
    p.spp /= n;
    p.meanSpp /= n;
    p.rays /= n;
    p.seconds /= n;
    p.relativeMse /= n;
    p.referenceRelativeMse /= n;
    p.rmse /= n;
    out.push_back(p);
  }
  return out;
}

namespace {

// Scenes and chapters in the order they first appear in the rows.
std::vector<std::string> distinct(const std::vector<Row>& rows, std::string Row::*field)
{
  std::vector<std::string> out;
  for (const Row& r : rows)
    if (std::find(out.begin(), out.end(), r.*field) == out.end())
      out.push_back(r.*field);
  return out;
}

} // namespace

std::string mainPrecision(const std::vector<Row>& rows)
{
  for (const Row& r : rows)
    if (r.kind == RowKind::Spp)
      return r.precision;
  return "double";
}

std::vector<SlopeResult> fitSlopes(const std::vector<Row>& rows)
{
  const std::string precision = mainPrecision(rows);
  std::vector<SlopeResult> out;
  for (const std::string& scene : distinct(rows, &Row::scene))
    for (const std::string& chapter : distinct(rows, &Row::chapter)) {
      const std::vector<LadderPoint> points = ladder(rows, scene, chapter, RowKind::Spp, precision);
      if (points.size() < 2)
        continue;
      std::vector<double> x, y, yRaw;
      SlopeResult s{scene, chapter, {}, {}, false, 0};
      for (const LadderPoint& p : points) {
        x.push_back(p.spp);
        yRaw.push_back(p.relativeMse);
        y.push_back(p.relativeMse - p.referenceRelativeMse);
        if (p.relativeMse > 0)
          s.worstReferenceShare = std::max(s.worstReferenceShare, p.referenceRelativeMse / p.relativeMse);
      }
      try {
        s.fit = fitLogLog(x, y);
        s.rawFit = fitLogLog(x, yRaw);
      } catch (const std::invalid_argument&) {
        continue;
      }
      s.acceptable = slopeAcceptable(s.fit.slope);
      out.push_back(s);
    }
  return out;
}

std::optional<EqualError> plainAtEqualError(const std::vector<LadderPoint>& ladder, double relativeMse)
{
  std::vector<const LadderPoint*> rungs; // those with a logarithm, in spp order
  for (const LadderPoint& p : ladder)
    if (p.unit == BudgetUnit::Spp && p.relativeMse > 0 && p.seconds > 0 && p.spp > 0)
      rungs.push_back(&p);
  if (rungs.empty() || !(relativeMse > 0))
    return std::nullopt;
  // Interpolate log seconds and log spp linearly in log error between the first bracketing pair.
  for (std::size_t i = 0; i < rungs.size(); ++i) {
    const LadderPoint& a = *rungs[i];
    if (a.relativeMse == relativeMse)
      return EqualError{a.seconds, a.spp, EqualError::Bound::Interpolated};
    if (i + 1 == rungs.size())
      break;
    const LadderPoint& b = *rungs[i + 1];
    const auto [low, high] = std::minmax(a.relativeMse, b.relativeMse);
    if (low <= relativeMse && relativeMse <= high) {
      const double t = std::log(relativeMse / a.relativeMse) / std::log(b.relativeMse / a.relativeMse);
      auto between = [t](double x, double y) { return std::exp(std::log(x) + t * std::log(y / x)); };
      return EqualError{between(a.seconds, b.seconds), between(a.spp, b.spp), EqualError::Bound::Interpolated};
    }
  }
  // Outside the ladder's errors: its end rung bounds what the ladder would need, error falling with spp.
  auto lessError = [](const LadderPoint* x, const LadderPoint* y) { return x->relativeMse < y->relativeMse; };
  const auto [least, most] = std::minmax_element(rungs.begin(), rungs.end(), lessError);
  if (relativeMse < (*least)->relativeMse)
    return EqualError{(*least)->seconds, (*least)->spp, EqualError::Bound::AtLeast};
  return EqualError{(*most)->seconds, (*most)->spp, EqualError::Bound::AtMost};
}

std::string formatNumber(double x, int digits)
{
  char text[48];
  std::snprintf(text, sizeof text, "%.*g", digits, x);
  return text;
}

namespace {

std::string ratio(double a, double b) { return b > 0 && a > 0 ? formatNumber(a / b, 3) + "×" : "—"; }

const LadderPoint* largestTime(const std::vector<LadderPoint>& points)
{
  const LadderPoint* best = nullptr;
  for (const LadderPoint& p : points)
    if (p.unit == BudgetUnit::Seconds && (!best || p.budget > best->budget))
      best = &p;
  return best;
}

const LadderPoint* atBudget(const std::vector<LadderPoint>& points, BudgetUnit unit, double budget)
{
  for (const LadderPoint& p : points)
    if (p.unit == unit && p.budget == budget)
      return &p;
  return nullptr;
}

double efficiencyOf(const LadderPoint& p) { return p.seconds > 0 && p.relativeMse > 0 ? 1 / (p.seconds * p.relativeMse) : 0; }

} // namespace

std::string summaryMarkdown(const std::vector<Row>& rows, const SummaryContext& c)
{
  const std::string ladderPrecision = mainPrecision(rows); // (the build of --bin's)
  std::ostringstream md;
  md << "# raylife benchmark: run time against error (" << c.mode << " mode)\n\n";
  md << "- Run: " << c.date << "\n- Machine: " << c.machine << "\n- Build: " << c.build << "\n- Conditions: "
     << c.conditions << "\n";
  for (const std::string& n : c.notes)
    md << "- " << n << "\n";
  md << "\nRelative MSE is the mean over pixels and channels of (x − ref)² / (ref² + 0.01); efficiency is "
        "1 / (seconds × relative MSE). Every figure is a mean over seeds; ratios are to "
     << c.baselineChapter << " in the same run. Timings on a shared machine are noisy: compare ratios, not "
                             "absolute seconds.\n";

  const std::vector<SlopeResult> slopes = fitSlopes(rows);
  for (const std::string& scene : distinct(rows, &Row::scene)) {
    md << "\n## " << scene << "\n\n";
    for (const ReferenceCheck& k : c.checks)
      if (k.scene == scene) {
        md << "Reference: " << k.referenceChapter << " at " << k.referenceSpp << " spp (cache key " << k.hash
           << "), checked against " << k.checkChapter << " at " << k.checkSpp << " spp"
           << (k.checkChapter == k.referenceChapter ? " with another seed (a self-check only: no second estimator "
                                                      "was available)"
                                                    : "")
           << (k.cell > 1 ? ", in cells of " + std::to_string(k.cell) + "×" + std::to_string(k.cell) + " pixels"
                          : std::string())
           << ": " << formatNumber(k.failedShare * 100, 3) << "% of " << (k.cell > 1 ? "cell channels" : "channels")
           << " with |z| > " << formatNumber(k.critical, 3)
           << " (allowed " << formatNumber(k.maxFailedShare * 100, 3) << "%), total z = " << formatNumber(k.totalZ, 3)
           << " → **" << (k.passed ? "trusted" : "NOT TRUSTED") << "**.";
        if (k.referenceVariance > 0 && k.checkVariance > 0 && k.checkChapter != k.referenceChapter) {
          md << " Relative variance per sample (each render's own estimate): " << k.referenceChapter << " "
             << formatNumber(k.referenceVariance, 3) << ", " << k.checkChapter << " "
             << formatNumber(k.checkVariance, 3);
          if (k.checkVariance < k.referenceVariance)
            md << " (**the second estimator has less: it should render the reference**, unless its own estimate "
                  "misses rare, bright samples)";
          md << ".";
        }
        md << "\n\n";
      }

    // Equal time and efficiency, double build, ladder thread count.
    std::vector<std::string> chapters;
    for (const Row& r : rows)
      if (r.scene == scene && std::find(chapters.begin(), chapters.end(), r.chapter) == chapters.end())
        chapters.push_back(r.chapter);
    const LadderPoint* base = nullptr;
    std::vector<LadderPoint> baseTime = ladder(rows, scene, c.baselineChapter, RowKind::Time, ladderPrecision);
    base = largestTime(baseTime);
    md << "| chapter | spp in " << (base ? formatNumber(base->budget, 3) + " s" : "equal time")
       << " | seconds | rel. MSE at equal time | vs " << c.baselineChapter << " | efficiency 1/(s·relMSE) | vs "
       << c.baselineChapter << " | slope of log MSE vs log spp |\n|---|---|---|---|---|---|---|---|\n";
    for (const std::string& chapter : chapters) {
      const std::vector<LadderPoint> t = ladder(rows, scene, chapter, RowKind::Time, ladderPrecision);
      const LadderPoint* p = largestTime(t);
      std::string slope = "—";
      for (const SlopeResult& s : slopes)
        if (s.scene == scene && s.chapter == chapter)
          slope = formatNumber(s.fit.slope, 3) + (s.acceptable                 ? " (ok)"
                                                  : s.fit.slope > kIdealSlope ? " **FLAGGED** (shallow)"
                                                                              : " **FLAGGED** (steep)");
      if (!p) {
        md << "| " << chapter << " | — | — | — | — | — | — | " << slope << " |\n";
        continue;
      }
      md << "| " << chapter << " | " << formatNumber(p->spp, 4) << " | " << formatNumber(p->seconds, 3) << " | "
         << formatNumber(p->relativeMse, 4) << " | " << (base ? ratio(p->relativeMse, base->relativeMse) : "—")
         << " | " << formatNumber(efficiencyOf(*p), 4) << " | "
         << (base ? ratio(efficiencyOf(*p), efficiencyOf(*base)) : "—") << " | " << slope << " |\n";
    }

    // Every equal-time budget, for the error at each.
    md << "\nRelative MSE at each equal-time budget:\n\n| chapter |";
    std::set<double> budgets;
    for (const Row& r : rows)
      if (r.scene == scene && r.kind == RowKind::Time && r.precision == ladderPrecision)
        budgets.insert(r.budget);
    for (double b : budgets)
      md << " " << formatNumber(b, 3) << " s |";
    md << "\n|---|";
    for (std::size_t i = 0; i < budgets.size(); ++i)
      md << "---|";
    md << "\n";
    for (const std::string& chapter : chapters) {
      const std::vector<LadderPoint> t = ladder(rows, scene, chapter, RowKind::Time, ladderPrecision);
      md << "| " << chapter << " |";
      for (double b : budgets) {
        const LadderPoint* p = atBudget(t, BudgetUnit::Seconds, b);
        md << " " << (p ? formatNumber(p->relativeMse, 4) + " (" + formatNumber(p->spp, 4) + " spp)" : "—") << " |";
      }
      md << "\n";
    }
  }

  // Adaptive sampling against the plain spp ladder at the error it reached.
  bool anyAdaptive = false;
  std::ostringstream ad;
  ad << "\n## Adaptive sampling\n\nEach chapter with `--adaptive E --spp N` (a pixel stops once the relative "
        "standard error of its mean is below E, or at N samples; \"most spp\" is what the busiest pixel took), "
        "against its own plain spp ladder at the same error: the ladder's seconds and spp are interpolated log–log "
        "between the two rungs whose errors bracket the adaptive render's; beyond the ladder the end rung gives a "
        "bound (≥, ≤). Time saved is 1 − adaptive seconds / plain seconds at equal error. Adaptive sampling is "
        "biased a little (its stopping rule depends on the samples; docs/measurements/09_bvh.md measures how "
        "little).\n\n"
        "| scene | chapter | E | most spp | mean spp | seconds | rays | rel. MSE | plain spp at equal error | "
        "plain seconds | time saved |\n|---|---|---|---|---|---|---|---|---|---|---|\n";
  for (const std::string& scene : distinct(rows, &Row::scene))
    for (const std::string& chapter : distinct(rows, &Row::chapter)) {
      const std::vector<LadderPoint> plain = ladder(rows, scene, chapter, RowKind::Spp, ladderPrecision);
      for (const LadderPoint& p : ladder(rows, scene, chapter, RowKind::Adaptive, ladderPrecision)) {
        anyAdaptive = true;
        const std::optional<EqualError> e = plainAtEqualError(plain, p.relativeMse);
        std::string sppText = "—", secondsText = "—", saved = "—";
        if (e) {
          const std::string mark = e->bound == EqualError::Bound::AtLeast  ? "≥ "
                                   : e->bound == EqualError::Bound::AtMost ? "≤ "
                                                                           : "";
          sppText = mark + formatNumber(e->spp, 4);
          secondsText = mark + formatNumber(e->seconds, 3);
          const double share = 1 - p.seconds / e->seconds;
          // A bound on the plain time bounds the saving the same way; a bound that leaves its sign open says nothing.
          if (e->bound == EqualError::Bound::Interpolated || (e->bound == EqualError::Bound::AtLeast && share > 0) ||
              (e->bound == EqualError::Bound::AtMost && share < 0))
            saved = mark + formatNumber(share * 100, 3) + "%";
          else
            saved = "beyond the ladder";
        }
        ad << "| " << scene << " | " << chapter << " | " << formatNumber(p.budget, 4) << " | "
           << formatNumber(p.spp, 5) << " | " << formatNumber(p.meanSpp, 4) << " | " << formatNumber(p.seconds, 3)
           << " | " << formatNumber(p.rays, 3) << " | " << formatNumber(p.relativeMse, 4) << " | " << sppText << " | "
           << secondsText << " | " << saved << " |\n";
      }
    }
  if (anyAdaptive)
    md << ad.str();

  md << "\n## Slopes\n\nFitted by least squares to log(mean relative MSE − the reference's own share) against "
        "log(spp) over the spp ladder; an unbiased estimator has −1, and a slope outside −1 ± "
     << kSlopeTolerance << " is flagged.\n\n| scene | chapter | slope | R² | points | slope of the raw MSE | "
                           "largest reference share | verdict |\n|---|---|---|---|---|---|---|---|\n";
  for (const SlopeResult& s : slopes)
    md << "| " << s.scene << " | " << s.chapter << " | " << formatNumber(s.fit.slope, 4) << " | "
       << formatNumber(s.fit.r2, 4) << " | " << s.fit.points << " | " << formatNumber(s.rawFit.slope, 4) << " | "
       << formatNumber(s.worstReferenceShare * 100, 3) << "% | " << slopeVerdict(s.fit.slope) << " |\n";

  // Thread scaling: the Threads rows against the ladder's rows at the same spp budget.
  bool anyThreads = false;
  std::ostringstream th;
  th << "\n## Thread scaling\n\nThe same spp budget and seeds on 1 thread and on the ladder's thread count. The "
        "images must be bit-identical (same seed), so the error must be equal.\n\n| scene | chapter | spp | "
        "threads | seconds | threads | seconds | speed-up | same error |\n|---|---|---|---|---|---|---|---|---|\n";
  for (const std::string& scene : distinct(rows, &Row::scene))
    for (const std::string& chapter : distinct(rows, &Row::chapter))
      for (const Row& t : rows) {
        if (t.kind != RowKind::Threads || t.scene != scene || t.chapter != chapter)
          continue;
        // One table line per (scene, chapter, budget, thread count): the first row of the group stands for it.
        bool first = true;
        for (const Row& u : rows) {
          if (&u == &t)
            break;
          if (u.kind == RowKind::Threads && u.scene == scene && u.chapter == chapter && u.budget == t.budget &&
              u.threads == t.threads)
            first = false;
        }
        if (!first)
          continue;
        const std::vector<LadderPoint> few = ladder(rows, scene, chapter, RowKind::Threads, ladderPrecision, t.threads);
        const LadderPoint* a = atBudget(few, BudgetUnit::Spp, t.budget);
        // The ladder's rows at this budget and the seeds the thread rows used.
        int manyThreads = 0;
        double manySeconds = 0;
        int n = 0;
        bool same = true;
        for (const Row& m : rows)
          if (m.kind == RowKind::Spp && m.scene == scene && m.chapter == chapter && m.precision == ladderPrecision &&
              m.budget == t.budget && m.unit == BudgetUnit::Spp) {
            for (const Row& o : rows)
              if (o.kind == RowKind::Threads && o.scene == scene && o.chapter == chapter && o.budget == t.budget &&
                  o.threads == t.threads && o.seed == m.seed) {
                manySeconds += m.seconds;
                manyThreads = m.threads;
                ++n;
                same = same && o.error.relativeMse == m.error.relativeMse;
              }
          }
        if (!a || n == 0)
          continue;
        anyThreads = true;
        manySeconds /= n;
        th << "| " << scene << " | " << chapter << " | " << formatNumber(t.budget, 4) << " | " << t.threads << " | "
           << formatNumber(a->seconds, 3) << " | " << manyThreads << " | " << formatNumber(manySeconds, 3) << " | "
           << ratio(a->seconds, manySeconds) << " | " << (same ? "yes" : "**NO**") << " |\n";
      }
  if (anyThreads)
    md << th.str();

  // Float against double.
  bool anyFloat = false;
  std::ostringstream fl;
  fl << "\n## Float against double\n\nThe same chapter built with `RAYLIFE_REAL=float` (the `float` preset) and "
        "with double, against the same (double) reference.\n\n| scene | chapter | precision | budget | spp | "
        "seconds | rel. MSE | efficiency |\n|---|---|---|---|---|---|---|---|\n";
  for (const std::string& scene : distinct(rows, &Row::scene))
    for (const std::string& chapter : distinct(rows, &Row::chapter)) {
      const std::vector<LadderPoint> f = ladder(rows, scene, chapter, RowKind::Precision, "float");
      if (f.empty())
        continue;
      anyFloat = true;
      const std::vector<LadderPoint> dSpp = ladder(rows, scene, chapter, RowKind::Spp, "double");
      const std::vector<LadderPoint> dTime = ladder(rows, scene, chapter, RowKind::Time, "double");
      for (const LadderPoint& p : f) {
        const bool isTime = p.unit == BudgetUnit::Seconds;
        const LadderPoint* d = isTime ? atBudget(dTime, p.unit, p.budget) : atBudget(dSpp, p.unit, p.budget);
        const std::string budget = formatNumber(p.budget, 4) + (isTime ? " s" : " spp");
        for (const auto& [name, q] : {std::pair{"double", d}, std::pair{"float", &p}}) {
          if (!q)
            continue;
          fl << "| " << scene << " | " << chapter << " | " << name << " | " << budget << " | "
             << formatNumber(q->spp, 4) << " | " << formatNumber(q->seconds, 3) << " | "
             << formatNumber(q->relativeMse, 4) << " | " << formatNumber(efficiencyOf(*q), 4) << " |\n";
        }
      }
    }
  if (anyFloat)
    md << fl.str();
  return md.str();
}

std::string gnuplotScript(const std::vector<PlotPanel>& panels, const std::string& xLabel, const std::string& yLabel,
                          const std::string& outputBase)
{
  const int width = 560 * std::max<int>(1, int(panels.size())), height = 480;
  std::ostringstream gp;
  gp << "# Drawn by raylife_bench; run with: gnuplot THIS_FILE\n";
  // The data, inlined as named blocks so the script stands alone.
  for (std::size_t p = 0; p < panels.size(); ++p)
    for (std::size_t s = 0; s < panels[p].series.size(); ++s) {
      const Series& se = panels[p].series[s];
      gp << "$d" << p << "_" << s << " << EOD\n";
      for (std::size_t i = 0; i < se.x.size(); ++i)
        if (se.x[i] > 0 && se.y[i] > 0)
          gp << formatNumber(se.x[i], 10) << " " << formatNumber(se.y[i], 10) << "\n";
      gp << "EOD\n";
    }
  auto escape = [](const std::string& s) {
    std::string out;
    for (char ch : s) {
      if (ch == '"' || ch == '\\')
        out += '\\';
      out += ch;
    }
    return out;
  };
  gp << "set logscale xy\nset format x '%g'\nset format y '%.0e'\nset grid xtics ytics mxtics mytics lc rgb '#dddddd'\n"
     << "set key top right box opaque\nset xlabel \"" << escape(xLabel) << "\"\nset ylabel \"" << escape(yLabel)
     << "\"\n";
  for (const std::string& terminal : {std::string("svg size ") + std::to_string(width) + "," +
                                          std::to_string(height) + " dynamic noenhanced background '#ffffff' font 'Sans,12'",
                                      std::string("pngcairo size ") + std::to_string(width) + "," +
                                          std::to_string(height) + " noenhanced font 'Sans,10'"}) {
    const std::string ext = terminal.rfind("svg", 0) == 0 ? ".svg" : ".png";
    gp << "set terminal " << terminal << "\nset output \"" << escape(outputBase + ext) << "\"\n";
    gp << "set multiplot layout 1," << std::max<std::size_t>(1, panels.size()) << "\n";
    for (std::size_t p = 0; p < panels.size(); ++p) {
      const PlotPanel& panel = panels[p];
      gp << "set title \"" << escape(panel.title) << "\"\n";
      gp << "plot ";
      bool firstItem = true;
      for (std::size_t s = 0; s < panel.series.size(); ++s) {
        const Series& se = panel.series[s];
        gp << (firstItem ? "" : ", \\\n     ") << "$d" << p << "_" << s << " using 1:2 with "
           << (se.pointsOnly ? "points ps 1.2" : se.dashed ? "linespoints ps 1.2 lw 2 dt 4" : "linespoints ps 0.8 lw 2")
           << " pt " << (se.pointType > 0 ? se.pointType : se.dashed ? 6 : 7)
           << " lc " << (se.color > 0 ? se.color : int(s) + 1) << " title \"" << escape(se.label) << "\"";
        firstItem = false;
      }
      if (panel.anchor) {
        const auto [ax, ay] = *panel.anchor;
        gp << (firstItem ? "" : ", \\\n     ") << formatNumber(ax * ay, 10)
           << " / x with lines dt 2 lw 1.5 lc rgb '#555555' title \"ideal 1/N\"";
        firstItem = false;
      }
      if (firstItem)
        gp << "1/0 notitle";
      gp << "\n";
    }
    gp << "unset multiplot\nset output\n";
  }
  return gp.str();
}

} // namespace raylife::bench

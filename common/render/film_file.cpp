#include "render/film_file.h"

#include "core/printable.h"

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>

namespace raylife {

namespace {

constexpr const char* kMagic = "raylife film 1";
// Bytes per pixel in the payload: six Fixed128 sums, then (in a second block) one uint32 count.
constexpr std::size_t kSumBytes = 6 * 16;
// More bytes than a film's header can take: the magic, fourteen keys (each given once, "end" among them), a line of
// at most 4,097 bytes each.
constexpr std::size_t kHeaderMost = 1 << 16;

void putWord(std::vector<unsigned char>& out, std::uint64_t v, int bytes)
{
  for (int i = 0; i < bytes; ++i)
    out.push_back(static_cast<unsigned char>(v >> (8 * i)));
}

std::uint64_t getWord(const unsigned char* p, int bytes)
{
  std::uint64_t v = 0;
  for (int i = 0; i < bytes; ++i)
    v |= std::uint64_t(p[i]) << (8 * i);
  return v;
}

std::string hex(std::uint64_t v)
{
  char buffer[17];
  std::snprintf(buffer, sizeof buffer, "%016llx", static_cast<unsigned long long>(v));
  return buffer;
}

} // namespace

std::string FilmHeader::renderKey() const
{
  return "chapter " + chapter + ", scene hash " + hex(sceneHash) + ", " + std::to_string(width) + "x" +
         std::to_string(height) + ", spp " + std::to_string(spp) + ", seed " + std::to_string(seed) +
         ", max depth " + std::to_string(maxDepth);
}

std::int64_t FilmHeader::sampleCount() const
{
  std::int64_t n = 0;
  for (const SampleRange& r : samples)
    n += r.count;
  return n;
}

namespace {
// FNV-1a over `bytes`, going on from `h` (the offset basis for the first bytes).
std::uint64_t fnv1a(std::string_view bytes, std::uint64_t h)
{
  for (const char c : bytes) {
    h ^= static_cast<unsigned char>(c);
    h *= 0x100000001b3ull; // FNV-1a's prime
  }
  return h;
}
constexpr std::uint64_t kFnvOffsetBasis = 0xcbf29ce484222325ull;
} // namespace

std::uint64_t hashBytes(std::string_view bytes) { return fnv1a(bytes, kFnvOffsetBasis); }

std::uint64_t hashFile(const std::string& path)
{
  std::ifstream in(path, std::ios::binary);
  if (!in)
    throw FilmError(path + ": cannot open: " + std::strerror(errno));
  // A block at a time: no copy of the file in memory, and none of istreambuf_iterator's cost per byte (it was
  // two thirds of the instructions to hash a 3 MB scene).
  std::uint64_t h = kFnvOffsetBasis;
  char buffer[65536];
  while (in.read(buffer, sizeof buffer) || in.gcount() > 0)
    h = fnv1a(std::string_view(buffer, std::size_t(in.gcount())), h);
  if (in.bad())
    throw FilmError(path + ": cannot read: " + std::strerror(errno));
  return h;
}

std::string describeRanges(const std::vector<SampleRange>& ranges)
{
  // (A stream, not string concatenation: GCC 12's LTO warns falsely about the latter's memcpy bound.)
  std::ostringstream out;
  for (const SampleRange& r : ranges)
    out << (&r == ranges.data() ? "" : ", ") << r.first << ".." << (r.end() - 1);
  return ranges.empty() ? "none" : out.str();
}

std::vector<unsigned char> encodeFilm(const PartialFilm& film)
{
  const FilmHeader& h = film.header;
  std::ostringstream text;
  text << kMagic << "\n"
       << "layers pixel\n" // what follows the header; a later version adds "splat" (docs/beyond-one-machine.md)
       << "chapter " << printable(h.chapter) << "\n" // (a name with a newline would end its line early)
       << "scene_hash " << hex(h.sceneHash) << "\n"
       << "width " << h.width << "\n"
       << "height " << h.height << "\n"
       << "spp " << h.spp << "\n"
       << "seed " << h.seed << "\n"
       << "max_depth " << h.maxDepth << "\n"
       << "samples";
  for (const SampleRange& r : h.samples)
    text << " " << r.first << ":" << r.count;
  char seconds[32];
  std::snprintf(seconds, sizeof seconds, "%.17g", h.seconds);
  text << "\n"
       << "rays " << h.rays << "\n"
       << "bad_samples " << h.badSamples << "\n"
       << "seconds " << seconds << "\n"
       << "scene " << printable(h.scene) << "\n" // last: a name may hold spaces, and takes the rest of its line
       << "end\n";
  const std::string header = text.str();
  std::vector<unsigned char> out(header.begin(), header.end());
  const std::vector<Film::Sums>& sums = film.film.sums();
  out.reserve(out.size() + sums.size() * (kSumBytes + 4));
  for (const Film::Sums& p : sums)
    for (const Fixed128* words : {p.sum, p.squares})
      for (int c = 0; c < 3; ++c) {
        putWord(out, words[c].lo, 8);
        putWord(out, words[c].hi, 8);
      }
  for (const std::uint32_t n : film.film.counts())
    putWord(out, n, 4);
  return out;
}

namespace {

// Text from the file, for a message: short, and printable on one line.
std::string quote(std::string_view text) { return printable(shorten(text, 60)); }

// Parses a whole number in [lo, hi] for `key` on `line`, or throws.
long long number(const std::string& path, int line, const std::string& key, const std::string& text, long long lo,
                 long long hi)
{
  errno = 0;
  char* end = nullptr;
  const long long v = std::strtoll(text.c_str(), &end, 10);
  if (text.empty() || *end != '\0' || errno == ERANGE || v < lo || v > hi)
    throw FilmError(path + ": line " + std::to_string(line) + ": " + key + " '" + quote(text) +
                    "' is not a whole number in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]");
  return v;
}

} // namespace

PartialFilm readFilm(const std::string& path)
{
  std::ifstream in(path, std::ios::binary);
  if (!in)
    throw FilmError(path + ": cannot open: " + std::strerror(errno));
  // The header first, from the file's first kHeaderMost bytes (a valid header is shorter); the pixel data, whose
  // length the header gives, only once the file is known to hold that much. (Read whole, a 10 GB file that is no
  // film took 10 GB of memory before its first line was looked at, and a film's pixels were held twice.)
  std::string bytes(kHeaderMost, '\0');
  in.read(bytes.data(), std::streamsize(bytes.size()));
  bytes.resize(std::size_t(in.gcount()));
  if (bytes.compare(0, std::strlen(kMagic) + 1, std::string(kMagic) + "\n") != 0)
    throw FilmError(path + ": not a raylife film (it does not start with \"" + kMagic + "\")");

  FilmHeader h;
  std::size_t at = 0;
  int lineNumber = 0;
  bool ended = false;
  std::vector<std::string> seen;
  const auto limit = std::numeric_limits<long long>::max();
  while (!ended) {
    const std::size_t newline = bytes.find('\n', at);
    if (newline == std::string::npos || newline - at > 4096)
      throw FilmError(path + ": the header is truncated (no \"end\" line)");
    const std::string line = bytes.substr(at, newline - at);
    at = newline + 1;
    ++lineNumber;
    if (lineNumber == 1)
      continue; // the magic, checked above
    const std::size_t space = line.find(' ');
    const std::string key = line.substr(0, space);
    const std::string value = space == std::string::npos ? "" : line.substr(space + 1);
    for (const std::string& s : seen)
      if (s == key)
        throw FilmError(path + ": line " + std::to_string(lineNumber) + ": '" + quote(key) + "' is given twice");
    seen.push_back(key);
    auto bad = [&](const std::string& what) {
      return FilmError(path + ": line " + std::to_string(lineNumber) + ": " + what);
    };
    if (key == "end")
      ended = true;
    else if (key == "layers") {
      if (value != "pixel")
        throw bad("layers '" + quote(value) +
                  "': this raylife reads only \"pixel\" (a newer raylife wrote this film?)");
    } else if (key == "chapter")
      h.chapter = printable(value); // (as encodeFilm writes them: for messages, and a line each)
    else if (key == "scene")
      h.scene = printable(value);
    else if (key == "scene_hash") {
      char* end = nullptr;
      h.sceneHash = std::strtoull(value.c_str(), &end, 16);
      if (value.size() != 16 || *end != '\0')
        throw bad("scene_hash '" + quote(value) + "' is not 16 hexadecimal digits");
    } else if (key == "width")
      h.width = int(number(path, lineNumber, key, value, 1, 1 << 26));
    else if (key == "height")
      h.height = int(number(path, lineNumber, key, value, 1, 1 << 26));
    else if (key == "spp")
      h.spp = int(number(path, lineNumber, key, value, 0, kMaxSamplesPerPixel));
    else if (key == "seed")
      h.seed = std::uint64_t(number(path, lineNumber, key, value, 0, limit));
    else if (key == "max_depth")
      h.maxDepth = int(number(path, lineNumber, key, value, -1, 1 << 20));
    else if (key == "rays")
      h.rays = std::uint64_t(number(path, lineNumber, key, value, 0, limit));
    else if (key == "bad_samples")
      h.badSamples = std::uint64_t(number(path, lineNumber, key, value, 0, limit));
    else if (key == "seconds") {
      char* end = nullptr;
      h.seconds = std::strtod(value.c_str(), &end);
      if (value.empty() || *end != '\0' || !(h.seconds >= 0) || h.seconds > 1e300)
        throw bad("seconds '" + quote(value) + "' is not a number >= 0");
    } else if (key == "samples") {
      std::istringstream words(value);
      std::string word;
      while (words >> word) {
        const std::size_t colon = word.find(':');
        if (colon == std::string::npos)
          throw bad("samples: '" + quote(word) + "' is not FIRST:COUNT");
        const SampleRange r{int(number(path, lineNumber, "a range's first", word.substr(0, colon), 0, kMaxSamplesPerPixel)),
                            int(number(path, lineNumber, "a range's count", word.substr(colon + 1), 1, kMaxSamplesPerPixel))};
        if (!h.samples.empty() && r.first <= h.samples.back().end())
          throw bad("samples: the ranges must be in order, apart, and not touch (" + quote(word) + ")");
        h.samples.push_back(r);
      }
    } else
      throw bad("unknown key '" + quote(key) + "'");
  }
  for (const char* required : {"chapter", "scene_hash", "width", "height", "spp", "seed", "max_depth", "samples",
                               "layers"}) {
    bool found = false;
    for (const std::string& s : seen)
      found = found || s == required;
    if (!found)
      throw FilmError(path + ": the header has no '" + required + "' line");
  }
  if (h.sampleCount() > std::int64_t(kMaxSamplesPerPixel))
    throw FilmError(path + ": holds more than " + std::to_string(kMaxSamplesPerPixel) + " samples per pixel");
  if (h.spp > 0 && !h.samples.empty() && h.samples.back().end() > h.spp)
    throw FilmError(path + ": holds samples beyond the render's " + std::to_string(h.spp) + " (" +
                    describeRanges(h.samples) + ")");

  const std::size_t pixels = std::size_t(h.width) * std::size_t(h.height);
  const std::size_t expected = pixels * (kSumBytes + 4);
  // The pixel data's length: the file's size past the header, or, for a pipe, what it holds (read up to a byte past
  // what the header promises).
  std::error_code error;
  const bool regular = std::filesystem::is_regular_file(path, error);
  const std::uintmax_t fileSize = regular ? std::filesystem::file_size(path, error) : 0;
  const bool sized = regular && !error;
  if (!sized) {
    // Up to one byte more than the header promises: a pipe that goes on and on cannot exhaust memory.
    const std::size_t most = at + expected + 1;
    char buffer[1 << 16];
    while (bytes.size() < most) {
      in.read(buffer, std::streamsize(std::min(sizeof buffer, most - bytes.size())));
      if (in.gcount() == 0)
        break;
      bytes.append(buffer, std::size_t(in.gcount()));
    }
  }
  const std::uintmax_t end = sized ? fileSize : bytes.size(), have = end > at ? end - at : 0;
  const std::string size = std::to_string(h.width) + "x" + std::to_string(h.height);
  if (have > expected && !sized) // (a pipe: read no further than a byte past)
    throw FilmError(path + ": the pixel data is longer than the " + std::to_string(expected) + " bytes of a " + size +
                    " film");
  if (have != expected)
    throw FilmError(path + ": the pixel data is " + std::to_string(have) + " bytes, but a " + size + " film has " +
                    std::to_string(expected) + (have < expected ? " (truncated)" : ""));
  // The pixel data a block at a time: what the header's read took of it, then the rest of the file.
  std::size_t blockAt = at;
  std::vector<unsigned char> block;
  auto next = [&](std::size_t n) -> const unsigned char* {
    block.resize(n);
    const std::size_t fromBytes = std::min(n, bytes.size() - blockAt);
    std::memcpy(block.data(), bytes.data() + blockAt, fromBytes);
    blockAt += fromBytes;
    if (fromBytes < n && !in.read(reinterpret_cast<char*>(block.data() + fromBytes), std::streamsize(n - fromBytes)))
      throw FilmError(path + ": cannot read its pixel data (the file changed while it was read?)");
    return block.data();
  };
  constexpr std::size_t kBlockPixels = 1 << 14;
  std::vector<Film::Sums> sums(pixels);
  for (std::size_t first = 0; first < pixels; first += kBlockPixels) {
    const std::size_t n = std::min(kBlockPixels, pixels - first);
    const unsigned char* p = next(n * kSumBytes);
    for (std::size_t i = first; i < first + n; ++i)
      for (Fixed128* words : {sums[i].sum, sums[i].squares})
        for (int c = 0; c < 3; ++c) {
          words[c].lo = getWord(p, 8);
          words[c].hi = getWord(p + 8, 8);
          p += 16;
        }
  }
  std::vector<std::uint32_t> counts(pixels);
  for (std::size_t first = 0; first < pixels; first += kBlockPixels) {
    const std::size_t n = std::min(kBlockPixels, pixels - first);
    const unsigned char* p = next(n * 4);
    for (std::size_t i = first; i < first + n; ++i, p += 4) {
      counts[i] = std::uint32_t(getWord(p, 4));
      if (counts[i] > kMaxSamplesPerPixel)
        throw FilmError(path + ": a pixel holds " + std::to_string(counts[i]) + " samples, more than " +
                        std::to_string(kMaxSamplesPerPixel));
    }
  }
  return {h, Film(h.width, h.height, std::move(sums), std::move(counts))};
}

std::vector<SampleRange> uniteRanges(const std::vector<SampleRange>& a, const std::vector<SampleRange>& b,
                                     const std::string& aName, const std::string& bName)
{
  std::vector<SampleRange> all;
  std::size_t i = 0, j = 0;
  while (i < a.size() || j < b.size()) {
    const bool fromA = j == b.size() || (i < a.size() && a[i].first < b[j].first);
    const SampleRange r = fromA ? a[i++] : b[j++];
    if (r.count == 0)
      continue;
    if (!all.empty() && r.first < all.back().end()) {
      // The last range came from the other list (each list is disjoint): name the indices they share.
      const int first = r.first, last = std::min(r.end(), all.back().end()) - 1;
      throw FilmError(bName + " and " + aName + " both hold samples " + std::to_string(first) + ".." +
                      std::to_string(last) + ": each sample index may be merged once");
    }
    if (!all.empty() && r.first == all.back().end())
      all.back().count += r.count;
    else
      all.push_back(r);
  }
  return all;
}

SampleRange firstGap(const std::vector<SampleRange>& ranges, int spp)
{
  int next = 0;
  for (const SampleRange& r : ranges) {
    if (r.first > next)
      return {next, std::min(r.first, spp) - next};
    next = std::max(next, r.end());
  }
  return next < spp ? SampleRange{next, spp - next} : SampleRange{spp, 0};
}

void mergeFilm(PartialFilm& total, const std::string& totalName, const PartialFilm& part, const std::string& partName)
{
  const FilmHeader& a = total.header;
  const FilmHeader& b = part.header;
  auto differ = [&](const std::string& field, const std::string& x, const std::string& y) {
    if (x != y)
      throw FilmError(partName + " is a share of another render than " + totalName + ": its " + field + " is " +
                      shorten(y, 200) + ", not " + shorten(x, 200));
  };
  differ("chapter", a.chapter, b.chapter);
  if (a.sceneHash != b.sceneHash) // the names may differ (one file, two paths): the content decides
    throw FilmError(partName + " is a share of another render than " + totalName + ": its scene file (" +
                    shorten(b.scene, 200) + ", hash " + hex(b.sceneHash) + ") is not the same as " +
                    shorten(a.scene, 200) + " (hash " + hex(a.sceneHash) + ")");
  differ("size", std::to_string(a.width) + "x" + std::to_string(a.height),
         std::to_string(b.width) + "x" + std::to_string(b.height));
  differ("spp", std::to_string(a.spp), std::to_string(b.spp));
  differ("seed", std::to_string(a.seed), std::to_string(b.seed));
  differ("max depth", std::to_string(a.maxDepth), std::to_string(b.maxDepth));
  std::vector<SampleRange> samples = uniteRanges(a.samples, b.samples, totalName, partName);
  total.film.merge(part.film);
  total.header.samples = std::move(samples);
  total.header.rays += b.rays;
  total.header.badSamples += b.badSamples;
  total.header.seconds += b.seconds;
}

} // namespace raylife

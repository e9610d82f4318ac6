// The scene file loader: JSON (nlohmann/json) → a validated Scene. Every key is checked; every fault is reported
// once, as "FILE:LINE:COLUMN: /json/path: what is wrong", and nothing is half-loaded.
#include "scene/scene.h"

#include "core/edit_distance.h"
#include "core/printable.h"
#include "scene/mesh_file.h"
#include "scene/texture_file.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <sstream>
#include <unordered_map>

namespace raylife {

namespace {

// ordered_json keeps the file's order, so material indices and messages follow the file.
using Json = nlohmann::ordered_json;

/// Largest scene file loadScene reads, in bytes (64 MiB): far beyond any real scene, small enough to hold.
constexpr std::size_t kMaxSceneBytes = std::size_t(64) << 20;

// The value of a JSON string literal `quoted` (with its quotes), escapes resolved; "" if it is malformed.
std::string decodeString(std::string_view quoted)
{
  if (quoted.find('\\') == std::string_view::npos)
    return std::string(quoted.substr(1, quoted.size() >= 2 ? quoted.size() - 2 : 0));
  try {
    return Json::parse(quoted).get<std::string>();
  } catch (const Json::exception&) {
    return "";
  }
}

// 3 when `text` starts with a UTF-8 byte order mark (which nlohmann/json skips), else 0.
std::size_t byteOrderMarkLength(std::string_view text) { return text.substr(0, 3) == "\xEF\xBB\xBF" ? 3 : 0; }

// ---- Where in the text a JSON path points, for line:column in messages --------------------------------------
// nlohmann/json keeps no source positions, so this small scanner walks the (already valid) text to the value
// a path names. It returns npos if it cannot follow the path; messages then carry the path alone.
class Locator {
public:
  explicit Locator(std::string_view text) : text_(text) {}

  std::size_t find(const std::vector<std::string>& path) const
  {
    std::size_t pos = skipSpace(byteOrderMarkLength(text_));
    for (const std::string& token : path) {
      if (pos >= text_.size())
        return npos;
      if (text_[pos] == '{')
        pos = member(pos, token);
      else if (text_[pos] == '[')
        pos = element(pos, token);
      else
        return npos;
      if (pos == npos)
        return npos;
    }
    return pos;
  }

  static constexpr std::size_t npos = std::string_view::npos;

private:
  std::size_t skipSpace(std::size_t pos) const
  {
    while (pos < text_.size() && (text_[pos] == ' ' || text_[pos] == '\t' || text_[pos] == '\n' || text_[pos] == '\r'))
      ++pos;
    return pos;
  }
  std::size_t skipString(std::size_t pos) const // pos at the opening quote; returns one past the closing quote
  {
    for (++pos; pos < text_.size(); ++pos) {
      if (text_[pos] == '\\')
        ++pos;
      else if (text_[pos] == '"')
        return pos + 1;
    }
    return npos;
  }
  std::size_t skipValue(std::size_t pos) const // returns one past the value
  {
    if (pos >= text_.size())
      return npos;
    const char c = text_[pos];
    if (c == '"')
      return skipString(pos);
    if (c == '{' || c == '[') {
      const char close = c == '{' ? '}' : ']';
      pos = skipSpace(pos + 1);
      if (pos < text_.size() && text_[pos] == close)
        return pos + 1;
      while (pos < text_.size()) {
        if (c == '{') { // key : value
          pos = skipString(pos);
          if (pos == npos)
            return npos;
          pos = skipSpace(pos);
          if (pos >= text_.size() || text_[pos] != ':')
            return npos;
          pos = skipSpace(pos + 1);
        }
        pos = skipValue(pos);
        if (pos == npos)
          return npos;
        pos = skipSpace(pos);
        if (pos < text_.size() && text_[pos] == ',') {
          pos = skipSpace(pos + 1);
          continue;
        }
        return pos < text_.size() && text_[pos] == close ? pos + 1 : npos;
      }
      return npos;
    }
    // number, true, false, null
    while (pos < text_.size() && std::string_view(",]} \t\r\n").find(text_[pos]) == std::string_view::npos)
      ++pos;
    return pos;
  }
  std::size_t member(std::size_t pos, const std::string& key) const
  {
    pos = skipSpace(pos + 1);
    while (pos < text_.size() && text_[pos] == '"') {
      const std::size_t keyEnd = skipString(pos);
      if (keyEnd == npos)
        return npos;
      const std::string name = decodeString(text_.substr(pos, keyEnd - pos));
      pos = skipSpace(keyEnd);
      if (pos >= text_.size() || text_[pos] != ':')
        return npos;
      pos = skipSpace(pos + 1);
      if (name == key)
        return pos;
      pos = skipValue(pos);
      if (pos == npos)
        return npos;
      pos = skipSpace(pos);
      if (pos < text_.size() && text_[pos] == ',')
        pos = skipSpace(pos + 1);
    }
    return npos;
  }
  std::size_t element(std::size_t pos, const std::string& token) const
  {
    std::size_t index = 0;
    for (char ch : token) {
      if (ch < '0' || ch > '9')
        return npos;
      index = index * 10 + std::size_t(ch - '0');
    }
    pos = skipSpace(pos + 1);
    for (std::size_t i = 0; i < index; ++i) {
      pos = skipValue(pos);
      if (pos == npos)
        return npos;
      pos = skipSpace(pos);
      if (pos >= text_.size() || text_[pos] != ',')
        return npos;
      pos = skipSpace(pos + 1);
    }
    return pos < text_.size() && text_[pos] != ']' ? pos : npos;
  }

  std::string_view text_;
};

// "LINE:COLUMN" of a byte offset; lines and columns count from 1, columns in characters (UTF-8 code points).
std::string lineColumn(std::string_view text, std::size_t offset)
{
  std::size_t line = 1, column = 1;
  for (std::size_t i = 0; i < offset && i < text.size(); ++i) {
    if (text[i] == '\n') {
      ++line;
      column = 1;
    } else if ((static_cast<unsigned char>(text[i]) & 0xC0) != 0x80) { // not a UTF-8 continuation byte
      ++column;
    }
  }
  return std::to_string(line) + ":" + std::to_string(column);
}

// " (did you mean 'x'?)" for the nearest candidate within a small edit distance, else "".
std::string suggestion(std::string_view word, const std::vector<std::string>& candidates)
{
  std::string best;
  constexpr std::size_t kLongest = 64; // no name is that long: beyond it, a suggestion would only cost time
  if (word.size() > kLongest)
    return "";
  std::size_t bestDistance = std::max<std::size_t>(2, word.size() / 3) + 1;
  for (const std::string& c : candidates) {
    if (c.size() > kLongest)
      continue;
    const std::size_t d = editDistance(word, c);
    if (d < bestDistance) {
      bestDistance = d;
      best = c;
    }
  }
  return best.empty() ? "" : " (did you mean '" + shorten(best) + "'?)";
}

// 'a', 'b', 'c': at most the first 12 words, each shortened.
std::string joinQuoted(const std::vector<std::string>& words)
{
  constexpr std::size_t kMaxWords = 12;
  std::string out;
  for (std::size_t i = 0; i < words.size() && i < kMaxWords; ++i)
    out += (i ? ", '" : "'") + shorten(words[i]) + "'";
  if (words.size() > kMaxWords)
    out += " and " + std::to_string(words.size() - kMaxWords) + " more";
  return out;
}

// ---- What nlohmann/json accepts but a scene file must not contain -----------------------------------------
// A fault found by scanning the text itself: where it is (byte offset), the JSON path to it, and what is wrong.
struct TextFault {
  std::size_t offset;
  std::string path;
  std::string message;
};

/// Deepest nesting of objects and arrays a scene file may have. The format needs 4 ({"materials": {"x":
/// {"color": [...]}}}); the limit keeps every recursive walk of the value (dump(), the Locator) shallow.
constexpr std::size_t kMaxNesting = 32;

// Walks the text of a JSON document iteratively and finds what nlohmann/json lets pass: nesting deeper than
// kMaxNesting, a key given twice in one object (nlohmann keeps the last silently), a number too large for a
// double (which nlohmann reports without a position). On text that is not valid JSON it stops at the first
// thing it does not understand and reports nothing.
std::optional<TextFault> scanText(std::string_view text)
{
  struct Frame {
    bool object;                                  // an object (else an array)
    std::string token;                            // the current key, or the current index as text
    std::size_t index = 0;                        // the current index (arrays)
    std::unordered_map<std::string, std::size_t> keys; // keys seen so far, with their offsets
  };
  std::vector<Frame> stack;
  auto path = [&](const std::string* last) {
    std::string p;
    for (const Frame& f : stack)
      if (!f.token.empty() || !f.object) {
        p += '/';
        p += shorten(f.token);
      }
    if (last) {
      p += '/';
      p += shorten(*last);
    }
    return p.empty() ? std::string("/") : p;
  };
  bool expectKey = false;
  for (std::size_t pos = byteOrderMarkLength(text); pos < text.size();) {
    const char c = text[pos];
    if (c == ' ' || c == '\t' || c == '\n' || c == '\r' || c == ':') {
      ++pos;
    } else if (c == '{' || c == '[') {
      if (stack.size() >= kMaxNesting)
        return TextFault{pos, path(nullptr), "objects and arrays nested deeper than " + std::to_string(kMaxNesting) +
                                                 " levels (a scene needs at most 4)"};
      stack.push_back(Frame{c == '{', c == '[' ? "0" : "", 0, {}});
      expectKey = c == '{';
      ++pos;
    } else if (c == '}' || c == ']') {
      if (stack.empty())
        return std::nullopt;
      stack.pop_back();
      expectKey = false;
      ++pos;
    } else if (c == ',') {
      if (stack.empty())
        return std::nullopt;
      Frame& top = stack.back();
      if (top.object) {
        expectKey = true;
      } else {
        ++top.index;
        top.token = std::to_string(top.index);
      }
      ++pos;
    } else if (c == '"') {
      std::size_t end = pos + 1;
      while (end < text.size() && text[end] != '"')
        end += text[end] == '\\' ? 2 : 1;
      if (end >= text.size())
        return std::nullopt;
      ++end;
      if (expectKey && !stack.empty()) {
        Frame& top = stack.back();
        std::string key = decodeString(text.substr(pos, end - pos));
        if (const auto seen = top.keys.find(key); seen != top.keys.end()) {
          top.token.clear();
          return TextFault{pos, path(&key), "the key '" + shorten(key) + "' is given twice in one object (first at " +
                                                lineColumn(text, seen->second) + "); give each key once"};
        }
        top.keys.emplace(key, pos);
        top.token = std::move(key);
        expectKey = false;
      }
      pos = end;
    } else {
      // A number or a literal: check that a number fits in a double.
      std::size_t end = pos;
      // (A switch, not a search of the string ",]} \t\r\n:" for every character, and the exponent noted on the
      // way, not searched for: the two searches were more than a third of this scan's instructions.)
      auto endsToken = [](char e) {
        switch (e) {
        case ',': case ']': case '}': case ' ': case '\t': case '\r': case '\n': case ':':
          return true;
        default:
          return false;
        }
      };
      bool exponent = false;
      for (; end < text.size() && !endsToken(text[end]); ++end)
        exponent = exponent || text[end] == 'e' || text[end] == 'E';
      const std::string_view token = text.substr(pos, end - pos);
      // Only a number with an exponent, or with more than 308 characters, can reach 1.8·10³⁰⁸: without an
      // exponent it has at most 308 digits before its point, so it is below 10³⁰⁸. (strtod on every number was 8 %
      // of the instructions it took to load 20,000 spheres.)
      constexpr std::size_t kDigitsBelowDoubleMax = 308;
      if ((c == '-' || (c >= '0' && c <= '9')) &&
          (token.size() > kDigitsBelowDoubleMax || exponent)) {
        const std::string number(token);
        const double v = std::strtod(number.c_str(), nullptr);
        if (!std::isfinite(v))
          return TextFault{pos, path(nullptr), "the number " + shorten(number) + " is too large for a double"};
      }
      if (end == pos)
        return std::nullopt;
      pos = end;
    }
  }
  return std::nullopt;
}

// ---- Reading checked values -------------------------------------------------------------------------------

class Reader {
public:
  Reader(std::string_view text, const std::string& file) : text_(text), file_(file) {}

  // A JSON path: the tokens and their "/a/0/b" spelling.
  struct Path {
    std::vector<std::string> tokens;
    Path operator/(const std::string& token) const
    {
      Path p = *this;
      p.tokens.push_back(token);
      return p;
    }
    Path operator/(std::size_t index) const { return *this / std::to_string(index); }
    std::string str() const
    {
      std::string s;
      for (const std::string& t : tokens) {
        s += '/'; // (appended in two steps: "/" + shorten(t) trips a false -Wrestrict in GCC 12)
        s += shorten(t);
      }
      return s.empty() ? "/" : s;
    }
  };

  // "FILE:LINE:COLUMN: /json/path" of a value, or of its nearest enclosing value that is in the text (the
  // parent of a missing key, say).
  std::string where(const Path& path) const
  {
    std::vector<std::string> tokens = path.tokens;
    std::size_t offset = Locator::npos;
    while (true) {
      offset = Locator(text_).find(tokens);
      if (offset != Locator::npos || tokens.empty())
        break;
      tokens.pop_back();
    }
    const std::string place = offset != Locator::npos ? lineColumn(text_, offset) + ": " : "";
    return file_ + ":" + place + path.str();
  }

  [[noreturn]] void fail(const Path& path, const std::string& message) const
  {
    throw SceneError(printable(where(path) + ": " + message));
  }

  const Json& object(const Json& j, const Path& path) const
  {
    if (!j.is_object())
      fail(path, "expected an object { ... }, got " + describe(j));
    return j;
  }

  // Every key of `j` must be one of `known`; the first unknown one is an error with a suggestion.
  void onlyKeys(const Json& j, const Path& path, const std::vector<std::string>& known) const
  {
    for (auto it = j.begin(); it != j.end(); ++it)
      if (std::find(known.begin(), known.end(), it.key()) == known.end())
        fail(path / it.key(), "unknown key '" + shorten(it.key()) + "'" + suggestion(it.key(), known) +
                                  "; known keys here: " + joinQuoted(known));
  }

  const Json& required(const Json& j, const Path& path, const std::string& key) const
  {
    auto it = j.find(key);
    if (it == j.end())
      fail(path / key, "missing key '" + key + "'");
    return *it;
  }

  Real number(const Json& j, const Path& path) const
  {
    if (!j.is_number())
      fail(path, "expected a number, got " + describe(j));
    const double v = j.get<double>();
    if (!std::isfinite(v) || !std::isfinite(Real(v)))
      fail(path, "the number is not finite in " + std::string(sizeof(Real) == 4 ? "float" : "double"));
    return Real(v);
  }

  int wholeNumber(const Json& j, const Path& path, std::int64_t lo, std::int64_t hi) const
  {
    if (j.is_number_float()) {
      // A whole number beyond 64 bits arrives as a double: say it is out of range rather than not whole. One in
      // range written with a point or an exponent (320.0, 1e3) is asked for without.
      const double v = j.get<double>();
      if (std::isfinite(v) && v == std::floor(v)) {
        if (v > double(hi))
          fail(path, "must be at most " + std::to_string(hi) + ", got " + j.dump());
        if (v < double(lo))
          fail(path, "must be at least " + std::to_string(lo) + ", got " + j.dump());
        fail(path, "expected a whole number written without a decimal point or exponent, got " + j.dump());
      }
    }
    if (!j.is_number_integer())
      fail(path, "expected a whole number, got " + describe(j));
    // nlohmann stores every non-negative whole number as unsigned: compare without converting a huge one to int64.
    if (j.is_number_unsigned() ? j.get<std::uint64_t>() > std::uint64_t(hi) : j.get<std::int64_t>() > hi)
      fail(path, "must be at most " + std::to_string(hi) + ", got " + j.dump());
    const std::int64_t value = j.is_number_unsigned() ? std::int64_t(j.get<std::uint64_t>()) : j.get<std::int64_t>();
    if (value < lo)
      fail(path, "must be at least " + std::to_string(lo) + ", got " + j.dump());
    return int(value);
  }

  Vec3 vec3(const Json& j, const Path& path) const
  {
    if (!j.is_array() || j.size() != 3)
      fail(path, "expected an array of 3 numbers [x, y, z], got " + describe(j));
    return Vec3(number(j[0], path / 0), number(j[1], path / 1), number(j[2], path / 2));
  }

  // A point of the scene's geometry: [x, y, z], each within ±kMaxSceneExtent.
  Vec3 point(const Json& j, const Path& path) const
  {
    const Vec3 p = vec3(j, path);
    for (std::size_t c = 0; c < 3; ++c)
      if (!withinSceneExtent(p[int(c)]))
        fail(path / c, std::string("a coordinate must lie within ±") + kMaxSceneExtentText +
                            " (raylife's bound on a scene's size), got " + j[c].dump());
    return p;
  }

  // A colour with every channel in [0, maxChannel].
  Color color(const Json& j, const Path& path, Real maxChannel, const char* what) const
  {
    if (!j.is_array() || j.size() != 3)
      fail(path, std::string("expected ") + what + " as an array of 3 numbers [r, g, b], got " + describe(j));
    Color c;
    for (int i = 0; i < 3; ++i) {
      c[i] = number(j[std::size_t(i)], path / std::size_t(i));
      if (c[i] < 0)
        fail(path / std::size_t(i), std::string(what) + " must not be negative, got " + j[std::size_t(i)].dump());
      if (c[i] > maxChannel)
        fail(path / std::size_t(i), std::string(what) + " must be at most 1 (a surface cannot reflect more light "
                                                         "than reaches it), got " + j[std::size_t(i)].dump());
    }
    return c;
  }

  std::string string(const Json& j, const Path& path) const
  {
    if (!j.is_string())
      fail(path, "expected a string, got " + describe(j));
    return j.get<std::string>();
  }

  static std::string describe(const Json& j)
  {
    std::string text = j.dump();
    if (text.size() > 40)
      text = text.substr(0, 37) + "...";
    return std::string(j.type_name()) + " " + text;
  }

private:
  std::string_view text_;
  const std::string& file_;
};

using Path = Reader::Path;

void readCamera(const Reader& r, const Json& j, const Path& path, CameraSpec& cam, bool sizeGiven)
{
  r.object(j, path);
  r.onlyKeys(j, path, {"eye", "focal", "up", "vfov", "width", "height", "aperture", "focus", "medium"});
  cam.eye = r.point(r.required(j, path, "eye"), path / "eye");
  cam.focal = r.point(r.required(j, path, "focal"), path / "focal");
  if (j.contains("up"))
    cam.up = r.vec3(j["up"], path / "up");
  if (j.contains("vfov")) {
    cam.vfovDeg = r.number(j["vfov"], path / "vfov");
    if (!(cam.vfovDeg > 0 && cam.vfovDeg < 180))
      r.fail(path / "vfov", "the field of view must lie strictly between 0 and 180 degrees, got " + j["vfov"].dump());
  }
  if (j.contains("width"))
    cam.width = r.wholeNumber(j["width"], path / "width", 1, kMaxPixels);
  if (j.contains("height"))
    cam.height = r.wholeNumber(j["height"], path / "height", 1, kMaxPixels);
  if (std::int64_t(cam.width) * cam.height > kMaxPixels && !sizeGiven)
    r.fail(path / "width", "an image of " + std::to_string(cam.width) + "x" + std::to_string(cam.height) +
                               " pixels is larger than the " + std::to_string(kMaxPixels) + " pixels raylife allows");
  if (j.contains("aperture")) {
    cam.aperture = r.number(j["aperture"], path / "aperture");
    if (!(cam.aperture >= 0 && withinSceneExtent(cam.aperture)))
      r.fail(path / "aperture", std::string("the aperture (the lens radius) must lie in [0, ") + kMaxSceneExtentText +
                                    "], got " + j["aperture"].dump());
  }
  if (j.contains("focus")) {
    cam.focus = r.number(j["focus"], path / "focus");
    if (!(cam.focus > 0 && withinSceneExtent(cam.focus)))
      r.fail(path / "focus", std::string("the focus distance must be greater than 0 and at most ") +
                                 kMaxSceneExtentText + ", got " + j["focus"].dump());
  }
  // (The largest coordinate first, so that the distance neither underflows nor overflows on the way.)
  const Vec3 view = cam.eye - cam.focal;
  const double largest = std::max({std::abs(double(view.x)), std::abs(double(view.y)), std::abs(double(view.z))});
  if (largest > 0 && largest * glm::length(glm::dvec3(view) / largest) < double(Real(kMinSceneLength))) {
    char apart[32];
    std::snprintf(apart, sizeof apart, "%.6g", largest * glm::length(glm::dvec3(view) / largest));
    r.fail(path / "focal", std::string("eye and focal are only ") + apart + " apart, less than raylife's smallest "
                           "length (" + kMinSceneLengthText + ")");
  }
  auto basis = makeCameraBasis(cam.eye, cam.focal, cam.up);
  if (auto* error = std::get_if<BasisError>(&basis))
    r.fail(path / (cam.eye == cam.focal ? "focal" : "up"), error->message); // blame the vector at fault
  cam.basis = std::get<CameraBasis>(basis);
}

// ---- Textures (chapter 14) ------------------------------------------------------------------------------------

// The images the scene's textures and environment name, read once each (by resolved path and encoding) and shared.
struct ImageCache {
  std::string sceneFile;
  std::map<std::pair<std::string, bool>, std::shared_ptr<const TexelImage>> images;

  // The image `file` names (relative to the scene file), read as `encoding`; a fault is the scene's, at `path`.
  std::shared_ptr<const TexelImage> get(const Reader& r, const Json& file, const Path& path, ImageEncoding encoding)
  {
    const std::string name = r.string(file, path);
    if (name.empty())
      r.fail(path, "the file name is empty");
    const std::string resolved = (std::filesystem::path(sceneFile).parent_path() / name).string();
    const auto key = std::make_pair(resolved, encoding == ImageEncoding::Linear);
    if (const auto found = images.find(key); found != images.end())
      return found->second;
    try {
      auto image = std::make_shared<const TexelImage>(readTextureImage(resolved, encoding));
      images.emplace(key, image);
      return image;
    } catch (const ImageFileError& e) {
      r.fail(path, e.what());
    }
  }
};

// A material's "color" or "emission" given as a texture object: { "image": ..., "filter", "linear" } or
// { "checker": { "scale", "even", "odd" } }. Channels at most `maxChannel` (1 for a colour).
TexturePtr readTexture(const Reader& r, const Json& j, const Path& path, Real maxChannel, const char* what,
                       ImageCache& cache)
{
  if (j.contains("checker")) {
    r.onlyKeys(j, path, {"checker"});
    const Path cp = path / "checker";
    const Json& jc = r.object(j["checker"], cp);
    r.onlyKeys(jc, cp, {"scale", "even", "odd"});
    Checker checker;
    if (jc.contains("scale")) {
      checker.scale = r.number(jc["scale"], cp / "scale");
      if (!(checker.scale > 0 && checker.scale <= Real(1e9)))
        r.fail(cp / "scale", "the checker's scale (squares per unit of u and v) must lie in (0, 1e9], got " +
                                 jc["scale"].dump());
    }
    if (jc.contains("even"))
      checker.even = r.color(jc["even"], cp / "even", maxChannel, what);
    if (jc.contains("odd"))
      checker.odd = r.color(jc["odd"], cp / "odd", maxChannel, what);
    return std::make_shared<const Texture>(checker);
  }
  r.onlyKeys(j, path, {"image", "filter", "linear"});
  if (!j.contains("image"))
    r.fail(path, std::string("expected ") + what + " as [r, g, b], { \"image\": \"file\" } or { \"checker\": {...} }");
  TextureFilter filter = TextureFilter::Bilinear;
  if (j.contains("filter")) {
    const std::string f = r.string(j["filter"], path / "filter");
    if (f == "nearest")
      filter = TextureFilter::Nearest;
    else if (f != "bilinear")
      r.fail(path / "filter", "unknown filter '" + shorten(f) + "'; known filters: 'bilinear', 'nearest'");
  }
  bool linear = false;
  if (j.contains("linear")) {
    if (!j["linear"].is_boolean())
      r.fail(path / "linear", "expected true or false, got " + Reader::describe(j["linear"]));
    linear = j["linear"].get<bool>();
  }
  auto image = cache.get(r, j["image"], path / "image", linear ? ImageEncoding::Linear : ImageEncoding::Srgb);
  if (maxChannel <= 1)
    for (float v : image->rgb)
      if (v > 1)
        r.fail(path / "image", std::string("a colour texture's values must lie in [0, 1] (a surface cannot reflect "
                                           "more light than reaches it); the image has ") + std::to_string(v));
  return std::make_shared<const Texture>(std::move(image), filter);
}

Material readMaterial(const Reader& r, const Json& j, const Path& path, const std::string& name, ImageCache& cache)
{
  r.object(j, path);
  Material m;
  m.name = name;
  const std::string type = r.string(r.required(j, path, "type"), path / "type");
  const std::vector<std::string> types = {"diffuse", "mirror", "glass", "glossy", "metal", "interface"};
  if (type == "diffuse")
    m.type = MaterialType::Diffuse;
  else if (type == "mirror")
    m.type = MaterialType::Mirror;
  else if (type == "glass")
    m.type = MaterialType::Glass;
  else if (type == "glossy")
    m.type = MaterialType::Glossy;
  else if (type == "metal")
    m.type = MaterialType::Metal;
  else if (type == "interface")
    m.type = MaterialType::Interface;
  else
    r.fail(path / "type", "unknown material type '" + shorten(type) + "'" + suggestion(type, types) + "; known types: " +
                              joinQuoted(types));

  // Each type takes only the keys that mean something for it, so a misplaced key is caught, not ignored.
  std::vector<std::string> keys = {"type", "color", "emission"};
  if (m.type == MaterialType::Interface) { // chapter 15: a boundary between media, not a surface
    if (j.contains("emission"))
      r.fail(path / "emission", "an interface is not a surface and cannot emit (give the light its own shape)");
    if (j.contains("color"))
      r.fail(path / "color", "an interface is not a surface and has no colour (the media on its sides do the work)");
    keys = {"type"};
  }
  if (m.type == MaterialType::Glass)
    keys.push_back("ior");
  if (m.type == MaterialType::Glossy || m.type == MaterialType::Metal)
    keys.push_back("roughness");
  for (const char* special : {"ior", "roughness"})
    if (j.contains(special) && std::find(keys.begin(), keys.end(), special) == keys.end())
      r.fail(path / special, std::string("'") + special + "' does not apply to a " + type + " material (only to " +
                                 (std::string(special) == "ior" ? "glass" : "glossy and metal") + ")");
  r.onlyKeys(j, path, keys);

  if (j.contains("color") && j["color"].is_object()) { // a texture (chapter 14); the mean for the earlier chapters
    m.colorTexture = readTexture(r, j["color"], path / "color", 1, "a colour", cache);
    m.color = m.colorTexture->mean();
  } else if (j.contains("color")) {
    m.color = r.color(j["color"], path / "color", 1, "a colour");
  }
  if (j.contains("emission") && j["emission"].is_object()) {
    m.emissionTexture = readTexture(r, j["emission"], path / "emission", kInfinity, "emission", cache);
    m.emission = m.emissionTexture->mean();
  } else if (j.contains("emission")) {
    m.emission = r.color(j["emission"], path / "emission", kInfinity, "emission");
  }
  if (j.contains("ior")) {
    m.ior = r.number(j["ior"], path / "ior");
    if (m.ior < 1)
      r.fail(path / "ior", "the index of refraction must be at least 1, got " + j["ior"].dump());
    if (!(m.ior <= kMaxIor))
      r.fail(path / "ior", std::string("the index of refraction must be at most ") +
                               (kMaxIor == kMaxIorFloat ? "1e10 in the float build" : "1e50") +
                               " (diamond's is 2.42), got " + j["ior"].dump());
  }
  if (j.contains("roughness")) {
    m.roughness = r.number(j["roughness"], path / "roughness");
    if (m.type == MaterialType::Metal && !(m.roughness >= 0 && m.roughness <= 1))
      r.fail(path / "roughness", "a metal's roughness (GGX alpha) must lie in [0, 1], got " + j["roughness"].dump());
    if (m.type == MaterialType::Glossy && !(m.roughness > 0 && m.roughness <= 1))
      r.fail(path / "roughness", "roughness must lie in (0, 1], got " + j["roughness"].dump());
  }
  return m;
}

// ---- Meshes -----------------------------------------------------------------------------------------------

// A mesh's "transform": scale, then rotate, then translate.
struct Transform {
  Vec3 scale{1};
  Vec3 axis{0, 0, 1};
  SinCos<Real> rotation{0, 1}; // sin and cos of the angle
  Vec3 translate{0};

  Vec3 rotate(const Vec3& v) const // Rodrigues' formula about the unit axis
  {
    return v * rotation.cos + glm::cross(axis, v) * rotation.sin + axis * (glm::dot(axis, v) * (1 - rotation.cos));
  }
  Vec3 point(const Vec3& p) const { return rotate(p * scale) + translate; }
  // A normal goes through the inverse transpose: for a scale, a division (then it is normalised again).
  Vec3 normal(const Vec3& n) const { return rotate(n / scale); }
  // A negative scale mirrors the mesh, which turns its triangles over: their winding is then reversed.
  bool mirrors() const { return scale.x * scale.y * scale.z < 0; }
};

Transform readTransform(const Reader& r, const Json& j, const Path& path)
{
  r.object(j, path);
  r.onlyKeys(j, path, {"scale", "rotate", "translate"});
  Transform t;
  if (j.contains("scale")) {
    const Json& js = j["scale"];
    t.scale = js.is_array() ? r.vec3(js, path / "scale") : Vec3(r.number(js, path / "scale"));
    if (t.scale.x == 0 || t.scale.y == 0 || t.scale.z == 0)
      r.fail(path / "scale", "a scale of 0 flattens the mesh; every factor must be non-zero, got " + js.dump());
  }
  if (j.contains("rotate")) {
    const Path rp = path / "rotate";
    const Json& jr = r.object(j["rotate"], rp);
    r.onlyKeys(jr, rp, {"axis", "degrees"});
    t.axis = safeNormalize(r.vec3(r.required(jr, rp, "axis"), rp / "axis"), Vec3(0));
    if (t.axis == Vec3(0))
      r.fail(rp / "axis", "the rotation axis must not be zero, got " + jr["axis"].dump());
    const Real degrees = r.number(r.required(jr, rp, "degrees"), rp / "degrees");
    // sin and cos of 2π·u with u = degrees/360 in [0, 1): exact at the quarter turns (a box turned by 90 degrees
    // keeps its corners exactly), which sin and cos of the angle in radians are not.
    Real turn = std::fmod(degrees, Real(360)) / 360;
    if (turn < 0)
      turn += 1;
    t.rotation = sinCos2Pi(std::min(turn, Real(1)));
  }
  if (j.contains("translate"))
    t.translate = r.vec3(j["translate"], path / "translate");
  return t;
}

// The inline form's vertices, triangles and normals.
MeshData readInlineMesh(const Reader& r, const Json& j, const Path& path)
{
  MeshData data;
  const Json& vertices = r.required(j, path, "vertices");
  if (!vertices.is_array() || vertices.size() < 3)
    r.fail(path / "vertices", "expected an array of at least 3 vertices [x, y, z], got " + Reader::describe(vertices));
  data.positions.reserve(vertices.size());
  for (std::size_t v = 0; v < vertices.size(); ++v)
    data.positions.push_back(r.point(vertices[v], path / "vertices" / v));
  const Json& triangles = r.required(j, path, "triangles");
  if (!triangles.is_array() || triangles.empty())
    r.fail(path / "triangles", "expected an array of at least one triangle [i, j, k], got " +
                                   Reader::describe(triangles));
  data.triangles.reserve(triangles.size());
  for (std::size_t k = 0; k < triangles.size(); ++k) {
    const Path tp = path / "triangles" / k;
    if (!triangles[k].is_array() || triangles[k].size() != 3)
      r.fail(tp, "expected a triangle as 3 vertex indices [i, j, k], got " + Reader::describe(triangles[k]));
    std::array<std::uint32_t, 3> tri{};
    for (std::size_t c = 0; c < 3; ++c)
      tri[c] = std::uint32_t(r.wholeNumber(triangles[k][c], tp / c, 0, std::int64_t(vertices.size()) - 1));
    data.triangles.push_back(tri);
  }
  if (j.contains("uvs")) { // texture coordinates (chapter 14): one [u, v] per vertex
    const Json& uvs = j["uvs"];
    if (!uvs.is_array() || uvs.size() != vertices.size())
      r.fail(path / "uvs", "expected one [u, v] per vertex (" + std::to_string(vertices.size()) + "), got " +
                               Reader::describe(uvs));
    for (std::size_t v = 0; v < uvs.size(); ++v) {
      const Path up = path / "uvs" / v;
      if (!uvs[v].is_array() || uvs[v].size() != 2)
        r.fail(up, "expected texture coordinates [u, v], got " + Reader::describe(uvs[v]));
      data.uvs.push_back(Vec2(r.number(uvs[v][0], up / 0), r.number(uvs[v][1], up / 1)));
    }
  }
  if (j.contains("normals")) {
    const Json& normals = j["normals"];
    if (!normals.is_array() || normals.size() != vertices.size())
      r.fail(path / "normals", "expected one normal [x, y, z] per vertex (" + std::to_string(vertices.size()) +
                                   "), got " + Reader::describe(normals));
    for (std::size_t v = 0; v < normals.size(); ++v) {
      const Vec3 n = r.vec3(normals[v], path / "normals" / v);
      if (n == Vec3(0))
        r.fail(path / "normals" / v, "a normal must not be zero");
      data.normals.push_back(n);
    }
  }
  return data;
}

// [vertexNormals]
// Smooth shading's vertex normals: each vertex's is the sum of its triangles' (p1 − p0) × (p2 − p0), whose length
// is twice the triangle's area, so larger triangles weigh more (the area-weighted average), normalised.
std::vector<Vec3> areaWeightedNormals(const std::vector<Vec3>& positions,
                                      const std::vector<std::array<std::uint32_t, 3>>& triangles)
{
  std::vector<Vec3> normals(positions.size(), Vec3(0));
  for (const auto& tri : triangles) {
    const Vec3 n = glm::cross(positions[tri[1]] - positions[tri[0]], positions[tri[2]] - positions[tri[0]]);
    for (std::uint32_t v : tri)
      normals[v] += n;
  }
  for (Vec3& n : normals)
    n = safeNormalize(n, Vec3(0, 0, 1));
  return normals;
}
// [vertexNormals]

// [fromFile]
// A mesh file's own materials (chapter 14's "material": "from-file"), appended to the scene's as the nearest raylife
// material each: Kd (or map_Kd, an image beside the file) a diffuse colour; Ks and Ns a glossy one where the file's
// specular outweighs its diffuse (roughness from the Phong exponent, sqrt(2/(Ns + 2))); Ke an emission. Colours above
// 1 are clamped. One warning line says what was approximated. Returns the index of the first appended material.
int addFileMaterials(const Reader& r, const Path& path, const MeshData& data, const std::filesystem::path& folder,
                     const std::string& file, Scene& scene)
{
  if (data.materials.empty() || data.triangleMaterials.size() != data.triangles.size())
    r.fail(path / "material", "\"from-file\": " + file + " names no materials (an OBJ's mtllib, with its usemtl)");
  const int first = int(scene.materials.size());
  std::size_t glossy = 0, clamped = 0, specularDropped = 0;
  for (const FileMaterial& fm : data.materials) {
    Material m;
    m.name = file + ":" + fm.name;
    const Real kd = maxComponent(fm.diffuse), ks = maxComponent(fm.specular);
    if (ks > kd && ks > Real(0.05)) {
      m.type = MaterialType::Glossy;
      m.color = glm::min(fm.specular, Color(1));
      m.roughness = std::clamp(std::sqrt(2 / (fm.shininess + 2)), Real(1e-3), Real(1));
      ++glossy;
    } else {
      m.color = glm::min(fm.diffuse, Color(1));
      specularDropped += ks > 0;
    }
    clamped += glm::any(glm::greaterThan(fm.diffuse, Color(1))) || glm::any(glm::greaterThan(fm.specular, Color(1)));
    m.emission = fm.emission;
    if (!fm.diffuseMap.empty() && m.type == MaterialType::Diffuse) {
      std::string map = fm.diffuseMap;
      std::replace(map.begin(), map.end(), '\\', '/'); // (Windows separators, as some MTL files have)
      const std::string resolved = (folder / map).string();
      try {
        auto image = std::make_shared<const TexelImage>(readTextureImage(resolved, ImageEncoding::Srgb));
        m.colorTexture = std::make_shared<const Texture>(std::move(image), TextureFilter::Bilinear);
        m.color = m.colorTexture->mean();
      } catch (const ImageFileError& e) {
        r.fail(path / "material", std::string("\"from-file\": material '") + fm.name + "' of " + file + ": " + e.what());
      }
    }
    scene.materials.push_back(std::move(m));
  }
  scene.warnings.push_back(printable(
      r.where(path / "material") + ": " + std::to_string(data.materials.size()) + " materials from " + file +
      ", approximated: " + std::to_string(glossy) + " as glossy (Ks, Ns), " +
      std::to_string(data.materials.size() - glossy) + " as diffuse (Kd, map_Kd; Ks of " +
      std::to_string(specularDropped) + " dropped), Ka and illum ignored" +
      (clamped ? ", " + std::to_string(clamped) + " with colours above 1 clamped" : "")));
  return first;
}
// [fromFile]

// One entry of "meshes": read (from its file or inline), transformed, checked, and appended to the scene.
template <class MaterialOf>
void readMesh(const Reader& r, const Json& j, const Path& path, MaterialOf&& materialOf, Scene& scene,
              const std::string& sceneFile)
{
  r.object(j, path);
  const bool fromFile = j.contains("file");
  if (fromFile && j.contains("vertices"))
    r.fail(path, "a mesh has \"file\" and inline \"vertices\": give one or the other");
  if (fromFile)
    r.onlyKeys(j, path, {"file", "material", "transform", "smooth", "interior", "exterior"});
  else
    r.onlyKeys(j, path, {"vertices", "triangles", "normals", "uvs", "material", "transform", "smooth", "interior",
                         "exterior"});
  if (!fromFile && !j.contains("vertices"))
    r.fail(path, "a mesh needs \"file\" (an .obj or .ply file) or inline \"vertices\" and \"triangles\"");
  Mesh mesh;
  // "from-file" (chapter 14): each part's material is the file's own (an OBJ's MTL), mapped to the nearest raylife one.
  const bool materialsFromFile = fromFile && j.contains("material") && j["material"] == "from-file";
  mesh.material = materialsFromFile ? 0 : materialOf(j, path);
  if (j.contains("smooth")) {
    if (!j["smooth"].is_boolean())
      r.fail(path / "smooth", "expected true or false, got " + Reader::describe(j["smooth"]));
    mesh.smooth = j["smooth"].get<bool>();
  }
  const Transform transform = j.contains("transform") ? readTransform(r, j["transform"], path / "transform")
                                                       : Transform{};
  MeshData data;
  if (fromFile) {
    const std::string file = r.string(j["file"], path / "file");
    if (file.empty())
      r.fail(path / "file", "the file name is empty");
    // Relative to the scene file's folder, so a scene and its models move together.
    const std::filesystem::path resolved = std::filesystem::path(sceneFile).parent_path() / file;
    mesh.source = file;
    try {
      const bool textured = materialsFromFile || scene.materials[std::size_t(mesh.material)].colorTexture ||
                            scene.materials[std::size_t(mesh.material)].emissionTexture;
      data = readMeshFile(resolved.string(), textured, materialsFromFile);
    } catch (const MeshError& e) {
      r.fail(path / "file", e.what());
    }
    if (materialsFromFile)
      mesh.material = addFileMaterials(r, path, data, resolved.parent_path(), file, scene);
  } else {
    mesh.source = "inline";
    data = readInlineMesh(r, j, path);
  }

  // Transform, drop what has no area, and append.
  const auto base = std::uint32_t(scene.vertices.size());
  if (std::uint64_t(base) + data.positions.size() > std::uint64_t(UINT32_MAX))
    r.fail(path, "the scene has more than 4,294,967,295 mesh vertices");
  for (Vec3& p : data.positions) {
    p = transform.point(p);
    if (!isFinite(p))
      r.fail(path / "transform", "the transform takes a vertex beyond the range of " +
                                     std::string(sizeof(Real) == 4 ? "float" : "double"));
    // An inline vertex was checked as it was read; a file's are floats (up to 3.4e38), which may lie beyond the
    // bound themselves, or be taken there by the transform.
    if (!withinSceneExtent(p)) {
      // Named by where it lands: a file's vertices may be renumbered by the reader.
      char at[96];
      std::snprintf(at, sizeof at, "(%.6g, %.6g, %.6g)", double(p.x), double(p.y), double(p.z));
      const std::string beyond = std::string(at) + ", beyond ±" + kMaxSceneExtentText +
                                 " (raylife's bound on a scene's size)";
      if (j.contains("transform"))
        r.fail(path / "transform", "the transform takes a vertex to " + beyond);
      r.fail(path / "file", "a vertex of the file lies at " + beyond + "; a transform's scale can bring it in");
    }
  }
  mesh.firstTriangle = std::uint32_t(scene.triangles.size());
  std::size_t degenerate = 0;
  std::vector<std::array<std::uint32_t, 3>> kept;
  std::vector<int> keptMaterial; // with the file's materials: each kept triangle's index into scene.materials
  kept.reserve(data.triangles.size());
  for (std::size_t k = 0; k < data.triangles.size(); ++k) {
    std::array<std::uint32_t, 3> tri = data.triangles[k];
    if (transform.mirrors())
      std::swap(tri[1], tri[2]);
    // (Below kMinSceneLength² what the tests square and multiply leaves the normal numbers: degenerate too.)
    if (!(triangleDoubleArea(data.positions[tri[0]], data.positions[tri[1]], data.positions[tri[2]]) >=
          Real(kMinSceneLength * kMinSceneLength))) {
      ++degenerate;
      continue;
    }
    kept.push_back(tri);
    if (!data.triangleMaterials.empty())
      keptMaterial.push_back(mesh.material + int(data.triangleMaterials[k]));
  }
  if (kept.empty())
    r.fail(path, "every one of its " + std::to_string(data.triangles.size()) +
                     " triangles is degenerate (no area, or too little: " + kMinSceneLengthText +
                     " is raylife's smallest length): nothing to render");
  if (degenerate > 0)
    scene.warnings.push_back(printable(r.where(path) + ": " + std::to_string(degenerate) +
                                       (degenerate == 1 ? " degenerate triangle" : " degenerate triangles") +
                                       " (area 0, or below the square of raylife's smallest length, " +
                                       kMinSceneLengthText + ") dropped (of " + std::to_string(data.triangles.size()) +
                                       ")"));

  // Smooth shading: the file's normals, transformed, if every one has a direction; else computed from the faces.
  if (mesh.smooth) {
    std::vector<Vec3> normals;
    bool usable = !data.normals.empty();
    for (const Vec3& n : data.normals) {
      normals.push_back(safeNormalize(transform.normal(n), Vec3(0)));
      usable = usable && normals.back() != Vec3(0);
    }
    if (!data.normals.empty() && !usable)
      scene.warnings.push_back(printable(r.where(path) + ": some of its normals are zero or not finite: smooth " +
                                         "normals computed from the faces instead"));
    if (!usable)
      normals = areaWeightedNormals(data.positions, kept);
    scene.vertexNormals.resize(base, Vec3(0));
    scene.vertexNormals.insert(scene.vertexNormals.end(), normals.begin(), normals.end());
  } else if (!scene.vertexNormals.empty()) {
    scene.vertexNormals.resize(base + data.positions.size(), Vec3(0));
  }

  // Texture coordinates (chapter 14), indexed as the vertices; 0 for the meshes without.
  if (!data.uvs.empty() && data.uvs.size() == data.positions.size()) {
    mesh.hasUvs = true;
    scene.vertexUvs.resize(base, Vec2(0));
    scene.vertexUvs.insert(scene.vertexUvs.end(), data.uvs.begin(), data.uvs.end());
  } else if (!scene.vertexUvs.empty()) {
    scene.vertexUvs.resize(base + data.positions.size(), Vec2(0));
  }

  const auto meshIndex = std::uint32_t(scene.meshes.size());
  for (std::size_t k = 0; k < kept.size(); ++k) {
    const auto& tri = kept[k];
    const int material = keptMaterial.empty() ? mesh.material : keptMaterial[k];
    scene.triangles.push_back(Triangle{{base + tri[0], base + tri[1], base + tri[2]}, material, meshIndex});
  }
  scene.vertices.insert(scene.vertices.end(), data.positions.begin(), data.positions.end());
  mesh.triangleCount = std::uint32_t(kept.size());
  scene.meshes.push_back(std::move(mesh));
}

// ---- Participating media (chapter 15) ----

// A coefficient per unit length: a number (grey) or [r, g, b], each finite and ≥ 0.
Color readCoefficient(const Reader& r, const Json& j, const Path& path)
{
  if (j.is_number()) {
    const Real v = r.number(j, path);
    if (v < 0)
      r.fail(path, "a coefficient per unit length must not be negative, got " + j.dump());
    return Color(v);
  }
  return r.color(j, path, kInfinity, "a coefficient per unit length (a number or [r, g, b])");
}

// The scene's media by name, and how a shape names them.
struct SceneMedia {
  const Reader& r;
  std::vector<std::string> names;
  int topLevel = kVacuum;

  // The medium named at `path` (a string, or null for vacuum).
  int lookup(const Json& j, const Path& path) const
  {
    if (j.is_null())
      return kVacuum;
    const std::string name = r.string(j, path);
    const auto found = std::find(names.begin(), names.end(), name);
    if (found == names.end())
      r.fail(path, "undefined medium '" + shorten(name) + "'" + suggestion(name, names) +
                       (names.empty() ? "; the scene defines no \"media\"" : "; defined: " + joinQuoted(names)) +
                       " (null: no medium)");
    return int(found - names.begin());
  }

  // A shape's "interior" (default vacuum) and "exterior" (default the top-level medium).
  MediumInterface interfaceOf(const Json& j, const Path& path) const
  {
    MediumInterface mi;
    mi.changes = true;
    mi.exterior = topLevel;
    if (j.contains("interior"))
      mi.interior = lookup(j["interior"], path / "interior");
    if (j.contains("exterior"))
      mi.exterior = lookup(j["exterior"], path / "exterior");
    return mi;
  }
};

/// Most cells a density grid may have per axis, and the majorant cells along its longest axis (by default, and at
/// most).
constexpr int kMaxDensityCells = 512;
constexpr int kMajorantCells = 32;
constexpr int kMaxMajorantCells = 256;
/// Most tentative collisions (mean free paths at the largest density) a ray across a density grid's box may meet:
/// delta tracking steps once per mean free path, so about this many steps a crossing at worst.
constexpr double kMaxMajorantThickness = 1e9;

// A medium's "density": {"file": "cloud.json", "majorant": "grid" | "global", "majorant_cells": 16}. The file (relative to the scene's
// folder) is JSON: {"resolution": [nx, ny, nz], "bounds": [[x0, y0, z0], [x1, y1, z1]], "density": [nx·ny·nz
// numbers ≥ 0, x fastest]} (docs/scene-format.md; tools/gen_density writes one).
void readDensity(const Reader& r, const Json& j, const Path& path, const std::string& sceneFile, Medium& m)
{
  r.object(j, path);
  r.onlyKeys(j, path, {"file", "majorant", "majorant_cells"});
  const int majorantCells =
      j.contains("majorant_cells") ? r.wholeNumber(j["majorant_cells"], path / "majorant_cells", 1, kMaxMajorantCells)
                                   : kMajorantCells;
  if (j.contains("majorant")) {
    const std::string kind = r.string(j["majorant"], path / "majorant");
    if (kind != "grid" && kind != "global")
      r.fail(path / "majorant", "expected \"grid\" (a coarse grid of maxima) or \"global\" (one maximum), got '" +
                                    shorten(kind) + "'");
    m.globalMajorant = kind == "global";
  }
  const std::string file = r.string(r.required(j, path, "file"), path / "file");
  const std::string resolved = (std::filesystem::path(sceneFile).parent_path() / file).string();
  std::ifstream in(resolved, std::ios::binary);
  if (!in)
    r.fail(path / "file", "cannot open the density file '" + shorten(file) + "': " + std::strerror(errno));
  Json g;
  try {
    g = Json::parse(in);
  } catch (const Json::exception& e) {
    r.fail(path / "file", "the density file '" + shorten(file) + "' is not valid JSON: " + shorten(e.what(), 200));
  }
  auto bad = [&](const std::string& where, const std::string& what) {
    r.fail(path / "file", "the density file '" + shorten(file) + "' at " + where + ": " + what);
  };
  if (!g.is_object())
    bad("/", "expected an object with \"resolution\", \"bounds\" and \"density\"");
  for (auto it = g.begin(); it != g.end(); ++it)
    if (it.key() != "resolution" && it.key() != "bounds" && it.key() != "density")
      bad("/" + it.key(), "unknown key (known: 'resolution', 'bounds', 'density')");
  auto grid = std::make_shared<DensityGrid>();
  const Json& res = g.contains("resolution") ? g["resolution"] : Json();
  if (!res.is_array() || res.size() != 3)
    bad("/resolution", "expected [nx, ny, nz]");
  int n[3];
  for (std::size_t a = 0; a < 3; ++a) {
    if (!res[a].is_number_integer() || res[a].get<std::int64_t>() < 1 || res[a].get<std::int64_t>() > kMaxDensityCells)
      bad("/resolution/" + std::to_string(a), "expected a whole number from 1 to " + std::to_string(kMaxDensityCells));
    n[a] = int(res[a].get<std::int64_t>());
  }
  grid->nx = n[0], grid->ny = n[1], grid->nz = n[2];
  const Json& bounds = g.contains("bounds") ? g["bounds"] : Json();
  if (!bounds.is_array() || bounds.size() != 2)
    bad("/bounds", "expected [[x0, y0, z0], [x1, y1, z1]]");
  for (std::size_t k = 0; k < 2; ++k) {
    if (!bounds[k].is_array() || bounds[k].size() != 3)
      bad("/bounds/" + std::to_string(k), "expected [x, y, z]");
    for (std::size_t a = 0; a < 3; ++a) {
      if (!bounds[k][a].is_number() || !std::isfinite(bounds[k][a].get<double>()) ||
          !withinSceneExtent(Real(bounds[k][a].get<double>())))
        bad("/bounds/" + std::to_string(k) + "/" + std::to_string(a),
            std::string("expected a finite coordinate within +-") + kMaxSceneExtentText);
      (k == 0 ? grid->lo : grid->hi)[int(a)] = Real(bounds[k][a].get<double>());
    }
  }
  for (int a = 0; a < 3; ++a)
    if (!(grid->lo[a] < grid->hi[a]))
      bad("/bounds", "the low corner must lie below the high one on every axis");
  const Json& values = g.contains("density") ? g["density"] : Json();
  const std::size_t count = std::size_t(n[0]) * std::size_t(n[1]) * std::size_t(n[2]);
  if (!values.is_array() || values.size() != count)
    bad("/density", "expected an array of nx*ny*nz = " + std::to_string(count) + " numbers");
  grid->values.resize(count);
  for (std::size_t i = 0; i < count; ++i) {
    if (!values[i].is_number() || !(values[i].get<double>() >= 0) || !std::isfinite(values[i].get<float>()))
      bad("/density/" + std::to_string(i), "a density must be a finite number >= 0");
    grid->values[i] = values[i].get<float>();
  }
  grid->buildMajorants(majorantCells);
  // Delta and ratio tracking take a step per mean free path at the majorant, so a ray across the box at its densest
  // takes about (its optical thickness there) steps: bounded here, with the rate itself, so that every tracking loop
  // ends in that many steps and its sums stay finite (a rate that overflowed had stalled them for ever).
  const Color sigmaT = m.sigmaT();
  const Real sMax = std::max({sigmaT.r, sigmaT.g, sigmaT.b});
  const Real rate = sMax * grid->globalMajorant;
  const double diagonal = grid->diagonal();
  const double thickness = double(sMax) * double(grid->globalMajorant) * diagonal;
  auto g3 = [](double v) {
    char text[32];
    std::snprintf(text, sizeof text, "%.3g", v);
    return std::string(text);
  };
  if (!std::isfinite(Real(3) * rate))
    r.fail(path, "sigma_t (" + g3(double(sMax)) + ", the largest channel of sigma_a + sigma_s) times the largest "
                 "density (" + g3(double(grid->globalMajorant)) + ") is beyond the range of the renderer's numbers; "
                 "lower sigma_a, sigma_s or the densities");
  if (!(thickness <= kMaxMajorantThickness))
    r.fail(path, "a ray across the density box at its densest would meet " + g3(thickness) +
                     " tentative collisions (sigma_t " + g3(double(sMax)) + " x density " +
                     g3(double(grid->globalMajorant)) + " x the box's diagonal " + g3(diagonal) +
                     "), and delta tracking takes a step for each: at most " + g3(kMaxMajorantThickness) +
                     " are allowed; lower sigma_a, sigma_s or the densities");
  m.density = std::move(grid);
}

// "media", "medium" and "camera.medium".
SceneMedia readMedia(const Reader& r, const Json& root, const Path& top, Scene& scene, const std::string& sceneFile)
{
  SceneMedia out{r, {}, kVacuum};
  if (root.contains("media")) {
    const Json& media = r.object(root["media"], top / "media");
    for (auto it = media.begin(); it != media.end(); ++it) {
      const Path p = top / "media" / it.key();
      const Json& jm = r.object(it.value(), p);
      r.onlyKeys(jm, p, {"sigma_a", "sigma_s", "g", "density"});
      Medium m;
      m.name = it.key();
      if (jm.contains("sigma_a"))
        m.sigmaA = readCoefficient(r, jm["sigma_a"], p / "sigma_a");
      if (jm.contains("sigma_s"))
        m.sigmaS = readCoefficient(r, jm["sigma_s"], p / "sigma_s");
      if (jm.contains("g")) {
        m.g = r.number(jm["g"], p / "g");
        if (!(m.g > -1 && m.g < 1))
          r.fail(p / "g", "the Henyey-Greenstein g must lie strictly between -1 and 1, got " + jm["g"].dump());
      }
      if (jm.contains("density"))
        readDensity(r, jm["density"], p / "density", sceneFile, m);
      scene.media.push_back(m);
      out.names.push_back(it.key());
    }
  }
  if (root.contains("medium"))
    out.topLevel = out.lookup(root["medium"], top / "medium");
  scene.medium = out.topLevel;
  scene.cameraMedium = out.topLevel;
  if (const Json& cam = root.at("camera"); cam.contains("medium"))
    scene.cameraMedium = out.lookup(cam["medium"], top / "camera" / "medium");
  return out;
}

// A medium fills the inside of a closed surface: the mesh just read must be closed (every edge shared by exactly
// two triangles, matched by vertex position, as files split vertices at seams) and wound consistently. Its media,
// swapped when the triangles wind inwards (a negative signed volume), so that exterior lies on the normal's side.
MediumInterface closedMeshMedia(const Reader& r, const Path& path, const Scene& scene, MediumInterface mi)
{
  const Mesh& mesh = scene.meshes.back();
  struct Key {
    Vec3 p;
    bool operator==(const Key& o) const { return p == o.p; }
  };
  struct KeyHash {
    std::size_t operator()(const Key& k) const
    {
      const std::hash<Real> h;
      return h(k.p.x) ^ (h(k.p.y) * 0x9E3779B97F4A7C15ULL) ^ (h(k.p.z) * 0xC2B2AE3D27D4EB4FULL);
    }
  };
  std::unordered_map<Key, std::uint32_t, KeyHash> ids; // position -> its canonical id
  auto id = [&](std::uint32_t v) { return ids.emplace(Key{scene.vertices[v]}, std::uint32_t(ids.size())).first->second; };
  std::unordered_map<std::uint64_t, int> directed; // (a, b) -> times an edge runs from a to b
  double volume = 0;
  for (std::uint32_t k = 0; k < mesh.triangleCount; ++k) {
    const Triangle& tri = scene.triangles[mesh.firstTriangle + k];
    const std::uint32_t v[3] = {id(tri.v[0]), id(tri.v[1]), id(tri.v[2])};
    for (int e = 0; e < 3; ++e)
      ++directed[(std::uint64_t(v[e]) << 32) | v[(e + 1) % 3]];
    const auto [p0, p1, p2] = scene.triangleVertices(mesh.firstTriangle + k);
    volume += double(glm::dot(p0, glm::cross(p1, p2)));
  }
  for (const auto& [edge, count] : directed) {
    const auto a = std::uint32_t(edge >> 32), b = std::uint32_t(edge);
    const auto reverse = directed.find((std::uint64_t(b) << 32) | a);
    const int back = reverse == directed.end() ? 0 : reverse->second;
    if (count == 1 && back == 1)
      continue;
    std::string why = back == 0 ? "an edge belongs to one triangle only: the mesh is open"
                                : "an edge is shared by more than two triangles, or by two wound the same way";
    r.fail(path / "interior", why + "; a medium fills only the inside of a closed, consistently wound surface "
                                    "(\"interior\" and \"exterior\" need one)");
  }
  if (volume < 0)
    std::swap(mi.interior, mi.exterior);
  return mi;
}

// A camera that the loader can see is inside a sphere with media while camera.medium says otherwise: a warning
// naming both (the innermost such sphere at time 0 decides).
void warnCameraMedium(const Reader& r, const Path& top, Scene& scene)
{
  int inside = -1;
  for (std::size_t i = 0; i < scene.sphereMedia.size(); ++i) {
    const Sphere& s = scene.spheres[i];
    if (scene.sphereMedia[i].changes && glm::length(scene.camera.eye - s.center) < s.radius &&
        (inside < 0 || s.radius < scene.spheres[std::size_t(inside)].radius))
      inside = int(i);
  }
  if (inside < 0 || scene.sphereMedia[std::size_t(inside)].interior == scene.cameraMedium)
    return;
  auto name = [&](int m) { return m == kVacuum ? std::string("no medium") : "'" + scene.media[std::size_t(m)].name + "'"; };
  scene.warnings.push_back(printable(
      r.where(top / "camera" / "eye") + ": the camera is inside /spheres/" + std::to_string(inside) +
      ", whose interior is " + name(scene.sphereMedia[std::size_t(inside)].interior) + ", but camera.medium (or " +
      "the top-level medium) puts it in " + name(scene.cameraMedium) + "; set \"camera\": {\"medium\": ...} to say " +
      "where it is"));
}

} // namespace

namespace {
// parseScene without the accelerator. The callers build it once the JSON tree is gone (and loadScene once the text is
// too): with 100,000 spheres the two take about 28 MB, more than the scene and its tree, and the tree's build has
// its own scratch on top.
Scene readScene(std::string_view text, const std::string& fileName, bool sizeGiven = false)
{
  auto failAt = [&](std::size_t offset, const std::string& what) {
    throw SceneError(printable(fileName + ":" + lineColumn(text, offset) + ": " + what));
  };
  // Faults of the text itself first: a NUL byte (nlohmann/json would take it as the end), an empty file.
  if (const std::size_t nul = text.find('\0'); nul != std::string_view::npos)
    failAt(nul, "the file contains a NUL byte: a scene file is JSON text");
  if (text.find_first_not_of(" \t\r\n") == std::string_view::npos)
    failAt(text.size(), "the file is empty: expected a JSON object such as {\"camera\": {...}, \"spheres\": [...]}");

  Json root;
  try {
    root = Json::parse(text.begin(), text.end());
  } catch (const Json::parse_error& e) {
    // e.byte is one past the offending character (1-based); report the line and column of that character, or
    // of the start of the offending string when it is a string (nlohmann stops at its closing quote).
    std::size_t offset = std::min(e.byte > 0 ? e.byte - 1 : 0, text.size());
    if (offset < text.size() && offset > 0 && text[offset] == '"' &&
        std::string_view(e.what()).find("unexpected string literal") != std::string_view::npos) {
      std::size_t open = offset - 1;
      auto escaped = [&](std::size_t at) { // preceded by an odd number of backslashes
        std::size_t n = 0;
        while (at > n && text[at - n - 1] == '\\')
          ++n;
        return n % 2 == 1;
      };
      while (open > 0 && !(text[open] == '"' && !escaped(open)))
        --open;
      offset = open;
    }
    std::string what = e.what();
    // nlohmann's message reads "[json.exception.parse_error.101] parse error at line 3, column 5: <detail>".
    const std::size_t colon = what.find(": ");
    std::string detail = colon != std::string::npos ? what.substr(colon + 2) : what;
    // "...; last read: '<the token so far>'; expected ...": the token may be the rest of the file; shorten it.
    // The token may itself hold "'; expected": the real clause is the last one, and short ("'; expected '}'").
    if (const std::size_t read = detail.find("last read: '"); read != std::string::npos) {
      const std::size_t start = read + 12;
      std::size_t end = detail.rfind("'; expected ");
      if (end == std::string::npos || end < start || detail.size() - end > 40)
        end = detail.size() - 1;
      if (end > start)
        detail.replace(start, end - start, shorten(std::string_view(detail).substr(start, end - start)));
    }
    failAt(offset, "malformed JSON: " + shorten(detail, 400)); // (and never a page long, whatever nlohmann says)
  } catch (const Json::exception& e) {
    // A number too large for a double (out_of_range.406) comes without a position: find it in the text.
    if (const std::optional<TextFault> fault = scanText(text))
      failAt(fault->offset, fault->path + ": " + fault->message);
    throw SceneError(printable(fileName + ": malformed JSON: " + e.what()));
  }
  // What nlohmann/json accepts but a scene must not have: deep nesting, a key given twice, numbers out of range.
  if (const std::optional<TextFault> fault = scanText(text))
    failAt(fault->offset, fault->path + ": " + fault->message);

  const Reader r(text, fileName);
  const Path top;
  Scene scene;
  scene.fileName = fileName;
  r.object(root, top);
  r.onlyKeys(root, top,
             {"camera", "background", "ambient", "materials", "spheres", "meshes", "lights", "environment", "media",
              "medium"});
  ImageCache images{fileName, {}};

  readCamera(r, r.required(root, top, "camera"), top / "camera", scene.camera, sizeGiven);
  if (root.contains("background"))
    scene.background = r.color(root["background"], top / "background", kInfinity, "background radiance");
  if (root.contains("ambient"))
    scene.ambient = r.color(root["ambient"], top / "ambient", kInfinity, "ambient radiance");
  if (root.contains("environment")) { // chapter 14: an equirectangular map instead of the background
    const Path ep = top / "environment";
    if (root.contains("background"))
      r.fail(ep, "the scene gives \"background\" and \"environment\": give one or the other");
    const Json& je = r.object(root["environment"], ep);
    r.onlyKeys(je, ep, {"file", "scale", "rotate"});
    auto image = images.get(r, r.required(je, ep, "file"), ep / "file", ImageEncoding::Linear);
    Real scale = 1, rotate = 0;
    if (je.contains("scale")) {
      scale = r.number(je["scale"], ep / "scale");
      if (!(scale >= 0 && scale <= Real(1e30)))
        r.fail(ep / "scale", "the scale must lie in [0, 1e30], got " + je["scale"].dump());
    }
    if (je.contains("rotate"))
      rotate = r.number(je["rotate"], ep / "rotate");
    scene.environment = std::make_shared<const EnvironmentMap>(std::move(image), scale, rotate);
  }

  // Materials: an object of name → material; order of the names gives the indices.
  std::vector<std::string> materialNames;
  if (root.contains("materials")) {
    const Json& mats = r.object(root["materials"], top / "materials");
    for (auto it = mats.begin(); it != mats.end(); ++it) {
      scene.materials.push_back(readMaterial(r, it.value(), top / "materials" / it.key(), it.key(), images));
      materialNames.push_back(it.key());
    }
  }

  // Participating media (chapter 15): before the shapes, which name them.
  const SceneMedia mediaOf = readMedia(r, root, top, scene, fileName);

  // Spheres (optional: a scene needs at least one sphere or one triangle).
  std::unordered_map<std::string, int> materialIndex; // name -> index, so a large scene loads in linear time
  for (std::size_t i = 0; i < materialNames.size(); ++i)
    materialIndex.emplace(materialNames[i], int(i));
  std::vector<bool> used(materialNames.size(), false);
  // The material a sphere or mesh names under `p`/"material".
  auto material = [&](const Json& j, const Path& p) {
    const std::string name = r.string(r.required(j, p, "material"), p / "material");
    const auto found = materialIndex.find(name);
    if (found == materialIndex.end())
      r.fail(p / "material", "undefined material '" + shorten(name) + "'" + suggestion(name, materialNames) +
                                 (materialNames.empty() ? "; the scene defines no materials"
                                                        : "; defined: " + joinQuoted(materialNames)));
    used[std::size_t(found->second)] = true;
    return found->second;
  };
  if (root.contains("spheres")) {
    const Json& spheres = root["spheres"];
    if (!spheres.is_array())
      r.fail(top / "spheres", "expected an array of spheres, got " + Reader::describe(spheres));
    for (std::size_t i = 0; i < spheres.size(); ++i) {
      const Path p = top / "spheres" / i;
      const Json& js = r.object(spheres[i], p);
      r.onlyKeys(js, p, {"center", "radius", "material", "velocity", "rotate", "interior", "exterior"});
      Sphere s;
      s.center = r.point(r.required(js, p, "center"), p / "center");
      s.radius = r.number(r.required(js, p, "radius"), p / "radius");
      if (!(s.radius > 0))
        r.fail(p / "radius", "the radius must be greater than 0, got " + js["radius"].dump());
      if (s.radius < Real(kMinSceneLength))
        r.fail(p / "radius", std::string("the radius must be at least ") + kMinSceneLengthText +
                                 " (raylife's smallest length), got " + js["radius"].dump());
      if (!withinSceneExtent(s.radius))
        r.fail(p / "radius", std::string("the radius must be at most ") + kMaxSceneExtentText +
                                 " (raylife's bound on a scene's size), got " + js["radius"].dump());
      s.material = material(js, p);
      if (js.contains("velocity")) {
        s.velocity = r.vec3(js["velocity"], p / "velocity");
        if (!withinSceneExtent(s.center + s.velocity))
          r.fail(p / "velocity", std::string("the sphere's centre at the end of the shutter interval (center + "
                                             "velocity) lies beyond ±") +
                                     kMaxSceneExtentText + " (raylife's bound on a scene's size)");
      }
      if (js.contains("rotate")) { // its texture turned about +y (chapter 14), in degrees
        const Real angle = r.number(js["rotate"], p / "rotate") * kPi / 180;
        scene.sphereUvRotation.resize(scene.spheres.size(), SinCos<Real>{0, 1});
        scene.sphereUvRotation.push_back(SinCos<Real>{std::sin(angle), std::cos(angle)});
      } else if (!scene.sphereUvRotation.empty()) {
        scene.sphereUvRotation.push_back(SinCos<Real>{0, 1});
      }
      scene.spheres.push_back(s);
      if (js.contains("interior") || js.contains("exterior")) {
        scene.sphereMedia.resize(spheres.size());
        scene.sphereMedia[i] = mediaOf.interfaceOf(js, p);
      }
    }
  }

  // Meshes.
  if (root.contains("meshes")) {
    const Json& meshes = root["meshes"];
    if (!meshes.is_array())
      r.fail(top / "meshes", "expected an array of meshes, got " + Reader::describe(meshes));
    for (std::size_t i = 0; i < meshes.size(); ++i) {
      readMesh(r, meshes[i], top / "meshes" / i, material, scene, fileName);
      if (meshes[i].contains("interior") || meshes[i].contains("exterior")) {
        scene.meshMedia.resize(meshes.size());
        scene.meshMedia[i] = closedMeshMedia(r, top / "meshes" / i, scene, mediaOf.interfaceOf(meshes[i], top / "meshes" / i));
      }
    }
  }
  warnCameraMedium(r, top, scene);
  if (scene.spheres.empty() && scene.triangles.empty())
    r.fail(root.contains("spheres") ? top / "spheres" : top,
           "the scene is empty: give at least one sphere (\"spheres\") or one mesh (\"meshes\")");
  if (scene.primitiveCount() > kMaxPrimitives)
    r.fail(top / "meshes", "the scene has " + std::to_string(scene.primitiveCount()) + " spheres and triangles, more " +
                               "than the " + std::to_string(kMaxPrimitives) + " raylife allows");

  // Lights.
  if (root.contains("lights")) {
    const Json& lights = root["lights"];
    if (!lights.is_array())
      r.fail(top / "lights", "expected an array of lights, got " + Reader::describe(lights));
    for (std::size_t i = 0; i < lights.size(); ++i) {
      const Path p = top / "lights" / i;
      const Json& jl = r.object(lights[i], p);
      r.onlyKeys(jl, p, {"type", "position", "intensity"});
      const std::string type = r.string(r.required(jl, p, "type"), p / "type");
      if (type != "point")
        r.fail(p / "type", "unknown light type '" + shorten(type) + "'; known types: 'point' (for area lights, give a "
                                                            "sphere a material with \"emission\")");
      PointLight l;
      l.position = r.point(r.required(jl, p, "position"), p / "position");
      l.intensity = r.color(r.required(jl, p, "intensity"), p / "intensity", kInfinity, "intensity");
      scene.lights.push_back(l);
    }
  }

  // An unused material is only a warning: one per material for the first few, then one line for the rest.
  constexpr std::size_t kMaxUnusedWarnings = 5;
  std::size_t unused = 0;
  for (std::size_t i = 0; i < materialNames.size(); ++i)
    if (!used[i] && ++unused <= kMaxUnusedWarnings)
      scene.warnings.push_back(printable(r.where(top / "materials" / materialNames[i]) + ": material '" +
                                         shorten(materialNames[i]) + "' is defined but no sphere or mesh uses it"));
  if (unused > kMaxUnusedWarnings)
    scene.warnings.push_back(printable(fileName + ": /materials: " + std::to_string(unused - kMaxUnusedWarnings) +
                                       " more materials are defined but no sphere or mesh uses them"));
  return scene;
}
} // namespace

Scene parseScene(std::string_view text, const std::string& fileName)
{
  Scene scene = readScene(text, fileName);
  scene.buildAccelerator();
  return scene;
}

Scene loadScene(const std::string& path, bool sizeGiven)
{
  // Say plainly what is wrong with a path that is not a readable file, before JSON has a chance to.
  namespace fs = std::filesystem;
  std::error_code ec;
  const fs::file_status status = fs::status(path, ec);
  if (fs::is_directory(status))
    throw SceneError(printable(path + ": is a folder, not a scene file"));
  std::ifstream in(path, std::ios::binary);
  if (!in)
    throw SceneError(printable(path + ": cannot open the scene file: " + std::strerror(errno)));
  // Read at most kMaxSceneBytes (+1 to notice a larger file): /dev/zero or a runaway file cannot exhaust memory.
  std::string text;
  char buffer[65536];
  while (in.read(buffer, sizeof buffer) || in.gcount() > 0) {
    text.append(buffer, std::size_t(in.gcount()));
    if (text.size() > kMaxSceneBytes)
      throw SceneError(printable(path + ": the scene file is larger than " + std::to_string(kMaxSceneBytes >> 20) +
                                 " MiB; a scene file is a small JSON text"));
  }
  if (in.bad())
    throw SceneError(printable(path + ": cannot read the scene file: " + std::strerror(errno)));
  Scene scene = readScene(text, path, sizeGiven);
  std::string().swap(text); // the text's memory back before the tree's build needs its own
  scene.buildAccelerator();
  return scene;
}

} // namespace raylife

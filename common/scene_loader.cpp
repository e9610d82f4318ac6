// The scene file loader: JSON (nlohmann/json) → a validated Scene. Every key is checked; every fault is reported
// once, as "FILE:LINE:COLUMN: /json/path: what is wrong", and nothing is half-loaded.
#include "scene.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <fstream>
#include <set>
#include <sstream>

namespace raylife {

namespace {

// ordered_json keeps the file's order, so material indices and messages follow the file.
using Json = nlohmann::ordered_json;

// ---- Where in the text a JSON path points, for line:column in messages --------------------------------------
// nlohmann/json keeps no source positions, so this small scanner walks the (already valid) text to the value
// a path names. It returns npos if it cannot follow the path; messages then carry the path alone.
class Locator {
public:
  explicit Locator(std::string_view text) : text_(text) {}

  std::size_t find(const std::vector<std::string>& path) const
  {
    std::size_t pos = skipSpace(0);
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
      const std::string_view name = text_.substr(pos + 1, keyEnd - pos - 2);
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

std::string lineColumn(std::string_view text, std::size_t offset)
{
  std::size_t line = 1, column = 1;
  for (std::size_t i = 0; i < offset && i < text.size(); ++i) {
    if (text[i] == '\n') {
      ++line;
      column = 1;
    } else {
      ++column;
    }
  }
  return std::to_string(line) + ":" + std::to_string(column);
}

std::size_t editDistance(std::string_view a, std::string_view b)
{
  std::vector<std::size_t> row(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j)
    row[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    std::size_t diagonal = row[0];
    row[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t above = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (a[i - 1] == b[j - 1] ? 0 : 1)});
      diagonal = above;
    }
  }
  return row[b.size()];
}

// " (did you mean 'x'?)" for the nearest candidate within a small edit distance, else "".
std::string suggestion(std::string_view word, const std::vector<std::string>& candidates)
{
  std::string best;
  std::size_t bestDistance = std::max<std::size_t>(2, word.size() / 3) + 1;
  for (const std::string& c : candidates) {
    const std::size_t d = editDistance(word, c);
    if (d < bestDistance) {
      bestDistance = d;
      best = c;
    }
  }
  return best.empty() ? "" : " (did you mean '" + best + "'?)";
}

std::string joinQuoted(const std::vector<std::string>& words)
{
  std::string out;
  for (std::size_t i = 0; i < words.size(); ++i)
    out += (i ? ", '" : "'") + words[i] + "'";
  return out;
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
      for (const std::string& t : tokens)
        s += "/" + t;
      return s.empty() ? "/" : s;
    }
  };

  [[noreturn]] void fail(const Path& path, const std::string& message) const
  {
    // Point at the value's position in the text, or at its parent's when the value is missing.
    std::vector<std::string> tokens = path.tokens;
    std::size_t offset = Locator::npos;
    while (true) {
      offset = Locator(text_).find(tokens);
      if (offset != Locator::npos || tokens.empty())
        break;
      tokens.pop_back();
    }
    const std::string where = offset != Locator::npos ? lineColumn(text_, offset) + ": " : "";
    throw SceneError(file_ + ":" + where + path.str() + ": " + message);
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
        fail(path / it.key(), "unknown key '" + it.key() + "'" + suggestion(it.key(), known) +
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
    if (!j.is_number_integer())
      fail(path, "expected a whole number, got " + describe(j));
    // nlohmann stores non-negative integers as unsigned: compare without converting a huge one to int64.
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

void readCamera(const Reader& r, const Json& j, const Path& path, CameraSpec& cam)
{
  r.object(j, path);
  r.onlyKeys(j, path, {"eye", "focal", "up", "vfov", "width", "height"});
  cam.eye = r.vec3(r.required(j, path, "eye"), path / "eye");
  cam.focal = r.vec3(r.required(j, path, "focal"), path / "focal");
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
  if (std::int64_t(cam.width) * cam.height > kMaxPixels)
    r.fail(path / "width", "an image of " + std::to_string(cam.width) + "x" + std::to_string(cam.height) +
                               " pixels is larger than the " + std::to_string(kMaxPixels) + " pixels raylife allows");
  auto basis = makeCameraBasis(cam.eye, cam.focal, cam.up);
  if (auto* error = std::get_if<BasisError>(&basis))
    r.fail(path / "up", error->message);
  cam.basis = std::get<CameraBasis>(basis);
}

Material readMaterial(const Reader& r, const Json& j, const Path& path, const std::string& name)
{
  r.object(j, path);
  Material m;
  m.name = name;
  const std::string type = r.string(r.required(j, path, "type"), path / "type");
  const std::vector<std::string> types = {"diffuse", "mirror", "glass", "glossy"};
  if (type == "diffuse")
    m.type = MaterialType::Diffuse;
  else if (type == "mirror")
    m.type = MaterialType::Mirror;
  else if (type == "glass")
    m.type = MaterialType::Glass;
  else if (type == "glossy")
    m.type = MaterialType::Glossy;
  else
    r.fail(path / "type", "unknown material type '" + type + "'" + suggestion(type, types) + "; known types: " +
                              joinQuoted(types));

  // Each type takes only the keys that mean something for it, so a misplaced key is caught, not ignored.
  std::vector<std::string> keys = {"type", "color", "emission"};
  if (m.type == MaterialType::Glass)
    keys.push_back("ior");
  if (m.type == MaterialType::Glossy)
    keys.push_back("roughness");
  for (const char* special : {"ior", "roughness"})
    if (j.contains(special) && std::find(keys.begin(), keys.end(), special) == keys.end())
      r.fail(path / special, std::string("'") + special + "' does not apply to a " + type + " material (only to " +
                                 (std::string(special) == "ior" ? "glass" : "glossy") + ")");
  r.onlyKeys(j, path, keys);

  if (j.contains("color"))
    m.color = r.color(j["color"], path / "color", 1, "a colour");
  if (j.contains("emission"))
    m.emission = r.color(j["emission"], path / "emission", kInfinity, "emission");
  if (j.contains("ior")) {
    m.ior = r.number(j["ior"], path / "ior");
    if (m.ior < 1)
      r.fail(path / "ior", "the index of refraction must be at least 1, got " + j["ior"].dump());
  }
  if (j.contains("roughness")) {
    m.roughness = r.number(j["roughness"], path / "roughness");
    if (!(m.roughness > 0 && m.roughness <= 1))
      r.fail(path / "roughness", "roughness must lie in (0, 1], got " + j["roughness"].dump());
  }
  return m;
}

} // namespace

Scene parseScene(std::string_view text, const std::string& fileName)
{
  Json root;
  try {
    root = Json::parse(text.begin(), text.end());
  } catch (const Json::parse_error& e) {
    // e.byte is one past the offending character (1-based); report the line and column of that character.
    const std::size_t offset = e.byte > 0 ? e.byte - 1 : 0;
    std::string what = e.what();
    // nlohmann's message reads "[json.exception.parse_error.101] parse error at line 3, column 5: <detail>".
    const std::size_t colon = what.find(": ");
    const std::string detail = colon != std::string::npos ? what.substr(colon + 2) : what;
    throw SceneError(fileName + ":" + lineColumn(text, offset) + ": malformed JSON: " + detail);
  }

  const Reader r(text, fileName);
  const Path top;
  Scene scene;
  scene.fileName = fileName;
  r.object(root, top);
  r.onlyKeys(root, top, {"camera", "background", "ambient", "materials", "spheres", "lights"});

  readCamera(r, r.required(root, top, "camera"), top / "camera", scene.camera);
  if (root.contains("background"))
    scene.background = r.color(root["background"], top / "background", kInfinity, "background radiance");
  if (root.contains("ambient"))
    scene.ambient = r.color(root["ambient"], top / "ambient", kInfinity, "ambient radiance");

  // Materials: an object of name → material; order of the names gives the indices.
  std::vector<std::string> materialNames;
  if (root.contains("materials")) {
    const Json& mats = r.object(root["materials"], top / "materials");
    for (auto it = mats.begin(); it != mats.end(); ++it) {
      scene.materials.push_back(readMaterial(r, it.value(), top / "materials" / it.key(), it.key()));
      materialNames.push_back(it.key());
    }
  }

  // Spheres.
  const Json& spheres = r.required(root, top, "spheres");
  if (!spheres.is_array())
    r.fail(top / "spheres", "expected an array of spheres, got " + Reader::describe(spheres));
  if (spheres.empty())
    r.fail(top / "spheres", "the scene is empty: give at least one sphere");
  std::set<int> used;
  for (std::size_t i = 0; i < spheres.size(); ++i) {
    const Path p = top / "spheres" / i;
    const Json& js = r.object(spheres[i], p);
    r.onlyKeys(js, p, {"center", "radius", "material"});
    Sphere s;
    s.center = r.vec3(r.required(js, p, "center"), p / "center");
    s.radius = r.number(r.required(js, p, "radius"), p / "radius");
    if (!(s.radius > 0))
      r.fail(p / "radius", "the radius must be greater than 0, got " + js["radius"].dump());
    const std::string name = r.string(r.required(js, p, "material"), p / "material");
    auto found = std::find(materialNames.begin(), materialNames.end(), name);
    if (found == materialNames.end())
      r.fail(p / "material", "undefined material '" + name + "'" + suggestion(name, materialNames) +
                                 (materialNames.empty() ? "; the scene defines no materials"
                                                        : "; defined: " + joinQuoted(materialNames)));
    s.material = int(found - materialNames.begin());
    used.insert(s.material);
    scene.spheres.push_back(s);
  }

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
        r.fail(p / "type", "unknown light type '" + type + "'; known types: 'point' (for area lights, give a "
                                                            "sphere a material with \"emission\")");
      PointLight l;
      l.position = r.vec3(r.required(jl, p, "position"), p / "position");
      l.intensity = r.color(r.required(jl, p, "intensity"), p / "intensity", kInfinity, "intensity");
      scene.lights.push_back(l);
    }
  }

  for (std::size_t i = 0; i < materialNames.size(); ++i)
    if (!used.count(int(i)))
      scene.warnings.push_back(fileName + ": /materials/" + materialNames[i] + ": material '" + materialNames[i] +
                               "' is defined but no sphere uses it");
  scene.buildAccelerator();
  return scene;
}

Scene loadScene(const std::string& path)
{
  std::ifstream in(path, std::ios::binary);
  if (!in)
    throw SceneError(path + ": cannot open the scene file: " + std::strerror(errno));
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad())
    throw SceneError(path + ": cannot read the scene file");
  return parseScene(text.str(), path);
}

} // namespace raylife

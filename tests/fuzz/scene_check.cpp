#include "scene_check.h"

#include "scene/scene.h"

#include <cmath>

namespace raylife::fuzz {

namespace {

bool finite(const Vec3& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }
bool nonNegative(const Color& c) { return finite(c) && c.r >= 0 && c.g >= 0 && c.b >= 0; }

// True when `s` is valid UTF-8 with no control characters: safe to print on one terminal line.
bool printableLine(const std::string& s)
{
  for (std::size_t i = 0; i < s.size();) {
    const auto c = static_cast<unsigned char>(s[i]);
    if (c < 0x20 || c == 0x7f)
      return false;
    std::size_t n = c < 0x80 ? 1 : (c >> 5) == 0x6 ? 2 : (c >> 4) == 0xe ? 3 : (c >> 3) == 0x1e ? 4 : 0;
    if (n == 0 || i + n > s.size())
      return false;
    for (std::size_t k = 1; k < n; ++k)
      if ((static_cast<unsigned char>(s[i + k]) >> 6) != 0x2)
        return false;
    i += n;
  }
  return true;
}

} // namespace

std::string checkSceneText(std::string_view text)
{
  Scene scene;
  try {
    scene = parseScene(text, "fuzz.json");
  } catch (const SceneError& e) {
    const std::string message = e.what();
    if (message.rfind("fuzz.json:", 0) != 0)
      return "the message does not start with the file name: " + message;
    if (!printableLine(message))
      return "the message is not one printable UTF-8 line";
    if (message.size() > 2000)
      return "the message is longer than 2000 characters";
    return "";
  }
  if (scene.spheres.empty())
    return "a scene without spheres was accepted";
  for (const Sphere& s : scene.spheres) {
    if (!finite(s.center) || !(s.radius > 0) || !std::isfinite(s.radius))
      return "a sphere with a bad centre or radius was accepted";
    if (s.material < 0 || std::size_t(s.material) >= scene.materials.size())
      return "a sphere's material index is out of range";
  }
  for (const Material& m : scene.materials)
    if (!nonNegative(m.color) || !nonNegative(m.emission) || !(m.ior >= 1) || !std::isfinite(m.ior) ||
        !(m.roughness > 0 && m.roughness <= 1))
      return "material '" + m.name + "' has a value out of range";
  for (const PointLight& l : scene.lights)
    if (!finite(l.position) || !nonNegative(l.intensity))
      return "a light has a bad position or intensity";
  if (!nonNegative(scene.background) || !nonNegative(scene.ambient))
    return "a bad background or ambient term was accepted";
  const CameraSpec& c = scene.camera;
  if (c.width < 1 || c.height < 1 || std::int64_t(c.width) * c.height > kMaxPixels)
    return "an image size out of range was accepted";
  if (!(c.vfovDeg > 0 && c.vfovDeg < 180))
    return "a field of view out of range was accepted";
  if (!finite(c.eye) || !finite(c.basis.u) || !finite(c.basis.v) || !finite(c.basis.w))
    return "a camera with a non-finite eye or basis was accepted";
  const Real tolerance = Real(1e-3);
  if (std::abs(glm::length(c.basis.u) - 1) > tolerance || std::abs(glm::length(c.basis.v) - 1) > tolerance ||
      std::abs(glm::length(c.basis.w) - 1) > tolerance || std::abs(glm::dot(c.basis.u, c.basis.v)) > tolerance ||
      std::abs(glm::dot(c.basis.v, c.basis.w)) > tolerance || std::abs(glm::dot(c.basis.u, c.basis.w)) > tolerance)
    return "a camera basis that is not orthonormal was accepted";
  return "";
}

} // namespace raylife::fuzz

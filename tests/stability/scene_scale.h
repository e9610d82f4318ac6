/// @file scene_scale.h
/// @brief A scene file's geometry scaled by one factor (stability case 14 and chapter 17's tests of the largest
/// scene size): the camera's eye and focal point, the spheres' centres and radii, and inline mesh vertices; and the
/// largest and smallest of its lengths, which the loader bounds.
#pragma once

#include <nlohmann/json.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>

namespace raylife::test {

/// The largest magnitude among the coordinates and radii that scaledScene scales.
inline double largestMagnitude(const nlohmann::json& j)
{
  double m = 0;
  auto point = [&m](const nlohmann::json& p) {
    for (const nlohmann::json& c : p)
      m = std::max(m, std::abs(c.get<double>()));
  };
  point(j["camera"]["eye"]);
  point(j["camera"]["focal"]);
  for (const nlohmann::json& s : j.value("spheres", nlohmann::json::array())) {
    point(s["center"]);
    m = std::max(m, s["radius"].get<double>());
  }
  for (const nlohmann::json& mesh : j.value("meshes", nlohmann::json::array()))
    for (const nlohmann::json& v : mesh["vertices"])
      point(v);
  return m;
}

/// The smallest of the lengths the loader holds to kMinSceneLength: the spheres' radii, the distance from the
/// camera's eye to its focal point, and each inline triangle's size (the square root of twice its area).
inline double smallestLength(const nlohmann::json& j)
{
  auto vec = [](const nlohmann::json& p) {
    return std::array<double, 3>{p[0].get<double>(), p[1].get<double>(), p[2].get<double>()};
  };
  const auto eye = vec(j["camera"]["eye"]), focal = vec(j["camera"]["focal"]);
  double m = std::hypot(eye[0] - focal[0], eye[1] - focal[1], eye[2] - focal[2]);
  for (const nlohmann::json& s : j.value("spheres", nlohmann::json::array()))
    m = std::min(m, s["radius"].get<double>());
  for (const nlohmann::json& mesh : j.value("meshes", nlohmann::json::array()))
    for (const nlohmann::json& t : mesh["triangles"]) {
      const auto a = vec(mesh["vertices"][t[0].get<std::size_t>()]);
      const auto b = vec(mesh["vertices"][t[1].get<std::size_t>()]);
      const auto c = vec(mesh["vertices"][t[2].get<std::size_t>()]);
      const double e[2][3] = {{b[0] - a[0], b[1] - a[1], b[2] - a[2]}, {c[0] - a[0], c[1] - a[1], c[2] - a[2]}};
      const double doubleArea = std::hypot(e[0][1] * e[1][2] - e[0][2] * e[1][1], e[0][2] * e[1][0] - e[0][0] * e[1][2],
                                           e[0][0] * e[1][1] - e[0][1] * e[1][0]);
      m = std::min(m, std::sqrt(doubleArea));
    }
  return m;
}

/// Scene `j` (its meshes inline, no point lights, no lens or motion) with every length times `factor`: the image is
/// the same, as emission is radiance.
inline nlohmann::json scaledScene(nlohmann::json j, double factor)
{
  auto scale = [factor](nlohmann::json& p) {
    for (nlohmann::json& c : p)
      c = c.get<double>() * factor;
  };
  scale(j["camera"]["eye"]);
  scale(j["camera"]["focal"]);
  if (j.contains("spheres"))
    for (nlohmann::json& s : j["spheres"]) {
      scale(s["center"]);
      s["radius"] = s["radius"].get<double>() * factor;
    }
  if (j.contains("meshes"))
    for (nlohmann::json& mesh : j["meshes"])
      for (nlohmann::json& v : mesh["vertices"])
        scale(v);
  return j;
}

} // namespace raylife::test

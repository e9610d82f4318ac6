/// @file scene_scale.h
/// @brief A scene file's geometry scaled by one factor (stability case 14 and chapter 17's tests of the largest
/// scene size): the camera's eye and focal point, the spheres' centres and radii, and inline mesh vertices.
#pragma once

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>

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

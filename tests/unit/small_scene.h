/// @file small_scene.h
/// @brief The one-sphere, 37×23 test scene the render-loop tests share.
#pragma once

#include "scene/scene.h"

namespace raylife::test {

/// A diffuse unit sphere at the origin seen from 5 units away, 37×23 pixels (odd sizes, so tiles are ragged).
inline Scene smallScene()
{
  return parseScene(R"({ "camera": { "eye": [0, 0, 5], "focal": [0, 0, 0], "width": 37, "height": 23 },
                         "materials": { "m": { "type": "diffuse" } },
                         "spheres": [ { "center": [0, 0, 0], "radius": 1, "material": "m" } ] })",
                    "small.json");
}

} // namespace raylife::test

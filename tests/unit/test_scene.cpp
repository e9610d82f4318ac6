#include "render/options.h"
#include "render/runner.h"
#include "scene/scene.h"

#include <catch2/catch.hpp>

#include <cstdio>
#include <string>

using namespace raylife;

namespace {
const char* kScene = R"({
  "camera": { "eye": [0, 1, 5], "focal": [0, 1, 0], "vfov": 45, "width": 40, "height": 30 },
  "background": [0.1, 0.2, 0.3],
  "ambient": [0.05, 0.05, 0.05],
  "materials": {
    "red":  { "type": "diffuse", "color": [0.75, 0.25, 0.25] },
    "lamp": { "type": "diffuse", "color": [0, 0, 0], "emission": [12, 12, 12] },
    "glass": { "type": "glass", "color": [1, 1, 1], "ior": 1.5 },
    "satin": { "type": "glossy", "color": [0.8, 0.8, 0.8], "roughness": 0.3 },
    "steel": { "type": "mirror", "color": [0.9, 0.9, 0.9] }
  },
  "spheres": [ { "center": [0, 1, 0], "radius": 1, "material": "red" },
               { "center": [2, 1, 0], "radius": 0.5, "material": "glass" },
               { "center": [0, 5, 0], "radius": 0.5, "material": "lamp" },
               { "center": [-2, 1, 0], "radius": 0.5, "material": "satin" } ],
  "lights": [ { "type": "point", "position": [5, 8, 5], "intensity": [1, 2, 3] } ]
})";
// What parseScene says of `text` as file `name`: its SceneError's message, or "(no error)".
std::string loadError(const std::string& text, const std::string& name)
{
  try {
    parseScene(text, name);
  } catch (const SceneError& e) {
    return std::string(e.what());
  }
  return std::string("(no error)");
}
} // namespace

TEST_CASE("the design's example scene loads with every key read")
{
  const Scene scene = parseScene(kScene, "example.json");
  CHECK(scene.camera.eye == Vec3(0, 1, 5));
  CHECK(scene.camera.up == Vec3(0, 1, 0)); // default
  CHECK(scene.camera.vfovDeg == 45);
  CHECK(scene.camera.width == 40);
  CHECK(scene.background == Color(Real(0.1), Real(0.2), Real(0.3)));
  REQUIRE(scene.materials.size() == 5);
  CHECK(scene.materials[1].isEmissive());
  CHECK(scene.materials[2].type == MaterialType::Glass);
  CHECK(scene.materials[3].roughness == Approx(0.3));
  REQUIRE(scene.spheres.size() == 4);
  CHECK(scene.spheres[1].material == 2);
  REQUIRE(scene.lights.size() == 1);
  CHECK(scene.lights[0].intensity == Color(1, 2, 3));
  REQUIRE(scene.warnings.size() == 1); // "steel" is defined but unused
  CHECK_THAT(scene.warnings[0], Catch::Contains("steel"));
}

TEST_CASE("a chapter says what of the scene it ignores")
{
  const Scene scene = parseScene(kScene, "example.json");
  CHECK(describeIgnored(scene, 0) == "4 spheres, 1 point light, the ambient term and the background");
  const unsigned lambert = kUsesSpheres | kUsesColors | kUsesPointLights | kUsesAmbient | kUsesBackground;
  // (What the command line asks that the chapter ignores, --max-depth, is not the scene's: the runner says it apart.)
  CHECK(describeIgnored(scene, lambert) ==
        "the emission of 1 material and the reflection and refraction of 2 materials (shaded as diffuse)");
  CHECK(describeIgnored(scene, lambert | kUsesEmission | kUsesGlass | kUsesGlossy | kUsesMirror).empty());
}

TEST_CASE("scene faults name the file - the line and column - the JSON path and the fault")
{
  auto message = [](const std::string& text) { return loadError(text, "bad.json"); };
  const std::string camera = R"("camera": { "eye": [0, 0, 5], "focal": [0, 0, 0] })";
  const std::string mats = R"("materials": { "m": { "type": "diffuse" } })";
  CHECK(message("{ \"camera\": ") .find("bad.json:1:") == 0);
  CHECK_THAT(message("{ \"camera\": "), Catch::Contains("malformed JSON"));
  CHECK(message("{" + camera + ",\n " + mats + ",\n \"spheres\": [ { \"center\": [0,0,0], \"radius\": -1, "
                "\"material\": \"m\" } ] }") ==
        "bad.json:3:46: /spheres/0/radius: the radius must be greater than 0, got -1");
  CHECK_THAT(message("{" + camera + ", " + mats + ", \"spheres\": [ { \"center\": [0,0,0], \"radius\": 1, "
                     "\"material\": \"n\" } ] }"),
             Catch::Contains("/spheres/0/material: undefined material 'n'"));
  CHECK_THAT(message("{" + camera + ", " + mats + ", \"sphere\": [] }"),
             Catch::Contains("unknown key 'sphere' (did you mean 'spheres'?)"));
  CHECK_THAT(message("{" + camera + ", " + mats + ", \"spheres\": [] }"), Catch::Contains("the scene is empty"));
  CHECK_THAT(message(R"({ "camera": { "eye": [0, 5, 0], "focal": [0, 0, 0] }, "spheres": [] })"),
             Catch::Contains("/camera/up: the up vector is parallel"));
  CHECK_THAT(message(R"({ "camera": { "eye": [0, 0, 5], "focal": [0, 0, 0], "width": 0 }, "spheres": [] })"),
             Catch::Contains("/camera/width: must be at least 1"));
}

TEST_CASE("the command line: defaults - every option and faults")
{
  auto parse = [](std::vector<const char*> args) {
    args.insert(args.begin(), "step");
    return parseCommandLine(int(args.size()), args.data());
  };
  const RenderOptions none = parse({});
  CHECK(none.scenePath.empty());
  CHECK(none.outputs.empty());
  CHECK_FALSE(none.spp);
  const RenderOptions all = parse({"s.json", "-o", "a.png", "-o", "a.pfm", "--width", "64", "--height", "48",
                                   "--spp", "8", "--seed", "3", "--threads", "2", "--max-depth", "5", "--quiet"});
  CHECK(all.scenePath == "s.json");
  CHECK(all.outputs == std::vector<std::string>{"a.png", "a.pfm"});
  CHECK(all.width == 64);
  CHECK(all.height == 48);
  CHECK(*all.spp == 8);
  CHECK(all.seed == 3);
  CHECK(all.threads == 2);
  CHECK(*all.maxDepth == 5);
  CHECK(all.quiet);
  CHECK(*parse({"--time", "2.5"}).seconds == 2.5);
  CHECK_THROWS_WITH(parse({"--spp"}), Catch::Contains("--spp expects a value"));
  CHECK_THROWS_WITH(parse({"--spp", "abc"}), Catch::Contains("expects a whole number"));
  CHECK_THROWS_WITH(parse({"--width", "0"}), Catch::Contains("--width must lie in [1,"));
  CHECK_THROWS_WITH(parse({"--time", "-1"}), Catch::Contains("greater than 0"));
  CHECK_THROWS_WITH(parse({"--frobnicate"}), Catch::Contains("unknown option '--frobnicate'"));
  CHECK_THROWS_WITH(parse({"--spp", "4", "--time", "1"}), Catch::Contains("not both"));
  CHECK_THROWS_WITH(parse({"a.json", "b.json"}), Catch::Contains("more than one scene"));
  CHECK_THROWS_WITH(parse({"-o", "a.png", "-o", "b.pfm", "-o", "c.png"}), Catch::Contains("two .png files"));
}

TEST_CASE("the smallest length: a radius and the eye's distance to the focal point below it are refused, a triangle "
          "below it is dropped")
{
  auto message = [](const std::string& text) { return loadError(text, "small.json"); };
  // A tenth of the build's smallest length, the length itself and twice it, as JSON numbers.
  char below[32], at[32], twice[32];
  std::snprintf(below, sizeof below, "%.6g", kMinSceneLength / 10);
  std::snprintf(at, sizeof at, "%.6g", kMinSceneLength);
  std::snprintf(twice, sizeof twice, "%.6g", 2 * kMinSceneLength);
  const std::string camera = R"("camera": { "eye": [0, 0, 5], "focal": [0, 0, 0] })";
  const std::string mats = R"("materials": { "m": { "type": "diffuse" } })";
  auto sphere = [&](const char* radius) {
    return "{" + camera + ", " + mats + R"(, "spheres": [ { "center": [0, 0, 0], "radius": )" + radius +
           R"(, "material": "m" } ] })";
  };
  CHECK(message(sphere(at)) == "(no error)");
  CHECK_THAT(message(sphere(below)), Catch::Contains(std::string("/spheres/0/radius: the radius must be at least ") +
                                                     kMinSceneLengthText + " (raylife's smallest length)"));
  auto eyeAt = [&](const char* z) {
    return std::string(R"({ "camera": { "eye": [0, 0, )") + z + R"(], "focal": [0, 0, 0] }, )" + mats +
           R"(, "spheres": [ { "center": [0, 0, -5], "radius": 1, "material": "m" } ] })";
  };
  CHECK(message(eyeAt(at)) == "(no error)");
  CHECK_THAT(message(eyeAt(below)), Catch::Contains(std::string("/camera/focal: eye and focal are only ") + below +
                                                    " apart, less than raylife's smallest length"));
  CHECK_THAT(message(eyeAt("0")), Catch::Contains("/camera/focal: eye and focal are the same point"));
  // Triangles: twice the area against the square of the smallest length (right triangles with legs `twice` and
  // `below`: 4 and 1/100 times it); the big one keeps the scene from being empty.
  auto triangles = [&](const char* leg) {
    return "{" + camera + ", " + mats + R"(, "meshes": [ { "material": "m", "vertices": [[0,0,0],[)" + leg +
           R"(,0,0],[0,)" + leg + R"(,0],[1,0,0],[0,1,0]], "triangles": [[0, 1, 2], [0, 3, 4]] } ] })";
  };
  CHECK(parseScene(triangles(twice), "small.json").triangles.size() == 2);
  const Scene dropped = parseScene(triangles(below), "small.json");
  CHECK(dropped.triangles.size() == 1);
  REQUIRE_FALSE(dropped.warnings.empty());
  CHECK_THAT(dropped.warnings[0], Catch::Contains("1 degenerate triangle (area 0, or below the square of"));
}

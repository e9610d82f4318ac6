// The render's plan (scene_plan.h): what each scene lets a chapter skip.
#include "scene/light_sampling.h"
#include "render/runner.h"
#include "scene/scene_plan.h"

#include <catch2/catch.hpp>

#include <algorithm>

using namespace raylife;

namespace {
// What chapters 7 and 8 read.
constexpr unsigned kMonteCarlo = kUsesSpheres | kUsesColors | kUsesPointLights | kUsesBackground | kUsesEmission |
                                 kUsesMirror | kUsesGlass | kUsesGlossy | kUsesMaxDepth | kSamplesLights;

Scene load(const std::string& name) { return loadScene(sceneDirectory() + "/" + name); }
} // namespace

TEST_CASE("the plan of the Cornell box - 9 spheres in a flat list and 1 emitter and glass and a black background")
{
  const ScenePlan plan = planScene(load("cornell.json"), kMonteCarlo);
  CHECK(plan.spheres == 9);
  CHECK_FALSE(plan.bvh);
  CHECK(plan.emitters == 1);
  CHECK(plan.pointLights == 0);
  CHECK(plan.lightSampling());
  CHECK_FALSE(plan.shadowRays());
  CHECK(plan.glass);
  CHECK(plan.backgroundBlack);
  const std::vector<std::string> lines = describePlan(plan);
  REQUIRE(lines.size() == 4);
  CHECK(plan.lanes == laneTestAvailable(LaneTest::FourAtOnce));
  CHECK(lines[0] == std::string("plan: 9 spheres -> flat list: each ray tests every one") +
                        (plan.lanes ? ", four spheres at a time" : "") + " (more than 9 go in a BVH, chapter 9)");
  CHECK(lines[1] == "plan: 1 emitter, 0 point lights -> light sampling of 1 light");
  CHECK(lines[3] == "plan: background black -> no environment lookups");
}

TEST_CASE("the plan of the MIS scene - 5 emitters - no glass - a background that is not black")
{
  const ScenePlan plan = planScene(load("mis.json"), kMonteCarlo);
  CHECK(plan.emitters == 5);
  CHECK_FALSE(plan.glass);
  CHECK_FALSE(plan.backgroundBlack);
  const std::vector<std::string> lines = describePlan(plan);
  CHECK(std::find(lines.begin(), lines.end(), "plan: no glass -> no refraction") != lines.end());
}

TEST_CASE("the plan of the random spheres - a BVH and point lights - and of the adaptive scene - nothing to sample")
{
  const ScenePlan random = planScene(load("random_spheres.json"), kMonteCarlo);
  CHECK(random.spheres == 500);
  CHECK(random.bvh);
  CHECK(random.pointLights == 2);
  CHECK(random.shadowRays());
  CHECK(describePlan(random)[0] == "plan: 500 spheres -> BVH (flat list up to 9)");
  // The ground sphere is kept out of the tree, and the plan says so.
  CHECK(random.outsideTree == std::vector<int>{0});
  CHECK(describePlan(random)[1] ==
        "plan: 1 huge primitive outside the tree, tested first (each box at least 4x the area of the tree's): sphere 0");

  const ScenePlan sky = planScene(load("adaptive.json"), kMonteCarlo);
  CHECK_FALSE(sky.lightSampling());
  CHECK(describePlan(sky)[1] == "plan: 0 emitters, 0 point lights -> no light sampling (BSDF sampling only)");
}

TEST_CASE("the plan counts only what the chapter reads")
{
  // Chapter 4 (point lights, no emission, no glass) on the Whitted scene: its glass is shaded as diffuse.
  const Scene whitted = load("whitted.json");
  const ScenePlan plan = planScene(whitted, kUsesSpheres | kUsesColors | kUsesPointLights | kUsesAmbient);
  CHECK(plan.pointLights == 3);
  CHECK_FALSE(plan.glass);
  CHECK(plan.backgroundBlack); // not read: as good as black
  CHECK(planScene(whitted, kMonteCarlo).glass);
  CHECK_FALSE(planScene(whitted, kMonteCarlo).backgroundBlack);
}

TEST_CASE("skipping light sampling without lights is exact - the light sampler of such a scene returns nothing")
{
  const Scene sky = load("adaptive.json");
  const LightSampler lights(sky);
  CHECK(lights.empty());
  Sampler sampler(7, 0, 0, 0);
  for (int i = 0; i < 1000; ++i) {
    const Real u = sampler.next1D();
    const Vec2 u2 = sampler.next2D();
    CHECK_FALSE(lights.sample(Vec3(0, 0, 0), u, u2).has_value());
  }
}

TEST_CASE("the plan speaks of what the chapter does, in its words (issue 26)")
{
  const Scene spheres = load("spheres.json");
  const unsigned lambert = kUsesSpheres | kUsesColors | kUsesPointLights | kUsesAmbient | kUsesBackground;
  // Chapter 4: shadow rays, no light sampling, nothing of glass or environments.
  const std::vector<std::string> four = describePlan(planScene(spheres, lambert | kShadowRays));
  REQUIRE(four.size() == 2);
  CHECK(four[1] == "plan: 2 point lights -> a shadow ray to each from every hit that faces it");
  // Chapter 3: the lights are taken as seen.
  const std::vector<std::string> three = describePlan(planScene(spheres, lambert));
  REQUIRE(three.size() == 2);
  CHECK(three[1] == "plan: 2 point lights -> each taken as seen from every point (no shadow rays until chapter 4)");
  // Chapter 6: the emitter is found by the paths that hit it.
  const unsigned six = kUsesSpheres | kUsesColors | kUsesBackground | kUsesEmission | kUsesMirror | kUsesGlass |
                       kUsesGlossy | kUsesMaxDepth;
  CHECK(describePlan(planScene(load("cornell.json"), six))[1] ==
        "plan: 1 emitter -> found only by paths that hit them (no light sampling until chapter 7)");
  // Chapter 10 lights what it sees from the eye: neither emitters nor environments are looked for.
  CHECK(describePlan(planScene(load("meshes.json"), kUsesSpheres | kUsesColors | kUsesBackground | kUsesEmission))
            .size() == 1);
  // Chapter 1 intersects nothing.
  CHECK(describePlan(planScene(spheres, 0)) ==
        std::vector<std::string>{"plan: nothing is intersected -> no geometry, no lights"});
  for (const std::vector<std::string>& lines : {four, three})
    for (const std::string& line : lines)
      CHECK(line.find("light sampling") == std::string::npos);
}

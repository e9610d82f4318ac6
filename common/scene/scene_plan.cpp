#include "scene/scene_plan.h"

namespace raylife {

ScenePlan planScene(const Scene& scene, unsigned uses)
{
  ScenePlan plan;
  plan.uses = uses;
  plan.spheres = scene.spheres.size();
  plan.bvh = scene.usesAccelerator();
  plan.lanes = scene.usesLanes();
  if (plan.bvh)
    plan.outsideTree = scene.accelerator.outsidePrimitives();
  if (uses & kUsesPointLights)
    plan.pointLights = scene.lights.size();
  plan.triangles = scene.triangles.size();
  for (std::size_t i = 0; i < scene.primitiveCount(); ++i) {
    const Material& m = scene.materials[std::size_t(scene.materialOf(int(i)))];
    plan.emitters += (uses & kUsesEmission) && m.isEmissive();
    plan.glass = plan.glass || ((uses & kUsesGlass) && m.type == MaterialType::Glass);
  }
  plan.backgroundBlack = !(uses & kUsesBackground) ||
                         (scene.background == Color(0) && !(scene.environment && (uses & kUsesEnvironment)));
  plan.ambient = (uses & kUsesAmbient) && scene.ambient != Color(0);
  if (!(uses & kUsesPointLights))
    plan.ignoredPointLights = scene.lights.size();
  if (!(uses & kUsesEmission))
    for (std::size_t i = 0; i < scene.primitiveCount(); ++i)
      plan.ignoredEmitters += scene.materials[std::size_t(scene.materialOf(int(i)))].isEmissive();
  return plan;
}

bool litByScene(unsigned uses)
{
  // Shading by point lights or light sampling, or a path tracer (one that follows rays and reads emission).
  return (uses & kUsesSpheres) && ((uses & (kUsesPointLights | kShadowRays | kSamplesLights)) ||
                                   ((uses & kUsesEmission) && (uses & kUsesMaxDepth)));
}

std::string describeDarkness(const ScenePlan& plan)
{
  if (!litByScene(plan.uses) || plan.pointLights + plan.emitters > 0 || plan.ambient || !plan.backgroundBlack)
    return "";
  std::string ignored;
  if (plan.ignoredEmitters > 0)
    ignored = "emission";
  if (plan.ignoredPointLights > 0)
    ignored += std::string(ignored.empty() ? "" : " and ") + "point lights";
  return "has no light this chapter uses" + (ignored.empty() ? std::string() : " (it ignores " + ignored + ")") +
         ": the image will be black";
}

std::vector<std::string> describePlan(const ScenePlan& plan)
{
  auto count = [](std::size_t n, const char* one, const char* many) {
    return std::to_string(n) + " " + (n == 1 ? one : many);
  };
  const unsigned uses = plan.uses;
  std::vector<std::string> lines;
  if (!(uses & kUsesSpheres))
    return {"plan: nothing is intersected -> no geometry, no lights"};
  const std::string primitives = count(plan.spheres, "sphere", "spheres") +
                                 (plan.triangles > 0 ? ", " + count(plan.triangles, "triangle", "triangles") : "");
  lines.push_back("plan: " + primitives +
                  (plan.bvh ? " -> BVH (flat list up to " + std::to_string(kFlatListMaxPrimitives) + ")"
                            : std::string(" -> flat list: each ray tests every one") +
                                  (plan.lanes ? ", four spheres at a time" : "") + " (more than " +
                                  std::to_string(kFlatListMaxPrimitives) + " go in a BVH, chapter 9)"));
  if (!plan.outsideTree.empty()) {
    // "spheres 0-5, 8; triangle 3": the numbers of each kind, runs shortened.
    std::vector<std::size_t> kinds[2]; // spheres' numbers, triangles' (their own, from 0)
    for (const int p : plan.outsideTree)
      std::size_t(p) < plan.spheres ? kinds[0].push_back(std::size_t(p))
                                    : kinds[1].push_back(std::size_t(p) - plan.spheres);
    std::string list;
    for (int kind = 0; kind < 2; ++kind) {
      const std::vector<std::size_t>& v = kinds[kind];
      if (v.empty())
        continue;
      list += list.empty() ? "" : "; ";
      list += kind == 0 ? (v.size() == 1 ? "sphere " : "spheres ") : (v.size() == 1 ? "triangle " : "triangles ");
      for (std::size_t i = 0; i < v.size();) {
        std::size_t j = i;
        while (j + 1 < v.size() && v[j + 1] == v[j] + 1)
          ++j;
        list += i == 0 ? "" : ", ";
        list += std::to_string(v[i]);
        if (j > i) {
          list += '-';
          list += std::to_string(v[j]);
        }
        i = j + 1;
      }
    }
    std::string line = "plan: " + count(plan.outsideTree.size(), "huge primitive", "huge primitives");
    line += " outside the tree, tested first (each box at least ";
    line += std::to_string(int(kHugeAreaRatio));
    line += "x the area of the tree's): ";
    line += list;
    lines.push_back(line);
  }
  if (uses & kSamplesLights) {
    const std::string lights =
        count(plan.emitters, "emitter", "emitters") + ", " + count(plan.pointLights, "point light", "point lights");
    lines.push_back("plan: " + lights +
                    (plan.lightSampling()
                         ? " -> light sampling of " + count(plan.emitters + plan.pointLights, "light", "lights")
                         : " -> no light sampling (BSDF sampling only)"));
  } else if (uses & kShadowRays) {
    lines.push_back(plan.shadowRays() ? "plan: " + count(plan.pointLights, "point light", "point lights") +
                                            " -> a shadow ray to each from every hit that faces it"
                                      : "plan: no point lights -> no shadow rays");
  } else if (uses & kUsesPointLights) {
    lines.push_back("plan: " + count(plan.pointLights, "point light", "point lights") +
                    " -> each taken as seen from every point (no shadow rays until chapter 4)");
  } else if ((uses & kUsesEmission) && (uses & kUsesMaxDepth)) { // (a path tracer; chapter 10 only colours them)
    lines.push_back("plan: " + count(plan.emitters, "emitter", "emitters") +
                    " -> found only by paths that hit them (no light sampling until chapter 7)");
  }
  if (uses & kUsesGlass)
    lines.push_back(plan.glass ? "plan: glass -> refraction" : "plan: no glass -> no refraction");
  if (uses & kUsesMaxDepth) // (a chapter that follows rays on; the others return the background on a miss)
    lines.push_back(plan.backgroundBlack ? "plan: background black -> no environment lookups"
                                         : "plan: background not black -> environment lookups on escape");
  return lines;
}

} // namespace raylife

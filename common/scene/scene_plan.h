/// @file scene_plan.h
/// @brief The plan of a render: what a scene holds, decided once before rendering, and so what a chapter may skip
/// (issue 7: "skip what the scene does not need").
#pragma once

#include "scene/scene.h"

#include <cstddef>
#include <string>
#include <vector>

namespace raylife {

/// What of a scene a chapter reads, so the runner can say once what it ignores.
enum Feature : unsigned {
  kUsesSpheres = 1u << 0,       ///< Intersects the scene's surfaces: its spheres and its triangle meshes.
  kUsesColors = 1u << 1,        ///< Reads material colours.
  kUsesPointLights = 1u << 2,   ///< Reads point lights.
  kUsesAmbient = 1u << 3,       ///< Reads the ambient term.
  kUsesBackground = 1u << 4,    ///< Returns the background on a miss.
  kUsesEmission = 1u << 5,      ///< Reads material emission.
  kUsesMirror = 1u << 6,        ///< Treats mirror materials as mirrors.
  kUsesGlass = 1u << 7,         ///< Treats glass materials as glass.
  kUsesGlossy = 1u << 8,        ///< Treats glossy materials as glossy.
  kUsesMaxDepth = 1u << 9,      ///< Honours --max-depth.
  kShadowRays = 1u << 10,       ///< Traces a shadow ray from a hit to each point light (chapters 4, 5, 9).
  kSamplesLights = 1u << 11,    ///< Samples a light at each hit: next-event estimation (chapters 7 on).
  kUsesLens = 1u << 12,         ///< Honours the camera's aperture (a thin lens; several samples a pixel).
  kUsesMotion = 1u << 13,       ///< Honours the spheres' velocities (each sample draws a time).
  kUsesMetal = 1u << 14,        ///< Treats metal materials as metal (GGX).
  kUsesMedia = 1u << 20,        ///< Renders participating media and interfaces (chapter 15).
  // (Chapter 14's two flags stand apart from the others' sequence, so that flags added beside them do not collide.)
  kUsesEnvironment = 1u << 24,  ///< Looks up the environment map where a ray leaves the scene (chapters 3 to 14).
  kUsesTextures = 1u << 25,     ///< Looks up textures at a hit's (u, v) (chapter 14; the others shade their mean).
};

/// What a scene needs, computed once from the scene and a chapter's feature flags (Feature, above).
/// Every field is a plain fact of the scene; the "skip" fields say what a chapter that reads `uses` may leave out
/// without changing its expected value.
struct ScenePlan {
  std::size_t spheres = 0;      ///< Spheres in the scene.
  std::size_t triangles = 0;    ///< Triangles in the scene (all its meshes').
  bool bvh = false;             ///< True: queries go through the BVH; false: a flat loop (≤ kFlatListMaxPrimitives).
  bool lanes = false;           ///< The flat loop tests four spheres at once (Scene::usesLanes; CPUs with AVX2).
  /// The huge primitives the BVH keeps out of its tree and tests first (Bvh::outsidePrimitives), by number; empty
  /// without a BVH.
  std::vector<int> outsideTree;
  std::size_t pointLights = 0;  ///< Point lights in the scene (counted only if the chapter reads them).
  std::size_t emitters = 0;     ///< Spheres and triangles with an emissive material (counted only if the chapter
                                ///< reads emission).
  bool glass = false;           ///< Some sphere or triangle is glass and the chapter treats glass as glass.
  bool backgroundBlack = true;  ///< The background is black, or the chapter does not read it.
  bool ambient = false;         ///< The ambient term is not black and the chapter reads it.
  /// Lights the scene holds that the chapter ignores (it does not read them): point lights, emitters.
  std::size_t ignoredPointLights = 0;
  std::size_t ignoredEmitters = 0; ///< See ignoredPointLights.
  unsigned uses = 0;            ///< The chapter's Feature flags: describePlan speaks only of what it does.
  /// Light sampling has something to sample: at least one emitter or point light. Without it chapters 7 and 8
  /// do BSDF sampling only (a light sampler with no light returns nothing, so this is exact).
  bool lightSampling() const { return emitters + pointLights > 0; }
  /// Shadow rays have a light to go to (chapters 3 to 5: only point lights cast shadow rays).
  bool shadowRays() const { return pointLights > 0; }
};

/// True for a chapter whose image is lit by the scene's lights (point lights, emitters, the ambient term, the
/// background as an environment), which a scene without any it reads leaves black: chapters 3 to 9, 11 and 13; not
/// the ones that show geometry (1, 2), light by a headlight (10) or by occlusion (12).
bool litByScene(unsigned uses);

/// The plan for `scene` as a chapter reading `uses` (Feature flags) renders it.
ScenePlan planScene(const Scene& scene, unsigned uses);

/// The plan as lines of text, one per decision the chapter (ScenePlan::uses) makes, in its words, e.g.
/// "plan: 5 spheres -> flat list: each ray tests every one (more than 9 go in a BVH, chapter 9)".
std::vector<std::string> describePlan(const ScenePlan& plan);

/// "", or, when the chapter (litByScene) finds no light it uses in the scene, no ambient term and a black
/// background, so that its image will be black: what to tell the user, e.g. "has no light this chapter uses (it
/// ignores emission): the image will be black".
std::string describeDarkness(const ScenePlan& plan);

} // namespace raylife

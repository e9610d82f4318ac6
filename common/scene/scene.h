/// @file scene.h
/// @brief The scene: camera settings, materials, spheres, triangle meshes and lights, its intersection queries, and
/// its loader.
#pragma once

#include "geometry/bvh.h"
#include "scene/camera.h"
#include "geometry/hit.h"
#include "shading/light.h"
#include "shading/environment.h"
#include "shading/material.h"
#include "shading/medium.h"
#include "geometry/ray.h"
#include "geometry/sphere.h"
#include "geometry/sphere_lanes.h"
#include "geometry/triangle.h"

#include <array>
#include <cmath>
#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

namespace raylife {

/// The camera as the scene file states it; the image size may be overridden on the command line.
struct CameraSpec {
  Vec3 eye{0, 0, 5};   ///< Centre of projection.
  Vec3 focal{0};       ///< The point looked at.
  Vec3 up{0, 1, 0};    ///< Roughly up; must not be parallel to eye − focal.
  Real vfovDeg = 40;   ///< Full vertical field of view in degrees, in (0, 180).
  int width = 320;     ///< Default image width in pixels, ≥ 1.
  int height = 240;    ///< Default image height in pixels, ≥ 1.
  Real aperture = 0;   ///< The lens radius in scene units, ≥ 0 (0: a pinhole; chapter 11).
  /// The distance from the eye to the plane in focus along the view direction, > 0; 0 stands for |focal − eye|
  /// (the point looked at is sharp).
  Real focus = 0;
  CameraBasis basis{}; ///< The orthonormal basis, built and checked when the scene is loaded.
};

/// Largest image the loader and the command line accept, in pixels (width × height): 8192 × 8192.
/// The film keeps about 100 bytes a pixel (its exact fixed-point sums, film.h), so this bounds its memory at about
/// 6.3 GiB.
inline constexpr std::int64_t kMaxPixels = std::int64_t(1) << 26;

/// The largest magnitude a scene's geometry may have in the float build, and in chapter 17's float kernels, in
/// scene units (see kMaxSceneExtent). Float's range ends at 3.4·10³⁸, and a triangle's area is the length of a cross
/// product of two edges, whose squared length is a fourth power of the scene's size: with every coordinate within
/// 10⁸ it stays below 1.5·10³⁴. Measured in the float build, scaling scenes up by powers of ten: the original Cornell
/// box with its corners at 5.6·10¹⁰ gave bad samples in chapters 7, 8, 11 and 13 to 16 (its lamp's area was
/// infinite); at 5.6·10¹² chapters 10 and 17 lost hits as well (the watertight test's scaled distance is a cube of
/// the size); smallpt's room with its walls' radius at 10²⁰ (whose square is infinite in float) rendered wrong
/// images, without a word, in chapters 8 and 17.
inline constexpr double kMaxSceneExtentFloat = 1e8;

/// The largest magnitude a scene's geometry may have, in scene units: each coordinate of a sphere's centre (also at
/// the end of its motion), of a mesh vertex after its transform, of the camera's eye and focal point and of a point
/// light; a sphere's radius, the lens's aperture and its focus distance. Far beyond what any scene needs (10³⁰ metres
/// is 10⁴ times the observable universe), the bound keeps the tree's boxes, which are float (bvh.h), inside float's
/// range (3.4·10³⁸) with room to spare: beyond it every ray entered every box, and chapter 10's model scaled to
/// 8·10³⁹ rendered the same image 36 times slower (stability case 14). It also keeps what the renderer squares in
/// double's range: an emitting sphere or triangle 10⁸⁰ across gave bad samples in chapter 13, whose MIS weights
/// square areas and densities, and a triangle with vertices 10²⁵⁰ apart has an infinite area, which gave bad samples
/// in chapters 7, 8, 11 and 13. (The bound was 10⁵⁰ until case 14 found the tree's cliff.) The float build's bound is
/// kMaxSceneExtentFloat.
inline constexpr double kMaxSceneExtent = sizeof(Real) == sizeof(float) ? kMaxSceneExtentFloat : 1e30;
/// kMaxSceneExtent as the loader's messages write it.
inline constexpr const char* kMaxSceneExtentText = sizeof(Real) == sizeof(float) ? "1e8" : "1e30";

/// The float build's kMinSceneLength, which chapter 17's float kernels need in the double build too.
inline constexpr double kMinSceneLengthFloat = 1e-8;

/// The smallest length a scene may have, in scene units: a sphere's radius, the distance from the camera's eye to
/// its focal point, and the size of a triangle (the square root of twice its area: a triangle below it is dropped as
/// degenerate). 10⁻³⁰ in double and 10⁻⁸ in float, kMaxSceneExtent's mirror. Below it what the renderer squares
/// leaves the numbers' normal range and rounding takes over: smallpt's room scaled down to 10⁻¹⁶⁰ rendered a
/// different image in double (mean +2 %, with 30 % more rays), and to 10⁻²² in float (−13 %), without a word; a
/// triangle's area squares a squared length, which in float underflows below about 10⁻¹⁰. Within the two bounds
/// every chapter renders a scene the same at any size (stability case 14).
inline constexpr double kMinSceneLength = sizeof(Real) == sizeof(float) ? kMinSceneLengthFloat : 1e-30;
/// kMinSceneLength as the loader's messages write it.
inline constexpr const char* kMinSceneLengthText = sizeof(Real) == sizeof(float) ? "1e-8" : "1e-30";

/// True when |v| ≤ bound (false for NaN): with kMaxSceneExtent, what the loader demands of every length and
/// coordinate.
inline bool withinSceneExtent(Real v, double bound = kMaxSceneExtent) { return std::abs(double(v)) <= bound; }
/// True when each coordinate of `p` lies within ±bound.
inline bool withinSceneExtent(const Vec3& p, double bound = kMaxSceneExtent)
{
  return withinSceneExtent(p.x, bound) && withinSceneExtent(p.y, bound) && withinSceneExtent(p.z, bound);
}

/// The largest index of refraction a glass may have. The Fresnel equations square it, which overflows double from
/// about 10¹⁵⁴ (ior 1e160 gave bad samples in chapters 5, 6, 8 and 13, the ones tried); 10⁵⁰ leaves a wide
/// margin. Float overflows from about 1.8·10¹⁹ (ior 1e20 gave bad samples in chapters 5 to 8, 11
/// and 13 to 16 of the float build), so there, and in chapter 17's float kernels, the bound is kMaxIorFloat. No
/// transparent material comes near either: diamond's index is 2.42.
inline constexpr double kMaxIorFloat = 1e10;
inline constexpr double kMaxIor = sizeof(Real) == sizeof(float) ? kMaxIorFloat : 1e50; ///< (see above)

/// Scenes with at most this many primitives (spheres and triangles) are searched as a flat list; larger ones through
/// a BVH. Below the crossover a flat loop beats a tree (no boxes to test, no stack). Measured with
/// `tools/bvh_bench crossover` on the random-spheres scene, one thread: the tree overtakes the one-by-one loop at
/// about 15 spheres for camera rays and 8 for shadow rays; for chapter 4's mix (1.3 shadow rays per camera ray) at
/// 10. So the Cornell box (9) stays a flat list. (Four at a time, the list would hold its own against the tree up
/// to about 20 spheres, but the threshold is the one-by-one loop's, which every CPU runs.) A triangle test costs
/// about what a sphere test does, so triangles count as spheres here.
inline constexpr std::size_t kFlatListMaxPrimitives = 9;

/// Most primitives (spheres and triangles) a scene may hold: 2³⁰ − 1, what the BVH's nodes can number
/// (BvhWideNode::kIndexMask). The loader refuses more.
inline constexpr std::size_t kMaxPrimitives = BvhWideNode::kIndexMask;

/// A flat list of at least this many spheres tests them four at a time (sphere_lanes.h) where the CPU has AVX2;
/// a shorter one one by one, whose early exits (a sphere behind the ray, a miss without a square root) are then
/// cheaper than four lanes' full test and their reduction. Measured with `tools/bvh_bench crossover`, one thread:
/// for chapter 4's mix the two are even at 6 spheres and four at a time wins from 7; chapter 4 on
/// scenes/spheres.json (5 spheres) ran 5% slower four at a time. Rays inside large spheres favour the lanes more:
/// chapter 6 in the Cornell box (9) runs 1.13 to 1.25 times as fast.
inline constexpr std::size_t kLanesMinSpheres = 7;

/// Scene::intersectWithWork's answer: the hit, and the work the query did.
struct TracedHit {
  std::optional<Hit> hit; ///< As Scene::intersect.
  BvhWork work;           ///< Boxes and primitives tested (no boxes when the scene is searched one by one).
};

/// Scene::occludedWithWork's answer: the occlusion, and the work the query did.
struct TracedOcclusion {
  bool occluded = false; ///< As Scene::occluded.
  BvhWork work;          ///< Boxes and primitives tested until the answer was known.
};

/// The media on the two sides of a closed shape's boundary (chapter 15): "interior" and "exterior" in the scene
/// file, each an index into Scene::media or kVacuum.
///
/// Contract: a ray that leaves a boundary point along a direction d is in `exterior` when d points to the side of
/// the geometric normal (Hit::geometricNormal: out of a sphere; for a mesh, the loader swaps the two when its
/// triangles wind inwards), and in `interior` otherwise. A shape that names neither key has `changes` false: a ray
/// crossing it stays in the medium it was in.
struct MediumInterface {
  int interior = kVacuum; ///< The medium inside the shape.
  int exterior = kVacuum; ///< The medium outside it (the scene's top-level medium unless the file says otherwise).
  bool changes = false;   ///< True when the shape names "interior" or "exterior".

  /// The medium a ray leaving the boundary along `direction` travels in, given the boundary's geometric normal
  /// and the medium it was in (`current`, kept when the shape changes nothing).
  int after(const Vec3& geometricNormal, const Vec3& direction, int current) const
  {
    if (!changes)
      return current;
    return glm::dot(direction, geometricNormal) > 0 ? exterior : interior;
  }
};

/// A triangle mesh of the scene file: which of Scene::triangles are its own, and how it is shaded.
struct Mesh {
  std::string source;               ///< The file it was read from, or "inline" (for messages and the plan).
  int material = 0;                 ///< Index into Scene::materials, shared by all its triangles.
  bool smooth = false;              ///< Shaded with interpolated vertex normals (Scene::vertexNormals).
  std::uint32_t firstTriangle = 0;  ///< Its triangles are Scene::triangles[firstTriangle, + triangleCount).
  std::uint32_t triangleCount = 0;  ///< ≥ 1.
  bool hasUvs = false;              ///< True when its vertices have texture coordinates (Scene::vertexUvs).
};

/// A loaded, validated scene. Immutable while rendering, so it is shared by all threads without locks.
///
/// Its primitives are numbered spheres first, then triangles: sphere i is primitive i, triangle j is primitive
/// spheres.size() + j (Hit::primitive, the BVH, the light sampler all use this numbering).
struct Scene {
  std::string fileName;            ///< Where it came from (for messages).
  CameraSpec camera;               ///< The camera.
  Color background{0};             ///< Radiance of every ray that leaves the scene, ≥ 0.
  Color ambient{0};                ///< The lecture's ambient term (chapters 3 to 5), ≥ 0.
  std::vector<Material> materials; ///< Indexed by Sphere::material and Triangle::material.
  std::vector<Sphere> spheres;     ///< The spheres (a scene has at least one sphere or one triangle).
  std::vector<Mesh> meshes;        ///< The triangle meshes, in the order of the file.
  std::vector<Vec3> vertices;      ///< Every mesh's vertices, world space (their transforms applied), all finite.
  /// Unit vertex normals, indexed as `vertices`, for the vertices of smooth meshes (0 for the others); empty when no
  /// mesh is smooth.
  std::vector<Vec3> vertexNormals;
  std::vector<Triangle> triangles; ///< Every mesh's triangles, none degenerate (see kMinSceneLength).
  std::vector<PointLight> lights;  ///< Point lights (may be empty).
  /// The environment map (chapter 14; "environment" in the file), or null: then `background` is what a ray that
  /// leaves the scene sees. A scene gives one or the other.
  std::shared_ptr<const EnvironmentMap> environment;
  /// Each sphere's texture rotation about +y ("rotate", as sine and cosine), indexed as `spheres`; empty when no
  /// sphere turns its texture.
  std::vector<SinCos<Real>> sphereUvRotation;
  /// Texture coordinates (u, v) per vertex, indexed as `vertices` (v = 0 the image's bottom row), for the meshes that
  /// have them (Mesh::hasUvs); empty when none has.
  std::vector<Vec2> vertexUvs;
  std::vector<std::string> warnings; ///< Non-fatal remarks from the loader (an unused material, say).

  // Participating media (chapter 15; earlier chapters ignore them).
  std::vector<Medium> media;       ///< The scene file's "media", in its order; empty without.
  int medium = kVacuum;            ///< The top-level "medium": what fills space outside every shape.
  int cameraMedium = kVacuum;      ///< The medium the camera is in: "camera.medium", else `medium`.
  /// One per sphere (indexed as `spheres`) when any sphere names "interior" or "exterior"; else empty.
  std::vector<MediumInterface> sphereMedia;
  /// One per mesh (indexed as `meshes`) when any mesh names "interior" or "exterior"; else empty. A mesh with media
  /// is closed and consistently wound (the loader checks).
  std::vector<MediumInterface> meshMedia;

  /// The media on the two sides of primitive `primitive` (a sphere's, or a triangle's mesh's): `changes` false
  /// for a shape that names none.
  MediumInterface mediumInterface(int primitive) const
  {
    const auto p = std::size_t(primitive);
    if (p < spheres.size())
      return sphereMedia.empty() ? MediumInterface{} : sphereMedia[p];
    return meshMedia.empty() ? MediumInterface{} : meshMedia[triangles[p - spheres.size()].mesh];
  }

  /// The BVH over the spheres and triangles, or an empty one. Filled by buildAccelerator(), which the loader calls.
  /// Contract: intersect and occluded use it only while it covers exactly primitiveCount() primitives (see
  /// usesAccelerator), and otherwise search the primitives one by one, with the same answers. So a scene filled by
  /// hand works without it; but whoever changes the geometry after building it must call buildAccelerator() again
  /// (a tree over moved primitives of the same count would answer for the old ones).
  Bvh accelerator;

  /// The spheres four to a group, for a scene the BVH does not take (of kLanesMinSpheres or more), where the CPU
  /// tests four at once (sphere_lanes.h); or an empty list. Filled by buildAccelerator() and used under the same
  /// contract as `accelerator` (see usesLanes).
  SphereLanes lanes;

  /// Builds `accelerator` over the spheres and triangles when there are more than kFlatListMaxPrimitives, and
  /// empties it otherwise; then `lanes` over the spheres of a scene without a tree of at least kLanesMinSpheres,
  /// where the CPU tests four spheres at once, and empties it otherwise.
  /// Not thread-safe: call it before rendering (no query ever builds anything, so queries are thread-safe).
  void buildAccelerator();

  /// True when some sphere moves (Sphere::velocity): rays then carry a time (Ray::time).
  bool hasMotion() const;

  /// Spheres and triangles together.
  std::size_t primitiveCount() const { return spheres.size() + triangles.size(); }

  /// True when intersect and occluded go through `accelerator`, false when they loop over the primitives.
  bool usesAccelerator() const;

  /// True when intersect and occluded, without a tree, test the spheres four at a time through `lanes`.
  bool usesLanes() const;

  /// The nearest hit of the ray inside [ray.tmin, ray.tmax), or nothing: the nearest primitive, the lowest number
  /// on a tie. Counts one ray (see rayCount()).
  std::optional<Hit> intersect(const Ray& ray) const;

  /// The hit record of primitive `primitive`, which `ray` hits at `t` (as a query found it: the record intersect
  /// makes for that answer). Counts no ray. For a wavefront (chapter 16), whose kernels find (t, primitive) for
  /// many rays at once.
  Hit hitAt(const Ray& ray, Real t, int primitive) const;

  /// Where the ray meets primitive `primitive` alone inside [ray.tmin, ray.tmax) (the test intersect applies to
  /// it), or nothing. Counts no ray. For light sampling: where a shadow ray meets the light it was aimed at.
  std::optional<Real> intersectPrimitive(const Ray& ray, int primitive) const;

  /// The material of primitive `primitive` (a sphere or a triangle), an index into `materials`.
  int materialOf(int primitive) const;

  /// The vertices of triangle `triangle` (an index into `triangles`, not a primitive number).
  std::array<Vec3, 3> triangleVertices(std::size_t triangle) const
  {
    const Triangle& tri = triangles[triangle];
    return {vertices[tri.v[0]], vertices[tri.v[1]], vertices[tri.v[2]]};
  }

  /// The shading normal of triangle `triangle` (an index into `triangles`) at barycentrics (b0, b1, b2), as a hit
  /// record holds it: for a smooth mesh its vertex normals so weighted, normalised (geometricNormal where that
  /// leaves no direction) and turned to geometricNormal's side; for a flat mesh geometricNormal itself.
  /// @param triangle an index into `triangles`. @param b0,b1,b2 the hit's barycentric weights of its corners (as
  ///   intersectTriangle gives them: each in [0, 1], summing to 1). @param geometricNormal the triangle's unit normal
  ///   (triangleNormal).
  Vec3 triangleShadingNormal(std::size_t triangle, Real b0, Real b1, Real b2, const Vec3& geometricNormal) const;

  /// True when anything blocks the ray inside [ray.tmin, ray.tmax): the shadow-ray query, which may stop at
  /// the first blocker it finds. Counts one ray.
  bool occluded(const Ray& ray) const;

  /// intersect, also returning the work it did (for chapter 9's heat map). Counts one ray.
  TracedHit intersectWithWork(const Ray& ray) const;

  /// occluded, also returning the work it did. Counts one ray.
  TracedOcclusion occludedWithWork(const Ray& ray) const;

  /// The radiance a ray leaving the scene along unit direction `direction` sees: the environment map's there, or
  /// the background. What every chapter from 5 on adds where a path escapes.
  Color escaped(const Vec3& direction) const { return environment ? environment->radiance(direction) : background; }

  /// Where the texture of primitive `primitive` is looked up at `point` on it (at time `time`, where a moving sphere
  /// is): a sphere's (u, v) from its outward normal (turned by sphereUvRotation), t = v, clamped at the poles; a
  /// triangle's (u, v) interpolated from its vertices' uvs (the barycentrics when it has none), t = 1 − v, repeated.
  /// See texture.h for (s, t). `footprint` is copied into the lookup.
  TextureLookup textureLookup(int primitive, const Vec3& point, Real time = 0, Real footprint = 0) const;

  /// How many units of the texture coordinate s one scene unit of length on primitive `primitive` at `point` spans
  /// (≥ 0): for a triangle √(its area in (u, v) / its area), for a sphere 1/(2πr sin θ) along its parallel. A ray
  /// cone's footprint (scene units) times this is its width in (s, t) (chapter 14's mip-map level).
  Real textureScale(int primitive, const Vec3& point, Real time = 0) const;
  /// The curvature of primitive `primitive` (1/radius for a sphere, 0 for a triangle), per scene unit: how much a
  /// reflection there widens a ray cone.
  Real curvature(int primitive) const
  {
    return std::size_t(primitive) < spheres.size() ? 1 / spheres[std::size_t(primitive)].radius : 0;
  }

  /// Material `m`'s colour at the hit: its texture's at the hit's (u, v), or its constant colour.
  Color colorAt(const Material& m, const Hit& hit, Real footprint = 0) const
  {
    return m.colorTexture ? m.colorTexture->eval(textureLookup(hit.primitive, hit.point, hit.time, footprint))
                          : m.color;
  }
  /// Emission of primitive `primitive`'s material at `point`: its texture's there, or the constant.
  Color emissionAt(int primitive, const Vec3& point, Real time = 0) const
  {
    const Material& m = materials[std::size_t(materialOf(primitive))];
    return m.emissionTexture ? m.emissionTexture->eval(textureLookup(primitive, point, time)) : m.emission;
  }

  /// The camera for an image of width × height pixels (the scene's own size when these are 0), with the scene's
  /// lens (aperture and focus).
  Camera makeCamera(int width = 0, int height = 0) const;
};

/// The first place where `scene`'s geometry lies beyond ±bound, as a phrase ("sphere 3's radius, 2e+20"), or an
/// empty string when it all lies within. What is checked: the camera's eye and focal point, each sphere's centre and
/// radius, each mesh vertex and each point light's position (the lens and the motion are not: for chapter 17, whose
/// float kernels use neither, against kMaxSceneExtentFloat, where the loader has checked kMaxSceneExtent).
std::string beyondSceneExtent(const Scene& scene, double bound);

/// The first of `scene`'s lengths below `smallest`, as a phrase ("sphere 6's radius, 1.65e-24"), or an empty
/// string when none is: each sphere's radius, the distance from the camera's eye to its focal point, and each
/// triangle's size (the square root of twice its area). For chapter 17, against kMinSceneLengthFloat, where the
/// loader has checked kMinSceneLength.
std::string belowSceneLength(const Scene& scene, double smallest);

/// A fault in a scene file. what() is the whole message: "FILE:LINE:COLUMN: /json/path: what is wrong".
class SceneError : public std::runtime_error {
public:
  using std::runtime_error::runtime_error;
};

/// Reads and validates a scene file (a regular file of at most 64 MiB), and the mesh files it names (relative to
/// the scene file's folder). @throws SceneError naming the file, the place and the fault; the message is one
/// printable line.
/// @param path The scene file.
/// @param sizeGiven True when the image size comes from elsewhere (the command line's --width or --height): the
/// scene's own width × height may then exceed kMaxPixels (each must still lie in [1, kMaxPixels]).
Scene loadScene(const std::string& path, bool sizeGiven = false);

/// Parses and validates scene text; `fileName` is used in messages and to find mesh files (relative to its
/// folder). @throws SceneError.
Scene parseScene(std::string_view text, const std::string& fileName);

/// Adds `n` rays to this thread's count (rayCount): rays that a kernel traced for many at once, outside
/// Scene::intersect and Scene::occluded (chapter 16).
void countRays(std::uint64_t n);

/// Rays this thread has traced through Scene::intersect and Scene::occluded since it started.
/// A per-thread statistic read by the render loop (like pbrt's stat counters); never shared between threads.
std::uint64_t rayCount();

} // namespace raylife

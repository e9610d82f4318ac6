/// @file ray_stream.h
/// @brief Many rays at once, stored by coordinate (structure of arrays), and the kernels that work on them with one
/// ray per SIMD lane: the nearest and any sphere of a flat list, the hit records, the light samples and their shadow
/// rays, and the bounces of diffuse and glossy hits. The wavefront of chapter 16 is built of them.
///
/// Why lanes across rays. One ray against one sphere is a short chain of arithmetic with nothing to do side by side;
/// the same chain for eight or sixteen rays fills the vector registers. Stored by coordinate (all the origins' x,
/// then all their y, ...), the rays of lanes i .. i + L − 1 are one load per coordinate.
///
/// The vector code goes through Google Highway (hwy, Debian's libhwy-dev), compiled for several instruction sets in
/// one binary (SSE4, AVX2, AVX-512 and a portable fallback) and chosen at run time for the CPU it runs on: the
/// build stays generic x86-64. simdTargets() lists what the machine runs and forceSimdTarget() picks one (for tests
/// and benchmarks).
///
/// The contract: each lane does, operation for operation, what the scalar code of the library does for one ray
/// (intersectSphere over the list in order; lambertianSample, phongSample and Frame; ...), with the same IEEE
/// operations in the same order and none fused (the build says -ffp-contract=off), and libm's own functions (pow,
/// atan2, acos, sin and cos) called lane by lane where the scalar code calls them. So every kernel gives the scalar
/// code's answer bit for bit, in every instruction set: tests/wavefront checks it on random rays.
#pragma once

#include "core/math.h"
#include "core/sample_tree.h"
#include "geometry/ray.h"
#include "geometry/sphere.h"
#include "scene/camera.h"

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

namespace raylife {

/// Rays stored by coordinate: ray i is (ox[i], oy[i], oz[i]) + t·(dx[i], dy[i], dz[i]) for t in [0, tmax[i]).
/// Every array has size() entries; the directions are unit and tmin is 0 (raylife's spawned rays; camera rays).
struct RayStream {
  std::vector<Real> ox; ///< Origins, world space: x.
  std::vector<Real> oy; ///< Origins, world space: y.
  std::vector<Real> oz; ///< Origins, world space: z.
  std::vector<Real> dx; ///< Unit directions: x.
  std::vector<Real> dy; ///< Unit directions: y.
  std::vector<Real> dz; ///< Unit directions: z.
  std::vector<Real> tmax; ///< The end of each ray's interval, > 0 (+∞ for a ray that goes on forever).

  /// Rays in the stream.
  std::size_t size() const { return ox.size(); }
  /// Makes room for `n` rays: the first min(n, size()) keep their values, the others are unspecified.
  void resize(std::size_t n);
  /// Ray i, from `ray` (whose tmin must be 0). (Inline: every queue's push calls it. Defined in the .cpp, only
  /// link-time optimisation could inline it, and its inliner once left it a call in chapter 16's shade.)
  void set(std::size_t i, const Ray& ray)
  {
    ox[i] = ray.origin.x, oy[i] = ray.origin.y, oz[i] = ray.origin.z;
    dx[i] = ray.direction.x, dy[i] = ray.direction.y, dz[i] = ray.direction.z;
    tmax[i] = ray.tmax;
  }
  /// Ray i as a Ray (tmin 0, time `time`).
  Ray get(std::size_t i, Real time = 0) const
  {
    return Ray{Vec3(ox[i], oy[i], oz[i]), Vec3(dx[i], dy[i], dz[i]), 0, tmax[i], time};
  }
};

/// A flat list of still spheres stored by coordinate, for the stream kernels.
struct SphereList {
  std::vector<Real> cx; ///< Centres, world space: x.
  std::vector<Real> cy; ///< Centres, world space: y.
  std::vector<Real> cz; ///< Centres, world space: z.
  std::vector<Real> radius; ///< Radii, > 0.
  /// The spheres of `spheres`, in order (their centres at time 0).
  static SphereList from(std::span<const Sphere> spheres);
  /// Spheres in the list.
  std::size_t size() const { return cx.size(); }
};

/// For rays [0, count) of `rays`: the nearest sphere of `spheres` in [0, tmax), exactly as the loop
/// `for each sphere, in order: t = intersectSphere(o, d, c, r, 0, nearest)` finds it (the lowest index on a tie).
/// @param spheres the list. @param rays the rays (at least `count`). @param count how many rays to trace.
/// @param t out: t[i] the hit's distance, or rays.tmax[i] when none is hit; at least `count` entries.
/// @param sphere out: sphere[i] the sphere's index in the list, or −1 when none is hit; at least `count` entries.
void nearestSpheres(const SphereList& spheres, const RayStream& rays, std::size_t count, std::span<Real> t,
                    std::span<std::int32_t> sphere);
/// nearestSpheres for rays [first, first + count) of `rays` alone, into entries [first, first + count) of t and
/// sphere (each at least first + count long).
void nearestSpheres(const SphereList& spheres, const RayStream& rays, std::size_t first, std::size_t count,
                    std::span<Real> t, std::span<std::int32_t> sphere);

/// For rays [0, count): whether any sphere of `spheres` is hit in [0, tmax), exactly when nearestSpheres finds one.
/// @param spheres the list. @param rays the rays (at least `count`). @param count how many rays to trace.
/// @param occluded out: occluded[i] 1 when ray i is blocked, else 0; at least `count` entries.
void anySpheres(const SphereList& spheres, const RayStream& rays, std::size_t count,
                std::span<std::uint8_t> occluded);

/// Each ray's own short list of spheres, and a list every ray tests (anySpheresListed): a light buffer's cells, say.
struct SphereLists {
  const SphereList& spheres;            ///< The spheres, by number.
  std::span<const LaneIndex> listed;    ///< The rays' lists back to back: numbers in `spheres`.
  std::span<const LaneIndex> first;     ///< Ray i's list starts at listed[first[i]] …
  std::span<const LaneIndex> size;      ///< … and holds size[i] ≥ 0 numbers.
  std::span<const LaneIndex> everywhere; ///< Numbers in `spheres` that every ray tests.
};

/// For rays [first, first + count): whether a sphere of the ray's own list or of the list every ray tests is hit in
/// [0, tmax), exactly when the loop over those spheres with intersectSphere finds one. Each lane follows its own
/// ray's list, gathering each sphere's centre and radius, so a group of rays waits on the longest of its lists.
/// @param lists the spheres and the lists (lists.first and lists.size at least first + count long).
/// @param rays the rays. @param first the first ray to trace. @param count how many rays to trace.
/// @param occluded out: entry i 1 where ray i is blocked, else 0 (at least first + count long).
void anySpheresListed(const SphereLists& lists, const RayStream& rays, std::size_t first, std::size_t count,
                      std::span<std::uint8_t> occluded);

/// Diffuse hits stored by coordinate: the shading normal and the incoming ray's direction at each, and the two
/// uniform numbers of each hit's bounce.
struct DiffuseBounceInput {
  std::span<const Real> nx; ///< Unit shading normals: x.
  std::span<const Real> ny; ///< Unit shading normals: y.
  std::span<const Real> nz; ///< Unit shading normals: z.
  std::span<const Real> dx; ///< Unit directions of the rays that arrived (towards the surface): x.
  std::span<const Real> dy; ///< Unit directions of the rays that arrived (towards the surface): y.
  std::span<const Real> dz; ///< Unit directions of the rays that arrived (towards the surface): z.
  std::span<const Real> u1; ///< The bounce's first uniform number (u.x), in [0, 1).
  std::span<const Real> u2; ///< The bounce's second uniform number (u.y), in [0, 1).
};

/// Where each diffuse bounce goes: the world direction and the two numbers its weight needs.
struct DiffuseBounceOutput {
  std::span<Real> wx; ///< The sampled direction in world space, unit: x.
  std::span<Real> wy; ///< The sampled direction in world space, unit: y.
  std::span<Real> wz; ///< The sampled direction in world space, unit: z.
  std::span<Real> cosTheta; ///< Its cosine with the normal in the shading frame (wi.z; negative below).
  std::span<Real> pdf; ///< Its solid-angle pdf, |cosθ|/π; 0 where the bounce failed (see below).
};

/// For hits [0, count): lambertianSample(ρ, wo, (u1, u2)) in the frame Frame::fromNormal(n), wo = toLocal(−d), its
/// direction turned to world space by toWorld: what chapter 8 computes for a diffuse bounce, bit for bit. pdf is 0
/// where lambertianSample has no sample (wo in the surface, or a direction exactly in it): the path ends there.
void diffuseBounces(const DiffuseBounceInput& in, std::size_t count, const DiffuseBounceOutput& out);

/// Glossy hits stored by coordinate: what a diffuse hit has, and each surface's Phong exponent.
struct GlossyBounceInput {
  DiffuseBounceInput hit; ///< The shading normals, the incoming directions and the two uniform numbers.
  std::span<const Real> exponent; ///< The Phong exponent, phongExponent(roughness), in [0, kMaxPhongExponent].
};

/// Where each glossy bounce goes: a diffuse bounce's numbers (its pdf phongPdf), and the factor of f.
struct GlossyBounceOutput {
  DiffuseBounceOutput bounce; ///< The world direction, its cosθ and its pdf (0 where the bounce failed: below).
  std::span<Real> fScale; ///< f = ρ_s · fScale: (n + 2)/(2π) cosⁿα, as phongEval computes it.
};

/// For hits [0, count): phongSample(ρ_s, n, wo, (u1, u2)) in the frame Frame::fromNormal(normal), wo = toLocal(−d),
/// its direction turned to world space by toWorld: chapter 8's glossy bounce, bit for bit (the lobe's cosine and
/// cosⁿα through libm's pow, lane by lane). pdf is 0 where phongSample has no sample (wo in the surface, or a
/// direction below it): the path ends there.
void glossyBounces(const GlossyBounceInput& in, std::size_t count, const GlossyBounceOutput& out);

/// Mirror and glass hits stored by coordinate: the shading normal and the incoming ray's direction at each, the
/// number that chooses between reflection and refraction, and each surface's index of refraction.
struct SpecularBounceInput {
  std::span<const Real> nx; ///< Unit shading normals: x.
  std::span<const Real> ny; ///< Unit shading normals: y.
  std::span<const Real> nz; ///< Unit shading normals: z.
  std::span<const Real> dx; ///< Unit directions of the rays that arrived (towards the surface): x.
  std::span<const Real> dy; ///< Unit directions of the rays that arrived (towards the surface): y.
  std::span<const Real> dz; ///< Unit directions of the rays that arrived (towards the surface): z.
  std::span<const Real> uChoice; ///< The number that chooses the lobe, in [0, 1) (a mirror's is not used).
  std::span<const Real> eta; ///< A glass's index of refraction, η_t/η_i > 0 (Material::ior); 0 for a mirror.
};

/// For hits [0, count): mirrorSample(ρ, wo) where eta is 0, else dielectricSample(ρ, eta, wo, uChoice), in the frame
/// Frame::fromNormal(n), wo = toLocal(−d), the direction turned to world space by toWorld: chapter 8's mirror and
/// glass bounces, bit for bit. Every such sample's f is ρ · pdf / |cosθ| (its pdf is the chosen lobe's share, F or
/// 1 − F, or 1 for a mirror), so out.pdf gives both. pdf is 0 where there is no sample (wo in the surface, or a
/// refracted direction in it): the path ends there.
void specularBounces(const SpecularBounceInput& in, std::size_t count, const DiffuseBounceOutput& out);

/// Rays that hit spheres, stored by coordinate: each ray, its hit's t and the sphere.
struct SphereHitInput {
  std::span<const Real> ox; ///< The rays' origins: x.
  std::span<const Real> oy; ///< The rays' origins: y.
  std::span<const Real> oz; ///< The rays' origins: z.
  std::span<const Real> dx; ///< The rays' unit directions: x.
  std::span<const Real> dy; ///< The rays' unit directions: y.
  std::span<const Real> dz; ///< The rays' unit directions: z.
  std::span<const Real> t; ///< Where each hits its sphere.
  std::span<const Real> cx; ///< The centre of each ray's sphere: x.
  std::span<const Real> cy; ///< The centre of each ray's sphere: y.
  std::span<const Real> cz; ///< The centre of each ray's sphere: z.
  std::span<const Real> radius; ///< The radius of each ray's sphere.
};

/// The surface points of those hits, stored by coordinate.
struct SphereHitOutput {
  std::span<Real> px; ///< The point, re-projected onto the sphere: x.
  std::span<Real> py; ///< The point, re-projected onto the sphere: y.
  std::span<Real> pz; ///< The point, re-projected onto the sphere: z.
  std::span<Real> nx; ///< The outward unit normal: x.
  std::span<Real> ny; ///< The outward unit normal: y.
  std::span<Real> nz; ///< The outward unit normal: z.
  std::span<Real> ex; ///< The bound on the point's error, per coordinate: x.
  std::span<Real> ey; ///< The bound on the point's error, per coordinate: y.
  std::span<Real> ez; ///< The bound on the point's error, per coordinate: z.
};

/// For hits [0, count): sphereSurfacePoint(o, d, t, c, r), bit for bit: the hit record Scene::intersect makes on a
/// sphere (its point, normal and error bound).
void sphereHitPoints(const SphereHitInput& in, std::size_t count, const SphereHitOutput& out);

/// Rays that hit triangles, stored by coordinate: each ray and its triangle.
struct TriangleHitInput {
  std::span<const Real> ox;   ///< The rays' origins: x.
  std::span<const Real> oy;   ///< The rays' origins: y.
  std::span<const Real> oz;   ///< The rays' origins: z.
  std::span<const Real> dx;   ///< The rays' unit directions: x.
  std::span<const Real> dy;   ///< The rays' unit directions: y.
  std::span<const Real> dz;   ///< The rays' unit directions: z.
  std::span<const Real> tmax; ///< The rays' far ends (their tmin is 0, as RayStream::get gives it).
  std::span<const Real> ax;   ///< Corner p0 of each ray's triangle: x.
  std::span<const Real> ay;   ///< Corner p0: y.
  std::span<const Real> az;   ///< Corner p0: z.
  std::span<const Real> bx;   ///< Corner p1: x.
  std::span<const Real> by;   ///< Corner p1: y.
  std::span<const Real> bz;   ///< Corner p1: z.
  std::span<const Real> cx;   ///< Corner p2: x.
  std::span<const Real> cy;   ///< Corner p2: y.
  std::span<const Real> cz;   ///< Corner p2: z.
};

/// The surface points of those hits, stored by coordinate.
struct TriangleHitOutput {
  std::span<Real> px; ///< The point from its barycentrics (trianglePoint): x.
  std::span<Real> py; ///< The point: y.
  std::span<Real> pz; ///< The point: z.
  std::span<Real> ex; ///< The bound on the point's error, per coordinate: x.
  std::span<Real> ey; ///< The bound: y.
  std::span<Real> ez; ///< The bound: z.
  std::span<Real> gx; ///< The unit geometric normal (triangleNormal): x.
  std::span<Real> gy; ///< The normal: y.
  std::span<Real> gz; ///< The normal: z.
  std::span<Real> b0; ///< The barycentric weight of p0 (for a smooth mesh's shading normal).
  std::span<Real> b1; ///< The weight of p1.
  std::span<Real> b2; ///< The weight of p2.
};

/// For hits [0, count): what Scene::intersect's record of a triangle hit takes from the triangle, bit for bit:
/// intersectTriangle's barycentrics on the same ray (1/3 each, as the scene's record, should it refuse), the point
/// and its error bound from them (trianglePoint), and the geometric normal (triangleNormal). A lane whose normal
/// needs safeNormalize's rare branch, or (float) whose edge function is exactly 0, gets the scalar functions.
void triangleHitPoints(const TriangleHitInput& in, std::size_t count, const TriangleHitOutput& out);

/// Shading points and the still spherical light each chose (LightSampler::choose), stored by coordinate.
struct SphereLightInput {
  std::span<const Real> px; ///< The shading points, world space: x.
  std::span<const Real> py; ///< The shading points, world space: y.
  std::span<const Real> pz; ///< The shading points, world space: z.
  std::span<const Real> cx; ///< The centre of each point's light, a still sphere: x.
  std::span<const Real> cy; ///< The centre of each point's light, a still sphere: y.
  std::span<const Real> cz; ///< The centre of each point's light, a still sphere: z.
  std::span<const Real> radius; ///< The radius of each point's light.
  std::span<const Real> u1; ///< LightChoice::u.x, in [0, 1).
  std::span<const Real> u2; ///< LightChoice::u.y, in [0, 1).
  std::span<const Real> choice; ///< LightChoice::choice, in (0, 1].
  std::span<const Real> guide; ///< LightChoice::guide, > 0.
};

/// The light samples' directions and pdfs, stored by coordinate.
struct SphereLightOutput {
  std::span<Real> wx; ///< The direction towards the light, unit, world space: x.
  std::span<Real> wy; ///< The direction towards the light, unit, world space: y.
  std::span<Real> wz; ///< The direction towards the light, unit, world space: z.
  std::span<Real> pdf; ///< Its solid-angle pdf, light choice and guide included.
};

/// For points [0, count): sampleSphereCone(p, c, r, u) and choice · sphereConePdf(p, c, r) · guide, bit for bit:
/// the direction and pdf LightSampler::sampleChosen gives for a sphere.
void sphereLightDirections(const SphereLightInput& in, std::size_t count, const SphereLightOutput& out);

/// Shading points and the triangle light each chose (LightSampler::choose), stored by coordinate.
struct TriangleLightInput {
  std::span<const Real> px; ///< The shading points, world space: x.
  std::span<const Real> py; ///< The shading points, world space: y.
  std::span<const Real> pz; ///< The shading points, world space: z.
  std::span<const Real> ax; ///< Corner p0 of each point's light, world space: x.
  std::span<const Real> ay; ///< Corner p0: y.
  std::span<const Real> az; ///< Corner p0: z.
  std::span<const Real> bx; ///< Corner p1: x.
  std::span<const Real> by; ///< Corner p1: y.
  std::span<const Real> bz; ///< Corner p1: z.
  std::span<const Real> cx; ///< Corner p2: x.
  std::span<const Real> cy; ///< Corner p2: y.
  std::span<const Real> cz; ///< Corner p2: z.
  std::span<const Real> u1; ///< LightChoice::u.x, in [0, 1).
  std::span<const Real> u2; ///< LightChoice::u.y, in [0, 1).
};

/// The triangle light samples' directions and pdfs, stored by coordinate.
struct TriangleLightOutput {
  std::span<Real> wx;  ///< The direction towards the light, unit, world space: x (0 where there is no sample).
  std::span<Real> wy;  ///< The direction: y.
  std::span<Real> wz;  ///< The direction: z.
  std::span<Real> pdf; ///< Its solid-angle pdf (TriangleLightSample::pdf, > 0), or 0 where there is no sample.
};

/// For points [0, count): sampleTriangleLight(p, p0, p1, p2, u), bit for bit: the direction and the pdf (light choice
/// and guide not included) LightSampler::sampleChosen gives for a triangle. The sampling by solid angle runs in the
/// lanes, its atan2, acos, sin and cos through the scalar functions lane by lane (so the same bits); a lane sampled
/// by area, or one of the rare cases (a point on a corner, a degenerate spherical triangle, a vector too short or
/// too long for safeNormalize's usual branch), gets the scalar function itself.
void triangleLightDirections(const TriangleLightInput& in, std::size_t count, const TriangleLightOutput& out);

/// The light guide's grid of cells (LightSampler::GuideGrid) with, per cell, the number guideCells gives for it.
struct GuideCellGrid {
  Vec3 min{0};        ///< The grid's lowest corner, world space.
  Vec3 scale{0};      ///< Cells per scene unit along each axis, > 0.
  glm::ivec3 size{0}; ///< Cells along each axis, ≥ 1 (at most 2²⁴ cells in all in a float build).
  /// Per cell: its own number where the guide learned something there, else −1; empty: no guide.
  std::span<const SampleForestIndex> cell;
};

/// For points [0, count): LightSampler::cellOf, bit for bit: the guide's cell of (px, py, pz)[i] or −1.
void guideCells(const GuideCellGrid& grid, std::span<const Real> px, std::span<const Real> py,
                std::span<const Real> pz, std::size_t count, std::span<SampleForestIndex> cell);

/// Light samples' direction numbers and the light guide's mixture that warps each (LightChoice::u, guideTree,
/// guideShare), stored by coordinate.
struct GuideWarpInput {
  /// The root, in the forest, of the tree whose mixture warps each point's numbers (SampleTree::appendTo), or −1
  /// where they are not guided.
  std::span<const SampleForestIndex> root;
  std::span<const Real> alpha; ///< The mixture's uniform share α, in (0, 1].
  std::span<const Real> u1;    ///< The numbers as drawn: x, in [0, 1).
  std::span<const Real> u2;    ///< The numbers as drawn: y, in [0, 1).
};

/// The warped numbers and the mixture's density there, stored by coordinate.
struct GuideWarpOutput {
  std::span<Real> u1;  ///< The warped numbers: x, in [0, 1).
  std::span<Real> u2;  ///< The warped numbers: y, in [0, 1).
  std::span<Real> pdf; ///< The mixture's density at (u1, u2) (LightChoice::guide), > 0; 1 where not guided.
};

/// For points [0, count): SampleTree::sampleMixture(u, α) of the tree rooted at `root` in `forest`, its point and
/// density bit for bit (u unchanged and density 1 where root is −1). Each lane walks its own tree (gathering its
/// nodes), twice: down to the leaf its numbers choose, then down to the leaf of the point, for its density.
void guidedWarps(const SampleForest& forest, const GuideWarpInput& in, std::size_t count, const GuideWarpOutput& out);

/// Light samples at Lambertian or glossy surfaces, stored by coordinate: what the light brings if its shadow ray gets
/// through.
struct SurfaceLightInput {
  std::span<const Real> nx; ///< The unit shading normals: x.
  std::span<const Real> ny; ///< The unit shading normals: y.
  std::span<const Real> nz; ///< The unit shading normals: z.
  std::span<const Real> dx; ///< The unit directions of the rays that arrived (towards the surface): x.
  std::span<const Real> dy; ///< The unit directions of the rays that arrived (towards the surface): y.
  std::span<const Real> dz; ///< The unit directions of the rays that arrived (towards the surface): z.
  std::span<const Real> wx; ///< The unit directions towards the light: x.
  std::span<const Real> wy; ///< The unit directions towards the light: y.
  std::span<const Real> wz; ///< The unit directions towards the light: z.
  std::span<const Real> pdf; ///< The light sample's solid-angle pdf, > 0.
  std::span<const Real> betaR; ///< The paths' throughputs: red.
  std::span<const Real> betaG; ///< The paths' throughputs: green.
  std::span<const Real> betaB; ///< The paths' throughputs: blue.
  std::span<const Real> rhoR; ///< The surfaces' albedos (a glossy surface's ρ_s): red.
  std::span<const Real> rhoG; ///< The surfaces' albedos: green.
  std::span<const Real> rhoB; ///< The surfaces' albedos: blue.
  std::span<const Real> leR; ///< The radiance arriving from the light (its Le): red.
  std::span<const Real> leG; ///< The radiance arriving from the light (its Le): green.
  std::span<const Real> leB; ///< The radiance arriving from the light (its Le): blue.
  bool power = true; ///< The power heuristic (else the balance heuristic) weighs the sample.
  /// The lights are points (delta lights, which BSDF sampling never finds): the weight is 1 and `pdf` is the
  /// probability of having chosen the light; `power` is then unused.
  bool delta = false;
  /// Each surface's normalised Phong exponent, phongExponent(roughness), in [0, kMaxPhongExponent] where it is glossy,
  /// or −1 where it is Lambertian; empty: every surface is Lambertian.
  std::span<const Real> exponent = {};
};

/// The light each sample brings, stored by coordinate, and whether the BSDF lets any through.
struct SurfaceLightOutput {
  std::span<Real> lightR; ///< β f |cosθ| Le w / pdf: red.
  std::span<Real> lightG; ///< β f |cosθ| Le w / pdf: green.
  std::span<Real> lightB; ///< β f |cosθ| Le w / pdf: blue.
  std::span<Real> useful; ///< 1 where f ≠ 0 (the shadow ray is worth tracing), else 0.
};

/// For samples [0, count): chapter 8's light sample at a Lambertian or glossy surface, bit for bit: f and its pdf in
/// Frame::fromNormal(n) (wo = −d), lambertianEval and lambertianPdf, or phongEval and phongPdf (their power of cosα
/// through libm's pow, lane by lane, as the scalar code calls it), the MIS weight powerHeuristic (or balanceHeuristic)
/// of the light's pdf against the BSDF's (1 for point lights: `delta`), and β f |cosθ| Le (w / pdf).
void surfaceLightSamples(const SurfaceLightInput& in, std::size_t count, const SurfaceLightOutput& out);

/// Shadow rays from surface points towards spheres, stored by coordinate: each point with its error bound and
/// geometric normal, the direction, and the sphere the ray is aimed at.
struct ShadowSpawnInput {
  std::span<const Real> px; ///< The surface points: x.
  std::span<const Real> py; ///< The surface points: y.
  std::span<const Real> pz; ///< The surface points: z.
  std::span<const Real> ex; ///< Their error bounds: x.
  std::span<const Real> ey; ///< Their error bounds: y.
  std::span<const Real> ez; ///< Their error bounds: z.
  std::span<const Real> gx; ///< Their geometric normals: x.
  std::span<const Real> gy; ///< Their geometric normals: y.
  std::span<const Real> gz; ///< Their geometric normals: z.
  std::span<const Real> wx; ///< The unit directions of the rays: x.
  std::span<const Real> wy; ///< The unit directions of the rays: y.
  std::span<const Real> wz; ///< The unit directions of the rays: z.
  std::span<const Real> cx; ///< The centres of the spheres they are aimed at: x.
  std::span<const Real> cy; ///< The centres of the spheres they are aimed at: y.
  std::span<const Real> cz; ///< The centres of the spheres they are aimed at: z.
  std::span<const Real> radius; ///< The radii of the spheres they are aimed at.
};

/// The shadow rays' origins and lengths, stored by coordinate.
struct ShadowSpawnOutput {
  std::span<Real> ox; ///< The origin, off the surface (offsetRayOrigin): x.
  std::span<Real> oy; ///< The origin, off the surface (offsetRayOrigin): y.
  std::span<Real> oz; ///< The origin, off the surface (offsetRayOrigin): z.
  std::span<Real> t; ///< Where the ray first meets its sphere; +∞ where it does not.
};

/// For rays [0, count): the origin spawnRay(hit, w) gives (offsetRayOrigin(p, e, g, w)) and the first root of the
/// ray with its sphere in [0, ∞) (intersectSphere), bit for bit: the ray lightVisible tests for a spherical light.
void shadowRaysToSpheres(const ShadowSpawnInput& in, std::size_t count, const ShadowSpawnOutput& out);

/// Surface points, the directions of shadow rays from them, and the triangles the rays are aimed at, stored by
/// coordinate.
struct TriangleShadowInput {
  std::span<const Real> px; ///< The surface points: x.
  std::span<const Real> py; ///< The surface points: y.
  std::span<const Real> pz; ///< The surface points: z.
  std::span<const Real> ex; ///< Their error bounds: x.
  std::span<const Real> ey; ///< Their error bounds: y.
  std::span<const Real> ez; ///< Their error bounds: z.
  std::span<const Real> gx; ///< Their geometric normals: x.
  std::span<const Real> gy; ///< Their geometric normals: y.
  std::span<const Real> gz; ///< Their geometric normals: z.
  std::span<const Real> wx; ///< The unit directions of the rays: x.
  std::span<const Real> wy; ///< The unit directions of the rays: y.
  std::span<const Real> wz; ///< The unit directions of the rays: z.
  std::span<const Real> ax; ///< Corner p0 of the triangle each ray is aimed at: x.
  std::span<const Real> ay; ///< Corner p0: y.
  std::span<const Real> az; ///< Corner p0: z.
  std::span<const Real> bx; ///< Corner p1: x.
  std::span<const Real> by; ///< Corner p1: y.
  std::span<const Real> bz; ///< Corner p1: z.
  std::span<const Real> cx; ///< Corner p2: x.
  std::span<const Real> cy; ///< Corner p2: y.
  std::span<const Real> cz; ///< Corner p2: z.
};

/// For rays [0, count): the origin spawnRay(hit, w) gives (offsetRayOrigin(p, e, g, w)) and where the ray meets its
/// triangle in [0, ∞) (intersectTriangle's t; +∞ where it does not), bit for bit: the shadow ray chapter 8 makes for
/// a triangle light (Scene::intersectPrimitive gives its length). The watertight test runs in the lanes, each lane
/// with its own choice of axes; in a float build a lane with an edge function of exactly 0, which the scalar test
/// decides again in double, gets the scalar test.
void shadowRaysToTriangles(const TriangleShadowInput& in, std::size_t count, const ShadowSpawnOutput& out);

/// Shading points and the point light each chose, stored by coordinate: each point with its error bound and
/// geometric normal (as a Hit holds them), and the light's position and intensity.
struct PointLightInput {
  std::span<const Real> px; ///< The surface points: x.
  std::span<const Real> py; ///< The surface points: y.
  std::span<const Real> pz; ///< The surface points: z.
  std::span<const Real> ex; ///< Their error bounds: x.
  std::span<const Real> ey; ///< Their error bounds: y.
  std::span<const Real> ez; ///< Their error bounds: z.
  std::span<const Real> gx; ///< Their geometric normals: x.
  std::span<const Real> gy; ///< Their geometric normals: y.
  std::span<const Real> gz; ///< Their geometric normals: z.
  std::span<const Real> lx; ///< The position of each point's light, world space: x.
  std::span<const Real> ly; ///< The position of each point's light, world space: y.
  std::span<const Real> lz; ///< The position of each point's light, world space: z.
  std::span<const Real> iR; ///< Its radiant intensity, ≥ 0: red.
  std::span<const Real> iG; ///< Its radiant intensity, ≥ 0: green.
  std::span<const Real> iB; ///< Its radiant intensity, ≥ 0: blue.
};

/// The light arriving from each point light and the shadow ray towards it, stored by coordinate.
struct PointLightOutput {
  std::span<Real> wx;  ///< The unit direction towards the light: x.
  std::span<Real> wy;  ///< The unit direction towards the light: y.
  std::span<Real> wz;  ///< The unit direction towards the light: z.
  std::span<Real> liR; ///< The radiance-like term that arrives, I / r²: red.
  std::span<Real> liG; ///< The radiance-like term that arrives, I / r²: green.
  std::span<Real> liB; ///< The radiance-like term that arrives, I / r²: blue.
  std::span<Real> ox;  ///< The shadow ray's origin, off the surface (offsetRayOrigin): x.
  std::span<Real> oy;  ///< The shadow ray's origin, off the surface (offsetRayOrigin): y.
  std::span<Real> oz;  ///< The shadow ray's origin, off the surface (offsetRayOrigin): z.
  std::span<Real> t;   ///< The shadow ray's tmax: its distance to the light, shortened by kShadowRayShorten.
  /// 1 where light arrives (the point is not the light's own position), else 0: there the other outputs are
  /// unspecified and the path takes no light sample.
  std::span<Real> arrives;
};

/// For points [0, count): PointLight::arrivalAt (the direction and I / r²) and the ray spawnRayTo makes towards the
/// light (its origin and tmax; its direction is the arrival's), bit for bit: chapter 8's light sample of a point
/// light, and its shadow ray.
void pointLightRays(const PointLightInput& in, std::size_t count, const PointLightOutput& out);

/// Camera rays' places on the film, stored by coordinate: each pixel sample's pixel and where in the pixel its ray
/// goes, as pixelOffsetParts gives it (render_loop.h: PinholeSample::offset).
struct FilmInput {
  std::span<const Real> x;       ///< The pixel's column, in [0, width): its left edge on the film.
  std::span<const Real> y;       ///< The pixel's row, in [0, height): its top edge.
  std::span<const Real> offsetX; ///< The offset in the pixel as a quotient: its numerator, x.
  std::span<const Real> offsetY; ///< Its numerator, y.
  std::span<const Real> strata;  ///< Its denominator, ≥ 1 (1 where the offset is not a stratum's).
};

/// Unit directions, stored by coordinate.
struct DirectionOutput {
  std::span<Real> dx; ///< x.
  std::span<Real> dy; ///< y.
  std::span<Real> dz; ///< z.
};

/// For samples [0, count): the direction of camera.ray(film), film = (x, y) + (offsetX, offsetY) / strata, bit for
/// bit: the pinhole camera's primary rays (their origin is the eye, their tmax +∞), as every chapter makes them.
void pinholeDirections(const Camera& camera, const FilmInput& in, std::size_t count, const DirectionOutput& out);

/// Pixel samples' keys stored by coordinate (PixelSampleKey's fields, render_loop.h).
struct PixelSampleColumns {
  std::span<const std::int32_t> x;      ///< The pixels' columns, ≥ 0.
  std::span<const std::int32_t> y;      ///< Their rows, ≥ 0.
  std::span<const std::int32_t> sample; ///< The samples' indices in the render, ≥ 0.
};

/// Random number generators stored by coordinate: each one's Pcg32::state() and Pcg32::increment().
struct GeneratorColumns {
  std::span<std::uint64_t> state;     ///< The states.
  std::span<std::uint64_t> increment; ///< The increments (odd).
};

/// For samples [0, count): the generator of Sampler(seed, x, y, sample) as it starts, bit for bit, so that
/// Sampler(Pcg32::fromState(state, increment)) draws what that sampler draws. The seeding's hashes (mix64) and the
/// generator's first two steps run in lanes of 64-bit integers (with AVX-512 one multiplication a product, with
/// the other instruction sets three of 32 bits): a wavefront's camera rays' numbers, made at once.
void pixelSamplers(std::uint64_t seed, const PixelSampleColumns& in, std::size_t count, const GeneratorColumns& out);

/// An instruction set the kernels are compiled for and this CPU runs.
struct SimdTarget {
  std::int64_t id = 0; ///< Highway's bit for it (hwy::Targets).
  std::string name;    ///< Its name: "AVX3" (AVX-512), "AVX2", "SSE4", "EMU128" (portable), ...
  int lanes = 0;       ///< Reals per vector in it.
};

/// The instruction sets the kernels can run on this CPU, the best first (the one they use by default).
std::vector<SimdTarget> simdTargets();

/// Makes the kernels use `target` (one of simdTargets()) from now on, or, with id 0, the best again. For tests
/// and benchmarks: not thread-safe, call it while no kernel runs.
void forceSimdTarget(std::int64_t id);

/// The instruction set the kernels use now.
SimdTarget currentSimdTarget();

} // namespace raylife

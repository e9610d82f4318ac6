/// @file ray_stream.h
/// @brief Many rays at once, stored by coordinate (structure of arrays), and the kernels that work on them with one
/// ray per SIMD lane: the nearest and any sphere of a flat list, and the cosine-weighted bounce of diffuse hits.
/// The wavefront of chapter 16 is built of them.
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
/// (intersectSphere over the list in order; lambertianSample and Frame), with the same IEEE operations in the same
/// order and none fused (the build says -ffp-contract=off). So every kernel gives the scalar code's answer bit for
/// bit, in every instruction set: tests/wavefront checks it on random rays.
#pragma once

#include "core/math.h"
#include "geometry/ray.h"
#include "geometry/sphere.h"

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

namespace raylife {

/// Rays stored by coordinate: ray i is (ox[i], oy[i], oz[i]) + t·(dx[i], dy[i], dz[i]) for t in [0, tmax[i]).
/// Every array has size() entries; the directions are unit and tmin is 0 (raylife's spawned rays; camera rays).
struct RayStream {
  std::vector<Real> ox, oy, oz; ///< Origins, world space.
  std::vector<Real> dx, dy, dz; ///< Unit directions.
  std::vector<Real> tmax;       ///< The end of each ray's interval, > 0 (+∞ for a ray that goes on forever).

  /// Rays in the stream.
  std::size_t size() const { return ox.size(); }
  /// Makes room for `n` rays (their values unspecified).
  void resize(std::size_t n);
  /// Ray i, from `ray` (whose tmin must be 0).
  void set(std::size_t i, const Ray& ray);
  /// Ray i as a Ray (tmin 0, time `time`).
  Ray get(std::size_t i, Real time = 0) const
  {
    return Ray{Vec3(ox[i], oy[i], oz[i]), Vec3(dx[i], dy[i], dz[i]), 0, tmax[i], time};
  }
};

/// A flat list of still spheres stored by coordinate, for the stream kernels.
struct SphereList {
  std::vector<Real> cx, cy, cz; ///< Centres, world space.
  std::vector<Real> radius;     ///< Radii, > 0.
  /// The spheres of `spheres`, in order (their centres at time 0).
  static SphereList from(std::span<const Sphere> spheres);
  /// Spheres in the list.
  std::size_t size() const { return cx.size(); }
};

/// For rays [0, count) of `rays`: the nearest sphere of `spheres` in [0, tmax), exactly as the loop
/// `for each sphere, in order: t = intersectSphere(o, d, c, r, 0, nearest)` finds it (the lowest index on a tie):
/// t[i] its distance and sphere[i] its index, or t[i] = rays.tmax[i] and sphere[i] = −1 when none is hit.
/// @param t,sphere at least `count` entries each.
void nearestSpheres(const SphereList& spheres, const RayStream& rays, std::size_t count, std::span<Real> t,
                    std::span<std::int32_t> sphere);

/// For rays [0, count): occluded[i] = 1 when any sphere of `spheres` is hit in [0, tmax) (exactly when
/// nearestSpheres finds one), else 0. @param occluded at least `count` entries.
void anySpheres(const SphereList& spheres, const RayStream& rays, std::size_t count,
                std::span<std::uint8_t> occluded);

/// Diffuse hits stored by coordinate: the shading normal and the incoming ray's direction at each, and the two
/// uniform numbers of each hit's bounce.
struct DiffuseBounceInput {
  std::span<const Real> nx, ny, nz; ///< Unit shading normals.
  std::span<const Real> dx, dy, dz; ///< Unit directions of the rays that arrived (towards the surface).
  std::span<const Real> u1, u2;     ///< Uniform numbers in [0, 1): the bounce's (u.x, u.y).
};

/// Where each diffuse bounce goes: the world direction and the two numbers its weight needs.
struct DiffuseBounceOutput {
  std::span<Real> wx, wy, wz; ///< The sampled direction in world space, unit.
  std::span<Real> cosTheta;   ///< Its cosine with the normal in the shading frame (wi.z; negative below).
  std::span<Real> pdf;        ///< Its solid-angle pdf, |cosθ|/π; 0 where the bounce failed (see below).
};

/// For hits [0, count): lambertianSample(ρ, wo, (u1, u2)) in the frame Frame::fromNormal(n), wo = toLocal(−d), its
/// direction turned to world space by toWorld: what chapter 8 computes for a diffuse bounce, bit for bit. pdf is 0
/// where lambertianSample has no sample (wo in the surface, or a direction exactly in it): the path ends there.
void diffuseBounces(const DiffuseBounceInput& in, std::size_t count, const DiffuseBounceOutput& out);

/// Rays that hit spheres, stored by coordinate: each ray, its hit's t and the sphere.
struct SphereHitInput {
  std::span<const Real> ox, oy, oz, dx, dy, dz; ///< The rays (unit directions).
  std::span<const Real> t;                      ///< Where each hits its sphere.
  std::span<const Real> cx, cy, cz, radius;     ///< Each ray's sphere (its centre at the ray's time).
};

/// The surface points of those hits, stored by coordinate.
struct SphereHitOutput {
  std::span<Real> px, py, pz; ///< The point, re-projected onto the sphere.
  std::span<Real> nx, ny, nz; ///< The outward unit normal.
  std::span<Real> ex, ey, ez; ///< The bound on the point's error, per coordinate.
};

/// For hits [0, count): sphereSurfacePoint(o, d, t, c, r), bit for bit: the hit record Scene::intersect makes on a
/// sphere (its point, normal and error bound).
void sphereHitPoints(const SphereHitInput& in, std::size_t count, const SphereHitOutput& out);

/// Shading points and the still spherical light each chose (LightSampler::choose), stored by coordinate.
struct SphereLightInput {
  std::span<const Real> px, py, pz;         ///< The shading points, world space.
  std::span<const Real> cx, cy, cz, radius; ///< Each point's light: a still sphere.
  std::span<const Real> u1, u2;             ///< LightChoice::u, in [0, 1)².
  std::span<const Real> choice, guide;      ///< LightChoice::choice and LightChoice::guide.
};

/// The light samples' directions and pdfs, stored by coordinate.
struct SphereLightOutput {
  std::span<Real> wx, wy, wz; ///< The direction towards the light, unit, world space.
  std::span<Real> pdf;        ///< Its solid-angle pdf, light choice and guide included.
};

/// For points [0, count): sampleSphereCone(p, c, r, u) and choice · sphereConePdf(p, c, r) · guide, bit for bit:
/// the direction and pdf LightSampler::sampleChosen gives for a sphere.
void sphereLightDirections(const SphereLightInput& in, std::size_t count, const SphereLightOutput& out);

/// Light samples at diffuse surfaces, stored by coordinate: what the light brings if its shadow ray gets through.
struct DiffuseLightInput {
  std::span<const Real> nx, ny, nz;       ///< The unit shading normals.
  std::span<const Real> dx, dy, dz;       ///< The unit directions of the rays that arrived (towards the surface).
  std::span<const Real> wx, wy, wz;       ///< The unit directions towards the light.
  std::span<const Real> pdf;              ///< The light sample's solid-angle pdf, > 0.
  std::span<const Real> betaR, betaG, betaB; ///< The paths' throughputs.
  std::span<const Real> rhoR, rhoG, rhoB;    ///< The surfaces' albedos.
  std::span<const Real> leR, leG, leB;       ///< The radiance arriving from the light (its Le).
  bool power = true;                      ///< The power heuristic (else the balance heuristic) weighs the sample.
};

/// The light each sample brings, stored by coordinate, and whether the BSDF lets any through.
struct DiffuseLightOutput {
  std::span<Real> lightR, lightG, lightB; ///< β f |cosθ| Le w / pdf.
  std::span<Real> useful;                 ///< 1 where f ≠ 0 (the shadow ray is worth tracing), else 0.
};

/// For samples [0, count): chapter 8's light sample at a Lambertian surface, bit for bit: f = lambertianEval(ρ, wo,
/// wi) and its pdf lambertianPdf in Frame::fromNormal(n) (wo = −d), the MIS weight powerHeuristic (or
/// balanceHeuristic) of the light's pdf against the BSDF's, and β f |cosθ| Le (w / pdf).
void diffuseLightSamples(const DiffuseLightInput& in, std::size_t count, const DiffuseLightOutput& out);

/// Shadow rays from surface points towards spheres, stored by coordinate: each point with its error bound and
/// geometric normal, the direction, and the sphere the ray is aimed at.
struct ShadowSpawnInput {
  std::span<const Real> px, py, pz;         ///< The surface points.
  std::span<const Real> ex, ey, ez;         ///< Their error bounds.
  std::span<const Real> gx, gy, gz;         ///< Their geometric normals.
  std::span<const Real> wx, wy, wz;         ///< The unit directions of the rays.
  std::span<const Real> cx, cy, cz, radius; ///< The spheres they are aimed at.
};

/// The shadow rays' origins and lengths, stored by coordinate.
struct ShadowSpawnOutput {
  std::span<Real> ox, oy, oz; ///< The origin, off the surface (offsetRayOrigin).
  std::span<Real> t;          ///< Where the ray first meets its sphere; +∞ where it does not.
};

/// For rays [0, count): the origin spawnRay(hit, w) gives (offsetRayOrigin(p, e, g, w)) and the first root of the
/// ray with its sphere in [0, ∞) (intersectSphere), bit for bit: the ray lightVisible tests for a spherical light.
void shadowRaysToSpheres(const ShadowSpawnInput& in, std::size_t count, const ShadowSpawnOutput& out);

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

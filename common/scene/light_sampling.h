/// @file light_sampling.h
/// @brief Explicit light sampling (chapters 7 and 8): a direction towards an emissive sphere chosen uniformly in
/// the cone it subtends, and towards an emissive triangle uniformly in the solid angle it subtends (Arvo's
/// spherical-triangle sampling), each with its pdf beside it; the choice of one light in proportion to its power;
/// and the heuristics that weight two sampling strategies in multiple importance sampling.
///
/// Every pdf here is a density with respect to solid angle at the shaded point (per steradian), like the BSDF
/// pdfs of bsdf.h, so the two can be compared and combined. A point light is a delta light: its "pdf" is the
/// discrete probability of choosing it, and no direction sampled any other way can find it.
#pragma once

#include "core/math.h"
#include "core/sampling.h"
#include "core/sample_tree.h"
#include "scene/scene.h"
#include "geometry/sphere.h"
#include "geometry/triangle.h"

#include <algorithm>
#include <cstdint>
#include <cmath>
#include <numbers>
#include <optional>
#include <span>
#include <string>
#include <utility>
#include <vector>

namespace raylife {

// ---- The cone a sphere subtends -------------------------------------------------------------------------------

/// Two unit vectors that make a right-handed orthonormal frame (s, t, n) with unit vector `n` (Duff et al.'s
/// construction, as in frame.h): sampleSphereCone and sphereConeCoordinates measure the azimuth φ in it.
template <class T> std::pair<TVec3<T>, TVec3<T>> coneAxisFrame(const TVec3<T>& n)
{
  const T sign = std::copysign(T(1), n.z);
  const T a = T(-1) / (sign + n.z);
  const T b = n.x * n.y * a;
  return {TVec3<T>(1 + sign * n.x * n.x * a, sign * b, -sign * n.x), TVec3<T>(b, sign + n.y * n.y * a, -n.y)};
}

// [cone]
/// 1 − cosθmax of the cone that a sphere with sin²θmax = r²/d² subtends, computed without cancellation.
///
/// The direct form 1 − √(1 − sin²θmax) subtracts two numbers that agree in every digit when the light is small or
/// far: in float, a sphere of radius 1 at distance 10⁴ (sin²θmax = 10⁻⁸) gives 1 − cosθmax = 0 and an infinite pdf.
/// Multiplying by (1 + cosθmax)/(1 + cosθmax) gives the exact identity 1 − cosθmax = sin²θmax/(1 + cosθmax), whose
/// every operation is well conditioned, so it keeps full relative precision for every sin²θmax in [0, 1].
/// @param sin2ThetaMax r²/d² in [0, 1] (clamped).
template <class T> T oneMinusCosConeAngle(T sin2ThetaMax)
{
  const T s2 = std::clamp(sin2ThetaMax, T(0), T(1));
  return s2 / (1 + std::sqrt(1 - s2));
}

/// The solid-angle pdf of sampleSphereCone towards a sphere of centre `c` and radius `r` seen from `ref`, for any
/// direction that hits the sphere: 1/(2π(1 − cosθmax)) from outside (|ref − c| > r), 1/(4π) from inside or on it
/// (where every direction hits the sphere and sampleSphereCone samples the whole sphere of directions).
template <class T> T sphereConePdf(const TVec3<T>& ref, const TVec3<T>& c, T r)
{
  const TVec3<T> toCentre = c - ref;
  const T d2 = glm::dot(toCentre, toCentre);
  if (d2 <= r * r)
    return T(1) / (4 * std::numbers::pi_v<T>);
  return T(1) / (2 * std::numbers::pi_v<T> * oneMinusCosConeAngle(r * r / d2));
}

/// A direction from `ref` chosen uniformly in the solid angle the sphere (centre `c`, radius `r` > 0) subtends:
/// uniform in its cone from outside; uniform over the whole sphere of directions from inside or on it. Its pdf is
/// sphereConePdf for every direction.
/// @param ref the point the direction leaves from, world space. @param c the sphere's centre, world space.
/// @param r the sphere's radius, > 0. @param u uniform in [0, 1)². @return a unit direction (never NaN).
template <class T> TVec3<T> sampleSphereCone(const TVec3<T>& ref, const TVec3<T>& c, T r, glm::vec<2, T> u)
{
  const TVec3<T> toCentre = c - ref;
  const T d2 = glm::dot(toCentre, toCentre);
  // Inside or on the light: every direction sees it, so sample them all (pdf 1/(4π)).
  if (d2 <= r * r) {
    const T z = 1 - 2 * u.x;
    const T s = std::sqrt(std::max(T(0), (1 - z) * (1 + z)));
    const SinCos<T> phi = sinCos2Pi(u.y);
    return TVec3<T>(s * phi.cos, s * phi.sin, z);
  }
  // Uniform in the cone: 1 − cosθ = u·(1 − cosθmax), and sin²θ = (1 − cosθ)(1 + cosθ) with no cancellation.
  const T oneMinusCos = u.x * oneMinusCosConeAngle(r * r / d2);
  const T cosTheta = 1 - oneMinusCos;
  const T sinTheta = std::sqrt(std::max(T(0), oneMinusCos * (2 - oneMinusCos)));
  const SinCos<T> phi = sinCos2Pi(u.y);
  // Build the direction in a frame around the axis towards the centre (Duff et al., as in frame.h).
  const TVec3<T> n = toCentre / std::sqrt(d2);
  const auto [s, t] = coneAxisFrame(n);
  return glm::normalize(sinTheta * phi.cos * s + sinTheta * phi.sin * t + cosTheta * n);
}

// [cone]

/// The inverse of sampleSphereCone from outside the sphere: the numbers u in [0, 1)² that give direction `wi`
/// (unit, inside the cone), u.x = (1 − cosθ)/(1 − cosθmax) and u.y = φ/(2π) in the same frame. A direction
/// outside the cone (by rounding, at its edge) gets u.x just below 1. Contract: |ref − c| > r.
/// @param ref the point the direction leaves from. @param c the sphere's centre. @param r its radius, > 0.
/// @param wi a unit direction from `ref`.
template <class T>
glm::vec<2, T> sphereConeCoordinates(const TVec3<T>& ref, const TVec3<T>& c, T r, const TVec3<T>& wi)
{
  const TVec3<T> toCentre = c - ref;
  const T d2 = glm::dot(toCentre, toCentre);
  const TVec3<T> n = toCentre / std::sqrt(d2);
  const auto [s, t] = coneAxisFrame(n);
  // 1 − cosθ = |wi − n|²/2 for unit vectors, without the cancellation of 1 − wi·n near the axis.
  const TVec3<T> off = wi - n;
  const T oneMinusCos = glm::dot(off, off) / 2;
  const T belowOne = std::nextafter(T(1), T(0));
  const T x = std::clamp(oneMinusCos / oneMinusCosConeAngle(r * r / d2), T(0), belowOne);
  T y = std::atan2(glm::dot(wi, t), glm::dot(wi, s)) / (2 * std::numbers::pi_v<T>);
  if (y < 0)
    y += 1;
  return glm::vec<2, T>(x, std::clamp(y, T(0), belowOne));
}

// ---- The solid angle a triangle subtends -----------------------------------------------------------------------

/// Below this solid angle (steradians) a triangle light is sampled by area rather than by solid angle: Arvo's
/// construction divides by sines of the triangle's angles on the unit sphere, which lose their precision as the
/// spherical triangle shrinks, while for so small a triangle (about 1/42,000 of the sphere) area sampling is
/// already almost uniform in solid angle. The value is pbrt-v4's.
inline constexpr Real kMinSphericalTriangleArea = Real(3e-4);
/// Above this solid angle (steradians; 2π is the whole hemisphere, about 6.283) a triangle light is sampled by
/// area: the point then lies nearly in the triangle's plane, where the spherical triangle's angles approach π and
/// the construction becomes ill-conditioned. The value is pbrt-v4's.
inline constexpr Real kMaxSphericalTriangleArea = Real(6.22);

// [triangleSolidAngle]
/// A triangle as seen from a point: the unit directions towards its corners (the corners of a triangle on the
/// unit sphere) and the solid angle they bound.
template <class T> struct SphericalTriangle {
  TVec3<T> a; ///< Unit direction from the point towards p0.
  TVec3<T> b; ///< Unit direction from the point towards p1.
  TVec3<T> c; ///< Unit direction from the point towards p2.
  T solidAngle = 0; ///< Ω in steradians, [0, 2π]; 0 when the point lies in the triangle's plane or on a corner.
};

/// The triangle (p0, p1, p2) as seen from `ref`. The solid angle is Van Oosterom and Strackee's formula,
/// tan(Ω/2) = |a·(b × c)| / (1 + a·b + b·c + c·a): atan2 keeps it right past Ω = π (a negative denominator), and it
/// is exact to rounding for tiny triangles, where the angle-sum form α + β + γ − π cancels.
template <class T>
SphericalTriangle<T> sphericalTriangle(const TVec3<T>& ref, const TVec3<T>& p0, const TVec3<T>& p1, const TVec3<T>& p2)
{
  const TVec3<T> da = p0 - ref, db = p1 - ref, dc = p2 - ref;
  const T la = glm::length(da), lb = glm::length(db), lc = glm::length(dc);
  if (!(la > 0 && lb > 0 && lc > 0))
    return SphericalTriangle<T>{TVec3<T>(0), TVec3<T>(0), TVec3<T>(0), T(0)};
  SphericalTriangle<T> st{da / la, db / lb, dc / lc, T(0)};
  const T numerator = std::abs(glm::dot(st.a, glm::cross(st.b, st.c)));
  const T denominator = 1 + glm::dot(st.a, st.b) + glm::dot(st.b, st.c) + glm::dot(st.c, st.a);
  st.solidAngle = 2 * std::atan2(numerator, denominator);
  return st;
}

/// The solid angle (steradians) that triangle (p0, p1, p2) subtends from `ref` (see sphericalTriangle), in [0, 2π].
template <class T>
T triangleSolidAngle(const TVec3<T>& ref, const TVec3<T>& p0, const TVec3<T>& p1, const TVec3<T>& p2)
{
  return sphericalTriangle(ref, p0, p1, p2).solidAngle;
}
// [triangleSolidAngle]

/// A direction from `ref` towards a triangle light, chosen by sampleTriangleLight.
template <class T> struct TriangleLightSample {
  TVec3<T> wi; ///< Unit direction from `ref` into the triangle.
  T pdf;       ///< Its solid-angle pdf (per steradian), > 0: triangleLightPdf of the point it meets.
};

/// True when a triangle that subtends `solidAngle` from the shaded point is sampled by solid angle (Arvo), false
/// when by area (uniformly on its surface): see kMinSphericalTriangleArea and kMaxSphericalTriangleArea.
template <class T> bool sampledBySolidAngle(T solidAngle)
{
  return solidAngle >= T(kMinSphericalTriangleArea) && solidAngle <= T(kMaxSphericalTriangleArea);
}

// [sampleSphericalTriangle]
/// A direction uniform in the solid angle of spherical triangle `st` (Arvo, "Stratified Sampling of Spherical
/// Triangles", SIGGRAPH 1995), pdf 1/Ω; nothing if it has no area. Contract: Ω in [kMinSphericalTriangleArea,
/// kMaxSphericalTriangleArea].
///
/// The corners A, B, C bound a triangle on the unit sphere with angles α, β, γ at its corners and area
/// Ω = α + β + γ − π. Arvo inverts the area: u₀ chooses the sub-triangle A B C' of area u₀·Ω, whose corner C' on
/// the arc AC follows in closed form from α and the sub-area; then u₁ chooses the direction on the arc from B to C'
/// so that the density is uniform.
template <class T>
std::optional<TriangleLightSample<T>> sampleSphericalTriangle(const SphericalTriangle<T>& st, glm::vec<2, T> u)
{
  const TVec3<T>&a = st.a, &b = st.b, &c = st.c;
  const T area = st.solidAngle;
  // The angle α at A, between the great circles AB and AC (the angle between their planes' normals).
  const TVec3<T> ab = glm::cross(a, b), ac = glm::cross(a, c);
  const T lab = glm::length(ab), lac = glm::length(ac);
  if (!(area > 0 && lab > 0 && lac > 0))
    return std::nullopt;
  const T cosAlpha = std::clamp(glm::dot(ab, ac) / (lab * lac), T(-1), T(1));
  const T alpha = std::acos(cosAlpha);
  const T sinAlpha = std::sqrt(std::max(T(0), (1 - cosAlpha) * (1 + cosAlpha)));

  // The sub-triangle of area u₀·Ω: its corner C' on the arc from A to C.
  const T areaPrime = u.x * area;
  const T s = std::sin(areaPrime - alpha), t = std::cos(areaPrime - alpha);
  const T uu = t - cosAlpha;
  const T vv = s + sinAlpha * glm::dot(a, b); // cos c = A·B, the arc AB
  const T q = std::clamp(((vv * t - uu * s) * cosAlpha - vv) / ((vv * s + uu * t) * sinAlpha), T(-1), T(1));
  const TVec3<T> cPerp = safeNormalize(c - glm::dot(c, a) * a, TVec3<T>(0));
  const TVec3<T> cPrime = q * a + std::sqrt(std::max(T(0), 1 - q * q)) * cPerp;
  // The direction on the arc from B to C', at cosine z to B.
  const T z = std::clamp(1 - u.y * (1 - glm::dot(cPrime, b)), T(-1), T(1));
  const TVec3<T> bPerp = safeNormalize(cPrime - glm::dot(cPrime, b) * b, TVec3<T>(0));
  const TVec3<T> wi = safeNormalize(z * b + std::sqrt(std::max(T(0), 1 - z * z)) * bPerp, b);
  return TriangleLightSample<T>{wi, 1 / area};
}
// [sampleSphericalTriangle]

/// sampleSphericalTriangle for triangle (p0, p1, p2) seen from `ref`.
template <class T>
std::optional<TriangleLightSample<T>> sampleSphericalTriangle(const TVec3<T>& ref, const TVec3<T>& p0,
                                                              const TVec3<T>& p1, const TVec3<T>& p2,
                                                              glm::vec<2, T> u)
{
  return sampleSphericalTriangle(sphericalTriangle(ref, p0, p1, p2), u);
}

// [sampleTriangleArea]
/// The naive way: a point uniform on the triangle's surface (pdf 1/A per unit area), as a direction from `ref` with
/// its solid-angle pdf d²/(|cosθ|·A) (θ at the light). It is fine for a triangle that is small or far, and bad for a
/// large one seen up close: points near `ref` get a tiny pdf and huge weights (the docs' figure). Nothing when the
/// point is `ref` itself or the direction grazes the triangle's plane.
template <class T>
std::optional<TriangleLightSample<T>> sampleTriangleArea(const TVec3<T>& ref, const TVec3<T>& p0, const TVec3<T>& p1,
                                                         const TVec3<T>& p2, glm::vec<2, T> u)
{
  // Uniform barycentrics: b0 = 1 − √u₀, b1 = √u₀·(1 − u₁), b2 = √u₀·u₁.
  const T su = std::sqrt(u.x);
  const TVec3<T> point = (1 - su) * p0 + (su * (1 - u.y)) * p1 + (su * u.y) * p2;
  const TVec3<T> toPoint = point - ref;
  const T d2 = glm::dot(toPoint, toPoint);
  const T doubleArea = triangleDoubleArea(p0, p1, p2);
  if (!(d2 > 0) || !(doubleArea > 0))
    return std::nullopt;
  const TVec3<T> wi = toPoint / std::sqrt(d2);
  const T cosLight = std::abs(glm::dot(wi, triangleNormal(p0, p1, p2)));
  if (!(cosLight > 0))
    return std::nullopt;
  return TriangleLightSample<T>{wi, d2 / (cosLight * doubleArea / 2)};
}
// [sampleTriangleArea]

/// A direction from `ref` towards triangle light (p0, p1, p2) as chapters 7 and 8 choose it: uniform in its solid
/// angle where that is well conditioned (sampledBySolidAngle), uniform on its area otherwise. Nothing when the
/// triangle is seen edge on from `ref`.
/// @param ref the shaded point. @param p0,p1,p2 the light's corners. @param u uniform in [0, 1)².
template <class T>
std::optional<TriangleLightSample<T>> sampleTriangleLight(const TVec3<T>& ref, const TVec3<T>& p0, const TVec3<T>& p1,
                                                          const TVec3<T>& p2, glm::vec<2, T> u)
{
  const SphericalTriangle<T> st = sphericalTriangle(ref, p0, p1, p2);
  if (sampledBySolidAngle(st.solidAngle))
    return sampleSphericalTriangle(st, u);
  return sampleTriangleArea(ref, p0, p1, p2, u);
}

/// The solid-angle pdf of sampleTriangleLight for the direction from `ref` to `point` on the triangle: 1/Ω, or
/// d²/(|cosθ|·A) where the triangle is sampled by area. 0 when the direction grazes the triangle.
template <class T>
T triangleLightPdf(const TVec3<T>& ref, const TVec3<T>& p0, const TVec3<T>& p1, const TVec3<T>& p2,
                   const TVec3<T>& point)
{
  const T solidAngle = triangleSolidAngle(ref, p0, p1, p2);
  if (sampledBySolidAngle(solidAngle))
    return 1 / solidAngle;
  const TVec3<T> toPoint = point - ref;
  const T d2 = glm::dot(toPoint, toPoint);
  const T cosLight = std::abs(glm::dot(toPoint, triangleNormal(p0, p1, p2))) / std::sqrt(d2);
  const T area = triangleDoubleArea(p0, p1, p2) / 2;
  if (!(d2 > 0) || !(cosLight > 0) || !(area > 0))
    return 0;
  return d2 / (cosLight * area);
}

// ---- Lights and their choice ----------------------------------------------------------------------------------

/// A direction towards a light, chosen by LightSampler::sample, with what the estimator needs to weight it.
struct LightSample {
  Vec3 wi{0, 0, 1};  ///< Unit direction from the shaded point towards the light, world space.
  Vec3 target{0};    ///< The point on the light: the point light's position, or where wi first meets the emitter.
  Color Li{0};       ///< Radiance arriving along wi if nothing blocks it: the emitter's Le; for a point light I/d².
  Real pdf = 0;      ///< Probability of choosing this light times the solid-angle pdf of wi (> 0); for a point
                     ///< light, the probability of choosing it alone (a delta light: no density).
  int primitive = -1; ///< The emitter sampled (a primitive number, sphere or triangle), or −1 for a point light.
  bool delta = false; ///< True for a point light, which no BSDF-sampled ray can hit (its MIS weight is 1).
};

/// A point on an emitter, where a path that starts at the light begins (bidirectional path tracing, chapter 13).
struct EmitterPoint {
  Hit hit;         ///< The point as a hit record: point and its error bound, normals, primitive, material.
  Color Le{0};     ///< The emitter's radiance (it emits from both sides of its surface).
  Real pdfArea = 0; ///< The probability of choosing this emitter times 1/area: the density of the point, per unit area.
};

/// How a LightSampler learns, before the render, where each light's samples are of use (the guided constructor).
///
/// A pre-pass follows `paths` paths from the camera (BSDF-sampled, at most `bounces` surfaces each) and, at each
/// non-specular surface they meet, draws an eighth of `samplesPerPoint` samples of every light as the unguided
/// sampler would, with a shadow ray each, and the rest only in the cells where that first round found the light
/// mostly hidden (`guideBelow`). A sample is of use when the light is visible along it and the BSDF there is not 0
/// for it. The points fall into cells of a grid over their bounds; per cell and light the sampler keeps the share
/// of useful samples and, for a sphere light, where in its cone they were (a SampleTree over the numbers that
/// choose the direction). Its numbers come from `seed` alone, and its shadow rays' answers (traced on every core)
/// are gathered in point order: what it learns does not depend on --seed, --threads, the image's size or how the
/// samples are shared between processes.
struct LightGuiding {
  int paths = 2048;            ///< Camera paths of the pre-pass, ≥ 1 (through the scene's own image size).
  int bounces = 3;             ///< Surfaces a pre-pass path meets at most, ≥ 1.
  int samplesPerPoint = 32;    ///< Samples of each light at each surface point, in [1, 64].
  int cellsPerAxis = 6;        ///< Cells along the longest side of the points' bounds, ≥ 1.
  /// A cell's light is learned (the second round) and guided only while less than this share of its first
  /// round's samples are of use (in (0, 1]). Where one sample in ten or more finds the light, its samples are not
  /// what keeps the image noisy: behind a slit, in a lampshade or a recess (an eighth to a quarter of use) guiding
  /// them changed the relative MSE at equal samples by under 1%, and the pre-pass's rounds were pure cost.
  Real guideBelow = Real(0.1);
  /// A cell's light is guided only where the mixture's second moment, measured on points the guide was not learned
  /// from, is below this share of uniform sampling's (in (0, 1]); the mixture's uniform share α is the best of
  /// 0.15, 0.3, 0.5 and 0.7 by the same measure. α keeps the pdf above 0 on the whole cone, so the estimate stays
  /// unbiased wherever the pre-pass missed light.
  Real keepBelow = Real(0.9);
  std::uint64_t seed = 0x5eed1e57ull; ///< The pre-pass's random numbers.
  /// Threads for the pre-pass's shadow rays, ≥ 1, or 0 for every core (a chapter passes its --threads). What is
  /// learned is the same for any number.
  int threads = 0;
};

/// The first half of a light sample (LightSampler::choose): the light chosen, with what probability, and the
/// numbers its direction is to be drawn from. The second half (LightSampler::sampleChosen) draws the direction; a
/// wavefront (chapter 16) draws those towards spheres many at a time, with the same arithmetic.
struct LightChoice {
  std::size_t index = 0; ///< Which of the sampler's lights (for sampleChosen).
  /// The light: an emitter's primitive number (≥ 0: a sphere when below Scene::spheres.size(), else a triangle),
  /// or −(i + 1) for point light i.
  int light = -1;
  Real choice = 0;      ///< The probability of having chosen it, in (0, 1].
  Vec2 u{0};            ///< The numbers its direction is drawn from (the guide's, where it guides), in [0, 1)².
  /// The factor on the direction's solid-angle pdf: the guided mixture's density over the cone's (1 where the
  /// light is not guided, which leaves the pdf's bits unchanged).
  Real guide = 1;
  /// Where the guide steers the direction: the index into LightSampler::guideTrees() of the tree whose mixture
  /// (SampleTree::sampleMixture, uniform share guideShare) warps u, or −1 when it is not guided.
  int guideTree = -1;
  Real guideShare = 1; ///< The mixture's uniform share α, in (0, 1] (1 where not guided).
};

/// Chooses one of a scene's lights (its emissive spheres and triangles, and its point lights) in proportion to an
/// estimate of its power, and a direction towards it.
///
/// The power of an emitter of area A and radiance Le is Φ = π·Le·A (area times π, the integral of the cosine over
/// the hemisphere): π·Le·4πr² for a sphere of radius r; a point light of intensity I sends Φ = 4π·I. The luminance
/// of Φ is the weight. (An emissive triangle emits from both faces, as a sphere emits inside too; the weight counts
/// one, which changes nothing but the choice's odds.) Built once per scene before the render (its cumulative
/// distribution is computed once), then only read, so threads share it. It keeps a reference to the scene, which
/// must outlive it and not change.
class LightSampler {
public:
  /// Collects the lights of `scene` and their power.
  explicit LightSampler(const Scene& scene);
  /// Collects them and learns, by the pre-pass of `guiding`, where each light's samples are of use: sample() and
  /// pdf() then choose, in the cell of the shaded point, a light with probability ½ ∝ power + ½ ∝ power × its
  /// share of useful samples there, and a direction in a sphere light's cone from the mixture
  /// α × uniform + (1 − α) × the learned SampleTree, α chosen per cell and light (see LightGuiding). Both are > 0 wherever the unguided
  /// sampler's are, so every estimate stays unbiased. Deterministic (see LightGuiding).
  LightSampler(const Scene& scene, const LightGuiding& guiding);

  /// What the guided constructor learned, one line each (for --verbose): the pre-pass, and per light the share
  /// of useful samples before and after guiding. Empty for an unguided sampler.
  std::vector<std::string> describeGuide() const { return guideReport_; }

  /// True when the scene has no light to sample (only the background, if anything, lights it).
  bool empty() const { return cdf_.empty(); }

  /// The sum of the lights' power estimates (the luminance of Φ, as the choice weighs them; 0 when empty): what a
  /// chapter weighs a light of its own against (chapter 14's environment map).
  Real totalPower() const { return totalPower_; }

  /// One light, chosen with probability ∝ power by `uLight`, and a direction towards it from `ref`, the shaded
  /// point on a surface: uniform in the emissive sphere's cone (sampleSphereCone), in the emissive triangle's
  /// solid angle (sampleTriangleLight), or the point light itself.
  /// @param ref the shaded point, world space. @param uLight uniform in [0, 1). @param u uniform in [0, 1)².
  /// @param time the time of the shaded point's ray (Ray::time): a moving emissive sphere is sampled where it is
  /// then.
  /// @return nothing when there is no light, or the sample carries no light (ref at a point light's position, a
  /// triangle seen edge on).
  std::optional<LightSample> sample(const Vec3& ref, Real uLight, Vec2 u, Real time = 0) const;

  /// The light sample() chooses from `ref` with these numbers, and the numbers its direction comes from: sample()
  /// is sampleChosen(*choose(...)). Nothing when there is no light. (Chapter 16 draws the directions towards still
  /// spheres itself, many at a time: sampleSphereCone(ref, centre, radius, u), its pdf choice · sphereConePdf ·
  /// guide.)
  std::optional<LightChoice> choose(const Vec3& ref, Real uLight, Vec2 u, Real time = 0) const;
  /// choose()'s first half, for a wavefront that warps many points' numbers at once: the light chosen in the
  /// guide's cell `cell` (cellOf(ref)), with u as drawn and guide 1, and in guideTree and guideShare the mixture that
  /// choose() then applies (SampleTree::sampleMixture of guideTrees()[guideTree]: its point is u, its pdf guide).
  std::optional<LightChoice> chooseInCell(int cell, const Vec3& ref, Real uLight, Vec2 u, Real time = 0) const;
  /// choose()'s second half: `choice` (from chooseInCell) with its numbers u warped by its guide's mixture and guide
  /// set to the mixture's density there; unchanged where it is not guided (guideTree −1).
  LightChoice guided(LightChoice choice) const;
  /// The guide's cell of point `ref` (an index into its grid), or −1 when there is no guide or the cell learned
  /// nothing.
  int cellOf(const Vec3& ref) const;
  /// The guide's grid of cells, for finding many points' cells at once (chapter 16): cellOf(p) is, with
  /// c = (p − min) × scale and each coordinate clamped to [0, size − 1] and truncated, cell
  /// (c.z × size.y + c.y) × size.x + c.x where learned[cell] is 1, else −1. Empty `learned` without a guide.
  struct GuideGrid {
    Vec3 min{0};            ///< The grid's lowest corner, world space.
    Vec3 scale{0};          ///< Cells per scene unit along each axis, > 0.
    glm::ivec3 size{0};     ///< Cells along each axis, ≥ 1.
    std::span<const char> learned; ///< Per cell: 1 where the pre-pass learned something.
  };
  /// The guide's grid (see GuideGrid).
  GuideGrid guideGrid() const { return {gridMin_, gridScale_, gridSize_, cellLearned_}; }
  /// The guide's learned densities in sphere lights' cones, one per cell and light (LightChoice::guideTree indexes
  /// it); empty without a guide.
  const std::vector<SampleTree>& guideTrees() const { return cellTree_; }
  /// The direction towards the light of `choice` (made by choose() for `ref` and `time`), as sample() returns it.
  std::optional<LightSample> sampleChosen(const LightChoice& choice, const Vec3& ref, Real time = 0) const;

  /// The pdf with which sample() chooses, from `ref`, the direction towards `point` on emitter `primitive` (a
  /// direction that meets it there first): its choice probability times sphereConePdf or triangleLightPdf. 0 for a
  /// primitive that does not emit. This is the pdf MIS needs when a BSDF-sampled ray from `ref` hits that emitter
  /// at `point`. `time` is the ray's time (Ray::time), where a moving emissive sphere is.
  Real pdf(const Vec3& ref, int primitive, const Vec3& point, Real time = 0) const;

  /// The probability of choosing emitter `primitive` (0 for a primitive that does not emit), in [0, 1].
  Real probability(int primitive) const;

  /// A light chosen with probability ∝ power by `uLight` (as sample() chooses) and a point on it uniform on its area
  /// (`u` uniform in [0, 1)²). Nothing when there is no light or the choice is a point light.
  std::optional<EmitterPoint> sampleEmitterPoint(Real uLight, Vec2 u) const;
  /// The area of emitter `primitive` (a sphere or a triangle), scene units², > 0.
  Real area(int primitive) const;
  /// The unit outward (sphere) or front (triangle) normal of primitive `primitive` at `point` on its surface.
  Vec3 normalAt(int primitive, const Vec3& point) const;

private:
  // The index into lights_ that `uLight` chooses (cdf_ not empty), and the probability of that choice, in the
  // guide's cell `cell` (−1: by power alone).
  std::pair<std::size_t, Real> choose(Real uLight, int cell = -1) const;
  // The index into lights_ of emitter `primitive`, or −1.
  int lightIndex(int primitive) const;
  // A direction towards lights_[k] from `ref`, chosen with probability `choice`, as the unguided sampler does.
  std::optional<LightSample> sampleLight(std::size_t k, Real choice, const Vec3& ref, Vec2 u, Real time) const;
  // The pre-pass of the guided constructor.
  void learn(const LightGuiding& guiding);

  const Scene& scene_;
  std::vector<int> lights_;   // ≥ 0: an emitter's primitive number; < 0: point light −(index + 1)
  std::vector<Real> cdf_;     // cumulative probability of lights_[0..i], the last exactly 1
  std::vector<std::pair<int, Real>> emitters_; // (primitive, choice probability) of each emitter, by primitive
  Real totalPower_ = 0;

  // The guide (empty without one): a grid of cells over the pre-pass's points, and per cell and light (index
  // cell × lights_.size() + k) the cumulative choice probability and the learned density in a sphere's cone.
  Vec3 gridMin_{0}, gridScale_{0}; // cell coordinates of a point: (point − gridMin_) × gridScale_
  glm::ivec3 gridSize_{0};
  std::vector<char> cellLearned_;   // per cell: 1 when points fell into it
  std::vector<Real> cellCdf_;
  std::vector<SampleTree> cellTree_;
  std::vector<Real> cellShare_;     // the mixture's uniform share α (1: not guided)
  std::vector<std::string> guideReport_;
};

// [visible]
/// True when light sample `ls`, taken at the hit `hit`, is not blocked: the light is what the shadow ray sees.
///
/// For an emitter the sample is visible when the first primitive the shadow ray meets is the sampled light.
/// That is exactly the event in which a BSDF-sampled ray in the same direction would have found the light, so the
/// two strategies agree on every direction (MIS needs that), the light never blocks itself, and a point on or
/// inside the light is handled without a tolerance (a direction leaving the light's own surface outwards never
/// meets it). It is tested without a closest-hit query: first where the ray meets the light (one sphere or triangle
/// test, from the ray's own origin), then an any-hit query (Scene::occluded) over [0, that distance), which stops at
/// the first blocker and builds no hit record. The answer is the closest-hit query's (only a tie, another primitive
/// met at exactly the same distance, could differ), so images stay the same bit for bit. For a point light, a shadow
/// ray that stops just short of it (spawnRayTo) must hit nothing.
bool lightVisible(const Scene& scene, const Hit& hit, const LightSample& ls);
// [visible]

// ---- Multiple importance sampling -----------------------------------------------------------------------------

// [heuristics]
/// Veach's balance heuristic for one sample from each of two strategies: the weight f/(f + g) of a sample drawn by
/// the strategy of pdf f, where the other strategy would have drawn it with pdf g. In [0, 1]; the weights of the two
/// strategies for one direction sum to 1. 0 when f = 0; 1 when g = 0 < f. (Written as 1/(1 + g/f), so neither
/// huge nor infinite pdfs overflow.)
inline Real balanceHeuristic(Real f, Real g)
{
  if (!(f > 0))
    return 0;
  if (std::isinf(f))
    return std::isinf(g) ? Real(0.5) : Real(1);
  return 1 / (1 + g / f);
}

/// Veach's power heuristic with exponent 2: f²/(f² + g²), which sharpens the balance heuristic towards the strategy
/// that is clearly better. Same contract as balanceHeuristic.
inline Real powerHeuristic(Real f, Real g)
{
  if (!(f > 0))
    return 0;
  if (std::isinf(f))
    return std::isinf(g) ? Real(0.5) : Real(1);
  const Real ratio = g / f;
  return 1 / (1 + ratio * ratio);
}

/// Which of the two heuristics weighs a chapter's strategies (`--heuristic power|balance`: chapters 8 and 16).
enum class MisHeuristic {
  Power,   ///< powerHeuristic, the default.
  Balance, ///< balanceHeuristic.
};

/// The MIS weight of a sample that its strategy drew with pdf `p`, the other strategy having pdf `q` for it, by
/// `heuristic`: powerHeuristic(p, q) or balanceHeuristic(p, q), with their contract.
inline Real misWeight(MisHeuristic heuristic, Real p, Real q)
{
  return heuristic == MisHeuristic::Power ? powerHeuristic(p, q) : balanceHeuristic(p, q);
}
// [heuristics]

} // namespace raylife

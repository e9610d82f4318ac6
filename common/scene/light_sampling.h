/// @file light_sampling.h
/// @brief Explicit light sampling (chapters 7 and 8): a direction towards an emissive sphere chosen uniformly in
/// the cone it subtends, with its pdf beside it; the choice of one light in proportion to its power; and the
/// heuristics that weight two sampling strategies in multiple importance sampling.
///
/// Every pdf here is a density with respect to solid angle at the shaded point (per steradian), like the BSDF
/// pdfs of bsdf.h, so the two can be compared and combined. A point light is a delta light: its "pdf" is the
/// discrete probability of choosing it, and no direction sampled any other way can find it.
#pragma once

#include "core/math.h"
#include "core/sampling.h"
#include "scene/scene.h"
#include "geometry/sphere.h"

#include <algorithm>
#include <cmath>
#include <optional>
#include <vector>

namespace raylife {

// ---- The cone a sphere subtends -------------------------------------------------------------------------------

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
  const T sign = std::copysign(T(1), n.z);
  const T a = T(-1) / (sign + n.z);
  const T b = n.x * n.y * a;
  const TVec3<T> s(1 + sign * n.x * n.x * a, sign * b, -sign * n.x);
  const TVec3<T> t(b, sign + n.y * n.y * a, -n.y);
  return glm::normalize(sinTheta * phi.cos * s + sinTheta * phi.sin * t + cosTheta * n);
}

// [cone]

// ---- Lights and their choice ----------------------------------------------------------------------------------

/// A direction towards a light, chosen by LightSampler::sample, with what the estimator needs to weight it.
struct LightSample {
  Vec3 wi{0, 0, 1};  ///< Unit direction from the shaded point towards the light, world space.
  Vec3 target{0};    ///< The point on the light: the point light's position, or where wi first meets the sphere.
  Color Li{0};       ///< Radiance arriving along wi if nothing blocks it: the sphere's Le; for a point light I/d².
  Real pdf = 0;      ///< Probability of choosing this light times the solid-angle pdf of wi (> 0); for a point
                     ///< light, the probability of choosing it alone (a delta light: no density).
  int sphere = -1;   ///< The emissive sphere sampled (index into Scene::spheres), or −1 for a point light.
  bool delta = false; ///< True for a point light, which no BSDF-sampled ray can hit (its MIS weight is 1).
};

/// Chooses one of a scene's lights (its emissive spheres and its point lights) in proportion to an estimate of its
/// power, and a direction towards it.
///
/// The power of an emissive sphere of radius r and radiance Le is Φ = π·Le·4πr² (area times π, the integral of the
/// cosine over the hemisphere); a point light of intensity I sends Φ = 4π·I. The luminance of Φ is the weight.
/// Built once per scene before the render (its cumulative distribution is computed once), then only read, so
/// threads share it. It keeps a reference to the scene, which must outlive it and not change.
class LightSampler {
public:
  /// Collects the lights of `scene` and their power.
  explicit LightSampler(const Scene& scene);

  /// True when the scene has no light to sample (only the background, if anything, lights it).
  bool empty() const { return cdf_.empty(); }

  /// One light, chosen with probability ∝ power by `uLight`, and a direction towards it from `ref`, the shaded
  /// point on a surface: uniform in the emissive sphere's cone (sampleSphereCone), or the point light itself.
  /// @param ref the shaded point, world space. @param uLight uniform in [0, 1). @param u uniform in [0, 1)².
  /// @return nothing when there is no light, or the
  /// sample carries no light (ref at a point light's position).
  std::optional<LightSample> sample(const Vec3& ref, Real uLight, Vec2 u) const;

  /// The pdf with which sample() chooses, from `ref`, any given direction that hits emissive sphere `sphere`
  /// first: its choice probability times sphereConePdf. 0 for a sphere that does not emit. This is the pdf MIS
  /// needs when a BSDF-sampled ray from `ref` hits that sphere.
  Real pdf(const Vec3& ref, int sphere) const;

  /// The probability of choosing emissive sphere `sphere` (0 for a sphere that does not emit), in [0, 1].
  Real sphereProbability(int sphere) const { return sphereProbability_[std::size_t(sphere)]; }

private:
  const Scene& scene_;
  std::vector<int> lights_;             // ≥ 0: an emissive sphere's index; < 0: point light −(index + 1)
  std::vector<Real> cdf_;               // cumulative probability of lights_[0..i], the last exactly 1
  std::vector<Real> sphereProbability_; // per sphere of the scene: its choice probability (0 if not a light)
};

// [visible]
/// True when light sample `ls`, taken at the hit `hit`, is not blocked: the light is what the shadow ray sees.
///
/// For an emissive sphere the sample is visible when the first sphere the shadow ray meets is the sampled light.
/// That is exactly the event in which a BSDF-sampled ray in the same direction would have found the light, so the
/// two strategies agree on every direction (MIS needs that), the light never blocks itself, and a point on or
/// inside the light is handled without a tolerance (a direction leaving the light's own surface outwards never
/// meets it). It is tested without a closest-hit query: first where the ray meets the light (one sphere test, from
/// the ray's own origin), then an any-hit query (Scene::occluded) over [0, that distance), which stops at the first
/// blocker and builds no hit record. The answer is the closest-hit query's (only a tie, another sphere met at
/// exactly the same distance, could differ), so images stay the same bit for bit. For a point light, a shadow ray
/// that stops just short of it (spawnRayTo) must hit nothing.
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
// [heuristics]

} // namespace raylife

/// @file medium.h
/// @brief Participating media (chapter 15): a homogeneous medium's coefficients, the Henyey–Greenstein phase
/// function with its sampler and pdf, free-flight distance sampling and transmittance (Beer–Lambert).
///
/// Units and conventions, which every function here keeps:
///  - σa, σs and σt = σa + σs are per scene unit of length, ≥ 0, one value per RGB channel.
///  - The phase function is a density over directions (per steradian) that integrates to 1 over the sphere. Its
///    argument is cosθ = ω·ω', the cosine between the direction the light travelled before the scattering event
///    (ω, along the ray) and after it (ω'): g > 0 scatters forward (cosθ near 1, the light keeps going), g < 0
///    backward. The Henyey–Greenstein function is symmetric in ω and ω' (reciprocal), so a path traced from the
///    camera may evaluate it with its own ray direction and the new direction: the cosine is the same.
///  - Optical depths of any size are fine: the transmittance of σt·d = 10⁶ is 0, never NaN, and no weight here
///    divides two transmittances that may both underflow (see sampleFreeFlight).
#pragma once

#include "core/math.h"
#include "shading/density_grid.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <string>

namespace raylife {

/// The index of no medium (vacuum) wherever a medium is named by its index into Scene::media.
inline constexpr int kVacuum = -1;

/// A homogeneous medium as the scene file states it ("media": { name: { "sigma_a", "sigma_s", "g" } }).
struct Medium {
  std::string name;  ///< Its key in the scene file's "media".
  Color sigmaA{0};   ///< Absorption coefficient σa per unit length, ≥ 0 per channel.
  Color sigmaS{0};   ///< Scattering coefficient σs per unit length, ≥ 0 per channel.
  Real g = 0;        ///< Henyey–Greenstein asymmetry in (−1, 1): > 0 forward, < 0 backward, 0 isotropic.
  /// A heterogeneous medium's density, scaling σa and σs per point (density_grid.h); empty: homogeneous.
  std::shared_ptr<const DensityGrid> density;
  /// With a density: track against one global majorant instead of the grid of majorants (for comparison).
  bool globalMajorant = false;

  /// The extinction coefficient σt = σa + σs per unit length.
  Color sigmaT() const { return sigmaA + sigmaS; }
};

// ---- The Henyey–Greenstein phase function ----------------------------------------------------------------------

/// Below this |g| the Henyey–Greenstein function is sampled as the isotropic one (its inversion divides by g).
inline constexpr Real kIsotropicG = Real(1e-3);

// [hg]
/// The Henyey–Greenstein phase function p(cosθ) = (1 − g²) / (4π (1 + g² − 2g cosθ)^{3/2}), per steradian.
/// @param cosTheta ω·ω' in [−1, 1], ω the direction of travel before scattering and ω' after (see the file comment).
/// @param g the asymmetry in (−1, 1); its mean cosine ∫ p cosθ dω' equals g.
inline Real hgPhase(Real cosTheta, Real g)
{
  const Real denom = 1 + g * g - 2 * g * cosTheta;
  return (1 - g * g) / (4 * kPi * denom * std::sqrt(std::max(denom, Real(0))));
}

/// cosθ drawn with density p(cosθ)·2π (the Henyey–Greenstein density of the cosine, azimuth apart), by inverting
/// its distribution function: cosθ = (1 + g² − ((1 − g²)/(1 − g + 2gu))²) / (2g); u = 0 gives cosθ = −1 and u → 1
/// gives cosθ = 1 for every g. Uniform cosθ = 2u − 1 when |g| < kIsotropicG.
/// @param g the asymmetry, in (−1, 1) (g > 0: forward). @param u uniform in [0, 1). @return cosθ in [−1, 1].
inline Real sampleHgCosTheta(Real g, Real u)
{
  if (std::abs(g) < kIsotropicG)
    return std::clamp(2 * u - 1, Real(-1), Real(1));
  const Real s = (1 - g * g) / (1 - g + 2 * g * u);
  return std::clamp((1 + g * g - s * s) / (2 * g), Real(-1), Real(1));
}
// [hg]

/// A direction scattered by the Henyey–Greenstein phase function, with its pdf.
struct PhaseSample {
  Vec3 wi{0, 0, 1}; ///< The new unit direction of travel ω', world space.
  Real pdf = 0;     ///< Its density per steradian: hgPhase(ω·ω', g), equal to the phase value, so f/pdf = 1.
};

/// ω' drawn from the Henyey–Greenstein function around the direction of travel `w` (unit): cosθ by
/// sampleHgCosTheta(g, u.x), the azimuth 2π·u.y. @param w the direction of travel, unit, world space.
/// @param g the asymmetry, in (−1, 1). @param u uniform in [0, 1)². @return ω' and its pdf (> 0).
PhaseSample sampleHg(const Vec3& w, Real g, Vec2 u);

// ---- Transmittance and free flight -----------------------------------------------------------------------------

/// e^{−a·d} for a ≥ 0 and d ≥ 0, either of which may be huge and d infinite: exactly 1 when a = 0 (no 0·∞ = NaN),
/// and 0, not NaN, when a·d overflows.
template <class T> T decay(T a, T d) { return a > 0 ? std::exp(-(a * d)) : T(1); }

/// Beer–Lambert: the fraction exp(−σt·d) of light that crosses a distance d of the medium, per channel. Exact 0 for
/// any channel whose optical depth is huge (up to infinite), and 1 for a channel with σt = 0, even at d = ∞ (no
/// 0·∞). @param sigmaT σt ≥ 0 per channel. @param d distance ≥ 0 (may be infinite).
template <class T> TVec3<T> transmittance(const TVec3<T>& sigmaT, T d)
{
  return TVec3<T>(decay(sigmaT.x, d), decay(sigmaT.y, d), decay(sigmaT.z, d));
}

/// What free-flight sampling returns: where the ray's first interaction in the medium is, and the weight it brings.
template <class T> struct FreeFlightOf {
  bool scattered = false; ///< True: a scattering event at `t`, before the surface; false: the ray reaches it.
  T t = 0;                ///< The distance of the event (scattered), else the surface distance it was given.
  /// The path's throughput factor: for a scattering event σs·Tr(t) / p̄(t), else Tr(tMax) / P̄(reach); finite and
  /// ≥ 0 always. Its expectation, summed over the two cases, makes the estimator unbiased for every channel.
  TVec3<T> weight{1};
};
/// Free flight in the renderer's precision.
using FreeFlight = FreeFlightOf<Real>;

// [freeFlight]
/// Samples the distance to the next scattering event along a ray in a homogeneous medium of coefficients `sigmaA`,
/// `sigmaS`, up to a surface at distance `tMax` (∞: none).
///
/// Spectral MIS (the "hero channel" of pbrt-v4 and Mitsuba): a channel c is chosen uniformly by `uChannel`, and
/// t = −ln(1 − u)/σt,c. The density of t is then the average of the three channels' densities,
/// p̄(t) = ⅓ Σ σt,i e^{−σt,i t}, and the chance of passing the surface P̄ = ⅓ Σ e^{−σt,i tMax}: weighting by these
/// averages (rather than by the chosen channel's own pdf) keeps every channel unbiased and bounded. Every ratio is
/// taken after factoring out the smallest channel's exponential, so no weight divides two transmittances that
/// underflow together (0/0): with σt·d = 10⁶ the answer is a finite number, not NaN.
/// Absorption is not sampled: a scattering event carries the albedo in its weight (σs/σt per channel, on average).
/// @param sigmaA,sigmaS the absorption and scattering coefficients per unit length, each channel ≥ 0.
/// @param tMax the distance to the surface the ray meets, positive (∞: none). @param uChannel,u uniform in [0, 1).
template <class T>
FreeFlightOf<T> sampleFreeFlight(const TVec3<T>& sigmaA, const TVec3<T>& sigmaS, T tMax, T uChannel, T u)
{
  const TVec3<T> sigmaT = sigmaA + sigmaS;
  const int c = std::min(int(uChannel * 3), 2);
  // The chosen channel's exponential distance (∞ for a channel that does not interact).
  const T t = sigmaT[c] > 0 ? -std::log1p(-u) / sigmaT[c] : std::numeric_limits<T>::infinity();
  if (t < tMax) {
    // A scattering event: weight σs,i e^{−σt,i t} / (⅓ Σ σt,j e^{−σt,j t}), each exponential taken relative to the
    // smallest positive σt (m ≤ σt,c), so every one is ≤ 1 and the denominator ≥ m/3 > 0 up to underflow.
    T m = std::numeric_limits<T>::max();
    for (int i = 0; i < 3; ++i)
      if (sigmaT[i] > 0)
        m = std::min(m, sigmaT[i]);
    TVec3<T> relative(0); // e^{−(σt,i − m) t}; 0 for a channel that does not interact
    for (int i = 0; i < 3; ++i)
      relative[i] = sigmaT[i] > 0 ? decay(sigmaT[i] - m, t) : T(0);
    const T pdf = (sigmaT.x * relative.x + sigmaT.y * relative.y + sigmaT.z * relative.z) / 3;
    return FreeFlightOf<T>{true, t, pdf > 0 ? sigmaS * relative / pdf : TVec3<T>(0)};
  }
  // The ray reaches the surface: weight e^{−σt,i tMax} / (⅓ Σ e^{−σt,j tMax}), relative to the smallest σt, so the
  // denominator is ≥ ⅓.
  const T m = std::min({sigmaT.x, sigmaT.y, sigmaT.z});
  const TVec3<T> relative(decay(sigmaT.x - m, tMax), decay(sigmaT.y - m, tMax), decay(sigmaT.z - m, tMax));
  return FreeFlightOf<T>{false, tMax, relative / ((relative.x + relative.y + relative.z) / 3)};
}
// [freeFlight]

} // namespace raylife

/// @file bsdf.h
/// @brief Reflection and refraction at a surface: Snell's law, the Fresnel equations, and the BSDFs of the
/// path tracer, each with its evaluation, its sampling routine and its pdf.
///
/// Conventions (as in pbrt). Directions point *away* from the surface: wo towards the viewer (the reversed
/// ray), wi towards where the light comes from. BSDFs work in the local shading frame (frame.h) built around
/// the sphere's **outward** normal, so cosθ = w.z, wo.z < 0 means "seen from inside the sphere", and a
/// dielectric knows from the sign of wo.z which way it is crossing. The opaque BSDFs (Lambertian, mirror,
/// glossy) reflect on whichever side wo is: a diffuse sphere seen from inside is diffuse inside.
///
/// What the estimator needs of a sample is its weight f·|cosθi|/pdf. For the specular lobes (mirror, glass),
/// which are Dirac deltas, f is stored as the delta's weight divided by |cosθi| and pdf as the discrete
/// probability of the lobe chosen, so that the same formula gives the right weight (pbrt's convention).
/// eval and pdf of a delta lobe are 0: no direction chosen any other way can hit it.
#pragma once

#include "shading/material.h"
#include "core/math.h"

#include <optional>

namespace raylife {

// ---- Snell's law and the Fresnel equations (world or local space alike) --------------------------------------

// [reflect]
/// The mirror direction of unit `wo` about unit normal `n` (either side): 2(wo·n)n − wo, unit.
inline Vec3 reflect(const Vec3& wo, const Vec3& n) { return 2 * glm::dot(wo, n) * n - wo; }
// [reflect]

/// The direction refracted by Snell's law, η_i sinθ_i = η_t sinθ_t.
///
/// @param wo  unit direction away from the surface, on the side the light leaves towards (the viewer's side).
/// @param n   unit **outward** normal of the surface (the side of the outside medium).
/// @param eta relative index of refraction η_inside/η_outside, > 0 (a sphere's `ior`).
/// @return the unit refracted direction on the other side of the surface, or nothing under total internal
///         reflection (sin²θ_t ≥ 1, possible only when wo is inside and η > 1).
std::optional<Vec3> refract(const Vec3& wo, const Vec3& n, Real eta);

/// The Fresnel reflectance of a smooth dielectric interface for unpolarised light: the share of light
/// reflected, the average of the s- and p-polarised reflectances (the rest is transmitted).
///
/// @param cosThetaO cosine of the angle between wo and the **outward** normal, in [−1, 1]: > 0 outside,
///                  < 0 inside the sphere.
/// @param eta       relative index of refraction η_inside/η_outside, > 0.
/// @return reflectance in [0, 1]; exactly 1 under total internal reflection.
Real fresnelDielectric(Real cosThetaO, Real eta);

// ---- BSDF samples ------------------------------------------------------------------------------------------

/// A direction chosen by a BSDF's sampling routine, with what the estimator needs to weight it.
struct BsdfSample {
  Vec3 wi{0, 0, 1};    ///< Sampled direction towards the light, local frame, unit.
  Color f{0};          ///< f(wo, wi), per steradian; for a delta lobe its weight divided by |cosθi| (file comment).
  Real pdf = 0;        ///< Solid-angle pdf of wi, > 0; for a delta lobe the probability of choosing that lobe.
  bool specular = false; ///< True for a Dirac-delta lobe (mirror reflection, glass).

  /// The estimator's weight f·|cosθi|/pdf, per channel, ≥ 0.
  Color weight() const { return f * std::abs(wi.z) / pdf; }
};

// ---- Lambertian: f = ρ/π ------------------------------------------------------------------------------------

/// The Lambertian BRDF, ρ/π per steradian when wo and wi lie on the same side, 0 otherwise.
/// @param albedo ρ in [0, 1] per channel: the share of light reflected, whatever the direction of arrival.
/// @param wo,wi unit directions in the local frame (towards the viewer, towards the light).
Color lambertianEval(const Color& albedo, const Vec3& wo, const Vec3& wi);
/// The pdf of lambertianSample: cos-weighted, |cosθi|/π on wo's side, 0 on the other.
Real lambertianPdf(const Vec3& wo, const Vec3& wi);
/// A cosine-weighted direction on wo's side; its weight is exactly ρ. Nothing when wo is tangent (wo.z = 0).
std::optional<BsdfSample> lambertianSample(const Color& albedo, const Vec3& wo, Vec2 u);

// ---- Ideal mirror --------------------------------------------------------------------------------------------

/// The ideal mirror: wi = reflect(wo, n) with weight `tint` (in [0, 1] per channel). Nothing when wo.z = 0.
std::optional<BsdfSample> mirrorSample(const Color& tint, const Vec3& wo);

/// An interface (chapter 15: a boundary between media, not a surface) as chapters before 15 see it: the ray goes
/// on unchanged, wi = −wo, with weight exactly 1 (a delta lobe). Nothing when wo.z = 0.
std::optional<BsdfSample> passThroughSample(const Vec3& wo);

// ---- Ideal dielectric (glass) --------------------------------------------------------------------------------

/// The smooth dielectric: reflection with probability F and refraction with probability 1 − F, F the Fresnel
/// reflectance (fresnelDielectric), so each sample's weight is `tint` (per channel in [0, 1]). Under total
/// internal reflection F = 1 and the sample always reflects. Radiance is not scaled by η² on crossing: for a path
/// that enters and leaves a closed object (every path from a camera outside glass to a light outside it) the factors
/// cancel, and leaving them out keeps the weight exactly the tint.
/// @param tint colour C in [0, 1] per channel. @param eta η_inside/η_outside, > 0.
/// @param wo unit direction towards the viewer, local frame. @param uChoice uniform in [0, 1): chooses the lobe.
std::optional<BsdfSample> dielectricSample(const Color& tint, Real eta, const Vec3& wo, Real uChoice);

// ---- Glossy: normalised (modified) Phong ---------------------------------------------------------------------

/// The Phong exponent n for a roughness r in (0, 1]: n = 2/r² − 2, so r = 1 is Lambertian (n = 0) and the
/// lobe narrows as r → 0 (the mapping makes the lobe's width grow about linearly with r). Infinite below
/// r ≈ 10⁻¹⁵⁴ in double (r² is 0), which the Phong functions below take as the mirror (kMaxPhongExponent).
/// (Inline: chapter 16's shade asks it of every glossy path, and defined in the .cpp only link-time optimisation
/// could inline it.)
inline Real phongExponent(Real roughness) { return 2 / (roughness * roughness) - 2; }

/// Below this roughness a glossy material is the mirror its lobe narrows to, as a metal is below kMinGgxAlpha (the
/// same 10⁻³). The lobe is then about r = 10⁻³ radians wide, less than a pixel of the chapters' images spans (3·10⁻³
/// for 240 rows over a 40° field of view), and lower still its arithmetic breaks: at n ≈ 10¹⁸ (r ≈ 10⁻⁹) a cosine
/// that rounds to just above 1, raised to n, overflows, so f and the pdf are both infinite and their ratio is NaN.
inline constexpr Real kMinPhongRoughness = Real(1e-3);
/// The largest Phong exponent the functions below treat as a lobe, phongExponent(kMinPhongRoughness) (2·10⁶ − 2).
/// Above it (or infinite): the delta lobe in the mirror direction with weight ρ_s |cosθi|, the limit of the lobe's
/// weight ρ_s (n + 2)/(n + 1) cosθi as n → ∞, so the material's look does not jump at the threshold.
inline constexpr Real kMaxPhongExponent = 2 / (kMinPhongRoughness * kMinPhongRoughness) - 2;

/// The normalised modified Phong BRDF (Lafortune and Willems 1994): f = ρ_s (n + 2)/(2π) cosⁿα, with α the
/// angle between wi and the mirror direction of wo, on wo's side only. Symmetric in wo and wi (reciprocal), and
/// its directional albedo is at most ρ_s (exactly ρ_s at normal incidence), so it conserves energy.
/// @param albedo ρ_s in [0, 1] per channel. @param exponent n ≥ 0 (above kMaxPhongExponent the mirror: a delta,
/// so 0 here). @param wo,wi unit directions in the local frame (towards the viewer, towards the light).
Color phongEval(const Color& albedo, Real exponent, const Vec3& wo, const Vec3& wi);
/// The pdf of phongSample: (n + 1)/(2π) cosⁿα on wo's side, 0 on the other; 0 for the mirror (n above
/// kMaxPhongExponent).
Real phongPdf(Real exponent, const Vec3& wo, const Vec3& wi);
/// A direction from the cosⁿα lobe around the mirror direction; nothing when it falls below the surface
/// (the estimator then counts the sample as 0, which keeps it unbiased: the pdf is not renormalised). Above
/// kMaxPhongExponent: the mirror direction, as a delta lobe with weight ρ_s |cosθi|.
std::optional<BsdfSample> phongSample(const Color& albedo, Real exponent, const Vec3& wo, Vec2 u);

// ---- Metal: the GGX (Trowbridge–Reitz) microfacet BRDF -------------------------------------------------------

/// Below this GGX α a metal is a smooth mirror (a delta lobe, with Schlick's Fresnel): the distribution's peak
/// 1/(πα²) and the sampled directions' spread leave the range where they mean anything. pbrt-v4's threshold.
inline constexpr Real kMinGgxAlpha = Real(1e-3);

/// Schlick's approximation of a conductor's Fresnel reflectance: F0 + (1 − F0)(1 − cosθ)⁵.
/// @param f0 the reflectance at normal incidence, per channel in [0, 1]. @param cosTheta |cos| of the angle between
/// the direction and the (micro)normal, in [0, 1].
Color schlickFresnel(const Color& f0, Real cosTheta);

/// The GGX normal distribution D(h) = α² / (π ((α² − 1) cos²θh + 1)²), per steradian of microfacet normals; its
/// projected area integrates to 1: ∫ D(h) cosθh dh = 1. @param h unit microfacet normal (local frame; 0 below the
/// surface). @param alpha α in (0, 1].
Real ggxD(const Vec3& h, Real alpha);
/// Smith's Λ for GGX, Λ(w) = (√(1 + α² tan²θ) − 1)/2, the masking function's auxiliary. @param w unit direction.
/// @param alpha α in (0, 1].
Real ggxLambda(const Vec3& w, Real alpha);
/// The masking function G1(w) = 1/(1 + Λ(w)): the share of the microsurface seen from w that is not hidden.
/// @param w unit direction. @param alpha α in (0, 1].
Real ggxG1(const Vec3& w, Real alpha);

/// A microfacet normal sampled from the distribution of normals visible from `wo` (Heitz 2018, "Sampling the GGX
/// Distribution of Visible Normals"): density D_wo(h) = G1(wo) max(0, wo·h) D(h) / wo.z.
/// @param wo unit direction towards the viewer, wo.z > 0. @param alpha α in (0, 1]. @param u uniform in [0, 1)².
/// @return a unit normal with h.z ≥ 0.
Vec3 sampleGgxVisibleNormal(const Vec3& wo, Real alpha, Vec2 u);

/// The GGX metal: f = D(h) G2(wo, wi) F(wi·h) / (4 |cosθo| |cosθi|), h the half vector, G2 the height-correlated
/// Smith term 1/(1 + Λ(wo) + Λ(wi)) and F Schlick's, on wo's side only (a metal seen from inside a sphere is a
/// metal inside). Reciprocal; its directional albedo is at most 1 (below 1 at high roughness: single scattering
/// loses the light that bounces between microfacets). With α < kMinGgxAlpha it is the mirror (a delta: 0 here).
/// @param f0 F0 in [0, 1] per channel. @param alpha α in [0, 1]. @param wo,wi unit directions, local frame.
Color metalEval(const Color& f0, Real alpha, const Vec3& wo, const Vec3& wi);
/// The pdf of metalSample: D_wo(h) / (4 |wo·h|) = G1(wo) D(h) / (4 |cosθo|) on wo's side, 0 on the other; 0 for
/// the mirror (α < kMinGgxAlpha).
Real metalPdf(Real alpha, const Vec3& wo, const Vec3& wi);
/// A direction reflected about a visible normal (sampleGgxVisibleNormal); nothing when it falls below the surface
/// (the pdf keeps that mass, so the estimator stays unbiased). Below kMinGgxAlpha: the mirror direction, as a
/// delta lobe with weight F(cosθo).
std::optional<BsdfSample> metalSample(const Color& f0, Real alpha, const Vec3& wo, Vec2 u);

// ---- A material's BSDF ---------------------------------------------------------------------------------------

/// f(wo, wi) of material `m` (local frame); 0 for the delta lobes of mirror, glass and a smooth metal.
Color bsdfEval(const Material& m, const Vec3& wo, const Vec3& wi);
/// The pdf with which bsdfSample chooses wi (local frame); 0 for mirror, glass and a smooth metal.
Real bsdfPdf(const Material& m, const Vec3& wo, const Vec3& wi);
/// Samples wi for material `m` (local frame). @param m the material. @param wo unit direction towards the viewer.
/// @param u uniform in [0, 1)² (the direction).
/// @param uChoice uniform in [0, 1) (which lobe, for glass). Nothing when the sample carries no light.
std::optional<BsdfSample> bsdfSample(const Material& m, const Vec3& wo, Vec2 u, Real uChoice);

/// bsdfEval with `color` (the material's colour at the hit: a texture's value there, chapter 14) for `m.color`.
Color bsdfEval(const Material& m, const Color& color, const Vec3& wo, const Vec3& wi);
/// bsdfSample with `color` (the material's colour at the hit) for `m.color`.
std::optional<BsdfSample> bsdfSample(const Material& m, const Color& color, const Vec3& wo, Vec2 u, Real uChoice);

} // namespace raylife

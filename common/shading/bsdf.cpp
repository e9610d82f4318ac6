#include "shading/bsdf.h"

#include "core/frame.h"
#include "core/sampling.h"

#include <algorithm>
#include <cmath>

namespace raylife {

namespace {

// The mirror direction of a local direction about the local normal (0, 0, 1).
Vec3 reflectLocal(const Vec3& w) { return Vec3(-w.x, -w.y, w.z); }

bool sameSide(const Vec3& wo, const Vec3& wi) { return wo.z * wi.z > 0; }

} // namespace

// [refract]
namespace {
// cos²θt = 1 − sin²θi/η², written as ((η − 1)(η + 1) + cos²θi)/η² so that nothing cancels: the textbook
// 1 − (1 − cos²θi)/η² loses the small cos²θi of a grazing ray (and with η = 1 bends a ray it must not bend).
// ≤ 0 means total internal reflection. cosI ≥ 0, eta > 0 (transmitted over incident index).
Real cosTransmittedSquared(Real cosI, Real eta)
{
  return ((eta - 1) * (eta + 1) + cosI * cosI) / (eta * eta);
}
} // namespace

std::optional<Vec3> refract(const Vec3& wo, const Vec3& n, Real eta)
{
  // Which side: from outside the ray enters (η = η_t/η_i = eta); from inside it leaves (1/eta, normal flipped).
  Real cosI = glm::dot(wo, n);
  Vec3 nFacing = n;
  if (cosI < 0) {
    eta = 1 / eta;
    cosI = -cosI;
    nFacing = -n;
  }
  // Snell's law: sin²θt = sin²θi / η²; past 1 there is no refracted ray (total internal reflection).
  const Real cos2T = cosTransmittedSquared(cosI, eta);
  if (cos2T <= 0)
    return std::nullopt;
  const Real cosT = std::sqrt(cos2T);
  // The tangential part shrinks by 1/η, the normal part makes the result unit and points through the surface.
  return glm::normalize(-wo / eta + (cosI / eta - cosT) * nFacing);
}
// [refract]

// [fresnel]
Real fresnelDielectric(Real cosThetaO, Real eta)
{
  Real cosI = std::clamp(cosThetaO, Real(-1), Real(1));
  if (cosI < 0) { // inside: the light crosses from the sphere's medium to the outside one
    eta = 1 / eta;
    cosI = -cosI;
  }
  // Snell's law for the refracted angle; total internal reflection reflects everything.
  const Real cos2T = cosTransmittedSquared(cosI, eta);
  if (cos2T <= 0)
    return 1;
  const Real cosT = std::sqrt(cos2T);
  // The Fresnel equations for parallel and perpendicular polarisation (η = η_t/η_i), averaged.
  const Real rParallel = (eta * cosI - cosT) / (eta * cosI + cosT);
  const Real rPerpendicular = (cosI - eta * cosT) / (cosI + eta * cosT);
  return (rParallel * rParallel + rPerpendicular * rPerpendicular) / 2;
}
// [fresnel]

// [lambertian]
Color lambertianEval(const Color& albedo, const Vec3& wo, const Vec3& wi)
{
  return sameSide(wo, wi) ? albedo * kInvPi : Color(0);
}

Real lambertianPdf(const Vec3& wo, const Vec3& wi) { return sameSide(wo, wi) ? std::abs(wi.z) * kInvPi : 0; }

std::optional<BsdfSample> lambertianSample(const Color& albedo, const Vec3& wo, Vec2 u)
{
  if (wo.z == 0)
    return std::nullopt;
  // Cosine-weighted on wo's side: the weight (ρ/π)·cosθ / (cosθ/π) is exactly ρ.
  Vec3 wi = sampleCosineHemisphere(u);
  if (wo.z < 0)
    wi.z = -wi.z;
  const Real pdf = lambertianPdf(wo, wi);
  if (!(pdf > 0)) // wi exactly tangent: a direction of zero density
    return std::nullopt;
  return BsdfSample{wi, albedo * kInvPi, pdf, false};
}
// [lambertian]

// [mirror]
std::optional<BsdfSample> mirrorSample(const Color& tint, const Vec3& wo)
{
  if (wo.z == 0)
    return std::nullopt;
  const Vec3 wi = reflectLocal(wo);
  return BsdfSample{wi, tint / std::abs(wi.z), 1, true};
}
// [mirror]

// An interface (chapter 15) seen as a surface: the ray goes on unchanged, with weight 1 (a delta lobe).
std::optional<BsdfSample> passThroughSample(const Vec3& wo)
{
  if (wo.z == 0)
    return std::nullopt;
  return BsdfSample{-wo, Color(1 / std::abs(wo.z)), 1, true};
}

// [dielectric]
std::optional<BsdfSample> dielectricSample(const Color& tint, Real eta, const Vec3& wo, Real uChoice)
{
  if (wo.z == 0)
    return std::nullopt;
  // Choose reflection with probability F: the weight F/F (or T/T) of the chosen lobe is then 1, times the tint.
  const Real F = fresnelDielectric(wo.z, eta);
  if (uChoice < F) {
    const Vec3 wi = reflectLocal(wo);
    return BsdfSample{wi, tint * F / std::abs(wi.z), F, true};
  }
  const std::optional<Vec3> wi = refract(wo, Vec3(0, 0, 1), eta);
  if (!wi || wi->z == 0) // cannot happen when F < 1, but never divide by a zero cosine
    return std::nullopt;
  return BsdfSample{*wi, tint * (1 - F) / std::abs(wi->z), 1 - F, true};
}
// [dielectric]

// [phong]
Color phongEval(const Color& albedo, Real exponent, const Vec3& wo, const Vec3& wi)
{
  if (!(exponent <= kMaxPhongExponent) || !sameSide(wo, wi))
    return Color(0);
  const Real cosAlpha = glm::dot(wi, reflectLocal(wo));
  if (cosAlpha <= 0)
    return Color(0);
  return albedo * ((exponent + 2) / (2 * kPi) * std::pow(cosAlpha, exponent));
}

Real phongPdf(Real exponent, const Vec3& wo, const Vec3& wi)
{
  if (!(exponent <= kMaxPhongExponent) || !sameSide(wo, wi))
    return 0;
  return phongLobePdf(glm::dot(wi, reflectLocal(wo)), exponent);
}

std::optional<BsdfSample> phongSample(const Color& albedo, Real exponent, const Vec3& wo, Vec2 u)
{
  if (wo.z == 0)
    return std::nullopt;
  // Sample the lobe around the mirror direction r, in r's own frame, then rotate it into the shading frame.
  const Vec3 r = reflectLocal(wo);
  if (!(exponent <= kMaxPhongExponent)) // smooth: the mirror the lobe narrows to, f·|cosθi|/pdf = ρ_s |cosθi|
    return BsdfSample{r, albedo, 1, true};
  const Vec3 wi = glm::normalize(Frame::fromNormal(r).toWorld(samplePhongLobe(u, exponent)));
  // Below the surface: no light (the pdf keeps its mass there, so the estimator stays unbiased).
  const Real pdf = phongPdf(exponent, wo, wi);
  if (!(pdf > 0))
    return std::nullopt;
  return BsdfSample{wi, phongEval(albedo, exponent, wo, wi), pdf, false};
}
// [phong]

// [ggx]
Color schlickFresnel(const Color& f0, Real cosTheta)
{
  const Real m = std::clamp(1 - cosTheta, Real(0), Real(1));
  const Real m2 = m * m;
  return f0 + (Color(1) - f0) * (m2 * m2 * m);
}

Real ggxD(const Vec3& h, Real alpha)
{
  if (h.z <= 0)
    return 0;
  const Real a2 = alpha * alpha;
  const Real denominator = (a2 - 1) * (h.z * h.z) + 1;
  return a2 / (kPi * denominator * denominator);
}

Real ggxLambda(const Vec3& w, Real alpha)
{
  // α² tan²θ = α² (1 − cos²θ)/cos²θ; a grazing direction (cosθ = 0) is wholly masked (Λ = ∞).
  const Real cos2 = w.z * w.z;
  if (cos2 == 0)
    return kInfinity;
  const Real a2Tan2 = alpha * alpha * std::max(Real(0), 1 - cos2) / cos2;
  return (std::sqrt(1 + a2Tan2) - 1) / 2;
}

Real ggxG1(const Vec3& w, Real alpha) { return 1 / (1 + ggxLambda(w, alpha)); }

Vec3 sampleGgxVisibleNormal(const Vec3& wo, Real alpha, Vec2 u)
{
  // Stretch the view direction so that the ellipsoid of normals becomes the hemisphere of radius 1.
  const Vec3 v = glm::normalize(Vec3(alpha * wo.x, alpha * wo.y, wo.z));
  // A frame around it.
  const Real lengthSq = v.x * v.x + v.y * v.y;
  const Vec3 t1 = lengthSq > 0 ? Vec3(-v.y, v.x, 0) / std::sqrt(lengthSq) : Vec3(1, 0, 0);
  const Vec3 t2 = glm::cross(v, t1);
  // A uniform point on the disk, its half behind the view direction squeezed onto the part that is seen.
  const Real r = std::sqrt(u.x);
  const SinCos<Real> phi = sinCos2Pi(u.y);
  const Real p1 = r * phi.cos;
  const Real s = (1 + v.z) / 2;
  const Real p2 = (1 - s) * std::sqrt(std::max(Real(0), 1 - p1 * p1)) + s * r * phi.sin;
  // Lift it onto the hemisphere and unstretch the normal.
  const Vec3 n = p1 * t1 + p2 * t2 + std::sqrt(std::max(Real(0), 1 - p1 * p1 - p2 * p2)) * v;
  return glm::normalize(Vec3(alpha * n.x, alpha * n.y, std::max(Real(0), n.z)));
}

namespace {
// A direction on wo's side taken to the upper hemisphere (the opaque BSDFs reflect on either side).
Vec3 upper(const Vec3& w, bool flip) { return flip ? Vec3(w.x, w.y, -w.z) : w; }
} // namespace

Color metalEval(const Color& f0, Real alpha, const Vec3& wo, const Vec3& wi)
{
  if (alpha < kMinGgxAlpha || !sameSide(wo, wi))
    return Color(0);
  const bool flip = wo.z < 0;
  const Vec3 o = upper(wo, flip), i = upper(wi, flip);
  const Vec3 h = glm::normalize(o + i);
  const Real G2 = 1 / (1 + ggxLambda(o, alpha) + ggxLambda(i, alpha));
  return ggxD(h, alpha) * G2 * schlickFresnel(f0, std::abs(glm::dot(i, h))) / (4 * o.z * i.z);
}

Real metalPdf(Real alpha, const Vec3& wo, const Vec3& wi)
{
  if (alpha < kMinGgxAlpha || !sameSide(wo, wi))
    return 0;
  const bool flip = wo.z < 0;
  const Vec3 o = upper(wo, flip), i = upper(wi, flip);
  const Vec3 h = glm::normalize(o + i);
  // D_wo(h) / (4 wo·h), with D_wo(h) = G1(wo) (wo·h) D(h) / wo.z: the wo·h cancel.
  return ggxG1(o, alpha) * ggxD(h, alpha) / (4 * o.z);
}

std::optional<BsdfSample> metalSample(const Color& f0, Real alpha, const Vec3& wo, Vec2 u)
{
  if (wo.z == 0)
    return std::nullopt;
  const bool flip = wo.z < 0;
  const Vec3 o = upper(wo, flip);
  if (alpha < kMinGgxAlpha) { // smooth: the mirror, with the Fresnel of its angle
    const Vec3 wi = reflectLocal(wo);
    return BsdfSample{wi, schlickFresnel(f0, o.z) / std::abs(wi.z), 1, true};
  }
  // Reflect wo about a normal the viewer sees; below the horizon: no light (the pdf keeps that mass).
  const Vec3 h = sampleGgxVisibleNormal(o, alpha, u);
  const Vec3 i = reflect(o, h);
  if (!(i.z > 0))
    return std::nullopt;
  const Vec3 wi = upper(i, flip);
  const Real pdf = metalPdf(alpha, wo, wi);
  if (!(pdf > 0))
    return std::nullopt;
  return BsdfSample{wi, metalEval(f0, alpha, wo, wi), pdf, false};
}
// [ggx]

Color bsdfEval(const Material& m, const Vec3& wo, const Vec3& wi) { return bsdfEval(m, m.color, wo, wi); }

Color bsdfEval(const Material& m, const Color& color, const Vec3& wo, const Vec3& wi)
{
  switch (m.type) {
  case MaterialType::Diffuse: return lambertianEval(color, wo, wi);
  case MaterialType::Glossy: return phongEval(color, phongExponent(m.roughness), wo, wi);
  case MaterialType::Metal: return metalEval(color, m.roughness, wo, wi);
  case MaterialType::Mirror:
  case MaterialType::Glass:
  case MaterialType::Interface: return Color(0);
  }
  return Color(0);
}

Real bsdfPdf(const Material& m, const Vec3& wo, const Vec3& wi)
{
  switch (m.type) {
  case MaterialType::Diffuse: return lambertianPdf(wo, wi);
  case MaterialType::Glossy: return phongPdf(phongExponent(m.roughness), wo, wi);
  case MaterialType::Metal: return metalPdf(m.roughness, wo, wi);
  case MaterialType::Mirror:
  case MaterialType::Glass:
  case MaterialType::Interface: return 0;
  }
  return 0;
}

// [bsdfSample]
std::optional<BsdfSample> bsdfSample(const Material& m, const Vec3& wo, Vec2 u, Real uChoice)
{
  return bsdfSample(m, m.color, wo, u, uChoice);
}
// [bsdfSample]

std::optional<BsdfSample> bsdfSample(const Material& m, const Color& color, const Vec3& wo, Vec2 u, Real uChoice)
{
  switch (m.type) {
  case MaterialType::Diffuse: return lambertianSample(color, wo, u);
  case MaterialType::Mirror: return mirrorSample(color, wo);
  case MaterialType::Glass: return dielectricSample(color, m.ior, wo, uChoice);
  case MaterialType::Glossy: return phongSample(color, phongExponent(m.roughness), wo, u);
  case MaterialType::Metal: return metalSample(color, m.roughness, wo, u);
  case MaterialType::Interface: return passThroughSample(wo);
  }
  return std::nullopt;
}

} // namespace raylife

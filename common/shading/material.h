/// @file material.h
/// @brief A surface's material as the scene file states it.
#pragma once

#include "core/math.h"
#include "shading/texture.h"

#include <string>

namespace raylife {

/// The kinds of surface raylife knows. A closed set, switched on where it is used: no plugin registry.
enum class MaterialType {
  Diffuse, ///< Lambertian: reflects equally in all directions; `color` is the albedo ρ.
  Mirror,  ///< Ideal specular reflection, tinted by `color`.
  Glass,   ///< Ideal dielectric: Fresnel-weighted reflection and refraction with index `ior`, tinted by `color`.
  Glossy,  ///< Rough reflection, `roughness` in (0, 1] (below kMinPhongRoughness a mirror); `color` the albedo.
  /// A rough conductor: the GGX (Trowbridge–Reitz) microfacet BRDF with α = `roughness` in [0, 1], and Schlick's
  /// Fresnel with `color` the reflectance at normal incidence F0 (chapter 11).
  Metal,
  /// A boundary that is not a surface (chapter 15): no reflection, no refraction; a ray crosses it unchanged and
  /// only the medium it travels in changes (the shape's "interior" and "exterior", scene.h). `color` is ignored
  /// and it cannot emit. Chapters before 15 pass straight through it.
  Interface,
};

/// The name a scene file uses for a material type ("diffuse", "mirror", "glass", "glossy", "metal", "interface").
const char* materialTypeName(MaterialType type);

/// A material. Colours are linear RGB reflectances in [0, 1]; emission is radiance (≥ 0, unbounded).
struct Material {
  std::string name;                         ///< The key it has in the scene file's "materials".
  MaterialType type = MaterialType::Diffuse; ///< What kind of surface.
  Color color{Real(0.8)};                   ///< Reflectance / tint per channel, in [0, 1].
  Color emission{0};                        ///< Emitted radiance Le, ≥ 0 per channel; non-zero makes an area light.
  Real ior = Real(1.5);                     ///< Index of refraction (glass), ≥ 1, relative to the outside medium.
  Real roughness = Real(0.3);               ///< Roughness: glossy's in (0, 1]; metal's GGX α in [0, 1].
  /// `color` as a texture (chapter 14), or null. When set, `color` holds its mean: what the chapters before 14,
  /// which know no (u, v), shade with.
  TexturePtr colorTexture;
  /// `emission` as a texture (chapter 14), or null; when set, `emission` holds its mean (the light's power).
  TexturePtr emissionTexture;

  /// True when the surface emits light.
  bool isEmissive() const { return emission.r > 0 || emission.g > 0 || emission.b > 0; }
};

} // namespace raylife

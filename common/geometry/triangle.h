/// @file triangle.h
/// @brief Ray–triangle intersection that is watertight (Woop, Benthin and Wald, "Watertight Ray/Triangle
/// Intersection", JCGT 2013, in the form pbrt-v4 uses), templated on the scalar for the stability tests; the hit's
/// barycentric coordinates and the error bound of the point they give.
///
/// Why watertight. A mesh's triangles share their edges and vertices. The usual test (Möller–Trumbore) decides
/// "inside" for each triangle from its own edge vectors and its own rounding, so for a ray through a shared edge
/// the two triangles can both say "outside": the ray slips through a closed mesh (a light leak, a speck of
/// background inside a closed model). The watertight test first moves the ray to the origin and shears space so
/// that the ray becomes the +z axis. Then "does the ray pass inside the triangle" is "is the origin inside the
/// triangle's 2-D projection", decided by the signs of three 2-D edge functions. The edge function of an edge
/// depends only on its two (transformed) vertices, which are transformed the same way for every triangle that
/// shares them, and swapping the two vertices gives exactly its negation. So a shared edge gets one consistent
/// answer: a ray that crosses a closed mesh's edge hits at least one of the two triangles, every time.
#pragma once

#include "core/math.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <optional>
#include <type_traits>

namespace raylife {

/// A triangle of a scene's mesh: three indices into the scene's vertices, counter-clockwise seen from its front
/// (the side its geometric normal (v1 − v0) × (v2 − v0) points to), and its material.
struct Triangle {
  std::array<std::uint32_t, 3> v{}; ///< Indices into Scene::vertices (and Scene::vertexNormals, if any).
  int material = 0;                 ///< Index into Scene::materials.
  std::uint32_t mesh = 0;           ///< Index into Scene::meshes: the mesh it came from.
};

/// Where a ray meets a triangle: the ray parameter and the barycentric coordinates of the point,
/// b0·p0 + b1·p1 + b2·p2 with b0 + b1 + b2 = 1 (each in [0, 1]).
template <class T> struct TriangleHit {
  T t;  ///< Ray parameter, > 0.
  T b0; ///< Weight of vertex p0.
  T b1; ///< Weight of vertex p1.
  T b2; ///< Weight of vertex p2.
};

// [intersectTriangle]
/// The watertight ray–triangle test (see the file comment): where the ray o + t·d meets triangle (p0, p1, p2) with
/// t in [tmin, tmax), or nothing. A degenerate triangle (zero area) is never hit.
///
/// @param o the ray's origin. @param d its direction (unit in raylife, but any non-zero d works).
/// @param p0,p1,p2 the triangle's corners, in any winding (both sides are hit).
/// @param tmin,tmax the interval; contract 0 ≤ tmin. Besides, t is accepted only when it is provably greater than
///   0 (by the bound on its rounding error that pbrt-v4 derives), so a ray leaving a surface does not find that
///   surface again at t ≈ 0.
template <class T>
std::optional<TriangleHit<T>> intersectTriangle(const TVec3<T>& o, const TVec3<T>& d, const TVec3<T>& p0,
                                                const TVec3<T>& p1, const TVec3<T>& p2, T tmin, T tmax)
{
  // Translate the vertices so that the ray starts at the origin.
  TVec3<T> a = p0 - o, b = p1 - o, c = p2 - o;
  // Permute the axes so that the ray's largest component is z (so the shear below never divides by a small d.z).
  const TVec3<T> ad = glm::abs(d);
  const int kz = ad.x > ad.y ? (ad.x > ad.z ? 0 : 2) : (ad.y > ad.z ? 1 : 2);
  const int kx = kz == 2 ? 0 : kz + 1;
  const int ky = kx == 2 ? 0 : kx + 1;
  const TVec3<T> dp(d[kx], d[ky], d[kz]);
  a = TVec3<T>(a[kx], a[ky], a[kz]);
  b = TVec3<T>(b[kx], b[ky], b[kz]);
  c = TVec3<T>(c[kx], c[ky], c[kz]);
  // Shear x and y so that the ray becomes the +z axis (z is scaled later, only if there is a hit).
  const T sx = -dp.x / dp.z, sy = -dp.y / dp.z, sz = 1 / dp.z;
  a.x += sx * a.z;
  a.y += sy * a.z;
  b.x += sx * b.z;
  b.y += sy * b.z;
  c.x += sx * c.z;
  c.y += sy * c.z;

  // The edge functions: twice the signed areas of the triangles (origin, edge) in the xy-plane. e0 belongs to
  // the edge p1p2, e1 to p2p0, e2 to p0p1; each depends on its edge's two vertices only.
  T e0 = b.x * c.y - b.y * c.x;
  T e1 = c.x * a.y - c.y * a.x;
  T e2 = a.x * b.y - a.y * b.x;
  // In float, an edge function of exactly 0 may be rounding's doing: decide it again in double (as Woop et al.).
  if constexpr (std::is_same_v<T, float>) {
    if (e0 == 0 || e1 == 0 || e2 == 0) {
      e0 = T(double(b.x) * double(c.y) - double(b.y) * double(c.x));
      e1 = T(double(c.x) * double(a.y) - double(c.y) * double(a.x));
      e2 = T(double(a.x) * double(b.y) - double(a.y) * double(b.x));
    }
  }
  // The origin is inside when the three have one sign (zeros count as either: a ray exactly through an edge hits).
  if ((e0 < 0 || e1 < 0 || e2 < 0) && (e0 > 0 || e1 > 0 || e2 > 0))
    return std::nullopt;
  const T det = e0 + e1 + e2;
  if (det == 0) // the ray runs in the triangle's plane, or the triangle has no area
    return std::nullopt;

  // The hit's distance, still scaled by det: a hit behind the origin (t ≤ 0) is refused before any division.
  a.z *= sz;
  b.z *= sz;
  c.z *= sz;
  const T tScaled = e0 * a.z + e1 * b.z + e2 * c.z;
  if ((det < 0 && tScaled >= 0) || (det > 0 && tScaled <= 0))
    return std::nullopt;

  // t, compared with the interval as the value it is (so that every caller's comparisons of two hits' t agree with
  // the interval the test applied: the brute-force loop and the BVH then find the same nearest hit).
  const T invDet = 1 / det;
  const T t = tScaled * invDet;
  if (!(t >= tmin && t < tmax))
    return std::nullopt;
  // Accept t only when it is greater than 0 beyond its rounding error (pbrt-v4's bound on the error of t).
  // (std::max: a NaN here makes deltaT NaN, which refuses the hit, as it should.)
  auto maxAbs = [](T x, T y, T z) { return std::max(std::fabs(x), std::max(std::fabs(y), std::fabs(z))); };
  const T maxZ = maxAbs(a.z, b.z, c.z);
  const T maxX = maxAbs(a.x, b.x, c.x);
  const T maxY = maxAbs(a.y, b.y, c.y);
  const T deltaZ = gamma<T>(3) * maxZ;
  const T deltaX = gamma<T>(5) * (maxX + maxZ);
  const T deltaY = gamma<T>(5) * (maxY + maxZ);
  const T deltaE = 2 * (gamma<T>(2) * maxX * maxY + deltaY * maxX + deltaX * maxY);
  const T maxE = maxAbs(e0, e1, e2);
  const T deltaT = 3 * (gamma<T>(3) * maxE * maxZ + deltaE * maxZ + deltaZ * maxE) * std::abs(invDet);
  if (!(t > deltaT))
    return std::nullopt;
  return TriangleHit<T>{t, e0 * invDet, e1 * invDet, e2 * invDet};
}
// [intersectTriangle]

/// A point on a triangle from its barycentric coordinates, with a bound on its floating-point error.
template <class T> struct TrianglePoint {
  TVec3<T> point; ///< b0·p0 + b1·p1 + b2·p2.
  TVec3<T> error; ///< Per-component bound on |point − the exact point of those coordinates|, ≥ 0.
};

// [trianglePoint]
/// The point with barycentric coordinates (b0, b1, b2) on triangle (p0, p1, p2), and its error bound.
///
/// The point comes from the barycentrics, not from o + t·d: t carries the error of the whole test times |d|,
/// while the weighted sum of the vertices is off by at most γ(7)·(|b0·p0| + |b1·p1| + |b2·p2|) per component
/// (the bound pbrt-v4 derives for triangles). The bound is what lets a ray leave the surface without a fixed epsilon
/// (offsetRayOrigin).
template <class T>
TrianglePoint<T> trianglePoint(const TVec3<T>& p0, const TVec3<T>& p1, const TVec3<T>& p2, T b0, T b1, T b2)
{
  const TVec3<T> point = b0 * p0 + b1 * p1 + b2 * p2;
  const TVec3<T> sum = absBranchFree(b0 * p0) + absBranchFree(b1 * p1) + absBranchFree(b2 * p2);
  return TrianglePoint<T>{point, gamma<T>(7) * sum};
}
// [trianglePoint]

/// The unit geometric normal of triangle (p0, p1, p2): (p1 − p0) × (p2 − p0), normalised (the front side, by the
/// counter-clockwise rule), or (0, 0, 1) for a degenerate triangle.
template <class T> TVec3<T> triangleNormal(const TVec3<T>& p0, const TVec3<T>& p1, const TVec3<T>& p2)
{
  return safeNormalize(glm::cross(p1 - p0, p2 - p0), TVec3<T>(0, 0, 1));
}

/// Twice the area of triangle (p0, p1, p2): |(p1 − p0) × (p2 − p0)|, in scene units², ≥ 0.
template <class T> T triangleDoubleArea(const TVec3<T>& p0, const TVec3<T>& p1, const TVec3<T>& p2)
{
  return glm::length(glm::cross(p1 - p0, p2 - p0));
}

} // namespace raylife

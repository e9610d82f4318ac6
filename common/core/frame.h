/// @file frame.h
/// @brief The shading frame: an orthonormal basis (s, t, n) around a surface normal, in which cosθ = w.z.
#pragma once

#include "core/math.h"

#include <cmath>

namespace raylife {

/// An orthonormal, right-handed basis (s, t, n) with n the surface normal.
///
/// BSDFs work in this local frame, where the normal is (0, 0, 1): cosθ of a unit direction w is w.z, and
/// "the same side of the surface" is "the same sign of z". toLocal and toWorld are each other's inverse.
struct Frame {
  Vec3 s; ///< First tangent, unit.
  Vec3 t; ///< Second tangent, unit; s × t = n.
  Vec3 n; ///< The normal, unit.

  // [frame]
  /// The frame around unit normal `normal`, built without a branch on the normal's direction nor any
  /// division by a small number (Duff et al., "Building an Orthonormal Basis, Revisited", JCGT 2017).
  static Frame fromNormal(const Vec3& normal)
  {
    const Real sign = std::copysign(Real(1), normal.z);
    const Real a = Real(-1) / (sign + normal.z);
    const Real b = normal.x * normal.y * a;
    return Frame{Vec3(1 + sign * normal.x * normal.x * a, sign * b, -sign * normal.x),
                 Vec3(b, sign + normal.y * normal.y * a, -normal.y), normal};
  }

  /// World direction → local coordinates (w·s, w·t, w·n).
  Vec3 toLocal(const Vec3& w) const { return Vec3(glm::dot(w, s), glm::dot(w, t), glm::dot(w, n)); }

  /// Local coordinates → world direction x·s + y·t + z·n.
  Vec3 toWorld(const Vec3& local) const { return local.x * s + local.y * t + local.z * n; }
  // [frame]
};

} // namespace raylife

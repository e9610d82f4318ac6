// The irradiance from a uniformly emitting polygon, in closed form (Lambert's formula, as Arvo's "The Irradiance
// Jacobian for Partially Occluded Polyhedral Sources" (1994) writes it): at a point x with unit normal n, a convex
// polygon of radiance L seen entirely above x's tangent plane delivers
//   E = L · n · Φ,   Φ = ½ Σᵢ Θᵢ Γᵢ,
// where, for the edge from vertex vᵢ to vᵢ₊₁, Θᵢ is the angle it subtends at x and Γᵢ the unit normal of the plane
// through x and the edge (uᵢ × uᵢ₊₁ normalised, uᵢ the unit vector from x to vᵢ). The sign of Φ depends on which way
// round the polygon is listed, so its magnitude is taken.
#pragma once

#include "core/math.h"

#include <algorithm>
#include <cmath>
#include <vector>

namespace raylife::test {

inline double polygonIrradiance(const glm::dvec3& x, const glm::dvec3& n, const std::vector<glm::dvec3>& polygon,
                                double radiance)
{
  glm::dvec3 phi(0);
  for (std::size_t i = 0; i < polygon.size(); ++i) {
    const glm::dvec3 a = glm::normalize(polygon[i] - x), b = glm::normalize(polygon[(i + 1) % polygon.size()] - x);
    const double theta = std::acos(std::clamp(glm::dot(a, b), -1.0, 1.0));
    phi += 0.5 * theta * glm::normalize(glm::cross(a, b));
  }
  return radiance * std::abs(glm::dot(n, phi));
}

} // namespace raylife::test

#include "scene/camera.h"

#include "core/sampling.h"

namespace raylife {

// [makeCameraBasis]
std::variant<CameraBasis, BasisError> makeCameraBasis(const Vec3& eye, const Vec3& focal, const Vec3& up)
{
  if (!isFinite(eye) || !isFinite(focal) || !isFinite(up))
    return BasisError{"eye, focal and up must be finite"};
  const Vec3 view = eye - focal;
  const Real viewLength = glm::length(view);
  if (!(viewLength > 0))
    return BasisError{"eye and focal are the same point, so there is no view direction"};
  const Real upLength = glm::length(up);
  if (!(upLength > 0))
    return BasisError{"the up vector has zero length"};

  // w points from the focal point back to the eye; the camera looks along −w.
  CameraBasis b;
  b.w = view / viewLength;
  // |up × w| = |up| sin θ: too small a sine and u is rounding noise, so refuse rather than guess.
  const Vec3 side = glm::cross(up / upLength, b.w);
  const Real sine = glm::length(side);
  if (!(sine >= kMinUpSine))
    return BasisError{"the up vector is parallel to the view direction (eye - focal)"};
  // Rounding leaves `side` a component along w of a few u, which dividing by a small sine magnifies (in float,
  // to 1e-2 at sine 2e-6: tests/stability/test_camera_up.cpp). One Gram–Schmidt step removes it, so u ⟂ w to
  // rounding whatever the sine.
  const Vec3 across = side - glm::dot(side, b.w) * b.w;
  b.u = across / glm::length(across);
  b.v = glm::cross(b.w, b.u); // unit: w and u are orthonormal
  return b;
}
// [makeCameraBasis]

Camera::Camera(const CameraBasis& basis, const Vec3& eye, Real vfovDeg, int width, int height, Real aperture,
               Real focus)
    : basis_(basis), eye_(eye), width_(width), height_(height), aperture_(aperture), focus_(focus)
{
  halfHeight_ = std::tan(glm::radians(vfovDeg) / 2);
  halfWidth_ = halfHeight_ * Real(width) / Real(height);
}

// [camera_ray]
Vec3 Camera::imagePlaneDirection(Vec2 film) const
{
  // Film position in pixels → image-plane coordinates in [−halfWidth, halfWidth] × [−halfHeight, halfHeight],
  // with y flipped so that row 0 is the top.
  const Real x = (2 * film.x / Real(width_) - 1) * halfWidth_;
  const Real y = (1 - 2 * film.y / Real(height_)) * halfHeight_;
  const Real z = 1;
  return basis_.u * x + basis_.v * y - basis_.w * z;
}

Ray Camera::ray(Vec2 film) const { return Ray{eye_, glm::normalize(imagePlaneDirection(film)), 0, kInfinity}; }
// [camera_ray]

PinholeFrustum Camera::frustum(Vec2 filmMin, Vec2 filmMax) const
{
  // The sides at z = 1 (imagePlaneDirection's x and y of the corners; y runs up as film y runs down). A point
  // eye + q lies in the pyramid when its image-plane coordinates x = q·u / z and y = q·v / z, z = −q·w its depth,
  // lie within them: q·n ≥ 0 for each side's inward normal n, e.g. q·u − left·z = q·(u + left·w) for the left.
  const Real left = (2 * filmMin.x / Real(width_) - 1) * halfWidth_;
  const Real right = (2 * filmMax.x / Real(width_) - 1) * halfWidth_;
  const Real top = (1 - 2 * filmMin.y / Real(height_)) * halfHeight_;
  const Real bottom = (1 - 2 * filmMax.y / Real(height_)) * halfHeight_;
  return PinholeFrustum{eye_,
                        -basis_.w,
                        {glm::normalize(basis_.u + left * basis_.w), glm::normalize(-basis_.u - right * basis_.w),
                         glm::normalize(-basis_.v - top * basis_.w), glm::normalize(basis_.v + bottom * basis_.w)}};
}

// [thin_lens]
Ray Camera::ray(Vec2 film, Vec2 lens) const
{
  if (!(aperture_ > 0))
    return ray(film);
  // The pinhole ray's point on the plane of focus: d's component along −w is 1, so eye + focus·d lies on it.
  const Vec3 d = imagePlaneDirection(film);
  const Vec3 inFocus = eye_ + focus_ * d;
  // A point on the lens (a disk of radius `aperture` around the eye, in the plane of u and v), aimed at it.
  const Vec2 disk = aperture_ * sampleConcentricDisk(lens);
  const Vec3 origin = eye_ + basis_.u * disk.x + basis_.v * disk.y;
  return Ray{origin, glm::normalize(inFocus - origin), 0, kInfinity};
}
// [thin_lens]
std::optional<Vec2> Camera::project(const Vec3& point) const
{
  // The point in the camera frame; the image plane is at z = 1 in front of the eye.
  const Vec3 d = point - eye_;
  const Real z = -glm::dot(d, basis_.w);
  if (!(z > 0))
    return std::nullopt;
  const Real x = glm::dot(d, basis_.u) / z, y = glm::dot(d, basis_.v) / z;
  const Vec2 film((x / halfWidth_ + 1) / 2 * Real(width_), (1 - y / halfHeight_) / 2 * Real(height_));
  if (!(film.x >= 0 && film.x < Real(width_) && film.y >= 0 && film.y < Real(height_)))
    return std::nullopt;
  return film;
}

} // namespace raylife

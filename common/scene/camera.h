/// @file camera.h
/// @brief The camera: the lecture's orthonormal basis and d = u·x + v·y − w·z, through a pinhole or a thin lens.
#pragma once

#include "core/math.h"
#include "geometry/ray.h"

#include <optional>
#include <string>
#include <variant>

namespace raylife {

/// An orthonormal, right-handed camera frame (u × v = w).
struct CameraBasis {
  Vec3 u; ///< Right.
  Vec3 v; ///< Up (in the image).
  Vec3 w; ///< Backwards: from the focal point towards the eye. The camera looks along −w.
};

/// Why a camera basis could not be built (empty when it could).
struct BasisError {
  std::string message; ///< Human-readable fault, e.g. "the up vector is parallel to the view direction".
};

/// Builds the lecture's basis: w = (eye − focal)/|eye − focal|, u = (up × w)/|up × w|, v = w × u.
///
/// @return the basis, or an error when eye == focal, up is zero, up is (within kMinUpSine) parallel to the
///         view direction, or any input is not finite. Never returns a basis with a NaN in it.
std::variant<CameraBasis, BasisError> makeCameraBasis(const Vec3& eye, const Vec3& focal, const Vec3& up);

/// The pyramid of a camera's pinhole rays through a rectangle of the film (Camera::frustum): its apex at the eye,
/// its four sides' unit inward normals. For culling: chapter 16 tests a block of pixels' camera rays against only
/// the spheres the block may see.
struct PinholeFrustum {
  Vec3 eye;       ///< The apex: where every ray starts.
  Vec3 forward;   ///< The view direction, −w: a point ahead of the eye has a positive component along it.
  Vec3 inward[4]; ///< Unit normals of the sides (left, right, top, bottom), pointing into the pyramid.

  /// Whether a ray of the pyramid may meet the sphere (center, radius > 0): false only when the sphere lies wholly
  /// outside a side, or behind the eye, by a margin of kCullMargin (10⁻⁴) of its distance from the eye plus its
  /// radius, far beyond the rounding of Camera::ray and of intersectSphere, in float as in double. So a false is
  /// certain; a true may be a sphere none of the rays meets.
  bool mayMeet(const Vec3& center, Real radius) const
  {
    const Vec3 q = center - eye;
    const Real reach = radius + kCullMargin * (glm::length(q) + radius);
    if (glm::dot(q, forward) < -reach)
      return false;
    for (const Vec3& n : inward)
      if (glm::dot(q, n) < -reach)
        return false;
    return true;
  }
};

/// A camera that maps a position on the image (and, for a thin lens, a point on the lens) to a primary ray.
///
/// Image coordinates: x to the right in [0, width], y downwards in [0, height]; pixel (i, j) covers
/// [i, i+1] × [j, j+1], so its centre is (i + ½, j + ½). Row 0 is the top of the image.
///
/// The thin lens (chapter 11): a lens of radius `aperture` centred on the eye, in the plane spanned by u and v,
/// focused on the plane at distance `focus` in front of the eye (along −w). Every ray through a given image point
/// meets the pinhole ray of that point on the plane of focus, whatever the lens point, so what lies on that plane is
/// sharp and the rest is blurred into a circle of confusion. Aperture 0 is the pinhole.
class Camera {
public:
  /// @param basis   a basis from makeCameraBasis (orthonormal).
  /// @param eye     the centre of projection (the lens's centre), world space.
  /// @param vfovDeg full vertical field of view in degrees, in (0, 180).
  /// @param width,height image size in pixels, ≥ 1.
  /// @param aperture the lens radius in scene units, ≥ 0 (0: a pinhole).
  /// @param focus   the distance from the eye to the plane in focus, along the view direction, > 0.
  Camera(const CameraBasis& basis, const Vec3& eye, Real vfovDeg, int width, int height, Real aperture = 0,
         Real focus = 1);

  /// The pinhole ray through image position `film` (pixels, see the class comment), from the eye.
  /// Its direction is d = u·x + v·y − w·z with z = 1 and (x, y) the position on the image plane, normalised.
  Ray ray(Vec2 film) const;

  /// The ray through image position `film` from lens point `lens` (uniform in [0, 1)², mapped onto the lens by the
  /// concentric disk mapping): from that point on the lens towards where the pinhole ray of `film` meets the plane
  /// of focus. With aperture 0 it is ray(film), bit for bit.
  Ray ray(Vec2 film, Vec2 lens) const;
  /// The pyramid the pinhole rays ray(film) fill for film positions in [filmMin, filmMax] (pixels, min ≤ max).
  PinholeFrustum frustum(Vec2 filmMin, Vec2 filmMax) const;
  /// The image position (pixels, as ray() takes it) whose ray passes through `point` (world space): the inverse of
  /// ray(), for light paths that reach the camera (chapter 13). Nothing when the point lies on or behind the plane of
  /// the eye, or projects outside [0, width) × [0, height).
  std::optional<Vec2> project(const Vec3& point) const;
  /// The distance from the eye (scene units, > 0) of the plane parallel to the image on which one pixel has an area of
  /// exactly 1: height / (2 tan(vfov/2)). A pixel's sample is uniform on its square there, so the density of a
  /// primary ray of direction d is that distance² / cos³θ per steradian (θ between d and the view direction).
  Real unitPixelDistance() const { return Real(height_) / (2 * halfHeight_); }

  /// The camera frame.
  const CameraBasis& basis() const { return basis_; }
  /// The centre of projection.
  const Vec3& eye() const { return eye_; }
  /// Half the image plane's width at distance 1 from the eye, tan(hfov/2) (ray() maps the film onto it).
  Real halfWidth() const { return halfWidth_; }
  /// Half the image plane's height at distance 1 from the eye, tan(vfov/2).
  Real halfHeight() const { return halfHeight_; }
  /// Image width in pixels.
  int width() const { return width_; }
  /// Image height in pixels.
  int height() const { return height_; }
  /// The lens radius in scene units (0: a pinhole).
  Real aperture() const { return aperture_; }
  /// The distance from the eye to the plane in focus, along −w.
  Real focus() const { return focus_; }

private:
  CameraBasis basis_;
  Vec3 eye_;
  Real halfHeight_; // tan(vfov / 2): half the image plane's height at z = 1
  Real halfWidth_;  // halfHeight_ · width / height
  int width_;
  int height_;
  Real aperture_; // lens radius
  Real focus_;    // distance to the plane in focus

  // The unnormalised direction u·x + v·y − w of image position `film`: its component along −w is 1.
  Vec3 imagePlaneDirection(Vec2 film) const;
};

} // namespace raylife

// stability_images: renders the pictures of docs/robustness.md, each failure beside its cure, in float (where the
// failures are large enough to see) with the scalar-templated routines of common/geometry/sphere.h.
//
//   stability_images OUTPUT_DIR
//
// writes acne_no_offset.png, acne_fixed_tmin.png, acne_cured.png (scenes/spheres.json, chapter 4's shading) and
// far_sphere_naive.png, far_sphere_robust.png (scenes/stress/far_small_sphere.json, chapter 2's normals).
// Not a test: the stability tests assert the same failures and cures by counting them.
#include "render/image_io.h"
#include "render/runner.h"
#include "scene/scene.h"
#include "support.h"

#include <cstdio>
#include <exception>
#include <string>

using namespace raylife;
using namespace raylife::stability;

namespace {

using F = float;
using V = TVec3<F>;

enum class Intersector { Naive, Robust };
enum class Spawn { NoOffset, FixedTmin, ErrorBound };

/// The fixed t_min of the "fixed epsilon" picture: a value that looks safe at the scene's scale of 1.
constexpr F kPictureTmin = F(1e-5);

struct FloatHit {
  int sphere = -1;
  F t = 0;
};

FloatHit nearest(const Scene& scene, const V& o, const V& d, F tmin, Intersector how)
{
  FloatHit best;
  F tmax = std::numeric_limits<F>::infinity();
  for (std::size_t i = 0; i < scene.spheres.size(); ++i) {
    const V c(scene.spheres[i].center);
    const F r = F(scene.spheres[i].radius);
    const auto t = how == Intersector::Naive ? naiveIntersectSphere(o, d, c, r, tmin, tmax)
                                             : intersectSphere(o, d, c, r, tmin, tmax);
    if (t) {
      tmax = *t;
      best = {int(i), *t};
    }
  }
  return best;
}

/// Renders `scene` in float: chapter 2's normal colours (`shade` false) or chapter 4's Lambert with shadows.
Image renderFloat(const Scene& scene, bool shade, Intersector how, Spawn spawn)
{
  const Camera camera = scene.makeCamera();
  Image image(camera.width(), camera.height());
  for (int y = 0; y < image.height; ++y)
    for (int x = 0; x < image.width; ++x) {
      const Ray primary = camera.ray(Vec2(Real(x) + Real(0.5), Real(y) + Real(0.5)));
      const V o(primary.origin), d = glm::normalize(V(primary.direction));
      const FloatHit hit = nearest(scene, o, d, 0, how);
      glm::dvec3 colour(scene.background);
      if (hit.sphere >= 0) {
        const Sphere& s = scene.spheres[std::size_t(hit.sphere)];
        const V c(s.center);
        const F r = F(s.radius);
        const SurfacePoint<F> sp = sphereSurfacePoint(o, d, hit.t, c, r);
        const V n = glm::dot(sp.normal, d) < 0 ? sp.normal : -sp.normal;
        if (!shade) {
          colour = (glm::dvec3(sp.normal) + 1.0) / 2.0;
        } else {
          const glm::dvec3 C(scene.materials[std::size_t(s.material)].color);
          colour = glm::dvec3(scene.ambient) * C;
          for (const PointLight& light : scene.lights) {
            const V p = spawn == Spawn::ErrorBound ? sp.point : o + hit.t * d;
            const V toLight = V(light.position) - p;
            const F distance = glm::length(toLight);
            const V L = toLight / distance;
            const F cosine = glm::dot(L, n);
            if (!(cosine > 0))
              continue;
            FloatHit blocker;
            if (spawn == Spawn::ErrorBound) {
              const V origin = offsetRayOrigin(sp.point, sp.error, sp.normal, L);
              blocker = nearest(scene, origin, L, 0, how);
              if (blocker.t >= glm::length(V(light.position) - origin))
                blocker.sphere = -1;
            } else {
              blocker = nearest(scene, p, L, spawn == Spawn::FixedTmin ? kPictureTmin : F(0), how);
              if (blocker.t >= distance)
                blocker.sphere = -1;
            }
            if (blocker.sphere < 0)
              colour += double(cosine) * C * glm::dvec3(light.intensity) / double(distance * distance);
          }
        }
      }
      for (int ch = 0; ch < 3; ++ch)
        image.at(x, y, ch) = float(colour[ch]);
    }
  return image;
}

} // namespace

int main(int argc, char** argv)
{
  if (argc != 2) {
    std::fprintf(stderr, "usage: stability_images OUTPUT_DIR\n");
    return 2;
  }
  try {
    const std::string out = argv[1];
    Scene spheres = loadScene(sceneDirectory() + "/spheres.json");
    spheres.camera.width = 200;
    spheres.camera.height = 150;
    writeImage(renderFloat(spheres, true, Intersector::Robust, Spawn::NoOffset), out + "/acne_no_offset.png");
    writeImage(renderFloat(spheres, true, Intersector::Robust, Spawn::FixedTmin), out + "/acne_fixed_tmin.png");
    writeImage(renderFloat(spheres, true, Intersector::Robust, Spawn::ErrorBound), out + "/acne_cured.png");
    Scene far = loadScene(sceneDirectory() + "/stress/far_small_sphere.json");
    far.camera.width = 160;
    far.camera.height = 120;
    far.camera.vfovDeg *= 4; // a wider view, so that the naive hits show around the sphere
    writeImage(renderFloat(far, false, Intersector::Naive, Spawn::ErrorBound), out + "/far_sphere_naive.png");
    writeImage(renderFloat(far, false, Intersector::Robust, Spawn::ErrorBound), out + "/far_sphere_robust.png");
    std::printf("wrote 5 images into %s\n", out.c_str());
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "stability_images: %s\n", e.what());
    return 1;
  }
}

#include "scene/scene.h"

namespace raylife {

namespace {
thread_local std::uint64_t tRayCount = 0;
}

std::uint64_t rayCount() { return tRayCount; }

namespace {
// The hit record of sphere `index` at parameter t, on the re-projected surface point with its error bound. Filled in
// place in the optional that intersect returns: built as a Hit and then moved in, its 88 bytes were copied once
// more on every ray (GCC kept the copy; 11 instructions a ray in chapter 6).
std::optional<Hit> makeHit(const std::vector<Sphere>& spheres, const Ray& ray, Real t, int index)
{
  const Sphere& s = spheres[std::size_t(index)];
  const SurfacePoint<Real> sp = sphereSurfacePoint(ray.origin, ray.direction, t, s.center, s.radius);
  std::optional<Hit> hit(std::in_place);
  hit->t = t;
  hit->point = sp.point;
  hit->normal = sp.normal;
  hit->pointError = sp.error;
  hit->sphere = index;
  hit->material = s.material;
  return hit;
}
} // namespace

void Scene::buildAccelerator()
{
  const bool tree = spheres.size() > kFlatListMaxSpheres;
  accelerator = tree ? Bvh(spheres) : Bvh();
  const bool fourAtOnce = !tree && spheres.size() >= kLanesMinSpheres && laneTestAvailable(LaneTest::FourAtOnce);
  lanes = fourAtOnce ? SphereLanes(spheres, LaneTest::FourAtOnce) : SphereLanes();
}

bool Scene::usesAccelerator() const
{
  return accelerator.primitiveCount() > 0 && accelerator.primitiveCount() == spheres.size();
}

bool Scene::usesLanes() const
{
  return !usesAccelerator() && lanes.size() > 0 && lanes.size() == spheres.size();
}

// [intersect]
// The hot path of every chapter: flatten inlines the sphere test into the loop (about 16% fewer instructions).
// The nearest sphere is found one of three ways, all with the same answer; then one hit record is made (one copy
// of makeHit keeps the function small enough for the chapters to inline it: 4% fewer instructions in chapter 6).
[[gnu::flatten]] std::optional<Hit> Scene::intersect(const Ray& ray) const
{
  ++tRayCount;
  Real tNearest = ray.tmax;
  int nearest = -1;
  if (usesAccelerator()) { // the same answer as the loop below, found through the BVH
    if (const std::optional<BvhHit> h = accelerator.intersect(ray)) {
      tNearest = h->t;
      nearest = h->primitive;
    }
  } else if (usesLanes()) { // the same answer again, four spheres at a time
    if (const std::optional<SphereHit> h = lanes.intersect(ray)) {
      tNearest = h->t;
      nearest = h->sphere;
    }
  } else {
    // Find the nearest sphere: each hit shrinks the interval, so later spheres must be nearer to count.
    for (std::size_t i = 0; i < spheres.size(); ++i) {
      const Sphere& s = spheres[i];
      if (auto t = intersectSphere(ray.origin, ray.direction, s.center, s.radius, ray.tmin, tNearest)) {
        tNearest = *t;
        nearest = int(i);
      }
    }
  }
  if (nearest < 0)
    return std::nullopt;

  return makeHit(spheres, ray, tNearest, nearest);
}
// [intersect]

// [occluded]
[[gnu::flatten]] bool Scene::occluded(const Ray& ray) const
{
  ++tRayCount;
  if (usesAccelerator())
    return accelerator.occluded(ray);
  if (usesLanes())
    return lanes.occluded(ray);
  for (const Sphere& s : spheres)
    if (intersectSphere(ray.origin, ray.direction, s.center, s.radius, ray.tmin, ray.tmax))
      return true;
  return false;
}
// [occluded]

TracedHit Scene::intersectWithWork(const Ray& ray) const
{
  if (usesAccelerator()) {
    ++tRayCount;
    const BvhTracedHit h = accelerator.intersectWithWork(ray);
    return TracedHit{h.hit ? makeHit(spheres, ray, h.hit->t, h.hit->primitive) : std::nullopt, h.work};
  }
  // One by one: every sphere is tested.
  return TracedHit{intersect(ray), BvhWork{0, std::uint32_t(spheres.size())}};
}

TracedOcclusion Scene::occludedWithWork(const Ray& ray) const
{
  ++tRayCount;
  if (usesAccelerator()) {
    const BvhTracedOcclusion o = accelerator.occludedWithWork(ray);
    return TracedOcclusion{o.occluded, o.work};
  }
  // One by one, up to the first blocker.
  std::uint32_t tested = 0;
  for (const Sphere& s : spheres) {
    ++tested;
    if (intersectSphere(ray.origin, ray.direction, s.center, s.radius, ray.tmin, ray.tmax))
      return TracedOcclusion{true, BvhWork{0, tested}};
  }
  return TracedOcclusion{false, BvhWork{0, tested}};
}

Camera Scene::makeCamera(int width, int height) const
{
  return Camera(camera.basis, camera.eye, camera.vfovDeg, width > 0 ? width : camera.width,
                height > 0 ? height : camera.height);
}

} // namespace raylife

#include "scene/scene.h"

#include "geometry/triangle.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace raylife {

namespace {
thread_local std::uint64_t tRayCount = 0;
}

std::uint64_t rayCount() { return tRayCount; }

void countRays(std::uint64_t n) { tRayCount += n; }

namespace {
// The hit record of sphere `index` at parameter t, on the re-projected surface point with its error bound. Filled in
// place in the optional that intersect returns: built as a Hit and then moved in, its bytes were copied once more on
// every ray (GCC kept the copy; 11 instructions a ray in chapter 6).
std::optional<Hit> makeSphereHit(const std::vector<Sphere>& spheres, const Ray& ray, Real t, int index)
{
  const Sphere& s = spheres[std::size_t(index)];
  const SurfacePoint<Real> sp = sphereSurfacePoint(ray.origin, ray.direction, t, s.centerAt(ray.time), s.radius);
  std::optional<Hit> hit(std::in_place);
  hit->t = t;
  hit->point = sp.point;
  hit->normal = sp.normal;
  hit->geometricNormal = sp.normal;
  hit->pointError = sp.error;
  hit->primitive = index;
  hit->material = s.material;
  hit->time = ray.time;
  return hit;
}

// [triangleHit]
// A smooth mesh's normal: its vertex normals interpolated at the hit, turned to the front side.
Vec3 shadingNormal(const Scene& scene, std::size_t triangle, Real b0, Real b1, Real b2, const Vec3& geometricNormal)
{
  const Triangle& tri = scene.triangles[triangle];
  if (!scene.meshes[tri.mesh].smooth)
    return geometricNormal;
  const Vec3 n = b0 * scene.vertexNormals[tri.v[0]] + b1 * scene.vertexNormals[tri.v[1]] +
                 b2 * scene.vertexNormals[tri.v[2]];
  const Vec3 shading = safeNormalize(n, geometricNormal);
  return glm::dot(shading, geometricNormal) < 0 ? -shading : shading;
}

// The hit record of triangle `triangle` (an index into scene.triangles), which the ray hits at parameter t: the
// test is made again for the barycentrics (the search kept only t), the point comes from them with its error bound,
// and so does a smooth mesh's normal. (Out of line, so that Scene::intersect stays small enough to be inlined into the
// chapters.)
[[gnu::noinline]] std::optional<Hit> makeTriangleHit(const Scene& scene, const Ray& ray, Real t, std::size_t triangle)
{
  const Triangle& tri = scene.triangles[triangle];
  const auto [p0, p1, p2] = scene.triangleVertices(triangle);
  const std::optional<TriangleHit<Real>> h =
      intersectTriangle(ray.origin, ray.direction, p0, p1, p2, ray.tmin, ray.tmax);
  // (The same test on the same ray gives the same t, so h exists; an empty record only if that ever failed.)
  const TriangleHit<Real> b = h ? *h : TriangleHit<Real>{t, Real(1) / 3, Real(1) / 3, Real(1) / 3};
  const TrianglePoint<Real> tp = trianglePoint(p0, p1, p2, b.b0, b.b1, b.b2);
  std::optional<Hit> hit(std::in_place);
  hit->t = t;
  hit->point = tp.point;
  hit->geometricNormal = triangleNormal(p0, p1, p2);
  hit->normal = shadingNormal(scene, triangle, b.b0, b.b1, b.b2, hit->geometricNormal);
  hit->pointError = tp.error;
  hit->primitive = int(scene.spheres.size() + triangle);
  hit->material = tri.material;
  hit->time = ray.time;
  return hit;
}
// [triangleHit]

// The nearest primitive found so far: its parameter t along the ray, and its number (−1: none).
struct Nearest {
  Real t;
  int primitive;
};

// The hit record of primitive `index`, hit at t.
std::optional<Hit> makeHit(const Scene& scene, const Ray& ray, Real t, int index)
{
  if (std::size_t(index) < scene.spheres.size())
    return makeSphereHit(scene.spheres, ray, t, index);
  return makeTriangleHit(scene, ray, t, std::size_t(index) - scene.spheres.size());
}
} // namespace

void Scene::buildAccelerator()
{
  const bool tree = primitiveCount() > kFlatListMaxPrimitives;
  accelerator = tree ? Bvh(spheres, vertices, triangles) : Bvh();
  // (The lanes hold still spheres only: a scene with motion loops over its spheres at the ray's time.)
  const bool fourAtOnce = !tree && spheres.size() >= kLanesMinSpheres &&
                          laneTestAvailable(LaneTest::FourAtOnce) && !hasMotion();
  lanes = fourAtOnce ? SphereLanes(spheres, LaneTest::FourAtOnce) : SphereLanes();
}

bool Scene::hasMotion() const
{
  return std::any_of(spheres.begin(), spheres.end(), [](const Sphere& s) { return s.moving(); });
}

bool Scene::usesAccelerator() const
{
  return accelerator.primitiveCount() > 0 && accelerator.primitiveCount() == primitiveCount();
}

bool Scene::usesLanes() const
{
  return !usesAccelerator() && lanes.size() > 0 && lanes.size() == spheres.size();
}

// [intersect]
// The nearest primitive of a scene without a tree, by loops (flatten: the sphere and triangle tests inlined into
// them, about 16% fewer instructions). Its own function, out of line, as is a triangle's hit record: the tree's way
// and a sphere's record are what most rays take, and with the loops inlined intersect grew too large for the
// chapters to inline it.
[[gnu::flatten, gnu::noinline]] static Nearest nearestByLoop(const Scene& scene, const Ray& ray)
{
  Nearest nearest{ray.tmax, -1};
  if (scene.usesLanes()) { // the same answer as the loop below, four spheres at a time
    if (const std::optional<SphereHit> h = scene.lanes.intersect(ray))
      nearest = Nearest{h->t, h->sphere};
  } else {
    // Find the nearest sphere: each hit shrinks the interval, so later spheres must be nearer to count.
    for (std::size_t i = 0; i < scene.spheres.size(); ++i) {
      const Sphere& s = scene.spheres[i];
      const Vec3 center = s.centerAt(ray.time);
      if (auto t = intersectSphere(ray.origin, ray.direction, center, s.radius, ray.tmin, nearest.t))
        nearest = Nearest{*t, int(i)};
    }
  }
  // Then the triangles, numbered after the spheres, in the same way.
  for (std::size_t j = 0; j < scene.triangles.size(); ++j) {
    const auto [p0, p1, p2] = scene.triangleVertices(j);
    if (auto h = intersectTriangle(ray.origin, ray.direction, p0, p1, p2, ray.tmin, nearest.t))
      nearest = Nearest{h->t, int(scene.spheres.size() + j)};
  }
  return nearest;
}

// The hot path of every chapter. The nearest primitive is found one of three ways, all with the same answer: the
// tree, four spheres at a time, or the loop; then one hit record is made.
std::optional<Hit> Scene::intersect(const Ray& ray) const
{
  ++tRayCount;
  Nearest nearest{ray.tmax, -1};
  if (usesAccelerator()) { // the same answer as the loops, found through the BVH
    if (const std::optional<BvhHit> h = accelerator.intersect(ray))
      nearest = Nearest{h->t, h->primitive};
  } else {
    nearest = nearestByLoop(*this, ray);
  }
  if (nearest.primitive < 0)
    return std::nullopt;

  return makeHit(*this, ray, nearest.t, nearest.primitive);
}
// [intersect]

Vec3 Scene::triangleShadingNormal(std::size_t triangle, Real b0, Real b1, Real b2, const Vec3& geometricNormal) const
{
  return shadingNormal(*this, triangle, b0, b1, b2, geometricNormal);
}

Hit Scene::hitAt(const Ray& ray, Real t, int primitive) const { return *makeHit(*this, ray, t, primitive); }

// [occluded]
[[gnu::flatten]] bool Scene::occluded(const Ray& ray) const
{
  ++tRayCount;
  if (usesAccelerator())
    return accelerator.occluded(ray);
  if (usesLanes()) {
    if (lanes.occluded(ray))
      return true;
  } else {
    for (const Sphere& s : spheres)
      if (intersectSphere(ray.origin, ray.direction, s.centerAt(ray.time), s.radius, ray.tmin, ray.tmax))
        return true;
  }
  for (std::size_t j = 0; j < triangles.size(); ++j) {
    const auto [p0, p1, p2] = triangleVertices(j);
    if (intersectTriangle(ray.origin, ray.direction, p0, p1, p2, ray.tmin, ray.tmax))
      return true;
  }
  return false;
}
// [occluded]

std::optional<Real> Scene::intersectPrimitive(const Ray& ray, int primitive) const
{
  if (std::size_t(primitive) < spheres.size()) {
    const Sphere& s = spheres[std::size_t(primitive)];
    return intersectSphere(ray.origin, ray.direction, s.centerAt(ray.time), s.radius, ray.tmin, ray.tmax);
  }
  const auto [p0, p1, p2] = triangleVertices(std::size_t(primitive) - spheres.size());
  if (const auto h = intersectTriangle(ray.origin, ray.direction, p0, p1, p2, ray.tmin, ray.tmax))
    return h->t;
  return std::nullopt;
}

int Scene::materialOf(int primitive) const
{
  if (std::size_t(primitive) < spheres.size())
    return spheres[std::size_t(primitive)].material;
  return triangles[std::size_t(primitive) - spheres.size()].material;
}

TracedHit Scene::intersectWithWork(const Ray& ray) const
{
  if (usesAccelerator()) {
    ++tRayCount;
    const BvhTracedHit h = accelerator.intersectWithWork(ray);
    return TracedHit{h.hit ? makeHit(*this, ray, h.hit->t, h.hit->primitive) : std::nullopt, h.work};
  }
  // One by one: every primitive is tested.
  return TracedHit{intersect(ray), BvhWork{0, std::uint32_t(primitiveCount())}};
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
  for (std::size_t i = 0; i < primitiveCount(); ++i) {
    ++tested;
    if (intersectPrimitive(ray, int(i)))
      return TracedOcclusion{true, BvhWork{0, tested}};
  }
  return TracedOcclusion{false, BvhWork{0, tested}};
}

Camera Scene::makeCamera(int width, int height) const
{
  const Real focus = camera.focus > 0 ? camera.focus : glm::length(camera.focal - camera.eye);
  return Camera(camera.basis, camera.eye, camera.vfovDeg, width > 0 ? width : camera.width,
                height > 0 ? height : camera.height, camera.aperture, focus);
}

} // namespace raylife

namespace raylife {

// [textureLookup]
TextureLookup Scene::textureLookup(int primitive, const Vec3& point, Real time, Real footprint) const
{
  if (std::size_t(primitive) < spheres.size()) {
    // A sphere: (u, v) of its outward normal (sphereUv, not the sky's directionToUv: it is seen from outside), the
    // texture turned about +y: what the unturned texture shows at n0 appears at R(rotate)·n0, as for the sky.
    const Sphere& s = spheres[std::size_t(primitive)];
    Vec3 n = glm::normalize(point - s.centerAt(time));
    if (!sphereUvRotation.empty()) {
      const SinCos<Real> r = sphereUvRotation[std::size_t(primitive)];
      n = rotateAboutY(n, SinCos<Real>{-r.sin, r.cos});
    }
    return TextureLookup{sphereUv(n), footprint, true};
  }
  // A triangle: the barycentrics of the point, then its vertices' uvs interpolated (or the barycentrics themselves).
  const std::size_t j = std::size_t(primitive) - spheres.size();
  const Triangle& tri = triangles[j];
  const auto [p0, p1, p2] = triangleVertices(j);
  const Vec3 e1 = p1 - p0, e2 = p2 - p0, d = point - p0;
  const Real d11 = glm::dot(e1, e1), d12 = glm::dot(e1, e2), d22 = glm::dot(e2, e2);
  const Real dp1 = glm::dot(d, e1), dp2 = glm::dot(d, e2);
  const Real denominator = d11 * d22 - d12 * d12;
  const Real b1 = denominator > 0 ? (d22 * dp1 - d12 * dp2) / denominator : 0;
  const Real b2 = denominator > 0 ? (d11 * dp2 - d12 * dp1) / denominator : 0;
  const Real b0 = 1 - b1 - b2;
  Vec2 uv(b1, b2);
  if (meshes[tri.mesh].hasUvs)
    uv = b0 * vertexUvs[tri.v[0]] + b1 * vertexUvs[tri.v[1]] + b2 * vertexUvs[tri.v[2]];
  return TextureLookup{Vec2(uv.x, 1 - uv.y), footprint, false};
}
// [textureLookup]

Real Scene::textureScale(int primitive, const Vec3& point, Real time) const
{
  if (std::size_t(primitive) < spheres.size()) {
    const Sphere& s = spheres[std::size_t(primitive)];
    const Vec3 n = glm::normalize(point - s.centerAt(time));
    const Real sinTheta = std::max(std::sqrt(std::max(Real(0), 1 - n.y * n.y)), Real(1e-3));
    return 1 / (2 * kPi * s.radius * sinTheta);
  }
  const std::size_t j = std::size_t(primitive) - spheres.size();
  const Triangle& tri = triangles[j];
  const auto [p0, p1, p2] = triangleVertices(j);
  const Real area = glm::length(glm::cross(p1 - p0, p2 - p0));
  Real uvArea = 1; // the barycentrics' own triangle, (0, 0), (1, 0), (0, 1), doubled
  if (meshes[tri.mesh].hasUvs) {
    const Vec2 a = vertexUvs[tri.v[1]] - vertexUvs[tri.v[0]], b = vertexUvs[tri.v[2]] - vertexUvs[tri.v[0]];
    uvArea = std::abs(a.x * b.y - a.y * b.x);
  }
  return area > 0 ? std::sqrt(uvArea / area) : 0;
}

std::string beyondSceneExtent(const Scene& scene, double bound)
{
  auto show = [](const Vec3& p) {
    char text[96];
    std::snprintf(text, sizeof text, "(%.6g, %.6g, %.6g)", double(p.x), double(p.y), double(p.z));
    return std::string(text);
  };
  if (!withinSceneExtent(scene.camera.eye, bound))
    return "the camera's eye, " + show(scene.camera.eye);
  if (!withinSceneExtent(scene.camera.focal, bound))
    return "the camera's focal point, " + show(scene.camera.focal);
  for (std::size_t i = 0; i < scene.spheres.size(); ++i) {
    const Sphere& s = scene.spheres[i];
    if (!withinSceneExtent(s.center, bound))
      return "sphere " + std::to_string(i) + "'s centre, " + show(s.center);
    if (!withinSceneExtent(s.radius, bound)) {
      char radius[32];
      std::snprintf(radius, sizeof radius, "%.6g", double(s.radius));
      return "sphere " + std::to_string(i) + "'s radius, " + radius;
    }
  }
  for (std::size_t i = 0; i < scene.vertices.size(); ++i)
    if (!withinSceneExtent(scene.vertices[i], bound))
      return "mesh vertex " + std::to_string(i) + ", " + show(scene.vertices[i]);
  for (std::size_t i = 0; i < scene.lights.size(); ++i)
    if (!withinSceneExtent(scene.lights[i].position, bound))
      return "point light " + std::to_string(i) + "'s position, " + show(scene.lights[i].position);
  return {};
}

std::string belowSceneLength(const Scene& scene, double smallest)
{
  auto show = [](double v) {
    char text[32];
    std::snprintf(text, sizeof text, "%.6g", v);
    return std::string(text);
  };
  const double distance = double(glm::length(scene.camera.eye - scene.camera.focal));
  if (distance < smallest)
    return "the distance from the camera's eye to its focal point, " + show(distance);
  for (std::size_t i = 0; i < scene.spheres.size(); ++i)
    if (double(scene.spheres[i].radius) < smallest)
      return "sphere " + std::to_string(i) + "'s radius, " + show(double(scene.spheres[i].radius));
  for (std::size_t i = 0; i < scene.triangles.size(); ++i) {
    const auto [p0, p1, p2] = scene.triangleVertices(i);
    const double size = std::sqrt(double(triangleDoubleArea(p0, p1, p2)));
    if (size < smallest)
      return "triangle " + std::to_string(i) + "'s size (the square root of twice its area), " + show(size);
  }
  return {};
}

} // namespace raylife

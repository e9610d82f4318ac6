// Chapter 11's shared pieces: the thin lens (Camera::ray(film, lens)) and motion (Ray::time, moving spheres in the
// flat list and in the BVH), checked in the library itself and through the render loop.
#include "../bvh/random_scenes.h"

#include "core/sampling.h"
#include "render/render_loop.h"
#include "scene/scene.h"

#include <catch2/catch.hpp>

#include <cmath>
#include <cstring>
#include <iostream>
#include <type_traits>

using namespace raylife;
using raylife::testing::Random;

namespace {

// How close the geometry below must come: 1e-9 in double; in the float build (about seven digits, on numbers up to
// some 10 here), 1e-4.
constexpr double kClose = std::is_same_v<Real, float> ? 1e-4 : 1e-9;

bool sameBits(const Ray& a, const Ray& b)
{
  return std::memcmp(&a.origin, &b.origin, sizeof a.origin) == 0 &&
         std::memcmp(&a.direction, &b.direction, sizeof a.direction) == 0 && a.tmin == b.tmin && a.tmax == b.tmax;
}

Camera testCamera(Real aperture, Real focus, int width = 64, int height = 48)
{
  const Vec3 eye(1, 2, 10), focal(0, 0, 0);
  const CameraBasis basis = std::get<CameraBasis>(makeCameraBasis(eye, focal, Vec3(0, 1, 0)));
  return Camera(basis, eye, 40, width, height, aperture, focus);
}

// A scene of emitters on black, whose trace is the emission of the first hit: what the camera sees, unshaded.
Scene emitterScene(const std::vector<Sphere>& spheres, const Vec3& eye, const Vec3& focal, Real aperture, Real focus)
{
  Scene scene;
  Material lamp;
  lamp.color = Color(0);
  lamp.emission = Color(1);
  scene.materials = {lamp};
  scene.spheres = spheres;
  scene.camera.eye = eye;
  scene.camera.focal = focal;
  scene.camera.vfovDeg = 40;
  scene.camera.aperture = aperture;
  scene.camera.focus = focus;
  scene.camera.basis = std::get<CameraBasis>(makeCameraBasis(eye, focal, Vec3(0, 1, 0)));
  scene.buildAccelerator();
  return scene;
}

Color emission(const Scene& scene, const Ray& ray, Sampler&, int)
{
  const std::optional<Hit> hit = scene.intersect(ray);
  return hit ? scene.materials[std::size_t(hit->material)].emission : Color(0);
}

RenderResult renderWith(const Scene& scene, const Camera& camera, int spp, std::uint64_t seed, bool lens, bool motion)
{
  RenderSettings settings;
  settings.spp = spp;
  settings.seed = seed;
  settings.threads = 2;
  settings.pixelSampling = PixelSampling::Jittered;
  settings.lens = lens;
  settings.motion = motion;
  return render(scene, camera, settings, emission);
}

double channelSum(const Image& image, int c = 0)
{
  double sum = 0;
  for (int y = 0; y < image.height; ++y)
    for (int x = 0; x < image.width; ++x)
      sum += image.at(x, y, c);
  return sum;
}

} // namespace

// ---- The thin lens -------------------------------------------------------------------------------------------

TEST_CASE("thin lens: aperture 0 gives the pinhole ray, bit for bit, whatever the lens sample")
{
  const Camera pinhole = testCamera(0, 7);
  Random random(1);
  for (int i = 0; i < 10000; ++i) {
    // One draw a statement, in the order GCC made them when two were the arguments of one call: each point's y first.
    // (C++ leaves the order of a call's arguments unspecified, and clang makes the other choice; see random_scenes.h.)
    const Real filmY = random.uniform(0, 48);
    const Real filmX = random.uniform(0, 64);
    const Real lensY = random.uniform();
    const Real lensX = random.uniform();
    const Vec2 film(filmX, filmY), lens(lensX, lensY);
    REQUIRE(sameBits(pinhole.ray(film, lens), pinhole.ray(film)));
  }
}

TEST_CASE("thin lens: every lens sample of an image point meets the pinhole ray on the plane of focus")
{
  for (Real focus : {Real(2), Real(10.3), Real(50)}) {
    const Camera camera = testCamera(Real(0.8), focus);
    const Vec3 forward = -camera.basis().w;
    Random random(2);
    double worst = 0;
    for (int i = 0; i < 20000; ++i) {
      const Real filmY = random.uniform(0, 48); // one draw a statement, as in the test above
      const Real filmX = random.uniform(0, 64);
      const Real lensY = random.uniform();
      const Real lensX = random.uniform();
      const Vec2 film(filmX, filmY), lens(lensX, lensY);
      const Ray pin = camera.ray(film), thin = camera.ray(film, lens);
      // The lens point lies in the lens plane, within the aperture.
      REQUIRE(std::abs(glm::dot(thin.origin - camera.eye(), forward)) < kClose);
      REQUIRE(glm::length(thin.origin - camera.eye()) <= Real(0.8) * (1 + kClose));
      REQUIRE(std::abs(glm::length(thin.direction) - 1) < kClose);
      // Both rays on the plane of focus (distance `focus` along the view direction).
      const Vec3 a = pin.at(focus / glm::dot(pin.direction, forward));
      const Vec3 b = thin.at(glm::dot(camera.eye() + focus * forward - thin.origin, forward) /
                             glm::dot(thin.direction, forward));
      worst = std::max(worst, double(glm::length(a - b)));
    }
    INFO("focus " << focus << ": farthest meeting " << worst);
    CHECK(worst < kClose * focus);
  }
}

TEST_CASE("thin lens: the concentric disk mapping is uniform on the disk (equal counts in equal areas)")
{
  // 16 rings × 16 sectors of equal area; chi-square with 255 degrees of freedom.
  constexpr int kRings = 16, kSectors = 16, kN = 256000;
  std::vector<int> count(kRings * kSectors, 0);
  Sampler rng(5, 0, 0, 0);
  for (int i = 0; i < kN; ++i) {
    const Vec2 p = sampleConcentricDisk(rng.next2D());
    const double r2 = double(glm::dot(p, p));
    REQUIRE(r2 <= 1 + 1e-12);
    double phi = std::atan2(double(p.y), double(p.x));
    if (phi < 0)
      phi += 2 * kPi;
    const int ring = std::min(kRings - 1, int(r2 * kRings));
    const int sector = std::min(kSectors - 1, int(phi / (2 * kPi) * kSectors));
    ++count[std::size_t(ring * kSectors + sector)];
  }
  const double expected = double(kN) / (kRings * kSectors);
  double chi2 = 0;
  for (int c : count)
    chi2 += (c - expected) * (c - expected) / expected;
  INFO("chi2 = " << chi2 << " (255 degrees of freedom; 1% critical value 310.5)");
  CHECK(chi2 < 310.5);
}

TEST_CASE("thin lens: a small bright sphere off the plane of focus blurs into the thin-lens formula's circle")
{
  // A sphere of radius r at distance z in front of the eye, focus f, lens radius A: its image is a disk of radius
  // A·|1/z − 1/f| on the image plane at unit distance, in pixels times H / (2 tan(vfov/2)). The disk is uniform
  // (the lens is sampled uniformly), so its radius is √(2⟨ρ²⟩) with ⟨ρ²⟩ the mean squared distance of the image's
  // light from its centre; the pixels' own width adds 1/6 pixel² to ⟨ρ²⟩, the sphere's own image (r/z) about
  // (r/z)²/2 in the same units.
  const int width = 96, height = 96;
  const Real vfov = 40, z = 10, r = Real(0.02);
  const Real pixelsPerUnit = Real(height) / (2 * std::tan(glm::radians(vfov) / 2));
  for (const auto& [aperture, focus] : {std::pair{Real(0.2), Real(5)}, std::pair{Real(0.3), Real(20)},
                                      std::pair{Real(0.5), Real(8)}}) {
    const Vec3 eye(0, 0, 0), focal(0, 0, -1);
    Scene scene = emitterScene({Sphere{Vec3(0, 0, -z), r, 0}}, eye, focal, aperture, focus);
    scene.camera.vfovDeg = vfov;
    const Camera camera = scene.makeCamera(width, height);
    const Image image = renderWith(scene, camera, 256, 11, true, false).film.mean();
    double sum = 0, sx = 0, sy = 0;
    for (int y = 0; y < height; ++y)
      for (int x = 0; x < width; ++x) {
        const double v = image.at(x, y, 0);
        sum += v;
        sx += v * (x + 0.5);
        sy += v * (y + 0.5);
      }
    REQUIRE(sum > 0);
    const double cx = sx / sum, cy = sy / sum;
    double rho2 = 0;
    for (int y = 0; y < height; ++y)
      for (int x = 0; x < width; ++x)
        rho2 += image.at(x, y, 0) * ((x + 0.5 - cx) * (x + 0.5 - cx) + (y + 0.5 - cy) * (y + 0.5 - cy));
    rho2 /= sum;
    const double own = double(r / z * pixelsPerUnit);
    const double measured = std::sqrt(2 * std::max(0.0, rho2 - 1.0 / 6 - own * own / 2));
    const double formula = double(aperture * std::abs(1 / z - 1 / focus) * pixelsPerUnit);
    std::cout << "circle of confusion, aperture " << aperture << ", focus " << focus << ": diameter " << 2 * measured
              << " pixels, thin-lens formula " << 2 * formula << "\n";
    CHECK(std::abs(2 * measured - 2 * formula) < 1);
    CHECK(std::abs(cx - width / 2.0) < 0.5);
    CHECK(std::abs(cy - height / 2.0) < 0.5);
  }
}

TEST_CASE("thin lens: defocus moves light but keeps its mean, on a small sphere and on a uniform field")
{
  // A small emitter: the image's total is its solid angle in pixels, with or without a lens (z-test of the sums).
  const Vec3 eye(0, 0, 0), focal(0, 0, -1);
  Scene scene = emitterScene({Sphere{Vec3(Real(0.3), Real(-0.2), -6), Real(0.4), 0}}, eye, focal, Real(0.4), 3);
  const Camera camera = scene.makeCamera(48, 48);
  const RenderResult pin = renderWith(scene, camera, 64, 21, false, false);
  const RenderResult thin = renderWith(scene, camera, 64, 22, true, false);
  const double a = channelSum(pin.film.mean()), b = channelSum(thin.film.mean());
  const double var = channelSum(pin.film.varianceOfMean()) + channelSum(thin.film.varianceOfMean());
  INFO("pinhole total " << a << ", thin lens total " << b << ", z = " << (a - b) / std::sqrt(var));
  CHECK(std::abs(a - b) <= 4 * std::sqrt(var));
  CHECK(channelSum(thin.film.mean()) != channelSum(pin.film.mean())); // the lens did move light
  // A uniform field (inside an emitting sphere): every lens ray sees 1, so every pixel stays exactly 1.
  Scene inside = emitterScene({Sphere{Vec3(0), 100, 0}}, eye, focal, Real(2), 10);
  const Image field = renderWith(inside, inside.makeCamera(16, 12), 8, 23, true, false).film.mean();
  for (float v : field.pixels)
    REQUIRE(v == 1.0f);
}

// ---- Motion --------------------------------------------------------------------------------------------------

TEST_CASE("motion: spheres with velocity 0 are met exactly as still ones, at every time, listed or in a tree")
{
  Random random(31);
  for (int n : {5, 40}) { // a flat list, and a BVH
    Scene still;
    still.materials = {Material{}};
    for (int i = 0; i < n; ++i)
      still.spheres.push_back(Sphere{random.inBox(-5, 5), random.uniform(Real(0.2), 1), 0});
    Scene zero = still;
    for (Sphere& s : zero.spheres)
      s.velocity = Vec3(0);
    still.buildAccelerator();
    zero.buildAccelerator();
    for (int i = 0; i < 20000; ++i) {
      Ray ray{random.inBox(-8, 8), random.direction(), 0, kInfinity, random.uniform()};
      const std::optional<Hit> a = still.intersect(ray), b = zero.intersect(ray);
      REQUIRE(a.has_value() == b.has_value());
      if (a) {
        REQUIRE(a->t == b->t);
        REQUIRE(a->primitive == b->primitive);
        REQUIRE(std::memcmp(&a->point, &b->point, sizeof a->point) == 0);
      }
    }
  }
}

TEST_CASE("motion: the BVH meets moving spheres where the brute-force loop does, at every time (bounds hold them)")
{
  Random random(41);
  Scene scene;
  scene.materials = {Material{}};
  for (int i = 0; i < 300; ++i) {
    Sphere s{random.inBox(-20, 20), random.uniform(Real(0.1), Real(1.5)), 0};
    if (i % 3 != 0) // a third stand still
      s.velocity = random.inBox(-6, 6);
    scene.spheres.push_back(s);
  }
  scene.buildAccelerator();
  REQUIRE(scene.usesAccelerator());
  REQUIRE(scene.hasMotion());
  // The root's boxes together hold every sphere at every time tested (the walked tree's root: the binary tree it
  // was made from is not kept).
  const BvhWideNode& root = scene.accelerator.wideNodes().at(0);
  Vec3 lo(kInfinity), hi(-kInfinity);
  for (int k = 0; k < int(root.boxes); ++k)
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::min(lo[a], Real(root.bound(0, a, k)));
      hi[a] = std::max(hi[a], Real(root.bound(1, a, k)));
    }
  for (const Sphere& s : scene.spheres)
    for (int k = 0; k <= 16; ++k) {
      const Vec3 c = s.centerAt(Real(k) / 16);
      for (int a = 0; a < 3; ++a) {
        REQUIRE(lo[a] <= c[a] - s.radius);
        REQUIRE(hi[a] >= c[a] + s.radius);
      }
    }
  // The tree against the loop over the spheres at the ray's time, rays aimed at random spheres' centres then.
  int hits = 0;
  for (int i = 0; i < 200000; ++i) {
    const Real time = random.uniform();
    const Sphere& target = scene.spheres[random.index(scene.spheres.size())];
    const Vec3 origin = random.inBox(-30, 30);
    const Vec3 aim = target.centerAt(time) + random.inBox(-2, 2);
    const Ray ray{origin, glm::normalize(aim - origin), 0, kInfinity, time};
    Real tNearest = kInfinity;
    int nearest = -1;
    for (std::size_t k = 0; k < scene.spheres.size(); ++k)
      if (auto t = intersectSphere(ray.origin, ray.direction, scene.spheres[k].centerAt(time), scene.spheres[k].radius,
                                   Real(0), tNearest)) {
        tNearest = *t;
        nearest = int(k);
      }
    const std::optional<Hit> hit = scene.intersect(ray);
    REQUIRE(hit.has_value() == (nearest >= 0));
    REQUIRE(scene.occluded(ray) == (nearest >= 0));
    if (hit) {
      ++hits;
      REQUIRE(hit->primitive == nearest);
      REQUIRE(hit->t == tNearest);
      REQUIRE(hit->time == time);
      // The hit point lies on the sphere where it is at that time.
      const Sphere& s = scene.spheres[std::size_t(nearest)];
      REQUIRE(std::abs(glm::length(hit->point - s.centerAt(time)) - s.radius) < kClose * (1 + s.radius));
    }
  }
  std::cout << "moving spheres: 200000 rays, " << hits << " hits, tree and loop agree on all\n";
  CHECK(hits > 50000);
}

TEST_CASE("motion: a moving sphere's image is the average of still images at times through the interval (z-test)")
{
  // The moving render draws a time per sample; the still renders put the sphere at stratified random times
  // t_k = (k + u_k)/K (an unbiased estimate of the same time integral). Per pixel, z = (a − b)/√(var_a + var_b).
  const Vec3 eye(0, 0, 6), focal(0, 0, 0);
  const Sphere moving{Vec3(-1, Real(-0.3), 0), Real(0.7), 0, Vec3(Real(2.2), Real(0.6), 0)};
  const Sphere still{Vec3(Real(0.8), Real(0.6), -2), Real(0.8), 0};
  Scene scene = emitterScene({moving, still}, eye, focal, 0, 0);
  const Camera camera = scene.makeCamera(40, 30);
  const RenderResult blurred = renderWith(scene, camera, 512, 51, false, true);
  constexpr int kTimes = 64;
  Image sum, sumVar;
  Sampler times(52, 0, 0, 0);
  for (int k = 0; k < kTimes; ++k) {
    const Real t = (Real(k) + times.next1D()) / kTimes;
    Sphere at = moving;
    at.center = moving.centerAt(t);
    at.velocity = Vec3(0);
    const Scene frozen = emitterScene({at, still}, eye, focal, 0, 0);
    const RenderResult r = renderWith(frozen, camera, 16, 100 + std::uint64_t(k), false, false);
    const Image m = r.film.mean(), v = r.film.varianceOfMean();
    if (k == 0) {
      sum = m;
      sumVar = v;
      continue;
    }
    for (std::size_t i = 0; i < m.pixels.size(); ++i) {
      sum.pixels[i] += m.pixels[i];
      sumVar.pixels[i] += v.pixels[i];
    }
  }
  const Image a = blurred.film.mean(), varA = blurred.film.varianceOfMean();
  int failed = 0, blurredPixels = 0;
  double diff = 0, var = 0;
  for (std::size_t i = 0; i < a.pixels.size(); ++i) {
    const double b = sum.pixels[i] / kTimes, varB = sumVar.pixels[i] / (kTimes * kTimes);
    const double d = a.pixels[i] - b, s2 = varA.pixels[i] + varB + 1e-10;
    failed += std::abs(d / std::sqrt(s2)) > 3.29;
    blurredPixels += a.pixels[i] > 0.05f && a.pixels[i] < 0.95f;
    diff += d;
    var += s2;
  }
  const double share = double(failed) / double(a.pixels.size());
  std::cout << "motion blur against still renders: " << 100 * share << "% of channels over |z| 3.29, image mean z = "
            << diff / std::sqrt(var) << ", " << blurredPixels << " channels part covered\n";
  CHECK(share < 0.01);
  CHECK(std::abs(diff / std::sqrt(var)) < 4);
  CHECK(blurredPixels > 150); // the sphere did blur
  // The control: the same sphere still at time 0 is far from the blurred image.
  Sphere atStart = moving;
  atStart.velocity = Vec3(0);
  const Scene atStartScene = emitterScene({atStart, still}, eye, focal, 0, 0);
  const RenderResult frozen = renderWith(atStartScene, camera, 64, 53, false, false);
  const Image f = frozen.film.mean();
  int far = 0;
  for (std::size_t i = 0; i < f.pixels.size(); ++i)
    far += std::abs(double(f.pixels[i]) - a.pixels[i]) > 0.2;
  CHECK(far > 100);
}

#include "render/render_loop.h"
#include "core/rng.h"
#include "small_scene.h"

#include <catch2/catch.hpp>

using namespace raylife;
using raylife::test::smallScene;

namespace {
// A trace that draws several random numbers and intersects the scene: enough to show any dependence on
// thread scheduling.
Color noisyTrace(const Scene& scene, const Ray& ray, Sampler& sampler, int)
{
  Real sum = 0;
  for (int i = 0; i < 5; ++i)
    sum += sampler.next1D();
  const Real hit = scene.intersect(ray) ? 1 : 0;
  return Color(sum, hit * sampler.next1D(), ray.direction.x * ray.direction.x);
}
} // namespace

TEST_CASE("one seed gives a bit-identical image on 1 - 2 and 3 threads - another seed does not")
{
  const Scene scene = smallScene();
  const Camera camera = scene.makeCamera();
  RenderSettings settings;
  settings.spp = 9;
  settings.seed = 42;
  settings.pixelSampling = PixelSampling::Jittered;
  settings.threads = 1;
  const Image one = render(scene, camera, settings, noisyTrace).film.mean();
  settings.threads = 2;
  const Image two = render(scene, camera, settings, noisyTrace).film.mean();
  settings.threads = 3;
  const Image three = render(scene, camera, settings, noisyTrace).film.mean();
  CHECK(one.pixels == two.pixels);
  CHECK(one.pixels == three.pixels);
  settings.seed = 43;
  CHECK(render(scene, camera, settings, noisyTrace).film.mean().pixels != one.pixels);
}

TEST_CASE("the render loop counts samples - rays and bad samples and keeps NaN - Inf and negatives off the film")
{
  const Scene scene = smallScene();
  const Camera camera = scene.makeCamera();
  RenderSettings settings;
  settings.spp = 3;
  const RenderResult ok = render(scene, camera, settings, noisyTrace);
  CHECK(ok.spp == 3);
  CHECK(ok.rays == 3u * 37u * 23u);
  CHECK(ok.badSamples == 0);

  auto badTrace = [](const Scene&, const Ray& ray, Sampler&, int) {
    if (ray.direction.x > Real(0.05))
      return Color(std::numeric_limits<Real>::quiet_NaN());
    if (ray.direction.x < Real(-0.05))
      return Color(-1);
    return Color(kInfinity, 0, 0);
  };
  const RenderResult bad = render(scene, camera, settings, badTrace);
  CHECK(bad.badSamples == 3u * 37u * 23u);
  const Image image = bad.film.mean();
  for (float v : image.pixels)
    CHECK(v == 0.0f);
}

TEST_CASE("a time budget renders whole passes until the time is spent")
{
  const Scene scene = smallScene();
  RenderSettings settings;
  settings.seconds = 0.05;
  const RenderResult r = render(scene, scene.makeCamera(), settings, noisyTrace);
  CHECK(r.spp >= 1);
  CHECK(r.seconds >= 0.05);
  for (int y = 0; y < r.film.height(); ++y)
    for (int x = 0; x < r.film.width(); ++x)
      REQUIRE(r.film.samples(x, y) == std::uint32_t(r.spp));
}

TEST_CASE("jittered samples are stratified: one per cell of the √N × √N grid")
{
  const Scene scene = smallScene();
  const Camera camera = parseScene(R"({ "camera": { "eye": [0, 0, 5], "focal": [0, 0, 0], "width": 1, "height": 1 },
                         "materials": { "m": { "type": "diffuse" } },
                         "spheres": [ { "center": [0, 0, 0], "radius": 1, "material": "m" } ] })",
                                   "one.json").makeCamera();
  // Record where each sample's ray falls on the image plane, via its direction.
  std::vector<Vec3> directions;
  RenderSettings settings;
  settings.spp = 16;
  settings.threads = 1;
  settings.pixelSampling = PixelSampling::Jittered;
  render(scene, camera, settings, [&](const Scene&, const Ray& ray, Sampler&, int) {
    directions.push_back(ray.direction);
    return Color(0);
  });
  REQUIRE(directions.size() == 16);
  const CameraBasis& b = camera.basis();
  const Real half = std::tan(glm::radians(Real(40)) / 2);
  std::vector<int> cells(16, 0);
  for (const Vec3& d : directions) {
    const Real z = -glm::dot(d, b.w);
    const Real fx = (glm::dot(d, b.u) / z / half + 1) / 2;  // [0, 1) across the pixel
    const Real fy = (1 - glm::dot(d, b.v) / z / half) / 2;
    cells[std::size_t(int(fy * 4) * 4 + int(fx * 4))] += 1;
  }
  for (int count : cells)
    CHECK(count == 1);
}

TEST_CASE("the per-sample random numbers depend on seed - pixel and sample index only")
{
  Sampler a(7, 3, 4, 5), b(7, 3, 4, 5);
  for (int i = 0; i < 100; ++i)
    REQUIRE(a.next1D() == b.next1D());
  for (auto other : {Sampler(8, 3, 4, 5), Sampler(7, 4, 4, 5), Sampler(7, 3, 5, 5), Sampler(7, 3, 4, 6)}) {
    Sampler c(7, 3, 4, 5);
    CHECK(other.next1D() != c.next1D());
  }
  // Uniform in [0, 1): the mean of many draws is ½ within a few standard errors, and 1 never appears.
  Sampler s(1, 0, 0, 0);
  double sum = 0;
  const int n = 100000;
  for (int i = 0; i < n; ++i) {
    const Real u = s.next1D();
    REQUIRE(u >= 0);
    REQUIRE(u < 1);
    sum += double(u);
  }
  CHECK(std::abs(sum / n - 0.5) < 4 * std::sqrt(1.0 / 12 / n));
}

TEST_CASE("splats: each lands once in its pixel across tile borders - exact on 1 - 2 and 3 threads - bad ones counted")
{
  // Every pixel sample splats a known amount into the pixel 17 columns right and 11 rows down (wrapping around), so
  // splats cross every tile border (16 × 16 tiles of a 37 × 23 image); each pixel receives exactly one splat a pass.
  const Scene scene = smallScene();
  const Camera camera = scene.makeCamera();
  const int W = camera.width(), H = camera.height();
  auto splatTrace = [&](const Scene&, const Ray& ray, Sampler& sampler, int, Splats& splats) {
    const std::optional<Vec2> film = splats.camera().project(ray.origin + ray.direction);
    if (!film)
      return Color(-1); // (never: a bad sample would show in the count below)
    const int x = int(film->x), y = int(film->y);
    const Vec2 target(Real((x + 17) % W) + Real(0.5), Real((y + 11) % H) + Real(0.5));
    splats.add(target, Color(1, Real(0.5), Real(0.25)) * Real(x + 1)); // (the source's column, for the check)
    if (x == 3 && y == 4)
      splats.add(target, Color(std::numeric_limits<Real>::quiet_NaN())); // dropped and counted
    splats.add(Vec2(Real(-1), Real(2)), Color(1)); // outside the image: ignored
    return Color(sampler.next1D() * 0); // no light of its own
  };
  RenderSettings settings;
  settings.spp = 5;
  settings.pixelSampling = PixelSampling::Jittered;
  std::vector<Image> images;
  for (int threads : {1, 2, 3}) {
    settings.threads = threads;
    const RenderResult r = render(scene, camera, settings, SplatTraceFunction(splatTrace));
    CHECK(r.spp == 5);
    CHECK(r.badSamples == 5); // the NaN splat, once a pass
    images.push_back(r.film.mean());
  }
  CHECK(images[0].pixels == images[1].pixels);
  CHECK(images[0].pixels == images[2].pixels);
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      const int source = (x - 17 + W) % W; // the column whose samples splat here
      CHECK(images[0].at(x, y, 0) == float(source + 1));
      CHECK(images[0].at(x, y, 2) == float(Real(0.25) * Real(source + 1)));
    }
}

TEST_CASE("splats: adaptive sampling is refused")
{
  const Scene scene = smallScene();
  RenderSettings settings;
  settings.spp = 4;
  settings.adaptive = 0.1;
  const SplatTraceFunction trace = [](const Scene&, const Ray&, Sampler&, int, Splats&) { return Color(0); };
  CHECK_THROWS_AS(render(scene, scene.makeCamera(), settings, trace), std::invalid_argument);
}

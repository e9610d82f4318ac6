// Adaptive sampling in render(): reproducible on any thread count, stops constant pixels at the minimum count,
// and keeps the image mean close to its expectation.
#include "render/render_loop.h"
#include "core/rng.h"
#include "small_scene.h"

#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>

using namespace raylife;
using raylife::test::smallScene;

namespace {
// Constant on a miss (the plain background), noisy with mean 1 on the sphere: U(0, 2) in every channel.
Color skyAndNoise(const Scene& scene, const Ray& ray, Sampler& sampler, int)
{
  if (!scene.intersect(ray))
    return Color(Real(0.5));
  return Color(2 * sampler.next1D());
}
} // namespace

TEST_CASE("adaptive sampling gives a bit-identical image and sample counts on 1 and 2 threads")
{
  const Scene scene = smallScene();
  const Camera camera = scene.makeCamera();
  RenderSettings settings;
  settings.spp = 256;
  settings.seed = 5;
  settings.pixelSampling = PixelSampling::Jittered;
  settings.adaptive = 0.05;
  settings.threads = 1;
  const RenderResult one = render(scene, camera, settings, skyAndNoise);
  settings.threads = 2;
  const RenderResult two = render(scene, camera, settings, skyAndNoise);
  CHECK(one.film.mean().pixels == two.film.mean().pixels);
  CHECK(one.meanSpp == two.meanSpp);
  bool sameCounts = true;
  for (int y = 0; y < camera.height(); ++y)
    for (int x = 0; x < camera.width(); ++x)
      sameCounts = sameCounts && one.film.samples(x, y) == two.film.samples(x, y);
  CHECK(sameCounts);
  CHECK(one.meanSpp < 256); // it did stop some pixels
}

TEST_CASE("a constant pixel stops at 16 samples unless a neighbour is noisy, and a noisy one goes on")
{
  const Scene scene = smallScene();
  const Camera camera = scene.makeCamera();
  RenderSettings settings;
  settings.spp = 256;
  settings.adaptive = 0.01;
  const RenderResult r = render(scene, camera, settings, skyAndNoise);
  // Corner pixels miss the sphere (constant 0.5); the centre pixel sees U(0, 2), whose relative standard error
  // 0.577/√n falls below 0.01 only after about 3300 samples: it takes all 256.
  CHECK(r.film.samples(0, 0) == std::uint32_t(kAdaptiveMinSamples));
  CHECK(r.film.samples(36, 22) == std::uint32_t(kAdaptiveMinSamples));
  CHECK(r.film.samples(18, 11) == 256u);
  CHECK(r.spp == 256);
  CHECK(r.meanSpp > kAdaptiveMinSamples);
  CHECK(r.meanSpp < 256);

  // A pixel just off an edge may see only the background in its first samples; it stops only once its
  // neighbours have settled too (here they never do).
  const int w = camera.width(), h = camera.height();
  int besideNoise = 0, kept = 0;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      if (r.film.relativeError(x, y, kAdaptiveMeanFloor) != 0)
        continue; // not a constant pixel
      bool noisyNeighbour = false;
      for (int ny = std::max(0, y - 1); ny <= std::min(h - 1, y + 1); ++ny)
        for (int nx = std::max(0, x - 1); nx <= std::min(w - 1, x + 1); ++nx)
          noisyNeighbour = noisyNeighbour || r.film.relativeError(nx, ny, kAdaptiveMeanFloor) > 0.01;
      besideNoise += noisyNeighbour;
      kept += noisyNeighbour && r.film.samples(x, y) == 256u;
    }
  CHECK(besideNoise > 0);
  CHECK(kept == besideNoise);
}

TEST_CASE("the adaptive image mean stays within 2 percent of its expectation")
{
  // On the sphere the expectation is 1. With the threshold 0.05 each pixel's mean has a standard error of about
  // 5 %; over the ~130 pixels on the sphere the image mean has one of about 0.45 %, so 2 % (4.5 of them) allows
  // the noise and the stopping rule's small bias, and catches a wrong count (a sum divided by another count).
  const Scene scene = smallScene();
  const Camera camera = scene.makeCamera();
  RenderSettings settings;
  settings.spp = 1024;
  settings.seed = 11;
  settings.adaptive = 0.05;
  const RenderResult r = render(scene, camera, settings, skyAndNoise);
  const Image mean = r.film.mean();
  double sum = 0;
  int onSphere = 0;
  for (int y = 0; y < mean.height; ++y)
    for (int x = 0; x < mean.width; ++x)
      if (mean.at(x, y, 0) != 0.5f) {
        sum += mean.at(x, y, 0);
        ++onSphere;
      }
  REQUIRE(onSphere > 50);
  CHECK(std::abs(sum / onSphere - 1.0) < 0.02);
}

TEST_CASE("adaptive sampling spreads each 16 of a pixel's samples over its 4 x 4 cells")
{
  // The film averages each sample's direction (plus 2: the film takes no negative sample), so a pixel's mean shows
  // where its samples fell. With 16 samples in
  // [0, 1) across a pixel, uniform positions put the mean's x at a root-mean-square distance of √(1/12/16) = 0.072
  // of a pixel from the centre; one sample in each of 16 columns (a (0, 4, 2)-net), at about 1/16 of that.
  const Scene scene = smallScene();
  const Camera camera = scene.makeCamera();
  auto direction = [](const Scene&, const Ray& ray, Sampler&, int) { return Color(ray.direction + Vec3(2)); };
  auto rmsOffset = [&](const RenderResult& r) {
    const Image mean = r.film.mean();
    double sum = 0;
    for (int y = 0; y < camera.height(); ++y)
      for (int x = 0; x < camera.width(); ++x) {
        const Real centre = camera.ray(Vec2(Real(x) + Real(0.5), Real(y) + Real(0.5))).direction.x;
        const Real pixel = camera.ray(Vec2(Real(x) + 1, Real(y) + Real(0.5))).direction.x -
                           camera.ray(Vec2(Real(x), Real(y) + Real(0.5))).direction.x;
        const double offset = (double(mean.at(x, y, 0)) - 2 - double(centre)) / double(pixel);
        sum += offset * offset;
      }
    return std::sqrt(sum / (camera.width() * camera.height()));
  };
  RenderSettings settings;
  settings.spp = 16; // the first checkpoint: every pixel takes 16
  settings.seed = 3;
  settings.pixelSampling = PixelSampling::Jittered;
  settings.adaptive = 1e-9;
  const double adaptive = rmsOffset(render(scene, camera, settings, direction));
  settings.adaptive.reset();
  const double grid = rmsOffset(render(scene, camera, settings, direction)); // the 4 x 4 grid of strata
  INFO("adaptive " << adaptive << ", grid " << grid);
  CHECK(adaptive < 0.03);
  CHECK(grid < 0.03);
}

TEST_CASE("a pixel whose samples were all black is not taken as known")
{
  // In a path tracer, 16 black samples in a dim corner say that no path found the light yet, not that the pixel is
  // black: its error is unknown (+infinity) until a sample is not black. A constant non-black pixel is known.
  Film film(2, 1);
  for (int s = 0; s < 64; ++s) {
    film.add(0, 0, Color(0));
    film.add(1, 0, Color(Real(0.25)));
  }
  CHECK(std::isinf(film.relativeError(0, 0, kAdaptiveMeanFloor)));
  CHECK(film.relativeError(1, 0, kAdaptiveMeanFloor) == 0);
  film.add(0, 0, Color(0, Real(0.5), 0));
  CHECK(std::isfinite(film.relativeError(0, 0, kAdaptiveMeanFloor)));
}

TEST_CASE("a pixel that stays black stops after kAdaptiveBlackSamples")
{
  // A black background: every sample 0. Unknown at 16 samples, taken as black at 64, not rendered to the end.
  const Scene scene = smallScene();
  const Camera camera = scene.makeCamera();
  RenderSettings settings;
  settings.spp = 256;
  settings.adaptive = 0.01;
  const RenderResult r = render(scene, camera, settings, [](const Scene&, const Ray&, Sampler&, int) {
    return Color(0);
  });
  CHECK(r.film.samples(0, 0) == std::uint32_t(kAdaptiveBlackSamples));
  CHECK(r.meanSpp == double(kAdaptiveBlackSamples));
}

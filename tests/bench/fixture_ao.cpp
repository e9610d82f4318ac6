// A TEST FIXTURE for the benchmark driver, never a chapter and never used for a reported figure: a tiny Monte
// Carlo estimator of ambient occlusion, so tests/bench can run raylife_bench end to end before the Monte Carlo
// chapters exist. Each variant estimates the same integral, the cosine-weighted visible fraction of the
// hemisphere times the material colour, (C/π) ∫ V(ω) cos θ dω:
//   FIXTURE_COSINE   cosine-weighted directions, estimate C · V          (unbiased)
//   FIXTURE_UNIFORM  uniform directions, estimate C · 2 cos θ · V        (unbiased, noisier)
//   FIXTURE_BIASED   as FIXTURE_COSINE, times 1.2                        (biased: the reference check must fail)
#include "geometry/hit.h"
#include "render/runner.h"
#include "shading/shading.h"

using namespace raylife;

namespace {

// An orthonormal frame around n (Duff et al. 2017).
void frame(const Vec3& n, Vec3& t, Vec3& b)
{
  const Real sign = std::copysign(Real(1), n.z);
  const Real a = Real(-1) / (sign + n.z);
  const Real c = n.x * n.y * a;
  t = Vec3(1 + sign * n.x * n.x * a, sign * c, -sign * n.x);
  b = Vec3(c, sign + n.y * n.y * a, -n.y);
}

Color trace(const Scene& scene, const Ray& ray, Sampler& sampler)
{
  const std::optional<Hit> hit = scene.intersect(ray);
  if (!hit)
    return scene.background;
  const Color C = scene.materials[std::size_t(hit->material)].color;
  const Vec3 N = facingNormal(*hit, ray.direction);
  Vec3 T, B;
  frame(N, T, B);
  const Vec2 u = sampler.next2D();
  const Real phi = 2 * kPi * u.y;
#if defined(FIXTURE_UNIFORM)
  const Real cosTheta = u.x;
  const Real weight = 2 * cosTheta;
#else
  const Real cosTheta = std::sqrt(Real(1) - u.x);
  const Real weight = 1;
#endif
  const Real sinTheta = std::sqrt(std::max(Real(0), 1 - cosTheta * cosTheta));
  const Vec3 dir = T * (sinTheta * std::cos(phi)) + B * (sinTheta * std::sin(phi)) + N * cosTheta;
  if (scene.occluded(spawnRay(*hit, dir)))
    return Color(0);
#if defined(FIXTURE_BIASED)
  return C * (weight * Real(1.2));
#else
  return C * weight;
#endif
}

} // namespace

int main(int argc, char** argv)
{
  const ChapterInfo chapter{.binary = FIXTURE_NAME,
                            .defaultScene = "spheres.json",
                            .uses = kUsesSpheres | kUsesColors | kUsesBackground,
                            .pixelSampling = PixelSampling::Centre,
                            .adaptiveSampling = true};
  return runChapter(argc, argv, chapter, trace);
}

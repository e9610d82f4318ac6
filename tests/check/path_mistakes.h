// Chapter 6's path tracing loop with one classic mistake switched in, so that the tests can show that
// raylife_check fails what these mistakes render (tests/check/mistake_main.cpp builds a chapter program of each).
#pragma once

#include "core/frame.h"
#include "core/sampling.h"
#include "render/runner.h"
#include "shading/bsdf.h"

namespace raylife::test {

/// The ways to get chapter 6's loop wrong that grading must catch.
enum class Mistake {
  None,             ///< chapter 6's loop as it is (the control for this copy)
  LostCosine,       ///< the weight f/pdf without |cosθi|
  RouletteNoDivide, ///< Russian roulette that does not divide by the survival probability
};

/// A copy of chapter 6's trace (steps/06_path_tracer/main.cpp, drawing its random numbers in the same order) with
/// `mistake` switched in.
inline Color traceWith(Mistake mistake, const Scene& scene, const Ray& primary, Sampler& sampler, int maxDepth)
{
  Color L(0), beta(1);
  Ray ray = primary;
  for (int bounce = 0;; ++bounce) {
    const std::optional<Hit> hit = scene.intersect(ray);
    if (!hit) {
      L += beta * scene.background;
      break;
    }
    const Material& m = scene.materials[std::size_t(hit->material)];
    L += beta * m.emission;
    if (bounce == maxDepth)
      break;
    const Frame frame = Frame::fromNormal(hit->normal);
    const Vec3 wo = frame.toLocal(-ray.direction);
    const Real uChoice = sampler.next1D();
    const Vec2 u = sampler.next2D();
    const std::optional<BsdfSample> bs = bsdfSample(m, wo, u, uChoice);
    if (!bs)
      break;
    beta *= mistake == Mistake::LostCosine ? bs->f / bs->pdf : bs->f * std::abs(bs->wi.z) / bs->pdf;
    if (beta == Color(0))
      break;
    if (bounce >= kRouletteMinBounces) {
      const Real q = rouletteSurvival(beta);
      if (sampler.next1D() >= q)
        break;
      if (mistake != Mistake::RouletteNoDivide)
        beta /= q;
    }
    ray = spawnRay(*hit, frame.toWorld(bs->wi));
  }
  return L;
}

} // namespace raylife::test

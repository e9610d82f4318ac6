#include "scene/light_sampling.h"

#include "core/frame.h"
#include "core/rng.h"
#include "core/threads.h"
#include "scene/camera.h"
#include "shading/bsdf.h"

#include <algorithm>
#include <array>
#include <cstdio>
#include <omp.h>

namespace raylife {

namespace {

// The quadtrees of the light guide: at most 10 levels (leaves down to 1/1024 of a side), a node split while it
// holds more than 1% of the useful samples and at least 8 of them.
constexpr int kGuideDepth = 10;
constexpr double kGuideSplit = 0.01;
constexpr int kGuideMin = 8;

} // namespace

LightSampler::LightSampler(const Scene& scene) : scene_(scene)
{
  // Each light's power Φ (its luminance): π·Le·A for an emitter of area A (4πr² for a sphere), 4π·I for a point light.
  std::vector<Real> power;
  for (std::size_t i = 0; i < scene.primitiveCount(); ++i) {
    const Material& m = scene.materials[std::size_t(scene.materialOf(int(i)))];
    if (!m.isEmissive())
      continue;
    Real phi = 0;
    if (i < scene.spheres.size()) {
      const Real r = scene.spheres[i].radius;
      phi = luminance(m.emission) * kPi * 4 * kPi * r * r;
    } else {
      const auto [p0, p1, p2] = scene.triangleVertices(i - scene.spheres.size());
      phi = luminance(m.emission) * kPi * (triangleDoubleArea(p0, p1, p2) / 2);
    }
    if (phi > 0) {
      lights_.push_back(int(i));
      power.push_back(phi);
    }
  }
  for (std::size_t i = 0; i < scene.lights.size(); ++i) {
    const Real phi = 4 * kPi * luminance(scene.lights[i].intensity);
    if (phi > 0) {
      lights_.push_back(-int(i) - 1);
      power.push_back(phi);
    }
  }
  // The cumulative distribution, normalised; the last entry is exactly 1 so that every u < 1 finds a light.
  Real total = 0;
  for (Real p : power)
    total += p;
  if (!(total > 0)) {
    lights_.clear();
    return;
  }
  totalPower_ = total;
  Real running = 0;
  for (std::size_t k = 0; k < power.size(); ++k) {
    running += power[k];
    cdf_.push_back(running / total);
    if (lights_[k] >= 0)
      emitters_.emplace_back(lights_[k], power[k] / total); // in increasing primitive order
  }
  cdf_.back() = 1;
}

Real LightSampler::probability(int primitive) const
{
  const auto it = std::lower_bound(emitters_.begin(), emitters_.end(), primitive,
                                   [](const std::pair<int, Real>& e, int p) { return e.first < p; });
  return it != emitters_.end() && it->first == primitive ? it->second : 0;
}

std::pair<std::size_t, Real> LightSampler::choose(Real uLight, int cell) const
{
  // Choose a light by inverting the cumulative distribution: of power, or of the guide's cell.
  const std::size_t n = cdf_.size();
  if (n == 1)
    return {0, 1}; // what the search below gives (the last entry is exactly 1), without it

  const auto cdf = cell < 0 ? cdf_.begin() : cellCdf_.begin() + std::ptrdiff_t(std::size_t(cell) * n);
  const std::size_t k = std::size_t(std::upper_bound(cdf, cdf + std::ptrdiff_t(n), uLight) - cdf);
  const std::size_t chosen = std::min(k, n - 1);
  return {chosen, cdf[std::ptrdiff_t(chosen)] - (chosen > 0 ? cdf[std::ptrdiff_t(chosen) - 1] : 0)};
}

int LightSampler::lightIndex(int primitive) const
{
  for (std::size_t k = 0; k < lights_.size(); ++k)
    if (lights_[k] == primitive)
      return int(k);
  return -1;
}

int LightSampler::cellOf(const Vec3& ref) const
{
  if (cellLearned_.empty())
    return -1;
  const Vec3 g = (ref - gridMin_) * gridScale_;
  // Clamped into the grid (a NaN to 0: max(0, NaN) is 0 as std::max orders its arguments), without branches.
  glm::ivec3 c;
  for (int a = 0; a < 3; ++a)
    c[a] = int(std::min(Real(gridSize_[a] - 1), std::max(Real(0), g[a])));
  const int cell = (c.z * gridSize_.y + c.y) * gridSize_.x + c.x;
  return cellLearned_[std::size_t(cell)] ? cell : -1;
}

Real LightSampler::area(int primitive) const
{
  if (std::size_t(primitive) < scene_.spheres.size()) {
    const Real r = scene_.spheres[std::size_t(primitive)].radius;
    return 4 * kPi * r * r;
  }
  const auto [p0, p1, p2] = scene_.triangleVertices(std::size_t(primitive) - scene_.spheres.size());
  return triangleDoubleArea(p0, p1, p2) / 2;
}

Vec3 LightSampler::normalAt(int primitive, const Vec3& point) const
{
  if (std::size_t(primitive) < scene_.spheres.size()) {
    const Sphere& s = scene_.spheres[std::size_t(primitive)];
    return safeNormalize(point - s.center, Vec3(0, 0, 1));
  }
  const auto [p0, p1, p2] = scene_.triangleVertices(std::size_t(primitive) - scene_.spheres.size());
  return triangleNormal(p0, p1, p2);
}

std::optional<EmitterPoint> LightSampler::sampleEmitterPoint(Real uLight, Vec2 u) const
{
  if (cdf_.empty())
    return std::nullopt;
  const auto [chosen, choice] = choose(uLight);
  const int light = lights_[chosen];
  if (light < 0)
    return std::nullopt; // a point light: no surface to start from
  EmitterPoint e;
  e.hit.primitive = light;
  e.hit.material = scene_.materialOf(light);
  e.Le = scene_.materials[std::size_t(e.hit.material)].emission;
  e.pdfArea = choice / area(light);
  if (std::size_t(light) < scene_.spheres.size()) {
    // Uniform on the sphere: a uniform direction from the centre, re-projected with its error bound.
    const Sphere& s = scene_.spheres[std::size_t(light)];
    const SurfacePoint<Real> sp = sphereSurfacePoint(s.center, sampleUniformSphere(u), s.radius, s.center, s.radius);
    e.hit.point = sp.point;
    e.hit.pointError = sp.error;
    e.hit.normal = e.hit.geometricNormal = sp.normal;
  } else {
    // Uniform on the triangle: b0 = 1 − √u₀, b1 = √u₀·(1 − u₁), b2 = √u₀·u₁.
    const auto [p0, p1, p2] = scene_.triangleVertices(std::size_t(light) - scene_.spheres.size());
    const Real su = std::sqrt(u.x);
    const TrianglePoint<Real> tp = trianglePoint(p0, p1, p2, 1 - su, su * (1 - u.y), su * u.y);
    e.hit.point = tp.point;
    e.hit.pointError = tp.error;
    e.hit.normal = e.hit.geometricNormal = triangleNormal(p0, p1, p2);
  }
  return e;
}

// [sample]
std::optional<LightSample> LightSampler::sample(const Vec3& ref, Real uLight, Vec2 u, Real time) const
{
  const std::optional<LightChoice> chosen = choose(ref, uLight, u, time);
  return chosen ? sampleChosen(*chosen, ref, time) : std::nullopt;
}

std::optional<LightChoice> LightSampler::choose(const Vec3& ref, Real uLight, Vec2 u, Real time) const
{
  const std::optional<LightChoice> chosen = chooseInCell(cellOf(ref), ref, uLight, u, time);
  if (!chosen)
    return std::nullopt;
  return guided(*chosen);
}

LightChoice LightSampler::guided(LightChoice choice) const
{
  if (choice.guideTree < 0)
    return choice;
  // A guided sphere light: u.x chooses between uniform in the cone and the learned density, and the direction
  // comes from the numbers that component gives; its pdf is the mixture's, whichever component chose it.
  const MixtureSample m = cellTree_[std::size_t(choice.guideTree)].sampleMixture(choice.u, choice.guideShare);
  choice.u = m.p;
  choice.guide = m.pdf;
  return choice;
}

std::optional<LightChoice> LightSampler::chooseInCell(int cell, const Vec3& ref, Real uLight, Vec2 u, Real time) const
{
  // (Every return is `result`, filled in place: the record is returned without a copy.)
  std::optional<LightChoice> result;
  if (cdf_.empty())
    return result;
  LightChoice& c = result.emplace();
  const auto [chosen, choice] = choose(uLight, cell);
  c.index = chosen, c.light = lights_[chosen], c.choice = choice, c.u = u;
  const std::size_t tree = std::size_t(cell) * lights_.size() + chosen;
  if (cell < 0 || cellTree_[tree].uniform() || std::size_t(c.light) >= scene_.spheres.size())
    return result;
  const Sphere& s = scene_.spheres[std::size_t(c.light)];
  const Vec3 toCentre = s.centerAt(time) - ref;
  if (glm::dot(toCentre, toCentre) <= s.radius * s.radius)
    return result; // inside the light: not guided
  c.guideTree = int(tree), c.guideShare = cellShare_[tree];
  return result;
}

std::optional<LightSample> LightSampler::sampleChosen(const LightChoice& chosen, const Vec3& ref, Real time) const
{
  std::optional<LightSample> ls = sampleLight(chosen.index, chosen.choice, ref, chosen.u, time);
  if (ls)
    ls->pdf *= chosen.guide; // (× 1 where not guided: the same bits)
  return ls;
}

std::optional<LightSample> LightSampler::sampleLight(std::size_t k, Real choice, const Vec3& ref, Vec2 u,
                                                     Real time) const
{
  const int light = lights_[k];
  // A point light: the one direction towards it, with the inverse-square law; a delta light has no density.
  if (light < 0) {
    const PointLight& p = scene_.lights[std::size_t(-light - 1)];
    const std::optional<LightArrival> in = p.arrivalAt(ref);
    if (!in)
      return std::nullopt;
    return LightSample{in->direction, p.position, in->intensity, choice, -1, true};
  }

  const Color& Le = scene_.materials[std::size_t(scene_.materialOf(light))].emission;
  if (std::size_t(light) >= scene_.spheres.size()) {
    // An emissive triangle: a direction uniform in its solid angle (or on its area), and the point where it meets
    // the triangle's plane.
    const auto [p0, p1, p2] = scene_.triangleVertices(std::size_t(light) - scene_.spheres.size());
    const std::optional<TriangleLightSample<Real>> ts = sampleTriangleLight(ref, p0, p1, p2, u);
    if (!ts)
      return std::nullopt;
    const Vec3 n = triangleNormal(p0, p1, p2);
    const Real along = glm::dot(ts->wi, n);
    const Real t = along != 0 ? glm::dot(p0 - ref, n) / along : 0;
    const Vec3 target = ref + std::max(Real(0), t) * ts->wi;
    return LightSample{ts->wi, target, Le, choice * ts->pdf, light, false};
  }

  // An emissive sphere: a direction uniform in the cone it subtends, and the point it first hits on the sphere.
  const Sphere& s = scene_.spheres[std::size_t(light)];
  const Vec3 center = s.centerAt(time);
  const Vec3 wi = sampleSphereCone(ref, center, s.radius, u);
  const Real pdf = choice * sphereConePdf(ref, center, s.radius);
  const std::optional<SphereRoots<Real>> roots = intersectSphereRoots(ref, wi, center, s.radius);
  // A direction at the cone's very edge may graze past by rounding: take the closest approach, which is on the
  // sphere to within that rounding. From inside, the far root is the one in front.
  Real t = glm::dot(center - ref, wi);
  if (roots)
    t = roots->t0 >= 0 ? roots->t0 : roots->t1;
  const Vec3 target = ref + std::max(Real(0), t) * wi;
  return LightSample{wi, target, Le, pdf, light, false};
}
// [sample]

// [visibleImpl]
bool lightVisible(const Scene& scene, const Hit& hit, const LightSample& ls)
{
  if (ls.delta)
    return !scene.occluded(spawnRayTo(hit, ls.target));
  // Where the shadow ray first meets the light, from the ray's own origin (the test Scene::intersect makes).
  // Nowhere ahead: the direction leaves the light's own surface, or grazes past its edge by rounding.
  Ray ray = spawnRay(hit, ls.wi);
  const std::optional<Real> t = scene.intersectPrimitive(ray, ls.primitive);
  if (!t)
    return false;
  // Nothing may be met before it: an any-hit query over [0, t), which the light's own root t does not enter.
  ray.tmax = *t;
  return !scene.occluded(ray);
}
// [visibleImpl]

Real LightSampler::pdf(const Vec3& ref, int primitive, const Vec3& point, Real time) const
{
  const int cell = cellOf(ref);
  int k = -1;
  Real choice = 0;
  if (cell < 0) {
    choice = probability(primitive);
  } else if ((k = lightIndex(primitive)) >= 0) {
    const Real* cdf = &cellCdf_[std::size_t(cell) * lights_.size()];
    choice = cdf[k] - (k > 0 ? cdf[k - 1] : 0);
  }
  if (!(choice > 0))
    return 0;
  if (std::size_t(primitive) >= scene_.spheres.size()) {
    const auto [p0, p1, p2] = scene_.triangleVertices(std::size_t(primitive) - scene_.spheres.size());
    return choice * triangleLightPdf(ref, p0, p1, p2, point);
  }
  const Sphere& s = scene_.spheres[std::size_t(primitive)];
  const Vec3 center = s.centerAt(time);
  const Real cone = choice * sphereConePdf(ref, center, s.radius);
  const SampleTree* tree = cell < 0 ? nullptr : &cellTree_[std::size_t(cell) * lights_.size() + std::size_t(k)];
  const Vec3 toCentre = center - ref;
  if (!tree || tree->uniform() || glm::dot(toCentre, toCentre) <= s.radius * s.radius)
    return cone;
  // The guided mixture's density at the numbers that give this direction.
  const Vec3 wi = safeNormalize(point - ref, Vec3(0, 0, 1));
  const Vec2 uc = sphereConeCoordinates(ref, center, s.radius, wi);
  const Real a = cellShare_[std::size_t(cell) * lights_.size() + std::size_t(k)];
  return cone * (a + (1 - a) * tree->pdf(uc));
}

// [learn]
LightSampler::LightSampler(const Scene& scene, const LightGuiding& guiding) : LightSampler(scene)
{
  if (!cdf_.empty())
    learn(guiding);
}

void LightSampler::learn(const LightGuiding& guiding)
{
  // 1. Surface points where the render will sample lights: the non-specular vertices of paths from the camera.
  struct Point {
    Hit hit;
    Vec3 wo; // towards where the path came from, world space
  };
  std::vector<Point> points;
  points.reserve(std::size_t(std::max(1, guiding.paths)) * std::size_t(std::max(1, guiding.bounces)));
  const Camera camera = scene_.makeCamera();
  for (int p = 0; p < std::max(1, guiding.paths); ++p) {
    Sampler sampler(guiding.seed, p, 0, 0);
    const Vec2 film = sampler.next2D() * Vec2(Real(scene_.camera.width), Real(scene_.camera.height));
    Ray ray = camera.ray(film);
    for (int bounce = 0; bounce < std::max(1, guiding.bounces); ++bounce) {
      const std::optional<Hit> hit = scene_.intersect(ray);
      if (!hit)
        break;
      const Material& m = scene_.materials[std::size_t(hit->material)];
      if (m.type != MaterialType::Mirror && m.type != MaterialType::Glass)
        points.push_back(Point{*hit, -ray.direction});
      const Frame frame = Frame::fromNormal(hit->normal);
      const Real uChoice = sampler.next1D();
      const std::optional<BsdfSample> bs = bsdfSample(m, frame.toLocal(-ray.direction), sampler.next2D(), uChoice);
      if (!bs)
        break;
      ray = spawnRay(*hit, frame.toWorld(bs->wi));
    }
  }
  if (points.empty())
    return;

  // 2. A grid of cells over their bounds, cubic, cellsPerAxis along the longest side.
  Vec3 lo(points[0].hit.point), hi(lo);
  for (const Point& p : points) {
    lo = glm::min(lo, p.hit.point);
    hi = glm::max(hi, p.hit.point);
  }
  const Real longest = std::max({hi.x - lo.x, hi.y - lo.y, hi.z - lo.z});
  const int perAxis = std::max(1, guiding.cellsPerAxis);
  const Real side = longest > 0 ? longest / Real(perAxis) : 1;
  for (int a = 0; a < 3; ++a)
    gridSize_[a] = std::clamp(int(std::ceil((hi[a] - lo[a]) / side)), 1, perAxis);
  gridMin_ = lo;
  gridScale_ = Vec3(1 / side);
  const std::size_t cells = std::size_t(gridSize_.x) * std::size_t(gridSize_.y) * std::size_t(gridSize_.z);
  const std::size_t n = lights_.size();
  cellLearned_.assign(cells, 0);
  for (const Point& p : points) {
    const Vec3 g = (p.hit.point - gridMin_) * gridScale_;
    const glm::ivec3 c = glm::clamp(glm::ivec3(g), glm::ivec3(0), gridSize_ - 1);
    cellLearned_[std::size_t((c.z * gridSize_.y + c.y) * gridSize_.x + c.x)] = 1;
  }

  // 3. Samples of every light at every point, as the unguided sampler draws them, each with its shadow ray: per
  // cell and light, how many there were, how many were of use, and where in a sphere's cone those fell.
  // In two rounds: first an eighth of the samples everywhere, then the rest only for the cells and lights that
  // the first round found mostly hidden (a light seen whole needs no guide, so a scene like the Cornell box costs
  // an eighth of the pre-pass). The shadow rays run on every core (each point has its own random numbers and its
  // own bits for the answers), then the answers are gathered in point order, so what is learned does not depend
  // on the threads. Only whether each sample was of use is kept (a bit); the numbers that chose a useful one are
  // drawn again from the same stream when they are gathered, so the pre-pass holds a few bytes per point (a fresh
  // process pays for every page it touches).
  const int perPoint = std::clamp(guiding.samplesPerPoint, 1, 64), firstRound = std::max(1, perPoint / 8);
  std::vector<std::uint64_t> usefulBits(points.size() * n, 0); // per point and light, bit j: sample j was of use
  std::vector<int> pointCell(points.size());
  for (std::size_t i = 0; i < points.size(); ++i)
    pointCell[i] = cellOf(points[i].hit.point);
  std::vector<char> wanted(cells * n, 1); // per cell and light: draw its samples in this round
  const int threads = threadCount(guiding.threads);
  const auto drawRound = [&](int from, int to) {
#pragma omp parallel for schedule(dynamic, 64) num_threads(threads)
    for (std::ptrdiff_t ii = 0; ii < std::ptrdiff_t(points.size()); ++ii) {
      const std::size_t i = std::size_t(ii);
      const Point& p = points[i];
      const Material& m = scene_.materials[std::size_t(p.hit.material)];
      const Frame frame = Frame::fromNormal(p.hit.normal);
      const Vec3 wo = frame.toLocal(p.wo);
      for (std::size_t k = 0; k < n; ++k) {
        if (!wanted[std::size_t(pointCell[i]) * n + k])
          continue;
        // Each point, light and round has its own stream of numbers.
        Sampler sampler(guiding.seed + 1 + k, int(i), from, 0);
        std::uint64_t bits = 0;
        for (int j = from; j < to; ++j) {
          const std::optional<LightSample> ls = sampleLight(k, 1, p.hit.point, sampler.next2D(), p.hit.time);
          if (ls && bsdfEval(m, wo, frame.toLocal(ls->wi)) != Color(0) && lightVisible(scene_, p.hit, *ls))
            bits |= std::uint64_t(1) << j;
        }
        usefulBits[i * n + k] |= bits;
      }
    }
  };
  drawRound(0, firstRound);
  std::vector<std::size_t> drawn1(cells * n, 0), useful1(cells * n, 0); // of the first round: every cell alike
  {
    for (std::size_t i = 0; i < points.size(); ++i)
      for (std::size_t k = 0; k < n; ++k)
        for (int j = 0; j < firstRound; ++j) {
          ++drawn1[std::size_t(pointCell[i]) * n + k];
          useful1[std::size_t(pointCell[i]) * n + k] += std::size_t((usefulBits[i * n + k] >> j) & 1);
        }
    for (std::size_t at = 0; at < cells * n; ++at)
      wanted[at] = useful1[at] > 0 && Real(useful1[at]) < guiding.guideBelow * Real(drawn1[at]);
  }
  drawRound(firstRound, perPoint);

  std::vector<std::size_t> drawn(cells * n, 0), useful(cells * n, 0);
  // The useful samples' numbers, apart for points of even and of odd index (each half tests the other's guide).
  std::vector<std::array<std::vector<Vec2>, 2>> usefulAt(cells * n);
  for (std::size_t i = 0; i < points.size(); ++i) {
    const Point& p = points[i];
    const int cell = pointCell[i];
    for (std::size_t k = 0; k < n; ++k) {
      const std::size_t at = std::size_t(cell) * n + k;
      // A sphere's cone is guided only from outside it (from inside, the whole sphere of directions is sampled).
      bool outside = false;
      if (lights_[k] >= 0 && std::size_t(lights_[k]) < scene_.spheres.size()) {
        const Sphere& s = scene_.spheres[std::size_t(lights_[k])];
        const Vec3 toCentre = s.centerAt(p.hit.time) - p.hit.point;
        outside = glm::dot(toCentre, toCentre) > s.radius * s.radius;
      }
      // The first round's samples, and the second's where it was drawn; the numbers of a useful one drawn again.
      const int taken = wanted[at] ? perPoint : firstRound;
      Sampler first(guiding.seed + 1 + k, int(i), 0, 0), second(guiding.seed + 1 + k, int(i), firstRound, 0);
      for (int j = 0; j < taken; ++j) {
        const Vec2 u = (j < firstRound ? first : second).next2D();
        ++drawn[at];
        if (!((usefulBits[i * n + k] >> j) & 1))
          continue;
        ++useful[at];
        if (outside)
          usefulAt[at][i % 2].push_back(u);
      }
    }
  }

  // 4. Per cell: the choice of a light, ½ by power and ½ by power × share of useful samples; and for a sphere
  // light seen only in part, the density of its useful samples in the cone (SampleTree) and its mix with the
  // uniform cone, where that lowers the variance.
  cellShare_.assign(cells * n, 1);
  cellCdf_.assign(cells * n, 0);
  cellTree_.assign(cells * n, SampleTree());
  std::vector<Real> power(n);
  for (std::size_t k = 0; k < n; ++k)
    power[k] = cdf_[k] - (k > 0 ? cdf_[k - 1] : 0);
  // A guide is judged on points it was not learned from: the tree of the even points on the odd ones' samples and
  // the other way round. With samples uniform in the cone and v = 1 for a useful one, the second moment of the
  // estimate (its variance, but for the square of the mean) is ∝ Σ v under uniform sampling and Σ v / q(u) under
  // the mixture q, for each uniform share α tried; the cell is guided with the best α only where that sum falls
  // below guiding.keepBelow × the uniform one.
  const auto chooseShare = [&](const std::array<std::vector<Vec2>, 2>& halves) -> Real {
    const std::array<SampleTree, 2> trees = {SampleTree::fromPoints(halves[0], kGuideDepth, kGuideSplit, kGuideMin),
                                             SampleTree::fromPoints(halves[1], kGuideDepth, kGuideSplit, kGuideMin)};
    const double uniformMoment = double(halves[0].size() + halves[1].size());
    Real best = 1;
    double bestMoment = uniformMoment * double(guiding.keepBelow);
    for (const Real alpha : {Real(0.15), Real(0.3), Real(0.5), Real(0.7)}) {
      double moment = 0;
      for (std::size_t h = 0; h < 2; ++h)
        for (const Vec2& u : halves[h])
          moment += 1 / double(alpha + (1 - alpha) * trees[1 - h].pdf(u));
      if (moment < bestMoment) {
        bestMoment = moment;
        best = alpha;
      }
    }
    return best;
  };
  // For the report: useful samples before (uniform) and as expected after guiding (each uniform sample weighted
  // by the guided pdf over the uniform one), summed over cells.
  std::vector<double> before(n, 0), after(n, 0), count(n, 0);
  std::vector<int> guidedCells(n, 0), leaves(n, 0);
  double chosenBefore = 0, chosenAfter = 0, pointsTotal = 0;
  std::vector<std::size_t> pointsIn(cells, 0);
  for (const int pc : pointCell)
    ++pointsIn[std::size_t(pc)];
  for (std::size_t c = 0; c < cells; ++c) {
    if (!cellLearned_[c])
      continue;
    std::vector<Real> share(n, 0), weight(n, 0), afterShare(n, 0);
    Real totalWeight = 0;
    for (std::size_t k = 0; k < n; ++k) {
      const std::size_t at = c * n + k;
      share[k] = drawn[at] ? Real(useful[at]) / Real(drawn[at]) : 0;
      afterShare[k] = share[k];
      weight[k] = power[k] * share[k];
      totalWeight += weight[k];
      const Real alpha = share[k] < guiding.guideBelow ? chooseShare(usefulAt[at]) : Real(1);
      if (alpha < 1) {
        std::vector<Vec2> all = usefulAt[at][0];
        all.insert(all.end(), usefulAt[at][1].begin(), usefulAt[at][1].end());
        cellTree_[at] = SampleTree::fromPoints(all, kGuideDepth, kGuideSplit, kGuideMin);
        cellShare_[at] = alpha;
        if (!cellTree_[at].uniform()) {
          double expected = 0;
          for (const Vec2& u : all)
            expected += double(alpha + (1 - alpha) * cellTree_[at].pdf(u));
          afterShare[k] = Real(expected / double(drawn[at]));
          ++guidedCells[k];
          leaves[k] = std::max(leaves[k], cellTree_[at].leafCount());
        }
      }
      // Weighted by the first round's samples, which every cell drew alike.
      before[k] += double(useful1[at]);
      after[k] += double(afterShare[k]) * double(drawn1[at]);
      count[k] += double(drawn1[at]);
    }
    Real running = 0;
    const double cellPoints = double(pointsIn[c]);
    for (std::size_t k = 0; k < n; ++k) {
      const Real p = totalWeight > 0 ? (power[k] + weight[k] / totalWeight) / 2 : power[k];
      running += p;
      cellCdf_[c * n + k] = running;
      chosenBefore += cellPoints * double(power[k] * share[k]);
      chosenAfter += cellPoints * double(p * afterShare[k]);
    }
    for (std::size_t k = 0; k < n; ++k)
      cellCdf_[c * n + k] /= running;
    cellCdf_[c * n + n - 1] = 1;
    pointsTotal += cellPoints;
  }

  // 5. The report (--verbose).
  const auto percent = [](double x) {
    char text[32];
    std::snprintf(text, sizeof text, "%.1f%%", 100 * x);
    return std::string(text);
  };
  std::size_t learned = 0;
  for (char l : cellLearned_)
    learned += std::size_t(l);
  guideReport_.push_back("light guide: " + std::to_string(points.size()) + " surface points of " +
                         std::to_string(guiding.paths) + " camera paths, " + std::to_string(firstRound) +
                         " samples of each of " + std::to_string(n) + " lights at each (" + std::to_string(perPoint) +
                         " where mostly hidden), in " + std::to_string(learned) + " of " + std::to_string(cells) +
                         " cells (" + std::to_string(gridSize_.x) + "x" + std::to_string(gridSize_.y) + "x" +
                         std::to_string(gridSize_.z) + ")");
  for (std::size_t k = 0; k < n; ++k) {
    const int light = lights_[k];
    const std::string name = light < 0 ? "point light " + std::to_string(-light - 1)
                             : std::size_t(light) < scene_.spheres.size()
                                 ? "sphere " + std::to_string(light)
                                 : "triangle " + std::to_string(std::size_t(light) - scene_.spheres.size());
    guideReport_.push_back("light guide: " + name + ": samples of use " + percent(before[k] / count[k]) +
                           " uniform -> " + percent(after[k] / count[k]) + " guided (in " +
                           std::to_string(guidedCells[k]) + " cells; up to " + std::to_string(leaves[k]) +
                           " leaves)");
  }
  guideReport_.push_back("light guide: samples of use, light choice included: " +
                         percent(chosenBefore / pointsTotal) + " by power -> " + percent(chosenAfter / pointsTotal) +
                         " guided");

  // 6. With a single light a cell that guides nothing chooses it with probability 1 and samples it uniformly, as
  // the unguided sampler does: such cells are dropped (cellOf gives −1 there), and if that is every cell, the grid
  // too, so that the render does not look up a cell for every sample.
  if (n == 1) {
    for (std::size_t c = 0; c < cells; ++c)
      if (cellTree_[c].uniform())
        cellLearned_[c] = 0;
    if (guidedCells[0] == 0) {
      cellLearned_.clear();
      cellCdf_.clear();
      cellTree_.clear();
      cellShare_.clear();
      guideReport_.push_back("light guide: one light, guided nowhere: the render samples it unguided");
    }
  }
}
// [learn]

} // namespace raylife

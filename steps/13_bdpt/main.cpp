// Chapter 13 — bidirectional path tracing: every connection strategy, light tracing, MIS over all of them.
//
// Chapters 6 to 8 build every path from the eye. A path that reaches the eye through glass from a small lamp (a
// caustic) is then found only when a path from the floor happens to pass through the glass and hit the lamp: rare,
// and weighted enormously when it happens. Bidirectional path tracing (Veach and Guibas 1995, Lafortune and Willems
// 1993) traces two subpaths per sample, one from the camera (z₀ = the eye, z₁, z₂, ...) and one from a light
// (y₀ on an emitter, y₁, ...), and joins them in every possible way. A path of k edges can be made by k + 2
// strategies (s, t): s vertices from the light, t from the camera, s + t = k + 1:
//   s = 0        the camera subpath hits an emitter (chapter 6);
//   s = 1        the camera vertex z_{t−1} connects to a point chosen on a light (next-event estimation, chapter 7);
//   s ≥ 2, t ≥ 2 the light vertex y_{s−1} and the camera vertex z_{t−1} are joined by a shadow ray;
//   t = 1        the light vertex y_{s−1} is joined to the eye (light tracing): its light lands in whatever pixel it
//                projects to, a *splat*, not in the pixel whose sample made it.
// Each strategy's estimate is weighted by the power heuristic over all the strategies that could have made the same
// path, w_s = p_s² / Σ_i p_i², with p_i the pdf of the whole path (a product of densities per unit area) under
// strategy i. The ratios p_i/p_s are computed in O(1) per connection from two running sums carried along each
// subpath, dVCM and dVC (Georgiev, "Implementing Vertex Connection and Merging", 2012, without the merging).
// Mirror and glass vertices are deltas: no connection can end at them, and their factors cancel in the ratios.
//
// Two strategies are left out, so their paths are weighted over the others: the light's own point seen by the eye
// (s = 1, t = 1: a camera ray that hits an emitter counts with weight 1) and the eye hit by a light path (t = 0: a
// pinhole cannot be hit). The background emits but is never a light subpath's start: a camera path that escapes sees
// it with weight 1. Point lights are found by next-event estimation only (weight 1), as in chapter 8.
#include "core/frame.h"
#include "core/sampling.h"
#include "render/runner.h"
#include "scene/light_sampling.h"
#include "shading/bsdf.h"

#include <climits>
#include <cstdio>
#include <cstring>
#include <iostream>
#include <optional>
#include <vector>

using namespace raylife;

/// [options]
// Which strategies the image shows: all, weighted (the default), or one strategy (s, t) alone (--strategy s,t),
// weighted or, with --unweighted, as it would be without MIS.
struct Strategies {
  int s = -1, t = -1;      // −1: every strategy
  bool unweighted = false; // weight 1 instead of the MIS weight
  // The weight an estimate of strategy (s, t) enters the image with, given its MIS weight.
  Real weight(int ss, int tt, double mis) const
  {
    if (s >= 0 && (ss != s || tt != t))
      return 0;
    return unweighted ? 1 : Real(mis);
  }
};
/// [options]

/// [mis]
// The power heuristic's exponent applied to a ratio of pdfs: every weight below is 1 / Σ of these. They square
// lengths and densities, so they are reckoned in double even in the float build (where a length of 1e10 squared
// twice, or a small density's inverse squared, is infinite and the weight NaN); only the weight becomes a Real.
double mis(double ratio) { return ratio * ratio; }

// A subpath as it grows, and what its last vertex x_i (reached from x_{i−1}) needs for the weights (Georgiev's
// eqs. 31-33, without the merging):
//   dVCM: the ratio the strategy that connects at x_{i−1} brings (its density of x_{i−1} over this subpath's), made
//         a density per unit area at x_i once the edge's length and cosine are known;
//   dVC:  the sum of the ratios of every strategy further back, carried from vertex to vertex.
// Both are sums of mis(ratio) terms, so the weight of a connection is 1 / (1 + wLight + wCamera), each side's sum
// made of its running sums in O(1).
struct SubpathState {
  Color beta{1};  // throughput: the path's contribution so far over its pdf
  double dVCM = 0; // see above
  double dVC = 0;  // see above
};

// Updates the running sums at a new vertex, reached over `distance` and seen at |cos| `cosHit` from the last edge.
void arrive(SubpathState& state, Real distance, Real cosHit)
{
  state.dVCM *= mis(double(distance) * distance) / mis(cosHit);
  state.dVC /= mis(cosHit);
}

// Updates the running sums when the subpath leaves a vertex along a direction its BSDF sampled: `bs`, with `revPdf`
// the pdf of the opposite walk (from wi back to wo) and cosOut = |cosθ| of the new direction.
void leave(SubpathState& state, const BsdfSample& bs, Real revPdf)
{
  const Real cosOut = std::abs(bs.wi.z);
  if (bs.specular) {
    // A delta vertex: no strategy connects here; its pdfs are the same both ways and cancel.
    state.dVCM = 0;
    state.dVC *= mis(cosOut);
  } else {
    state.dVC = mis(double(cosOut) / bs.pdf) * (state.dVC * mis(revPdf) + state.dVCM);
    state.dVCM = mis(1 / double(bs.pdf));
  }
  state.beta *= bs.weight();
}
/// [mis]

// A vertex of the light subpath where connections can end (not a delta surface).
struct LightVertex {
  Hit hit;          // where
  Vec3 toPrevious;  // unit world direction towards the vertex before it (where its light comes from)
  SubpathState state;
  int s;            // light vertices of the subpath that ends here (y₀ alone: s = 1)
};

// The camera's density of a primary ray at cosine `cosAtCamera` to the view direction, per steradian: a pixel sample is
// uniform on the pixel's square, of area 1 on the plane at unitPixelDistance d, so the density is d²/cos³θ.
Real primaryRayPdf(const Camera& camera, Real cosAtCamera)
{
  const Real toPlane = camera.unitPixelDistance() / cosAtCamera; // from the eye to the image point
  return toPlane * toPlane / cosAtCamera;
}

// The radiance `trace` and the splats find, with what they need.
struct Context {
  const Scene& scene;
  const LightSampler& lights;
  const Strategies& strategies;
  Splats& splats;
  Sampler& sampler;
  int maxEdges;      // the longest path in edges (--max-depth + 1)
  Real lightPaths;   // light subpaths per pass: one per pixel
};

// A light subpath leaves its emitter from a face chosen with this probability, in a direction cosine-weighted on it:
// a triangle emits from both faces (½ each); a sphere's light subpaths leave from its outside only, since its inside
// is seen only by a camera inside it, where s = 0 and s = 1 find that light alone (a weight then knows that no light
// subpath could make the path: the probability is 0). `cosOutward`: the direction's cosine with the surface's
// outward (sphere) or front (triangle) normal.
Real faceProbability(const Scene& scene, int primitive, Real cosOutward)
{
  if (std::size_t(primitive) < scene.spheres.size())
    return cosOutward > 0 ? 1 : 0;
  return Real(0.5);
}

// The density with which a light subpath starts at `point` on emitter `primitive` and leaves along `direction`
// (unit, world): the emitter's choice over its area, times the face's probability and the cosine-weighted direction's
// density (per unit area and per steradian).
Real emissionPdf(const Context& c, int primitive, const Vec3& point, const Vec3& direction)
{
  const Real cosOutward = glm::dot(c.lights.normalAt(primitive, point), direction);
  return c.lights.probability(primitive) / c.lights.area(primitive) *
         faceProbability(c.scene, primitive, cosOutward) * std::abs(cosOutward) * kInvPi;
}

// Russian roulette on either subpath after kRouletteMinBounces bounces: true when the path ends. (Its probabilities
// are left out of the MIS weights, as pbrt does: the weights still sum to 1 over the strategies, so nothing is biased.)
bool roulette(SubpathState& state, int bounce, Sampler& sampler)
{
  if (bounce < kRouletteMinBounces)
    return false;
  const Real q = rouletteSurvival(state.beta);
  if (sampler.next1D() >= q)
    return true;
  state.beta /= q;
  return false;
}

// Both subpaths go on alike from `hit` (wo, local: towards where the subpath came from): the BSDF samples the next
// direction, the running sums follow it, Russian roulette may end the subpath after `bounce` bounces. Returns the
// next ray, or nothing when the subpath ends.
std::optional<Ray> scatter(const Context& c, SubpathState& state, const Hit& hit, const Frame& frame, const Vec3& wo,
                           int bounce)
{
  const Material& m = c.scene.materials[std::size_t(hit.material)];
  const Real uChoice = c.sampler.next1D();
  const std::optional<BsdfSample> bs = bsdfSample(m, wo, c.sampler.next2D(), uChoice);
  if (!bs)
    return std::nullopt;
  leave(state, *bs, bs->specular ? bs->pdf : bsdfPdf(m, bs->wi, wo));
  if (state.beta == Color(0) || roulette(state, bounce, c.sampler))
    return std::nullopt;
  return spawnRay(hit, frame.toWorld(bs->wi));
}

/// [lightTracing]
// t = 1: the light vertex `v` joined to the eye. Its light lands in the pixel it projects to, divided by the
// number of light subpaths of the pass, since every one of them could have splatted there.
void connectToCamera(const Context& c, const LightVertex& v)
{
  const Camera& camera = c.splats.camera();
  const std::optional<Vec2> film = camera.project(v.hit.point);
  if (!film)
    return;
  Vec3 toEye = camera.eye() - v.hit.point;
  const Real distance2 = glm::dot(toEye, toEye);
  toEye /= std::sqrt(distance2);
  const Material& m = c.scene.materials[std::size_t(v.hit.material)];
  const Frame frame = Frame::fromNormal(v.hit.normal);
  const Vec3 wo = frame.toLocal(toEye), wi = frame.toLocal(v.toPrevious);
  const Color f = bsdfEval(m, wo, wi);
  if (f == Color(0))
    return;
  // The camera's density of this vertex per unit area: a pixel has area 1 on the plane at unitPixelDistance, so a
  // primary ray at angle θ to the view direction has density d²/cos³θ per steradian; × |cos at the vertex| / r².
  const Real cameraPdfA = primaryRayPdf(camera, glm::dot(camera.basis().w, toEye)) * std::abs(wo.z) / distance2;
  const double wLight = mis(double(cameraPdfA) / c.lightPaths) * (v.state.dVCM + v.state.dVC * mis(bsdfPdf(m, wo, wi)));
  const Real weight = c.strategies.weight(v.s, 1, 1 / (1 + wLight));
  if (weight == 0 || c.scene.occluded(spawnRayTo(v.hit, camera.eye())))
    return;
  c.splats.add(*film, weight * v.state.beta * f * (cameraPdfA / c.lightPaths));
}
/// [lightTracing]

/// [lightSubpath]
// The light subpath: a light chosen by power, a point uniform on its area, a cosine-weighted direction from one of
// its faces (faceProbability), then bounces as the camera subpath makes them. Every non-delta vertex is kept for
// the connections and joined to the eye at once (t = 1).
std::vector<LightVertex> traceLightSubpath(const Context& c)
{
  std::vector<LightVertex> vertices;
  const Real uLight = c.sampler.next1D();
  const Vec2 uPoint = c.sampler.next2D(), uDirection = c.sampler.next2D();
  const Real uSide = c.sampler.next1D();
  const std::optional<EmitterPoint> y0 = c.lights.sampleEmitterPoint(uLight, uPoint);
  if (!y0 || c.maxEdges < 2) // (y₀ alone makes no path: the eye does not see the light's own point through it)
    return vertices;
  const bool back = faceProbability(c.scene, y0->hit.primitive, -1) > 0 && uSide < Real(0.5);
  const Vec3 n = back ? -y0->hit.normal : y0->hit.normal;
  const Vec3 local = sampleCosineHemisphere(uDirection);
  if (!(local.z > 0))
    return vertices;
  const Real cosLight = local.z;
  const Vec3 direction = Frame::fromNormal(n).toWorld(local);
  const Real emissionPdfW = emissionPdf(c, y0->hit.primitive, y0->hit.point, direction); // the point and direction
  SubpathState state;
  state.beta = y0->Le * cosLight / emissionPdfW;
  state.dVC = mis(double(cosLight) / emissionPdfW);
  Ray ray = spawnRay(y0->hit, direction);

  for (int s = 2;; ++s) {
    const std::optional<Hit> hit = c.scene.intersect(ray);
    if (!hit)
      break;
    const Real cosHit = std::abs(glm::dot(hit->normal, ray.direction));
    if (s == 2) {
      // y₁: the strategy s = 1 would have chosen y₀ from here by the light sampler's solid-angle density, so the
      // ratio it brings is known only now: p_conn(y₀)/p_emit(y₀), both per unit area.
      const Real directPdfW = c.lights.pdf(hit->point, y0->hit.primitive, y0->hit.point);
      state.dVCM = mis(double(directPdfW) * cosLight / (double(emissionPdfW) * cosHit));
      state.dVC /= mis(cosHit);
    } else {
      arrive(state, hit->t, cosHit);
    }
    const Material& m = c.scene.materials[std::size_t(hit->material)];
    const bool delta = m.type == MaterialType::Mirror || m.type == MaterialType::Glass;
    if (!delta) {
      vertices.push_back({*hit, -ray.direction, state, s});
      connectToCamera(c, vertices.back());
    }
    if (s >= c.maxEdges)
      break;
    // The light path samples the BSDF with wo the direction its light came from.
    const Frame frame = Frame::fromNormal(hit->normal);
    const std::optional<Ray> next = scatter(c, state, *hit, frame, frame.toLocal(-ray.direction), s - 2);
    if (!next)
      break;
    ray = *next;
  }
  return vertices;
}
/// [lightSubpath]

/// [connections]
// s = 0: the camera subpath has hit emitter `hit` (at camera vertex t ≥ 3) from `previous`; `state` has arrived.
// The other strategies that make this path: s = 1 from `previous` (the light sampler's density), and every s ≥ 2
// (the emission's density, then the running sum).
Real weightHitLight(const Context& c, const SubpathState& state, const Hit& hit, const Vec3& previous, Real cosLight)
{
  const Vec3 d = hit.point - previous;
  const double directPdfA =
      double(c.lights.pdf(previous, hit.primitive, hit.point)) * cosLight / glm::dot(glm::dvec3(d), glm::dvec3(d));
  const Real emissionPdfW = emissionPdf(c, hit.primitive, hit.point, -d / std::sqrt(glm::dot(d, d)));
  return Real(1 / (1 + mis(directPdfA) * state.dVCM + mis(emissionPdfW) * state.dVC));
}

// s = 1: next-event estimation from camera vertex `hit` (wo towards the eye, local), as in chapter 7.
Color connectToLight(const Context& c, const SubpathState& state, const Hit& hit, const Frame& frame, const Vec3& wo,
                     int t)
{
  const Real uLight = c.sampler.next1D();
  const Vec2 u = c.sampler.next2D();
  const std::optional<LightSample> ls = c.lights.sample(hit.point, uLight, u);
  if (!ls)
    return Color(0);
  const Material& m = c.scene.materials[std::size_t(hit.material)];
  const Vec3 wi = frame.toLocal(ls->wi);
  const Color f = bsdfEval(m, wo, wi);
  if (f == Color(0))
    return Color(0);
  Real weight = 1; // a point light: only this strategy finds it
  if (!ls->delta) {
    // The light's point is where the shadow ray meets it (LightSample::target may be the shaded point itself when
    // that lies on the emitter, as on the inside of a glowing sphere).
    const Ray toLight = spawnRay(hit, ls->wi);
    const std::optional<Real> along = c.scene.intersectPrimitive(toLight, ls->primitive);
    if (!along)
      return Color(0);
    const Vec3 y0 = toLight.at(*along);
    const Real cosAtLight = std::abs(glm::dot(c.lights.normalAt(ls->primitive, y0), ls->wi));
    const Real emissionPdfW = emissionPdf(c, ls->primitive, y0, -ls->wi);
    // Against s = 0 (the BSDF's direction) and every s ≥ 2 (the light subpath from the same point, its ratio made
    // of solid-angle densities at both ends, whose distance terms cancel).
    const double wLight = mis(double(bsdfPdf(m, wo, wi)) / ls->pdf);
    const double wCamera = mis(double(emissionPdfW) * std::abs(wi.z) / (double(ls->pdf) * cosAtLight)) *
                           (state.dVCM + state.dVC * mis(bsdfPdf(m, wi, wo)));
    weight = Real(1 / (1 + wLight + wCamera));
  }
  weight = c.strategies.weight(1, t, weight);
  if (weight == 0 || !lightVisible(c.scene, hit, *ls))
    return Color(0);
  return weight * state.beta * f * std::abs(wi.z) * ls->Li / ls->pdf;
}

// s ≥ 2, t ≥ 2: camera vertex `hit` (wo towards the eye, local) joined to light vertex `v` by a shadow ray.
Color connectVertices(const Context& c, const SubpathState& state, const Hit& hit, const Frame& frame,
                      const Vec3& wo, const LightVertex& v, int t)
{
  Vec3 d = v.hit.point - hit.point;
  const Real distance2 = glm::dot(d, d);
  if (!(distance2 > 0))
    return Color(0);
  d /= std::sqrt(distance2);
  const Material& mc = c.scene.materials[std::size_t(hit.material)];
  const Material& ml = c.scene.materials[std::size_t(v.hit.material)];
  const Vec3 wiCamera = frame.toLocal(d);
  const Frame lightFrame = Frame::fromNormal(v.hit.normal);
  const Vec3 woLight = lightFrame.toLocal(-d), wiLight = lightFrame.toLocal(v.toPrevious);
  const Color fCamera = bsdfEval(mc, wo, wiCamera);
  const Color fLight = bsdfEval(ml, woLight, wiLight);
  if (fCamera == Color(0) || fLight == Color(0))
    return Color(0);
  const Real cosCamera = std::abs(wiCamera.z), cosLight = std::abs(woLight.z);
  // Each side's density of the other's vertex, per unit area: how the other strategies would have made this edge.
  const double cameraPdfA = double(bsdfPdf(mc, wo, wiCamera)) * cosLight / distance2;
  const double lightPdfA = double(bsdfPdf(ml, wiLight, woLight)) * cosCamera / distance2;
  const double wLight = mis(cameraPdfA) * (v.state.dVCM + v.state.dVC * mis(bsdfPdf(ml, woLight, wiLight)));
  const double wCamera = mis(lightPdfA) * (state.dVCM + state.dVC * mis(bsdfPdf(mc, wiCamera, wo)));
  const Real weight = c.strategies.weight(v.s, t, 1 / (1 + wLight + wCamera));
  if (weight == 0 || c.scene.occluded(spawnRayTo(hit, v.hit)))
    return Color(0);
  return weight * state.beta * fCamera * fLight * v.state.beta * (cosCamera * cosLight / distance2);
}
/// [connections]

/// [trace]
// One sample: a light subpath (joined to the eye on the way), then the camera subpath from `primary`, which at
// every vertex hits emitters (s = 0), samples a light (s = 1) and joins every stored light vertex (s ≥ 2).
Color trace(const Context& c, const Ray& primary)
{
  const std::vector<LightVertex> lightPath = traceLightSubpath(c);

  // The camera subpath starts with the eye's own density: a pixel sample uniform on its unit square.
  const Camera& camera = c.splats.camera();
  const Real cosAtCamera = -glm::dot(camera.basis().w, primary.direction);
  SubpathState state;
  state.dVCM = mis(double(c.lightPaths) / primaryRayPdf(camera, cosAtCamera));
  Color L(0);
  Ray ray = primary;
  Vec3 previous = primary.origin;
  for (int t = 2;; ++t) {
    const std::optional<Hit> hit = c.scene.intersect(ray);
    if (!hit) {
      // Only the camera subpath finds the background or the environment.
      L += c.strategies.weight(0, t, 1) * state.beta * c.scene.escaped(ray.direction);
      break;
    }
    const Real cosHit = std::abs(glm::dot(hit->normal, ray.direction));
    arrive(state, hit->t, cosHit);
    const Material& m = c.scene.materials[std::size_t(hit->material)];
    if (m.isEmissive())
      L += c.strategies.weight(0, t, t == 2 ? 1 : weightHitLight(c, state, *hit, previous, cosHit)) * state.beta *
           m.emission;
    if (t - 1 >= c.maxEdges)
      break;
    const Frame frame = Frame::fromNormal(hit->normal);
    const Vec3 wo = frame.toLocal(-ray.direction);
    const bool delta = m.type == MaterialType::Mirror || m.type == MaterialType::Glass;
    if (!delta) {
      L += connectToLight(c, state, *hit, frame, wo, t);
      for (const LightVertex& v : lightPath)
        if (v.s + t - 1 <= c.maxEdges)
          L += connectVertices(c, state, *hit, frame, wo, v, t);
    }
    const std::optional<Ray> next = scatter(c, state, *hit, frame, wo, t - 2);
    if (!next)
      break;
    previous = hit->point;
    ray = *next;
  }
  return L;
}
/// [trace]

int main(int argc, char** argv)
{
  /// [chapter]
  const ChapterInfo chapter{.binary = "step13_bdpt",
                            .defaultScene = "caustics.json",
                            .uses = kUsesSpheres | kUsesColors | kUsesPointLights | kUsesBackground |
                                    kUsesEnvironment | kUsesEmission |
                                    kUsesMirror | kUsesGlass | kUsesGlossy | kUsesMaxDepth,
                            .pixelSampling = PixelSampling::Jittered,
                            .defaultSpp = 16,
                            .defaultMaxDepth = -1,
                            .options = {{.name = "--strategy",
                                         .kind = OptionKind::IntegerList,
                                         .help = "s,t: one strategy's weighted image alone (s light vertices, t >= 1 "
                                                 "camera vertices); default: every strategy, weighted by MIS",
                                         .min = 0,
                                         .max = 1000},
                                        {.name = "--unweighted",
                                         .kind = OptionKind::Flag,
                                         .help = "with --strategy: that strategy without its MIS weight"}}};
  /// [chapter]
  // The light sampler is built once per scene and shared, read-only, by every thread.
  return runSplattingChapter(argc, argv, chapter, [](const Scene& scene, const ChapterOptions& options) {
    Strategies strategies;
    if (options.given("--strategy")) {
      const std::vector<long long> st = options.integers("--strategy");
      if (st.size() != 2 || st[1] < 1)
        throw UsageError("--strategy takes s,t with s >= 0 light vertices and t >= 1 camera vertices");
      strategies.s = int(st[0]);
      strategies.t = int(st[1]);
    }
    strategies.unweighted = options.flag("--unweighted");
    if (strategies.unweighted && strategies.s < 0)
      throw UsageError("--unweighted needs --strategy s,t (the strategies unweighted would count each path several "
                       "times)");
    return SplatTraceFunction([strategies, lights = LightSampler(scene)](const Scene& s, const Ray& ray,
                                                                         Sampler& sampler, int maxDepth,
                                                                         Splats& splats) {
      const Camera& camera = splats.camera();
      const Context c{s,       lights,
                      strategies, splats,
                      sampler, maxDepth < 0 ? INT_MAX : maxDepth + 1,
                      Real(camera.width()) * Real(camera.height())};
      return trace(c, ray);
    });
  });
}

// Chapter 16 — making it faster on the CPU: chapter 8's estimator as a wavefront of paths.
//
// Chapters 1 to 13 follow one path at a time: trace a ray, shade the hit, trace the next ray, all for one pixel
// sample before the next begins. That reads well, and chapter 9 made it about as fast as one path at a time goes.
// But a modern core does eight or sixteen floating-point operations in one instruction (SIMD), and one path has
// nothing to put beside its own arithmetic: the lanes stay idle.
// So this chapter keeps chapter 8's estimator (light sampling and BSDF sampling weighted by MIS, the same lights,
// materials and pdfs) and changes only how the work is organised. Many paths are in flight at once, a wavefront,
// stored field by field (all the rays' origins' x side by side, then their y, ...), and each step of the estimator
// is a stage that runs over the whole wavefront before the next stage begins:
//   generate → extend (nearest hit) → shade (grouped by material: light sample, BSDF sample, roulette)
//            → connect (shadow rays) → back to extend with the paths that go on.
// Inside a stage the same arithmetic is done for every path, so it runs one path per SIMD lane (render/ray_stream.h:
// eight doubles to a register with AVX-512). Each stage could be a GPU kernel as it stands (chapter 17 makes them so).
// A path's random numbers are still its own (seed, pixel, sample), drawn in chapter 8's order, and the kernels do the
// scalar code's arithmetic operation for operation, so the image is chapter 8's, bit for bit, for any thread count
// and any wavefront size.
#include "core/frame.h"
#include "core/sampling.h"
#include "geometry/light_buffer.h"
#include "render/guided_lights.h"
#include "render/ray_stream.h"
#include "render/runner.h"
#include "scene/light_sampling.h"
#include "scene/scene_plan.h"
#include "shading/bsdf.h"

#include <algorithm>
#include <array>
#include <cstdint>
#include <iostream>
#include <memory>
#include <numeric>
#include <optional>
#include <span>
#include <vector>

using namespace raylife;

// Makes `v` hold at least n entries. The queues only grow: what they hold past the paths in flight is left as it is,
// so a wavefront neither frees nor clears memory that the next one uses again.
template <class T> void atLeast(std::vector<T>& v, std::size_t n)
{
  if (v.size() < n)
    v.resize(n);
}

/// [paths]
// Every path in flight, stored field by field (structure of arrays): path i is entry i of every array. A stage
// reads a field of many paths in a row, which is one load per SIMD register and whole cache lines of use.
struct Paths {
  RayStream ray;                        // the ray the path follows next (origin, direction, tmax)
  std::vector<Real> time;               // that ray's time (motion blur)
  std::vector<Color> beta;              // the throughput: the product of f·|cosθ|/pdf so far
  std::vector<Sampler> sampler;         // the path's random numbers, keyed by (seed, pixel, sample)
  std::vector<std::uint8_t> specular;   // the last bounce was the camera or a delta lobe (MIS weight 1)
  std::vector<Real> bsdfPdf;            // the pdf with which the last vertex's BSDF chose the ray
  std::vector<Vec3> from;               // that vertex
  std::vector<std::uint32_t> slot;      // where its radiance goes: its pixel sample's index
  std::size_t count = 0;                // paths in flight: entries [0, count) of each array

  std::size_t size() const { return count; }
  void resize(std::size_t n)
  {
    if (n > time.size()) {
      ray.resize(n), time.resize(n), beta.resize(n), sampler.resize(n, Sampler(0, 0, 0, 0)), specular.resize(n),
          bsdfPdf.resize(n), from.resize(n), slot.resize(n);
    }
    count = n;
  }
};
/// [paths]

/// The shadow rays of one round, with the light each would add if it gets through (connect's queue): entries
/// [0, size()) of the arrays, which keep their length from round to round (a path adds at most one a round).
struct ShadowRays {
  RayStream ray;
  std::vector<Color> light;
  std::vector<std::uint32_t> slot;
  std::vector<Real> time;
  std::size_t count = 0;
  std::size_t size() const { return count; }
  // Empties the queue, with room for `n` rays.
  void clear(std::size_t n)
  {
    count = 0;
    if (ray.size() < n)
      ray.resize(n), light.resize(n), slot.resize(n), time.resize(n);
  }
  void push(const Ray& r, const Color& L, std::uint32_t s)
  {
    ray.set(count, r);
    light[count] = L, slot[count] = s, time[count] = r.time;
    ++count;
  }
};

/// The shadow rays of one round to one point light that its light buffer answers (connect's queue for that light),
/// each with the buffer's cell it starts in: like ShadowRays, entries [0, size()). Each light's queue grows as its
/// rays come, to the most it has had in a round: a scene's many lights do not each keep room for every path.
struct BufferedShadowRays {
  RayStream ray;
  std::vector<Color> light;
  std::vector<std::uint32_t> slot;
  std::vector<LaneIndex> cellFirst, cellSize;
  std::vector<std::uint8_t> blocked; // (connect's answers)
  std::size_t count = 0;
  std::size_t size() const { return count; }
  void clear() { count = 0; }
  void grow()
  {
    const std::size_t n = std::max<std::size_t>(64, 2 * count);
    ray.resize(n), light.resize(n), slot.resize(n), cellFirst.resize(n), cellSize.resize(n), blocked.resize(n);
  }
  void push(const Ray& r, const Color& L, std::uint32_t s, LightBuffer::CellRange cell)
  {
    if (count == ray.size()) [[unlikely]]
      grow();
    ray.set(count, r);
    light[count] = L, slot[count] = s, cellFirst[count] = cell.first, cellSize[count] = cell.size;
    ++count;
  }
};

/// The camera rays' places on the film by coordinate: generate's input to pinholeDirections (and extend's, to find
/// each camera ray's block of pixels), and the pinhole camera they come from (null for rays through a lens); and
/// generate's input to pixelSamplers, the keys, and its output, the samples' generators.
struct FilmColumns {
  const Camera* camera = nullptr;
  std::vector<Real> x, y, offsetX, offsetY, strata;
  std::vector<std::int32_t> keyX, keyY, keySample;
  std::vector<std::uint64_t> state, increment;
  void resize(std::size_t n)
  {
    for (std::vector<Real>* v : {&x, &y, &offsetX, &offsetY, &strata})
      atLeast(*v, n);
    atLeast(keyX, n), atLeast(keyY, n), atLeast(keySample, n), atLeast(state, n), atLeast(increment, n);
  }
};

/// The sphere hits of a round by coordinate: extend's input to sphereHitPoints and its output.
struct SphereHitColumns {
  std::vector<std::uint32_t> path; // which path each entry is
  std::vector<Real> ox, oy, oz, dx, dy, dz, t, cx, cy, cz, radius, px, py, pz, nx, ny, nz, ex, ey, ez;
  void resize(std::size_t n)
  {
    atLeast(path, n);
    for (std::vector<Real>* v : {&ox, &oy, &oz, &dx, &dy, &dz, &t, &cx, &cy, &cz, &radius, &px, &py, &pz, &nx, &ny,
                                 &nz, &ex, &ey, &ez})
      atLeast(*v, n);
  }
};

/// The triangle hits of a round by coordinate: extend's input to triangleHitPoints and its output.
struct TriangleHitColumns {
  std::vector<std::uint32_t> path; // which path each entry is
  std::vector<Real> ox, oy, oz, dx, dy, dz, tmax, ax, ay, az, bx, by, bz, cx, cy, cz, px, py, pz, ex, ey, ez, gx, gy,
      gz, b0, b1, b2;
  void resize(std::size_t n)
  {
    atLeast(path, n);
    for (std::vector<Real>* v : {&ox, &oy, &oz, &dx, &dy, &dz, &tmax, &ax, &ay, &az, &bx, &by, &bz, &cx, &cy, &cz, &px,
                                 &py, &pz, &ex, &ey, &ez, &gx, &gy, &gz, &b0, &b1, &b2})
      atLeast(*v, n);
  }
};

/// The light samples towards still spheres of a round by coordinate: shade's input to sphereLightDirections,
/// surfaceLightSamples and shadowRaysToSpheres, and their output.
struct SphereLightColumns {
  std::vector<std::uint32_t> path; // which path each entry is
  // The guided ones among them (entry guided[g] is the g-th): the light guide's tree (GuideLanes::root), its
  // uniform share, the numbers as drawn, and guidedWarps' output.
  std::vector<std::uint32_t> guided;
  std::vector<SampleForestIndex> root;
  std::vector<Real> alpha, v1, v2, w1, w2, density;
  std::vector<Real> px, py, pz, cx, cy, cz, radius, u1, u2, choice, guide, wx, wy, wz, pdf; // the directions
  std::vector<Real> nx, ny, nz, dx, dy, dz, betaR, betaG, betaB, rhoR, rhoG, rhoB, leR, leG, leB, exponent, lightR,
      lightG, lightB, useful;                                                             // the light they bring
  std::vector<Real> ex, ey, ez, gx, gy, gz, ox, oy, oz, t;                                // the shadow rays
  void resize(std::size_t n)
  {
    atLeast(path, n), atLeast(guided, n), atLeast(root, n), atLeast(exponent, n);
    for (std::vector<Real>* v : {&alpha, &v1, &v2, &w1, &w2, &density})
      atLeast(*v, n);
    for (std::vector<Real>* v : {&px,    &py,    &pz,    &cx,    &cy,    &cz,     &radius, &u1,     &u2,
                                 &choice, &guide, &wx,   &wy,    &wz,    &pdf,    &nx,     &ny,     &nz,
                                 &dx,    &dy,    &dz,    &betaR, &betaG, &betaB,  &rhoR,   &rhoG,   &rhoB,
                                 &leR,   &leG,   &leB,   &lightR, &lightG, &lightB, &useful, &ex,   &ey,
                                 &ez,    &gx,    &gy,    &gz,    &ox,    &oy,     &oz,     &t})
      atLeast(*v, n);
  }
};

/// The light samples towards point lights of a round by coordinate: shade's input to pointLightRays and
/// surfaceLightSamples, and their output.
struct PointLightColumns {
  std::vector<std::uint32_t> path; // which path each entry is
  std::vector<std::int32_t> light; // and which light it samples (its number in the scene)
  std::vector<Real> px, py, pz, ex, ey, ez, gx, gy, gz, lx, ly, lz, iR, iG, iB; // the points and their lights
  std::vector<Real> wx, wy, wz, liR, liG, liB, ox, oy, oz, t, arrives;        // the arrivals and shadow rays
  std::vector<Real> nx, ny, nz, dx, dy, dz, choice, betaR, betaG, betaB, rhoR, rhoG, rhoB, exponent, lightR, lightG,
      lightB, useful; // the light they bring
  void resize(std::size_t n)
  {
    atLeast(path, n), atLeast(light, n), atLeast(exponent, n);
    for (std::vector<Real>* v : {&px, &py, &pz, &ex, &ey, &ez, &gx, &gy, &gz, &lx, &ly, &lz, &iR, &iG, &iB, &wx, &wy,
                                 &wz, &liR, &liG, &liB, &ox, &oy, &oz, &t, &arrives, &nx, &ny, &nz, &dx, &dy, &dz,
                                 &choice, &betaR, &betaG, &betaB, &rhoR, &rhoG, &rhoB, &lightR, &lightG, &lightB,
                                 &useful})
      atLeast(*v, n);
  }
};

/// The light samples towards triangles of a round by coordinate: shade's input to triangleLightDirections and
/// surfaceLightSamples, and their output.
struct TriangleLightColumns {
  std::vector<std::uint32_t> path; // which path each entry is
  std::vector<Real> px, py, pz, ax, ay, az, bx, by, bz, cx, cy, cz, u1, u2, wx, wy, wz, solidAnglePdf; // directions
  std::vector<Real> choice, guide, pdf, nx, ny, nz, dx, dy, dz, betaR, betaG, betaB, rhoR, rhoG, rhoB, leR, leG, leB,
      exponent, lightR, lightG, lightB, useful;                       // the light they bring
  std::vector<Real> ex, ey, ez, gx, gy, gz, ox, oy, oz, t; // the shadow rays
  void resize(std::size_t n)
  {
    atLeast(path, n), atLeast(exponent, n);
    for (std::vector<Real>* v : {&px,    &py,    &pz,    &ax,    &ay,    &az,     &bx,     &by,     &bz,
                                 &cx,    &cy,    &cz,    &u1,    &u2,    &wx,     &wy,     &wz,     &solidAnglePdf,
                                 &choice, &guide, &pdf,  &nx,    &ny,    &nz,     &dx,     &dy,     &dz,
                                 &betaR, &betaG, &betaB, &rhoR,  &rhoG,  &rhoB,   &leR,    &leG,    &leB,
                                 &lightR, &lightG, &lightB, &useful, &ex,  &ey,     &ez,     &gx,     &gy,
                                 &gz,    &ox,    &oy,    &oz,    &t})
      atLeast(*v, n);
  }
};

/// Camera rays come in blocks of kBlock × kBlock pixels (extend), each tested against the spheres it may see, which
/// are found among those its region of kRegion × kRegion blocks may see, found among the scene's (in a scene of at
/// most kMostCulledSpheres: finding them costs each region a pass over the spheres). A block that may see more than
/// kMostBlockSpheres sends its rays through the tree's packets instead: the kernel's time grows with the spheres.
constexpr int kBlock = 8;
constexpr int kRegion = 8;
constexpr std::size_t kMostCulledSpheres = 4096;
constexpr std::size_t kMostBlockSpheres = 32;
/// Shadow rays towards a point light go through its light buffer (connect), with this many cells on a cube face's
/// side, when they start within four times the light's distance from the eye.
constexpr int kLightBufferCells = 128;

/// The spheres a block (or a region) of pixels may see (PinholeFrustum::mayMeet): their numbers in the scene, in its
/// order, and for a block the kernel's list of them (unless `packets`: too many).
struct BlockSpheres {
  bool ready = false;
  bool packets = false;
  std::vector<std::int32_t> index;
  SphereList list;
};

/// The queues and scratch arrays of one wavefront, kept from round to round (a round allocates nothing once the
/// first has sized them).
struct Queues {
  Paths paths;
  Paths next; // shade: the paths that go on, side by side, for the next round (then swapped with `paths`)
  FilmColumns film; // generate: where on the film each camera ray goes
  // extend → shade: the nearest hit of every path's ray; found[i] says whether path i hit anything.
  std::vector<Hit> hit;
  std::vector<std::uint8_t> found;
  std::vector<Real> t;                 // where each ray hits,
  std::vector<std::int32_t> primitive; // and what (a primitive's number; −1: nothing)
  std::vector<BlockSpheres> blocks, regions;  // (camera rays: each block's spheres, found the first time it comes)
  std::vector<Ray> rays;                      // (camera rays, for the tree's packets)
  std::vector<std::optional<BvhHit>> hits;    // (and their answers)
  SphereHitColumns sphereHits;      // and the hit records' points, normals and error bounds
  TriangleHitColumns triangleHits;  // (on triangles too)
  SphereLightColumns sphereLights;  // shade: light samples towards still spheres
  PointLightColumns pointLights;    // and towards point lights
  TriangleLightColumns triangleLights; // and towards triangles
  // shade: the paths grouped by material (those shaded in the lanes: the diffuse ones, then the glossy ones; the
  // mirrors and glass; the others).
  std::vector<std::uint32_t> inLanes, glossy, specular, other, grouped;
  // shade's diffuse bounces, then its glossy ones, then its mirror and glass ones, by coordinate (the stream
  // kernels' input and output; `exponent` holds a glossy surface's Phong exponent, a glass's index of refraction).
  std::vector<Real> nx, ny, nz, dx, dy, dz, u1, u2, exponent, wx, wy, wz, cosTheta, pdf, fScale;
  // shade's diffuse and glossy hits' points and the light guide's cell of each (guideCells).
  std::vector<Real> px, py, pz;
  std::vector<SampleForestIndex> cell;
  // shade → connect: shadow rays, and the light each brings if it gets through: those a point light's buffer
  // answers in that light's queue (Stages::lightBuffers' order), the others for the tree (or the stream kernel).
  ShadowRays shadows;
  std::vector<std::uint8_t> blocked;
  std::vector<BufferedShadowRays> buffered;
  // Empties the shadow rays' queues (one for each of `buffers` light buffers), the tree's with room for `n` rays.
  void clearShadows(std::size_t n, std::size_t buffers)
  {
    shadows.clear(n);
    buffered.resize(buffers);
    for (BufferedShadowRays& b : buffered)
      b.clear();
  }
};

/// The light guide's trees (LightSampler::guideTrees) in one table, for warping many light samples' numbers at once
/// (guidedWarps): root[k] is tree k's root in `forest`, or −1 for a tree that learned nothing.
struct GuideLanes {
  SampleForest forest;
  std::vector<SampleForestIndex> root;
  std::vector<SampleForestIndex> cellNumber; // guideCells' table: per cell its number where learned, else −1
  GuideCellGrid grid;
  explicit GuideLanes(const LightSampler& lights)
  {
    for (const SampleTree& tree : lights.guideTrees())
      root.push_back(tree.appendTo(forest));
    const LightSampler::GuideGrid g = lights.guideGrid();
    for (std::size_t k = 0; k < g.learned.size(); ++k)
      cellNumber.push_back(g.learned[k] ? SampleForestIndex(k) : -1);
    grid = {g.min, g.scale, g.size, {}};
  }
  GuideCellGrid cells() const { return {grid.min, grid.scale, grid.size, cellNumber}; }
};

/// What the stages need of the scene: the scene, its lights, and whether its primitives are a flat list of still
/// spheres, which the stream kernels test many rays at a time (else each ray goes through Scene::intersect).
struct Stages {
  const Scene& scene;
  LightSampler lights;
  GuideLanes guide;
  bool sampleLights;
  MisHeuristic heuristic;
  bool sphereKernels;
  bool cameraBlocks; // a tree over still spheres alone: pinhole camera rays go block by block (extend)
  SphereList spheres;
  bool triangleLights; // some triangle emits: its light samples' columns are needed
  std::vector<LightBuffer> lightBuffers; // with cameraBlocks, each point light's (else none): connect's shadow rays
};

/// [generate]
// Stage 1, generate: each pixel sample's camera ray and random numbers, made as every chapter makes them: every
// sample's generator at once, then each one's numbers (where in its pixel its ray goes, and through a lens its ray),
// then through a pinhole every ray's direction at once.
void generate(const PrimaryRays& primary, std::span<const PixelSampleKey> keys, Paths& paths, FilmColumns& film)
{
  const std::size_t n = keys.size();
  paths.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    paths.beta[i] = Color(1);
    paths.specular[i] = 1;
    paths.bsdfPdf[i] = 0;
    paths.from[i] = Vec3(0);
    paths.slot[i] = std::uint32_t(i);
  }
  film.camera = primary.pinhole() ? &primary.camera() : nullptr;
  film.resize(n);
  for (std::size_t i = 0; i < n; ++i)
    film.keyX[i] = keys[i].x, film.keyY[i] = keys[i].y, film.keySample[i] = keys[i].sample;
  pixelSamplers(primary.seed(), {film.keyX, film.keyY, film.keySample}, n, {film.state, film.increment});
  if (!primary.pinhole()) { // (a lens: one ray at a time)
    for (std::size_t i = 0; i < n; ++i) {
      const PixelSampleKey& key = keys[i];
      Sampler& sampler = paths.sampler[i] = Sampler(Pcg32::fromState(film.state[i], film.increment[i]));
      const Ray ray = primary.ray(key.x, key.y, key.sample, sampler, PixelSequence(primary.seed(), key.x, key.y));
      paths.ray.set(i, ray);
      paths.time[i] = ray.time;
    }
    return;
  }
  for (std::size_t i = 0; i < n; ++i) {
    Sampler& sampler = paths.sampler[i] = Sampler(Pcg32::fromState(film.state[i], film.increment[i]));
    const PinholeSample p = primary.pinholeSample(keys[i], sampler);
    paths.time[i] = p.time;
    film.x[i] = Real(keys[i].x), film.y[i] = Real(keys[i].y);
    film.offsetX[i] = p.offset.numerator.x, film.offsetY[i] = p.offset.numerator.y, film.strata[i] = p.offset.strata;
  }
  pinholeDirections(primary.camera(), {film.x, film.y, film.offsetX, film.offsetY, film.strata}, n,
                    {paths.ray.dx, paths.ray.dy, paths.ray.dz});
  const Vec3& eye = primary.camera().eye();
  std::fill_n(paths.ray.ox.begin(), n, eye.x);
  std::fill_n(paths.ray.oy.begin(), n, eye.y);
  std::fill_n(paths.ray.oz.begin(), n, eye.z);
  std::fill_n(paths.ray.tmax.begin(), n, kInfinity);
}
/// [generate]

// The spheres of `from` (numbers in the scene, in its order; all of them where null) that the camera's rays through
// the film rectangle [lo, hi] may meet, into `out`.
void cull(const Scene& scene, const Camera& camera, Vec2 lo, Vec2 hi, const std::vector<std::int32_t>* from,
          std::vector<std::int32_t>& out)
{
  const PinholeFrustum frustum = camera.frustum(lo, hi);
  auto test = [&](std::int32_t k) {
    const Sphere& sphere = scene.spheres[std::size_t(k)];
    if (frustum.mayMeet(sphere.center, sphere.radius))
      out.push_back(k);
  };
  if (from)
    for (const std::int32_t k : *from)
      test(k);
  else
    for (std::size_t k = 0; k < scene.spheres.size(); ++k)
      test(std::int32_t(k));
}

// The spheres block (bx, by) of the image may see, found the first time its rays come (each thread keeps its own),
// among those its region may see.
const BlockSpheres& blockSpheres(const Scene& scene, Queues& q, int bx, int by)
{
  const Camera& camera = *q.film.camera;
  const int across = (camera.width() + kBlock - 1) / kBlock, down = (camera.height() + kBlock - 1) / kBlock;
  const int regionsAcross = (across + kRegion - 1) / kRegion, regionsDown = (down + kRegion - 1) / kRegion;
  if (q.blocks.size() != std::size_t(across) * std::size_t(down)) {
    q.blocks.assign(std::size_t(across) * std::size_t(down), BlockSpheres{});
    q.regions.assign(std::size_t(regionsAcross) * std::size_t(regionsDown), BlockSpheres{});
  }
  // A rectangle of whole blocks, [x0, x1) × [y0, y1) in blocks, on the film (cut at its edges).
  auto film = [&](int x0, int y0, int x1, int y1) {
    return std::pair{Vec2(Real(x0 * kBlock), Real(y0 * kBlock)),
                     Vec2(Real(std::min(x1 * kBlock, camera.width())), Real(std::min(y1 * kBlock, camera.height())))};
  };
  BlockSpheres& b = q.blocks[std::size_t(by) * std::size_t(across) + std::size_t(bx)];
  if (!b.ready) {
    const int rx = bx / kRegion, ry = by / kRegion;
    BlockSpheres& region = q.regions[std::size_t(ry) * std::size_t(regionsAcross) + std::size_t(rx)];
    if (!region.ready) {
      const auto [lo, hi] = film(rx * kRegion, ry * kRegion, (rx + 1) * kRegion, (ry + 1) * kRegion);
      cull(scene, camera, lo, hi, nullptr, region.index);
      region.ready = true;
    }
    const auto [lo, hi] = film(bx, by, bx + 1, by + 1);
    cull(scene, camera, lo, hi, &region.index, b.index);
    b.packets = b.index.size() > kMostBlockSpheres;
    if (!b.packets) {
      std::vector<Sphere> seen;
      for (const std::int32_t k : b.index)
        seen.push_back(scene.spheres[std::size_t(k)]);
      b.list = SphereList::from(seen);
    }
    b.ready = true;
  }
  return b;
}

/// [extend]
// Stage 2, extend: the nearest hit of every path's ray. First what each ray hits: in a short list of still spheres
// one ray per lane (the stream kernel); in a tree, camera rays through a pinhole block of pixels by block, against
// the few spheres the block may see (the stream kernel again; with triangles, motion or a lens, in packets of sixteen
// neighbours), the others one ray at a time (chapter 9's walk, which tests a node's eight boxes in the lanes). Then
// the hit records: on still spheres and on triangles many at a time, on moving spheres one by one. (A short list
// with triangles or motion goes through the scene's own query, record and all.)
void extend(const Stages& st, Queues& q, bool cameraRays)
{
  const Scene& scene = st.scene;
  const Paths& paths = q.paths;
  const std::size_t n = paths.size();
  atLeast(q.hit, n), atLeast(q.t, n), atLeast(q.primitive, n);
  q.found.assign(n, 0);
  // Camera rays [first, end) through the tree in packets of sixteen: neighbouring pixels' rays enter nearly the same
  // boxes.
  auto inPackets = [&](std::size_t first, std::size_t end) {
    atLeast(q.rays, n), atLeast(q.hits, n);
    for (std::size_t i = first; i < end; ++i)
      q.rays[i] = paths.ray.get(i, paths.time[i]);
    scene.accelerator.intersectPacket(std::span(q.rays).subspan(first, end - first), std::span(q.hits).subspan(first));
    for (std::size_t i = first; i < end; ++i) {
      q.t[i] = q.hits[i] ? q.hits[i]->t : 0;
      q.primitive[i] = q.hits[i] ? q.hits[i]->primitive : -1;
    }
  };
  if (st.sphereKernels) {
    nearestSpheres(st.spheres, paths.ray, n, q.t, q.primitive);
  } else if (st.cameraBlocks && cameraRays && q.film.camera) {
    // Camera rays through a pinhole, block of pixels by block: a block's rays can meet only the spheres in the
    // pyramid they fill, a few of the scene's, which the stream kernel tests in lanes (the nearest of them, in the
    // scene's order, is the tree's answer: the others none of the rays meets).
    for (std::size_t i = 0; i < n;) {
      const int bx = int(q.film.x[i]) / kBlock, by = int(q.film.y[i]) / kBlock;
      std::size_t end = i + 1;
      while (end < n && int(q.film.x[end]) / kBlock == bx && int(q.film.y[end]) / kBlock == by)
        ++end;
      const BlockSpheres& b = blockSpheres(scene, q, bx, by);
      if (b.packets) {
        inPackets(i, end);
      } else {
        nearestSpheres(b.list, paths.ray, i, end - i, q.t, q.primitive);
        for (std::size_t k = i; k < end; ++k)
          if (q.primitive[k] >= 0)
            q.primitive[k] = b.index[std::size_t(q.primitive[k])];
      }
      i = end;
    }
  } else if (scene.usesAccelerator() && cameraRays) {
    inPackets(0, n);
  } else if (scene.usesAccelerator()) {
    for (std::size_t i = 0; i < n; ++i) {
      const std::optional<BvhHit> h = scene.accelerator.intersect(paths.ray.get(i, paths.time[i]));
      q.t[i] = h ? h->t : 0;
      q.primitive[i] = h ? h->primitive : -1;
    }
  } else {
    for (std::size_t i = 0; i < n; ++i)
      if (const std::optional<Hit> h = scene.intersect(paths.ray.get(i, paths.time[i]))) {
        q.hit[i] = *h;
        q.found[i] = 1;
      }
    return;
  }
  countRays(n);
  SphereHitColumns& h = q.sphereHits;
  TriangleHitColumns& th = q.triangleHits;
  h.resize(n);
  if (!scene.triangles.empty())
    th.resize(n);
  std::size_t m = 0, mt = 0;
  for (std::uint32_t i = 0; i < n; ++i) {
    const int primitive = q.primitive[i];
    if (primitive < 0)
      continue;
    q.found[i] = 1;
    if (std::size_t(primitive) >= scene.spheres.size()) {
      const auto [p0, p1, p2] = scene.triangleVertices(std::size_t(primitive) - scene.spheres.size());
      th.path[mt] = i, th.ox[mt] = paths.ray.ox[i], th.oy[mt] = paths.ray.oy[i], th.oz[mt] = paths.ray.oz[i];
      th.dx[mt] = paths.ray.dx[i], th.dy[mt] = paths.ray.dy[i], th.dz[mt] = paths.ray.dz[i];
      th.tmax[mt] = paths.ray.tmax[i];
      th.ax[mt] = p0.x, th.ay[mt] = p0.y, th.az[mt] = p0.z, th.bx[mt] = p1.x, th.by[mt] = p1.y, th.bz[mt] = p1.z;
      th.cx[mt] = p2.x, th.cy[mt] = p2.y, th.cz[mt] = p2.z;
      ++mt;
      continue;
    }
    if (scene.spheres[std::size_t(primitive)].moving()) {
      q.hit[i] = scene.hitAt(paths.ray.get(i, paths.time[i]), q.t[i], primitive);
      continue;
    }
    const Sphere& s = scene.spheres[std::size_t(primitive)];
    h.path[m] = i, h.t[m] = q.t[i], h.cx[m] = s.center.x, h.cy[m] = s.center.y, h.cz[m] = s.center.z;
    h.radius[m] = s.radius, h.ox[m] = paths.ray.ox[i], h.oy[m] = paths.ray.oy[i], h.oz[m] = paths.ray.oz[i];
    h.dx[m] = paths.ray.dx[i], h.dy[m] = paths.ray.dy[i], h.dz[m] = paths.ray.dz[i];
    ++m;
  }
  // The sphere hits' points, normals and error bounds (sphereSurfacePoint), many at a time.
  sphereHitPoints({h.ox, h.oy, h.oz, h.dx, h.dy, h.dz, h.t, h.cx, h.cy, h.cz, h.radius}, m,
                  {h.px, h.py, h.pz, h.nx, h.ny, h.nz, h.ex, h.ey, h.ez});
  for (std::size_t k = 0; k < m; ++k) {
    const std::uint32_t i = h.path[k];
    Hit& hit = q.hit[i];
    hit.t = h.t[k];
    hit.point = Vec3(h.px[k], h.py[k], h.pz[k]);
    hit.normal = hit.geometricNormal = Vec3(h.nx[k], h.ny[k], h.nz[k]);
    hit.pointError = Vec3(h.ex[k], h.ey[k], h.ez[k]);
    hit.primitive = q.primitive[i];
    hit.material = scene.spheres[std::size_t(q.primitive[i])].material;
    hit.time = paths.time[i];
  }
  // The triangle hits' points, error bounds and normals (as the scene's record makes them), many at a time; a smooth
  // mesh's shading normal, from the barycentrics, one by one.
  triangleHitPoints({th.ox, th.oy, th.oz, th.dx, th.dy, th.dz, th.tmax, th.ax, th.ay, th.az, th.bx, th.by, th.bz, th.cx,
                     th.cy, th.cz},
                    mt, {th.px, th.py, th.pz, th.ex, th.ey, th.ez, th.gx, th.gy, th.gz, th.b0, th.b1, th.b2});
  for (std::size_t k = 0; k < mt; ++k) {
    const std::uint32_t i = th.path[k];
    const std::size_t triangle = std::size_t(q.primitive[i]) - scene.spheres.size();
    Hit& hit = q.hit[i];
    hit.t = q.t[i];
    hit.point = Vec3(th.px[k], th.py[k], th.pz[k]);
    hit.geometricNormal = Vec3(th.gx[k], th.gy[k], th.gz[k]);
    hit.normal = scene.triangleShadingNormal(triangle, th.b0[k], th.b1[k], th.b2[k], hit.geometricNormal);
    hit.pointError = Vec3(th.ex[k], th.ey[k], th.ez[k]);
    hit.primitive = q.primitive[i];
    hit.material = scene.triangles[triangle].material;
    hit.time = paths.time[i];
  }
}
/// [extend]

/// [shade]
// Stage 3, shade: at every hit, what chapter 8's loop does at a vertex. Emission found by the BSDF's ray (weighted
// against light sampling); a light sample, whose shadow ray goes to connect's queue with the light it would bring;
// the BSDF sample that continues the path; Russian roulette. The paths are taken grouped by material: the diffuse
// and the glossy ones' light samples and bounces together through the stream kernels, and the mirrors' and glass's
// bounces; the others (metal) one by one. Paths that end are dropped, and those that go on are written side by side
// into the next round's wavefront.
void shade(const Stages& st, int bounce, int maxDepth, Queues& q, std::span<Color> out)
{
  const Scene& scene = st.scene;
  Paths& paths = q.paths;
  const std::size_t n = paths.size();
  auto material = [&](std::uint32_t i) -> const Material& { return scene.materials[std::size_t(q.hit[i].material)]; };
  // Misses and emission first; then which paths shade, grouped: the diffuse ones, the glossy ones (but a lobe so
  // narrow that phongSample takes it for a mirror), the mirrors and glass, then the rest by type.
  q.inLanes.clear(), q.glossy.clear(), q.specular.clear(), q.other.clear();
  for (std::uint32_t i = 0; i < n; ++i) {
    Color& L = out[paths.slot[i]];
    if (!q.found[i]) { // the ray left the scene: the background or the environment map, found only by BSDF
      // sampling (weight 1), looked up in the ray's direction as chapter 8 looks it up
      L += paths.beta[i] * scene.escaped(Vec3(paths.ray.dx[i], paths.ray.dy[i], paths.ray.dz[i]));
      continue;
    }
    const Hit& hit = q.hit[i];
    const Material& m = material(i);
    // Le(x, ωo), found by BSDF sampling: weighted against the chance that light sampling found it too.
    if (m.isEmissive())
      L += paths.beta[i] * m.emission *
           (paths.specular[i] ? Real(1)
                              : misWeight(st.heuristic, paths.bsdfPdf[i],
                                          st.lights.pdf(paths.from[i], hit.primitive, hit.point, hit.time)));
    if (bounce == maxDepth)
      continue;
    if (m.type == MaterialType::Diffuse)
      q.inLanes.push_back(i);
    else if (m.type == MaterialType::Glossy && phongExponent(m.roughness) <= kMaxPhongExponent)
      q.glossy.push_back(i);
    else if (m.type == MaterialType::Mirror || m.type == MaterialType::Glass)
      q.specular.push_back(i);
    else
      q.other.push_back(i);
  }
  // (Grouped by type, in the order of MaterialType, each type's paths in order: counted, then placed.)
  std::array<std::size_t, std::size_t(MaterialType::Interface) + 2> start{};
  for (const std::uint32_t i : q.other)
    ++start[std::size_t(material(i).type) + 1];
  std::partial_sum(start.begin(), start.end(), start.begin());
  q.grouped.resize(q.other.size());
  for (const std::uint32_t i : q.other)
    q.grouped[start[std::size_t(material(i).type)]++] = i;
  std::swap(q.other, q.grouped);

  // Light sampling (as chapters 7 and 8): a light, a direction towards it, and its shadow ray into connect's
  // queue. A point light's, a still sphere's or a triangle's direction and shadow ray are left to the stream kernels
  // (below) when `inLanes` (a diffuse or glossy surface).
  SphereLightColumns& sl = q.sphereLights;
  PointLightColumns& pl = q.pointLights;
  TriangleLightColumns& tl = q.triangleLights;
  sl.resize(n);
  if (!scene.lights.empty()) // (the point lights' columns only where there are some: 350 bytes a path)
    pl.resize(n);
  if (st.triangleLights) // (and the triangles' where some emit: 400 bytes a path)
    tl.resize(n);
  std::size_t nl = 0, ng = 0, np = 0, nt = 0;
  // The lobe of a surface in the lanes: a glossy one's Phong exponent, −1 for a diffuse one (surfaceLightSamples).
  auto lobe = [](const Material& m) { return m.type == MaterialType::Glossy ? phongExponent(m.roughness) : Real(-1); };
  // What every light sample in the lanes needs of its path, its hit and its surface, into entry k of `c` (the
  // sphere or the triangle lights' columns).
  auto shadingColumns = [&](auto& c, std::size_t k, std::uint32_t i, const Hit& hit, const Material& m,
                            const Color& Le) {
    c.nx[k] = hit.normal.x, c.ny[k] = hit.normal.y, c.nz[k] = hit.normal.z;
    c.dx[k] = paths.ray.dx[i], c.dy[k] = paths.ray.dy[i], c.dz[k] = paths.ray.dz[i];
    c.betaR[k] = paths.beta[i].r, c.betaG[k] = paths.beta[i].g, c.betaB[k] = paths.beta[i].b;
    c.rhoR[k] = m.color.r, c.rhoG[k] = m.color.g, c.rhoB[k] = m.color.b;
    c.leR[k] = Le.r, c.leG[k] = Le.g, c.leB[k] = Le.b;
    c.ex[k] = hit.pointError.x, c.ey[k] = hit.pointError.y, c.ez[k] = hit.pointError.z;
    c.gx[k] = hit.geometricNormal.x, c.gy[k] = hit.geometricNormal.y, c.gz[k] = hit.geometricNormal.z;
  };
  auto sampleLight = [&](std::uint32_t i, const Material& m, int cell, bool inLanes) {
    const Hit& hit = q.hit[i];
    const Real uLight = paths.sampler[i].next1D();
    const Vec2 uDirection = paths.sampler[i].next2D();
    // (With no light to sample, the numbers are drawn all the same, so the path is unchanged.)
    // (The light is chosen here; the guide's warp of a still sphere's numbers is left to the lanes, below.)
    const std::optional<LightChoice> chosen =
        st.sampleLights ? st.lights.chooseInCell(cell, hit.point, uLight, uDirection, hit.time)
                        : std::nullopt;
    if (!chosen)
      return;
    if (inLanes && chosen->light < 0) {
      const PointLight& light = scene.lights[std::size_t(-chosen->light - 1)];
      pl.path[np] = i, pl.light[np] = -chosen->light - 1;
      pl.px[np] = hit.point.x, pl.py[np] = hit.point.y, pl.pz[np] = hit.point.z;
      pl.ex[np] = hit.pointError.x, pl.ey[np] = hit.pointError.y, pl.ez[np] = hit.pointError.z;
      pl.gx[np] = hit.geometricNormal.x, pl.gy[np] = hit.geometricNormal.y, pl.gz[np] = hit.geometricNormal.z;
      pl.lx[np] = light.position.x, pl.ly[np] = light.position.y, pl.lz[np] = light.position.z;
      pl.iR[np] = light.intensity.r, pl.iG[np] = light.intensity.g, pl.iB[np] = light.intensity.b;
      pl.nx[np] = hit.normal.x, pl.ny[np] = hit.normal.y, pl.nz[np] = hit.normal.z;
      pl.dx[np] = paths.ray.dx[i], pl.dy[np] = paths.ray.dy[i], pl.dz[np] = paths.ray.dz[i];
      pl.choice[np] = chosen->choice; // (a point light is never guided: its pdf is the choice's, × 1)
      pl.betaR[np] = paths.beta[i].r, pl.betaG[np] = paths.beta[i].g, pl.betaB[np] = paths.beta[i].b;
      pl.rhoR[np] = m.color.r, pl.rhoG[np] = m.color.g, pl.rhoB[np] = m.color.b;
      ++np;
      return;
    }
    if (inLanes && chosen->light >= 0 && std::size_t(chosen->light) < scene.spheres.size() &&
        !scene.spheres[std::size_t(chosen->light)].moving()) {
      const Sphere& s = scene.spheres[std::size_t(chosen->light)];
      const Color& Le = scene.materials[std::size_t(s.material)].emission;
      sl.path[nl] = i, sl.px[nl] = hit.point.x, sl.py[nl] = hit.point.y, sl.pz[nl] = hit.point.z;
      sl.cx[nl] = s.center.x, sl.cy[nl] = s.center.y, sl.cz[nl] = s.center.z, sl.radius[nl] = s.radius;
      sl.u1[nl] = chosen->u.x, sl.u2[nl] = chosen->u.y, sl.choice[nl] = chosen->choice, sl.guide[nl] = 1;
      if (chosen->guideTree >= 0) { // (warped below, with the other guided ones)
        sl.guided[ng] = std::uint32_t(nl), sl.root[ng] = st.guide.root[std::size_t(chosen->guideTree)];
        sl.alpha[ng] = chosen->guideShare, sl.v1[ng] = chosen->u.x, sl.v2[ng] = chosen->u.y;
        ++ng;
      }
      shadingColumns(sl, nl, i, hit, m, Le);
      ++nl;
      return;
    }
    if (inLanes && chosen->light >= 0 && std::size_t(chosen->light) >= scene.spheres.size()) {
      // (The guide's warp, where it guides, is done here: its numbers go into the lanes as drawn from it.)
      const LightChoice g = st.lights.guided(*chosen);
      const auto [p0, p1, p2] = scene.triangleVertices(std::size_t(chosen->light) - scene.spheres.size());
      const Color& Le = scene.materials[std::size_t(scene.materialOf(chosen->light))].emission;
      tl.path[nt] = i;
      tl.px[nt] = hit.point.x, tl.py[nt] = hit.point.y, tl.pz[nt] = hit.point.z;
      tl.ax[nt] = p0.x, tl.ay[nt] = p0.y, tl.az[nt] = p0.z, tl.bx[nt] = p1.x, tl.by[nt] = p1.y, tl.bz[nt] = p1.z;
      tl.cx[nt] = p2.x, tl.cy[nt] = p2.y, tl.cz[nt] = p2.z;
      tl.u1[nt] = g.u.x, tl.u2[nt] = g.u.y, tl.choice[nt] = g.choice, tl.guide[nt] = g.guide;
      shadingColumns(tl, nt, i, hit, m, Le);
      ++nt;
      return;
    }
    const Frame frame = Frame::fromNormal(hit.normal);
    const Vec3 wo = frame.toLocal(-Vec3(paths.ray.dx[i], paths.ray.dy[i], paths.ray.dz[i]));
    const std::optional<LightSample> ls = st.lights.sampleChosen(st.lights.guided(*chosen), hit.point, hit.time);
    if (!ls)
      return;
    const Vec3 wi = frame.toLocal(ls->wi);
    const Color f = bsdfEval(m, wo, wi);
    if (f == Color(0))
      return;
    const Real weight = ls->delta ? 1 : misWeight(st.heuristic, ls->pdf, bsdfPdf(m, wo, wi));
    const Color light = paths.beta[i] * f * std::abs(wi.z) * ls->Li * (weight / ls->pdf);
    // The shadow ray: to a point light, stopping short of it; to an emitter, up to where it first meets it.
    if (ls->delta) {
      q.shadows.push(spawnRayTo(hit, ls->target), light, paths.slot[i]);
      return;
    }
    Ray ray = spawnRay(hit, ls->wi);
    const std::optional<Real> t = scene.intersectPrimitive(ray, ls->primitive);
    if (!t)
      return; // the direction leaves the light's own surface: no light this way
    ray.tmax = *t;
    q.shadows.push(ray, light, paths.slot[i]);
  };

  // What a path does after its BSDF sample: the throughput, Russian roulette, and the next ray (or its end). A path
  // that goes on is written to the next round's wavefront, after those that went on before it: so the paths close up
  // as they go, with no pass of their own (stream compaction). Their order is the groups' (each path has its own
  // numbers and its own pixel sample, so the order changes no path, and no pixel's sums).
  Paths& next = q.next;
  next.resize(n);
  std::size_t kept = 0;
  auto continuePath = [&](std::uint32_t i, const Color& weight, bool specular, Real pdf, const Vec3& direction) {
    Color beta = paths.beta[i] * weight;
    if (beta == Color(0))
      return; // nothing more can reach the eye along this path
    // Russian roulette: go on with probability p, and divide by p so that the expectation is unchanged.
    if (bounce >= kRouletteMinBounces) {
      const Real p = rouletteSurvival(beta);
      if (paths.sampler[i].next1D() >= p)
        return;
      beta /= p;
    }
    next.ray.set(kept, spawnRay(q.hit[i], direction));
    next.time[kept] = paths.time[i], next.beta[kept] = beta, next.sampler[kept] = paths.sampler[i];
    next.specular[kept] = specular, next.bsdfPdf[kept] = pdf, next.from[kept] = q.hit[i].point;
    next.slot[kept] = paths.slot[i];
    ++kept;
  };

  // The diffuse and the glossy paths (entries [0, nd) and [nd, nb) of the columns below): light samples one by one
  // (each path's light and direction differ), then every bounce at once, one path per lane (diffuseBounces:
  // lambertianSample and the frame; glossyBounces: phongSample; bit for bit).
  const std::size_t nd = q.inLanes.size(), nb = nd + q.glossy.size(), ns = nb + q.specular.size();
  q.inLanes.insert(q.inLanes.end(), q.glossy.begin(), q.glossy.end());
  for (std::vector<Real>* v : {&q.nx, &q.ny, &q.nz, &q.dx, &q.dy, &q.dz, &q.u1, &q.u2, &q.exponent, &q.wx, &q.wy,
                               &q.wz, &q.cosTheta, &q.pdf, &q.fScale, &q.px, &q.py, &q.pz})
    atLeast(*v, ns);
  atLeast(q.cell, nb);
  for (std::size_t k = 0; k < nb; ++k) {
    const Vec3& p = q.hit[q.inLanes[k]].point;
    q.px[k] = p.x, q.py[k] = p.y, q.pz[k] = p.z;
  }
  guideCells(st.guide.cells(), q.px, q.py, q.pz, nb, q.cell); // (the light guide's cell of each, as cellOf finds it)
  for (std::size_t k = 0; k < nb; ++k) {
    const std::uint32_t i = q.inLanes[k];
    const Hit& hit = q.hit[i];
    sampleLight(i, material(i), int(q.cell[k]), true);
    paths.sampler[i].next1D(); // the lobe choice, which neither surface uses (drawn as in chapter 8)
    const Vec2 u = paths.sampler[i].next2D();
    q.nx[k] = hit.normal.x, q.ny[k] = hit.normal.y, q.nz[k] = hit.normal.z;
    q.dx[k] = paths.ray.dx[i], q.dy[k] = paths.ray.dy[i], q.dz[k] = paths.ray.dz[i], q.u1[k] = u.x, q.u2[k] = u.y;
  }
  for (std::size_t k = nd; k < nb; ++k)
    q.exponent[k] = lobe(material(q.inLanes[k]));
  // Each light sample's lobe, for surfaceLightSamples, in a round with glossy paths (in the others it needs none).
  auto lobes = [&](std::vector<Real>& e, const std::vector<std::uint32_t>& path, std::size_t count) {
    if (nb == nd)
      return std::span<const Real>();
    for (std::size_t k = 0; k < count; ++k)
      e[k] = lobe(material(path[k]));
    return std::span<const Real>(e);
  };
  // The light samples towards still spheres, all at once: the guide's warp of their numbers, the directions
  // (sampleSphereCone), the light each would bring (Lambert's or Phong's f, the MIS weight), and the shadow rays'
  // origins and lengths.
  guidedWarps(st.guide.forest, {sl.root, sl.alpha, sl.v1, sl.v2}, ng, {sl.w1, sl.w2, sl.density});
  for (std::size_t g = 0; g < ng; ++g) {
    const std::uint32_t k = sl.guided[g];
    sl.u1[k] = sl.w1[g], sl.u2[k] = sl.w2[g], sl.guide[k] = sl.density[g];
  }
  sphereLightDirections({sl.px, sl.py, sl.pz, sl.cx, sl.cy, sl.cz, sl.radius, sl.u1, sl.u2, sl.choice, sl.guide}, nl,
                        {sl.wx, sl.wy, sl.wz, sl.pdf});
  surfaceLightSamples({sl.nx, sl.ny, sl.nz, sl.dx, sl.dy, sl.dz, sl.wx, sl.wy, sl.wz, sl.pdf, sl.betaR, sl.betaG,
                       sl.betaB, sl.rhoR, sl.rhoG, sl.rhoB, sl.leR, sl.leG, sl.leB, st.heuristic == MisHeuristic::Power,
                       false, lobes(sl.exponent, sl.path, nl)},
                      nl, {sl.lightR, sl.lightG, sl.lightB, sl.useful});
  shadowRaysToSpheres({sl.px, sl.py, sl.pz, sl.ex, sl.ey, sl.ez, sl.gx, sl.gy, sl.gz, sl.wx, sl.wy, sl.wz, sl.cx, sl.cy,
                       sl.cz, sl.radius},
                      nl, {sl.ox, sl.oy, sl.oz, sl.t});
  for (std::size_t k = 0; k < nl; ++k)
    if (sl.useful[k] != 0 && sl.t[k] < kInfinity) // (no root: the direction leaves the light's own surface)
      q.shadows.push(Ray{Vec3(sl.ox[k], sl.oy[k], sl.oz[k]), Vec3(sl.wx[k], sl.wy[k], sl.wz[k]), 0, sl.t[k],
                         q.hit[sl.path[k]].time},
                     Color(sl.lightR[k], sl.lightG[k], sl.lightB[k]), paths.slot[sl.path[k]]);

  // The light samples towards point lights, all at once: the light that arrives and the shadow ray (pointLightRays),
  // and what it brings (Lambert's or Phong's f, weight 1: no other strategy finds a point).
  pointLightRays({pl.px, pl.py, pl.pz, pl.ex, pl.ey, pl.ez, pl.gx, pl.gy, pl.gz, pl.lx, pl.ly, pl.lz, pl.iR, pl.iG,
                  pl.iB},
                 np, {pl.wx, pl.wy, pl.wz, pl.liR, pl.liG, pl.liB, pl.ox, pl.oy, pl.oz, pl.t, pl.arrives});
  surfaceLightSamples({pl.nx, pl.ny, pl.nz, pl.dx, pl.dy, pl.dz, pl.wx, pl.wy, pl.wz, pl.choice, pl.betaR, pl.betaG,
                       pl.betaB, pl.rhoR, pl.rhoG, pl.rhoB, pl.liR, pl.liG, pl.liB, true, true,
                       lobes(pl.exponent, pl.path, np)},
                      np, {pl.lightR, pl.lightG, pl.lightB, pl.useful});
  // (A ray that its light's buffer answers goes to that light's queue, with the cell it starts in.)
  for (std::size_t k = 0; k < np; ++k)
    if (pl.arrives[k] != 0 && pl.useful[k] != 0) {
      const Ray ray{Vec3(pl.ox[k], pl.oy[k], pl.oz[k]), Vec3(pl.wx[k], pl.wy[k], pl.wz[k]), 0, pl.t[k],
                    q.hit[pl.path[k]].time};
      const Color light(pl.lightR[k], pl.lightG[k], pl.lightB[k]);
      const std::size_t target = std::size_t(pl.light[k]);
      if (target < st.lightBuffers.size() && st.lightBuffers[target].answers(ray.origin))
        q.buffered[target].push(ray, light, paths.slot[pl.path[k]], st.lightBuffers[target].cellRange(ray.origin));
      else
        q.shadows.push(ray, light, paths.slot[pl.path[k]]);
    }

  // The light samples towards triangles, all at once: the directions (sampleTriangleLight), the pdf
  // (the choice's, the direction's, then the guide's, as sampleChosen multiplies them), the light each would bring,
  // and the shadow rays, each as long as the way to its triangle (the watertight test in the lanes).
  triangleLightDirections({tl.px, tl.py, tl.pz, tl.ax, tl.ay, tl.az, tl.bx, tl.by, tl.bz, tl.cx, tl.cy, tl.cz, tl.u1,
                           tl.u2},
                          nt, {tl.wx, tl.wy, tl.wz, tl.solidAnglePdf});
  for (std::size_t k = 0; k < nt; ++k)
    tl.pdf[k] = tl.choice[k] * tl.solidAnglePdf[k] * tl.guide[k];
  surfaceLightSamples({tl.nx, tl.ny, tl.nz, tl.dx, tl.dy, tl.dz, tl.wx, tl.wy, tl.wz, tl.pdf, tl.betaR, tl.betaG,
                       tl.betaB, tl.rhoR, tl.rhoG, tl.rhoB, tl.leR, tl.leG, tl.leB,
                       st.heuristic == MisHeuristic::Power, false, lobes(tl.exponent, tl.path, nt)},
                      nt, {tl.lightR, tl.lightG, tl.lightB, tl.useful});
  shadowRaysToTriangles({tl.px, tl.py, tl.pz, tl.ex, tl.ey, tl.ez, tl.gx, tl.gy, tl.gz, tl.wx, tl.wy, tl.wz, tl.ax,
                         tl.ay, tl.az, tl.bx, tl.by, tl.bz, tl.cx, tl.cy, tl.cz},
                        nt, {tl.ox, tl.oy, tl.oz, tl.t});
  // (No direction where the triangle is seen edge on; no light where the surface's f is 0; no ray where the direction
  // leaves the light's own surface.)
  for (std::size_t k = 0; k < nt; ++k)
    if (tl.solidAnglePdf[k] > 0 && tl.useful[k] != 0 && tl.t[k] < kInfinity)
      q.shadows.push(Ray{Vec3(tl.ox[k], tl.oy[k], tl.oz[k]), Vec3(tl.wx[k], tl.wy[k], tl.wz[k]), 0, tl.t[k],
                         q.hit[tl.path[k]].time},
                     Color(tl.lightR[k], tl.lightG[k], tl.lightB[k]), paths.slot[tl.path[k]]);

  diffuseBounces({q.nx, q.ny, q.nz, q.dx, q.dy, q.dz, q.u1, q.u2}, nd, {q.wx, q.wy, q.wz, q.cosTheta, q.pdf});
  const auto from = [nd](std::vector<Real>& v) { return std::span<Real>(v).subspan(nd); };
  glossyBounces({{from(q.nx), from(q.ny), from(q.nz), from(q.dx), from(q.dy), from(q.dz), from(q.u1), from(q.u2)},
                 from(q.exponent)},
                nb - nd, {{from(q.wx), from(q.wy), from(q.wz), from(q.cosTheta), from(q.pdf)}, from(q.fScale)});
  for (std::size_t k = 0; k < nb; ++k) {
    const std::uint32_t i = q.inLanes[k];
    if (!(q.pdf[k] > 0))
      continue; // no sample: the path ends
    const Color f = material(i).color * (k < nd ? kInvPi : q.fScale[k]); // lambertianSample's f, or phongSample's
    continuePath(i, f * std::abs(q.cosTheta[k]) / q.pdf[k], false, q.pdf[k], Vec3(q.wx[k], q.wy[k], q.wz[k]));
  }

  // The mirrors and glass (entries [nb, ns)): no light sample (a delta lobe meets no light's direction), then every
  // bounce at once (specularBounces: mirrorSample and dielectricSample, bit for bit), whose f is ρ·pdf/|cosθ|. (The
  // weight is then worked out as chapter 8 works it out, f·|cosθ|/pdf, not taken as ρ: the same bits.)
  for (std::size_t k = nb; k < ns; ++k) {
    const std::uint32_t i = q.specular[k - nb];
    const Hit& hit = q.hit[i];
    const Material& m = material(i);
    q.u1[k] = paths.sampler[i].next1D();
    paths.sampler[i].next2D(); // (drawn as in chapter 8, which neither lobe uses)
    q.nx[k] = hit.normal.x, q.ny[k] = hit.normal.y, q.nz[k] = hit.normal.z;
    q.dx[k] = paths.ray.dx[i], q.dy[k] = paths.ray.dy[i], q.dz[k] = paths.ray.dz[i];
    q.exponent[k] = m.type == MaterialType::Glass ? m.ior : 0;
  }
  const auto specular = [nb](std::vector<Real>& v) { return std::span<Real>(v).subspan(nb); };
  specularBounces({specular(q.nx), specular(q.ny), specular(q.nz), specular(q.dx), specular(q.dy), specular(q.dz),
                   specular(q.u1), specular(q.exponent)},
                  ns - nb, {specular(q.wx), specular(q.wy), specular(q.wz), specular(q.cosTheta), specular(q.pdf)});
  for (std::size_t k = nb; k < ns; ++k) {
    const std::uint32_t i = q.specular[k - nb];
    if (!(q.pdf[k] > 0))
      continue;
    const Color f = material(i).color * q.pdf[k] / std::abs(q.cosTheta[k]);
    continuePath(i, f * std::abs(q.cosTheta[k]) / q.pdf[k], true, q.pdf[k], Vec3(q.wx[k], q.wy[k], q.wz[k]));
  }

  // The other materials (metal, and glossy lobes too narrow for the lanes), one path at a time, grouped by type.
  for (const std::uint32_t i : q.other) {
    const Material& m = material(i);
    sampleLight(i, m, st.lights.cellOf(q.hit[i].point), false);
    const Frame frame = Frame::fromNormal(q.hit[i].normal);
    const Vec3 wo = frame.toLocal(-Vec3(paths.ray.dx[i], paths.ray.dy[i], paths.ray.dz[i]));
    const Real uChoice = paths.sampler[i].next1D();
    const Vec2 u = paths.sampler[i].next2D();
    if (const std::optional<BsdfSample> bs = bsdfSample(m, wo, u, uChoice))
      continuePath(i, bs->f * std::abs(bs->wi.z) / bs->pdf, bs->specular, bs->pdf, frame.toWorld(bs->wi));
  }

  next.resize(kept);
  std::swap(q.paths, q.next);
}
/// [shade]

/// [connect]
// Stage 4, connect: every shadow ray of the round at once (any hit); the light of each that gets through is added
// to its pixel sample. In a tree of still spheres, the rays to a point light that its buffer answers come in that
// light's own queue, and test only the spheres that lie in their directions from the light (Haines and Greenberg's
// light buffer).
void connect(const Stages& st, Queues& q, std::span<Color> out)
{
  const ShadowRays& shadows = q.shadows;
  const std::size_t n = shadows.size();
  q.blocked.assign(n, 0);
  if (st.sphereKernels) {
    anySpheres(st.spheres, shadows.ray, n, q.blocked);
    countRays(n);
  } else {
    for (std::size_t i = 0; i < n; ++i) // (Scene::occluded counts its rays)
      q.blocked[i] = st.scene.occluded(shadows.ray.get(i, shadows.time[i]));
  }
  for (std::size_t i = 0; i < n; ++i)
    if (!q.blocked[i])
      out[shadows.slot[i]] += shadows.light[i];
  // Each light's buffered rays in the lanes, each ray against its cell's spheres and those every ray tests.
  for (std::size_t light = 0; light < st.lightBuffers.size(); ++light) {
    const LightBuffer& buffer = st.lightBuffers[light];
    BufferedShadowRays& b = q.buffered[light];
    anySpheresListed({st.spheres, buffer.listed(), b.cellFirst, b.cellSize, buffer.everywhere()}, b.ray, 0, b.size(),
                     b.blocked);
    countRays(b.size());
    for (std::size_t k = 0; k < b.size(); ++k)
      if (!b.blocked[k])
        out[b.slot[k]] += b.light[k];
  }
}
/// [connect]

/// [wavefront]
// The estimator: a wavefront of pixel samples through the stages, round after round, until no path is left.
// Each path adds its light to out[i], its pixel sample's (which the render loop hands over at 0, and adds to the film
// afterwards: stage 5, accumulate). Each thread has its
// own queues `q`, kept from one wavefront to the next (their memory, not their contents).
void renderWavefront(const Stages& st, Queues& q, const PrimaryRays& primary, std::span<const PixelSampleKey> keys,
                     int maxDepth, std::span<Color> out)
{
  generate(primary, keys, q.paths, q.film);
  for (int bounce = 0; q.paths.size() > 0; ++bounce) {
    extend(st, q, bounce == 0);
    q.clearShadows(q.paths.size(), st.lightBuffers.size());
    shade(st, bounce, maxDepth, q, out);
    connect(st, q, out);
  }
}
/// [wavefront]

// Whether some triangle of the scene emits light (and so may be a light sample's target).
bool triangleEmits(const Scene& scene)
{
  for (std::size_t k = 0; k < scene.triangles.size(); ++k)
    if (scene.materials[std::size_t(scene.materialOf(int(scene.spheres.size() + k)))].isEmissive())
      return true;
  return false;
}

int main(int argc, char** argv)
{
  /// [chapter]
  const ChapterInfo chapter{.binary = "step16_wavefront",
                            .defaultScene = "smallpt.json",
                            .uses = kUsesSpheres | kUsesColors | kUsesPointLights | kUsesBackground |
                                    kUsesEnvironment | kUsesEmission | kUsesMirror | kUsesGlass | kUsesGlossy |
                                    kUsesMaxDepth | kSamplesLights | kUsesMetal | kUsesLens | kUsesMotion,
                            .pixelSampling = PixelSampling::Jittered,
                            .defaultSpp = 64,
                            .defaultMaxDepth = -1,
                            .adaptiveSampling = true,
                            .options = {kHeuristicOption,
                                        kGuideOption,
                                        {.name = "--wavefront",
                                         .kind = OptionKind::Integer,
                                         .help = "most paths in flight at once per thread (1 to 2 KB of queues each)",
                                         .defaultValue = "4096",
                                         .min = 1,
                                         .max = 1 << 24}}};
  /// [chapter]
  auto makeWavefront = [&chapter](const Scene& scene, const ChapterOptions& options) -> Wavefront {
    const MisHeuristic heuristic = heuristicOption(options);
    // The stream kernels take a flat list of still spheres; a tree is walked one ray at a time.
    const bool sphereKernels = !scene.usesAccelerator() && scene.triangles.empty() && !scene.hasMotion();
    const bool cameraBlocks = scene.usesAccelerator() && scene.triangles.empty() && !scene.hasMotion() &&
                              scene.spheres.size() <= kMostCulledSpheres;
    std::vector<LightBuffer> lightBuffers;
    std::size_t bufferBytes = 0;
    if (cameraBlocks)
      for (const PointLight& light : scene.lights) {
        lightBuffers.emplace_back(light.position, scene.spheres, kLightBufferCells,
                                  4 * glm::length(light.position - scene.camera.eye));
        bufferBytes += lightBuffers.back().memoryBytes();
      }
    if (options.verbose()) {
      const SimdTarget simd = currentSimdTarget();
      std::cerr << chapter.binary << ": plan: wavefronts of up to " << options.integer("--wavefront")
                << " paths a thread; nearest hits and shadow rays "
                << (sphereKernels ? "through the stream kernels"
                    : cameraBlocks
                        ? "through the tree one ray at a time, but camera rays through a pinhole by blocks of 8 x 8 "
                          "pixels, each against the spheres it may see (through a lens, or a block that may see more "
                          "than 32: in packets of 16)"
                    : scene.usesAccelerator()
                        ? "through the tree (camera rays in packets of 16, the others one ray at a time)"
                        : "through the scene, one ray at a time (triangles or motion)");
      if (!lightBuffers.empty())
        std::cerr << "; shadow rays to a point light through its light buffer (" << kLightBufferCells << " x "
                  << kLightBufferCells << " cells a face, " << (bufferBytes + 1023) / 1024 << " KB for "
                  << lightBuffers.size() << (lightBuffers.size() == 1 ? " light" : " lights")
                  << "; from beyond 4 times the light's distance from the eye: the tree)";
      std::cerr << "; the kernels run " << simd.lanes << " paths a vector (" << simd.name << ")\n";
    }
    LightSampler lights = makeLightSampler(chapter.binary, scene, options);
    GuideLanes guide(lights);
    const auto stages = std::make_shared<const Stages>(
        Stages{scene, std::move(lights), std::move(guide), planScene(scene, chapter.uses).lightSampling(), heuristic,
               sphereKernels, cameraBlocks, SphereList::from(scene.spheres), triangleEmits(scene),
               std::move(lightBuffers)});
    // Each thread of the render gets its own queues.
    auto workers = [stages]() -> WavefrontFunction {
      return [stages, queues = std::make_shared<Queues>()](const Scene&, const PrimaryRays& primary,
                                                           std::span<const PixelSampleKey> keys, int maxDepth,
                                                           std::span<Color> out) {
        renderWavefront(*stages, *queues, primary, keys, maxDepth, out);
      };
    };
    return Wavefront{workers, std::size_t(options.integer("--wavefront"))};
  };
  return runWavefrontChapter(argc, argv, chapter, makeWavefront);
}

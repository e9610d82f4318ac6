// Chapter 17's building blocks (blocks.cl) against the C++ library's on random inputs, run on the OpenCL device the
// chapter would pick (PoCL's CPU device in CI). The device computes in float, the library in double from the same
// float inputs, so they agree to float's precision, not bit for bit. The tolerances:
//  - a distance t: within 1e-4 of the distances involved (|origin − centre| + radius, or the ray's length to the
//    triangle), which is some 800 float ulps;
//  - barycentrics and directions: within 1e-4 absolute (unit quantities);
//  - f and pdf: within 2e-3 relative (a glossy lobe raises a float to a power of up to 800);
//  - hit or miss, sample or none, an environment map's texel: the same, except within 1e-4 of the boundary where the
//    answer flips (a ray that grazes a sphere or crosses a triangle's edge; a random number within 1e-4 of the
//    glass's Fresnel reflectance; a direction within 1e-4 of a texel's edge).
// The box test must be conservative: it never culls a box the exact (double) slab test enters.
#include "opencl_device.h"

#include "core/frame.h"
#include "geometry/bvh.h"
#include "geometry/sphere.h"
#include "geometry/triangle.h"
#include "shading/bsdf.h"
#include "shading/environment.h"

#include <catch2/catch.hpp>

#include <cmath>
#include <cstring>
#include <iostream>
#include <random>
#include <vector>

using namespace raylife;

namespace {

// The test kernels: each calls one building block for work-item i's inputs.
const char* kTestKernels = R"(
__kernel void testSphere(__global const float4* o, __global const float4* d, __global const float4* s,
                         __global float* t, __global float* inLanes)
{
  const uint i = get_global_id(0);
  t[i] = intersectSphere(o[i].xyz, d[i].xyz, s[i].xyz, s[i].w, 0.0f, INFINITY);
  // The eight-lane test: ray i against the eight spheres of its sphere's group of eight, its own in lane i % 8.
  __global const float4* g = s + (i & ~7u);
  float lanes[8];
  vstore8(intersectSpheres(o[i].xyz, d[i].xyz, (float8)(g[0].x, g[1].x, g[2].x, g[3].x, g[4].x, g[5].x, g[6].x, g[7].x),
                           (float8)(g[0].y, g[1].y, g[2].y, g[3].y, g[4].y, g[5].y, g[6].y, g[7].y),
                           (float8)(g[0].z, g[1].z, g[2].z, g[3].z, g[4].z, g[5].z, g[6].z, g[7].z),
                           (float8)(g[0].w, g[1].w, g[2].w, g[3].w, g[4].w, g[5].w, g[6].w, g[7].w), 0.0f, INFINITY),
          0, lanes);
  inLanes[i] = lanes[i & 7u];
}
__kernel void testTriangle(__global const float4* o, __global const float4* d, __global const float4* p,
                           __global float4* out)
{
  const uint i = get_global_id(0);
  out[i] = intersectTriangle(o[i].xyz, d[i].xyz, p[3 * i].xyz, p[3 * i + 1].xyz, p[3 * i + 2].xyz, 0.0f, INFINITY);
}
__kernel void testBox(__global const WideNode* nodes, __global const float4* o, __global const float4* d,
                      __global float* entry, __global float* oneByOne)
{
  const uint i = get_global_id(0);
  vstore8(boxEntries(&nodes[i], o[i].xyz, 1.0f / d[i].xyz, 0.0f, INFINITY), i, entry);
  for (int k = 0; k < (int)nodes[i].boxes; ++k)
    oneByOne[8 * i + k] = boxEntry(&nodes[i], k, o[i].xyz, 1.0f / d[i].xyz, 0.0f, INFINITY);
}
__kernel void testEnvironment(__global const float4* texels, const float4 info, __global const float4* d,
                              __global float4* out)
{
  const uint i = get_global_id(0);
  out[i] = (float4)(escapedRadiance(texels, info, (float3)(-1.0f), d[i].xyz), 0.0f);
}
__kernel void testBsdf(__global const float4* materials, __global const float4* wo, __global const float4* u,
                       __global float4* wi, __global float4* f)
{
  const uint i = get_global_id(0);
  const Material m = materialAt(materials, (int)i);
  const BsdfSample bs = bsdfSample(&m, wo[i].xyz, u[i].xy, u[i].z);
  wi[i] = (float4)(bs.wi, bs.pdf);
  f[i] = (float4)(bs.f, (float)bs.specular);
}
__kernel void testScan(__global const uint* value, __global uint* before, __global uint* total)
{
  __local uint partial[256];
  const uint i = get_global_id(0);
  uint sum;
  before[i] = groupExclusiveScan(value[i], partial, &sum);
  total[i] = sum;
}
)";

// The device, and the building blocks with the test kernels built for it.
struct TestDevice {
  opencl::DeviceInfo info = opencl::chooseDevice(-1);
  cl::Context context{info.device};
  cl::CommandQueue queue{context, info.device};
  cl::Program program = opencl::buildProgram(context, info.device, opencl::blocksSource() + kTestKernels);

  template <class T> cl::Buffer input(const std::vector<T>& data)
  {
    return cl::Buffer(context, CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, data.size() * sizeof(T),
                      const_cast<T*>(data.data()));
  }
  cl::Buffer output(std::size_t bytes) { return cl::Buffer(context, CL_MEM_WRITE_ONLY, bytes); }
  template <class T> std::vector<T> read(const cl::Buffer& b, std::size_t n)
  {
    std::vector<T> out(n);
    queue.enqueueReadBuffer(b, CL_TRUE, 0, n * sizeof(T), out.data());
    return out;
  }
  void run(const char* name, std::size_t n, const std::vector<const cl::Buffer*>& args)
  {
    cl::Kernel k(program, name);
    for (std::size_t a = 0; a < args.size(); ++a)
      k.setArg(cl_uint(a), *args[a]);
    queue.enqueueNDRangeKernel(k, cl::NullRange, cl::NDRange(n));
    queue.finish();
  }
};

TestDevice& device()
{
  static TestDevice d;
  return d;
}

constexpr std::size_t kCount = 20000;
constexpr double kMaxBoundaryShare = 1e-3;

cl_float4 f4(float x, float y, float z, float w = 0) { return cl_float4{{x, y, z, w}}; }
Vec3 v3(const cl_float4& v) { return Vec3(v.s[0], v.s[1], v.s[2]); }

// A unit vector in float, and the same as a double Vec3.
cl_float4 unitFloat(std::mt19937& rng)
{
  std::normal_distribution<float> g;
  for (;;) {
    const float x = g(rng), y = g(rng), z = g(rng);
    const float l = std::sqrt(x * x + y * y + z * z);
    if (l > 1e-3f)
      return f4(x / l, y / l, z / l);
  }
}

} // namespace

TEST_CASE("opencl blocks: ray-sphere on the device agrees with intersectSphere on random rays, in lanes too")
{
  std::mt19937 rng(17);
  std::uniform_real_distribution<float> pos(-10, 10), rad(0.1f, 3), near(-1.5f, 1.5f);
  std::vector<cl_float4> o(kCount), d(kCount), s(kCount);
  for (std::size_t i = 0; i < kCount; ++i) {
    s[i] = f4(pos(rng) / 2, pos(rng) / 2, pos(rng) / 2, rad(rng));
    o[i] = f4(pos(rng), pos(rng), pos(rng));
    // Aimed at a point around the sphere, so that about half the rays hit; some start inside.
    const Vec3 target = v3(s[i]) + Vec3(near(rng), near(rng), near(rng)) * Real(s[i].s[3]);
    const Vec3 dir = glm::normalize(target - v3(o[i]));
    d[i] = f4(float(dir.x), float(dir.y), float(dir.z));
  }
  TestDevice& dev = device();
  const cl::Buffer bo = dev.input(o), bd = dev.input(d), bs = dev.input(s), bt = dev.output(kCount * sizeof(float));
  const cl::Buffer b8 = dev.output(kCount * sizeof(float));
  dev.run("testSphere", kCount, {&bo, &bd, &bs, &bt, &b8});
  const std::vector<float> t = dev.read<float>(bt, kCount), t8 = dev.read<float>(b8, kCount);
  // The eight lanes against intersectSphere on the device: the same bits (the walk's shadow rays rely on it).
  std::size_t lanesDiffer = 0;
  for (std::size_t i = 0; i < kCount; ++i)
    lanesDiffer += std::memcmp(&t[i], &t8[i], sizeof(float)) != 0;
  std::size_t hits = 0, boundary = 0;
  double worst = 0;
  for (std::size_t i = 0; i < kCount; ++i) {
    const Vec3 c = v3(s[i]), origin = v3(o[i]), dir = v3(d[i]);
    const Real r = s[i].s[3];
    const std::optional<Real> expected = intersectSphere(origin, dir, c, r, Real(0), kInfinity);
    if (expected.has_value() != (t[i] >= 0)) {
      // Only a ray that grazes the sphere may differ: its closest approach within 1e-4 radii of the surface.
      const Vec3 f = origin - c;
      const Real approach = glm::length(f - glm::dot(f, dir) * dir);
      INFO("ray " << i << ": closest approach " << approach << ", radius " << r);
      CHECK(std::abs(approach - r) <= 1e-4 * r);
      ++boundary;
      continue;
    }
    if (!expected)
      continue;
    ++hits;
    const double error = std::abs(double(t[i]) - *expected) / (glm::length(origin - c) + r);
    worst = std::max(worst, error);
    CHECK(error <= 1e-4);
  }
  std::cout << "ray-sphere: " << hits << " hits of " << kCount << ", worst relative error of t " << worst << ", "
            << boundary << " grazing rays answered differently; " << lanesDiffer << " unlike in the eight lanes\n";
  CHECK(hits > kCount / 4);
  CHECK(double(boundary) <= kMaxBoundaryShare * kCount);
  CHECK(lanesDiffer == 0);
}

TEST_CASE("opencl blocks: ray-triangle on the device agrees with intersectTriangle on random rays")
{
  std::mt19937 rng(18);
  std::uniform_real_distribution<float> pos(-2, 2), bary(-0.2f, 1.2f), far(3, 8);
  std::vector<cl_float4> o(kCount), d(kCount), p(3 * kCount);
  std::vector<Vec3> aimed(kCount);
  for (std::size_t i = 0; i < kCount; ++i) {
    // Well-shaped triangles (every altitude at least a tenth of the longest side) seen from at least 6 degrees off
    // their plane: where the answer is well conditioned, so that float's rounding stays within the tolerances.
    Vec3 q[3], origin, target;
    for (;;) {
      for (Vec3& c : q)
        c = Vec3(pos(rng), pos(rng), pos(rng));
      const Real area2 = triangleDoubleArea(q[0], q[1], q[2]);
      const Real longest = std::max({glm::length(q[1] - q[0]), glm::length(q[2] - q[1]), glm::length(q[0] - q[2])});
      if (area2 / longest < Real(0.1) * longest)
        continue;
      // Aimed at barycentrics in [−0.2, 1.2]: some inside, some outside, some across an edge.
      const Real b1 = bary(rng), b2 = bary(rng);
      aimed[i] = Vec3(1 - b1 - b2, b1, b2);
      target = aimed[i].x * q[0] + aimed[i].y * q[1] + aimed[i].z * q[2];
      const cl_float4 u = unitFloat(rng);
      if (std::abs(glm::dot(v3(u), triangleNormal(q[0], q[1], q[2]))) < Real(0.1))
        continue;
      origin = target + Real(far(rng)) * v3(u);
      break;
    }
    for (int k = 0; k < 3; ++k)
      p[3 * i + std::size_t(k)] = f4(float(q[k].x), float(q[k].y), float(q[k].z));
    o[i] = f4(float(origin.x), float(origin.y), float(origin.z));
    const Vec3 dir = glm::normalize(target - v3(o[i]));
    d[i] = f4(float(dir.x), float(dir.y), float(dir.z));
  }
  TestDevice& dev = device();
  const cl::Buffer bo = dev.input(o), bd = dev.input(d), bp = dev.input(p), out = dev.output(kCount * sizeof(cl_float4));
  dev.run("testTriangle", kCount, {&bo, &bd, &bp, &out});
  const std::vector<cl_float4> got = dev.read<cl_float4>(out, kCount);
  std::size_t hits = 0, boundary = 0;
  double worstT = 0, worstB = 0;
  for (std::size_t i = 0; i < kCount; ++i) {
    const auto expected = intersectTriangle(v3(o[i]), v3(d[i]), v3(p[3 * i]), v3(p[3 * i + 1]), v3(p[3 * i + 2]),
                                            Real(0), kInfinity);
    if (expected.has_value() != (got[i].s[0] >= 0)) {
      // Only a ray through (within 1e-4 of) an edge may differ.
      const Real edge = std::min(std::abs(aimed[i].x), std::min(std::abs(aimed[i].y), std::abs(aimed[i].z)));
      INFO("ray " << i << ": nearest barycentric " << edge);
      CHECK(edge <= 1e-4);
      ++boundary;
      continue;
    }
    if (!expected)
      continue;
    ++hits;
    const double tError = std::abs(double(got[i].s[0]) - expected->t) / expected->t;
    const double bError = std::max({std::abs(double(got[i].s[1]) - expected->b0),
                                    std::abs(double(got[i].s[2]) - expected->b1),
                                    std::abs(double(got[i].s[3]) - expected->b2)});
    worstT = std::max(worstT, tError), worstB = std::max(worstB, bError);
    CHECK(tError <= 1e-4);
    CHECK(bError <= 1e-4);
  }
  std::cout << "ray-triangle: " << hits << " hits of " << kCount << ", worst relative error of t " << worstT
            << ", of the barycentrics " << worstB << ", " << boundary << " rays through an edge answered differently\n";
  CHECK(hits > kCount / 5);
  CHECK(double(boundary) <= kMaxBoundaryShare * kCount);
}

TEST_CASE("opencl blocks: the box test never culls a box the exact slab test enters, and misses what is clearly missed")
{
  // Nodes of 1 to 8 random boxes, every box tested in its lane; each ray is aimed near one of its node's boxes (or
  // along an axis).
  std::mt19937 rng(19);
  std::uniform_real_distribution<float> pos(-5, 5), size(0.01f, 3);
  std::vector<BvhWideNode> nodes(kCount);
  std::vector<cl_float4> o(kCount), d(kCount);
  for (std::size_t i = 0; i < kCount; ++i) {
    BvhWideNode& n = nodes[i];
    n = BvhWideNode{};
    n.boxes = std::uint32_t(1 + i % BvhWideNode::kWidth);
    for (std::uint32_t k = 0; k < BvhWideNode::kWidth; ++k)
      for (int a = 0; a < 3; ++a) {
        // (A slot past the node's boxes holds a box around everything, which the test must not enter.)
        const float lo = k < n.boxes ? pos(rng) / 2 : -100;
        n.bounds[a * BvhWideNode::kWidth + k] = lo;
        n.bounds[(3 + a) * BvhWideNode::kWidth + k] = k < n.boxes ? lo + size(rng) : 100;
      }
    o[i] = f4(pos(rng), pos(rng), pos(rng));
    d[i] = unitFloat(rng);
    if (i % 2 == 0) { // half of them aimed at a point near a box: some enter it, some pass close by
      const std::size_t k = (i / 2) % n.boxes;
      Vec3 target;
      for (int a = 0; a < 3; ++a) {
        const float lo = n.bound(0, a, int(k)), hi = n.bound(1, a, int(k));
        target[a] = lo + (hi - lo) * (std::uniform_real_distribution<float>(-0.3f, 1.3f)(rng));
      }
      const Vec3 dir = glm::normalize(target - v3(o[i]));
      d[i] = f4(float(dir.x), float(dir.y), float(dir.z));
    }
    if (i % 10 == 0) // some directions along an axis (1/d infinite in the others)
      d[i] = f4(0, i % 20 == 0 ? 1.0f : -1.0f, 0);
  }
  const std::size_t width = BvhWideNode::kWidth;
  TestDevice& dev = device();
  const cl::Buffer bn = dev.input(nodes), bo = dev.input(o), bd = dev.input(d);
  const cl::Buffer out = dev.output(kCount * width * sizeof(float)), out1 = dev.output(kCount * width * sizeof(float));
  dev.run("testBox", kCount, {&bn, &bo, &bd, &out, &out1});
  const std::vector<float> entry = dev.read<float>(out, kCount * width), one = dev.read<float>(out1, kCount * width);
  std::size_t entered = 0, culled = 0, missedClearly = 0, keptWrongly = 0, emptyKept = 0, lanesDiffer = 0;
  for (std::size_t i = 0; i < kCount; ++i)
    for (std::size_t k = 0; k < width; ++k) {
      const float e = entry[i * width + k];
      if (k >= nodes[i].boxes) { // no such child
        emptyKept += e != INFINITY;
        continue;
      }
      // (The eight lanes and the test of one child, as a GPU's walk uses it: the same bits.)
      lanesDiffer += std::memcmp(&e, &one[i * width + k], sizeof e) != 0;
      // The exact slab test in double: the interval [tNear, tFar] ∩ [0, ∞) inside all three slabs.
      double tNear = 0, tFar = INFINITY, gap = 0;
      for (int a = 0; a < 3; ++a) {
        const double lo = nodes[i].bound(0, a, int(k)), hi = nodes[i].bound(1, a, int(k));
        const double oa = o[i].s[a], da = d[i].s[a];
        if (da == 0) {
          if (oa < lo || oa > hi)
            tNear = INFINITY, gap = INFINITY;
          continue;
        }
        const double t0 = (lo - oa) / da, t1 = (hi - oa) / da;
        tNear = std::max(tNear, std::min(t0, t1));
        tFar = std::min(tFar, std::max(t0, t1));
      }
      if (gap == 0)
        gap = tNear - tFar;
      if (tNear <= tFar) {
        ++entered;
        culled += e == INFINITY;
      } else if (gap > 1e-3 * (1 + std::abs(tNear))) {
        ++missedClearly;
        keptWrongly += e != INFINITY;
      }
    }
  std::cout << "box test: " << entered << " boxes entered (" << culled << " culled), " << missedClearly
            << " clearly missed (" << keptWrongly << " kept), " << emptyKept << " empty slots kept, " << lanesDiffer
            << " lanes unlike the one-child test\n";
  CHECK(entered > kCount / 10);
  CHECK(missedClearly > kCount / 10);
  CHECK(culled == 0);
  CHECK(emptyKept == 0);
  CHECK(lanesDiffer == 0);
  CHECK(keptWrongly == 0);
}

TEST_CASE("opencl blocks: the environment lookup on the device finds EnvironmentMap::radiance's texel, the map turned")
{
  // A 24 × 12 map whose every texel is its own number, scaled by 2 and turned by 140° (as scenes/sun_sky.json), packed
  // as chapter 17's host packs it: the texels with the scale applied, and (width, height, sin, cos) of the turn.
  auto image = std::make_shared<TexelImage>();
  image->width = 24, image->height = 12;
  for (int k = 0; k < image->width * image->height; ++k)
    image->rgb.insert(image->rgb.end(), {float(k), float(k % 7), 1.0f});
  const EnvironmentMap map(image, 2, 140);
  std::vector<cl_float4> texels;
  for (int y = 0; y < image->height; ++y)
    for (int x = 0; x < image->width; ++x) {
      const Color c = image->texel(x, y) * map.scale();
      texels.push_back(f4(float(c.r), float(c.g), float(c.b)));
    }
  const cl_float4 info = f4(float(image->width), float(image->height), float(map.rotation().sin),
                            float(map.rotation().cos));
  std::mt19937 rng(23);
  std::vector<cl_float4> d(kCount);
  for (cl_float4& v : d)
    v = unitFloat(rng);
  TestDevice& dev = device();
  const cl::Buffer bt = dev.input(texels), bd = dev.input(d), out = dev.output(kCount * sizeof(cl_float4));
  cl::Kernel k(dev.program, "testEnvironment");
  k.setArg(0, bt), k.setArg(1, info), k.setArg(2, bd), k.setArg(3, out);
  dev.queue.enqueueNDRangeKernel(k, cl::NullRange, cl::NDRange(kCount));
  dev.queue.finish();
  const std::vector<cl_float4> got = dev.read<cl_float4>(out, kCount);
  std::size_t same = 0, nearEdge = 0, wrong = 0;
  for (std::size_t i = 0; i < kCount; ++i) {
    const Color expected = map.radiance(v3(d[i]));
    if (double(got[i].s[0]) == double(expected.r) && double(got[i].s[1]) == double(expected.g)) {
      ++same;
      continue;
    }
    // The device works in float: a direction within 1e-4 of a texel's edge may land in its neighbour.
    const Vec2 uv = map.uvOf(v3(d[i]));
    const double u = uv.x * image->width, v = uv.y * image->height;
    if (std::abs(u - std::round(u)) < 1e-4 * image->width || std::abs(v - std::round(v)) < 1e-4 * image->height)
      ++nearEdge;
    else
      ++wrong;
  }
  INFO(same << " directions find the same texel, " << nearEdge << " differ within 1e-4 of an edge, " << wrong
            << " differ elsewhere");
  CHECK(wrong == 0);
  CHECK(double(nearEdge) <= kMaxBoundaryShare * double(kCount));
  // No map (width 0): the background.
  const cl_float4 none = f4(0, 0, 0, 1);
  k.setArg(1, none);
  dev.queue.enqueueNDRangeKernel(k, cl::NullRange, cl::NDRange(1));
  dev.queue.finish();
  const cl_float4 background = dev.read<cl_float4>(out, 1)[0];
  CHECK((background.s[0] == -1.0f && background.s[1] == -1.0f && background.s[2] == -1.0f));
}

TEST_CASE("opencl blocks: BSDF sampling on the device agrees with bsdfSample for every material type")
{
  std::mt19937 rng(20);
  std::uniform_real_distribution<float> unit(0, 1), rough(0.05f, 1), ior(1.1f, 2);
  std::vector<cl_float4> materials(3 * kCount), wo(kCount), u(kCount);
  std::vector<Material> cpu(kCount);
  for (std::size_t i = 0; i < kCount; ++i) {
    Material& m = cpu[i];
    m.type = MaterialType(i % 5);
    m.color = Color(unit(rng), unit(rng), unit(rng));
    m.ior = ior(rng);
    m.roughness = m.type == MaterialType::Metal && i % 4 == 0 ? Real(0) : Real(rough(rng)); // smooth metal too
    const Color c(float(m.color.r), float(m.color.g), float(m.color.b));
    m.color = c;
    m.ior = Real(float(m.ior));
    m.roughness = Real(float(m.roughness));
    materials[3 * i] = f4(float(c.r), float(c.g), float(c.b), float(int(m.type)));
    materials[3 * i + 1] = f4(0, 0, 0, float(m.ior));
    materials[3 * i + 2] = f4(float(m.roughness), 0, 0);
    wo[i] = unitFloat(rng);
    u[i] = f4(unit(rng), unit(rng), unit(rng));
  }
  TestDevice& dev = device();
  const cl::Buffer bm = dev.input(materials), bwo = dev.input(wo), bu = dev.input(u);
  const cl::Buffer bwi = dev.output(kCount * sizeof(cl_float4)), bf = dev.output(kCount * sizeof(cl_float4));
  dev.run("testBsdf", kCount, {&bm, &bwo, &bu, &bwi, &bf});
  const std::vector<cl_float4> wi = dev.read<cl_float4>(bwi, kCount), f = dev.read<cl_float4>(bf, kCount);
  std::size_t samples = 0, boundary = 0;
  double worstDirection = 0, worstValue = 0;
  for (std::size_t i = 0; i < kCount; ++i) {
    const Vec3 w = v3(wo[i]);
    const std::optional<BsdfSample> expected =
        bsdfSample(cpu[i], w, Vec2(u[i].s[0], u[i].s[1]), Real(u[i].s[2]));
    const bool got = wi[i].s[3] > 0;
    // The glass's choice of lobe within 1e-4 of its reflectance F may go either way in float.
    if (cpu[i].type == MaterialType::Glass && std::abs(double(u[i].s[2]) - fresnelDielectric(w.z, cpu[i].ior)) <= 1e-4) {
      ++boundary;
      continue;
    }
    if (expected.has_value() != got) {
      // Otherwise only a direction at the horizon may differ.
      const bool horizon = got ? std::abs(wi[i].s[2]) <= 1e-3 : expected && std::abs(expected->wi.z) <= 1e-3;
      INFO("sample " << i << " of a " << materialTypeName(cpu[i].type));
      CHECK(horizon);
      ++boundary;
      continue;
    }
    if (!expected)
      continue;
    ++samples;
    INFO("sample " << i << " of a " << materialTypeName(cpu[i].type));
    const double direction = glm::length(v3(wi[i]) - expected->wi);
    const double pdf = std::abs(double(wi[i].s[3]) - expected->pdf) / expected->pdf;
    double value = pdf;
    for (int c = 0; c < 3; ++c)
      value = std::max(value, std::abs(double(f[i].s[c]) - expected->f[c]) / std::max(Real(1e-6), expected->f[c]));
    worstDirection = std::max(worstDirection, direction), worstValue = std::max(worstValue, value);
    CHECK(direction <= 1e-4);
    CHECK(value <= 2e-3);
    CHECK((f[i].s[3] != 0) == expected->specular);
  }
  std::cout << "BSDF sampling: " << samples << " samples of " << kCount << ", worst direction error " << worstDirection
            << ", worst relative error of f and pdf " << worstValue << ", " << boundary << " at a boundary\n";
  CHECK(samples > kCount / 2);
  CHECK(double(boundary) <= kMaxBoundaryShare * kCount);
}

TEST_CASE("opencl blocks: a work-group's scan gives each work-item the sum before it in its group, and the group's")
{
  // Random numbers of up to 2^16 + 1 (two flags packed, as shade packs them), in groups of several sizes (shade's
  // 64, and others, not all powers of 2); each group's prefix sums against a loop on the host.
  std::mt19937 rng(7);
  std::uniform_int_distribution<cl_uint> flag(0, 1);
  TestDevice& dev = device();
  for (const std::size_t group : {std::size_t(64), std::size_t(1), std::size_t(2), std::size_t(37), std::size_t(256)}) {
    const std::size_t n = group * 40;
    std::vector<cl_uint> value(n);
    for (cl_uint& v : value)
      v = flag(rng) | flag(rng) << 16;
    const cl::Buffer bv = dev.input(value), bb = dev.output(n * sizeof(cl_uint)), bt = dev.output(n * sizeof(cl_uint));
    cl::Kernel k(dev.program, "testScan");
    k.setArg(0, bv), k.setArg(1, bb), k.setArg(2, bt);
    dev.queue.enqueueNDRangeKernel(k, cl::NullRange, cl::NDRange(n), cl::NDRange(group));
    dev.queue.finish();
    const std::vector<cl_uint> before = dev.read<cl_uint>(bb, n), total = dev.read<cl_uint>(bt, n);
    std::size_t wrong = 0;
    for (std::size_t first = 0; first < n; first += group) {
      cl_uint sum = 0;
      for (std::size_t i = first; i < first + group; ++i) {
        wrong += before[i] != sum;
        sum += value[i];
      }
      for (std::size_t i = first; i < first + group; ++i)
        wrong += total[i] != sum;
    }
    INFO("groups of " << group);
    CHECK(wrong == 0);
  }
}

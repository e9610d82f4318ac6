// Chapter 17 — making it faster on a GPU: chapter 16's wavefront as OpenCL kernels, on any OpenCL device.
//
// Chapter 16 organised chapter 8's estimator as a wavefront: thousands of paths in flight, stored field by field,
// taken through stages that each do one step of the estimator for all of them. A GPU is made for exactly that shape
// of work: thousands of threads, each running the same small program (a kernel) on its own data (a work-item). So
// each stage becomes a kernel, written in OpenCL C (generate, extend, shade, connect, accumulate in stages.cl, the
// building blocks they call in blocks.cl), and this file is the host: it flattens the scene and chapter 9's tree into
// buffers in the device's memory once, then, for each batch of pixel samples the render loop hands it, launches the
// stages round after round until no path is left, and reads back each sample's radiance.
//
// The same kernel source runs on any OpenCL device: the driver compiles it when the program starts (PoCL's CPU
// device here and in CI; an NVIDIA, AMD or Intel GPU's driver elsewhere). It is float, as GPUs are; the random
// numbers are still keyed by (seed, pixel, sample), so a device renders the same image every time; and the estimator
// is chapter 8's (lights chosen by power; a triangle light sampled by area), so the image agrees with chapter 8's by
// the z-test, not bit for bit.
#include "opencl_device.h"

#include "render/guided_lights.h"
#include "render/runner.h"
#include "scene/scene_plan.h"

#include <cstdint>
#include <cstdlib>
#include <iostream>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <vector>

using namespace raylife;

namespace {

// The entries of the tree walk's stack in blocks.cl (kStackSize there).
constexpr int kStackSize = 449;

cl_float4 float4(const Vec3& v, Real w = 0) { return cl_float4{{float(v.x), float(v.y), float(v.z), float(w)}}; }

// A read-only buffer holding `data` (a buffer may not be empty: one zero element stands in for none).
template <class T> cl::Buffer upload(const cl::Context& context, std::vector<T> data)
{
  if (data.empty())
    data.resize(1);
  return cl::Buffer(context, CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, data.size() * sizeof(T), data.data());
}

/// [flatten]
// The scene as the kernels read it, made once on the host: spheres, vertices and triangles, chapter 9's eight-wide
// tree as the CPU walks it (its nodes byte for byte, and the order its leaves hold the primitives in), the
// materials, and the lights with the cumulative distribution that chooses one by its power.
struct DeviceScene {
  cl::Buffer spheres, sphereMaterials, vertices, triangles, nodes, leafSpheres, leafTriangles, outside;
  cl::Buffer materials, lightInfo, lightCdf, lightProbability, pointLights, vertexNormals, smooth, environment;
  int sphereCount = 0, triangleCount = 0, nodeCount = 0, outsideCount = 0, lightCount = 0, hasNormals = 0;
  cl_float4 background{};
  // The environment map's width and height (0: none, and a ray that leaves the scene sees `background`), and the
  // sine and cosine of its turn; its texels, scale applied, in `environment`, row 0 first.
  cl_float4 environmentInfo{};

  DeviceScene(const cl::Context& context, const Scene& scene, bool sampleLights)
  {
    // The kernels square lengths, and a triangle's area squares a squared one, in float: past kMaxSceneExtentFloat
    // (the float build's own bound) that leaves float's range, and the image would be wrong without a word.
    if (const std::string beyond = beyondSceneExtent(scene, kMaxSceneExtentFloat); !beyond.empty())
      throw ChapterError(scene.fileName + ": " + beyond + ", lies beyond ±1e8, the largest scene the float kernels "
                         "can square (the float build's bound; scale the scene down)");
    // And below kMinSceneLengthFloat what they square leaves float's normal numbers.
    if (const std::string below = belowSceneLength(scene, kMinSceneLengthFloat); !below.empty())
      throw ChapterError(scene.fileName + ": " + below + ", lies below 1e-8, the smallest length the float kernels "
                         "can square (the float build's bound; scale the scene up)");
    std::vector<cl_float4> sphereData, vertexData, normalData;
    std::vector<cl_int> sphereMaterial;
    for (const Sphere& s : scene.spheres) {
      sphereData.push_back(float4(s.center, s.radius));
      sphereMaterial.push_back(s.material);
    }
    // (Padded to a multiple of 8 with spheres no query asks about: a CPU device reads them eight at a time.)
    sphereData.resize((sphereData.size() + 7) / 8 * 8, cl_float4{{0, 0, 0, 0}});
    for (const Vec3& v : scene.vertices)
      vertexData.push_back(float4(v));
    for (const Vec3& n : scene.vertexNormals)
      normalData.push_back(float4(n));
    std::vector<cl_uint4> triangleData;
    std::vector<cl_uchar> smoothData;
    for (const Triangle& t : scene.triangles) {
      triangleData.push_back(cl_uint4{{t.v[0], t.v[1], t.v[2], cl_uint(t.material)}});
      smoothData.push_back(scene.meshes[t.mesh].smooth ? 1 : 0);
    }
    // The tree the CPU walks (none for a short list: the kernels then loop over every primitive).
    const Bvh& tree = scene.accelerator;
    const bool useTree = scene.usesAccelerator();
    if (useTree && 1 + 7 * tree.depth() > kStackSize)
      throw ChapterError("chapter 9's tree is " + std::to_string(tree.depth()) + " levels deep, more than the kernels' "
                         "stack holds (kStackSize in blocks.cl)");
    std::vector<BvhWideNode> nodeData = useTree ? tree.wideNodes() : std::vector<BvhWideNode>{};
    const std::vector<int> outsideData = useTree ? tree.outsidePrimitives() : std::vector<int>{};
    std::vector<cl_uint> leafSphereData = useTree ? tree.leafPrimitives(false) : std::vector<cl_uint>{};
    std::vector<cl_uint> leafTriangleData = useTree ? tree.leafPrimitives(true) : std::vector<cl_uint>{};
    // Materials: (colour, type), (emission, ior), (roughness).
    std::vector<cl_float4> materialData;
    for (const Material& m : scene.materials) {
      // The kernels square a glass's index in float (the Fresnel equations), past which it would be infinite.
      if (m.type == MaterialType::Glass && m.ior > kMaxIorFloat)
        throw ChapterError(scene.fileName + ": material '" + m.name + "': an index of refraction above 1e10 is "
                           "beyond what the float kernels can square (diamond's is 2.42)");
      materialData.push_back(float4(m.color, Real(int(m.type))));
      materialData.push_back(float4(m.emission, m.ior));
      materialData.push_back(cl_float4{{float(m.roughness), 0, 0, 0}});
    }
    // Lights by power Φ (as LightSampler: π·Le·area for an emitter, 4π·I for a point light), then the cdf.
    std::vector<cl_int4> info;
    std::vector<double> power;
    for (std::size_t p = 0; p < scene.primitiveCount(); ++p) {
      const Material& m = scene.materials[std::size_t(scene.materialOf(int(p)))];
      if (!sampleLights || !m.isEmissive())
        continue;
      double area = 0;
      if (p < scene.spheres.size())
        area = 4 * kPi * scene.spheres[p].radius * scene.spheres[p].radius;
      else {
        const auto [p0, p1, p2] = scene.triangleVertices(p - scene.spheres.size());
        area = triangleDoubleArea(p0, p1, p2) / 2;
      }
      info.push_back(cl_int4{{p < scene.spheres.size() ? 1 : 2, int(p), 0, 0}});
      power.push_back(double(luminance(m.emission)) * kPi * area);
    }
    std::vector<cl_float4> pointData;
    for (std::size_t i = 0; i < scene.lights.size() && sampleLights; ++i) {
      info.push_back(cl_int4{{0, int(i), 0, 0}});
      power.push_back(4 * kPi * double(luminance(scene.lights[i].intensity)));
      pointData.push_back(float4(scene.lights[i].position));
      pointData.push_back(float4(scene.lights[i].intensity));
    }
    double total = 0;
    for (const double p : power)
      total += p;
    std::vector<cl_float> cdf, probability(scene.primitiveCount(), 0.0f);
    if (total > 0) {
      double running = 0;
      for (std::size_t k = 0; k < power.size(); ++k) {
        running += power[k];
        cdf.push_back(float(running / total));
        if (info[k].s[0] != 0)
          probability[std::size_t(info[k].s[1])] = float(power[k] / total);
      }
      cdf.back() = 1;
      lightCount = int(info.size());
    }
    spheres = upload(context, sphereData);
    sphereMaterials = upload(context, sphereMaterial);
    vertices = upload(context, vertexData);
    triangles = upload(context, triangleData);
    nodes = upload(context, nodeData);
    leafSpheres = upload(context, leafSphereData);
    leafTriangles = upload(context, leafTriangleData);
    outside = upload(context, outsideData);
    materials = upload(context, materialData);
    lightInfo = upload(context, info);
    lightCdf = upload(context, cdf);
    lightProbability = upload(context, probability);
    pointLights = upload(context, pointData);
    vertexNormals = upload(context, normalData);
    smooth = upload(context, smoothData);
    sphereCount = int(scene.spheres.size());
    triangleCount = int(scene.triangles.size());
    nodeCount = int(nodeData.size());
    outsideCount = int(outsideData.size());
    hasNormals = normalData.empty() ? 0 : 1;
    background = float4(scene.background);
    std::vector<cl_float4> texels;
    if (scene.environment) {
      const EnvironmentMap& map = *scene.environment;
      const TexelImage& image = map.image();
      for (int y = 0; y < image.height; ++y)
        for (int x = 0; x < image.width; ++x)
          texels.push_back(float4(Vec3(image.texel(x, y) * map.scale())));
      environmentInfo = cl_float4{
          {float(image.width), float(image.height), float(map.rotation().sin), float(map.rotation().cos)}};
    }
    environment = upload(context, texels);
  }

  // The scene's arguments, first of every kernel that traces (GEOMETRY_ARGS in stages.cl).
  void setGeometry(cl::Kernel& k) const
  {
    int a = 0;
    for (const cl::Buffer* b : {&spheres, &sphereMaterials, &vertices, &triangles, &nodes, &leafSpheres,
                                &leafTriangles, &outside})
      k.setArg(cl_uint(a++), *b);
    for (const int v : {sphereCount, triangleCount, nodeCount, outsideCount})
      k.setArg(cl_uint(a++), cl_int(v));
  }
};
/// [flatten]

constexpr cl_uint kGeometryArgs = 12;

// One queue of paths on the device, field by field (structure of arrays).
struct PathBuffers {
  cl::Buffer origin, direction, beta, from, rng, slot;
  PathBuffers(const cl::Context& c, std::size_t n)
      : origin(c, CL_MEM_READ_WRITE, n * sizeof(cl_float4)), direction(c, CL_MEM_READ_WRITE, n * sizeof(cl_float4)),
        beta(c, CL_MEM_READ_WRITE, n * sizeof(cl_float4)), from(c, CL_MEM_READ_WRITE, n * sizeof(cl_float4)),
        rng(c, CL_MEM_READ_WRITE, n * sizeof(cl_ulong2)), slot(c, CL_MEM_READ_WRITE, n * sizeof(cl_uint))
  {
  }
  std::vector<const cl::Buffer*> all() const { return {&origin, &direction, &beta, &from, &rng, &slot}; }
};

// The device, its compiled stages, the scene in its memory and the queues of one wavefront of up to `capacity`
// paths.
class DeviceWavefront {
public:
  DeviceWavefront(const opencl::DeviceInfo& device, const Scene& scene, bool sampleLights, MisHeuristic heuristic,
                  std::size_t capacity)
      : context_(device.device), queue_(context_, device.device),
        program_(opencl::buildProgram(context_, device.device, opencl::kernelSource(),
                                      "-D GROUP_SIZE=" + std::to_string(kGroupSize) +
                                          (device.gpu ? "" : " -D BOX_LANES=1 -D SPHERE_LANES=1"))),
        scene_(context_, scene, sampleLights), power_(heuristic == MisHeuristic::Power),
        paths_{PathBuffers(context_, capacity), PathBuffers(context_, capacity)},
        keys_(context_, CL_MEM_READ_ONLY, capacity * sizeof(cl_int4)),
        hitT_(context_, CL_MEM_READ_WRITE, capacity * sizeof(cl_float)),
        hitPrimitive_(context_, CL_MEM_READ_WRITE, capacity * sizeof(cl_int)),
        shadows_(context_, capacity), shadowLight_(context_, CL_MEM_READ_WRITE, capacity * sizeof(cl_float4)),
        blocked_(context_, CL_MEM_READ_WRITE, capacity),
        counts_(context_, CL_MEM_READ_WRITE, 2 * sizeof(cl_uint)),
        radiance_(context_, CL_MEM_READ_WRITE, capacity * sizeof(cl_float4)),
        generate_(program_, "generate"), extend_(program_, "extend"), shade_(program_, "shade"),
        connect_(program_, "connect"), accumulate_(program_, "accumulate")
  {
    for (cl::Kernel* k : {&extend_, &shade_, &connect_})
      scene_.setGeometry(*k);
  }

  /// [rounds]
  // The radiance of every pixel sample of `keys` (at most the capacity): generate, then rounds of extend, shade,
  // connect and accumulate until no path is left, then one read of the radiance.
  void render(const PrimaryRays& primary, const Camera& camera, std::span<const PixelSampleKey> keys, int maxDepth,
              std::span<Color> out)
  {
    const auto n = cl_uint(keys.size());
    hostKeys_.resize(keys.size());
    for (std::size_t i = 0; i < keys.size(); ++i)
      hostKeys_[i] = cl_int4{{keys[i].x, keys[i].y, keys[i].sample, 0}};
    queue_.enqueueWriteBuffer(keys_, CL_FALSE, 0, n * sizeof(cl_int4), hostKeys_.data());
    // Stage 1: the camera rays, as the render loop makes them (the pixel's stratum or sequence, then the pinhole).
    const CameraBasis& b = camera.basis();
    const Real halfHeight = Real(camera.height()) / (2 * camera.unitPixelDistance());
    const Real halfWidth = halfHeight * Real(camera.width()) / Real(camera.height());
    int a = 0;
    generate_.setArg(cl_uint(a++), keys_);
    generate_.setArg(cl_uint(a++), n);
    generate_.setArg(cl_uint(a++), cl_ulong(primary.seed()));
    generate_.setArg(cl_uint(a++), cl_int(primary.pixelSampling() == PixelSampling::Jittered));
    generate_.setArg(cl_uint(a++), cl_int(primary.strata()));
    generate_.setArg(cl_uint(a++), float4(camera.eye()));
    generate_.setArg(cl_uint(a++), float4(b.u));
    generate_.setArg(cl_uint(a++), float4(b.v));
    generate_.setArg(cl_uint(a++), float4(b.w));
    generate_.setArg(cl_uint(a++), cl_float4{{float(halfWidth), float(halfHeight), float(camera.width()),
                                               float(camera.height())}});
    for (const cl::Buffer* buffer : paths_[0].all())
      generate_.setArg(cl_uint(a++), *buffer);
    generate_.setArg(cl_uint(a++), radiance_);
    launch(generate_, n);

    cl_uint count = n;
    int current = 0;
    for (int bounce = 0; count > 0; ++bounce) {
      const PathBuffers& in = paths_[current];
      const PathBuffers& next = paths_[1 - current];
      // Stage 2: the nearest hits.
      extend_.setArg(kGeometryArgs, count);
      extend_.setArg(kGeometryArgs + 1, in.origin);
      extend_.setArg(kGeometryArgs + 2, in.direction);
      extend_.setArg(kGeometryArgs + 3, hitT_);
      extend_.setArg(kGeometryArgs + 4, hitPrimitive_);
      launch(extend_, count);
      // Stage 3: shade, into the next round's queue and the shadow rays' (their counts start at 0).
      const cl_uint zero[2] = {0, 0};
      queue_.enqueueWriteBuffer(counts_, CL_FALSE, 0, sizeof zero, zero);
      cl_uint s = kGeometryArgs;
      for (const cl::Buffer* buffer : {&scene_.materials, &scene_.lightInfo, &scene_.lightCdf,
                                       &scene_.lightProbability, &scene_.pointLights})
        shade_.setArg(s++, *buffer);
      shade_.setArg(s++, cl_int(scene_.lightCount));
      shade_.setArg(s++, scene_.vertexNormals);
      shade_.setArg(s++, scene_.smooth);
      shade_.setArg(s++, cl_int(scene_.hasNormals));
      shade_.setArg(s++, scene_.background);
      shade_.setArg(s++, scene_.environment);
      shade_.setArg(s++, scene_.environmentInfo);
      shade_.setArg(s++, cl_int(bounce));
      shade_.setArg(s++, cl_int(maxDepth));
      shade_.setArg(s++, cl_int(power_));
      shade_.setArg(s++, count);
      for (const cl::Buffer* buffer : in.all())
        shade_.setArg(s++, *buffer);
      shade_.setArg(s++, hitT_);
      shade_.setArg(s++, hitPrimitive_);
      for (const cl::Buffer* buffer : next.all())
        shade_.setArg(s++, *buffer);
      shade_.setArg(s++, shadows_.origin);
      shade_.setArg(s++, shadows_.direction);
      shade_.setArg(s++, shadowLight_);
      shade_.setArg(s++, shadows_.slot);
      shade_.setArg(s++, counts_);
      shade_.setArg(s++, radiance_);
      launch(shade_, count);
      // Stages 4 and 5: the shadow rays (at most one a path; the kernels read how many there are), and their light.
      connect_.setArg(kGeometryArgs, counts_);
      connect_.setArg(kGeometryArgs + 1, shadows_.origin);
      connect_.setArg(kGeometryArgs + 2, shadows_.direction);
      connect_.setArg(kGeometryArgs + 3, blocked_);
      launch(connect_, count);
      accumulate_.setArg(0, counts_);
      accumulate_.setArg(1, shadowLight_);
      accumulate_.setArg(2, shadows_.slot);
      accumulate_.setArg(3, blocked_);
      accumulate_.setArg(4, radiance_);
      launch(accumulate_, count);
      // How many paths go on (the one wait of a round: the host needs it to size the next launch).
      cl_uint counts[2];
      queue_.enqueueReadBuffer(counts_, CL_TRUE, 0, sizeof counts, counts);
      countRays(std::uint64_t(count) + counts[1]);
      count = counts[0];
      current = 1 - current;
    }
    hostRadiance_.resize(keys.size());
    queue_.enqueueReadBuffer(radiance_, CL_TRUE, 0, n * sizeof(cl_float4), hostRadiance_.data());
    for (std::size_t i = 0; i < keys.size(); ++i)
      out[i] = Color(hostRadiance_[i].s[0], hostRadiance_[i].s[1], hostRadiance_[i].s[2]);
  }
  /// [rounds]

private:
  // One work-item a path, in work-groups of a fixed size: the kernels ignore the items past n. (Left to the driver,
  // the group size follows n, and PoCL compiles the kernel again for every new size: minutes of compiling. Shade's
  // scan is built for this size, as GROUP_SIZE, and asks for it.)
  void launch(cl::Kernel& kernel, cl_uint n)
  {
    const cl_uint groups = (n + kGroupSize - 1) / kGroupSize;
    queue_.enqueueNDRangeKernel(kernel, cl::NullRange, cl::NDRange(groups * kGroupSize), cl::NDRange(kGroupSize));
  }
  static constexpr cl_uint kGroupSize = 64;

  cl::Context context_;
  cl::CommandQueue queue_;
  cl::Program program_;
  DeviceScene scene_;
  bool power_;
  PathBuffers paths_[2]; // this round's paths and the next round's, in turn
  cl::Buffer keys_, hitT_, hitPrimitive_;
  PathBuffers shadows_; // the shadow rays: origin (and tmax), direction, slot (its other fields unused)
  cl::Buffer shadowLight_, blocked_, counts_, radiance_;
  cl::Kernel generate_, extend_, shade_, connect_, accumulate_;
  std::vector<cl_int4> hostKeys_;
  std::vector<cl_float4> hostRadiance_;
};

// --list-devices: every platform's devices, numbered as --device takes them.
int listDevices()
{
  const std::vector<opencl::DeviceInfo> devices = opencl::listDevices();
  if (devices.empty()) {
    std::cerr << "step17_opencl: " << opencl::noDeviceMessage() << "\n";
    return 1;
  }
  for (std::size_t i = 0; i < devices.size(); ++i) {
    const opencl::DeviceInfo& d = devices[i];
    std::cout << i << ": " << d.name << " (" << (d.gpu ? "GPU" : "not a GPU") << "; platform " << d.platform << "; "
              << d.computeUnits << " compute units, " << d.memory / (1024 * 1024) << " MiB; " << d.version << ")\n";
  }
  return 0;
}

} // namespace

int main(int argc, char** argv)
{
  /// [chapter]
  const ChapterInfo chapter{.binary = "step17_opencl",
                            .defaultScene = "smallpt.json",
                            .uses = kUsesSpheres | kUsesColors | kUsesPointLights | kUsesBackground |
                                    kUsesEnvironment | kUsesEmission | kUsesMirror | kUsesGlass | kUsesGlossy |
                                    kUsesMaxDepth | kSamplesLights | kUsesMetal,
                            .pixelSampling = PixelSampling::Jittered,
                            .defaultSpp = 64,
                            .defaultMaxDepth = -1,
                            .adaptiveSampling = true,
                            .options = {kHeuristicOption,
                                        {.name = "--device",
                                         .kind = OptionKind::Integer,
                                         .help = "the OpenCL device to render on, numbered as --list-devices "
                                                 "shows them (-1: the first GPU, else the first device)",
                                         .defaultValue = "-1",
                                         .min = -1,
                                         .max = 1 << 20},
                                        {.name = "--list-devices",
                                         .kind = OptionKind::Flag,
                                         .help = "list every OpenCL platform's devices, and render nothing"},
                                        {.name = "--wavefront",
                                         .kind = OptionKind::Integer,
                                         .help = "most paths in flight on the device at once (about 300 bytes of "
                                                 "its memory each)",
                                         .defaultValue = "262144",
                                         .min = 1,
                                         .max = 1 << 24}}};
  /// [chapter]
  for (int i = 1; i < argc; ++i)
    if (std::string_view(argv[i]) == "--list-devices")
      return listDevices();

  auto makeWavefront = [&chapter](const Scene& scene, const ChapterOptions& options) -> Wavefront {
    const opencl::DeviceInfo device = opencl::chooseDevice(int(options.integer("--device")));
    const bool sampleLights = planScene(scene, chapter.uses).lightSampling();
    const auto capacity = std::size_t(options.integer("--wavefront"));
    if (options.verbose())
      std::cerr << chapter.binary << ": plan: on " << device.name << " (" << device.platform << ", "
                << device.computeUnits << " compute units), wavefronts of up to " << capacity << " paths; "
                << (scene.usesAccelerator() ? "chapter 9's tree" : "a flat list of primitives") << " in its memory, "
                << (device.gpu                  ? "tested one box or sphere at a time (a GPU)"
                    : scene.usesAccelerator() ? "a node's eight boxes tested at once in float8 lanes (a CPU device)"
                                              : "its spheres tested eight at a time in float8 lanes (a CPU device)")
                << "\n";
    std::shared_ptr<DeviceWavefront> wavefront;
    try {
      wavefront = std::make_shared<DeviceWavefront>(device, scene, sampleLights, heuristicOption(options), capacity);
    } catch (const cl::Error& e) {
      throw ChapterError("OpenCL on " + device.name + ": " + opencl::describe(e));
    }
    // One host thread feeds the device, a whole image a tile (the device is what runs the paths in parallel).
    auto workers = [wavefront]() -> WavefrontFunction {
      return [wavefront](const Scene&, const PrimaryRays& primary, std::span<const PixelSampleKey> keys,
                         int maxDepth, std::span<Color> out) {
        try {
          wavefront->render(primary, primary.camera(), keys, maxDepth, out);
        } catch (const cl::Error& e) { // (in the render loop's thread, which no exception may leave)
          std::cerr << "step17_opencl: OpenCL: " << opencl::describe(e) << "; nothing was written\n";
          std::exit(1);
        }
      };
    };
    return Wavefront{.workers = workers, .size = capacity, .threads = 1, .tileSize = 1 << 13, .device = device.name};
  };
  return runWavefrontChapter(argc, argv, chapter, makeWavefront);
}

#include "scene_check.h"

#include "scene/scene.h"
#include "shading/density_grid.h"

#include <cmath>
#include <filesystem>
#include <fstream>
#include <optional>

#include <unistd.h>

namespace raylife::fuzz {

namespace {

bool finite(const Vec3& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }
bool nonNegative(const Color& c) { return finite(c) && c.r >= 0 && c.g >= 0 && c.b >= 0; }

// True when `s` is valid UTF-8 with no control characters: safe to print on one terminal line.
bool printableLine(const std::string& s)
{
  for (std::size_t i = 0; i < s.size();) {
    const auto c = static_cast<unsigned char>(s[i]);
    if (c < 0x20 || c == 0x7f)
      return false;
    std::size_t n = c < 0x80 ? 1 : (c >> 5) == 0x6 ? 2 : (c >> 4) == 0xe ? 3 : (c >> 3) == 0x1e ? 4 : 0;
    if (n == 0 || i + n > s.size())
      return false;
    for (std::size_t k = 1; k < n; ++k)
      if ((static_cast<unsigned char>(s[i + k]) >> 6) != 0x2)
        return false;
    i += n;
  }
  return true;
}

// The invariants of a scene's meshes: every index in range, every vertex finite, no triangle without area, the
// meshes' ranges covering the triangles, unit normals for the smooth meshes' vertices, materials in range.
std::string checkMeshes(const Scene& scene)
{
  for (const Vec3& v : scene.vertices)
    if (!withinSceneExtent(v))
      return "a mesh vertex beyond the bound on a scene's size was accepted";
  if (!scene.vertexNormals.empty() && scene.vertexNormals.size() != scene.vertices.size())
    return "vertex normals that do not match the vertices";
  std::size_t covered = 0;
  for (std::size_t m = 0; m < scene.meshes.size(); ++m) {
    const Mesh& mesh = scene.meshes[m];
    if (mesh.firstTriangle != covered || mesh.triangleCount == 0)
      return "a mesh's range of triangles is wrong";
    covered += mesh.triangleCount;
    if (mesh.material < 0 || std::size_t(mesh.material) >= scene.materials.size())
      return "a mesh's material index is out of range";
    for (std::size_t t = mesh.firstTriangle; t < covered && t < scene.triangles.size(); ++t) {
      const Triangle& tri = scene.triangles[t];
      if (tri.mesh != m || tri.material != mesh.material)
        return "a triangle's mesh or material is wrong";
      for (std::uint32_t v : tri.v) {
        if (v >= scene.vertices.size())
          return "a triangle's vertex index is out of range";
        if (mesh.smooth && std::abs(glm::length(scene.vertexNormals[v]) - 1) > Real(1e-3))
          return "a smooth mesh's vertex normal is not unit";
      }
      const auto [p0, p1, p2] = scene.triangleVertices(t);
      if (!(triangleDoubleArea(p0, p1, p2) >= Real(kMinSceneLength * kMinSceneLength)))
        return "a degenerate triangle was kept";
    }
  }
  if (covered != scene.triangles.size())
    return "triangles outside every mesh";
  return "";
}

// A message must be one printable line, not too long, starting with `name`.
std::string checkMessage(const std::string& message, const std::string& name)
{
  if (message.rfind(name, 0) != 0)
    return "the message does not start with the file name: " + message;
  if (!printableLine(message))
    return "the message is not one printable UTF-8 line";
  if (message.size() > 2000)
    return "the message is longer than 2000 characters";
  return "";
}

// The promises of an image the readers accept: a size in [1, kMaxTexels], width·height·3 texels, finite and ≥ 0.
std::string checkTexels(const TexelImage& image)
{
  if (image.width < 1 || image.height < 1 || (long long)image.width * image.height > kMaxTexels)
    return "an image of " + std::to_string(image.width) + "x" + std::to_string(image.height) + " was accepted";
  if (image.rgb.size() != std::size_t(image.width) * std::size_t(image.height) * 3)
    return "texels that do not match the size";
  for (float v : image.rgb)
    if (!std::isfinite(v) || v < 0)
      return "a texel that is negative or not finite was accepted";
  return "";
}

} // namespace

std::string checkMeshBytes(std::string_view bytes, MeshFormat format)
{
  MeshData data;
  try {
    data = parseMeshData(std::span<const char>(bytes.data(), bytes.size()), format, "fuzz.mesh");
  } catch (const MeshError& e) {
    return checkMessage(e.what(), "fuzz.mesh");
  }
  if (data.triangles.empty())
    return "a mesh without triangles was accepted";
  if (!data.normals.empty() && data.normals.size() != data.positions.size())
    return "normals that do not match the positions";
  for (const Vec3& p : data.positions)
    if (!finite(p))
      return "a vertex that is not finite was accepted";
  for (const auto& tri : data.triangles)
    for (std::uint32_t v : tri)
      if (v >= data.positions.size())
        return "an index out of range was accepted";
  return "";
}

std::string checkImageBytes(std::string_view bytes, ImageEncoding encoding)
{
  TexelImage image;
  try {
    image = decodeStbImage(std::span<const unsigned char>(reinterpret_cast<const unsigned char*>(bytes.data()),
                                                          bytes.size()),
                           encoding, "fuzz.image");
  } catch (const ImageFileError& e) {
    return checkMessage(e.what(), "fuzz.image");
  }
  return checkTexels(image);
}

namespace {

// This process's own folder for the inputs that readers take as files (the fuzzers and the regression test may run
// side by side), made on first use and removed at exit.
struct InputFolder {
  std::filesystem::path path =
      std::filesystem::temp_directory_path() / ("raylife-fuzz-" + std::to_string(::getpid()));
  InputFolder() { std::filesystem::create_directories(path); }
  InputFolder(const InputFolder&) = delete;
  InputFolder& operator=(const InputFolder&) = delete;
  ~InputFolder()
  {
    std::error_code ignored;
    std::filesystem::remove_all(path, ignored);
  }
};

// Writes `bytes` to the file `name` in the process's input folder; returns its path.
std::string writeInput(std::string_view bytes, const std::string& name)
{
  static const InputFolder folder;
  const std::string path = (folder.path / name).string();
  std::ofstream(path, std::ios::binary | std::ios::trunc).write(bytes.data(), std::streamsize(bytes.size()));
  return path;
}

} // namespace

std::string checkFilmBytes(std::string_view bytes)
{
  const std::string path = writeInput(bytes, "fuzz.film");
  std::optional<PartialFilm> read;
  try {
    read = readFilm(path);
  } catch (const FilmError& e) {
    return checkMessage(e.what(), path);
  }
  const PartialFilm& film = *read;
  const FilmHeader& h = film.header;
  if (h.width < 1 || h.height < 1 || film.film.width() != h.width || film.film.height() != h.height)
    return "a film whose size does not match its header was accepted";
  for (std::size_t i = 0; i < h.samples.size(); ++i)
    if (h.samples[i].count < 1 || (i > 0 && h.samples[i].first <= h.samples[i - 1].end()))
      return "sample ranges out of order, touching or empty were accepted";
  if (h.sampleCount() > std::int64_t(kMaxSamplesPerPixel))
    return "more samples than kMaxSamplesPerPixel were accepted";
  for (int y = 0; y < h.height; ++y)
    for (int x = 0; x < h.width; ++x)
      if (film.film.samples(x, y) > kMaxSamplesPerPixel)
        return "a pixel with more than kMaxSamplesPerPixel samples was accepted";
  (void)film.film.mean();
  PartialFilm total = film;
  try {
    mergeFilm(total, path, film, path);
    if (!h.samples.empty())
      return "a film that holds samples merged with itself";
  } catch (const FilmError& e) {
    return checkMessage(e.what(), path);
  }
  return "";
}

std::string checkFloatImageBytes(std::string_view bytes, const std::string& extension)
{
  const std::string path = writeInput(bytes, "fuzz" + extension);
  TexelImage image;
  try {
    image = readTextureImage(path, ImageEncoding::Linear);
  } catch (const ImageFileError& e) {
    return checkMessage(e.what(), path);
  }
  return checkTexels(image);
}

namespace {

// The promises of a medium the loader accepts: coefficients finite and ≥ 0, |g| < 1; and of its density grid, if
// it has one: its size, box and values as the format allows, its majorants at least every value, and a crossing of
// its box at the majorant of at most 1e9 tentative collisions, with finite sums of three rates. Where a crossing
// is cheap (10^4 collisions at most), delta and ratio tracking then run along rays through the box, from outside,
// from inside and from far away (where t's numbers are coarse): each must end, with finite weights ≥ 0 and a
// transmittance in [0, 1].
std::string checkMedium(const Medium& m)
{
  if (!nonNegative(m.sigmaA) || !nonNegative(m.sigmaS) || !(m.g > -1 && m.g < 1))
    return "medium '" + m.name + "' has a value out of range";
  if (!m.density)
    return "";
  const DensityGrid& grid = *m.density;
  const std::size_t cells = std::size_t(grid.nx) * std::size_t(grid.ny) * std::size_t(grid.nz);
  if (grid.nx < 1 || grid.ny < 1 || grid.nz < 1 || grid.nx > 512 || grid.ny > 512 || grid.nz > 512 ||
      grid.values.size() != cells)
    return "a density grid of the wrong size was accepted";
  if (!withinSceneExtent(grid.lo) || !withinSceneExtent(grid.hi) || !(grid.lo.x < grid.hi.x) ||
      !(grid.lo.y < grid.hi.y) || !(grid.lo.z < grid.hi.z))
    return "a density grid with a bad box was accepted";
  if (grid.majorants.size() != std::size_t(grid.mx) * std::size_t(grid.my) * std::size_t(grid.mz))
    return "a density grid's majorants do not match their size";
  for (const float v : grid.values)
    if (!std::isfinite(v) || v < 0 || !(Real(v) <= grid.globalMajorant))
      return "a density that is negative, not finite or above the global majorant was accepted";
  const Color sigmaT = m.sigmaT();
  const Real sMax = std::max({sigmaT.r, sigmaT.g, sigmaT.b});
  const double thickness = double(sMax) * double(grid.globalMajorant) * grid.diagonal();
  if (!std::isfinite(Real(3) * (sMax * grid.globalMajorant)) || !(thickness <= 1e9)) // (as the loader reckons it)
    return "a density medium that takes more than 1e9 steps to cross was accepted";
  if (!(thickness <= 1e4))
    return "";
  const Vec3 centre = grid.lo + (grid.hi - grid.lo) * Real(0.5), size = grid.hi - grid.lo;
  const Vec3 far = centre + size * Real(1e15); // (there t's numbers are a seventh of the box's diagonal apart)
  const Ray rays[] = {
      {grid.lo - size, safeNormalize(size, Vec3(1, 0, 0))},
      {Vec3(grid.lo.x - size.x, centre.y, centre.z), Vec3(1, 0, 0)},
      {Vec3(centre.x, grid.hi.y + size.y, centre.z), Vec3(0, -1, 0)},
      {centre, safeNormalize(Vec3(1, 2, -3), Vec3(0, 0, 1))},
      {far, safeNormalize(centre - far, Vec3(0, 0, -1))},
  };
  Sampler sampler(1, 0, 0, 0);
  for (const bool global : {false, true})
    for (const Ray& ray : rays) {
      if (!finite(ray.origin) || !finite(ray.direction))
        continue;
      const TrackedFlight f = deltaTrack(grid, global, m.sigmaA, m.sigmaS, ray, kInfinity, sampler);
      if (!nonNegative(f.weight) || !(f.t >= 0) || (f.scattered && !std::isfinite(f.t)))
        return "delta tracking through medium '" + m.name + "' gave a bad weight or distance";
      const Color tr = ratioTrack(grid, global, sigmaT, ray, kInfinity, sampler);
      if (!nonNegative(tr) || tr.r > 1 || tr.g > 1 || tr.b > 1)
        return "ratio tracking through medium '" + m.name + "' gave a transmittance outside [0, 1]";
    }
  return "";
}

} // namespace

std::string checkSceneText(std::string_view text)
{
  // "SCENE\n#density\nGRID": the grid is the file "density.json" beside the scene, which the scene may name; without
  // the marker there is no such file.
  constexpr std::string_view marker = "\n#density\n";
  const std::size_t split = text.find(marker);
  const std::string densityFile =
      writeInput(split == std::string_view::npos ? std::string_view() : text.substr(split + marker.size()),
                 "density.json");
  if (split == std::string_view::npos)
    std::filesystem::remove(densityFile);
  const std::string sceneFile = (std::filesystem::path(densityFile).parent_path() / "fuzz.json").string();
  Scene scene;
  try {
    scene = parseScene(text.substr(0, split), sceneFile);
  } catch (const SceneError& e) {
    return checkMessage(e.what(), sceneFile + ":");
  }
  if (scene.spheres.empty() && scene.triangles.empty())
    return "a scene without spheres or triangles was accepted";
  if (std::string problem = checkMeshes(scene); !problem.empty())
    return problem;
  for (const Sphere& s : scene.spheres) {
    if (!withinSceneExtent(s.center) || !(s.radius >= Real(kMinSceneLength)) || !withinSceneExtent(s.radius))
      return "a sphere with a bad centre or radius was accepted";
    if (s.material < 0 || std::size_t(s.material) >= scene.materials.size())
      return "a sphere's material index is out of range";
    if (!finite(s.velocity) || !withinSceneExtent(s.center + s.velocity))
      return "a sphere with a bad velocity was accepted";
  }
  for (const Material& m : scene.materials)
    if (!nonNegative(m.color) || !nonNegative(m.emission) || !(m.ior >= 1 && m.ior <= kMaxIor) ||
        !(m.roughness >= 0 && m.roughness <= 1) || (m.type != MaterialType::Metal && !(m.roughness > 0)))
      return "material '" + m.name + "' has a value out of range";
  for (const PointLight& l : scene.lights)
    if (!withinSceneExtent(l.position) || !nonNegative(l.intensity))
      return "a light has a bad position or intensity";
  if (!nonNegative(scene.background) || !nonNegative(scene.ambient))
    return "a bad background or ambient term was accepted";
  const CameraSpec& c = scene.camera;
  if (c.width < 1 || c.height < 1 || std::int64_t(c.width) * c.height > kMaxPixels)
    return "an image size out of range was accepted";
  if (!(c.vfovDeg > 0 && c.vfovDeg < 180))
    return "a field of view out of range was accepted";
  if (!(c.aperture >= 0 && withinSceneExtent(c.aperture)) || !(c.focus >= 0 && withinSceneExtent(c.focus)))
    return "a lens with a bad aperture or focus was accepted";
  if (!withinSceneExtent(c.eye) || !withinSceneExtent(c.focal) || !finite(c.basis.u) || !finite(c.basis.v) ||
      !finite(c.basis.w))
    return "a camera with a non-finite eye or basis was accepted";
  const Real tolerance = Real(1e-3);
  if (std::abs(glm::length(c.basis.u) - 1) > tolerance || std::abs(glm::length(c.basis.v) - 1) > tolerance ||
      std::abs(glm::length(c.basis.w) - 1) > tolerance || std::abs(glm::dot(c.basis.u, c.basis.v)) > tolerance ||
      std::abs(glm::dot(c.basis.v, c.basis.w)) > tolerance || std::abs(glm::dot(c.basis.u, c.basis.w)) > tolerance)
    return "a camera basis that is not orthonormal was accepted";
  for (const Medium& m : scene.media)
    if (std::string problem = checkMedium(m); !problem.empty())
      return problem;
  return "";
}

} // namespace raylife::fuzz

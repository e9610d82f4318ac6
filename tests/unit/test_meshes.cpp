// Meshes in scene files (common/scene/scene_loader.cpp) and mesh files (common/scene/mesh_file.h): inline meshes,
// transforms, smooth normals, OBJ and PLY (ASCII and binary) files, and every bad or hostile file refused with one
// message that names the scene file, the place in it and the fault, never a crash.
#include "scene/mesh_file.h"
#include "scene/scene.h"

#include <catch2/catch.hpp>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>

#include <sys/wait.h>

using namespace raylife;
namespace fs = std::filesystem;

namespace {

// A folder of this test's own files, emptied first (ctest runs test cases in parallel: each uses its own name).
fs::path folder(const std::string& name)
{
  const fs::path dir = fs::temp_directory_path() / ("raylife_test_meshes_" + name);
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

void write(const fs::path& path, const std::string& bytes)
{
  std::ofstream out(path, std::ios::binary);
  out << bytes;
}

// A scene whose only geometry is `mesh` (a JSON object), with materials "white" and "lamp".
std::string sceneWith(const std::string& mesh)
{
  return R"({ "camera": { "eye": [0, 0, 5], "focal": [0, 0, 0], "width": 16, "height": 16 },
              "materials": { "white": { "type": "diffuse", "color": [0.5, 0.5, 0.5] },
                             "lamp": { "type": "diffuse", "color": [0, 0, 0], "emission": [1, 1, 1] } },
              "meshes": [ )" + mesh + " ] }";
}

// The message loading `text` as scene `path` fails with ("" if it loads).
std::string failure(const std::string& text, const std::string& path = "scene.json")
{
  try {
    parseScene(text, path);
  } catch (const SceneError& e) {
    return e.what();
  }
  return "";
}

const char* kQuad = R"("vertices": [[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]], "triangles": [[0, 1, 2], [0, 2, 3]])";

} // namespace

TEST_CASE("an inline mesh loads: vertices, triangles, material, and its triangles are hit")
{
  const Scene scene = parseScene(sceneWith(std::string("{ \"material\": \"white\", ") + kQuad + " }"), "s.json");
  REQUIRE(scene.triangles.size() == 2);
  REQUIRE(scene.vertices.size() == 4);
  REQUIRE(scene.meshes.size() == 1);
  CHECK(scene.meshes[0].source == "inline");
  CHECK(scene.meshes[0].triangleCount == 2);
  CHECK(scene.spheres.empty());
  const std::optional<Hit> hit = scene.intersect(Ray{Vec3(Real(0.2), Real(0.3), 5), Vec3(0, 0, -1), 0, kInfinity});
  REQUIRE(hit);
  CHECK(hit->t == Approx(5));
  CHECK(hit->point.x == Approx(0.2));
  CHECK(hit->geometricNormal == Vec3(0, 0, 1));
  CHECK(hit->normal == Vec3(0, 0, 1));
  CHECK(hit->primitive >= 0);
  CHECK(scene.materialOf(hit->primitive) == 0);
}

TEST_CASE("a mesh's transform scales, then rotates, then translates, exactly at 90 degrees, and a mirror keeps the front")
{
  const Scene scene = parseScene(
      sceneWith(std::string("{ \"material\": \"white\", ") + kQuad +
                R"(, "transform": { "scale": [2, 1, 1], "rotate": { "axis": [0, 1, 0], "degrees": 90 },
                                     "translate": [0, 0, 10] } })"),
      "s.json");
  // (1, -1, 0) scaled to (2, -1, 0), turned 90 degrees about +y to (0, -1, -2), moved to (0, -1, 8): exactly.
  CHECK(scene.vertices[1] == Vec3(0, -1, 8));
  CHECK(scene.vertices[0] == Vec3(0, -1, 12));
  // A negative scale mirrors the quad; its triangles are turned round so that its front still faces +z.
  const Scene mirrored = parseScene(
      sceneWith(std::string("{ \"material\": \"white\", ") + kQuad + R"(, "transform": { "scale": [-1, 1, 1] } })"),
      "s.json");
  const auto [p0, p1, p2] = mirrored.triangleVertices(0);
  CHECK(triangleNormal(p0, p1, p2).z == Approx(1));
}

TEST_CASE("smooth shading interpolates the corners' normals: given inline, or area-weighted from the faces")
{
  // A roof: two triangles meeting at a ridge along y, tilted ±45 degrees. Its corner normals, computed, point
  // straight up on the ridge and along each face's normal at the eaves.
  const std::string roof = R"("vertices": [[-1, 0, -1], [0, 1, -1], [1, 0, -1], [-1, 0, 1], [0, 1, 1], [1, 0, 1]],
                               "triangles": [[0, 4, 1], [0, 3, 4], [1, 4, 2], [4, 5, 2]])";
  const Scene flat = parseScene(sceneWith("{ \"material\": \"white\", " + roof + " }"), "s.json");
  const Scene smooth = parseScene(sceneWith("{ \"material\": \"white\", \"smooth\": true, " + roof + " }"), "s.json");
  CHECK(flat.vertexNormals.empty());
  REQUIRE(smooth.vertexNormals.size() == 6);
  CHECK(smooth.vertexNormals[1].y == Approx(1));
  CHECK(smooth.vertexNormals[0].x == Approx(-std::sqrt(0.5)));
  // A ray down onto the middle of the left face: flat, the face's normal; smooth, halfway between it and the ridge's.
  const Ray down{Vec3(Real(-0.5), 5, 0), Vec3(0, -1, 0), 0, kInfinity};
  const std::optional<Hit> a = flat.intersect(down), b = smooth.intersect(down);
  REQUIRE(a);
  REQUIRE(b);
  CHECK(a->normal.x == Approx(-std::sqrt(0.5)));
  CHECK(b->geometricNormal.x == Approx(-std::sqrt(0.5)));
  CHECK(b->normal.x > a->normal.x); // turned towards the ridge
  CHECK(glm::length(b->normal) == Approx(1));
  // Normals given inline are used (normalised, turned with the mesh).
  const Scene given = parseScene(
      sceneWith(R"({ "material": "white", "smooth": true, "vertices": [[-1, -1, 0], [1, -1, 0], [0, 1, 0]],
                     "triangles": [[0, 1, 2]], "normals": [[0, 0, 2], [0, 0, 2], [0, 2, 2]],
                     "transform": { "rotate": { "axis": [1, 0, 0], "degrees": 180 } } })"),
      "s.json");
  CHECK(given.vertexNormals[0] == Vec3(0, 0, -1));
  CHECK(given.vertexNormals[2].z == Approx(-std::sqrt(0.5)));
}

TEST_CASE("OBJ (with polygons and negative indices) and PLY (ASCII and binary) files load, relative to the scene")
{
  const fs::path dir = folder("files");
  fs::create_directories(dir / "models");
  // A unit cube as six quads, the last face with negative (relative) indices.
  write(dir / "models" / "cube.obj", "# a cube\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\n"
                                     "v 0 1 1\nf 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 2 3 7 6\nf 3 4 8 7\nf -8 -4 -1 -5\n");
  write(dir / "models" / "tri.ply", "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                                    "property float z\nelement face 1\nproperty list uchar int vertex_indices\n"
                                    "end_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n");
  {
    std::string ply = "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                      "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n";
    const float v[9] = {0, 0, 0, 2, 0, 0, 0, 2, 0};
    ply.append(reinterpret_cast<const char*>(v), sizeof v);
    ply += char(3);
    const std::int32_t f[3] = {0, 1, 2};
    ply.append(reinterpret_cast<const char*>(f), sizeof f);
    write(dir / "models" / "tri_binary.ply", ply);
  }
  write(dir / "scene.json", sceneWith(R"({ "file": "models/cube.obj", "material": "white" },
                                        { "file": "models/tri.ply", "material": "white" },
                                        { "file": "models/TRI_BINARY.PLY", "material": "white" })"));
  // (The upper-case name does not exist: a clean refusal first, then the real name.)
  try {
    loadScene((dir / "scene.json").string());
    FAIL("a missing mesh file was not refused");
  } catch (const SceneError& e) {
    CHECK(std::string(e.what()).find("models/TRI_BINARY.PLY: cannot open the mesh file") != std::string::npos);
  }
  write(dir / "scene.json", sceneWith(R"({ "file": "models/cube.obj", "material": "white" },
                                        { "file": "models/tri.ply", "material": "white" },
                                        { "file": "models/tri_binary.ply", "material": "white", "smooth": true })"));
  const Scene scene = loadScene((dir / "scene.json").string());
  REQUIRE(scene.meshes.size() == 3);
  CHECK(scene.meshes[0].triangleCount == 12);
  CHECK(scene.meshes[1].triangleCount == 1);
  CHECK(scene.meshes[2].triangleCount == 1);
  CHECK(scene.meshes[0].source == "models/cube.obj");
  // The cube's corners are shared: 8 vertices, not 24.
  CHECK(scene.vertices.size() == 8 + 3 + 3);
  // A ray from inside the cube hits it whichever way it goes (closed).
  for (const Vec3& d : {Vec3(1, 0, 0), Vec3(-1, 0, 0), Vec3(0, 1, 0), Vec3(0, -1, 0), Vec3(0, 0, 1), Vec3(0, 0, -1)})
    CHECK(scene.intersect(Ray{Vec3(Real(0.5), Real(0.5), Real(0.5)), d, 0, kInfinity}));
  CHECK(scene.vertices.back() == Vec3(0, 2, 0));
}

TEST_CASE("bad mesh entries and bad mesh files are refused with one message naming the place and the fault")
{
  const fs::path dir = folder("bad");
  struct Bad {
    const char* what;
    std::string file;  // written to dir/<name>; empty: an inline mesh given in `entry`
    std::string name;
    std::string entry; // the mesh's JSON (for a file: its extra keys)
    std::string expected;
  };
  const std::string png = std::string("\x89PNG\r\n\x1a\n\0\0\0\rIHDR\0\0\0\x01\0\0\0\x01\x08\x02\0\0\0", 29);
  const std::vector<Bad> cases = {
      {"an OBJ index out of range", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n", "a.obj", "", "a.obj"},
      {"a negative OBJ index out of range", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf -1 -2 -9\n", "b.obj", "", "b.obj"},
      {"a NaN vertex", "v 0 0 0\nv nan 0 0\nv 0 1 0\nf 1 2 3\n", "c.obj", "", "c.obj"},
      {"an infinite vertex", "v 0 0 0\nv 1e999 0 0\nv 0 1 0\nf 1 2 3\n", "d.obj", "", "d.obj"},
      {"an empty file", "", "e.obj", "", "e.obj: the file is empty"},
      {"a file of comments only", "# nothing\n", "f.obj", "", "f.obj"},
      {"a PNG named .obj", png, "g.obj", "", "g.obj"},
      {"a PNG named .ply", png, "h.ply", "", "h.ply"},
      {"points and lines only", "v 0 0 0\nv 1 0 0\nv 0 1 0\np 1\nl 1 2\n", "i.obj", "", "i.obj"},
      {"a PLY whose face names a vertex it lacks",
       "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
       "element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n",
       "j.ply", "", "j.ply"},
      {"a truncated binary PLY",
       "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
       "element face 1\nproperty list uchar int vertex_indices\nend_header\n\x01\x02",
       "k.ply", "", "k.ply"},
      // (400 million vertices over one line of data: Assimp's process took 58 s and 4.7 GB before it aborted.)
      {"an ASCII PLY that announces far more rows than it has bytes for",
       "ply\nformat ascii 1.0\nelement vertex 400000000\nproperty float x\nproperty float y\nproperty float z\n"
       "element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n",
       "k2.ply", "", "k2.ply: cannot read it as PLY: the file ends before the data its header announces"},
      {"every triangle degenerate", "v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n", "l.obj", "", "degenerate"},
      {"an unknown extension", "v 0 0 0\n", "m.stl", "", "unknown mesh format '.stl'"},
      {"a missing file", "", "", R"({ "file": "nowhere.obj", "material": "white" })", "cannot open the mesh file"},
      {"a folder named like a mesh", "", "", R"({ "file": "folder.obj", "material": "white" })", "is a folder"},
      {"both a file and vertices", "", "", R"({ "file": "a.obj", "vertices": [], "material": "white" })",
       "/meshes/0: a mesh has \"file\" and inline \"vertices\": give one or the other"},
      {"neither a file nor vertices", "", "", R"({ "material": "white" })", "a mesh needs \"file\""},
      {"an inline index out of range", "", "",
       R"({ "material": "white", "vertices": [[0,0,0],[1,0,0],[0,1,0]], "triangles": [[0, 1, 3]] })",
       "/meshes/0/triangles/0/2: must be at most 2, got 3"},
      {"a negative inline index", "", "",
       R"({ "material": "white", "vertices": [[0,0,0],[1,0,0],[0,1,0]], "triangles": [[0, -1, 2]] })",
       "/meshes/0/triangles/0/1: must be at least 0"},
      {"a triangle of two corners", "", "",
       R"({ "material": "white", "vertices": [[0,0,0],[1,0,0],[0,1,0]], "triangles": [[0, 1]] })",
       "expected a triangle as 3 vertex indices"},
      {"normals not one per vertex", "", "",
       R"({ "material": "white", "vertices": [[0,0,0],[1,0,0],[0,1,0]], "triangles": [[0, 1, 2]],
            "normals": [[0,0,1]] })",
       "expected one normal [x, y, z] per vertex (3)"},
      {"a zero normal", "", "",
       R"({ "material": "white", "vertices": [[0,0,0],[1,0,0],[0,1,0]], "triangles": [[0, 1, 2]],
            "normals": [[0,0,1],[0,0,0],[0,0,1]] })",
       "/meshes/0/normals/1: a normal must not be zero"},
      {"a scale of 0", "", "",
       R"({ "material": "white", "vertices": [[0,0,0],[1,0,0],[0,1,0]], "triangles": [[0, 1, 2]],
            "transform": { "scale": [1, 0, 1] } })",
       "/meshes/0/transform/scale: a scale of 0 flattens the mesh"},
      {"a rotation about nothing", "", "",
       R"({ "material": "white", "vertices": [[0,0,0],[1,0,0],[0,1,0]], "triangles": [[0, 1, 2]],
            "transform": { "rotate": { "axis": [0, 0, 0], "degrees": 10 } } })",
       "/meshes/0/transform/rotate/axis: the rotation axis must not be zero"},
      {"an unknown material", "", "",
       R"({ "material": "whte", "vertices": [[0,0,0],[1,0,0],[0,1,0]], "triangles": [[0, 1, 2]] })",
       "undefined material 'whte' (did you mean 'white'?)"},

      // (Beyond the bound, 10^30 in double and 10^8 in float, and finite in float too.)
      {"an inline vertex beyond the bound on a scene's size", "", "",
       R"({ "material": "white", "vertices": [[0,0,0],[0,-1e31,0],[0,1,0]], "triangles": [[0, 1, 2]] })",
       std::string("/meshes/0/vertices/1/1: a coordinate must lie within ±") + kMaxSceneExtentText +
           " (raylife's bound on a scene's size), got -1e+31"},
      {"a transform that takes a vertex beyond the bound on a scene's size", "", "",
       R"({ "material": "white", "vertices": [[0,0,0],[1,0,0],[0,1,0]], "triangles": [[0, 1, 2]],
            "transform": { "scale": 2e30 } })",
       std::string("/meshes/0/transform: the transform takes a vertex to (2e+30, 0, 0), beyond ±") +
           kMaxSceneExtentText + " (raylife's bound on a scene's size)"},
      {"smooth not a boolean", "", "",
       R"({ "material": "white", "smooth": 1, "vertices": [[0,0,0],[1,0,0],[0,1,0]], "triangles": [[0, 1, 2]] })",
       "/meshes/0/smooth: expected true or false"},
  };
  // A file's vertices are read as float (up to 3.4e38): one may lie beyond the bound itself, and a transform may
  // bring it in or take another out; each message blames what did it.
  write(dir / "far.obj", "v 0 0 0\nv 1e38 0 0\nv 0 1 0\nf 1 2 3\n");
  CHECK(failure(sceneWith(R"({ "file": "far.obj", "material": "white" })"), (dir / "scene.json").string())
            .find(std::string("/meshes/0/file: a vertex of the file lies at (1e+38, 0, 0), beyond ±") +
                  kMaxSceneExtentText + " (raylife's bound on a scene's size); a transform's scale can bring it in") !=
        std::string::npos);
  if (sizeof(Real) == sizeof(double)) { // (in float, scaled into ±1e8 the triangle has no area left)
    CHECK(failure(sceneWith(R"({ "file": "far.obj", "material": "white", "transform": { "scale": 1e-9 } })"),
                  (dir / "scene.json").string()) == "");
    CHECK(failure(sceneWith(R"({ "file": "far.obj", "material": "white", "transform": { "scale": 1e13 } })"),
                  (dir / "scene.json").string())
              .find("/meshes/0/transform: the transform takes a vertex to (1e+51, 0, 0), beyond ±1e30 (raylife's "
                    "bound on a scene's size)") != std::string::npos);
  }
  fs::create_directories(dir / "folder.obj");
  for (const Bad& c : cases) {
    std::string entry = c.entry;
    if (!c.name.empty()) {
      write(dir / c.name, c.file);
      entry = R"({ "file": ")" + c.name + R"(", "material": "white" })";
    }
    const std::string message = failure(sceneWith(entry), (dir / "scene.json").string());
    INFO(c.what << ": " << message);
    REQUIRE_FALSE(message.empty());
    CHECK(message.find((dir / "scene.json").string() + ":") == 0); // names the scene file first
    CHECK(message.find("/meshes/0") != std::string::npos);          // and the place in it
    CHECK(message.find(c.expected) != std::string::npos);           // and the fault
    CHECK(message.find('\n') == std::string::npos);                 // on one line
  }
}

TEST_CASE("a mesh file that crashes the library is one message, and the reader leaves no process behind")
{
  // Debian's Assimp 5.2 aborts (an assertion in its triangulation) on a PLY face of no corners: raylife reads mesh
  // files in a child process, so the crash is the child's, and the parent says so (tests/fuzz/mesh_regressions).
  const fs::path dir = folder("crash");
  write(dir / "crash.ply", "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                           "property float z\nelement face 2\nproperty list uchar int vertex_indices\nend_header\n"
                           "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n0\n");
  const std::string crash = (dir / "crash.ply").string();
  try {
    readMeshFile(crash);
    FAIL("the file was read");
  } catch (const MeshError& e) {
    CHECK(std::string(e.what()) == crash + ": the mesh reader crashed (SIGABRT) on this file: it is malformed");
  }
  CHECK(failure(sceneWith(R"({ "file": "crash.ply", "material": "white" })"), (dir / "scene.json").string())
            .find("/meshes/0/file: " + crash + ": the mesh reader crashed (SIGABRT)") != std::string::npos);

  // The parent stops reading at the first fault while the child still has megabytes to write (a NaN first, then
  // 300,000 vertices): the child is ended, and the parent is not (no SIGPIPE reaches it).
  std::string big = "ply\nformat ascii 1.0\nelement vertex 300000\nproperty float x\nproperty float y\n"
                    "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\nnan 0 0\n";
  for (int v = 1; v < 300000; ++v)
    big += std::to_string(v) + " 1 2\n";
  big += "3 0 1 2\n";
  write(dir / "big.ply", big);
  try {
    readMeshFile((dir / "big.ply").string());
    FAIL("a NaN vertex was read");
  } catch (const MeshError& e) {
    CHECK(std::string(e.what()).find("vertex 1 is not finite") != std::string::npos);
  }
  // No child is left, running or a zombie: each reader was waited for.
  errno = 0;
  CHECK(::waitpid(-1, nullptr, WNOHANG) == -1);
  CHECK(errno == ECHILD);
  // And the reader still works.
  write(dir / "tri.ply", "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                         "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n"
                         "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n");
  CHECK(readMeshFile((dir / "tri.ply").string()).triangles.size() == 1);
}

TEST_CASE("degenerate triangles are dropped with a count in a warning, and the rest of the mesh loads")
{
  const Scene scene = parseScene(
      sceneWith(R"({ "material": "white", "vertices": [[0,0,0],[1,0,0],[0,1,0],[2,0,0]],
                     "triangles": [[0, 1, 2], [0, 1, 3], [2, 2, 1]] })"),
      "s.json");
  CHECK(scene.triangles.size() == 1);
  REQUIRE(scene.warnings.size() == 2); // the dropped triangles, and the unused material "lamp"
  CHECK(scene.warnings[0].find(std::string("2 degenerate triangles (area 0, or below the square of raylife's "
                                           "smallest length, ") +
                               kMinSceneLengthText + ") dropped (of 3)") != std::string::npos);
  CHECK(scene.warnings[0].find("/meshes/0") != std::string::npos);
}

TEST_CASE("a scene needs a sphere or a triangle, meshes alone are a scene, and emissive meshes are lights")
{
  CHECK(failure(R"({ "camera": { "eye": [0, 0, 5], "focal": [0, 0, 0] }, "materials": {} })")
            .find("the scene is empty") != std::string::npos);
  const Scene scene =
      parseScene(sceneWith(std::string("{ \"material\": \"lamp\", ") + kQuad + " }"), "s.json");
  CHECK(scene.primitiveCount() == 2);
  CHECK(scene.materials[std::size_t(scene.triangles[0].material)].isEmissive());
}

TEST_CASE("Assimp's own malformed and empty test files load or are refused cleanly (when assimp-testmodels is there)")
{
  // Debian's assimp-testmodels (./setup.sh installs it): a folder of invalid files, and real models.
  const fs::path models = "/usr/share/assimp/models";
  REQUIRE(fs::is_directory(models));
  int refused = 0, loaded = 0;
  for (const char* name : {"invalid/empty.obj", "invalid/empty.ply", "invalid/malformed.obj", "invalid/malformed2.obj",
                           "OBJ/box.obj", "OBJ/testline.obj", "OBJ/testpoints.obj", "OBJ/testmixed.obj",
                           "OBJ/concave_polygon.obj", "OBJ/box_UTF16BE.obj", "PLY/cube_binary.ply", "PLY/points.ply",
                           "PLY/issue623.ply", "PLY/Wuson.ply"}) {
    try {
      const MeshData data = readMeshFile((models / name).string());
      ++loaded;
      for (const auto& tri : data.triangles)
        for (std::uint32_t v : tri)
          REQUIRE(v < data.positions.size());
    } catch (const MeshError& e) {
      ++refused;
      INFO(name << ": " << e.what());
      CHECK(std::string(e.what()).find(name) != std::string::npos);
    }
  }
  CHECK(loaded >= 3);  // box, the concave polygon, the binary cube, Wuson at least
  CHECK(refused >= 3); // the empty files, points and lines at least
  const MeshData wuson = readMeshFile((models / "PLY/Wuson.ply").string());
  CHECK(wuson.triangles.size() == 3732);
}

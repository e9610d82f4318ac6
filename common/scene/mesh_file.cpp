// Mesh files through Assimp, then raylife's own checks (see mesh_file.h for why both).
#include "scene/mesh_file.h"

#include <assimp/Importer.hpp>
#include <assimp/config.h>
#include <assimp/mesh.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>
#ifdef __GLIBC__
#include <malloc.h>
#endif

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <vector>
#include <unordered_map>
#include <string_view>

namespace raylife {

namespace {

std::string lowerCase(std::string s)
{
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  return s;
}

// Assimp's message made one line, and short: it may quote the file's own bytes.
std::string libraryMessage(const char* text)
{
  std::string out;
  for (const char* p = text; *p && out.size() < 200; ++p)
    out += (*p == '\n' || *p == '\r' || *p == '\t' || static_cast<unsigned char>(*p) < 0x20) ? ' ' : *p;
  while (!out.empty() && out.back() == ' ')
    out.pop_back();
  return out.empty() ? "the library gave no reason" : out;
}

// The meshes of an Assimp scene, with the transforms of the nodes that hold them (identity for OBJ and PLY, but
// applied all the same), appended to `data`.
void collect(const aiScene& scene, const aiNode& node, const aiMatrix4x4& parent, const std::string& name,
             MeshData& data)
{
  const aiMatrix4x4 transform = parent * node.mTransformation;
  aiMatrix3x3 normalTransform(transform);
  normalTransform.Inverse().Transpose();
  for (unsigned k = 0; k < node.mNumMeshes; ++k) {
    if (node.mMeshes[k] >= scene.mNumMeshes)
      throw MeshError(name + ": malformed: a node names mesh " + std::to_string(node.mMeshes[k]) + " of " +
                      std::to_string(scene.mNumMeshes));
    const aiMesh& mesh = *scene.mMeshes[node.mMeshes[k]];
    if (mesh.mPrimitiveTypes & (aiPrimitiveType_POINT | aiPrimitiveType_LINE))
      throw MeshError(name + ": unsupported polygon: the file has points or lines (faces of 1 or 2 vertices); " +
                      "raylife renders triangles only");
    const std::size_t first = data.positions.size();
    const bool normals = mesh.mNormals != nullptr;
    for (unsigned v = 0; v < mesh.mNumVertices; ++v) {
      const aiVector3D p = transform * mesh.mVertices[v];
      const Vec3 position(p.x, p.y, p.z);
      if (!isFinite(position))
        throw MeshError(name + ": vertex " + std::to_string(first + v + 1) + " is not finite (NaN or infinite)");
      data.positions.push_back(position);
      if (normals) {
        const aiVector3D n = normalTransform * mesh.mNormals[v];
        data.normals.emplace_back(n.x, n.y, n.z);
      }
    }
    for (unsigned f = 0; f < mesh.mNumFaces; ++f) {
      const aiFace& face = mesh.mFaces[f];
      if (face.mNumIndices != 3)
        throw MeshError(name + ": unsupported polygon: face " + std::to_string(f + 1) + " has " +
                        std::to_string(face.mNumIndices) + " vertices after triangulation");
      std::array<std::uint32_t, 3> tri{};
      for (int c = 0; c < 3; ++c) {
        const unsigned index = face.mIndices[c];
        // Checked here whatever the library checked: an index out of range must never reach the renderer.
        if (index >= mesh.mNumVertices)
          throw MeshError(name + ": bad index: face " + std::to_string(f + 1) + " names vertex " +
                          std::to_string(index + 1) + " of " + std::to_string(mesh.mNumVertices));
        tri[std::size_t(c)] = std::uint32_t(first + index);
      }
      data.triangles.push_back(tri);
    }
  }
  for (unsigned c = 0; c < node.mNumChildren; ++c)
    collect(scene, *node.mChildren[c], transform, name, data);
}

// [weld]
// Joins the vertices of `data` that have equal positions and normals (all finite), and renumbers the triangles: the
// vertices sorted by (position, normal), each run of equal ones becoming one. O(n log n) time, 8 bytes a vertex.
// Checks a PLY file's header before Assimp reads it: Debian's Assimp 5.2 reads past the end of a binary PLY whose
// header is cut short (found by fuzzing). The header must start with "ply", hold no control character, declare known
// formats, counts and property types, and end with "end_header"; a binary file must hold at least the bytes its
// fixed-size elements need. Throws MeshError naming the fault.
void checkPlyHeader(std::span<const char> bytes, const std::string& name)
{
  const std::string_view text(bytes.data(), bytes.size());
  auto fail = [&](const std::string& why) { throw MeshError(name + ": cannot read it as PLY: " + why); };
  static const std::unordered_map<std::string_view, std::size_t> kTypeSizes = {
      {"char", 1},   {"uchar", 1},  {"short", 2},  {"ushort", 2},  {"int", 4},     {"uint", 4},
      {"float", 4},  {"double", 8}, {"int8", 1},   {"uint8", 1},   {"int16", 2},   {"uint16", 2},
      {"int32", 4},  {"uint32", 4}, {"float32", 4}, {"float64", 8}};
  std::size_t at = 0, line = 0;
  bool binary = false, fixedSoFar = true, ended = false;
  // The bytes the elements before the first list property need (a list's length is in the data).
  unsigned long long fixedBytes = 0, rowBytes = 0, rows = 0;
  while (at < text.size()) {
    const std::size_t end = text.find('\n', at);
    if (end == std::string_view::npos)
      fail("the header has no end_header line");
    std::string_view l = text.substr(at, end - at);
    at = end + 1;
    ++line;
    if (!l.empty() && l.back() == '\r')
      l.remove_suffix(1);
    std::vector<std::string_view> words;
    for (std::size_t i = 0; i < l.size();) {
      while (i < l.size() && l[i] == ' ')
        ++i;
      std::size_t j = i;
      while (j < l.size() && l[j] != ' ')
        ++j;
      if (j > i)
        words.push_back(l.substr(i, j - i));
      i = j;
    }
    const std::string where = "header line " + std::to_string(line) + ": ";
    for (const char c : l)
      if (static_cast<unsigned char>(c) < 32 && c != '\t')
        fail(where + "a control character");
    if (line == 1) {
      if (l != "ply")
        fail("it does not start with 'ply'");
      continue;
    }
    if (words.empty() || words[0] == "comment" || words[0] == "obj_info")
      continue;
    if (words[0] == "format") {
      if (words.size() != 3 || (words[1] != "ascii" && words[1] != "binary_little_endian" &&
                                words[1] != "binary_big_endian"))
        fail(where + "an unknown format");
      binary = words[1] != "ascii";
    } else if (words[0] == "element") {
      if (words.size() != 3 || words[2].find_first_not_of("0123456789") != std::string_view::npos ||
          words[2].size() > 12)
        fail(where + "an element needs a name and a whole count");
      if (fixedSoFar)
        fixedBytes += rows * rowBytes;
      rows = std::stoull(std::string(words[2]));
      rowBytes = 0;
    } else if (words[0] == "property") {
      if (words.size() == 5 && words[1] == "list") {
        if (!kTypeSizes.count(words[2]) || !kTypeSizes.count(words[3]))
          fail(where + "an unknown type in a list property");
        fixedSoFar = false;
      } else if (words.size() == 3) {
        const auto type = kTypeSizes.find(words[1]);
        if (type == kTypeSizes.end())
          fail(where + "an unknown property type"); // (not echoed: the file's bytes may not be text)
        rowBytes += type->second;
      } else {
        fail(where + "a property needs a type and a name");
      }
    } else if (words[0] == "end_header") {
      ended = true;
      break;
    } // (Other lines are passed over, as Assimp does: Blender wrote comments without "comment".)
  }
  if (!ended)
    fail("the header has no end_header line");
  if (fixedSoFar)
    fixedBytes += rows * rowBytes;
  if (binary && fixedBytes > text.size() - at)
    fail("the file ends before the data its header announces");
}

void weld(MeshData& data)
{
  const std::size_t n = data.positions.size();
  const bool normals = !data.normals.empty();
  auto key = [&](std::uint32_t v) {
    const Vec3& p = data.positions[v];
    const Vec3 nrm = normals ? data.normals[v] : Vec3(0);
    return std::array<Real, 6>{p.x, p.y, p.z, nrm.x, nrm.y, nrm.z};
  };
  std::vector<std::uint32_t> order(n);
  for (std::size_t v = 0; v < n; ++v)
    order[v] = std::uint32_t(v);
  std::sort(order.begin(), order.end(), [&](std::uint32_t a, std::uint32_t b) { return key(a) < key(b); });
  std::vector<std::uint32_t> newIndex(n);
  std::vector<Vec3> positions, vertexNormals;
  for (std::size_t k = 0; k < n; ++k) {
    if (k == 0 || key(order[k]) != key(order[k - 1])) {
      positions.push_back(data.positions[order[k]]);
      if (normals)
        vertexNormals.push_back(data.normals[order[k]]);
    }
    newIndex[order[k]] = std::uint32_t(positions.size() - 1);
  }
  for (auto& tri : data.triangles)
    for (std::uint32_t& v : tri)
      v = newIndex[v];
  data.positions = std::move(positions);
  data.normals = std::move(vertexNormals);
}
// [weld]

} // namespace

MeshFormat meshFormatOf(const std::string& path)
{
  const std::string extension = lowerCase(std::filesystem::path(path).extension().string());
  if (extension == ".obj")
    return MeshFormat::Obj;
  if (extension == ".ply")
    return MeshFormat::Ply;
  throw MeshError(path + ": unknown mesh format '" + (extension.empty() ? std::string("(no extension)") : extension) +
                  "': raylife reads .obj and .ply files");
}

MeshData parseMeshData(std::span<const char> bytes, MeshFormat format, const std::string& name)
{
  if (bytes.empty())
    throw MeshError(name + ": the file is empty");
  if (format == MeshFormat::Ply)
    checkPlyHeader(bytes, name);
  // OBJ is text: a control character (a NUL, a UTF-16 file) is refused here, before Assimp's OBJ reader, which
  // Debian's 5.2 crashes on with some of them (found by fuzzing).
  if (format == MeshFormat::Obj)
    for (std::size_t i = 0; i < bytes.size(); ++i) {
      const auto c = static_cast<unsigned char>(bytes[i]);
      if ((c < 32 && c != '\t' && c != '\n' && c != '\r' && c != '\f' && c != '\v') || c == 127)
        throw MeshError(name + ": cannot read it as OBJ: a control character (byte " + std::to_string(int(c)) +
                        ") at byte " + std::to_string(i) + ": OBJ is text");
    }
  Assimp::Importer importer;
  // Keep positions and normals only (less to hold; materials and textures are the scene's business).
  importer.SetPropertyInteger(AI_CONFIG_PP_RVC_FLAGS, aiComponent_TANGENTS_AND_BITANGENTS | aiComponent_COLORS |
                                                          aiComponent_TEXCOORDS | aiComponent_BONEWEIGHTS |
                                                          aiComponent_ANIMATIONS | aiComponent_TEXTURES |
                                                          aiComponent_LIGHTS | aiComponent_CAMERAS |
                                                          aiComponent_MATERIALS);
  // (Not Assimp's JoinIdenticalVertices: on a million-triangle PLY it took 15 s and 300 MB more than the reading
  // itself, 2 s and 83 MB. OBJ files are welded below instead.)
  const unsigned flags = aiProcess_ValidateDataStructure | aiProcess_RemoveComponent | aiProcess_Triangulate;
  // From memory, with the format named: Assimp then uses that one importer and opens no other file.
  const aiScene* scene =
      importer.ReadFileFromMemory(bytes.data(), bytes.size(), flags, format == MeshFormat::Obj ? "obj" : "ply");
  if (!scene)
    throw MeshError(name + ": cannot read it as " + (format == MeshFormat::Obj ? "OBJ" : "PLY") + ": " +
                    libraryMessage(importer.GetErrorString()));
  if (!scene->mRootNode)
    throw MeshError(name + ": no triangles in the file");
  MeshData data;
  collect(*scene, *scene->mRootNode, aiMatrix4x4(), name, data);
  importer.FreeScene(); // the library's copy, before the welding's scratch
  if (data.normals.size() != data.positions.size() ||
      !std::all_of(data.normals.begin(), data.normals.end(), [](const Vec3& n) { return isFinite(n); }))
    data.normals.clear(); // some parts had normals and some did not, or bad ones: none (smooth shading computes them)
  if (data.triangles.empty())
    throw MeshError(name + ": no triangles in the file");
  // An OBJ face lists its own corners, and Assimp gives every corner a vertex of its own: join the corners that
  // share a position (and a normal), so that the mesh is connected (smooth normals average over a vertex's faces).
  // A PLY file is indexed already.
  if (format == MeshFormat::Obj)
    weld(data);
  return data;
}

MeshData readMeshFile(const std::string& path)
{
  const MeshFormat format = meshFormatOf(path);
  namespace fs = std::filesystem;
  std::error_code ec;
  if (fs::is_directory(path, ec))
    throw MeshError(path + ": is a folder, not a mesh file");
  std::ifstream in(path, std::ios::binary);
  if (!in)
    throw MeshError(path + ": cannot open the mesh file: " + std::strerror(errno));
  std::vector<char> bytes;
  char buffer[1 << 16];
  while (in.read(buffer, sizeof buffer) || in.gcount() > 0) {
    bytes.insert(bytes.end(), buffer, buffer + in.gcount());
    if (bytes.size() > kMaxMeshFileBytes)
      throw MeshError(path + ": the mesh file is larger than " + std::to_string(kMaxMeshFileBytes >> 20) + " MiB");
  }
  if (in.bad())
    throw MeshError(path + ": cannot read the mesh file: " + std::strerror(errno));
  MeshData data = parseMeshData(bytes, format, path);
  std::vector<char>().swap(bytes);
#ifdef __GLIBC__
  // The file's bytes and Assimp's scene are freed but glibc keeps much of it; hand it back, so that the memory a
  // big model holds while the tree is built and the image rendered is the mesh itself.
  malloc_trim(0);
#endif
  return data;
}

} // namespace raylife

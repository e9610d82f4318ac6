// Mesh files through Assimp, then raylife's own checks (see mesh_file.h for why both).
#include "scene/mesh_file.h"

#include <assimp/Importer.hpp>
#include <assimp/config.h>
#include <assimp/mesh.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>

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
  Assimp::Importer importer;
  // Keep positions and normals only, so that vertices that differ in texture coordinates or colours alone are
  // joined: a mesh whose faces list their own corners (as OBJ files often do) comes out connected.
  importer.SetPropertyInteger(AI_CONFIG_PP_RVC_FLAGS, aiComponent_TANGENTS_AND_BITANGENTS | aiComponent_COLORS |
                                                          aiComponent_TEXCOORDS | aiComponent_BONEWEIGHTS |
                                                          aiComponent_ANIMATIONS | aiComponent_TEXTURES |
                                                          aiComponent_LIGHTS | aiComponent_CAMERAS |
                                                          aiComponent_MATERIALS);
  const unsigned flags = aiProcess_ValidateDataStructure | aiProcess_RemoveComponent | aiProcess_Triangulate |
                         aiProcess_JoinIdenticalVertices;
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
  if (data.normals.size() != data.positions.size())
    data.normals.clear(); // some parts had normals and some did not: none (smooth shading computes them)
  if (data.triangles.empty())
    throw MeshError(name + ": no triangles in the file");
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
  return parseMeshData(bytes, format, path);
}

} // namespace raylife

/// @file mesh_file.h
/// @brief Triangle meshes read from OBJ and PLY files (ASCII and binary PLY), through the Assimp library, and
/// checked by raylife: every index in range, every vertex finite, at least one triangle, nothing but triangles.
///
/// Why a library: OBJ and PLY look simple and are not (OBJ's negative and relative indices, polygons to triangulate,
/// PLY's binary layouts and property lists), and a hand-written parser is where hostile files find their way in.
/// Why raylife checks anyway: a library's own checks vary by version (Debian 12's tinyobjloader, for one, does not
/// range-check negative OBJ indices), and a renderer that indexes out of range on a bad file crashes or draws
/// garbage. Why in a child process: the library itself faults on some hostile files (Debian's Assimp 5.2 aborts, or
/// reads and writes out of bounds: found by fuzzing), which no check in this process could catch; the child's crash
/// becomes a MeshError. The meshes here are in the file's own coordinates; the scene loader transforms them.
#pragma once

#include "core/math.h"

#include <array>
#include <cstdint>
#include <span>
#include <stdexcept>
#include <string>
#include <vector>

namespace raylife {

/// A material as a mesh file states it (an OBJ's MTL, through Assimp): what chapter 14's `"material": "from-file"`
/// maps to the nearest raylife material.
struct FileMaterial {
  std::string name;        ///< Its name in the file.
  Color diffuse{0};        ///< Kd, ≥ 0.
  Color specular{0};       ///< Ks, ≥ 0.
  Color emission{0};       ///< Ke, ≥ 0.
  Real shininess = 0;      ///< Ns (a Phong exponent), ≥ 0.
  std::string diffuseMap;  ///< map_Kd as the file writes it (relative to the file's folder), or empty.
};

/// A mesh as a file holds it: vertex positions, optional vertex normals, and triangles as index triples into them.
struct MeshData {
  std::vector<Vec3> positions;                          ///< Every vertex, finite.
  /// Empty, or one per position, as the file gives them (not checked for length: the scene loader normalises them
  /// and drops the file's normals if any is zero or not finite). Empty when only some of the file's parts have them.
  std::vector<Vec3> normals;
  std::vector<std::array<std::uint32_t, 3>> triangles;  ///< Counter-clockwise from the front; every index in range.
  /// Empty, or one (u, v) per position (chapter 14: OBJ `vt`, PLY `u v` or `s t`; v = 0 the image's bottom row),
  /// finite; read only when asked for. Empty when only some of the file's parts have them.
  std::vector<Vec2> uvs;
  /// The file's materials, read only when asked for (readMeshFile's `materials`); empty otherwise.
  std::vector<FileMaterial> materials;
  /// With the materials: each triangle's, an index into `materials`, as `triangles` is ordered; empty otherwise.
  std::vector<std::uint32_t> triangleMaterials;
};

/// A fault in a mesh file. what() is the whole message: "FILE: what is wrong" (with the line where the
/// library names one).
class MeshError : public std::runtime_error {
public:
  using std::runtime_error::runtime_error;
};

/// The mesh formats raylife reads.
enum class MeshFormat {
  Obj, ///< Wavefront OBJ (text; polygons are triangulated; materials and textures are ignored).
  Ply, ///< Stanford PLY, ASCII or binary.
};

/// Largest mesh file readMeshFile reads, in bytes (1 GiB): room for tens of millions of triangles.
inline constexpr std::size_t kMaxMeshFileBytes = std::size_t(1) << 30;

/// The format of a file by its extension (.obj or .ply, in any case). @throws MeshError for any other extension.
MeshFormat meshFormatOf(const std::string& path);

/// Reads and checks a mesh file (a regular file of at most kMaxMeshFileBytes). An OBJ file's vertices that share a
/// position (and a normal, when the file gives normals) are joined, since OBJ faces list their own corners, so that
/// the mesh is connected; a PLY file's indexing is kept as it is. The library runs in a child process (fork(); the
/// arrays come back through a pipe), so this is safe on any file, but not to call while other threads of the program
/// hold locks the child would need (call it before starting threads, as the scene loader does). @throws MeshError
/// naming the file and the fault: unreadable, empty, not OBJ or PLY, malformed (the library's message), an index out
/// of range, a vertex that is not finite, points or lines (raylife renders triangles), no triangle at all, or a
/// reader that crashed on it or could not be started.
/// @param path the mesh file, an .obj or a .ply.
/// @param uvs also read the texture coordinates (MeshData::uvs), when a textured material needs them; an OBJ's
/// corners are then joined only where their (u, v) agree too.
/// @param materials also read the file's materials (MeshData::materials, triangleMaterials): an OBJ's MTL file, which
/// the library then opens beside it.
MeshData readMeshFile(const std::string& path, bool uvs = false, bool materials = false);

/// readMeshFile on bytes already in memory, `name` used in messages only (the fuzz target's entry). Reads no other
/// file (an OBJ's material library is ignored) unless `materialsFrom` names the file the bytes came from: the
/// library then reads that file and what it names, and the file's materials come back too. @throws MeshError.
MeshData parseMeshData(std::span<const char> bytes, MeshFormat format, const std::string& name, bool uvs = false,
                       const std::string* materialsFrom = nullptr);

} // namespace raylife

// Mesh files through Assimp, in a child process, then raylife's own checks (see mesh_file.h for why both, and
// below for why the child).
#include "scene/mesh_file.h"
#include "scene/pipe_io.h"

#include <assimp/Importer.hpp>
#include <assimp/config.h>
#include <assimp/mesh.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>
#ifdef __GLIBC__
#include <malloc.h>
#endif
#include <fcntl.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>
#ifdef __linux__
#include <sys/prctl.h>
#endif

#include <algorithm>
#include <cmath>
#include <cctype>
#include <cerrno>
#include <csignal>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <optional>
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
  // In an ASCII file, the numbers the rows hold at the least: one a property (a list's is its length), each a
  // character and a space or line end. (In double: a count of 10^12 rows times many properties overflows 64 bits.)
  double tokens = 0, rowTokens = 0;
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
      tokens += double(rows) * rowTokens;
      rows = std::stoull(std::string(words[2]));
      rowBytes = 0, rowTokens = 0;
    } else if (words[0] == "property") {
      if (words.size() == 5 && words[1] == "list") {
        if (!kTypeSizes.count(words[2]) || !kTypeSizes.count(words[3]))
          fail(where + "an unknown type in a list property");
        fixedSoFar = false;
        ++rowTokens;
      } else if (words.size() == 3) {
        const auto type = kTypeSizes.find(words[1]);
        if (type == kTypeSizes.end())
          fail(where + "an unknown property type"); // (not echoed: the file's bytes may not be text)
        rowBytes += type->second;
        ++rowTokens;
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
  tokens += double(rows) * rowTokens;
  // (An ASCII header that announced 400 million vertices over a line of data cost 58 s and 4.7 GB in Assimp's
  // process before it aborted.)
  if ((binary && fixedBytes > text.size() - at) || (!binary && 2 * tokens - 1 > double(text.size() - at)))
    fail("the file ends before the data its header announces");
}

// [weld]
// Joins the vertices of `data` that have equal positions and normals (all finite), and renumbers the triangles: the
// vertices sorted by (position, normal), each run of equal ones becoming one. O(n log n) time, 8 bytes a vertex.
void weld(MeshData& data)
{
  const std::size_t n = data.positions.size();
  const bool normals = !data.normals.empty(), uvs = !data.uvs.empty();
  auto key = [&](std::uint32_t v) {
    const Vec3& p = data.positions[v];
    const Vec3 nrm = normals ? data.normals[v] : Vec3(0);
    const Vec2 uv = uvs ? data.uvs[v] : Vec2(0);
    return std::array<Real, 8>{p.x, p.y, p.z, nrm.x, nrm.y, nrm.z, uv.x, uv.y};
  };
  std::vector<std::uint32_t> order(n);
  for (std::size_t v = 0; v < n; ++v)
    order[v] = std::uint32_t(v);
  std::sort(order.begin(), order.end(), [&](std::uint32_t a, std::uint32_t b) { return key(a) < key(b); });
  std::vector<std::uint32_t> newIndex(n);
  std::vector<Vec3> positions, vertexNormals;
  std::vector<Vec2> vertexUvs;
  for (std::size_t k = 0; k < n; ++k) {
    if (k == 0 || key(order[k]) != key(order[k - 1])) {
      positions.push_back(data.positions[order[k]]);
      if (normals)
        vertexNormals.push_back(data.normals[order[k]]);
      if (uvs)
        vertexUvs.push_back(data.uvs[order[k]]);
    }
    newIndex[order[k]] = std::uint32_t(positions.size() - 1);
  }
  for (auto& tri : data.triangles)
    for (std::uint32_t& v : tri)
      v = newIndex[v];
  data.positions = std::move(positions);
  data.normals = std::move(vertexNormals);
  data.uvs = std::move(vertexUvs);
}
// [weld]


// ---- Assimp in a process of its own ---------------------------------------------------------------------------
// Why: Debian's Assimp 5.2 faults on hostile files, in ways raylife cannot catch in its own process. Fuzzing found an
// assertion that aborts in its triangulation, a read past the end of a binary PLY whose header is cut short, a write
// through a bad pointer on an OBJ with control characters, and leaks. The checks before Assimp (checkPlyHeader, the
// OBJ's control characters) give those files a better message, but only a separate process makes "nothing crashes
// on any input" hold for the faults nobody has found yet: a fork()ed child runs Assimp and writes the arrays it got
// to a pipe, then _exit()s; the parent reads them, every count bounded, and makes a child that died, or an answer cut
// short or garbled, the usual one-line message. Every check on the data itself (indices, finite vertices, nothing but
// triangles) is made in the parent, on what it received: the child's only job is to run the library.
//
// The stream, in this machine's byte order (both ends are one program on one machine), is records, each a Tag and
// its fields: a Mesh (WireMesh, then its positions as float x, y, z, its normals likewise if it has them, and its
// faces as WireFace), an Error (kind, length, the text), and an End (the number of meshes sent), which is last.
enum Tag : std::uint32_t {
  kMeshTag = 0x4d455348u,
  kErrorTag = 0x4552524fu,
  kEndTag = 0x454e4421u,
  kMaterialTag = 0x4d41544cu, // a material of the file (chapter 14's "from-file"): WireMaterial, name, texture path
};
struct WireMesh {
  std::uint32_t primitiveTypes, vertices, hasNormals, faces;
  std::uint32_t hasUvs; // texture coordinates follow the normals (as aiVector3D; only x and y are used)
  std::uint32_t material; // the index of its material among the Material records (sent after the meshes)
};
struct WireMaterial {
  float kd[3], ks[3], ke[3], ns;
  std::uint32_t nameBytes, textureBytes; // each at most kMaxErrorBytes
};
struct WireFace {
  std::uint32_t count;    // the face's number of corners
  std::uint32_t index[3]; // its first three (0 where it has fewer)
};
// An Error record's kind: the library refused the file (its message follows), or its scene is malformed.
enum ErrorKind : std::uint32_t { kLibraryError = 0, kMalformed = 1 };
constexpr std::size_t kMaxErrorBytes = 1024;
// The child's exit statuses, besides 0.
constexpr int kExitNoMemory = 3, kExitFailed = 4, kExitPipe = 5;

// The child's buffered writing to the pipe; a write that fails (the parent stopped reading) ends the child.
class PipeWriter {
public:
  explicit PipeWriter(int fd) : fd_(fd) { buffer_.reserve(kBufferBytes); }
  template <class T> void put(const T& value) { put(&value, sizeof value); }
  void put(const void* data, std::size_t size)
  {
    if (buffer_.size() + size > kBufferBytes)
      flush();
    if (size > kBufferBytes)
      send(static_cast<const char*>(data), size);
    else
      buffer_.insert(buffer_.end(), static_cast<const char*>(data), static_cast<const char*>(data) + size);
  }
  void flush()
  {
    send(buffer_.data(), buffer_.size());
    buffer_.clear();
  }

private:
  static constexpr std::size_t kBufferBytes = std::size_t(1) << 20;
  void send(const char* data, std::size_t size) const
  {
    if (!writeAll(fd_, data, size))
      _exit(kExitPipe);
  }
  int fd_;
  std::vector<char> buffer_;
};

void sendError(PipeWriter& out, ErrorKind kind, const std::string& text)
{
  const std::string cut = text.substr(0, kMaxErrorBytes);
  out.put(kErrorTag);
  out.put(std::uint32_t(kind));
  out.put(std::uint32_t(cut.size()));
  out.put(cut.data(), cut.size());
}

// The child's walk over an Assimp scene: every mesh a node holds, with the transforms of the nodes above it (identity
// for OBJ and PLY, but applied all the same), sent as a Mesh record. Returns the number of meshes sent, or -1 after
// sending an Error. It checks only what it must not dereference.
long sendNode(const aiScene& scene, const aiNode& node, const aiMatrix4x4& parent, PipeWriter& out)
{
  const aiMatrix4x4 transform = parent * node.mTransformation;
  aiMatrix3x3 normalTransform(transform);
  normalTransform.Inverse().Transpose();
  constexpr std::size_t kChunk = 4096;
  long sent = 0;
  for (unsigned k = 0; k < node.mNumMeshes; ++k) {
    if (node.mMeshes[k] >= scene.mNumMeshes || !scene.mMeshes[node.mMeshes[k]]) {
      sendError(out, kMalformed, "a node names mesh " + std::to_string(node.mMeshes[k]) + " of " +
                                     std::to_string(scene.mNumMeshes));
      return -1;
    }
    const aiMesh& mesh = *scene.mMeshes[node.mMeshes[k]];
    if ((mesh.mNumVertices > 0 && !mesh.mVertices) || (mesh.mNumFaces > 0 && !mesh.mFaces)) {
      sendError(out, kMalformed, "a mesh without its vertices or faces");
      return -1;
    }
    const bool normals = mesh.mNormals != nullptr;
    out.put(kMeshTag);
    const bool uvs = mesh.mTextureCoords[0] != nullptr;
    out.put(WireMesh{mesh.mPrimitiveTypes, mesh.mNumVertices, normals ? 1u : 0u, mesh.mNumFaces, uvs ? 1u : 0u,
                     mesh.mMaterialIndex});
    // (In arrays of a few thousand: a million triangles take tens of milliseconds.)
    std::vector<aiVector3D> vectors;
    auto sendVectors = [&](const aiVector3D* from, const aiMatrix3x3* linear, const aiMatrix4x4* affine) {
      for (std::size_t v = 0; v < mesh.mNumVertices; v += kChunk) {
        vectors.assign(from + v, from + std::min<std::size_t>(mesh.mNumVertices, v + kChunk));
        // (Even by the identity, as raylife always did: it makes -0 +0, and the meshes stay bit for bit the same.)
        for (aiVector3D& x : vectors)
          x = linear ? *linear * x : *affine * x;
        out.put(vectors.data(), vectors.size() * sizeof(aiVector3D));
      }
    };
    sendVectors(mesh.mVertices, nullptr, &transform);
    if (normals)
      sendVectors(mesh.mNormals, &normalTransform, nullptr);
    if (uvs)
      for (std::size_t v = 0; v < mesh.mNumVertices; v += kChunk) {
        vectors.assign(mesh.mTextureCoords[0] + v,
                       mesh.mTextureCoords[0] + std::min<std::size_t>(mesh.mNumVertices, v + kChunk));
        out.put(vectors.data(), vectors.size() * sizeof(aiVector3D));
      }
    std::vector<WireFace> wire;
    for (std::size_t f = 0; f < mesh.mNumFaces; f += kChunk) {
      wire.clear();
      for (std::size_t g = f; g < std::min<std::size_t>(mesh.mNumFaces, f + kChunk); ++g) {
        const aiFace& face = mesh.mFaces[g];
        WireFace w{face.mNumIndices, {0, 0, 0}};
        for (unsigned c = 0; c < 3 && c < face.mNumIndices && face.mIndices; ++c)
          w.index[c] = face.mIndices[c];
        wire.push_back(w);
      }
      out.put(wire.data(), wire.size() * sizeof(WireFace));
    }
    ++sent;
  }
  for (unsigned c = 0; c < node.mNumChildren; ++c) {
    if (!node.mChildren[c]) {
      sendError(out, kMalformed, "a node without its child");
      return -1;
    }
    const long more = sendNode(scene, *node.mChildren[c], transform, out);
    if (more < 0)
      return -1;
    sent += more;
  }
  return sent;
}

// The child: Assimp on the bytes, the stream to `fd`, and _exit (no destructor, no atexit handler: nothing of the
// parent's is flushed or freed twice, LeakSanitizer's check at exit does not run, and the library's scene is not
// freed, which takes long on a big model and gains nothing).
// The scene's materials as Material records: the colours, shininess, name and diffuse texture an OBJ's MTL gives.
void sendMaterials(const aiScene& scene, PipeWriter& out)
{
  for (unsigned k = 0; k < scene.mNumMaterials; ++k) {
    const aiMaterial* m = scene.mMaterials ? scene.mMaterials[k] : nullptr;
    aiColor3D kd(0, 0, 0), ks(0, 0, 0), ke(0, 0, 0);
    float ns = 0;
    aiString name, texture;
    if (m) {
      m->Get(AI_MATKEY_COLOR_DIFFUSE, kd);
      m->Get(AI_MATKEY_COLOR_SPECULAR, ks);
      m->Get(AI_MATKEY_COLOR_EMISSIVE, ke);
      m->Get(AI_MATKEY_SHININESS, ns);
      m->Get(AI_MATKEY_NAME, name);
      if (m->GetTextureCount(aiTextureType_DIFFUSE) > 0)
        m->GetTexture(aiTextureType_DIFFUSE, 0, &texture);
    }
    const std::string n(name.C_Str()), t(texture.C_Str());
    const std::string nameCut = n.substr(0, kMaxErrorBytes), textureCut = t.substr(0, kMaxErrorBytes);
    out.put(kMaterialTag);
    out.put(WireMaterial{{kd.r, kd.g, kd.b}, {ks.r, ks.g, ks.b}, {ke.r, ke.g, ke.b}, ns,
                         std::uint32_t(nameCut.size()), std::uint32_t(textureCut.size())});
    out.put(nameCut.data(), nameCut.size());
    out.put(textureCut.data(), textureCut.size());
  }
}

[[noreturn]] void runReader(int fd, std::span<const char> bytes, MeshFormat format, bool uvs,
                            const std::string* materialsFrom) noexcept
{
  // The faults must end this process, by their signal: a handler inherited from the parent (a sanitizer's, the
  // fuzzer's) would otherwise run here. So must a stop signal the parent catches (a chapter's Ctrl-C); one it ignores
  // (nohup's SIGHUP) stays ignored. A write to a parent that stopped reading fails instead of killing.
  for (const int s : {SIGSEGV, SIGBUS, SIGABRT, SIGFPE, SIGILL, SIGTRAP, SIGSYS})
    std::signal(s, SIG_DFL);
  for (const int s : {SIGINT, SIGTERM, SIGHUP, SIGQUIT}) {
    struct sigaction now{};
    if (::sigaction(s, nullptr, &now) == 0 && now.sa_handler != SIG_IGN)
      std::signal(s, SIG_DFL);
  }
  std::signal(SIGPIPE, SIG_IGN);
#ifdef __linux__
  // Ends with the parent (killed, say), rather than reading on for nobody.
  const pid_t parent = ::getppid();
  ::prctl(PR_SET_PDEATHSIG, SIGKILL);
  if (::getppid() != parent)
    _exit(kExitPipe);
#endif
  // Quiet: what the library or the C library says as it fails (an assertion's text) is not the one-line message.
  const int devNull = ::open("/dev/null", O_WRONLY | O_CLOEXEC);
  if (devNull >= 0) {
    ::dup2(devNull, STDOUT_FILENO);
    ::dup2(devNull, STDERR_FILENO);
  }
  try {
    PipeWriter out(fd);
    // Never deleted (see above).
    auto* importer = new Assimp::Importer;
    // Keep positions and normals only (less to hold; materials and textures are the scene's business).
    importer->SetPropertyInteger(AI_CONFIG_PP_RVC_FLAGS,
                                 aiComponent_TANGENTS_AND_BITANGENTS | aiComponent_COLORS |
                                     (uvs ? 0u : unsigned(aiComponent_TEXCOORDS)) |
                                     aiComponent_BONEWEIGHTS | aiComponent_ANIMATIONS | aiComponent_TEXTURES |
                                     aiComponent_LIGHTS | aiComponent_CAMERAS |
                                     (materialsFrom ? 0u : unsigned(aiComponent_MATERIALS)));
    // (Not Assimp's JoinIdenticalVertices: on a million-triangle PLY it took 15 s and 300 MB more than the reading
    // itself, 2 s and 83 MB. OBJ files are welded by the parent instead.)
    const unsigned flags = aiProcess_ValidateDataStructure | aiProcess_RemoveComponent | aiProcess_Triangulate;
    // From memory, with the format named: Assimp then uses that one importer and opens no other file.
    // (With the file's materials, from the file itself: the OBJ's MTL beside it is then read too.)
    const aiScene* scene =
        materialsFrom ? importer->ReadFile(*materialsFrom, flags)
                      : importer->ReadFileFromMemory(bytes.data(), bytes.size(), flags,
                                                     format == MeshFormat::Obj ? "obj" : "ply");
    long meshes = 0;
    if (!scene) {
      const char* message = importer->GetErrorString();
      sendError(out, kLibraryError, message ? message : "");
    } else if (scene->mRootNode) {
      meshes = sendNode(*scene, *scene->mRootNode, aiMatrix4x4(), out);
      if (meshes >= 0 && materialsFrom)
        sendMaterials(*scene, out);
    }
    if (meshes >= 0) {
      out.put(kEndTag);
      out.put(std::uint32_t(meshes));
    }
    out.flush();
  } catch (const std::bad_alloc&) {
    _exit(kExitNoMemory);
  } catch (...) {
    _exit(kExitFailed);
  }
  _exit(0);
}

// The parent's reading of the stream: whole values, EINTR retried; the end of the stream is reported, not thrown.
class PipeReader {
public:
  explicit PipeReader(int fd) : fd_(fd) {}
  // Fills `data` with `size` bytes; false if the stream ends first.
  bool get(void* data, std::size_t size) { return readAll(fd_, data, size); }

private:
  int fd_;
};

// What ended the parent's reading before the End record: the stream ended (the child died, or closed it), or it
// was not what the child writes.
struct StreamFault {
  bool garbled;
  std::string what;
};

// The child, for the parent: its pipe's reading end, and its process, killed and reaped on the way out unless
// wait() reaped it (an exception from the checks leaves no process behind, and no zombie).
class ReaderProcess {
public:
  ReaderProcess(pid_t pid, int fd) : pid_(pid), fd_(fd) {}
  ReaderProcess(const ReaderProcess&) = delete;
  ReaderProcess& operator=(const ReaderProcess&) = delete;
  ~ReaderProcess()
  {
    if (pid_ > 0)
      ::kill(pid_, SIGKILL);
    wait();
  }
  int fd() const { return fd_; }
  void kill() const
  {
    if (pid_ > 0)
      ::kill(pid_, SIGKILL);
  }
  // Closes the pipe and waits for the child's end: its wait status, or nothing if it cannot be known (SIGCHLD
  // ignored by the program, which has the system reap children at once).
  std::optional<int> wait()
  {
    if (fd_ >= 0) {
      ::close(fd_);
      fd_ = -1;
    }
    if (pid_ <= 0)
      return std::nullopt;
    int status = 0;
    pid_t done;
    while ((done = ::waitpid(pid_, &status, 0)) < 0 && errno == EINTR) {
    }
    pid_ = -1;
    return done > 0 ? std::optional<int>(status) : std::nullopt;
  }

private:
  pid_t pid_;
  int fd_;
};

std::string signalName(int signal)
{
  switch (signal) {
  case SIGSEGV: return "SIGSEGV";
  case SIGABRT: return "SIGABRT";
  case SIGBUS: return "SIGBUS";
  case SIGFPE: return "SIGFPE";
  case SIGILL: return "SIGILL";
  case SIGTRAP: return "SIGTRAP";
  case SIGSYS: return "SIGSYS";
  case SIGKILL: return "SIGKILL";
  case SIGINT: return "SIGINT";
  case SIGTERM: return "SIGTERM";
  case SIGHUP: return "SIGHUP";
  case SIGQUIT: return "SIGQUIT";
  case SIGXCPU: return "SIGXCPU";
  default: return "signal " + std::to_string(signal);
  }
}

// What a child that ended so, without a whole answer, means for the user.
std::string describeEnd(std::optional<int> status, const StreamFault& fault)
{
  if (status && WIFSIGNALED(*status)) {
    const int s = WTERMSIG(*status);
    if (s == SIGINT || s == SIGTERM || s == SIGHUP || s == SIGQUIT)
      return "the mesh reader was stopped (" + signalName(s) + ") before it finished";
    if (s == SIGKILL)
      return "the mesh reader was killed (SIGKILL) before it finished: out of memory?";
    return "the mesh reader crashed (" + signalName(s) + ") on this file: it is malformed";
  }
  if (status && WIFEXITED(*status) && WEXITSTATUS(*status) == kExitNoMemory)
    return "the mesh reader ran out of memory on this file";
  if (status && WIFEXITED(*status) && WEXITSTATUS(*status) != 0)
    return "the mesh reader failed (exit status " + std::to_string(WEXITSTATUS(*status)) + ") on this file";
  return "the mesh reader's answer was " + fault.what;
}

// Reads `count` elements of T from the stream into `out`, chunk by chunk (a count is not trusted with an allocation:
// memory grows with what arrives), calling `take(element, index)` for each.
template <class T, class Take> void receiveArray(PipeReader& in, std::uint64_t count, std::vector<T>& scratch,
                                                 const Take& take)
{
  constexpr std::uint64_t kChunk = std::uint64_t(1) << 16;
  for (std::uint64_t done = 0; done < count;) {
    const std::size_t n = std::size_t(std::min(kChunk, count - done));
    scratch.resize(n);
    if (!in.get(scratch.data(), n * sizeof(T)))
      throw StreamFault{false, "cut short"};
    for (std::size_t i = 0; i < n; ++i)
      take(scratch[i], done + i);
    done += n;
  }
}

// The parent: reads the child's stream into `data`, checking every array as it comes. Limits: a file of `fileBytes`
// bytes cannot make more vertices or faces than a few per byte (a corner takes at least a byte or two in either
// format); more is a garbled stream, and so is any record the child does not write. @throws MeshError for a fault
// of the file, StreamFault for one of the stream.
void receive(PipeReader& in, MeshData& data, std::size_t fileBytes, const std::string& name,
             const std::string& formatName)
{
  const std::uint64_t limit = std::min<std::uint64_t>(8 * std::uint64_t(fileBytes) + 4096, UINT32_MAX);
  auto garbled = [](const std::string& what) { return StreamFault{true, "garbled: " + what}; };
  std::uint64_t meshes = 0, faces = 0, largestMaterial = 0;
  std::vector<aiVector3D> vectors;
  std::vector<WireFace> wireFaces;
  for (;;) {
    std::uint32_t tag = 0;
    if (!in.get(&tag, sizeof tag))
      throw StreamFault{false, "cut short"};
    if (tag == kEndTag) {
      std::uint32_t sent = 0;
      if (!in.get(&sent, sizeof sent))
        throw StreamFault{false, "cut short"};
      if (sent != meshes)
        throw garbled("it ends after " + std::to_string(sent) + " meshes, of " + std::to_string(meshes) + " sent");
      if (!data.materials.empty() && largestMaterial >= data.materials.size())
        throw MeshError(name + ": a part names material " + std::to_string(largestMaterial) + " of " +
                        std::to_string(data.materials.size()));
      return;
    }
    if (tag == kMaterialTag) {
      WireMaterial m{};
      if (!in.get(&m, sizeof m))
        throw StreamFault{false, "cut short"};
      if (m.nameBytes > kMaxErrorBytes || m.textureBytes > kMaxErrorBytes || data.materials.size() >= limit)
        throw garbled("a material record out of range");
      std::string text(std::size_t(m.nameBytes) + m.textureBytes, '\0');
      if (!in.get(text.data(), text.size()))
        throw StreamFault{false, "cut short"};
      FileMaterial fm;
      fm.name = text.substr(0, m.nameBytes);
      fm.diffuseMap = text.substr(m.nameBytes);
      fm.diffuse = Color(m.kd[0], m.kd[1], m.kd[2]);
      fm.specular = Color(m.ks[0], m.ks[1], m.ks[2]);
      fm.emission = Color(m.ke[0], m.ke[1], m.ke[2]);
      fm.shininess = Real(m.ns);
      for (const Color& c : {fm.diffuse, fm.specular, fm.emission})
        if (!isFinite(c) || c.r < 0 || c.g < 0 || c.b < 0)
          throw MeshError(name + ": material '" + fm.name + "' has a colour that is negative or not finite");
      if (!std::isfinite(fm.shininess) || fm.shininess < 0)
        throw MeshError(name + ": material '" + fm.name + "' has a shininess (Ns) that is negative or not finite");
      data.materials.push_back(std::move(fm));
      continue;
    }
    if (tag == kErrorTag) {
      std::uint32_t fields[2] = {};
      if (!in.get(fields, sizeof fields))
        throw StreamFault{false, "cut short"};
      if (fields[0] > kMalformed || fields[1] > kMaxErrorBytes)
        throw garbled("an error record out of range");
      std::string text(fields[1], '\0');
      if (!in.get(text.data(), text.size()))
        throw StreamFault{false, "cut short"};
      if (fields[0] == kMalformed)
        throw MeshError(name + ": malformed: " + libraryMessage(text.c_str()));
      throw MeshError(name + ": cannot read it as " + formatName + ": " + libraryMessage(text.c_str()));
    }
    if (tag != kMeshTag)
      throw garbled("an unknown record");
    WireMesh mesh{};
    if (!in.get(&mesh, sizeof mesh))
      throw StreamFault{false, "cut short"};
    ++meshes;
    if (mesh.hasNormals > 1 || mesh.hasUvs > 1 || data.positions.size() + std::uint64_t(mesh.vertices) > limit ||
        faces + mesh.faces > limit || meshes > limit)
      throw garbled("a mesh larger than the file can hold");
    faces += mesh.faces;
    if (mesh.primitiveTypes & (aiPrimitiveType_POINT | aiPrimitiveType_LINE))
      throw MeshError(name + ": unsupported polygon: the file has points or lines (faces of 1 or 2 vertices); " +
                      "raylife renders triangles only");
    const std::size_t first = data.positions.size();
    data.positions.reserve(first + std::min<std::size_t>(mesh.vertices, std::size_t(1) << 20));
    receiveArray(in, mesh.vertices, vectors, [&](const aiVector3D& p, std::uint64_t v) {
      const Vec3 position(p.x, p.y, p.z);
      if (!isFinite(position))
        throw MeshError(name + ": vertex " + std::to_string(first + v + 1) + " is not finite (NaN or infinite)");
      data.positions.push_back(position);
    });
    // (A file whose parts do not all have normals has none: see the caller.)
    if (mesh.hasNormals) {
      data.normals.reserve(data.positions.size());
      receiveArray(in, mesh.vertices, vectors, [&](const aiVector3D& n, std::uint64_t) {
        data.normals.emplace_back(n.x, n.y, n.z);
      });
    }
    // (Likewise a file whose parts do not all have texture coordinates has none.)
    if (mesh.hasUvs) {
      data.uvs.reserve(data.positions.size());
      receiveArray(in, mesh.vertices, vectors, [&](const aiVector3D& t, std::uint64_t v) {
        if (!std::isfinite(t.x) || !std::isfinite(t.y))
          throw MeshError(name + ": the texture coordinates of vertex " + std::to_string(first + v + 1) +
                          " are not finite (NaN or infinite)");
        data.uvs.emplace_back(t.x, t.y);
      });
    }
    data.triangles.reserve(data.triangles.size() + std::min<std::size_t>(mesh.faces, std::size_t(1) << 20));
    receiveArray(in, mesh.faces, wireFaces, [&](const WireFace& face, std::uint64_t f) {
      if (face.count != 3)
        throw MeshError(name + ": unsupported polygon: face " + std::to_string(f + 1) + " has " +
                        std::to_string(face.count) + " vertices after triangulation");
      std::array<std::uint32_t, 3> tri{};
      for (int c = 0; c < 3; ++c) {
        const std::uint32_t index = face.index[c];
        // Checked here whatever the library checked: an index out of range must never reach the renderer.
        if (index >= mesh.vertices)
          throw MeshError(name + ": bad index: face " + std::to_string(f + 1) + " names vertex " +
                          std::to_string(std::uint64_t(index) + 1) + " of " + std::to_string(mesh.vertices));
        tri[std::size_t(c)] = std::uint32_t(first + index);
      }
      data.triangles.push_back(tri);
      data.triangleMaterials.push_back(mesh.material);
    });
    largestMaterial = std::max<std::uint64_t>(largestMaterial, mesh.material);
  }
}

// Assimp on `bytes`, in a child process (see above), and its answer checked. @throws MeshError.
MeshData readInChild(std::span<const char> bytes, MeshFormat format, const std::string& name, bool uvs,
                     const std::string* materialsFrom)
{
  const std::string formatName = format == MeshFormat::Obj ? "OBJ" : "PLY";
  // (A pipe of 1 MiB: fewer, larger transfers for a big model.)
  const auto [fd, pid] = forkWithPipe<MeshError>(
      name + ": cannot start the mesh reader: ",
      [&](int writeEnd) { runReader(writeEnd, bytes, format, uvs, materialsFrom); }, 1 << 20);
  ReaderProcess child(pid, fd);
  PipeReader in(child.fd());
  MeshData data;
  try {
    receive(in, data, bytes.size(), name, formatName);
  } catch (const StreamFault& fault) {
    if (fault.garbled)
      child.kill(); // it may be writing on: its status is ours, not the file's
    const std::optional<int> status = child.wait();
    throw MeshError(name + ": " + (fault.garbled ? "the mesh reader's answer was " + fault.what
                                                 : describeEnd(status, fault)));
  }
  const std::optional<int> status = child.wait();
  // A whole answer from a child that then failed is refused too: a library that crashed after writing its answer
  // may have written through a bad pointer before.
  if (status && !(WIFEXITED(*status) && WEXITSTATUS(*status) == 0))
    throw MeshError(name + ": " + describeEnd(status, StreamFault{false, "whole"}));
  return data;
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

MeshData parseMeshData(std::span<const char> bytes, MeshFormat format, const std::string& name, bool uvs,
                       const std::string* materialsFrom)
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
  MeshData data = readInChild(bytes, format, name, uvs, materialsFrom);
  if (!materialsFrom)
    data.triangleMaterials.clear();
  if (data.uvs.size() != data.positions.size())
    data.uvs.clear(); // some parts had texture coordinates and some did not: none
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

MeshData readMeshFile(const std::string& path, bool uvs, bool materials)
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
  MeshData data = parseMeshData(bytes, format, path, uvs, materials ? &path : nullptr);
  std::vector<char>().swap(bytes);
#ifdef __GLIBC__
  // The file's bytes and Assimp's scene are freed but glibc keeps much of it; hand it back, so that the memory a
  // big model holds while the tree is built and the image rendered is the mesh itself.
  malloc_trim(0);
#endif
  return data;
}

} // namespace raylife

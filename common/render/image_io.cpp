#include "render/image_io.h"

#include "scene/texture_file.h"

#include <stb/stb_image_write.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <cstdlib>
#include <cctype>
#include <fstream>
#include <sstream>

#include <sys/stat.h>
#include <fcntl.h>
#include <unistd.h>

namespace raylife {

float linearToSrgb(float linear)
{
  const float v = std::clamp(linear, 0.0f, 1.0f);
  return v <= 0.0031308f ? 12.92f * v : 1.055f * std::pow(v, 1.0f / 2.4f) - 0.055f;
}

float srgbToLinear(float encoded)
{
  const float v = std::clamp(encoded, 0.0f, 1.0f);
  return v <= 0.04045f ? v / 12.92f : std::pow((v + 0.055f) / 1.055f, 2.4f);
}

float toneMap(float v, ToneMap curve)
{
  if (!(v > 0)) // (NaN too)
    return 0;
  switch (curve) {
  case ToneMap::Clamp:
    return std::min(v, 1.0f);
  case ToneMap::Reinhard:
    return std::isinf(v) ? 1.0f : v / (1 + v);
  case ToneMap::Aces:
    if (std::isinf(v))
      return 1;
    return std::clamp(v * (2.51f * v + 0.03f) / (v * (2.43f * v + 0.59f) + 0.14f), 0.0f, 1.0f);
  }
  return v;
}

Image toneMapped(Image image, ToneMap curve)
{
  if (curve != ToneMap::Clamp)
    for (float& v : image.pixels)
      v = toneMap(v, curve);
  return image;
}

ToneMap parseToneMap(const std::string& word)
{
  if (word == "clamp")
    return ToneMap::Clamp;
  if (word == "reinhard")
    return ToneMap::Reinhard;
  if (word == "aces")
    return ToneMap::Aces;
  throw std::invalid_argument("unknown tone map '" + word + "' (known: clamp, reinhard, aces)");
}

std::vector<unsigned char> encodePng(const Image& image)
{
  std::vector<unsigned char> bytes(std::size_t(image.width) * std::size_t(image.height) * 3);
  for (std::size_t i = 0; i < bytes.size(); ++i) {
    const float v = image.pixels[i];
    // NaN maps to 0 (std::clamp would pass it through); the render loop never lets one reach the film.
    const float encoded = std::isnan(v) ? 0.0f : linearToSrgb(v);
    bytes[i] = static_cast<unsigned char>(std::lround(encoded * 255.0f));
  }
  std::vector<unsigned char> png;
  auto append = [](void* context, void* data, int size) {
    auto* out = static_cast<std::vector<unsigned char>*>(context);
    const auto* p = static_cast<const unsigned char*>(data);
    out->insert(out->end(), p, p + size);
  };
  if (!stbi_write_png_to_func(append, &png, image.width, image.height, 3, bytes.data(), image.width * 3))
    throw ImageIoError("cannot encode a PNG of " + std::to_string(image.width) + "x" + std::to_string(image.height));
  return png;
}

std::vector<unsigned char> encodePfm(const Image& image)
{
  // A negative scale marks little-endian data; this machine (x86-64) is little-endian.
  const std::string header = "PF\n" + std::to_string(image.width) + " " + std::to_string(image.height) + "\n-1.0\n";
  std::vector<unsigned char> out(header.begin(), header.end());
  const std::size_t rowBytes = std::size_t(image.width) * 3 * sizeof(float);
  out.reserve(out.size() + rowBytes * std::size_t(image.height));
  for (int y = image.height - 1; y >= 0; --y) { // PFM stores the bottom row first
    const auto* row = reinterpret_cast<const unsigned char*>(&image.pixels[std::size_t(y) * std::size_t(image.width) * 3]);
    out.insert(out.end(), row, row + rowBytes);
  }
  return out;
}

namespace {

std::string readToken(std::istream& in)
{
  std::string token;
  char c;
  while (in.get(c) && std::isspace(static_cast<unsigned char>(c))) {
  }
  if (!in)
    return token;
  token += c;
  while (in.get(c) && !std::isspace(static_cast<unsigned char>(c)))
    token += c;
  return token; // the single whitespace after the token has been consumed, as PFM requires
}

} // namespace

Image readPfm(const std::string& path)
{
  std::ifstream in(path, std::ios::binary);
  if (!in)
    throw ImageIoError(path + ": cannot open: " + std::strerror(errno));
  const std::string magic = readToken(in);
  if (magic != "PF" && magic != "Pf")
    throw ImageIoError(path + ": not a PFM file (it does not start with PF or Pf)");
  const int channels = magic == "PF" ? 3 : 1;
  long width = 0, height = 0;
  double scale = 0;
  try {
    // Each token whole: std::stol alone took "4\xce2" as 4.
    const auto whole = [](const std::string& token, std::size_t used) {
      if (used != token.size())
        throw std::invalid_argument(token);
    };
    std::size_t used = 0;
    const std::string w = readToken(in), h = readToken(in), sc = readToken(in);
    width = std::stol(w, &used);
    whole(w, used);
    height = std::stol(h, &used);
    whole(h, used);
    scale = std::stod(sc, &used);
    whole(sc, used);
  } catch (const std::exception&) {
    throw ImageIoError(path + ": malformed PFM header");
  }
  // (width > 2^28 / height, not width·height > 2^28: the sides may be anything a long holds, and so overflow it.)
  if (width <= 0 || height <= 0 || width > (1L << 28) / height || scale == 0 || !std::isfinite(scale))
    throw ImageIoError(path + ": bad PFM header (size " + std::to_string(width) + "x" + std::to_string(height) + ")");
  const bool swap = scale > 0; // positive scale: big-endian data
  // The pixels' bytes, counted before the image is allocated: a short file that claims 16384x16384 pixels would
  // otherwise cost 3 GiB before its end was found.
  const std::streamoff start = in.tellg();
  in.seekg(0, std::ios::end);
  const std::streamoff have = in.tellg() - start;
  in.seekg(start);
  const long long need = (long long)width * height * channels * (long long)sizeof(float);
  if (start < 0 || !in || have < need)
    throw ImageIoError(path + ": the PFM file is truncated (" + std::to_string(width) + "x" + std::to_string(height) +
                       " pixels need " + std::to_string(need) + " bytes after the header, and it has " +
                       std::to_string(std::max<std::streamoff>(have, 0)) + ")");
  Image image{int(width), int(height)};
  std::vector<float> row(std::size_t(width) * std::size_t(channels));
  for (long y = height - 1; y >= 0; --y) {
    in.read(reinterpret_cast<char*>(row.data()), std::streamsize(row.size() * sizeof(float)));
    if (!in)
      throw ImageIoError(path + ": the PFM file is truncated");
    for (long x = 0; x < width; ++x)
      for (int c = 0; c < 3; ++c) {
        float v = row[std::size_t(x * channels + (channels == 3 ? c : 0))];
        if (swap) {
          std::uint32_t bits;
          std::memcpy(&bits, &v, 4);
          bits = __builtin_bswap32(bits);
          std::memcpy(&v, &bits, 4);
        }
        image.at(int(x), int(y), c) = v;
      }
  }
  return image;
}

Image readPng(const std::string& path)
{
  // Through the texture reader: stb_image in a child process, on a PNG only (texture_file.h says why), so that a
  // crafted file given to raylife_check, raylife_compare or raylife_image ends in a message, not in a fault. The
  // values come as stored (an 8-bit code c as c/255.0f, the float this reader always decoded) and are decoded from
  // sRGB here.
  TexelImage texels;
  try {
    texels = readStbImageFile(path, ".png", ImageEncoding::Linear);
  } catch (const ImageFileError& e) {
    throw ImageIoError(e.what());
  }
  Image image;
  image.width = texels.width;
  image.height = texels.height;
  image.pixels = std::move(texels.rgb);
  for (float& v : image.pixels)
    v = srgbToLinear(v);
  return image;
}

std::string fileExtension(const std::string& path)
{
  const std::size_t slash = path.find_last_of('/'), dot = path.find_last_of('.');
  if (dot == std::string::npos || (slash != std::string::npos && dot < slash))
    return "";
  std::string extension = path.substr(dot);
  for (char& c : extension)
    c = char(std::tolower(static_cast<unsigned char>(c)));
  return extension;
}

namespace {
// Whether `path` has the extension `suffix` (lower case, with its dot), in any case.
bool endsWith(const std::string& path, const char* suffix) { return fileExtension(path) == suffix; }
} // namespace

bool isImagePath(const std::string& path)
{
  return endsWith(path, ".png") || endsWith(path, ".pfm") || endsWith(path, ".exr");
}

Image readImage(const std::string& path)
{
  if (endsWith(path, ".pfm"))
    return readPfm(path);
  if (endsWith(path, ".png"))
    return readPng(path);
  if (endsWith(path, ".exr"))
    return readExr(path);
  throw ImageIoError(path + ": unknown image format (expected a .png, .pfm or .exr file)");
}

std::vector<unsigned char> encodeImage(const Image& image, const std::string& path)
{
  if (endsWith(path, ".pfm"))
    return encodePfm(image);
  if (endsWith(path, ".png"))
    return encodePng(image);
  if (endsWith(path, ".exr"))
    return encodeExr(image);
  throw ImageIoError(path + ": unknown image format (expected a .png, .pfm or .exr file)");
}

namespace {

// Why writing `target` failed, and that an existing file of that name was not touched.
std::string writeFailure(const std::string& target, int error)
{
  struct stat info{};
  const bool exists = ::stat(target.c_str(), &info) == 0;
  return "cannot write " + target + ": " + std::strerror(error) +
         (exists ? "; the existing " + target + " was left as it was" : "");
}

// Writes all of `bytes` to a new temporary file in `target`'s folder; returns its name. The name is hidden
// (".NAME.tmp.XXXXXX"), and short enough to be valid whenever the target's name is.
std::string writeTemporary(const std::string& target, const std::vector<unsigned char>& bytes,
                           const std::atomic<bool>* cancel)
{
  const std::size_t slash = target.rfind('/');
  const std::string folder = slash == std::string::npos ? "" : target.substr(0, slash + 1);
  std::string base = slash == std::string::npos ? target : target.substr(slash + 1);
  if (base.size() > 200)
    base.resize(200);
  std::string name = folder + "." + base + ".tmp.XXXXXX";
  const int fd = mkstemp(name.data());
  if (fd < 0)
    throw ImageIoError(writeFailure(target, errno));
  auto abandon = [&](int error) {
    ::close(fd);
    ::unlink(name.c_str());
    if (error == 0)
      throw WriteCancelled("writing " + target + " was cancelled");
    throw ImageIoError(writeFailure(target, error));
  };
  // RAYLIFE_FAIL_WRITE_AFTER=N (tests only) makes every write fail with ENOSPC after N bytes, as a full disk would.
  std::size_t failAfter = std::size_t(-1);
  if (const char* inject = std::getenv("RAYLIFE_FAIL_WRITE_AFTER"))
    failAfter = std::size_t(std::strtoull(inject, nullptr, 10));
  constexpr std::size_t kChunk = std::size_t(1) << 20;
  std::size_t done = 0;
  while (done < bytes.size()) {
    if (cancel && cancel->load())
      abandon(0);
    std::size_t chunk = std::min(kChunk, bytes.size() - done);
    ssize_t wrote;
    if (done + chunk > failAfter) {
      chunk = failAfter > done ? failAfter - done : 0;
      wrote = chunk ? ::write(fd, bytes.data() + done, chunk) : (errno = ENOSPC, -1);
    } else {
      wrote = ::write(fd, bytes.data() + done, chunk);
    }
    if (wrote < 0) {
      if (errno == EINTR)
        continue;
      abandon(errno);
    }
    done += std::size_t(wrote);
  }
  // fsync: a full disk or a failing device may report only now; close may too (on NFS, say).
  if (::fsync(fd) != 0)
    abandon(errno);
  if (::close(fd) != 0) {
    const int saved = errno;
    ::unlink(name.c_str());
    throw ImageIoError(writeFailure(target, saved));
  }
  ::chmod(name.c_str(), 0644); // mkstemp creates 0600; an image is for everyone to read
  return name;
}

} // namespace

void writeFilesAtomically(const std::vector<std::pair<std::string, std::vector<unsigned char>>>& files,
                          const std::atomic<bool>* cancel)
{
  std::vector<std::string> temporaries;
  try {
    for (const auto& [target, bytes] : files)
      temporaries.push_back(writeTemporary(target, bytes, cancel));
    if (cancel && cancel->load())
      throw WriteCancelled("writing was cancelled");
  } catch (...) {
    for (const std::string& t : temporaries)
      ::unlink(t.c_str());
    throw;
  }
  // Rename every file into place. A rename within one folder fails only in odd cases (the target became a
  // folder, say); then the files not yet renamed are removed and the ones already in place stay complete.
  for (std::size_t i = 0; i < files.size(); ++i) {
    if (std::rename(temporaries[i].c_str(), files[i].first.c_str()) != 0) {
      const int saved = errno;
      for (std::size_t j = i; j < temporaries.size(); ++j)
        ::unlink(temporaries[j].c_str());
      throw ImageIoError(writeFailure(files[i].first, saved));
    }
  }
}

void writeImage(const Image& image, const std::string& path)
{
  writeFilesAtomically({{path, encodeImage(image, path)}});
}

} // namespace raylife

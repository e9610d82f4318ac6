// Images for textures (texture_file.h): stb_image in a child process, OpenEXR and PFM through the image files of
// the render layer (the one place the scene layer reads a file format the render layer also writes).
#include "scene/texture_file.h"

#include "render/image_io.h"
#include "scene/pipe_io.h"

#include <stb/stb_image.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <csignal>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <span>
#include <vector>

#include <fcntl.h>
#include <sys/wait.h>
#include <unistd.h>
#ifdef __linux__
#include <sys/prctl.h>
#endif

namespace raylife {

namespace {

std::string lowerExtension(const std::string& path)
{
  std::string e = std::filesystem::path(path).extension().string();
  std::transform(e.begin(), e.end(), e.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  return e;
}

// The child's answer: a header, then (status 0) width·height·3 floats, or (status 1) `width` bytes of message.
struct WireHeader {
  std::uint32_t status, width, height;
};

// Whether a Radiance (.hdr) file's texel data ends before its w × h texels. stb_image reads past the end as zeros, so
// a truncated file would decode, without a word, to an image black at the bottom: its scanlines are walked here
// first, as stb_image reads them (flat RGBE when w is outside [8, 32767] or the first scanline is not run-length
// encoded; otherwise per scanline 2, 2, w and four channels of runs). What is malformed rather than short (a run of
// 0, a scanline of another width) is left to stb_image, which says what it is.
bool radianceEndsEarly(std::span<const unsigned char> b, int w, int h)
{
  const std::size_t n = b.size();
  std::size_t at = 0;
  auto skipLine = [&] {
    while (at < n && b[at] != '\n')
      ++at;
    ++at; // (past the end when there is no newline: then at > n)
  };
  // The header's lines, up to an empty one, then the resolution line.
  while (at < n && b[at] != '\n')
    skipLine();
  ++at;
  skipLine();
  if (at > n)
    return true;
  const auto flatTexels = [&](std::size_t texels) { return n - at < texels * 4; };
  const std::size_t width = std::size_t(w);
  if (w < 8 || w > 0x7fff)
    return flatTexels(width * std::size_t(h));
  for (int y = 0; y < h; ++y) {
    if (n - at < 4)
      return true;
    if (b[at] != 2 || b[at + 1] != 2 || (b[at + 2] & 0x80) != 0)
      return flatTexels(width * std::size_t(h - y)); // stb_image reads the rest flat, from this texel on
    if (((std::size_t(b[at + 2]) << 8) | b[at + 3]) != width)
      return false;
    at += 4;
    for (int channel = 0; channel < 4; ++channel)
      for (std::size_t x = 0; x < width;) {
        if (at >= n)
          return true;
        std::size_t count = b[at++];
        const bool run = count > 128;
        if (run)
          count -= 128;
        if (count == 0 || count > width - x)
          return false;
        const std::size_t bytes = run ? 1 : count;
        if (n - at < bytes)
          return true;
        at += bytes;
        x += count;
      }
  }
  return false;
}

// The child: stb_image on the bytes, linear floats to `fd`, then _exit (see mesh_file.cpp for why _exit).
[[noreturn]] void decodeInChild(int fd, std::span<const unsigned char> bytes, ImageEncoding encoding) noexcept
{
  for (const int s : {SIGSEGV, SIGBUS, SIGABRT, SIGFPE, SIGILL, SIGTRAP, SIGSYS})
    std::signal(s, SIG_DFL);
  std::signal(SIGPIPE, SIG_IGN);
#ifdef __linux__
  const pid_t parent = ::getppid();
  ::prctl(PR_SET_PDEATHSIG, SIGKILL);
  if (::getppid() != parent)
    _exit(5);
#endif
  auto fail = [&](const std::string& message) {
    const WireHeader header{1, std::uint32_t(message.size()), 0};
    writeAll(fd, &header, sizeof header);
    writeAll(fd, message.data(), message.size());
    _exit(0);
  };
  const auto* data = bytes.data();
  const int length = int(bytes.size());
  int w = 0, h = 0, n = 0;
  // The size from the header first: nothing is decoded for a file that claims too many texels.
  if (!stbi_info_from_memory(data, length, &w, &h, &n))
    fail(std::string("cannot read it: ") + stbFailureReason());
  if (w <= 0 || h <= 0)
    fail("the image has no texels (" + std::to_string(w) + "x" + std::to_string(h) + ")");
  if ((long long)w * h > kMaxTexels)
    fail("the image is " + std::to_string(w) + "x" + std::to_string(h) + " texels, more than the " +
         std::to_string(kMaxTexels) + " raylife reads");
  // A file too short for the texels its header claims, refused before anything is allocated for them. (A PNG header
  // of 25 bytes that claimed 16384x16384 texels cost 3 GiB and 13 s before stb_image found it cut short: found by
  // fuzzing.) No file of these formats packs more than kMaxTexelsPerByte texels into a byte.
  if ((long long)w * h > kMaxTexelsPerByte * (long long)bytes.size())
    fail("its header claims " + std::to_string(w) + "x" + std::to_string(h) + " texels, more than a file of " +
         std::to_string(bytes.size()) + " bytes can hold: the file is truncated or malformed");
  // (The floats are allocated once stb_image has decoded the texels, not before: a file it refuses costs no more.)
  std::vector<float> rgb;
  if (stbi_is_hdr_from_memory(data, length)) {
    if (radianceEndsEarly(bytes, w, h))
      fail("its texels end early: the file is truncated (a " + std::to_string(w) + "x" + std::to_string(h) +
           " Radiance image)");
    float* f = stbi_loadf_from_memory(data, length, &w, &h, &n, 3);
    if (!f)
      fail(std::string("cannot decode it: ") + stbFailureReason());
    rgb.assign(f, f + std::size_t(w) * std::size_t(h) * 3);
  } else if (stbi_is_16_bit_from_memory(data, length)) {
    stbi_us* s = stbi_load_16_from_memory(data, length, &w, &h, &n, 3);
    if (!s)
      fail(std::string("cannot decode it: ") + stbFailureReason());
    rgb.resize(std::size_t(w) * std::size_t(h) * 3);
    for (std::size_t i = 0; i < rgb.size(); ++i) {
      const float e = float(s[i]) / 65535.0f;
      rgb[i] = encoding == ImageEncoding::Srgb ? srgbToLinear(e) : e;
    }
  } else {
    stbi_uc* c = stbi_load_from_memory(data, length, &w, &h, &n, 3);
    if (!c)
      fail(std::string("cannot decode it: ") + stbFailureReason());
    rgb.resize(std::size_t(w) * std::size_t(h) * 3);
    // [srgbTable]
    // 8 bits: 256 possible values, decoded once into a table rather than by pow() for every texel.
    const std::array<float, 256>& decode = srgbDecodeTable();
    for (std::size_t i = 0; i < rgb.size(); ++i)
      rgb[i] = encoding == ImageEncoding::Srgb ? decode[c[i]] : float(c[i]) / 255.0f;
    // [srgbTable]
  }
  const WireHeader header{0, std::uint32_t(w), std::uint32_t(h)};
  if (!writeAll(fd, &header, sizeof header) ||
      !writeAll(fd, rgb.data(), rgb.size() * sizeof(float)))
    _exit(5);
  _exit(0);
}

std::string describeStatus(int status)
{
  if (WIFSIGNALED(status))
    return "the image reader crashed on it (signal " + std::to_string(WTERMSIG(status)) + "): the file is malformed";
  return "the image reader failed on it (exit status " + std::to_string(WEXITSTATUS(status)) + ")";
}

// Every texel finite and ≥ 0 (radiance and reflectance are), and the size as claimed.
void checkTexels(const TexelImage& image, const std::string& name)
{
  if (image.width <= 0 || image.height <= 0)
    throw ImageFileError(name + ": the image has no texels");
  if ((long long)image.width * image.height > kMaxTexels)
    throw ImageFileError(name + ": the image is " + std::to_string(image.width) + "x" +
                         std::to_string(image.height) + " texels, more than the " + std::to_string(kMaxTexels) +
                         " raylife reads");
  for (std::size_t i = 0; i < image.rgb.size(); ++i)
    if (!std::isfinite(image.rgb[i]) || image.rgb[i] < 0) {
      const std::size_t texel = i / 3;
      throw ImageFileError(name + ": texel (" + std::to_string(texel % std::size_t(image.width)) + ", " +
                           std::to_string(texel / std::size_t(image.width)) + ") is " +
                           (std::isfinite(image.rgb[i]) ? "negative" : "not finite") +
                           ": a texture holds finite values ≥ 0");
    }
}

// The stb_image format whose signature `bytes` start with: ".png", ".jpg", ".hdr", or "" (stb_image's other formats,
// some without a signature at all, are never handed to it).
std::string signatureOf(std::span<const unsigned char> bytes)
{
  auto starts = [&](std::string_view magic) {
    return bytes.size() >= magic.size() && std::memcmp(bytes.data(), magic.data(), magic.size()) == 0;
  };
  if (starts("\x89PNG\r\n\x1a\n"))
    return ".png";
  if (starts("\xff\xd8\xff"))
    return ".jpg";
  if (starts("#?RADIANCE\n") || starts("#?RGBE\n"))
    return ".hdr";
  return "";
}

TexelImage fromImage(Image image)
{
  TexelImage t;
  t.width = image.width;
  t.height = image.height;
  t.rgb = std::move(image.pixels);
  return t;
}

} // namespace

TexelImage decodeStbImage(std::span<const unsigned char> bytes, ImageEncoding encoding, const std::string& name)
{
  if (bytes.empty())
    throw ImageFileError(name + ": the file is empty");
  if (bytes.size() > std::size_t(INT32_MAX))
    throw ImageFileError(name + ": the file is larger than 2 GiB");
  if (signatureOf(bytes).empty())
    throw ImageFileError(name + ": not a PNG, JPEG or Radiance HDR image (its first bytes are none of theirs)");
  // (Not a structured binding: clang 14, the sanitizer build's compiler, cannot capture one in a lambda.)
  const std::pair<int, pid_t> child = forkWithPipe<ImageFileError>(
      name + ": cannot start the image reader: ", [&](int writeEnd) { decodeInChild(writeEnd, bytes, encoding); });
  const int fd = child.first;
  const pid_t pid = child.second;
  // The parent: the header, then the texels or the message; the child reaped whatever happens.
  auto reap = [pid](bool kill) {
    if (kill)
      ::kill(pid, SIGKILL);
    int status = 0;
    while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) {
    }
    return status;
  };
  WireHeader header{};
  TexelImage image;
  std::string message;
  bool whole = readAll(fd, &header, sizeof header);
  if (whole && header.status == 1) {
    message.resize(std::min<std::uint32_t>(header.width, 1024));
    whole = readAll(fd, message.data(), message.size());
  } else if (whole && header.status == 0 && header.width > 0 && header.height > 0 &&
             (long long)header.width * header.height <= kMaxTexels) {
    image.width = int(header.width);
    image.height = int(header.height);
    image.rgb.resize(std::size_t(header.width) * header.height * 3);
    whole = readAll(fd, image.rgb.data(), image.rgb.size() * sizeof(float));
  } else {
    whole = false;
  }
  ::close(fd);
  const int status = reap(!whole);
  if (!whole || !WIFEXITED(status) || WEXITSTATUS(status) != 0)
    throw ImageFileError(name + ": " + (WIFSIGNALED(status) || (WIFEXITED(status) && WEXITSTATUS(status) != 0)
                                            ? describeStatus(status)
                                            : "the image reader's answer was cut short"));
  if (header.status == 1)
    throw ImageFileError(name + ": " + message);
  checkTexels(image, name);
  return image;
}

TexelImage readTextureImage(const std::string& path, ImageEncoding encoding)
{
  const std::string extension = lowerExtension(path);
  namespace fs = std::filesystem;
  std::error_code ec;
  if (fs::is_directory(path, ec))
    throw ImageFileError(path + ": is a folder, not an image file");
  if (extension == ".exr" || extension == ".pfm") {
    if (!fs::exists(path, ec))
      throw ImageFileError(path + ": cannot open the image file: " + std::strerror(ENOENT));
    TexelImage image;
    try {
      image = fromImage(extension == ".exr" ? readExr(path) : readPfm(path));
    } catch (const ImageIoError& e) {
      throw ImageFileError(e.what());
    }
    checkTexels(image, path);
    return image;
  }
  if (extension != ".png" && extension != ".jpg" && extension != ".jpeg" && extension != ".hdr")
    throw ImageFileError(path + ": unknown image format '" + (extension.empty() ? "(no extension)" : extension) +
                         "': raylife reads .png, .jpg, .jpeg, .hdr, .exr and .pfm");
  std::ifstream in(path, std::ios::binary);
  if (!in)
    throw ImageFileError(path + ": cannot open the image file: " + std::strerror(errno));
  std::vector<unsigned char> bytes;
  char buffer[1 << 16];
  while (in.read(buffer, sizeof buffer) || in.gcount() > 0) {
    bytes.insert(bytes.end(), buffer, buffer + in.gcount());
    if (bytes.size() > kMaxImageFileBytes)
      throw ImageFileError(path + ": the image file is larger than " + std::to_string(kMaxImageFileBytes >> 20) +
                           " MiB");
  }
  if (in.bad())
    throw ImageFileError(path + ": cannot read the image file: " + std::strerror(errno));
  // The signature must be the extension's: a .png that is a JPEG is a mistake worth naming.
  const std::string format = signatureOf(bytes);
  if (!bytes.empty() && format != (extension == ".jpeg" ? ".jpg" : extension))
    throw ImageFileError(path + ": not a " + extension.substr(1) + " file (its first bytes are not the format's "
                         "signature)");
  return decodeStbImage(bytes, encoding, path);
}

} // namespace raylife

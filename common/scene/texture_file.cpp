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

// The child's answer: a header, then width·height·3 values as stb_image decoded them (kFloats: floats, kCodes8:
// bytes, kCodes16: 16-bit codes), or (kMessage) `width` bytes of message. The codes are made floats in the parent:
// a quarter (or half) of the bytes through the pipe, and no second copy of the image in the child.
enum WireStatus : std::uint32_t { kFloats = 0, kMessage = 1, kCodes8 = 2, kCodes16 = 3 };
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

// stb_image's reason for its last failure, as one printable line for a message: never empty, every byte outside
// printable ASCII shown as '?'. (stb_image copies a PNG chunk's unknown type, four bytes of the file, into its
// reason; the zero bytes it reads past a file's end made that reason empty.)
std::string stbFailureReason()
{
  const char* raw = stbi_failure_reason();
  if (!raw)
    return "the file is malformed";
  std::string reason = raw;
  if (reason.empty()) // a PNG chunk type whose first byte is 0: what stb_image reads past the file's end
    return "it ends early (or holds a chunk whose type starts with a zero byte)";
  for (char& c : reason)
    if ((unsigned char)c < 0x20 || (unsigned char)c >= 0x7f)
      c = '?';
  return reason;
}

// The child's answer of texels: w·h·3 values of `valueBytes` each, then _exit.
[[noreturn]] void sendTexels(int fd, WireStatus status, int w, int h, const void* values, std::size_t valueBytes)
{
  const WireHeader header{status, std::uint32_t(w), std::uint32_t(h)};
  if (!writeAll(fd, &header, sizeof header) ||
      !writeAll(fd, values, std::size_t(w) * std::size_t(h) * 3 * valueBytes))
    _exit(5);
  _exit(0);
}

// The child: stb_image on the bytes, its texels to `fd` as it decoded them, then _exit (see mesh_file.cpp for why
// _exit).
[[noreturn]] void decodeInChild(int fd, std::span<const unsigned char> bytes) noexcept
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
    const WireHeader header{kMessage, std::uint32_t(message.size()), 0};
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
  // (The texels are allocated by stb_image as it decodes them, not before: a file it refuses costs no more.)
  if (stbi_is_hdr_from_memory(data, length)) {
    if (radianceEndsEarly(bytes, w, h))
      fail("its texels end early: the file is truncated (a " + std::to_string(w) + "x" + std::to_string(h) +
           " Radiance image)");
    const float* f = stbi_loadf_from_memory(data, length, &w, &h, &n, 3);
    if (!f)
      fail(std::string("cannot decode it: ") + stbFailureReason());
    sendTexels(fd, kFloats, w, h, f, sizeof(float));
  } else if (stbi_is_16_bit_from_memory(data, length)) {
    const stbi_us* codes = stbi_load_16_from_memory(data, length, &w, &h, &n, 3);
    if (!codes)
      fail(std::string("cannot decode it: ") + stbFailureReason());
    sendTexels(fd, kCodes16, w, h, codes, sizeof(stbi_us));
  } else {
    const stbi_uc* codes = stbi_load_from_memory(data, length, &w, &h, &n, 3);
    if (!codes)
      fail(std::string("cannot decode it: ") + stbFailureReason());
    sendTexels(fd, kCodes8, w, h, codes, 1);
  }
}

// The parent's side of the codes: `count` of them from `fd` as linear floats, decoded as `encoding` says, a block at
// a time (no second copy of the image). @return false if the answer was cut short.
template <class Code>
bool readCodes(int fd, std::size_t count, ImageEncoding encoding, std::vector<float>& rgb)
{
  rgb.resize(count);
  std::vector<Code> codes(std::min<std::size_t>(count, 1 << 16));
  for (std::size_t at = 0; at < count; at += codes.size()) {
    const std::size_t n = std::min(codes.size(), count - at);
    if (!readAll(fd, codes.data(), n * sizeof(Code)))
      return false;
    float* out = rgb.data() + at;
    if constexpr (sizeof(Code) == 1) {
      // [srgbTable]
      // 8 bits: 256 possible values, decoded once into a table rather than by pow() for every texel.
      const std::array<float, 256>& decode = srgbDecodeTable();
      for (std::size_t i = 0; i < n; ++i)
        out[i] = encoding == ImageEncoding::Srgb ? decode[codes[i]] : float(codes[i]) / 255.0f;
      // [srgbTable]
    } else {
      for (std::size_t i = 0; i < n; ++i) {
        const float e = float(codes[i]) / 65535.0f;
        out[i] = encoding == ImageEncoding::Srgb ? srgbToLinear(e) : e;
      }
    }
  }
  return true;
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

// The format signatureOf names, as a reader knows it: "PNG", "JPEG" or "Radiance HDR".
std::string formatName(const std::string& format)
{
  return format == ".jpg" ? "JPEG" : format == ".hdr" ? "Radiance HDR" : "PNG";
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
      name + ": cannot start the image reader: ", [&](int writeEnd) { decodeInChild(writeEnd, bytes); },
      1 << 20);
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
  if (whole && header.status == kMessage) {
    message.resize(std::min<std::uint32_t>(header.width, 1024));
    whole = readAll(fd, message.data(), message.size());
  } else if (whole && (header.status == kFloats || header.status == kCodes8 || header.status == kCodes16) &&
             header.width > 0 && header.height > 0 && (long long)header.width * header.height <= kMaxTexels) {
    image.width = int(header.width);
    image.height = int(header.height);
    const std::size_t count = std::size_t(header.width) * header.height * 3;
    if (header.status == kFloats) {
      image.rgb.resize(count);
      whole = readAll(fd, image.rgb.data(), count * sizeof(float));
    } else {
      whole = header.status == kCodes8 ? readCodes<std::uint8_t>(fd, count, encoding, image.rgb)
                                       : readCodes<std::uint16_t>(fd, count, encoding, image.rgb);
    }
  } else {
    whole = false;
  }
  ::close(fd);
  const int status = reap(!whole);
  if (!whole || !WIFEXITED(status) || WEXITSTATUS(status) != 0)
    throw ImageFileError(name + ": " + (WIFSIGNALED(status) || (WIFEXITED(status) && WEXITSTATUS(status) != 0)
                                            ? describeStatus(status)
                                            : "the image reader's answer was cut short"));
  if (header.status == kMessage)
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
  return readStbImageFile(path, extension == ".jpeg" ? ".jpg" : extension, encoding);
}

TexelImage readStbImageFile(const std::string& path, const std::string& format, ImageEncoding encoding)
{
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec))
    throw ImageFileError(path + ": is a folder, not an image file");
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
  // The signature must be the format's, whatever the name says: a .png that is a JPEG is a mistake worth naming,
  // and stb_image's decoders for formats raylife does not read (GIF, PSD, PNM, ...) are never reached.
  if (!bytes.empty() && signatureOf(bytes) != format)
    throw ImageFileError(path + ": not a " + formatName(format) +
                         " file (its first bytes are not the format's signature)");
  return decodeStbImage(bytes, encoding, path);
}

} // namespace raylife

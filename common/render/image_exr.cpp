// OpenEXR files (image_io.h): 32-bit float RGB, written into memory so that writeFilesAtomically can put them in
// place all or nothing, and read with any channel type OpenEXR converts to float.
#include "render/image_io.h"

#include "core/printable.h"

#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfIO.h>
#include <OpenEXR/ImfInputFile.h>
#include <OpenEXR/ImfOutputFile.h>
#include <OpenEXR/ImfPartType.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <memory>
#include <system_error>

namespace raylife {

namespace {

// An OpenEXR output stream into a byte vector. OpenEXR seeks back to fill in the table of line offsets.
class MemoryStream : public Imf::OStream {
public:
  MemoryStream() : Imf::OStream("memory") {}
  void write(const char c[], int n) override
  {
    const std::size_t end = std::size_t(position_) + std::size_t(n);
    if (bytes_.size() < end)
      bytes_.resize(end);
    std::memcpy(bytes_.data() + position_, c, std::size_t(n));
    position_ = end;
  }
  std::uint64_t tellp() override { return position_; }
  void seekp(std::uint64_t pos) override { position_ = pos; }
  std::vector<unsigned char> take() { return std::move(bytes_); }

private:
  std::vector<unsigned char> bytes_;
  std::uint64_t position_ = 0;
};

// A channel as the pixels' bytes count it: the bytes of a sample (2 for half, 4 for the others), and one sample every
// xSampling pixels across and every ySampling down.
struct ExrChannel {
  int bytes = 4;
  long xSampling = 1, ySampling = 1;
};

// The bytes of a pixel of all `channels`, as if each had a sample at every pixel.
double bytesPerPixel(const std::vector<ExrChannel>& channels)
{
  double bytes = 0;
  for (const ExrChannel& channel : channels)
    bytes += channel.bytes;
  return bytes;
}

// A tiled part is read through buffers its header sizes: whole rows of tiles (OpenEXR's InputFile keeps the data
// window's width times a tile's height, for each channel read) and whole tiles of every channel. Refused where those
// are far beyond the image itself: the fuzzer found a 2.8 KB file of 16x8 pixels with tiles 33,554,436 pixels tall.
// (In double: a tile's two sides, each up to 2^32, times its bytes would overflow 64 bits.)
void checkTiles(const std::string& path, long width, long height, std::uint32_t tileWidth, std::uint32_t tileHeight,
                double bytesPerPixel)
{
  if (width <= 0 || height <= 0)
    return; // (an empty data window: checkDataWindow refuses it)
  const double pixelBytes = std::max(bytesPerPixel, double(3 * sizeof(float)));
  const double allowed = std::max(4 * double(width) * double(height) * pixelBytes, double(64 << 20));
  const double rowBytes = double(width) * double(tileHeight) * double(3 * sizeof(float));
  const double tileBytes = double(tileWidth) * double(tileHeight) * pixelBytes;
  if (rowBytes > allowed || tileBytes > allowed)
    throw ImageIoError(path + ": the EXR's tiles of " + std::to_string(tileWidth) + "x" + std::to_string(tileHeight) +
                       " pixels are far larger than its " + std::to_string(width) + "x" + std::to_string(height) +
                       " pixels");
}

// The most bytes of pixels one byte of an EXR of `compression` can decode to, or 0 where OpenEXR does not know it
// (its constructor refuses those). Each is the format's own limit, so no file that decodes can pass it:
//  - RLE: a run of 128 bytes is 2 bytes (64);
//  - ZIP and ZIPS: zlib's deflate, at most 258 bytes a 2-bit code (1,032);
//  - PXR24: zlib over floats cut to 3 bytes (1,032 × 4/3);
//  - PIZ: a Huffman code of at least 1 bit, then 8 bits, for a run of up to 256 16-bit values (453, taken as 512);
//  - B44 and B44A: 3 bytes for a flat 4x4 block of halves (32 bytes);
//  - DWAA and DWAB: run lengths then zlib in series (64 × 1,032), doubled, as their layout is intricate.
// Measured, files of zeros reach 63.7, 1,022, 1,358, 409, 10.7 and 37,145 (DWAB, floats) respectively.
double exrMaxExpansion(int compression)
{
  switch (Imf::Compression(compression)) {
  case Imf::NO_COMPRESSION: return 1;
  case Imf::RLE_COMPRESSION: return 64;
  case Imf::ZIPS_COMPRESSION:
  case Imf::ZIP_COMPRESSION: return 1032;
  case Imf::PXR24_COMPRESSION: return 1376;
  case Imf::PIZ_COMPRESSION: return 512;
  case Imf::B44_COMPRESSION:
  case Imf::B44A_COMPRESSION: return 11;
  case Imf::DWAA_COMPRESSION:
  case Imf::DWAB_COMPRESSION: return 2 * 64 * 1032;
  default: return 0;
  }
}

// Refuses a data window of width x height pixels of `channels` that could not come from a file of `fileBytes`, even
// at its compression's best (exrMaxExpansion): the float image fuzzer found (in CI) a 16x8 ZIP file of 1,688 bytes
// whose data window was made 7,995,408 pixels wide. OpenEXR 3.1 decoded its one chunk, 1,536 bytes, into a buffer
// sized for the window and read the rest of the image from memory nothing had written: 20 s, 2.2 GB and an image, in
// a release build. The pixels are counted as stored: each channel's samples times their bytes.
void checkPixelsFitFile(const std::string& path, long width, long height, const std::vector<ExrChannel>& channels,
                        int compression, std::uintmax_t fileBytes)
{
  double bytes = 0;
  for (const ExrChannel& channel : channels) {
    if (channel.xSampling < 1 || channel.ySampling < 1)
      return; // (OpenEXR refuses those)
    bytes += std::floor(double(width) / double(channel.xSampling)) *
             std::floor(double(height) / double(channel.ySampling)) * channel.bytes;
  }
  const double expansion = exrMaxExpansion(compression);
  if (expansion > 0 && bytes > expansion * double(fileBytes))
    throw ImageIoError(path + ": the EXR is damaged: its " + std::to_string(width) + "x" + std::to_string(height) +
                       " pixels are " + std::to_string(std::uintmax_t(bytes)) + " bytes, more than its " +
                       std::to_string(fileBytes) + " bytes could hold (" + std::to_string(long(expansion)) +
                       " to 1 at most, with its compression)");
}

// Refuses a part of deep pixels (each pixel holds as many samples, at their depths, as the file says): not an image
// raylife reads. OpenEXR's InputFile would composite them into a flat one, at a cost the file's size does not bound:
// a deep file of 804 bytes whose data window was made 33,554,432x8 pixels took 147 s and 18 GB to read in a release
// build. And OpenEXR 3.1's deep reader leaked memory on files the fuzzer made from that one within a second.
[[noreturn]] void refuseDeep(const std::string& path)
{
  throw ImageIoError(path + ": the EXR holds deep pixels (samples at many depths), which raylife does not read: save "
                            "it as a flat image");
}

// The sides of the data window of a header that gives none: OpenEXR reads a header into a default Imf::Header, whose
// windows are 64x64 pixels, and keeps them where the file has no window of its own.
constexpr long kExrDefaultWindow = 64;

// A data window of width x height pixels: refused where empty, or beyond the 2^28 pixels an image may have.
// (Divided, not multiplied: a product of two sides of up to 2^32 overflows.)
void checkDataWindow(const std::string& path, long width, long height)
{
  if (width <= 0 || height <= 0 || width > (1L << 28) / height)
    throw ImageIoError(path + ": bad EXR data window (" + std::to_string(width) + "x" + std::to_string(height) + ")");
}

// A little-endian 32-bit integer at `p`.
std::uint32_t littleEndian32(const unsigned char* p)
{
  return std::uint32_t(p[0]) | std::uint32_t(p[1]) << 8 | std::uint32_t(p[2]) << 16 | std::uint32_t(p[3]) << 24;
}

// The bytes OpenEXR 3.1 reads for an attribute of type `type` whose value is `value` (its declared size: the whole of
// `value`, or only its first bytes where they suffice), or −1 where `value` is too short to say. OpenEXR reads most
// types by their own layout, not by the size the header gives: a fixed number of bytes for numbers and vectors, a
// channel list up to its empty name. Strings, types it does not know and the ones not listed here it reads by the size.
// For a channel list, `channels` is set to its channels.
std::int64_t exrValueBytes(const std::string& type, const std::string& value, std::vector<ExrChannel>& channels)
{
  static const std::pair<const char*, int> fixed[] = {
      {"box2i", 16}, {"box2f", 16},  {"chromaticities", 32}, {"compression", 1}, {"deepImageState", 1},
      {"double", 8}, {"envmap", 1},  {"float", 4},           {"int", 4},         {"keycode", 28},
      {"lineOrder", 1}, {"m33f", 36}, {"m33d", 72},          {"m44f", 64},       {"m44d", 128},
      {"rational", 8}, {"tiledesc", 9}, {"timecode", 8},     {"v2i", 8},         {"v2f", 8},
      {"v2d", 16},   {"v3i", 12},    {"v3f", 12},            {"v3d", 24}};
  for (const auto& [name, bytes] : fixed)
    if (type == name)
      return bytes;
  const auto* v = reinterpret_cast<const unsigned char*>(value.data());
  if (type == "chlist") { // names of up to 255 characters, each with its 0 and 16 bytes more, then an empty name
    channels.clear();
    for (std::size_t i = 0; i < value.size();) {
      const std::size_t end = value.find('\0', i);
      if (end == std::string::npos || end - i > 255)
        return -1;
      if (end == i)
        return std::int64_t(end + 1);
      if (end + 17 <= value.size()) // the pixel type (1: half), pLinear and 3 reserved bytes, the two samplings
        channels.push_back({littleEndian32(v + end + 1) == 1 ? 2 : 4, long(std::int32_t(littleEndian32(v + end + 9))),
                            long(std::int32_t(littleEndian32(v + end + 13)))});
      i = end + 17;
    }
    return -1;
  }
  if (type == "stringvector") { // strings, each a 32-bit length and its characters, up to the size
    std::int64_t read = 0;
    while (read < std::int64_t(value.size())) {
      if (read + 4 > std::int64_t(value.size()))
        return -1;
      const std::int64_t length = std::int32_t(littleEndian32(v + read));
      if (length < 0)
        return -1;
      read += 4 + length;
    }
    return read;
  }
  if (type == "preview") { // width and height, then 4 bytes a pixel
    if (value.size() < 8)
      return -1;
    const double bytes = 8 + 4 * double(littleEndian32(v)) * double(littleEndian32(v + 4));
    return bytes > double(value.size()) ? -1 : std::int64_t(bytes);
  }
  if (type == "floatvector")
    return std::int64_t(value.size() / 4 * 4);
  return std::int64_t(value.size());
}

// Checks an EXR's headers before OpenEXR opens it, for what OpenEXR would allocate before it found the file wrong:
//  - an attribute that claims more bytes than are left in the file. OpenEXR sizes a string's value as the file says
//    before it reads it: the float image fuzzer found a file of 672 bytes whose "type" string claimed 2,003,042,314,
//    which cost 2 GB and 12 s before OpenEXR found it too short;
//  - an attribute whose value is not the size its header gives (exrValueBytes): OpenEXR reads it by its layout, so
//    the next attribute would begin elsewhere for OpenEXR than for this check, which would miss a lie there. (The
//    fuzzer found one: a channel list one byte longer than its size, then a string that claimed 2 GB.) No writer
//    makes such a file;
//  - tiles far larger than the image (checkTiles), and a data window beyond 2^28 pixels (checkDataWindow).
//    InputFile's constructor allocates buffers for them: untouched, so only address space, but AddressSanitizer
//    spent 7 s of a fuzzer's run freeing a row of such tiles, and went past the fuzzer's 10 s limit freeing the line
//    buffers of a data window 5,308,423 pixels wide;
//  - pixels more than the file could hold at its compression's best (checkPixelsFitFile). InputFile's constructor
//    sizes its line buffers by the window: for the fuzzer's 1.7 KB file that claimed 7,995,408 x 8 pixels, 4.6 GB,
//    which cost AddressSanitizer 6.7 s to allocate and free;
//  - a part of deep pixels (refuseDeep), before OpenEXR's deep reader sees it.
// A header is attributes (a name and a type name, each ending in a 0, then the value's size, a 32-bit little-endian
// integer, and the value) ended by a 0; a multi-part file has one header a part, and an empty one after the last.
// Anything else that is wrong is left to OpenEXR to say.
void checkExrHeaders(const std::string& path)
{
  std::ifstream in(path, std::ios::binary);
  std::error_code error;
  const std::uintmax_t fileSize = std::filesystem::file_size(path, error);
  if (!in || error)
    return; // (OpenEXR says why it cannot open it)
  char start[8];
  if (!in.read(start, sizeof start) || std::memcmp(start, "\x76\x2f\x31\x01", 4) != 0)
    return;
  const bool multiPart = (static_cast<unsigned char>(start[5]) & 0x10) != 0; // version flag 0x1000
  // One name: at most 255 characters and its 0 (31 in files without long names); false where it does not end.
  auto readName = [&in](std::string& name) {
    name.clear();
    for (char c; in.get(c);) {
      if (c == 0)
        return true;
      if (name.size() == 255)
        return false;
      name += c;
    }
    return false;
  };
  // What the header so far says of its data window, its tiles, its channels, its compression (OpenEXR's default is
  // ZIP) and whether its pixels are deep (samples a pixel that the file sets).
  long width = 0, height = 0;
  bool window = false;
  std::uint32_t tileWidth = 0, tileHeight = 0;
  std::vector<ExrChannel> channels;
  int compression = Imf::ZIP_COMPRESSION;
  bool deep = (static_cast<unsigned char>(start[5]) & 0x08) != 0; // version flag 0x800, single-part deep data
  for (std::string name, type, value;;) {
    if (!readName(name))
      return;
    if (name.empty()) { // the end of a header; a multi-part file's headers end with an empty one
      if (window)
        checkDataWindow(path, width, height);
      else
        width = height = kExrDefaultWindow;
      if (tileWidth > 0 || tileHeight > 0)
        checkTiles(path, width, height, tileWidth, tileHeight, bytesPerPixel(channels));
      if (deep)
        refuseDeep(path);
      checkPixelsFitFile(path, width, height, channels, compression, fileSize);
      if (!multiPart || in.peek() == 0)
        return;
      width = height = 0, window = false, tileWidth = tileHeight = 0, channels.clear();
      compression = Imf::ZIP_COMPRESSION, deep = false;
      continue;
    }
    unsigned char size[4];
    if (!readName(type) || !in.read(reinterpret_cast<char*>(size), sizeof size))
      return;
    const std::int64_t bytes = std::int32_t(littleEndian32(size));
    const std::int64_t left = std::int64_t(fileSize) - std::int64_t(in.tellg());
    // (Each name cut short first: a name of 255 control characters would print as 1,530.)
    const std::string what = path + ": the EXR's header attribute '" + printable(shorten(name)) + "' (" +
                             printable(shorten(type)) + ")";
    if (bytes < 0 || bytes > left)
      throw ImageIoError(what + " claims " + std::to_string(bytes) + " bytes, and the file has " +
                         std::to_string(left) + " left");
    // The value itself where its layout matters (a string's characters are only skipped, but for the part's type).
    if (type == "string" && name != "type") {
      in.seekg(bytes, std::ios::cur);
      continue;
    }
    value.resize(std::size_t(bytes));
    if (!in.read(value.data(), bytes))
      return;
    std::vector<ExrChannel> listed;
    const std::int64_t takes = exrValueBytes(type, value, listed);
    if (takes != bytes)
      throw ImageIoError(what + " says its value is " + std::to_string(bytes) + " bytes, but " +
                         (takes < 0 ? std::string("its layout does not fit in them")
                                    : "its layout takes " + std::to_string(takes)));
    const auto* v = reinterpret_cast<const unsigned char*>(value.data());
    if (name == "dataWindow" && type == "box2i") { // xMin, yMin, xMax, yMax
      const auto at = [v](int i) { return long(std::int32_t(littleEndian32(v + 4 * i))); };
      width = at(2) - at(0) + 1, height = at(3) - at(1) + 1, window = true;
    } else if (name == "tiles" && type == "tiledesc") { // width, height, mode
      tileWidth = littleEndian32(v), tileHeight = littleEndian32(v + 4);
    } else if (name == "channels" && type == "chlist") {
      channels = std::move(listed);
    } else if (name == "compression" && type == "compression") {
      compression = v[0];
    } else if (name == "type" && type == "string") {
      deep = Imf::isDeepData(value);
    }
  }
}

} // namespace

std::vector<unsigned char> encodeExr(const Image& image)
{
  // A scan-line file of three FLOAT channels, ZIP-compressed (lossless), display window = data window.
  Imf::Header header(image.width, image.height);
  for (const char* name : {"R", "G", "B"})
    header.channels().insert(name, Imf::Channel(Imf::FLOAT));
  Imf::FrameBuffer frame;
  const std::size_t xStride = 3 * sizeof(float), yStride = xStride * std::size_t(image.width);
  char* base = reinterpret_cast<char*>(const_cast<float*>(image.pixels.data())); // OpenEXR only reads it here
  for (int c = 0; c < 3; ++c)
    frame.insert(c == 0 ? "R" : c == 1 ? "G" : "B",
                 Imf::Slice(Imf::FLOAT, base + std::size_t(c) * sizeof(float), xStride, yStride));
  MemoryStream stream;
  try {
    Imf::OutputFile file(stream, header);
    file.setFrameBuffer(frame);
    file.writePixels(image.height);
  } catch (const std::exception& e) {
    throw ImageIoError("cannot encode an EXR of " + std::to_string(image.width) + "x" + std::to_string(image.height) +
                       ": " + e.what());
  }
  return stream.take();
}

Image readExr(const std::string& path)
{
  try {
    checkExrHeaders(path);
    Imf::InputFile file(path.c_str());
    const Imath::Box2i window = file.header().dataWindow();
    const long width = long(window.max.x) - window.min.x + 1, height = long(window.max.y) - window.min.y + 1;
    checkDataWindow(path, width, height);
    // The tiles and the pixels' bytes again, as OpenEXR took them (checkExrHeaders checks what it finds in the
    // bytes), before setFrameBuffer allocates a row of tiles and readPixels reads any.
    std::vector<ExrChannel> stored;
    for (auto c = file.header().channels().begin(); c != file.header().channels().end(); ++c)
      stored.push_back({c.channel().type == Imf::HALF ? 2 : 4, c.channel().xSampling, c.channel().ySampling});
    if (file.header().hasTileDescription()) {
      const Imf::TileDescription& tiles = file.header().tileDescription();
      checkTiles(path, width, height, tiles.xSize, tiles.ySize, bytesPerPixel(stored));
    }
    if (file.header().hasType() && Imf::isDeepData(file.header().type()))
      refuseDeep(path);
    checkPixelsFitFile(path, width, height, stored, file.header().compression(), std::filesystem::file_size(path));
    // Before the pixels are allocated: a header that claims 16384x16384 pixels over a table of chunks that are not
    // there cost 3 GiB and 15 s before readPixels found them missing.
    if (!file.isComplete())
      throw ImageIoError(path + ": the EXR is incomplete: some of its " + std::to_string(width) + "x" +
                         std::to_string(height) + " pixels are missing from the file (cut short?)");
    const Imf::ChannelList& channels = file.header().channels();
    const bool rgb = channels.findChannel("R") || channels.findChannel("G") || channels.findChannel("B");
    const bool grey = !rgb && channels.findChannel("Y");
    if (!rgb && !grey)
      throw ImageIoError(path + ": the EXR has no R, G, B or Y channel");
    // The pixels are read in strips of rows, each appended to the image as it comes, so that the memory touched is
    // what the file has given: an 8.5 KB file whose header claims 16384x16384 pixels over 1,024 chunk offsets all
    // pointing to its one chunk passed isComplete(), and the image, zeroed before the read, took 3 GB and 12 s
    // before the second chunk was found wrong. reserve() takes the address space without touching it, and the
    // strip is not zeroed either (a strip that fails is never read). 256 rows: whole chunks of every compression.
    Image image;
    image.width = int(width);
    image.height = int(height);
    image.pixels.reserve(std::size_t(width) * std::size_t(height) * 3);
    const long stripRows = std::min(height, 256L);
    const std::size_t rowFloats = std::size_t(width) * 3;
    const auto strip = std::make_unique_for_overwrite<float[]>(std::size_t(stripRows) * rowFloats);
    // OpenEXR addresses pixel (x, y) of the data window at base + x·xStride + y·yStride.
    const std::size_t xStride = 3 * sizeof(float), yStride = xStride * std::size_t(width);
    for (long y0 = 0; y0 < height; y0 += stripRows) {
      const long rows = std::min(stripRows, height - y0);
      char* base = reinterpret_cast<char*>(strip.get()) - std::ptrdiff_t(window.min.x) * std::ptrdiff_t(xStride) -
                   std::ptrdiff_t(window.min.y + y0) * std::ptrdiff_t(yStride);
      Imf::FrameBuffer frame;
      for (int c = 0; c < (grey ? 1 : 3); ++c) // a missing channel reads as 0
        frame.insert(grey ? "Y" : c == 0 ? "R" : c == 1 ? "G" : "B",
                     Imf::Slice(Imf::FLOAT, base + std::size_t(c) * sizeof(float), xStride, yStride, 1, 1, 0.0));
      file.setFrameBuffer(frame);
      file.readPixels(int(window.min.y + y0), int(window.min.y + y0 + rows - 1));
      image.pixels.insert(image.pixels.end(), strip.get(), strip.get() + std::size_t(rows) * rowFloats);
    }
    if (grey)
      for (std::size_t i = 0; i < image.pixels.size(); i += 3)
        image.pixels[i + 1] = image.pixels[i + 2] = image.pixels[i];
    return image;
  } catch (const ImageIoError&) {
    throw;
  } catch (const std::exception& e) {
    throw ImageIoError(path + ": cannot read the EXR: " + printable(shorten(e.what(), 600)));
  }
}

} // namespace raylife

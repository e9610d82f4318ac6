#include "render/film.h"
#include "render/image_compare.h"
#include "render/image_io.h"

#include <catch2/catch.hpp>

#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfOutputFile.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

using namespace raylife;

namespace {
std::string tempPath(const std::string& name)
{
  return (std::filesystem::temp_directory_path() / ("raylife_unit_" + name)).string();
}
} // namespace

TEST_CASE("PFM round trip keeps linear floats exactly - unclamped - with row 0 at the top")
{
  Image image(5, 3);
  for (std::size_t i = 0; i < image.pixels.size(); ++i)
    image.pixels[i] = float(i) * 0.37f - 2.0f; // negative and > 1 values survive
  image.at(0, 0, 0) = 1e30f;
  const std::string path = tempPath("roundtrip.pfm");
  writeImage(image, path);
  const Image back = readPfm(path);
  REQUIRE(back.width == 5);
  REQUIRE(back.height == 3);
  CHECK(back.pixels == image.pixels);
  std::remove(path.c_str());
}

TEST_CASE("the PFM file stores the bottom row first - little-endian - as the format says")
{
  Image image(1, 2);
  image.at(0, 0, 0) = 1.0f; // top
  image.at(0, 1, 0) = 2.0f; // bottom
  const std::vector<unsigned char> bytes = encodePfm(image);
  const std::string header = "PF\n1 2\n-1.0\n";
  REQUIRE(bytes.size() == header.size() + 2 * 3 * 4);
  float first;
  std::memcpy(&first, bytes.data() + header.size(), 4);
  CHECK(first == 2.0f);
}

TEST_CASE("a PFM header with sides whose product overflows, or with junk in a number, is refused")
{
  // The float image fuzzer's find: "Pf", then 4 and 4444444444444444444 (with junk after the 4). The check of
  // width·height overflowed a long (undefined; here it wrapped negative and passed), and raylife_image then ended in
  // an uncaught std::length_error making the image. The 4 had been read from "4\xce2".
  const std::string path = tempPath("sides.pfm");
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"PF\n4 4444444444444444444\n-1\n", "bad PFM header (size 4x4444444444444444444)"},
      {"PF\n4444444444444444444 4\n-1\n", "bad PFM header (size 4444444444444444444x4)"},
      {"Pf\n4\xce" "2 2\n-1\n", "malformed PFM header"},
      {"PF\n2 2\n-1x\n", "malformed PFM header"},
  };
  for (const auto& [header, fault] : cases) {
    CAPTURE(header);
    std::ofstream(path, std::ios::binary | std::ios::trunc) << header << std::string(4096, '\0');
    CHECK_THROWS_WITH(readPfm(path), Catch::Contains(fault));
  }
  std::remove(path.c_str());
}

TEST_CASE("PNG is clamped and sRGB-encoded and decodes back to linear within 8-bit steps")
{
  CHECK(linearToSrgb(0.0f) == 0.0f);
  CHECK(linearToSrgb(1.0f) == Approx(1.0f));
  CHECK(linearToSrgb(0.5f) == Approx(0.7353569f).epsilon(1e-5)); // sRGB of 0.5
  CHECK(linearToSrgb(7.0f) == Approx(1.0f));                     // clamped
  CHECK(linearToSrgb(-1.0f) == 0.0f);
  for (float v : {0.001f, 0.01f, 0.2f, 0.5f, 0.9f})
    CHECK(srgbToLinear(linearToSrgb(v)) == Approx(v).epsilon(1e-4));

  Image image(4, 2);
  image.at(0, 0, 0) = 0.5f;
  image.at(1, 0, 1) = 3.0f;
  image.at(2, 1, 2) = -1.0f;
  const std::string path = tempPath("image.png");
  writeImage(image, path);
  const Image back = readPng(path);
  CHECK(back.at(0, 0, 0) == Approx(0.5f).epsilon(0.01)); // 8-bit quantisation of the encoded value
  CHECK(back.at(1, 0, 1) == 1.0f);
  CHECK(back.at(2, 1, 2) == 0.0f);
  std::remove(path.c_str());
}

TEST_CASE("a PNG that ends after its header, or holds an unknown chunk, is refused with a printable reason")
{
  // The signature and a 16 x 16 RGB header (stb_image does not check the CRC), then nothing, or a critical chunk of
  // an unknown type whose first byte is a control character.
  const std::string header = std::string("\x89PNG\r\n\x1a\n\0\0\0\x0dIHDR\0\0\0\x10\0\0\0\x10", 24) +
                             std::string("\x08\x02\0\0\0\0\0\0\0", 9);
  const std::string unknown = header + std::string("\0\0\0\0\x01" "BCD\0\0\0\0", 12);
  for (const auto& [bytes, reason] :
       {std::pair{header, "it ends early (or holds a chunk whose type starts with a zero byte)"},
        std::pair{unknown, "?BCD PNG chunk not known"}}) {
    const std::string path = tempPath("short.png");
    std::ofstream(path, std::ios::binary) << bytes;
    try {
      readPng(path);
      FAIL("no error");
    } catch (const ImageIoError& e) {
      // (Before: "cannot read the PNG: " and nothing after it, or the control character itself.)
      CHECK(std::string(e.what()) == path + ": cannot decode it: " + reason);
    }
    std::remove(path.c_str());
  }
}

namespace {
// A PNG of one pixel, 16-bit RGB, its IDAT one stored (uncompressed) deflate block, every CRC and the Adler-32 right.
std::string png16(std::uint16_t r, std::uint16_t g, std::uint16_t b)
{
  auto be32 = [](std::uint32_t v) {
    return std::string{char(v >> 24), char((v >> 16) & 0xff), char((v >> 8) & 0xff), char(v & 0xff)};
  };
  auto crc = [](const std::string& bytes) {
    std::uint32_t c = 0xffffffffu;
    for (const unsigned char byte : bytes) {
      c ^= byte;
      for (int k = 0; k < 8; ++k)
        c = (c >> 1) ^ (0xedb88320u & (0u - (c & 1u)));
    }
    return ~c;
  };
  auto chunk = [&](const std::string& type, const std::string& data) {
    return be32(std::uint32_t(data.size())) + type + data + be32(crc(type + data));
  };
  std::string row(1, '\0'); // filter type 0, then the three samples, big-endian
  for (const std::uint16_t v : {r, g, b})
    row += std::string{char(v >> 8), char(v & 0xff)};
  std::uint32_t a = 1, s = 0;
  for (const unsigned char byte : row) {
    a = (a + byte) % 65521;
    s = (s + a) % 65521;
  }
  const std::string stored = std::string{'\x01', char(row.size()), '\0', char(~row.size() & 0xff), '\xff'};
  const std::string ihdr = be32(1) + be32(1) + std::string("\x10\x02\0\0\0", 5);
  return std::string("\x89PNG\r\n\x1a\n", 8) + chunk("IHDR", ihdr) +
         chunk("IDAT", std::string("\x78\x01", 2) + stored + row + be32((s << 16) | a)) + chunk("IEND", "");
}
} // namespace

TEST_CASE("readPng reads PNG files only, whatever their names, and 16-bit ones at 16 bits")
{
  const std::string path = tempPath("not_a_png.png");
  // stb_image would decode any of these as the format it is (it did, as a PNG: a PNM file compared and converted
  // as one); raylife's tools read PNG, and stb_image's other decoders are never reached.
  for (const std::string& bytes : {std::string("P6\n2 2\n255\n") + std::string(12, '\x80'),
                                   std::string("\xff\xd8\xff\xe0\0\x10JFIF", 10), std::string("GIF89a"),
                                   std::string("BM") + std::string(60, '\0')}) {
    CAPTURE(bytes.substr(0, 4));
    std::ofstream(path, std::ios::binary) << bytes;
    try {
      readPng(path);
      FAIL("no error");
    } catch (const ImageIoError& e) {
      CHECK(std::string(e.what()) == path + ": not a PNG file (its first bytes are not the format's signature)");
    }
  }
  // A header of 33 bytes that claims 16384 x 16384 texels: refused from the header (texture_file.h).
  std::ofstream(path, std::ios::binary) << std::string("\x89PNG\r\n\x1a\n\0\0\0\x0dIHDR\0\0\x40\0\0\0\x40\0", 24) +
                                               std::string("\x08\x02\0\0\0\0\0\0\0", 9);
  CHECK_THROWS_WITH(readPng(path), Catch::Contains("more than a file of 33 bytes can hold"));
  CHECK_THROWS_WITH(readPng(tempPath("no_such_file.png")), Catch::Contains("cannot open the image file"));
  // 16 bits a sample, kept: 32768 is not 128 (what stb_image's 8-bit decode made of it), and 257 is not 1.
  std::ofstream(path, std::ios::binary) << png16(65535, 32768, 257);
  const Image image = readPng(path);
  REQUIRE(image.width == 1);
  REQUIRE(image.height == 1);
  CHECK(image.at(0, 0, 0) == 1.0f);
  CHECK(image.at(0, 0, 1) == srgbToLinear(32768 / 65535.0f));
  CHECK(image.at(0, 0, 2) == srgbToLinear(257 / 65535.0f));
  std::remove(path.c_str());
}

namespace {
// The float image fuzzer's regression `name` without its first byte (with which the fuzzer chose the format), after
// checking that the file holds `size` bytes in all: the EXR itself.
std::string regressionExr(const std::string& name, std::size_t size)
{
  std::ifstream in(std::string(RAYLIFE_FUZZ_FLOAT_IMAGE_REGRESSIONS) + "/" + name, std::ios::binary);
  std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  REQUIRE(bytes.size() == size);
  return bytes.substr(1);
}

// Reads the EXR at `path`, checks that it is width x height pixels of zeros, and removes it.
void readsAsZeros(const std::string& path, int width, int height)
{
  Image image;
  REQUIRE_NOTHROW(image = readExr(path));
  CHECK(image.width == width);
  CHECK(image.height == height);
  CHECK(std::all_of(image.pixels.begin(), image.pixels.end(), [](float v) { return v == 0; }));
  std::remove(path.c_str());
}

// Writes `bytes` to the temporary file `name` and returns its path.
std::string writeTemp(const std::string& name, const std::string& bytes)
{
  const std::string path = tempPath(name);
  std::ofstream(path, std::ios::binary | std::ios::trunc).write(bytes.data(), std::streamsize(bytes.size()));
  return path;
}

// Writes the EXR `bytes` (a header with a lineOrder attribute) to the temporary file `name` and checks that readExr
// refuses it with `reason` after its path; then again with a line order OpenEXR does not know. OpenEXR's constructor
// would refuse that file with its own reason, so only a check made before OpenEXR reads the file gives `reason`.
void refusedBeforeOpenExr(const std::string& name, std::string bytes, const std::string& reason)
{
  const std::string path = writeTemp(name, bytes);
  CHECK_THROWS_WITH(readExr(path), Catch::Contains(path + reason));
  const std::string key("lineOrder\0lineOrder\0\x01\0\0\0", 24);
  const std::size_t at = bytes.find(key);
  REQUIRE(at != std::string::npos);
  bytes[at + key.size()] = char(0xee);
  writeTemp(name, bytes);
  CHECK_THROWS_WITH(readExr(path), Catch::Contains(path + reason));
  std::remove(path.c_str());
}
} // namespace

TEST_CASE("an EXR of more rows than a strip reads back exactly")
{
  // readExr reads 256 rows at a time (a strip) and appends each to the image: 600 rows are two whole strips and a
  // part of one, each pixel with a value of its own.
  Image image(5, 600);
  for (int y = 0; y < image.height; ++y)
    for (int x = 0; x < image.width; ++x)
      for (int c = 0; c < 3; ++c)
        image.at(x, y, c) = float(y * 16 + x * 3 + c) + 0.25f;
  const std::vector<unsigned char> bytes = encodeExr(image);
  const std::string path = writeTemp("strips.exr", std::string(bytes.begin(), bytes.end()));
  const Image back = readExr(path);
  REQUIRE(back.width == 5);
  REQUIRE(back.height == 600);
  CHECK(back.pixels == image.pixels);
  std::remove(path.c_str());
}

TEST_CASE("an EXR whose tiles dwarf its pixels is refused before its buffers are allocated")
{
  // The float image fuzzer's find (its first byte chose the format): 2,829 bytes of a 16x8 image whose tiles are 4
  // pixels wide and 33,554,436 tall. OpenEXR allocated a row of such tiles, 2 GB, before it found the pixel data
  // damaged; the fuzzer's replay cannot see that (the memory is never touched), so this test asks for the reason.
  const std::string path = writeTemp("tiles.exr", regressionExr("exr_tiles_far_taller_than_the_image.exr.bin", 2830));
  CHECK_THROWS_WITH(readExr(path), Catch::Contains("tiles of 4x33554436 pixels are far larger than its 16x8 pixels"));
  std::remove(path.c_str());
}

TEST_CASE("an EXR without a data window has OpenEXR's 64x64 pixels, and tiles far larger than those are refused")
{
  // The float image fuzzer's find: 549 bytes of a tiled file that gives no data window (OpenEXR then keeps its
  // default, 64x64 pixels) and tiles 4 pixels wide and 33,554,436 tall. The check before OpenEXR took the missing
  // window for one OpenEXR would refuse and let the tiles by; setFrameBuffer then allocated a row of them for a
  // channel, 8.6 GB (untouched address space in a release build, past the fuzzer's memory limit under
  // AddressSanitizer).
  std::string bytes = regressionExr("exr_no_data_window_tiles_far_taller.exr.bin", 550);
  const std::string path = writeTemp("no_window.exr", bytes);
  const std::string reason = "tiles of 4x33554436 pixels are far larger than its 64x64 pixels";
  CHECK_THROWS_WITH(readExr(path), Catch::Contains(path + ": the EXR's " + reason));
  // With a compression OpenEXR does not know added to the header, its constructor refuses the file with its own
  // reason: only the check before OpenEXR gives this one.
  const std::string last("wrapmodes\0string\0\x0b\0\0\0clamp,clamp", 32);
  const std::size_t at = bytes.find(last);
  REQUIRE(at != std::string::npos);
  bytes.insert(at + last.size(), std::string("compression\0compression\0\x01\0\0\0\xee", 29));
  writeTemp("no_window.exr", bytes);
  CHECK_THROWS_WITH(readExr(path), Catch::Contains(path + ": the EXR's " + reason));
  std::remove(path.c_str());
}

TEST_CASE("an EXR whose data window is beyond 2^28 pixels is refused before OpenEXR allocates its line buffers")
{
  // The float image fuzzer's find: 812 bytes of a ZIP-compressed scan-line file whose data window is 5,308,423 x
  // 1,025 pixels. InputFile's constructor allocated line buffers for rows that wide before readExr refused the window
  // (untouched address space; under AddressSanitizer, freeing them took the fuzzer past its 10 s limit). With its
  // compression made unknown, OpenEXR's constructor refuses the file with its own reason, so only a check that runs
  // before OpenEXR can give this one.
  std::string bytes = regressionExr("exr_data_window_5_million_pixels_wide.exr.bin", 813);
  const std::string path = writeTemp("window.exr", bytes);
  CHECK_THROWS_WITH(readExr(path), Catch::Contains(path + ": bad EXR data window (5308423x1025)"));
  const std::string key("compression\0compression\0\x01\0\0\0", 28);
  const std::size_t at = bytes.find(key);
  REQUIRE(at != std::string::npos);
  bytes[at + key.size()] = char(0xee);
  writeTemp("window.exr", bytes);
  CHECK_THROWS_WITH(readExr(path), Catch::Contains(path + ": bad EXR data window (5308423x1025)"));
  std::remove(path.c_str());
}

TEST_CASE("an EXR whose pixels are more bytes than the file could hold is refused before OpenEXR reads it")
{
  // The float image fuzzer's find (in CI): a 16x8 ZIP file of 1,688 bytes, one byte of its data window changed, so
  // that it claims 7,995,408x8 pixels of three floats. OpenEXR decoded the short chunk and read the rest of the
  // image from memory it had not written: 20 s, 2.2 GB and an image, in a release build. zlib gives at most 1,032
  // bytes a byte.
  // The check runs before OpenEXR's constructor, which would take 4.6 GB of line buffers for this window.
  refusedBeforeOpenExr("wide.exr", regressionExr("exr_data_window_far_wider_than_its_bytes.exr.bin", 1689),
                       ": the EXR is damaged: its 7995408x8 pixels are 767559168 bytes, more than its 1688 bytes "
                       "could hold (1032 to 1 at most, with its compression)");
}

TEST_CASE("EXRs of zeros, each compression at its best, read back: the bytes-a-byte limits refuse no real file")
{
  // A wide strip of zeros compresses about as far as each compression goes: in floats here, ZIP 976 to 1 against the
  // 1,032 allowed, PXR24 1,279 against 1,376, RLE 63 against 64, PIZ 403 against 512, DWAB 18,358 against 132,096.
  // A subsampled chroma channel (a sample every 2x2 pixels) counts a quarter.
  const int width = 4096, height = 256;
  for (const Imf::PixelType type : {Imf::HALF, Imf::FLOAT})
    for (int compression = 0; compression < Imf::NUM_COMPRESSION_METHODS; ++compression) {
      Imf::Header header(width, height);
      header.compression() = Imf::Compression(compression);
      for (const char* name : {"R", "G", "B", "A"})
        header.channels().insert(name, Imf::Channel(type));
      header.channels().insert("BY", Imf::Channel(type, 2, 2));
      const std::size_t bytes = type == Imf::HALF ? 2 : 4;
      std::vector<char> zeros(std::size_t(width) * height * bytes, 0);
      Imf::FrameBuffer frame;
      for (const char* name : {"R", "G", "B", "A"})
        frame.insert(name, Imf::Slice(type, zeros.data(), bytes, bytes * width));
      frame.insert("BY", Imf::Slice(type, zeros.data(), bytes, bytes * width, 2, 2));
      const std::string path = tempPath("zeros.exr");
      {
        Imf::OutputFile file(path.c_str(), header);
        file.setFrameBuffer(frame);
        file.writePixels(height);
      }
      INFO("compression " << compression << ", " << (type == Imf::HALF ? "half" : "float") << ": "
                          << double(width) * height * double(bytes) * 4.25 / double(std::filesystem::file_size(path))
                          << " bytes a byte");
      readsAsZeros(path, width, height);
    }
}

TEST_CASE("a deep EXR is refused in one line before OpenEXR reads it, whatever its size")
{
  // A deep scan-line file of 16x8 pixels of no samples (five float channels, ZIPS, 804 bytes; in the fuzzer's seeds)
  // and the same with its data window made 33,554,432 pixels wide: read, that took 147 s and 18 GB (OpenEXR
  // composites deep pixels into flat ones), and the fuzzer found OpenEXR 3.1's deep reader leaking within a second.
  const std::string reason = ": the EXR holds deep pixels (samples at many depths), which raylife does not read";
  refusedBeforeOpenExr("deep.exr", regressionExr("deep_scanline.exr.bin", 805), reason);
  refusedBeforeOpenExr("deep.exr", regressionExr("exr_deep_data_window_far_wider_than_its_bytes.exr.bin", 805),
                       reason);
}

TEST_CASE("an EXR whose header attribute claims more bytes than the file holds is refused before OpenEXR reads it")
{
  // The float image fuzzer's find: 672 bytes (after the byte that chose the format) whose "type" string attribute
  // claims 2,003,042,314 bytes. OpenEXR sized the string to that, 2 GB and 12 s of zeroes, before it found the file
  // too short; the fuzzer saw only the time. So this test asks for the reason, which only the check gives.
  const std::string path =
      writeTemp("attribute.exr", regressionExr("exr_string_attribute_claiming_2_gb.exr.bin", 673));
  CHECK_THROWS_WITH(readExr(path), Catch::Contains(path + ": the EXR's header attribute 'type' (string) claims "
                                                          "2003042314 bytes, and the file has 293 left"));
  std::remove(path.c_str());
}

TEST_CASE("an EXR attribute whose value is not the size its header gives is refused")
{
  // The float image fuzzer's next find: a channel list of 55 bytes (three channels and the empty name) whose header
  // says 54. OpenEXR reads a channel list to its empty name, so its next attribute began a byte later than the size
  // said: a string there claimed 2 GB. The check walks the header by the sizes, so it must refuse what OpenEXR
  // would read otherwise.
  const std::string path =
      writeTemp("channels.exr", regressionExr("exr_channel_list_longer_than_its_size.exr.bin", 658));
  CHECK_THROWS_WITH(readExr(path), Catch::Contains(": the EXR's header attribute 'channels' (chlist) says its value "
                                                   "is 54 bytes, but its layout does not fit in them"));
  // And a number with a size other than its type's: an int of 4 bytes said to be 5 (the next byte is the next
  // attribute's name for OpenEXR, which reads an int as 4).
  std::string bytes = regressionExr("multi_part_two_headers.exr.bin", 1403);
  const std::string key("chunkCount\0int\0\x04\0\0\0", 19);
  const std::size_t at = bytes.find(key);
  REQUIRE(at != std::string::npos);
  bytes[at + 15] = 5;
  writeTemp("channels.exr", bytes);
  CHECK_THROWS_WITH(readExr(path), Catch::Contains("'chunkCount' (int) says its value is 5 bytes, but its layout "
                                                   "takes 4"));
  std::remove(path.c_str());
}

TEST_CASE("an EXR with an attribute of every common type passes the attribute check")
{
  // Made with OpenEXR: 7x5 half RGBA of 0.5, with a preview image, a multiView string vector, chromaticities, a key
  // code, a time code, strings, an envmap, a rational, a 4x4 matrix, a double, a V3f and a float vector: each value
  // is the size its header gives, and the check must take each as OpenEXR does.
  const std::string path = writeTemp("attributes.exr", regressionExr("many_attribute_types.exr.bin", 1008));
  const Image image = readExr(path);
  CHECK(image.width == 7);
  CHECK(image.height == 5);
  CHECK(image.at(6, 4, 2) == 0.5f);
  std::remove(path.c_str());
}

TEST_CASE("a multi-part EXR passes the attribute check, and a lie in its second header does not")
{
  // Two parts of 4x3 pixels, R = 0.5, each header with a 300-byte "comment" string (made with OpenEXR's
  // MultiPartOutputFile). readExr reads the first part; the check walks every header up to the empty one.
  std::string bytes = regressionExr("multi_part_two_headers.exr.bin", 1403);
  const std::string path = writeTemp("parts.exr", bytes);
  const Image image = readExr(path);
  CHECK(image.width == 4);
  CHECK(image.height == 3);
  CHECK(image.at(3, 2, 0) == 0.5f);
  // The second header's comment made to claim 2^31 − 1 bytes.
  const std::string key("comment\0string\0", 15);
  const std::size_t second = bytes.find(key, bytes.find(key) + 1);
  REQUIRE(second != std::string::npos);
  bytes.replace(second + key.size(), 4, "\xff\xff\xff\x7f");
  writeTemp("parts.exr", bytes);
  CHECK_THROWS_WITH(readExr(path), Catch::Contains("header attribute 'comment' (string) claims 2147483647 bytes"));
  std::remove(path.c_str());
}

TEST_CASE("the film's mean and variance of the mean follow the textbook formulas")
{
  Film film(2, 1);
  for (double v : {1.0, 2.0, 3.0, 6.0})
    film.add(0, 0, Color(Real(v)));
  film.add(1, 0, Color(5));
  const Image mean = film.mean(), var = film.varianceOfMean();
  CHECK(mean.at(0, 0, 0) == Approx(3.0));
  CHECK(var.at(0, 0, 0) == Approx(14.0 / 3.0 / 4.0)); // s² = Σ(x − 3)²/(n − 1) = 14/3, over n = 4
  CHECK(mean.at(1, 0, 1) == Approx(5.0));
  CHECK(var.at(1, 0, 1) == 0.0f); // one sample: no variance estimate
  CHECK(film.samples(0, 0) == 4);
}

TEST_CASE("image metrics: identical - shifted and a NaN")
{
  Image a(10, 10), b(10, 10);
  for (float& p : a.pixels)
    p = 0.5f;
  b = a;
  const ImageDifference same = compareImages(a, b, 0);
  CHECK(same.maxAbs == 0);
  CHECK(same.overTolerance == 0);
  CHECK(std::isinf(same.psnr));
  b.at(3, 4, 1) = 0.6f;
  const ImageDifference one = compareImages(b, a, 0.05);
  CHECK(one.maxAbs == Approx(0.1));
  CHECK(one.worstX == 3);
  CHECK(one.worstY == 4);
  CHECK(one.overTolerance == Approx(0.01));
  CHECK(one.rmse == Approx(std::sqrt(0.01 / 300)));
  CHECK(one.relativeMse == Approx(0.01 / (0.25 + 0.01) / 300));
  b.at(0, 0, 0) = std::numeric_limits<float>::quiet_NaN();
  CHECK(std::isinf(compareImages(b, a, 0.05).maxAbs)); // a NaN never passes
}

TEST_CASE("tone curves: their values at a few points against their formulas (--tonemap, issue 43)")
{
  using raylife::ToneMap;
  using raylife::toneMap;
  // clamp: v in [0, 1], as encodePng has always clamped.
  CHECK(toneMap(0.25f, ToneMap::Clamp) == 0.25f);
  CHECK(toneMap(2.0f, ToneMap::Clamp) == 1.0f);
  CHECK(toneMap(-1.0f, ToneMap::Clamp) == 0.0f);
  // Reinhard: v / (1 + v).
  CHECK(toneMap(1.0f, ToneMap::Reinhard) == Approx(0.5));
  CHECK(toneMap(3.0f, ToneMap::Reinhard) == Approx(0.75));
  CHECK(toneMap(0.25f, ToneMap::Reinhard) == Approx(0.2));
  CHECK(toneMap(1e30f, ToneMap::Reinhard) == Approx(1.0));
  // ACES (Narkowicz's fit): v(2.51v + 0.03) / (v(2.43v + 0.59) + 0.14), clamped to [0, 1].
  auto aces = [](double v) { return std::min(1.0, v * (2.51 * v + 0.03) / (v * (2.43 * v + 0.59) + 0.14)); };
  CHECK(toneMap(0.0f, ToneMap::Aces) == 0.0f);
  for (float v : {0.01f, 0.18f, 0.5f, 1.0f, 4.0f})
    CHECK(toneMap(v, ToneMap::Aces) == Approx(aces(v)).epsilon(1e-5));
  CHECK(toneMap(1.0f, ToneMap::Aces) == Approx(2.54 / 3.16).epsilon(1e-5));
  CHECK(toneMap(1000.0f, ToneMap::Aces) == 1.0f); // the fit passes 1 at v = 7.24: clamped
  // Every curve keeps NaN and negatives out of the PNG, and rises.
  for (ToneMap m : {ToneMap::Clamp, ToneMap::Reinhard, ToneMap::Aces}) {
    CHECK(toneMap(std::nanf(""), m) == 0.0f);
    CHECK(toneMap(0.3f, m) < toneMap(0.6f, m));
  }
  CHECK(raylife::parseToneMap("aces") == ToneMap::Aces);
  CHECK_THROWS_AS(raylife::parseToneMap("filmic"), std::invalid_argument);
}

/// @file texture_file.h
/// @brief Images for textures and environment maps (chapter 14), read with libraries: PNG and JPEG (8 or 16 bits)
/// and Radiance .hdr through stb_image, OpenEXR through OpenEXR, PFM through raylife's own reader; checked by
/// raylife (a size in range, every texel finite and ≥ 0).
///
/// Why stb_image runs in a child process: stb_image decodes hostile files in C with many hand-written size
/// computations, and Debian's version (2.27) has published faults on crafted files (out-of-bounds reads and
/// writes). As with the mesh reader (mesh_file.h), a fork()ed child decodes and sends the texels back through a
/// pipe; a child that crashes, or whose answer is cut short, becomes an ImageFileError. The size is checked from the
/// file's header before anything is decoded, against kMaxTexels and against the file's own length
/// (kMaxTexelsPerByte), so a file that claims 10⁹ texels, or a short one that claims 16384 × 16384, costs nothing.
#pragma once

#include "shading/texture.h"

#include <span>
#include <stdexcept>
#include <string>

namespace raylife {

/// A fault in an image file. what() is "FILE: what is wrong".
class ImageFileError : public std::runtime_error {
public:
  using std::runtime_error::runtime_error;
};

/// The largest texture or environment map raylife reads, in texels: 2²⁸ (16384 × 16384), 3 GiB as floats.
inline constexpr long long kMaxTexels = 1ll << 28;
/// The most texels a PNG, JPEG or Radiance file may claim for each of its bytes: 2¹⁴. No file of those formats packs
/// more (PNG at most 8,256: deflate packs at most 1,032 bytes into one, and a byte holds at most 8 one-bit texels;
/// JPEG at most 512: an 8×8 block takes at least a bit; Radiance about 16), so a file that claims more is cut short
/// or malformed, and is refused before anything is allocated for its texels.
inline constexpr long long kMaxTexelsPerByte = 1ll << 14;
/// The largest image file raylife reads, in bytes (1 GiB).
inline constexpr std::size_t kMaxImageFileBytes = std::size_t(1) << 30;

/// How to read an image file's values.
enum class ImageEncoding {
  Srgb,   ///< 8- and 16-bit values are sRGB-encoded: decoded to linear (by a table, once, as the file is read).
  Linear, ///< 8- and 16-bit values are linear already (a normal map, a mask): divided by 255 or 65535 only.
};

/// Reads an image file for a texture: .png, .jpg/.jpeg (8/16-bit, decoded as `encoding` says), .hdr, .exr, .pfm
/// (linear floats, `encoding` ignored), by extension. Grey and grey-alpha images become RGB; alpha is dropped.
/// @throws ImageFileError naming the file and the fault: missing, a folder, empty, too large, an unknown extension,
/// not the format its extension says, truncated, zero-sized, more than kMaxTexels, a texel negative or not finite.
TexelImage readTextureImage(const std::string& path, ImageEncoding encoding);

/// readTextureImage's reading of a PNG, JPEG or Radiance HDR file, for any name: the file is read whole (at most
/// kMaxImageFileBytes), its first bytes must be the signature of `format` (".png", ".jpg" or ".hdr"; stb_image's
/// decoders of other formats are never reached), and it is decoded by decodeStbImage, in a child process.
/// @throws ImageFileError naming the file and the fault (as readTextureImage).
TexelImage readStbImageFile(const std::string& path, const std::string& format, ImageEncoding encoding);
/// readTextureImage's decoding of bytes in memory (PNG, JPEG or Radiance HDR: stb_image's formats, chosen by the
/// bytes' signature), `name` in messages: the fuzz target's entry. @throws ImageFileError.
TexelImage decodeStbImage(std::span<const unsigned char> bytes, ImageEncoding encoding, const std::string& name);

} // namespace raylife

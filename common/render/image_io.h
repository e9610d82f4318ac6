/// @file image_io.h
/// @brief Image files: PNG (clamped, sRGB-encoded, 8 bits), PFM and OpenEXR (linear float), written atomically.
#pragma once

#include "render/film.h"

#include <atomic>
#include <stdexcept>
#include <string>
#include <vector>

namespace raylife {

/// A failure to read or write an image file. what() names the file and the cause.
class ImageIoError : public std::runtime_error {
public:
  using std::runtime_error::runtime_error;
};

/// The sRGB transfer function: linear value in [0, 1] → encoded value in [0, 1] (IEC 61966-2-1).
float linearToSrgb(float linear);
/// The inverse of linearToSrgb: encoded value in [0, 1] → linear value in [0, 1].
float srgbToLinear(float encoded);

/// How a PNG maps linear radiance into [0, 1] before its sRGB encoding (--tonemap).
enum class ToneMap {
  Clamp,    ///< v clamped to [0, 1]: everything above 1 is white (the default; what encodePng does anyway).
  Reinhard, ///< v / (1 + v) (Reinhard et al. 2002): 1 becomes ½, nothing reaches white.
  Aces,     ///< Narkowicz's fit of the ACES filmic curve, v(2.51v + 0.03) / (v(2.43v + 0.59) + 0.14), in [0, 1].
};
/// The tone curve `curve` at linear value `v` (a negative v, and NaN, give 0); the result is in [0, 1].
float toneMap(float v, ToneMap curve);
/// `image` with `curve` applied to every channel (Clamp: the image as it is; encodePng clamps it).
Image toneMapped(Image image, ToneMap curve);
/// "clamp", "reinhard" or "aces" as a ToneMap; @throws std::invalid_argument for any other word.
ToneMap parseToneMap(const std::string& word);

/// The bytes of a PNG file of `image`: each channel clamped to [0, 1], sRGB-encoded, rounded to 8 bits.
std::vector<unsigned char> encodePng(const Image& image);
/// The bytes of a PFM file of `image` ("PF", little-endian, linear floats unclamped, rows stored bottom-up as
/// the format requires).
std::vector<unsigned char> encodePfm(const Image& image);

/// The bytes of an OpenEXR file of `image`: channels R, G and B as 32-bit floats (linear, unclamped, NaN and ∞
/// kept), ZIP-compressed (lossless), scan lines from the top. @throws ImageIoError if OpenEXR fails.
std::vector<unsigned char> encodeExr(const Image& image);

/// Reads a PFM file (colour "PF" or grey "Pf", either byte order) into linear floats, row 0 at the top.
/// @throws ImageIoError naming the file and the fault.
Image readPfm(const std::string& path);
/// Reads a PNG file (8 or 16 bits, any channel count; grey becomes RGB, alpha is dropped) and decodes sRGB to
/// linear: an 8-bit code c becomes srgbToLinear(c / 255.0f), so PNG codes are recovered exactly (grading.h), and a
/// 16-bit one srgbToLinear(c / 65535.0f). The file's first bytes must be PNG's signature, whatever its name; it is
/// decoded in a child process, as a texture is (readStbImageFile in scene/texture_file.h), at most kMaxTexels.
/// @throws ImageIoError naming the file and the fault.
Image readPng(const std::string& path);
/// Reads an OpenEXR file's R, G and B channels (or its Y channel, as grey; any pixel type, converted to float;
/// a missing one of R, G, B reads as 0) over its data window, row 0 at the top. Of a multi-part file, the first part.
/// @throws ImageIoError, also for deep pixels (any part) and for pixels more bytes than the file could hold.
Image readExr(const std::string& path);
/// Reads a PNG, PFM or EXR file, chosen by its extension. @throws ImageIoError.
Image readImage(const std::string& path);

/// True when `path` ends in ".png", ".pfm" or ".exr" (in any case, ".PNG" too): the image formats raylife writes.
bool isImagePath(const std::string& path);

/// The extension of `path`'s file name in lower case, with its dot (".png"), or "" if it has none.
std::string fileExtension(const std::string& path);

/// Encodes `image` in the format `path`'s extension names (.png, .pfm or .exr). @throws ImageIoError otherwise.
std::vector<unsigned char> encodeImage(const Image& image, const std::string& path);

/// writeFilesAtomically was cancelled through its `cancel` flag: nothing was written.
class WriteCancelled : public ImageIoError {
public:
  using ImageIoError::ImageIoError;
};

/// Writes several files all or nothing: each is first written in full (and synced) to a temporary file in its
/// target's folder, and only when all have been written are they renamed into place (rename is atomic on one
/// file system). On any failure every temporary file is removed, no target is touched, and ImageIoError says
/// what failed and that an existing file was left as it was.
/// @param files  the files to write: each target path with its bytes (its temporary file goes in its folder).
/// @param cancel if not null, checked between chunks of 1 MiB and before the renames: once it is true, the
///               temporary files are removed and WriteCancelled is thrown. It may be set from a signal handler.
/// Tests may set the environment variable RAYLIFE_FAIL_WRITE_AFTER=N to make every write fail with ENOSPC
/// after N bytes of a file, as a full disk would.
void writeFilesAtomically(const std::vector<std::pair<std::string, std::vector<unsigned char>>>& files,
                          const std::atomic<bool>* cancel = nullptr);

/// Writes one image (PNG, PFM or EXR by extension) atomically. @throws ImageIoError.
void writeImage(const Image& image, const std::string& path);

} // namespace raylife

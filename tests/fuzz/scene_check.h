/// @file scene_check.h
/// @brief The property the scene fuzzer checks, shared by the libFuzzer target and the regression test that
/// replays every input the fuzzer ever found.
#pragma once

#include "render/film_file.h"
#include "scene/mesh_file.h"
#include "scene/texture_file.h"

#include <string>
#include <string_view>

namespace raylife::fuzz {

/// Feeds `text` to parseScene (as file "fuzz.json" in this process's own folder under the system's temporary
/// folder) and checks what comes back. Text after a line "#density" is written to the file "density.json" beside
/// it, which the scene's media may name (without that line there is no such file). A SceneError must be one
/// printable line that starts with the scene file's path and ":"; a scene that loads must satisfy every invariant the
/// loader promises (at least one sphere or triangle, radii and triangles no smaller than kMinSceneLength, colours
/// ≥ 0 and finite, material indices in range, mesh indices in range, geometry and the index of refraction within
/// kMaxSceneExtent and kMaxIor, a valid camera, media with coefficients in range and density grids within the
/// format's bounds, at most 1e9 tentative collisions across), and delta and ratio tracking through a density grid
/// that is cheap to cross must end with finite weights and a transmittance in [0, 1].
/// Any other exception escapes: that is a bug, and the caller reports it.
/// @return "" when all is well, otherwise what was wrong.
std::string checkSceneText(std::string_view text);

/// Feeds `bytes` to parseMeshData as a mesh file of `format` (named "fuzz.mesh") and checks what comes back: a
/// MeshError must be one printable line that starts with "fuzz.mesh"; a mesh that loads must have triangles, every
/// index in range and every vertex finite. @return "" when all is well, otherwise what was wrong.
std::string checkMeshBytes(std::string_view bytes, MeshFormat format);

/// Feeds `bytes` to decodeStbImage (chapter 14's textures; stb_image runs in a child process) as `encoding`, named
/// "fuzz.image", and checks what comes back: an ImageFileError must be one printable line that starts with
/// "fuzz.image"; an image that decodes must have a size in [1, kMaxTexels] and width·height·3 finite texels ≥ 0.
/// @return "" when all is well, otherwise what was wrong.
std::string checkImageBytes(std::string_view bytes, ImageEncoding encoding);

/// Writes `bytes` to a file "fuzz.exr" or "fuzz.pfm" (as `extension` says: ".exr" or ".pfm") in this process's own
/// folder under the system's temporary folder, reads it with readTextureImage (OpenEXR and raylife's PFM reader run
/// in this process), and checks what comes back as checkImageBytes does; the message must start with the file's
/// path. @return "" when all is well, otherwise what was wrong.
std::string checkFloatImageBytes(std::string_view bytes, const std::string& extension);

/// Writes `bytes` to a file "fuzz.film" in this process's own folder under the system's temporary folder, reads it
/// with readFilm (raylife_merge's reader of partial films), and checks what comes back: a FilmError must be one
/// printable line that starts with the file's path; a film that reads must keep the header's promises (a size of at
/// least 1 × 1, the film that size, sample ranges in order and apart, at most kMaxSamplesPerPixel samples, in all and
/// in each pixel), give a mean image, and refuse to merge with itself when it holds samples.
/// @return "" when all is well, otherwise what was wrong.
std::string checkFilmBytes(std::string_view bytes);

} // namespace raylife::fuzz

/// @file film_file.h
/// @brief Partial films (`.film` files): the exact sums of a share of a render's samples, with what a merge needs
/// to check that shares belong together, and the merge itself (raylife_merge and MPI ranks share it).
#pragma once

#include "render/film.h"
#include "render/render_loop.h"

#include <cstdint>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

namespace raylife {

/// A fault in a .film file or in a merge of films. what() names the file and the fault.
class FilmError : public std::runtime_error {
public:
  using std::runtime_error::runtime_error;
};

/// What a partial film says of itself: the render it is a share of, and which share.
struct FilmHeader {
  // The render: films merge only when every one of these is equal.
  std::string chapter;          ///< The binary that rendered it, e.g. "step06_path_tracer".
  std::uint64_t sceneHash = 0;  ///< hashBytes of the scene file, combined with that of the geometry its meshes gave.
  int width = 0;                ///< Film width in pixels (chapter 9: its two images side by side).
  int height = 0;               ///< Film height in pixels.
  int spp = 0;                  ///< The whole render's samples per pixel; 0 for a time budget (no fixed total).
  std::uint64_t seed = 0;       ///< --seed.
  int maxDepth = -1;            ///< The depth the trace function was given (−1: unlimited).
  // The share: summed by a merge.
  std::string scene;            ///< The scene file's name, as given (for people; not compared).
  std::vector<SampleRange> samples; ///< The sample indices it holds: sorted, disjoint, coalesced.
  std::uint64_t rays = 0;       ///< Rays traced.
  std::uint64_t badSamples = 0; ///< Samples replaced by black (render_loop.h).
  double seconds = 0;           ///< Render time, summed over the shares (processor seconds, not wall clock).

  /// The fields that must agree for two films to merge, as one line of text ("chapter ... max_depth D").
  std::string renderKey() const;
  /// Samples held per pixel: the sum of the ranges' counts.
  std::int64_t sampleCount() const;
};

/// A film and its header.
struct PartialFilm {
  FilmHeader header; ///< What it is.
  Film film;         ///< Its sums (header.width × header.height).
};

/// FNV-1a, 64 bits, of `bytes`: the scene's fingerprint in a film and between MPI ranks (not cryptographic: it
/// catches a different file, not a forged one).
std::uint64_t hashBytes(std::string_view bytes);
/// hashBytes of a file's content. @throws FilmError when it cannot be read.
std::uint64_t hashFile(const std::string& path);

/// The bytes of a .film file: a text header (one "key value" line per field, from "raylife film 1" to "end"),
/// then every pixel's sums (six Fixed128, each its low then its high word) and then every count (uint32), all
/// little-endian, row-major from the top row.
std::vector<unsigned char> encodeFilm(const PartialFilm& film);
/// Reads a .film file. @throws FilmError naming the file, the line and the fault (an unknown version or key, a
/// missing field, a bad number, ranges out of order, a truncated or overlong payload).
PartialFilm readFilm(const std::string& path);

/// The ranges of `a` and `b` (each sorted, disjoint) together, coalesced. @throws FilmError (naming `aName` and
/// `bName`) when they share an index.
std::vector<SampleRange> uniteRanges(const std::vector<SampleRange>& a, const std::vector<SampleRange>& b,
                                     const std::string& aName, const std::string& bName);
/// The first run of indices of [0, spp) that `ranges` lack, or a count of 0 when they hold all of it.
SampleRange firstGap(const std::vector<SampleRange>& ranges, int spp);
/// Ranges as text for messages: "0..63, 128..191".
std::string describeRanges(const std::vector<SampleRange>& ranges);

/// Adds `part` (read from `partName`) to `total` (made of `totalName`): exact, in any order. @throws FilmError
/// when they are shares of different renders (naming the first field that differs) or share a sample index.
void mergeFilm(PartialFilm& total, const std::string& totalName, const PartialFilm& part, const std::string& partName);

} // namespace raylife

/// @file edit_distance.h
/// @brief The edit distance between two words, for "did you mean" in messages (scene keys, command-line options).
#pragma once

#include <algorithm>
#include <cstddef>
#include <string_view>
#include <vector>

namespace raylife {

/// The Levenshtein distance between `a` and `b`: the fewest single-character insertions, deletions and
/// substitutions that turn one into the other (0 for equal words; at most max(|a|, |b|)).
/// @param a One word. @param b The other.
inline std::size_t editDistance(std::string_view a, std::string_view b)
{
  std::vector<std::size_t> row(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j)
    row[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    std::size_t diagonal = row[0];
    row[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t above = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (a[i - 1] == b[j - 1] ? 0 : 1)});
      diagonal = above;
    }
  }
  return row[b.size()];
}

} // namespace raylife

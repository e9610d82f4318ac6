/// @file printable.h
/// @brief Text made safe to print on one line, and short, for messages that quote a file's bytes or a library's
/// words.
#pragma once

#include <cstddef>
#include <cstdio>
#include <string>
#include <string_view>

namespace raylife {

/// `text` made safe to print on one line: control characters become `\n`, `\t` or `\u00XX`, and bytes that are not
/// well-formed UTF-8 (a stray continuation byte, an overlong form, a surrogate, a sequence cut short) become `\xXX`;
/// well-formed UTF-8 is kept as it is. So a message never breaks the terminal or the line it stands on.
inline std::string printable(std::string_view text)
{
  std::string out;
  char buffer[8];
  for (std::size_t i = 0; i < text.size();) {
    const auto c = static_cast<unsigned char>(text[i]);
    if (c < 0x20 || c == 0x7f) {
      if (c == '\n')
        out += "\\n";
      else if (c == '\t')
        out += "\\t";
      else {
        std::snprintf(buffer, sizeof buffer, "\\u%04x", unsigned(c));
        out += buffer;
      }
      ++i;
      continue;
    }
    // The length of the UTF-8 sequence c starts, and whether it is well formed (no overlongs or surrogates).
    std::size_t n = c < 0x80 ? 1 : (c >= 0xC2 && c <= 0xDF) ? 2 : (c >= 0xE0 && c <= 0xEF) ? 3 : (c >= 0xF0 && c <= 0xF4) ? 4 : 0;
    bool ok = n > 0 && i + n <= text.size();
    for (std::size_t k = 1; ok && k < n; ++k)
      ok = (static_cast<unsigned char>(text[i + k]) & 0xC0) == 0x80;
    if (ok && n >= 3) {
      const auto c1 = static_cast<unsigned char>(text[i + 1]);
      ok = !(c == 0xE0 && c1 < 0xA0) && !(c == 0xED && c1 >= 0xA0) && !(c == 0xF0 && c1 < 0x90) &&
           !(c == 0xF4 && c1 >= 0x90);
    }
    if (!ok) {
      std::snprintf(buffer, sizeof buffer, "\\x%02x", unsigned(c));
      out += buffer;
      ++i;
      continue;
    }
    out.append(text.substr(i, n));
    i += n;
  }
  return out;
}

/// `text` cut to at most `max` bytes (`max` ≥ 4; at a UTF-8 character boundary), with "..." when it was cut: names
/// taken from a file are quoted in messages, and a message must stay short whatever the file holds.
inline std::string shorten(std::string_view text, std::size_t max = 40)
{
  if (text.size() <= max)
    return std::string(text);
  std::size_t cut = max - 3;
  while (cut > 0 && (static_cast<unsigned char>(text[cut]) & 0xC0) == 0x80)
    --cut;
  return std::string(text.substr(0, cut)) + "...";
}

} // namespace raylife

/// @file scene_check.h
/// @brief The property the scene fuzzer checks, shared by the libFuzzer target and the regression test that
/// replays every input the fuzzer ever found.
#pragma once

#include <string>
#include <string_view>

namespace raylife::fuzz {

/// Feeds `text` to parseScene (as file "fuzz.json") and checks what comes back. A SceneError must be one
/// printable line that starts with "fuzz.json:"; a scene that loads must satisfy every invariant the loader
/// promises (at least one sphere, radii > 0, colours ≥ 0 and finite, material indices in range, a valid camera).
/// Any other exception escapes: that is a bug, and the caller reports it.
/// @return "" when all is well, otherwise what was wrong.
std::string checkSceneText(std::string_view text);

} // namespace raylife::fuzz

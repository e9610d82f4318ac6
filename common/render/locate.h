/// @file locate.h
/// @brief Where a build finds the project's data (scenes, goldens): relative to the program itself, never through
/// a path fixed when the build was configured, so that a copied or moved checkout uses its own files.
#pragma once

#include <filesystem>

namespace raylife {

/// The folder of the running program (read from /proc/self/exe); empty when the system does not say.
std::filesystem::path programDirectory();

/// The raylife tree the running program belongs to: the nearest folder, from the program's own folder upwards,
/// that holds a `scenes/` folder (build/bin/x → the tree above build/). Empty when there is none.
std::filesystem::path projectRoot();

/// The scenes folder: the environment variable RAYLIFE_SCENES when it is set and not empty, else projectRoot()'s
/// `scenes/`. Empty when neither exists.
std::filesystem::path findSceneDirectory();

} // namespace raylife

/// @file locate.h
/// @brief Where a build finds the project's data (scenes, goldens): relative to the program itself, never through
/// a path compiled into it, so that a copied or moved checkout uses its own files.
///
/// In order: the tree the program lies in (build/bin/x → the tree above build/); else the source tree named in the
/// file `raylife-source-tree` beside the program, which every build writes into its bin/ (so that a build folder
/// outside the source tree, `cmake -S . -B /tmp/b`, finds the scenes of the tree it was configured from); else an
/// installed layout, PREFIX/bin/x beside PREFIX/share/raylife/ (`cmake --install`).
#pragma once

#include <filesystem>

namespace raylife {

/// The folder of the running program (read from /proc/self/exe); empty when the system does not say.
std::filesystem::path programDirectory();

/// The name of the file beside a build's programs that names its source tree (one line: the tree's folder).
inline constexpr const char* kSourceTreeFile = "raylife-source-tree";

/// The raylife tree a program in `programDir` belongs to: the nearest folder, from `programDir` upwards, that holds
/// a `scenes/` folder; else the folder named by `programDir`/raylife-source-tree, if it holds `scenes/`. Empty when
/// there is none.
std::filesystem::path projectRootFor(const std::filesystem::path& programDir);

/// projectRootFor(programDirectory()).
std::filesystem::path projectRoot();

/// The data of an installed raylife for a program in `programDir`: `programDir`/../share/raylife when it holds a
/// `scenes/` folder (its goldens in `golden/`); empty otherwise.
std::filesystem::path installedDataFor(const std::filesystem::path& programDir);

/// The scenes folder for a program in `programDir`: the environment variable RAYLIFE_SCENES when it is set and not
/// empty, else projectRootFor(programDir)'s `scenes/`, else installedDataFor(programDir)'s `scenes/`. Empty when
/// none exists.
std::filesystem::path findSceneDirectoryFor(const std::filesystem::path& programDir);

/// findSceneDirectoryFor(programDirectory()).
std::filesystem::path findSceneDirectory();

} // namespace raylife

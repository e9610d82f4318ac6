# raylife_lto: link-time optimisation for the programs whose speed counts: the chapters, and bvh_bench, which
# times their queries.
#
# Why: a chapter's hot loop calls across files (trace in main.cpp, Scene::intersect in scene.cpp, the BSDF
# samplers in bsdf.cpp); without LTO every such call stays a call. With it, GCC sees the whole program and inlines
# across files (in chapter 6, perf finds Scene::intersect and the samplers folded into trace), and chapter 6 runs
# about 1.16 times as fast with the same bits (11.5-11.7 -> 13.4-13.5 Mrays/s, 256x192, 64 spp, two threads).
# The price is one to two minutes more of build on two cores, so the tests, which need no speed, are left out:
# raylife_common's objects are "fat", holding both the code LTO reads and ordinary machine code, and a target
# that does not link raylife_lto simply uses the latter.
#
# GCC only, Release only (a sanitizer or debug build wants its code as written); RAYLIFE_LTO=OFF turns it off.
option(RAYLIFE_LTO "Link-time optimisation of the chapters and bvh_bench (GCC, Release builds)" ON)
add_library(raylife_lto INTERFACE)
set(RAYLIFE_LTO_ACTIVE OFF)
if(RAYLIFE_LTO AND CMAKE_CXX_COMPILER_ID STREQUAL "GNU" AND CMAKE_BUILD_TYPE STREQUAL "Release")
  set(RAYLIFE_LTO_ACTIVE ON)
  # -flto=auto: as many link-time jobs as make's jobserver allows (plain -flto warns that it runs them serially).
  target_compile_options(raylife_lto INTERFACE -flto=auto)
  target_link_options(raylife_lto INTERFACE -flto=auto)
endif()
message(STATUS "raylife: link-time optimisation of the chapters and bvh_bench: ${RAYLIFE_LTO_ACTIVE}")

# For the libraries the programs share: LTO's code and ordinary code side by side.
function(raylife_fat_lto target)
  if(RAYLIFE_LTO_ACTIVE)
    target_compile_options(${target} PRIVATE -flto=auto -ffat-lto-objects)
  endif()
endfunction()

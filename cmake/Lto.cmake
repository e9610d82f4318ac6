# raylife_lto: link-time optimisation for the programs whose speed counts and gains from it: chapters 6, 8 and 16
# (RAYLIFE_LTO_CHAPTERS below), and bvh_bench and mesh_bench, which time their queries.
#
# Why: a chapter's hot loop calls across files (trace in main.cpp, Scene::intersect in scene.cpp, the BSDF
# samplers in bsdf.cpp); without LTO every such call stays a call. With it, GCC sees the whole program and inlines
# across files (in chapter 6, perf finds Scene::intersect and the samplers folded into trace), and chapter 6 runs
# about 1.16 times as fast with the same bits (11.5-11.7 -> 13.4-13.5 Mrays/s, 256x192, 64 spp, two threads).
# The price is some 10 s of a core for each program linked so, so the tests, which need no speed, are left out:
# raylife_common's objects are "fat", holding both the code LTO reads and ordinary machine code, and a target
# that does not link raylife_lto is linked with -fno-lto, which takes the latter.
#
# GCC only, Release only (a sanitizer or debug build wants its code as written); RAYLIFE_LTO=OFF turns it off.
#
# Only the link depends on RAYLIFE_LTO: in every GCC Release build the library and the programs that may link with
# LTO compile their objects fat (raylife_fat_lto below), whatever RAYLIFE_LTO says. So the README's two commands,
# the render (LTO on) and then the test (LTO off) in the same build/, share every object file: switching between
# them relinks the chapters and compiles nothing.
option(RAYLIFE_LTO "Link-time optimisation of the chapters and bvh_bench (GCC, Release builds)" ON)
# The chapters it speeds up, and only those: an LTO link compiles the whole library again (about 10 s of a core a
# chapter), and chapter 6 traces 1.16 times as many rays a second with it, chapter 8 1.05 times, the others as
# many; chapter 16, measured against chapter 8, takes 0.96 of its time without LTO (smallpt, 160x120, 32 spp, one
# thread, medians of 5 alternating runs). A new chapter whose speed counts (and gains) joins this list.
set(RAYLIFE_LTO_CHAPTERS step06_path_tracer step08_mis step16_wavefront)
# Of those, the ones whose link-time inlining may grow the program further (raylife_lto_inlining, below).
set(RAYLIFE_LTO_MORE_INLINING step16_wavefront)
add_library(raylife_lto INTERFACE)
add_library(raylife_lto_inlining INTERFACE)
set(RAYLIFE_LTO_OBJECTS OFF)
set(RAYLIFE_LTO_ACTIVE OFF)
if(CMAKE_CXX_COMPILER_ID STREQUAL "GNU" AND CMAKE_BUILD_TYPE STREQUAL "Release")
  set(RAYLIFE_LTO_OBJECTS ON)
  # -flto=auto: as many link-time jobs as make's jobserver allows (plain -flto warns that it runs them serially).
  target_compile_options(raylife_lto INTERFACE -flto=auto -ffat-lto-objects)
  if(RAYLIFE_LTO)
    set(RAYLIFE_LTO_ACTIVE ON)
    target_link_options(raylife_lto INTERFACE -flto=auto)
    # Chapter 16's inlining may grow the program by as much again, not by GCC's 40 %. Past that limit GCC stops
    # inlining the small functions its shade stage calls (a queue's push, the light choice, refraction), and new code
    # elsewhere in the program (the light buffer) made shade 1.1 to 1.2 times as slow through no change of its own.
    # Chapters 6 and 8 take the same time with it or without (medians of 5 alternating runs), so they keep GCC's.
    target_link_options(raylife_lto_inlining INTERFACE --param=inline-unit-growth=100)
  else()
    target_link_options(raylife_lto INTERFACE -fno-lto)
  endif()
endif()
message(STATUS "raylife: link-time optimisation of the chapters and bvh_bench: ${RAYLIFE_LTO_ACTIVE}")

# For the libraries the programs share: LTO's code and ordinary code side by side. A program that does not link
# raylife_lto links them with -fno-lto: without it, GCC's linker plugin finds LTO's code in the fat objects and runs
# link-time optimisation over the whole library anyway (some 10 s of a core for every test and tool, which made the
# test build several minutes longer), where -fno-lto takes the ordinary code (half a second).
function(raylife_fat_lto target)
  if(RAYLIFE_LTO_OBJECTS)
    target_compile_options(${target} PRIVATE -flto=auto -ffat-lto-objects)
    target_link_options(${target} INTERFACE
      $<$<NOT:$<IN_LIST:raylife_lto,$<TARGET_PROPERTY:LINK_LIBRARIES>>>:-fno-lto>)
  endif()
endfunction()

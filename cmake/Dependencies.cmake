# Every dependency comes from Debian's packages (./setup.sh installs them). Nothing is downloaded.
find_package(glm REQUIRED CONFIG)
find_package(nlohmann_json 3.10 REQUIRED CONFIG)
# Assimp reads the mesh files (OBJ, ASCII and binary PLY); raylife checks what it returns (scene/mesh_file.h).
find_package(assimp 5 REQUIRED CONFIG)
find_package(OpenMP REQUIRED COMPONENTS CXX)
find_package(Threads REQUIRED)
# OpenEXR (libopenexr-dev, 3.1 in Debian 12): -o x.exr, and every tool that reads images reads EXR too.
# Debian 12's libimath-dev declares a PyImath target whose library ships in another package (python3-imath), and
# Imath's package file, which OpenEXR's loads, reports the missing file in ten status lines on every configure.
# raylife uses Imath's C++ library only: status messages are held back while OpenEXR is found (warnings and errors
# still show, and `cmake --log-level=STATUS` or more shows everything again).
set(CMAKE_MESSAGE_LOG_LEVEL NOTICE)
find_package(OpenEXR 3 REQUIRED CONFIG)
unset(CMAKE_MESSAGE_LOG_LEVEL)
# Google Highway (libhwy-dev, 1.0.3 in Debian 12): the SIMD of chapter 16's stream kernels, compiled for several
# instruction sets in one binary and chosen at run time (render/ray_stream.h), so the build stays generic x86-64.
find_package(hwy 1 REQUIRED CONFIG)
# MPI (libopenmpi-dev): only in the MPI build (cmake --preset mpi; ./setup.sh --mpi installs it).
option(RAYLIFE_MPI "Build the chapters as MPI programs (mpirun -np N renders one image over N ranks)" OFF)
if(RAYLIFE_MPI)
  find_package(MPI REQUIRED COMPONENTS CXX)
endif()

# stb: Debian's libstb-dev ships the headers under include/stb and the compiled implementation as libstb.
find_path(STB_INCLUDE_DIR stb/stb_image_write.h REQUIRED)
find_library(STB_LIBRARY NAMES stb REQUIRED)
add_library(raylife_stb INTERFACE)
target_include_directories(raylife_stb SYSTEM INTERFACE ${STB_INCLUDE_DIR})
target_link_libraries(raylife_stb INTERFACE ${STB_LIBRARY})

if(RAYLIFE_BUILD_TESTS)
  find_package(Catch2 2 REQUIRED CONFIG)
  include(Catch)
endif()

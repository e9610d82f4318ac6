#!/usr/bin/env bash
# Installs the Debian 12 packages raylife needs, when they are missing.
# As root it runs apt-get; otherwise it prints the one apt-get line to run and exits 1.
# First it resets a preset's build folder that an older raylife configured for make (the presets build with Ninja).
#   ./setup.sh          build, tests and docs
#   ./setup.sh --fuzz   also clang's libFuzzer runtime (tests/fuzz)
#   ./setup.sh --browser also Chromium, for the docs screenshot check
#   ./setup.sh --bench  also gnuplot, for the benchmark's plots (tools/bench, docs/benchmarks.md)
#                       and xsimd, for tools/simd_bench
#   ./setup.sh --embree also Embree 3, the yardstick of tools/mesh_bench (cmake --preset embree)
#   ./setup.sh --mpi    also Open MPI, for the MPI build (cmake --preset mpi; docs/beyond-one-machine.md)
#   ./setup.sh --opencl also OpenCL and PoCL's CPU device, for chapter 17 (cmake --preset opencl)
set -euo pipefail

packages=(
  g++ cmake ninja-build make     # compiler and build (the presets build with Ninja)
  libglm-dev                     # vector maths
  libstb-dev                     # PNG reading and writing
  nlohmann-json3-dev             # scene files
  libhwy-dev                     # SIMD kernels chosen at run time (Google Highway: chapter 16)
  libassimp-dev                  # mesh files (OBJ, PLY)
  assimp-testmodels              # chapter 10's model and the mesh loader's tests (real and malformed files)
  libopenexr-dev openexr         # EXR images (openexr: exrheader, which a test reads them with)
  catch2                         # tests (version 2)
  doxygen graphviz libjs-mathjax # docs, offline formulas
)
for arg in "$@"; do
  case "$arg" in
    --fuzz) packages+=(clang libclang-rt-14-dev libomp-14-dev) ;; # libomp: OpenMP for a clang build
    --browser) packages+=(chromium) ;;
    --bench) packages+=(gnuplot-nox fonts-dejavu-core libxsimd-dev) ;; # libxsimd-dev: tools/simd_bench
    --embree) packages+=(libembree-dev) ;;
    --mpi) packages+=(openmpi-bin libopenmpi-dev) ;;
    --opencl) packages+=(pocl-opencl-icd ocl-icd-opencl-dev opencl-c-headers opencl-clhpp-headers clinfo) ;;
    *) echo "setup.sh: unknown option '$arg' (known: --fuzz, --browser, --bench, --mpi, --embree, --opencl)" >&2; exit 2 ;;
  esac
done

# The presets build with Ninja. A preset's build folder that an older raylife configured for make cannot be configured
# again for Ninja: its cache goes, and its next build compiles everything again.
cd "$(dirname "$0")"
for dir in $(sed -n 's|.*"binaryDir": "${sourceDir}/\(.*\)".*|\1|p' CMakePresets.json | sort -u); do
  if grep -qx 'CMAKE_GENERATOR:INTERNAL=Unix Makefiles' "$dir/CMakeCache.txt" 2>/dev/null; then
    echo "setup.sh: $dir/ was configured for make, and the presets now build with Ninja: removing its CMakeCache.txt" \
      "and CMakeFiles/ (its next build compiles everything again)"
    rm -rf "$dir/CMakeCache.txt" "$dir/CMakeFiles" "$dir/Makefile"
  fi
done

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
  echo "setup.sh: every package raylife needs is installed."
  exit 0
fi
if [ "$(id -u)" -ne 0 ]; then
  echo "setup.sh: missing packages. Run, as root:" >&2
  echo "  apt-get update && apt-get install -y ${missing[*]}" >&2
  exit 1
fi
echo "setup.sh: installing ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
apt-get update -qq
apt-get install -y -qq --no-install-recommends "${missing[@]}"

#!/bin/sh
# Re-renders the golden references of chapters 11 and 12 kept in tests/distributed/golden/ (run from the top of the
# source tree): chapter 11 on scenes/distributed.json at 64x48 and chapter 12 on scenes/meshes.json at 64x64, both
# with 4096 samples per pixel (seed 0), each with the variance of its pixel means, which the golden z-test of
# test_chapters.cpp uses. A golden image changes only in a commit that says why.
# RAYLIFE_RANKS=N renders over N MPI ranks (a build of the mpi preset, given as BUILD_DIR: build-mpi).
set -eu
build=${1:-build}
launch=${RAYLIFE_RANKS:+mpirun -np $RAYLIFE_RANKS}
out=tests/distributed/golden
mkdir -p "$out"
$launch "$build/bin/step11_distributed" scenes/distributed.json --width 64 --height 48 --spp 4096 --seed 0 --quiet \
  -o "$out/step11_distributed_64x48.pfm" --variance "$out/step11_distributed_64x48_variance.pfm"
$launch "$build/bin/step12_ambient_occlusion" scenes/meshes.json --width 64 --height 64 --spp 4096 --seed 0 --quiet \
  -o "$out/step12_ambient_occlusion_64x64.pfm" --variance "$out/step12_ambient_occlusion_64x64_variance.pfm"
echo "references written to $out/"

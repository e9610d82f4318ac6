#!/bin/sh
# Re-renders the golden references of the Monte Carlo and Whitted chapters kept in tests/golden/mc/.
#
#   tools/make_reference.sh [BUILD_DIR]      (default: build; run from the top of the source tree)
#
# Chapter 6: the Cornell box at 64x48 with 4096 samples per pixel (seed 0): its mean and the variance of each
# pixel's mean, which the statistical golden test (tests/golden/mc/test_golden_mc.cpp) compares against.
# Chapter 5: the Whitted scene at 160x120 (default 16 spp, seed 0), compared with a per-pixel tolerance.
# A golden image changes only in a commit that says why.
# RAYLIFE_RANKS=N renders over N MPI ranks (a build of the mpi preset, given as BUILD_DIR: build-mpi): the same
# bytes, sooner on a cluster (docs/beyond-one-machine.md).
set -eu
build=${1:-build}
launch=${RAYLIFE_RANKS:+mpirun -np $RAYLIFE_RANKS}
out=tests/golden/mc
$launch "$build/bin/step06_path_tracer" scenes/cornell.json --width 64 --height 48 --spp 4096 --seed 0 \
  -o "$out/step06_cornell_64x48.pfm" --variance "$out/step06_cornell_64x48_variance.pfm"
$launch "$build/bin/step05_whitted" scenes/whitted.json --width 160 --height 120 --seed 0 \
  -o "$out/step05_whitted_160x120.pfm"
echo "references written to $out/"

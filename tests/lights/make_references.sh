#!/bin/sh
# Re-renders the golden references of chapters 7, 8 and 13 kept in tests/lights/golden/ (run from the top of the source
# tree): chapter 7 on the Cornell box, chapter 8 on the MIS scene and chapter 13 on the caustic scene, all at 64x48 with 2048 samples per pixel
# (seed 0), each with the variance of its pixel means, which the golden z-test of test_lights_render.cpp uses.
# A golden image changes only in a commit that says why.
# RAYLIFE_RANKS=N renders over N MPI ranks (a build of the mpi preset, given as BUILD_DIR: build-mpi): the same
# bytes, sooner on a cluster (docs/beyond-one-machine.md).
set -eu
build=${1:-build}
launch=${RAYLIFE_RANKS:+mpirun -np $RAYLIFE_RANKS}
out=tests/lights/golden
$launch "$build/bin/step07_light_sampling" scenes/cornell.json --width 64 --height 48 --spp 2048 --seed 0 --quiet \
  -o "$out/step07_cornell_64x48.pfm" --variance "$out/step07_cornell_64x48_variance.pfm"
$launch "$build/bin/step08_mis" scenes/mis.json --width 64 --height 48 --spp 2048 --seed 0 --quiet \
  -o "$out/step08_mis_64x48.pfm" --variance "$out/step08_mis_64x48_variance.pfm"
$launch "$build/bin/step13_bdpt" scenes/caustics.json --width 64 --height 48 --spp 2048 --seed 0 --quiet \
  -o "$out/step13_caustics_64x48.pfm" --variance "$out/step13_caustics_64x48_variance.pfm"
echo "references written to $out/"

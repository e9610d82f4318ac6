#!/usr/bin/env bash
# Fuzzes the scene loader, the mesh files, the texture images (stb_image's formats), the float images (OpenEXR and
# PFM) and the partial films (raylife_merge's .film files) with libFuzzer for SECONDS in all (default 60): a fifth
# each, or all of it for the scene loader when RAYLIFE_FUZZ_MESH=0. One fuzzer at a time, or RAYLIFE_FUZZ_JOBS at a
# time (each still gets its share, so the fuzzing is the same and takes less of the clock: CI runs two on its two
# cores); each is a single process.
#   tools/fuzz.sh SECONDS [BUILD_DIR]
# Builds tests/fuzz/fuzz_scene, fuzz_mesh, fuzz_image, fuzz_float_image and fuzz_film in BUILD_DIR (default
# build-asan/) configured by the asan preset: clang, -fsanitize=fuzzer-no-link,address,undefined, the same build in
# which `cmake --workflow --preset asan` runs the suite, so CI builds the sanitized code once for both. The scene
# fuzzer is seeded from scenes/, scenes/stress/ and tests/fuzz/regressions/ (an input may carry a medium's density
# file after a line "#density", and the check tracks rays through it: tests/fuzz/scene_check.h), the mesh fuzzer from
# tests/fuzz/mesh_regressions/ (and Assimp's test models, where Debian's assimp-testmodels is installed), the image
# and film fuzzers from their own regressions folders (and Assimp's PNG and JPEG files); each keeps its growing
# corpus in BUILD_DIR/corpus*/ between runs, and leaves any crashing or hanging input in BUILD_DIR/crashes/.
# The mesh fuzzer checks raylife's handling of mesh files end to end: Assimp runs in a child process of the loader
# (common/scene/mesh_file.cpp), where a fault of the library itself (Debian's Assimp 5.2 has several on hostile files)
# must come back as one MeshError line; a crash, a hang or a sanitizer report in raylife's own process stops it.
# (Coverage inside the child is not seen: the fuzzer steers by raylife's code in the parent.)
# Exit status: 0 nothing found, 1 the fuzzer found a fault (copy the input into tests/fuzz/regressions/,
# mesh_regressions/, image_regressions/, float_image_regressions/ or film_regressions/ once fixed), 2 bad usage.
# Needs clang, libclang-rt-14-dev and libomp-14-dev (./setup.sh --fuzz).
set -euo pipefail

seconds=${1:-60}
if ! [[ "$seconds" =~ ^[1-9][0-9]*$ ]]; then
  echo "usage: tools/fuzz.sh SECONDS [BUILD_DIR]" >&2
  exit 2
fi
root=$(cd "$(dirname "$0")/.." && pwd)
build=${2:-$root/build-asan}

mkdir -p "$build"
(cd "$root" && cmake --preset asan -B "$build") >"$build/configure.log" 2>&1 || { cat "$build/configure.log" >&2; exit 1; }
cmake --build "$build" --target fuzz_scene fuzz_mesh fuzz_image fuzz_float_image fuzz_film -j2

meshOn=1
[ "${RAYLIFE_FUZZ_MESH:-1}" != 0 ] || meshOn=0
sceneSeconds=$seconds
if [ "$meshOn" = 1 ]; then
  # A fifth each to the scene loader, the mesh files, the texture images, the float images and the films, at least a
  # second each.
  share=$(( seconds / 5 > 0 ? seconds / 5 : 1 ))
  meshSeconds=$share imageSeconds=$share floatSeconds=$share filmSeconds=$share
  sceneSeconds=$(( seconds - 4 * share > 0 ? seconds - 4 * share : 1 ))
fi

corpus="$build/corpus"
crashes="$build/crashes"
mkdir -p "$corpus" "$crashes"
# (To find the inputs this run leaves in crashes/: see the end.)
touch "$build/fuzz-started"
seeds=("$root/scenes")
[ -d "$root/scenes/stress" ] && seeds+=("$root/scenes/stress")
seeds+=("$root/tests/fuzz/regressions")

# fuzzOne WHAT TARGET SECONDS MAX_LEN CORPUS [SEED FOLDERS and libFuzzer options...]: one target's run, started
# once fewer than $jobs are going; with several at a time, its output is printed whole when it ends (fuzzWait). No
# run starts once one has found a fault. (The readers that run a library in a child process end it with _exit:
# LeakSanitizer checks raylife's process only.)
jobs=${RAYLIFE_FUZZ_JOBS:-1}
if ! [[ "$jobs" =~ ^[1-9][0-9]*$ ]]; then
  echo "fuzz.sh: RAYLIFE_FUZZ_JOBS must be a whole number of fuzzers at a time, 1 or more (it is '$jobs')" >&2
  exit 2
fi
logs=$(mktemp -d)
status=0
running=()        # the runs going, by process id
# (A run is a background process, which ignores Ctrl-C: stopped or failing, this script stops the runs it leaves.)
trap 'kill "${running[@]}" 2>/dev/null || true; rm -rf "$logs"' EXIT
trap 'exit 130' INT TERM
declare -A logOf  # each run's output file
# fuzzWait N: waits until fewer than N runs are going (N = 1: until all have ended), printing each one's output as it
# ends and taking a fault's exit status into $status. (wait -n -p: bash 5.1 or later.)
fuzzWait() {
  while [ "${#running[@]}" -ge "$1" ]; do
    local pid rc=0 still=() other
    wait -n -p pid "${running[@]}" || rc=$?
    [ -z "${logOf[$pid]}" ] || cat "${logOf[$pid]}"
    [ "$rc" -eq 0 ] || status=$rc
    for other in "${running[@]}"; do [ "$other" = "$pid" ] || still+=("$other"); done
    running=("${still[@]+"${still[@]}"}")
  done
}
fuzzOne() {
  local what=$1 target=$2 budget=$3 maxLen=$4 corpusDir=$5
  shift 5
  fuzzWait "$jobs"
  [ "$status" -eq 0 ] || return 0
  mkdir -p "$corpusDir"
  # (One at a time, its output goes straight out as it comes.)
  local log=""
  [ "$jobs" = 1 ] || log="$logs/$target.log"
  (
    [ -z "$log" ] || exec > "$log" 2>&1
    echo "fuzz.sh: fuzzing the $what for $budget s; corpus $corpusDir, faults into $crashes/"
    ASAN_OPTIONS=detect_leaks=1 exec "$build/bin/$target" "$corpusDir" "$@" -max_total_time="$budget" -timeout=10 \
      -rss_limit_mb=2048 -max_len="$maxLen" -print_final_stats=1 -artifact_prefix="$crashes/"
  ) &
  running+=("$!")
  logOf[$!]="$log"
}

fuzzOne "scene loader" fuzz_scene "$sceneSeconds" 16384 "$corpus" "${seeds[@]}" -dict="$root/tests/fuzz/scene.dict"

if [ "$status" -eq 0 ] && [ "$meshOn" = 1 ]; then
  # The mesh fuzzer's seeds: its regressions, and small OBJ and PLY files from Assimp's test models (prefixed with the
  # byte that names their format: 'n', even, for OBJ; 'q', odd, for PLY).
  meshCorpus="$build/corpus-mesh"
  meshSeeds="$build/seeds-mesh"
  mkdir -p "$meshSeeds"
  for f in /usr/share/assimp/models/OBJ/*.obj /usr/share/assimp/models/PLY/*.ply /usr/share/assimp/models/invalid/*; do
    [ -f "$f" ] && [ "$(stat -c %s "$f")" -le 65536 ] || continue
    case "$f" in *.obj) prefix=n ;; *.ply) prefix=q ;; *) continue ;; esac
    { printf '%s' "$prefix"; cat "$f"; } >"$meshSeeds/$(basename "$f").bin"
  done
  fuzzOne "mesh files" fuzz_mesh "$meshSeconds" 65536 "$meshCorpus" "$meshSeeds" "$root/tests/fuzz/mesh_regressions"
fi
if [ "$status" -eq 0 ] && [ "$meshOn" = 1 ]; then
  # The image fuzzer's seeds: its regressions, and small PNG and JPEG files from Assimp's test models ('n', even:
  # decoded as sRGB).
  imageCorpus="$build/corpus-image"
  imageSeeds="$build/seeds-image"
  mkdir -p "$imageSeeds"
  for f in /usr/share/assimp/models/*/*.png /usr/share/assimp/models/*/*.jpg; do
    [ -f "$f" ] && [ "$(stat -c %s "$f")" -le 65536 ] || continue
    { printf 'n'; cat "$f"; } >"$imageSeeds/$(basename "$f").bin"
  done
  fuzzOne "texture images" fuzz_image "$imageSeconds" 65536 "$imageCorpus" "$imageSeeds" \
    "$root/tests/fuzz/image_regressions"
fi
if [ "$status" -eq 0 ] && [ "$meshOn" = 1 ]; then
  # The float images: OpenEXR and raylife's PFM reader, in this process. Seeded with their regressions, which hold
  # small files of each of OpenEXR's compressions, scan lines and tiles, and PFMs (the first byte: even for OpenEXR,
  # odd for PFM).
  fuzzOne "float images" fuzz_float_image "$floatSeconds" 65536 "$build/corpus-float-image" \
    "$root/tests/fuzz/float_image_regressions"
fi
if [ "$status" -eq 0 ] && [ "$meshOn" = 1 ]; then
  # The partial films (raylife_merge's input), seeded with their regressions: shares of renders of chapters 6, 8
  # (a time budget) and 9.
  fuzzOne "partial films" fuzz_film "$filmSeconds" 16384 "$build/corpus-film" "$root/tests/fuzz/film_regressions"
fi
fuzzWait 1
if [ "$status" -ne 0 ]; then
  echo "fuzz.sh: the fuzzer found a fault (status $status); inputs in $crashes/:" >&2
  ls -l "$crashes" >&2
  exit 1
fi
# Inputs left in crashes/ by a run that found no fault. The mesh and image readers fork a child for the library, and
# the child inherits libFuzzer's limits: where it passes one (memory: oom-*), it leaves its input there and dies, and
# the parent turns that into one error line, as it must, so the run goes on. libFuzzer also keeps inputs slower than
# 10 s (slow-unit-*). Worth a look, not a failure (a library may reserve memory it never touches): a 25-byte PNG once
# cost the image reader 3 GiB and 13 s, found so.
left=$(find "$crashes" -type f -newer "$build/fuzz-started" | sort)
if [ -n "$left" ]; then
  echo "fuzz.sh: $(echo "$left" | wc -l) input(s) passed libFuzzer's limits on memory or time without a fault (in a" \
    "reader's child process, or slow); the first byte chooses the format or the encoding, the rest is the file:"
  echo "$left" | head -20 | sed 's/^/  /'
fi
echo "fuzz.sh: no fault found in $seconds s"

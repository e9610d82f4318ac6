#!/usr/bin/env bash
# Chapter 16 against chapter 8, side by side (docs/benchmarks.md, "Chapter 16: the wavefront"): for each scene the
# two chapters render the same image bit for bit at equal samples per pixel (tests/wavefront), so the ratio of their
# times is the ratio of their equal-time efficiencies. Runs each pair N times, alternating (A B A B ...), one thread
# on one core, and prints the medians of the CPU seconds (user + sys, /usr/bin/time), of the pair-by-pair ratios and
# of each chapter's million rays a second (its --stats: rays traced over the render's seconds); then chapter 16 on 2
# threads against 1 (wall seconds).
# Usage: [CORE=N] tools/wavefront_bench.sh [BUILD_DIR] [RUNS]   (default: build, 5; a release build: cmake --preset
# release; CORE: below)
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build}
runs=${2:-5}
ch8="$build/bin/step08_mis"
ch16="$build/bin/step16_wavefront"
for program in "$ch8" "$ch16"; do
  [ -x "$program" ] || { echo "wavefront_bench: no $program (cmake --build --preset release)" >&2; exit 2; }
done
[ -x /usr/bin/time ] || { echo "wavefront_bench: needs /usr/bin/time (Debian's package time)" >&2; exit 2; }
# The test preset configures the same folder as the release one, without link-time optimisation, and chapter 16
# then runs some per cent slower: say which build this is, and warn where it is not the release build.
cache="$build/CMakeCache.txt"
lto=$(sed -n 's/^RAYLIFE_LTO:BOOL=//p' "$cache" 2> /dev/null || true)
type=$(sed -n 's/^CMAKE_BUILD_TYPE:STRING=//p' "$cache" 2> /dev/null || true)
if [ "$lto" != ON ] || [ "$type" != Release ]; then
  echo "wavefront_bench: $build is not the release build (${type:-unknown type}, link-time optimisation" \
    "${lto:-unknown}): its figures are not those of docs/benchmarks.md (cmake --preset release, then" \
    "cmake --build --preset release)" >&2
elif [ "$cache" -nt "$ch16" ] || [ "$cache" -nt "$ch8" ]; then
  echo "wavefront_bench: $build was configured again after its programs were built (cmake --build --preset" \
    "release)" >&2
fi

# The one-thread runs all go to one core, where taskset is there: the cores of a virtual machine need not be equally
# fast (on the one docs/benchmarks.md was measured on, one took 1.3 times as long), and runs that land on either at
# random widen the ratios' spread (there, on the Cornell box, 0.35 to 0.63 over nine pairs left to the scheduler,
# 0.38 to 0.52 over nine pinned, in the next call). CORE=N chooses that core (say, the faster of a machine whose
# other core a neighbour's load slows now and then); by default it is the last this script may use. (Pinning the
# whole script with taskset instead would put the two-thread runs on one core too.)
pin=()
if command -v taskset > /dev/null; then
  last=$(awk '/^Cpus_allowed_list/ {n = split($2, c, /[-,]/); print c[n]}' /proc/self/status 2> /dev/null || true)
  core=${CORE:-$last}
  [ -n "$core" ] && pin=(taskset -c "$core")
  if [ -n "${CORE:-}" ] && ! taskset -c "$CORE" true 2> /dev/null; then
    echo "wavefront_bench: CORE=$CORE is not a core this script may run on" >&2
    exit 2
  fi
fi

# seconds COMMAND...: the command's user + sys CPU seconds (or, with WALL=1, its wall seconds); with PIN=1, on the
# one core above.
seconds() {
  local out
  local -a on=()
  [ "${PIN:-0}" = 1 ] && on=("${pin[@]}")
  /usr/bin/time -f '%U %S %e' -o "$times" "${on[@]}" "$@" > /dev/null 2>&1
  out=$(tail -n 1 "$times")
  if [ "${WALL:-0}" = 1 ]; then echo "$out" | awk '{print $3}'; else echo "$out" | awk '{print $1 + $2}'; fi
}
# mrays FILE: a --stats file's million rays a second (rays over the render's seconds).
mrays() {
  tr ',' '\n' < "$1" | awk -F': ' '$1 ~ /"rays"/ {r = $2} $1 ~ /"seconds"/ {s = $2}
    END {if (s > 0) printf "%.2f", r / s / 1e6; else print 0}'
}
median() { sort -g | awk '{v[NR] = $1} END {print (NR % 2 ? v[(NR + 1) / 2] : (v[NR / 2] + v[NR / 2 + 1]) / 2)}'; }

# pair NAME "ARGS A" "ARGS B" PROGRAM_A PROGRAM_B: medians of A, B and A/B over alternating runs; with STATS=1, also
# the medians of A's and B's million rays a second.
pair() {
  local name=$1 argsA=$2 argsB=$3 a=$4 b=$5 ta tb statsA=() statsB=()
  local -a as=() bs=() rs=() ma=() mb=()
  if [ "${STATS:-0}" = 1 ]; then statsA=(--stats "$out/a.json") statsB=(--stats "$out/b.json"); fi
  for ((i = 0; i < runs; ++i)); do
    rm -f "$out/a.json" "$out/b.json" # (a run that writes none stops the bench, rather than repeat the last figure)
    # shellcheck disable=SC2086 # the arguments are words
    ta=$(seconds "$a" $argsA "${statsA[@]}")
    # shellcheck disable=SC2086
    tb=$(seconds "$b" $argsB "${statsB[@]}")
    as+=("$ta") bs+=("$tb") rs+=("$(awk -v x="$ta" -v y="$tb" 'BEGIN {printf "%.3f", (y > 0 ? x / y : 0)}')")
    if [ "${STATS:-0}" = 1 ]; then ma+=("$(mrays "$out/a.json")") mb+=("$(mrays "$out/b.json")"); fi
  done
  printf '| %s | %s | %s | %s (%s to %s) |' "$name" "$(printf '%s\n' "${as[@]}" | median)" \
    "$(printf '%s\n' "${bs[@]}" | median)" "$(printf '%s\n' "${rs[@]}" | median)" \
    "$(printf '%s\n' "${rs[@]}" | sort -g | head -n 1)" "$(printf '%s\n' "${rs[@]}" | sort -g | tail -n 1)"
  if [ "${STATS:-0}" = 1 ]; then
    printf ' %s | %s |' "$(printf '%s\n' "${ma[@]}" | median)" "$(printf '%s\n' "${mb[@]}" | median)"
  fi
  printf '\n'
}

out=$(mktemp -d)
times="$out/times"
trap 'rm -rf "$out"' EXIT
echo "Chapter 16 against chapter 8, one thread${pin[*]:+ (${pin[*]})}, the same image (CPU seconds, medians of $runs"
echo "alternating runs; $build: ${type:-unknown type}, link-time optimisation ${lto:-unknown}):"
echo
echo "| scene | chapter 16 (s) | chapter 8 (s) | 16 / 8 (range) | chapter 16 (Mrays/s) | chapter 8 (Mrays/s) |"
echo "| --- | --- | --- | --- | --- | --- |"
for spec in "smallpt.json 160 120 64" "cornell.json 160 120 64" "mis.json 160 120 64" \
            "random_spheres.json 320 180 32" "cornell_original.json 160 120 64" "meshes.json 160 120 32"; do
  read -r scene w h spp <<< "$spec"
  args="scenes/$scene --width $w --height $h --spp $spp --threads 1 --quiet -o $out/image.pfm"
  STATS=1 PIN=1 pair "$scene ($w x $h, $spp spp)" "$args" "$args" "$ch16" "$ch8"
done
echo
echo "Chapter 16 on 2 threads against 1 (wall seconds, medians of $runs alternating runs; 2 / 1 below 0.5 is"
echo "more than twice as fast):"
echo
echo "| scene | 2 threads (s) | 1 thread (s) | 2 / 1 (range) |"
echo "| --- | --- | --- | --- |"
args="scenes/smallpt.json --width 320 --height 240 --spp 32 --quiet -o $out/image.pfm"
WALL=1 pair "smallpt.json (320 x 240, 32 spp)" "$args --threads 2" "$args --threads 1" "$ch16" "$ch16"

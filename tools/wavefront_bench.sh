#!/usr/bin/env bash
# Chapter 16 against chapter 8, side by side (docs/benchmarks.md, "Chapter 16: the wavefront"): for each scene the
# two chapters render the same image bit for bit at equal samples per pixel (tests/wavefront), so the ratio of their
# times is the ratio of their equal-time efficiencies. Runs each pair N times, alternating (A B A B ...), one thread,
# and prints the medians of the CPU seconds (user + sys, /usr/bin/time) and of the pair-by-pair ratios; then chapter
# 16 on 2 threads against 1 (wall seconds).
# Usage: tools/wavefront_bench.sh [BUILD_DIR] [RUNS]   (default: build, 5; a release build: cmake --preset release)
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

# seconds COMMAND...: the command's user + sys CPU seconds (or, with WALL=1, its wall seconds).
seconds() {
  local out
  /usr/bin/time -f '%U %S %e' -o "$times" "$@" > /dev/null 2>&1
  out=$(tail -n 1 "$times")
  if [ "${WALL:-0}" = 1 ]; then echo "$out" | awk '{print $3}'; else echo "$out" | awk '{print $1 + $2}'; fi
}
median() { sort -g | awk '{v[NR] = $1} END {print (NR % 2 ? v[(NR + 1) / 2] : (v[NR / 2] + v[NR / 2 + 1]) / 2)}'; }

# pair NAME "ARGS A" "ARGS B" PROGRAM_A PROGRAM_B: medians of A, B and A/B over alternating runs.
pair() {
  local name=$1 argsA=$2 argsB=$3 a=$4 b=$5 ta tb
  local -a as=() bs=() rs=()
  for ((i = 0; i < runs; ++i)); do
    # shellcheck disable=SC2086 # the arguments are words
    ta=$(seconds "$a" $argsA)
    # shellcheck disable=SC2086
    tb=$(seconds "$b" $argsB)
    as+=("$ta") bs+=("$tb") rs+=("$(awk -v x="$ta" -v y="$tb" 'BEGIN {printf "%.3f", (y > 0 ? x / y : 0)}')")
  done
  printf '| %s | %s | %s | %s (%s to %s) |\n' "$name" "$(printf '%s\n' "${as[@]}" | median)" \
    "$(printf '%s\n' "${bs[@]}" | median)" "$(printf '%s\n' "${rs[@]}" | median)" \
    "$(printf '%s\n' "${rs[@]}" | sort -g | head -n 1)" "$(printf '%s\n' "${rs[@]}" | sort -g | tail -n 1)"
}

out=$(mktemp -d)
times="$out/times"
trap 'rm -rf "$out"' EXIT
echo "Chapter 16 against chapter 8, one thread, the same image (CPU seconds, medians of $runs alternating runs):"
echo
echo "| scene | chapter 16 (s) | chapter 8 (s) | 16 / 8 (range) |"
echo "| --- | --- | --- | --- |"
for spec in "smallpt.json 160 120 64" "cornell.json 160 120 64" "mis.json 160 120 64" \
            "random_spheres.json 320 180 32" "cornell_original.json 160 120 64" "meshes.json 160 120 32"; do
  read -r scene w h spp <<< "$spec"
  args="scenes/$scene --width $w --height $h --spp $spp --threads 1 --quiet -o $out/image.pfm"
  pair "$scene ($w x $h, $spp spp)" "$args" "$args" "$ch16" "$ch8"
done
echo
echo "Chapter 16 on 2 threads against 1 (wall seconds, medians of $runs alternating runs; 2 / 1 below 0.5 is"
echo "more than twice as fast):"
echo
echo "| scene | 2 threads (s) | 1 thread (s) | 2 / 1 (range) |"
echo "| --- | --- | --- | --- |"
args="scenes/smallpt.json --width 320 --height 240 --spp 32 --quiet -o $out/image.pfm"
WALL=1 pair "smallpt.json (320 x 240, 32 spp)" "$args --threads 2" "$args --threads 1" "$ch16" "$ch16"

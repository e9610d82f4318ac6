#!/usr/bin/env bash
# Chapter 17 on every OpenCL device, against chapter 16 on all the CPU's threads, in one command (docs/17_opencl.md,
# docs/measurements/17_opencl.md). Builds the opencl preset, lists the devices, then for each scene (the Cornell box,
# the 500 random spheres, a generated mesh of about a million triangles) renders for SECONDS with each and prints one
# table: Mrays/s, and the equal-time efficiency 1/(seconds × relative MSE) as a ratio to chapter 16's, the error
# measured against a reference rendered by chapter 16 for REF_FACTOR × SECONDS (its own error adds a little to
# every row's, the same for all).
# Usage: tools/gpu_bench.sh [SECONDS] [WIDTHxHEIGHT]   (default 5 s, 320x240; a few minutes in all)
set -euo pipefail
cd "$(dirname "$0")/.."
seconds=${1:-5}
size=${2:-320x240}
width=${size%x*}
height=${size#*x}
refFactor=${REF_FACTOR:-6}
build=build-opencl
work="$build/gpu-bench"

echo "== building the opencl preset (./setup.sh --opencl first)"
cmake --preset opencl > /dev/null
cmake --build "$build" -j2 --target step16_wavefront step17_opencl gen_mesh raylife_compare > /dev/null
mkdir -p "$work"
ch16="$build/bin/step16_wavefront"
ch17="$build/bin/step17_opencl"

echo "== OpenCL devices"
"$ch17" --list-devices || { echo "gpu_bench: no OpenCL device" >&2; exit 1; }
devices=$("$ch17" --list-devices | grep -c '^[0-9]*:')

# The mesh: about a million triangles, white, in a room lit by a sphere lamp.
mesh="$work/mesh1m.ply"
[ -f "$mesh" ] || "$build/bin/gen_mesh" 1000000 1 "$mesh" > /dev/null
cat > "$work/mesh1m.json" << 'EOF'
{
  "camera": { "eye": [0, 0.5, 4], "focal": [0, 0, 0], "up": [0, 1, 0], "vfov": 40, "width": 320, "height": 240 },
  "background": [0.1, 0.1, 0.12],
  "materials": {
    "white": { "type": "diffuse", "color": [0.75, 0.75, 0.75] },
    "lamp": { "type": "diffuse", "color": [0, 0, 0], "emission": [20, 18, 15] }
  },
  "spheres": [ { "center": [2, 3, 2], "radius": 0.5, "material": "lamp" },
               { "center": [0, -1001.5, 0], "radius": 1000, "material": "white" } ],
  "meshes": [ { "file": "mesh1m.ply", "material": "white" } ]
}
EOF

# stat FILE KEY: a number from a --stats file.
stat() { sed -n "s/.*\"$2\": \([0-9.e+-]*\).*/\1/p" "$1"; }
# relmse IMAGE REFERENCE: raylife_compare's relative MSE.
relmse() { "$build/bin/raylife_compare" "$1" "$2" --tolerance 1e9 | sed -n 's/^relative MSE *//p'; }

printf '\n%-14s %-44s %9s %10s %12s\n' scene renderer Mrays/s "rel. MSE" "efficiency"
for scene in scenes/cornell.json scenes/random_spheres.json "$work/mesh1m.json"; do
  name=$(basename "$scene" .json)
  common=(--width "$width" --height "$height" --quiet)
  "$ch16" "$scene" "${common[@]}" --time "$(awk "BEGIN {print $seconds * $refFactor}")" --seed 99 -o "$work/$name-ref.pfm"
  "$ch16" "$scene" "${common[@]}" --time "$seconds" -o "$work/$name-16.pfm" --stats "$work/$name-16.json"
  base=$(relmse "$work/$name-16.pfm" "$work/$name-ref.pfm")
  baseSeconds=$(stat "$work/$name-16.json" seconds)
  rows=("chapter 16, $(nproc) CPU threads|$work/$name-16")
  for ((d = 0; d < devices; ++d)); do
    "$ch17" "$scene" "${common[@]}" --device "$d" --time "$seconds" -o "$work/$name-17-$d.pfm" \
      --stats "$work/$name-17-$d.json"
    label=$(sed -n 's/.*"device": "\([^"]*\)".*/\1/p' "$work/$name-17-$d.json")
    rows+=("chapter 17, ${label:0:32}|$work/$name-17-$d")
  done
  for row in "${rows[@]}"; do
    label=${row%%|*}
    file=${row#*|}
    rays=$(stat "$file.json" rays)
    secs=$(stat "$file.json" seconds)
    mse=$(relmse "$file.pfm" "$work/$name-ref.pfm")
    printf '%-14s %-44s %9.2f %10.3g %11.2fx\n' "$name" "$label" "$(awk "BEGIN {print $rays / $secs / 1e6}")" \
      "$mse" "$(awk "BEGIN {print ($base * $baseSeconds) / ($mse * $secs)}")"
  done
done
echo
echo "efficiency: 1/(seconds x relative MSE), as a ratio to chapter 16's on the same scene (higher is better)"

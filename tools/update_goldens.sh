#!/usr/bin/env bash
# Re-renders the goldens raylife_check grades against (tests/golden/): for a deterministic chapter its image at the
# golden's size (.pfm) and its default render (.png); for a Monte Carlo chapter a reference at many samples per
# pixel (.pfm), the variance of each pixel's mean (_variance.pfm) and a .png to look at. What each chapter needs
# comes from raylife_check (tools/check/chapters.h), so a new chapter needs no change here.
# Usage: tools/update_goldens.sh [BUILD_DIR] [CHAPTER...]   (default: build, every chapter)
# RAYLIFE_RANKS=N renders over N MPI ranks (a build of the mpi preset as BUILD_DIR): the same bytes, sooner.
# It stops at once, touching no golden, when the build fails or BUILD_DIR was configured for another tree.
# For each golden that changes it prints how and writes a difference image to BUILD_DIR/golden-review/. Look at
# every one before you commit, and say in the commit why the images changed.
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build}
shift || true
if [ ! -f "$build/CMakeCache.txt" ]; then
  echo "update_goldens: $build is not a configured build folder (cmake --preset release)" >&2
  exit 2
fi
home=$(sed -n 's/^CMAKE_HOME_DIRECTORY:INTERNAL=//p' "$build/CMakeCache.txt")
if [ "$(cd "$home" 2>/dev/null && pwd -P)" != "$(pwd -P)" ]; then
  echo "update_goldens: $build was configured for $home, not for this tree ($(pwd -P)); configure a build here" >&2
  exit 2
fi
check="$build/bin/raylife_check"
if ! cmake --build "$build" -j2 --target raylife_check raylife_compare; then
  echo "update_goldens: the build failed; no golden was touched" >&2
  exit 1
fi
chapters=("$@")
if [ ${#chapters[@]} -eq 0 ]; then
  mapfile -t chapters < <("$check" --list)
  # Chapter 17 is built only with RAYLIFE_OPENCL (cmake --preset opencl): a build without it leaves its golden be.
  if ! grep -q '^RAYLIFE_OPENCL:BOOL=ON' "$build/CMakeCache.txt"; then
    mapfile -t chapters < <(printf '%s\n' "${chapters[@]}" | grep -vx step17_opencl)
  fi
fi
binaries=()
for chapter in "${chapters[@]}"; do
  command=$("$check" "$chapter" 2>/dev/null) || {
    echo "update_goldens: raylife_check knows no chapter '$chapter'" >&2
    exit 2
  }
  binaries+=("$(basename "${command%% *}")")
done
if ! cmake --build "$build" -j2 --target "${binaries[@]}"; then
  echo "update_goldens: the build failed; no golden was touched" >&2
  exit 1
fi
export RAYLIFE_SCENES="$PWD/scenes" # this tree's scenes, whatever the build
review="$build/golden-review"
updated=()
rm -rf "$review"
mkdir -p "$review"
for chapter in "${binaries[@]}"; do
  echo "$chapter: rendering"
  "$check" --reference "$chapter" "$review" | while IFS= read -r command; do
    bash -c "${RAYLIFE_RANKS:+mpirun -np $RAYLIFE_RANKS} $command" || {
      echo "update_goldens: failed: $command" >&2
      exit 1
    }
  done
  for new in "$review/$chapter".pfm "$review/$chapter".png "$review/${chapter}"_variance.pfm; do
    [ -f "$new" ] || continue
    old="tests/golden/$(basename "$new")"
    if [ -f "$old" ] && cmp -s "$new" "$old"; then
      echo "  $(basename "$new"): unchanged"
      continue
    fi
    if [ ! -f "$old" ]; then
      echo "  $(basename "$new"): new"
    elif [[ "$new" == *.pfm && "$new" != *_variance.pfm ]]; then
      echo "  $(basename "$new"): CHANGED; the new one graded against the old:"
      "$check" "$chapter" "$new" --diff "$review/$chapter-difference.png" | sed 's/^/    /' || true
      "$build/bin/raylife_compare" "$new" "$old" --diff "$review/$chapter-absolute-difference.png" --gain 10 |
        sed 's/^/    /' || true
    else
      echo "  $(basename "$new"): CHANGED"
    fi
    updated+=("$new")
  done
done
for new in "${updated[@]}"; do
  cp "$new" tests/golden/
done
echo "Review the images and differences in $review, then commit tests/golden with the reason for the change."

#!/usr/bin/env bash
# Re-renders the golden images of the deterministic chapters (tests/golden/<chapter>.pfm, and a .png to look at)
# and, for each one that changes, writes a difference image (x10) and prints the metrics first.
# Usage: tools/update_goldens.sh [BUILD_DIR] [CHAPTER...]   (default: build, every golden chapter)
# Look at every difference image before you commit, and say in the commit why the images changed.
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build}
shift || true
chapters=("$@")
[ ${#chapters[@]} -gt 0 ] || chapters=(step01_camera step02_sphere step03_lambert step04_shadows step09_bvh step10_meshes)
review="$build/golden-review"
mkdir -p "$review"
cmake --build "$build" -j2 >/dev/null
for chapter in "${chapters[@]}"; do
  new="$review/$chapter.pfm"
  "$build/bin/$chapter" --width 160 --height 120 --quiet -o "$new" -o "$review/$chapter.png"
  old="tests/golden/$chapter.pfm"
  if [ -f "$old" ]; then
    if cmp -s "$new" "$old"; then
      echo "$chapter: unchanged"
      continue
    fi
    echo "$chapter: CHANGED; difference image: $review/$chapter-difference.png"
    "$build/bin/raylife_compare" "$new" "$old" --tolerance 1e-4 --diff "$review/$chapter-difference.png" || true
  else
    echo "$chapter: new golden image"
  fi
  cp "$new" "$old"
  cp "$review/$chapter.png" "tests/golden/$chapter.png"
done
echo "Review the images in $review, then commit tests/golden with the reason for the change."

#!/usr/bin/env bash
# Cache figures of chapter 8 (one path at a time) against chapter 16 (the wavefront's queues) on smallpt
# (docs/benchmarks.md, "Cache figures: one path at a time against the wavefront"). There are no hardware counters in
# the machines this was written on, so the caches are valgrind's cachegrind: a simulation of an L1 (this CPU's sizes)
# and one last level, given here (LL=SIZE,WAYS,LINE; default 1 MiB, 16 ways: the L2 of one core; 33554432,16,64 is
# an L3 of 32 MiB). Each run is made at SPP and at 2·SPP samples per pixel, and the figures per ray are the
# difference over the difference in rays: what loading the scene and setting up the light guide cost is taken out.
# Prints a Markdown table.
# Usage: tools/wavefront_cachegrind.sh [BUILD_DIR] [LL] [WIDTH HEIGHT SPP]   (default: build 1048576,16,64 64 48 4)
#
# Two things valgrind changes, undone by a small library preloaded (built here, in a temporary folder):
# - libhwy's static initialiser reads the time stamp counter with RDTSCP, which valgrind 3.19 cannot decode: the
#   library's hwy::platform::TimerResolution returns a constant instead;
# - the render loop cuts its batches of samples to a quarter of a second (render_loop.cpp), and under valgrind
#   everything runs about 50 to 100 times slower, so a tile's batch, and with it the wavefront's queues, would stay
#   small: the library's clock_gettime runs 100 times slow, so that batches grow as they do outside valgrind.
# Under valgrind, Highway also sees the CPU valgrind presents, without AVX-512: chapter 16's kernels run AVX2 there.
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build}
ll=${2:-1048576,16,64}
width=${3:-64}
height=${4:-48}
spp=${5:-4}
ch8="$build/bin/step08_mis"
ch16="$build/bin/step16_wavefront"
for program in "$ch8" "$ch16"; do
  [ -x "$program" ] || { echo "wavefront_cachegrind: no $program (cmake --build --preset test)" >&2; exit 2; }
done
command -v valgrind > /dev/null || { echo "wavefront_cachegrind: needs valgrind" >&2; exit 2; }
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cat > "$work/shim.cpp" << 'SHIM'
#include <cstdint>
#include <dlfcn.h>
#include <time.h>
namespace hwy::platform {
std::uint64_t TimerResolution() { return 1; }
}
// Every clock runs 100 times slow from its first reading (one thread reads them: --threads 1).
extern "C" int clock_gettime(clockid_t id, timespec* ts)
{
  using Function = int (*)(clockid_t, timespec*);
  static const Function real = reinterpret_cast<Function>(dlsym(RTLD_NEXT, "clock_gettime"));
  static long double first[16];
  static bool seen[16];
  const int r = real(id, ts);
  if (r != 0 || id < 0 || id >= 16)
    return r;
  const long double t = (long double)ts->tv_sec + 1e-9L * (long double)ts->tv_nsec;
  if (!seen[id])
    seen[id] = true, first[id] = t;
  const long double slow = first[id] + (t - first[id]) / 100;
  ts->tv_sec = time_t(slow);
  ts->tv_nsec = long((slow - (long double)ts->tv_sec) * 1e9L);
  return 0;
}
SHIM
g++ -O2 -shared -fPIC -o "$work/shim.so" "$work/shim.cpp" -ldl

# measure SPP PROGRAM ARGS...: "rays Irefs D1misses LLmisses" of one run under cachegrind.
measure() {
  local s=$1 program=$2
  shift 2
  LD_PRELOAD="$work/shim.so" valgrind --tool=cachegrind --cache-sim=yes --LL="$ll" \
    --cachegrind-out-file=/dev/null "$program" scenes/smallpt.json --width "$width" --height "$height" --spp "$s" \
    --threads 1 -o "$work/x.png" "$@" > "$work/log" 2>&1
  local rays irefs d1 llm
  rays=$(grep -o '[0-9]* rays,' "$work/log" | tr -dc 0-9)
  irefs=$(grep 'I *refs:' "$work/log" | awk '{print $4}' | tr -d ,)
  d1=$(grep 'D1 *misses:' "$work/log" | awk '{print $4}' | tr -d ,)
  llm=$(grep 'LL misses:' "$work/log" | awk '{print $4}' | tr -d ,)
  echo "$rays $irefs $d1 $llm"
}

echo "smallpt.json at ${width}x${height}, $spp and $((2 * spp)) spp, one thread. Simulated caches: D1 as this" \
  "CPU's ($(getconf LEVEL1_DCACHE_SIZE) B), LL $ll (size,ways,line)."
echo
echo "| run | rays ($((2 * spp)) − $spp spp) | I refs / ray | D1 misses / ray | LL misses / ray |" \
  "$spp spp, all in: I, D1, LL / ray |"
echo "|---|---:|---:|---:|---:|---|"
row() {
  local name=$1 program=$2
  shift 2
  read -r r1 i1 d1 l1 <<< "$(measure "$spp" "$program" "$@")"
  read -r r2 i2 d2 l2 <<< "$(measure $((2 * spp)) "$program" "$@")"
  awk -v n="$name" -v r1="$r1" -v i1="$i1" -v d1="$d1" -v l1="$l1" -v r2="$r2" -v i2="$i2" -v d2="$d2" -v l2="$l2" \
    'BEGIN { dr = r2 - r1; printf "| %s | %d | %.0f | %.2f | %.3f | %.0f, %.2f, %.3f |\n", n, dr, (i2 - i1) / dr,
             (d2 - d1) / dr, (l2 - l1) / dr, i1 / r1, d1 / r1, l1 / r1 }'
}
row "chapter 8 (one path at a time)" "$ch8"
for w in 64 512 4096 32768 262144; do
  row "chapter 16 --wavefront $w" "$ch16" --wavefront "$w"
done

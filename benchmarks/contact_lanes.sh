#!/usr/bin/env bash
# What SIMD lanes would give the contact kernel: benchmarks/contact_lanes.cpp built without
# lanes, with SSE2 lanes (the portable baseline) and, where the processor has it, AVX2 lanes
# (no FMA, so that every build computes the same bits). Checks that the builds agree bit for
# bit, then times them alternately.
#
# usage: benchmarks/contact_lanes.sh [REPS] [ROUNDS]   (defaults 400 passes, 3 rounds)
# Builds into build/contact_lanes (ignored by git). Needs g++ (build-essential).
set -euo pipefail
REPS=${1:-400}
ROUNDS=${2:-3}
for v in "$REPS" "$ROUNDS"; do
  [[ "$v" =~ ^[1-9][0-9]*$ ]] || { echo "$0: error: '$v' is not a positive integer" >&2; exit 2; }
done
ROOT=$(cd "$(dirname "$0")/.." && pwd)
OUT=$ROOT/build/contact_lanes
mkdir -p "$OUT"
SRC=$ROOT/benchmarks/contact_lanes.cpp
FLAGS=(-O3 -std=c++17 -fno-math-errno -fno-trapping-math -fopenmp-simd)
g++ "${FLAGS[@]}" "$SRC" -o "$OUT/scalar"
g++ "${FLAGS[@]}" -DLANES "$SRC" -o "$OUT/sse2"
builds=(scalar sse2)
if grep -qw avx2 /proc/cpuinfo 2>/dev/null; then
  g++ "${FLAGS[@]}" -DLANES -mavx2 "$SRC" -o "$OUT/avx2"
  builds+=(avx2)
fi
for b in "${builds[@]}"; do "$OUT/$b" 3 "$OUT/$b.out" > /dev/null; done
for b in "${builds[@]}"; do
  if cmp -s "$OUT/scalar.out" "$OUT/$b.out"; then
    echo "$b: same forces, torques and springs as scalar, bit for bit"
  else
    echo "$0: error: $b differs from scalar" >&2
    exit 1
  fi
done
declare -A best
for ((k = 1; k <= ROUNDS; k++)); do
  for b in "${builds[@]}"; do
    t=$("$OUT/$b" "$REPS" | sed -n 's/^ns_per_contact=\([0-9.]*\).*/\1/p')
    echo "round $k $b ns_per_contact=$t"
    best[$b]=$(awk -v a="${best[$b]:-1e30}" -v b="$t" 'BEGIN { print (b < a) ? b : a }')
  done
done
for b in "${builds[@]}"; do
  awk -v b="$b" -v t="${best[$b]}" -v s="${best[scalar]}" \
    'BEGIN { printf "%s: best %.2f ns per contact, %.2fx scalar\n", b, t, s / t }'
done

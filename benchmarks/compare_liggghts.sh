#!/usr/bin/env bash
# millscope against the LIGGGHTS yardstick on the same scene, the same dt and the same machine,
# back to back: the paper-scale pilot mill at 71 % of critical, timed from a tumbling state.
#
# usage: benchmarks/compare_liggghts.sh STEPS [NPROCS] [SCENE] [REPEAT]
#   STEPS    timed steps of each code (>= 2)
#   NPROCS   LIGGGHTS MPI processes and millscope threads (default 2)
#   SCENE    balls (default): 2466 steel balls of 25 mm, the yardstick's own scene and state,
#              dt = the yardstick's 2.5e-6 s;
#            ceramic4: the balls plus load level #4 of 12 mm ceramic particles (18 714 in all).
#              LIGGGHTS continues millscope's cached tumbling state, written by
#              benchmarks/liggghts_state.py (positions, velocities, spins; the mesh turned to
#              the state's drum angle), at millscope's dt (0.2 x the ball Rayleigh time).
#   REPEAT   pairs of runs, LIGGGHTS then millscope in each (default 1); with more than one,
#            each pair's ratio and the medians are printed
# environment:
#   LIGGGHTS_YARDSTICK  the yardstick folder (default ../shared/yardstick/liggghts from the
#                       repository root); its run.sh does the LIGGGHTS side
#   WORKDIR             LIGGGHTS work files (run.sh's default /tmp/millscope-yardstick)
#   PYTHON              the Python with millscope (default .venv/bin/python of the repository)
#   SPIN_UP             millscope's rotation before timing, s (default 1.0, as the yardstick)
#
# The first call prepares the tumbling states (balls: LIGGGHTS 0.5 s settling + 1.0 s rotation;
# millscope: fill, settle, SPIN_UP s of rotation, cached in out/bench-cache): minutes, not
# timed. LIGGGHTS then runs 2000 untimed warm-up steps before its timed STEPS; millscope times
# from the cached state directly. Repeat runs scatter by 10-20 % on a shared machine: take
# several pairs (REPEAT) and compare their median ratio.
# Before each millscope run with NPROCS > 1 it prints core_handoff_ns (benchmarks/core_handoff.cpp,
# built here with g++ when there is one): the time a cache line takes from one core to the
# other. On a VM it changes with where the host puts the vCPUs (about 30 ns when they share a
# last-level cache, 160 ns when not, on this project's machine), and millscope's threads, which
# meet twice a step, slow down with it.
# Last lines: both particle_steps_per_s and their ratio (with REPEAT > 1: the medians over the
# pairs, and the median of the pairs' ratios).
set -euo pipefail

usage="usage: $0 STEPS [NPROCS] [SCENE: balls or ceramic4] [REPEAT]"
STEPS=${1:?$usage}
NP=${2:-2}
SCENE=${3:-balls}
REPEAT=${4:-1}
case "$SCENE" in
  balls|ceramic4) ;;
  *) echo "$0: error: SCENE = '$SCENE' is not valid; it must be balls or ceramic4" >&2; exit 2 ;;
esac
for v in "$STEPS" "$NP" "$REPEAT"; do
  [[ "$v" =~ ^[0-9]+$ ]] || { echo "$0: error: '$v' is not a positive integer; $usage" >&2; exit 2; }
done
[ "$STEPS" -ge 2 ] || { echo "$0: error: STEPS = $STEPS is not valid; it must be >= 2" >&2; exit 2; }
[ "$NP" -ge 1 ] || { echo "$0: error: NPROCS = $NP is not valid; it must be >= 1" >&2; exit 2; }
[ "$REPEAT" -ge 1 ] || { echo "$0: error: REPEAT = $REPEAT is not valid; it must be >= 1" >&2; exit 2; }

ROOT=$(cd "$(dirname "$0")/.." && pwd)
YARD=${LIGGGHTS_YARDSTICK:-$ROOT/../shared/yardstick/liggghts}
PY=${PYTHON:-$ROOT/.venv/bin/python}
SPIN_UP=${SPIN_UP:-1.0}

missing=()
command -v liggghts >/dev/null 2>&1 || missing+=(liggghts)
if [ "$NP" -gt 1 ]; then command -v mpirun >/dev/null 2>&1 || missing+=(mpirun); fi
if [ ${#missing[@]} -gt 0 ]; then
  echo "$0: error: ${missing[*]} not found. Install LIGGGHTS and Open MPI (Debian/Ubuntu, as" \
       "root or with sudo): apt-get install -y liggghts openmpi-bin" >&2
  exit 1
fi
if [ ! -f "$YARD/run.sh" ] || [ ! -f "$YARD/in.mill_bench" ]; then
  echo "$0: error: no LIGGGHTS yardstick (run.sh, in.mill_bench) in '$YARD'; set" \
       "LIGGGHTS_YARDSTICK to its folder" >&2
  exit 1
fi
if [ ! -x "$PY" ]; then
  echo "$0: error: no Python at '$PY'; run scripts/setup.sh, or set PYTHON" >&2
  exit 1
fi

cd "$ROOT"
WARMUP=2000

# The core-to-core hand-off probe (a diagnostic: skipped without a C++ compiler).
HANDOFF=""
if [ "$NP" -gt 1 ] && command -v g++ >/dev/null 2>&1; then
  PROBE_DIR=$(mktemp -d)
  trap 'rm -rf "$PROBE_DIR"' EXIT
  if g++ -O2 -pthread "$ROOT/benchmarks/core_handoff.cpp" -o "$PROBE_DIR/core_handoff"; then
    HANDOFF=$PROBE_DIR/core_handoff
  else
    echo "$0: warning: benchmarks/core_handoff.cpp did not build; no core_handoff_ns" >&2
  fi
fi

if [ "$SCENE" = balls ]; then
  # The yardstick's time step, read from its input so that both codes run the same dt.
  DT=$(sed -n 's/^[[:space:]]*variable[[:space:]]\{1,\}dtv[[:space:]]\{1,\}equal[[:space:]]\{1,\}\([0-9.eE+-]\{1,\}\).*/\1/p' \
    "$YARD/in.mill_bench" | head -n 1)
  if [ -z "$DT" ]; then
    echo "$0: error: no 'variable dtv equal ...' time step in $YARD/in.mill_bench" >&2
    exit 1
  fi
  "$PY" - "$DT" <<'PY'
import sys
import millscope as ms
from millscope.contact import DEFAULT_DT_FRACTION
dt = float(sys.argv[1])
t_r = ms.presets.pilot_mill(0.71, None, scale="paper").min_rayleigh_time()[0]
print(f"dt: yardstick {dt:.6g} s = {dt / t_r:.4f} x the ball Rayleigh time {t_r:.5g} s; "
      f"millscope's default {DEFAULT_DT_FRACTION:g} x = {DEFAULT_DT_FRACTION * t_r:.5g} s; "
      f"both run {dt:.6g} s")
PY
  MS_DT=(--dt "$DT")
else
  # LIGGGHTS continues millscope's own tumbling state of the scene.
  W=${WORKDIR:-/tmp/millscope-yardstick}/$SCENE
  mkdir -p "$W"
  "$PY" "$ROOT/benchmarks/liggghts_state.py" "$SCENE" "$W" --spin-up "$SPIN_UP"
  # shellcheck disable=SC1090
  . "$W/$SCENE.vars"
  DT=$dt
  if [ "$mesh_type" != 1 ]; then
    echo "$0: error: the drum's material is type $mesh_type; the yardstick's mesh is type 1" >&2
    exit 1
  fi
  python3 "$YARD/make_mill_stl.py" "$W/mill_$SCENE.stl" --phase-deg "$phase_deg" > /dev/null
  cp "$YARD/common_fixes.in" "$W/"
  echo "dt: millscope's state, $DT s (0.2 x the ball Rayleigh time); lifter 0 at $phase_deg deg"
  if [ "$NP" -gt 1 ]; then LAUNCH=(mpirun --allow-run-as-root -np "$NP" liggghts); else LAUNCH=(liggghts); fi
  MS_DT=()
fi

# One LIGGGHTS run of the scene; prints its particle_steps_per_s line last.
run_liggghts() {
  if [ "$SCENE" = balls ]; then
    echo "== LIGGGHTS yardstick: $STEPS steps on $NP process(es)"
    bash "$YARD/run.sh" "$STEPS" "$NP" || {
      echo "$0: error: the LIGGGHTS run failed; see out.setup, out.bench and log.* in" \
           "${WORKDIR:-/tmp/millscope-yardstick}" >&2
      return 1
    }
    return 0
  fi
  echo "== LIGGGHTS from millscope's state: $WARMUP warm-up + $STEPS steps on $NP process(es)"
  (cd "$W" && "${LAUNCH[@]}" -in "$ROOT/benchmarks/liggghts/in.mill_from_state" -log log.state \
     -var datafile "$SCENE.data" -var mats "${SCENE}_materials.in" -var stl "mill_$SCENE.stl" \
     -var common common_fixes.in -var dt "$DT" -var period "$period" -var skin 0.005 \
     -var px 1 -var py 1 -var pz "$NP" -var warmup "$WARMUP" -var nsteps "$STEPS" \
     -var tag "$SCENE" > out.state 2>&1) || {
    echo "$0: error: the LIGGGHTS run failed; see out.state and log.state in $W" >&2
    return 1
  }
  # The timed run's own figure: "Loop time of WALL on P procs for N steps with M atoms, ..."
  local loop wall procs n atoms
  loop=$(grep '^Loop time of' "$W/log.state" | tail -n 1)
  read -r wall procs n atoms <<< "$(echo "$loop" | awk '{print $4, $6, $9, $12}')"
  if [ -z "$loop" ] || [ "$n" != "$STEPS" ]; then
    echo "$0: error: no timed loop of $STEPS steps in $W/log.state" >&2
    return 1
  fi
  awk -v w="$wall" -v p="$procs" -v n="$n" -v a="$atoms" 'BEGIN {
    printf "procs=%d particles=%d steps=%d loop_wall_s=%.3f\n", p, a, n, w
    printf "particle_steps_per_s=%.6g\n", a * n / w }'
}

# The median of the numbers given as arguments.
median() {
  printf '%s\n' "$@" | sort -g | awk '{ v[NR] = $1 } END {
    if (NR % 2) print v[(NR + 1) / 2]; else printf "%.6g\n", (v[NR / 2] + v[NR / 2 + 1]) / 2 }'
}

# Each pair is also appended to benchmarks/results/compare_liggghts.csv (CSV=... to change).
CSV=${CSV:-$ROOT/benchmarks/results/compare_liggghts.csv}
CPU_MODEL=$(sed -n 's/^model name[[:space:]]*:[[:space:]]*//p' /proc/cpuinfo 2>/dev/null | head -n 1 | tr ',' ' ')
SIMD_PATH=$("$PY" -c 'from millscope import _core; print(_core.simd_path()[0])' 2>/dev/null || echo unknown)
STAMP=$(date -u +%Y-%m-%dT%H:%M:%SZ)
mkdir -p "$(dirname "$CSV")"
[ -s "$CSV" ] || echo "utc,cpu,simd_path,scene,nprocs,steps,dt_s,pair,liggghts_particle_steps_per_s,millscope_particle_steps_per_s,ratio,core_handoff_ns" > "$CSV"

ligs=(); mss=(); ratios=()
for ((k = 1; k <= REPEAT; k++)); do
  if [ "$REPEAT" -gt 1 ]; then echo "== pair $k of $REPEAT"; fi
  lig_out=$(run_liggghts) || { echo "$lig_out"; exit 1; }
  echo "$lig_out"
  lig=$(echo "$lig_out" | sed -n 's/^particle_steps_per_s=//p' | tail -n 1)

  echo "== millscope: $STEPS steps on $NP thread(s)"
  handoff=""
  if [ -n "$HANDOFF" ]; then
    # a diagnostic: if it fails, the comparison goes on without it
    handoff=$("$HANDOFF" | sed -n 's/^core_handoff_ns=//p') || handoff=""
    echo "core_handoff_ns=$handoff"
  fi
  ms_out=$("$PY" -m millscope bench --scale paper --scenes "$SCENE" --threads "$NP" \
    --steps "$STEPS" "${MS_DT[@]}" --spin-up "$SPIN_UP")
  echo "$ms_out"
  ms=$(echo "$ms_out" | sed -n 's/^particle_steps_per_s=//p' | tail -n 1)

  if [ -z "$lig" ] || [ -z "$ms" ]; then
    echo "$0: error: a run printed no particle_steps_per_s line" >&2
    exit 1
  fi
  ligs+=("$lig"); mss+=("$ms")
  ratios+=("$(awk -v m="$ms" -v l="$lig" 'BEGIN { printf "%.3f", m / l }')")
  if [ "$REPEAT" -gt 1 ]; then
    echo "pair $k: ratio ${ratios[-1]}${handoff:+ (core hand-off $handoff ns)}"
  fi
  echo "$STAMP,$CPU_MODEL,$SIMD_PATH,$SCENE,$NP,$STEPS,$DT,$k,$lig,$ms,${ratios[-1]},$handoff" >> "$CSV"
done

echo "== same scene ($SCENE), dt = $DT s, $STEPS steps, $NP process(es)/thread(s)"
if [ "$REPEAT" -gt 1 ]; then
  echo "$REPEAT pairs, ratios: ${ratios[*]}; the lines below are medians"
fi
echo "liggghts_particle_steps_per_s=$(median "${ligs[@]}")"
echo "millscope_particle_steps_per_s=$(median "${mss[@]}")"
echo "ratio_millscope_over_liggghts=$(median "${ratios[@]}")"

#!/usr/bin/env bash
# millscope against the LIGGGHTS yardstick on the same scene, the same dt and the same machine,
# back to back: the paper-scale pilot mill at 71 % of critical, timed from a tumbling state.
#
# usage: benchmarks/compare_liggghts.sh STEPS [NPROCS] [SCENE]
#   STEPS    timed steps of each code (>= 2)
#   NPROCS   LIGGGHTS MPI processes and millscope threads (default 2)
#   SCENE    balls (default): 2466 steel balls of 25 mm, the yardstick's own scene and state,
#              dt = the yardstick's 2.5e-6 s;
#            ceramic4: the balls plus load level #4 of 12 mm ceramic particles (18 714 in all).
#              LIGGGHTS continues millscope's cached tumbling state, written by
#              benchmarks/liggghts_state.py (positions, velocities, spins; the mesh turned to
#              the state's drum angle), at millscope's dt (0.2 x the ball Rayleigh time).
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
# from the cached state directly. Repeat runs scatter by about 10 %: compare several times.
# Last lines: both particle_steps_per_s and their ratio.
set -euo pipefail

usage="usage: $0 STEPS [NPROCS] [SCENE: balls or ceramic4]"
STEPS=${1:?$usage}
NP=${2:-2}
SCENE=${3:-balls}
case "$SCENE" in
  balls|ceramic4) ;;
  *) echo "$0: error: SCENE = '$SCENE' is not valid; it must be balls or ceramic4" >&2; exit 2 ;;
esac
for v in "$STEPS" "$NP"; do
  [[ "$v" =~ ^[0-9]+$ ]] || { echo "$0: error: '$v' is not a positive integer; $usage" >&2; exit 2; }
done
[ "$STEPS" -ge 2 ] || { echo "$0: error: STEPS = $STEPS is not valid; it must be >= 2" >&2; exit 2; }
[ "$NP" -ge 1 ] || { echo "$0: error: NPROCS = $NP is not valid; it must be >= 1" >&2; exit 2; }

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

  echo "== LIGGGHTS yardstick: $STEPS steps on $NP process(es)"
  lig_out=$(bash "$YARD/run.sh" "$STEPS" "$NP") || {
    echo "$0: error: the LIGGGHTS run failed; see out.setup, out.bench and log.* in" \
         "${WORKDIR:-/tmp/millscope-yardstick}" >&2
    exit 1
  }
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
  echo "== LIGGGHTS from millscope's state: $WARMUP warm-up + $STEPS steps on $NP process(es)"
  (cd "$W" && "${LAUNCH[@]}" -in "$ROOT/benchmarks/liggghts/in.mill_from_state" -log log.state \
     -var datafile "$SCENE.data" -var mats "${SCENE}_materials.in" -var stl "mill_$SCENE.stl" \
     -var common common_fixes.in -var dt "$DT" -var period "$period" -var skin 0.005 \
     -var px 1 -var py 1 -var pz "$NP" -var warmup "$WARMUP" -var nsteps "$STEPS" \
     -var tag "$SCENE" > out.state 2>&1) || {
    echo "$0: error: the LIGGGHTS run failed; see out.state and log.state in $W" >&2
    exit 1
  }
  # The timed run's own figure: "Loop time of WALL on P procs for N steps with M atoms, ..."
  loop=$(grep '^Loop time of' "$W/log.state" | tail -n 1)
  read -r wall procs n atoms <<< "$(echo "$loop" | awk '{print $4, $6, $9, $12}')"
  if [ -z "$loop" ] || [ "$n" != "$STEPS" ]; then
    echo "$0: error: no timed loop of $STEPS steps in $W/log.state" >&2
    exit 1
  fi
  lig_out=$(awk -v w="$wall" -v p="$procs" -v n="$n" -v a="$atoms" 'BEGIN {
    printf "procs=%d particles=%d steps=%d loop_wall_s=%.3f\n", p, a, n, w
    printf "particle_steps_per_s=%.6g\n", a * n / w }')
  MS_DT=()
fi
echo "$lig_out"
lig=$(echo "$lig_out" | sed -n 's/^particle_steps_per_s=//p' | tail -n 1)

echo "== millscope: $STEPS steps on $NP thread(s)"
ms_out=$("$PY" -m millscope bench --scale paper --scenes "$SCENE" --threads "$NP" \
  --steps "$STEPS" "${MS_DT[@]}" --spin-up "$SPIN_UP")
echo "$ms_out"
ms=$(echo "$ms_out" | sed -n 's/^particle_steps_per_s=//p' | tail -n 1)

if [ -z "$lig" ] || [ -z "$ms" ]; then
  echo "$0: error: a run printed no particle_steps_per_s line" >&2
  exit 1
fi
echo "== same scene ($SCENE), dt = $DT s, $STEPS steps, $NP process(es)/thread(s)"
echo "liggghts_particle_steps_per_s=$lig"
echo "millscope_particle_steps_per_s=$ms"
awk -v m="$ms" -v l="$lig" 'BEGIN { printf "ratio_millscope_over_liggghts=%.3f\n", m / l }'

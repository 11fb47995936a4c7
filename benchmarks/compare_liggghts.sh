#!/usr/bin/env bash
# millscope against the LIGGGHTS yardstick on the same scene, the same dt and the same machine,
# back to back: the paper-scale pilot mill with balls only (2466 steel balls of 25 mm, 71 % of
# critical), timed from a tumbling state.
#
# usage: benchmarks/compare_liggghts.sh STEPS [NPROCS]
#   STEPS    timed steps of each code (>= 2)
#   NPROCS   LIGGGHTS MPI processes and millscope threads (default 2)
# environment:
#   LIGGGHTS_YARDSTICK  the yardstick folder (default ../shared/yardstick/liggghts from the
#                       repository root); its run.sh does the LIGGGHTS side
#   WORKDIR             LIGGGHTS work files (run.sh's default /tmp/millscope-yardstick)
#   PYTHON              the Python with millscope (default .venv/bin/python of the repository)
#   SPIN_UP             millscope's rotation before timing, s (default 1.0, as the yardstick)
#
# The first call prepares both tumbling states (LIGGGHTS: 0.5 s settling + 1.0 s rotation;
# millscope: fill, settle, SPIN_UP s of rotation, cached in out/bench-cache): minutes, not
# timed. LIGGGHTS then runs 2000 untimed warm-up steps before its timed STEPS; millscope times
# from the cached state directly. Repeat runs scatter by about 10 %: compare several times.
# Last lines: both particle_steps_per_s and their ratio.
set -euo pipefail

usage="usage: $0 STEPS [NPROCS]"
STEPS=${1:?$usage}
NP=${2:-2}
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

# The yardstick's time step, read from its input so that both codes run the same dt.
DT=$(sed -n 's/^[[:space:]]*variable[[:space:]]\{1,\}dtv[[:space:]]\{1,\}equal[[:space:]]\{1,\}\([0-9.eE+-]\{1,\}\).*/\1/p' \
  "$YARD/in.mill_bench" | head -n 1)
if [ -z "$DT" ]; then
  echo "$0: error: no 'variable dtv equal ...' time step in $YARD/in.mill_bench" >&2
  exit 1
fi
cd "$ROOT"
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
echo "$lig_out"
lig=$(echo "$lig_out" | sed -n 's/^particle_steps_per_s=//p' | tail -n 1)

echo "== millscope: $STEPS steps on $NP thread(s)"
ms_out=$("$PY" -m millscope bench --scale paper --scenes balls --threads "$NP" \
  --steps "$STEPS" --dt "$DT" --spin-up "$SPIN_UP")
echo "$ms_out"
ms=$(echo "$ms_out" | sed -n 's/^particle_steps_per_s=//p' | tail -n 1)

if [ -z "$lig" ] || [ -z "$ms" ]; then
  echo "$0: error: a run printed no particle_steps_per_s line" >&2
  exit 1
fi
echo "== same scene, dt = $DT s, $STEPS steps, $NP process(es)/thread(s)"
echo "liggghts_particle_steps_per_s=$lig"
echo "millscope_particle_steps_per_s=$ms"
awk -v m="$ms" -v l="$lig" 'BEGIN { printf "ratio_millscope_over_liggghts=%.3f\n", m / l }'

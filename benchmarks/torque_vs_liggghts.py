"""Mean drive torque of millscope against LIGGGHTS 3.8 on the identical scene and state.

    python benchmarks/torque_vs_liggghts.py [--cases balls 1 2 3] [--spin-up 1.0]
        [--length 1.5] [--skip 0.1] [--nprocs 1] [--workdir /tmp/millscope-torque]

For each case (``balls``: the balls-only pilot mill; ``1``..``7``: load level k of ceramic
particles, LDMS#k), at the paper's scale and stiffness, 71 % of critical, millscope's default
dt (0.2 x the smallest Rayleigh time):

1. millscope fills, settles and turns the drum for ``--spin-up`` s, and keeps that state (a
   checkpoint, reused by later calls);
2. millscope continues the state for ``--length`` s, recording the drive torque as 10 ms
   interval means;
3. LIGGGHTS (``gran model hertz tangential history``, the yardstick's drum mesh turned to the
   state's drum angle) continues the same state for as many steps (the state goes over as a
   data file, :mod:`liggghts_state`; LIGGGHTS has no tangential springs in a data file, so they
   start at zero), recording the mean of the mesh torque over every 4000 steps (10.6 ms).

Each code's mean torque over [``--skip``, ``--length``] s of the continuation is printed with
its standard error from 0.1 s blocks (the two runs part ways within a few tenths of a second,
so their difference is a difference of two noisy means), and a row per case is appended to
``benchmarks/results/torque_vs_liggghts.csv``. The skip lets LIGGGHTS' springs build up: over
its first 0.1 s it reads less torque than millscope from the same state (12-14 % on the balls,
4-5 % on LDMS#1), and the two agree from then on.

Each stage's output is kept in a folder of ``--workdir`` named by the case, the seed, the
spin-up and the length, and reused when present (``--fresh`` redoes them); each case's row is
appended as soon as the case is done. LIGGGHTS comes from Debian (``apt-get install liggghts
openmpi-bin``); nothing of it is in the package. With the defaults, LIGGGHTS took 8 (balls),
15 (LDMS#1) and 30 (LDMS#3) minutes of one core per case, and millscope less than half of that.
"""

from __future__ import annotations

import argparse
import datetime
import math
import os
import shutil
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

import millscope as ms
from millscope.engine.simulation import Simulation

sys.path.insert(0, str(Path(__file__).resolve().parent))
import liggghts_state  # noqa: E402  (this folder's module)

ROOT = Path(__file__).resolve().parent.parent
YARDSTICK = Path(os.environ.get("LIGGGHTS_YARDSTICK", ROOT.parent / "shared/yardstick/liggghts"))
RESULTS = ROOT / "benchmarks/results/torque_vs_liggghts.csv"
SPEED_FRACTION = 0.71
SAMPLE_DT_S = 0.01
BLOCK_S = 0.1


@dataclass(frozen=True)
class Mean:
    """A mean torque over a window, N m, and its standard error from blocks."""

    value: float
    standard_error: float
    blocks: int


def block_mean(time_s: np.ndarray, torque: np.ndarray, skip_s: float) -> Mean:
    """Mean of the samples whose interval starts at or after ``skip_s``, with the standard
    error of the means of whole BLOCK_S blocks."""
    kept = torque[time_s >= skip_s - 1e-9]
    per_block = max(1, round(BLOCK_S / float(np.median(np.diff(time_s)))))
    n = len(kept) // per_block
    if n < 2:
        raise SystemExit(f"error: fewer than 2 blocks of {BLOCK_S} s after the skip; "
                         f"give a longer --length or a shorter --skip")
    means = kept[: n * per_block].reshape(n, per_block).mean(axis=1)
    return Mean(float(kept.mean()), float(means.std(ddof=1) / math.sqrt(n)), n)


def scene_of(case: str) -> ms.Scene:
    """The paper-scale pilot mill of a case name."""
    if case == "balls":
        return ms.presets.pilot_mill(SPEED_FRACTION, None, scale="paper")
    return ms.presets.pilot_mill(SPEED_FRACTION, "ceramic", int(case), scale="paper")


def case_name(case: str) -> str:
    """``balls`` or ``LDMS<k>``: the name of a case in the output and the CSV."""
    return "balls" if case == "balls" else f"LDMS{case}"


def case_folder(workdir: Path, case: str, seed: int, spin_up_s: float, length_s: float) -> Path:
    """The folder of a case's stages, named by everything they depend on, so that a call with
    other settings never reuses them."""
    return workdir / f"{case_name(case)}-seed{seed}-spin{spin_up_s:g}s-length{length_s:g}s"


def append_row(row: dict[str, object]) -> None:
    """Appends one case's row to RESULTS, atomically (temporary file, then rename)."""
    table = pd.DataFrame([row])
    if RESULTS.exists():
        table = pd.concat([pd.read_csv(RESULTS), table], ignore_index=True)
    tmp = RESULTS.with_suffix(".csv.tmp")
    table.to_csv(tmp, index=False)
    os.replace(tmp, RESULTS)


def prepare(case: str, folder: Path, spin_up_s: float, seed: int) -> Path:
    """Stage 1: the state after the spin-up, and its LIGGGHTS files."""
    checkpoint = folder / "state.npz"
    if not checkpoint.exists():
        sim = Simulation(scene_of(case), seed=seed, threads=1, adapt_threads=False)
        sim.run(spin_up_s, sample_dt=SAMPLE_DT_S, sampling="mean", progress=False)
        liggghts_state.write_state(sim, folder, "state")
        sim.save(checkpoint)  # last: a checkpoint means the stage is complete
    return checkpoint


def run_millscope(folder: Path, length_s: float) -> tuple[np.ndarray, np.ndarray]:
    """Stage 2: millscope's continuation, as (time since the state, s; 10 ms means, N m)."""
    out = folder / "millscope_torque.txt"
    if not out.exists():
        sim = Simulation.load(folder / "state.npz", threads=1, track_energy=False)
        sim.adapt_threads = False
        t0 = sim.time
        rec = sim.run(length_s, sample_dt=SAMPLE_DT_S, sampling="mean", progress=False)
        # The record's times are the ends of the intervals; keep their starts.
        liggghts_state._write_atomic(out, "".join(
            f"{t - t0 - SAMPLE_DT_S:.9f} {q:.9g}\n"
            for t, q in zip(rec.time_s, rec.torque_Nm, strict=True)))
    data = np.loadtxt(out, ndmin=2)
    return data[:, 0], data[:, 1]


def read_vars(path: Path) -> dict[str, str]:
    return dict(line.split("=", 1) for line in path.read_text().split())


def run_liggghts(folder: Path, length_s: float, nprocs: int) -> tuple[np.ndarray, np.ndarray]:
    """Stage 3: LIGGGHTS' continuation, as (time since the state, s; interval means of the
    drive torque, N m: minus the torque the particles put on the mesh)."""
    out = folder / "torque_state_liggghts.txt"
    done = folder / "liggghts.done"
    if not done.exists():
        if shutil.which("liggghts") is None:
            raise SystemExit("error: no liggghts on PATH (apt-get install liggghts openmpi-bin)")
        v = read_vars(folder / "state.vars")
        if v["mesh_type"] != "1":
            raise SystemExit(f"error: the drum is material type {v['mesh_type']}; "
                             "the yardstick's mesh is type 1")
        subprocess.run([sys.executable, str(YARDSTICK / "make_mill_stl.py"), "mill.stl",
                        "--phase-deg", v["phase_deg"]], cwd=folder, check=True,
                       stdout=subprocess.DEVNULL)
        shutil.copy(YARDSTICK / "common_fixes.in", folder)
        steps = round(length_s / float(v["dt"]))
        launch = (["mpirun", "--allow-run-as-root", "-np", str(nprocs), "liggghts"]
                  if nprocs > 1 else ["liggghts"])
        with open(folder / "out.liggghts", "w") as log:
            ran = subprocess.run(launch + [
                "-in", str(ROOT / "benchmarks/liggghts/in.mill_from_state"), "-log", "log.state",
                "-var", "datafile", "state.data", "-var", "mats", "state_materials.in",
                "-var", "stl", "mill.stl", "-var", "common", "common_fixes.in",
                "-var", "dt", v["dt"], "-var", "period", v["period"], "-var", "skin", "0.005",
                "-var", "px", "1", "-var", "py", "1", "-var", "pz", str(nprocs),
                "-var", "warmup", "0", "-var", "nsteps", str(steps), "-var", "tag", "liggghts"],
                cwd=folder, stdout=log, stderr=subprocess.STDOUT)
        if ran.returncode != 0:
            raise SystemExit(f"error: LIGGGHTS failed (exit {ran.returncode}); see "
                             f"{folder / 'out.liggghts'} and {folder / 'log.state'}")
        done.touch()
    data = np.loadtxt(out, comments="#", ndmin=2)
    end, mean_on_mesh = data[:, 0], data[:, 2]
    window = float(np.median(np.diff(end)))
    return end - window, -mean_on_mesh


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--cases", nargs="+", default=["balls", "1", "2", "3"],
                   help="balls and/or load levels 1-7 (default: balls 1 2 3)")
    p.add_argument("--spin-up", type=float, default=1.0, help="rotation before the state, s")
    p.add_argument("--length", type=float, default=1.5, help="continuation of each code, s")
    p.add_argument("--skip", type=float, default=0.1,
                   help="start of the compared window in the continuation, s")
    p.add_argument("--nprocs", type=int, default=1, help="LIGGGHTS MPI processes")
    p.add_argument("--seed", type=int, default=0, help="millscope's fill seed")
    p.add_argument("--workdir", type=Path, default=Path("/tmp/millscope-torque"))
    p.add_argument("--fresh", action="store_true", help="redo every stage")
    args = p.parse_args(argv)
    for case in args.cases:
        if case != "balls" and not (case.isdigit() and 1 <= int(case) <= 7):
            p.error(f"--cases: {case!r} is not valid; each must be balls or a level 1-7")
    if not 0.0 < args.spin_up <= 20.0:
        p.error(f"--spin-up = {args.spin_up} is not valid; it must be in (0, 20] s")
    if not 0.0 <= args.skip < args.length <= 20.0:
        p.error(f"--skip = {args.skip}, --length = {args.length}: need 0 <= skip < length <= 20 s")
    if args.seed < 0:
        p.error(f"--seed = {args.seed} is not valid; it must be >= 0")
    if args.nprocs < 1:
        p.error(f"--nprocs = {args.nprocs} is not valid; it must be >= 1")
    for case in args.cases:
        folder = case_folder(args.workdir, case, args.seed, args.spin_up, args.length)
        if args.fresh and folder.exists():
            shutil.rmtree(folder)
        folder.mkdir(parents=True, exist_ok=True)
        name = case_name(case)
        print(f"== {name}: state after {args.spin_up} s", flush=True)
        prepare(case, folder, args.spin_up, args.seed)
        print(f"== {name}: millscope, {args.length} s", flush=True)
        ours = block_mean(*run_millscope(folder, args.length), args.skip)
        print(f"== {name}: LIGGGHTS, {args.length} s on {args.nprocs} process(es)",
              flush=True)
        theirs = block_mean(*run_liggghts(folder, args.length, args.nprocs), args.skip)
        diff = 100.0 * (ours.value / theirs.value - 1.0)
        diff_se = 100.0 * ours.value / theirs.value * math.hypot(
            ours.standard_error / ours.value, theirs.standard_error / theirs.value)
        print(f"{name}: millscope {ours.value:.1f} ± {ours.standard_error:.1f} N m, "
              f"LIGGGHTS {theirs.value:.1f} ± {theirs.standard_error:.1f} N m, "
              f"millscope - LIGGGHTS {diff:+.2f} % ± {diff_se:.2f} %", flush=True)
        append_row({
            "utc": datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ"),
            "case": name, "particles": scene_of(case).n_particles, "seed": args.seed,
            "spin_up_s": args.spin_up, "window_s": f"{args.skip}-{args.length}",
            "millscope_torque_Nm": round(ours.value, 2),
            "millscope_se_Nm": round(ours.standard_error, 2),
            "liggghts_torque_Nm": round(theirs.value, 2),
            "liggghts_se_Nm": round(theirs.standard_error, 2),
            "difference_pct": round(diff, 2), "difference_se_pct": round(diff_se, 2)})
    print(f"appended {len(args.cases)} row(s) to {RESULTS.relative_to(ROOT)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""Time to the first rotating sample: filling and settling against the rotating run.

For each case, one at a time, on the given thread count and without the energy ledger (as a
campaign runs): the wall time of :meth:`Simulation.fill`, of :meth:`Simulation.settle` (the
simulated settling time, its steps, the rest measure it stopped at and why), and of a short
rotating stretch, from which the cost of a 14 s case is extrapolated. The rest measure (the
99th percentile of kinetic energy / (m g d)) is logged every time settle() takes it, so the
CSV of the trace shows where the settling time goes. The settled bed is described by its
centre of mass height and the height of its top (95th percentile of y + r), both about the
drum axis.

    nice -n 5 .venv/bin/python benchmarks/time_to_first_sample.py --cases balls ceramic4
    nice -n 5 .venv/bin/python benchmarks/time_to_first_sample.py --cases balls --rotate 1.0
    .venv/bin/python benchmarks/time_to_first_sample.py --slices 200000 --scale tiny

Writes ``benchmarks/results/time_to_first_sample.csv`` (one row per case, appended) and
``benchmarks/results/time_to_first_sample_trace.csv`` (the rest measure over settling time).
"""

from __future__ import annotations

import argparse
import csv
import platform
import time
from pathlib import Path
from typing import Any

import numpy as np

import millscope as ms
from millscope.engine.simulation import Simulation

RESULTS = Path(__file__).resolve().parent / "results"
CASES: dict[str, dict[str, Any]] = {
    "balls": {"particles": None, "load_level": 1},
    "ceramic1": {"particles": "ceramic", "load_level": 1},
    "ceramic4": {"particles": "ceramic", "load_level": 4},
    "ceramic7": {"particles": "ceramic", "load_level": 7},
}
CASE_SECONDS = 14.0  # the paper's record: 4 s warm-up and the block 4-14 s


def _append(path: Path, rows: list[dict[str, Any]]) -> None:
    if not rows:
        return
    new = not path.exists()
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("a", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]), lineterminator="\n")
        if new:
            w.writeheader()
        w.writerows(rows)


def _placement() -> str:
    """The name of the placement the millscope being timed uses (records' meta "filling")."""
    try:
        from millscope.engine.filling import FILLING
    except ImportError:
        return "cubic-lattice"  # before the close-packed placement
    return FILLING


def bed_shape(sim: Simulation) -> tuple[float, float]:
    """Centre of mass height and top of the bed (95th percentile of y + r), m about the axis."""
    x = sim.positions
    r = sim.scene.particle_radii()
    m = np.asarray(sim._engine.mass)  # noqa: SLF001 - a benchmark reads the engine's masses
    return float(np.sum(m * x[:, 1]) / np.sum(m)), float(np.quantile(x[:, 1] + r, 0.95))


def time_case(label: str, scale: str, seed: int, threads: int, rotate_s: float,
              speed: float) -> tuple[dict[str, Any], list[dict[str, Any]]]:
    scene = (ms.presets.axial_slice(int(label.removeprefix("slice-")), scale, speed)
             if label.startswith("slice-")
             else ms.presets.pilot_mill(speed, scale=scale, **CASES[label]))
    sim = Simulation(scene, seed=seed, threads=threads, track_energy=False)
    trace: list[dict[str, Any]] = []
    start = time.perf_counter()
    measure = sim._rest_measure  # noqa: SLF001 - logged, not changed

    def logged() -> float:
        value = measure()
        trace.append({"case": label, "scale": scale, "seed": seed,
                      "settle_time_s": sim._engine.step_count * sim.dt,  # noqa: SLF001
                      "rest_measure": value, "wall_s": time.perf_counter() - start})
        return value

    sim._rest_measure = logged  # type: ignore[method-assign]  # noqa: SLF001
    sim.fill()
    t_fill = time.perf_counter() - start
    report = sim.settle(progress=False)
    t_settle = time.perf_counter() - start - t_fill
    com_y, top_y = bed_shape(sim)
    builds_settle = int(sim._engine.list_builds)  # noqa: SLF001
    t0 = time.perf_counter()
    sim.run(rotate_s, progress=False)
    t_rot = time.perf_counter() - t0
    per_s = t_rot / rotate_s
    prep = t_fill + t_settle
    case_cost = CASE_SECONDS * per_s
    why = "tolerance" if report.converged else "settle_max_s"
    row = {
        "case": label, "scale": scale, "seed": seed, "threads": threads,
        "particles": scene.n_particles, "dt_s": sim.dt, "host": platform.node(),
        "fill_wall_s": round(t_fill, 3), "settle_wall_s": round(t_settle, 3),
        "settle_sim_s": round(report.time_s, 5),
        "settle_steps": int(round(report.time_s / sim.dt)),
        "settle_stop": why, "rest_measure": report.kinetic_energy_ratio,
        "settle_wall_per_sim_s": round(t_settle / report.time_s, 2),
        "list_builds_settle": builds_settle,
        "bed_com_y_m": round(com_y, 5), "bed_top_y_m": round(top_y, 5),
        "rotate_sim_s": rotate_s, "rotate_wall_s": round(t_rot, 3),
        "rotate_wall_per_sim_s": round(per_s, 2),
        "case14_rotating_wall_s": round(case_cost, 1),
        "prep_over_case14": round(prep / case_cost, 4),
        "prep_share_of_total": round(prep / (prep + case_cost), 4),
        "placement": _placement(),
    }
    return row, trace


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--cases", nargs="+", default=None, choices=sorted(CASES),
                   help="default: balls ceramic4, or none when --slices are given")
    p.add_argument("--slices", nargs="+", type=int, default=[],
                   help="also periodic axial slices of the pilot mill holding this many balls "
                        "(presets.axial_slice), e.g. 200000 with --scale tiny")
    p.add_argument("--scale", default="paper")
    p.add_argument("--seeds", nargs="+", type=int, default=[0])
    p.add_argument("--threads", type=int, default=1)
    p.add_argument("--rotate", type=float, default=0.2, help="rotating stretch timed, s")
    p.add_argument("--speed", type=float, default=0.71)
    p.add_argument("--tag", default="", help="a note stored with each row")
    p.add_argument("--out", type=Path, default=RESULTS / "time_to_first_sample.csv")
    args = p.parse_args()
    cases = args.cases if args.cases is not None else ([] if args.slices else
                                                        ["balls", "ceramic4"])
    for label in [*cases, *(f"slice-{n}" for n in args.slices)]:
        for seed in args.seeds:
            row, trace = time_case(label, args.scale, seed, args.threads, args.rotate,
                                   args.speed)
            row["tag"] = args.tag
            for t in trace:
                t["tag"] = args.tag
            print(", ".join(f"{k}={v}" for k, v in row.items()), flush=True)
            _append(args.out, [row])
            _append(args.out.with_name(args.out.stem + "_trace.csv"), trace)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

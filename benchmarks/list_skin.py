"""The Verlet-list skin against the run time: the floor (0.4 x the smallest radius) against the
default skin (``engine.simulation.default_skin``) on the soft scales, whose time steps are
10-30 times the paper's.

Each round settles a fresh charge with each skin in turn (same seed) and times a stretch of
rotation on one thread, the thread governor off; the ratio of the medians is what the default
gains. The rebuilds per step say why. Appends one row per case and skin to
``benchmarks/results/list_skin.csv``::

    .venv/bin/python benchmarks/list_skin.py
    .venv/bin/python benchmarks/list_skin.py --levels 1 4 --scale small --rounds 5
"""

from __future__ import annotations

import argparse
import platform
import time
from pathlib import Path

import numpy as np
import pandas as pd

import millscope as ms
from millscope.engine.simulation import Simulation, default_skin

RESULTS = Path(__file__).resolve().parent / "results" / "list_skin.csv"


def time_rotation(scene: ms.Scene, skin: float, seconds: float, seed: int) -> tuple[float, float]:
    """Wall time of ``seconds`` of rotation after settling, s, and list builds per step."""
    sim = Simulation(scene, seed=seed, threads=1, skin=skin, adapt_threads=False)
    sim.settle(progress=False)
    builds = sim._engine.list_builds  # noqa: SLF001 - a benchmark reads the engine's counter
    start = time.perf_counter()
    sim.run(seconds, progress=False)
    wall = time.perf_counter() - start
    return wall, (sim._engine.list_builds - builds) / (seconds / sim.dt)  # noqa: SLF001


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--levels", nargs="+", type=int, default=[1, 4], help="ceramic load levels")
    p.add_argument("--scale", default="tiny")
    p.add_argument("--rounds", type=int, default=3)
    p.add_argument("--seconds", type=float, default=0.5, help="rotation timed per run, s")
    p.add_argument("--out", type=Path, default=RESULTS)
    args = p.parse_args()
    rows = []
    for level in args.levels:
        scene = ms.presets.pilot_mill(0.71, "ceramic", level, args.scale)
        r_min = float(scene.particle_radii().min())
        dt = ms.stiffness.time_step_limit(scene).default_dt()
        skins = {"floor": 0.4 * r_min, "default": default_skin(scene, dt)}
        timed: dict[str, list[tuple[float, float]]] = {k: [] for k in skins}
        for _ in range(args.rounds):
            for label, skin in skins.items():
                timed[label].append(time_rotation(scene, skin, args.seconds, seed=1))
        floor_wall = float(np.median([w for w, _ in timed["floor"]]))
        for label, skin in skins.items():
            wall = float(np.median([w for w, _ in timed[label]]))
            rows.append({"case": scene.name, "scale": args.scale, "particles": scene.n_particles,
                         "dt_s": dt, "skin": label, "skin_m": skin, "skin_over_r_min": skin / r_min,
                         "rounds": args.rounds, "rotation_s": args.seconds,
                         "wall_s_median": wall,
                         "builds_per_step": float(np.median([b for _, b in timed[label]])),
                         "floor_over_this": floor_wall / wall, "host": platform.node()})
            print(", ".join(f"{k}={v:.4g}" if isinstance(v, float) else f"{k}={v}"
                            for k, v in rows[-1].items()), flush=True)
    frame = pd.DataFrame(rows)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    frame.to_csv(args.out, mode="a", header=not args.out.exists(), index=False)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

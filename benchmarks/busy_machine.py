"""The engine's thread count and OpenMP wait policy on an idle and on a busy machine.

    .venv/bin/python benchmarks/busy_machine.py                       # tiny ceramic4, 3 rounds
    .venv/bin/python benchmarks/busy_machine.py --scene balls --scale paper --steps 4000

"default" is what a user gets: all the cores' threads, with the running threads adapted to
what steps faster (``Simulation.adapt_threads``); the others hold the running threads fixed.
Each setting times the same steps from one cached tumbling state (``millscope bench``'s cache),
in a process of its own, since OpenMP reads its wait policy from the environment when it
starts. "busy" runs a CPU-bound process at normal priority on all but one of the cores this
process may use, as another user's job would, for the whole timed stretch. The settings of a
round run back to back, idle then busy, and the rounds repeat, so that the ratios come from one
sitting. Writes ``benchmarks/results/busy_machine.csv`` (one row per timed run) and prints the
median wall time of each setting and load, and its ratio to one thread.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

import pandas as pd

from millscope.app.bench import build_scene, tumbling_state

RESULTS = Path(__file__).resolve().parent / "results" / "busy_machine.csv"

#: name -> (threads or None for the default, whether the run adapts its running threads,
#: extra environment)
SETTINGS: dict[str, tuple[int | None, bool, dict[str, str]]] = {
    "1 thread": (1, False, {}),
    "default": (None, True, {}),
    "all threads": (None, False, {}),
    "all threads, passive wait": (None, False, {"OMP_WAIT_POLICY": "passive"}),
    "all threads, spin 10k": (None, False, {"GOMP_SPINCOUNT": "10000"}),
}

_TIMED = """
import json, sys, time
from millscope import Simulation
from millscope.app.bench import measure
path, steps, threads, adapt = sys.argv[1], int(sys.argv[2]), sys.argv[3], sys.argv[4]
sim = Simulation.load(path, threads=None if threads == "None" else int(threads),
                      track_energy=False)
sim.adapt_threads = adapt == "True"
m = measure(sim, steps)
print(json.dumps({"wall_s": m.wall_s, "steps": m.steps, "threads": sim.threads,
                  "running_threads": sim.running_threads}))
"""

_HOG = "while True:\n    pass\n"


def timed_run(state: Path, steps: int, threads: int | None, adapt: bool,
              env: dict[str, str]) -> dict:
    """Times ``steps`` steps from ``state`` in a new process; its result as a dict."""
    full = {k: v for k, v in os.environ.items() if k not in ("OMP_WAIT_POLICY", "GOMP_SPINCOUNT")}
    full.update(env)
    out = subprocess.run([sys.executable, "-c", _TIMED, str(state), str(steps), str(threads),
                          str(adapt)], env=full, check=True, capture_output=True,
                         text=True).stdout
    return json.loads(out.strip().splitlines()[-1])


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--scene", default="ceramic4", choices=["balls", "ceramic4"])
    parser.add_argument("--scale", default="tiny", choices=["paper", "soft", "tiny"])
    parser.add_argument("--steps", type=int, default=6000, help="timed steps per run")
    parser.add_argument("--rounds", type=int, default=3, help="rounds of all settings")
    parser.add_argument("--settings", nargs="+", default=list(SETTINGS), choices=list(SETTINGS))
    parser.add_argument("--cache-dir", default="out/bench-cache")
    parser.add_argument("--out", type=Path, default=RESULTS)
    args = parser.parse_args()

    cores = len(os.sched_getaffinity(0))
    if cores < 2:
        parser.error(f"this process may use {cores} core; a busy machine needs at least 2")
    state = tumbling_state(args.scene, args.scale, 0.5, cache_dir=args.cache_dir, progress=False)
    particles = build_scene(args.scene, args.scale).n_particles
    rows = []
    for k in range(args.rounds):
        for load in ("idle", "busy"):
            hogs = [subprocess.Popen([sys.executable, "-c", _HOG])
                    for _ in range(cores - 1)] if load == "busy" else []
            try:
                time.sleep(0.5 if hogs else 0.0)
                for name in args.settings:
                    threads, adapt, env = SETTINGS[name]
                    r = timed_run(state, args.steps, threads, adapt, env)
                    rows.append({"round": k, "load": load, "setting": name, "scene": args.scene,
                                 "scale": args.scale, "particles": particles,
                                 "threads": r["threads"],
                                 "running_threads_last": r["running_threads"],
                                 "steps": r["steps"], "wall_s": r["wall_s"]})
                    print(f"round {k} {load:4s} {name:26s} {r['wall_s']:7.2f} s", flush=True)
            finally:
                for h in hogs:
                    h.kill()
                    h.wait()
    table = pd.DataFrame(rows)
    table["particle_steps_per_s"] = table.particles * table.steps / table.wall_s
    args.out.parent.mkdir(parents=True, exist_ok=True)
    tmp = args.out.with_suffix(".tmp")
    table.to_csv(tmp, index=False)
    tmp.replace(args.out)
    med = table.groupby(["load", "setting"]).wall_s.median().unstack(0)
    for load in med.columns:
        med[f"{load} / 1 thread"] = med[load] / med.loc["1 thread", load]
    print(med.round(3).to_string())
    print(f"cores this process may use: {cores}; written {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

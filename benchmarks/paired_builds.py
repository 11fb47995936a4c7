"""Two builds of millscope timed against each other from the same checkpoint, in alternating runs.

A change to the engine is kept when it pays; on a shared, noisy machine only a comparison made
in one sitting, run against run, says whether it does. This script times the same stretch of
steps from a checkpoint (for instance a cached bench state, ``out/bench-cache/*.npz``) with
build A and with build B, each run in a process of its own, in the order A B, B A, A B, ...,
and prints every pair's ratio B/A and their median.

Make the two builds with pip, one folder each, at the two commits to compare::

    git stash  # or check out the commit before
    .venv/bin/python -m pip install --no-deps --target /tmp/build-a .
    git stash pop
    .venv/bin/python -m pip install --no-deps --target /tmp/build-b .
    .venv/bin/python benchmarks/paired_builds.py \\
        out/bench-cache/ceramic4-paper-spin0.3-0.1.0-ckpt3.npz /tmp/build-a /tmp/build-b \\
        --threads 1 --steps 1500 --pairs 6

The checkpoint must be one both builds can read (the same millscope version). Each run loads it
with the given thread count and times ``--steps`` steps with :func:`millscope.bench.measure`
(the torque sampled as a user's run samples it), so loading is not timed.

``--clock cpu`` divides by the process's CPU time over the stretch (all its threads) instead of
the wall-clock time: where other processes share the cores, the time a run waits for a core
then does not count. What they do to the caches still counts, and on a shared VM the ratios
may scatter as much by either clock: compare medians of several pairs. On several threads the
CPU time counts the threads' waits at the barriers too, so compare thread counts by the wall
clock.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
from collections.abc import Callable, Sequence
from pathlib import Path

# One timed run, in a fresh process whose first import path is the build's folder.
_RUN = """
import sys
sys.path.insert(0, sys.argv[1])
import millscope
from millscope import bench
if not millscope.__file__.startswith(sys.argv[1]):
    sys.exit(f"millscope was imported from {millscope.__file__}, not from {sys.argv[1]}")
import time
sim = millscope.Simulation.load(sys.argv[2], threads=int(sys.argv[3]))
cpu = time.process_time()
timed = bench.measure(sim, int(sys.argv[4]))
cpu = time.process_time() - cpu
print(timed.particle_steps_per_s, timed.particle_steps / cpu)
"""
CLOCKS = ("wall", "cpu")


def _positive_int(name: str, least: int) -> Callable[[str], int]:
    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            value = least - 1
        if value < least:
            raise argparse.ArgumentTypeError(f"{name} = {text!r} is not valid; it must be an "
                                             f"integer >= {least}")
        return value
    return parse


def _build_folder(text: str) -> Path:
    folder = Path(text).resolve()
    if not (folder / "millscope" / "__init__.py").is_file():
        raise argparse.ArgumentTypeError(
            f"build folder = {text!r} is not valid; it must hold a millscope package "
            "(pip install --no-deps --target FOLDER .)")
    return folder


def _checkpoint(text: str) -> Path:
    path = Path(text).resolve()
    if not path.is_file():
        raise argparse.ArgumentTypeError(f"checkpoint = {text!r} is not valid; it must be an "
                                         "existing .npz file written by Simulation.save")
    return path


def _clock(text: str) -> str:
    if text not in CLOCKS:
        raise argparse.ArgumentTypeError(f"clock = {text!r} is not valid; it must be one of "
                                         + ", ".join(repr(c) for c in CLOCKS))
    return text


def time_run(build: Path, checkpoint: Path, threads: int, steps: int,
             env: dict[str, str] | None = None, clock: str = "wall") -> float:
    """Particle-steps per second of one run of ``build`` from ``checkpoint``, with ``env`` added
    to this process's environment (for instance MILLSCOPE_SIMD): per second of wall-clock time,
    or with ``clock="cpu"`` per second of the process's CPU time."""
    # OMP_NUM_THREADS too, so that no OpenMP region of the run starts more threads than asked
    # for (idle ones spin for a while, which the CPU clock would count)
    out = subprocess.run([sys.executable, "-c", _RUN, str(build), str(checkpoint), str(threads),
                          str(steps)], capture_output=True, text=True,
                         env={**os.environ, "OMP_NUM_THREADS": str(threads), **(env or {})})
    if out.returncode != 0:
        raise RuntimeError(f"the run of the build in {build} failed:\n{out.stderr.strip()}")
    wall_rate, cpu_rate = (float(v) for v in out.stdout.strip().splitlines()[-1].split())
    return cpu_rate if clock == "cpu" else wall_rate


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("checkpoint", type=_checkpoint, help="checkpoint (.npz) to start from")
    parser.add_argument("build_a", type=_build_folder, help="folder holding build A")
    parser.add_argument("build_b", type=_build_folder, help="folder holding build B")
    parser.add_argument("--threads", type=_positive_int("threads", 1), default=1,
                        help="threads of each run (default 1)")
    parser.add_argument("--steps", type=_positive_int("steps", 2), default=2000,
                        help="timed steps of each run (default 2000)")
    parser.add_argument("--pairs", type=_positive_int("pairs", 1), default=6,
                        help="alternating pairs of runs (default 6)")
    parser.add_argument("--clock", type=_clock, default="wall",
                        help="time each run by the wall clock or by the process's CPU time "
                             "(wall or cpu; default wall)")
    args = parser.parse_args(argv)

    a_runs: list[float] = []
    b_runs: list[float] = []
    for k in range(args.pairs):
        order = ((args.build_a, a_runs), (args.build_b, b_runs))
        for build, runs in order if k % 2 == 0 else order[::-1]:
            runs.append(time_run(build, args.checkpoint, args.threads, args.steps,
                                 clock=args.clock))
        print(f"pair {k + 1}: A {a_runs[-1]:.4e}  B {b_runs[-1]:.4e}  particle-steps/s  "
              f"B/A {b_runs[-1] / a_runs[-1]:.3f}", flush=True)
    ratios = [b / a for a, b in zip(a_runs, b_runs, strict=True)]
    print(f"A median {statistics.median(a_runs):.4e}, B median {statistics.median(b_runs):.4e} "
          f"particle-steps/s ({args.threads} thread(s), {args.steps} steps a run, "
          f"{args.clock} clock)")
    print(f"B/A: median {statistics.median(ratios):.3f}, min {min(ratios):.3f}, "
          f"max {max(ratios):.3f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

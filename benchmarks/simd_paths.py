"""The engine's SIMD paths (and other builds) timed against each other from the same checkpoints.

Each configuration is a build folder and, optionally, environment settings, for instance the
SIMD path (``MILLSCOPE_SIMD``, ``python -m millscope info`` lists the paths this CPU runs). For
each checkpoint, every configuration times the same stretch of steps in a process of its own
(``paired_builds.time_run``), the configurations in a rotating order, round after round; then
the medians, and each configuration's ratio to the first one, round by round (median, min,
max). Only ratios measured in one sitting say anything on a shared, noisy machine. ::

    .venv/bin/python benchmarks/simd_paths.py out/bench-cache/balls-*.npz \\
        --config before=/tmp/before-pkg portable=python,MILLSCOPE_SIMD=portable \\
                 avx2=python,MILLSCOPE_SIMD=avx2 avx512=python,MILLSCOPE_SIMD=avx512 \\
        --threads 1 --steps 3000 --rounds 5 --csv benchmarks/results/simd_paths.csv

The CSV has one row per run: checkpoint, configuration, round, threads, steps,
particle_steps_per_s.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
from collections.abc import Sequence
from pathlib import Path

import pandas as pd
from paired_builds import _build_folder, _checkpoint, _positive_int, time_run


def _config(text: str) -> tuple[str, Path, dict[str, str]]:
    """LABEL=FOLDER[,VAR=VALUE...] -> (label, build folder, environment settings)."""
    label, sep, rest = text.partition("=")
    parts = rest.split(",")
    env = dict(p.partition("=")[::2] for p in parts[1:])
    if not sep or not label or not parts[0] or any(not k for k in env):
        raise argparse.ArgumentTypeError(f"config = {text!r} is not valid; it must be "
                                         "LABEL=FOLDER[,VAR=VALUE...]")
    return label, _build_folder(parts[0]), env


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("checkpoints", type=_checkpoint, nargs="+",
                        help="checkpoints (.npz) to start from")
    parser.add_argument("--config", type=_config, nargs="+", required=True,
                        help="LABEL=FOLDER[,VAR=VALUE...]; the first is the reference")
    parser.add_argument("--threads", type=_positive_int("threads", 1), default=1,
                        help="threads of each run (default 1)")
    parser.add_argument("--steps", type=_positive_int("steps", 2), default=2000,
                        help="timed steps of each run (default 2000)")
    parser.add_argument("--rounds", type=_positive_int("rounds", 1), default=5,
                        help="rounds of runs, one run per configuration each (default 5)")
    parser.add_argument("--csv", type=Path, default=None, help="write every run here")
    args = parser.parse_args(argv)

    rows: list[dict[str, object]] = []
    for checkpoint in args.checkpoints:
        speed: dict[str, list[float]] = {label: [] for label, _, _ in args.config}
        for k in range(args.rounds):
            shift = k % len(args.config)
            for label, build, env in args.config[shift:] + args.config[:shift]:
                value = time_run(build, checkpoint, args.threads, args.steps, env)
                speed[label].append(value)
                rows.append({"checkpoint": checkpoint.name, "config": label, "round": k + 1,
                             "threads": args.threads, "steps": args.steps,
                             "particle_steps_per_s": f"{value:.6g}"})
            print(f"{checkpoint.name} round {k + 1}: " + "  ".join(
                f"{label} {runs[-1]:.4e}" for label, runs in speed.items()), flush=True)
        ref = args.config[0][0]
        for label, runs in speed.items():
            ratios = [v / r for v, r in zip(runs, speed[ref], strict=True)]
            print(f"{checkpoint.name} {label}: median {statistics.median(runs):.4e} "
                  f"particle-steps/s; /{ref}: median {statistics.median(ratios):.3f}, "
                  f"min {min(ratios):.3f}, max {max(ratios):.3f}")
    if args.csv is not None:
        args.csv.parent.mkdir(parents=True, exist_ok=True)
        tmp = args.csv.with_name(args.csv.name + ".tmp")
        pd.DataFrame(rows).to_csv(tmp, index=False)
        os.replace(tmp, args.csv)
    return 0


if __name__ == "__main__":
    sys.exit(main())

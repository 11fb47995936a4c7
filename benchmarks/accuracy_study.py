"""The published error-against-run-time study: a thin wrapper over ``millscope study accuracy``.

    .venv/bin/python benchmarks/accuracy_study.py                      # out/accuracy-balls
    .venv/bin/python benchmarks/accuracy_study.py --out out/elsewhere --workers 2

The balls-only pilot mill at 71 % of critical speed as the tiny scale's axial slice (391 balls
of 25 mm, 0.05 m long, periodic ends), 3 seeds per setting, 1 engine thread per run. The
reference is the most accurate setting the machine affords: shear moduli 0.01 of the paper's,
a time step of 0.1 Rayleigh times, 2 s of warm-up and a 6 s block, instantaneous samples as
the paper's. Around it, one knob at a time: the time step (0.2, 0.4 Rayleigh times), the
stiffness (0.001 of the paper's), the block (2 s), the warm-up (1 s) and the sampling
(interval means); and the cheapest of them together: 8 settings x 3 seeds, about 20 minutes
of one core. One run at a time on one engine thread, so that each wall time is one core's.
Any further option is passed on (e.g. ``--out``, ``--workers``, ``--no-progress``); the
command it runs is printed first.

It writes ``accuracy.csv``, ``accuracy.md`` and ``accuracy.png`` into the output folder and
keeps the runs in ``<out>/store`` (a rerun reuses them).
"""

from __future__ import annotations

import sys

from millscope.cli import main

ARGUMENTS = [
    "--out", "out/accuracy-balls", "--particles", "none", "--speed", "0.71", "--seeds", "3",
    "--scale", "tiny", "--shear", "0.01", "--dt-fraction", "0.1", "--warm-up", "2",
    "--record", "6", "--sampling", "instant",
    "--vary-dt-fraction", "0.2", "0.4", "--vary-shear", "0.001", "--vary-record", "2",
    "--vary-warm-up", "1", "--vary-sampling", "mean", "--combine",
    "--workers", "1", "--threads", "1",
]

if __name__ == "__main__":
    argv = ["study", "accuracy", *ARGUMENTS, *sys.argv[1:]]
    print("python -m millscope " + " ".join(argv), flush=True)
    raise SystemExit(main(argv))

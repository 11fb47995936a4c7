"""How long `import millscope` and `millscope --help` take, each in a fresh interpreter.

    .venv/bin/python benchmarks/import_time.py            # 10 runs each, limit 1 s
    .venv/bin/python benchmarks/import_time.py --runs 20 --limit 0.8

Each command runs once unmeasured (so that the bytecode is compiled and the files are in the
page cache), then ``--runs`` times; the wall time of each run (start to exit) and its CPU time
(user + system, from the operating system's accounting of the finished child) are printed as
median and minimum and written to ``benchmarks/results/import_time.csv`` (one row per run).
The children run with bytecode writing on, as an installed package has its bytecode; the
wall time includes the interpreter's own start (compare ``python -c pass``, measured too).

Exit status 1 when the median wall time of `import millscope` or of `millscope --help` is
above ``--limit`` seconds. On a machine busy with other work the wall time grows while the CPU
time does not: compare the two before reading a failure as a slower import.
"""

from __future__ import annotations

import argparse
import csv
import io
import os
import resource
import shutil
import statistics
import subprocess
import sys
import time
from pathlib import Path

from millscope._files import atomic_write

RESULTS = Path(__file__).resolve().parent / "results" / "import_time.csv"


def _commands() -> dict[str, list[str]]:
    """The measured commands: the console script beside this interpreter when installed, else
    the module (``python -m millscope``, one import of runpy more)."""
    script = shutil.which("millscope", path=str(Path(sys.executable).parent))
    help_command = [script, "--help"] if script else [sys.executable, "-m", "millscope", "--help"]
    return {"python -c pass": [sys.executable, "-c", "pass"],
            "import millscope": [sys.executable, "-c", "import millscope"],
            "millscope --help": help_command}


def _run(command: list[str], env: dict[str, str]) -> tuple[float, float]:
    """Wall and CPU seconds of one run of ``command``."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    subprocess.run(command, env=env, check=True, stdout=subprocess.DEVNULL)
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return wall, cpu


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=10, help="measured runs per command")
    parser.add_argument("--limit", type=float, default=1.0,
                        help="the largest median wall time allowed, s")
    args = parser.parse_args(argv)
    if not 1 <= args.runs <= 1000:
        parser.error(f"--runs = {args.runs} is not valid; it must be in [1, 1000]")
    if not 0 < args.limit < 60:
        parser.error(f"--limit = {args.limit} is not valid; it must be in (0, 60) s")
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    rows: list[tuple[str, int, float, float]] = []
    over = []
    print(f"{'command':<18} {'median wall':>12} {'min wall':>9} {'median CPU':>11}"
          f"  ({args.runs} runs)")
    for name, command in _commands().items():
        _run(command, env)  # unmeasured: compiles the bytecode, fills the page cache
        times = [_run(command, env) for _ in range(args.runs)]
        rows += [(name, k, wall, cpu) for k, (wall, cpu) in enumerate(times)]
        wall_median = statistics.median(w for w, _ in times)
        print(f"{name:<18} {wall_median:>11.3f}s {min(w for w, _ in times):>8.3f}s "
              f"{statistics.median(c for _, c in times):>10.3f}s")
        if name != "python -c pass" and wall_median > args.limit:
            over.append(f"{name}: median {wall_median:.3f} s")
    text = io.StringIO()
    writer = csv.writer(text, lineterminator="\n")
    writer.writerow(["command", "run", "wall_s", "cpu_s"])
    writer.writerows([name, k, f"{wall:.4f}", f"{cpu:.4f}"] for name, k, wall, cpu in rows)
    RESULTS.parent.mkdir(exist_ok=True)
    with atomic_write(RESULTS) as f:
        f.write(text.getvalue())
    print(f"wrote {RESULTS}")
    if over:
        print(f"above the limit of {args.limit:g} s: " + "; ".join(over), file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

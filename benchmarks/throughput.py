"""Throughput of the DEM engine on the pilot mill: a thin wrapper over ``millscope.bench``.

    .venv/bin/python benchmarks/throughput.py                  # paper scale, all fixed scenes
    .venv/bin/python benchmarks/throughput.py --scale soft --steps 5000 --scenes balls

The same options and output as ``python -m millscope bench`` (``--help`` lists them).
"""

from __future__ import annotations

from millscope.app.bench import main

if __name__ == "__main__":
    raise SystemExit(main(prog="throughput.py"))

"""`import millscope` and `millscope --help` load no heavy third-party module they do not need:
scipy's signal, stats and spatial packages, matplotlib, pandas, dask and tqdm load when the
function that needs them first runs (the import time itself is measured by
benchmarks/import_time.py, not here: a timed test would fail on a busy machine).

Each check runs in a fresh interpreter, whose ``sys.modules`` is the reference.
"""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

#: modules that take a large part of a second to import, and the import of millscope needs none
HEAVY = ("scipy.signal", "scipy.stats", "scipy.spatial", "matplotlib", "pandas", "dask", "tqdm")

REPORT_LOADED = """
import json, sys
{setup}
print(json.dumps(sorted(m for m in sys.modules if m.split(".")[0] in {roots!r} and any(
    m == h or m.startswith(h + ".") for h in {heavy!r}))))
"""


def _heavy_after(setup: str) -> list[str]:
    code = REPORT_LOADED.format(setup=setup, heavy=HEAVY,
                                roots=sorted({h.split(".")[0] for h in HEAVY}))
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True, timeout=120).stdout
    loaded: list[str] = json.loads(out.splitlines()[-1])
    return loaded


@pytest.mark.parametrize("setup", [
    "import millscope",
    "import millscope as ms; ms.presets.pilot_mill; ms.Simulation; ms.spectrum; ms.Campaign",
    # the command line's help: argparse exits after printing it
    "from millscope.app.cli import main\ntry:\n    main(['--help'])\nexcept SystemExit:\n    pass",
])
def test_import_loads_no_heavy_module(setup: str) -> None:
    assert _heavy_after(setup) == []


def test_the_check_sees_a_heavy_module_once_used() -> None:
    """The reference works: decimating a record (scipy.signal.resample_poly) and a prediction
    interval (scipy.stats.t) load what they need."""
    setup = """
import numpy as np
from millscope.signal.drivetrain import decimate
from millscope.calibration.logfit import log_fit
t = np.arange(400) / 100.0
decimate(t, np.sin(t), 25.0)
log_fit([1, 2, 3, 4], [1.0, 0.8, 0.75, 0.6]).prediction_half_width(2.5)
"""
    loaded = _heavy_after(setup)
    assert "scipy.signal" in loaded and "scipy.stats" in loaded

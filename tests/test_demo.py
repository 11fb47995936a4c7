"""The main job end to end, fast: every stage of the pipeline on synthetic records."""

from __future__ import annotations

import json

import pytest

from millscope.demo import run_demo
from millscope.synthetic import PAPER_HDMS_LAW


def test_main_job_writes_everything_and_recovers_the_law(tmp_path) -> None:
    report = run_demo(tmp_path, progress=False)
    for name in ("synthetic_level1.csv", "spectrum_level1.png", "filtered_level1.png",
                 "waterfall.png", "energy_fit.png", "calibration.json", "report.txt"):
        assert (tmp_path / name).stat().st_size > 0
    assert (tmp_path / "report.txt").read_text().strip() == report.strip()
    fit = json.loads((tmp_path / "calibration.json").read_text())["fit"]
    a, b = PAPER_HDMS_LAW
    # per-unit of the largest of 7 noisy energies: the slope/intercept ratio is scale-free
    assert fit["a"] / fit["b"] == pytest.approx(a / b, rel=0.15)
    assert fit["a"] < 0  # energy falls as the filling rises

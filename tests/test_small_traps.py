"""Small traps a new user meets in the first hour (issue 24, item 7): a calibration without its
block length, a warning that calls a format-2 file "format-1", a broken pipe reported as an
error, a block silently cut to the record, and "none Hz"."""

from __future__ import annotations

import json
import subprocess
import sys
import warnings

import numpy as np
import pytest

import millscope as ms
from millscope.cli import main
from millscope.synthetic import SyntheticTorque, synthetic_record

CONTENT = SyntheticTorque()


@pytest.fixture
def record_csv(tmp_path):
    """A 14 s record sampled at 100 Hz."""
    path = tmp_path / "mill.csv"
    synthetic_record(2, content=CONTENT, seed=3).to_csv(path)
    return path


def _calibration(block_s: float, band_hz: float | None) -> ms.Calibration:
    levels = np.arange(1.0, 6.0)
    fit = ms.log_fit(levels, 1.0 - 0.4 * np.log(levels) + 0.01 * np.sin(levels))
    return ms.Calibration(fit=fit, reference_energy=1e4, lifters=CONTENT.lifters,
                          rotation_hz=CONTENT.rotation_hz, block_s=block_s, band_hz=band_hz)


def test_a_calibration_needs_its_block_length() -> None:
    """Without block_s the calibration is not made (it used to default to 10 s, so that
    estimate_fill refused the 6 s block the fit came from); with it, a 6 s block is taken."""
    fit = ms.log_fit([1.0, 2.0, 3.0], [1.0, 0.72, 0.55])
    with pytest.raises(TypeError, match="block_s"):
        ms.Calibration(fit=fit, reference_energy=1e4, lifters=16,  # type: ignore[call-arg]
                       rotation_hz=CONTENT.rotation_hz)
    block = synthetic_record(2, content=CONTENT, seed=1).block(4.0, 10.0)
    cal = ms.Calibration(fit=fit, reference_energy=1e4, lifters=16,
                         rotation_hz=CONTENT.rotation_hz, block_s=block.duration_s)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        assert np.isfinite(ms.estimate_fill(block, cal).level)


def test_monitor_does_not_call_a_format_2_file_format_1(tmp_path, capsys) -> None:
    """A format-2 calibration whose band_hz is null: the warning says so, not "a format-1
    file"."""
    path = _calibration(10.0, None).save(tmp_path / "cal.json")
    assert json.loads(path.read_text())["format"] == "millscope-calibration-2"
    record = tmp_path / "long.csv"
    synthetic_record(2, content=CONTENT, seed=5, duration_s=20.0).to_csv(record)
    assert main(["monitor", str(record), "--calibration", str(path)]) == 0
    warning = next(line for line in capsys.readouterr().out.splitlines()
                   if "band_hz" in line)
    assert "format-1 file" not in warning and "its band_hz is null" in warning


def test_a_closed_pipe_ends_analyze_quietly(record_csv, tmp_path) -> None:
    """``millscope analyze ... | head``: the reader is gone before the report is written; no
    error line, no traceback, exit 1 (as the Python documentation's SIGPIPE note does)."""
    with subprocess.Popen([sys.executable, "-m", "millscope", "analyze", str(record_csv),
                           "--lifters", "16", "--rotation-hz", str(CONTENT.rotation_hz),
                           "--out", str(tmp_path)],
                          stdout=subprocess.PIPE, stderr=subprocess.PIPE) as run:
        assert run.stdout is not None and run.stderr is not None
        run.stdout.close()  # the reader leaves at once
        err = run.stderr.read().decode()
        code = run.wait(timeout=120)
    assert (code, err) == (1, "")


@pytest.mark.parametrize(("span", "option", "value"), [
    (["--from", "4", "--to", "30"], "--to", "30"),
    (["--from", "-1", "--to", "10"], "--from", "-1"),
])
def test_a_block_past_the_record_is_refused_naming_its_span(record_csv, tmp_path, capsys, span,
                                                            option, value) -> None:
    """--to 30 on a 14 s record used to analyse 4 .. 14 s and print "4 .. 30 s"."""
    code = main(["analyze", str(record_csv), "--lifters", "16", "--rotation-hz",
                 str(CONTENT.rotation_hz), "--out", str(tmp_path), *span])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1
    assert f"{option} {value} s is not valid" in err and "spans 0 .. 14 s" in err


def test_no_line_says_none_hz(record_csv, tmp_path, capsys) -> None:
    assert main(["analyze", str(record_csv), "--lifters", "16", "--rotation-hz",
                 str(CONTENT.rotation_hz), "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "none Hz" not in out
    assert any(line.split() == ["drive-train", "lines", "none"] for line in out.splitlines())

"""Monitoring: a calibration slid over a long record whose filling changes, simulated-like and
measured-like (1 kHz, drive-train lines), from Python and from the command line."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

import millscope as ms
from millscope.cli import main
from millscope.drivetrain import DriveTrain
from millscope.fit import NoIntervalWarning
from millscope.monitoring import MissingBandWarning, monitor_record
from millscope.synthetic import synthetic_record

from .synthetic_campaign import LAW, case_results, content_for

SEGMENTS = (2.0, 5.0, 3.0)  # load levels of three 20 s stretches of one long record
SEGMENT_S = 20.0
MOTOR_HZ = 23.1


@pytest.fixture(scope="module")
def calibration() -> ms.Calibration:
    return ms.Calibration.from_results(case_results(family=21))


def long_record(*, sample_rate_hz: float = 100.0, noise_scale: float = 1.0,
                lines: tuple[tuple[float, float], ...] = ()) -> ms.TorqueRecord:
    """Three stretches at the SEGMENTS levels, one after the other."""
    scene = ms.presets.pilot_mill(0.71, "ceramic", 1, scale="tiny")
    content = content_for(scene, LAW, noise_std_Nm=30.0 * noise_scale, lines=lines)
    parts = [synthetic_record(level, content=content, duration_s=SEGMENT_S,
                              sample_rate_hz=sample_rate_hz, seed=40 + k)
             for k, level in enumerate(SEGMENTS)]
    torque = np.concatenate([p.torque_Nm for p in parts])
    return ms.TorqueRecord(np.arange(torque.size) / sample_rate_hz, torque)


def truth(window: ms.WindowEstimate) -> float:
    return SEGMENTS[int(window.start_s // SEGMENT_S)]


def test_windows_follow_the_filling(calibration) -> None:
    windows = ms.monitor(long_record(), calibration)
    assert [(w.start_s, w.end_s) for w in windows] == [(10.0 * k, 10.0 * k + 10.0)
                                                       for k in range(6)]
    for w in windows:
        assert w.interval[0] <= truth(w) <= w.interval[1]
        assert not w.outside
    overlapping = ms.monitor(long_record(), calibration, step_s=2.5)
    assert len(overlapping) == 21 and overlapping[1].start_s == 2.5


def test_a_measured_record_is_decimated_and_its_drive_lines_removed(calibration) -> None:
    """1 kHz with a 40 N m motor line: decimated to 125 Hz, only 0-50 Hz counted, the drive's
    lines removed. The noise has the density of the 100 Hz records in the band (10 x the
    variance at 10 x the rate)."""
    record = long_record(sample_rate_hz=1000.0, noise_scale=np.sqrt(10.0),
                         lines=((MOTOR_HZ, 40.0),))
    drive = DriveTrain.from_dict({"motor": {"pole_pairs": 2, "speed_hz": MOTOR_HZ},
                                  "stages": [{"ratio": MOTOR_HZ / calibration.rotation_hz}],
                                  "lifters": 16})
    result = monitor_record(record, calibration, drive=drive)
    assert result.decimated_from_hz == pytest.approx(1000.0)
    assert result.sample_rate_hz == pytest.approx(125.0)
    assert MOTOR_HZ in result.lines_hz
    for w in result.windows:
        assert w.interval[0] <= truth(w) <= w.interval[1]
    without = ms.monitor(record, calibration)  # the motor line counted as grinding noise
    assert all(w.outside and w.level < 1.0 for w in without)


def test_bad_arguments_are_refused_before_any_window(calibration) -> None:
    record = long_record()
    with pytest.raises(ValueError, match="window_s = 5 .* block_s = 10 s"):
        ms.monitor(record, calibration, window_s=5)
    with pytest.raises(ValueError, match="step_s = 0 is not valid"):
        ms.monitor(record, calibration, step_s=0)
    with pytest.raises(ValueError, match="shorter than one window"):
        ms.monitor(record.block(0, 8), calibration)
    drive = DriveTrain.from_dict({"motor": {"pole_pairs": 2, "speed_hz": 20.0}, "stages": [],
                                  "lifters": 12})
    with pytest.raises(ValueError, match="drive.lifters = 12 .* lifter count, 16"):
        ms.monitor(record, calibration, drive=drive)


def test_cli_prints_one_line_per_window(calibration, tmp_path, capsys) -> None:
    cal = calibration.save(tmp_path / "cal.json")
    csv = long_record().to_csv(tmp_path / "long.csv")
    assert main(["monitor", str(csv), "--calibration", str(cal)]) == 0
    out = capsys.readouterr().out.splitlines()
    rows = [line.split() for line in out if not line.startswith("#")]
    assert rows[0] == ["start_s", "end_s", "level", "low_95", "high_95", "flag"]
    windows = ms.monitor(ms.TorqueRecord.from_csv(csv), calibration)
    assert len(rows) == 1 + len(windows)
    for row, w in zip(rows[1:], windows, strict=True):
        assert float(row[0]) == pytest.approx(w.start_s)
        assert float(row[2]) == pytest.approx(w.level, abs=5e-4)
        assert float(row[3]) <= truth(w) <= float(row[4])
        assert row[5] == "ok"


def _format_1(calibration: ms.Calibration, path) -> ms.Calibration:
    """The calibration as a format-1 file holds it: without band_hz and block_relative_std."""
    data = json.loads(calibration.save(path).read_text())
    data["format"] = "millscope-calibration-1"
    del data["band_hz"], data["block_relative_std"]
    path.write_text(json.dumps(data))
    return ms.Calibration.load(path)


def test_a_calibration_without_band_warns_and_takes_one_given(calibration, tmp_path,
                                                              capsys) -> None:
    """A format-1 calibration does not say its band. A 1 kHz record with the density of the
    100 Hz records in 0-50 Hz: counted up to 500 Hz it reads ten times the energy and every
    window falls below the calibrated range; told band_hz=50 it is decimated and reads as with
    the format-2 calibration (same fit and reference; the intervals differ, format 1 has no
    block_relative_std)."""
    old = _format_1(calibration, tmp_path / "old.json")
    assert old.band_hz is None and calibration.band_hz == pytest.approx(50.0)
    record = long_record(sample_rate_hz=1000.0, noise_scale=np.sqrt(10.0))
    message = (r"gives no band_hz \(its band_hz is null, or its file is of format 1, which has "
               r"none\).*the 1000 Hz record is neither decimated nor band-limited")
    with pytest.warns(MissingBandWarning, match=message) as caught:
        unbounded = ms.monitor(record, old)
    assert len(caught) == 1 and caught[0].filename == __file__
    assert all(w.outside and w.level < 1.0 for w in unbounded)

    given = monitor_record(record, old, band_hz=50.0)  # no warning (warnings are errors)
    reference = monitor_record(record, calibration)
    assert given.sample_rate_hz == reference.sample_rate_hz == pytest.approx(125.0)
    assert [w.level for w in given.windows] == [w.level for w in reference.windows]
    for w in given.windows:
        assert w.interval[0] <= truth(w) <= w.interval[1]
    with pytest.raises(ValueError, match="band_hz = 20.0 is not valid; the calibration counts "
                                         "energy up to its own band_hz = 50 Hz"):
        ms.monitor(record, calibration, band_hz=20.0)
    with pytest.raises(ValueError, match="band_hz = -1 is not valid"):
        ms.monitor(record, old, band_hz=-1)

    csv = record.to_csv(tmp_path / "fast.csv")
    assert main(["monitor", str(csv), "--calibration", str(tmp_path / "old.json")]) == 0
    notes = [line for line in capsys.readouterr().out.splitlines()
             if line.startswith("# warning: ")]
    assert len(notes) == 1 and "no band_hz" in notes[0] and "--band-hz" in notes[0]
    assert main(["monitor", str(csv), "--calibration", str(tmp_path / "old.json"),
                 "--band-hz", "50"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert not any(line.startswith("# warning") for line in out)
    rows = [line.split() for line in out if not line.startswith("#")][1:]
    assert [float(r[2]) for r in rows] == pytest.approx([w.level for w in reference.windows],
                                                        abs=5e-4)


def test_a_two_level_calibration_is_warned_about_once_and_printed_without_interval(
        tmp_path, capsys) -> None:
    """A fit through levels 1 and 5 gives no interval: one warning for the whole record (not
    one per window), nan intervals, and on the command line '-' with the warning in the
    header instead of 'nan'."""
    with pytest.warns(NoIntervalWarning):
        cal = ms.Calibration.from_results(case_results(levels=(1, 5), family=22))
    record = long_record()
    with pytest.warns(NoIntervalWarning, match="gives no intervals: its log fit goes through 2 "
                                               "load levels") as caught:
        windows = ms.monitor(record, cal)
    assert len(caught) == 1 and caught[0].filename == __file__
    assert len(windows) == 6
    assert all(np.isnan(w.interval).all() and np.isfinite(w.level) for w in windows)

    path = cal.save(tmp_path / "cal2.json")
    csv = record.to_csv(tmp_path / "long.csv")
    assert main(["monitor", str(csv), "--calibration", str(path)]) == 0
    out = capsys.readouterr().out.splitlines()
    notes = [line for line in out if line.startswith("# warning: ")]
    assert len(notes) == 1 and "2 load levels (1 and 5)" in notes[0]
    rows = [line.split() for line in out if not line.startswith("#")][1:]
    assert len(rows) == len(windows)
    for row, w in zip(rows, windows, strict=True):
        assert float(row[2]) == pytest.approx(w.level, abs=5e-4)
        assert row[3:5] == ["-", "-"]
    assert not any("nan" in field for row in rows for field in row)


def test_cli_bad_input_is_one_line_and_exit_2(calibration, tmp_path, capsys) -> None:
    cal = calibration.save(tmp_path / "cal.json")
    short = long_record().block(0, 5).to_csv(tmp_path / "short.csv")
    cases = [([str(short), "--calibration", str(cal)], "shorter than one window"),
             ([str(short), "--calibration", str(tmp_path / "none.json")],
              "no such calibration file"),
             ([str(tmp_path / "none.csv"), "--calibration", str(cal)], "no such file")]
    for args, message in cases:
        assert main(["monitor", *args]) == 2
        err = capsys.readouterr().err
        assert err.startswith("millscope: error: ") and message in err
        assert err.count("\n") == 1
    run = subprocess.run([sys.executable, "-m", "millscope", "monitor", str(short),
                          "--calibration", str(cal), "--step", "-1"],
                         capture_output=True, text=True)
    assert run.returncode == 2 and "--step: '-1' is not valid" in run.stderr
    assert "Traceback" not in run.stderr

"""Plant torque files: fifteen common export shapes written from one known signal load to the
same SI samples, by sniffing or by explicit options, from Python and from the command line."""

from __future__ import annotations

import math
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import millscope as ms
from millscope.cli import main
from millscope.synthetic import SyntheticTorque, synthetic_record

from .synthetic_campaign import case_results
from .test_monitor import long_record

N = 300
DT = 0.01
TIME = np.arange(N) / 100.0  # s
# the known torque, N m, with 3 decimals so every shape below can write it exactly
TORQUE = np.round(265.0 + 40.0 * np.sin(2 * np.pi * 8.8 * TIME)
                  + 5.0 * np.cos(2 * np.pi * 0.55 * TIME), 3)


def table(times: list[str], torques: list[str], sep: str, end: str = "\n") -> str:
    return "".join(f"{t}{sep}{q}{end}" for t, q in zip(times, torques, strict=True))


def fixed(values: np.ndarray, digits: int, decimal: str = ".") -> list[str]:
    return [f"{v:.{digits}f}".replace(".", decimal) for v in values]


SECONDS = fixed(TIME, 2)
NEWTON_METRES = fixed(TORQUE, 3)
ISO_STAMPS = [f"2024-03-01T12:00:{k // 100:02d}.{k % 100 * 10:03d}" for k in range(N)]


def jittered(max_jitter: float) -> tuple[np.ndarray, np.ndarray]:
    """A logger sampling the analytic signal at times off the grid by up to max_jitter x DT."""
    offsets = np.random.default_rng(7).uniform(-max_jitter, max_jitter, N) * DT
    offsets[[0, -1]] = 0.0  # the span, hence the mean step, stays (N - 1) DT
    times = TIME + offsets
    return times, signal(times)


def signal(t: np.ndarray) -> np.ndarray:
    return 265.0 + 40.0 * np.sin(2 * np.pi * 8.8 * t) + 5.0 * np.cos(2 * np.pi * 0.55 * t)



# name -> (file name, its bytes, the options the file needs beyond sniffing)
SHAPES: dict[str, tuple[str, Callable[[], bytes], dict[str, Any]]] = {
    "1 millscope's own": ("m.csv", lambda: (  # as TorqueRecord.to_csv writes it
        "# meta: {\"lifters\": 16}\ntime_s,torque_Nm\n"
        + table([repr(float(t)) for t in TIME], [repr(float(q)) for q in TORQUE], ",")
    ).encode(), {}),
    "2 extra columns and comments": ("m.csv", lambda: (
        "# measured on the rig\n# meta: {\"lifters\": 16}\nspeed_rpm,time_s,torque_Nm,temp_C\n"
        + "".join(f"33,{t},{q},21.5\n" for t, q in zip(SECONDS, NEWTON_METRES, strict=True))
    ).encode(), {}),
    "3 semicolons": ("m.csv", lambda: (
        "time_s;torque_Nm\n" + table(SECONDS, NEWTON_METRES, ";")).encode(), {}),
    "4 tabs in a .tsv": ("m.tsv", lambda: (
        "Time [s]\tTorque [Nm]\n" + table(SECONDS, NEWTON_METRES, "\t")).encode(), {}),
    "5 decimal comma": ("m.csv", lambda: (
        "Zeit [s];Drehmoment [Nm]\n"
        + table(fixed(TIME, 2, ","), fixed(TORQUE, 3, ","), ";")).encode(), {}),
    "6 names with units": ("m.csv", lambda: (
        "Time [s],Torque [Nm]\n" + table(SECONDS, NEWTON_METRES, ",")).encode(), {}),
    "7 title, header, units line": ("m.csv", lambda: (
        "Mill 3 drive torque, export of 2024-03-01\nTime,Torque\ns,Nm\n"
        + table(SECONDS, NEWTON_METRES, ",")).encode(), {}),
    "8 title, units line above the header": ("m.csv", lambda: (
        "Plant export\n[s];[kN m]\nTime;Torque\n"
        + table(SECONDS, fixed(TORQUE / 1000, 6), ";")).encode(), {}),
    "9 time in ms": ("m.csv", lambda: (
        "Time [ms],Torque [Nm]\n"
        + table([str(10 * k) for k in range(N)], NEWTON_METRES, ",")).encode(), {}),
    "10 torque in kN m": ("m.csv", lambda: (
        "Time (s),Torque (kN·m)\n" + table(SECONDS, fixed(TORQUE / 1000, 6), ",")).encode(), {}),
    "11 UTF-8 byte-order mark (Excel CSV UTF-8)": ("m.csv", lambda: (
        "\ufefftime_s,torque_Nm\r\n" + table(SECONDS, NEWTON_METRES, ",", "\r\n")
    ).encode("utf-8"), {}),
    "12 latin-1 text": ("m.txt", lambda: (
        "Mühle 3, Messung bei 20 °C\nZeit [s];Drehmoment [Nm]\n"
        + table(SECONDS, NEWTON_METRES, ";")).encode("latin-1"), {}),
    "13 ISO timestamps": ("m.csv", lambda: (
        "Timestamp,Torque [Nm]\n" + table(ISO_STAMPS, NEWTON_METRES, ",")).encode(), {}),
    "14 time stamps with 0.1 % jitter": ("m.csv", lambda: (
        "time_s,torque_Nm\n" + table([repr(float(t)) for t in jittered(1e-3)[0]],
                                     [repr(float(q)) for q in jittered(1e-3)[1]], ",")
    ).encode(), {"resample": True}),
    "15 logger preamble, quoted, minutes and MN m by options": ("m.dat", lambda: (
        "Logger 7;SN 4711\r\n1234;5678\r\n\r\n\"ch0\";\"ch1\";\"ch2\"\r\n"
        + "".join(f"\"{k / 6000!r}\";\"{k % 7}\";\"{q / 1e6:.9f}\"\r\n"
                  for k, q in enumerate(TORQUE))).encode(),
        {"skiprows": 3, "time_column": 0, "torque_column": "ch2", "time_unit": "min",
         "torque_unit": "MN m", "sep": ";", "decimal": ".", "encoding": "utf-8"}),
}


def write_shape(tmp_path: Path, name: str) -> tuple[Path, dict[str, Any]]:
    filename, content, options = SHAPES[name]
    path = tmp_path / filename
    path.write_bytes(content())
    return path, options


@pytest.mark.parametrize("name", list(SHAPES))
def test_each_export_shape_loads_to_the_known_si_samples(tmp_path, name: str) -> None:
    path, options = write_shape(tmp_path, name)
    rec = ms.TorqueRecord.load(path, **options)
    np.testing.assert_allclose(rec.time_s, TIME, rtol=1e-12, atol=1e-15)
    if "jitter" in name:
        # linear interpolation from a sample at most e = 0.1 % DT away: |error| <= e DT
        # max|q''| / 2 (plus the neighbour's weight of e), an analytic bound on the known signal
        second = 40.0 * (2 * np.pi * 8.8) ** 2 + 5.0 * (2 * np.pi * 0.55) ** 2
        bound = 1e-3 * DT * DT * second / 2 * 1.01
        np.testing.assert_allclose(rec.torque_Nm, signal(TIME), rtol=0, atol=bound)
        # stamps off by up to 0.1 % of DT make steps off by up to 0.2 %
        steps = np.diff(jittered(1e-3)[0])
        assert rec.meta["resampled"]["max_jitter"] == pytest.approx(
            np.max(np.abs(steps - DT)) / DT, rel=1e-6)
    else:
        np.testing.assert_allclose(rec.torque_Nm, TORQUE, rtol=1e-12)
    if "ISO" in name:
        assert rec.meta["time_origin"] == "2024-03-01T12:00:00.000"
    if name.startswith(("1 ", "2 ")):
        assert rec.meta["lifters"] == 16


@pytest.mark.parametrize("name", ["5 decimal comma", "8 title, units line above the header",
                                  "12 latin-1 text"])
def test_the_same_shapes_load_with_the_options_given(tmp_path, name: str) -> None:
    """Sniffing and explicit options agree (the options win only where the file is silent)."""
    path, _ = write_shape(tmp_path, name)
    options = {"5 decimal comma": dict(sep=";", decimal=",", time_column="Zeit",
                                       torque_column=1, time_unit="s", torque_unit="Nm"),
               "8 title, units line above the header": dict(skiprows=1, torque_unit="kNm"),
               "12 latin-1 text": dict(encoding="latin-1", skiprows=1,
                                       time_column="Zeit [s]")}[name]
    rec = ms.TorqueRecord.from_csv(path, **options)
    np.testing.assert_allclose(rec.torque_Nm, TORQUE, rtol=1e-12)
    np.testing.assert_allclose(rec.time_s, TIME, rtol=1e-12, atol=1e-15)


def test_jitter_beyond_the_tolerance_is_refused_with_the_measured_jitter(tmp_path) -> None:
    path, _ = write_shape(tmp_path, "14 time stamps with 0.1 % jitter")
    with pytest.raises(ms.RecordError, match=r"sampling is not uniform: .*deviation of "
                                             r"0\.00\d+ relative.*resample=True"):
        ms.TorqueRecord.load(path)  # not resampled unless asked
    times, torques = jittered(0.05)
    path.write_text("time_s,torque_Nm\n" + "".join(f"{t!r},{q!r}\n" for t, q in
                                                   zip(times.tolist(), torques.tolist(),
                                                       strict=True)))
    measured = np.max(np.abs(np.diff(times) - DT)) / DT
    with pytest.raises(ms.RecordError, match=rf"a jitter of {measured:.3g} relative; resampling "
                                             r"accepts up to jitter_rtol = 0\.01"):
        ms.TorqueRecord.from_csv(path, resample=True)
    rec = ms.TorqueRecord.from_csv(path, resample=True, jitter_rtol=0.1)
    assert rec.dt == pytest.approx(DT, rel=1e-12)


@pytest.mark.parametrize(
    ("content", "options", "message"),
    [
        (b"Time [h:m:s],Torque [Nm]\n1,2\n2,3\n", {},
         r"column 'Time \[h:m:s\]' has the unit 'h:m:s', which is not one of 's', 'ms'"),
        (b"Time,Torque [Nm]\n1,2\n2,3\n", {}, r"column 'Time' has no unit; give time_unit"),
        (b"Time [s],Torque [Nm]\n1,2\n2,3\n", {"time_unit": "ms"},
         r"time_unit = 'ms' contradicts the unit 's' the file gives for column 'Time \[s\]'"),
        (b"Time [s],Torque A [Nm],Torque B [Nm]\n1,2,3\n2,3,4\n", {},
         r"several columns named like a torque .* give torque_column"),
        (b"Time [s],Torque [Nm]\n1,2\n2,3\n", {"torque_column": 5},
         r"torque_column = 5 is not valid; it must be an index in 0..1"),
        (b"Time [s],Torque [Nm]\n1,2\n2,3\n", {"torque_column": "Moment"},
         r"torque_column = 'Moment' is not one column of the header"),
        (b"time_s;torque_Nm\n0;1,5\n0,01;2,5\n", {"decimal": "."},
         r"line 3: column 'time_s': '0,01' is not a number \(a decimal comma\? give "
         r"decimal=','\)"),
        (b"Zeit [s];Drehmoment [Nm]\n0;1\n\xff\n", {"encoding": "utf-8"},
         r"not utf-8 text: byte 29 is 0xff; give the file's encoding"),
        (b"time_s,torque_Nm\n0,1\n\x00\x01", {}, r"binary data \(a NUL character on line 3\)"),
    ],
)
def test_a_file_the_options_do_not_fit_is_refused_naming_what(tmp_path, content: bytes,
                                                               options: dict[str, Any],
                                                               message: str) -> None:
    path = tmp_path / "m.csv"
    path.write_bytes(content)
    with pytest.raises(ms.RecordError, match=message):
        ms.TorqueRecord.from_csv(path, **options)


@pytest.mark.parametrize(
    ("options", "message"),
    [
        ({"time_unit": "fortnight"}, r"time_unit = 'fortnight' is not valid; it must be one of "
                                     r"'s', 'ms', 'min', 'h', 'iso'"),
        ({"torque_unit": "lbf ft"}, r"torque_unit = 'lbf ft' is not valid"),
        ({"sep": ";;"}, r"sep = ';;' is not valid; it must be one character"),
        ({"decimal": ";"}, r"decimal = ';' is not valid; it must be '.' or ','"),
        ({"skiprows": -1}, r"skiprows = -1 is not valid; it must be an integer >= 0"),
        ({"encoding": "klingon"}, r"encoding = 'klingon' is not valid"),
        ({"time_column": True}, r"time_column = True is not valid"),
        ({"jitter_rtol": 0.7}, r"jitter_rtol = 0.7 is not valid; it must be a number in "
                               r"\(0, 0.5\)"),
        ({"resample": "yes"}, r"resample = 'yes' is not valid; it must be True or False"),
        ({"uniform_rtol": math.nan}, r"uniform_rtol = nan is not valid"),
    ],
)
def test_bad_options_are_refused_before_the_file_is_read(options: dict[str, Any],
                                                         message: str) -> None:
    with pytest.raises(ValueError, match=message):
        ms.TorqueRecord.from_csv("/no/such/file.csv", **options)


def test_load_tells_files_by_content_and_says_what_they_are(tmp_path) -> None:
    """A .tsv used to reach np.load ("pickled (object) data"), latin-1 was "not a text file"."""
    path, _ = write_shape(tmp_path, "4 tabs in a .tsv")
    assert len(ms.TorqueRecord.load(path)) == N
    npz = ms.TorqueRecord(TIME, TORQUE).save(tmp_path / "r.npz")
    with pytest.raises(ms.RecordError, match="an npz record; the CSV options time_unit apply "
                                             "to text files only"):
        ms.TorqueRecord.load(npz, time_unit="ms")
    with pytest.raises(ms.RecordError, match="is a directory, not a record file"):
        ms.TorqueRecord.load(tmp_path)
    with pytest.raises(ms.RecordError, match="not a regular file"):
        ms.TorqueRecord.load("/dev/null")


# -- the command line ------------------------------------------------------------------------
PLANT_OPTIONS = ["--skip-rows", "1", "--sep", ";", "--decimal", ",", "--time-column", "0",
                 "--torque-column", "Drehmoment", "--time-unit", "ms", "--torque-unit", "kN m",
                 "--encoding", "latin-1"]


def plant_copy(record: ms.TorqueRecord, path: Path) -> Path:
    """``record`` as a German plant export: a title, ';', decimal commas, ms and kN m."""
    lines = "".join(f"{t * 1000!r};{q / 1000!r}\n".replace(".", ",")
                    for t, q in zip(record.time_s.tolist(), record.torque_Nm.tolist(),
                                    strict=True))
    path.write_bytes(("Mühle 3\nZeit;Drehmoment\n" + lines).encode("latin-1"))
    return path


def summary(text: str) -> list[str]:
    return [line for line in text.splitlines() if not line.startswith(("file", "wrote", "# "))]


def test_analyze_takes_the_file_options_end_to_end(tmp_path, capsys) -> None:
    """``python -m millscope analyze`` of a plant export with the options prints what the
    same record as millscope's CSV gives."""
    record = synthetic_record(2, content=SyntheticTorque(rotation_hz=0.55), seed=4,
                              duration_s=12.0)
    native_csv = record.to_csv(tmp_path / "mill.csv")
    plant = plant_copy(record, tmp_path / "plant.txt")
    common = ["--lifters", "16", "--rotation-hz", "0.55", "--out", str(tmp_path / "out")]
    assert main(["analyze", str(native_csv), *common]) == 0
    reference = capsys.readouterr().out
    run = subprocess.run([sys.executable, "-m", "millscope", "analyze", str(plant), *common,
                          *PLANT_OPTIONS, "--resample", "--jitter-tol", "0.01"],
                         capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    assert summary(run.stdout) == summary(reference)
    assert any(line.startswith("LTH found") for line in summary(reference))
    for extra, message in ((["--torque-column", "Moment"],
                            "torque_column = 'Moment' is not one column of the header"),
                           (["--time-unit", "parsec"], "time_unit = 'parsec' is not valid"),
                           (["--jitter-tol", "0"], "jitter_rtol = 0.0 is not valid")):
        assert main(["analyze", str(plant), *common, *PLANT_OPTIONS, *extra]) == 2
        err = capsys.readouterr().err
        assert err.startswith("millscope: error: ") and err.count("\n") == 1
        assert message in err


def test_monitor_takes_the_file_options(tmp_path, capsys) -> None:
    calibration = ms.Calibration.from_results(case_results(family=21))
    cal = calibration.save(tmp_path / "cal.json")
    record = long_record()
    native_csv = record.to_csv(tmp_path / "long.csv")
    plant = plant_copy(record, tmp_path / "long.txt")
    assert main(["monitor", str(native_csv), "--calibration", str(cal)]) == 0
    reference = capsys.readouterr().out
    assert main(["monitor", str(plant), "--calibration", str(cal), *PLANT_OPTIONS]) == 0
    assert summary(capsys.readouterr().out) == summary(reference)
    assert len(summary(reference)) >= 3  # the column names and the windows
    assert main(["monitor", str(plant), "--calibration", str(cal)]) == 2
    assert "column 'Zeit' has no unit; give time_unit" in capsys.readouterr().err


def test_jittered_file_needs_resample_on_the_command_line(tmp_path, capsys) -> None:
    path, _ = write_shape(tmp_path, "14 time stamps with 0.1 % jitter")
    args = ["analyze", str(path), "--lifters", "16", "--rotation-hz", "0.55", "--out",
            str(tmp_path)]
    assert main(args) == 2
    err = capsys.readouterr().err
    assert "sampling is not uniform" in err and "--resample" in err
    assert main([*args, "--resample"]) == 0
    assert "LTH found" in capsys.readouterr().out

"""The command line as a user runs it: output, plots, and one clear line for bad input."""

from __future__ import annotations

import os
import subprocess
import sys

import numpy as np
import pytest

from millscope.app.cli import pair_search_line
from millscope.cli import main
from millscope.synthetic import SyntheticTorque, synthetic_record

from .cpu import usable_cores, x86_simd_paths


@pytest.fixture
def csv_record(tmp_path):
    content = SyntheticTorque(rotation_hz=0.55)
    path = tmp_path / "mill.csv"
    synthetic_record(2, content=content, seed=4).to_csv(path)
    return path


def _info(env: dict[str, str]) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "millscope", "info"], capture_output=True,
                          text=True, env=env)


def _pair_search(out: str) -> str:
    return next(line for line in out.splitlines()
                if line.startswith("pair search")).split(maxsplit=2)[2]


def test_info_runs_as_a_module() -> None:
    """The pair search line says which search this CPU runs by default, as /proc/cpuinfo tells
    it (x86-64: AVX-512, AVX2 or neither), and lists the SIMD paths."""
    env = {k: v for k, v in os.environ.items() if k != "MILLSCOPE_SIMD"}
    out = _info(env)
    assert out.returncode == 0, out.stderr
    assert "FFTW" in out.stdout and "fftw-3" in out.stdout and "OpenMP" in out.stdout
    paths = x86_simd_paths()
    if paths is None:
        pytest.skip("not an x86-64 Linux host")
    widest = {"avx512": "AVX-512, 8 listed pairs at a time",
              "avx2": "AVX2, 4 listed pairs at a time",
              "portable": "portable, one listed pair at a time (no AVX2, AVX-512, NEON or SVE "
                          "here)"}[paths[0]]
    assert _pair_search(out.stdout) == widest
    assert f"SIMD paths        {', '.join(paths)} (MILLSCOPE_SIMD picks one)" in out.stdout


def test_millscope_simd_picks_a_path_on_any_host() -> None:
    """MILLSCOPE_SIMD=portable gives the portable search on every CPU: `info` says so and an
    engine made under it takes it (so the suite can be run with it); a path the CPU does not
    run is one line naming the variable and the paths it does run, exit 2."""
    env = dict(os.environ, MILLSCOPE_SIMD="portable")
    out = _info(env)
    assert _pair_search(out.stdout) == ("portable, one listed pair at a time "
                                        "(MILLSCOPE_SIMD=portable)")
    code = ("import sys; import numpy as np; import millscope._core as c; "
            "e = c.Engine([c.Material(7800.0, 8e10, 0.3)], np.array([[0.5]]), "
            "np.array([[0.3]]), 0, c.DrumGeometry(0.4, 0.3, True, 0, 0.0, 0.0), "
            "np.array([0.01]), np.array([0], np.int32), 1e-6); "
            "sys.stdout.write(c.simd_path()[0] + ' ' + e.simd)")
    ran = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True, env=env).stdout
    assert ran == "portable portable"
    bad = _info(dict(os.environ, MILLSCOPE_SIMD="mmx"))
    assert bad.returncode == 2 and bad.stderr.count("\n") == 1
    assert "MILLSCOPE_SIMD = 'mmx'" in bad.stderr and "'portable'" in bad.stderr


@pytest.mark.parametrize("path, lanes, asked, line", [
    ("avx512", 8, False, "AVX-512, 8 listed pairs at a time"),
    ("avx2", 4, True, "AVX2, 4 listed pairs at a time"),
    ("neon", 2, False, "NEON, 2 listed pairs at a time"),
    ("portable", 1, False, "portable, one listed pair at a time (no AVX2, AVX-512, NEON or SVE "
                           "here)"),
    ("portable", 1, True, "portable, one listed pair at a time (MILLSCOPE_SIMD=portable)")])
def test_info_names_the_pair_search_of_any_cpu(path: str, lanes: int, asked: bool,
                                               line: str) -> None:
    """Every line, whatever this host has."""
    assert pair_search_line(path, lanes, asked) == line


@pytest.mark.parametrize("command", [
    ["demo", "--no-progress"],
    ["study", "accuracy", "--vary-dt-fraction", "0.1", "--no-progress"],
    ["bench", "--scale", "tiny", "--scenes", "balls", "--steps", "2", "--spin-up", "0.02",
     "--no-progress"],
])
def test_more_threads_than_the_cores_are_one_line_and_exit_2(
        capsys: pytest.CaptureFixture[str], tmp_path, command: list[str]) -> None:
    """`bench --threads 100000` crashed with a segfault (exit 139) and 10000 hung; demo and
    study take the same counts per case: refused by the option, before anything runs."""
    too_many = usable_cores() + 1
    out = ["--cache-dir" if command[0] == "bench" else "--out", str(tmp_path / "out")]
    with pytest.raises(SystemExit) as stop:
        main([*command, *out, "--threads", str(too_many)])
    assert stop.value.code == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err
    assert err.splitlines()[-1].endswith(
        f"error: argument --threads: '{too_many}' is not valid; it must be an integer in "
        f"[1, {usable_cores()}], the cores this process may use")
    assert not (tmp_path / "out").exists()


def test_analyze_prints_the_figures_and_writes_plots(csv_record, tmp_path, capsys) -> None:
    out_dir = tmp_path / "plots"
    code = main(["analyze", str(csv_record), "--lifters", "16", "--rotation-hz", "0.55",
                 "--from", "4", "--to", "14", "--resolution", "0.1", "--out", str(out_dir)])
    text = capsys.readouterr().out
    assert code == 0
    lth_line = next(line for line in text.splitlines() if line.startswith("LTH found"))
    assert float(lth_line.split()[2]) == pytest.approx(16 * 0.55, abs=0.02)
    assert "mean torque" in text and "spectral energy" in text
    for name in ("mill_spectrum.png", "mill_filtered.png"):
        assert (out_dir / name).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_analyze_removes_drive_lines_and_decimates(tmp_path, capsys) -> None:
    """A 1 kHz record with a 23.1 Hz motor line: decimated to 125 Hz, the line removed, only
    0-50 Hz counted."""
    content = SyntheticTorque(rotation_hz=0.61, noise_std_Nm=5.0, lines=((23.1, 40.0),))
    path = tmp_path / "measured.csv"
    synthetic_record(2, content=content, sample_rate_hz=1000.0, duration_s=12.0).to_csv(path)
    drive = tmp_path / "drive.json"
    drive.write_text('{"motor": {"pole_pairs": 2, "speed_hz": 23.1}, '
                     '"stages": [{"ratio": 37.8688524590164}], "lifters": 16}')
    args = ["analyze", str(path), "--lifters", "16", "--rotation-hz", "0.61", "--from", "1",
            "--to", "11", "--out", str(tmp_path)]
    assert main(args) == 0
    plain = capsys.readouterr().out
    assert main([*args, "--drive", str(drive)]) == 0
    with_drive = capsys.readouterr().out
    assert "decimated from 1000 Hz to 125 Hz" in with_drive

    def energy(text: str) -> float:
        return float(next(x for x in text.splitlines() if x.startswith("spectral")).split()[2])

    # white noise at 1 kHz keeps a tenth of its power in the 0-50 Hz band left by decimation
    noise_level = 5.0**2 * (-0.454 * np.log(2) + 0.9987) * 10.0 * (50.0 / 500.0)
    assert energy(with_drive) == pytest.approx(noise_level, rel=0.25)
    assert energy(plain) > 10 * noise_level  # the 40 N m motor line dominates when kept


@pytest.mark.parametrize(
    ("content", "extra", "message"),
    [
        ("time_s,torque\n0,1\n0.01,2\n", [], "missing column 'torque_Nm'"),
        ("time_s,torque_Nm\n0,1\n0.01,x\n", [], "'x' is not a number"),
        ("time_s,torque_Nm\n0,1\n0.01,nan\n0.02,1\n", [], "is not finite"),
        ("time_s,torque_Nm\n0,1\n0.01,2\n0.03,1\n", [], "sampling is not uniform"),
        ("time_s,torque_Nm\n0,1\n0.02,2\n0.01,1\n", [], "not strictly increasing"),
        (None, ["--resolution", "0.1", "--to", "5"], "coarser than the asked resolution_hz = 0.1"),
        (None, ["--from", "50", "--to", "60"], "--from 50 s is not valid; it must lie within"),
    ],
)
def test_bad_input_is_one_line_and_exit_2(tmp_path, csv_record, capsys, content, extra,
                                          message: str) -> None:
    path = csv_record
    if content is not None:
        path = tmp_path / "bad.csv"
        path.write_text(content)
    code = main(["analyze", str(path), "--lifters", "16", "--rotation-hz", "0.55", "--out",
                 str(tmp_path), *extra])
    err = capsys.readouterr().err
    assert code == 2
    assert err.startswith("millscope: error: ") and message in err
    assert err.count("\n") == 1 and "Traceback" not in err


def test_bad_options_exit_2_without_traceback(csv_record) -> None:
    run = subprocess.run([sys.executable, "-m", "millscope", "analyze", str(csv_record),
                          "--lifters", "0", "--rotation-hz", "0.5"], capture_output=True, text=True)
    assert run.returncode == 2
    assert "--lifters: '0' is not valid; it must be >= 1" in run.stderr
    assert "Traceback" not in run.stderr
    run = subprocess.run([sys.executable, "-m", "millscope", "analyze", "/no/such.csv",
                          "--lifters", "16", "--rotation-hz", "0.5"],
                         capture_output=True, text=True)
    assert run.returncode == 2 and "no such file" in run.stderr


@pytest.mark.parametrize("raised, code, message", [
    (KeyboardInterrupt(), 130, "interrupted; the finished cases are kept in"),
    (RuntimeError("1 of 4 cases failed, first LDMS#2: boom"), 2,
     "millscope: error: 1 of 4 cases failed, first LDMS#2: boom"),
])
def test_demo_reports_ctrl_c_and_a_failed_case_in_one_line(
        monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str], tmp_path,
        raised: BaseException, code: int, message: str) -> None:
    import millscope.demo

    def run_demo(*args: object, **kwargs: object) -> None:
        raise raised

    monkeypatch.setattr(millscope.demo, "run_demo", run_demo)
    assert main(["demo", "--out", str(tmp_path), "--no-progress"]) == code
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1

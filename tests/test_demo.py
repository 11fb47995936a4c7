"""The main job end to end, fast: a few short DEM cases at the tiny scale through the demo's
whole path (campaign, store, report), checked against the stored records re-analysed here; and
the synthetic analysis (``demo --synthetic``) against the law its records were made with."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest

import millscope as ms
from millscope.campaign import read_manifest
from millscope.cli import main
from millscope.demo import DemoPlan, DemoResult, run_demo, run_synthetic_demo
from millscope.synthetic import PAPER_HDMS_LAW

# three levels (the log fit then has a residual and the leave-one-out check runs), 0.8 s kept
# after 0.2 s (the shortest block DemoPlan takes is 0.69 s): seconds per case at the tiny scale
QUICK = DemoPlan(scale="tiny", load_levels=(3, 1, 2), duration_s=1.0, warm_up_s=0.2)


@pytest.fixture(scope="module")
def demo(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, DemoResult]:
    out = tmp_path_factory.mktemp("demo")
    return out, run_demo(out, QUICK, progress=False)


def _stored(out: Path) -> dict[int, ms.TorqueRecord]:
    """Every case file of the store, by load level (read back here, not through the demo)."""
    records = {}
    for path in sorted((out / "store" / "cases").glob("*.npz")):
        rec = ms.TorqueRecord.load(path)
        name = rec.meta["campaign"]["case"]["scene"]["name"]
        records[int(name.split("#")[1])] = rec
    return records


def test_demo_runs_a_dem_campaign_into_the_store(demo: tuple[Path, DemoResult]) -> None:
    out, result = demo
    manifest = read_manifest(out / "store")
    assert manifest["counts"] == {"done": 3, "failed": 0, "pending": 0}
    assert [r.scene.name for r in result.results] == ["LDMS#1", "LDMS#2", "LDMS#3"]
    records = _stored(out)
    assert sorted(records) == [1, 2, 3]
    for level, rec in records.items():
        assert rec.meta["source"] == "millscope DEM"
        scene = ms.Scene.from_dict(rec.meta["scene"])
        assert scene == ms.presets.pilot_mill(0.71, "ceramic", level, "tiny")
        # sample k is taken at k x 10 ms, k = 1, 2, ...: the warm-up drops the first 20
        assert len(rec) == 80 and rec.time_s[0] == pytest.approx(0.21)


def test_demo_report_agrees_with_the_stored_records(demo: tuple[Path, DemoResult]) -> None:
    out, result = demo
    for name in ("report.md", "fig12_waterfall_LDMS.png", "fig15_fits.png", "fig14_energy.png",
                 "calibration_LDMS.json", "torque_level1.png", "spectrum_level1.png",
                 "filtered_level1.png"):
        assert (out / name).stat().st_size > 0, name
    assert result.report == out / "report.md"
    assert result.calibration == out / "calibration_LDMS.json"

    # the energies re-computed from the raw records: mean and LTH (located as the paper does,
    # near 16 x rotation frequency) removed, Hann window, 0.3 Hz bands
    records = _stored(out)
    levels = np.array(sorted(records), dtype=float)
    energies = []
    for level in sorted(records):
        blk = records[level].block(0.2, 1.0)
        f_lth = 16 * records[level].meta["rotation_hz"]
        lth = ms.find_peak(blk, f_lth)
        energies.append(ms.spectral_energy(blk, ["mean", lth.frequency_hz], bandwidth=0.3).energy)
    e = np.array(energies)
    pu = e / e.max()
    a, b = np.polyfit(np.log(levels), pu, 1)  # y = a ln(x) + b by plain least squares

    cal = ms.Calibration.load(result.calibration)
    assert cal.reference_energy == pytest.approx(e.max(), rel=1e-9)
    assert (cal.fit.a, cal.fit.b) == pytest.approx((a, b), rel=1e-9, abs=1e-12)
    assert cal.block_s == pytest.approx(0.8) and cal.lifters == 16
    assert cal.rotation_hz == pytest.approx(ms.presets.pilot_mill(0.71).rotation_hz)

    text = (out / "report.md").read_text()
    # the campaign report (Table 6 analogue, per-level table) and the main job's section
    assert "## Table 6 analogue" in text and "## LDMS" in text and "## Main job: LDMS" in text
    for level, y in zip(levels, pu, strict=True):
        # the group table: level, cases, mean T, T p.u., LTH Hz, LTH N m, E, E p.u. [interval]
        row = rf"^\| {level:g} \| 1 \|(?:[^|\n]*\|){{5}} {y:.4f}[ [|]"
        assert re.search(row, text, re.M), (level, y)
    assert f"**Energy p.u.: {', '.join(f'{y:.3f}' for y in pu)}**" in text
    falls = bool(np.all(np.diff(pu) < 0))
    assert ("falls monotonically" in text) == falls
    assert ("does NOT fall monotonically" in text) == (not falls)
    assert "tiny" in text and "Leave-one-out" in text
    # the bias the paper-scale study measured for the scale it runs
    quoted = [f"{b.case} ({b.seeds} seeds): {b.figures()}"
              for b in ms.presets.SCALE_BIAS["tiny"].values() if b.case.startswith("LDMS#")]
    assert quoted and "- measured bias of this scale: the paper-scale study measured" in text
    assert all(q in text for q in quoted)
    for name in ("torque_level1.png", "fig12_waterfall_LDMS.png", "fig15_fits.png"):
        assert f"]({name})" in text, name


def test_a_two_level_demo_writes_no_calibration(tmp_path: Path) -> None:
    """Through 2 levels the fit is exact and gives no interval: the report writes no
    calibration for it and says why; the main job's section has no leave-one-out table."""
    plan = DemoPlan(scale="tiny", load_levels=(1, 2), duration_s=0.9, warm_up_s=0.2)
    result = run_demo(tmp_path, plan, progress=False)
    assert result.calibration is None and not list(tmp_path.glob("calibration*.json"))
    text = result.report.read_text()
    assert "No calibration file" in text and "Leave-one-out" not in text


def test_leave_one_out_of_3_levels_says_its_2_level_fits_give_no_interval(
        demo: tuple[Path, DemoResult]) -> None:
    """Each calibration left after holding one of 3 levels out goes through the other 2: an
    exact fit with no residual, so no interval; the report's rows say so, not 'nan'."""
    out, result = demo
    text = (out / "report.md").read_text()
    rows = re.findall(r"^\| (\d) \| [0-9.]+ \| ([^|]+) \| (?:yes|no) \|$", text, re.M)
    levels = sorted({int(r.scene.name.split("#")[1]) for r in result.results})
    assert [int(level) for level, _ in rows] == levels
    assert all(interval == f"none (fit through {len(levels) - 1} levels)"
               for _, interval in rows)
    assert "each calibration left is fitted through 2" in text


def test_a_rerun_reuses_the_store(demo: tuple[Path, DemoResult]) -> None:
    out, first = demo
    again = run_demo(out, QUICK, progress=False)
    assert [r.hash for r in again.results] == [r.hash for r in first.results]
    assert [r.energy for r in again.results] == [r.energy for r in first.results]
    assert all(r.wall_time_s == f.wall_time_s for r, f in zip(again.results, first.results,
                                                              strict=True))


@pytest.mark.parametrize(
    "kwargs, pattern",
    [
        ({"scale": "huge"}, r"DemoPlan.scale = 'huge'"),
        ({"particles": None}, r"DemoPlan.particles = None"),
        ({"load_levels": (1,)}, r"load_levels = \(1,\) .*at least 2"),
        ({"load_levels": (1, 1, 2)}, r"load_levels"),
        ({"load_levels": (0, 1)}, r"load_levels"),
        ({"speed_fraction": 1.5}, r"speed_fraction = 1.5"),
        ({"duration_s": 2.0, "warm_up_s": 2.0}, r"duration_s = 2.0 .* > warm_up_s"),
        ({"warm_up_s": -1.0}, r"warm_up_s = -1.0"),
        ({"threads": 0}, r"threads = 0"),
        ({"duration_s": 0.6, "warm_up_s": 0.0}, r"duration_s - warm_up_s = 0.6 s .* >= 0.69"),
    ],
)
def test_demo_plan_refuses_bad_input(kwargs: dict[str, object], pattern: str) -> None:
    with pytest.raises(ValueError, match=pattern):
        DemoPlan(**kwargs)  # type: ignore[arg-type]


@pytest.mark.parametrize(
    "args, message",
    [
        (["--levels", "2"], "load_levels"),
        (["--scale", "huge"], "scale = 'huge'"),
        (["--particles", "glass"], "particles = 'glass'"),
        (["--warm-up", "20"], "duration_s = 8.0"),
    ],
)
def test_demo_command_refuses_bad_input(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                        args: list[str], message: str) -> None:
    assert main(["demo", "--out", str(tmp_path / "out"), "--no-progress", *args]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("millscope: error:") and message in err and "\n" not in err
    assert not (tmp_path / "out").exists()  # nothing ran


def test_synthetic_demo_recovers_the_law(tmp_path: Path) -> None:
    report = run_synthetic_demo(tmp_path, progress=False)
    for name in ("synthetic_level1.csv", "synthetic_spectrum_level1.png",
                 "synthetic_filtered_level1.png", "synthetic_waterfall.png",
                 "synthetic_energy_fit.png", "synthetic_calibration.json",
                 "synthetic_report.txt"):
        assert (tmp_path / name).stat().st_size > 0, name
    assert (tmp_path / "synthetic_report.txt").read_text().strip() == report.strip()
    assert "SYNTHETIC" in report
    fit = json.loads((tmp_path / "synthetic_calibration.json").read_text())["fit"]
    a, b = PAPER_HDMS_LAW
    # per-unit of the largest of 7 noisy energies: the slope/intercept ratio is scale-free
    assert fit["a"] / fit["b"] == pytest.approx(a / b, rel=0.15)
    assert fit["a"] < 0  # energy falls as the filling rises


def test_demo_synthetic_command(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["demo", "--synthetic", "--out", str(tmp_path), "--no-progress"]) == 0
    assert "SYNTHETIC" in capsys.readouterr().out
    assert not (tmp_path / "store").exists()  # no DEM campaign

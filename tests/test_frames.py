"""Results as tables: the columns, types and values of every ``to_frame()`` (campaign results,
a campaign store, a study, the monitor's windows, one block's analysis), and the command
line's ``--format csv|json`` read back with pandas."""

from __future__ import annotations

import io
import json
import math
import shutil

import numpy as np
import pandas as pd
import pytest

import millscope as ms
from millscope.analysis import analyze_block
from millscope.campaign import CaseResults, read_manifest
from millscope.campaign.tables import CASE_COLUMNS
from millscope.cli import main
from millscope.monitoring import monitor_record
from millscope.studies import QUANTITIES, Setting, StudyPlan, StudyResult
from millscope.synthetic import SyntheticTorque, synthetic_record

from .synthetic_campaign import BLOCK, LAW, case_results, content_for, synthetic_store
from .test_studies import _fake_runs

LEVELS = (1, 2, 3)


def _is_str(series: pd.Series) -> bool:
    """A text column: pandas' str type (pandas 3) or object holding str (pandas 2)."""
    return bool(pd.api.types.is_string_dtype(series)
                or series.dropna().map(lambda v: isinstance(v, str)).all())


@pytest.fixture(scope="module")
def store(tmp_path_factory):
    """LDMS #1..#3, seeds 0 and 1, through the real store; #2 fails."""
    path = tmp_path_factory.mktemp("store")
    scenes = [ms.presets.pilot_mill(0.71, "ceramic", level, scale="tiny") for level in LEVELS]
    synthetic_store(path, scenes, seeds=(0, 1), fail=["LDMS#2"])
    return path


def test_campaign_results_table_has_one_typed_row_per_case(store) -> None:
    results = ms.Campaign.from_store(store).results()
    assert isinstance(results, CaseResults) and isinstance(results, list)
    table = results.to_frame()
    assert list(table.columns) == list(CASE_COLUMNS) and len(table) == len(results) == 6
    for name in ("load_level", "seed", "lifters", "n_particles", "threads"):
        assert table[name].dtype == np.int64, name
    assert table["lth_distinct"].dtype == bool
    for name in ("scene", "hash", "status", "group", "particles", "sampling", "window", "error"):
        assert _is_str(table[name]), name
    floats = [c for c, kind in CASE_COLUMNS.items() if kind == "float"]
    assert all(table[c].dtype == np.float64 for c in floats)
    assert "mean_torque_Nm" in floats and "energy_Nm2s" in floats and "speed_fraction" in floats

    for row, r in zip(table.itertuples(index=False), results, strict=True):
        scene = r.scene
        assert (row.scene, row.hash, row.status) == (scene.name, r.hash, r.status)
        assert (row.group, row.particles) == ("LDMS", "ceramic")
        assert row.load_level == int(scene.name.split("#")[1])  # the level the name gives
        assert row.seed == r.case.settings.seed
        assert row.speed_fraction == scene.speed_fraction == 0.71
        assert row.rotation_hz == scene.rotation_hz and row.lifters == scene.drum.lifters.count
        assert row.n_particles == sum(f.count for f in scene.charge)
        assert (row.sampling, row.sample_dt_s) == ("instant", 0.01)
        if r.status == "failed":
            assert row.error == "RuntimeError: synthetic failure"
            assert math.isnan(row.mean_torque_Nm) and math.isnan(row.energy_Nm2s)
            assert math.isnan(row.block_start_s)
            continue
        assert (row.block_start_s, row.block_end_s, row.bandwidth_hz) == (*BLOCK, 0.3)
        assert pd.isna(row.error)
        block = r.record.block(*BLOCK)
        assert row.mean_torque_Nm == pytest.approx(np.mean(block.torque_Nm), rel=1e-12)
        assert (row.lth_hz, row.lth_amplitude_Nm, row.lth_snr, row.lth_distinct) == (
            r.lth_hz, r.lth_amplitude, r.lth_snr, r.lth_distinct)
        # the noise floor is what the signal-to-noise ratio divides by
        assert row.lth_noise_Nm * row.lth_snr == pytest.approx(row.lth_amplitude_Nm)
        energy = ms.spectral_energy(block, ["mean", r.lth_hz], bandwidth=0.3, window="hann")
        assert row.energy_Nm2s == pytest.approx(energy.energy, rel=1e-12)
        assert row.energy_relative_std == r.energy_relative_std


def test_a_store_reads_as_one_table_with_failed_and_damaged_cases(store, tmp_path) -> None:
    copy = tmp_path / "store"
    shutil.copytree(store, copy)
    whole = ms.read_store(copy)
    pd.testing.assert_frame_equal(whole, ms.Campaign.from_store(copy).results().to_frame())
    assert whole["status"].tolist() == ["done", "done", "failed", "failed", "done", "done"]

    entry = next(e for e in read_manifest(copy)["cases"] if e["status"] == "done")
    (copy / entry["file"]).write_bytes(b"not a zip")
    table = ms.read_store(copy)
    assert len(table) == 6  # the damaged case is a row, not dropped
    damaged = table[table["status"] == "unreadable"]
    assert len(damaged) == 1
    row = damaged.iloc[0]
    assert (row["hash"], row["scene"], row["seed"]) == (entry["hash"], entry["name"],
                                                          entry["seed"])
    assert row["error"].startswith(entry["file"]) and math.isnan(row["energy_Nm2s"])
    assert table["seed"].dtype == np.int64  # the manifest gave its seed
    assert (table["status"] == "failed").sum() == 2

    # a case the manifest lists as pending (never run, no file) is a row too
    manifest = json.loads((copy / "manifest.json").read_text())
    manifest["cases"].append({"hash": "f" * 64, "name": "LDMS#9", "seed": 3,
                              "status": "pending", "file": None})
    (copy / "manifest.json").write_text(json.dumps(manifest))
    pending = ms.read_store(copy).iloc[-1]
    assert (pending["hash"], pending["scene"], pending["seed"], pending["status"]) == (
        "f" * 64, "LDMS#9", 3, "pending")


def test_a_study_table_holds_its_rows_and_is_its_csv() -> None:
    ref = Setting(scale="soft", record_s=2.0, warm_up_s=1.0)
    plan = StudyPlan((Setting(record_s=1.0, warm_up_s=1.0), ref), seeds=(0, 1),
                     particles="ceramic", load_levels=(1, 3))
    result = StudyResult.from_runs(plan, _fake_runs(plan, np.random.default_rng(9)))
    table = result.to_frame()
    assert len(table) == len(result.rows) == 4
    assert table["reference"].dtype == bool
    for name in ("load_level", "n_particles", "seeds"):
        assert table[name].dtype == np.int64
    assert _is_str(table["label"]) and _is_str(table["sampling"]) and _is_str(table["scale"])
    assert table["shear_modulus_factor"].isna().all()  # the scale's own
    for row, r in zip(table.to_dict("records"), result.rows, strict=True):
        assert (row["label"], row["reference"], row["load_level"]) == (
            r.label, r.reference, r.load_level)
        assert (row["record_s"], row["sampling"]) == (r.setting.record_s, r.setting.sampling)
        assert (row["dt_s"], row["wall_s"], row["seeds"]) == (r.dt_s, r.wall_s, r.seeds)
        for q in QUANTITIES:
            e = r.quantities[q]
            for suffix, value in (("", e.mean), ("_std", e.std), ("_error", e.error),
                                  ("_spread", e.spread), ("_error_se", e.error_se)):
                assert row[q + suffix] == value or (math.isnan(value)
                                                    and math.isnan(row[q + suffix]))
    # the CSV is that table: pandas reads it back value for value
    back = pd.read_csv(io.StringIO(result.to_csv()))
    back["reference"] = back["reference"].astype(bool)
    pd.testing.assert_frame_equal(back, table, check_dtype=False, check_exact=True)


@pytest.fixture(scope="module")
def calibration() -> ms.Calibration:
    return ms.Calibration.from_results(case_results(family=33))


def _long_record() -> ms.TorqueRecord:
    """30 s at level 2, then 30 s at level 5."""
    scene = ms.presets.pilot_mill(0.71, "ceramic", 1, scale="tiny")
    content = content_for(scene, LAW, noise_std_Nm=30.0)
    parts = [synthetic_record(level, content=content, duration_s=30.0, seed=50 + k)
             for k, level in enumerate((2.0, 5.0))]
    torque = np.concatenate([p.torque_Nm for p in parts])
    return ms.TorqueRecord(np.arange(torque.size) * 0.01, torque)


def test_the_monitor_windows_table(calibration) -> None:
    result = monitor_record(_long_record(), calibration, step_s=5.0, confidence=0.9)
    table = result.to_frame()
    assert list(table.columns) == ["start_s", "end_s", "level", "level_low", "level_high",
                                   "energy_pu", "outside"]
    assert table["outside"].dtype == bool
    assert all(table[c].dtype == np.float64 for c in table.columns[:-1])
    assert len(table) == len(result.windows) == 11  # (60 - 10) / 5 + 1
    for row, w in zip(table.itertuples(index=False), result.windows, strict=True):
        assert (row.start_s, row.end_s, row.level, row.energy_pu, row.outside) == (
            w.start_s, w.end_s, w.level, w.energy_pu, w.outside)
        assert (row.level_low, row.level_high) == w.interval
        assert row.level_low < row.level < row.level_high
    assert np.diff(table["start_s"]) == pytest.approx(5.0)
    assert table.attrs["confidence"] == 0.9 and table.attrs["window_s"] == calibration.block_s


@pytest.fixture
def csv_record(tmp_path):
    path = tmp_path / "mill.csv"
    synthetic_record(2, content=SyntheticTorque(rotation_hz=0.55), seed=4).to_csv(path)
    return path


def _read(text: str, fmt: str) -> pd.DataFrame:
    if fmt == "csv":
        return pd.read_csv(io.StringIO(text))
    return pd.DataFrame.from_records(json.loads(text))


@pytest.mark.parametrize("fmt", ["csv", "json"])
def test_analyze_prints_its_figures_as_a_table(csv_record, tmp_path, capsys, fmt) -> None:
    args = ["analyze", str(csv_record), "--lifters", "16", "--rotation-hz", "0.55", "--from",
            "4", "--to", "14", "--out", str(tmp_path), "--format", fmt]
    assert main(args) == 0
    printed = capsys.readouterr()
    assert "wrote" in printed.err and "wrote" not in printed.out
    back = _read(printed.out, fmt)
    block = ms.TorqueRecord.from_csv(csv_record).block(4.0, 14.0)
    expected = analyze_block(block, lifters=16, rotation_hz=0.55, band_hz=(0.0, 50.0)).to_frame()
    assert list(back.columns) == ["file", "block_start_s", "block_end_s", "samples",
                                  "sample_rate_hz", *expected.columns]
    assert back.loc[0, "samples"] == len(block) == 1000
    assert back.loc[0, "lth_hz"] == pytest.approx(16 * 0.55, abs=0.02)
    # no drive: no lines removed, an empty field (CSV: read as missing)
    assert expected.loc[0, "lines_hz"] == "" and back["lines_hz"].isna().sum() + (
        back["lines_hz"] == "").sum() == 1
    columns = [c for c in expected.columns if c != "lines_hz"]
    pd.testing.assert_frame_equal(back[columns], expected[columns], check_dtype=False,
                                  check_exact=True)


@pytest.mark.parametrize("fmt", ["csv", "json"])
def test_monitor_prints_its_windows_as_a_table(calibration, tmp_path, capsys, fmt) -> None:
    cal = calibration.save(tmp_path / "cal.json")
    csv = _long_record().to_csv(tmp_path / "long.csv")
    assert main(["monitor", str(csv), "--calibration", str(cal), "--format", fmt]) == 0
    back = _read(capsys.readouterr().out, fmt)
    expected = monitor_record(ms.TorqueRecord.from_csv(csv), calibration).to_frame()
    pd.testing.assert_frame_equal(back, expected, check_dtype=False, check_exact=True)


@pytest.mark.parametrize("fmt", ["csv", "json"])
def test_report_prints_the_store_as_a_table(store, tmp_path, capsys, monkeypatch, fmt) -> None:
    monkeypatch.setattr("millscope.plots.save_figure", lambda fig, path: None)
    out = tmp_path / "report"
    assert main(["report", str(store), "--out", str(out), "--no-progress", "--bootstrap", "20",
                 "--format", fmt]) == 0
    printed = capsys.readouterr()
    assert printed.err == f"wrote {out / 'report.md'}\n"
    back = _read(printed.out, fmt)
    expected = ms.read_store(store)
    assert back["status"].tolist() == expected["status"].tolist()  # the failed cases too
    if fmt == "json":  # JSON has no nan: missing numbers are null, read back as None
        back = back.fillna(value=np.nan)
    pd.testing.assert_frame_equal(back, expected, check_dtype=False, check_exact=True)


@pytest.mark.parametrize("command", [
    ["analyze", "x.csv", "--lifters", "16", "--rotation-hz", "0.5"],
    ["monitor", "x.csv", "--calibration", "cal.json"],
    ["report", "store"],
    ["demo"],
    ["study", "accuracy", "--vary-dt-fraction", "0.2"],
])
def test_a_bad_format_is_one_error_line_and_exit_2(capsys, command) -> None:
    with pytest.raises(SystemExit) as stop:
        main([*command, "--format", "xml"])
    assert stop.value.code == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err
    assert [line for line in err.splitlines() if "error:" in line] == [
        f"millscope {command[0] if command[0] != 'study' else 'study accuracy'}: error: "
        "argument --format: invalid choice: 'xml' (choose from 'text', 'csv', 'json')"]


def test_the_synthetic_demo_refuses_a_table(tmp_path, capsys) -> None:
    assert main(["demo", "--synthetic", "--out", str(tmp_path / "out"), "--format", "csv"]) == 2
    assert capsys.readouterr().err == ("millscope: error: --format csv is not valid with "
                                       "--synthetic, which runs no campaign; it must be text\n")
    assert not (tmp_path / "out").exists()


def test_study_and_demo_print_their_tables(monkeypatch, tmp_path, capsys) -> None:
    """The commands' campaigns stubbed: what they print is the table of what they got."""
    import types

    import millscope.campaign.studies
    import millscope.demo
    import millscope.report.reports

    plan = StudyPlan((Setting(record_s=1.0, warm_up_s=1.0), Setting(record_s=2.0)),
                     seeds=(0, 1))
    study = StudyResult.from_runs(plan, _fake_runs(plan, np.random.default_rng(2)))
    monkeypatch.setattr(millscope.campaign.studies, "run_study", lambda *a, **k: study)
    monkeypatch.setattr(millscope.report.reports, "write_study", lambda *a, **k: [])
    assert main(["study", "accuracy", "--out", str(tmp_path), "--vary-record", "1",
                 "--no-progress", "--format", "csv"]) == 0
    printed = capsys.readouterr()
    assert printed.err.startswith("millscope study accuracy: ")
    back = pd.read_csv(io.StringIO(printed.out))
    back["reference"] = back["reference"].astype(bool)
    pd.testing.assert_frame_equal(back, study.to_frame(), check_dtype=False, check_exact=True)

    results = case_results(LEVELS)

    def run_demo(*args: object, **kwargs: object) -> types.SimpleNamespace:
        print("millscope demo: DEM campaign ...")  # the demo's own message
        return types.SimpleNamespace(results=results, wall_time_s=1.0, report="report.md")

    monkeypatch.setattr(millscope.demo, "run_demo", run_demo)
    assert main(["demo", "--out", str(tmp_path), "--format", "json"]) == 0
    printed = capsys.readouterr()
    assert printed.err == "millscope demo: DEM campaign ...\ncampaign 1 s; report report.md\n"
    back = pd.DataFrame.from_records(json.loads(printed.out)).fillna(value=np.nan)
    pd.testing.assert_frame_equal(back, CaseResults(results).to_frame(), check_dtype=False,
                                  check_exact=True)

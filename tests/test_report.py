"""The report of a campaign store written through the real store code (cases answered with
synthetic records instead of DEM runs): files, tables, calibrations, figures, CLI, bad input."""

from __future__ import annotations

import contextlib
import io
import json
import re

import pytest

import millscope as ms
from millscope.campaign_analysis import analyze_campaign, table6_markdown
from millscope.cli import main
from millscope.fit import NoIntervalWarning
from millscope.presets import case_key
from millscope.report import write_report

from .synthetic_campaign import synthetic_store

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


@pytest.fixture(scope="module")
def store(tmp_path_factory):
    """LDMS at levels 1-4 (two seeds), HDHS at levels 1 and 3, a balls-only case, and a case
    that failed."""
    path = tmp_path_factory.mktemp("store")
    scenes = (ms.presets.paper_cases("ceramic", 0.71, [1, 2, 3, 4], scale="tiny")
              + ms.presets.paper_cases("steel", 0.80, [1, 3], scale="tiny")
              + ms.presets.paper_cases(None, 0.71, scale="tiny")
              + ms.presets.paper_cases("steel", 0.80, [5], scale="tiny"))
    results = synthetic_store(path, scenes, seeds=(0, 1), fail=["HDHS#5"])
    assert sum(r.status == "done" for r in results) == 14
    return path


@pytest.fixture(scope="module")
def report(store, tmp_path_factory):
    """The report as ``python -m millscope report STORE --out DIR`` writes it."""
    out = tmp_path_factory.mktemp("report")
    printed = io.StringIO()
    with contextlib.redirect_stdout(printed):
        assert main(["report", str(store), "--out", str(out), "--no-progress",
                     "--bootstrap", "300"]) == 0
    assert printed.getvalue().strip() == f"wrote {out / 'report.md'}"
    return out / "report.md"


def test_the_report_holds_table_6_and_every_figure(store, report) -> None:
    text = report.read_text()
    results = ms.Campaign.from_store(store).results()
    groups = analyze_campaign(results, bootstrap=300)
    assert [g.name for g in groups] == ["LDMS", "HDHS"]
    assert table6_markdown(groups) in text
    images = re.findall(r"!\[[^]]*\]\(([^)]+)\)", text)
    expected = {"fig09_torque.png", "fig10_spectra_LDMS.png", "fig10_spectra_HDHS.png",
                "fig11_lth.png", "fig12_waterfall_LDMS.png", "fig12_waterfall_HDHS.png",
                "fig14_energy.png", "fig15_fits.png"}
    assert set(images) == expected
    for name in images:
        assert (report.parent / name).read_bytes()[:8] == PNG_SIGNATURE
    for r in results:  # every case with a file is listed, failed ones with their error
        assert f"`{r.hash[:12]}`" in text
    assert "HDHS#5 seed 0" in text and "synthetic failure" in text
    assert "balls-MS" in text


def test_each_group_with_3_levels_gets_its_calibration(store, report) -> None:
    results = ms.Campaign.from_store(store).results()
    path = report.parent / "calibration_LDMS.json"
    assert f"({path.name})" in report.read_text()
    cal = ms.Calibration.load(path)
    assert cal.gives_intervals
    assert cal == ms.Calibration.from_results(results, group="LDMS", bootstrap=300)
    assert json.loads(path.read_text())["format"] == "millscope-calibration-2"


def test_a_two_level_group_gets_no_calibration_and_its_exact_fit_is_marked(store,
                                                                          report) -> None:
    """HDHS finished at levels 1 and 3 only (level 5 failed): its fit passes through both
    points, R^2 = 1 says nothing, and a calibration from it could give no interval."""
    results = ms.Campaign.from_store(store).results()
    hdhs_levels = {case_key(r.scene).load_level for r in results
                   if r.status == "done" and r.scene.name.startswith("HDHS")}
    assert hdhs_levels == {1, 3}
    text = report.read_text()
    assert not (report.parent / "calibration_HDHS.json").exists()
    section = text.split("## HDHS")[1].split("\n## ")[0]
    assert "No calibration file: its log fit goes through 2 load levels (1 and 3)" in section
    assert "R² = 1 (exact: 2 levels)" in section
    row = next(line for line in text.splitlines() if line.startswith("| HDHS | y = "))
    assert row.split(" | ")[2] == "1 (exact: 2 levels)"
    ldms = next(line for line in text.splitlines() if line.startswith("| LDMS | y = "))
    assert "exact" not in ldms
    with pytest.warns(NoIntervalWarning):  # what the report declined to write
        assert not ms.Calibration.from_results(results, group="HDHS").gives_intervals


def test_write_report_defaults_to_a_folder_in_the_store(store, report, monkeypatch) -> None:
    """write_report(store) writes STORE/report; its figures are the same calls as the CLI's
    (not drawn again here: save_figure is stubbed)."""
    saved = []
    monkeypatch.setattr("millscope.plots.save_figure", lambda fig, path: saved.append(path))
    path = write_report(store, progress=False, bootstrap=300)
    assert path == store / "report" / "report.md"
    assert {p.name for p in saved} == {p.name for p in report.parent.glob("*.png")}
    assert path.read_text().split("## Cases")[1] == report.read_text().split("## Cases")[1]


def test_cli_report_bad_input(store, tmp_path, capsys) -> None:
    empty = tmp_path / "empty"
    empty.mkdir()
    for args, message in [([str(tmp_path / "none")], "store = "),
                          ([str(empty)], "holds no case file"),
                          ([str(store), "--block", "4", "30"], "block = ")]:
        assert main(["report", *args, "--no-progress"]) == 2
        err = capsys.readouterr().err
        assert err.startswith("millscope: error: ") and message in err
        assert err.count("\n") == 1

"""The report of a campaign store written through the real store code (cases answered with
synthetic records instead of DEM runs): files, tables, calibrations, figures, CLI, bad input."""

from __future__ import annotations

import contextlib
import io
import json
import math
import re
import shutil
import zipfile
from pathlib import Path

import numpy as np
import pytest

import millscope as ms
from millscope.campaign import read_manifest, unreadable_cases
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


def test_table_6_is_followed_by_the_span_of_the_papers_six_fits(report) -> None:
    """The paper's Table 6: a from -0.476 (HDHS) to -0.408 (LDMS), R² from 0.8982 (LDMS) to
    0.9959 (HDMS)."""
    assert ("The paper's six fits (its Table 6): a from -0.476 to -0.408, R² from 0.898 to "
            "0.996.") in report.read_text()


def test_fig_9_quotes_each_groups_torque_change_beside_the_papers(store, report) -> None:
    """Fig. 9's caption: (max - min) / max of each group's mean torques per level (computed
    here from the results, seed means per level), and the paper's bound of 9 %."""
    results = [r for r in ms.Campaign.from_store(store).results() if r.status == "done"]
    quoted = []
    for group in ("LDMS", "HDHS"):
        per_level: dict[int, list[float]] = {}
        for r in results:
            key = case_key(r.scene)
            if r.scene.name.startswith(group) and key.load_level is not None:
                per_level.setdefault(key.load_level, []).append(r.mean_torque)
        means = np.array([np.mean(v) for _, v in sorted(per_level.items())])
        quoted.append(f"{group} {100 * (means.max() - means.min()) / means.max():.1f} %")
    assert (f"Largest change within a group, (max - min) / max: {', '.join(quoted)} (the "
            "paper's Fig. 9: under 9 %).") in report.read_text()


def test_the_cost_table_counts_each_groups_runs_and_core_hours(store, report) -> None:
    """Per group of the store's done cases (counted here from its manifest): the runs, their
    levels, and the sum of wall time x threads in hours; left to run, the failed cases (a rerun
    retries them). The synthetic records give no time step, so no particle-steps done and no
    pace."""
    results = {r.hash: r for r in ms.Campaign.from_store(store).results()}
    groups: dict[str, list[tuple[float, float | None]]] = {}
    for entry in read_manifest(store)["cases"]:
        r = results[entry["hash"]]
        groups.setdefault(case_key(r.scene).group, []).append(
            (entry["wall_time_s"] * r.case.settings.threads / 3600.0
             if entry["status"] == "done" else math.nan, case_key(r.scene).load_level))
    text = report.read_text()
    table = text[text.index("## Cost"):text.index("## Cases")]
    rows = {line.split("|")[1].strip(): [c.strip() for c in line.split("|")[2:-1]]
            for line in table.splitlines() if line.startswith("| ") and "---" not in line}
    assert set(rows) == {"group", *groups, "all"}
    for name, members in groups.items():
        levels = sorted({lv for _, lv in members if lv is not None})
        done = [h for h, _ in members if math.isfinite(h)]
        failed = len(members) - len(done)  # a rerun retries them
        assert rows[name][:7] == [",".join(f"{lv:g}" for lv in levels) or "-",
                                  str(len(members)), str(len(done)), str(len(done)), "-",
                                  f"{sum(done):.3g}", str(failed)]
        # the failed runs' planned steps; no pace to turn them into hours without a time step
        assert rows[name][7:] == (["0", "0"] if not failed else [rows[name][7], "-"])
        assert (rows[name][7] == "0") == (failed == 0)
    assert rows["all"][3] == "14"  # every done case ran alone: no twins in this store


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


# -- a store with a damaged case file ----------------------------------------------------------


@pytest.fixture(scope="module")
def whole_store(tmp_path_factory):
    """LDMS at levels 1-3, one seed: three finished cases."""
    path = tmp_path_factory.mktemp("whole") / "store"
    results = synthetic_store(path, ms.presets.paper_cases("ceramic", 0.71, [1, 2, 3],
                                                           scale="tiny"))
    assert [r.status for r in results] == ["done"] * 3
    return path


def _rewrite(path: Path, **arrays: np.ndarray) -> None:
    path.unlink()
    with open(path, "wb") as fh:
        np.savez(fh, **arrays)


def _damage(path: Path, kind: str) -> None:
    data = path.read_bytes()
    if kind == "truncated":
        path.write_bytes(data[: len(data) // 2])
    elif kind == "flipped":  # one byte in the middle of the samples
        flipped = bytearray(data)
        flipped[len(data) // 2] ^= 0xFF
        path.write_bytes(bytes(flipped))
    elif kind == "empty":
        path.write_bytes(b"")
    elif kind == "directory":
        path.unlink()
        path.mkdir()
    elif kind == "missing":
        path.unlink()
    elif kind == "huge header":  # the torque's header claims 10**11 values
        with zipfile.ZipFile(path) as archive:
            members = {name: archive.read(name) for name in archive.namelist()}
        header = io.BytesIO()
        np.lib.format.write_array_header_1_0(
            header, {"descr": "<f8", "fortran_order": False, "shape": (10**11,)})
        members["torque_Nm.npy"] = header.getvalue() + bytes(80)
        with zipfile.ZipFile(path, "w") as archive:
            for name, content in members.items():
                archive.writestr(name, content)
    else:
        with np.load(path) as npz:
            arrays = {name: npz[name] for name in npz.files}
        if kind == "no meta":
            del arrays["meta_json"]
        elif kind == "nan torque":
            arrays["torque_Nm"] = arrays["torque_Nm"].copy()
            arrays["torque_Nm"][7] = np.nan
        _rewrite(path, **arrays)


DAMAGE = {  # kind: what the reason must say
    "truncated": "BadZipFile", "flipped": "CRC", "empty": "an empty file",
    "directory": "a directory", "no meta": "no 'meta_json' array", "nan torque": "not finite",
    "missing": "missing, although manifest.json lists the case as done",
    "huge header": "torque_Nm.npy claims shape (100000000000,)"}


@pytest.mark.parametrize("kind", list(DAMAGE))
def test_report_names_a_case_file_it_cannot_read_and_fails(whole_store, tmp_path, kind,
                                                          capsys, monkeypatch) -> None:
    """The report of the readable cases is written, lists the damaged one with the reason,
    and the command exits 2 with one line naming it (before: exit 0, the case left out of
    the counts, or a NaN case shown as pending). Figures are stubbed (not drawn)."""
    monkeypatch.setattr("millscope.plots.save_figure", lambda fig, path: None)
    store = tmp_path / "store"
    shutil.copytree(whole_store, store)
    entries = read_manifest(store)["cases"]
    assert [e["status"] for e in entries] == ["done"] * 3
    bad = entries[1]
    file = f"cases/{bad['hash']}.npz"
    _damage(store / file, kind)

    out = tmp_path / "report"
    assert main(["report", str(store), "--out", str(out), "--no-progress",
                 "--bootstrap", "50"]) == 2
    printed = capsys.readouterr()
    assert printed.out == f"wrote {out / 'report.md'}\n"
    assert printed.err.count("\n") == 1
    assert printed.err.startswith("millscope: error: 1 case file could not be read")
    assert f"{file} ({bad['name']} seed 0): " in printed.err and DAMAGE[kind] in printed.err

    text = (out / "report.md").read_text()
    assert "3 cases, 2 done, 0 failed, **1 could not be read**" in text
    section = text.split("## Unreadable case files")[1]
    assert f"- `{file}` ({bad['name']} seed 0): " in section and DAMAGE[kind] in section
    cases = text.split("## Cases")[1].split("## Unreadable")[0]
    assert [e["hash"][:12] in cases for e in entries] == [True, False, True]

    (found,) = unreadable_cases(store)
    assert (found.file, found.hash, found.name) == (file, bad["hash"], f"{bad['name']} seed 0")
    camp = ms.Campaign.from_store(store)
    assert bad["hash"] not in camp.hashes and len(camp) == 2

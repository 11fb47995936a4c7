"""``millscope run case.toml`` and ``millscope campaign spec.toml``: a real run whose record is
the Python API's, a campaign and its resume, and one clear line for every bad file."""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import millscope as ms
from millscope.app import case_files
from millscope.campaign import Campaign, CaseResult, RunSettings
from millscope.campaign.study_plans import Setting
from millscope.cli import main
from millscope.presets import pilot_mill

EXAMPLES = Path(__file__).parent.parent / "examples"

# The tiny scale's balls-only slice, settled quickly (a loose tolerance: settle_min_s decides)
SETTLE = {"settle_tolerance": 10.0, "settle_min_s": 0.05, "settle_max_s": 0.1}
TINY = f"""
[scene]
preset = "pilot_mill"
speed_fraction = 0.71
scale = "tiny"

[settings]
seed = 3
duration_s = 0.3
warm_up_s = 0.1
sample_dt = 0.01
sampling = "mean"
threads = 1
dt_fraction = 0.2
energy_ledger = true
settle_tolerance = {SETTLE["settle_tolerance"]}
settle_min_s = {SETTLE["settle_min_s"]}
settle_max_s = {SETTLE["settle_max_s"]}

[output]
record = "out/tiny.csv"
checkpoint = "out/tiny.ckpt"
analysis = true
spectrum = "out/tiny.png"
"""

# 40 soft steel balls in a 0.3 m jar with 8 lifters: a case of well under a second
JAR = """
[[scenes]]
name = "jar"
speed_fraction = 0.71
materials = [{name = "steel", density = 7860.0, shear_modulus = 81e6, poisson = 0.3}]
charge = [{name = "balls", material = "steel", diameter = 0.025, count = 40}]
pairs = [{a = "steel", b = "steel", restitution = 0.5, friction = 0.15}]
[scenes.drum]
diameter = 0.3
length = 0.1
material = "steel"
lifters = {count = 8, width = 0.02, height = 0.015}
"""
CAMPAIGN = f"""
[campaign]
store = "store"
seeds = [0, 1]
block = [0.1, 0.5]
{JAR}
[settings]
duration_s = 0.5
warm_up_s = 0.1
sampling = "mean"
settle_tolerance = 10.0
settle_min_s = 0.05
settle_max_s = 0.1

[executor]
kind = "local"
max_workers = 1
"""


def write(tmp_path: Path, text: str, name: str = "case.toml") -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


def test_run_writes_the_record_the_python_api_gives(tmp_path, monkeypatch, capsys) -> None:
    monkeypatch.chdir(tmp_path)
    case = write(tmp_path, TINY)
    assert main(["run", str(case), "--no-progress"]) == 0
    out = capsys.readouterr().out

    # the same run built directly on the engine
    scene = pilot_mill(0.71, None, 1, "tiny")
    sim = ms.Simulation(scene, seed=3, dt=0.2 * scene.min_rayleigh_time()[0], threads=1,
                        track_energy=True, **SETTLE)  # the case file asks for the ledger
    full = sim.run(0.3, sample_dt=0.01, sampling="mean", progress=False)
    kept = slice(10, None)  # 0.1 s of warm-up at 0.01 s

    written = ms.TorqueRecord.load(tmp_path / "out" / "tiny.csv")
    np.testing.assert_array_equal(written.time_s, full.time_s[kept])
    np.testing.assert_array_equal(written.torque_Nm, full.torque_Nm[kept])
    assert written.meta["seed"] == 3 and written.meta["sampling"] == "mean"
    # the ledger of the run, and its checkpoint: the state at the end of the run
    assert written.meta["energies"] == pytest.approx(sim.energies(), rel=1e-12)
    restored = ms.Simulation.load(tmp_path / "out" / "tiny.ckpt")
    np.testing.assert_array_equal(restored.positions, sim.positions)
    assert restored.time == sim.time and abs(sim.time - 0.3) <= sim.dt
    assert (tmp_path / "out" / "tiny.png").read_bytes().startswith(b"\x89PNG\r\n")
    # the analysis printout's mean torque is the kept record's mean
    assert f"mean torque            {np.mean(full.torque_Nm[kept]):.6g} N m" in out


def test_campaign_file_runs_and_resumes_its_store(tmp_path, monkeypatch, capsys) -> None:
    monkeypatch.chdir(tmp_path)
    # the cases are real runs, in a thread pool rather than the local process pool, whose
    # workers take seconds to start (the file's max_workers is checked, then not used)
    run = Campaign.run

    def in_threads(self: Campaign, executor: object = None, *, max_workers: object = None,
                   **options: Any) -> list[CaseResult]:
        assert executor is None and max_workers == 1
        with ThreadPoolExecutor(1) as pool:
            return run(self, pool, **options)

    monkeypatch.setattr(Campaign, "run", in_threads)
    spec = write(tmp_path, CAMPAIGN, "spec.toml")
    assert main(["campaign", str(spec), "--no-progress"]) == 0
    out = capsys.readouterr().out
    assert "2 cases, 0 already done" in out
    files = sorted((tmp_path / "store" / "cases").glob("*.npz"))
    rows = [line.split() for line in out.splitlines() if line.startswith("jar ")]
    assert len(files) == 2 and [r[1:4] for r in rows] == [["0", "mean", "done"],
                                                          ["1", "mean", "done"]]
    first = ms.TorqueRecord.load(files[0])
    stamps = {f: f.stat().st_mtime_ns for f in files}

    # a rerun keeps both cases; with one case file gone it computes that one alone, again
    assert main(["campaign", str(spec), "--no-progress"]) == 0
    assert "2 cases, 2 already done" in capsys.readouterr().out
    assert {f: f.stat().st_mtime_ns for f in files} == stamps
    files[0].unlink()
    assert main(["campaign", str(spec), "--no-progress"]) == 0
    assert "2 cases, 1 already done" in capsys.readouterr().out
    assert files[1].stat().st_mtime_ns == stamps[files[1]]
    again = ms.TorqueRecord.load(files[0])
    np.testing.assert_array_equal(again.torque_Nm, first.torque_Nm)  # bit for bit


def test_a_campaign_file_listing_both_sampling_modes_stores_each_case_in_both(
        tmp_path, monkeypatch, capsys) -> None:
    monkeypatch.chdir(tmp_path)
    spec = write(tmp_path, CAMPAIGN.replace('sampling = "mean"',
                                            'sampling = ["instant", "mean"]'), "spec.toml")
    plan = case_files.load_campaign(spec)
    cases = plan.campaign.cases
    assert [(c.settings.seed, c.settings.sampling) for c in cases] == [
        (0, "instant"), (0, "mean"), (1, "instant"), (1, "mean")]
    # each pair differs in its sampling mode alone
    for a, b in (cases[0:2], cases[2:4]):
        assert a.settings.replace(sampling="mean") == b.settings and a.scene == b.scene
    assert main(["campaign", str(spec), "--no-progress"]) == 0
    rows = [line.split() for line in capsys.readouterr().out.splitlines()
            if line.startswith("jar ")]
    assert [r[1:4] for r in rows] == [["0", "instant", "done"], ["0", "mean", "done"],
                                      ["1", "instant", "done"], ["1", "mean", "done"]]
    infos = [ms.TorqueRecord.load(plan.campaign.case_file(k)).meta["campaign"]
             for k in range(4)]
    assert infos[0]["wall_time_s"] == infos[1]["wall_time_s"]  # one run made the pair


def test_a_campaign_file_reuses_the_finished_cases_of_another_store(
        tmp_path, monkeypatch, capsys) -> None:
    """``reuse``: the cases another store finished are copied, the rest run; the copies are
    the other store's files, byte for byte."""
    monkeypatch.chdir(tmp_path)
    earlier = write(tmp_path, edit(CAMPAIGN, 'store = "store"', 'store = "earlier"'), "a.toml")
    assert main(["campaign", str(earlier), "--no-progress"]) == 0
    spec = write(tmp_path, edit(CAMPAIGN, "seeds = [0, 1]",
                                'seeds = [0, 1, 2]\nreuse = ["earlier"]'), "b.toml")
    capsys.readouterr()
    assert main(["campaign", str(spec), "--no-progress"]) == 0
    out = capsys.readouterr().out
    assert "2 finished case(s) copied from earlier" in out and "3 cases, 2 already done" in out
    before = sorted((tmp_path / "earlier" / "cases").glob("*.npz"))
    for path in before:
        assert (tmp_path / "store" / "cases" / path.name).read_bytes() == path.read_bytes()
    assert len(list((tmp_path / "store" / "cases").glob("*.npz"))) == 3


@pytest.mark.parametrize("value", ['[]', '["mean", "mean"]', '["instant", "sum"]', '3'])
def test_a_bad_list_of_sampling_modes_is_refused(tmp_path, value) -> None:
    spec = write(tmp_path, CAMPAIGN.replace('sampling = "mean"', f"sampling = {value}"),
                 "spec.toml")
    with pytest.raises(case_files.CaseFileError,
                       match=r"spec.toml: \[settings\] sampling = .* is not valid; it must be "
                             r"one of 'instant', 'mean', or a list of them"):
        case_files.load_campaign(spec)


def api_message(build) -> str:
    """What the Python API says for the same value."""
    with pytest.raises(ValueError) as caught:
        build()
    return str(caught.value)


def edit(text: str, old: str, new: str) -> str:
    assert old in text
    return text.replace(old, new)


BAD_RUNS = [
    # a typo'd key: named, with its table and the allowed keys
    (lambda: edit(TINY, "seed = 3", "sead = 3"),
     "[settings]: unknown key 'sead'; the keys are seed, duration_s, warm_up_s, sample_dt, "
     "sampling, threads, dt, settle_tolerance, settle_min_s, settle_max_s, dt_fraction, "
     "energy_ledger"),
    (lambda: edit(TINY, "[settings]", "[setting]"),
     "unknown key 'setting'; the keys are scene, settings, output"),
    (lambda: edit(TINY, "scale = \"tiny\"", "scael = \"tiny\""),
     "[scene] (preset 'pilot_mill'): unknown key 'scael'; the keys are preset, "
     "speed_fraction, particles, load_level, scale, particle_diameter, ball_diameter"),
    # wrong types and values out of range: the API's own message
    (lambda: edit(TINY, "seed = 3", "seed = \"3\""),
     "[settings] " + api_message(lambda: RunSettings(seed="3"))),
    (lambda: edit(TINY, "warm_up_s = 0.1", "warm_up_s = 0.5"),
     "[settings] " + api_message(lambda: RunSettings(duration_s=0.3, warm_up_s=0.5))),
    (lambda: edit(TINY, "dt_fraction = 0.2", "dt_fraction = 0.9"),
     "[settings] " + api_message(lambda: Setting(dt_fraction=0.9))),
    (lambda: edit(TINY, "speed_fraction = 0.71", "speed_fraction = 4.0"),
     "[scene] " + api_message(lambda: pilot_mill(4.0, None, 1, "tiny"))),
    (lambda: edit(TINY, "energy_ledger = true", "energy_ledger = \"yes\""),
     "[settings] energy_ledger = 'yes' is not valid; it must be True or False"),
    (lambda: edit(TINY, "record = \"out/tiny.csv\"", "record = \"out/tiny.txt\""),
     "[output] record = 'out/tiny.txt' is not valid; it must be a path ending in .npz or .csv"),
    (lambda: edit(TINY, "record = \"out/tiny.csv\"", ""),
     "[output]: missing key 'record'"),
    (lambda: "scene = 3\n[output]\nrecord = 'a.npz'\n",
     "[scene]: the scene must be a table, not an integer"),
    (lambda: edit(TINY, "dt_fraction = 0.2", "dt_fraction = 0.2\ndt = 1e-5"),
     "[settings] dt = 1e-05 and dt_fraction = 0.2 are not valid together; give one of them "
     "(neither: the engine's default step)"),
    (lambda: edit(TINY, "tiny.png", "tiny.xyz"),
     "[output] spectrum = 'out/tiny.xyz' is not valid; it must be a path ending in "),
]


@pytest.mark.parametrize("text, message", [(t(), m) for t, m in BAD_RUNS])
def test_a_bad_case_file_is_one_line_and_exit_2_before_any_run(
        tmp_path, monkeypatch, capsys, text: str, message: str) -> None:
    monkeypatch.chdir(tmp_path)

    def no_run(*args: object, **kwargs: object) -> None:
        raise AssertionError("a simulation started")

    monkeypatch.setattr(case_files, "simulate_case", no_run)
    path = write(tmp_path, text)
    assert main(["run", str(path), "--no-progress"]) == 2
    captured = capsys.readouterr()
    assert captured.err.startswith(f"millscope: error: {path}: {message}")
    assert captured.err.count("\n") == 1 and captured.out == ""
    assert list(tmp_path.iterdir()) == [path]


def test_an_explicit_scene_gets_the_scenes_messages(tmp_path, capsys) -> None:
    text = edit(JAR.replace("[[scenes]]", "[scene]").replace("[scenes.", "[scene."),
                "diameter = 0.025", "diameter = -0.01")
    path = write(tmp_path, text + "[output]\nrecord = 'x.npz'\n")
    expected = api_message(lambda: ms.Fraction("steel", -0.01, 40))
    assert main(["run", str(path)]) == 2
    assert capsys.readouterr().err == f"millscope: error: {path}: [scene] {expected}\n"


@pytest.mark.parametrize("content, message", [
    (b"[scene\npreset = 1\n", "not valid TOML (Expected ']' at the end of a table declaration "
                              "(at line 1, column 7))"),
    (b"\xff\xfe[scene]\n", "not a UTF-8 text file (byte 0); a case file is TOML text"),
    (None, "no such case file"),
    ("/dev/zero", "larger than 4194304 bytes; a case file is a small text file, at most "
                  "4194304 bytes"),
    ("folder", "cannot read the case file (Is a directory)"),
])
def test_a_file_that_is_not_toml_is_one_line(tmp_path, capsys, content, message) -> None:
    path = tmp_path / "case.toml"
    if content == "/dev/zero":
        path = Path(content)
    elif content == "folder":
        path.mkdir()
    elif content is not None:
        path.write_bytes(content)
    assert main(["run", str(path)]) == 2
    assert capsys.readouterr().err == f"millscope: error: {path}: {message}\n"


def test_bad_campaign_files_are_one_line(tmp_path, monkeypatch, capsys) -> None:
    monkeypatch.chdir(tmp_path)
    cases = [
        (edit(CAMPAIGN, "seeds = [0, 1]", "seed = [0, 1]"),
         "[campaign]: unknown key 'seed'; the keys are store, block, seeds, bandwidth, window, "
         "retry_failed, reuse"),
        (edit(CAMPAIGN, "seeds = [0, 1]", 'seeds = [0, 1]\nreuse = "earlier"'),
         "[campaign] reuse = 'earlier' is not valid; it must be a list of campaign store "
         'directories, e.g. ["data/study-paper-ldms/store"]'),
        (edit(CAMPAIGN, "seeds = [0, 1]", 'seeds = [0, 1]\nreuse = ["nowhere"]'),
         "[campaign] reuse = ['nowhere'] is not valid; it must list existing campaign store "
         "directories ('nowhere' is not one; relative paths are relative to the working "
         "directory)"),
        (edit(CAMPAIGN, "seeds = [0, 1]", "seeds = [0, 0]"),
         "[campaign] seeds = [0, 0] is not valid; it must be free of repeats"),
        (edit(CAMPAIGN, "block = [0.1, 0.5]", "block = [0.1, 0.9]"),
         "[campaign] block = [0.1, 0.9] is not valid; it must be within the record of "
         "cases[0] (jar seed 0), [warm_up_s, duration_s] = [0.1, 0.5] s"),
        (edit(CAMPAIGN, "max_workers = 1", "max_workers = 0"),
         "[executor] max_workers = 0 is not valid; it must be an integer >= 1"),
        (edit(CAMPAIGN, 'kind = "local"', 'kind = "dask"'),
         "[executor] kind = 'dask' is not valid; it must be one of 'local'"),
    ]
    for text, message in cases:
        path = write(tmp_path, text, "spec.toml")
        assert main(["campaign", str(path), "--no-progress"]) == 2
        assert capsys.readouterr().err == f"millscope: error: {path}: {message}\n"
    assert not (tmp_path / "store").exists()


@pytest.mark.parametrize("name", ["tiny.toml", "paper.toml", "jar.toml", "campaign.toml",
                                  "paper_campaign.toml"])
def test_the_examples_are_valid(tmp_path, monkeypatch, name: str) -> None:
    monkeypatch.chdir(tmp_path)  # checking writes nothing
    campaign = name.endswith("campaign.toml")
    load = case_files.load_campaign if campaign else case_files.load_run
    plan = load(EXAMPLES / name)
    assert list(tmp_path.iterdir()) == []
    if name == "paper_campaign.toml":  # Table 5's seven levels, 3 seeds, both sampling modes
        assert isinstance(plan, case_files.CampaignPlan)
        cases = plan.campaign.cases
        assert len(cases) == 7 * 3 * 2
        assert sorted({c.scene.n_particles for c in cases}) == [
            pilot_mill(0.71, "ceramic", level, "paper").n_particles for level in range(1, 8)]

"""A study's report made again from its folder (plan file and campaign store), simulating
nothing: the committed paper-scale study (data/study-paper-balls) and synthetic runs.

References: numpy on the stored records (mean torque, the errors of the seed means), numpy on
the runs' energies (the per-unit energy ratio), and the plan that wrote the plan file.
"""

from __future__ import annotations

import json
import math
import shutil
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np
import pytest

from millscope.app.case_files import load_campaign
from millscope.app.cli import build_parser, main
from millscope.calibration.groups import analyze_campaign
from millscope.campaign import Campaign
from millscope.campaign.studies import (
    PLAN_FILE,
    Setting,
    StudyPlan,
    StudyResult,
    read_study,
    read_study_plan,
    run_study,
    save_study_plan,
)
from millscope.model.presets import SCALE_BIAS, ScaleBias, measured_bias, pilot_mill
from millscope.report.plots import PAPER_TORQUE_CHANGE, torque_change
from millscope.report.reports import write_study
from millscope.signal.record import TorqueRecord
from millscope.signal.synthetic import PAPER_TABLE_6

from .test_studies import SHORT, _fake_runs

STUDY = Path(__file__).resolve().parents[1] / "data" / "study-paper-balls"
LDMS_STUDY = STUDY.parent / "study-paper-ldms"


# -- the plan file ------------------------------------------------------------------------------


def test_the_plan_file_reads_back_the_plan_that_wrote_it(tmp_path) -> None:
    plan = StudyPlan.around(SHORT, {"dt_fraction": [0.1], "sampling": ["mean"]},
                            seeds=(3, 5), particles="ceramic", load_levels=(1, 4))
    save_study_plan(plan, tmp_path)
    back = read_study_plan(tmp_path)
    assert back == plan
    assert back.reference == plan.reference
    assert [c.hash() for c in back.cases()] == [c.hash() for c in plan.cases()]


@pytest.mark.parametrize(("edit", "words"), [
    (lambda d: d.pop("format"), ["not a millscope study plan"]),
    (lambda d: d["plan"].pop("seeds"), ["exactly the fields", "seeds"]),
    (lambda d: d["plan"].update(reference=7), ["reference = 7", "0..1"]),
    (lambda d: d["plan"].update(seeds=[1]), ["StudyPlan.seeds", "at least 2"]),
    (lambda d: d["plan"]["settings"][0].update(dt_fraction=2.0), ["dt_fraction = 2.0"]),
    (lambda d: d["plan"]["settings"][0].update(colour="red"), ["settings is not valid"]),
])
def test_a_damaged_plan_file_is_one_clear_error(tmp_path, edit, words) -> None:
    save_study_plan(StudyPlan.ladder("dt_fraction", [0.1, 0.3], base=SHORT), tmp_path)
    path = tmp_path / PLAN_FILE
    data = json.loads(path.read_text())
    edit(data)
    path.write_text(json.dumps(data))
    with pytest.raises(ValueError) as info:
        read_study_plan(tmp_path)
    for word in words:
        assert word in str(info.value)


# -- the per-unit energy ratio ------------------------------------------------------------------


def test_the_energy_ratio_is_last_over_first_level_per_seed() -> None:
    plan = StudyPlan.ladder("dt_fraction", [0.1, 0.3], base=SHORT, particles="ceramic",
                            load_levels=(4, 1), seeds=(0, 1, 2))
    runs = _fake_runs(plan, np.random.default_rng(5))
    result = StudyResult.from_runs(plan, runs)

    def ratios(k: int) -> np.ndarray:
        energy = {(r.setting, r.load_level, r.seed): r.energy for r in runs}
        return np.array([energy[(k, 4, s)] / energy[(k, 1, s)] for s in plan.seeds])

    q, q_ref = ratios(1), ratios(0)
    for row in result.rows:
        e = row.quantities["energy_ratio"]
        if row.reference:
            assert e.mean == pytest.approx(q_ref.mean())
            assert e.error == 0.0
        else:
            assert e.mean == pytest.approx(q.mean())
            assert e.error == pytest.approx((q.mean() - q_ref.mean()) / q_ref.mean())
            assert e.error_se == pytest.approx(
                np.sqrt(q.var(ddof=1) / 3 + q_ref.var(ddof=1) / 3) / q_ref.mean())
    se = q_ref.std(ddof=1) / math.sqrt(3) / q_ref.mean()
    need = max(2, math.ceil(3 * (se / 0.05) ** 2))
    assert f"a 5 % standard error needs {need} seeds" in result.to_markdown("energy_ratio")


def test_a_partial_study_leaves_out_unfinished_settings_but_not_the_reference() -> None:
    plan = StudyPlan.ladder("dt_fraction", [0.1, 0.2, 0.3], base=SHORT, seeds=(0, 1))
    runs = _fake_runs(plan, np.random.default_rng(6))
    some = [r for r in runs if not (r.setting == 2 and r.seed == 1)]
    result = StudyResult.from_runs(plan, some, partial=True)
    assert result.settings == plan.settings[:2]
    assert result.pending == (plan.settings[2],)
    assert ("Not finished yet (only their finished levels are shown, and they stay off the "
            "Pareto front): " + plan.settings[2].label) in result.to_markdown()
    with pytest.raises(ValueError, match="runs lack setting 2"):
        StudyResult.from_runs(plan, some)
    no_ref = [r for r in runs if r.setting != plan.reference_index]
    with pytest.raises(ValueError, match="the reference: nothing to compare with yet"):
        StudyResult.from_runs(plan, no_ref, partial=True)


def test_a_partial_study_shows_the_levels_finished_with_the_reference(tmp_path) -> None:
    """Two levels: the reference and a setting finished at level 1 only are compared there;
    the per-unit energy, which needs both levels, is left empty, and neither is a point of
    the Pareto front yet."""
    plan = StudyPlan.ladder("dt_fraction", [0.1, 0.2, 0.3], base=SHORT, seeds=(0, 1),
                            particles="ceramic", load_levels=(1, 2))
    runs = _fake_runs(plan, np.random.default_rng(7))
    some = [r for r in runs if not (r.setting in (0, 1) and r.load_level == 2)]
    result = StudyResult.from_runs(plan, some, partial=True)
    levels = {(plan.settings.index(r.setting), r.load_level) for r in result.rows}
    assert levels == {(0, 1), (1, 1), (2, 1)}  # level 2 lacks the reference (setting 0)
    assert result.pending == (plan.settings[0], plan.settings[1])
    ref = plan.reference_index
    by = {(r.setting, r.load_level, r.seed): r for r in some}
    for row in result.rows:
        k = plan.settings.index(row.setting)
        e = np.array([by[(k, 1, s)].energy for s in plan.seeds])
        e_ref = np.array([by[(ref, 1, s)].energy for s in plan.seeds])
        assert row.quantities["energy"].error == pytest.approx(
            (e.mean() - e_ref.mean()) / e_ref.mean())
        assert math.isnan(row.quantities["energy_ratio"].error)
    assert [s.setting for s in result.summary("energy")] == [plan.settings[2]]
    assert "| setting | level |" in result.to_markdown("energy_ratio")
    # no finished setting has a per-unit energy error yet: the tables, without the figure
    written = write_study(result, tmp_path, quantity="energy_ratio")
    assert [p.name for p in written] == ["accuracy.csv", "accuracy.md"]
    assert [p.name for p in write_study(result, tmp_path, quantity="energy")][-1] == \
        "accuracy.png"
    with pytest.raises(ValueError, match="runs lack setting 0"):
        StudyResult.from_runs(plan, some)


# -- the committed paper-scale study ------------------------------------------------------------


def _block_means(result: StudyResult, k: int) -> np.ndarray:
    """Mean torque of each seed's block, by numpy on the stored record, per length of the
    reference's drum (a slice stands for its share of the mill)."""
    setting = result.plan.settings[k]
    out = []
    for run in sorted((r for r in result.runs if r.setting == k), key=lambda r: r.seed):
        record = TorqueRecord.load(STUDY / "store" / "cases" / f"{run.hash}.npz")
        t, torque = record.time_s, record.torque_Nm
        block = (t >= setting.warm_up_s) & (t < setting.duration_s)
        length = result.plan.scene(setting, 1).drum.length
        ref_length = result.plan.scene(result.reference, 1).drum.length
        out.append(torque[block].mean() * ref_length / length)
    return np.array(out)


def test_the_committed_study_reads_back_without_simulating() -> None:
    result = read_study(STUDY)
    plan = result.plan
    assert plan.settings[plan.reference_index].scale == "paper"
    k_ref = plan.reference_index
    ref = _block_means(result, k_ref)
    ref_row = next(r for r in result.rows if r.reference)
    assert ref_row.quantities["mean_torque"].mean == pytest.approx(ref.mean(), rel=1e-12)
    for row in result.rows:
        if row.reference:
            continue
        v = _block_means(result, plan.settings.index(row.setting))
        e = row.quantities["mean_torque"]
        assert e.error == pytest.approx((v.mean() - ref.mean()) / ref.mean(), rel=1e-9)
        assert e.error_se == pytest.approx(
            np.sqrt(v.var(ddof=1) / v.size + ref.var(ddof=1) / ref.size) / ref.mean(), rel=1e-9)
    assert len(result.rows) + len(result.pending) == len(plan.settings)


def test_report_on_a_study_folder_writes_its_tables(tmp_path, capsys) -> None:
    folder = tmp_path / "study"
    shutil.copytree(STUDY, folder)
    for target in (folder, folder / "store"):  # the folder or its store
        out = tmp_path / f"out-{target.name}"
        assert main(["report", str(target), "--out", str(out)]) == 0
        printed = capsys.readouterr().out
        assert "(reference)" in printed
        table = StudyResult.from_csv(out / "accuracy.csv")
        assert [r.label for r in table.rows] == [r.label for r in read_study(folder).rows]
        assert (out / "accuracy.png").stat().st_size > 0
    assert main(["report", str(folder), "--out", str(tmp_path / "steps"),
                 "--cost", "particle_steps"]) == 0
    printed = capsys.readouterr().out
    front = read_study(folder).pareto("energy", "particle_steps")
    assert "Pareto front of particle-steps against" in printed
    assert printed.count(" ◆ |") == len(front)
    assert main(["report", str(folder), "--block", "4", "14"]) == 2
    assert "--block is not valid for a study" in capsys.readouterr().err


def test_report_on_a_study_without_its_reference_is_one_error(tmp_path, capsys) -> None:
    plan = StudyPlan.ladder("dt_fraction", [0.1, 0.3], base=Setting(record_s=1.0, warm_up_s=0.5))
    save_study_plan(plan, tmp_path)
    (tmp_path / "store").mkdir()
    assert main(["report", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("millscope: error:") and "nothing to compare with yet" in err
    assert len(err.strip().splitlines()) == 1


# -- shorter blocks cut from longer runs (tiny DEM) ----------------------------------------------


def test_a_shorter_block_is_cut_from_the_longer_run_exactly(tmp_path) -> None:
    """The record ladder runs only its longest block; the shorter one, run on its own as a
    campaign case, gives the same samples bit for bit as the head of the longer record."""
    plan = StudyPlan.ladder("record_s", [1.0, 2.0], base=Setting(warm_up_s=0.5), seeds=(0, 1))
    short = [i for i, (k, *_) in enumerate(plan._cases) if plan.settings[k].record_s == 1.0]
    assert [plan.donor(i) is not None for i in range(len(plan.cases()))] == [
        i in short for i in range(len(plan.cases()))]
    with ThreadPoolExecutor(1) as pool:
        result = run_study(plan, tmp_path / "study" / "store", executor=pool, progress=False)
    assert len(list((tmp_path / "study" / "store" / "cases").glob("*.npz"))) == 2  # only 2 ran
    alone = Campaign([plan.cases()[short[0]]], tmp_path / "alone", block=None)
    with ThreadPoolExecutor(1) as pool:
        (own,) = alone.run(executor=pool, progress=False)
    donor = result.record(next(r for r in result.runs if r.seed == 0 and not r.derived))
    n = len(own.record)
    assert np.array_equal(own.record.torque_Nm, donor.torque_Nm[:n])
    assert np.array_equal(own.record.time_s, donor.time_s[:n])
    run = next(r for r in result.runs if r.seed == 0 and r.derived)
    t, x = own.record.time_s, own.record.torque_Nm
    assert run.mean_torque == np.mean(x[(t >= 0.5 - 1e-9) & (t < 1.5 - 1e-9)])
    assert run.particle_steps < next(r.particle_steps for r in result.runs
                                     if r.seed == 0 and not r.derived)


def test_also_adds_a_setting_with_several_knobs_changed(tmp_path, capsys) -> None:
    """--also KNOB=V,... parses into Setting fields; a bad one is one error line (argparse's
    exit 2) before any work."""
    out = tmp_path / "s"
    args = ["study", "accuracy", "--out", str(out), "--record", "1", "--warm-up", "0.5",
            "--seeds", "2", "--vary-dt-fraction", "0.3", "--no-progress"]
    for bad in ("scale=tiny,colour=red", "shear=soft", "scale=tiny,scale=small", "tiny"):
        with pytest.raises(SystemExit) as info:
            main([*args, "--also", bad])
        err = capsys.readouterr().err
        assert info.value.code == 2 and "--also" in err and "is not valid" in err
        assert not out.exists()
    parsed = build_parser().parse_args([*args, "--also", "scale=tiny,shear=0.001",
                                        "--also", "dt-fraction=0.2,sampling=instant"])
    assert parsed.also == [{"scale": "tiny", "shear_modulus_factor": 0.001},
                           {"dt_fraction": 0.2, "sampling": "instant"}]
    reference = Setting(dt_fraction=0.1, record_s=1.0, warm_up_s=0.5)
    settings = [reference.replace(**changes) for changes in parsed.also]
    assert settings[0].label == "dt 0.1 T_R, G x0.001, tiny, 0.5+1 s, instant"


# -- what the presets say each scale's bias is -------------------------------------------------


_BIASES = [(scale, case) for scale, cases in SCALE_BIAS.items() for case in cases]
# The committed study that measured each group of cases
_STUDIES = {"balls-MS": STUDY, "LDMS": LDMS_STUDY}


@pytest.mark.parametrize(("scale", "case"), _BIASES)
def test_the_scale_bias_is_what_the_committed_study_measured(scale: str, case: str) -> None:
    """presets.SCALE_BIAS quotes the studies rounded: the study read again must round to it."""
    bias = SCALE_BIAS[scale][case]
    group, _, level = case.partition("#")
    own = pilot_mill(0.71, scale=scale)
    paper = pilot_mill(0.71, scale="paper")
    factor = (own.material(own.drum.material).shear_modulus
              / paper.material(paper.drum.material).shear_modulus)
    result = read_study(_STUDIES[group])
    (row,) = [r for r in result.rows  # the scale's drum and stiffness, the reference's rest
              if r.length_m == own.drum.length
              and (r.setting.scale == "paper") == (own.drum.length == paper.drum.length)
              and r.shear_modulus_ratio == pytest.approx(factor, rel=1e-12)
              and r.setting.dt_fraction == result.reference.dt_fraction
              and r.setting.record_s == result.reference.record_s
              and r.setting.sampling == result.reference.sampling
              and (not level or r.load_level == int(level))]
    q = row.quantities
    assert bias.case == case and row.seeds == bias.seeds
    assert bias.mean_torque == pytest.approx(q["mean_torque"].error, abs=5e-4)
    assert bias.mean_torque_se == pytest.approx(q["mean_torque"].error_se, abs=5e-4)
    assert bias.energy == pytest.approx(q["energy"].error, abs=5e-4)
    assert bias.energy_se == pytest.approx(q["energy"].error_se, abs=5e-4)
    ratio = q["energy_ratio"]
    if bias.per_unit_energy is None:  # the first level's per-unit energy is 1 by definition
        assert level in ("", "1") or not math.isfinite(ratio.error)
    else:
        assert bias.per_unit_energy == pytest.approx(ratio.error, abs=5e-4)
        assert bias.per_unit_energy_se == pytest.approx(ratio.error_se, abs=5e-4)


def test_the_biases_quoted_for_a_group_are_its_cases_in_level_order() -> None:
    """measured_bias picks a group's cases out of SCALE_BIAS, in load-level order, and names
    a scale it does not know."""
    ldms = measured_bias("tiny", "LDMS")
    assert [b.case for b in ldms] == sorted(c for c in SCALE_BIAS["tiny"] if c.startswith("LDMS#"))
    assert [b.case for b in measured_bias("tiny", "balls-MS")] == ["balls-MS"]
    assert measured_bias("tiny", "HDMS") == () and measured_bias("small", "LDMS") == ()
    with pytest.raises(ValueError, match="scale = 'huge' is not valid"):
        measured_bias("huge", "LDMS")
    with pytest.raises(ValueError, match="per_unit_energy and per_unit_energy_se"):
        ScaleBias("LDMS#4", 3, -0.1, 0.01, -0.9, 0.08, per_unit_energy=-0.2)


def test_the_paper_campaign_takes_its_reference_levels_from_the_ldms_study(
        tmp_path, monkeypatch) -> None:
    """data/paper-campaign runs LDMS #1-#7 at the LDMS study's reference; its level-1 and
    level-4 cases are the study's reference runs, in both sampling modes (the same hashes),
    so adopting them copies exactly those, and each copy is the study's file."""
    root = Path(__file__).resolve().parents[1]
    monkeypatch.chdir(root)  # the campaign file's paths are relative to the checkout's top
    plan = load_campaign("data/paper-campaign/campaign.toml")
    study = read_study_plan(LDMS_STUDY)
    reference = {c.hash() for k, _, _, c in study._cases
                 if study.settings[k] in (study.reference,
                                          study.reference.replace(sampling="mean"))}
    camp = plan.campaign
    shared = [d for d in camp.hashes if d in reference]
    at_1_and_4 = [d for c, d in zip(camp.cases, camp.hashes, strict=True)
                  if c.scene.name in ("LDMS#1", "LDMS#4")]
    assert len(camp) == 7 * 2 * 2  # levels x seeds x sampling modes
    assert shared == at_1_and_4 and len(shared) == 2 * 2 * 2
    here = Campaign(camp.cases, tmp_path / "store", block=camp.block)
    assert set(here.adopt([root / reuse for reuse in plan.reuse])) == set(shared)
    for digest in shared:
        copied = tmp_path / "store" / "cases" / f"{digest}.npz"
        assert copied.read_bytes() == (LDMS_STUDY / "store" / "cases" /
                                       copied.name).read_bytes()


def test_the_committed_paper_campaign_stands_beside_the_papers_table_6_and_fig_9(
        monkeypatch) -> None:
    """Every case of data/paper-campaign is in the committed store (LDMS #1-#7, 2 seeds, both
    sampling modes), and reading it again gives what the paper published for its DEM runs in
    the sampling it used (instantaneous 10 ms samples): a log fit of the per-unit energy whose
    slope lies within the span of Table 6's six fits, R² above its lowest, and a mean torque that
    changes by less than Fig. 9's 9 % across the levels, in both modes."""
    root = Path(__file__).resolve().parents[1]
    monkeypatch.chdir(root)
    camp = load_campaign("data/paper-campaign/campaign.toml").campaign  # on its store
    results = camp.results()
    assert len(results) == len(camp) == 28 and all(r.ok for r in results)
    groups = {g.name: g for g in analyze_campaign(results, bootstrap=0)}
    assert sorted(groups) == ["LDMS-instant", "LDMS-mean"]
    a = [fit[0] for fit in PAPER_TABLE_6.values()]
    r2 = [fit[2] for fit in PAPER_TABLE_6.values()]
    instant = groups["LDMS-instant"]
    assert instant.levels.tolist() == [1, 2, 3, 4, 5, 6, 7]
    assert min(a) <= instant.log_fit.a <= max(a)
    assert instant.log_fit.r2 >= min(r2)
    for g in groups.values():
        assert 0.0 < torque_change(g.torque_pu) < PAPER_TORQUE_CHANGE

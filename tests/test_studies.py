"""Error against run time (millscope.studies): plans, the statistics of a table, its Pareto
front, CSV and Markdown, the figure, the command line, and a study of the tiny mill whose
errors are checked against numpy on the stored records."""

from __future__ import annotations

import dataclasses
import itertools
import math
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest
from matplotlib.figure import Figure

import millscope as ms
from millscope import plots
from millscope.analysis import analyze_block
from millscope.campaign import Case
from millscope.cli import main
from millscope.presets import pilot_mill
from millscope.studies import (
    QUANTITIES,
    QuantityError,
    Setting,
    StudyPlan,
    StudyResult,
    StudyRow,
    StudyRun,
    run_study,
)

from .cpu import usable_cores

# -- settings and plans (no simulation) --------------------------------------------------------


@pytest.mark.parametrize(("changes", "words"), [
    ({"dt_fraction": 0.6}, ["Setting.dt_fraction", "0.6", "(0, 0.5]"]),
    ({"dt_fraction": 0.0}, ["Setting.dt_fraction", "0.0", "(0, 0.5]"]),
    ({"shear_modulus_factor": 2.0}, ["Setting.shear_modulus_factor", "2.0", "(0, 1]"]),
    ({"shear_modulus_factor": "soft"}, ["Setting.shear_modulus_factor", "'soft'", "(0, 1]"]),
    ({"record_s": -1.0}, ["Setting.record_s", "-1.0 s", "in (0, 3598] s"]),
    ({"record_s": 1e308}, ["Setting.record_s", "1e+308 s", "in (0, 3598] s", "3600 s of rotation"]),
    ({"warm_up_s": math.nan}, ["Setting.warm_up_s", "nan", "in [0, 3600] s"]),
    ({"sampling": "peak"}, ["Setting.sampling", "'peak'", "'instant', 'mean'"]),
    ({"scale": "huge"}, ["Setting.scale", "'huge'", "'paper'", "'tiny'"]),
])
def test_a_bad_setting_names_the_knob_the_value_and_the_range(changes, words) -> None:
    with pytest.raises(ValueError) as info:
        Setting(**changes)
    for word in words:
        assert word in str(info.value)


SHORT = Setting(record_s=1.0, warm_up_s=0.5)  # the block holds 6 LTH periods and more


@pytest.mark.parametrize(("make", "words"), [
    (lambda: StudyPlan((SHORT,)), ["StudyPlan.settings", "at least 2"]),
    (lambda: StudyPlan((SHORT, SHORT)), ["settings[1]", "repeats settings[0]"]),
    (lambda: StudyPlan((SHORT, SHORT.replace(shear_modulus_factor=0.001))),
     ["settings[1]", "same cases as settings[0]"]),
    (lambda: StudyPlan((SHORT, SHORT.replace(dt_fraction=0.3)), seeds=(3,)),
     ["StudyPlan.seeds", "(3,)", "at least 2"]),
    (lambda: StudyPlan((SHORT, SHORT.replace(dt_fraction=0.3)), seeds=(1, 1)),
     ["StudyPlan.seeds", "(1, 1)"]),
    (lambda: StudyPlan((SHORT, SHORT.replace(dt_fraction=0.3)), load_levels=(2,)),
     ["StudyPlan.load_levels", "(2,)", "balls only"]),
    (lambda: StudyPlan((SHORT, SHORT.replace(dt_fraction=0.3)), particles="ceramic",
                       load_levels=(1, 9)), ["StudyPlan.load_levels", "1..7"]),
    (lambda: StudyPlan((SHORT, SHORT.replace(dt_fraction=0.3)), particles="sand"),
     ["StudyPlan.particles", "'sand'", "'ceramic'"]),
    (lambda: StudyPlan((SHORT, SHORT.replace(dt_fraction=0.3)), speed_fraction=1.5),
     ["StudyPlan.speed_fraction", "1.5", "(0, 1]"]),
    (lambda: StudyPlan((SHORT, SHORT.replace(dt_fraction=0.3)), sample_dt=0.1),
     ["StudyPlan.sample_dt", "0.1 s", "Nyquist"]),
    (lambda: StudyPlan((SHORT, SHORT.replace(record_s=0.5))),
     ["settings[1].record_s", "0.5 s", "LTH"]),
    (lambda: StudyPlan((SHORT, SHORT.replace(record_s=1.005))),
     ["settings[1].record_s", "1.005", "whole number of samples"]),
    (lambda: StudyPlan((SHORT, SHORT.replace(dt_fraction=0.3)), reference=Setting()),
     ["StudyPlan.reference", "one of the settings"]),
    (lambda: StudyPlan((SHORT, SHORT.replace(dt_fraction=0.3)), threads=0),
     ["StudyPlan.threads", "0", ">= 1"]),
    (lambda: StudyPlan.ladder("speed", [0.1, 0.2]), ["knob", "'speed'", "'dt_fraction'"]),
    (lambda: StudyPlan.ladder("dt_fraction", [0.1]), ["values", "at least 2"]),
])
def test_a_bad_plan_is_refused_before_any_work(make, words) -> None:
    with pytest.raises(ValueError) as info:
        make()
    for word in words:
        assert word in str(info.value)


def test_the_reference_is_the_most_expensive_setting_unless_named() -> None:
    plan = StudyPlan.ladder("dt_fraction", [0.2, 0.05, 0.3], base=SHORT)
    assert plan.reference == SHORT.replace(dt_fraction=0.05)
    costs = [plan.planned_particle_steps(s) for s in plan.settings]
    assert costs[1] == max(costs)
    # particles x rotation steps: 391 balls of the tiny slice, (0.5 + 1) s at 0.05 T_R
    t_rayleigh = plan.scene(plan.reference, 1).min_rayleigh_time()[0]
    assert costs[1] == 391 * round(1.5 / (0.05 * t_rayleigh))
    # equal cost: the anti-aliased sampling is the reference
    tie = StudyPlan.ladder("sampling", ["instant", "mean"], base=SHORT)
    assert tie.reference.sampling == "mean"
    named = StudyPlan(plan.settings, reference=plan.settings[0])
    assert named.reference_index == 0


def test_a_shear_modulus_factor_scales_the_papers_moduli_and_nothing_else() -> None:
    plan = StudyPlan.ladder("shear_modulus_factor", [0.1, 0.01], base=SHORT,
                            particles="ceramic", load_levels=(1, 2))
    paper = pilot_mill(0.71, "ceramic", 2, "paper")
    own = pilot_mill(0.71, "ceramic", 2, "tiny")
    for factor in (0.1, 0.01):
        scene = plan.scene(SHORT.replace(shear_modulus_factor=factor), 2)
        for m in scene.materials:
            assert m.shear_modulus == pytest.approx(factor * paper.material(m.name).shear_modulus)
            assert dataclasses.replace(m, shear_modulus=1.0) == \
                dataclasses.replace(own.material(m.name), shear_modulus=1.0)
        assert scene.replace(materials=own.materials) == own
        # the Rayleigh time goes as 1 / sqrt(G)
        assert scene.min_rayleigh_time()[0] == pytest.approx(
            paper.min_rayleigh_time()[0] / math.sqrt(factor))
    assert plan.scene(SHORT, 2) == own


def test_around_varies_one_knob_at_a_time_from_the_reference() -> None:
    ref = Setting(dt_fraction=0.1, record_s=2.0, sampling="mean")
    plan = StudyPlan.around(ref, {"dt_fraction": [0.2, 0.3, 0.1], "sampling": ["instant"]},
                            extra=[ref.replace(dt_fraction=0.3, sampling="instant")])
    assert plan.reference == ref
    assert plan.settings == (ref, ref.replace(dt_fraction=0.2), ref.replace(dt_fraction=0.3),
                             ref.replace(sampling="instant"),
                             ref.replace(dt_fraction=0.3, sampling="instant"))
    assert len(plan.cases()) == 5 * 3  # settings x seeds (one load level)
    combined = StudyPlan.around(ref, {"dt_fraction": [0.2, 0.3], "sampling": ["instant"],
                                      "record_s": [1.0]}, combine=True)
    # the cheapest rung of each ladder that saves steps, all at once; the sampling saves none
    assert combined.settings[-1] == ref.replace(dt_fraction=0.3, record_s=1.0)
    assert len(combined.settings) == 6
    one = StudyPlan.around(ref, {"dt_fraction": [0.2, 0.3]}, combine=True)
    assert len(one.settings) == 3  # one knob: nothing to combine


# -- the table from runs (no simulation): numpy is the reference ------------------------------


def _fake_runs(plan: StudyPlan, rng: np.random.Generator) -> list[StudyRun]:
    """A run per setting, level and seed with random values, lengths and costs as the plan's
    scenes have them."""
    runs = []
    for k, setting in enumerate(plan.settings):
        for level in plan.load_levels:
            scene = plan.scene(setting, level)
            for seed in plan.seeds:
                runs.append(StudyRun(
                    setting=k, load_level=level, seed=seed, hash=f"{k}-{level}-{seed}",
                    wall_s=float(rng.uniform(1, 100)), particle_steps=float(rng.uniform(1e6, 1e9)),
                    n_particles=scene.n_particles, dt_s=1e-4, length_m=scene.drum.length,
                    block_s=setting.record_s, mean_torque=float(rng.normal(40, 3) * level),
                    lth_amplitude=float(rng.normal(2, 0.3)),
                    energy=float(rng.lognormal(3, 0.2) / level)))
    return runs


def test_errors_and_spreads_are_the_numpy_statistics_on_the_reference_footing() -> None:
    """Two scales (drum 0.315 m and 0.05 m) and two block lengths: torques are compared per
    length of drum, energies per length of drum and of block."""
    ref = Setting(scale="soft", record_s=2.0, warm_up_s=1.0)
    plan = StudyPlan((Setting(record_s=1.0, warm_up_s=1.0), ref, Setting(record_s=2.0)),
                     reference=ref, seeds=(4, 5, 6))
    runs = _fake_runs(plan, np.random.default_rng(1))
    result = StudyResult.from_runs(plan, runs)
    assert [r.setting for r in result.rows] == list(plan.settings)

    def values(k: int, attr: str) -> np.ndarray:
        return np.array([getattr(r, attr) for r in runs if r.setting == k])

    length = 0.315 / 0.05
    for k, row, block in ((0, result.rows[0], 2.0), (2, result.rows[2], 1.0)):
        for q, factor in (("mean_torque", length), ("lth_amplitude", length),
                          ("energy", length * block)):
            v, r = values(k, q) * factor, values(1, q)
            e = row.quantities[q]
            assert e.mean == pytest.approx(v.mean())
            assert e.std == pytest.approx(np.std(v, ddof=1))
            assert e.error == pytest.approx((v.mean() - r.mean()) / abs(r.mean()))
            assert e.spread == pytest.approx(np.std(v, ddof=1) / abs(r.mean()))
            assert e.error_se == pytest.approx(
                np.sqrt(np.var(v, ddof=1) / 3 + np.var(r, ddof=1) / 3) / abs(r.mean()))
        assert row.wall_s == pytest.approx(values(k, "wall_s").mean())
        assert row.particle_steps == pytest.approx(values(k, "particle_steps").mean())
        assert math.isnan(row.quantities["slope_a"].error)  # one load level: no slope
    ref_row = result.rows[1]
    assert ref_row.reference and not result.rows[0].reference
    for q in ("mean_torque", "energy", "lth_amplitude"):
        e = ref_row.quantities[q]
        assert (e.error, e.error_se) == (0.0, 0.0)
        assert e.spread == pytest.approx(np.std(values(1, q), ddof=1) / abs(values(1, q).mean()))
    assert result.rows[0].shear_modulus_ratio == pytest.approx(0.001)


def test_the_slope_a_is_fitted_per_seed_to_per_unit_energies() -> None:
    plan = StudyPlan.ladder("dt_fraction", [0.1, 0.3], base=SHORT, particles="ceramic",
                            load_levels=(4, 1, 2), seeds=(0, 1, 2))
    runs = _fake_runs(plan, np.random.default_rng(2))
    result = StudyResult.from_runs(plan, runs)
    levels = np.array([1.0, 2.0, 4.0])

    def slopes(k: int) -> np.ndarray:
        out = []
        for seed in plan.seeds:
            e = np.array([next(r.energy for r in runs if (r.setting, r.load_level, r.seed)
                               == (k, int(level), seed)) for level in levels])
            out.append(np.polyfit(np.log(levels), e / e.max(), 1)[0])
        return np.array(out)

    a, a_ref = slopes(1), slopes(0)
    rows = [r for r in result.rows if r.setting == plan.settings[1]]
    assert [r.load_level for r in rows] == [1, 2, 4]
    for row in rows:  # the same on every level of the setting
        e = row.quantities["slope_a"]
        assert e.mean == pytest.approx(a.mean())
        assert e.error == pytest.approx((a.mean() - a_ref.mean()) / abs(a_ref.mean()))
        assert e.spread == pytest.approx(np.std(a, ddof=1) / abs(a_ref.mean()))
    summary = result.summary("mean_torque", "particle_steps")[1]
    errors = [abs(r.quantities["mean_torque"].error) for r in rows]
    assert summary.error == max(errors)
    assert summary.cost == pytest.approx(sum(r.particle_steps for r in rows))


def test_a_missing_run_is_named() -> None:
    plan = StudyPlan.ladder("dt_fraction", [0.1, 0.3], base=SHORT, seeds=(0, 1))
    runs = _fake_runs(plan, np.random.default_rng(3))
    with pytest.raises(ValueError, match="setting 1 .* load level 1, seed 0"):
        StudyResult.from_runs(plan, [r for r in runs if (r.setting, r.seed) != (1, 0)])


def _table(points: list[tuple[float, float]]) -> StudyResult:
    """A table with one row per (cost, |error|), the first the reference."""
    rows = []
    for k, (cost, error) in enumerate(points):
        q = QuantityError(1.0, 0.1, error if k % 2 else -error, 0.1, 0.0 if k == 0 else 0.05)
        rows.append(StudyRow(setting=Setting(dt_fraction=0.01 * (k + 1)), reference=k == 0,
                             load_level=1, n_particles=10, dt_s=1e-4, shear_modulus_ratio=1.0,
                             length_m=1.0, seeds=2, wall_s=cost, particle_steps=cost * 1e6,
                             quantities=dict.fromkeys(QUANTITIES, q)))
    return StudyResult(tuple(rows))


@pytest.mark.parametrize("seed", range(6))
def test_the_pareto_front_is_exactly_the_non_dominated_settings(seed: int) -> None:
    rng = np.random.default_rng(seed)
    # small integers: many ties in cost, in error and in both
    points = [(float(c), float(e)) for c, e in rng.integers(1, 6, size=(14, 2))]
    points[0] = (7.0, 0.0)
    table = _table(points)
    front = table.pareto("energy")
    by_setting = dict(zip(table.settings, points, strict=True))

    def dominated(p: tuple[float, float]) -> bool:
        return any(q[0] <= p[0] and q[1] <= p[1] and q != p for q in points)

    assert set(front) == {s for s, p in by_setting.items() if not dominated(p)}
    assert [by_setting[s][0] for s in front] == sorted(by_setting[s][0] for s in front)
    assert table.pareto("energy", "particle_steps") == front  # the same order of costs


def test_cheapest_within_a_bound_counts_two_standard_errors() -> None:
    table = _table([(100.0, 0.0), (10.0, 0.03), (5.0, 0.045), (1.0, 0.2)])
    assert table.cheapest("energy", 0.05, with_se=False) == table.settings[2]
    assert table.cheapest("energy", 0.05) == table.settings[0]  # 0.03 + 2 x 0.05 > 0.05
    assert table.cheapest("energy", 0.14) == table.settings[1]
    assert _table([(1.0, 0.5), (2.0, 0.6)]).cheapest("energy", 0.01, with_se=False) is None
    # a second bound that every level must keep too: the torque of _table errs as much
    assert table.cheapest("energy", 0.05, with_se=False,
                          also={"mean_torque": 0.04}) == table.settings[1]
    with pytest.raises(ValueError, match=r"also = 'torque' is not valid; it must be one of"):
        table.cheapest("energy", 0.05, also={"torque": 0.02})


def test_seeds_to_show_an_error_within_a_bound() -> None:
    """The standard error falls as 1 / sqrt(seeds): n' = n (2 SE / (bound - |error|))^2."""
    table = _table([(100.0, 0.0), (10.0, 0.03), (5.0, 0.045), (1.0, 0.2)])
    assert table.seeds_to_show(table.settings[1], "energy", 0.05) == pytest.approx(
        2 * (2 * 0.05 / 0.02) ** 2)
    assert table.seeds_to_show(table.settings[3], "energy", 0.05) == math.inf
    assert table.seeds_to_show(table.settings[0], "energy", 0.05) == 2  # the reference's own


def _changed(table: StudyResult, quantity: str, **changes: float) -> StudyResult:
    """``table`` with ``changes`` made to ``quantity`` in every row but the reference's."""
    return StudyResult(tuple(
        r if r.reference else dataclasses.replace(r, quantities={
            **r.quantities, quantity: dataclasses.replace(r.quantities[quantity], **changes)})
        for r in table.rows))


def test_the_report_names_the_recommended_setting_or_says_none_qualifies() -> None:
    # the torque well within 2 %, the energy errs by 0, 3, 4.5 and 20 % (± 5 %)
    table = _changed(_table([(100.0, 0.0), (10.0, 0.03), (5.0, 0.045), (1.0, 0.2)]),
                     "mean_torque", error=0.0, error_se=0.001)
    s = table.settings
    assert (f"**none of the cheaper settings qualifies**. By their errors alone, without the "
            f"noise, {s[2].label} and {s[1].label} keep the bounds; showing it for "
            f"{s[2].label} would take about {2 * (2 * 0.05 / 0.005) ** 2:.0f} seeds of it and "
            "of the reference.") in table.to_markdown()
    sure = _changed(_table([(100.0, 0.0), (10.0, 0.001)]), "mean_torque", error=0.0,
                    error_se=0.001)
    assert f"noise, {sure.settings[1].label} keeps the bounds" in sure.to_markdown()
    sure = _changed(sure, "energy", error_se=0.001)  # now 0.001 + 2 x 0.001 <= 0.05
    assert f"reference's at every level, each error with 2 standard errors): " \
           f"**{sure.settings[1].label}**." in sure.to_markdown()
    # a torque off by 3 %: nothing keeps the bounds
    off = _changed(table, "mean_torque", error=0.03)
    assert "None is within the bounds even by its errors alone." in off.to_markdown()


def test_csv_round_trip_and_markdown(tmp_path) -> None:
    ref = Setting(scale="soft", record_s=2.0, warm_up_s=1.0, shear_modulus_factor=0.01)
    plan = StudyPlan((Setting(record_s=1.0, warm_up_s=1.0), ref), seeds=(0, 1),
                     particles="ceramic", load_levels=(1, 3))
    result = StudyResult.from_runs(plan, _fake_runs(plan, np.random.default_rng(4)))
    path = tmp_path / "study.csv"
    text = result.to_csv(path)
    assert path.read_text() == text
    back = StudyResult.from_csv(path)
    assert back.to_csv() == text  # floats are written exactly
    assert [r.setting for r in back.rows] == [r.setting for r in result.rows]
    assert back.rows[1].quantities == result.rows[1].quantities
    assert back.description == result.description and back.plan is None
    assert back.pareto("slope_a") == result.pareto("slope_a")
    md = result.to_markdown()
    lines = [line for line in md.splitlines() if line.startswith("| ")]
    assert len(lines) == 1 + len(result.rows)  # the header and one line per row
    assert "level" in lines[0] and "slope a" in lines[0]
    assert sum("(reference)" in line for line in lines) == 2  # the reference at both levels
    e = result.rows[0].quantities["energy"]
    assert f"{100 * e.error:+.1f} % ± {100 * e.spread:.1f} %" in lines[1]


def test_a_damaged_csv_is_named(tmp_path) -> None:
    path = tmp_path / "table.csv"
    path.write_text("label,reference\nx,1\n")
    with pytest.raises(ValueError, match="table.csv: not a millscope study table; missing"):
        StudyResult.from_csv(path)
    with pytest.raises(ValueError, match="no such study table"):
        StudyResult.from_csv(tmp_path / "none.csv")
    table = _table([(2.0, 0.0), (1.0, 0.1)])
    table.to_csv(path)
    path.write_text(path.read_text().replace(",0.01,", ",fast,", 1))
    with pytest.raises(ValueError, match="table.csv, line 2"):
        StudyResult.from_csv(path)


def test_the_figure_marks_the_front_and_the_reference() -> None:
    table = _table([(100.0, 0.0), (10.0, 0.03), (20.0, 0.05), (1.0, 0.2)])
    fig = plots.plot_accuracy(table, "energy")
    assert isinstance(fig, Figure)
    ax = fig.axes[0]
    assert ax.get_xscale() == "log"
    front = [line for line in ax.lines if line.get_label() == "Pareto front"][0]
    # the front joins (1, 20 %), (10, 3 %), (100, 0 %); (20, 5 %) is dominated
    assert list(front.get_xdata()) == [1.0, 10.0, 100.0]
    assert list(front.get_ydata()) == pytest.approx([20.0, 3.0, 0.0])
    assert {t.get_text() for t in ax.texts} >= {"reference", "dt 0.02 T_R"}
    with pytest.raises(ValueError, match="slope a needs 2 or more load levels"):
        plots.plot_accuracy(StudyResult(tuple(dataclasses.replace(
            r, quantities={**r.quantities, "slope_a": QuantityError(*[math.nan] * 5)})
            for r in table.rows)), "slope_a")


def test_the_figure_keeps_the_labels_of_close_points_apart() -> None:
    """Two settings of nearly the same cost and error (as the LDMS study's dt 0.4 T_R and
    2.5 s block): their labels' boxes do not overlap, and each stays beside its point."""
    table = _table([(100.0, 0.0), (50.0, 0.012), (51.0, 0.016), (52.0, 0.014), (1.0, 0.2)])
    fig = plots.plot_accuracy(table, "energy")
    fig.draw_without_rendering()  # laid out as a saved figure is
    ax = fig.axes[0]
    boxes = [t.get_window_extent() for t in ax.texts]
    assert len(boxes) == 5
    for a in range(len(boxes)):
        for b in range(a):
            assert not boxes[a].overlaps(boxes[b]), (ax.texts[a].get_text(),
                                                     ax.texts[b].get_text())
    for t in ax.texts:  # beside its point: to its right, and above it by a few lines at most
        point = ax.transData.transform(t.xy)
        box = t.get_window_extent()
        assert box.x0 >= point[0] and 0.0 <= box.y0 - point[1] <= 5 * float(t.get_fontsize())


# -- the command line: bad input (no simulation) -----------------------------------------------


@pytest.mark.parametrize(("args", "words"), [
    ([], ["give at least one ladder"]),
    (["--vary-dt-fraction", "0.7"], ["Setting.dt_fraction = 0.7", "(0, 0.5]"]),
    (["--vary-record", "0.2"], ["record_s = 0.2 s", "LTH"]),
    (["--scale", "huge", "--vary-dt-fraction", "0.4"], ["Setting.scale = 'huge'"]),
    (["--seeds", "1", "--vary-dt-fraction", "0.4"], ["StudyPlan.seeds", "at least 2"]),
    (["--levels", "2", "--vary-dt-fraction", "0.4"], ["StudyPlan.load_levels", "balls only"]),
    (["--quantity", "slope_a", "--vary-dt-fraction", "0.4"], ["slope_a needs 2 or more"]),
])
def test_study_accuracy_bad_input_is_one_line_and_exit_2(tmp_path, capsys, args, words) -> None:
    code = main(["study", "accuracy", "--out", str(tmp_path / "s"), "--record", "1",
                 "--warm-up", "0.5", *args])
    err = capsys.readouterr().err
    assert code == 2
    assert err.count("\n") == 1 and err.startswith("millscope: error: ")
    for word in words:
        assert word in err
    assert not (tmp_path / "s").exists()  # refused before any work


# -- a study of the tiny mill (DEM) ------------------------------------------------------------

# The tiny balls-only slice (391 balls), a 1 s block after 1.5, 0.5 or 0 s of warm-up, 2 seeds,
# instantaneous samples, the default step (0.2 Rayleigh times): the drum starts from rest, so
# a short warm-up puts the start-up transient into the block. The reference is the longest.
WARM_LADDER = (1.5, 0.5, 0.0)
TINY_REF = Setting(dt_fraction=0.2, record_s=1.0, warm_up_s=WARM_LADDER[0], sampling="instant")
TINY_PLAN = StudyPlan.around(TINY_REF, {"warm_up_s": WARM_LADDER[1:]}, seeds=(0, 1))


@pytest.fixture(scope="module")
def tiny_study(tmp_path_factory) -> StudyResult:
    folder = tmp_path_factory.mktemp("study")
    with ThreadPoolExecutor(1) as pool:
        return run_study(TINY_PLAN, folder / "out" / "store", executor=pool, progress=False)


def test_the_reference_row_has_zero_error(tiny_study) -> None:
    (ref,) = [r for r in tiny_study.rows if r.reference]
    assert ref.setting == TINY_REF
    for q in ("mean_torque", "energy", "lth_amplitude"):
        assert ref.quantities[q].error == 0.0
        assert ref.quantities[q].spread > 0.0  # two seeds differ
    assert tiny_study.pareto("energy")[-1] == TINY_REF  # nothing else has zero error


def test_the_errors_are_the_numpy_statistics_of_the_stored_records(tiny_study) -> None:
    """Mean torque from the stored samples with numpy; energies and LTH as the campaign's
    analysis gives them for the stored block; then the table's statistics with numpy."""
    plan = tiny_study.plan
    assert plan is TINY_PLAN and len(tiny_study.runs) == 3 * 2
    per_setting: dict[int, dict[str, list[float]]] = {}
    for run in tiny_study.runs:
        setting = plan.settings[run.setting]
        record = tiny_study.record(run)
        t, x = record.time_s, record.torque_Nm
        # kept: the samples stamped warm-up + sample_dt .. duration; the block is t1 <= t < t2
        assert len(t) == round(setting.record_s / plan.sample_dt)
        assert t[-1] == pytest.approx(setting.duration_s)
        inside = (t >= setting.warm_up_s - 1e-9) & (t < setting.duration_s - 1e-9)
        assert run.block_s == pytest.approx(np.count_nonzero(inside) * plan.sample_dt)
        assert run.mean_torque == pytest.approx(np.mean(x[inside]), rel=1e-12)
        again = analyze_block(record.block(setting.warm_up_s, setting.duration_s), lifters=16,
                              rotation_hz=record.meta["rotation_hz"])
        assert run.energy == pytest.approx(again.energy.energy, rel=1e-12)
        assert run.lth_amplitude == pytest.approx(again.lth.amplitude, rel=1e-12)
        assert run.dt_s == pytest.approx(setting.dt_fraction * plan.scene(setting, 1)
                                         .min_rayleigh_time()[0])
        # settling included: more steps than the rotation alone
        assert run.particle_steps > run.n_particles * setting.duration_s / run.dt_s
        values = per_setting.setdefault(run.setting, {})
        values.setdefault("mean_torque", []).append(float(np.mean(x[inside])))
        values.setdefault("energy", []).append(run.energy)
        values.setdefault("lth_amplitude", []).append(run.lth_amplitude)
    ref = per_setting[plan.reference_index]
    for row in tiny_study.rows:
        own = per_setting[plan.settings.index(row.setting)]
        assert row.wall_s == pytest.approx(np.mean([
            r.wall_s for r in tiny_study.runs if plan.settings[r.setting] == row.setting]))
        for q, v in own.items():
            r = np.array(ref[q])
            e = row.quantities[q]
            assert e.error == pytest.approx((np.mean(v) - r.mean()) / abs(r.mean()), abs=1e-12)
            assert e.spread == pytest.approx(np.std(v, ddof=1) / abs(r.mean()))
            if not row.reference:
                assert e.error_se == pytest.approx(
                    np.sqrt((np.var(v, ddof=1) + np.var(r, ddof=1)) / 2) / abs(r.mean()))


def test_a_shorter_warm_up_costs_less_and_errs_more(tiny_study) -> None:
    """Cost falls along the ladder (particle-steps of rotation; not timed) and the error
    grows beyond the seed noise: a block that starts at 0 s or at 0.5 s of rotation holds the
    start-up transient of the mean torque, and the worse of the two is off the reference by
    more than 2 standard errors. (Which one depends on the run: the block from 0 s averages
    the charge's slow start with the overshoot of its first cascade, and the two partly
    cancel. From the close-packed fill the LTH amplitude of a 1 s block is within the seed
    noise of the reference already in the first second; from the earlier loose fill it built
    up over that second.)"""
    rows = {r.setting.warm_up_s: r for r in tiny_study.rows}
    planned = [TINY_PLAN.planned_particle_steps(TINY_REF.replace(warm_up_s=w))
               for w in WARM_LADDER]
    assert planned[0] > planned[1] > planned[2]
    ref, mid, cheap = (rows[w].quantities for w in WARM_LADDER)
    for q in ("mean_torque", "lth_amplitude"):
        assert ref[q].error == 0.0
    worst = max((mid["mean_torque"], cheap["mean_torque"]),
                key=lambda e: abs(e.error) / e.error_se)
    assert abs(worst.error) > 2.0 * worst.error_se, worst


def test_the_command_line_reuses_the_store_and_writes_the_table(tiny_study, capsys) -> None:
    out = tiny_study.store.parent
    args = ["study", "accuracy", "--out", str(out), "--seeds", "2", "--record", "1",
            "--warm-up", str(WARM_LADDER[0]), "--sampling", "instant", "--dt-fraction", "0.2",
            "--vary-warm-up", *map(str, WARM_LADDER[1:]), "--no-progress"]
    assert main(args) == 0
    text = capsys.readouterr().out
    assert "6 runs" in text and "(reference)" in text
    back = StudyResult.from_csv(out / "accuracy.csv")
    assert back.to_csv() == tiny_study.to_csv()  # the same runs, read back from the store
    assert (out / "accuracy.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert (out / "accuracy.md").read_text() == tiny_study.to_markdown()


# -- heavier studies ---------------------------------------------------------------------------


@pytest.mark.slow
def test_a_dt_ladder_within_the_limit_keeps_the_mean_torque_within_5_percent(tmp_path) -> None:
    """0.05, 0.1 and 0.3 Rayleigh times, 4 seeds, a 3 s block after 1.5 s: the rotation's
    particle-steps fall as 1 / dt, and up to the scene's limit (0.33 Rayleigh times, the
    balls' stick mode: stiffness.time_step_limit) the mean torque stays within 5 % of the
    smallest step's. At the tiny scale no dt bias of the mean torque is resolved beyond the
    seed noise (standard errors about 1 %), so this checks a bound, not an ordering along the
    ladder."""
    ladder = (0.05, 0.1, 0.3)
    base = Setting(record_s=3.0, warm_up_s=1.5, sampling="instant")
    plan = StudyPlan.ladder("dt_fraction", ladder, base=base, seeds=(0, 1, 2, 3))
    result = run_study(plan, tmp_path / "store", max_workers=min(2, usable_cores()),
                       progress=False)
    rows = {r.setting.dt_fraction: r for r in result.rows}
    rotation = [rows[f].n_particles * base.duration_s / rows[f].dt_s for f in ladder]
    assert rotation == pytest.approx([rotation[0] * ladder[0] / f for f in ladder])
    for f in ladder[1:]:
        e = rows[f].quantities["mean_torque"]
        assert abs(e.error) < 0.05, (f, e)


@pytest.mark.slow
def test_a_campaign_study_compares_the_log_fit_slope(tmp_path) -> None:
    """LDMS #1 and #2 at the tiny scale, two time steps: the slope a of each seed's per-unit
    energies, and every quantity of every level, against the smaller step."""
    plan = StudyPlan.ladder("dt_fraction", [0.1, 0.3], base=Setting(record_s=1.0, warm_up_s=0.5),
                            particles="ceramic", load_levels=(1, 2), seeds=(0, 1))
    result = run_study(plan, tmp_path / "store", max_workers=min(2, usable_cores()),
                       progress=False)
    assert len(result.rows) == 2 * 2
    ref_rows = [r for r in result.rows if r.reference]
    assert all(r.quantities["slope_a"].error == 0.0 for r in ref_rows)
    cheap = [r for r in result.rows if not r.reference]
    assert len({r.quantities["slope_a"].error for r in cheap}) == 1
    assert all(math.isfinite(r.quantities[q].error) for r in cheap for q in QUANTITIES)

    def slopes(k: int) -> np.ndarray:  # numpy on the stored records' energies, seed by seed
        out = []
        for seed in plan.seeds:
            e = np.array([next(r.energy for r in result.runs
                               if (r.setting, r.load_level, r.seed) == (k, level, seed))
                          for level in (1, 2)])
            out.append(np.polyfit(np.log([1.0, 2.0]), e / e.max(), 1)[0])
        return np.array(out)

    a, a_ref = slopes(1), slopes(0)
    e = cheap[0].quantities["slope_a"]
    assert e.mean == pytest.approx(a.mean())
    assert e.error == pytest.approx((a.mean() - a_ref.mean()) / abs(a_ref.mean()))


@pytest.mark.slow
def test_a_stiffness_ladder_costs_more_for_stiffer_charges(tmp_path) -> None:
    """Shear moduli x 0.001, 0.01 and 0.1 of the paper's at one dt fraction: the time step
    shrinks and the planned particle-steps grow as 1 / sqrt(G) (the Rayleigh time), the
    stiffest is the reference, and every run takes at least its planned steps (settling
    comes on top)."""
    plan = StudyPlan.ladder("shear_modulus_factor", [0.001, 0.01, 0.1],
                            base=Setting(record_s=1.0, warm_up_s=0.5), seeds=(0, 1))
    assert plan.reference.shear_modulus_factor == 0.1
    result = run_study(plan, tmp_path / "store", max_workers=min(2, usable_cores()),
                       progress=False)
    rows = {r.setting.shear_modulus_factor: r for r in result.rows}
    for soft, stiff in itertools.pairwise((0.001, 0.01, 0.1)):
        assert rows[stiff].dt_s == pytest.approx(rows[soft].dt_s / math.sqrt(10))
        assert plan.planned_particle_steps(rows[stiff].setting) == pytest.approx(
            math.sqrt(10) * plan.planned_particle_steps(rows[soft].setting))
    for run in result.runs:
        assert run.particle_steps >= plan.planned_particle_steps(plan.settings[run.setting])
    result.to_csv(tmp_path / "t.csv")
    assert ms.StudyResult.from_csv(tmp_path / "t.csv").to_csv() == result.to_csv()


class _Recording:
    """An executor that runs cases in a thread pool and notes each submitted case."""

    def __init__(self, pool: ThreadPoolExecutor) -> None:
        self.pool = pool
        self.cases: list[Case] = []

    def submit(self, fn, case, *rest):  # noqa: ANN001, ANN201 - forwards to the pool
        self.cases.append(Case.from_dict(case))
        return self.pool.submit(fn, case, *rest)


@pytest.mark.parametrize("cheapest_first", [False, True])
def test_cases_go_in_order_of_cost_and_the_mean_setting_rides_on_the_instant_runs(
        tmp_path, cheapest_first) -> None:
    reference = Setting(dt_fraction=0.2, record_s=1.0, warm_up_s=0.5, sampling="instant")
    plan = StudyPlan.around(reference, {"dt_fraction": [0.3], "sampling": ["mean"]},
                            seeds=(0, 1))
    with ThreadPoolExecutor(1) as pool:
        executor = _Recording(pool)
        result = run_study(plan, tmp_path / "store", executor=executor, progress=False,
                           cheapest_first=cheapest_first)
    # the mean setting's cases are never submitted: each is stored from its instant twin's run
    assert {c.settings.sampling for c in executor.cases} == {"instant"}
    assert len(executor.cases) == 4
    costs = [c.scene.n_particles * c.settings.duration_s / c.settings.dt for c in executor.cases]
    assert costs == sorted(costs, reverse=not cheapest_first)
    assert costs[0] != costs[-1]
    mean_runs = [r for r in result.runs if plan.settings[r.setting].sampling == "mean"]
    instant_runs = [r for r in result.runs if r.setting == plan.reference_index]
    assert len(mean_runs) == 2 and len(instant_runs) == 2
    # the same steps sampled two ways: the same mean torque to within the sampling's noise,
    # and far less spectral energy in the means (docs/architecture.md, Sampling)
    for m, i in zip(sorted(mean_runs, key=lambda r: r.seed),
                    sorted(instant_runs, key=lambda r: r.seed), strict=True):
        assert m.mean_torque == pytest.approx(i.mean_torque, rel=0.05)
        assert m.energy < i.energy


def test_cheapest_first_must_be_a_flag(tmp_path) -> None:
    with pytest.raises(ValueError, match="cheapest_first = 'yes' is not valid"):
        run_study(TINY_PLAN, tmp_path / "store", cheapest_first="yes")  # type: ignore[arg-type]
    assert not (tmp_path / "store").exists()


def test_the_report_gives_the_per_unit_energy_in_each_sampling_mode() -> None:
    """The per-unit energy E(last level) / E(first level) of the reference and of the same
    setting with interval-mean samples, each with the standard error of its seed mean,
    std / mean / sqrt(seeds), computed here with numpy."""
    ref = Setting(scale="soft", record_s=2.0, warm_up_s=1.0)
    mean = ref.replace(sampling="mean")
    plan = StudyPlan((ref, mean, ref.replace(dt_fraction=0.1)), reference=ref, seeds=(0, 1, 2),
                     particles="ceramic", load_levels=(1, 4))
    runs = _fake_runs(plan, np.random.default_rng(7))
    text = StudyResult.from_runs(plan, runs).to_markdown()
    for k, whose in ((0, "the reference"),
                     (1, "the reference's setting with interval-mean samples")):
        energy = {(r.load_level, r.seed): r.energy for r in runs if r.setting == k}
        ratios = np.array([energy[4, s] / energy[1, s] for s in plan.seeds])
        se = ratios.std(ddof=1) / ratios.mean() / np.sqrt(3)
        assert (f"Per-unit energy of {whose}: {ratios.mean():.4g}, standard error "
                f"{100 * se:.1f} % from 3 seeds") in text

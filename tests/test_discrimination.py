"""How well one block tells a load level from the next (millscope.calibration.discrimination).

References: scipy's Mann-Whitney U and normal distribution, the fill estimates of millscope's
own estimate_fill taken block by block (the functions must agree with them), and the synthetic
records' known load levels (held out, the intervals must hold them about as often as their
confidence says).
"""

from __future__ import annotations

import math
import warnings
from pathlib import Path

import numpy as np
import pytest
from scipy import stats

import millscope as ms
from millscope.analysis import analyze_campaign
from millscope.calibration.discrimination import discrimination, held_out, order_probability
from millscope.calibration.fit import Calibration, NoIntervalWarning, estimate_fill
from millscope.report.reports import write_report

from .synthetic_campaign import case_results, synthetic_store


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_the_order_probability_is_the_mann_whitney_share_and_the_normal_of_the_logs(
        seed: int) -> None:
    rng = np.random.default_rng(seed)
    x = np.round(rng.lognormal(1.0, 0.3, 5), 1)  # rounded: ties happen
    y = np.round(rng.lognormal(0.8, 0.3, 4), 1)
    share, lognormal = order_probability(x, y)
    u = stats.mannwhitneyu(x, y, alternative="greater").statistic
    assert share == pytest.approx(u / (x.size * y.size), abs=1e-15)
    lx, ly = np.log(x), np.log(y)
    z = (lx.mean() - ly.mean()) / math.sqrt(lx.var(ddof=1) + ly.var(ddof=1))
    assert lognormal == pytest.approx(stats.norm.cdf(z), rel=1e-12)


def test_one_value_a_side_gives_no_lognormal_and_bad_values_are_refused() -> None:
    assert order_probability([2.0], [1.0]) == (1.0, pytest.approx(math.nan, nan_ok=True))
    assert math.isnan(order_probability([2.0], [1.0])[1])
    for bad in ([], [1.0, -1.0], [math.nan]):
        with pytest.raises(ValueError, match="higher"):
            order_probability(bad, [1.0])


def test_a_campaign_group_is_ordered_and_estimated_block_by_block() -> None:
    """Synthetic LDMS #1..#4, 3 seeds a level (energy law -0.45 ln x + 1 with noise)."""
    results = case_results(range(1, 5), seeds=(0, 1, 2))
    (group,) = analyze_campaign(results, bootstrap=0)
    d = discrimination(group)
    assert [(p.low, p.high) for p in d.pairs] == [(1, 2), (2, 3), (3, 4)]
    assert d.sampling == results[0].case.settings.sampling
    energies = {lvl: [r.energy for r in results if r.key.load_level == lvl] for lvl in range(1, 5)}
    for p in d.pairs:
        assert p.blocks == (3, 3)
        u = stats.mannwhitneyu(energies[p.low], energies[p.high], alternative="greater")
        assert p.p_order == pytest.approx(u.statistic / 9)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", NoIntervalWarning)
        cal = Calibration.from_group(group)
    for spread in d.levels:
        own = [r for r in results if r.key.load_level == spread.level]
        est = []
        for r in own:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                est.append(estimate_fill(r.record.block(*r.analysis.block), cal))
        levels = np.array([e.level for e in est])
        assert spread.blocks == 3
        assert spread.estimate_mean == pytest.approx(levels.mean())
        assert spread.estimate_std == pytest.approx(levels.std(ddof=1))
        assert spread.interval_width == pytest.approx(
            np.mean([e.interval[1] - e.interval[0] for e in est]))
    text = d.to_markdown()
    assert "| 1 / 2 | 3 / 3 |" in text and "95 % interval width" in text


def test_a_group_of_one_level_and_a_bad_confidence_are_refused() -> None:
    (one,) = analyze_campaign(case_results([1], seeds=(0, 1)), bootstrap=0)
    with pytest.raises(ValueError, match="2 or more load levels"):
        discrimination(one)
    (group,) = analyze_campaign(case_results([1, 2, 3]), bootstrap=0)
    with pytest.raises(ValueError, match="confidence = 1.5"):
        discrimination(group, confidence=1.5)


def test_the_campaign_report_gives_each_group_its_discrimination(tmp_path) -> None:
    scenes = [ms.presets.pilot_mill(0.71, "ceramic", level, scale="tiny") for level in (1, 2, 3)]
    results = synthetic_store(tmp_path / "store", scenes, seeds=(0, 1))
    path = write_report(tmp_path / "store", tmp_path / "report", progress=False, bootstrap=50)
    text = Path(path).read_text()
    (group,) = analyze_campaign(results, bootstrap=0)
    expected = discrimination(group).to_markdown()
    assert expected.strip() in text
    assert held_out(group).to_markdown().strip() in text


def test_a_report_without_repeats_says_why_it_has_no_held_out_estimates(tmp_path) -> None:
    scenes = [ms.presets.pilot_mill(0.71, "ceramic", level, scale="tiny") for level in (1, 2, 3)]
    synthetic_store(tmp_path / "store", scenes, seeds=(0,))
    path = write_report(tmp_path / "store", tmp_path / "report", progress=False, bootstrap=50)
    text = Path(path).read_text()
    assert "No held-out estimates: group = " in text and "2 or more seeds" in text
    assert "held out**" not in text


def test_held_out_estimates_each_seed_against_a_calibration_of_the_other_seeds() -> None:
    """Synthetic LDMS #1..#5, 3 seeds: each block against the calibration of the 2 others."""
    results = case_results(range(1, 6), seeds=(0, 1, 2))
    (group,) = analyze_campaign(results, bootstrap=0)
    h = held_out(group)
    assert h.seeds == (0, 1, 2) and h.sampling == results[0].case.settings.sampling
    estimates: dict[float, list[ms.FillEstimate]] = {}
    for seed in (0, 1, 2):
        (others,) = analyze_campaign([r for r in results if r.case.settings.seed != seed],
                                     bootstrap=0)
        cal = Calibration.from_group(others)
        assert cal.meta["repeats"] == [2] * 5 and h.group == group.name
        for r in results:
            if r.case.settings.seed == seed:
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    est = estimate_fill(r.record.block(*r.analysis.block), cal)
                estimates.setdefault(float(r.key.load_level), []).append(est)
    assert [s.level for s in h.levels] == sorted(estimates)
    for s in h.levels:
        own = estimates[s.level]
        levels = np.array([e.level for e in own])
        assert s.blocks == 3
        assert s.estimate_mean == pytest.approx(levels.mean())
        assert s.error_rms == pytest.approx(np.sqrt(np.mean((levels - s.level) ** 2)))
        assert s.covered == sum(e.interval[0] <= s.level <= e.interval[1] for e in own)
        assert s.interval_width == pytest.approx(
            np.mean([e.interval[1] - e.interval[0] for e in own]))
    assert h.blocks == 15
    assert h.error_rms == pytest.approx(math.sqrt(np.mean(
        [(e.level - lvl) ** 2 for lvl, own in estimates.items() for e in own])))
    text = h.to_markdown()
    assert f"In all: {h.covered} of 15 true levels inside their 95 % interval" in text


def test_held_out_intervals_hold_the_true_level_about_as_often_as_they_claim() -> None:
    """Records that follow the law exactly, 7 levels x 4 seeds, 28 blocks held out. Honest 95 %
    intervals miss no improbably many true levels (binomial, P(as many misses) > 1e-3, that is
    at most 7 misses), and are not so wide that they say nothing: their mean half-width is
    under 3 x 1.96 x the estimates' RMS error (1.96 x would be exact for normal errors)."""
    results = case_results(range(1, 8), seeds=(0, 1, 2, 3), family=3)
    (group,) = analyze_campaign(results, bootstrap=0)
    h = held_out(group)
    assert h.blocks == 28
    assert stats.binom.sf(28 - h.covered - 1, 28, 0.05) > 1e-3
    half_width = 0.5 * np.mean([s.interval_width for s in h.levels])
    assert 0 < h.error_rms and half_width < 3 * 1.96 * h.error_rms
    assert h.error_rms < 0.5  # of a load level: the law is recovered


def test_held_out_needs_seeds_and_levels_left() -> None:
    (one_seed,) = analyze_campaign(case_results([1, 2, 3]), bootstrap=0)
    with pytest.raises(ValueError, match="2 or more seeds"):
        held_out(one_seed)
    lone = case_results([1, 2, 3], seeds=(0,)) + case_results([1], seeds=(1,))
    (group,) = analyze_campaign(lone, bootstrap=0)
    with pytest.raises(ValueError, match="other seeds than 0 span 2 or more load levels"):
        held_out(group)
    (group,) = analyze_campaign(case_results([1, 2, 3], seeds=(0, 1)), bootstrap=0)
    with pytest.raises(ValueError, match="confidence = 0"):
        held_out(group, confidence=0.0)

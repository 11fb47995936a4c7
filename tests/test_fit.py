"""Log fit against scipy, calibration I/O and the filling estimate."""

from __future__ import annotations

import json
import math
import warnings

import numpy as np
import pytest
from scipy import stats

import millscope as ms
from millscope.fit import (
    CalibrationError,
    NoIntervalWarning,
    OutsideCalibrationWarning,
    log_fit_coefficients,
    per_unit,
)
from millscope.synthetic import SyntheticTorque, synthetic_record


def test_exact_data_recovers_a_b_with_r2_one() -> None:
    x = np.arange(1, 8)
    fit = ms.log_fit(x, -0.423 * np.log(x) + 0.9279)  # HDLS, paper Table 6
    assert fit.a == pytest.approx(-0.423, rel=1e-12)
    assert fit.b == pytest.approx(0.9279, rel=1e-12)
    assert fit.r2 == pytest.approx(1.0, abs=1e-12)
    y = np.array([0.9, 0.5, 0.3])
    np.testing.assert_allclose(fit(fit.inverse(y)), y, rtol=1e-12)
    assert fit.inverse(fit(3.5)) == pytest.approx(3.5, rel=1e-12)
    assert fit.equation() == "y = -0.423 ln(x) + 0.9279"


def test_noisy_fit_agrees_with_scipy_linregress(rng) -> None:
    x = np.repeat(np.arange(1, 8), 3).astype(float)
    y = -0.45 * np.log(x) + 1.0 + rng.normal(0, 0.05, x.size)
    fit = ms.log_fit(x, y)
    ref = stats.linregress(np.log(x), y)
    assert fit.a == pytest.approx(ref.slope, rel=1e-10)
    assert fit.b == pytest.approx(ref.intercept, rel=1e-10)
    assert fit.r2 == pytest.approx(ref.rvalue**2, rel=1e-10)
    assert fit.a_stderr == pytest.approx(ref.stderr, rel=1e-10)
    assert fit.b_stderr == pytest.approx(ref.intercept_stderr, rel=1e-10)


@pytest.mark.parametrize(
    ("x", "y", "message"),
    [
        ([1], [1], "at least 2 points"),
        ([0, 1], [1, 2], "x must be finite and > 0"),
        ([1, 2], [1, np.nan], "y must be finite"),
        ([2, 2, 2], [1, 2, 3], "all x are equal"),
        ([1, 2, 3], [1, 2], "equal length"),
    ],
)
def test_log_fit_bad_input(x, y, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        ms.log_fit(x, y)


def test_per_unit_divides_by_the_largest() -> None:
    np.testing.assert_allclose(per_unit([4.0, 2.0, 1.0]), [1.0, 0.5, 0.25])
    with pytest.raises(ValueError, match="positive maximum"):
        per_unit([0.0, 0.0])
    np.testing.assert_allclose(per_unit([[4.0, 2.0], [1.0, 3.0]]), [[1.0, 0.5], [1 / 3, 1.0]])
    with pytest.raises(ValueError, match="positive maximum"):
        per_unit([[1.0, 2.0], [0.0, 0.0]])


def test_log_fit_coefficients_fit_every_row_as_scipy_does(rng) -> None:
    x = np.arange(1, 8)
    rows = -0.45 * np.log(x) + 1.0 + rng.normal(0, 0.05, (5, x.size))
    a, b = log_fit_coefficients(x, rows)
    assert a.shape == b.shape == (5,)
    for k, row in enumerate(rows):
        ref = stats.linregress(np.log(x), row)
        assert a[k] == pytest.approx(ref.slope, rel=1e-10)
        assert b[k] == pytest.approx(ref.intercept, rel=1e-10)
    with pytest.raises(ValueError, match=r"shape \(7,\) or \(m, 7\)"):
        log_fit_coefficients(x, rows[:, :6])


@pytest.fixture(scope="module")
def calibration() -> ms.Calibration:
    content = SyntheticTorque()
    levels = np.repeat(np.arange(1, 8), 4)
    energies = np.array([
        ms.spectral_energy(synthetic_record(lv, content=content, seed=i).block(4, 14),
                           ["mean", content.lifters * content.rotation_hz]).energy
        for i, lv in enumerate(levels)])
    fit = ms.log_fit(levels, energies / energies.max())
    return ms.Calibration(fit=fit, reference_energy=float(energies.max()), lifters=16,
                          rotation_hz=content.rotation_hz, block_s=10.0)


def test_synthetic_family_recovers_the_energy_law(calibration) -> None:
    """Noise energy follows s1^2 (a ln x + b): per unit of the largest, the fit's slope/intercept
    ratio equals a/b of the law (the per-unit scaling cancels)."""
    a, b = SyntheticTorque().energy_law
    fit = calibration.fit
    assert fit.a / fit.b == pytest.approx(a / b, rel=0.1)
    assert fit.r2 > 0.9


@pytest.mark.parametrize("level", [1.5, 3.0, 5.0])
def test_estimate_fill_finds_the_level_within_its_interval(calibration, level: float) -> None:
    rec = synthetic_record(level, seed=999).block(4, 14)
    est = ms.estimate_fill(rec, calibration)
    assert est.interval[0] <= level <= est.interval[1]
    assert est.interval[0] < est.level < est.interval[1]


def test_estimate_fill_warns_outside_the_range_and_checks_length(calibration) -> None:
    quiet = SyntheticTorque(noise_std_Nm=5.0)  # far less noise than any calibrated level
    with pytest.warns(OutsideCalibrationWarning, match="outside the calibrated range"):
        ms.estimate_fill(synthetic_record(1, content=quiet).block(4, 14), calibration)
    with pytest.raises(ValueError, match="block_s = 10 s"):
        ms.estimate_fill(synthetic_record(3).block(4, 9), calibration)


def test_calibration_round_trip_and_damaged_files(tmp_path, calibration) -> None:
    path = calibration.save(tmp_path / "cal.json")
    assert ms.Calibration.load(path) == calibration
    rec = synthetic_record(2.0, seed=5).block(4, 14)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", OutsideCalibrationWarning)
        reloaded = ms.Calibration.load(path)
        assert ms.estimate_fill(rec, reloaded) == ms.estimate_fill(rec, calibration)
    bad = tmp_path / "bad.json"
    bad.write_text("{")
    with pytest.raises(ValueError, match="not valid JSON"):
        ms.Calibration.load(bad)
    bad.write_text(json.dumps({"format": "other"}))
    with pytest.raises(ValueError, match="not a millscope calibration"):
        ms.Calibration.load(bad)
    data = json.loads(path.read_text())
    del data["fit"]
    bad.write_text(json.dumps(data))
    with pytest.raises(CalibrationError, match="missing key 'fit'"):
        ms.Calibration.load(bad)
    with pytest.raises(ValueError, match="reference_energy = 0"):
        ms.Calibration(fit=calibration.fit, reference_energy=0.0, lifters=16, rotation_hz=0.5,
                       block_s=10.0)



def test_a_two_point_calibration_is_standard_json(tmp_path) -> None:
    """A fit through 2 levels has no standard errors: written as null (JSON has no NaN),
    read back as nan."""
    fit = ms.log_fit([1.0, 3.0], [1.0, 0.5])
    assert math.isnan(fit.a_stderr)
    cal = ms.Calibration(fit=fit, reference_energy=2.0, lifters=16, rotation_hz=0.5, block_s=10.0)
    path = cal.save(tmp_path / "cal.json")

    def refuse(name: str) -> None:
        raise AssertionError(f"{name} is not standard JSON")

    data = json.loads(path.read_text(), parse_constant=refuse)
    assert data["fit"]["a_stderr"] is None and data["fit"]["a"] == fit.a
    loaded = ms.Calibration.load(path)
    assert math.isnan(loaded.fit.a_stderr) and math.isnan(loaded.fit.residual_std)
    assert (loaded.fit.a, loaded.fit.b, loaded.fit.n) == (fit.a, fit.b, 2)
    data["fit"] = [1, 2]
    (tmp_path / "bad.json").write_text(json.dumps(data))
    with pytest.raises(CalibrationError, match="calibration fit must be a JSON object"):
        ms.Calibration.load(tmp_path / "bad.json")

# -- calibration from a campaign's results ---------------------------------------------------------
@pytest.fixture(scope="module")
def campaign_results():
    from .synthetic_campaign import case_results

    return case_results(family=11)


def test_calibration_from_results_takes_the_groups_fit_and_settings(campaign_results,
                                                                    tmp_path) -> None:
    from millscope.campaign_analysis import analyze_campaign

    cal = ms.Calibration.from_results(campaign_results)
    (group,) = analyze_campaign(campaign_results)
    assert cal.fit == group.fit
    assert cal.reference_energy == max(r.energy for r in campaign_results)
    assert cal.label == "LDMS" and cal.lifters == 16
    assert cal.rotation_hz == campaign_results[0].scene.rotation_hz
    assert (cal.block_s, cal.bandwidth, cal.window) == (10.0, 0.3, "hann")
    assert cal.band_hz == pytest.approx(50.0)  # the Nyquist frequency of 10 ms samples
    assert cal.block_relative_std == pytest.approx(group.block_relative_std())
    assert cal.meta["a_interval"] == list(group.a_interval)
    assert cal.meta["cases"] == [r.hash for r in group.results]
    assert ms.Calibration.load(cal.save(tmp_path / "cal.json")) == cal


def test_calibration_from_results_chooses_among_groups(campaign_results) -> None:
    from .synthetic_campaign import case_results

    both = campaign_results + case_results(levels=(1, 3), particles="steel", speed=0.80)
    with pytest.raises(ValueError, match=r"2 groups \(LDMS, HDHS\); choose one with group="):
        ms.Calibration.from_results(both)
    with pytest.raises(ValueError, match="group = 'LDLS' is not among .*: LDMS, HDHS"):
        ms.Calibration.from_results(both, group="LDLS")
    with pytest.warns(NoIntervalWarning):  # HDHS has 2 levels
        assert ms.Calibration.from_results(both, group="HDHS").label == "HDHS"
    single = case_results(levels=(2,))
    with pytest.raises(ValueError, match="single load level"):
        ms.Calibration.from_results(single)


def test_a_groups_log_fit_is_its_fit_or_a_clear_error(campaign_results) -> None:
    """GroupAnalysis.log_fit (typed LogFit, for code that needs the fit) is the fit, whose slope
    is scipy's linregress of the per-unit energy on ln(level); with one level it raises."""
    from .synthetic_campaign import case_results

    (group,) = ms.analyze_campaign(campaign_results)
    assert group.log_fit is group.fit
    ref = stats.linregress(np.log(group.levels), group.energy_pu)
    assert group.log_fit.a == pytest.approx(ref.slope, rel=1e-12)
    (single,) = ms.analyze_campaign(case_results(levels=(2,)))
    assert single.fit is None
    with pytest.raises(ValueError, match=r"group LDMS has a single load level \(2\); a fit "
                                         r"needs at least 2"):
        _ = single.log_fit


def test_a_two_level_calibration_warns_and_so_does_each_estimate_without_interval() -> None:
    """Through 2 levels the fit is exact (R^2 = 1 against scipy's r of +-1) with no residual
    left: the calibration is made with a warning, and an estimate from it warns that its
    interval is nan. The same group with a third level gives intervals and no warning."""
    from .synthetic_campaign import LAW, case_results, content_for

    two = case_results(levels=(1, 3), family=12)
    with pytest.warns(NoIntervalWarning, match=r"group LDMS: its log fit goes through 2 load "
                                               r"levels \(1 and 3\) exactly") as caught:
        cal = ms.Calibration.from_results(two)
    assert caught[0].filename == __file__  # points at the caller
    energies = [r.energy for r in two]
    ref = stats.linregress(np.log([1, 3]), np.asarray(energies) / max(energies))
    assert cal.fit.r2 == pytest.approx(ref.rvalue**2, abs=1e-12)
    assert not cal.gives_intervals
    (group,) = ms.analyze_campaign(two)
    with pytest.warns(NoIntervalWarning):  # repr: nan standard errors, and nan != nan
        assert repr(ms.Calibration.from_group(group)) == repr(cal)
    rec = synthetic_record(2, content=content_for(two[0].scene, LAW), seed=77).block(4, 14)
    with pytest.warns(NoIntervalWarning, match="no interval for the estimate: the calibration "
                                               "LDMS cannot give one") as caught:
        est = ms.estimate_fill(rec, cal)
    assert caught[0].filename == __file__
    assert math.isfinite(est.level) and np.isnan(est.interval).all()

    three = ms.Calibration.from_results(two + case_results(levels=(5,), family=12))  # silent
    assert three.gives_intervals
    est = ms.estimate_fill(rec, three)
    assert est.interval[0] < est.level < est.interval[1]


@pytest.mark.parametrize("level", [1.5, 2.5, 4.0, 6.0])
def test_estimate_from_a_campaign_calibration_holds_the_true_level(campaign_results,
                                                                   level: float) -> None:
    """Records the calibration has not seen, at levels between its own: over 80 such records
    (20 calibrations x 4 levels) the 95 % interval held the level 79 times."""
    from .synthetic_campaign import LAW, content_for

    cal = ms.Calibration.from_results(campaign_results)
    scene = campaign_results[0].scene
    for seed in (31, 32, 33):
        rec = synthetic_record(level, content=content_for(scene, LAW), seed=seed).block(4, 14)
        est = ms.estimate_fill(rec, cal)
        assert est.interval[0] <= level <= est.interval[1]
        assert not est.outside


def test_estimate_counts_the_calibrated_band_and_removes_further_lines(campaign_results) -> None:
    """A record sampled at 1 kHz whose noise has the same density in 0-50 Hz as a level-3
    record at 100 Hz (ten times the variance) reads level 3: only the calibrated band counts.
    A 40 N m line at 23.1 Hz is removed when named."""
    from .synthetic_campaign import LAW, content_for

    cal = ms.Calibration.from_results(campaign_results)
    scene = campaign_results[0].scene
    fast = content_for(scene, LAW, noise_std_Nm=30.0 * np.sqrt(10.0), lines=((23.1, 40.0),))
    rec = synthetic_record(3, content=fast, sample_rate_hz=1000.0, seed=8).block(4, 14)
    est = ms.estimate_fill(rec, cal, lines_hz=[23.1])
    assert est.interval[0] <= 3.0 <= est.interval[1]
    with pytest.warns(OutsideCalibrationWarning):
        assert ms.estimate_fill(rec, cal).level < 1.0  # the line's energy swamps the noise
    slow = synthetic_record(3, content=content_for(scene, LAW), sample_rate_hz=80.0)
    with pytest.raises(ValueError, match="band_hz = 50 Hz .* needs at least 100 Hz"):
        ms.estimate_fill(slow.block(4, 14), cal)


def test_format_1_calibrations_still_load(tmp_path, calibration) -> None:
    data = json.loads(calibration.save(tmp_path / "new.json").read_text())
    assert data["format"] == "millscope-calibration-2"
    old = {k: v for k, v in data.items() if k not in ("band_hz", "block_relative_std")}
    old["format"] = "millscope-calibration-1"
    (tmp_path / "old.json").write_text(json.dumps(old))
    loaded = ms.Calibration.load(tmp_path / "old.json")
    assert loaded == calibration
    assert loaded.band_hz is None and loaded.block_relative_std is None

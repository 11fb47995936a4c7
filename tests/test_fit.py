"""Log fit against scipy, calibration I/O and the filling estimate."""

from __future__ import annotations

import json
import warnings

import numpy as np
import pytest
from scipy import stats

import millscope as ms
from millscope.fit import OutsideCalibrationWarning, log_fit_coefficients, per_unit
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
    with pytest.raises(ValueError, match="incomplete or damaged"):
        ms.Calibration.load(bad)
    with pytest.raises(ValueError, match="reference_energy = 0"):
        ms.Calibration(fit=calibration.fit, reference_energy=0.0, lifters=16, rotation_hz=0.5)

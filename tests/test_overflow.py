"""No NaN or infinity out of finite input (issue 25, item 10).

Torque above about 1e154 N m overflowed in its squares: spectral energy inf, level nan in every
window. Blocks are now scaled by a power of two before the squares, which changes no digit, so
results must agree exactly with a scaled reference: energy(c x) = c^2 energy(x) and amplitude(c x)
= c amplitude(x) for c a power of two; a result beyond the float range is refused, naming the
largest samples that keep it finite."""

from __future__ import annotations

import dataclasses
import math
import warnings

import numpy as np
import pytest

import millscope as ms
from millscope.synthetic import SyntheticTorque, synthetic_record

CONTENT = SyntheticTorque()
LTH = CONTENT.lifters * CONTENT.rotation_hz
BLOCK = synthetic_record(3, content=CONTENT, seed=1).block(4.0, 14.0)
#: Scales the block to samples of about 3.6e154 N m: their squares overflow (above 1.8e308),
#: its energy, about 5e307 (N m)^2 s, does not.
C = 2.0**505


def _times(record: ms.TorqueRecord, c: float) -> ms.TorqueRecord:
    return ms.TorqueRecord(record.time_s, record.torque_Nm * c, record.meta)


def test_energy_amplitude_and_filtered_signal_scale_exactly() -> None:
    big = _times(BLOCK, C)
    with np.errstate(over="ignore"):
        assert not np.all(np.isfinite(big.torque_Nm**2))  # what overflowed before
    small = ms.spectral_energy(BLOCK, ["mean", LTH])
    large = ms.spectral_energy(big, ["mean", LTH])
    assert math.isfinite(large.energy)
    assert large.energy == small.energy * C * C
    assert large.relative_std == small.relative_std
    peak, big_peak = ms.find_peak(BLOCK, LTH), ms.find_peak(big, LTH)
    assert big_peak.frequency_hz == peak.frequency_hz
    assert big_peak.amplitude == peak.amplitude * C
    filtered = ms.band_stop(big, ["mean", LTH])
    np.testing.assert_array_equal(filtered.torque_Nm,
                                  ms.band_stop(BLOCK, ["mean", LTH]).torque_Nm * C)


def test_spectra_scale_exactly_or_are_refused() -> None:
    """The spectral density of the mean's bin, (N m)^2/Hz, leaves the float range before the
    energy does: refused, naming it."""
    c = 2.0**500
    spec, big_spec = ms.spectrum(BLOCK), ms.spectrum(_times(BLOCK, c))
    np.testing.assert_array_equal(big_spec.amplitude, spec.amplitude * c)
    np.testing.assert_array_equal(big_spec.power, spec.power * c * c)
    np.testing.assert_array_equal(big_spec.psd, spec.psd * c * c)
    with pytest.raises(ValueError, match="power spectral density exceeds the largest float"):
        ms.spectrum(_times(BLOCK, C))


def test_an_energy_beyond_the_float_range_is_refused_with_the_limit() -> None:
    c = 2.0**510
    with pytest.raises(ValueError, match=r"spectral energy exceeds the largest float, 1\.8e\+308: "
                                         r"its samples reach .* it stays finite for samples up "
                                         r"to (\S+);"):
        ms.spectral_energy(_times(BLOCK, c), ["mean", LTH])
    # the limit it names is right: just below it the energy is finite
    energy = ms.spectral_energy(BLOCK, ["mean", LTH]).energy
    largest = float(np.max(np.abs(BLOCK.torque_Nm)))
    limit = largest * math.sqrt(np.finfo(float).max / energy)
    below = _times(BLOCK, 0.999 * limit / largest)
    assert math.isfinite(ms.spectral_energy(below, ["mean", LTH]).energy)


def test_a_level_from_huge_torque_is_the_level_of_the_same_torque_in_a_safe_unit() -> None:
    """The same calibration in other units (reference energy x c^2) gives the same level, not
    nan, for the block x c."""
    levels = np.arange(1.0, 6.0)
    energies = np.array([ms.spectral_energy(synthetic_record(lv, content=CONTENT, seed=i)
                                            .block(4.0, 14.0), ["mean", LTH]).energy
                         for i, lv in enumerate(levels)])
    cal = ms.Calibration(fit=ms.log_fit(levels, energies / energies.max()),
                         reference_energy=float(energies.max()), lifters=CONTENT.lifters,
                         rotation_hz=CONTENT.rotation_hz, block_s=10.0)
    c = 2.0**502
    big_cal = dataclasses.replace(cal, reference_energy=cal.reference_energy * c * c)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ms.fit.OutsideCalibrationWarning)
        est = ms.estimate_fill(BLOCK, cal)
        big = ms.estimate_fill(_times(BLOCK, c), big_cal)
    assert math.isfinite(big.level)
    assert (big.level, big.interval, big.energy_pu) == (est.level, est.interval, est.energy_pu)

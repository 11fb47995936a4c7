"""Spectra, peaks and spectral energy against scipy and analytic values (docs/architecture.md,
Spectra)."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.signal as ss
from hypothesis import given, settings
from hypothesis import strategies as st

import millscope as ms

from .conftest import sine_record

SCIPY_WINDOWS = {
    "hann": lambda n: ss.windows.hann(n, sym=True),
    "hann_periodic": lambda n: ss.windows.hann(n, sym=False),
    "rectangular": lambda n: np.ones(n),
}


@pytest.mark.parametrize("window", sorted(SCIPY_WINDOWS))
@pytest.mark.parametrize("n", [1000, 1001, 64])
def test_spectrum_equals_scipy_periodogram(window: str, n: int, rng) -> None:
    fs = 100.0
    x = 265.0 + rng.normal(0.0, 3.0, n) + 4 * np.sin(2 * np.pi * 8.7 * np.arange(n) / fs)
    spec = ms.spectrum(x, sample_rate_hz=fs, window=window)
    w = SCIPY_WINDOWS[window](n)
    for scaling, ours in (("density", spec.psd), ("spectrum", spec.power)):
        f, p = ss.periodogram(x, fs, window=w, detrend=False, scaling=scaling)
        np.testing.assert_allclose(spec.freq, f, rtol=1e-12, atol=0)
        np.testing.assert_allclose(ours, p, rtol=1e-10, atol=1e-10 * p.max())
    # amplitude is the coherent-gain-corrected magnitude: interior bins sqrt(2 x power)
    np.testing.assert_allclose(spec.amplitude[1:-1], np.sqrt(2 * spec.power[1:-1]), rtol=1e-12)
    assert spec.amplitude[0] == pytest.approx(np.sqrt(spec.power[0]), rel=1e-12)


@pytest.mark.parametrize("window", sorted(SCIPY_WINDOWS))
def test_window_factors_match_their_definitions(window: str) -> None:
    n = 777
    w = SCIPY_WINDOWS[window](n)
    np.testing.assert_allclose(ms.spectral._core.window(window, n), w, rtol=0, atol=1e-15)
    f = ms.window_factors(window, n)
    assert f.coherent_gain == pytest.approx(w.mean(), rel=1e-12)
    assert f.power_gain == pytest.approx(np.mean(w**2), rel=1e-12)
    assert f.enbw_bins == pytest.approx(n * np.sum(w**2) / np.sum(w) ** 2, rel=1e-12)


def test_hann_enbw_is_one_and_a_half_bins() -> None:
    # textbook value for the Hann window (Harris 1978): 1.50 bins
    assert ms.window_factors("hann_periodic", 4096).enbw_bins == pytest.approx(1.5, rel=1e-9)


def test_off_bin_sinusoid_read_back_within_one_percent() -> None:
    """0.1 Hz resolution (10 s at 100 Hz), a line at 8.83 Hz between bins, mean and noise."""
    amplitude, f0 = 10.0, 8.83
    rec = sine_record(1000, 100.0, mean=265.0, amplitude=amplitude, freq_hz=f0, noise_std=0.25)
    peak = ms.find_peak(rec, 8.8, search_hz=0.5)
    assert abs(peak.frequency_hz - f0) < 0.02
    assert peak.amplitude == pytest.approx(amplitude, rel=0.01)
    # the bare spectrum reads the line lower (scalloping) at its nearest bin: refinement matters
    spec = ms.spectrum(rec)
    k = int(np.argmin(np.abs(spec.freq - f0)))
    assert spec.amplitude[k] < 0.95 * amplitude


def test_on_bin_sinusoid_amplitude_exact() -> None:
    rec = sine_record(1000, 100.0, amplitude=3.0, freq_hz=8.8)
    spec = ms.spectrum(rec)
    k = int(round(8.8 / spec.resolution_hz))
    assert spec.amplitude[k] == pytest.approx(3.0, rel=2e-3)  # symmetric Hann: N-1 periodicity
    assert ms.spectrum(rec, window="hann_periodic").amplitude[k] == pytest.approx(3.0, rel=1e-12)


def test_energy_after_removing_mean_and_line_matches_white_noise_level() -> None:
    """E = s^2 TR x (fraction kept) for white noise of variance s^2 (docs/architecture.md, Spectra).

    The estimate's relative standard deviation for a Hann window is about 2/sqrt(N), so the
    block is 2^17 samples long (0.5 %), making the 3 % tolerance a 5-sigma bound.
    """
    n, fs, s = 2**17, 100.0, 1.5
    rec = sine_record(n, fs, mean=265.0, amplitude=2.0, freq_hz=8.83, noise_std=s, seed=3)
    e = ms.spectral_energy(rec, ["mean", 8.83], bandwidth=0.3)
    expected = s**2 * rec.duration_s * e.fraction_kept
    assert e.energy == pytest.approx(expected, rel=0.03)
    assert 0.99 < e.fraction_kept < 1.0


def test_band_limit_keeps_its_share_of_the_noise() -> None:
    n, fs, s = 2**17, 100.0, 1.0
    rec = sine_record(n, fs, noise_std=s, seed=5)
    e = ms.spectral_energy(rec, [], band=(0.0, 25.0))
    assert e.fraction_kept == pytest.approx(0.5, abs=2 / n)
    assert e.energy == pytest.approx(s**2 * rec.duration_s * e.fraction_kept, rel=0.03)


def test_narrow_band_is_widened_to_the_main_lobe() -> None:
    rec = sine_record(1000, 100.0, noise_std=1.0)
    narrow = ms.spectral_energy(rec, ["mean", 8.8], bandwidth=0.3)  # +-0.15 < +-2/TR
    assert narrow.widened and narrow.half_width_hz == pytest.approx(0.2)
    wide = ms.spectral_energy(rec, ["mean", 8.8], bandwidth=1.0)
    assert not wide.widened and wide.half_width_hz == pytest.approx(0.5)
    assert ms.spectral_energy(rec, ["mean"], window="rectangular", bandwidth=0).half_width_hz == \
        pytest.approx(0.1)
    assert wide.removed_hz[1] == pytest.approx((8.3, 9.3))


def test_tracking_recentres_a_drifted_line() -> None:
    # the mill turns a little slower than nominal: the line sits 0.25 Hz below the expectation
    rec = sine_record(2000, 100.0, amplitude=20.0, freq_hz=8.55, noise_std=0.5, seed=2)
    fixed = ms.spectral_energy(rec, ["mean", 8.8], bandwidth=0.2)
    tracked = ms.spectral_energy(rec, ["mean", 8.8], bandwidth=0.2, track_hz=0.4)
    noise_only = 0.5**2 * rec.duration_s * tracked.fraction_kept
    assert tracked.energy == pytest.approx(noise_only, rel=0.2)
    assert fixed.energy > 10 * noise_only


def test_lifter_harmonic() -> None:
    assert ms.lifter_harmonic_hz(16, 0.55) == pytest.approx(8.8)
    with pytest.raises(ValueError, match="n_lifters = 0"):
        ms.lifter_harmonic_hz(0, 0.5)
    with pytest.raises(ValueError, match="rotation_hz = -1"):
        ms.lifter_harmonic_hz(16, -1)


@pytest.mark.parametrize(
    ("call", "message"),
    [
        (lambda r: ms.spectrum(r, window="hamming"), "window = 'hamming' is not known"),
        (lambda r: ms.spectrum(r.torque_Nm), "sample_rate_hz .* is required"),
        (lambda r: ms.spectrum(r, resolution_hz=0.05), r"resolves df = 1/TR = 0.1 Hz.*0.05"),
        (lambda r: ms.spectral_energy(r, ["median"]), "remove: 'median' is not known"),
        (lambda r: ms.spectral_energy(r, [70.0]), "line to remove at 70 Hz is outside"),
        (lambda r: ms.spectral_energy(r, bandwidth=-1), "bandwidth = -1 Hz is not valid"),
        (lambda r: ms.spectral_energy(r, band=(30, 20)), r"band = \(30, 20\) Hz is not valid"),
        (lambda r: ms.find_peak(r, 80.0), "near_hz = 80 Hz is outside"),
        (lambda r: ms.spectrum([1.0, 2.0, 3.0], sample_rate_hz=1), "at least 4"),
        (lambda r: ms.spectrum([1.0, np.nan, 3.0, 4.0], sample_rate_hz=1), "NaN"),
        (lambda r: ms.spectrum(r.torque_Nm, sample_rate_hz=-2), "sample_rate_hz = -2"),
    ],
)
def test_bad_arguments_name_the_parameter(call, message: str) -> None:
    rec = sine_record(1000, 100.0, noise_std=1.0)
    with pytest.raises(ValueError, match=message):
        call(rec)


@settings(max_examples=60, deadline=None)
@given(
    n=st.integers(min_value=4, max_value=3000),
    fs=st.floats(min_value=0.5, max_value=20000.0),
    window=st.sampled_from(sorted(SCIPY_WINDOWS)),
    scale=st.floats(min_value=1e-6, max_value=1e6),
    seed=st.integers(min_value=0, max_value=2**32 - 1),
    bandwidth=st.floats(min_value=0.0, max_value=10.0),
)
def test_properties_hold_for_any_block(n, fs, window, scale, seed, bandwidth) -> None:
    x = np.random.default_rng(seed).normal(0.0, scale, n) + scale
    spec = ms.spectrum(x, sample_rate_hz=fs, window=window)
    assert spec.freq.size == n // 2 + 1
    assert np.all(np.isfinite(spec.amplitude)) and np.all(spec.psd >= 0)
    full = ms.spectral_energy(x, [], window=window, sample_rate_hz=fs)
    filtered = ms.spectral_energy(x, ["mean", fs / 4], bandwidth=bandwidth, window=window,
                                  sample_rate_hz=fs)
    assert np.isfinite(filtered.energy) and filtered.energy >= 0
    assert filtered.energy <= full.energy * (1 + 1e-9)
    assert 0 <= filtered.fraction_kept <= 1


@pytest.mark.parametrize("window", ["hann", "rectangular"])
def test_relative_std_predicts_the_scatter_over_realisations(window: str) -> None:
    """Over 400 noise realisations the energies scatter as relative_std says (within 15 %;
    the standard error of a standard deviation from 400 samples is 3.5 %)."""
    n, fs = 1000, 100.0
    rng = np.random.default_rng(11)
    results = [ms.spectral_energy(rng.normal(0, 2.0, n), ["mean"], window=window,
                                  sample_rate_hz=fs) for _ in range(400)]
    energies = np.array([r.energy for r in results])
    predicted = np.mean([r.relative_std for r in results])
    assert np.std(energies) / np.mean(energies) == pytest.approx(predicted, rel=0.15)
    c_w = {"hann": 35 / 18, "rectangular": 1.0}[window]
    assert predicted == pytest.approx(np.sqrt(c_w * 2 / n), rel=0.1)  # white-noise value


def test_concurrent_calls_share_plans_safely() -> None:
    """FFTW plans are cached per length and planned under a lock; the GIL is released while
    transforming, so threads run at once. Results equal the single-threaded ones bit for bit."""
    from concurrent.futures import ThreadPoolExecutor

    rng = np.random.default_rng(8)
    blocks = [rng.normal(0, 1, n) for n in (997, 1000, 1024, 4096, 1000, 997) * 4]
    serial = [ms.spectrum(b, sample_rate_hz=100.0).psd for b in blocks]
    with ThreadPoolExecutor(max_workers=4) as pool:
        parallel = list(pool.map(lambda b: ms.spectrum(b, sample_rate_hz=100.0).psd, blocks))
    for a, b in zip(serial, parallel, strict=True):
        np.testing.assert_array_equal(a, b)

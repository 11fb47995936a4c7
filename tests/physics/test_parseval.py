"""Parseval: the spectral energy of eq. (11) equals the time-domain energy of the block."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.signal as ss

import millscope as ms

from ..conftest import sine_record


@pytest.mark.parametrize("n", [1000, 999])
def test_unfiltered_rectangular_energy_is_the_time_integral(n: int) -> None:
    rec = sine_record(n, 100.0, mean=30.0, amplitude=5.0, freq_hz=7.3, noise_std=2.0)
    e = ms.spectral_energy(rec, [], window="rectangular")
    assert e.energy == pytest.approx(np.sum(rec.torque_Nm**2) * rec.dt, rel=1e-12)
    assert e.fraction_kept == 1.0


@pytest.mark.parametrize("window", ["hann", "hann_periodic", "rectangular"])
def test_filtered_energy_equals_time_domain_energy_of_the_filtered_block(window: str) -> None:
    """Reference built with numpy's FFT, independently of the FFTW path."""
    n, fs = 1000, 100.0
    rec = sine_record(n, fs, mean=265.0, amplitude=6.0, freq_hz=8.66, noise_std=3.0, seed=7)
    remove, bandwidth = ["mean", 8.66, 23.1], 0.6
    e = ms.spectral_energy(rec, remove, bandwidth=bandwidth, window=window)

    w = {"hann": ss.windows.hann(n, sym=True), "hann_periodic": ss.windows.hann(n, sym=False),
         "rectangular": np.ones(n)}[window]
    x = rec.torque_Nm
    spec = np.fft.rfft(w * (x - x.mean()))
    f = np.fft.rfftfreq(n, 1 / fs)
    half = max(bandwidth / 2, (1 if window == "rectangular" else 2) * fs / n)
    for c in (0.0, 8.66, 23.1):
        spec[np.abs(f - c) <= half + 1e-9] = 0
    y = np.fft.irfft(spec, n) / np.sqrt(np.mean(w**2))
    time_domain = np.sum(y**2) / fs
    assert e.energy == pytest.approx(time_domain, rel=1e-10)

    # and band_stop hands out exactly that filtered block
    filtered = ms.band_stop(rec, remove, bandwidth=bandwidth, window=window)
    np.testing.assert_allclose(filtered.torque_Nm, y, rtol=0, atol=1e-9 * np.abs(y).max())
    assert np.sum(filtered.torque_Nm**2) * rec.dt == pytest.approx(e.energy, rel=1e-10)

"""find_peak stays inside its search window and says when a line does not stand out of the noise
(issue "Trust the numbers", item 1; "Bad input and faults", item 3)."""

from __future__ import annotations

import subprocess
import sys
import textwrap

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import millscope as ms


def _tone(n: int, fs: float, freq_hz: float, amplitude: float, phase: float = 0.3):
    return amplitude * np.sin(2 * np.pi * freq_hz * np.arange(n) / fs + phase)


@given(n=st.integers(400, 3000), fs=st.sampled_from([50.0, 100.0, 200.0, 1000.0 / 3]),
       bin_=st.integers(20, 150), side=st.sampled_from([-1, 1]),
       outside=st.floats(3.05, 6.0), search_bins=st.sampled_from([1.0, 2.0, 3.0]))
@settings(max_examples=150, deadline=None)
def test_the_located_line_lies_inside_the_asked_window(n, fs, bin_, side, outside,
                                                      search_bins) -> None:
    """A line 20 times larger just outside the window never draws the result out of it.

    The window's edges fall on exact bins here, where k df / df may round to k - 1."""
    df = fs / n
    near = bin_ * df
    if not 0 < near + side * (outside + 2) * df < fs / 2:
        return
    x = 300.0 + _tone(n, fs, near + side * outside * df, 20.0) + _tone(n, fs, near, 0.5, 1.1)
    search = search_bins * df
    peak = ms.find_peak(x, near, search_hz=search, sample_rate_hz=fs)
    assert near - search <= peak.frequency_hz <= near + search


def test_main_job_case_finds_the_small_lth_next_to_a_larger_line() -> None:
    """The shape the main job met: a 10 s block at 100 Hz, the LTH expected at 8.661 Hz, a
    line 20 times larger 4.9 bins below it. The LTH (1 N m) is found, not the larger line."""
    fs, n, f_lth = 100.0, 1000, 8.661
    rng = np.random.default_rng(7)
    x = (300.0 + _tone(n, fs, f_lth, 1.0) + _tone(n, fs, f_lth - 0.49, 20.0, 0.4)
         + rng.normal(0.0, 0.3, n))
    peak = ms.find_peak(x, f_lth, sample_rate_hz=fs)
    assert abs(peak.frequency_hz - f_lth) < 0.3 * fs / n  # within a third of a bin
    assert peak.amplitude == pytest.approx(1.0, rel=0.1)
    assert peak.local_maximum and peak.distinct


def test_only_a_slope_in_the_window_is_no_local_maximum() -> None:
    """No line in the window, a large one just beyond its edge: the search ends on the edge,
    and the result says that it is not a line."""
    fs, n = 100.0, 1000
    df = fs / n
    x = 300.0 + _tone(n, fs, 8.661 + 3.4 * df, 20.0)
    peak = ms.find_peak(x, 8.661, sample_rate_hz=fs)
    assert peak.frequency_hz == pytest.approx(8.661 + 3 * df, abs=1e-6)
    assert not peak.local_maximum and not peak.distinct
    assert "outside the search window" in peak.describe()


def test_noise_peaks_are_rarely_called_distinct_and_lines_are() -> None:
    """For Gaussian noise a bin's amplitude is Rayleigh distributed: it exceeds 3 x the median
    with probability 2**-9 per bin. The largest of 7 bins, refined between bins and compared
    with a median estimated from 44 bins, is called distinct in about 3 % of noise-only
    blocks (spectral.PEAK_DISTINCT_RATIO); 6 % is a bound four standard deviations above it
    for 400 blocks. A line of 8 times the noise's median bin amplitude stands out in every
    block."""
    fs, n, f0 = 100.0, 1000, 8.661
    rng = np.random.default_rng(3)
    # median bin amplitude of unit white noise, Hann: 2 sqrt(ln 2 sum w^2) / sum w
    w = np.sin(np.pi * np.arange(n) / (n - 1)) ** 2
    median_amplitude = 2 * np.sqrt(np.log(2) * np.sum(w**2)) / np.sum(w)
    noise_only = [ms.find_peak(rng.normal(0, 1, n), f0, sample_rate_hz=fs) for _ in range(400)]
    false_alarms = sum(p.distinct for p in noise_only)
    assert false_alarms <= 24
    # the noise estimate itself against the Rayleigh median
    assert np.median([p.noise_amplitude for p in noise_only]) == pytest.approx(
        median_amplitude, rel=0.05)
    with_line = [ms.find_peak(rng.normal(0, 1, n) + _tone(n, fs, f0, 8 * median_amplitude),
                              f0, sample_rate_hz=fs) for _ in range(100)]
    assert all(p.distinct for p in with_line)


def test_find_peak_returns_on_blocks_longer_than_2_to_the_23() -> None:
    """The refinement's loop is bounded: on a block of 2**23 + 1000 samples it used to spin for
    ever. Run in a subprocess with a time limit, so that a regression fails instead of hanging."""
    code = textwrap.dedent("""
        import numpy as np, millscope as ms
        n, fs, f0 = 2**23 + 1000, 100.0, 8.661
        x = 5.0 * np.sin(2 * np.pi * f0 * np.arange(n) / fs)
        p = ms.find_peak(x, f0, sample_rate_hz=fs)
        print(repr(p.frequency_hz), repr(p.amplitude))
    """)
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=120)
    assert done.returncode == 0, done.stderr
    freq, amplitude = map(float, done.stdout.split())
    assert freq == pytest.approx(8.661, abs=1e-6)
    assert amplitude == pytest.approx(5.0, rel=1e-4)

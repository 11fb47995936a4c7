"""Spectral analysis of torque blocks (paper sections 3.2, 6.2-6.4; docs/architecture.md, Spectra).

Thin, typed wrappers over the C++ DSP core (FFTW): spectra, the lifter torque harmonic (LTH),
band removal and the spectral energy of eq. (11).

Every function takes a :class:`~millscope.record.TorqueRecord` (usually a block of one), or a
plain 1-D array together with ``sample_rate_hz``.

Windows: ``"hann"`` (symmetric, eq. 10, the default), ``"hann_periodic"`` and ``"rectangular"``.

Every function divides the block by the power of two nearest above its largest |sample| before
the C++ core squares anything, and multiplies the results back by that power (squared for
energies and powers). A power of two changes no digit of a normal float, so the results are
those of the unscaled block, bit for bit, whenever that one does not overflow; and torque
whose squares would overflow (above about 1e154 N m) still gives finite results. A result that
is itself beyond the float range (e.g. an energy above 1.8e308 (N m)^2 s) raises ValueError.
"""

from __future__ import annotations

import math
import sys
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from numbers import Integral
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .. import _core
from .._checks import MAX_LIFTERS
from .record import TorqueRecord

__all__ = [
    "Spectrum",
    "Peak",
    "SpectralEnergy",
    "WindowName",
    "spectrum",
    "window_factors",
    "lifter_harmonic_hz",
    "find_peak",
    "spectral_energy",
    "band_stop",
    "LTH_CLEAR_BINS",
    "PEAK_DISTINCT_RATIO",
    "MAX_LIFTERS",
]

WindowName = Literal["hann", "hann_periodic", "rectangular"]
Samples = TorqueRecord | ArrayLike
RemoveItem = Literal["mean"] | float

_WINDOWS = ("hann", "hann_periodic", "rectangular")

#: A block must hold at least this many periods of the LTH for the LTH, searched within 3 bins
#: of lifters x rotation frequency, to lie clear of the mean's main lobe (2 bins with the Hann
#: window) with a bin to spare.
LTH_CLEAR_BINS = 6.0


def _samples(data: Samples, sample_rate_hz: float | None) -> tuple[NDArray[np.float64], float]:
    """(samples, fs) from a record, or from an array and its sample rate."""
    if isinstance(data, TorqueRecord):
        if sample_rate_hz is not None:
            raise ValueError("sample_rate_hz is taken from the TorqueRecord; do not pass it too")
        return data.torque_Nm, data.sample_rate_hz
    if sample_rate_hz is None:
        raise ValueError("sample_rate_hz (Hz) is required when the data is an array, not a "
                         "TorqueRecord")
    x = np.ascontiguousarray(data, dtype=np.float64)
    if x.ndim != 1:
        raise ValueError(f"data must be 1-D; got shape {x.shape}")
    if not np.all(np.isfinite(x)):
        raise ValueError("data holds NaN or infinite samples; every sample must be finite")
    fs = float(sample_rate_hz)
    if not (np.isfinite(fs) and fs > 0):
        raise ValueError(f"sample_rate_hz = {sample_rate_hz!r} is not valid; it must be > 0")
    return x, fs


@dataclass(frozen=True)
class _Scale:
    """A block divided by 2**k, the power of two at or just above its largest |sample| (k = 0
    for a block of zeros): the scaled samples are at most 1 in size, so their squares cannot
    overflow, and the division is exact."""

    k: int
    peak: float  # the largest |sample| of the block itself

    def back(self, value: NDArray[np.float64], power: int, what: str) -> NDArray[np.float64]:
        """``value`` x (2**k)**power, exactly, for a result of the scaled samples that is of
        their ``power`` (1 for amplitudes, 2 for energies); ValueError naming ``what`` and the
        largest samples that keep it finite when it leaves the float range."""
        with np.errstate(over="ignore"):
            out = np.ldexp(value, power * self.k)
        if not np.all(np.isfinite(out)):
            largest = float(np.max(np.abs(value)))
            limit = math.ldexp(self.peak, -self.k) * math.exp(
                (math.log(sys.float_info.max) - math.log(largest)) / power)
            raise ValueError(
                f"the block's {what} exceeds the largest float, {sys.float_info.max:.3g}: its "
                f"samples reach {self.peak:.3g} in size, and it stays finite for samples up to "
                f"{limit:.3g}; give the record in larger units (e.g. kN m instead of N m)")
        return out


def _normalised(x: NDArray[np.float64]) -> tuple[NDArray[np.float64], _Scale]:
    """The samples divided by the power of two at or just above their largest size, and the
    :class:`_Scale` that multiplies results back."""
    peak = float(np.max(np.abs(x))) if x.size else 0.0
    k = math.frexp(peak)[1] if peak > 0 else 0
    return np.ldexp(x, -k), _Scale(k, peak)


def _block(data: Samples, window: str, sample_rate_hz: float | None,
           resolution_hz: float | None = None
           ) -> tuple[NDArray[np.float64], float, NDArray[np.float64], _Scale]:
    """What every analysis of a block starts with: the window and the samples checked (and the
    resolution, when asked), then (samples, fs, the samples scaled by 2**-k, the scale)."""
    _check_window(window)
    x, fs = _samples(data, sample_rate_hz)
    _check_resolution(x.size, fs, resolution_hz)
    unit, scale = _normalised(x)
    return x, fs, unit, scale


def _check_window(window: str) -> None:
    if window not in _WINDOWS:
        raise ValueError(f"window = {window!r} is not known; use one of {', '.join(_WINDOWS)}")


def _check_resolution(n: int, fs: float, resolution_hz: float | None) -> None:
    """Eq. (9): df = 1/TR; a block too short for the asked resolution is an error."""
    if resolution_hz is None:
        return
    if not resolution_hz > 0:
        raise ValueError(f"resolution_hz = {resolution_hz!r} is not valid; it must be > 0")
    df = fs / n
    if df > resolution_hz * (1 + 1e-9):
        raise ValueError(
            f"block of {n / fs:g} s resolves df = 1/TR = {df:g} Hz, coarser than the asked "
            f"resolution_hz = {resolution_hz:g} Hz; it needs at least {1 / resolution_hz:g} s")


@dataclass(frozen=True)
class Spectrum:
    """Single-sided spectrum of a windowed block.

    Attributes
    ----------
    freq : ndarray
        Bin frequencies k/TR, Hz.
    amplitude : ndarray
        Amplitude corrected for the window's coherent gain (N m for torque): a sinusoid of
        amplitude A reads about A at its bin.
    psd : ndarray
        Power spectral density, (N m)^2/Hz; equals ``scipy.signal.periodogram(...,
        scaling="density")`` for the same window.
    power : ndarray
        Squared RMS per bin, (N m)^2; equals ``scaling="spectrum"`` of the periodogram.
    window : str
        The window used.
    resolution_hz : float
        df = 1/TR, Hz (eq. 9).
    """

    freq: NDArray[np.float64]
    amplitude: NDArray[np.float64]
    psd: NDArray[np.float64]
    power: NDArray[np.float64]
    window: str
    resolution_hz: float


def spectrum(data: Samples, *, window: WindowName = "hann", sample_rate_hz: float | None = None,
             resolution_hz: float | None = None) -> Spectrum:
    """The single-sided spectrum of a block (no detrending: the mean appears at 0 Hz).

    Parameters
    ----------
    data : TorqueRecord or array_like
        The block.
    window : {"hann", "hann_periodic", "rectangular"}
        Window applied before the FFT; ``"hann"`` is the paper's symmetric Hann (eq. 10).
    sample_rate_hz : float, optional
        Sampling frequency in Hz, required for a plain array.
    resolution_hz : float, optional
        If given, refuse a block too short to resolve it (eq. 9).
    """
    x, fs, unit, scale = _block(data, window, sample_rate_hz, resolution_hz)
    amplitude, power, psd = _core.spectra(unit, fs, window)
    return Spectrum(
        freq=_core.bin_frequencies(x.size, fs),
        amplitude=scale.back(amplitude, 1, "spectrum amplitude"),
        psd=scale.back(psd, 2, "power spectral density"),
        power=scale.back(power, 2, "spectrum power"),
        window=window,
        resolution_hz=fs / x.size,
    )


def window_factors(window: WindowName, n: int) -> _core.WindowFactors:
    """Coherent gain, power gain, equivalent noise bandwidth (bins) and main-lobe half-width of a
    window of ``n`` samples."""
    _check_window(window)
    if n < 1:
        raise ValueError(f"n = {n} is not valid; a window needs n >= 1 samples")
    return _core.window_factors(window, n)


def lifter_harmonic_hz(n_lifters: int, rotation_hz: float) -> float:
    """Frequency of the lifter torque harmonic, n_lifters x rotation frequency (section 6.2), Hz.

    ``n_lifters`` is an integer in [1, ``MAX_LIFTERS``]; the result must be finite."""
    whole = (isinstance(n_lifters, Integral) and not isinstance(n_lifters, bool)) or (
        isinstance(n_lifters, float) and float(n_lifters).is_integer())
    if not whole or not 1 <= n_lifters <= MAX_LIFTERS:
        raise ValueError(f"n_lifters = {n_lifters!r} is not valid; it must be an integer in "
                         f"[1, {MAX_LIFTERS}]")
    if not (np.isfinite(rotation_hz) and rotation_hz > 0):
        raise ValueError(f"rotation_hz = {rotation_hz!r} is not valid; it must be > 0 Hz")
    lth = float(n_lifters) * float(rotation_hz)
    if not np.isfinite(lth):
        raise ValueError(f"rotation_hz = {rotation_hz!r} is not valid; the LTH, "
                         f"{n_lifters} lifters x rotation_hz, must be finite")
    return lth


#: A located line is told apart from the noise when its amplitude is at least this many times
#: the median amplitude of the bins around it. For Gaussian noise a bin's amplitude is
#: Rayleigh distributed, so it exceeds c times the median with probability 2**(-c**2): 0.2 %
#: per bin at c = 3. The located peak is the largest of the window's bins, refined between
#: bins (which raises it) and compared with a median estimated from 44 bins, so noise alone
#: is called distinct more often than 7 x 0.2 %: in 57 of 2000 blocks of white noise (10 s
#: Hann blocks, the default +-3 bins), about 3 %.
PEAK_DISTINCT_RATIO = 3.0


@dataclass(frozen=True)
class Peak:
    """A spectral line located near an expected frequency.

    Attributes
    ----------
    frequency_hz : float
        Frequency, Hz, refined between bins; always inside the searched window.
    amplitude : float
        Amplitude of the sinusoid at ``frequency_hz``, window gain corrected (N m for torque).
    noise_amplitude : float
        Median amplitude of the bins around the line (25 bins each side, outside its main lobe
        and the mean's), in the same unit; nan when unknown.
    local_maximum : bool
        False when no bin of the window is a peak of the spectrum and the largest value lies on
        the window's edge: the slope of a larger line outside the window, not a line inside it.
    """

    frequency_hz: float
    amplitude: float
    noise_amplitude: float = float("nan")
    local_maximum: bool = True

    @property
    def snr(self) -> float:
        """``amplitude / noise_amplitude`` (inf over a noise-free spectrum, nan when unknown)."""
        if self.noise_amplitude > 0:
            return self.amplitude / self.noise_amplitude
        return float("inf") if self.noise_amplitude == 0 and self.amplitude > 0 else float("nan")

    @property
    def distinct(self) -> bool:
        """Whether the line stands out of the noise around it: a local maximum of the spectrum
        with ``snr >= PEAK_DISTINCT_RATIO``."""
        return self.local_maximum and self.snr >= PEAK_DISTINCT_RATIO

    def describe(self) -> str:
        """One line: frequency, amplitude and how far it stands out of the noise."""
        text = f"{self.frequency_hz:.4f} Hz, amplitude {self.amplitude:.4g}"
        if math.isfinite(self.snr):
            text += f", {self.snr:.3g} x the noise around it"
        if not self.local_maximum:
            text += " (not a line: the slope of a larger one outside the search window)"
        elif not self.distinct:
            text += f" (not distinguishable from the noise: below {PEAK_DISTINCT_RATIO:g} x)"
        return text


def find_peak(data: Samples, near_hz: float, *, search_hz: float | None = None,
              window: WindowName = "hann", sample_rate_hz: float | None = None) -> Peak:
    """Locate the largest line within ``near_hz +- search_hz`` and refine it between bins.

    Real mills drift in speed, so the LTH and drive lines are searched near where they are
    expected. Of the bins in the window, the largest that is a peak of the spectrum is taken
    (the largest bin when none is). The refinement maximises the windowed DTFT of the block
    (mean removed) between its neighbouring bins, never beyond the window, which is exact for a
    lone sinusoid whatever the window. The result says how far the line stands out of the noise
    (:attr:`Peak.snr`, :attr:`Peak.distinct`).

    Parameters
    ----------
    near_hz : float
        Expected frequency, Hz, in [0, Nyquist].
    search_hz : float, optional
        Half-width of the search window, Hz (>= 0); default 3 bins (3/TR).
    """
    x, fs, unit, scale = _block(data, window, sample_rate_hz)
    if search_hz is None:
        search_hz = 3.0 * fs / x.size
    p = _core.find_peak(unit, fs, window, float(near_hz), float(search_hz))
    amplitude = float(scale.back(np.array(p.amplitude), 1, "peak amplitude"))
    noise = float(scale.back(np.array(p.noise_amplitude), 1, "noise amplitude"))
    return Peak(frequency_hz=p.frequency_hz, amplitude=amplitude, noise_amplitude=noise,
                local_maximum=p.local_maximum)


@dataclass(frozen=True)
class SpectralEnergy:
    """Energy of a filtered block, eq. (11), with what the filter did.

    Attributes
    ----------
    energy : float
        E = integral of |x(t)|^2 dt over the block after removal, (N m)^2 s.
    relative_std : float
        Sampling spread of ``energy`` (standard deviation over mean) for a Gaussian signal whose
        spectrum is smooth over a main lobe; about 2/sqrt(N) for white noise and a Hann window.
        Lines left in the kept band make it larger.
    fraction_kept : float
        Share of the two-sided band 0 .. fs kept by the filter; white noise of variance s^2 gives
        about s^2 TR fraction_kept.
    removed_hz : tuple of (float, float)
        The removed bands as (low, high), Hz.
    half_width_hz : float
        Half-width of each removed band, Hz.
    widened : bool
        True when the requested bandwidth was narrower than the window's main lobe and was
        widened to it (Hann: +-2/TR).
    window : str
    record_length_s : float
        TR, s.
    """

    energy: float
    relative_std: float
    fraction_kept: float
    removed_hz: tuple[tuple[float, float], ...]
    half_width_hz: float
    widened: bool
    window: str
    record_length_s: float

    def __float__(self) -> float:
        return self.energy


def _mask(x: NDArray[np.float64], fs: float, window: str, remove: Iterable[RemoveItem],
          bandwidth: float, band: tuple[float, float] | None, track_hz: float
          ) -> _core.BandMask:
    remove_mean = False
    lines: list[float] = []
    for item in remove:
        if isinstance(item, str):
            if item != "mean":
                raise ValueError(f"remove: {item!r} is not known; give 'mean' or frequencies in Hz")
            remove_mean = True
        else:
            f = float(item)
            if track_hz > 0:
                f = _core.find_peak(x, fs, window, f, float(track_hz)).frequency_hz
            lines.append(f)
    lo, hi = band if band is not None else (0.0, fs / 2)
    return _core.band_mask(x.size, fs, window, remove_mean, lines, float(bandwidth),
                           float(lo), float(hi))


def spectral_energy(data: Samples, remove: Sequence[RemoveItem] = ("mean",), *,
                    bandwidth: float = 0.3, window: WindowName = "hann",
                    band: tuple[float, float] | None = None, track_hz: float = 0.0,
                    sample_rate_hz: float | None = None,
                    resolution_hz: float | None = None) -> SpectralEnergy:
    """Energy of the block after removing the mean and spectral lines (eq. 11).

    Evaluated by Parseval on the windowed spectrum with the window's power corrected
    (docs/architecture.md, Spectra): E = dt sum_{kept k} |X_k|^2 / sum(w^2), over two-sided bins.

    Parameters
    ----------
    remove : sequence of "mean" or float
        What to take out: ``"mean"`` (a band at 0 Hz) and line frequencies in Hz (the LTH,
        drive-train lines).
    bandwidth : float
        Full width of each removed band, Hz; widened to the window's main lobe when narrower
        (the result's ``widened`` says so).
    band : (float, float), optional
        Count only bins in [low, high] Hz; default 0 .. Nyquist.
    track_hz : float
        If > 0, re-centre each line on the largest peak within +- track_hz before removing it
        (real mills drift in speed).
    resolution_hz : float, optional
        If given, refuse a block too short to resolve it (eq. 9).
    """
    x, fs, unit, scale = _block(data, window, sample_rate_hz, resolution_hz)
    mask = _mask(unit, fs, window, remove, bandwidth, band, track_hz)
    h = mask.half_width_hz
    estimate = _core.spectral_energy(unit, fs, window, mask)
    return SpectralEnergy(
        energy=float(scale.back(np.array(estimate.energy), 2, "spectral energy")),
        relative_std=estimate.relative_std,
        fraction_kept=mask.fraction_kept,
        removed_hz=tuple((max(0.0, c - h), c + h) for c in mask.centres_hz),
        half_width_hz=h,
        widened=mask.widened,
        window=window,
        record_length_s=x.size / fs,
    )


def band_stop(data: TorqueRecord, remove: Sequence[RemoveItem] = ("mean",), *,
              bandwidth: float = 0.3, window: WindowName = "hann",
              band: tuple[float, float] | None = None, track_hz: float = 0.0) -> TorqueRecord:
    """The filtered block in the time domain, as a record.

    It is the inverse FFT of the kept bins of the windowed spectrum, divided by the square root of
    the window's power gain, so that its energy ``sum(y**2) * dt`` equals
    :func:`spectral_energy` with the same arguments. With ``window="rectangular"`` it is the
    plain band-stopped signal; with a Hann window it carries the window's taper.
    """
    _, fs, unit, scale = _block(data, window, None)
    mask = _mask(unit, fs, window, remove, bandwidth, band, track_hz)
    y = scale.back(_core.band_stop(unit, window, mask), 1, "filtered signal")
    return TorqueRecord(data.time_s, y, {**data.meta, "filtered": {
        "removed": [r if isinstance(r, str) else float(r) for r in remove],
        "half_width_hz": mask.half_width_hz, "window": window}})

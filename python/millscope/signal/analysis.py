"""Torque analysed the paper's way (Fig. 3, section 6), one block at a time.

:func:`analyze_block` analyses one block: mean torque, the LTH, and the spectral energy after
removing the mean and the LTH; it is what ``python -m millscope analyze`` runs, what a
:class:`~millscope.campaign.Campaign` runs on each case and what
:func:`~millscope.estimate_fill` runs on a new record. :class:`AnalysisSettings` say how a
campaign analyses its cases; :func:`sub_block_energies` gives the scatter of one block's
energy.

The analysis of a whole campaign (groups of cases, Table 6, bootstrap intervals) lives in
:mod:`millscope.calibration.groups`, which builds on campaign results; this module stays in
the signal layer (it imports neither the campaign nor the scenes). The old path
``millscope.analysis`` (this module and the three names of the groups' analysis) is kept by
the top-level ``millscope/analysis.py``.

Units: s, Hz, N m, (N m)^2 s.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, get_args

import numpy as np
from numpy.typing import NDArray

from .. import _checks
from .._frames import Kind, frame
from .record import TorqueRecord
from .spectral import (
    Peak,
    SpectralEnergy,
    WindowName,
    find_peak,
    lifter_harmonic_hz,
    spectral_energy,
)

if TYPE_CHECKING:
    from pandas import DataFrame

__all__ = ["AnalysisSettings", "BlockAnalysis", "analyze_block", "check_bandwidth",
           "sub_block_energies"]

WINDOWS: tuple[WindowName, ...] = get_args(WindowName)  # the windows spectral knows
MIN_SUB_BLOCK_SAMPLES = 32  # a sub-block of fewer samples loses most of its band to the removal
MIN_SUB_BLOCKS = 3  # fewer sub-blocks give no usable spread


@dataclass(frozen=True)
class BlockAnalysis:
    """Result of :func:`analyze_block`.

    Attributes
    ----------
    mean_torque_Nm : float
        Mean torque T_c, N m.
    lth_expected_hz : float
        lifters x rotation frequency, Hz.
    lth : Peak
        The LTH located near the expected frequency (Hz, N m).
    energy : SpectralEnergy
        Energy after removing the mean, the LTH and ``lines_hz`` ((N m)^2 s).
    lines_hz : tuple of float
        Further lines removed (drive train), Hz.
    record_length_s : float
        TR, s.
    """

    mean_torque_Nm: float
    lth_expected_hz: float
    lth: Peak
    energy: SpectralEnergy
    lines_hz: tuple[float, ...] = field(default_factory=tuple)
    record_length_s: float = 0.0

    def to_frame(self) -> DataFrame:
        """The analysis as a pandas DataFrame of one row.

        Columns: ``record_length_s`` (TR, s), ``mean_torque_Nm`` (N m), ``lth_expected_hz``
        and ``lth_hz`` (expected and located, Hz), ``lth_amplitude_Nm`` and ``lth_noise_Nm``
        (N m), ``lth_snr`` (dimensionless), ``energy_Nm2s`` ((N m)^2 s),
        ``energy_relative_std`` and ``fraction_kept`` (dimensionless), ``half_width_hz``
        (of each removed band, Hz): float64; ``lth_distinct`` and ``widened``: bool;
        ``window`` and ``lines_hz`` (the drive-train lines removed, Hz, separated by
        spaces; empty for none): str.
        """
        e = self.energy
        return frame(_COLUMNS, [{
            "record_length_s": self.record_length_s, "mean_torque_Nm": self.mean_torque_Nm,
            "lth_expected_hz": self.lth_expected_hz, "lth_hz": self.lth.frequency_hz,
            "lth_amplitude_Nm": self.lth.amplitude, "lth_noise_Nm": self.lth.noise_amplitude,
            "lth_snr": self.lth.snr, "lth_distinct": self.lth.distinct,
            "energy_Nm2s": e.energy, "energy_relative_std": e.relative_std,
            "fraction_kept": e.fraction_kept, "half_width_hz": e.half_width_hz,
            "widened": e.widened, "window": e.window,
            "lines_hz": " ".join(repr(float(f)) for f in self.lines_hz)}])

    def summary(self) -> str:
        """A short plain-text report."""
        e = self.energy
        widened = " (widened to the window's main lobe)" if e.widened else ""
        lines = ", ".join(f"{f:.3f}" for f in self.lines_hz) + " Hz" if self.lines_hz else "none"
        return "\n".join([
            f"block length TR        {self.record_length_s:.4g} s "
            f"(resolution {1 / self.record_length_s:.4g} Hz)",
            f"mean torque            {self.mean_torque_Nm:.6g} N m",
            f"LTH expected           {self.lth_expected_hz:.4f} Hz",
            f"LTH found              {self.lth.describe()}",
            f"drive-train lines      {lines}",
            f"removed band width     +-{e.half_width_hz:.3g} Hz{widened}",
            f"spectral energy        {e.energy:.6g} (N m)^2 s "
            f"(mean and lines removed, {100 * e.fraction_kept:.1f} % of the band kept)",
        ])


#: The columns of :meth:`BlockAnalysis.to_frame` with how each is stored.
_COLUMNS: dict[str, Kind] = {
    "record_length_s": "float", "mean_torque_Nm": "float", "lth_expected_hz": "float",
    "lth_hz": "float", "lth_amplitude_Nm": "float", "lth_noise_Nm": "float",
    "lth_snr": "float", "lth_distinct": "bool", "energy_Nm2s": "float",
    "energy_relative_std": "float", "fraction_kept": "float", "half_width_hz": "float",
    "widened": "bool", "window": "str", "lines_hz": "str"}


def check_bandwidth(name: str, bandwidth: object, lth_hz: float,
                    error: type[ValueError] = ValueError) -> float:
    """``bandwidth`` (the full width of each removed band, Hz) as a float when it lies in
    (0, ``lth_hz``]: a band around the mean wider than the LTH frequency would take the LTH's
    band, and the energy near it, with it. Else ``error`` naming ``name``."""
    return _checks.number(name, bandwidth, error, low=0.0, low_open=True, high=lth_hz,
                          unit="Hz", why="at most the LTH frequency: a wider band around the "
                                         "mean takes the LTH's band with it")


def analyze_block(block: TorqueRecord, *, lifters: int, rotation_hz: float,
                  lines_hz: Sequence[float] = (), window: WindowName = "hann",
                  bandwidth: float = 0.3, search_hz: float | None = None,
                  resolution_hz: float | None = None,
                  band_hz: tuple[float, float] | None = None) -> BlockAnalysis:
    """Analyse a block: mean torque, the LTH located near lifters x rotation_hz, and the
    spectral energy after removing the mean, the LTH (at its located frequency) and ``lines_hz``.

    Parameters
    ----------
    lifters : int
        Lifter count.
    rotation_hz : float
        Mill rotation frequency, Hz.
    lines_hz : sequence of float
        Drive-train lines to remove as well, Hz; those above Nyquist are ignored.
    bandwidth : float
        Full width of each removed band, Hz, in (0, LTH frequency].
    search_hz : float, optional
        Half-width of the LTH search, Hz (default 3 bins); real mills drift in speed.
    resolution_hz : float, optional
        Refuse a block too short to resolve this (eq. 9).
    band_hz : (float, float), optional
        Count only this band, Hz (default 0 .. Nyquist).
    """
    lth_hz = lifter_harmonic_hz(lifters, rotation_hz)
    check_bandwidth("bandwidth", bandwidth, lth_hz)
    nyquist = block.sample_rate_hz / 2
    if lth_hz > nyquist:
        raise ValueError(f"LTH at {lth_hz:g} Hz (lifters = {lifters} x rotation_hz = "
                         f"{rotation_hz:g}) is above the Nyquist frequency {nyquist:g} Hz")
    lth = find_peak(block, lth_hz, search_hz=search_hz, window=window)
    kept_lines = tuple(f for f in lines_hz if 0 < f <= nyquist and abs(f - lth_hz) > 1e-9)
    energy = spectral_energy(block, ["mean", lth.frequency_hz, *kept_lines], bandwidth=bandwidth,
                             window=window, resolution_hz=resolution_hz, band=band_hz)
    return BlockAnalysis(mean_torque_Nm=block.mean_torque_Nm, lth_expected_hz=lth_hz, lth=lth,
                         energy=energy, lines_hz=kept_lines, record_length_s=block.duration_s)


# -- how a campaign analyses its cases ---------------------------------------------------------
@dataclass(frozen=True)
class AnalysisSettings:
    """How the cases of a campaign are analysed (:class:`~millscope.campaign.Campaign`).

    Attributes
    ----------
    block : (float, float)
        The block ``t1 <= t < t2``, s from the start of rotation, with 0 <= t1 < t2.
    bandwidth : float
        Full width of the bands removed around the mean and the LTH, Hz, > 0.
    window : {"hann", "hann_periodic", "rectangular"}
    """

    block: tuple[float, float]
    bandwidth: float = 0.3
    window: WindowName = "hann"

    def __post_init__(self) -> None:
        try:
            t1, t2 = (float(t) for t in self.block)
        except (TypeError, ValueError):
            raise ValueError(f"AnalysisSettings.block = {self.block!r} is not valid; it must "
                             "be a pair (t1, t2) of times in s") from None
        if not (math.isfinite(t1) and math.isfinite(t2) and 0 <= t1 < t2):
            raise ValueError(f"AnalysisSettings.block = {self.block!r} is not valid; it must "
                             "be (t1, t2) with 0 <= t1 < t2, s")
        if not (isinstance(self.bandwidth, (int, float)) and math.isfinite(self.bandwidth)
                and self.bandwidth > 0):
            raise ValueError(f"AnalysisSettings.bandwidth = {self.bandwidth!r} is not valid; "
                             "it must be > 0 Hz")
        if self.window not in WINDOWS:
            raise ValueError(f"AnalysisSettings.window = {self.window!r} is not valid; it must "
                             f"be one of {', '.join(WINDOWS)}")
        object.__setattr__(self, "block", (t1, t2))
        object.__setattr__(self, "bandwidth", float(self.bandwidth))

    @property
    def block_s(self) -> float:
        """Block length t2 - t1, s."""
        return self.block[1] - self.block[0]

    def to_dict(self) -> dict[str, Any]:
        """Plain JSON data: ``{"block": [t1, t2], "bandwidth": ..., "window": ...}``."""
        return {"block": list(self.block), "bandwidth": self.bandwidth, "window": self.window}

    @classmethod
    def from_dict(cls, data: Any) -> AnalysisSettings:
        """The settings of a :meth:`to_dict` dict (ValueError when damaged)."""
        if not isinstance(data, dict) or set(data) != {"block", "bandwidth", "window"}:
            raise ValueError(f"analysis settings must be an object with keys block, bandwidth, "
                             f"window; got {data!r}")
        return cls(tuple(data["block"]), data["bandwidth"], data["window"])


def sub_block_energies(block: TorqueRecord, *, lth_hz: float | None, sub_blocks: int = 10,
                       bandwidth: float = 0.3, window: WindowName = "hann"
                       ) -> NDArray[np.float64] | None:
    """Spectral energies of equal consecutive sub-blocks of a block, mean and LTH removed.

    Their scatter measures how much the block's energy would scatter from one block of the same
    run to another: the mean of m sub-block energies, times m, has about the spread of the
    whole block's energy (for white noise and a Hann window both are 2/sqrt(N)).

    Parameters
    ----------
    block : TorqueRecord
        The analysed block.
    lth_hz : float or None
        The LTH to remove, Hz (None or nan: only the mean).
    sub_blocks : int
        How many sub-blocks to cut, >= 1; fewer are cut when the block holds less than
        ``MIN_SUB_BLOCK_SAMPLES`` (32) samples per sub-block. Left-over samples at the end are
        not used.
    bandwidth, window
        As :func:`~millscope.spectral_energy` (each sub-block widens the bands to its own,
        wider, main lobe).

    Returns
    -------
    ndarray or None
        One energy per sub-block, (N m)^2 s; None when fewer than ``MIN_SUB_BLOCKS`` (3)
        sub-blocks fit.
    """
    if int(sub_blocks) != sub_blocks or sub_blocks < 1:
        raise ValueError(f"sub_blocks = {sub_blocks!r} is not valid; it must be an integer >= 1")
    n = len(block)
    m = min(int(sub_blocks), n // MIN_SUB_BLOCK_SAMPLES)
    if m < MIN_SUB_BLOCKS:
        return None
    size = n // m
    remove: list[Any] = ["mean"]
    if lth_hz is not None and math.isfinite(lth_hz):
        remove.append(lth_hz)
    t, x = block.time_s, block.torque_Nm
    return np.array([
        spectral_energy(TorqueRecord(t[k * size:(k + 1) * size], x[k * size:(k + 1) * size]),
                        remove, bandwidth=bandwidth, window=window).energy
        for k in range(m)])

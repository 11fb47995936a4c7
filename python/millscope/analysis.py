"""One torque block analysed the paper's way (Fig. 3): mean, LTH, filtered energy.

:func:`analyze_block` is what ``python -m millscope analyze`` runs, usable from scripts too.
:class:`AnalysisSettings` says how a campaign analyses its cases (block, bandwidth, window).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

from .record import TorqueRecord
from .spectral import (
    Peak,
    SpectralEnergy,
    WindowName,
    find_peak,
    lifter_harmonic_hz,
    spectral_energy,
)

__all__ = ["AnalysisSettings", "BlockAnalysis", "analyze_block"]

WINDOWS = ("hann", "hann_periodic", "rectangular")


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

    def summary(self) -> str:
        """A short plain-text report."""
        e = self.energy
        widened = " (widened to the window's main lobe)" if e.widened else ""
        lines = ", ".join(f"{f:.3f}" for f in self.lines_hz) or "none"
        return "\n".join([
            f"block length TR        {self.record_length_s:.4g} s "
            f"(resolution {1 / self.record_length_s:.4g} Hz)",
            f"mean torque            {self.mean_torque_Nm:.6g} N m",
            f"LTH expected           {self.lth_expected_hz:.4f} Hz",
            f"LTH found              {self.lth.frequency_hz:.4f} Hz, amplitude "
            f"{self.lth.amplitude:.4g} N m",
            f"drive-train lines      {lines} Hz",
            f"removed band width     +-{e.half_width_hz:.3g} Hz{widened}",
            f"spectral energy        {e.energy:.6g} (N m)^2 s "
            f"(mean and lines removed, {100 * e.fraction_kept:.1f} % of the band kept)",
        ])


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
    search_hz : float, optional
        Half-width of the LTH search, Hz (default 3 bins); real mills drift in speed.
    resolution_hz : float, optional
        Refuse a block too short to resolve this (eq. 9).
    band_hz : (float, float), optional
        Count only this band, Hz (default 0 .. Nyquist).
    """
    lth_hz = lifter_harmonic_hz(lifters, rotation_hz)
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
    window: str = "hann"

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

"""Calibration and the filling estimate (paper section 6.4).

The paper fits the per-unit spectral energy y against the load level x (1..7, particle filling in
units of 40 %) with y = a ln(x) + b (Table 6; :mod:`millscope.logfit`, re-exported here). A
:class:`Calibration` stores such a fit with the reference energy that made it per-unit and the
analysis settings, so that a new record analysed the same way gives a filling estimate
x = exp((y - b) / a).
"""

from __future__ import annotations

import json
import math
import os
import warnings
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from ._files import atomic_write, read_json
from .logfit import LogFit, log_fit, log_fit_coefficients, per_unit
from .record import TorqueRecord
from .spectral import RemoveItem, lifter_harmonic_hz, spectral_energy

__all__ = ["LogFit", "log_fit", "log_fit_coefficients", "per_unit", "Calibration",
           "FillEstimate", "estimate_fill", "OutsideCalibrationWarning"]

CALIBRATION_FORMAT = "millscope-calibration-1"


class OutsideCalibrationWarning(UserWarning):
    """A filling estimate lies outside the range of levels the calibration was made from."""


@dataclass(frozen=True)
class Calibration:
    """A fit of per-unit energy against load level, with how the energy was obtained.

    Attributes
    ----------
    fit : LogFit
        y = a ln(level) + b, y the energy per unit of ``reference_energy``.
    reference_energy : float
        The energy that makes y per-unit (the largest of the group, the lowest filling),
        (N m)^2 s.
    lifters : int
        Lifter count (the LTH is lifters x rotation frequency).
    rotation_hz : float
        Mill rotation frequency, Hz, the calibration was made at.
    block_s : float
        Length of the analysed block TR, s; energies scale with TR, so records are analysed in
        blocks of this length.
    bandwidth : float
        Full width of each removed band, Hz.
    window : str
    extra_lines_hz : tuple of float
        Further lines removed (drive-train harmonics), Hz.
    label : str
        Free text (material, speed ...).
    """

    fit: LogFit
    reference_energy: float
    lifters: int
    rotation_hz: float
    block_s: float = 10.0
    bandwidth: float = 0.3
    window: str = "hann"
    extra_lines_hz: tuple[float, ...] = ()
    label: str = ""
    meta: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if not (self.reference_energy > 0 and math.isfinite(self.reference_energy)):
            raise ValueError(f"Calibration.reference_energy = {self.reference_energy!r} is not "
                             "valid; it must be finite and > 0 (N m)^2 s")
        if self.block_s <= 0:
            raise ValueError(f"Calibration.block_s = {self.block_s!r} is not valid; "
                             "it must be > 0 s")
        lifter_harmonic_hz(self.lifters, self.rotation_hz)  # validates both

    @property
    def remove(self) -> list[RemoveItem]:
        """What the analysis removes: the mean, the LTH and the extra lines."""
        return ["mean", lifter_harmonic_hz(self.lifters, self.rotation_hz), *self.extra_lines_hz]

    def save(self, path: str | os.PathLike[str]) -> Path:
        """Write the calibration as JSON, atomically."""
        data = {"format": CALIBRATION_FORMAT, **asdict(self)}
        target = Path(path)
        with atomic_write(target, "w") as fh:
            json.dump(data, fh, indent=2)
        return target

    @classmethod
    def load(cls, path: str | os.PathLike[str]) -> Calibration:
        """Read a calibration written by :meth:`save`; a damaged file raises ValueError."""
        source = Path(path)
        data = read_json(source, "calibration")
        if not isinstance(data, dict) or data.pop("format", None) != CALIBRATION_FORMAT:
            raise ValueError(f"{source}: not a millscope calibration (expected format "
                             f"{CALIBRATION_FORMAT!r})")
        try:
            data["fit"] = LogFit(**data["fit"])
            data["extra_lines_hz"] = tuple(data.get("extra_lines_hz", ()))
            return cls(**data)
        except (KeyError, TypeError) as exc:
            raise ValueError(f"{source}: calibration is incomplete or damaged ({exc})") from None


@dataclass(frozen=True)
class FillEstimate:
    """A filling estimate: ``level`` (load level units, Table 5), ``interval`` (low, high) from
    the calibration's prediction interval, ``energy_pu`` the per-unit energy it came from."""

    level: float
    interval: tuple[float, float]
    energy_pu: float
    energy: float


def estimate_fill(record: TorqueRecord, calibration: Calibration, *,
                  confidence: float = 0.95) -> FillEstimate:
    """Estimate the load level of the mill from a torque block, x = exp((y - b)/a).

    The block is analysed as the calibration was made: the same window and bandwidth, the mean,
    the LTH and the extra lines removed. Its length must match ``calibration.block_s`` within
    one sample, since energy grows with the block length. The interval is the fit's prediction
    interval, with the new energy's scatter taken as the larger of the fit's residuals and the
    block's own sampling spread (:attr:`SpectralEnergy.relative_std`). Warns with
    :class:`OutsideCalibrationWarning` outside the calibrated range.
    """
    cal = calibration
    if abs(record.duration_s - cal.block_s) > record.dt * 1.5:
        raise ValueError(f"record is {record.duration_s:g} s long but the calibration was made "
                         f"on blocks of block_s = {cal.block_s:g} s; pass a block of that length")
    e = spectral_energy(record, cal.remove, bandwidth=cal.bandwidth,
                        window=cal.window)  # type: ignore[arg-type]  # a str, checked at run time
    y = e.energy / cal.reference_energy
    level = cal.fit.inverse(y)
    half = cal.fit.prediction_half_width(float(level), confidence,
                                         observation_std=y * e.relative_std)
    if math.isfinite(half):
        bounds = sorted(float(cal.fit.inverse(y + s * half)) for s in (-1, 1))
        interval = (bounds[0], bounds[1])
    else:
        interval = (math.nan, math.nan)
    if not cal.fit.x_min <= level <= cal.fit.x_max:
        warnings.warn(f"estimated level {float(level):.3g} lies outside the calibrated range "
                      f"{cal.fit.x_min:g} .. {cal.fit.x_max:g}", OutsideCalibrationWarning,
                      stacklevel=2)
    return FillEstimate(level=float(level), interval=interval, energy_pu=y, energy=e.energy)

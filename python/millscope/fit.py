"""Log fit of energy against filling, calibration, and the filling estimate (paper section 6.4).

The paper fits the per-unit spectral energy y against the load level x (1..7, particle filling in
units of 40 %) with y = a ln(x) + b (Table 6). A :class:`Calibration` stores such a fit with the
reference energy that made it per-unit and the analysis settings, so that a new record analysed
the same way gives a filling estimate x = exp((y - b) / a).
"""

from __future__ import annotations

import json
import math
import os
import warnings
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import stats

from ._files import atomic_write, read_json
from .record import TorqueRecord
from .spectral import RemoveItem, lifter_harmonic_hz, spectral_energy

__all__ = ["LogFit", "log_fit", "Calibration", "FillEstimate", "estimate_fill",
           "OutsideCalibrationWarning"]

CALIBRATION_FORMAT = "millscope-calibration-1"


class OutsideCalibrationWarning(UserWarning):
    """A filling estimate lies outside the range of levels the calibration was made from."""


@dataclass(frozen=True)
class LogFit:
    """Least-squares fit y = a ln(x) + b.

    Attributes
    ----------
    a, b : float
        Slope against ln(x) and intercept (units of y).
    r2 : float
        Coefficient of determination.
    a_stderr, b_stderr : float
        Standard errors of a and b (nan with only 2 points).
    n : int
        Number of points.
    x_min, x_max : float
        Range of x fitted.
    ln_x_mean, ln_x_sxx, residual_std : float
        Mean of ln(x), sum of squared deviations of ln(x), and the residual standard deviation;
        they give prediction intervals.
    """

    a: float
    b: float
    r2: float
    a_stderr: float
    b_stderr: float
    n: int
    x_min: float
    x_max: float
    ln_x_mean: float
    ln_x_sxx: float
    residual_std: float

    def __call__(self, x: ArrayLike) -> NDArray[np.float64]:
        """y = a ln(x) + b."""
        return self.a * np.log(np.asarray(x, dtype=np.float64)) + self.b

    def inverse(self, y: ArrayLike) -> NDArray[np.float64] | float:
        """x = exp((y - b) / a)."""
        if self.a == 0:
            raise ValueError("the fit has slope a = 0; y does not determine x")
        result = np.exp((np.asarray(y, dtype=np.float64) - self.b) / self.a)
        return float(result) if np.ndim(result) == 0 else result

    def prediction_half_width(self, x: float, confidence: float = 0.95,
                              observation_std: float = 0.0) -> float:
        """Half-width of the prediction interval of a new y at x (units of y).

        The new observation's own scatter is the larger of the fit's residual standard
        deviation and ``observation_std`` (what the new y is known to scatter by, e.g. the
        sampling spread of its energy): a fit through few points can underestimate it.
        """
        if self.n < 3 or not np.isfinite(self.residual_std):
            return math.nan
        t = stats.t.ppf(0.5 + confidence / 2, self.n - 2)
        u = math.log(x)
        mean_var = self.residual_std**2 * (1 / self.n + (u - self.ln_x_mean) ** 2 / self.ln_x_sxx)
        new_var = max(self.residual_std, observation_std) ** 2
        return float(t * math.sqrt(mean_var + new_var))

    def equation(self) -> str:
        """The fit as the paper writes it, e.g. ``y = -0.423 ln(x) + 0.9279``."""
        sign = "+" if self.b >= 0 else "-"
        return f"y = {self.a:.4g} ln(x) {sign} {abs(self.b):.4g}"


def log_fit(x: ArrayLike, y: ArrayLike) -> LogFit:
    """Fit y = a ln(x) + b by least squares (paper Table 6).

    Parameters
    ----------
    x : array_like
        Positive abscissae (load levels).
    y : array_like
        Values (per-unit energies).

    Raises
    ------
    ValueError
        for fewer than 2 points, non-positive or non-finite x, non-finite y, mismatched lengths
        or all x equal.
    """
    xs = np.asarray(x, dtype=np.float64)
    ys = np.asarray(y, dtype=np.float64)
    if xs.ndim != 1 or xs.shape != ys.shape:
        raise ValueError(f"x and y must be 1-D of equal length; got shapes {xs.shape}, {ys.shape}")
    if xs.size < 2:
        raise ValueError(f"log_fit needs at least 2 points; got {xs.size}")
    if not (np.all(np.isfinite(xs)) and np.all(xs > 0)):
        raise ValueError(f"x must be finite and > 0 for ln(x); got {xs.tolist()}")
    if not np.all(np.isfinite(ys)):
        raise ValueError(f"y must be finite; got {ys.tolist()}")
    u = np.log(xs)
    sxx = float(np.sum((u - u.mean()) ** 2))
    if sxx == 0:
        raise ValueError("all x are equal; a slope cannot be fitted")
    a, b = np.polyfit(u, ys, 1)
    residuals = ys - (a * u + b)
    ss_res = float(np.sum(residuals**2))
    ss_tot = float(np.sum((ys - ys.mean()) ** 2))
    r2 = 1.0 - ss_res / ss_tot if ss_tot > 0 else 1.0
    n = xs.size
    if n > 2:
        s = math.sqrt(ss_res / (n - 2))
        a_se = s / math.sqrt(sxx)
        b_se = s * math.sqrt(1 / n + u.mean() ** 2 / sxx)
    else:
        s = a_se = b_se = math.nan
    return LogFit(a=float(a), b=float(b), r2=r2, a_stderr=a_se, b_stderr=b_se, n=n,
                  x_min=float(xs.min()), x_max=float(xs.max()), ln_x_mean=float(u.mean()),
                  ln_x_sxx=sxx, residual_std=s)


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


def per_unit(energies: ArrayLike) -> NDArray[np.float64]:
    """Energies divided by the largest of the group (DESIGN.md section 4)."""
    e = np.asarray(energies, dtype=np.float64)
    if e.size == 0 or not np.all(np.isfinite(e)) or e.max() <= 0:
        raise ValueError(f"energies must be finite with a positive maximum; got {e.tolist()}")
    return e / e.max()

"""Calibration and the filling estimate (paper section 6.4).

The paper fits the per-unit spectral energy y against the load level x (1..7, particle filling in
units of 40 %) with y = a ln(x) + b (Table 6; :mod:`millscope.logfit`, re-exported here). A
:class:`Calibration` stores such a fit with the reference energy that made it per-unit and the
analysis settings, so that a new record analysed the same way gives a filling estimate
x = exp((y - b) / a) (:func:`estimate_fill`). :meth:`Calibration.from_results` makes one from a
campaign's results (:func:`millscope.campaign_analysis.analyze_campaign`, imported when
called: this module stays below the campaign in the layering, DESIGN.md section 1).

A fit through 2 load levels is exact (R^2 = 1 trivially) and leaves no residual to estimate
the scatter from, so its estimates can have no interval. Such calibrations are allowed (the
point estimate is still defined) but never silently: :meth:`Calibration.from_results` and
:meth:`Calibration.from_group` warn with :class:`NoIntervalWarning`, and so does
:func:`estimate_fill` whenever it returns a nan interval. Calibrate with at least
``MIN_LEVELS_FOR_INTERVALS`` (3) levels.

Calibration files are JSON, format ``millscope-calibration-2``; files of format 1 (without
``band_hz`` and ``block_relative_std``) are read too.
"""

from __future__ import annotations

import json
import math
import os
import warnings
from collections.abc import Iterable, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ._files import atomic_write, read_json
from .analysis import analyze_block
from .logfit import LogFit, log_fit, log_fit_coefficients, per_unit
from .record import TorqueRecord
from .spectral import RemoveItem, lifter_harmonic_hz

if TYPE_CHECKING:
    from .campaign import CaseResult
    from .campaign_analysis import GroupAnalysis

__all__ = ["LogFit", "log_fit", "log_fit_coefficients", "per_unit", "Calibration",
           "FillEstimate", "estimate_fill", "OutsideCalibrationWarning", "NoIntervalWarning",
           "MIN_LEVELS_FOR_INTERVALS"]

CALIBRATION_FORMAT = "millscope-calibration-2"
READABLE_FORMATS = ("millscope-calibration-1", CALIBRATION_FORMAT)
#: A fit through fewer load levels is exact and gives its estimates no interval.
MIN_LEVELS_FOR_INTERVALS = 3


class OutsideCalibrationWarning(UserWarning):
    """A filling estimate lies outside the range of levels the calibration was made from."""


class NoIntervalWarning(UserWarning):
    """A calibration cannot give its filling estimates an interval: its fit goes through fewer
    than 3 load levels (exact, R^2 = 1 trivially, no residual scatter)."""


def no_interval_reason(fit: LogFit) -> str:
    """Why a fit gives estimates no interval (for warnings and reports)."""
    return (f"its log fit goes through {fit.n} load levels ({fit.x_min:g} and {fit.x_max:g}) "
            f"exactly (R^2 = 1 trivially) and leaves no residual scatter; a calibration needs "
            f"at least {MIN_LEVELS_FOR_INTERVALS} levels for a prediction interval")


def _plain(value: float) -> float | None:
    """A float for JSON: None for nan."""
    return float(value) if math.isfinite(value) else None


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
    meta : dict
        JSON-able facts (:meth:`from_results` puts the group, its levels, per-unit energies,
        bootstrap intervals and case hashes here).
    band_hz : float or None
        Upper edge of the band the energy counts, Hz (0 .. band_hz); None: up to the Nyquist
        frequency of the record. A campaign's calibration counts up to the Nyquist frequency of
        its records (50 Hz at 10 ms samples), so records sampled faster are compared over the
        same band.
    block_relative_std : float or None
        How much one block's energy scattered in the calibration data (standard deviation over
        mean, between seeds or sub-blocks); :func:`estimate_fill` takes a new block's energy
        to scatter at least this much. None: unknown.
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
    band_hz: float | None = None
    block_relative_std: float | None = None

    def __post_init__(self) -> None:
        if not (self.reference_energy > 0 and math.isfinite(self.reference_energy)):
            raise ValueError(f"Calibration.reference_energy = {self.reference_energy!r} is not "
                             "valid; it must be finite and > 0 (N m)^2 s")
        if self.block_s <= 0:
            raise ValueError(f"Calibration.block_s = {self.block_s!r} is not valid; "
                             "it must be > 0 s")
        if self.band_hz is not None and not (math.isfinite(self.band_hz) and self.band_hz > 0):
            raise ValueError(f"Calibration.band_hz = {self.band_hz!r} is not valid; it must be "
                             "> 0 Hz or None")
        if self.block_relative_std is not None and not (
                math.isfinite(self.block_relative_std) and self.block_relative_std >= 0):
            raise ValueError(f"Calibration.block_relative_std = {self.block_relative_std!r} is "
                             "not valid; it must be finite and >= 0, or None")
        lifter_harmonic_hz(self.lifters, self.rotation_hz)  # validates both

    @classmethod
    def from_results(cls, results: Iterable[CaseResult], *, group: str | None = None,
                     bootstrap: int = 1000, confidence: float = 0.95, seed: int = 0,
                     sub_blocks: int = 10) -> Calibration:
        """The calibration of one group (particles x speed) of a campaign's results.

        Parameters
        ----------
        results : iterable of CaseResult
            E.g. ``Campaign.run()``; analysed by
            :func:`~millscope.campaign_analysis.analyze_campaign`.
        group : str, optional
            The group's name, e.g. ``"LDMS"``; needed when the results hold several groups.
        bootstrap, confidence, seed, sub_blocks
            As :func:`~millscope.campaign_analysis.analyze_campaign` (the intervals go into
            ``meta``).

        Warns
        -----
        NoIntervalWarning
            when the group has 2 load levels: the calibration is made, but its estimates get
            no interval (see :meth:`from_group`).

        Raises
        ------
        ValueError
            when the results hold several groups and none is chosen, or the chosen one is not
            there (the message names the groups); when the group has a single load level.
        """
        from .campaign_analysis import analyze_campaign  # above fit in the layering

        groups = analyze_campaign(results, bootstrap=bootstrap, confidence=confidence,
                                  seed=seed, sub_blocks=sub_blocks)
        names = [g.name for g in groups]
        if group is None:
            if len(groups) > 1:
                raise ValueError(f"the results hold {len(groups)} groups ({', '.join(names)}); "
                                 "choose one with group=...")
            return cls._from_group(groups[0], stacklevel=3)
        for g in groups:
            if g.name == group:
                return cls._from_group(g, stacklevel=3)
        raise ValueError(f"group = {group!r} is not among the groups of the results: "
                         f"{', '.join(names)}")

    @classmethod
    def from_group(cls, group: GroupAnalysis) -> Calibration:
        """The calibration of an analysed group: its fit, its largest level energy as the
        reference, its analysis settings, the band up to the Nyquist frequency of its records,
        and the scatter of one block's energy it showed.

        A group with 2 load levels gives a calibration whose fit is exact (R^2 = 1 trivially):
        its point estimates are defined, but with no residual scatter to go by it gives them no
        interval. It is made (refusing would leave a 2-level campaign with nothing), with a
        :class:`NoIntervalWarning`; :attr:`gives_intervals` is False.

        Warns
        -----
        NoIntervalWarning
            when the group has fewer than ``MIN_LEVELS_FOR_INTERVALS`` (3) load levels.

        Raises
        ------
        ValueError
            when the group has a single load level (no fit).
        """
        return cls._from_group(group, stacklevel=3)

    @classmethod
    def _from_group(cls, group: GroupAnalysis, *, stacklevel: int) -> Calibration:
        g = group
        if g.fit is None:
            raise ValueError(f"group {g.name} has a single load level ({g.levels[0]:g}); a "
                             "calibration needs at least 2")
        nyquist = {0.5 * r.record.sample_rate_hz for r in g.results if r.record is not None}
        band = min(nyquist) if nyquist else None
        meta = {
            "source": "campaign", "group": g.name, "particles": g.particles,
            "speed_fraction": g.speed_fraction, "block": list(g.settings.block),
            "levels": g.levels.tolist(), "repeats": g.repeats.tolist(),
            "energy": g.energy.tolist(), "energy_pu": g.energy_pu.tolist(),
            "a_interval": [_plain(v) for v in g.a_interval],
            "b_interval": [_plain(v) for v in g.b_interval],
            "confidence": g.confidence, "bootstrap": g.bootstrap,
            "interval_source": list(g.interval_source),
            "cases": [r.hash for r in g.results],
        }
        calibration = cls(fit=g.fit, reference_energy=float(g.energy.max()), lifters=g.lifters,
                          rotation_hz=g.rotation_hz, block_s=g.settings.block_s,
                          bandwidth=g.settings.bandwidth, window=g.settings.window,
                          label=g.name, meta=meta, band_hz=band,
                          block_relative_std=g.block_relative_std())
        if not calibration.gives_intervals:
            warnings.warn(f"calibration of group {g.name}: {no_interval_reason(g.fit)}; its "
                          "estimates will have no interval (nan)", NoIntervalWarning,
                          stacklevel=stacklevel)
        return calibration

    @property
    def gives_intervals(self) -> bool:
        """True when :func:`estimate_fill` can give an interval: the fit goes through at least
        ``MIN_LEVELS_FOR_INTERVALS`` (3) load levels."""
        return self.fit.n >= MIN_LEVELS_FOR_INTERVALS and math.isfinite(self.fit.residual_std)

    @property
    def remove(self) -> list[RemoveItem]:
        """What the analysis removes: the mean, the LTH and the extra lines."""
        return ["mean", lifter_harmonic_hz(self.lifters, self.rotation_hz), *self.extra_lines_hz]

    def save(self, path: str | os.PathLike[str]) -> Path:
        """Write the calibration as JSON, atomically.

        The fit's undefined values (the standard errors of a fit through 2 points) are written
        as ``null``, not as the ``NaN`` that standard JSON does not have; :meth:`load` reads
        them back as nan.
        """
        data = {"format": CALIBRATION_FORMAT, **asdict(self)}
        data["fit"] = {k: _plain(v) if isinstance(v, float) else v
                       for k, v in data["fit"].items()}
        target = Path(path)
        with atomic_write(target, "w") as fh:
            json.dump(data, fh, indent=2)
        return target

    @classmethod
    def load(cls, path: str | os.PathLike[str]) -> Calibration:
        """Read a calibration written by :meth:`save` (format 2, or format 1); a damaged file
        raises ValueError."""
        source = Path(path)
        data = read_json(source, "calibration")
        if not isinstance(data, dict) or data.pop("format", None) not in READABLE_FORMATS:
            raise ValueError(f"{source}: not a millscope calibration (expected format "
                             f"{' or '.join(repr(f) for f in READABLE_FORMATS)})")
        try:
            data["fit"] = LogFit(**{k: math.nan if v is None else v
                                    for k, v in data["fit"].items()})
            data["extra_lines_hz"] = tuple(data.get("extra_lines_hz", ()))
            return cls(**data)
        except (AttributeError, KeyError, TypeError) as exc:
            raise ValueError(f"{source}: calibration is incomplete or damaged ({exc})") from None


def _named(cal: Calibration) -> str:
    return f" {cal.label}" if cal.label else ""


@dataclass(frozen=True)
class FillEstimate:
    """A filling estimate.

    Attributes
    ----------
    level : float
        Estimated load level (Table 5 units).
    interval : (float, float)
        (low, high) from the calibration's prediction interval; (nan, nan), with a
        :class:`NoIntervalWarning`, when the fit has fewer than 3 points.
    energy_pu : float
        The per-unit energy it came from.
    energy : float
        The block's spectral energy, (N m)^2 s.
    outside : bool
        True when ``level`` lies outside the calibrated range (a warning was issued).
    """

    level: float
    interval: tuple[float, float]
    energy_pu: float
    energy: float
    outside: bool = False


def estimate_fill(record: TorqueRecord, calibration: Calibration, *,
                  confidence: float = 0.95, lines_hz: Sequence[float] = ()) -> FillEstimate:
    """Estimate the load level of the mill from a torque block, x = exp((y - b)/a).

    The block is analysed as the calibration was made
    (:func:`~millscope.analysis.analyze_block`): the same window and bandwidth, the mean, the
    LTH (located near lifters x rotation frequency, as a campaign locates it), the extra lines
    and ``lines_hz`` removed, the energy counted over 0 .. ``band_hz``. Its length must match
    ``calibration.block_s`` within one sample, since energy grows with the block length. The
    interval is the fit's prediction interval, with the new energy's scatter taken as the
    largest of the fit's residuals, the block's own sampling spread
    (:attr:`SpectralEnergy.relative_std`) and the calibration's ``block_relative_std``. Warns
    with :class:`OutsideCalibrationWarning` outside the calibrated range, and with
    :class:`NoIntervalWarning` when the calibration cannot give an interval (a fit through 2
    levels): the interval is then (nan, nan).

    Parameters
    ----------
    record : TorqueRecord
        A block of ``calibration.block_s`` s.
    calibration : Calibration
    confidence : float
        Of the interval, in (0, 1).
    lines_hz : sequence of float
        Further lines to remove, Hz (e.g. a drive train's, :mod:`millscope.drivetrain`).
    """
    cal = calibration
    if not 0 < confidence < 1:
        raise ValueError(f"confidence = {confidence!r} is not valid; it must be in (0, 1)")
    if abs(record.duration_s - cal.block_s) > record.dt * 1.5:
        raise ValueError(f"record is {record.duration_s:g} s long but the calibration was made "
                         f"on blocks of block_s = {cal.block_s:g} s; pass a block of that length")
    nyquist = 0.5 * record.sample_rate_hz
    if cal.band_hz is not None and cal.band_hz > nyquist * (1 + 1e-9):
        raise ValueError(f"the calibration counts energy up to band_hz = {cal.band_hz:g} Hz but "
                         f"the record, sampled at {record.sample_rate_hz:g} Hz, stops at "
                         f"{nyquist:g} Hz; it needs at least {2 * cal.band_hz:g} Hz")
    analysis = analyze_block(record, lifters=cal.lifters, rotation_hz=cal.rotation_hz,
                             lines_hz=[*cal.extra_lines_hz, *lines_hz],
                             window=cal.window,  # type: ignore[arg-type]  # checked at run time
                             bandwidth=cal.bandwidth,
                             band_hz=None if cal.band_hz is None else (0.0, cal.band_hz))
    e = analysis.energy
    y = e.energy / cal.reference_energy
    level = float(cal.fit.inverse(y))
    scatter = max(e.relative_std, cal.block_relative_std or 0.0)
    half = cal.fit.prediction_half_width(level, confidence, observation_std=y * scatter)
    if math.isfinite(half):
        bounds = sorted(float(cal.fit.inverse(y + s * half)) for s in (-1, 1))
        interval = (bounds[0], bounds[1])
    else:
        interval = (math.nan, math.nan)
        warnings.warn(f"no interval for the estimate: the calibration{_named(cal)} cannot give "
                      f"one: {no_interval_reason(cal.fit)}", NoIntervalWarning, stacklevel=2)
    outside = not cal.fit.x_min <= level <= cal.fit.x_max
    if outside:
        warnings.warn(f"estimated level {level:.3g} lies outside the calibrated range "
                      f"{cal.fit.x_min:g} .. {cal.fit.x_max:g}", OutsideCalibrationWarning,
                      stacklevel=2)
    return FillEstimate(level=level, interval=interval, energy_pu=y, energy=e.energy,
                        outside=outside)

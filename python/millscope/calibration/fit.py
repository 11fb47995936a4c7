"""Calibration and the filling estimate (paper section 6.4).

The paper fits the per-unit spectral energy y against the load level x (1..7, particle filling in
units of 40 %) with y = a ln(x) + b (Table 6; :mod:`millscope.logfit`, re-exported here). A
:class:`Calibration` stores such a fit with the reference energy that made it per-unit and the
analysis settings, so that a new record analysed the same way gives a filling estimate
x = exp((y - b) / a) (:func:`estimate_fill`). :meth:`Calibration.from_results` makes one from a
campaign's results (:func:`millscope.campaign_analysis.analyze_campaign`, imported when
called: this module stays below the campaign in the layering, docs/architecture.md, Layers).

A fit through 2 load levels is exact (R^2 = 1 trivially) and leaves no residual to estimate
the scatter from, so its estimates can have no interval. Such calibrations are allowed (the
point estimate is still defined) but never silently: :meth:`Calibration.from_results` and
:meth:`Calibration.from_group` warn with :class:`NoIntervalWarning`, and so does
:func:`estimate_fill` whenever it returns a nan interval. Calibrate with at least
``MIN_LEVELS_FOR_INTERVALS`` (3) levels.

Calibration files are JSON, format ``millscope-calibration-2``; files of format 1 (without
``band_hz`` and ``block_relative_std``) are read too. A file is untrusted input: every field is
checked against its type and range on load (:meth:`Calibration.load`, the same checks as
construction), and any problem raises :class:`CalibrationError` naming the field, its value and
the valid range.
"""

from __future__ import annotations

import dataclasses
import json
import math
import os
import sys
import warnings
from collections.abc import Iterable, Sequence
from dataclasses import MISSING, asdict, dataclass, field, fields
from pathlib import Path
from typing import TYPE_CHECKING, Any

from .. import _checks
from .._files import MAX_JSON_BYTES, atomic_write, read_json
from ..signal.analysis import WINDOWS, analyze_block, check_bandwidth
from ..signal.record import TorqueRecord
from ..signal.spectral import MAX_LIFTERS, RemoveItem, WindowName, lifter_harmonic_hz
from .groups import GroupAnalysis, analyze_campaign
from .logfit import LogFit, log_fit, log_fit_coefficients, per_unit

if TYPE_CHECKING:  # for annotations only: the campaign sits above this layer
    from ..campaign.cases import CaseResult

__all__ = ["LogFit", "log_fit", "log_fit_coefficients", "per_unit", "Calibration",
           "CalibrationError", "FillEstimate", "estimate_fill", "OutsideCalibrationWarning",
           "NoIntervalWarning", "MIN_LEVELS_FOR_INTERVALS"]

CALIBRATION_FORMAT = "millscope-calibration-2"
READABLE_FORMATS = ("millscope-calibration-1", CALIBRATION_FORMAT)
#: A fit through fewer load levels is exact and gives its estimates no interval.
MIN_LEVELS_FOR_INTERVALS = 3
#: The most points a calibration's fit may have (one per analysed case).
MAX_FIT_POINTS = 10**6
#: The most a block's energy may scatter, as standard deviation over mean.
MAX_BLOCK_RELATIVE_STD = 10.0
_FIT_KEYS = tuple(f.name for f in fields(LogFit))
#: Standard errors that a fit through 2 points does not have (written as null).
_UNDEFINED_FOR_TWO_POINTS = ("a_stderr", "b_stderr", "residual_std")


class CalibrationError(ValueError):
    """A calibration, or a calibration file, that cannot be used; the message names the field
    (and the file), its value and the valid range."""


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
        Length of the analysed block TR, s (required: energies scale with TR, so records are
        analysed in blocks of this length; pass the length of the blocks the fit was made
        from, e.g. ``blk.duration_s``).
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
    block_s: float
    bandwidth: float = 0.3
    window: WindowName = "hann"
    extra_lines_hz: tuple[float, ...] = ()
    label: str = ""
    meta: dict[str, Any] = field(default_factory=dict)
    band_hz: float | None = None
    block_relative_std: float | None = None

    def __post_init__(self) -> None:
        """Check every field (types and ranges); raise :class:`CalibrationError` naming the
        first bad one, its value and the valid range."""
        err = CalibrationError
        if not isinstance(self.fit, LogFit):
            raise err(f"Calibration.fit = {_checks.show(self.fit)} is not valid; it must be a "
                      "LogFit")
        object.__setattr__(self, "fit", _check_fit(self.fit))
        _checks.number("Calibration.reference_energy", self.reference_energy, err, low=0.0,
                       low_open=True, unit="(N m)^2 s")
        lifters = _checks.integer("Calibration.lifters", self.lifters, err, low=1,
                                  high=MAX_LIFTERS)
        rotation = _checks.number("Calibration.rotation_hz", self.rotation_hz, err, low=0.0,
                                  low_open=True, unit="Hz")
        lth = lifters * rotation
        if not math.isfinite(lth):
            raise err(f"Calibration.rotation_hz = {rotation!r} Hz is not valid; lifters x "
                      f"rotation_hz (the LTH) must be finite, so it must be <= "
                      f"{sys.float_info.max / lifters:.4g} Hz with {lifters} lifters")
        values: dict[str, Any] = {
            "lifters": lifters, "rotation_hz": rotation,
            "reference_energy": float(self.reference_energy),
            "block_s": _checks.number("Calibration.block_s", self.block_s, err, low=0.0,
                                      low_open=True, unit="s"),
            "bandwidth": check_bandwidth("Calibration.bandwidth", self.bandwidth, lth, err),
        }
        if not isinstance(self.window, str) or self.window not in WINDOWS:
            raise err(f"Calibration.window = {_checks.show(self.window)} is not valid; it must "
                      f"be one of {', '.join(WINDOWS)}")
        lines = self.extra_lines_hz
        if isinstance(lines, (str, bytes, dict)) or not isinstance(lines, Iterable):
            raise err(f"Calibration.extra_lines_hz = {_checks.show(lines)} is not valid; it "
                      "must be a sequence of frequencies in Hz")
        values["extra_lines_hz"] = tuple(
            _checks.number(f"Calibration.extra_lines_hz[{i}]", f, err, low=0.0, low_open=True,
                           unit="Hz") for i, f in enumerate(lines))
        if not isinstance(self.label, str):
            raise err(f"Calibration.label = {_checks.show(self.label)} is not valid; it must "
                      "be a string")
        if not isinstance(self.meta, dict):
            raise err(f"Calibration.meta = {_checks.show(self.meta)} is not valid; it must be "
                      "a dict (a JSON object)")
        if self.band_hz is not None:
            values["band_hz"] = _checks.number("Calibration.band_hz", self.band_hz, err,
                                               low=0.0, low_open=True, unit="Hz")
        if self.block_relative_std is not None:
            values["block_relative_std"] = _checks.number(
                "Calibration.block_relative_std", self.block_relative_std, err, low=0.0,
                high=MAX_BLOCK_RELATIVE_STD, why="standard deviation over mean of one block's "
                "energy; None when unknown")
        for name, value in values.items():
            object.__setattr__(self, name, value)

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
        fit = g.log_fit  # ValueError for a group with a single load level
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
        calibration = cls(fit=fit, reference_energy=float(g.energy.max()), lifters=g.lifters,
                          rotation_hz=g.rotation_hz, block_s=g.settings.block_s,
                          bandwidth=g.settings.bandwidth, window=g.settings.window,
                          label=g.name, meta=meta, band_hz=band,
                          block_relative_std=g.block_relative_std())
        if not calibration.gives_intervals:
            warnings.warn(f"calibration of group {g.name}: {no_interval_reason(fit)}; its "
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
        """Read a calibration written by :meth:`save` (format 2, or format 1).

        The whole file is checked: its size (at most ``MAX_JSON_BYTES``), the JSON, the keys
        (unknown ones are errors) and every field's type and range, as construction checks
        them.

        Raises
        ------
        CalibrationError
            For any problem of the file, naming the file, the field, its value and the valid
            range.
        """
        source = Path(path)
        err = CalibrationError
        data = read_json(source, "calibration", err, max_bytes=MAX_JSON_BYTES)
        if not isinstance(data, dict) or data.get("format") not in READABLE_FORMATS:
            raise err(f"{source}: not a millscope calibration (expected format "
                      f"{' or '.join(repr(f) for f in READABLE_FORMATS)})")
        allowed = tuple(f.name for f in fields(cls))
        required = tuple(f.name for f in fields(cls)
                         if f.default is MISSING and f.default_factory is MISSING)
        try:
            body = dict(_checks.keys(f"{source}: calibration", data, err,
                                     ("format", *allowed), ("format", *required)))
            del body["format"]
            fit = _checks.keys(f"{source}: calibration fit", body["fit"], err, _FIT_KEYS,
                               _FIT_KEYS)
            values: dict[str, Any] = {k: math.nan if v is None and k in _UNDEFINED_FOR_TWO_POINTS
                                      else v for k, v in fit.items()}
            body["fit"] = LogFit(**values)
            if isinstance(body.get("extra_lines_hz"), list):
                body["extra_lines_hz"] = tuple(body["extra_lines_hz"])
            return cls(**body)
        except CalibrationError as exc:
            message = str(exc)
            raise err(message if message.startswith(str(source)) else f"{source}: {message}"
                      ) from None


def _check_fit(fit: LogFit) -> LogFit:
    """``fit`` with its numbers as float (n as int); :class:`CalibrationError` unless it is a
    least-squares fit y = a ln(x) + b of per-unit energies (y <= 1) that
    :func:`~millscope.logfit.log_fit` could have made: its fields finite and in range, and
    consistent with each other."""
    err = CalibrationError
    n = _checks.integer("Calibration.fit.n", fit.n, err, low=2, high=MAX_FIT_POINTS)
    x_min = _checks.number("Calibration.fit.x_min", fit.x_min, err, low=0.0, low_open=True)
    x_max = _checks.number("Calibration.fit.x_max", fit.x_max, err, low=x_min, low_open=True,
                           why="above x_min; a slope needs two different levels")
    lo, hi = math.log(x_min), math.log(x_max)
    _checks.number("Calibration.fit.ln_x_mean", fit.ln_x_mean, err, low=lo, high=hi,
                   why="the mean of ln(x) lies between ln(x_min) and ln(x_max)")
    span = hi - lo
    # n values of ln(x) that include ln(x_min) and ln(x_max): their sum of squared deviations
    # is at least span^2 / 2 (the others at the mean) and at most n span^2 / 4
    slack = 1e-9
    _checks.number("Calibration.fit.ln_x_sxx", fit.ln_x_sxx, err,
                   low=0.5 * span**2 * (1 - slack), high=0.25 * n * span**2 * (1 + slack),
                   why=f"the sum of squared deviations of {n} values of ln(x) spanning "
                       "ln(x_min) .. ln(x_max)")
    a = _checks.number("Calibration.fit.a", fit.a, err)
    if a == 0:
        raise err("Calibration.fit.a = 0.0 is not valid; it must be a finite number other "
                  "than 0 (with no slope the energy does not determine the level)")
    b = _checks.number("Calibration.fit.b", fit.b, err)
    # y <= 1 (per unit of the largest energy): a least-squares fitted value is a projection
    # of the n values, so |a ln(x) + b| <= sqrt(n) at the fitted levels x_min and x_max
    bound = math.sqrt(n)
    for name, ln_x in (("x_min", lo), ("x_max", hi)):
        y = a * ln_x + b
        if not abs(y) <= bound:
            raise err(f"Calibration.fit.a = {a!r}, b = {b!r} are not valid; the fitted "
                      f"per-unit energy at {name} = {math.exp(ln_x):g}, a ln(x) + b = {y:.4g}, "
                      f"must lie in [-{bound:.4g}, {bound:.4g}] (sqrt(n): the fit of {n} "
                      "per-unit energies, each <= 1)")
    _checks.number("Calibration.fit.r2", fit.r2, err, low=0.0, high=1.0)
    plain = dataclasses.replace(
        fit, n=n, a=a, b=b, r2=float(fit.r2), x_min=x_min, x_max=x_max,
        ln_x_mean=float(fit.ln_x_mean), ln_x_sxx=float(fit.ln_x_sxx))
    if n < MIN_LEVELS_FOR_INTERVALS:
        stderrs: dict[str, float] = {}
        for name in _UNDEFINED_FOR_TWO_POINTS:
            value = getattr(fit, name)
            if not (isinstance(value, float) and math.isnan(value)):
                value = _checks.number(f"Calibration.fit.{name}", value, err, low=0.0,
                                       why="or null: a fit through 2 points has none")
            stderrs[name] = value
        return dataclasses.replace(plain, a_stderr=stderrs["a_stderr"],
                                   b_stderr=stderrs["b_stderr"],
                                   residual_std=stderrs["residual_std"])
    s = _checks.number("Calibration.fit.residual_std", fit.residual_std, err, low=0.0,
                       high=math.sqrt(n / (n - 2)),
                       why=f"the residuals of {n} per-unit energies, each <= 1")
    # the standard errors follow from the other fields (as log_fit computes them)
    stderrs = {}
    for name, expected in (("a_stderr", s / math.sqrt(plain.ln_x_sxx)),
                           ("b_stderr", s * math.sqrt(1 / n + plain.ln_x_mean**2
                                                      / plain.ln_x_sxx))):
        value = _checks.number(f"Calibration.fit.{name}", getattr(fit, name), err, low=0.0)
        if not math.isclose(value, expected, rel_tol=1e-9, abs_tol=1e-300):
            raise err(f"Calibration.fit.{name} = {value!r} is not valid; it must be "
                      f"{expected!r}, as residual_std, n, ln_x_mean and ln_x_sxx give it")
        stderrs[name] = value
    return dataclasses.replace(plain, a_stderr=stderrs["a_stderr"], b_stderr=stderrs["b_stderr"],
                               residual_std=s)


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
                             window=cal.window,
                             bandwidth=cal.bandwidth,
                             band_hz=None if cal.band_hz is None else (0.0, cal.band_hz))
    e = analysis.energy
    y = e.energy / cal.reference_energy
    level = float(cal.fit.inverse(y))
    if not math.isfinite(level):
        raise ValueError(f"the block's per-unit energy y = {y:.4g} gives no finite level from "
                         f"the calibration's fit {cal.fit.equation()}: exp((y - b) / a) "
                         "overflows; the block is not like the calibration's records")
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

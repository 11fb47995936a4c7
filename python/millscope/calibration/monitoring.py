"""Filling-level monitoring: a calibration slid over a long torque record (paper section 6.5).

:func:`monitor` cuts a long record into windows of the calibration's block length and estimates
the load level of each (:func:`~millscope.estimate_fill`). Measured torque goes through the
drive-train handling first: a record sampled faster than the calibration's band is decimated to
it with an anti-aliasing filter (:func:`~millscope.drivetrain.decimate_record`), and the lines
of a described drive (mill turn, shafts, gear meshes, motor; :mod:`millscope.drivetrain`) are
removed besides the mean and the LTH. ``python -m millscope monitor`` prints the result, one
line per window.

A calibration of format 1 does not say up to which frequency its energies were counted
(``band_hz`` None): a fast record could then be neither decimated nor band-limited, and its
energy would count content the calibration's records never had. Give the band
(``band_hz=``, ``--band-hz``); without it the monitor warns (:class:`MissingBandWarning`) and
counts up to the record's Nyquist frequency.

A calibration fitted through 2 load levels gives no interval
(:class:`~millscope.fit.NoIntervalWarning`): the windows' intervals are (nan, nan), warned
about once per record, not once per window.
"""

from __future__ import annotations

import dataclasses
import math
import warnings
from dataclasses import dataclass
from typing import TYPE_CHECKING

from .._frames import Kind, frame
from ..signal.drivetrain import DriveTrain, decimate_record
from ..signal.record import TorqueRecord
from .fit import (
    Calibration,
    NoIntervalWarning,
    OutsideCalibrationWarning,
    estimate_fill,
    no_interval_reason,
)

if TYPE_CHECKING:
    from pandas import DataFrame

__all__ = ["MissingBandWarning", "MonitorResult", "WindowEstimate", "monitor", "monitor_record"]


class MissingBandWarning(UserWarning):
    """The calibration does not give its band (format 1) and none was passed: the record is
    counted up to its own Nyquist frequency, without decimation."""


@dataclass(frozen=True)
class WindowEstimate:
    """The filling estimate of one window.

    Attributes
    ----------
    start_s, end_s : float
        The window ``start_s <= t < end_s``, s (record time).
    level : float
        Estimated load level (Table 5 units).
    interval : (float, float)
        Its prediction interval (:func:`~millscope.estimate_fill`); (nan, nan) when the
        calibration gives none.
    energy_pu : float
        The window's spectral energy per unit of the calibration's reference.
    outside : bool
        True when ``level`` lies outside the calibrated range.
    """

    start_s: float
    end_s: float
    level: float
    interval: tuple[float, float]
    energy_pu: float
    outside: bool


@dataclass(frozen=True)
class MonitorResult:
    """:func:`monitor_record`'s result: the windows and what was done to the record.

    Attributes
    ----------
    windows : list of WindowEstimate
    window_s, step_s : float
        Window length and step, s.
    sample_rate_hz : float
        Sampling rate analysed, Hz (after any decimation).
    decimated_from_hz : float or None
        The record's own rate when it was decimated, Hz.
    lines_hz : tuple of float
        Drive-train lines removed besides the mean and the LTH, Hz.
    confidence : float
        Of the windows' intervals.
    """

    windows: list[WindowEstimate]
    window_s: float
    step_s: float
    sample_rate_hz: float
    decimated_from_hz: float | None
    lines_hz: tuple[float, ...]
    confidence: float = 0.95

    def to_frame(self) -> DataFrame:
        """The windows as a pandas DataFrame, one row per window in time order.

        Columns: ``start_s``, ``end_s`` (the window ``start_s <= t < end_s``, s, record
        time), ``level`` (the estimated load level, Table 5 units), ``level_low``,
        ``level_high`` (its interval at :attr:`confidence`; nan when the calibration gives
        none), ``energy_pu`` (the window's spectral energy per unit of the calibration's
        reference, dimensionless): float64; ``outside`` (the level lies outside the
        calibrated range): bool. ``attrs`` holds ``window_s``, ``step_s`` (s),
        ``sample_rate_hz`` (Hz) and ``confidence``.
        """
        table = frame(_WINDOW_COLUMNS, [
            {"start_s": w.start_s, "end_s": w.end_s, "level": w.level,
             "level_low": w.interval[0], "level_high": w.interval[1],
             "energy_pu": w.energy_pu, "outside": w.outside} for w in self.windows])
        table.attrs.update(window_s=self.window_s, step_s=self.step_s,
                           sample_rate_hz=self.sample_rate_hz, confidence=self.confidence)
        return table


#: The columns of :meth:`MonitorResult.to_frame` with how each is stored.
_WINDOW_COLUMNS: dict[str, Kind] = {
    "start_s": "float", "end_s": "float", "level": "float", "level_low": "float",
    "level_high": "float", "energy_pu": "float", "outside": "bool"}


def _length(name: str, value: float, dt: float, longest: float) -> int:
    """``value`` s as a whole number (>= 1) of samples of ``dt`` s, at most ``longest`` s (the
    record's length)."""
    if not (isinstance(value, (int, float)) and not isinstance(value, bool)
            and math.isfinite(value) and 0 < value <= longest + 0.5 * dt):
        raise ValueError(f"{name} = {value!r} is not valid; it must be in (0, {longest:g}] s, "
                         "at most the record's length")
    samples = round(value / dt)
    if samples < 1 or abs(samples * dt - value) > 0.5 * dt:
        raise ValueError(f"{name} = {value!r} is not valid; it must be at least one sample "
                         f"({dt:g} s)")
    return samples


def monitor_record(record: TorqueRecord, calibration: Calibration, *,
                   window_s: float | None = None, step_s: float | None = None,
                   drive: DriveTrain | None = None, confidence: float = 0.95,
                   band_hz: float | None = None) -> MonitorResult:
    """Estimate the load level in consecutive windows of a long record.

    Parameters
    ----------
    record : TorqueRecord
        Torque, N m, simulated or measured; at least one window long.
    calibration : Calibration
    window_s : float, optional
        Window length, s; it must be the calibration's ``block_s`` (the default), since
        energies grow with the block length.
    step_s : float, optional
        Step between window starts, s, in (0, the record's length] (default ``window_s``:
        windows side by side).
    drive : DriveTrain, optional
        The mill's drive: its lines up to the calibration's band are removed too (not the LTH,
        which is located and removed anyway). Its lifter count must be the calibration's.
    confidence : float
        Of the intervals, in (0, 1).
    band_hz : float, optional
        Top of the band to count, Hz, for a calibration that does not give one (format 1):
        the Nyquist frequency of the records it was made from (50 Hz for 10 ms samples).
        The record is decimated to it as for a format-2 calibration. A calibration with a
        band takes only its own (or None).

    Returns
    -------
    MonitorResult
        One :class:`WindowEstimate` per window, in time order. Estimates outside the
        calibrated range are flagged (``outside``), not warned about one by one.

    Warns
    -----
    NoIntervalWarning
        once, when the calibration cannot give intervals (a fit through 2 levels).
    MissingBandWarning
        when neither the calibration nor ``band_hz`` gives the band: the record is then
        neither decimated nor band-limited, and a record sampled faster than the
        calibration's gives biased levels.

    Raises
    ------
    ValueError
        for a bad argument (naming it, its value and the valid range) or a record shorter
        than one window, before any window is analysed.
    """
    return _monitor_record(record, calibration, window_s=window_s, step_s=step_s, drive=drive,
                           confidence=confidence, band_hz=band_hz, stacklevel=3)


def _with_band(cal: Calibration, band_hz: float | None) -> Calibration:
    """The calibration with ``band_hz`` filled in where it gives none."""
    if band_hz is None:
        return cal
    if not (isinstance(band_hz, (int, float)) and math.isfinite(band_hz) and band_hz > 0):
        raise ValueError(f"band_hz = {band_hz!r} is not valid; it must be > 0 Hz")
    if cal.band_hz is None:
        return dataclasses.replace(cal, band_hz=float(band_hz))
    if not math.isclose(band_hz, cal.band_hz, rel_tol=1e-9):
        raise ValueError(f"band_hz = {band_hz!r} is not valid; the calibration counts energy up "
                         f"to its own band_hz = {cal.band_hz:g} Hz, and only that band compares")
    return cal


def _monitor_record(record: TorqueRecord, calibration: Calibration, *, window_s: float | None,
                    step_s: float | None, drive: DriveTrain | None, confidence: float,
                    band_hz: float | None, stacklevel: int) -> MonitorResult:
    """:func:`monitor_record`, its warnings pointing ``stacklevel`` frames up."""
    cal = calibration
    if not isinstance(cal, Calibration):
        raise ValueError(f"calibration = {cal!r} is not valid; it must be a Calibration")
    cal = _with_band(cal, band_hz)
    if window_s is None:
        window_s = cal.block_s
    elif not (isinstance(window_s, (int, float)) and abs(window_s - cal.block_s) <= record.dt):
        raise ValueError(f"window_s = {window_s!r} is not valid; it must be the calibration's "
                         f"block_s = {cal.block_s:g} s (energies grow with the block length)")
    if drive is not None:
        if not isinstance(drive, DriveTrain):
            raise ValueError(f"drive = {drive!r} is not valid; it must be a DriveTrain or None")
        if drive.lifters != cal.lifters:
            raise ValueError(f"drive.lifters = {drive.lifters} is not valid; it must be the "
                             f"calibration's lifter count, {cal.lifters}")
    analysed = record if cal.band_hz is None else decimate_record(record, cal.band_hz)
    dt = analysed.dt
    if analysed.duration_s < window_s - 0.5 * dt:
        raise ValueError(f"the record is {analysed.duration_s:g} s long, shorter than one window "
                         f"of window_s = {window_s:g} s")
    width = _length("window_s", window_s, dt, analysed.duration_s)
    step = _length("step_s", window_s if step_s is None else step_s, dt, analysed.duration_s)
    nyquist = 0.5 * analysed.sample_rate_hz
    band = nyquist if cal.band_hz is None else min(cal.band_hz, nyquist)
    lines = () if drive is None else tuple(drive.frequencies_hz(max_hz=band, include_lth=False))
    if not cal.gives_intervals:
        label = f" {cal.label}" if cal.label else ""
        warnings.warn(f"the calibration{label} gives no intervals: "
                      f"{no_interval_reason(cal.fit)}; every window's interval is (nan, nan)",
                      NoIntervalWarning, stacklevel=stacklevel)
    if cal.band_hz is None:
        label = f" {cal.label}" if cal.label else ""
        warnings.warn(f"the calibration{label} gives no band_hz (its band_hz is null, or its "
                      f"file is of format 1, which has none) and no band_hz was given: the "
                      f"{record.sample_rate_hz:g} Hz record is neither decimated "
                      f"nor band-limited, its energy counted up to {nyquist:g} Hz; if the "
                      "calibration's records were sampled slower, the levels are biased. Pass "
                      "band_hz= (command line --band-hz), the Nyquist frequency of the "
                      "calibration's records (50 Hz for 10 ms samples)", MissingBandWarning,
                      stacklevel=stacklevel)
    t, x = analysed.time_s, analysed.torque_Nm
    windows = []
    for start in range(0, len(analysed) - width + 1, step):
        block = TorqueRecord(t[start:start + width], x[start:start + width])
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", OutsideCalibrationWarning)
            warnings.simplefilter("ignore", NoIntervalWarning)  # warned once above
            est = estimate_fill(block, cal, confidence=confidence, lines_hz=lines)
        windows.append(WindowEstimate(float(t[start]), float(t[start] + width * dt), est.level,
                                      est.interval, est.energy_pu, est.outside))
    return MonitorResult(windows=windows, window_s=width * dt, step_s=step * dt,
                         sample_rate_hz=analysed.sample_rate_hz,
                         decimated_from_hz=None if analysed is record else record.sample_rate_hz,
                         lines_hz=lines, confidence=float(confidence))


def monitor(record: TorqueRecord, calibration: Calibration, *, window_s: float | None = None,
            step_s: float | None = None, drive: DriveTrain | None = None,
            confidence: float = 0.95, band_hz: float | None = None) -> list[WindowEstimate]:
    """The filling estimate of every window of a long record: :func:`monitor_record`'s
    windows (same parameters)."""
    return _monitor_record(record, calibration, window_s=window_s, step_s=step_s, drive=drive,
                           confidence=confidence, band_hz=band_hz, stacklevel=3).windows

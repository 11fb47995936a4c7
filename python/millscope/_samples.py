"""Checks of uniformly sampled signals, shared by records and by the resampling of raw arrays."""

from __future__ import annotations

import math
from numbers import Real

import numpy as np
from numpy.typing import NDArray

__all__ = ["RecordError", "bad_option", "check_samples", "real_option", "step_jitter"]


class RecordError(ValueError):
    """A torque record or file that cannot be used; the message says what and where."""


def bad_option(name: str, value: object, valid: str) -> ValueError:
    """``ValueError("<name> = <value> is not valid; it must be <valid>")``."""
    return ValueError(f"{name} = {value!r} is not valid; it must be {valid}")


def real_option(name: str, value: object, low: float, high: float, valid: str) -> float:
    """``value`` as float when a real number (not a bool) with ``low <= value < high``; else
    :func:`bad_option` with ``valid``."""
    if not (isinstance(value, Real) and not isinstance(value, (bool, np.bool_))
            and math.isfinite(float(value)) and low <= float(value) < high):
        raise bad_option(name, value, valid)
    return float(value)


def step_jitter(time_s: NDArray[np.float64]) -> tuple[float, int]:
    """(largest deviation of a time step from the mean step, relative to the mean step; the
    index of that step) of at least 2 increasing times."""
    steps = np.diff(time_s)
    dt = (time_s[-1] - time_s[0]) / (time_s.size - 1)
    deviation = np.abs(steps - dt)
    worst = int(np.argmax(deviation))
    return float(deviation[worst] / dt), worst


def check_samples(time_s: NDArray[np.float64], torque: NDArray[np.float64], uniform_rtol: float,
                  where: str, torque_name: str = "torque_Nm",
                  hint: str = "resample the record first") -> None:
    """Raise :class:`RecordError` unless ``time_s`` and ``torque`` are 1-D, of equal length >= 2,
    finite, with strictly increasing and uniformly spaced times (within ``uniform_rtol`` of the
    mean step); the message starts with ``where``, names the sample (the values as
    ``torque_name``) and ends, for uneven sampling, with ``hint``."""
    if time_s.ndim != 1 or torque.ndim != 1:
        raise RecordError(f"{where}: time_s and {torque_name} must be 1-D arrays; got shapes "
                          f"{time_s.shape} and {torque.shape}")
    if time_s.shape != torque.shape:
        raise RecordError(f"{where}: time_s has {time_s.size} samples but {torque_name} has "
                          f"{torque.size}; they must match")
    if time_s.size < 2:
        raise RecordError(f"{where}: a record needs at least 2 samples; got {time_s.size}")
    for name, values in (("time_s", time_s), (torque_name, torque)):
        bad = np.flatnonzero(~np.isfinite(values))
        if bad.size:
            i = int(bad[0])
            raise RecordError(f"{where}: {name}[{i}] = {float(values[i])!r} is not finite; every "
                              f"sample must be a finite number ({bad.size} such samples)")
    steps = np.diff(time_s)
    if np.any(steps <= 0):
        i = int(np.flatnonzero(steps <= 0)[0])
        raise RecordError(f"{where}: time_s is not strictly increasing at sample {i + 1} "
                          f"({float(time_s[i])!r} s then {float(time_s[i + 1])!r} s)")
    jitter, worst = step_jitter(time_s)
    if jitter > uniform_rtol:
        dt = (time_s[-1] - time_s[0]) / (time_s.size - 1)
        raise RecordError(
            f"{where}: sampling is not uniform: step {worst + 1} is {float(steps[worst])!r} s "
            f"against a mean step of {float(dt)!r} s (a deviation of {jitter:.3g} relative; "
            f"allowed uniform_rtol = {uniform_rtol:g}); {hint}")

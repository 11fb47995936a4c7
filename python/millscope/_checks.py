"""Checks of values read from untrusted input (JSON files, command-line values).

Each check returns the value in its plain Python type or raises the caller's error type (a
``ValueError`` subclass, one per file format) with the message
``"<where> = <value> [unit] is not valid; it must be <valid range>"``. Bools are not numbers
here, and NaN and infinities are refused, so that a value that passes can be computed with.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from numbers import Integral, Real
from typing import Any, TypeGuard, TypeVar

import numpy as np

__all__ = ["MAX_LIFTERS", "as_float", "between", "choice", "count", "fail", "flag", "integer",
           "keys", "number", "positive", "real", "show", "shown", "text", "tuple_of"]

#: The most lifter bars a drum may have (a bar every 3 mm of the shell of a 10 m drum); here,
#: below both the scene (model) and the spectra (signal), which check it.
_Choice = TypeVar("_Choice", bound=str)

MAX_LIFTERS = 10_000


def _is_number(value: object) -> TypeGuard[Real]:
    return isinstance(value, Real) and not isinstance(value, bool)


def as_float(value: object) -> float:
    """``value`` as a float when it is a real number (not a bool), else nan; an integer too
    large for a float is inf."""
    if not _is_number(value):
        return math.nan
    try:
        return float(value)
    except OverflowError:
        return math.inf


def show(value: object) -> str:
    """A value as error messages print it: numbers plainly (no ``np.float64(...)``), long
    values cut short."""
    if _is_number(value) and isinstance(value, Integral):
        n = int(value)
        text = str(n) if abs(n) < 10**30 else \
            f"{'-' if n < 0 else ''}~1e{int(abs(n).bit_length() * math.log10(2))}"
    elif _is_number(value):
        text = repr(float(value))
    else:
        text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def _range(low: float, high: float, low_open: bool, high_open: bool) -> str:
    if high == math.inf:
        return f"{'>' if low_open else '>='} {low:g}"
    if low == -math.inf:
        return f"{'<' if high_open else '<='} {high:g}"
    return f"in {'(' if low_open else '['}{low:g}, {high:g}{')' if high_open else ']'}"


def number(where: str, value: object, error: type[ValueError], *, low: float = -math.inf,
           high: float = math.inf, low_open: bool = False, high_open: bool = False,
           unit: str = "", why: str = "") -> float:
    """``value`` as a float when it is a finite real number within the bounds, else ``error``.

    Parameters
    ----------
    where : str
        The value's name in the message, e.g. ``"calibration.fit.a"``.
    value : object
        What was read.
    error : type
        The ``ValueError`` subclass to raise.
    low, high : float
        Bounds, in the value's unit.
    low_open, high_open : bool
        Whether the bounds themselves are excluded.
    unit : str
        Unit for the message (e.g. ``"Hz"``).
    why : str
        Why the range is what it is, appended to the message.
    """
    x = as_float(value)
    inside = ((x > low if low_open else x >= low) and (x < high if high_open else x <= high))
    if not (math.isfinite(x) and inside):
        unit_text = f" {unit}" if unit else ""
        shown = f"{show(value)}{unit_text}" if _is_number(value) else show(value)
        reason = f" ({why})" if why else ""
        raise error(f"{where} = {shown} is not valid; it must be a finite number "
                    f"{_range(low, high, low_open, high_open)}{unit_text}{reason}")
    return x


def integer(where: str, value: object, error: type[ValueError], *, low: int,
            high: int | None = None, why: str = "") -> int:
    """``value`` as an int when it is an integer (not a bool, not a float) in [low, high],
    else ``error``."""
    n = int(value) if _is_number(value) and isinstance(value, Integral) else None
    if n is None or n < low or (high is not None and n > high):
        valid = f">= {low}" if high is None else f"in [{low}, {high}]"
        reason = f" ({why})" if why else ""
        raise error(f"{where} = {show(value)} is not valid; it must be an integer "
                    f"{valid}{reason}")
    return n


def keys(where: str, data: object, error: type[ValueError], allowed: tuple[str, ...],
         required: tuple[str, ...] = ()) -> Mapping[str, Any]:
    """``data`` when it is a JSON object holding every key of ``required`` and no key outside
    ``allowed`` (a misspelt key is not silently ignored), else ``error``."""
    if not isinstance(data, Mapping):
        raise error(f"{where} must be a JSON object with the keys {', '.join(allowed)}; got "
                    f"{type(data).__name__}")
    missing = [k for k in required if k not in data]
    if missing:
        raise error(f"{where}: missing key {', '.join(repr(k) for k in missing)}")
    unknown = [show(k) for k in data if k not in allowed]
    if unknown:
        raise error(f"{where}: unknown key {', '.join(unknown)}; the keys are "
                    f"{', '.join(allowed)}")
    return data


# -- checks of values given in code (scenes, campaigns, studies): ValueError ----------------


def shown(value: object) -> str:
    """A value as error messages print it: numbers plainly (no ``np.float64(...)``)."""
    if _is_number(value):
        return show(value)
    return repr(value)


def fail(where: str, value: object, valid: str, unit: str = "") -> ValueError:
    """``ValueError("<where> = <value> [unit] is not valid; it must be <valid>")``."""
    unit = f" {unit}" if unit and _is_number(value) else ""
    return ValueError(f"{where} = {shown(value)}{unit} is not valid; it must be {valid}")


def real(where: str, value: object, unit: str, valid: str) -> float:
    """A finite real number as float; ``valid`` is the range the caller goes on to check."""
    x = as_float(value) if not isinstance(value, np.bool_) else math.nan
    if not math.isfinite(x):
        raise fail(where, value, f"a finite number {valid}".rstrip(), unit)
    return x


def positive(where: str, value: object, unit: str = "") -> float:
    x = real(where, value, unit, "> 0")
    if not x > 0.0:
        raise fail(where, value, "> 0", unit)
    return x


def between(where: str, value: object, low: float, high: float, unit: str = "",
             low_open: bool = False, why: str = "") -> float:
    """A finite real number in [low, high] (or (low, high]) as float; ``why`` the range is
    what it is goes into the message."""
    unit_text = f" {unit}" if unit else ""
    reason = f" ({why})" if why else ""
    valid = f"in {'(' if low_open else '['}{low:g}, {high:g}]{unit_text}{reason}"
    x = real(where, value, unit, valid)
    if not ((x > low if low_open else x >= low) and x <= high):
        raise fail(where, value, valid, unit)
    return x


def count(where: str, value: object, high: int | None = None) -> int:
    if (not isinstance(value, Integral) or isinstance(value, (bool, np.bool_))
            or int(value) < 1 or (high is not None and int(value) > high)):
        raise fail(where, value, "an integer >= 1" if high is None else
                    f"an integer in [1, {high}]")
    return int(value)


def flag(where: str, value: object) -> bool:
    if not isinstance(value, (bool, np.bool_)):
        raise fail(where, value, "True or False")
    return bool(value)


def text(where: str, value: object, *, empty: bool = False) -> str:
    if not isinstance(value, str) or (not empty and not value):
        raise fail(where, value, "a string" if empty else "a non-empty string")
    return value


def choice(where: str, value: object, choices: tuple[_Choice, ...]) -> _Choice:
    """``value`` when it is one of ``choices`` (typed as they are, e.g. a Literal), else the
    error naming ``where``, the value and the choices."""
    for c in choices:
        if isinstance(value, str) and value == c:
            return c
    raise fail(where, value, f"one of {', '.join(repr(c) for c in choices)}")


def tuple_of(where: str, value: object, kind: type, what: str) -> tuple[Any, ...]:
    if isinstance(value, (str, bytes, Mapping)) or not isinstance(value, Iterable):
        raise fail(where, value, f"a sequence of {what}")
    items = tuple(value)
    for k, item in enumerate(items):
        if not isinstance(item, kind):
            raise fail(f"{where}[{k}]", item, f"a {kind.__name__}")
    return items

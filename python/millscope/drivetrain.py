"""Drive trains of real mills and the torque lines they add (paper section 6.5, Table 7).

Torque measured on a mill carries lines that do not come from grinding: the mill turn and its
second harmonic, the turn of every gear shaft, gear mesh frequencies and the motor turn, besides
the lifter torque harmonic (LTH). :class:`DriveTrain` lists them so that
:func:`millscope.spectral_energy` can remove them, and :func:`decimate` brings a fast record down
to the analysis band with an anti-aliasing filter.

A ``drive.json`` for the paper's rig, whose only known tooth count is the 18-tooth pinion of the
last stage (total ratio 36.27, 4-pole motor fed at 46 Hz)::

    {
      "motor": {"pole_pairs": 2, "supply_hz": 46.0, "slip": 0.04},
      "stages": [{"ratio": 6.2167}, {"driver_teeth": 18, "ratio": 5.8343}],
      "lifters": 16
    }

A stage gives either both tooth counts (``driver_teeth``, ``driven_teeth``; the ratio is
driven/driver) or a ``ratio`` (a speed reduction), optionally with ``driver_teeth`` so that its
mesh line is known. The motor gives ``supply_hz`` (with ``slip``) or ``speed_hz``.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from fractions import Fraction
from typing import Any

import numpy as np
import scipy.signal as ss
from numpy.typing import NDArray

from ._files import read_json

__all__ = ["Motor", "GearStage", "DriveTrain", "InterferenceLine", "decimate"]


def _require(ok: bool, message: str) -> None:
    if not ok:
        raise ValueError(message)


def _positive_int(owner: str, name: str, value: Any) -> None:
    _require(isinstance(value, int) and not isinstance(value, bool) and value >= 1,
             f"{owner}.{name} = {value!r} is not valid; it must be an integer >= 1")


def _positive_float(owner: str, name: str, value: Any) -> None:
    _require(isinstance(value, (int, float)) and not isinstance(value, bool)
             and math.isfinite(value) and value > 0,
             f"{owner}.{name} = {value!r} is not valid; it must be a finite number > 0")


@dataclass(frozen=True)
class Motor:
    """An induction motor.

    Parameters
    ----------
    pole_pairs : int
        Pole pairs (a four-pole motor has 2).
    supply_hz : float, optional
        Supply frequency, Hz; the shaft turns at supply_hz / pole_pairs x (1 - slip).
    slip : float
        Slip, in [0, 1).
    speed_hz : float, optional
        Shaft turn frequency, Hz, when known directly (then no supply_hz).
    """

    pole_pairs: int
    supply_hz: float | None = None
    slip: float = 0.0
    speed_hz: float | None = None

    def __post_init__(self) -> None:
        _positive_int("Motor", "pole_pairs", self.pole_pairs)
        _require((self.supply_hz is None) != (self.speed_hz is None),
                 "Motor: give exactly one of supply_hz and speed_hz; got "
                 f"supply_hz = {self.supply_hz!r}, speed_hz = {self.speed_hz!r}")
        if self.supply_hz is not None:
            _positive_float("Motor", "supply_hz", self.supply_hz)
        if self.speed_hz is not None:
            _positive_float("Motor", "speed_hz", self.speed_hz)
        _require(isinstance(self.slip, (int, float)) and 0 <= self.slip < 1,
                 f"Motor.slip = {self.slip!r} is not valid; it must be in [0, 1)")

    @property
    def shaft_hz(self) -> float:
        """Motor shaft turn frequency, Hz."""
        if self.speed_hz is not None:
            return float(self.speed_hz)
        assert self.supply_hz is not None
        return self.supply_hz / self.pole_pairs * (1.0 - self.slip)


@dataclass(frozen=True)
class GearStage:
    """One gear stage, a speed reduction from its driver (input) to its driven (output) shaft.

    Parameters
    ----------
    driver_teeth, driven_teeth : int, optional
        Tooth counts; both given fix the ratio driven/driver.
    ratio : float, optional
        Speed ratio input/output (> 0) when the tooth counts are not both known.
    """

    driver_teeth: int | None = None
    driven_teeth: int | None = None
    ratio: float | None = None

    def __post_init__(self) -> None:
        for name in ("driver_teeth", "driven_teeth"):
            value = getattr(self, name)
            if value is not None:
                _positive_int("GearStage", name, value)
        both = self.driver_teeth is not None and self.driven_teeth is not None
        if self.ratio is not None:
            _positive_float("GearStage", "ratio", self.ratio)
            _require(not both, "GearStage: give the ratio or both tooth counts, not both; got "
                     f"ratio = {self.ratio!r}, teeth {self.driver_teeth}/{self.driven_teeth}")
        else:
            _require(both, "GearStage: give both driver_teeth and driven_teeth, or a ratio; got "
                     f"driver_teeth = {self.driver_teeth!r}, driven_teeth = "
                     f"{self.driven_teeth!r}")

    @property
    def speed_ratio(self) -> float:
        """Input speed / output speed."""
        if self.ratio is not None:
            return float(self.ratio)
        assert self.driver_teeth is not None and self.driven_teeth is not None
        return self.driven_teeth / self.driver_teeth


@dataclass(frozen=True)
class InterferenceLine:
    """A torque line of the drive: ``name``, ``frequency_hz`` (Hz), ``source`` (what makes it)."""

    name: str
    frequency_hz: float
    source: str


@dataclass(frozen=True)
class DriveTrain:
    """Motor, gear stages from motor to mill, and the mill's lifter count."""

    motor: Motor
    stages: tuple[GearStage, ...]
    lifters: int

    def __post_init__(self) -> None:
        _require(isinstance(self.motor, Motor),
                 f"DriveTrain.motor must be a Motor; got {type(self.motor).__name__}")
        object.__setattr__(self, "stages", tuple(self.stages))
        _require(all(isinstance(s, GearStage) for s in self.stages),
                 "DriveTrain.stages must all be GearStage")
        _positive_int("DriveTrain", "lifters", self.lifters)

    @classmethod
    def from_mill_speed(cls, mill_hz: float, stages: tuple[GearStage, ...], lifters: int,
                        pole_pairs: int = 2) -> DriveTrain:
        """The drive whose mill turns at ``mill_hz`` (Hz): the motor speed follows the ratios."""
        _positive_float("DriveTrain", "mill_hz", mill_hz)
        ratio = math.prod(s.speed_ratio for s in stages)
        return cls(Motor(pole_pairs, speed_hz=mill_hz * ratio), tuple(stages), lifters)

    @property
    def total_ratio(self) -> float:
        """Motor speed / mill speed."""
        return math.prod(s.speed_ratio for s in self.stages)

    @property
    def shaft_hz(self) -> tuple[float, ...]:
        """Turn frequency of the output shaft of each stage, Hz (the last is the mill)."""
        speeds, speed = [], self.motor.shaft_hz
        for stage in self.stages:
            speed /= stage.speed_ratio
            speeds.append(speed)
        return tuple(speeds)

    @property
    def mill_hz(self) -> float:
        """Mill turn frequency, Hz."""
        return self.shaft_hz[-1] if self.stages else self.motor.shaft_hz

    def interference_lines(self, max_hz: float | None = None) -> list[InterferenceLine]:
        """The lines of Table 7, sorted by frequency, up to ``max_hz`` (Hz) when given:
        mill turn and its second harmonic, each intermediate shaft's turn, each known gear mesh,
        the motor turn, and the LTH (lifters x mill turn)."""
        mill = self.mill_hz
        lines = [InterferenceLine("mill turn", mill, "mill"),
                 InterferenceLine("2 x mill turn", 2 * mill, "mill"),
                 InterferenceLine("LTH", self.lifters * mill, "lifters"),
                 InterferenceLine("motor turn", self.motor.shaft_hz, "motor")]
        input_hz = self.motor.shaft_hz
        for i, (stage, out_hz) in enumerate(zip(self.stages, self.shaft_hz, strict=True), 1):
            if i < len(self.stages):
                lines.append(InterferenceLine(f"stage {i} output shaft turn", out_hz,
                                              f"gear stage {i}"))
            if stage.driver_teeth is not None:
                lines.append(InterferenceLine(f"stage {i} gear mesh",
                                              stage.driver_teeth * input_hz, f"gear stage {i}"))
            input_hz = out_hz
        if max_hz is not None:
            lines = [line for line in lines if line.frequency_hz <= max_hz]
        return sorted(lines, key=lambda line: line.frequency_hz)

    def frequencies_hz(self, max_hz: float | None = None, include_lth: bool = True
                       ) -> list[float]:
        """Frequencies of :meth:`interference_lines`, Hz, to pass as ``remove=``."""
        return [line.frequency_hz for line in self.interference_lines(max_hz)
                if include_lth or line.name != "LTH"]

    # -- JSON ------------------------------------------------------------------------------
    def to_dict(self) -> dict[str, Any]:
        """A JSON-serialisable dict (the ``drive.json`` schema of the module docstring)."""
        def clean(obj: object) -> dict[str, Any]:
            return {k: v for k, v in vars(obj).items() if v is not None}
        return {"motor": clean(self.motor), "stages": [clean(s) for s in self.stages],
                "lifters": self.lifters}

    @classmethod
    def from_dict(cls, data: Any, where: str = "drive") -> DriveTrain:
        """Build from :meth:`to_dict`'s form; errors name ``where`` and the faulty key."""
        if not isinstance(data, dict):
            raise ValueError(f"{where}: expected a JSON object with keys motor, stages, lifters")
        missing = [k for k in ("motor", "stages", "lifters") if k not in data]
        if missing:
            raise ValueError(f"{where}: missing key {', '.join(missing)}")
        if not isinstance(data["motor"], dict):
            raise ValueError(f"{where}: 'motor' must be an object")
        if not isinstance(data["stages"], list) or not all(isinstance(s, dict)
                                                           for s in data["stages"]):
            raise ValueError(f"{where}: 'stages' must be a list of objects")
        try:
            motor = Motor(**data["motor"])
            stages = tuple(GearStage(**s) for s in data["stages"])
            return cls(motor, stages, data["lifters"])
        except TypeError as exc:  # an unknown key
            raise ValueError(f"{where}: {exc}") from None
        except ValueError as exc:
            raise ValueError(f"{where}: {exc}") from None

    @classmethod
    def load(cls, path: str | os.PathLike[str]) -> DriveTrain:
        """Read a ``drive.json``."""
        return cls.from_dict(read_json(path, "drive"), str(path))


def decimate(time_s: NDArray[np.float64], torque: NDArray[np.float64], target_hz: float
             ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Resample a uniformly sampled record to ``target_hz`` (Hz) with an anti-aliasing filter.

    Uses ``scipy.signal.resample_poly`` (a zero-phase polyphase FIR) with the rational
    ratio target/source; returns the new time axis (from ``time_s[0]``, step 1/target_hz) and
    the filtered samples.
    """
    time_s = np.asarray(time_s, dtype=np.float64)
    torque = np.asarray(torque, dtype=np.float64)
    if time_s.size < 2 or time_s.shape != torque.shape:
        raise ValueError("decimate: time_s and torque must be 1-D of equal length >= 2")
    source_hz = (time_s.size - 1) / (time_s[-1] - time_s[0])
    if not (math.isfinite(target_hz) and 0 < target_hz < source_hz):
        raise ValueError(f"target_hz = {target_hz!r} is not valid; it must be in "
                         f"(0, {source_hz:g}) Hz, below the record's sample rate")
    ratio = Fraction(target_hz / source_hz).limit_denominator(1000)
    y = ss.resample_poly(torque, ratio.numerator, ratio.denominator)
    step = 1.0 / (source_hz * ratio.numerator / ratio.denominator)
    return time_s[0] + step * np.arange(y.size), y

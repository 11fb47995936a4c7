"""Drive trains of real mills and the torque lines they add (paper sections 5 and 6.5, Table 7).

Torque measured on a real mill carries lines that do not come from grinding: the mill turn and
its second harmonic, the turn of every gear shaft, the gear mesh frequencies and the motor turn,
besides the lifter torque harmonic (LTH, lifters x mill turn, paper section 6.2). They move with
the speed, so they are computed from a description of the drive: :class:`DriveTrain` lists them
(:meth:`DriveTrain.interference_lines`, :meth:`DriveTrain.frequencies_hz`) so that
:func:`millscope.spectral_energy` can remove them, and :func:`decimate` brings a record sampled
faster than the analysis band down to it with an anti-aliasing filter.

Frequencies are in Hz throughout.

The ``drive.json`` schema
-------------------------
One JSON object with exactly these keys (the command line reads it with ``--drive``)::

    motor    object   pole_pairs  integer in [1, 1000]              required
                      supply_hz   number in (0, 1e4], Hz  \\  exactly one of the two
                      speed_hz    number in (0, 1e4], Hz  /  (speed_hz: motor shaft turn)
                      slip        number in [0, 1)        only with supply_hz; default 0
    stages   array    one object per gear stage, from the motor to the mill (may be empty):
                      driver_teeth  integer in [1, 10000]  teeth of the input (driving) gear
                      driven_teeth  integer in [1, 10000]  teeth of the output (driven) gear
                      ratio         number in [1e-3, 1e3]  input speed / output speed
                      name          string         label of the stage's lines (optional)
                      A stage gives both tooth counts (the ratio is driven/driver), or a ratio,
                      optionally with one tooth count so that its mesh line is known.
    lifters  integer in [1, 10000]   lifters in the mill

Unknown keys are errors, so that a misspelt key is not silently ignored, and every line of the
drive (below) must come out finite. A file is read only up to ``MAX_JSON_BYTES``; every problem
of a file raises :class:`DriveError` naming the key, its value and the valid range.

The paper's rig: a four-pole motor (2 pole pairs) fed at 46 Hz by an adjustable speed drive, a
three-stage gear set of total ratio 36.27 whose last stage is an 18-tooth pinion turning at
3.55 Hz in mesh with the crown on the mill (the 63.9 Hz mesh line, 18 x 3.55), and 16 lifters.
The paper gives neither the ratios of the first two stages nor the crown's tooth count, so those
two stages are lumped into one and the pinion stage is given by its ratio. The mill speed is not
published either; taking the paper's "approximately 80 % critical" for the 880 mm mill
(0.610 Hz) gives a motor speed of 0.610 x 36.27 = 22.12 Hz, a slip of 1 - 22.12 / 23 = 0.038, and
the ratios 22.12 / 3.55 = 6.2315 and 36.27 / 6.2315 = 5.8204::

    {
      "motor": {"pole_pairs": 2, "supply_hz": 46.0, "slip": 0.038},
      "stages": [
        {"ratio": 6.2315, "name": "stages 1-2 (lumped)"},
        {"driver_teeth": 18, "ratio": 5.8204, "name": "pinion-crown"}
      ],
      "lifters": 16
    }

Its lines: mill turn 0.610 Hz, twice that 1.220 Hz, pinion shaft 3.55 Hz (Table 7's "second
stage gear output"), LTH 9.76 Hz, motor turn 22.12 Hz and the pinion-crown mesh 63.9 Hz (above
the paper's 0 to 50 Hz band). Table 7 also lists a "mesh-related frequency" whose origin is not
given; such lines can be appended to :meth:`DriveTrain.frequencies_hz` by hand.
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Iterable
from dataclasses import dataclass, fields
from fractions import Fraction
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .. import _checks
from .._files import MAX_JSON_BYTES, atomic_write, read_json
from .._samples import check_samples
from .record import TorqueRecord
from .spectral import MAX_LIFTERS

__all__ = ["DECIMATE_FACTOR", "DriveError", "DriveTrain", "GearStage", "InterferenceLine",
           "Motor", "decimate", "decimate_record"]

#: Records sampled faster than this x the analysis band are decimated to this x the band: the
#: anti-aliasing filter of :func:`decimate` rolls off over the top fifth below the new Nyquist
#: frequency, so 2.5x (not 2x) keeps the band itself flat.
DECIMATE_FACTOR = 2.5
#: The most teeth a gear may have (girth gears of the largest mills have a few hundred).
MAX_TEETH = 10_000
#: The most pole pairs a motor may have (slow synchronous mill motors have some tens).
MAX_POLE_PAIRS = 1_000
#: The highest supply or shaft frequency of a motor, Hz (600,000 rpm, beyond any motor).
MAX_MOTOR_HZ = 10_000.0
#: The largest speed change of one gear stage, either way.
MAX_STAGE_RATIO = 1_000.0


class DriveError(ValueError):
    """A drive description (a ``drive.json``) that cannot be used; the message names the file,
    the key, its value and the valid range."""


# -- validation helpers ---------------------------------------------------------------------------
def _is_real(value: Any) -> bool:
    return math.isfinite(_checks.as_float(value))


def _positive(owner: str, name: str, value: Any, unit: str = "") -> float:
    if not (_is_real(value) and float(value) > 0):
        raise ValueError(f"{owner}.{name} = {value!r} is not valid; it must be a finite number "
                         f"> 0{unit}")
    return float(value)


# -- the drive ------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Motor:
    """An induction motor, given by its supply frequency and slip or by its shaft speed.

    Parameters
    ----------
    pole_pairs : int
        Pole pairs, >= 1 (a four-pole motor has 2).
    supply_hz : float, optional
        Supply (electrical) frequency, Hz, > 0; the shaft turns at
        ``supply_hz / pole_pairs * (1 - slip)``. Exactly one of `supply_hz` and `speed_hz`.
    slip : float, default 0
        Slip, in [0, 1); only with `supply_hz`.
    speed_hz : float, optional
        Shaft turn frequency, Hz, > 0, when it is known directly (measured, or back-computed from
        the mill speed). Exactly one of `supply_hz` and `speed_hz`.

    Raises
    ------
    ValueError
        For a bad value, naming the parameter, the value and the valid range.
    """

    pole_pairs: int
    supply_hz: float | None = None
    slip: float = 0.0
    speed_hz: float | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "pole_pairs",
                           _checks.integer("Motor.pole_pairs", self.pole_pairs, ValueError, low=1,
                                           high=MAX_POLE_PAIRS))
        if (self.supply_hz is None) == (self.speed_hz is None):
            raise ValueError("Motor: give exactly one of supply_hz and speed_hz; got "
                             f"supply_hz = {self.supply_hz!r}, speed_hz = {self.speed_hz!r}")
        if self.supply_hz is not None:
            object.__setattr__(self, "supply_hz",
                               _checks.number("Motor.supply_hz", self.supply_hz, ValueError,
                                              low=0.0, low_open=True, high=MAX_MOTOR_HZ,
                                              unit="Hz"))
        if self.speed_hz is not None:
            object.__setattr__(self, "speed_hz",
                               _checks.number("Motor.speed_hz", self.speed_hz, ValueError,
                                              low=0.0, low_open=True, high=MAX_MOTOR_HZ,
                                              unit="Hz"))
        if not (_is_real(self.slip) and 0.0 <= float(self.slip) < 1.0):
            raise ValueError(f"Motor.slip = {self.slip!r} is not valid; it must be a number "
                             "in [0, 1)")
        if self.speed_hz is not None and self.slip != 0:
            raise ValueError(f"Motor.slip = {self.slip!r} is not valid with speed_hz; slip "
                             "applies to supply_hz only, so it must be 0 when the shaft speed "
                             "is given")
        object.__setattr__(self, "slip", float(self.slip))

    @property
    def shaft_hz(self) -> float:
        """Motor shaft turn frequency, Hz."""
        if self.speed_hz is not None:
            return self.speed_hz
        assert self.supply_hz is not None
        return self.supply_hz / self.pole_pairs * (1.0 - self.slip)


@dataclass(frozen=True)
class GearStage:
    """One gear stage: a speed reduction from its driver (input) shaft to its driven (output)
    shaft.

    Parameters
    ----------
    driver_teeth : int, optional
        Teeth of the input (driving) gear, >= 1.
    driven_teeth : int, optional
        Teeth of the output (driven) gear, >= 1.
    ratio : float, optional
        Speed ratio input / output, > 0, when the tooth counts are not both known.
    name : str, optional
        Label of the stage's lines (default ``"stage i"``).

    Notes
    -----
    Either both tooth counts (the ratio is driven_teeth / driver_teeth) or a ratio. A ratio alone
    leaves the mesh line unknown; with one tooth count besides it the mesh line is known, since
    the mesh frequency is driver_teeth x input turn = driven_teeth x output turn.

    Raises
    ------
    ValueError
        For a bad value or combination, naming the parameters and values.
    """

    driver_teeth: int | None = None
    driven_teeth: int | None = None
    ratio: float | None = None
    name: str | None = None

    def __post_init__(self) -> None:
        for key in ("driver_teeth", "driven_teeth"):
            value = getattr(self, key)
            if value is not None:
                object.__setattr__(self, key, _checks.integer(
                    f"GearStage.{key}", value, ValueError, low=1, high=MAX_TEETH))
        both = self.driver_teeth is not None and self.driven_teeth is not None
        if self.ratio is not None:
            object.__setattr__(self, "ratio", _checks.number(
                "GearStage.ratio", self.ratio, ValueError, low=1 / MAX_STAGE_RATIO,
                high=MAX_STAGE_RATIO, why="a gear stage changes the speed by at most "
                f"{MAX_STAGE_RATIO:g} either way"))
            if both:
                raise ValueError(
                    "GearStage: give the ratio or both tooth counts, not both; got "
                    f"ratio = {self.ratio!r}, driver_teeth = {self.driver_teeth!r}, "
                    f"driven_teeth = {self.driven_teeth!r}")
        elif not both:
            raise ValueError(
                "GearStage: give both driver_teeth and driven_teeth, or a ratio; got "
                f"driver_teeth = {self.driver_teeth!r}, driven_teeth = {self.driven_teeth!r}")
        if self.name is not None and not (isinstance(self.name, str) and self.name.strip()):
            raise ValueError(f"GearStage.name = {self.name!r} is not valid; it must be a "
                             "non-empty string or None")

    @property
    def speed_ratio(self) -> float:
        """Input turn frequency / output turn frequency (dimensionless)."""
        if self.ratio is not None:
            return self.ratio
        assert self.driver_teeth is not None and self.driven_teeth is not None
        return self.driven_teeth / self.driver_teeth

    def mesh_hz(self, input_hz: float) -> float | None:
        """Gear mesh frequency, Hz, for the input shaft turning at `input_hz` (Hz): driver_teeth x
        input_hz (or driven_teeth x output turn); None when no tooth count is known."""
        if self.driver_teeth is not None:
            return self.driver_teeth * input_hz
        if self.driven_teeth is not None:
            return self.driven_teeth * input_hz / self.speed_ratio
        return None


@dataclass(frozen=True)
class InterferenceLine:
    """A torque line that does not come from grinding.

    Parameters
    ----------
    name : str
        What the line is, e.g. ``"mill turn"``, ``"stage 3 gear mesh"``, ``"LTH"``.
    frequency_hz : float
        Its frequency, Hz, > 0.
    source : str
        The part that makes it: ``"mill"``, ``"lifters"``, ``"motor"`` or the stage's label.
    """

    name: str
    frequency_hz: float
    source: str

    def __post_init__(self) -> None:
        for key in ("name", "source"):
            value = getattr(self, key)
            if not (isinstance(value, str) and value.strip()):
                raise ValueError(f"InterferenceLine.{key} = {value!r} is not valid; it must be "
                                 "a non-empty string")
        object.__setattr__(self, "frequency_hz", _positive("InterferenceLine", "frequency_hz",
                                                           self.frequency_hz, " Hz"))


_TOP_KEYS = ("motor", "stages", "lifters")
_MOTOR_KEYS = tuple(f.name for f in fields(Motor))
_STAGE_KEYS = tuple(f.name for f in fields(GearStage))


@dataclass(frozen=True)
class DriveTrain:
    """A mill drive: the motor, the gear stages from the motor to the mill, and the lifters.

    Parameters
    ----------
    motor : Motor
        The motor; its shaft drives the first stage (or the mill when there is no stage).
    stages : tuple of GearStage
        Gear stages in order from the motor to the mill (a list is accepted and stored as a
        tuple); the output shaft of the last stage is the mill.
    lifters : int
        Lifters in the mill, >= 1 (the LTH is lifters x mill turn).

    Raises
    ------
    ValueError
        For a bad value, naming the parameter, the value and the valid range.
    """

    motor: Motor
    stages: tuple[GearStage, ...]
    lifters: int

    def __post_init__(self) -> None:
        if not isinstance(self.motor, Motor):
            raise ValueError(f"DriveTrain.motor = {self.motor!r} is not valid; it must be a "
                             "Motor")
        stages = self.stages
        if isinstance(stages, GearStage) or not isinstance(stages, Iterable):
            raise ValueError(f"DriveTrain.stages = {stages!r} is not valid; it must be a tuple "
                             "of GearStage (empty for a direct drive)")
        stages = tuple(stages)
        for i, stage in enumerate(stages):
            if not isinstance(stage, GearStage):
                raise ValueError(f"DriveTrain.stages[{i}] = {stage!r} is not valid; it must be "
                                 "a GearStage")
        object.__setattr__(self, "stages", stages)
        object.__setattr__(self, "lifters",
                           _checks.integer("DriveTrain.lifters", self.lifters, ValueError, low=1,
                                           high=MAX_LIFTERS))
        try:
            self.interference_lines()
        except ValueError:
            raise ValueError("DriveTrain: its speeds and ratios give a line that is not a "
                             "finite frequency > 0 (the motor speed times or over the stage "
                             f"ratios overflows): motor turn {self.motor.shaft_hz!r} Hz, total "
                             f"ratio {self.total_ratio!r}; give speeds and ratios of a real "
                             "drive") from None

    @classmethod
    def from_mill_speed(cls, mill_hz: float, stages: Iterable[GearStage], lifters: int,
                        pole_pairs: int = 2) -> DriveTrain:
        """The drive whose mill turns at `mill_hz`, the motor speed back-computed from the ratios.

        Parameters
        ----------
        mill_hz : float
            Mill turn frequency, Hz, > 0 (e.g. measured, or the LTH found divided by lifters).
        stages : iterable of GearStage
            Gear stages from the motor to the mill.
        lifters : int
            Lifters in the mill, >= 1.
        pole_pairs : int, default 2
            Pole pairs of the motor (recorded only: its speed is set directly, ``speed_hz``).

        Returns
        -------
        DriveTrain
            With ``Motor(pole_pairs, speed_hz=mill_hz * total_ratio)``.
        """
        mill = _positive("DriveTrain.from_mill_speed", "mill_hz", mill_hz, " Hz")
        # validate the stages and lifters first, with a placeholder motor speed
        unit_speed = cls(Motor(pole_pairs, speed_hz=1.0), tuple(stages), lifters)
        return cls(Motor(pole_pairs, speed_hz=mill * unit_speed.total_ratio), unit_speed.stages,
                   lifters)

    @property
    def total_ratio(self) -> float:
        """Motor turn frequency / mill turn frequency (dimensionless; 1 without stages)."""
        return math.prod(stage.speed_ratio for stage in self.stages)

    @property
    def shaft_hz(self) -> tuple[float, ...]:
        """Turn frequency, Hz, of the output shaft of each stage, in order (the last is the
        mill's)."""
        speeds, speed = [], self.motor.shaft_hz
        for stage in self.stages:
            speed /= stage.speed_ratio
            speeds.append(speed)
        return tuple(speeds)

    @property
    def mill_hz(self) -> float:
        """Mill turn frequency, Hz."""
        return self.shaft_hz[-1] if self.stages else self.motor.shaft_hz

    @property
    def lth_hz(self) -> float:
        """Lifter torque harmonic, Hz: lifters x mill turn (paper section 6.2)."""
        return self.lifters * self.mill_hz

    def interference_lines(self, max_hz: float | None = None) -> list[InterferenceLine]:
        """The drive's torque lines (paper Table 7), sorted by frequency.

        Parameters
        ----------
        max_hz : float, optional
            Keep only lines at or below this frequency, Hz, > 0 (e.g. the analysis band).

        Returns
        -------
        list of InterferenceLine
            The mill turn and its second harmonic, the turn of each intermediate shaft (the
            output of every stage but the last), each known gear mesh, the motor turn (when there
            is a gear stage; otherwise it is the mill turn) and the LTH, by rising frequency.
        """
        limit = None if max_hz is None else _positive("interference_lines", "max_hz", max_hz,
                                                      " Hz")
        mill = self.mill_hz
        lines = [InterferenceLine("mill turn", mill, "mill"),
                 InterferenceLine("2 x mill turn", 2.0 * mill, "mill"),
                 InterferenceLine("LTH", self.lth_hz, "lifters")]
        if self.stages:
            lines.append(InterferenceLine("motor turn", self.motor.shaft_hz, "motor"))
        input_hz = self.motor.shaft_hz
        last = len(self.stages) - 1
        for i, (stage, output_hz) in enumerate(zip(self.stages, self.shaft_hz, strict=True)):
            label = stage.name or f"stage {i + 1}"
            if i < last:
                lines.append(InterferenceLine(f"{label} output shaft turn", output_hz, label))
            mesh = stage.mesh_hz(input_hz)
            if mesh is not None:
                lines.append(InterferenceLine(f"{label} gear mesh", mesh, label))
            input_hz = output_hz
        if limit is not None:
            lines = [line for line in lines if line.frequency_hz <= limit]
        return sorted(lines, key=lambda line: line.frequency_hz)

    def frequencies_hz(self, max_hz: float | None = None, include_lth: bool = True
                       ) -> list[float]:
        """Frequencies of :meth:`interference_lines`, Hz, rising, to pass to spectral energy
        removal.

        Parameters
        ----------
        max_hz : float, optional
            Keep only lines at or below this frequency, Hz.
        include_lth : bool, default True
            Whether to include the LTH (leave it out when the caller locates and removes the LTH
            itself).

        Returns
        -------
        list of float
            Line frequencies, Hz.
        """
        return [line.frequency_hz for line in self.interference_lines(max_hz)
                if include_lth or line.source != "lifters"]

    # -- JSON -------------------------------------------------------------------------------------
    def to_dict(self) -> dict[str, Any]:
        """The drive as a JSON-serialisable dict (the ``drive.json`` schema of the module
        docstring); unset optional fields are left out."""
        def plain(obj: Motor | GearStage) -> dict[str, Any]:
            return {f.name: getattr(obj, f.name) for f in fields(obj)
                    if getattr(obj, f.name) is not None}
        return {"motor": plain(self.motor), "stages": [plain(s) for s in self.stages],
                "lifters": self.lifters}

    @classmethod
    def from_dict(cls, data: Any, where: str = "drive") -> DriveTrain:
        """Build a drive from :meth:`to_dict`'s form (a parsed ``drive.json``).

        Parameters
        ----------
        data : dict
            The parsed JSON.
        where : str, default "drive"
            Prefix of error messages (the file name when read by :meth:`load`).

        Raises
        ------
        DriveError
            Naming `where`, the key and what is wrong with it (missing, unknown, wrong type or
            out of range).
        """
        try:
            return cls._from_dict(data, where)
        except DriveError:
            raise
        except ValueError as exc:
            raise DriveError(str(exc)) from None

    @classmethod
    def _from_dict(cls, data: Any, where: str) -> DriveTrain:
        """:meth:`from_dict`, raising ValueError."""
        if not isinstance(data, dict):
            raise ValueError(f"{where}: expected a JSON object with keys motor, stages, lifters; "
                             f"got {type(data).__name__}")
        _checks.keys(where, data, ValueError, _TOP_KEYS, _TOP_KEYS)
        motor_data, stages_data = data["motor"], data["stages"]
        if not isinstance(motor_data, dict):
            raise ValueError(f"{where}: 'motor' must be an object; got "
                             f"{type(motor_data).__name__}")
        _checks.keys(f"{where}: motor", motor_data, ValueError, _MOTOR_KEYS, ("pole_pairs",))
        if not isinstance(stages_data, list):
            raise ValueError(f"{where}: 'stages' must be an array of objects; got "
                             f"{type(stages_data).__name__}")
        try:
            motor = Motor(**motor_data)
        except ValueError as exc:
            raise ValueError(f"{where}: motor: {exc}") from None
        stages = []
        for i, stage_data in enumerate(stages_data):
            if not isinstance(stage_data, dict):
                raise ValueError(f"{where}: stages[{i}] must be an object; got "
                                 f"{type(stage_data).__name__}")
            _checks.keys(f"{where}: stages[{i}]", stage_data, ValueError, _STAGE_KEYS, ())
            try:
                stages.append(GearStage(**stage_data))
            except ValueError as exc:
                raise ValueError(f"{where}: stages[{i}]: {exc}") from None
        try:
            return cls(motor, tuple(stages), data["lifters"])
        except ValueError as exc:
            raise ValueError(f"{where}: {exc}") from None

    @classmethod
    def load(cls, path: str | os.PathLike[str]) -> DriveTrain:
        """Read a ``drive.json`` (schema in the module docstring).

        Raises
        ------
        DriveError
            Naming the file and the problem: missing or unreadable file, larger than
            ``MAX_JSON_BYTES``, invalid JSON, missing or unknown key, wrong type, value out of
            range.
        """
        return cls.from_dict(read_json(path, "drive", DriveError, MAX_JSON_BYTES), str(path))

    def save(self, path: str | os.PathLike[str]) -> None:
        """Write the drive as a ``drive.json`` (atomically: a temporary file, then a rename)."""
        with atomic_write(path) as fh:
            json.dump(self.to_dict(), fh, indent=2)
            fh.write("\n")


# -- decimation -----------------------------------------------------------------------------------
def decimate(time_s: ArrayLike, torque: ArrayLike, target_hz: float, *,
             uniform_rtol: float = 1e-6) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Resample a uniformly sampled record to a lower rate `target_hz` with an anti-aliasing
    filter.

    Parameters
    ----------
    time_s : array_like
        Sample times, s: 1-D, finite, strictly increasing and uniform (within `uniform_rtol` of
        the mean step), at least 2 samples.
    torque : array_like
        Samples (e.g. torque in N m), 1-D, finite, as many as `time_s`.
    target_hz : float
        New sampling rate, Hz, in (0, input rate).
    uniform_rtol : float, default 1e-6
        Allowed deviation of a time step from the mean step, relative (as ``TorqueRecord``).

    Returns
    -------
    time_s : ndarray
        New uniform time axis, s, from ``time_s[0]`` with step 1 / (input rate x up / down).
    samples : ndarray
        The filtered, resampled samples.

    Raises
    ------
    ValueError
        For bad arrays, or a `target_hz` not below the input rate or not reachable as a ratio.

    Notes
    -----
    ``scipy.signal.resample_poly`` with ``up/down = Fraction(target_hz / input rate)
    .limit_denominator(1000)``; the rate reached is within 0.1 % of `target_hz` (exact for the
    usual rates, e.g. 1000 Hz to 100 Hz). The filter (scipy's default Kaiser FIR, zero phase) is
    flat within 0.05 dB up to 0.8 x the new Nyquist frequency f_N = rate/2, -0.7 dB at 0.9 f_N,
    -6 dB at f_N, and at least 55 dB down above 1.2 f_N; so keep the analysis band below
    0.8 f_N, i.e. choose `target_hz` >= 2.5 x its top. Beyond the ends the record is assumed to
    continue the straight line through its first and last samples (``padtype="line"``), so the
    mean torque and a slow drift leave no transient at the edges.
    """
    t = np.asarray(time_s, dtype=np.float64)
    x = np.asarray(torque, dtype=np.float64)
    check_samples(t, x, uniform_rtol, "decimate", torque_name="torque")
    dt = (t[-1] - t[0]) / (t.size - 1)
    source_hz = 1.0 / dt
    if not (_is_real(target_hz) and 0 < float(target_hz) < source_hz):
        raise ValueError(f"target_hz = {target_hz!r} is not valid; it must be in "
                         f"(0, {source_hz:g}) Hz, below the record's sample rate")
    ratio = Fraction(float(target_hz) / source_hz).limit_denominator(1000)
    reached_hz = source_hz * ratio.numerator / ratio.denominator
    if ratio == 0 or ratio >= 1 or abs(reached_hz / target_hz - 1) > 1e-3:
        raise ValueError(f"target_hz = {target_hz!r} is not valid for a record sampled at "
                         f"{source_hz:g} Hz: the nearest rational rate ratio up/down with "
                         f"down <= 1000 is {ratio}, giving {reached_hz:g} Hz; it must be a "
                         "reduction within 0.1 % of target_hz (decimate in two steps for ratios "
                         "below 1/1000)")
    # scipy.signal takes a large part of a second to import: loaded here, on first use, so
    # that `import millscope` stays quick
    import scipy.signal as ss

    y = ss.resample_poly(x, ratio.numerator, ratio.denominator, padtype="line")
    return t[0] + np.arange(y.size) / reached_hz, np.asarray(y, dtype=np.float64)


def decimate_record(record: TorqueRecord, band_hz: float) -> TorqueRecord:
    """A measured record brought to the analysis band: decimated (anti-aliased, :func:`decimate`)
    to ``DECIMATE_FACTOR`` x ``band_hz`` when it is sampled faster than that, else itself.

    Parameters
    ----------
    record : TorqueRecord
    band_hz : float
        Top of the analysis band, Hz, > 0 (the paper's is 50 Hz).

    Returns
    -------
    TorqueRecord
        ``record`` itself, or a new record whose ``meta["decimated_to_hz"]`` is the new rate;
        count its energy over 0 .. ``band_hz`` only.
    """
    band = _positive("decimate_record", "band_hz", band_hz, " Hz")
    target_hz = DECIMATE_FACTOR * band
    if record.sample_rate_hz <= target_hz * (1 + 1e-9):
        return record
    t, q = decimate(record.time_s, record.torque_Nm, target_hz)
    return TorqueRecord(t, q, {**record.meta, "decimated_to_hz": target_hz})

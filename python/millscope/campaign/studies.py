"""Error against run time: what each speed-up knob costs in accuracy (issue "Error against run
time", item 1).

A study runs the pilot mill (:func:`millscope.presets.pilot_mill`) under a ladder of
:class:`Setting` s and reports, for each, the run time and the error of what the analysis gives
(mean torque, spectral energy with the mean and the LTH removed, LTH amplitude and, for several
load levels, the log-fit slope a) against one **reference** setting, by default the most
expensive one. The knobs of a setting:

* ``dt_fraction``: the time step as a fraction of the smallest Rayleigh time (the engine's
  default is 0.2, its limit 0.5);
* ``shear_modulus_factor``: every shear modulus as a fraction of the paper's (1, 0.1, 0.01,
  0.001), or None for the scale's own;
* ``record_s`` and ``warm_up_s``: the analysed block and the rotation before it, s;
* ``sampling``: ``"instant"`` (as the paper) or ``"mean"`` (anti-aliased);
* ``scale``: a scale of :data:`millscope.presets.SCALES` (the whole mill or an axial slice).

Each setting runs with several filling seeds, so that noise can be told from bias: a row
gives the error of the seed mean against the reference's seed mean, the spread of one run (the
standard deviation over the seeds) and the standard error of the error (both means' seed
noise). An error well above its standard error is a bias of the setting; one within it is
noise.

The runs are the cases of one :class:`~millscope.campaign.Campaign` (store, resume, executors,
progress bar as there; each case is analysed as the campaign analyses its cases,
:meth:`~millscope.campaign.CaseResult.from_record`), one case per setting, load level and seed::

    from millscope.studies import Setting, StudyPlan, run_study
    plan = StudyPlan.ladder("dt_fraction", [0.05, 0.1, 0.2, 0.3], seeds=(0, 1, 2))
    result = run_study(plan, "out/dt-study/store")
    result.to_csv("out/dt-study/accuracy.csv"); print(result.to_markdown())
    result.pareto("energy")               # the settings no other beats in both cost and error

**Comparing unlike settings.** Quantities are put on the reference's footing before they are
compared: torques (mean, LTH amplitude) are scaled by the ratio of drum lengths L_ref / L (a
periodic slice stands for its share of the mill's length), and energies by
(L_ref / L) x (T_ref / T), T the block length: the energy of eq. (11) grows in proportion to
the block length for a stationary signal, and in proportion to the drum length for torque
noise from independent impacts along the axis (the aliased impact noise that dominates
instantaneous samples). Per-unit energies and the slope a need no scaling.

**Cost.** ``wall_s`` is the wall-clock time of one run (engine set-up, filling, settling, the
warm-up and the block; the mean over the seeds), ``particle_steps`` the particles x the time
steps of that run, settling included. With several load levels a setting's cost is the sum over
its levels (one run per level, as a campaign needs).

Units: s, m, N m, (N m)^2 s; errors and spreads are dimensionless fractions of the reference's
seed mean.
"""

from __future__ import annotations

import csv
import dataclasses
import io
import math
import os
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from numbers import Integral
from pathlib import Path
from types import MappingProxyType
from typing import Any

import numpy as np

from .. import _checks
from .._files import atomic_write
from ..calibration.logfit import log_fit, per_unit
from ..model.contact import MAX_DT_FRACTION
from ..model.presets import LOAD_LEVELS, PARTICLE_KINDS, SCALES, pilot_mill
from ..model.scene import Scene
from ..signal.analysis import WINDOWS, AnalysisSettings
from ..signal.record import TorqueRecord
from ..signal.spectral import LTH_CLEAR_BINS, lifter_harmonic_hz
from .cases import MAX_DURATION_S, Case, CaseResult, RunSettings
from .runs import Campaign

__all__ = [
    "KNOBS",
    "QUANTITIES",
    "QuantityError",
    "Setting",
    "SettingSummary",
    "StudyPlan",
    "StudyResult",
    "StudyRow",
    "StudyRun",
    "run_study",
]

#: The knobs a :class:`Setting` turns, in the order tables show them.
KNOBS: tuple[str, ...] = ("dt_fraction", "shear_modulus_factor", "record_s", "warm_up_s",
                          "sampling", "scale")
#: The quantities a study compares, with the unit of their values.
QUANTITIES: Mapping[str, str] = MappingProxyType({"mean_torque": "N m", "energy": "(N m)^2 s",
                                                   "lth_amplitude": "N m", "slope_a": ""})
SAMPLINGS = ("instant", "mean")
#: What a setting's cost is measured in: wall-clock s or particle-steps, per run.
COSTS = ("wall_s", "particle_steps")


# -- settings ----------------------------------------------------------------------------------


@dataclass(frozen=True)
class Setting:
    """One rung of a study's ladder: how a run is made. Validated on construction.

    Attributes
    ----------
    dt_fraction : float
        Time step / the smallest Rayleigh time of the charge, in (0, 0.5] (the engine's cap);
        the engine's default is 0.2. A case whose contacts set a lower limit is refused when
        the plan is built (:func:`millscope.stiffness.time_step_limit`: about 0.3 at the
        ``"tiny"`` scale). Issue range: 0.05 to 0.5.
    shear_modulus_factor : float or None
        Every material's shear modulus as a fraction of the paper's (Table 2), in (0, 1]; None
        keeps the scale's own (1 at ``"paper"``, 0.01 at ``"small"``, 0.001 at ``"tiny"`` and
        ``"soft"``). A softer charge allows a longer time step (the Rayleigh time grows as
        1 / sqrt(G)).
    record_s : float
        Length of the analysed block, s, > 0 (the paper's: 10 s); warm-up and block together
        at most ``MAX_DURATION_S`` (3600 s).
    warm_up_s : float
        Rotation before the block, s, >= 0 (the paper's: 4 s). The block is
        ``warm_up_s <= t < warm_up_s + record_s``, time from the start of rotation.
    sampling : {"instant", "mean"}
        Torque samples: the instantaneous value (as the paper) or the mean over each interval.
    scale : str
        A scale of :data:`millscope.presets.SCALES`: the drum (whole mill or axial slice),
        the counts and the scale's stiffness.
    """

    dt_fraction: float = 0.2
    shear_modulus_factor: float | None = None
    record_s: float = 4.0
    warm_up_s: float = 2.0
    sampling: str = "instant"
    scale: str = "tiny"

    def __post_init__(self) -> None:
        dt = _checks.real("Setting.dt_fraction", self.dt_fraction, "",
                          f"in (0, {MAX_DT_FRACTION:g}] (time step / Rayleigh time)")
        if not 0.0 < dt <= MAX_DT_FRACTION:
            raise _checks.fail("Setting.dt_fraction", self.dt_fraction,
                               f"in (0, {MAX_DT_FRACTION:g}] (time step / Rayleigh time; "
                               f"{MAX_DT_FRACTION:g} is the engine's cap)")
        g = self.shear_modulus_factor
        if g is not None:
            valid = "in (0, 1] (a fraction of the paper's shear moduli) or None (the scale's own)"
            g = _checks.real("Setting.shear_modulus_factor", g, "", valid)
            if not 0.0 < g <= 1.0:
                raise _checks.fail("Setting.shear_modulus_factor", self.shear_modulus_factor, valid)
        why = f"warm-up and block together are at most {MAX_DURATION_S:g} s of rotation"
        warm = _checks.between("Setting.warm_up_s", self.warm_up_s, 0.0, MAX_DURATION_S, "s",
                               why=why)
        record = _checks.between("Setting.record_s", self.record_s, 0.0, MAX_DURATION_S - warm,
                                 "s", low_open=True, why=why)
        values = {
            "dt_fraction": dt,
            "shear_modulus_factor": g,
            "record_s": record,
            "warm_up_s": warm,
            "sampling": _checks.choice("Setting.sampling", self.sampling, SAMPLINGS),
            "scale": _checks.choice("Setting.scale", self.scale, tuple(SCALES)),
        }
        for name, value in values.items():
            object.__setattr__(self, name, value)

    @property
    def label(self) -> str:
        """A short description, e.g. ``"dt 0.2 T_R, G x0.01, tiny, 2+4 s, instant"``."""
        g = "G of scale" if self.shear_modulus_factor is None else \
            f"G x{self.shear_modulus_factor:g}"
        return (f"dt {self.dt_fraction:g} T_R, {g}, {self.scale}, "
                f"{self.warm_up_s:g}+{self.record_s:g} s, {self.sampling}")

    @property
    def duration_s(self) -> float:
        """Rotation simulated per run, warm-up and block, s."""
        return self.warm_up_s + self.record_s

    def replace(self, **changes: Any) -> Setting:
        """A copy with some knobs changed, validated again."""
        return dataclasses.replace(self, **changes)

    def to_dict(self) -> dict[str, Any]:
        """The knobs as plain data (``shear_modulus_factor`` may be None)."""
        return dataclasses.asdict(self)


# -- the plan ----------------------------------------------------------------------------------


def _integers(where: str, value: object, valid: str, ok: Any) -> tuple[int, ...]:
    """A non-empty tuple of distinct integers each passing ``ok``, else ValueError."""
    items = [value] if isinstance(value, Integral) else value
    if isinstance(items, (str, bytes)) or not isinstance(items, Iterable):
        raise _checks.fail(where, value, valid)
    out = tuple(items)
    if (not out or len(set(out)) != len(out)
            or not all(isinstance(v, Integral) and not isinstance(v, (bool, np.bool_)) and ok(v)
                       for v in out)):
        raise _checks.fail(where, value, valid)
    return tuple(int(v) for v in out)


@dataclass(frozen=True)
class StudyPlan:
    """What a study runs: settings, the reference, the seeds and the case of the pilot mill.

    Everything is checked on construction, before any work: bad values raise ``ValueError``
    naming the field, the value and the valid range, and every case is built (a time step or
    sampling interval that does not suit a scene is refused here).

    Attributes
    ----------
    settings : tuple of Setting
        The ladder, at least 2 settings, no two alike (nor two that run the same cases, e.g.
        ``scale="tiny"`` and ``scale="tiny", shear_modulus_factor=0.001``).
    reference : Setting or None
        The setting the others are compared against; it must be one of ``settings``. None
        (the default) takes the most expensive: the most particle-steps of rotation planned
        (particles x (warm-up + block) / dt, summed over the load levels); on a tie the one
        with ``sampling="mean"`` (anti-aliased), then the first listed. After construction it
        is always a Setting.
    seeds : tuple of int
        Filling seeds, >= 0, at least 2 different ones: each setting runs once per seed and
        load level, and the seed-to-seed spread is what tells noise from bias.
    speed_fraction : float
        Rotation speed as a fraction of critical, in (0, 1]; the paper's 0.62, 0.71, 0.80.
    particles : {"ceramic", "steel"} or None
        Particles to grind (LD, HD), or None for balls only.
    load_levels : tuple of int
        Table 5's levels 1..7; (1,) for balls only. With 2 or more, each seed's energies are
        made per unit and fitted with y = a ln(x) + b, and the slope a is compared as well.
    sample_dt : float
        Torque sampling interval, s (0.01 as the paper); the LTH must lie below the Nyquist
        frequency and the interval must not be shorter than any setting's time step.
    threads : int
        Engine threads per run, >= 1 (1 uses 2 cores best with 2 runs at a time, and is how
        costs are compared).
    bandwidth : float
        Full width of the bands removed around the mean and the LTH, Hz, > 0.
    window : {"hann", "hann_periodic", "rectangular"}
        Window of the spectral analysis.
    """

    settings: tuple[Setting, ...]
    reference: Setting | None = None
    seeds: tuple[int, ...] = (0, 1, 2)
    speed_fraction: float = 0.71
    particles: str | None = None
    load_levels: tuple[int, ...] = (1,)
    sample_dt: float = 0.01
    threads: int = 1
    bandwidth: float = 0.3
    window: str = "hann"
    _cases: tuple[tuple[int, int, int, Case], ...] = field(init=False, repr=False,
                                                           compare=False)

    def __post_init__(self) -> None:
        settings = self.settings
        if isinstance(settings, Setting) or not isinstance(settings, Iterable):
            raise _checks.fail("StudyPlan.settings", settings, "a sequence of at least 2 Setting")
        settings = tuple(settings)
        for k, s in enumerate(settings):
            if not isinstance(s, Setting):
                raise _checks.fail(f"StudyPlan.settings[{k}]", s, "a Setting")
        if len(settings) < 2:
            raise _checks.fail("StudyPlan.settings", settings, "a sequence of at least 2 Setting "
                               "(a reference and one to compare with it)")
        for k, s in enumerate(settings):
            if s in settings[:k]:
                raise ValueError(f"StudyPlan.settings[{k}] = {s.label!r} is not valid; it "
                                 f"repeats settings[{settings.index(s)}] (settings must differ)")
        seeds = _integers("StudyPlan.seeds", self.seeds,
                          "at least 2 different integers >= 0 (the seed spread needs 2)",
                          lambda v: v >= 0)
        if len(seeds) < 2:
            raise _checks.fail("StudyPlan.seeds", self.seeds,
                               "at least 2 different integers >= 0 (the seed spread needs 2)")
        speed = _checks.real("StudyPlan.speed_fraction", self.speed_fraction, "", "in (0, 1]")
        if not 0.0 < speed <= 1.0:
            raise _checks.fail("StudyPlan.speed_fraction", self.speed_fraction,
                               "in (0, 1] (a fraction of the critical speed; the paper's are 0.62, "
                               "0.71, 0.80)")
        if self.particles is not None and (not isinstance(self.particles, str)
                                           or self.particles not in PARTICLE_KINDS):
            raise _checks.fail("StudyPlan.particles", self.particles,
                               f"one of {', '.join(repr(k) for k in PARTICLE_KINDS)} or None "
                               "(balls only)")
        if self.particles is None:
            levels = _integers("StudyPlan.load_levels", self.load_levels,
                               "(1,) for balls only (particles=None)", lambda v: v == 1)
        else:
            levels = tuple(sorted(_integers(
                "StudyPlan.load_levels", self.load_levels,
                "distinct integers in 1..7 (paper Table 5)", lambda v: v in LOAD_LEVELS)))
        values: dict[str, Any] = {
            "settings": settings, "seeds": seeds, "speed_fraction": speed,
            "load_levels": levels,
            "sample_dt": _checks.positive("StudyPlan.sample_dt", self.sample_dt, "s"),
            "bandwidth": _checks.positive("StudyPlan.bandwidth", self.bandwidth, "Hz"),
            "window": _checks.choice("StudyPlan.window", self.window, tuple(WINDOWS)),
        }
        if (not isinstance(self.threads, Integral) or isinstance(self.threads, bool)
                or self.threads < 1):
            raise _checks.fail("StudyPlan.threads", self.threads, "an integer >= 1")
        values["threads"] = int(self.threads)
        for name, value in values.items():
            object.__setattr__(self, name, value)
        self._check_blocks()
        cases = self._build_cases()
        object.__setattr__(self, "_cases", cases)
        object.__setattr__(self, "reference", self._choose_reference())

    def _check_blocks(self) -> None:
        scene = pilot_mill(self.speed_fraction)
        lifters = scene.drum.lifters
        assert lifters is not None  # the pilot mill has lifters
        f_lth = lifter_harmonic_hz(lifters.count, scene.rotation_hz)
        nyquist = 0.5 / self.sample_dt
        if f_lth >= nyquist:
            raise _checks.fail(
                "StudyPlan.sample_dt", self.sample_dt,
                f"< {0.5 / f_lth:.6g} s so that the LTH at {f_lth:.4g} Hz lies below the "
                "Nyquist frequency", "s")
        shortest = LTH_CLEAR_BINS / f_lth
        for k, s in enumerate(self.settings):
            if s.record_s < shortest:
                raise _checks.fail(
                    f"StudyPlan.settings[{k}].record_s", s.record_s,
                    f">= {shortest:.3g} s at {self.speed_fraction:g} of critical speed, "
                    f"{LTH_CLEAR_BINS:g} periods of the LTH ({f_lth:.3g} Hz), so that "
                    "the LTH is resolved apart from the mean", "s")
            for name in ("record_s", "warm_up_s"):
                value = getattr(s, name)
                samples = value / self.sample_dt
                if abs(samples - round(samples)) > 1e-6 * max(1.0, samples):
                    raise _checks.fail(
                        f"StudyPlan.settings[{k}].{name}", value,
                        f"a whole number of samples of sample_dt = {self.sample_dt:g} s",
                        "s")

    def scene(self, setting: Setting, load_level: int) -> Scene:
        """The scene a setting runs at a load level.

        :func:`~millscope.presets.pilot_mill` at the setting's scale; with a
        ``shear_modulus_factor``, its materials are replaced by the paper-scale ones, each with
        the shear modulus x that factor (:meth:`~millscope.scene.Material.with_shear_modulus`,
        the mechanism the scales use).

        Parameters
        ----------
        setting : Setting
        load_level : int
            One of ``load_levels``.

        Returns
        -------
        Scene
        """
        scene = pilot_mill(self.speed_fraction, self.particles, load_level, setting.scale)
        if setting.shear_modulus_factor is None:
            return scene
        paper = pilot_mill(self.speed_fraction, self.particles, load_level, "paper")
        by_name = {m.name: m for m in paper.materials}
        materials = tuple(by_name[m.name].with_shear_modulus(setting.shear_modulus_factor)
                          for m in scene.materials)
        return scene.replace(materials=materials)

    def _build_cases(self) -> tuple[tuple[int, int, int, Case], ...]:
        out: list[tuple[int, int, int, Case]] = []
        owner: dict[str, int] = {}
        for k, s in enumerate(self.settings):
            for level in self.load_levels:
                scene = self.scene(s, level)
                dt = s.dt_fraction * scene.min_rayleigh_time()[0]
                if self.sample_dt < dt:
                    raise _checks.fail(
                        "StudyPlan.sample_dt", self.sample_dt,
                        f">= the time step {dt:.6g} s of settings[{k}] ({s.label}) at "
                        f"load level {level}", "s")
                for seed in self.seeds:
                    settings = RunSettings(seed=seed, duration_s=s.duration_s,
                                           warm_up_s=s.warm_up_s, sample_dt=self.sample_dt,
                                           sampling=s.sampling, threads=self.threads, dt=dt)
                    case = Case(scene, settings)
                    digest = case.hash()
                    if digest in owner and owner[digest] != k:
                        j = owner[digest]
                        raise ValueError(
                            f"StudyPlan.settings[{k}] = {s.label!r} is not valid; it runs the "
                            f"same cases as settings[{j}] = {self.settings[j].label!r} (the "
                            "same scene, time step and sampling): leave one out")
                    owner[digest] = k
                    out.append((k, level, seed, case))
        return tuple(out)

    def _choose_reference(self) -> Setting:
        ref = self.reference
        if ref is not None:
            if not isinstance(ref, Setting) or ref not in self.settings:
                raise _checks.fail("StudyPlan.reference", ref,
                                   "None (the most expensive setting) or one of the settings")
            return ref
        costs = [self.planned_particle_steps(s) for s in self.settings]
        top = max(costs)
        tied = [s for s, c in zip(self.settings, costs, strict=True)
                if math.isclose(c, top, rel_tol=1e-9)]
        return next((s for s in tied if s.sampling == "mean"), tied[0])

    # -- facts ---------------------------------------------------------------------------------
    @property
    def reference_index(self) -> int:
        """Index of the reference in ``settings``."""
        assert self.reference is not None  # chosen on construction
        return self.settings.index(self.reference)

    def cases(self) -> list[Case]:
        """Every case of the study (setting x load level x seed), in that order."""
        return [c for _, _, _, c in self._cases]

    def planned_particle_steps(self, setting: Setting) -> float:
        """Particles x time steps of the rotation (warm-up and block) one seed of ``setting``
        runs, summed over the load levels; settling, which only the run tells, is not
        counted."""
        total = 0.0
        for k, _, seed, case in self._cases:
            if self.settings[k] == setting and seed == self.seeds[0]:
                dt = case.settings.dt
                assert dt is not None  # set for every case of a study
                total += case.scene.n_particles * setting.duration_s / dt
        return total

    # -- ladders -------------------------------------------------------------------------------
    @classmethod
    def ladder(cls, knob: str, values: Sequence[Any], *, base: Setting | None = None,
               **fields: Any) -> StudyPlan:
        """A one-knob ladder: ``base`` with ``knob`` set to each of ``values``.

        Parameters
        ----------
        knob : str
            One of :data:`KNOBS`.
        values : sequence
            The knob's values, at least 2.
        base : Setting, optional
            The other knobs (default ``Setting()``).
        **fields
            Further :class:`StudyPlan` fields (``seeds``, ``particles``, ``reference`` ...).

        Returns
        -------
        StudyPlan
        """
        base = _base(base)
        _knob(knob)
        items = _values(f"StudyPlan.ladder {knob} values", values)
        return cls(tuple(base.replace(**{knob: v}) for v in items), **fields)

    @classmethod
    def around(cls, reference: Setting, ladders: Mapping[str, Sequence[Any]], *,
               extra: Sequence[Setting] = (), combine: bool = False,
               **fields: Any) -> StudyPlan:
        """The reference and, knob by knob, the reference with that one knob changed.

        Every error is against the one reference, so the settings of all ladders can be
        compared (and form one Pareto front); give the reference the most accurate value of
        each knob the study varies.

        Parameters
        ----------
        reference : Setting
            The reference setting.
        ladders : mapping of str to sequence
            Knob (:data:`KNOBS`) -> its other values; a value equal to the reference's is
            skipped.
        extra : sequence of Setting
            Further settings, e.g. several knobs changed at once.
        combine : bool
            Also run the cheapest values together: the reference with, for every knob, the
            ladder value that plans the fewest particle-steps (where it plans fewer than the
            reference's value; the sampling never does).
        **fields
            Further :class:`StudyPlan` fields (not ``reference``).

        Returns
        -------
        StudyPlan
        """
        reference = _base(reference)
        if "reference" in fields:
            raise _checks.fail("StudyPlan.around reference", fields["reference"],
                               "given once, as the first argument")
        if not isinstance(ladders, Mapping):
            raise _checks.fail("StudyPlan.around ladders", ladders,
                               "a mapping of knob name to its values")
        settings = [reference]
        for knob, values in ladders.items():
            _knob(knob)
            for v in _values(f"StudyPlan.around ladders[{knob!r}]", values, least=1):
                s = reference.replace(**{knob: v})
                if s not in settings:
                    settings.append(s)
        for k, s in enumerate(extra):
            if not isinstance(s, Setting):
                raise _checks.fail(f"StudyPlan.around extra[{k}]", s, "a Setting")
            if s not in settings:
                settings.append(s)
        plan = cls(tuple(settings), reference=reference, **fields)
        if not combine:
            return plan
        cheapest: dict[str, Any] = {}
        for knob in ladders:  # the reference and its rungs on this knob's ladder
            rungs = [s for s in plan.settings
                     if s == reference.replace(**{knob: getattr(s, knob)})]
            best = min(rungs, key=plan.planned_particle_steps)
            if plan.planned_particle_steps(best) < plan.planned_particle_steps(reference):
                cheapest[knob] = getattr(best, knob)
        together = reference.replace(**cheapest)
        if len(cheapest) < 2 or together in plan.settings:
            return plan
        return cls((*plan.settings, together), reference=reference, **fields)

    def to_dict(self) -> dict[str, Any]:
        """The plan as plain data."""
        return {"settings": [s.to_dict() for s in self.settings],
                "reference": self.reference_index, "seeds": list(self.seeds),
                "speed_fraction": self.speed_fraction, "particles": self.particles,
                "load_levels": list(self.load_levels), "sample_dt": self.sample_dt,
                "threads": self.threads, "bandwidth": self.bandwidth, "window": self.window}


def _base(base: object) -> Setting:
    if base is None:
        return Setting()
    if not isinstance(base, Setting):
        raise _checks.fail("base", base, "a Setting")
    return base


def _knob(knob: object) -> str:
    return _checks.choice("knob", knob, KNOBS)


def _values(where: str, values: object, least: int = 2) -> list[Any]:
    if isinstance(values, (str, bytes)) or not isinstance(values, Iterable):
        raise _checks.fail(where, values, f"a sequence of at least {least} values")
    items = list(values)
    if len(items) < least:
        raise _checks.fail(where, values, f"a sequence of at least {least} values")
    return items


# -- results -----------------------------------------------------------------------------------


@dataclass(frozen=True)
class StudyRun:
    """One run of a study (a campaign case): what it cost and what its block gives.

    Attributes
    ----------
    setting : int
        Index of the setting in the plan.
    load_level : int
        Table 5's level.
    seed : int
        Filling seed.
    hash : str
        The campaign case's hash: its record is ``<store>/cases/<hash>.npz``.
    wall_s : float
        Wall-clock time of the run (set-up, filling, settling, warm-up, block), s.
    particle_steps : float
        Particles x time steps of the run, settling included.
    n_particles : int
        Spheres in the charge.
    dt_s : float
        Time step, s.
    length_m : float
        Drum length, m.
    block_s : float
        Length of the analysed block, N samples x sample_dt, s.
    mean_torque, lth_amplitude, energy : float
        Of the block as the campaign analyses it: N m, N m, (N m)^2 s (not normalised).
    """

    setting: int
    load_level: int
    seed: int
    hash: str
    wall_s: float
    particle_steps: float
    n_particles: int
    dt_s: float
    length_m: float
    block_s: float
    mean_torque: float
    lth_amplitude: float
    energy: float

    def value(self, quantity: str, length_m: float, block_s: float) -> float:
        """``quantity`` of this run on the footing of a run of drum length ``length_m`` (m)
        and block ``block_s`` (s): torques x L_ref / L, energies x (L_ref / L) (T_ref / T)."""
        length = length_m / self.length_m
        if quantity == "energy":
            return self.energy * length * (block_s / self.block_s)
        return float(getattr(self, quantity)) * length


@dataclass(frozen=True)
class QuantityError:
    """One quantity of one row: its seed statistics and its error against the reference.

    Attributes
    ----------
    mean : float
        Mean over the seeds, on the reference's footing (see the module docstring); in the
        quantity's unit (:data:`QUANTITIES`).
    std : float
        Standard deviation over the seeds (ddof 1), same unit.
    error : float
        (mean - reference mean) / |reference mean|: the relative error of the seed mean,
        signed; 0 for the reference.
    spread : float
        std / |reference mean|: the relative scatter of one run.
    error_se : float
        Standard error of ``error`` from the seed noise of both means,
        sqrt(std^2 / n + std_ref^2 / n_ref) / |reference mean|; 0 for the reference (which
        is compared with itself).
    """

    mean: float
    std: float
    error: float
    spread: float
    error_se: float


@dataclass(frozen=True)
class StudyRow:
    """One row of the table: a setting at one load level.

    Attributes
    ----------
    setting : Setting
    reference : bool
        True for the reference setting's rows.
    load_level : int
    n_particles : int
    dt_s : float
        Time step, s.
    shear_modulus_ratio : float
        The shear modulus used / the paper's (the setting's factor, or the scale's own).
    length_m : float
        Drum length, m.
    seeds : int
        Runs (seeds) behind the statistics.
    wall_s : float
        Wall-clock time of one run, s (mean over the seeds).
    particle_steps : float
        Particles x time steps of one run, settling included (mean over the seeds).
    quantities : mapping of str to QuantityError
        ``"mean_torque"``, ``"energy"``, ``"lth_amplitude"`` and ``"slope_a"`` (the slope
        is a property of the setting, the same on each of its levels; nan entries with one
        load level).
    """

    setting: Setting
    reference: bool
    load_level: int
    n_particles: int
    dt_s: float
    shear_modulus_ratio: float
    length_m: float
    seeds: int
    wall_s: float
    particle_steps: float
    quantities: Mapping[str, QuantityError]

    @property
    def label(self) -> str:
        return self.setting.label


@dataclass(frozen=True)
class SettingSummary:
    """A setting as one point of the error-against-cost plane (all load levels together).

    Attributes
    ----------
    setting : Setting
    reference : bool
    cost : float
        Summed over the load levels: s of wall-clock time or particle-steps per seed.
    error : float
        The largest |error| over the load levels (dimensionless).
    error_se : float
        The standard error at that level.
    spread : float
        The seed spread at that level.
    """

    setting: Setting
    reference: bool
    cost: float
    error: float
    error_se: float
    spread: float


_NAN_ERROR = QuantityError(math.nan, math.nan, math.nan, math.nan, math.nan)


def _statistics(values: Sequence[float], ref_values: Sequence[float],
                is_reference: bool) -> QuantityError:
    """Seed mean and spread of ``values`` and their error against ``ref_values``."""
    v = np.asarray(values, dtype=np.float64)
    r = np.asarray(ref_values, dtype=np.float64)
    if v.size == 0 or not np.all(np.isfinite(v)) or not np.all(np.isfinite(r)):
        return _NAN_ERROR
    mean, ref_mean = float(v.mean()), float(r.mean())
    std = float(v.std(ddof=1)) if v.size > 1 else math.nan
    ref_std = float(r.std(ddof=1)) if r.size > 1 else math.nan
    scale = abs(ref_mean)
    if scale == 0.0:
        return QuantityError(mean, std, math.nan, math.nan, math.nan)
    if is_reference:
        return QuantityError(mean, std, 0.0, std / scale, 0.0)
    se = math.sqrt(std**2 / v.size + ref_std**2 / r.size) / scale
    return QuantityError(mean, std, (mean - ref_mean) / scale, std / scale, se)


@dataclass(frozen=True)
class StudyResult:
    """The table of a study, with its runs when it was run here (not when read from CSV).

    Attributes
    ----------
    rows : tuple of StudyRow
        By setting (plan order), then load level.
    plan : StudyPlan or None
        The plan (None when read from CSV).
    runs : tuple of StudyRun
        Every run (empty when read from CSV).
    store : Path or None
        The campaign store holding the runs' records.
    description : str
        The case studied, e.g. ``"balls-MS, 3 seeds, 0.71 of critical speed"``.
    """

    rows: tuple[StudyRow, ...]
    plan: StudyPlan | None = None
    runs: tuple[StudyRun, ...] = ()
    store: Path | None = None
    description: str = ""

    @classmethod
    def from_runs(cls, plan: StudyPlan, runs: Iterable[StudyRun], *,
                  store: Path | None = None) -> StudyResult:
        """The table of a plan's runs (one per setting, load level and seed).

        Raises
        ------
        ValueError
            when a run is missing.
        """
        run_list = tuple(runs)
        by_key = {(r.setting, r.load_level, r.seed): r for r in run_list}
        for k in range(len(plan.settings)):
            for level in plan.load_levels:
                for seed in plan.seeds:
                    if (k, level, seed) not in by_key:
                        raise ValueError(f"runs lack setting {k} ({plan.settings[k].label}) at "
                                         f"load level {level}, seed {seed}")
        ref = plan.reference_index
        first_ref = by_key[(ref, plan.load_levels[0], plan.seeds[0])]
        length_ref, block_ref = first_ref.length_m, first_ref.block_s

        def values(k: int, level: int, quantity: str) -> list[float]:
            return [by_key[(k, level, s)].value(quantity, length_ref, block_ref)
                    for s in plan.seeds]

        def slopes(k: int) -> list[float]:
            if len(plan.load_levels) < 2:
                return []
            out = []
            for s in plan.seeds:
                energies = [by_key[(k, level, s)].energy for level in plan.load_levels]
                out.append(log_fit(plan.load_levels, per_unit(energies)).a)
            return out

        ref_slopes = slopes(ref)
        rows = []
        for k, setting in enumerate(plan.settings):
            slope = (_statistics(slopes(k), ref_slopes, k == ref)
                     if ref_slopes else _NAN_ERROR)
            for level in plan.load_levels:
                group = [by_key[(k, level, s)] for s in plan.seeds]
                stats = {q: _statistics(values(k, level, q), values(ref, level, q), k == ref)
                         for q in ("mean_torque", "energy", "lth_amplitude")}
                stats["slope_a"] = slope
                first = group[0]
                scene = plan.scene(setting, level)
                paper = pilot_mill(plan.speed_fraction, plan.particles, level, "paper")
                ratio = (scene.material(scene.drum.material).shear_modulus
                         / paper.material(paper.drum.material).shear_modulus)
                rows.append(StudyRow(
                    setting=setting, reference=k == ref, load_level=level,
                    n_particles=first.n_particles, dt_s=first.dt_s,
                    shear_modulus_ratio=ratio, length_m=first.length_m, seeds=len(group),
                    wall_s=float(np.mean([r.wall_s for r in group])),
                    particle_steps=float(np.mean([r.particle_steps for r in group])),
                    quantities=stats))
        name = pilot_mill(plan.speed_fraction, plan.particles, plan.load_levels[0]).name
        if len(plan.load_levels) > 1:
            name = f"{name.split('#')[0]} #{', #'.join(str(v) for v in plan.load_levels)}"
        return cls(tuple(rows), plan, run_list, store,
                   f"{name}, {len(plan.seeds)} seeds, {plan.speed_fraction:g} of critical speed")

    # -- queries -------------------------------------------------------------------------------
    @property
    def settings(self) -> tuple[Setting, ...]:
        """The settings, in table order, each once."""
        return tuple(dict.fromkeys(r.setting for r in self.rows))

    @property
    def reference(self) -> Setting:
        """The reference setting."""
        return next(r.setting for r in self.rows if r.reference)

    def summary(self, quantity: str = "energy", cost: str = "wall_s") -> list[SettingSummary]:
        """Every setting as a point (cost, |error|), in table order.

        Parameters
        ----------
        quantity : str
            One of :data:`QUANTITIES`.
        cost : {"wall_s", "particle_steps"}
            Summed over the load levels.

        Returns
        -------
        list of SettingSummary
            The error is the largest |error| over the setting's load levels (nan when the
            quantity is not available, e.g. the slope with one level).
        """
        _checks.choice("quantity", quantity, tuple(QUANTITIES))
        _checks.choice("cost", cost, COSTS)
        out = []
        for s in self.settings:
            rows = [r for r in self.rows if r.setting == s]
            total = float(sum(getattr(r, cost) for r in rows))
            worst = max(rows, key=lambda r: (abs(r.quantities[quantity].error)
                                             if math.isfinite(r.quantities[quantity].error)
                                             else -1.0))
            q = worst.quantities[quantity]
            out.append(SettingSummary(s, worst.reference, total, abs(q.error), q.error_se,
                                      q.spread))
        return out

    def pareto(self, quantity: str = "energy", cost: str = "wall_s") -> tuple[Setting, ...]:
        """The settings on the Pareto front of cost against |error|, cheapest first.

        A setting is on the front when no other setting costs no more and errs no more, and
        is better in one of the two. Settings whose error is nan are left out.

        Parameters
        ----------
        quantity : str
            One of :data:`QUANTITIES`.
        cost : {"wall_s", "particle_steps"}

        Returns
        -------
        tuple of Setting
        """
        points = [p for p in self.summary(quantity, cost) if math.isfinite(p.error)]
        points.sort(key=lambda p: (p.cost, p.error))
        front: list[SettingSummary] = []
        best = math.inf
        for p in points:
            if p.error < best:
                front.append(p)
                best = p.error
            elif front and (p.cost, p.error) == (front[-1].cost, front[-1].error):
                front.append(p)  # equal to a point of the front: not dominated
        return tuple(p.setting for p in front)

    def cheapest(self, quantity: str = "energy", within: float = 0.05, *,
                 cost: str = "wall_s", with_se: bool = True) -> Setting | None:
        """The cheapest setting whose error stays within ``within``.

        Parameters
        ----------
        quantity : str
            One of :data:`QUANTITIES`.
        within : float
            Largest acceptable |error| (a fraction, e.g. 0.05 for 5 %).
        cost : {"wall_s", "particle_steps"}
        with_se : bool
            Require |error| + 2 standard errors <= ``within`` (the error is below the bound
            with about 97.5 % confidence), not just |error| <= ``within``.

        Returns
        -------
        Setting or None
            None when none qualifies.
        """
        bound = _checks.positive("within", within)
        ok = [p for p in self.summary(quantity, cost)
              if math.isfinite(p.error)
              and p.error + (2.0 * p.error_se if with_se else 0.0) <= bound]
        return min(ok, key=lambda p: p.cost).setting if ok else None

    def record(self, run: StudyRun) -> TorqueRecord:
        """The stored torque record of a run (after the warm-up; N m against s)."""
        if self.store is None:
            raise ValueError("this result has no store (it was read from CSV)")
        return TorqueRecord.load(self.store / "cases" / f"{run.hash}.npz")

    # -- tables --------------------------------------------------------------------------------
    def to_csv(self, path: str | os.PathLike[str] | None = None) -> str:
        """The table as CSV, one line per row (setting and load level); written atomically to
        ``path`` when given. Returns the text.

        Columns: ``label``, ``reference`` (1/0), the knobs (:data:`KNOBS`;
        ``shear_modulus_factor`` empty for the scale's own), ``load_level``,
        ``n_particles``, ``dt_s``, ``shear_modulus_ratio``, ``length_m``, ``seeds``,
        ``wall_s``, ``particle_steps``, then per quantity ``<q>``, ``<q>_std``,
        ``<q>_error``, ``<q>_spread``, ``<q>_error_se`` (:class:`QuantityError`), and
        ``description``. Floats are written exactly (``repr``).
        """
        buffer = io.StringIO()
        writer = csv.writer(buffer, lineterminator="\n")
        writer.writerow(_csv_columns())
        for r in self.rows:
            knobs = r.setting.to_dict()
            line: list[Any] = [r.label, int(r.reference)]
            line += ["" if knobs[k] is None else knobs[k] if isinstance(knobs[k], str)
                     else _plain(knobs[k]) for k in KNOBS]
            line += [r.load_level, r.n_particles, _plain(r.dt_s), _plain(r.shear_modulus_ratio),
                     _plain(r.length_m), r.seeds, _plain(r.wall_s), _plain(r.particle_steps)]
            for q in QUANTITIES:
                e = r.quantities[q]
                line += [_plain(e.mean), _plain(e.std), _plain(e.error), _plain(e.spread),
                         _plain(e.error_se)]
            line.append(self.description)
            writer.writerow(line)
        text = buffer.getvalue()
        if path is not None:
            with atomic_write(path, "w") as fh:
                fh.write(text)
        return text

    @classmethod
    def from_csv(cls, path: str | os.PathLike[str]) -> StudyResult:
        """A table written by :meth:`to_csv` (without plan, runs or store).

        Raises
        ------
        ValueError
            naming the file, for a missing column or a value that does not parse.
        """
        source = Path(path)
        try:
            text = source.read_text()
        except FileNotFoundError:
            raise ValueError(f"{source}: no such study table") from None
        reader = csv.DictReader(io.StringIO(text))
        missing = [c for c in _csv_columns() if c not in (reader.fieldnames or [])]
        if missing:
            raise ValueError(f"{source}: not a millscope study table; missing columns "
                             f"{missing}")
        rows, description = [], ""
        for n, line in enumerate(reader, start=2):
            try:
                knobs: dict[str, Any] = {k: line[k] for k in KNOBS}
                for k in ("dt_fraction", "record_s", "warm_up_s"):
                    knobs[k] = float(knobs[k])
                g = knobs["shear_modulus_factor"]
                knobs["shear_modulus_factor"] = None if g == "" else float(g)
                quantities = {q: QuantityError(*(float(line[c]) for c in _quantity_columns(q)))
                              for q in QUANTITIES}
                rows.append(StudyRow(
                    setting=Setting(**knobs), reference=line["reference"] == "1",
                    load_level=int(line["load_level"]), n_particles=int(line["n_particles"]),
                    dt_s=float(line["dt_s"]),
                    shear_modulus_ratio=float(line["shear_modulus_ratio"]),
                    length_m=float(line["length_m"]), seeds=int(line["seeds"]),
                    wall_s=float(line["wall_s"]), particle_steps=float(line["particle_steps"]),
                    quantities=quantities))
            except (TypeError, ValueError) as exc:
                raise ValueError(f"{source}, line {n}: {exc}") from None
            description = line["description"]
        if sum(r.reference for r in rows) == 0:
            raise ValueError(f"{source}: no row is marked as the reference")
        return cls(tuple(rows), description=description)

    def to_markdown(self, pareto_quantity: str = "energy") -> str:
        """The table in Markdown: per row the setting, its cost, and per quantity the error of
        the seed mean with the seed spread of one run, ``+3.1 % ± 2.0 %``; the reference row
        gives its seed means instead. Settings on the Pareto front of ``pareto_quantity``
        (cost: wall time) are marked with a ◆.
        """
        front = set(self.pareto(pareto_quantity))
        shown = [q for q in QUANTITIES
                 if any(math.isfinite(r.quantities[q].error) for r in self.rows)]
        multi = len({r.load_level for r in self.rows}) > 1
        names = {"mean_torque": "mean torque", "energy": "energy",
                 "lth_amplitude": "LTH amplitude", "slope_a": "slope a"}
        head = ["setting", *(["level"] if multi else []), "dt (s)", "G / paper's",
                "wall s / run", "particle-steps / run", *(names[q] for q in shown)]
        lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
        ref_row = next(r for r in self.rows if r.reference)
        for r in self.rows:
            mark = " ◆" if r.setting in front else ""
            label = f"**{r.label}** (reference){mark}" if r.reference else f"{r.label}{mark}"
            cells = [label, *([str(r.load_level)] if multi else []), f"{r.dt_s:.3g}",
                     f"{r.shear_modulus_ratio:g}", f"{r.wall_s:.3g}", f"{r.particle_steps:.3g}"]
            for q in shown:
                e = r.quantities[q]
                if r.reference:
                    cells.append(f"{e.mean:.4g} ± {100 * e.spread:.1f} %")
                elif math.isfinite(e.error):
                    cells.append(f"{100 * e.error:+.1f} % ± {100 * e.spread:.1f} %")
                else:
                    cells.append("-")
            lines.append("| " + " | ".join(cells) + " |")
        units = ", ".join(f"{names[q]} in {QUANTITIES[q]}" for q in shown if QUANTITIES[q])
        notes = [
            f"Study of {self.description or 'the pilot mill'}; reference: {ref_row.label}.",
            "",
            *lines,
            "",
            "Each cell: the relative error of the seed mean against the reference's seed mean, "
            "± the seed-to-seed spread of one run (standard deviation over the seeds), both "
            "in % of the reference; the reference row gives its seed means "
            f"({units}) ± its spread. An error within about 2 x spread x sqrt(2 / seeds) "
            "is not told apart from noise (the CSV gives each error's standard error). "
            "Torques are compared per length of drum and energies per length of drum and of "
            "block (see millscope.studies). Wall time: one run (engine set-up, filling, "
            "settling, warm-up and block) on the plan's engine threads. ◆: on the Pareto front "
            f"of wall time against the {names[pareto_quantity]} error.",
        ]
        return "\n".join(notes) + "\n"


def _plain(value: float) -> str:
    """A float as CSV text that reads back exactly."""
    return repr(float(value))


def _quantity_columns(quantity: str) -> tuple[str, ...]:
    return (quantity, f"{quantity}_std", f"{quantity}_error", f"{quantity}_spread",
            f"{quantity}_error_se")


def _csv_columns() -> list[str]:
    columns = ["label", "reference", *KNOBS, "load_level", "n_particles", "dt_s",
               "shear_modulus_ratio", "length_m", "seeds", "wall_s", "particle_steps"]
    for q in QUANTITIES:
        columns += _quantity_columns(q)
    return [*columns, "description"]


# -- running -----------------------------------------------------------------------------------


def _run_of(plan: StudyPlan, k: int, level: int, seed: int, result: CaseResult) -> StudyRun:
    """A finished case analysed as the campaign does, with what it cost."""
    setting = plan.settings[k]
    case = result.case
    analysis = AnalysisSettings((setting.warm_up_s, setting.duration_s), plan.bandwidth,
                                plan.window)
    assert result.record is not None  # done cases have a record
    analysed = CaseResult.from_record(case, result.record, analysis,
                                      wall_time_s=result.wall_time_s)
    # The kept samples are stamped warm-up + sample_dt .. duration (the end of their
    # intervals), so the campaign's block [warm-up, duration) holds one sample fewer than
    # the record: energies are compared per the block length actually analysed.
    block_s = result.record.block(*analysis.block).duration_s
    dt = result.record.meta["dt"]
    settle = result.record.meta.get("settle") or {}
    steps = round(float(settle.get("time_s", 0.0)) / dt) + round(case.settings.duration_s / dt)
    n = case.scene.n_particles
    return StudyRun(setting=k, load_level=level, seed=seed, hash=result.hash,
                    wall_s=float(result.wall_time_s), particle_steps=float(n * steps),
                    n_particles=n, dt_s=float(dt), length_m=case.scene.drum.length,
                    block_s=block_s, mean_torque=analysed.mean_torque,
                    lth_amplitude=analysed.lth_amplitude, energy=analysed.energy)


def run_study(plan: StudyPlan, store: str | os.PathLike[str], *, executor: Any = None,
              max_workers: int | None = None, progress: bool = True) -> StudyResult:
    """Runs a study's cases through a :class:`~millscope.campaign.Campaign` and tabulates them.

    The cases go to the campaign from the most expensive to the cheapest (so that the
    longest do not start last). The store keeps every finished case: a rerun of the same plan
    (or of a plan sharing cases) runs only what is missing, and reports the wall times the
    cases took when they ran.

    Parameters
    ----------
    plan : StudyPlan
    store : path
        The campaign store (a directory; created if needed).
    executor : optional
        A ``concurrent.futures`` executor or a ``dask.distributed`` Client
        (:meth:`Campaign.run`); None: a local process pool.
    max_workers : int, optional
        Processes of the local pool (only with ``executor=None``). Default 1: one case at a
        time, so that the measured wall times do not disturb each other.
    progress : bool
        Show the campaign's progress bar.

    Returns
    -------
    StudyResult

    Raises
    ------
    ValueError
        for a bad argument, before any work.
    RuntimeError
        when a case failed (the finished ones are kept in the store; a rerun retries).
    """
    if not isinstance(plan, StudyPlan):
        raise _checks.fail("plan", plan, "a StudyPlan")
    order = sorted(range(len(plan.cases())),
                   key=lambda i: -plan.planned_particle_steps(plan.settings[plan._cases[i][0]]))
    campaign = Campaign([plan._cases[i][3] for i in order], store, block=None)
    if executor is None and max_workers is None:
        max_workers = 1
    results = campaign.run(executor=executor, max_workers=max_workers, progress=progress)
    failed = [r for r in results if not r.ok]
    if failed:
        raise RuntimeError(f"{len(failed)} of {len(results)} runs failed, first "
                           f"{failed[0].case.name}: {failed[0].error}; see "
                           f"{campaign.store / 'manifest.json'} (a rerun retries them)")
    by_hash = {r.hash: r for r in results}
    runs = [_run_of(plan, k, level, seed, by_hash[case.hash()])
            for k, level, seed, case in plan._cases]
    return StudyResult.from_runs(plan, runs, store=campaign.store)

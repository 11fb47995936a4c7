"""The plan of a study of error against run time: the :class:`Setting` s (the knobs) and the
:class:`StudyPlan` (settings x load levels x seeds); see :mod:`millscope.campaign.studies`.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from numbers import Integral
from types import MappingProxyType
from typing import Any

import numpy as np

from .. import _checks
from ..engine.simulation import Sampling
from ..model.contact import MAX_DT_FRACTION
from ..model.presets import LOAD_LEVELS, PARTICLE_KINDS, SCALES, pilot_mill
from ..model.scene import Scene
from ..signal.analysis import WINDOWS
from ..signal.spectral import LTH_CLEAR_BINS, WindowName, lifter_harmonic_hz
from .cases import MAX_DURATION_S, SAMPLINGS, Case, RunSettings, rotation_particle_steps

__all__ = ["COSTS", "KNOBS", "LEVEL_QUANTITIES", "QUANTITIES", "Setting", "StudyPlan"]

#: The knobs a :class:`Setting` turns, in the order tables show them.
KNOBS: tuple[str, ...] = ("dt_fraction", "shear_modulus_factor", "record_s", "warm_up_s",
                          "sampling", "scale")
#: The quantities a study compares, with the unit of their values.
#: ``energy_ratio`` is the per-unit energy of the last load level, E(last) / E(first) of the
#: same seed (e.g. LDMS #4 / LDMS #1), the quantity the fill estimate reads; like ``slope_a``
#: it needs 2 or more load levels.
QUANTITIES: Mapping[str, str] = MappingProxyType({"mean_torque": "N m", "energy": "(N m)^2 s",
                                                   "lth_amplitude": "N m", "slope_a": "",
                                                   "energy_ratio": ""})
#: The quantities that compare load levels (nan with one level).
LEVEL_QUANTITIES: tuple[str, ...] = ("slope_a", "energy_ratio")
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
    sampling: Sampling = "instant"
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
    window: WindowName = "hann"
    _cases: tuple[tuple[int, int, int, Case], ...] = field(init=False, repr=False,
                                                           compare=False)
    _donors: tuple[int | None, ...] = field(init=False, repr=False, compare=False)

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
            "window": _checks.choice("StudyPlan.window", self.window, WINDOWS),
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
        object.__setattr__(self, "_donors", self._find_donors())
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

    def _find_donors(self) -> tuple[int | None, ...]:
        """For each case, the case with the longest block whose record holds its block."""
        out: list[int | None] = []
        for k, level, seed, _ in self._cases:
            own = self.settings[k]
            longer = [(self.settings[k2].record_s, j)
                      for j, (k2, level2, seed2, _) in enumerate(self._cases)
                      if (level2, seed2) == (level, seed)
                      and self.settings[k2].record_s > own.record_s
                      and self.settings[k2] == own.replace(record_s=self.settings[k2].record_s)]
            out.append(max(longer)[1] if longer else None)
        return tuple(out)

    def donor(self, index: int) -> int | None:
        """The case whose record holds case ``index``'s block, or None.

        A setting that differs from another only by a shorter block (``record_s``) runs
        nothing: the engine is deterministic and samples a run the same whether it goes on
        or stops, so the first ``warm_up_s + record_s`` s of the longer run (same scene,
        seed, time step, sampling and warm-up) are exactly the shorter run. Its block is cut
        from the longest such run (``millscope.campaign.studies``).

        Parameters
        ----------
        index : int
            Index into :meth:`cases`.

        Returns
        -------
        int or None
            Index into :meth:`cases` of the donor (never itself derived), or None when the
            case runs.
        """
        return self._donors[index]

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
        return sum(self.case_particle_steps(i) for i, (k, _, seed, _) in enumerate(self._cases)
                   if self.settings[k] == setting and seed == self.seeds[0])

    def case_particle_steps(self, index: int) -> float:
        """Particles x time steps of the rotation (warm-up and block) case ``index`` of
        :meth:`cases` runs; settling is not counted."""
        return rotation_particle_steps(self._cases[index][3])

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
        """The plan as plain data (JSON-ready; :meth:`from_dict` reads it back)."""
        return {"settings": [s.to_dict() for s in self.settings],
                "reference": self.reference_index, "seeds": list(self.seeds),
                "speed_fraction": self.speed_fraction, "particles": self.particles,
                "load_levels": list(self.load_levels), "sample_dt": self.sample_dt,
                "threads": self.threads, "bandwidth": self.bandwidth, "window": self.window}

    @classmethod
    def from_dict(cls, data: object, where: str = "study plan") -> StudyPlan:
        """The plan :meth:`to_dict` wrote, validated as on construction.

        Parameters
        ----------
        data : mapping
            As :meth:`to_dict` returns it (read from an untrusted file: every field is
            checked).
        where : str
            Where the data came from, for error messages (e.g. a file name).

        Raises
        ------
        ValueError
            naming ``where`` and the field, for anything missing or out of range.
        """
        fields = ("settings", "reference", "seeds", "speed_fraction", "particles",
                  "load_levels", "sample_dt", "threads", "bandwidth", "window")
        if not isinstance(data, Mapping) or set(data) != set(fields):
            raise ValueError(f"{where} is not valid; it must be a mapping with exactly the "
                             f"fields {', '.join(fields)}")
        raw = data["settings"]
        if not isinstance(raw, list) or not all(isinstance(s, Mapping) for s in raw):
            raise ValueError(f"{where}: settings is not valid; it must be a list of mappings")
        try:
            settings = tuple(Setting(**s) for s in raw)
        except TypeError as exc:
            raise ValueError(f"{where}: settings is not valid; {exc}") from None
        ref = data["reference"]
        if (not isinstance(ref, int) or isinstance(ref, bool)
                or not 0 <= ref < len(settings)):
            raise ValueError(f"{where}: reference = {ref!r} is not valid; it must be an index "
                             f"into settings, 0..{len(settings) - 1}")
        rest = {k: data[k] for k in fields if k not in ("settings", "reference")}
        for k in ("seeds", "load_levels"):
            if isinstance(rest[k], list):
                rest[k] = tuple(rest[k])
        return cls(settings, reference=settings[ref], **rest)


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

"""Cases: a scene plus how to run it (:class:`RunSettings`, :class:`Case`), their matrices,
and a case's result (:class:`CaseResult`).

All quantities are SI (s, N m, Hz, (N m)^2 s).
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from numbers import Integral
from typing import Any, Literal, get_args

from .. import _checks
from ..engine.simulation import Sampling, Simulation
from ..model.presets import CaseKey, case_key, paper_cases
from ..model.scene import Scene
from ..model.stiffness import time_step_limit
from ..signal.analysis import AnalysisSettings, analyze_block
from ..signal.record import TorqueRecord
from ..signal.spectral import spectral_energy

__all__ = [
    "CASE_FORMAT",
    "MAX_DURATION_S",
    "Case",
    "CaseResult",
    "RunSettings",
    "case_matrix",
    "distinct_runs",
    "paper_matrix",
    "rotation_particle_steps",
    "run_particle_steps",
]

CASE_FORMAT = "millscope-case-1"  # part of every case hash: bump it when results change meaning
SAMPLINGS: tuple[Sampling, ...] = get_args(Sampling)
_MIN_BLOCK_SAMPLES = 4  # the spectral analysis needs at least this many
Status = Literal["done", "failed", "pending"]


# -- cases -------------------------------------------------------------------------------------


#: The longest rotation a case may simulate, s: an hour, 360,000 torque samples at 10 ms and
#: some 17 CPU hours at the smallest preset scale (17 s of CPU per simulated second). Longer
#: runs are refused before any work starts, rather than running for ever.
MAX_DURATION_S = 3600.0


@dataclass(frozen=True)
class RunSettings:
    """How one case is run (everything but the scene). Validated on construction.

    Attributes
    ----------
    seed : int
        Seed of the filling, >= 0 (:class:`~millscope.simulation.Simulation`).
    duration_s : float
        Simulated time after the drum starts, s, in (0, ``MAX_DURATION_S``] = (0, 3600]: the
        record ends here (record time 0 is the start of rotation). Rounded to whole samples.
    warm_up_s : float
        The first ``warm_up_s`` s of rotation are simulated but not kept, s, in
        [0, duration_s); at least 2 samples must remain. 0 keeps the whole run.
    sample_dt : float
        Sampling interval, s, > 0 (and >= the time step); 0.01 s in the paper.
    sampling : {"instant", "mean"}
        Instantaneous torque at each sample time (as the paper) or the mean over the interval.
    threads : int
        OpenMP threads of the engine for this case, >= 1. Runs are bit-for-bit reproducible
        at a given thread count, so it is part of the case.
    dt : float or None
        Time step, s; None: 0.2 x the smallest Rayleigh time of the scene.
    settle_tolerance : float
        The charge counts as settled when 99 % of the particles have a kinetic energy below
        this x m g d (dimensionless, > 0).
    settle_min_s, settle_max_s : float
        Least and most simulated settling time before rotation, s, > 0.
    """

    seed: int = 0
    duration_s: float = 14.0
    warm_up_s: float = 0.0
    sample_dt: float = 0.01
    sampling: Sampling = "instant"
    threads: int = 1
    dt: float | None = None
    settle_tolerance: float = 1e-4
    settle_min_s: float = 0.2
    settle_max_s: float = 3.0

    def __post_init__(self) -> None:
        values: dict[str, Any] = {
            "seed": _checks.integer("RunSettings.seed", self.seed, ValueError, low=0),
            "duration_s": _checks.between("RunSettings.duration_s", self.duration_s, 0.0,
                                          MAX_DURATION_S, "s", low_open=True,
                                          why="the longest rotation a case simulates"),
            "sample_dt": _checks.positive("RunSettings.sample_dt", self.sample_dt, "s"),
            "sampling": _checks.choice("RunSettings.sampling", self.sampling, SAMPLINGS),
            "threads": _checks.integer("RunSettings.threads", self.threads, ValueError, low=1),
            "dt": None if self.dt is None else _checks.positive("RunSettings.dt", self.dt, "s"),
            "settle_tolerance": _checks.positive("RunSettings.settle_tolerance",
                                                 self.settle_tolerance),
            "settle_min_s": _checks.positive("RunSettings.settle_min_s", self.settle_min_s, "s"),
            "settle_max_s": _checks.positive("RunSettings.settle_max_s", self.settle_max_s, "s"),
        }
        warm = _checks.real("RunSettings.warm_up_s", self.warm_up_s, "s", ">= 0")
        if not 0.0 <= warm < values["duration_s"]:
            raise _checks.fail("RunSettings.warm_up_s", self.warm_up_s,
                               f"in [0, duration_s = {values['duration_s']:g}) s", "s")
        values["warm_up_s"] = warm
        if values["settle_max_s"] < values["settle_min_s"]:
            raise _checks.fail("RunSettings.settle_max_s", self.settle_max_s,
                               f">= settle_min_s = {values['settle_min_s']:g} s", "s")
        for name, value in values.items():
            object.__setattr__(self, name, value)
        if self.total_samples < 2:
            raise _checks.fail("RunSettings.duration_s", self.duration_s,
                               f"at least 2 samples of sample_dt = {self.sample_dt:g} s", "s")
        if self.total_samples - self.warm_up_samples < 2:
            raise _checks.fail(
                "RunSettings.warm_up_s", self.warm_up_s,
                f"at most duration_s - 2 x sample_dt = "
                f"{self.duration_s - 2 * self.sample_dt:g} s, so that 2 samples remain",
                "s")

    @property
    def total_samples(self) -> int:
        """Samples simulated after the drum starts, warm-up included."""
        return int(round(self.duration_s / self.sample_dt))

    @property
    def warm_up_samples(self) -> int:
        """Samples of the warm-up, dropped from the record."""
        return int(round(self.warm_up_s / self.sample_dt))

    def replace(self, **changes: Any) -> RunSettings:
        """A copy with some fields changed, validated again."""
        return dataclasses.replace(self, **changes)


@dataclass(frozen=True)
class Case:
    """One run of a campaign: a scene and its settings.

    Attributes
    ----------
    scene : Scene
    settings : RunSettings

    Raises
    ------
    ValueError
        when the settings do not suit the scene: a time step above the stability limit, or a
        sampling interval shorter than the time step.
    """

    scene: Scene
    settings: RunSettings = field(default_factory=RunSettings)

    def __post_init__(self) -> None:
        if not isinstance(self.scene, Scene):
            raise _checks.fail("Case.scene", self.scene, "a millscope Scene")
        if not isinstance(self.settings, RunSettings):
            raise _checks.fail("Case.settings", self.settings, "a RunSettings")
        s = self.settings
        limit = time_step_limit(self.scene)
        if s.dt is not None and s.dt > limit.dt:
            raise _checks.fail("RunSettings.dt", s.dt,
                               f"{limit.valid_range()} (scene {self.scene.name or 'scene'!r})", "s")
        dt = limit.default_dt() if s.dt is None else s.dt
        if s.sample_dt < dt:
            raise _checks.fail(
                "RunSettings.sample_dt", s.sample_dt,
                f">= the time step dt = {dt:.6g} s of scene {self.scene.name or 'scene'!r}",
                "s")

    @property
    def name(self) -> str:
        """The scene's name and the seed, e.g. ``"LDMS#3 seed 0"``."""
        return f"{self.scene.name or 'scene'} seed {self.settings.seed}"

    def to_dict(self) -> dict[str, Any]:
        """Plain JSON-able data: ``{"format": CASE_FORMAT, "scene": {...}, "settings": {...}}``."""
        return {"format": CASE_FORMAT, "scene": self.scene.to_dict(),
                "settings": dataclasses.asdict(self.settings)}

    @classmethod
    def from_dict(cls, data: object) -> Case:
        """The case of a :meth:`to_dict` dict, validated (ValueError when damaged)."""
        if not isinstance(data, Mapping) or data.get("format") != CASE_FORMAT:
            found = data.get("format") if isinstance(data, Mapping) else type(data).__name__
            raise ValueError(f"not a millscope case: format {found!r}, expected {CASE_FORMAT!r}")
        settings = data.get("settings")
        if not isinstance(settings, Mapping):
            raise ValueError(f"case settings must be a mapping, not {type(settings).__name__}")
        known = {f.name for f in dataclasses.fields(RunSettings)}
        unknown = sorted(set(settings) - known)
        if unknown:
            raise ValueError(f"case settings have unknown keys {unknown}; known: {sorted(known)}")
        return cls(Scene.from_dict(data.get("scene")), RunSettings(**settings))

    def canonical_json(self) -> str:
        """The JSON the hash is taken of: sorted keys, no spaces, floats as Python repr."""
        return json.dumps(self.to_dict(), sort_keys=True, separators=(",", ":"),
                          ensure_ascii=True, allow_nan=False)

    def hash(self) -> str:
        """sha256 (64 hex digits) of :meth:`canonical_json`: the case's name in a store."""
        return hashlib.sha256(self.canonical_json().encode("ascii")).hexdigest()

    def simulation(self, *, track_energy: bool = False) -> Simulation:
        """A new, empty :class:`~millscope.simulation.Simulation` of the case: its scene, seed,
        time step, threads and settling criteria (``track_energy``: book the losses)."""
        s = self.settings
        return Simulation(self.scene, seed=s.seed, dt=s.dt, threads=s.threads,
                          settle_tolerance=s.settle_tolerance, settle_min_s=s.settle_min_s,
                          settle_max_s=s.settle_max_s, track_energy=track_energy)


def case_matrix(scenes: Iterable[Scene], *, seeds: int | Iterable[int] | None = None,
                settings: RunSettings | None = None, **changes: Any) -> list[Case]:
    """Every scene with every seed, run with ``settings`` (changed by ``changes``).

    Parameters
    ----------
    scenes : iterable of Scene
        E.g. :func:`millscope.presets.paper_cases`; any list of scenes.
    seeds : int or iterable of int, optional
        Filling seeds, >= 0; several seeds give the seed-to-seed spread of each scene.
        Default: the seed of ``settings``.
    settings : RunSettings, optional
        Default ``RunSettings()``; its seed is replaced by each of ``seeds``.
    **changes
        RunSettings fields to change, e.g. ``duration_s=3.0, threads=2``.

    Returns
    -------
    list of Case
        Ordered by scene, then seed.
    """
    scene_list = list(scenes)
    for k, scene in enumerate(scene_list):
        if not isinstance(scene, Scene):
            raise _checks.fail(f"scenes[{k}]", scene, "a millscope Scene")
    if settings is not None and not isinstance(settings, RunSettings):
        raise _checks.fail("settings", settings, "a RunSettings or None")
    base = (settings or RunSettings()).replace(**changes)
    seed_list = [base.seed] if seeds is None else _seeds(seeds)
    return [Case(scene, base.replace(seed=seed)) for scene in scene_list for seed in seed_list]


def paper_matrix(particles: str | None | Iterable[str | None] = ("ceramic", "steel"),
                 speed_fractions: float | Iterable[float] = (0.80, 0.71, 0.62),
                 load_levels: int | Iterable[int] = range(1, 8), scale: str = "paper", *,
                 seeds: int | Iterable[int] | None = None,
                 settings: RunSettings | None = None, **changes: Any) -> list[Case]:
    """The paper's Table 4 x Table 5 matrix (or part of it) as cases.

    :func:`millscope.presets.paper_cases` (particles x speeds x load levels at ``scale``)
    through :func:`case_matrix`.

    Parameters
    ----------
    particles : "ceramic", "steel", None or an iterable of them
        LD, HD or balls-only cases.
    speed_fractions : float or iterable of float
        Fractions of critical speed (the paper's: 0.80, 0.71, 0.62).
    load_levels : int or iterable of int
        Table 5's levels 1..7.
    scale : {"paper", "small", "tiny", "soft"}
        See :data:`millscope.presets.SCALES`.
    seeds, settings, **changes
        As :func:`case_matrix`.
    """
    return case_matrix(paper_cases(particles, speed_fractions, load_levels, scale), seeds=seeds,
                       settings=settings, **changes)


def _seeds(seeds: object) -> list[int]:
    items = [seeds] if isinstance(seeds, Integral) else seeds
    if isinstance(items, (str, bytes)) or not isinstance(items, Iterable):
        raise _checks.fail("seeds", seeds, "an integer >= 0 or an iterable of them")
    out = [_checks.integer("seeds", s, ValueError, low=0) for s in items]
    if not out:
        raise _checks.fail("seeds", seeds, "an integer >= 0 or a non-empty iterable of them")
    if len(set(out)) != len(out):
        raise _checks.fail("seeds", seeds, "free of repeats")
    return out


# -- results -----------------------------------------------------------------------------------


@dataclass(frozen=True)
class CaseResult:
    """One case of a campaign as the store holds it, with the analysis of its block.

    Attributes
    ----------
    case : Case
    hash : str
        :meth:`Case.hash`, the case's file name in the store.
    status : {"done", "failed", "pending"}
    record : TorqueRecord or None
        The drive torque after the warm-up (times from the start of rotation, s; N m); None
        unless done. ``record.meta["campaign"]`` says how and where the case ran.
    wall_time_s : float
        Wall-clock time the case took in its worker, s (nan when pending).
    cpu_time_s : float
        CPU time of the worker's process over the case's runs, all its threads, s (nan when
        not known: :class:`~millscope.campaign.partial.RunTime`).
    error, traceback : str or None
        Why a failed case failed: ``"Type: message"`` and a summary of the traceback. For a
        pending case whose file cannot be read, ``error`` says why (the next run computes
        the case again).
    mean_torque : float
        Mean drive torque over the campaign's block, N m (nan without a record or a block).
    lth_hz, lth_amplitude : float
        The lifter torque harmonic located near lifters x rotation frequency in the block, Hz
        and N m (nan without lifters).
    lth_noise : float
        The median amplitude of the bins around it, N m (:attr:`millscope.Peak.noise_amplitude`;
        nan without lifters).
    lth_snr : float
        Its amplitude over the median amplitude of the bins around it (nan without lifters).
    lth_distinct : bool
        Whether it stands out of the noise (:attr:`millscope.Peak.distinct`); a located "LTH"
        that does not is a noise peak, and its frequency and amplitude say little.
    energy : float
        Spectral energy of the block with the mean and the LTH removed, (N m)^2 s, eq. (11).
    energy_relative_std : float
        Its sampling spread (standard deviation / mean, dimensionless).
    analysis : AnalysisSettings or None
        How the values above were obtained (block, bandwidth, window); None when the case was
        not analysed.
    """

    case: Case
    hash: str
    status: Status
    record: TorqueRecord | None = None
    wall_time_s: float = math.nan
    cpu_time_s: float = math.nan
    error: str | None = None
    traceback: str | None = None
    mean_torque: float = math.nan
    lth_hz: float = math.nan
    lth_amplitude: float = math.nan
    lth_snr: float = math.nan
    lth_noise: float = math.nan
    lth_distinct: bool = False
    energy: float = math.nan
    energy_relative_std: float = math.nan
    analysis: AnalysisSettings | None = None

    @classmethod
    def from_record(cls, case: Case, record: TorqueRecord,
                    analysis: AnalysisSettings | None = None, *,
                    wall_time_s: float = math.nan,
                    cpu_time_s: float = math.nan) -> CaseResult:
        """A finished case from its record, analysed over ``analysis.block`` (None: not
        analysed).

        The block's mean torque, the LTH located near lifters x rotation frequency of the
        case's scene (:func:`~millscope.analysis.analyze_block`; without lifters only the mean
        is removed) and the spectral energy with the mean and the LTH removed.
        """
        if analysis is None:
            return cls(case, case.hash(), "done", record, wall_time_s=wall_time_s,
                       cpu_time_s=cpu_time_s)
        blk = record.block(*analysis.block)
        lifters = case.scene.drum.lifters
        window: Any = analysis.window
        if lifters is not None:
            a = analyze_block(blk, lifters=lifters.count, rotation_hz=case.scene.rotation_hz,
                              bandwidth=analysis.bandwidth, window=window)
            values: dict[str, Any] = {
                "mean_torque": a.mean_torque_Nm, "lth_hz": a.lth.frequency_hz,
                "lth_amplitude": a.lth.amplitude, "lth_snr": a.lth.snr,
                "lth_noise": a.lth.noise_amplitude,
                "lth_distinct": a.lth.distinct, "energy": a.energy.energy,
                "energy_relative_std": a.energy.relative_std}
        else:
            e = spectral_energy(blk, ["mean"], bandwidth=analysis.bandwidth, window=window)
            values = {"mean_torque": blk.mean_torque_Nm, "energy": e.energy,
                      "energy_relative_std": e.relative_std}
        return cls(case, case.hash(), "done", record, wall_time_s=wall_time_s,
                   cpu_time_s=cpu_time_s, analysis=analysis, **values)

    @property
    def scene(self) -> Scene:
        return self.case.scene

    @property
    def key(self) -> CaseKey:
        """The case's particles, speed, load level and group (:func:`~millscope.presets.case_key`
        of its scene), by which :func:`~millscope.analyze_campaign` groups the results."""
        return case_key(self.scene)

    @property
    def ok(self) -> bool:
        """True when the case is done."""
        return self.status == "done"

    @property
    def particle_steps(self) -> float:
        """Particles x time steps the case's run took (:func:`run_particle_steps`); nan
        unless done."""
        if self.record is None:
            return math.nan
        return run_particle_steps(self.record, self.scene.n_particles,
                                  self.case.settings.duration_s)

    @property
    def core_hours(self) -> float:
        """What the case's run cost in core-hours, h: its CPU time where it was recorded
        (:attr:`cpu_time_s`), else wall time x engine threads, the cores the run held,
        including any time other work on a shared machine took from it; nan when neither is
        known."""
        if math.isfinite(self.cpu_time_s):
            return self.cpu_time_s / 3600.0
        return self.wall_time_s * self.case.settings.threads / 3600.0


def run_particle_steps(record: TorqueRecord, n_particles: int, duration_s: float) -> float:
    """Particles x time steps of a run: its settling (``record.meta["settle"]["time_s"]``, 0
    when the record has none) and ``duration_s`` s of rotation, at the record's time step
    ``record.meta["dt"]`` (s). The engine's work grows with it on every machine.

    Returns nan when the record does not give a time step > 0.
    """
    dt = record.meta.get("dt")
    if not isinstance(dt, (int, float)) or not math.isfinite(dt) or dt <= 0:
        return math.nan
    settle = record.meta.get("settle")
    settle_s = settle.get("time_s", 0.0) if isinstance(settle, Mapping) else 0.0
    if not isinstance(settle_s, (int, float)) or not math.isfinite(settle_s):
        settle_s = 0.0
    return float(n_particles * (round(settle_s / dt) + round(duration_s / dt)))


def rotation_particle_steps(case: Case) -> float:
    """Particles x time steps of the case's rotation (warm-up and block) at its time step (the
    engine's default when its settings give none): what a run of it will take but for the
    settling, which only the run tells."""
    dt = case.settings.dt
    if dt is None:
        dt = time_step_limit(case.scene).default_dt()
    return float(case.scene.n_particles * round(case.settings.duration_s / dt))


def distinct_runs(results: Iterable[CaseResult]) -> list[CaseResult]:
    """The done results, one per run of the engine.

    A run samples both modes from the same steps, and a campaign holding a case and its twin
    in the other sampling mode stores both from one run, with that run's wall time. A done
    result whose twin (the same case but for ``settings.sampling``) came before it with the
    same wall time is that run's second record and is left out; twins run apart (their wall
    times differ) count twice.
    """
    seen: set[tuple[str, float]] = set()
    runs = []
    for r in results:
        if not r.ok:
            continue
        run = (Case(r.scene, r.case.settings.replace(sampling="instant")).hash(), r.wall_time_s)
        if math.isfinite(r.wall_time_s) and run in seen:
            continue
        seen.add(run)
        runs.append(r)
    return runs

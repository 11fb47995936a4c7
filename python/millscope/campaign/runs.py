"""Campaigns: many cases run through an executor into a resumable result store.

A **case** (:class:`Case`) is a :class:`~millscope.scene.Scene` plus how to run it
(:class:`RunSettings`: seed, duration, warm-up, sampling, threads, time step, settling). A
:class:`Campaign` runs its cases through any ``concurrent.futures``-style executor (a local
process pool by default, or a ``dask.distributed`` Client) and keeps the results in a store
directory::

    store/
      manifest.json          every case: hash, name, status, file, wall time, error
      cases/<hash>.npz       a finished case: its TorqueRecord (record.py's .npz format), the
                             case and how it ran in meta["campaign"]
      cases/<hash>.failed.json   a case that raised: the error and a traceback summary
      .lock                  held (flock) while a campaign runs on the store

``<hash>`` is :meth:`Case.hash`: the sha256 of the canonical JSON of the case (scene,
settings, :data:`CASE_FORMAT`), the same in every process and on every machine, different as
soon as anything in the scene or the settings differs.

Every file is written atomically (a temporary file, then a rename), and only the process that
called :meth:`Campaign.run` writes: workers return their record, so a dask cluster needs no
shared file system. The files are the truth; the manifest is rebuilt from them at every start,
so a campaign killed at any point resumes where it stopped and keeps every case whose file was
written; a case file that cannot be read (:func:`unreadable_cases` says why) is computed again.
The local pool's workers do not run the caller's main module (no ``__main__`` guard needed)
and end when the campaign process ends, even when it is killed. A rerun skips finished cases
and retries failed ones; a case that raises is recorded as failed and the others go on. Ctrl-C
stops the campaign, keeping what has finished.

Typical use (DESIGN.md section 5)::

    scenes = ms.presets.paper_cases(particles=["ceramic"], speed_fractions=[0.71],
                                    load_levels=[1, 2, 3, 4], scale="paper")
    camp = ms.Campaign(scenes, store="runs/demo", duration=14.0, block=(4.0, 14.0))
    results = camp.run()                  # or camp.run(executor=dask_client)
    [(r.scene.name, r.mean_torque, r.lth_amplitude, r.energy) for r in results]

All quantities are SI (s, N m, Hz, (N m)^2 s).
"""

from __future__ import annotations

import contextlib
import dataclasses
import hashlib
import json
import math
import multiprocessing
import multiprocessing.context
import multiprocessing.process
import os
import signal
import socket
import sys
import threading
import time
import traceback
import types
from collections.abc import Callable, Iterable, Iterator, Mapping
from dataclasses import dataclass, field
from numbers import Integral
from pathlib import Path
from typing import Any, Literal

from .. import _checks, _core
from .._files import atomic_write, read_json
from ..engine.simulation import Simulation, _available_cores
from ..model.presets import CaseKey, case_key, paper_cases
from ..model.scene import Scene
from ..model.stiffness import time_step_limit
from ..signal.analysis import AnalysisSettings, analyze_block
from ..signal.record import RecordError, TorqueRecord
from ..signal.spectral import spectral_energy

__all__ = [
    "CASE_FORMAT",
    "MANIFEST_FORMAT",
    "Campaign",
    "Case",
    "CaseResult",
    "RunSettings",
    "case_matrix",
    "paper_matrix",
    "UnreadableCase",
    "read_manifest",
    "run_case",
    "unreadable_cases",
]

CASE_FORMAT = "millscope-case-1"  # part of every case hash: bump it when results change meaning
MANIFEST_FORMAT = "millscope-campaign-1"
SAMPLINGS = ("instant", "mean")
_MIN_BLOCK_SAMPLES = 4  # the spectral analysis needs at least this many
_TRACEBACK_FRAMES = 12  # frames kept in a failed case's traceback summary (the innermost)
_TRACEBACK_CHARS = 8000
_TERMINATE_WAIT_S = 10.0  # how long to wait for a terminated worker process to end, s
_TICK_S = 5.0  # the progress bar is redrawn this often while no case finishes, s
_ORPHAN_EXIT_CODE = 70  # a worker's exit status when it ends because its campaign died
_MAIN_SWAP_LOCK = threading.Lock()  # one worker launch at a time hides __main__

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
    sampling: str = "instant"
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
    def from_dict(cls, data: Mapping[str, Any]) -> Case:
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
        return cls(Scene.from_dict(data.get("scene")), RunSettings(**settings))  # type: ignore[arg-type]

    def canonical_json(self) -> str:
        """The JSON the hash is taken of: sorted keys, no spaces, floats as Python repr."""
        return json.dumps(self.to_dict(), sort_keys=True, separators=(",", ":"),
                          ensure_ascii=True, allow_nan=False)

    def hash(self) -> str:
        """sha256 (64 hex digits) of :meth:`canonical_json`: the case's name in a store."""
        return hashlib.sha256(self.canonical_json().encode("ascii")).hexdigest()


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
    error, traceback : str or None
        Why a failed case failed: ``"Type: message"`` and a summary of the traceback. For a
        pending case whose file cannot be read, ``error`` says why (the next run computes
        the case again).
    mean_torque : float
        Mean drive torque over the campaign's block, N m (nan without a record or a block).
    lth_hz, lth_amplitude : float
        The lifter torque harmonic located near lifters x rotation frequency in the block, Hz
        and N m (nan without lifters).
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
    error: str | None = None
    traceback: str | None = None
    mean_torque: float = math.nan
    lth_hz: float = math.nan
    lth_amplitude: float = math.nan
    lth_snr: float = math.nan
    lth_distinct: bool = False
    energy: float = math.nan
    energy_relative_std: float = math.nan
    analysis: AnalysisSettings | None = None

    @classmethod
    def from_record(cls, case: Case, record: TorqueRecord,
                    analysis: AnalysisSettings | None = None, *,
                    wall_time_s: float = math.nan) -> CaseResult:
        """A finished case from its record, analysed over ``analysis.block`` (None: not
        analysed).

        The block's mean torque, the LTH located near lifters x rotation frequency of the
        case's scene (:func:`~millscope.analysis.analyze_block`; without lifters only the mean
        is removed) and the spectral energy with the mean and the LTH removed.
        """
        if analysis is None:
            return cls(case, case.hash(), "done", record, wall_time_s=wall_time_s)
        blk = record.block(*analysis.block)
        lifters = case.scene.drum.lifters
        window: Any = analysis.window
        if lifters is not None:
            a = analyze_block(blk, lifters=lifters.count, rotation_hz=case.scene.rotation_hz,
                              bandwidth=analysis.bandwidth, window=window)
            values: dict[str, Any] = {
                "mean_torque": a.mean_torque_Nm, "lth_hz": a.lth.frequency_hz,
                "lth_amplitude": a.lth.amplitude, "lth_snr": a.lth.snr,
                "lth_distinct": a.lth.distinct, "energy": a.energy.energy,
                "energy_relative_std": a.energy.relative_std}
        else:
            e = spectral_energy(blk, ["mean"], bandwidth=analysis.bandwidth, window=window)
            values = {"mean_torque": blk.mean_torque_Nm, "energy": e.energy,
                      "energy_relative_std": e.relative_std}
        return cls(case, case.hash(), "done", record, wall_time_s=wall_time_s,
                   analysis=analysis, **values)

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


# -- the store ---------------------------------------------------------------------------------


def _case_path(store: Path, digest: str) -> Path:
    return store / "cases" / f"{digest}.npz"


def _failure_path(store: Path, digest: str) -> Path:
    return store / "cases" / f"{digest}.failed.json"


class _Unreadable(Exception):
    """Why a case file cannot be read (one line)."""


def _open_done(path: Path) -> tuple[dict[str, Any], TorqueRecord]:
    """The ``meta["campaign"]`` and the record of a finished case's file.

    Raises :class:`_Unreadable` saying why unless the file is a whole, consistent case file:
    a zip whose checksums hold, the three arrays of record.py's format, samples a
    :class:`~millscope.record.TorqueRecord` accepts (finite, uniform), a stored case that
    hashes to the file's name and the number of samples its settings give.
    """
    try:
        record = TorqueRecord.load(path)  # every check of a record file (record.py)
        info = record.meta.get("campaign")
        if not isinstance(info, dict):
            raise _Unreadable('its meta holds no "campaign" mapping')
        case = Case.from_dict(info.get("case"))  # type: ignore[arg-type]
    except _Unreadable:
        raise
    except RecordError as exc:  # its message starts with the path, which the caller names
        raise _Unreadable(str(exc).removeprefix(f"{path}: ")) from None
    except (OSError, KeyError, TypeError, ValueError) as exc:
        raise _Unreadable(f"not a valid case file ({_one_line(exc)})") from None
    if case.hash() != path.stem:
        raise _Unreadable(f"it holds case {case.hash()[:12]}, not the one its name says")
    expected = case.settings.total_samples - case.settings.warm_up_samples
    if len(record) != expected:
        raise _Unreadable(f"it holds {len(record)} samples; its case gives {expected}")
    return info, record


def _open_failed(path: Path) -> dict[str, Any]:
    """The content of a failed case's file; :class:`_Unreadable` saying why when it is not a
    whole failure record of the case its name says."""
    try:
        if path.is_dir():
            raise _Unreadable("a directory, not a case file")
        try:
            info = read_json(path, "failed case")
        except ValueError as exc:  # the message starts with the path, which the caller names
            raise _Unreadable(str(exc).removeprefix(f"{path}: ")) from None
        if not isinstance(info, dict):
            raise _Unreadable(f"holds a JSON {type(info).__name__}, not a failed case")
        digest = Case.from_dict(info.get("case")).hash()  # type: ignore[arg-type]
    except _Unreadable:
        raise
    except (OSError, KeyError, TypeError, ValueError, RecursionError) as exc:
        raise _Unreadable(f"not a valid failed-case file ({_one_line(exc)})") from None
    if digest != path.name.split(".")[0]:
        raise _Unreadable(f"it holds case {digest[:12]}, not the one its name says")
    return info


def _one_line(exc: BaseException) -> str:
    text = " ".join(str(exc).split())
    return f"{type(exc).__name__}: {text}" if text else type(exc).__name__


def _read_done(path: Path) -> dict[str, Any] | None:
    """:func:`_open_done`'s info, or None when the file cannot be read."""
    try:
        return _open_done(path)[0]
    except _Unreadable:
        return None


def _read_failed(path: Path) -> dict[str, Any] | None:
    """:func:`_open_failed`'s info, or None when the file cannot be read."""
    try:
        return _open_failed(path)
    except _Unreadable:
        return None


def _case_files(store: Path) -> Iterator[tuple[Status, Path]]:
    """Every case file in ``store/cases`` (not the temporaries of unfinished writes):
    failures first, so that a finished case's file wins over a failure of the same case."""
    folder = store / "cases"
    if folder.is_dir():
        for status, pattern in (("failed", "*.failed.json"), ("done", "*.npz")):
            for path in sorted(folder.glob(pattern)):
                if not path.name.startswith("."):
                    yield status, path  # type: ignore[misc]


def _stored(store: Path) -> dict[str, tuple[Status, Path, dict[str, Any]]]:
    """Every whole case file in ``store`` by hash: (status, path, its case info); a finished
    case's file wins over a failure of the same case."""
    found: dict[str, tuple[Status, Path, dict[str, Any]]] = {}
    for status, path in _case_files(store):
        info = _read_done(path) if status == "done" else _read_failed(path)
        if info is not None:
            found[path.name.split(".")[0]] = (status, path, info)
    return found


@dataclass(frozen=True)
class UnreadableCase:
    """A case a store should hold but cannot give: its file is damaged, or missing although
    the manifest lists the case as finished or failed.

    Attributes
    ----------
    file : str
        The case file, relative to the store (``cases/<hash>.npz`` or
        ``cases/<hash>.failed.json``).
    hash : str
        The case's hash, from the file's name.
    name : str or None
        ``"<scene> seed <seed>"`` as the manifest lists the case; None when it does not.
    reason : str
        Why the file cannot be read (one line).
    """

    file: str
    hash: str
    name: str | None
    reason: str

    def __str__(self) -> str:
        named = f" ({self.name})" if self.name else ""
        return f"{self.file}{named}: {self.reason}"


def _listing(cases: list[UnreadableCase], most: int = 5) -> str:
    """The first ``most`` unreadable cases on one line, then how many more."""
    text = "; ".join(str(c) for c in cases[:most])
    return text + (f"; and {len(cases) - most} more" if len(cases) > most else "")


def unreadable_cases(store: str | os.PathLike[str]) -> list[UnreadableCase]:
    """Every case of ``store`` whose file cannot be read, with the reason.

    A case file (``cases/*.npz``, ``cases/*.failed.json``) that is not whole and consistent
    (truncated, altered, empty, a directory, without its meta, with samples a
    :class:`~millscope.record.TorqueRecord` refuses, or named for another case), and a case
    the manifest lists as done or failed whose file is missing. Temporary files of writes a
    killed campaign left are not cases (the next run removes them). A finished case's file
    wins over a failure of the same case, so a readable ``.npz`` hides a damaged
    ``.failed.json`` beside it.

    Parameters
    ----------
    store : str or path
        A campaign store directory.

    Returns
    -------
    list of UnreadableCase
        In file-name order; empty for a store whose every case can be read.

    Raises
    ------
    ValueError
        when ``store`` is not a directory or its manifest is damaged.
    """
    path = Path(store)
    if not path.is_dir():
        raise _checks.fail("store", str(store), "an existing campaign store directory")
    listed: dict[str, dict[str, Any]] = {}
    if (path / "manifest.json").exists():
        listed = {e["hash"]: e for e in read_manifest(path).get("cases", [])
                  if isinstance(e, dict) and isinstance(e.get("hash"), str)}

    def name(digest: str) -> str | None:
        entry = listed.get(digest)
        if entry is None or not isinstance(entry.get("name"), str):
            return None
        return f"{entry['name'] or 'scene'} seed {entry.get('seed')}"

    found: dict[str, UnreadableCase] = {}
    readable: set[str] = set()
    for status, file in _case_files(path):
        digest = file.name.split(".")[0]
        try:
            _open_done(file) if status == "done" else _open_failed(file)
        except _Unreadable as exc:
            found[file.name] = UnreadableCase(file.relative_to(path).as_posix(), digest,
                                              name(digest), str(exc))
        else:
            readable.add(digest)
    for digest in readable:  # a whole finished case outweighs a damaged failure record
        found.pop(_failure_path(path, digest).name, None)
    for digest, entry in listed.items():
        said = entry.get("status")
        if said in ("done", "failed") and digest not in readable:
            file = (_case_path if said == "done" else _failure_path)(path, digest)
            if not file.exists() and not file.is_symlink():
                found[file.name] = UnreadableCase(
                    file.relative_to(path).as_posix(), digest, name(digest),
                    f"missing, although manifest.json lists the case as {said}")
    return [found[k] for k in sorted(found)]


def _scan(store: Path) -> dict[str, dict[str, Any]]:
    """Manifest entries of every case file in ``store``."""
    return {digest: _entry(info, status, path, store)
            for digest, (status, path, info) in _stored(store).items()}


def _entry(info: Mapping[str, Any], status: Status, path: Path | None,
           store: Path) -> dict[str, Any]:
    case = info["case"]
    settings = case["settings"]
    return {
        "hash": info["hash"],
        "name": case["scene"].get("name", ""),
        "seed": settings["seed"],
        "status": status,
        "file": None if path is None else path.relative_to(store).as_posix(),
        "wall_time_s": info.get("wall_time_s"),
        "error": info.get("error"),
        "traceback": info.get("traceback"),
    }


def read_manifest(store: str | os.PathLike[str]) -> dict[str, Any]:
    """The manifest of a store as written by :meth:`Campaign.run` (it may be stale after a
    kill; the next run rebuilds it from the case files)."""
    path = Path(store) / "manifest.json"
    data = read_json(path, "campaign manifest")
    if not isinstance(data, dict) or data.get("format") != MANIFEST_FORMAT:
        raise ValueError(f"{path}: not a millscope campaign manifest (expected format "
                         f"{MANIFEST_FORMAT!r})")
    return data


def _write_manifest(store: Path, entries: Mapping[str, Mapping[str, Any]],
                    analysis: AnalysisSettings | None) -> None:
    counts = {s: sum(1 for e in entries.values() if e["status"] == s)
              for s in ("done", "failed", "pending")}
    data = {
        "format": MANIFEST_FORMAT,
        "millscope_version": _core.build_info()["version"],
        "updated": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
        "counts": counts,
        "analysis": None if analysis is None else analysis.to_dict(),
        "cases": list(entries.values()),
    }
    with atomic_write(store / "manifest.json", "w") as fh:
        json.dump(data, fh, indent=1)
        fh.write("\n")


@contextlib.contextmanager
def _locked(store: Path) -> Iterator[None]:
    """Holds an exclusive flock on ``store/.lock`` (released by the OS if the process dies)."""
    try:
        import fcntl
    except ImportError:  # not POSIX: no lock
        yield
        return
    with open(store / ".lock", "a+") as fh:
        try:
            fcntl.flock(fh.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            raise RuntimeError(f"the store {store} is in use by another campaign; run one "
                               "campaign per store at a time") from None
        try:
            yield
        finally:
            fcntl.flock(fh.fileno(), fcntl.LOCK_UN)


def _remove_temporaries(store: Path) -> None:
    """Deletes what atomic writes of a killed campaign left (``.<name>.<random>.tmp``)."""
    for folder in (store, store / "cases"):
        if folder.is_dir():
            for tmp in folder.glob(".*.tmp"):
                with contextlib.suppress(FileNotFoundError):
                    tmp.unlink()


# -- the worker side ---------------------------------------------------------------------------


def _start_worker() -> None:
    """Pool initializer: idle workers ignore Ctrl-C (the campaign handles it; a running
    simulation still stops on it, and its case is then reported as failed), and a watchdog
    thread ends the worker as soon as the campaign process is gone (killed by SIGKILL or
    SIGTERM): its case would be lost anyway, and an orphaned worker would otherwise wait on its
    queue for ever, holding the caller's stdout and multiprocessing's resource tracker."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    parent = multiprocessing.parent_process()
    if parent is not None:
        threading.Thread(target=_exit_with, args=(parent,), name="millscope-orphan-watchdog",
                         daemon=True).start()


def _exit_with(parent: multiprocessing.process.BaseProcess) -> None:
    """Waits for ``parent`` to end, then ends this process at once. The wait is on the
    parent's sentinel (a pipe that reads end-of-file when the parent dies, or its process
    handle on Windows), so it costs nothing while the parent lives."""
    parent.join()
    os._exit(_ORPHAN_EXIT_CODE)


class _WorkerProcess(multiprocessing.context.SpawnProcess):
    """A spawned process that does not run the caller's main module.

    ``spawn`` (and ``forkserver``) children import the parent's ``__main__`` (a script by its
    path, ``python -m`` by its name) so that functions defined there can be unpickled; a script
    without an ``if __name__ == "__main__":`` guard then starts its campaign again in every
    worker. A campaign's workers need nothing from ``__main__`` (they call :func:`run_case` with
    a plain dict), so while this process is launched ``__main__`` is a bare module and the child
    is told of no main module, as when started from a notebook or the REPL."""

    @staticmethod
    def _Popen(process_obj: Any) -> Any:  # multiprocessing's hook, called by start()
        with _MAIN_SWAP_LOCK:
            main = sys.modules["__main__"]
            sys.modules["__main__"] = types.ModuleType("__main__")
            try:
                return multiprocessing.context.SpawnProcess._Popen(process_obj)
            finally:
                sys.modules["__main__"] = main


class _WorkerContext(multiprocessing.context.SpawnContext):
    """The ``spawn`` context with :class:`_WorkerProcess` processes: the local pool's."""

    Process = _WorkerProcess


def _traceback_summary(exc: BaseException) -> str:
    text = "".join(traceback.TracebackException.from_exception(
        exc, limit=-_TRACEBACK_FRAMES).format())
    return text if len(text) <= _TRACEBACK_CHARS else "...\n" + text[-_TRACEBACK_CHARS:]


def run_case(case: Mapping[str, Any]) -> dict[str, Any]:
    """Runs one case where it is called (a worker); never raises for a failing case.

    Parameters
    ----------
    case : mapping
        :meth:`Case.to_dict` (plain data, so any executor can ship it).

    Returns
    -------
    dict
        ``status`` "done" with ``time_s``, ``torque_Nm`` (arrays: s, N m) and ``meta``, or
        "failed" with ``error`` and ``traceback``; always ``hash``, ``wall_time_s`` (s),
        ``host`` and ``pid``.
    """
    start = time.perf_counter()
    where = {"host": socket.gethostname(), "pid": os.getpid()}
    digest = ""
    try:
        c = Case.from_dict(case)
        digest = c.hash()
        s = c.settings
        # A case keeps the torque alone: the energy ledger would cost a quarter of the run
        # and change nothing in it (Simulation, track_energy).
        sim = Simulation(c.scene, seed=s.seed, dt=s.dt, threads=s.threads,
                         settle_tolerance=s.settle_tolerance, settle_min_s=s.settle_min_s,
                         settle_max_s=s.settle_max_s, track_energy=False)
        rec = sim.run(s.total_samples * s.sample_dt, sample_dt=s.sample_dt,
                      sampling=s.sampling,  # type: ignore[arg-type]  # checked by RunSettings
                      progress=False)
        if rec.meta.get("interrupted") or len(rec) != s.total_samples:
            raise RuntimeError(f"the run was interrupted after {len(rec)} of "
                               f"{s.total_samples} samples")
        settle = sim.settle_report
        meta = rec.meta
        meta["settle"] = None if settle is None else dataclasses.asdict(settle)
        return {"status": "done", "hash": digest, "time_s": rec.time_s[s.warm_up_samples:],
                "torque_Nm": rec.torque_Nm[s.warm_up_samples:], "meta": meta,
                "wall_time_s": time.perf_counter() - start, **where}
    except Exception as exc:  # a failing case is reported, not raised
        return {"status": "failed", "hash": digest, "error": f"{type(exc).__name__}: {exc}",
                "traceback": _traceback_summary(exc),
                "wall_time_s": time.perf_counter() - start, **where}


# -- the campaign ------------------------------------------------------------------------------


def _terminate_workers(pool: Any) -> None:
    """Stops the processes of our own pool at once (Ctrl-C, or an error in the campaign):
    their cases are lost either way, and a queued case would otherwise start and run to its
    end. ``terminate_workers`` is public from Python 3.14; before, the pool's process table."""
    terminate = getattr(pool, "terminate_workers", None)
    if callable(terminate):
        terminate()
        return
    processes = list((getattr(pool, "_processes", None) or {}).values())
    for process in processes:
        with contextlib.suppress(Exception):
            process.terminate()
    for process in processes:
        with contextlib.suppress(Exception):
            process.join(_TERMINATE_WAIT_S)


def _is_dask_client(executor: object) -> bool:
    return type(executor).__module__.split(".")[0] == "distributed"


def _completed(executor: object, futures: list[Any],
               tick: Callable[[], object] | None = None) -> Iterator[Any]:
    """Futures as they finish: dask's ``as_completed`` for a dask Client, else
    ``concurrent.futures.wait``, calling ``tick`` every :data:`_TICK_S` s while none finishes
    (so that the progress bar's elapsed time keeps moving through long cases)."""
    if _is_dask_client(executor):
        from distributed import as_completed as dask_as_completed

        yield from dask_as_completed(futures)
        return
    from concurrent.futures import FIRST_COMPLETED, wait

    pending = set(futures)
    while pending:
        done, pending = wait(pending, timeout=_TICK_S, return_when=FIRST_COMPLETED)
        if not done and tick is not None:
            tick()
        yield from (f for f in futures if f in done)  # in submission order


class Campaign:
    """Cases run through an executor into a resumable result store.

    Parameters
    ----------
    cases : iterable of Scene or Case
        Scenes are run with the settings below (one case per scene and seed); cases keep
        their own settings. :func:`millscope.presets.paper_cases` gives the paper's scenes,
        :func:`paper_matrix` and :func:`case_matrix` give cases.
    store : str or path
        Result directory (created on the first run); see the module docstring.
    duration : float, optional
        Simulated time after the drum starts, s, for the scenes; default
        ``settings.duration_s`` (14 s).
    block : (float, float) or None
        The block ``t1 <= t < t2`` (s from the start of rotation) the results are analysed
        over: mean torque, LTH and spectral energy. It must lie within every case's kept
        record, [warm_up_s, duration_s], and hold at least 4 samples. None: no analysis.
    seeds : int or iterable of int, optional
        Filling seeds for the scenes, >= 0 (default: the seed of ``settings``, 0).
    settings : RunSettings, optional
        Settings for the scenes (default ``RunSettings()``); ``duration`` and ``seeds``
        override its duration and seed.
    bandwidth : float
        Full width of the bands removed around the mean and the LTH, Hz.
    window : {"hann", "hann_periodic", "rectangular"}
        Window of the spectral analysis.

    Raises
    ------
    ValueError
        for any bad argument, naming it with its value and valid range, before any work:
        also for two equal cases, a block outside a record or an LTH above the Nyquist
        frequency.
    """

    def __init__(self, cases: Iterable[Scene | Case], store: str | os.PathLike[str], *,
                 duration: float | None = None,
                 block: tuple[float, float] | None = (4.0, 14.0),
                 seeds: int | Iterable[int] | None = None,
                 settings: RunSettings | None = None, bandwidth: float = 0.3,
                 window: str = "hann") -> None:
        if settings is not None and not isinstance(settings, RunSettings):
            raise _checks.fail("settings", settings, "a RunSettings or None")
        base = settings or RunSettings()
        if duration is not None:
            base = base.replace(duration_s=_checks.positive("duration", duration, "s"))
        seed_list = [base.seed] if seeds is None else _seeds(seeds)
        if isinstance(cases, (Scene, Case, str, bytes)) or not isinstance(cases, Iterable):
            raise _checks.fail("cases", cases, "an iterable of Scene or Case")
        out: list[Case] = []
        for k, item in enumerate(cases):
            if isinstance(item, Case):
                out.append(item)
            elif isinstance(item, Scene):
                out.extend(Case(item, base.replace(seed=s)) for s in seed_list)
            else:
                raise _checks.fail(f"cases[{k}]", item, "a Scene or a Case")
        if not out:
            raise _checks.fail("cases", cases, "a non-empty iterable of Scene or Case")
        self._cases = tuple(out)
        self._hashes = tuple(c.hash() for c in out)
        first: dict[str, int] = {}
        for k, digest in enumerate(self._hashes):
            if digest in first:
                raise ValueError(f"cases[{first[digest]}] and cases[{k}] are the same case "
                                 f"({out[k].name}, hash {digest[:12]}); every case must differ "
                                 "in its scene or settings (give other seeds for repeats)")
            first[digest] = k

        path = Path(store)
        if path.exists() and not path.is_dir():
            raise _checks.fail("store", str(store), "a directory (or a path to create one)")
        self._store = path
        self._bandwidth = _checks.positive("bandwidth", bandwidth, "Hz")
        self._window = _checks.choice("window", window, ("hann", "hann_periodic", "rectangular"))
        self._block = None if block is None else self._check_block(block)
        self._analysis = (None if self._block is None
                          else AnalysisSettings(self._block, self._bandwidth, self._window))

    @classmethod
    def from_store(cls, store: str | os.PathLike[str], *,
                   block: tuple[float, float] | None = None, bandwidth: float | None = None,
                   window: str | None = None) -> Campaign:
        """The campaign of the cases a store holds, to read their results without the scenes.

        Every case with a file in the store (finished or failed) is taken, in the manifest's
        order; cases the manifest lists as pending have no file and are left out. The results
        are analysed as the campaign that last ran on the store analysed them (its manifest
        says how) unless ``block``, ``bandwidth`` or ``window`` say otherwise; a store whose
        manifest predates that record gets the defaults, block (4, 14) s, 0.3 Hz, Hann.

        Parameters
        ----------
        store : str or path
            A campaign store directory.
        block, bandwidth, window
            As :class:`Campaign`; None: as recorded in the store.

        Raises
        ------
        ValueError
            when ``store`` is not a directory or holds no case file, for a damaged manifest,
            or a block that does not fit the stored cases.
        """
        path = Path(store)
        if not path.is_dir():
            raise _checks.fail("store", str(store), "an existing campaign store directory")
        stored = _stored(path)
        if not stored:
            damaged = unreadable_cases(path)
            if damaged:
                raise ValueError(f"store {path} holds no readable case file; {len(damaged)} "
                                 f"cannot be read: {_listing(damaged)}")
            raise ValueError(f"store {path} holds no case file (cases/<hash>.npz or "
                             "cases/<hash>.failed.json); run a Campaign into it first")
        order: list[str] = []
        saved: dict[str, Any] | None = {"block": [4.0, 14.0], "bandwidth": 0.3,
                                        "window": "hann"}
        if (path / "manifest.json").is_file():
            manifest = read_manifest(path)
            order = [e["hash"] for e in manifest.get("cases", [])
                     if isinstance(e, dict) and isinstance(e.get("hash"), str)]
            if "analysis" in manifest:
                saved = manifest["analysis"]
                if saved is not None:
                    saved = AnalysisSettings.from_dict(saved).to_dict()
        rank = {digest: k for k, digest in enumerate(order)}
        digests = sorted(stored, key=lambda d: (rank.get(d, len(rank)), d))
        cases = [Case.from_dict(stored[d][2]["case"]) for d in digests]
        if block is None and saved is not None:
            block = tuple(saved["block"])  # type: ignore[assignment]
        defaults = saved or {"bandwidth": 0.3, "window": "hann"}
        return cls(cases, path, block=block,
                   bandwidth=defaults["bandwidth"] if bandwidth is None else bandwidth,
                   window=defaults["window"] if window is None else window)

    def _check_block(self, block: object) -> tuple[float, float]:
        if (isinstance(block, (str, bytes)) or not isinstance(block, Iterable)
                or len(pair := tuple(block)) != 2):
            raise _checks.fail("block", block, "a pair (t1, t2) of times in s, or None")
        t1 = _checks.real("block[0]", pair[0], "s", ">= 0")
        t2 = _checks.real("block[1]", pair[1], "s", "> block[0]")
        if not t1 < t2:
            raise _checks.fail("block", block, "(t1, t2) with t1 < t2 (s)")
        for k, c in enumerate(self._cases):
            s = c.settings
            eps = 1e-9 * s.sample_dt
            if t1 < s.warm_up_s - eps or t2 > s.duration_s + eps:
                raise _checks.fail("block", block,
                                   f"within the record of cases[{k}] ({c.name}), [warm_up_s, "
                                   f"duration_s] = [{s.warm_up_s:g}, {s.duration_s:g}] s")
            if (t2 - t1) / s.sample_dt < _MIN_BLOCK_SAMPLES - 1e-9:
                raise _checks.fail("block", block,
                                   f"at least {_MIN_BLOCK_SAMPLES} samples long, "
                                   f"{_MIN_BLOCK_SAMPLES * s.sample_dt:g} s at the sample_dt of "
                                   f"cases[{k}] ({c.name})")
            lifters = c.scene.drum.lifters
            if lifters is not None:
                lth = lifters.count * c.scene.rotation_hz
                if lth >= 0.5 / s.sample_dt:
                    raise _checks.fail(f"cases[{k}] ({c.name}) RunSettings.sample_dt", s.sample_dt,
                                       f"< {0.5 / lth:.6g} s so that the LTH at {lth:.4g} Hz lies "
                                       "below the Nyquist frequency", "s")
        return (t1, t2)

    # -- facts ---------------------------------------------------------------------------------
    @property
    def cases(self) -> tuple[Case, ...]:
        return self._cases

    @property
    def hashes(self) -> tuple[str, ...]:
        """:meth:`Case.hash` of every case, in order."""
        return self._hashes

    @property
    def store(self) -> Path:
        return self._store

    @property
    def block(self) -> tuple[float, float] | None:
        """The analysed block (t1, t2), s, or None."""
        return self._block

    @property
    def analysis(self) -> AnalysisSettings | None:
        """How the results are analysed (block, bandwidth, window), or None."""
        return self._analysis

    def __len__(self) -> int:
        return len(self._cases)

    def __repr__(self) -> str:
        return f"Campaign({len(self)} cases, store={str(self._store)!r})"

    def case_file(self, case: int) -> Path:
        """Where case number ``case`` is (or will be) stored once finished."""
        return _case_path(self._store, self._hashes[case])

    # -- running -------------------------------------------------------------------------------
    def run(self, executor: Any = None, *, max_workers: int | None = None,
            progress: bool = True, retry_failed: bool = True) -> list[CaseResult]:
        """Runs every case not yet finished in the store, then returns all results.

        Parameters
        ----------
        executor : None, concurrent.futures.Executor or dask.distributed.Client
            None: a local process pool (spawned processes) of ``max_workers`` processes.
            Its workers do not import the caller's main module, so a script or notebook needs
            no ``if __name__ == "__main__":`` guard; they end as soon as this process ends,
            even when it is killed.
            Anything with ``submit(fn, *args)`` returning futures works; for a dask Client,
            ``distributed.as_completed`` collects them. Its workers must import millscope;
            with threads per case > 1, give each worker process that many cores.
        max_workers : int, optional
            Processes of the local pool; default the cores this process may use divided by
            the largest ``threads`` of the cases left to run. ``max_workers`` x threads may
            not exceed the cores. Only with ``executor=None``.
        progress : bool
            Show a tqdm bar over the cases.
        retry_failed : bool
            Run cases that failed before again (else they keep their failure).

        Returns
        -------
        list of CaseResult
            One per case, in order (:meth:`results`).

        Raises
        ------
        ValueError
            for bad arguments, before anything runs.
        RuntimeError
            when another campaign holds the store.
        KeyboardInterrupt
            on Ctrl-C, after cancelling what had not started and writing the manifest;
            finished cases are kept.
        """
        own_pool = executor is None
        if not own_pool:
            if not callable(getattr(executor, "submit", None)):
                raise _checks.fail("executor", executor, "None, a concurrent.futures Executor or a "
                                   "dask.distributed Client (an object with submit())")
            if max_workers is not None:
                raise _checks.fail("max_workers", max_workers,
                                   "None when an executor is given (it applies to the local pool)")
        cores = _available_cores()
        if max_workers is not None:
            _checks.integer("max_workers", max_workers, ValueError, low=1)
        if own_pool:
            threads = max(c.settings.threads for c in self._cases)
            if threads > cores:
                raise _checks.fail("RunSettings.threads", threads,
                                   f"<= {cores}, the cores this process may use, for the local "
                                   "pool (pass an executor to run elsewhere)")
            if max_workers is not None and max_workers * threads > cores:
                raise _checks.fail("max_workers", max_workers,
                                   f"<= {cores // threads}: max_workers x threads per case "
                                   f"({threads}) may not exceed the {cores} cores")

        self._store.mkdir(parents=True, exist_ok=True)
        (self._store / "cases").mkdir(exist_ok=True)
        with _locked(self._store):
            _remove_temporaries(self._store)
            entries = self._entries(_scan(self._store))
            todo = [k for k, d in enumerate(self._hashes)
                    if entries[d]["status"] == "pending"
                    or (retry_failed and entries[d]["status"] == "failed")]
            _write_manifest(self._store, entries, self._analysis)
            if todo:
                self._execute(todo, entries, executor, max_workers, cores, progress)
        return self.results()

    def _entries(self, on_disk: dict[str, dict[str, Any]]) -> dict[str, dict[str, Any]]:
        """This campaign's cases (in order) with their status on disk, then any other cases
        the store holds."""
        entries: dict[str, dict[str, Any]] = {}
        for c, digest in zip(self._cases, self._hashes, strict=True):
            entries[digest] = on_disk.pop(digest, {}) or {
                "hash": digest, "name": c.scene.name, "seed": c.settings.seed,
                "status": "pending", "file": None, "wall_time_s": None, "error": None,
                "traceback": None}
        entries.update(on_disk)
        return entries

    def _execute(self, todo: list[int], entries: dict[str, dict[str, Any]], executor: Any,
                 max_workers: int | None, cores: int, progress: bool) -> None:
        pool = None
        if executor is None:
            from concurrent.futures import ProcessPoolExecutor

            threads = max(self._cases[k].settings.threads for k in todo)
            workers = max_workers or max(1, cores // threads)
            pool = ProcessPoolExecutor(max_workers=min(workers, len(todo)),
                                       mp_context=_WorkerContext(),
                                       initializer=_start_worker)
            executor = pool
        futures: dict[Any, int] = {}
        done_before = sum(1 for d in self._hashes if entries[d]["status"] == "done")
        try:
            with _bar(progress, len(self._cases), done_before) as bar:
                for k in todo:
                    futures[executor.submit(run_case, self._cases[k].to_dict())] = k
                for future in _completed(executor, list(futures), bar.refresh):
                    k = futures[future]
                    try:
                        outcome = future.result()
                    except Exception as exc:  # the worker itself died or was lost
                        outcome = {"status": "failed", "hash": self._hashes[k],
                                   "error": f"{type(exc).__name__}: {exc}",
                                   "traceback": _traceback_summary(exc), "wall_time_s": None}
                    entries[self._hashes[k]] = self._store_outcome(k, outcome)
                    _write_manifest(self._store, entries, self._analysis)
                    bar.update(1)
                    if outcome["status"] == "failed":
                        bar.set_postfix(failed=sum(
                            1 for d in self._hashes if entries[d]["status"] == "failed"))
        except BaseException:
            for future in futures:
                future.cancel()
            if pool is not None:
                _terminate_workers(pool)
            raise
        finally:
            if pool is not None:
                pool.shutdown(wait=True, cancel_futures=True)
            _write_manifest(self._store, entries, self._analysis)

    def _store_outcome(self, k: int, outcome: Mapping[str, Any]) -> dict[str, Any]:
        """Writes a worker's outcome for case ``k``; returns its manifest entry."""
        case = self._cases[k]
        digest = self._hashes[k]
        info: dict[str, Any] = {
            "format": CASE_FORMAT, "hash": digest, "case": case.to_dict(),
            "wall_time_s": outcome.get("wall_time_s"), "host": outcome.get("host"),
            "pid": outcome.get("pid"), "millscope_version": _core.build_info()["version"]}
        failure = _failure_path(self._store, digest)
        if outcome["status"] == "done" and outcome.get("hash") != digest:
            outcome = {"status": "failed", "error": f"the worker ran case "
                       f"{outcome.get('hash')!r}, not {digest!r}", "traceback": None}
        if outcome["status"] == "done":
            meta = dict(outcome["meta"])
            info["warm_up_samples_dropped"] = case.settings.warm_up_samples
            meta["campaign"] = info
            path = _case_path(self._store, digest)
            TorqueRecord(outcome["time_s"], outcome["torque_Nm"], meta).save(path)
            with contextlib.suppress(FileNotFoundError):
                failure.unlink()
            return _entry(info, "done", path, self._store)
        info["error"] = outcome.get("error")
        info["traceback"] = outcome.get("traceback")
        with atomic_write(failure, "w") as fh:
            json.dump(info, fh, indent=1)
        return _entry(info, "failed", failure, self._store)

    # -- results -------------------------------------------------------------------------------
    def results(self) -> list[CaseResult]:
        """Every case as the store holds it now (nothing runs), analysed over the block.

        Returns
        -------
        list of CaseResult
            In the order of :attr:`cases`; "pending" for cases never run, and for cases whose
            file cannot be read (:func:`unreadable_cases`): their ``error`` says why, and the
            next :meth:`run` computes them again.
        """
        out = []
        for case, digest in zip(self._cases, self._hashes, strict=True):
            problems = []
            path = _case_path(self._store, digest)
            if path.exists():
                try:
                    info, record = _open_done(path)
                except _Unreadable as exc:
                    problems.append(f"{path.relative_to(self._store).as_posix()}: {exc}")
                else:
                    out.append(CaseResult.from_record(
                        case, record, self._analysis,
                        wall_time_s=_number(info.get("wall_time_s"))))
                    continue
            failure = _failure_path(self._store, digest)
            if failure.exists():
                try:
                    info = _open_failed(failure)
                except _Unreadable as exc:
                    problems.append(f"{failure.relative_to(self._store).as_posix()}: {exc}")
                else:
                    out.append(CaseResult(case, digest, "failed",
                                          wall_time_s=_number(info.get("wall_time_s")),
                                          error=info.get("error"),
                                          traceback=info.get("traceback")))
                    continue
            out.append(CaseResult(case, digest, "pending",
                                  error=("unreadable case file " + "; ".join(problems)
                                         if problems else None)))
        return out


def _number(value: object) -> float:
    return float(value) if isinstance(value, (int, float)) else math.nan


@contextlib.contextmanager
def _bar(enabled: bool, total: int, initial: int) -> Iterator[Any]:
    from tqdm.auto import tqdm

    with tqdm(total=total, initial=initial, desc="campaign", unit="case",
              disable=not enabled) as bar:
        yield bar


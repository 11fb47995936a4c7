"""A long case that goes on where a killed run stopped: in-case checkpoints.

A paper-scale case can take hours of one core (a 14 s LDMS #4 case is about 1e11
particle-steps). A case that a campaign runs with a *partial folder* (``<store>/partial``, see
:class:`~millscope.campaign.Campaign`) saves, every ``checkpoint_every_s`` s of wall-clock
time, two files there:

* ``<hash>.samples.npz``: the torque samples taken so far (in the case's sampling mode and in
  the other, which the engine takes from the same steps), the wall-clock and CPU time spent on
  the case and how its settling went;
* ``<hash>.checkpoint.npz``: the simulation's full state
  (:meth:`~millscope.simulation.Simulation.save`, compressed: a paper-scale LDMS #4 state is
  2-4 MB instead of about 7 MB, which keeps it small enough to carry a case from one machine
  to the next in git).

The samples are written first and the checkpoint second, each atomically, so the checkpoint
never holds a later state than the samples: a run killed between the two leaves samples the
checkpoint has not reached, which the resumed run drops. A rerun of the case loads both and
runs on; because the engine is deterministic and samples on a fixed grid from the start of
rotation, the resumed record is the same to the bit as that of a run that was never stopped
(``tests/test_partial_runs.py``). Files that cannot be read, that belong to another millscope
version or disagree with each other are set aside with a warning and the case starts afresh:
they are a cache, never an input the result depends on.

The campaign deletes a case's partial files once its finished record is stored; the folder
holds a ``.gitignore`` so that a store committed to git never takes them in.
"""

from __future__ import annotations

import contextlib
import dataclasses
import json
import math
import threading
import time
import types
import warnings
import zipfile
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from .. import _checks
from .._files import atomic_write
from ..engine.simulation import (
    CheckpointError,
    Sampling,
    SettleReport,
    Simulation,
    other_sampling,
)
from ..signal.record import TorqueRecord
from .cases import Case

__all__ = ["CHECKPOINT_EVERY_S", "PARTIAL_DIR", "PartialFiles", "RunTime", "SavedPace",
           "saved_share", "simulate_resumable"]

#: The folder of a store that holds the in-case checkpoints of unfinished cases.
PARTIAL_DIR = "partial"
#: Default wall-clock time between two in-case checkpoints, s. A paper-scale checkpoint is a
#: few MB written in well under a second, so saving every 10 minutes costs nothing measurable
#: and a kill loses at most 10 minutes of the case.
CHECKPOINT_EVERY_S = 600.0
#: Samples per engine run between two looks at the clock: at most about a minute of an LDMS #4
#: case on one core, a few milliseconds of a tiny one.
_SEGMENT_SAMPLES = 10
_FORMAT = "millscope-partial-1"
_MAX_META_BYTES = 64 * 1024
_NPY_HEADER_BYTES = 1024  # an .npy member's header, at most (numpy writes 128 bytes)


@dataclass(frozen=True)
class PartialFiles:
    """The two files of one unfinished case in a partial folder."""

    folder: Path
    digest: str

    @property
    def samples(self) -> Path:
        """The samples taken so far, the wall and CPU time spent and the settle report."""
        return self.folder / f"{self.digest}.samples.npz"

    @property
    def checkpoint(self) -> Path:
        """The simulation's state (:meth:`Simulation.save`)."""
        return self.folder / f"{self.digest}.checkpoint.npz"

    def remove(self) -> None:
        """Deletes both files (those that exist)."""
        for path in (self.samples, self.checkpoint):
            with contextlib.suppress(FileNotFoundError):
                path.unlink()


@dataclass(frozen=True)
class RunTime:
    """What a case's runs took, over every run of it (a resumed case: the killed runs' saved
    time and the last run's).

    Attributes
    ----------
    wall_s : float
        Wall-clock time, s.
    cpu_s : float
        CPU time (user + system) of the process that ran it, all its threads (the engine's
        team too), s. nan when it is not known: when another case ran in the same process at
        the same time (a dask worker with several threads: one clock counts both), or when a
        run of the case saved no CPU time (a checkpoint of a millscope that did not record it).
    """

    wall_s: float
    cpu_s: float


class _CpuClock:
    """The CPU time of this process (:func:`time.process_time`) while one case runs, s, or nan
    when another case ran in the process meanwhile.

    The process's clock counts every thread, so two cases that overlap in one process (threads
    of a dask worker) cannot be told apart on it. The clocks under way are kept per process,
    as the clock is: a class attribute, shared by the threads that run cases.
    """

    _lock = threading.Lock()
    _running: set[_CpuClock] = set()  # the clocks of the cases under way in this process

    def __init__(self) -> None:
        self._overlapped = False  # whether another case ran in the process meanwhile
        self._start = 0.0  # the process's CPU time when the case began, s

    def __enter__(self) -> _CpuClock:
        with self._lock:
            for other in self._running:
                other._overlapped = True
            self._overlapped = bool(self._running)
            self._running.add(self)
        self._start = time.process_time()
        return self

    def elapsed(self) -> float:
        """CPU time since the case began, s; nan once another case has overlapped it."""
        spent = time.process_time() - self._start
        with self._lock:
            return math.nan if self._overlapped else spent

    def __exit__(self, kind: type[BaseException] | None, exc: BaseException | None,
                 tb: types.TracebackType | None) -> None:
        with self._lock:
            self._running.discard(self)


@dataclass
class _Progress:
    """What a case has done so far: its samples (s; N m in the case's sampling mode and in the
    other), the wall and CPU time spent on it and how its settling went."""

    time_s: NDArray[np.float64]
    torque_Nm: NDArray[np.float64]
    other_Nm: NDArray[np.float64]
    spent: RunTime
    settle: SettleReport | None

    def cut(self, taken: int) -> None:
        """Keeps the first ``taken`` samples."""
        self.time_s, self.torque_Nm = self.time_s[:taken], self.torque_Nm[:taken]
        self.other_Nm = self.other_Nm[:taken]

    def extend(self, runs: list[tuple[TorqueRecord, TorqueRecord]]) -> None:
        """Appends runs' records (each: the case's sampling mode, the other), in one copy."""
        if runs:
            self.time_s = np.concatenate([self.time_s, *(mine.time_s for mine, _ in runs)])
            self.torque_Nm = np.concatenate([self.torque_Nm,
                                             *(mine.torque_Nm for mine, _ in runs)])
            self.other_Nm = np.concatenate([self.other_Nm,
                                            *(other.torque_Nm for _, other in runs)])
            runs.clear()


def saved_share(files: PartialFiles, total_samples: int) -> float | None:
    """The share of a case's ``total_samples`` samples its last in-case checkpoint holds, in
    [0, 1], or None when it has none (or its samples file cannot be read now: it is a
    progress report, never an input)."""
    try:
        with np.load(files.samples, allow_pickle=False) as data:
            taken = int(data["time_s"].shape[0])
    except (OSError, ValueError, KeyError, zipfile.BadZipFile):
        return None
    return min(1.0, taken / total_samples)


class SavedPace:
    """How long the cases under way have left, from their saved shares seen over time.

    A case's share (:func:`saved_share`) moves only when its run saves, every
    ``checkpoint_every_s`` s. The pace of a case is taken between saves seen in this sitting:
    from the first rise of its share seen (a save, seen within a tick of it) to the last. The
    share first seen is not a start: a case resumed from an older save may wait in the queue
    behind other cases before it runs. The time left is the share still to run at that pace,
    less the time since the last save. Before a case has saved twice in the sitting there is
    no pace, and no time left to give.

    Parameters
    ----------
    clock : callable
        Seconds, monotonic (default :func:`time.monotonic`).
    """

    def __init__(self, clock: Callable[[], float] = time.monotonic) -> None:
        self._clock = clock
        self._seen: dict[str, float] = {}  # the share last seen
        self._saves: dict[str, list[tuple[float, float]]] = {}  # (time, share) at each rise

    def left_s(self, digest: str, share: float) -> float | None:
        """The wall-clock time case ``digest`` has left, s, at its pace so far in this sitting,
        given its saved share now; None while it has no pace."""
        now = self._clock()
        before = self._seen.setdefault(digest, share)
        saves = self._saves.setdefault(digest, [])
        if share > before:
            self._seen[digest] = share
            saves.append((now, share))
        if len(saves) < 2:
            return None
        (t0, s0), (t1, s1) = saves[0], saves[-1]
        rate = (s1 - s0) / (t1 - t0)
        return max(0.0, (1.0 - s1) / rate - (now - t1))

    def note(self, digest: str, share: float) -> str:
        """The share for a progress note, with the time left once there is a pace:
        ``"46 %"``, ``"63 % (~25 min left)"``, ``"52 % (~1.4 h left)"``."""
        left = self.left_s(digest, share)
        if left is None:
            return f"{100 * share:.0f} %"
        if left < 3600.0:
            return f"{100 * share:.0f} % (~{max(1, round(left / 60.0))} min left)"
        return f"{100 * share:.0f} % (~{left / 3600.0:.1f} h left)"


def _prepare_folder(folder: Path) -> None:
    folder.mkdir(parents=True, exist_ok=True)
    ignore = folder / ".gitignore"
    if not ignore.exists():
        with atomic_write(ignore, "w") as fh:
            fh.write("# in-case checkpoints of unfinished cases: a cache, never committed\n*\n")


def _save(files: PartialFiles, sim: Simulation, done: _Progress) -> None:
    """Writes the samples, then the checkpoint (the order the module docstring relies on)."""
    _prepare_folder(files.folder)
    cpu = done.spent.cpu_s
    meta = {"format": _FORMAT, "hash": files.digest, "wall_time_s": done.spent.wall_s,
            "cpu_time_s": cpu if math.isfinite(cpu) else None,
            "settle": None if done.settle is None else dataclasses.asdict(done.settle)}
    with atomic_write(files.samples, "wb") as fh:
        np.savez(fh, allow_pickle=False, meta_json=np.array(json.dumps(meta)),
                 time_s=done.time_s, torque_Nm=done.torque_Nm, other_Nm=done.other_Nm)
    sim.save(files.checkpoint, compress=True)


def _read_samples(files: PartialFiles, most_samples: int) -> _Progress:
    """The samples file of a case of ``most_samples`` samples, checked field by field (no
    member larger than those samples need is read); ValueError saying what is wrong."""
    with zipfile.ZipFile(files.samples) as zf:
        names = sorted(zf.namelist())
        if names != ["meta_json.npy", "other_Nm.npy", "time_s.npy", "torque_Nm.npy"]:
            raise ValueError(f"it holds {names}, not meta_json, time_s, torque_Nm and "
                             "other_Nm")
        for info in zf.infolist():
            most = _NPY_HEADER_BYTES + (_MAX_META_BYTES if info.filename == "meta_json.npy"
                                        else 8 * most_samples)
            if info.file_size > most:
                raise ValueError(f"its member {info.filename} is {info.file_size} bytes, more "
                                 f"than the {most} its case can need")
    with np.load(files.samples, allow_pickle=False) as data:
        meta = json.loads(str(data["meta_json"][()]))
        t = np.asarray(data["time_s"])
        y = np.asarray(data["torque_Nm"])
        o = np.asarray(data["other_Nm"])
    if not isinstance(meta, dict) or meta.get("format") != _FORMAT:
        raise ValueError(f"its format is not {_FORMAT!r}")
    if meta.get("hash") != files.digest:
        raise ValueError(f"it belongs to case {meta.get('hash')!r}")
    if any(a.dtype != np.float64 or a.shape != t.shape for a in (y, o)) or t.ndim != 1:
        raise ValueError("its samples are not three float64 arrays of one length")
    if not all(np.all(np.isfinite(a)) for a in (t, y, o)):
        raise ValueError("its samples are not all finite")
    wall = _checks.number("its wall_time_s", meta.get("wall_time_s"), ValueError, low=0.0,
                          unit="s")
    cpu = meta.get("cpu_time_s")  # absent from the checkpoints of older versions: not known
    if cpu is not None:
        cpu = _checks.number("its cpu_time_s", cpu, ValueError, low=0.0, unit="s")
    settle = meta.get("settle")
    report = None
    if settle is not None:
        if not isinstance(settle, dict) or set(settle) != {f.name for f in
                                                            dataclasses.fields(SettleReport)}:
            raise ValueError("its settle report is not one")
        report = SettleReport(float(settle["time_s"]), float(settle["kinetic_energy_ratio"]),
                              bool(settle["converged"]))
    return _Progress(t, y, o, RunTime(wall, math.nan if cpu is None else cpu), report)


def _resume(case: Case, files: PartialFiles) -> tuple[Simulation, _Progress] | None:
    """The simulation and samples a killed run of ``case`` left, or None (nothing usable: any
    files there are deleted, with a warning saying why)."""
    if not files.checkpoint.exists():
        files.remove()  # samples without a checkpoint: the first save was cut short
        return None
    s = case.settings
    try:
        done = _read_samples(files, s.total_samples)
        sim = Simulation.load(files.checkpoint, threads=s.threads)
        if (sim.scene.to_dict() != case.scene.to_dict() or sim.seed != s.seed
                or (s.dt is not None and sim.dt != s.dt)):
            raise ValueError("its checkpoint holds another scene, seed or time step")
        if sim.phase not in ("settled", "rotating"):
            raise ValueError(f"its checkpoint is {sim.phase}, not settled or rotating")
        taken = round(sim.time / s.sample_dt)
        expected = s.sample_dt * np.arange(1, taken + 1)
        if (len(done.time_s) < taken or taken >= s.total_samples
                or not np.allclose(done.time_s[:taken], expected, rtol=0, atol=sim.dt)):
            raise ValueError(f"its checkpoint is at sample {taken}; its samples file holds "
                             f"{len(done.time_s)} samples that do not lead there")
    except (OSError, ValueError, KeyError, CheckpointError, zipfile.BadZipFile) as exc:
        warnings.warn(f"the partial run of case {files.digest[:12]} in {files.folder} cannot "
                      f"be continued ({exc}); the case starts afresh", RuntimeWarning,
                      stacklevel=4)
        files.remove()
        return None
    sim.settle_report = done.settle
    done.cut(taken)
    return sim, done


def simulate_resumable(case: Case, folder: Path | None, *,
                       checkpoint_every_s: float = CHECKPOINT_EVERY_S,
                       ) -> tuple[Simulation, dict[Sampling, TorqueRecord], RunTime]:
    """Runs ``case`` (fill, settle, the whole ``duration_s``) from where a killed run left it
    in ``folder``, saving its progress there every ``checkpoint_every_s`` s of wall time.

    Parameters
    ----------
    case : Case
    folder : Path or None
        The partial folder (made if missing); None: the case runs from the start and saves
        nothing.
    checkpoint_every_s : float
        Wall-clock time between two saves, s, >= 0 (0: after every few samples). A save that
        fails (a full disk, a folder not writable) warns once and the run goes on without
        saving.

    Returns
    -------
    (Simulation, dict, RunTime)
        The simulation after the run; the record of every sample since the start of rotation
        in each sampling mode, ``"instant"`` and ``"mean"`` (the case's as
        :func:`~millscope.campaign.simulate_case` returns it, and the other from the same
        steps); and the wall and CPU time spent on the case in every run of it. Interrupted with
        Ctrl-C, the records are shorter and their ``meta["interrupted"]`` is true; what was
        saved stays for the next run.
    """
    with _CpuClock() as cpu:
        return _simulate_resumable(case, folder, checkpoint_every_s, cpu)


def _simulate_resumable(case: Case, folder: Path | None, checkpoint_every_s: float,
                        cpu: _CpuClock) -> tuple[Simulation, dict[Sampling, TorqueRecord],
                                                 RunTime]:
    s = case.settings
    files = None if folder is None else PartialFiles(Path(folder), case.hash())
    start = time.perf_counter()
    resumed = None if files is None else _resume(case, files)
    if resumed is None:
        sim = case.simulation()
        done = _Progress(np.empty(0), np.empty(0), np.empty(0), RunTime(0.0, 0.0), None)
    else:
        sim, done = resumed
    before = done.spent  # what the killed runs spent
    saving = files is not None
    last_save = start

    def spent() -> RunTime:
        """The time spent on the case so far, in every run of it."""
        return RunTime(before.wall_s + time.perf_counter() - start, before.cpu_s + cpu.elapsed())

    def save() -> None:
        nonlocal saving, last_save
        assert files is not None  # saving only with a folder
        done.spent = spent()
        try:
            _save(files, sim, done)
        except OSError as exc:
            warnings.warn(f"case {files.digest[:12]}: its progress cannot be saved in "
                          f"{files.folder} ({exc}); it runs on without in-case checkpoints",
                          RuntimeWarning, stacklevel=4)
            saving = False
        last_save = time.perf_counter()

    if sim.phase in ("empty", "filled"):
        done.settle = sim.settle(progress=False)
        if saving and time.perf_counter() - last_save >= checkpoint_every_s:
            save()
    other = other_sampling(s.sampling)
    interrupted = False
    metas: dict[Sampling, dict[str, object]] = {}
    # The runs since the last save, joined to the samples only when they are saved or at the
    # end: joining at every run would copy the whole record each time.
    pending: list[tuple[TorqueRecord, TorqueRecord]] = []
    taken = len(done.time_s)
    while taken < s.total_samples and not interrupted:
        left = s.total_samples - taken
        count = left if left < 2 * _SEGMENT_SAMPLES else _SEGMENT_SAMPLES
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)  # the interruption is reported
            sim.run(count * s.sample_dt, sample_dt=s.sample_dt, sampling=s.sampling,
                    progress=False)
        records = sim.last_records
        pending.append((records[s.sampling], records[other]))
        taken += len(records[s.sampling])
        metas = {mode: rec.meta for mode, rec in records.items()}
        interrupted = bool(metas[s.sampling].get("interrupted"))
        if saving and not interrupted and taken < s.total_samples and \
                time.perf_counter() - last_save >= checkpoint_every_s:
            done.extend(pending)
            save()
    done.extend(pending)
    out = {s.sampling: TorqueRecord(done.time_s, done.torque_Nm, metas[s.sampling]),
           other: TorqueRecord(done.time_s, done.other_Nm, metas[other])}
    return sim, out, spent()

"""Campaigns: many cases run through an executor into a resumable result store.

A **case** (:class:`Case`) is a :class:`~millscope.scene.Scene` plus how to run it
(:class:`RunSettings`: seed, duration, warm-up, sampling, threads, time step, settling). A
:class:`Campaign` runs its cases through any ``concurrent.futures``-style executor (a local
process pool by default, or a ``dask.distributed`` Client) and keeps the results in a store
directory::

    store/
      manifest.json          every case: hash, name, status, file, wall and CPU time, error
      cases/<hash>.npz       a finished case: its TorqueRecord (record.py's .npz format), the
                             case and how it ran in meta["campaign"]
      cases/<hash>.failed.json   a case that raised: the error and a traceback summary
      .lock                  held (flock) while a campaign runs on the store
      partial/<hash>.*.npz   a running case's in-case checkpoint (samples so far, state),
                             written every ``checkpoint_every_s`` s of wall time and deleted
                             once the case is stored (:mod:`millscope.campaign.partial`)

``<hash>`` is :meth:`Case.hash`: the sha256 of the canonical JSON of the case (scene,
settings, :data:`CASE_FORMAT`), the same in every process and on every machine, different as
soon as anything in the scene or the settings differs.

Every file is written atomically (a temporary file, then a rename), and only the process that
called :meth:`Campaign.run` writes: workers return their record, so a dask cluster needs no
shared file system. The files are the truth; the manifest is rebuilt from them at every start,
so a campaign killed at any point resumes where it stopped and keeps every case whose file was
written, and a long case killed half-way goes on from its last in-case checkpoint; a case file
that cannot be read (:func:`unreadable_cases` says why) is computed again. Cases another store
already finished (an earlier campaign or study sharing them) are copied in by
:meth:`Campaign.adopt` instead of being run again.
The local pool's workers do not run the caller's main module (no ``__main__`` guard needed)
and end when the campaign process ends, even when it is killed. A rerun skips finished cases
and retries failed ones; a case that raises is recorded as failed and the others go on. Ctrl-C
stops the campaign, keeping what has finished.

Typical use (docs/architecture.md, Public API)::

    scenes = ms.presets.paper_cases(particles=["ceramic"], speed_fractions=[0.71],
                                    load_levels=[1, 2, 3, 4], scale="paper")
    camp = ms.Campaign(scenes, store="runs/demo", duration=14.0, block=(4.0, 14.0))
    results = camp.run()                  # or camp.run(executor=dask_client)
    [(r.scene.name, r.mean_torque, r.lth_amplitude, r.energy) for r in results]

All quantities are SI (s, N m, Hz, (N m)^2 s).
"""

from __future__ import annotations

import contextlib
import json
import math
import os
import shutil
from collections.abc import Iterable, Iterator, Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

from .. import _checks, _core
from .._files import atomic_path, atomic_write
from .._frames import frame
from ..engine.simulation import _available_cores, other_sampling
from ..model.scene import Scene
from ..signal.analysis import WINDOWS, AnalysisSettings
from ..signal.record import TorqueRecord
from ..signal.spectral import WindowName
from .cases import _MIN_BLOCK_SAMPLES, CASE_FORMAT, Case, CaseResult, RunSettings, _seeds
from .executors import (
    _completed,
    _start_worker,
    _terminate_workers,
    _traceback_summary,
    _WorkerContext,
    run_case,
)
from .partial import (
    CHECKPOINT_EVERY_S,
    PARTIAL_DIR,
    PartialFiles,
    SavedPace,
    saved_share,
)
from .store import (
    _case_path,
    _entry,
    _failure_path,
    _listing,
    _locked,
    _open_done,
    _open_failed,
    _remove_temporaries,
    _scan,
    _stored,
    _Unreadable,
    _write_manifest,
    read_manifest,
    unreadable_cases,
)
from .tables import CASE_COLUMNS, CaseResults, case_row, unlisted_rows

if TYPE_CHECKING:
    from pandas import DataFrame

__all__ = ["Campaign", "read_store"]


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
                 window: WindowName = "hann") -> None:
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
        # Case k's twin: the same case in the other sampling mode, which the engine samples
        # from the same steps, so one run stores both.
        self._twins: dict[int, int] = {}
        for k, c in enumerate(out):
            twin = first.get(Case(c.scene, c.settings.replace(
                sampling=other_sampling(c.settings.sampling))).hash())
            if twin is not None:
                self._twins[k] = twin

        path = Path(store)
        if path.exists() and not path.is_dir():
            raise _checks.fail("store", str(store), "a directory (or a path to create one)")
        self._store = path
        self._bandwidth = _checks.positive("bandwidth", bandwidth, "Hz")
        self._window = _checks.choice("window", window, WINDOWS)
        self._block = None if block is None else self._check_block(block)
        self._analysis = (None if self._block is None
                          else AnalysisSettings(self._block, self._bandwidth, self._window))

    @classmethod
    def from_store(cls, store: str | os.PathLike[str], *,
                   block: tuple[float, float] | None = None, bandwidth: float | None = None,
                   window: WindowName | None = None) -> Campaign:
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
            block = tuple(saved["block"])
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
    def adopt(self, stores: Iterable[str | os.PathLike[str]]) -> tuple[str, ...]:
        """Copies into this campaign's store the finished cases of other stores that it lacks.

        A case is the same case wherever it ran (:meth:`Case.hash` names its scene and
        settings, and the engine is deterministic), so a campaign that shares cases with an
        earlier campaign or study need not run them again: e.g. the paper's campaign at the
        reference setting of an accuracy study. Each of this campaign's cases that is not
        finished in its own store is looked up in ``stores``, in order; the first whole,
        consistent file found (read as untrusted input, as :func:`unreadable_cases` checks
        it) is copied in, atomically. Failures and in-case checkpoints are not copied.

        Parameters
        ----------
        stores : iterable of str or path
            Other campaign store directories (a study's is ``<folder>/store``).

        Returns
        -------
        tuple of str
            The hashes of the cases copied, in the campaign's order.

        Raises
        ------
        ValueError
            when a store is not a directory or is this campaign's own store, before anything
            is copied.
        RuntimeError
            when another campaign holds this store.
        """
        if isinstance(stores, (str, bytes, os.PathLike)) or not isinstance(stores, Iterable):
            raise _checks.fail("stores", stores, "an iterable of campaign store directories")
        sources = [Path(s) for s in stores]
        for k, src in enumerate(sources):
            if not src.is_dir():
                raise _checks.fail(f"stores[{k}]", str(src),
                                   "an existing campaign store directory")
            if self._store.is_dir() and src.resolve() == self._store.resolve():
                raise _checks.fail(f"stores[{k}]", str(src),
                                   f"another store than this campaign's own ({self._store})")
        self._store.mkdir(parents=True, exist_ok=True)
        (self._store / "cases").mkdir(exist_ok=True)
        copied: list[str] = []
        with _locked(self._store):
            _remove_temporaries(self._store)
            finished = {d for d, (status, _, _) in _stored(self._store).items()
                        if status == "done"}
            for digest in self._hashes:
                if digest in finished:
                    continue
                for src in sources:
                    # The copy is what is checked, so the source is read once and what
                    # lands is what passed.
                    try:
                        with atomic_path(_case_path(self._store, digest)) as tmp:
                            shutil.copyfile(_case_path(src, digest), tmp)
                            _open_done(tmp, digest)
                    except (_Unreadable, OSError):
                        continue  # missing or damaged there: try the next store
                    PartialFiles(self._store / PARTIAL_DIR, digest).remove()
                    copied.append(digest)
                    break
            if copied:
                _write_manifest(self._store, self._entries(_scan(self._store)), self._analysis)
        return tuple(copied)

    def run(self, executor: Any = None, *, max_workers: int | None = None,
            progress: bool = True, retry_failed: bool = True,
            checkpoint_every_s: float | None = CHECKPOINT_EVERY_S) -> CaseResults:
        """Runs every case not yet finished in the store, then returns all results.

        Two cases that differ only in their sampling mode (``"instant"`` and ``"mean"``) run
        once: the engine takes both kinds of sample from the same steps, so the one run stores
        both cases, each the same to the bit as if it had run alone.

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
        checkpoint_every_s : float or None
            Wall-clock time between two in-case checkpoints of a running case, s, >= 0
            (default 600): each case saves its progress in ``<store>/partial`` and a campaign
            killed in the middle of a long case goes on from there when run again, with the
            same record to the bit (:mod:`millscope.campaign.partial`). The files of a case
            are deleted once it is stored. None: cases save nothing and a killed case starts
            again. With a remote executor the workers save where they see this path; a worker
            that cannot write there warns and runs on without saving.

        Returns
        -------
        CaseResults
            One CaseResult per case, in order (:meth:`results`): a list, and its table
            (``.to_frame()``).

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
        if checkpoint_every_s is not None:
            _checks.number("checkpoint_every_s", checkpoint_every_s, ValueError, low=0.0,
                           unit="s", why="wall-clock time between two in-case checkpoints, "
                           "or None for none")
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
                self._execute(todo, entries, executor, max_workers, cores, progress,
                              checkpoint_every_s)
        return self.results()

    def _entries(self, on_disk: dict[str, dict[str, Any]]) -> dict[str, dict[str, Any]]:
        """This campaign's cases (in order) with their status on disk, then any other cases
        the store holds."""
        entries: dict[str, dict[str, Any]] = {}
        for c, digest in zip(self._cases, self._hashes, strict=True):
            entries[digest] = on_disk.pop(digest, {}) or {
                "hash": digest, "name": c.scene.name, "seed": c.settings.seed,
                "status": "pending", "file": None, "wall_time_s": None, "cpu_time_s": None,
                "error": None, "traceback": None}
        entries.update(on_disk)
        return entries

    def _execute(self, todo: list[int], entries: dict[str, dict[str, Any]], executor: Any,
                 max_workers: int | None, cores: int, progress: bool,
                 checkpoint_every_s: float | None) -> None:
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
        todo, carries = self._runs_of(todo)
        try:
            with _bar(progress, len(self._cases), done_before) as bar:
                partial = (None if checkpoint_every_s is None
                           else str(self._store / PARTIAL_DIR))
                for k in todo:
                    futures[executor.submit(run_case, self._cases[k].to_dict(), partial,
                                            checkpoint_every_s or 0.0)] = k

                pace = SavedPace()

                def tick() -> None:
                    running = [k for f, k in futures.items() if not f.done()]
                    bar.set_postfix_str(self._bar_note(running, entries, partial, pace),
                                        refresh=False)
                    bar.refresh()

                for future in _completed(executor, list(futures), tick):
                    k = futures[future]
                    try:
                        outcome = future.result()
                    except Exception as exc:  # the worker itself died or was lost
                        outcome = {"status": "failed", "hash": self._hashes[k],
                                   "error": f"{type(exc).__name__}: {exc}",
                                   "traceback": _traceback_summary(exc), "wall_time_s": None}
                    entries[self._hashes[k]] = self._store_outcome(k, outcome)
                    if k in carries:
                        twin = carries[k]
                        entries[self._hashes[twin]] = self._store_outcome(
                            twin, _twin_outcome(outcome, self._hashes[twin]))
                        bar.update(1)
                    _write_manifest(self._store, entries, self._analysis)
                    bar.update(1)
                    tick()
        except BaseException:
            for future in futures:
                future.cancel()
            if pool is not None:
                _terminate_workers(pool)
            raise
        finally:
            if pool is not None:
                pool.shutdown(wait=True, cancel_futures=True)
            # From the files, not from ``entries``: a Ctrl-C between storing a case and
            # booking it would otherwise leave the manifest a case behind the store.
            _write_manifest(self._store, self._entries(_scan(self._store)), self._analysis)

    def _runs_of(self, todo: list[int]) -> tuple[list[int], dict[int, int]]:
        """The cases of ``todo`` that run, and ``carries[k]``: the twin that case k's run
        stores as well. A case whose twin also runs is stored from the twin's run (the engine
        samples both modes at once)."""
        carries: dict[int, int] = {}
        waiting = set(todo)
        for k in todo:
            twin = self._twins.get(k)
            if twin is not None and twin in waiting and k in waiting:
                carries[k] = twin
                waiting.discard(twin)
        return [k for k in todo if k in waiting], carries

    def _bar_note(self, running: list[int], entries: Mapping[str, Mapping[str, Any]],
                  partial: str | None, pace: SavedPace) -> str:
        """The progress bar's note: the failed cases, and how far the cases under way are by
        their last in-case checkpoints, with the time they have left at their pace in this
        sitting (a long case moves the bar only when it ends)."""
        saved = []
        for k in running:
            digest = self._hashes[k]
            share = None if partial is None else saved_share(
                PartialFiles(Path(partial), digest), self._cases[k].settings.total_samples)
            if share is not None:
                saved.append(pace.note(digest, share))
        failed = sum(1 for d in self._hashes if entries[d]["status"] == "failed")
        notes = [f"failed={failed}"] if failed else []
        if saved:
            notes.append("saved " + ", ".join(saved))
        return ", ".join(notes)

    def _store_outcome(self, k: int, outcome: Mapping[str, Any]) -> dict[str, Any]:
        """Writes a worker's outcome for case ``k``; returns its manifest entry."""
        case = self._cases[k]
        digest = self._hashes[k]
        info: dict[str, Any] = {
            "format": CASE_FORMAT, "hash": digest, "case": case.to_dict(),
            "wall_time_s": outcome.get("wall_time_s"), "cpu_time_s": outcome.get("cpu_time_s"),
            "host": outcome.get("host"),
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
            PartialFiles(self._store / PARTIAL_DIR, digest).remove()
            return _entry(info, "done", path, self._store)
        info["error"] = outcome.get("error")
        info["traceback"] = outcome.get("traceback")
        with atomic_write(failure, "w") as fh:
            json.dump(info, fh, indent=1)
        return _entry(info, "failed", failure, self._store)

    # -- results -------------------------------------------------------------------------------
    def results(self) -> CaseResults:
        """Every case as the store holds it now (nothing runs), analysed over the block.

        Returns
        -------
        CaseResults
            A list of CaseResult, in the order of :attr:`cases`, with its table
            (:meth:`CaseResults.to_frame`); "pending" for cases never run, and for cases whose
            file cannot be read (:func:`unreadable_cases`): their ``error`` says why, and the
            next :meth:`run` computes them again.
        """
        out = CaseResults()
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
                        wall_time_s=_seconds(info.get("wall_time_s")),
                        cpu_time_s=_seconds(info.get("cpu_time_s"))))
                    continue
            failure = _failure_path(self._store, digest)
            if failure.exists():
                try:
                    info = _open_failed(failure)
                except _Unreadable as exc:
                    problems.append(f"{failure.relative_to(self._store).as_posix()}: {exc}")
                else:
                    out.append(CaseResult(case, digest, "failed",
                                          wall_time_s=_seconds(info.get("wall_time_s")),
                                          error=info.get("error"),
                                          traceback=info.get("traceback")))
                    continue
            out.append(CaseResult(case, digest, "pending",
                                  error=("unreadable case file " + "; ".join(problems)
                                         if problems else None)))
        return out


def read_store(store: str | os.PathLike[str], *, block: tuple[float, float] | None = None,
               bandwidth: float | None = None, window: WindowName | None = None) -> DataFrame:
    """Every case a campaign store holds as one table (a pandas DataFrame), nothing run.

    The rows of :meth:`CaseResults.to_frame` for the store's cases
    (:meth:`Campaign.from_store`: finished and failed, analysed as the store's campaign
    analysed them unless ``block``, ``bandwidth`` or ``window`` say otherwise), then one row
    per case the store names but cannot give: a damaged case file (``status``
    ``"unreadable"``, ``error`` naming the file and why) and a case its manifest lists
    without a file (``"pending"``); their scene and seed are the manifest's, or missing.

    Parameters
    ----------
    store : str or path
        A campaign store directory.
    block, bandwidth, window
        As :meth:`Campaign.from_store`.

    Returns
    -------
    pandas.DataFrame
        Columns :data:`~millscope.campaign.tables.CASE_COLUMNS`
        (:meth:`CaseResults.to_frame` says what each holds, in which unit and type).

    Raises
    ------
    ValueError
        as :meth:`Campaign.from_store`: no such directory, no readable case file, a damaged
        manifest, or a block that does not fit.
    """
    campaign = Campaign.from_store(store, block=block, bandwidth=bandwidth, window=window)
    rows = [case_row(r) for r in campaign.results()]
    rows += unlisted_rows(campaign.store, set(campaign.hashes))
    return frame(CASE_COLUMNS, rows)


def _twin_outcome(outcome: Mapping[str, Any], digest: str) -> dict[str, Any]:
    """The outcome of the twin (case ``digest``, the other sampling mode) of a case's run: its
    samples in the other mode from the same steps, or the same failure."""
    other = outcome.get("other")
    if outcome["status"] != "done" or not isinstance(other, Mapping):
        why = (f"failed: {outcome.get('error')}" if outcome["status"] != "done"
               else "returned no samples in the other sampling mode")
        return {**outcome, "status": "failed", "hash": digest, "traceback": None,
                "error": f"its twin in the other sampling mode, whose run makes it, {why}"}
    meta = {**outcome["meta"], "sampling": other["sampling"]}
    return {**outcome, "hash": digest, "torque_Nm": other["torque_Nm"], "meta": meta}


def _seconds(value: object) -> float:
    """A time a case file states, s: a finite number >= 0, else nan (not known)."""
    x = _checks.as_float(value)
    return x if math.isfinite(x) and x >= 0 else math.nan


@contextlib.contextmanager
def _bar(enabled: bool, total: int, initial: int) -> Iterator[Any]:
    from tqdm.auto import tqdm

    with tqdm(total=total, initial=initial, desc="campaign", unit="case",
              disable=not enabled) as bar:
        yield bar

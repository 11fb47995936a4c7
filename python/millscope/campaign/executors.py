"""Running cases: the worker side (:func:`run_case`, the local pool's worker processes, which
end with their campaign) and waiting on any executor (a ``concurrent.futures`` pool or a
``dask.distributed`` Client).
"""

from __future__ import annotations

import contextlib
import dataclasses
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
from collections.abc import Callable, Iterator, Mapping
from pathlib import Path
from typing import Any

from ..engine.simulation import Simulation, other_sampling
from ..signal.record import TorqueRecord
from .cases import Case
from .partial import CHECKPOINT_EVERY_S, simulate_resumable

__all__ = ["run_case", "simulate_case"]

_TRACEBACK_FRAMES = 12  # frames kept in a failed case's traceback summary (the innermost)
_TRACEBACK_CHARS = 8000
_TERMINATE_WAIT_S = 10.0  # how long to wait for a terminated worker process to end, s
_ORPHAN_EXIT_CODE = 70  # a worker's exit status when it ends because its campaign died
_TICK_S = 5.0  # the progress bar is redrawn this often while no case finishes, s
_MAIN_SWAP_LOCK = threading.Lock()  # one worker launch at a time hides __main__


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


def simulate_case(case: Case, *, track_energy: bool = False,
                  progress: bool = False) -> tuple[Simulation, TorqueRecord]:
    """Runs one case where it is called: its Simulation, filled, settled and run for the
    whole ``duration_s`` (warm-up included).

    Parameters
    ----------
    case : Case
    track_energy : bool
        Book the dissipated energy (:class:`~millscope.simulation.Simulation`).
    progress : bool
        Show the simulation's progress bars.

    Returns
    -------
    (Simulation, TorqueRecord)
        The simulation after the run (for its energies or a checkpoint) and the record of
        every sample since the start of rotation; the warm-up is
        ``case.settings.warm_up_samples`` samples long. Interrupted with Ctrl-C, the record
        is shorter and its ``meta["interrupted"]`` is true.
    """
    s = case.settings
    sim = case.simulation(track_energy=track_energy)
    rec = sim.run(s.total_samples * s.sample_dt, sample_dt=s.sample_dt,
                  sampling=s.sampling,
                  progress=progress)
    return sim, rec


def run_case(case: Mapping[str, Any], partial_dir: str | None = None,
             checkpoint_every_s: float = CHECKPOINT_EVERY_S) -> dict[str, Any]:
    """Runs one case where it is called (a worker); never raises for a failing case.

    Parameters
    ----------
    case : mapping
        :meth:`Case.to_dict` (plain data, so any executor can ship it).
    partial_dir : str, optional
        A folder for in-case checkpoints (:mod:`millscope.campaign.partial`): the case goes on
        from what a killed run of it saved there, and saves its own progress there every
        ``checkpoint_every_s`` s of wall time. None: the case runs from the start, saving
        nothing.
    checkpoint_every_s : float
        Wall-clock time between two in-case checkpoints, s, >= 0.

    Returns
    -------
    dict
        ``status`` "done" with ``time_s``, ``torque_Nm`` (arrays: s, N m), ``meta`` and
        ``other`` (``{"sampling": the other mode, "torque_Nm": its samples}``, taken from the
        same steps), or
        "failed" with ``error`` and ``traceback``; always ``hash``, ``wall_time_s`` (s),
        ``host`` and ``pid``; when done, ``cpu_time_s``: the CPU time of the process over the
        case's runs, s, or None when it is not known (:class:`~millscope.campaign.partial.RunTime`).
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
        sim, records, spent = simulate_resumable(
            c, None if partial_dir is None else Path(partial_dir),
            checkpoint_every_s=checkpoint_every_s)
        rec = records[s.sampling]
        other = other_sampling(s.sampling)
        if rec.meta.get("interrupted") or len(rec) != s.total_samples:
            raise RuntimeError(f"the run was interrupted after {len(rec)} of "
                               f"{s.total_samples} samples")
        settle = sim.settle_report
        meta = rec.meta
        meta["settle"] = None if settle is None else dataclasses.asdict(settle)
        return {"status": "done", "hash": digest, "time_s": rec.time_s[s.warm_up_samples:],
                "torque_Nm": rec.torque_Nm[s.warm_up_samples:], "meta": meta,
                "other": {"sampling": other,
                          "torque_Nm": records[other].torque_Nm[s.warm_up_samples:]},
                "wall_time_s": spent.wall_s,
                "cpu_time_s": spent.cpu_s if math.isfinite(spent.cpu_s) else None, **where}
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

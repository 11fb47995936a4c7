"""Simulation: fill the drum, settle the charge, spin the drum and record the drive torque.

A :class:`Simulation` runs one :class:`~millscope.scene.Scene` on the C++ engine
(``cpp/include/millscope/engine.hpp``): Hertz-Mindlin no-slip contacts with damping (paper
section 3.1, eqs. 1-8), velocity Verlet, gravity along -y, drum axis along +z
(docs/architecture.md, Units and axes).

Life of a simulation::

    sim = Simulation(scene, seed=0)        # checks dt against the stability limit; runs nothing
    rec = sim.run(14.0)                    # fills, settles, starts the drum, records 14 s
    rec2 = sim.run(2.0)                    # continues (times go on from 14 s)
    sim.run(1.0, snapshot_every=5, snapshot_dir="vtk")  # with VTK snapshots for ParaView
    sim.save("case.ckpt"); sim = Simulation.load("case.ckpt")

* **Filling** (:meth:`Simulation.fill`, :mod:`millscope.engine.filling`): every fraction,
  largest first, goes onto a hexagonal close-packed lattice of its own (pitch 1.05 d,
  jittered; solid fraction 0.64, about that of the settled bed) clear of the shell, the
  lifters and the end walls, and of the particles already placed; a fraction takes random
  sites among the lowest ones, so the bed is mixed and starts in the lower segment at about
  the height it settles to. Reproducible from ``seed``.
* **Settling** (:meth:`Simulation.settle`): the drum at rest until 99 % of the particles have a
  kinetic energy below ``settle_tolerance`` x m g d (after at least ``settle_min_s``);
  if that takes longer than ``settle_max_s``, a :class:`SettleWarning` says so and it goes on.
* **Rotation**: the drum starts impulsively at the scene's speed (as the LIGGGHTS yardstick
  does); record time 0 is the start of rotation.
* **Sampling**: sample k is stamped t_k = k ``sample_dt`` (k >= 1). ``"instant"`` takes the
  torque of the step nearest t_k (as EDEM writes it; the paper's data); ``"mean"`` averages
  exactly the steps that end in (t_k - sample_dt, t_k] (anti-aliased). A run that starts
  between sample times begins with the first sample whose interval starts then or later. The
  record's meta says which mode was used.

All quantities are SI. Long runs show a tqdm bar (``progress=False`` turns it off) and Ctrl-C
stops a run between chunks, keeping what was recorded.
"""

from __future__ import annotations

import json
import math
import os
import signal
import threading
import time
import warnings
import zipfile
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from functools import partial
from pathlib import Path
from typing import Any, Literal, TypeVar

import numpy as np
from numpy.typing import NDArray

from .. import _checks, _core
from .._files import atomic_write
from ..model.scene import Scene
from ..model.stiffness import time_step_limit, upper_impact_speed
from ..signal.record import TorqueRecord
from . import checkpoint as _checkpoint
from .filling import FILLING, fill_positions
from .running_threads import RunningThreads
from .snapshots import ChargeSnapshot, VtkSeries, check_folder

__all__ = ["CheckpointError", "Energies", "LedgerOffError", "Sampling", "SettleReport",
           "SettleWarning", "Simulation", "check_threads"]

#: how a torque sample is taken: the value at its instant, or the mean over its interval
Sampling = Literal["instant", "mean"]


def other_sampling(mode: Sampling) -> Sampling:
    """The other sampling mode ("mean" for "instant" and back): the engine takes both from
    the same steps (:attr:`Simulation.last_records`)."""
    return "mean" if mode == "instant" else "instant"

_T = TypeVar("_T")

CHECKPOINT_FORMAT = "millscope-checkpoint-3"  # 2: the ledger holds "dissipated"; 3: "order"
#: Guards (docs/physics.md, Guards): a run stops with a message naming the step, the particle and
#: its values when a particle moves faster than SPEED_BOUND_FACTOR x the fastest impact of the
#: scene (:func:`millscope.stiffness.upper_impact_speed`, omega R + sqrt(2 g D): a particle
#: leaves the shell at most at its speed and falls at most the diameter; collisions share
#: energy, they do not make it), or when a contact is deeper than
#: MAX_OVERLAP_FRACTION of the smaller radius (of the particle's, at the drum): the smaller
#: body's centre has then reached the other's surface and the contact normal means nothing.
#: A run that blows up passes both within steps. Sound runs stay below: the deepest contacts
#: of the pilot mill reach about 2 % of the ceramic radius at paper stiffness, 15 % at the
#: "small" scale and 50 % at the "tiny" one (shear moduli x 0.001), whose contacts are far
#: outside Hertz theory (tests/physics/test_guards.py).
SPEED_BOUND_FACTOR = 10.0
MAX_OVERLAP_FRACTION = 1.0
#: The default Verlet-list skin (:func:`default_skin`): the list is rebuilt once a particle
#: has moved half the skin, and a particle at the upper impact speed should need at least
#: SKIN_REBUILD_STEPS steps for that; the skin stays within SKIN_RANGE x the smallest radius
#: (0.4 r_min is what the LIGGGHTS yardstick uses; the pairs listed grow as the cube of the
#: contact distance plus the skin, so a much larger skin makes every step's pair search pay
#: for the rebuilds it saves).
SKIN_REBUILD_STEPS = 10
SKIN_RANGE = (0.4, 1.2)
#: Engine work handed to C++ in one call, in particle-steps and in steps (a step has a cost of
#: its own however few the particles): Ctrl-C and the progress bar act between calls, so a
#: call must last well under a second on a slow machine.
_CHUNK_PARTICLE_STEPS = 5.0e6
_CHUNK_STEPS = 20_000
#: The most steps one call of run() or settle() may take. Beyond it a run would last months
#: on any machine (a step costs at least a microsecond), and step offsets would lose their
#: exact representation as doubles long before the engine's 64-bit counter overflows.
MAX_RUN_STEPS = 10**12


class SettleWarning(RuntimeWarning):
    """The charge did not come to rest within the settling time limit."""


class CheckpointError(ValueError):
    """A checkpoint file is damaged, from another version, or not a checkpoint at all."""


#: the entries of Simulation.energies() that only the energy ledger books
LEDGER_ONLY = ("dissipated", "damping_loss", "friction_loss", "spring_work")


class LedgerOffError(KeyError):
    """An energy that only the energy ledger books, asked of a run made without it."""

    def __str__(self) -> str:  # KeyError would show the message in quotes
        return str(self.args[0])


class Energies(dict[str, float]):
    """What :meth:`Simulation.energies` returns: a dict of J. Without the energy ledger, an
    entry only the ledger books raises :class:`LedgerOffError`, which says how to book it,
    instead of a plain ``KeyError``."""

    def __missing__(self, key: str) -> float:
        if key in LEDGER_ONLY:
            raise LedgerOffError(
                f"energies()[{key!r}] is not booked: this Simulation runs, or ran before its "
                "checkpoint, without the energy ledger; make it with "
                "Simulation(..., track_energy=True) to book the losses from the start")
        raise KeyError(key)


@dataclass(frozen=True)
class SettleReport:
    """How the settling went.

    Attributes
    ----------
    time_s : float
        Simulated settling time, s.
    kinetic_energy_ratio : float
        The 99th percentile over the particles of kinetic energy / (m g d) at the end.
    converged : bool
        Whether the ratio fell below the tolerance within the time limit.
    """

    time_s: float
    kinetic_energy_ratio: float
    converged: bool


Phase = Literal["empty", "filled", "settled", "rotating"]
_PHASES: tuple[Phase, ...] = ("empty", "filled", "settled", "rotating")
#: The arrays of the engine's snapshot, saved as .npy members of a checkpoint (listed once, in
#: the engine: Engine::Snapshot::for_each_field).
_SNAPSHOT_ARRAYS: tuple[str, ...] = tuple(_core.SNAPSHOT_ARRAYS)


class Simulation:
    """One scene on the DEM engine.

    Parameters
    ----------
    scene : Scene
        What is in the mill (``millscope.presets.pilot_mill`` builds the paper's cases).
    seed : int
        Seed of the filling (positions and jitter); the same seed gives the same run.
    dt : float, optional
        Time step, s. Default: ``DEFAULT_DT_FRACTION`` (0.2) x the smallest Rayleigh time of the
        charge, or the scene's limit where that is smaller (heavily damped contacts). A step
        above the limit (:func:`millscope.stiffness.time_step_limit`: 0.8 x the
        velocity-Verlet stability bound of the fastest damped normal or tangential-rotational
        stick mode of its contacts at the upper impact speed, and at most ``MAX_DT_FRACTION``
        (0.5) x that Rayleigh time) raises ``ValueError`` naming the limit, the pair of
        fractions and the mode that set it.
    threads : int, optional
        OpenMP threads of the engine, in [1, the cores this process may use] (else
        ``ValueError``, see :func:`check_threads`); default: all those cores. The work of
        each step is split into this many shares, and runs are reproducible bit for bit at a
        given thread count.
    skin : float, optional
        Verlet-list skin, m, > 0; default :func:`default_skin` (0.4 x the smallest radius at
        the paper's stiffness, more at the soft scales' long time steps). It changes the cost
        of a step, never which contacts act.
    settle_tolerance : float
        Settled when 99 % of the particles have a kinetic energy < this x m g d.
    settle_min_s, settle_max_s : float
        Least and most simulated settling time, s.
    track_energy : bool
        Book the energy the dashpots and sliding take out (``energies()["dissipated"]`` and
        its split); default off. It costs a quarter to a half of the run time (the
        dissipating forces are summed per particle besides the forces, and the widest pair
        search is not used); the forces, the motion and the torque are the same to the bit
        without it. Off, only the drive's work is booked, and ``energies()`` refuses the
        losses with a message that says how to book them.
    adapt_threads : bool
        Time the engine's calls and run the threads' shares on one thread, in turn, while
        that steps faster than the whole team (when other programs hold some of the cores,
        threads that wait for each other twice a step can be several times slower than one);
        the results are the same to the bit (see :mod:`millscope.engine.running_threads`).
        Default on; benchmarks of the thread count turn it off. Also a settable attribute.
    """

    def __init__(self, scene: Scene, seed: int = 0, dt: float | None = None,
                 threads: int | None = None, *, skin: float | None = None,
                 settle_tolerance: float = 1e-4, settle_min_s: float = 0.2,
                 settle_max_s: float = 3.0, track_energy: bool = False,
                 adapt_threads: bool = True) -> None:
        if not isinstance(scene, Scene):
            raise TypeError(f"scene must be a millscope Scene, not {type(scene).__name__}")
        if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
            raise ValueError(f"seed = {seed!r} is not valid; it must be an integer >= 0")
        limit = time_step_limit(scene)
        dt = limit.default_dt() if dt is None else limit.check(dt)
        threads = _available_cores() if threads is None else check_threads(threads)
        if skin is not None and not (math.isfinite(skin) and skin > 0.0):
            raise ValueError(f"skin = {skin!r} m is not valid; it must be finite and > 0")
        for name, value in (("settle_tolerance", settle_tolerance),
                            ("settle_min_s", settle_min_s), ("settle_max_s", settle_max_s)):
            if not (math.isfinite(value) and value > 0.0):
                raise ValueError(f"{name} = {value!r} is not valid; it must be finite and > 0")
        if not isinstance(track_energy, (bool, np.bool_)):
            raise ValueError(f"track_energy = {track_energy!r} is not valid; it must be True or "
                             "False")
        if not isinstance(adapt_threads, (bool, np.bool_)):
            raise ValueError(f"adapt_threads = {adapt_threads!r} is not valid; it must be True "
                             "or False")
        if settle_max_s < settle_min_s:
            raise ValueError(f"settle_max_s = {settle_max_s} s is not valid; it must be >= "
                             f"settle_min_s = {settle_min_s} s")

        self._scene = scene
        self._seed = int(seed)
        self._rng = np.random.default_rng(self._seed)
        self._settle = (float(settle_tolerance), float(settle_min_s), float(settle_max_s))
        self._engine = _make_engine(scene, float(dt), int(threads), skin, bool(track_energy))
        self._running = RunningThreads(int(threads))
        self.adapt_threads = bool(adapt_threads)
        self._phase: Phase = "empty"
        self.settle_report: SettleReport | None = None
        #: Torque of the drum's parts over the last run, N m: "shell", "lifters", "ends".
        self.last_parts: dict[str, NDArray[np.float64]] = {}
        #: The last run's record in each sampling mode, "instant" and "mean": the one run()
        #: returned and the other, sampled from the same steps (the engine takes both at once).
        self.last_records: dict[Sampling, TorqueRecord] = {}
        #: The VTK series written into each folder (:meth:`write_vtk`, run's snapshots).
        self._series: dict[Path, VtkSeries] = {}

    # -- facts -----------------------------------------------------------------------------
    @property
    def scene(self) -> Scene:
        return self._scene

    @property
    def seed(self) -> int:
        return self._seed

    @property
    def dt(self) -> float:
        """Time step, s."""
        return float(self._engine.dt)

    @property
    def track_energy(self) -> bool:
        """Whether the run books the dissipated energy (see the class docstring)."""
        return bool(self._engine.track_energy)

    @property
    def threads(self) -> int:
        """The engine's threads: the shares each step's work is split into."""
        return int(self._engine.threads)

    @property
    def running_threads(self) -> int:
        """The threads that ran the shares in the last call into the engine (see
        ``adapt_threads``)."""
        return int(self._engine.running_threads)

    def _advance(self, steps: int) -> None:
        """``steps`` steps, in one call or more (a probe of the running threads takes fewer
        steps; the engine's steps are the same however they are split into calls)."""
        e = self._engine
        end = e.step_count + steps
        while e.step_count < end:
            self._call(int(end - e.step_count), e.advance)

    def _call(self, max_steps: int, call: Callable[..., _T], *args: Any) -> _T:
        """One call into the engine, ``call(steps, *args)`` with ``steps`` <= ``max_steps``,
        on the running threads that step faster now when ``adapt_threads`` is set (else on
        all of them), timed for the next choice."""
        e = self._engine
        running, limit = (self._running.plan(max_steps) if self.adapt_threads
                          else (self.threads, max_steps))
        e.running_threads = running
        steps, t0 = e.step_count, time.perf_counter()
        out = call(limit, *args)
        if self.adapt_threads:
            self._running.record(running, int(e.step_count - steps), time.perf_counter() - t0)
        return out

    @property
    def phase(self) -> Phase:
        """``"empty"`` (nothing placed), ``"filled"`` (placed, not settled), ``"settled"`` (at
        rest, drum stopped) or ``"rotating"``."""
        return self._phase

    @property
    def time(self) -> float:
        """Time since the start of rotation, s (0 before it)."""
        if self._phase != "rotating":
            return 0.0
        return float((self._engine.step_count - self._engine.rotation_start_step) * self.dt)

    @property
    def drum_angle(self) -> float:
        """Angle the drum has turned through about +z since it was filled, rad."""
        return float(self._engine.drum_angle)

    @property
    def variant(self) -> str:
        """Which specialised engine kernel the scene runs on (law, materials, lifters, ends)."""
        return str(self._engine.variant)

    @property
    def positions(self) -> NDArray[np.float64]:
        """Particle centres, (N, 3) m."""
        return np.asarray(self._engine.positions)

    @property
    def velocities(self) -> NDArray[np.float64]:
        """Particle velocities, (N, 3) m/s."""
        return np.asarray(self._engine.velocities)

    @property
    def spins(self) -> NDArray[np.float64]:
        """Particle angular velocities, (N, 3) rad/s."""
        return np.asarray(self._engine.spins)

    @property
    def bytes_per_particle(self) -> float:
        """Memory the engine keeps per particle, bytes: the state, the per-particle constants,
        the wall contact history, the neighbour list with its history, cell grid and build
        buffers, and the threads' pair buffers (capacities, not sizes)."""
        return float(self._engine.bytes_per_particle)

    def energies(self) -> Energies:
        """Energies now and work since the start, J.

        ``kinetic``, ``potential`` (m g y, y = 0 on the axis), ``elastic`` (stored in contacts),
        ``drive_work`` (done by the drive), ``dissipated`` (taken out by the dashpots and by
        sliding, exactly as the integrator applied them), its split ``damping_loss`` and
        ``friction_loss``, and ``spring_work``: the energy the Mindlin tangential springs gain
        without work, because their stiffness follows the overlap (paper eq. 6) and a contact
        that ends in tension drops what its spring holds (about 0.7 % of the drive work at
        mu = 0.15, 13 % at mu = 1). They close the balance
        drive_work + spring_work = change of (kinetic + potential + elastic) + dissipated
        to velocity Verlet's O(dt^2) error. The split is evaluated with the half-step
        velocities the forces were computed from, a first-order estimate:
        ``damping_loss + friction_loss`` exceeds ``dissipated`` by O(dt / contact time), about
        4 % at the default step.

        A simulation made without ``track_energy`` books none of the losses nor
        ``spring_work``, and one loaded with it from a checkpoint of a run without it cannot
        know them: the mapping then holds the first four only, and asking it for the others
        raises :class:`LedgerOffError` (a ``KeyError``) that says how to book them.
        """
        e = self._engine
        out = {"kinetic": e.kinetic_energy(), "potential": e.potential_energy(),
               "elastic": e.elastic_energy()}
        out.update(e.ledger())
        # The engine holds NaN for what it has not booked since the start.
        return Energies((k, float(v)) for k, v in out.items()
                        if k not in LEDGER_ONLY or (self.track_energy and math.isfinite(v)))

    def snapshot(self) -> ChargeSnapshot:
        """The particles' state now (copies) with the drum's angle and angular velocity; once
        the particles are placed (after :meth:`fill`, else ``RuntimeError``)."""
        if self._phase == "empty":
            raise RuntimeError("there is no charge to show yet: the drum is empty; call fill(), "
                               "settle() or run() first")
        e = self._engine
        return ChargeSnapshot(
            scene=self._scene, time_s=self.time, step=int(e.step_count),
            drum_angle=self.drum_angle, omega=float(e.omega),
            positions=self.positions.copy(), velocities=self.velocities.copy(),
            spins=self.spins.copy(), radii=self._scene.particle_radii(),
            materials=self._scene.particle_materials())

    def write_vtk(self, folder: str | os.PathLike[str]) -> tuple[Path, Path]:
        """Writes the state now into the VTK series in ``folder`` (made if missing), for
        ParaView: the particles, the drum at the same angle and the ``.pvd`` collections
        (:mod:`millscope.engine.snapshots` describes the files). A folder not writable raises
        ``ValueError`` naming it.

        Returns
        -------
        (Path, Path)
            The particle file and the drum file written.
        """
        return self._vtk_series("folder", folder).add(self.snapshot())

    def _vtk_series(self, where: str, folder: str | os.PathLike[str]) -> VtkSeries:
        """The series this simulation writes into ``folder`` (checked, see VtkSeries)."""
        path = check_folder(where, folder)
        key = path.resolve()
        if key not in self._series:
            self._series[key] = VtkSeries(path, up_to_step=int(self._engine.step_count))
        return self._series[key]

    def max_overlap_ratio(self) -> float:
        """Largest contact overlap over the radius of the smaller body (dimensionless)."""
        return float(self._engine.max_overlap_ratio())

    # -- filling and settling ----------------------------------------------------------------
    def fill(self) -> None:
        """Places every particle without overlap inside the drum (reproducible from the seed)."""
        if self._phase != "empty":
            raise RuntimeError(f"fill() is for an empty drum; this simulation is {self._phase}")
        self._engine.positions = fill_positions(self._scene, self._rng)
        self._phase = "filled"

    def settle(self, *, progress: bool = True) -> SettleReport:
        """Lets the charge come to rest in the stopped drum (fills it first if empty)."""
        if self._phase == "rotating":
            raise RuntimeError("settle() is for a stopped drum; the drum is already rotating")
        tolerance, t_min, t_max = self._settle
        self._check_steps("settle_max_s", t_max)
        if self._phase == "empty":
            self.fill()
        # The rest measure every 0.02 s of simulated time, or more often where that much time
        # would make a call too long to interrupt.
        chunk = min(max(1, int(round(0.02 / self.dt))), self._steps_per_call())
        elapsed, ratio = 0.0, math.inf
        with _progress(progress, t_max, "settling", "s") as bar:
            while True:
                self._advance(chunk)
                elapsed += chunk * self.dt
                ratio = self._rest_measure()
                bar.update(chunk * self.dt)
                if elapsed >= t_min and ratio < tolerance:
                    break
                if elapsed >= t_max:
                    warnings.warn(
                        f"the charge did not settle within settle_max_s = {t_max} s: 99 % of "
                        f"the particles have a kinetic energy below {ratio:.3g} x m g d "
                        f"(tolerance {tolerance}); going on", SettleWarning, stacklevel=2)
                    break
        self.settle_report = SettleReport(elapsed, ratio, ratio < tolerance)
        self._phase = "settled"
        return self.settle_report

    def _rest_measure(self) -> float:
        """The 99th percentile of kinetic energy / (m g d) over the particles. A percentile, not
        the mean: without rolling resistance a ball can roll along a trough between lifters
        for ever (with periodic ends), which must not hold the whole charge up."""
        e = self._engine
        m, r = np.asarray(e.mass), np.asarray(e.radius)
        v, w = np.asarray(e.velocities), np.asarray(e.spins)
        ke = 0.5 * m * np.sum(v * v, axis=1) + 0.2 * m * r * r * np.sum(w * w, axis=1)
        return float(np.quantile(ke / (m * self._scene.gravity * 2.0 * r), 0.99))

    # -- running -----------------------------------------------------------------------------
    def run(self, duration: float, sample_dt: float = 0.01,
            sampling: Sampling = "instant", *,
            progress: bool = True, snapshot_every: int | None = None,
            snapshot_dir: str | os.PathLike[str] | None = None) -> TorqueRecord:
        """Runs the rotating mill for ``duration`` s and returns its drive torque.

        The first call fills and settles the charge and starts the drum; record time 0 is the
        start of rotation, and later calls continue the time axis.

        Parameters
        ----------
        duration : float
            Simulated time to record, s (> 0); rounded to whole samples.
        sample_dt : float
            Sampling interval, s (>= dt); 0.01 s in the paper.
        sampling : {"instant", "mean"}
            Instantaneous torque at each sample time, or the mean over each interval.
        progress : bool
            Show a tqdm progress bar.
        snapshot_every : int, optional
            Write a VTK snapshot (:meth:`write_vtk`) into ``snapshot_dir`` after every torque
            sample whose index k (t_k = k sample_dt) is a multiple of this, >= 1: the state then
            is that of the step the sample was taken at. The run is cut there into the same
            engine calls a resumed run makes, so the torque is the same to the bit as without
            snapshots. A snapshot that cannot be written warns and the run goes on without
            further snapshots.
        snapshot_dir : path-like, optional
            The folder of the snapshots (made if missing, must be writable); given together with
            ``snapshot_every``. The series there goes on where this simulation's state is (a run
            continued from a checkpoint keeps the earlier snapshots; a new simulation starts
            afresh).

        Returns
        -------
        TorqueRecord
            ``time_s`` from the start of rotation, ``torque_Nm`` the drive torque (positive
            when the charge resists rotation; docs/architecture.md, Torque); ``meta`` holds the
            scene, dt, seed, rotation frequency, lifter count and sampling mode. The parts (shell,
            lifters, end walls) are in :attr:`last_parts`, and the record in the other
            sampling mode, taken from the same steps, in :attr:`last_records`. Interrupted with
            Ctrl-C, the record holds what was sampled and ``meta["interrupted"]`` is true.
        """
        if not (isinstance(duration, (int, float)) and math.isfinite(duration) and duration > 0):
            raise ValueError(f"duration = {duration!r} s is not valid; it must be finite and > 0")
        if not (isinstance(sample_dt, (int, float)) and math.isfinite(sample_dt)
                and sample_dt >= self.dt):
            raise ValueError(f"sample_dt = {sample_dt!r} s is not valid; it must be >= the time "
                             f"step dt = {self.dt:.6g} s")
        if sampling not in ("instant", "mean"):
            raise ValueError(f"sampling = {sampling!r} is not valid; it must be 'instant' or "
                             "'mean'")
        snapshots = snapshot_every is not None or snapshot_dir is not None
        every = _checks.count("snapshot_every", snapshot_every) if snapshots else 0
        if snapshots and snapshot_dir is None:
            raise _checks.fail("snapshot_dir", None, "a writable folder when snapshot_every is "
                               "given")
        self._check_steps("duration", duration + sample_dt)
        count = int(round(duration / sample_dt))
        if count < 2:
            raise ValueError(f"duration = {duration} s is not valid; it must hold at least 2 "
                             f"samples of sample_dt = {sample_dt} s")
        series = (None if snapshot_dir is None
                  else self._vtk_series("snapshot_dir", snapshot_dir))
        if self._phase in ("empty", "filled"):
            self.settle(progress=progress)
        if self._phase == "settled":
            self._engine.start_rotation(self._scene.omega)
            self._phase = "rotating"

        e = self._engine
        max_steps = self._steps_per_call()
        rows: list[NDArray[np.float64]] = []
        taken = 0
        last_index: int | None = None  # index k of the last sample taken (with snapshots)
        with _progress(progress, count * sample_dt, "simulating", "s") as bar, \
                _interrupt_flag() as stop:
            while taken < count and not stop.is_set():
                before = self.time
                want = count - taken
                if series is not None:
                    # Up to the next sample index that is a multiple of `every` (one sample
                    # first, to learn where the run starts).
                    want = min(want, 1 if last_index is None else every - last_index % every)
                # Calls of at most max_steps steps, each going on with the sample under way.
                sampled = partial(e.advance_sampled, sample_dt, sampling == "mean", want)
                out = np.asarray(self._call(max_steps, sampled, bool(rows)))
                rows.append(out)
                taken += len(out)
                bar.update(self.time - before)
                if series is not None and len(out):
                    last_index = int(round(out[-1, 0] / sample_dt))
                    if last_index % every == 0:
                        series = self._snapshot_into(series)
            interrupted = taken < count
        if interrupted:
            warnings.warn(f"run interrupted: kept {taken} of {count} samples", RuntimeWarning,
                          stacklevel=2)
        data = np.concatenate(rows) if rows else np.empty((0, 9))
        self.last_parts = {"shell": data[:, 2], "lifters": data[:, 3], "ends": data[:, 4]}
        other = other_sampling(sampling)
        self.last_records = {
            sampling: TorqueRecord(data[:, 0], data[:, 1],
                                   self._meta(sample_dt, sampling, interrupted)),
            other: TorqueRecord(data[:, 0], data[:, 5], self._meta(sample_dt, other, interrupted))}
        return self.last_records[sampling]

    def _snapshot_into(self, series: VtkSeries) -> VtkSeries | None:
        """Adds the state now to ``series``; None (no more snapshots) when it cannot be
        written, with a warning: the run and its torque matter more than its pictures."""
        try:
            series.add(self.snapshot())
        except OSError as exc:
            warnings.warn(f"a VTK snapshot could not be written into {series.folder} "
                          f"({exc}); the run goes on without snapshots", RuntimeWarning,
                          stacklevel=3)
            return None
        return series

    def _steps_per_call(self) -> int:
        """The most steps one call into the engine may take (see _CHUNK_PARTICLE_STEPS)."""
        return max(1, min(_CHUNK_STEPS, int(_CHUNK_PARTICLE_STEPS / self._engine.size)))

    def _check_steps(self, name: str, seconds: float) -> None:
        """Refuses, before any work, a span of simulated time that needs more than
        MAX_RUN_STEPS steps at this dt."""
        steps = seconds / self.dt
        if steps > MAX_RUN_STEPS:
            raise ValueError(
                f"{name} = {seconds:g} s is not valid: at dt = {self.dt:.6g} s it needs "
                f"{steps:.3g} steps; one call may take at most {MAX_RUN_STEPS:.0e} steps "
                f"({MAX_RUN_STEPS * self.dt:.6g} s at this dt)")

    def _meta(self, sample_dt: float, sampling: str, interrupted: bool) -> dict[str, Any]:
        lifters = self._scene.drum.lifters
        return {
            "source": "millscope DEM",
            "millscope_version": _core.build_info()["version"],
            "scene": self._scene.to_dict(),
            "scene_name": self._scene.name,
            "dt": self.dt,
            "seed": self._seed,
            "threads": self.threads,
            "rotation_hz": self._scene.rotation_hz,
            "lifters": 0 if lifters is None else lifters.count,
            "sampling": sampling,
            "sample_dt": sample_dt,
            "engine": self.variant,
            "filling": FILLING,
            "interrupted": interrupted,
        }

    # -- checkpoints -------------------------------------------------------------------------
    def save(self, path: str | os.PathLike[str], *, compress: bool = False) -> Path:
        """Writes the full state (a checkpoint) to ``path`` (.npz), atomically.

        A simulation loaded from it and run on the same number of threads continues exactly
        (bit for bit) as this one would.

        Parameters
        ----------
        path : path
            The file to write.
        compress : bool
            Deflate the arrays (:func:`numpy.savez_compressed`): a paper-scale checkpoint
            takes about half the bytes, at the cost of a fraction of a second to write it.
            :meth:`load` reads either kind.
        """
        _checks.flag("compress", compress)
        snap = self._engine.snapshot()
        arrays = {k: np.asarray(v) for k, v in snap.items() if isinstance(v, np.ndarray)}
        scalars = {k: v for k, v in snap.items() if not isinstance(v, np.ndarray)}
        meta = {
            "format": CHECKPOINT_FORMAT,
            "millscope_version": _core.build_info()["version"],
            "scene": self._scene.to_dict(),
            "seed": self._seed,
            "dt": self.dt,
            "threads": self.threads,
            "skin": float(self._engine.skin),
            "track_energy": self.track_energy,
            "phase": self._phase,
            "settle": list(self._settle),
            "rng_state": self._rng.bit_generator.state,
            "engine_scalars": {k: list(v) if isinstance(v, tuple) else v
                               for k, v in scalars.items()},
        }
        path = Path(path)
        with atomic_write(path, "wb") as f:
            # allow_pickle=False: the snapshot holds numeric arrays only (and no array key can
            # take the place of the keyword)
            write = np.savez_compressed if compress else np.savez
            write(f, allow_pickle=False, meta_json=np.array(json.dumps(meta)), **arrays)
        return path

    @classmethod
    def load(cls, path: str | os.PathLike[str], *, threads: int | None = None,
             track_energy: bool | None = None) -> Simulation:
        """Reads a checkpoint written by :meth:`save`.

        ``threads`` defaults to the thread count of the saved run (needed for a bit-for-bit
        continuation), ``track_energy`` to the saved run's (a run continued without it keeps
        the same motion; its losses read NaN from then on).

        A checkpoint is untrusted input: every array and number the engine would take is
        checked first (:mod:`millscope._checkpoint` lists the checks). A damaged file, a file
        that is not a checkpoint, one from another millscope version, one whose fields break
        the engine's invariants (an index out of range, a count below 0, an unknown phase,
        values of the wrong type or precision, a time step outside the scene's range), or
        whose saved thread count exceeds the cores this process may use (pass ``threads``)
        raises :class:`CheckpointError` and nothing else; ``threads`` and ``track_energy``
        themselves are checked as in the constructor (``ValueError``), and so is the
        environment's MILLSCOPE_SIMD (the SIMD path of the engine's kernels).
        """
        if threads is not None:
            threads = check_threads(threads)
        _core.simd_path()  # a MILLSCOPE_SIMD this CPU cannot run: ValueError, not the file's
        if track_energy is not None and not isinstance(track_energy, (bool, np.bool_)):
            raise ValueError(f"track_energy = {track_energy!r} is not valid; it must be None, "
                             "True or False")
        path = Path(path)
        try:
            with zipfile.ZipFile(path) as zf:
                return cls._from_checkpoint(zf, threads, track_energy)
        except FileNotFoundError:
            raise
        except CheckpointError as exc:
            raise CheckpointError(f"{path}: {exc}") from None
        except _checkpoint.Refused as exc:
            raise CheckpointError(f"{path} is not a valid millscope checkpoint: {exc}") from None
        except Exception as exc:  # noqa: BLE001 - whatever a damaged file provokes
            raise CheckpointError(f"{path} is damaged or not a millscope checkpoint: "
                                  f"{type(exc).__name__}: {exc}") from None

    @classmethod
    def _from_checkpoint(cls, zf: zipfile.ZipFile, threads: int | None,
                         track_energy: bool | None) -> Simulation:
        """The simulation a checkpoint holds, every field checked (see :meth:`load`)."""
        ck = _checkpoint
        names = {"meta_json", *_SNAPSHOT_ARRAYS}
        meta = ck.read_meta(zf, zf.getinfo("meta_json.npy"))
        if meta.get("format") != CHECKPOINT_FORMAT:
            raise CheckpointError(f"not a millscope checkpoint (format {meta.get('format')!r}, "
                                  f"expected {CHECKPOINT_FORMAT!r})")
        version = _core.build_info()["version"]
        if meta.get("millscope_version") != version:
            raise CheckpointError(
                f"written by millscope {meta.get('millscope_version')!r}; this is {version}, "
                "which cannot continue it exactly. Rerun the case, or load it with the version "
                "that wrote it.")
        found = ck.members(zf, names)
        keys = {"format", "millscope_version", "scene", "seed", "dt", "threads", "skin",
                "track_energy", "phase", "settle", "rng_state", "engine_scalars"}
        if meta.keys() != keys:
            raise ck.Refused(f"its meta has the keys {sorted(meta)}; a checkpoint's are "
                             f"{sorted(keys)}")
        try:
            scene = Scene.from_dict(meta["scene"])
        except Exception as exc:  # noqa: BLE001 - the scene's own checks, whatever they raise
            raise ck.Refused(f"its scene is not valid: {exc}") from None
        seed = ck.integer("seed", meta["seed"], 0, 2**64 - 1)
        dt = ck.check_dt(meta["dt"], scene)
        saved_threads = ck.integer("threads", meta["threads"], 1)
        if threads is None:
            try:
                threads = check_threads(saved_threads)
            except ValueError as exc:
                raise ck.Refused(f"{exc}; pass threads= to load it here (the continuation is "
                                 "then not bit for bit that of the saved run)") from None
        skin = ck.check_skin(meta["skin"], scene)
        saved_energy = ck.boolean("track_energy", meta["track_energy"])
        phase = meta["phase"]
        if phase not in _PHASES:
            raise ck._refuse("phase", phase, f"one of {', '.join(_PHASES)}")
        tol, t_min, t_max = ck.check_settle(meta["settle"])
        try:
            sim = cls(scene, seed=seed, dt=dt, threads=threads, skin=skin,
                      settle_tolerance=tol, settle_min_s=t_min, settle_max_s=t_max,
                      track_energy=saved_energy if track_energy is None else track_energy)
        except ValueError as exc:
            raise ck.Refused(str(exc)) from None
        rng_state = ck.check_rng_state(meta["rng_state"], sim._rng.bit_generator.state)
        # The engine just made for the scene says what each field must look like.
        template = sim._engine.snapshot()
        scalars = ck.check_scalars(meta["engine_scalars"],
                                   {k: v for k, v in template.items() if k not in names},
                                   phase, scene, dt)
        n = scene.n_particles
        partners = ck.max_partners(scene, sim._engine.skin)
        history_size = int(sim._engine.history_size)  # the law's, per pair and wall slot
        limits = {"list_start": n + 1, "list_partner": partners,
                  "list_history": history_size * partners}
        arrays = {k: ck.read_npy(zf, found[k], template[k].dtype,
                                 limits.get(k, template[k].size))
                  for k in _SNAPSHOT_ARRAYS}
        ck.check_arrays(arrays, scalars, scene, float(sim._engine.skin),
                        float(sim._engine.max_speed), history_size,
                        template["wall_history"].size)
        sim._engine.restore({**arrays, **scalars})
        sim._rng.bit_generator.state = rng_state
        sim._phase = phase
        return sim

    def __repr__(self) -> str:
        return (f"Simulation({self._scene.name or 'scene'!r}, {self._engine.size} particles, "
                f"dt={self.dt:.4g} s, threads={self.threads}, {self._phase})")


# -- helpers ---------------------------------------------------------------------------------

def _available_cores() -> int:
    """The cores this process may use: its CPU affinity, else the machine's count."""
    try:
        return len(os.sched_getaffinity(0))
    except (AttributeError, OSError):  # not on Linux
        return os.cpu_count() or 1


def check_threads(threads: object, name: str = "threads") -> int:
    """``threads`` as an int when it is a usable engine thread count, else ``ValueError``.

    Parameters
    ----------
    threads : object
        The thread count asked for.
    name : str
        How the message names it.

    Returns
    -------
    int
        The count, in [1, N] with N the cores this process may use (its CPU affinity, else
        the machine's count). More OpenMP threads than that only contend for the same cores,
        and very large counts crash or hang the OpenMP runtime.

    Raises
    ------
    ValueError
        Naming ``name``, the value and the valid range.
    """
    if (isinstance(threads, (bool, np.bool_)) or not isinstance(threads, (int, np.integer))
            or not 1 <= threads <= _available_cores()):
        raise ValueError(f"{name} = {threads!r} is not valid; it must be {threads_range()}")
    return int(threads)


def threads_range() -> str:
    """What a thread count must be, for messages: "an integer in [1, N], ..."."""
    return f"an integer in [1, {_available_cores()}], the cores this process may use"


def default_skin(scene: Scene, dt: float) -> float:
    """The Verlet-list skin a simulation of ``scene`` at time step ``dt`` (s) uses by default, m.

    The list is rebuilt once a particle has moved skin / 2 since the last build, so the skin
    is 2 x SKIN_REBUILD_STEPS x v_max x dt, v_max the upper impact speed
    (:func:`millscope.stiffness.upper_impact_speed`), within SKIN_RANGE x the smallest
    particle radius. At the paper's stiffness (dt about 2.6 us) that is the floor, 0.4 r_min;
    the soft scales' steps are 10 to 30 times longer, and with the floor alone they would
    rebuild the list every 5 to 15 steps.
    """
    r_min = float(np.min(scene.particle_radii()))
    low, high = SKIN_RANGE
    return float(np.clip(2.0 * SKIN_REBUILD_STEPS * upper_impact_speed(scene) * dt,
                         low * r_min, high * r_min))


def _make_engine(scene: Scene, dt: float, threads: int, skin: float | None,
                 track_energy: bool) -> _core.Engine:
    drum = scene.drum
    lifters = drum.lifters
    geometry_args: dict[str, Any] = {
        "radius": drum.radius, "length": drum.length, "end_walls": drum.end_walls,
        "lifters": 0 if lifters is None else lifters.count,
        "lifter_width": 0.0 if lifters is None else lifters.width,
        "lifter_height": 0.0 if lifters is None else lifters.height,
        "lifter_phase": 0.0 if lifters is None else lifters.phase,
    }
    if lifters is not None and lifters.profile == "trapezoidal":
        geometry_args["lifter_top_width"] = lifters.tip_width
    geometry = _core.DrumGeometry(**geometry_args)
    restitution, friction = scene.pair_matrices()
    materials = [_core.Material(m.density, m.shear_modulus, m.poisson) for m in scene.materials]
    return _core.Engine(materials, restitution, friction, scene.material_index(drum.material),
                        geometry, scene.particle_radii(), scene.particle_materials(), dt,
                        gravity=scene.gravity,
                        skin=default_skin(scene, dt) if skin is None else skin,
                        clamp_normal=scene.clamp_normal_force, threads=threads,
                        track_energy=track_energy,
                        max_speed=SPEED_BOUND_FACTOR * upper_impact_speed(scene),
                        max_overlap=MAX_OVERLAP_FRACTION)


@contextmanager
def _progress(enabled: bool, total: float, desc: str, unit: str) -> Iterator[Any]:
    if not enabled:
        class _Silent:
            def update(self, _n: float) -> None:
                pass
        yield _Silent()
        return
    from tqdm.auto import tqdm

    with tqdm(total=total, desc=desc, unit=unit, unit_scale=False,
              bar_format="{l_bar}{bar}| {n:.2f}/{total:.2f} s [{elapsed}<{remaining}]") as bar:
        yield bar


@contextmanager
def _interrupt_flag() -> Iterator[threading.Event]:
    """Turns Ctrl-C into a flag checked between chunks (main thread only). A process that
    ignores SIGINT (a campaign's pool worker, whose campaign handles Ctrl-C) keeps ignoring it."""
    stop = threading.Event()
    if threading.current_thread() is not threading.main_thread():
        yield stop
        return
    previous = signal.getsignal(signal.SIGINT)
    if previous is signal.SIG_IGN:
        yield stop
        return

    def handler(_signum: int, _frame: Any) -> None:
        stop.set()

    signal.signal(signal.SIGINT, handler)
    try:
        yield stop
    finally:
        signal.signal(signal.SIGINT, previous)

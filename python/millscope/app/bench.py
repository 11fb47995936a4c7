"""Throughput of the DEM engine on the pilot mill, over a steady tumbling stretch.

For each scene: particle-steps per second, ns per particle-step and bytes per particle, on each
thread count asked for (1 and 2 by default); then the speed-up of the most threads over the
fewest, and what leaving out the lifters, the friction or the one-material kernel saves
(docs/architecture.md, What a scene pays for). The ``slice`` scene checks that the
cost stays linear in the particle count: periodic axial slices of the balls-only mill with
10 000, 50 000 and 200 000 balls (or ``--slice-sizes``) should keep ns per particle-step within
20 % of each other.

    python -m millscope bench                          # paper scale, every scene but slice
    python -m millscope bench --scale soft --steps 5000 --scenes balls
    python -m millscope bench --slice-sizes 10000 50000 200000 --threads 2

Each scene is filled, settled and spun up for ``--spin-up`` seconds once; that tumbling state
is cached as a checkpoint under the cache folder (``out/bench-cache`` by default; delete it, or
pass ``--no-cache``, to redo it). The timed stretch starts from the cached state, so every
thread count and repeat runs the same steps. The steps are counted by the engine's own step
counter (the torque is sampled on whole steps, so a run takes up to 1 % more steps than
``--steps``). The timed runs keep the torque alone, as a campaign does, without booking the
dissipated energy (``Simulation(track_energy=False)``; LIGGGHTS does not book it either).
The last line, ``particle_steps_per_s=<value>``, is the first scene on the most threads.
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import sys
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from types import MappingProxyType
from typing import TextIO

from .._core import build_info
from ..engine.simulation import (
    CHECKPOINT_FORMAT,
    Simulation,
    _available_cores,
    check_threads,
    threads_range,
)
from ..model import presets
from ..model.scene import MAX_PERIOD_LENGTH, Scene
from ..model.stiffness import time_step_limit

__all__ = [
    "DEFAULT_CACHE_DIR",
    "DEFAULT_SLICE_SIZES",
    "SCENES",
    "SLICE_SPREAD_TARGET",
    "VARIANTS",
    "Measurement",
    "add_arguments",
    "build_scene",
    "main",
    "measure",
    "run",
    "run_from_args",
    "tumbling_state",
]

DEFAULT_CACHE_DIR = Path("out/bench-cache")
DEFAULT_SLICE_SIZES = (10_000, 50_000, 200_000)
SLICE_SPREAD_TARGET = 1.2  # max / min of ns per particle-step over the slice sizes
SLICE = "slice"  # the scene name that expands into one slice per size
MIN_SPIN_UP_S = 0.02  # two torque samples of 10 ms
_SAMPLE_DT = 0.01  # s: the paper's torque sampling, used for the spin-up
_TIMED_SAMPLES = 100  # the timed stretch is sampled at least this finely (whole samples)
_SEED = 1


def balls(scale: str) -> Scene:
    """The balls-only pilot mill at 71 % of critical (paper Table 1, 2466 balls of 25 mm)."""
    return presets.pilot_mill(0.71, None, scale=scale)


def ceramic4(scale: str) -> Scene:
    """The pilot mill at 71 % with load level #4 of ceramic particles."""
    return presets.pilot_mill(0.71, "ceramic", 4, scale=scale)


def no_lifters(scale: str) -> Scene:
    """``balls`` with a smooth shell."""
    s = balls(scale)
    return dataclasses.replace(s, drum=dataclasses.replace(s.drum, lifters=None))


def frictionless(scale: str) -> Scene:
    """``balls`` with every friction coefficient 0 (no tangential history, no torques)."""
    s = balls(scale)
    return dataclasses.replace(
        s, pairs=tuple(dataclasses.replace(p, friction=0.0) for p in s.pairs))


def pair_table(scale: str) -> Scene:
    """``balls`` with the drum made of an identical copy of steel: the same physics, but the
    kernel looks each contact's constants up in a pair table."""
    s = balls(scale)
    steel = next(m for m in s.materials if m.name == s.drum.material)
    copy = dataclasses.replace(steel, name=steel.name + " (drum)")
    like = next(p for p in s.pairs if {p.a, p.b} == {steel.name})
    extra = (dataclasses.replace(like, a=steel.name, b=copy.name),
             dataclasses.replace(like, a=copy.name, b=copy.name))
    return dataclasses.replace(s, materials=s.materials + (copy,), pairs=s.pairs + extra,
                               drum=dataclasses.replace(s.drum, material=copy.name))


#: The fixed scenes by name; each builds its Scene from a scale.
SCENES: Mapping[str, Callable[[str], Scene]] = MappingProxyType({
    "balls": balls, "ceramic4": ceramic4, "no_lifters": no_lifters,
    "frictionless": frictionless, "pair_table": pair_table})
#: Scenes compared against "balls".
VARIANTS = ("no_lifters", "frictionless", "pair_table")


def slice_name(n_particles: int) -> str:
    """Bench name of the axial slice with ``n_particles`` balls, e.g. ``"slice-10000"``."""
    return f"{SLICE}-{n_particles}"


def build_scene(name: str, scale: str) -> Scene:
    """The scene of a bench name: one of :data:`SCENES`, or ``"slice-N"`` for
    :func:`millscope.presets.axial_slice` with N balls.

    Parameters
    ----------
    name : str
        Bench scene name.
    scale : {"paper", "small", "tiny", "soft"}
        See :data:`millscope.presets.SCALES`; a slice takes only the stiffness from it.

    Returns
    -------
    Scene
    """
    if name in SCENES:
        return SCENES[name](scale)
    prefix = SLICE + "-"
    if name.startswith(prefix) and name[len(prefix):].isdigit():
        return presets.axial_slice(int(name[len(prefix):]), scale)
    raise ValueError(f"scene = {name!r} is not valid; it must be one of {', '.join(SCENES)} "
                     f"or '{SLICE}-N' (N balls, {presets.SLICE_MIN_BALLS} <= N <= "
                     f"{presets.SLICE_MAX_BALLS})")


@dataclass(frozen=True)
class Measurement:
    """One timed stretch of a scene on some threads.

    Attributes
    ----------
    scene : str
        Bench scene name.
    particles : int
        Number of spheres.
    threads : int
        OpenMP threads of the engine.
    steps : int
        Time steps taken in the timed stretch, from the engine's step counter.
    dt : float
        Time step, s.
    wall_s : float
        Wall-clock time of the stretch, s.
    bytes_per_particle : float
        The engine's memory (state, neighbour list, contact history, thread buffers) divided
        by the particle count, bytes, after the stretch.
    """

    scene: str
    particles: int
    threads: int
    steps: int
    dt: float
    wall_s: float
    bytes_per_particle: float

    @property
    def particle_steps(self) -> int:
        """particles x steps."""
        return self.particles * self.steps

    @property
    def particle_steps_per_s(self) -> float:
        """Throughput, particle-steps per second of wall-clock time."""
        return self.particle_steps / self.wall_s

    @property
    def ns_per_particle_step(self) -> float:
        """Wall-clock cost of one particle-step, ns."""
        return 1e9 * self.wall_s / self.particle_steps


def _cache_path(cache_dir: Path, name: str, scale: str, spin_up_s: float,
                dt: float | None) -> Path:
    # The checkpoint format is in the name: a build that reads another format makes its own.
    step = "" if dt is None else f"-dt{dt:.6g}"
    fmt = CHECKPOINT_FORMAT.rsplit("-", 1)[-1]
    return cache_dir / (f"{name}-{scale}-spin{spin_up_s:g}{step}-{build_info()['version']}"
                        f"-ckpt{fmt}.npz")


def tumbling_state(name: str, scale: str, spin_up_s: float, *,
                   cache_dir: str | Path = DEFAULT_CACHE_DIR, use_cache: bool = True,
                   dt: float | None = None, threads: int | None = None, progress: bool = True,
                   out: TextIO | None = None) -> Path:
    """A checkpoint of the scene tumbling after ``spin_up_s`` of rotation (made once, cached).

    Parameters
    ----------
    name : str
        Bench scene name (:func:`build_scene`).
    scale : {"paper", "small", "tiny", "soft"}
        Scale of the scene.
    spin_up_s : float
        Simulated rotation after filling and settling, s (>= 0.02).
    cache_dir : str or Path
        Folder of the cached checkpoints; made if missing.
    use_cache : bool
        Reuse a checkpoint made earlier for the same scene, scale, spin-up, dt, version and
        checkpoint format.
    dt : float, optional
        Time step, s; default the engine's, 0.2 x the smallest Rayleigh time.
    threads : int, optional
        Threads for the preparation; default every core this process may use.
    progress : bool
        Show progress bars while preparing.
    out : text stream, optional
        Where the one-line note on a fresh preparation goes (default stdout).

    Returns
    -------
    Path
        The checkpoint (``.npz``).
    """
    path = _cache_path(Path(cache_dir), name, scale, spin_up_s, dt)
    if use_cache and path.exists():
        return path
    path.parent.mkdir(parents=True, exist_ok=True)
    sim = Simulation(build_scene(name, scale), seed=_SEED, dt=dt, threads=threads,
                     track_energy=False)
    t0 = time.perf_counter()
    sim.run(spin_up_s, sample_dt=_SAMPLE_DT, progress=progress)
    print(f"  prepared {name} ({sim.scene.n_particles} particles): fill, settle and "
          f"{spin_up_s:g} s of rotation in {time.perf_counter() - t0:.0f} s",
          file=out or sys.stdout, flush=True)
    return sim.save(path)


def measure(sim: Simulation, steps: int, name: str = "") -> Measurement:
    """Times about ``steps`` steps of a rotating simulation.

    The stretch runs through :meth:`Simulation.run` with the torque sampled (as a user's run
    does), every 10 ms or finer so that it holds at least 100 samples. Samples fall on whole
    steps, so the stretch takes from ``steps`` to 1 % more steps; the steps reported are
    counted by the engine's step counter.

    Parameters
    ----------
    sim : Simulation
        A simulation whose drum is rotating (e.g. loaded from :func:`tumbling_state`).
    steps : int
        Steps to time, >= 2.
    name : str
        Scene name to put in the result.

    Returns
    -------
    Measurement
    """
    if isinstance(steps, bool) or not isinstance(steps, int) or steps < 2:
        raise ValueError(f"steps = {steps!r} is not valid; it must be an integer >= 2")
    if sim.phase != "rotating":
        raise ValueError(f"the simulation is {sim.phase}; measure() needs a rotating drum")
    dt = sim.dt
    sample_dt = max(dt, min(_SAMPLE_DT, steps * dt / _TIMED_SAMPLES))
    duration = math.ceil(steps * dt / sample_dt - 1e-9) * sample_dt  # whole samples, >= steps
    t_before = sim.time
    t0 = time.perf_counter()
    sim.run(duration, sample_dt=sample_dt, progress=False)
    wall = time.perf_counter() - t0
    taken = round((sim.time - t_before) / dt)
    return Measurement(scene=name or sim.scene.name, particles=sim.scene.n_particles,
                       threads=sim.threads, steps=taken, dt=dt, wall_s=wall,
                       bytes_per_particle=sim.bytes_per_particle)


# -- command line ------------------------------------------------------------------------------

def _int_in(least: int, most: int | None = None, why: str = "") -> Callable[[str], int]:
    """An argparse type: an integer >= least and, if given, <= most."""
    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not an integer") from None
        if value < least or (most is not None and value > most):
            valid = f">= {least}" if most is None else f"in [{least}, {most}]"
            raise argparse.ArgumentTypeError(f"{text!r} is not valid; it must be {valid}{why}")
        return value
    return parse


def thread_count(text: str) -> int:
    """An argparse type: an engine thread count in [1, the cores this process may use]
    (:func:`millscope.simulation.check_threads`)."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not an integer") from None
    try:
        return check_threads(value)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not valid; it must be "
                                         f"{threads_range()}") from None


def _float_at_least(least: float, unit: str, strict: bool = False) -> Callable[[str], float]:
    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
        ok = value > least if strict else value >= least
        if not (math.isfinite(value) and ok):
            raise argparse.ArgumentTypeError(
                f"{text!r} is not valid; it must be finite and {'>' if strict else '>='} "
                f"{least:g}{unit}")
        return value
    return parse


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Adds the bench options to ``parser`` (used by ``python -m millscope bench`` and by
    ``benchmarks/throughput.py``)."""
    parser.add_argument("--scale", default="paper", choices=sorted(presets.SCALES),
                        help="scale of every scene (default paper)")
    parser.add_argument("--scenes", nargs="+", choices=[*SCENES, SLICE], default=None,
                        help="scenes to time (default: all but slice; only slice when "
                             "--slice-sizes is given)")
    parser.add_argument("--threads", nargs="+", type=thread_count, default=None,
                        help="thread counts, each at most the cores this process may use "
                             "(default 1 2, or 1 where the process may use one core)")
    parser.add_argument("--steps", type=_int_in(2), default=20000,
                        help="timed steps per run (default 20000)")
    parser.add_argument("--spin-up", type=_float_at_least(MIN_SPIN_UP_S, " s"), default=0.5,
                        help="rotation before timing, s (default 0.5)")
    parser.add_argument("--dt", type=_float_at_least(0.0, " s", strict=True), default=None,
                        help="time step, s (default 0.2 x the smallest Rayleigh time)")
    parser.add_argument("--slice-sizes", nargs="+",
                        type=_int_in(presets.SLICE_MIN_BALLS, presets.SLICE_MAX_BALLS,
                                     f" (a slice from 2 ball diameters to {MAX_PERIOD_LENGTH:g}"
                                     " m long)"),
                        default=None,
                        help="ball counts of the slice scene (default 10000 50000 200000)")
    parser.add_argument("--cache-dir", type=Path, default=DEFAULT_CACHE_DIR,
                        help=f"folder of the cached tumbling states (default {DEFAULT_CACHE_DIR})")
    parser.add_argument("--no-cache", action="store_true", help="prepare every state afresh")
    parser.add_argument("--no-progress", action="store_true",
                        help="no progress bars while preparing")


def _scene_names(scenes: Sequence[str] | None, slice_sizes: Sequence[int] | None) -> list[str]:
    chosen = list(scenes) if scenes is not None else (
        [SLICE] if slice_sizes is not None else list(SCENES))
    if slice_sizes is not None and SLICE not in chosen:
        chosen.append(SLICE)
    sizes = list(slice_sizes) if slice_sizes is not None else list(DEFAULT_SLICE_SIZES)
    names: list[str] = []
    for name in chosen:
        for n in (sizes if name == SLICE else [None]):
            full = name if n is None else slice_name(n)
            if full not in names:
                names.append(full)
    return names


def _check_scenes(names: Sequence[str], scale: str, dt: float | None) -> None:
    """Builds every scene (each checks its own values) and checks dt against each, before
    any is prepared: a bad one must not wait for minutes of the others' work."""
    for name in names:
        scene = build_scene(name, scale)
        if dt is None:
            continue
        limit = time_step_limit(scene)
        if dt > limit.dt:
            raise ValueError(
                f"--dt = {dt:g} s is not valid; it must be {limit.valid_range()} (scene "
                f"{name!r} at scale {scale!r})")


def run(scale: str = "paper", scenes: Sequence[str] | None = None,
        threads: Sequence[int] | None = None, steps: int = 20000, spin_up_s: float = 0.5, *,
        dt: float | None = None, slice_sizes: Sequence[int] | None = None,
        cache_dir: str | Path = DEFAULT_CACHE_DIR, use_cache: bool = True,
        progress: bool = True, out: TextIO | None = None) -> dict[tuple[str, int], Measurement]:
    """Times the scenes and prints the table, the ratios and the final machine-readable line.

    Parameters
    ----------
    scale : {"paper", "small", "tiny", "soft"}
        Scale of every scene.
    scenes : sequence of str, optional
        Names from :data:`SCENES` and/or ``"slice"``; default every fixed scene, or only
        ``"slice"`` when ``slice_sizes`` is given.
    threads : sequence of int, optional
        Thread counts, each in [1, the cores this process may use]; default 1 and 2 (only 1
        where the process may use one core).
    steps : int
        Timed steps per run, >= 2.
    spin_up_s : float
        Rotation before timing, s, >= 0.02.
    dt : float, optional
        Time step, s; default 0.2 x the smallest Rayleigh time of each scene.
    slice_sizes : sequence of int, optional
        Ball counts of the ``"slice"`` scene (default 10 000, 50 000, 200 000).
    cache_dir : str or Path
        Folder of the cached tumbling states.
    use_cache : bool
        Reuse cached tumbling states.
    progress : bool
        Progress bars while preparing.
    out : text stream, optional
        Where the report goes (default stdout).

    Returns
    -------
    dict
        The measurements by (scene name, threads).
    """
    stream = out or sys.stdout
    names = _scene_names(scenes, slice_sizes)
    if threads is None:
        threads = [1, 2] if _available_cores() >= 2 else [1]
    threads = list(dict.fromkeys(threads))  # in the order given, once each
    if not threads:
        raise ValueError("threads = [] is not valid; give at least one thread count")
    threads = [check_threads(n) for n in threads]
    if not (math.isfinite(spin_up_s) and spin_up_s >= MIN_SPIN_UP_S):
        raise ValueError(f"spin_up_s = {spin_up_s!r} s is not valid; it must be >= "
                         f"{MIN_SPIN_UP_S} s")
    _check_scenes(names, scale, dt)

    def emit(text: str) -> None:
        print(text, file=stream, flush=True)

    width = max(14, *(len(n) + 2 for n in names))
    rows: dict[tuple[str, int], Measurement] = {}
    emit(f"{'scene':<{width}}{'particles':>10}{'threads':>8}{'dt (s)':>11}{'steps':>8}"
         f"{'wall (s)':>10}{'p-steps/s':>12}{'ns/p-step':>11}{'bytes/p':>9}")
    for name in names:
        path = tumbling_state(name, scale, spin_up_s, cache_dir=cache_dir, use_cache=use_cache,
                              dt=dt, threads=max(threads), progress=progress, out=stream)
        for n_threads in threads:
            sim = Simulation.load(path, threads=n_threads, track_energy=False)
            sim.adapt_threads = False  # time the thread count asked for
            r = measure(sim, steps, name)
            rows[name, n_threads] = r
            emit(f"{name:<{width}}{r.particles:>10}{n_threads:>8}{r.dt:>11.3e}{r.steps:>8}"
                 f"{r.wall_s:>10.3f}{r.particle_steps_per_s:>12.3e}"
                 f"{r.ns_per_particle_step:>11.1f}{r.bytes_per_particle:>9.0f}")
    lo, hi = min(threads), max(threads)
    if hi > lo:
        for name in names:
            ratio = rows[name, hi].particle_steps_per_s / rows[name, lo].particle_steps_per_s
            emit(f"{name}: {hi} threads / {lo} thread(s) = {ratio:.3g}x")
    if "balls" in names:
        for variant in (v for v in VARIANTS if v in names):
            for n_threads in threads:
                ratio = (rows[variant, n_threads].particle_steps_per_s
                         / rows["balls", n_threads].particle_steps_per_s)
                emit(f"{variant} vs balls, {n_threads} thread(s): {ratio:.3g}x the throughput")
    slices = [n for n in names if n.startswith(SLICE + "-")]
    if len(slices) > 1:
        for n_threads in threads:
            cost = {n: rows[n, n_threads].ns_per_particle_step for n in slices}
            spread = max(cost.values()) / min(cost.values())
            listed = ", ".join(f"{rows[n, n_threads].particles}: {c:.1f}" for n, c in cost.items())
            verdict = "within" if spread <= SLICE_SPREAD_TARGET else "outside"
            emit(f"slice, {n_threads} thread(s): ns/p-step by particles {listed}; max/min = "
                 f"{spread:.3f} ({verdict} the linear-cost target {SLICE_SPREAD_TARGET:g})")
    emit(f"particle_steps_per_s={rows[names[0], hi].particle_steps_per_s:.4e}")
    return rows


def run_from_args(args: argparse.Namespace, out: TextIO | None = None) -> int:
    """Runs the bench from options parsed by a parser set up with :func:`add_arguments`."""
    run(args.scale, args.scenes, args.threads, args.steps, args.spin_up, dt=args.dt,
        slice_sizes=args.slice_sizes, cache_dir=args.cache_dir, use_cache=not args.no_cache,
        progress=not args.no_progress, out=out)
    return 0


def main(argv: Sequence[str] | None = None, prog: str | None = None) -> int:
    """Command line of the bench on its own (``benchmarks/throughput.py``); the same options
    as ``python -m millscope bench``. Bad options: one line naming the option, exit code 2."""
    parser = argparse.ArgumentParser(prog=prog, description=(__doc__ or "").split("\n\n")[0])
    add_arguments(parser)
    args = parser.parse_args(argv)
    try:
        return run_from_args(args)
    except (ValueError, OSError) as exc:
        message = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        parser.exit(2, f"{parser.prog}: error: {message}\n")

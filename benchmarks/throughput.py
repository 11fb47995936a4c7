"""Throughput of the DEM engine on the pilot mill, over a steady tumbling stretch.

For each scene: particle-steps per second, ns per particle-step and bytes per particle, on 1 and
2 threads; then what leaving out the lifters, the friction or the one-material kernel saves
(DESIGN.md section 7: a scene pays only for what it uses).

    .venv/bin/python benchmarks/throughput.py                  # paper scale, all scenes
    .venv/bin/python benchmarks/throughput.py --scale soft --steps 5000 --scenes balls

Each scene is filled, settled and spun up for --spin-up seconds once; that tumbling state is
cached as a checkpoint under out/bench-cache/ (delete it, or pass --no-cache, to redo it). The
timed stretch starts from the cached state, so every thread count and repeat runs the same
steps. The last line, ``particle_steps_per_s=<value>``, is the first scene on the most threads.
"""

from __future__ import annotations

import argparse
import dataclasses
import time
from collections.abc import Callable
from pathlib import Path

import millscope as ms

CACHE = Path("out/bench-cache")


def balls(scale: str) -> ms.Scene:
    """The balls-only pilot mill at 71 % of critical (paper Table 1, 2466 balls of 25 mm)."""
    return ms.presets.pilot_mill(0.71, None, scale=scale)


def ceramic4(scale: str) -> ms.Scene:
    """The pilot mill at 71 % with load level #4 of ceramic particles."""
    return ms.presets.pilot_mill(0.71, "ceramic", 4, scale=scale)


def no_lifters(scale: str) -> ms.Scene:
    """balls with a smooth shell."""
    s = balls(scale)
    return dataclasses.replace(s, drum=dataclasses.replace(s.drum, lifters=None))


def frictionless(scale: str) -> ms.Scene:
    """balls with every friction coefficient 0 (no tangential history, no torques)."""
    s = balls(scale)
    return dataclasses.replace(
        s, pairs=tuple(dataclasses.replace(p, friction=0.0) for p in s.pairs))


def pair_table(scale: str) -> ms.Scene:
    """balls with the drum made of an identical copy of steel: the same physics, but the
    kernel looks each contact's constants up in a pair table."""
    s = balls(scale)
    steel = next(m for m in s.materials if m.name == s.drum.material)
    copy = dataclasses.replace(steel, name=steel.name + " (drum)")
    like = next(p for p in s.pairs if {p.a, p.b} == {steel.name})
    extra = (dataclasses.replace(like, a=steel.name, b=copy.name),
             dataclasses.replace(like, a=copy.name, b=copy.name))
    return dataclasses.replace(s, materials=s.materials + (copy,), pairs=s.pairs + extra,
                               drum=dataclasses.replace(s.drum, material=copy.name))


SCENES: dict[str, Callable[[str], ms.Scene]] = {
    "balls": balls, "ceramic4": ceramic4, "no_lifters": no_lifters,
    "frictionless": frictionless, "pair_table": pair_table}
VARIANTS = ("no_lifters", "frictionless", "pair_table")  # compared against "balls"


def tumbling_state(name: str, scale: str, spin_up_s: float, use_cache: bool) -> Path:
    """A checkpoint of the scene tumbling after spin_up_s of rotation (made once, cached)."""
    path = CACHE / f"{name}-{scale}-spin{spin_up_s:g}-{ms.__version__}.npz"
    if use_cache and path.exists():
        return path
    CACHE.mkdir(parents=True, exist_ok=True)
    sim = ms.Simulation(SCENES[name](scale), seed=1)
    t0 = time.perf_counter()
    sim.run(spin_up_s, progress=True)
    print(f"  prepared {name} ({sim.scene.n_particles} particles): fill, settle and "
          f"{spin_up_s:g} s of rotation in {time.perf_counter() - t0:.0f} s")
    return sim.save(path)


def measure(path: Path, threads: int, steps: int) -> dict[str, float]:
    """Times `steps` steps from the checkpoint on `threads` threads."""
    sim = ms.Simulation.load(path, threads=threads)
    t0 = time.perf_counter()
    sim.run(steps * sim.dt, progress=False)
    wall = time.perf_counter() - t0
    n = sim.scene.n_particles
    psps = n * steps / wall
    return {"particles": n, "threads": threads, "steps": steps, "dt": sim.dt, "wall_s": wall,
            "psps": psps, "ns_per_ps": 1e9 / psps, "bytes": sim.bytes_per_particle}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--scale", default="paper", choices=sorted(ms.presets.SCALES))
    parser.add_argument("--scenes", nargs="+", default=list(SCENES), choices=list(SCENES))
    parser.add_argument("--threads", nargs="+", type=int, default=[1, 2])
    parser.add_argument("--steps", type=int, default=20000, help="timed steps per run")
    parser.add_argument("--spin-up", type=float, default=0.5, help="rotation before timing, s")
    parser.add_argument("--no-cache", action="store_true")
    args = parser.parse_args(argv)
    if args.steps < 1:
        parser.error(f"--steps = {args.steps} is not valid; it must be >= 1")
    if min(args.threads) < 1:
        parser.error(f"--threads = {min(args.threads)} is not valid; it must be >= 1")
    if not args.spin_up > 0:
        parser.error(f"--spin-up = {args.spin_up} is not valid; it must be > 0 s")

    rows: dict[tuple[str, int], dict[str, float]] = {}
    print(f"{'scene':<14}{'particles':>10}{'threads':>8}{'dt (s)':>11}{'steps':>8}"
          f"{'p-steps/s':>12}{'ns/p-step':>11}{'bytes/p':>9}")
    for name in args.scenes:
        path = tumbling_state(name, args.scale, args.spin_up, not args.no_cache)
        for threads in args.threads:
            r = measure(path, threads, args.steps)
            rows[name, threads] = r
            print(f"{name:<14}{r['particles']:>10.0f}{threads:>8}{r['dt']:>11.3e}{args.steps:>8}"
                  f"{r['psps']:>12.3e}{r['ns_per_ps']:>11.1f}{r['bytes']:>9.0f}", flush=True)
    if len(args.threads) > 1:
        lo, hi = min(args.threads), max(args.threads)
        for name in args.scenes:
            print(f"{name}: {hi} threads / {lo} thread = "
                  f"{rows[name, hi]['psps'] / rows[name, lo]['psps']:.2f}x")
    for variant in VARIANTS:
        if variant in args.scenes and "balls" in args.scenes:
            for threads in args.threads:
                ratio = rows[variant, threads]["psps"] / rows["balls", threads]["psps"]
                print(f"{variant} vs balls, {threads} thread(s): {ratio:.2f}x the throughput")
    first = args.scenes[0]
    print(f"particle_steps_per_s={rows[first, max(args.threads)]['psps']:.4e}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

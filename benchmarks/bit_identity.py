"""Fingerprints of fixed short runs, to show that a change to the C++ core moves nothing.

A refactoring of the engine must leave every result the same to the bit. This script runs a
fixed set of short runs with the millscope found in a given folder and prints one SHA-256 per
run, of its torque record and its final positions, velocities, spins and energy ledger; run it
with the build before and the build after a change and compare the two outputs line by line::

    .venv/bin/python benchmarks/bit_identity.py /tmp/before-pkg > before.txt
    .venv/bin/python benchmarks/bit_identity.py python > after.txt
    diff before.txt after.txt

The runs: the paper's steel balls and a mixed scene (ceramic particles and steel balls, LDMS#1)
at the "tiny" scale, each with lifters and periodic ends and with end walls and no lifters,
on 1 and 2 threads, with and without the energy ledger (``track_energy``), from the filled
(unsettled) state; then impacts of the contact probe and single evaluations of the law
(``_core.contact_probe``, ``_core.sphere_contact``, ``_core.wall_contact``) over friction,
restitution and the normal clamp. Set MILLSCOPE_SIMD to run another SIMD path of the engine's
vector kernels than the widest (``python -m millscope info`` lists them, e.g. ``portable``);
every path must print the same.
"""

from __future__ import annotations

import argparse
import dataclasses
import hashlib
import importlib
import sys
from typing import Any

import numpy as np


def _digest(*arrays: Any) -> str:
    h = hashlib.sha256()
    for a in arrays:
        h.update(np.ascontiguousarray(np.asarray(a, dtype=np.float64)).tobytes())
    return h.hexdigest()[:16]


def _scenes(ms: Any) -> list[tuple[str, Any]]:
    out = []
    for label, particles in (("balls", None), ("LDMS#1", "ceramic")):
        scene = ms.presets.pilot_mill(0.71, particles, 1, "tiny")
        drum = dataclasses.replace(scene.drum, end_walls=True, lifters=None)
        out.append((f"{label} lifters periodic", scene))
        out.append((f"{label} end-walls smooth", dataclasses.replace(scene, drum=drum)))
    return out


def _runs(ms: Any, steps: int) -> None:
    for label, scene in _scenes(ms):
        for threads in (1, 2):
            for track in (False, True):
                sim = ms.Simulation(scene, seed=3, threads=threads, track_energy=track)
                sim.fill()
                e = sim._engine
                e.start_rotation(scene.omega)
                # the instantaneous columns (t, total, shell, lifters, ends); the mean ones follow
                rows = np.asarray(e.advance_sampled(5 * sim.dt, False, steps // 5))[:, :5]
                ledger = e.ledger()
                energy = [ledger[k] for k in sorted(ledger)] if track else []
                print(f"{label:26s} threads={threads} track_energy={track!s:5s} "
                      f"torque={_digest(rows)} state="
                      f"{_digest(e.positions, e.velocities, e.spins, energy)}", flush=True)


def _contacts(core: Any) -> None:
    steel = core.Material(7800.0, 80e9, 0.3)
    glass = core.Material(2500.0, 30e9, 0.25)
    results = []
    for wall in (False, True):
        for e in (0.5, 1.0):
            for mu in (0.0, 0.3):
                for clamp in (False, True):
                    r = core.contact_probe(steel, glass, wall, 0.01, 0.006, e, mu, 1.2, 0.4, 3.0,
                                           2e-8, clamp)
                    results.append([getattr(r, k) for k in sorted(dir(r))
                                    if not k.startswith("_")])
                    pc = core.pair_constants(steel, glass, e, mu)
                    hist = [1e-7, -2e-7, 3e-7]
                    for friction in (False, True):
                        if wall:
                            c = core.wall_contact(pc, [0, 0.00999, 0], [0.1, -1, 0.2], [1, 2, 3],
                                                  0.01, 0.03, [0, 1, 0], 1e-5, [0.5, 0, 0],
                                                  hist, 1e-7, friction, clamp)
                        else:
                            c = core.sphere_contact(pc, [0, 0.0159, 0], [0.1, -1, 0.2], [1, 2, 3],
                                                    0.01, 0.03, [0, 0, 0], [0, 0.3, 0],
                                                    [0, 0, 1], 0.006, 0.01, hist, 1e-7,
                                                    friction, clamp)
                        results.append([*c.force_i, *c.torque_i, *c.torque_j, c.normal,
                                        *c.tangential, float(c.sliding), *c.history])
    flat = np.array([float(v) for row in results for v in row])
    print(f"contact probe and law evaluations ({len(results)}) {_digest(flat)}")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("package_folder", help="folder holding the millscope package to run")
    parser.add_argument("--steps", type=int, default=2000, help="steps of each run (2000)")
    args = parser.parse_args(argv)
    sys.path.insert(0, args.package_folder)
    ms = importlib.import_module("millscope")
    core = importlib.import_module("millscope._core")
    print(f"# millscope from {ms.__file__}", file=sys.stderr)
    _contacts(core)
    _runs(ms, args.steps)
    return 0


if __name__ == "__main__":
    sys.exit(main())

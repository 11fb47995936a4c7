"""Runs the pilot-mill cases of the power comparison (docs/power.md) and keeps their raw data.

For each case not yet done: fill and settle the charge, spin the drum for ``SPIN_UP_S`` s
(discarded: the charge leaves the settled bed and takes its running shape), then record
``AVERAGE_S`` s of drive torque (``"mean"`` sampling) with a snapshot of the particle state
every ``SNAPSHOT_S`` s. Each case goes to ``data/power/raw/<case>.npz`` (not committed: a few
MB) and is written atomically, so an interrupted run resumes where it stopped.
``scripts/power_comparison.py`` turns the raw files into the committed table.

Run from the repository root, one core, politely::

    PYTHONPATH=python nice -n 10 python scripts/power_simulations.py [filters]

Filters (any mix) pick cases, so that several processes can share them out: ``balls``,
``balls+`` (more balls), ``ceramic``, a stiffness factor (``0.01``), a speed (``s0.71``).
"""

from __future__ import annotations

import dataclasses
import sys
import time
from pathlib import Path

import numpy as np

import millscope as ms
from millscope._files import atomic_write
from millscope.model.charge import particle_masses

RAW = Path("data/power/raw")
# The whole paper mill with every shear modulus x these factors (docs/power.md, Setting):
# x 0.001 (the "soft" scale) for the comparison, x 0.01 for the stiffness check.
STIFFNESS = (0.01, 0.001)
SPEEDS = (0.62, 0.71, 0.80)
# (particles, load level, ball count): the paper's balls only (ball filling 0.19 at porosity
# 0.45); more balls (ball filling 0.30); LD #2 (the paper's balls, particles filling 80 % of
# their voids)
FILLINGS = ((None, 1, None), (None, 1, 3864), ("ceramic", 2, None))
POROSITY = 0.45  # of a bed at rest (docs/physics.md, the pilot mill)
SEED = 0
SPIN_UP_S = 1.0
AVERAGE_S = 2.5
SNAPSHOT_S = 0.25
SAMPLE_DT = 0.01


def run_case(particles: str | None, level: int, balls: int | None, speed: float,
             stiffness: float) -> Path:
    """Runs one case and writes its raw file; returns the file's path."""
    paper = ms.presets.pilot_mill(speed, particles, level, scale="paper")
    scene = paper.replace(materials=tuple(m.with_shear_modulus(stiffness)
                                          for m in paper.materials))
    if balls is not None:
        charge = tuple(dataclasses.replace(f, count=balls) if f.name == "balls" else f
                       for f in scene.charge)
        scene = scene.replace(charge=charge, name=f"{scene.name} J{filling(charge, scene):.2f}")
    out = RAW / f"{scene.name.replace('#', '_')}_G{stiffness:g}.npz"
    if out.exists():
        return out
    start = time.process_time()
    sim = ms.Simulation(scene, seed=SEED, threads=1, track_energy=False)
    sim.run(SPIN_UP_S, SAMPLE_DT, "mean", progress=False)
    times, torques, snaps_x, snaps_v, angles, snap_t = [], [], [], [], [], []
    for _ in range(int(round(AVERAGE_S / SNAPSHOT_S))):
        rec = sim.run(SNAPSHOT_S, SAMPLE_DT, "mean", progress=False)
        times.append(rec.time_s)
        torques.append(rec.torque_Nm)
        snaps_x.append(sim.positions.copy())
        snaps_v.append(sim.velocities.copy())
        angles.append(sim.drum_angle)
        snap_t.append(sim.time)
    radii = scene.particle_radii()
    masses = particle_masses(scene)
    cpu = time.process_time() - start

    with atomic_write(out, "wb") as fh:
        np.savez_compressed(
            fh, time_s=np.concatenate(times), torque_Nm=np.concatenate(torques),
            positions_m=np.array(snaps_x), velocities_m_s=np.array(snaps_v),
            snapshot_time_s=np.array(snap_t), drum_angle_rad=np.array(angles),
            radii_m=radii, masses_kg=masses, omega_rad_s=scene.omega,
            speed_fraction=speed, load_level=level if particles else 0,
            particles=particles or "", scene_name=scene.name, stiffness=stiffness, seed=SEED,
            dt_s=sim.dt, spin_up_s=SPIN_UP_S, cpu_s=cpu)
    print(f"{scene.name}: {scene.n_particles} particles, dt {sim.dt:.3g} s, CPU {cpu:.0f} s",
          flush=True)
    return out


def filling(charge: tuple[ms.Fraction, ...], scene: ms.Scene) -> float:
    """Ball filling: the balls' bed (porosity POROSITY) as a fraction of the drum volume."""
    balls = next(f for f in charge if f.name == "balls")
    return balls.volume / (1.0 - POROSITY) / scene.drum.volume


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def main() -> int:
    RAW.mkdir(parents=True, exist_ok=True)
    # optional filters: "balls", "balls+" (more balls), "ceramic", a stiffness factor
    # ("0.01"), a speed ("s0.71");
    # several processes with different filters share the cases out between them
    only = sys.argv[1:]
    speeds = [float(a[1:]) for a in only if a.startswith("s")] or list(SPEEDS)
    only = [a for a in only if not a.startswith("s")]
    for stiffness in STIFFNESS:
        if only and any(_is_number(a) for a in only) and f"{stiffness:g}" not in only:
            continue
        for particles, level, balls in FILLINGS:
            kind = (particles or "balls") + ("" if balls is None else "+")
            if only and {"balls", "balls+", "ceramic"} & set(only) and kind not in only:
                continue
            for speed in speeds:
                run_case(particles, level, balls, speed, stiffness)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

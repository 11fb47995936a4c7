"""Write a millscope bench scene's tumbling state as a LIGGGHTS data file, so that LIGGGHTS
continues the very same state (positions, velocities, spins, sizes, densities) and both codes are
timed on the same stretch of the same scene.

    python benchmarks/liggghts_state.py ceramic4 WORKDIR [--spin-up 0.3] [--scale paper]

Writes, into WORKDIR:

- ``<scene>.data``: LIGGGHTS ``atom_style granular`` data file (Atoms: id type diameter
  density x y z; Velocities: id vx vy vz wx wy wz), SI units, z shifted by -L/2 (millscope's
  drum spans z in [0, L], the yardstick's mesh is centred on the origin). Atom type k + 1 is
  the scene's material k (:attr:`millscope.Scene.materials` order).
- ``<scene>_materials.in``: the ``fix property/global`` lines of every material and pair, with
  Young's modulus E = 2 G (1 + nu). The drum mesh is given the type of the drum's material.
- ``<scene>.vars``: shell-readable ``name=value`` lines: ``dt`` (s), ``omega`` (rad/s),
  ``period`` (s), ``phase_deg`` (where lifter 0 is now, degrees, the drum's angle plus the
  lifters' phase), ``mesh_type``, ``particles``.

The state is the bench's cached checkpoint (made once by :func:`millscope.bench.tumbling_state`;
minutes of both cores for the paper scale). LIGGGHTS has no contact history in a data file:
its tangential springs start at zero, so the comparison script lets it run untimed warm-up
steps first. Only the paper's geometry is exported (shell, 16 rectangular lifters, end caps);
a scene with another drum is refused.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import tempfile
from pathlib import Path

import numpy as np

from millscope import bench
from millscope.scene import Scene
from millscope.simulation import Simulation

# The yardstick's mesh (make_mill_stl.py): D 0.880 m, L 0.315 m, 16 rectangular lifters 30 x 20 mm.
_MESH_DRUM = {"diameter": 0.88, "length": 0.315}
_MESH_LIFTERS = {"count": 16, "width": 0.03, "height": 0.02, "profile": "rectangular"}


def _differ(have: float | int | str, want: float | int | str) -> bool:
    """Whether a geometry value differs from the mesh's (floats compared with isclose)."""
    if isinstance(want, float) and isinstance(have, (int, float)):
        return not math.isclose(have, want)
    return have != want


def _check_geometry(scene: Scene) -> None:
    drum, lifters = scene.drum, scene.drum.lifters
    wrong = [f"drum.{k} = {getattr(drum, k)!r}" for k, v in _MESH_DRUM.items()
             if _differ(getattr(drum, k), v)]
    if lifters is None:
        wrong.append("drum.lifters = None")
    else:
        wrong += [f"drum.lifters.{k} = {getattr(lifters, k)!r}" for k, v in _MESH_LIFTERS.items()
                  if _differ(getattr(lifters, k), v)]
    if wrong or not drum.end_walls:
        raise SystemExit(f"error: scene {scene.name!r} is not the yardstick's drum "
                         f"(D 0.88 m, L 0.315 m, end walls, 16 lifters 30 x 20 mm): "
                         f"{', '.join(wrong) or 'drum.end_walls = False'}")


def _write_atomic(path: Path, text: str) -> None:
    with tempfile.NamedTemporaryFile("w", dir=path.parent, delete=False,
                                     prefix=path.name + ".", suffix=".tmp") as f:
        f.write(text)
    os.replace(f.name, path)


def data_file(sim: Simulation) -> str:
    """The LIGGGHTS data file text of a simulation's current state."""
    scene = sim.scene
    # millscope's drum spans z in [0, L]; the yardstick's mesh is centred, z in [-L/2, L/2].
    x = sim.positions - np.array([0.0, 0.0, 0.5 * scene.drum.length])
    v, w = sim.velocities, sim.spins
    diameter = 2.0 * scene.particle_radii()
    kind = scene.particle_materials()
    density = np.array([m.density for m in scene.materials])[kind]
    half = 0.5 * scene.drum.diameter + 0.02
    half_z = 0.5 * scene.drum.length + 0.015
    lines = [f"LIGGGHTS data file: millscope {scene.name} at t = {sim.time:.6f} s "
             f"(drum angle {sim.drum_angle:.9f} rad)", "",
             f"{len(x)} atoms", f"{len(scene.materials)} atom types", "",
             f"{-half} {half} xlo xhi", f"{-half} {half} ylo yhi",
             f"{-half_z} {half_z} zlo zhi", "", "Atoms", ""]
    lines += [f"{i + 1} {kind[i] + 1} {diameter[i]:.9g} {density[i]:.9g} "
              f"{x[i, 0]:.12g} {x[i, 1]:.12g} {x[i, 2]:.12g}" for i in range(len(x))]
    lines += ["", "Velocities", ""]
    lines += [f"{i + 1} {v[i, 0]:.12g} {v[i, 1]:.12g} {v[i, 2]:.12g} "
              f"{w[i, 0]:.12g} {w[i, 1]:.12g} {w[i, 2]:.12g}" for i in range(len(x))]
    return "\n".join(lines) + "\n"


def materials_file(scene: Scene) -> str:
    """``fix property/global`` lines for LIGGGHTS: per type E and nu, per type pair e and mu."""
    mats = scene.materials
    n = len(mats)
    young = " ".join(f"{2.0 * m.shear_modulus * (1.0 + m.poisson):.9g}" for m in mats)
    poisson = " ".join(f"{m.poisson:.9g}" for m in mats)
    restitution, friction = [], []
    for a in mats:
        for b in mats:
            pair = scene.pair(a.name, b.name)
            restitution.append(f"{pair.restitution:.9g}")
            friction.append(f"{pair.friction:.9g}")
    names = ", ".join(f"type {k + 1} = {m.name}" for k, m in enumerate(mats))
    return (f"# millscope {scene.name}: {names}; E = 2 G (1 + nu)\n"
            f"fix m1 all property/global youngsModulus peratomtype {young}\n"
            f"fix m2 all property/global poissonsRatio peratomtype {poisson}\n"
            f"fix m3 all property/global coefficientRestitution peratomtypepair {n} "
            f"{' '.join(restitution)}\n"
            f"fix m4 all property/global coefficientFriction peratomtypepair {n} "
            f"{' '.join(friction)}\n")


def write_state(sim: Simulation, workdir: Path, stem: str) -> Path:
    """Writes ``<stem>.data``, ``<stem>_materials.in`` and ``<stem>.vars`` of the simulation's
    current state into ``workdir`` (made if missing), each atomically; returns the .vars path.
    The scene must have the yardstick's drum."""
    scene = sim.scene
    _check_geometry(scene)
    workdir.mkdir(parents=True, exist_ok=True)
    phase = sim.drum_angle + scene.drum.lifters.phase
    omega = scene.omega
    _write_atomic(workdir / f"{stem}.data", data_file(sim))
    _write_atomic(workdir / f"{stem}_materials.in", materials_file(scene))
    mesh_type = scene.material_index(scene.drum.material) + 1
    variables = workdir / f"{stem}.vars"
    _write_atomic(variables,
                  f"dt={sim.dt:.12g}\nomega={omega:.12g}\nperiod={2 * math.pi / omega:.12g}\n"
                  f"phase_deg={math.degrees(phase) % 360.0:.9f}\nmesh_type={mesh_type}\n"
                  f"particles={len(sim.positions)}\n")
    return variables


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("scene", choices=sorted(bench.SCENES), help="bench scene name")
    p.add_argument("workdir", type=Path, help="folder for the LIGGGHTS files (made if missing)")
    p.add_argument("--scale", default="paper", help="scene scale (default paper)")
    p.add_argument("--spin-up", type=float, default=0.3,
                   help="rotation before the state, s (default 0.3, the cached bench state)")
    p.add_argument("--cache-dir", type=Path, default=bench.DEFAULT_CACHE_DIR,
                   help=f"bench cache folder (default {bench.DEFAULT_CACHE_DIR})")
    args = p.parse_args(argv)
    scene = bench.build_scene(args.scene, args.scale)
    _check_geometry(scene)
    path = bench.tumbling_state(args.scene, args.scale, args.spin_up, cache_dir=args.cache_dir)
    sim = Simulation.load(path, threads=1)
    write_state(sim, args.workdir, args.scene)
    print(f"wrote {args.scene}.data ({len(sim.positions)} particles, t = {sim.time:.4f} s), "
          f"{args.scene}_materials.in and {args.scene}.vars in {args.workdir}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

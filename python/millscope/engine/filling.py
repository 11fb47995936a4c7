"""Where the particles start: a packed placement near the bed they settle into.

Every fraction, largest first, goes onto a hexagonal close-packed lattice of its own (pitch
``FILL_PITCH`` x its diameter, each site jittered by at most ``FILL_JITTER`` diameters per
axis), clear of the shell, the lifters and the end walls, and of the particles already placed.
The lattice's horizontal layers are triangular (rows along the drum axis, alternate rows
shifted by half a pitch); each layer sits over the pockets of the one below (ABAB stacking),
so a particle drops only by what the pitch leaves between it and its three supports. At
pitch 1.05 d the lattice holds a solid fraction of 0.74 / 1.05^3 = 0.64, about that of the
settled random bed, so the charge starts in the lower segment of the drum at about the height
it settles to, instead of a loose cloud that falls and rearranges. A fraction takes random
sites among the lowest ones: the largest fraction spreads over the height the whole charge
will take, the later ones fill the sites left between, from the bottom up, so the bed is
mixed. Reproducible from the random generator given.

With periodic ends the rows along the axis are stretched to a whole number per period
(at least one); the rows across are then moved closer (never below half a pitch) so that
neighbours stay one pitch apart.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .._drum_shape import lifter_angles
from ..model.scene import Scene

__all__ = ["FILLING", "FILL_JITTER", "FILL_PITCH", "WALL_GAP", "fill_positions",
           "lattice_sites"]

#: The placement's name in a record's meta ("filling"); records without it were placed on the
#: loose cubic lattice of earlier versions. Changed whenever the placement changes.
FILLING = "close-packed-1"

FILL_PITCH = 1.05  # lattice pitch of the filling, in diameters of the fraction
WALL_GAP = 0.05  # clearance of a placed particle from the drum and the others, in its diameters
#: Random offset of a site, in diameters, each axis: two neighbours come at most
#: 2 sqrt(3) x this closer, 0.035 d, less than the gap the pitch leaves (0.05 d), so no two
#: particles of a fraction overlap.
FILL_JITTER = 0.01


def lattice_sites(scene: Scene, diameter: float, rng: np.random.Generator) -> NDArray[np.float64]:
    """The jittered close-packed sites for spheres of ``diameter`` inside the drum, (n, 3) m.

    Every site keeps ``WALL_GAP`` diameters from the shell (inside the lifters' tips) and the
    end walls; with periodic ends z is wrapped into [0, length).
    """
    drum = scene.drum
    d, r = diameter, diameter / 2.0
    a = FILL_PITCH * d
    clearance = r + WALL_GAP * d
    reach = drum.radius - clearance
    if drum.end_walls:
        z_low, z_high = r + WALL_GAP * d, drum.length - r - WALL_GAP * d
        step_z = a
    else:
        z_low, z_high = 0.0, drum.length
        step_z = drum.length / max(1, int(drum.length // a))
    # rows along z, `row` apart in x, alternate rows shifted by step_z / 2: neighbours in
    # adjacent rows are a apart, rows of the same shift 2 row >= a apart
    row = max(math.sqrt(max(a * a - step_z * step_z / 4.0, 0.0)), a / 2.0)
    # the next layer over the pockets (row / 3, step_z / 2), as high as the nearest of the
    # three sites below allows
    nearest = min(math.hypot(row / 3.0, step_z / 2.0), 2.0 * row / 3.0)
    layer = math.sqrt(a * a - nearest * nearest)
    n_rows = int(math.ceil(reach / row)) + 1
    n_layers = int(math.ceil(reach / layer)) + 1
    if drum.end_walls:
        n_z = int(math.floor((z_high - z_low) / step_z + 1e-9)) + 1
    else:
        n_z = int(round(drum.length / step_z))
    j = np.arange(-n_rows, n_rows + 1)
    k = np.arange(-n_layers, n_layers + 1)
    m = np.arange(n_z)
    jj, kk, mm = np.meshgrid(j, k, m, indexing="ij")
    pocket = kk % 2  # 0: over the rows (A), 1: over the pockets (B)
    x = jj * row + pocket * row / 3.0
    y = kk * layer
    z = z_low + mm * step_z + ((jj % 2) + pocket) % 2 * step_z / 2.0
    sites = np.column_stack([x.ravel(), y.ravel(), z.ravel()])
    if drum.end_walls:
        sites = sites[sites[:, 2] <= z_high + 1e-12]
    sites += rng.uniform(-FILL_JITTER * d, FILL_JITTER * d, sites.shape)
    sites = sites[np.hypot(sites[:, 0], sites[:, 1]) <= reach]
    sites = sites[_clear_of_lifters(scene, sites, clearance)]
    if not drum.end_walls:
        sites[:, 2] %= drum.length
    return np.asarray(sites, dtype=np.float64)


def _clear_of_lifters(scene: Scene, sites: NDArray[np.float64],
                      clearance: float) -> NDArray[np.bool_]:
    """Which sites keep more than ``clearance`` from every lifter at drum angle 0. A lifter is
    taken as the rectangle as wide as it is at the shell (a trapezoid lies inside it): in the
    frame of its centre line at angle phi_k (docs: ``millscope._drum_shape``), radial a and
    tangential b, the points with a >= R - h and |b| <= w / 2."""
    lifters = scene.drum.lifters
    keep = np.ones(len(sites), dtype=bool)
    if lifters is None:
        return keep
    tip = scene.drum.radius - lifters.height
    for phi in lifter_angles(scene.drum, 0.0):
        a = sites[:, 0] * math.cos(phi) + sites[:, 1] * math.sin(phi)
        b = -sites[:, 0] * math.sin(phi) + sites[:, 1] * math.cos(phi)
        keep &= np.hypot(np.maximum(tip - a, 0.0),
                         np.maximum(np.abs(b) - lifters.width / 2.0, 0.0)) > clearance
    return keep


def fill_positions(scene: Scene, rng: np.random.Generator) -> NDArray[np.float64]:
    """Initial centres of every particle, (N, 3) m in the scene's order (module docstring).

    Raises ``ValueError`` when a fraction does not find enough free sites: the charge is too
    large for the drum.
    """
    from scipy.spatial import cKDTree

    radius_max = float(np.max(scene.particle_radii()))
    placed: list[NDArray[np.float64]] = []
    placed_radius: list[NDArray[np.float64]] = []
    total_volume = scene.charge_volume()
    order = sorted(range(len(scene.charge)), key=lambda k: -scene.charge[k].diameter)
    out = [np.empty((0, 3))] * len(scene.charge)
    for rank, k in enumerate(order):
        frac = scene.charge[k]
        d, r = frac.diameter, frac.diameter / 2.0
        sites = lattice_sites(scene, d, rng)
        if placed:
            centres = np.concatenate(placed)
            radii = np.concatenate(placed_radius)
            sites = sites[_clear_of(scene, sites, r + WALL_GAP * d, centres, radii,
                                    radius_max, cKDTree)]
        if len(sites) < frac.count:
            raise ValueError(
                f"the charge does not fit: fraction {frac.name or frac.material!r} needs "
                f"{frac.count} places but the filling lattice has {len(sites)} left; the "
                "charge is too large for this drum")
        # Random sites among the lowest ones: the largest fraction spreads over the height
        # the whole charge will take, the later ones fill what is left from the bottom up.
        spread = total_volume / (frac.count * math.pi * d**3 / 6.0) if rank == 0 else 1.0
        lowest = np.argsort(sites[:, 1], kind="stable")
        pool = lowest[: min(len(sites), max(frac.count, int(math.ceil(frac.count * spread))))]
        chosen = sites[rng.choice(pool, size=frac.count, replace=False)]
        out[k] = chosen
        placed.append(chosen)
        placed_radius.append(np.full(frac.count, r))
    return np.concatenate(out)


def _clear_of(scene: Scene, sites: NDArray[np.float64], clearance: float,
              centres: NDArray[np.float64], radii: NDArray[np.float64], radius_max: float,
              tree_type: Any) -> NDArray[np.bool_]:
    """Which sites keep more than ``clearance`` from the surface of every placed particle
    (through the periodic ends too, where the drum has them)."""
    drum = scene.drum
    keep = np.ones(len(sites), dtype=bool)
    if drum.end_walls:
        tree = tree_type(sites)
        probe = centres
    else:
        # periodic along z only: a box so wide across that nothing wraps there
        span = 4.0 * drum.radius
        shift = np.array([span / 2.0, span / 2.0, 0.0])
        tree = tree_type(sites + shift, boxsize=[span, span, drum.length])
        probe = centres + shift
    for c, rc, near in zip(centres, radii,
                           tree.query_ball_point(probe, clearance + radius_max), strict=True):
        if near:
            idx = np.asarray(near)
            delta = sites[idx] - c
            if not drum.end_walls:
                delta[:, 2] -= drum.length * np.round(delta[:, 2] / drum.length)
            keep[idx[np.linalg.norm(delta, axis=1) - rc <= clearance]] = False
    return keep

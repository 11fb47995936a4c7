"""The filling: a close-packed placement near the settled bed (engine/filling.py)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.spatial import cKDTree

import millscope as ms
from millscope.engine.filling import FILL_JITTER, FILL_PITCH, WALL_GAP, lattice_sites


def _gaps(scene: ms.Scene, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Surface gaps of the pairs closer than two largest diameters, and the smaller diameter
    of each pair (through the periodic ends where the drum has them)."""
    r = scene.particle_radii()
    length = scene.drum.length
    shifted = x + np.array([1.0, 1.0, 0.0])  # x, y in [0, 2) for the periodic box
    box = None if scene.drum.end_walls else [2.0, 2.0, length]
    pairs = cKDTree(shifted, boxsize=box).query_pairs(4.0 * r.max(), output_type="ndarray")
    delta = x[pairs[:, 0]] - x[pairs[:, 1]]
    if box is not None:
        delta[:, 2] -= length * np.round(delta[:, 2] / length)
    gap = np.linalg.norm(delta, axis=1) - r[pairs[:, 0]] - r[pairs[:, 1]]
    return gap, 2.0 * np.minimum(r[pairs[:, 0]], r[pairs[:, 1]])


@pytest.mark.parametrize(("particles", "level", "scale"), [
    (None, 1, "paper"), ("ceramic", 7, "paper"), ("ceramic", 7, "tiny"), ("steel", 3, "small")])
def test_every_particle_is_placed_inside_the_drum_clear_of_the_others(
        particles: str | None, level: int, scale: str) -> None:
    scene = ms.presets.pilot_mill(0.71, particles, level, scale=scale)
    sim = ms.Simulation(scene, seed=3, threads=1)
    sim.fill()
    x, r = sim.positions, scene.particle_radii()
    assert x.shape == (scene.n_particles, 3)
    gap, d_small = _gaps(scene, x)
    # Within a fraction the lattice leaves (pitch - 1) d and the jitter takes at most
    # 2 sqrt(3) x jitter x d of it; between fractions the placement keeps WALL_GAP d.
    bound = min(FILL_PITCH - 1.0 - 2.0 * math.sqrt(3.0) * FILL_JITTER, WALL_GAP)
    assert bound > 0.0
    assert np.all(gap >= bound * d_small * (1.0 - 1e-9))
    drum = scene.drum
    assert np.all(np.hypot(x[:, 0], x[:, 1]) + r <= drum.radius)
    if drum.end_walls:
        assert np.all((x[:, 2] - r >= 0.0) & (x[:, 2] + r <= drum.length))
    else:
        assert np.all((x[:, 2] >= 0.0) & (x[:, 2] < drum.length))
    # the engine's own drum geometry (shell, lifters, end walls) finds no contact either
    assert sim.max_overlap_ratio() == 0.0


def test_the_lattice_is_close_packed() -> None:
    """Away from the walls every site has the 12 neighbours of a close packing at one pitch
    (within the jitter), so the lattice's solid fraction is pi / (3 sqrt 2) / pitch^3."""
    scene = ms.presets.pilot_mill(0.71, scale="paper")
    d = 0.025
    a = FILL_PITCH * d
    sites = lattice_sites(scene, d, np.random.default_rng(0))
    tree = cKDTree(sites)
    inner = sites[(np.hypot(sites[:, 0], sites[:, 1]) < 0.3)
                  & (sites[:, 2] > 3 * a) & (sites[:, 2] < scene.drum.length - 3 * a)]
    assert len(inner) > 1000
    jitter = 2.0 * math.sqrt(3.0) * FILL_JITTER * d
    near = tree.query_ball_point(inner, a + jitter, return_length=True) - 1
    assert np.all(near == 12)
    closer = tree.query_ball_point(inner, a - jitter, return_length=True) - 1
    assert np.all(closer == 0)
    # sites per volume: one per a^3 / sqrt(2) (the cell of the close packing)
    box = inner[(np.abs(inner[:, 0]) < 0.15) & (np.abs(inner[:, 1]) < 0.15)]
    density = len(box) / (0.3 * 0.3 * (scene.drum.length - 6 * a))
    assert density == pytest.approx(math.sqrt(2.0) / a**3, rel=0.05)


def test_the_filling_is_reproducible_from_the_seed() -> None:
    scene = ms.presets.pilot_mill(0.71, "ceramic", 2, scale="tiny")
    first, again, other = (ms.Simulation(scene, seed=s, threads=1) for s in (5, 5, 6))
    for sim in (first, again, other):
        sim.fill()
    assert np.array_equal(first.positions, again.positions)
    assert not np.array_equal(first.positions, other.positions)


def test_a_charge_the_lattice_cannot_hold_is_refused() -> None:
    scene = ms.presets.pilot_mill(0.71, scale="tiny")
    (balls,) = scene.charge
    import dataclasses

    full = scene.replace(charge=(dataclasses.replace(balls, count=2000),))
    with pytest.raises(ValueError, match="the charge does not fit: fraction 'balls' needs 2000"):
        ms.Simulation(full, seed=0, threads=1).fill()


def test_the_charge_starts_near_the_bed_it_settles_into() -> None:
    """The placed charge's centre of mass lies less than a ball diameter above the settled
    bed's (the paper's mill at reduced stiffness): it settles by small moves, not by a fall
    and a rearrangement of the whole bed."""
    scene = ms.presets.pilot_mill(0.71, scale="soft")
    sim = ms.Simulation(scene, seed=0, threads=1, track_energy=False)
    sim.fill()
    placed = float(np.mean(sim.positions[:, 1]))
    report = sim.settle(progress=False)
    assert report.converged
    settled = float(np.mean(sim.positions[:, 1]))
    assert 0.0 < placed - settled < scene.charge[0].diameter

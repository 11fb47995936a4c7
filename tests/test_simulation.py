"""Simulation: filling, checkpoints (bit-for-bit continuation), bad files."""

from __future__ import annotations

import numpy as np
import pytest

import millscope as ms


def quick_sim(seed: int = 0) -> ms.Simulation:
    scene = ms.presets.pilot_mill(0.71, "ceramic", 1, scale="small")
    return ms.Simulation(scene, seed=seed, threads=2, settle_tolerance=10.0, settle_min_s=0.1,
                         settle_max_s=0.2)


def test_fill_places_every_particle_without_overlap_inside_the_drum() -> None:
    sim = quick_sim()
    sim.fill()
    x, r = sim.positions, sim.scene.particle_radii()
    assert len(x) == sim.scene.n_particles == 391 + 645
    from scipy.spatial import cKDTree

    pairs = cKDTree(x).query_pairs(2 * r.max())
    for i, j in pairs:
        assert np.linalg.norm(x[i] - x[j]) >= r[i] + r[j]
    assert np.all(np.hypot(x[:, 0], x[:, 1]) + r <= 0.44 - 0.02)  # clear of the lifters
    assert sim.max_overlap_ratio() == 0.0


def test_checkpoint_continues_bit_for_bit(tmp_path) -> None:  # type: ignore[no-untyped-def]
    sim = quick_sim()
    sim.run(0.05, progress=False)
    path = sim.save(tmp_path / "case.ckpt.npz")
    a = sim.run(0.1, sampling="mean", progress=False)
    again = ms.Simulation.load(path)
    assert again.phase == "rotating" and again.threads == 2
    b = again.run(0.1, sampling="mean", progress=False)
    assert np.array_equal(a.time_s, b.time_s)
    assert np.array_equal(a.torque_Nm, b.torque_Nm)


def test_damaged_checkpoint_is_refused(tmp_path) -> None:  # type: ignore[no-untyped-def]
    bad = tmp_path / "bad.npz"
    bad.write_bytes(b"not a zip file")
    with pytest.raises(ms.CheckpointError, match="damaged or not a millscope checkpoint"):
        ms.Simulation.load(bad)

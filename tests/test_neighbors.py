"""Neighbour list: the same pairs as a brute-force O(N^2) search, history kept across rebuilds."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.distance import pdist, squareform

from millscope import _core


def random_spheres(n: int, seed: int, box=(0.3, 0.3, 0.1)):
    rng = np.random.default_rng(seed)
    pos = rng.uniform(0, 1, (n, 3)) * np.array(box)
    r = rng.choice([0.006, 0.0125], n)
    return pos, r


def brute_force_pairs(pos: np.ndarray, r: np.ndarray, skin: float, period_z: float = 0.0):
    d = pos[:, None, :] - pos[None, :, :]
    if period_z:
        d[..., 2] -= period_z * np.round(d[..., 2] / period_z)
    gap = np.sqrt(np.sum(d**2, axis=-1)) - r[:, None] - r[None, :]
    i, j = np.nonzero(np.triu(gap < skin, k=1))
    return set(zip(i.tolist(), j.tolist(), strict=True))


@pytest.mark.parametrize(("n", "seed", "team"),
                         [(1, 0, 1), (2, 1, 1), (300, 2, 1), (1500, 3, 1), (2, 1, 3),
                          (1500, 3, 2), (1500, 3, 7)])
def test_pairs_equal_brute_force(n: int, seed: int, team: int) -> None:
    """Built by one thread or in blocks of rows by a team (as the engine's step loop does)."""
    pos, r = random_spheres(n, seed)
    skin = 0.003
    nl = _core.VerletList(skin, 3)
    nl.build(*pos.T.copy(), r, team=team)
    listed = {tuple(p) for p in nl.pairs().tolist()}
    assert len(listed) == len(nl.pairs())  # no duplicates
    assert listed == brute_force_pairs(pos, r, skin)
    # and scipy's distances agree on the closest listed pair
    if listed:
        dist = squareform(pdist(pos))
        i, j = min(listed, key=lambda p: dist[p] - r[p[0]] - r[p[1]])
        assert dist[i, j] - r[i] - r[j] < skin


@pytest.mark.parametrize("team", [1, 2])
def test_pairs_equal_brute_force_in_cell_order(team: int) -> None:
    """Stored cell by cell, as the engine stores them, every cell holds a run of consecutive
    indices, which the build scans without a search and tests in lanes."""
    pos, r = random_spheres(1500, 5)
    nl = _core.VerletList(0.003, 3)
    order = nl.spatial_order(*pos.T.copy(), r)
    assert sorted(order.tolist()) == list(range(len(r)))  # a permutation
    pos, r = pos[order], r[order]
    nl.build(*pos.T.copy(), r, team=team)
    listed = {tuple(p) for p in nl.pairs().tolist()}
    assert len(listed) == len(nl.pairs())
    assert listed == brute_force_pairs(pos, r, 0.003)
    # in that order, a particle's partners lie close behind it in storage
    assert np.median(np.diff(nl.pairs(), axis=1)) < 0.1 * len(r)


@pytest.mark.parametrize("period_z", [0.1, 0.03])
def test_periodic_ends_use_the_minimum_image(period_z: float) -> None:
    pos, r = random_spheres(400, 7, box=(0.2, 0.2, period_z))
    nl = _core.VerletList(0.002, 0, period_z)
    nl.build(*pos.T.copy(), r)
    listed = {tuple(p) for p in nl.pairs().tolist()}
    assert listed == brute_force_pairs(pos, r, 0.002, period_z)
    assert listed != brute_force_pairs(pos, r, 0.002)  # pairs across the ends exist


def test_a_centre_on_the_period_finds_its_partners_across_it() -> None:
    """A wrapped z can round to the period itself (z - L floor(z / L) for z just below 0): it
    bins into the first cell, yet lies at its far face; partners just below the period, in
    the last cell, are found."""
    period_z = 0.1
    pos, r = random_spheres(400, 8, box=(0.2, 0.2, period_z))
    pos[:30, 2] = period_z
    pos[30:60, 2] = period_z - 0.004
    nl = _core.VerletList(0.002, 0, period_z)
    nl.build(*pos.T.copy(), r)
    listed = {tuple(p) for p in nl.pairs().tolist()}
    assert listed == brute_force_pairs(pos, r, 0.002, period_z)
    assert any(i < 30 <= j < 60 for i, j in listed)  # such pairs exist


@pytest.mark.parametrize("team", [1, 3])
def test_history_follows_its_pair_across_rebuilds(team: int) -> None:
    pos, r = random_spheres(600, 11)
    nl = _core.VerletList(0.003, 2)
    nl.build(*pos.T.copy(), r, team=team)
    pairs0 = nl.pairs()
    nl.history = np.column_stack([pairs0[:, 0] * 1e4 + pairs0[:, 1], -pairs0[:, 1]])
    moved = pos + np.random.default_rng(12).normal(0, 0.002, pos.shape)
    nl.build(*moved.T.copy(), r, team=team)
    pairs1, h = nl.pairs(), nl.history
    old = {tuple(p) for p in pairs0.tolist()}
    kept = np.array([tuple(p) in old for p in pairs1.tolist()])
    assert kept.any() and (~kept).any()  # some pairs survive, some are new
    np.testing.assert_array_equal(h[kept, 0], pairs1[kept, 0] * 1e4 + pairs1[kept, 1])
    np.testing.assert_array_equal(h[kept, 1], -pairs1[kept, 1])
    np.testing.assert_array_equal(h[~kept], 0.0)
    assert nl.builds == 2


def test_bad_arguments() -> None:
    with pytest.raises(ValueError, match="skin = -0.001 m is not valid; it must be > 0"):
        _core.VerletList(-0.001, 3)
    with pytest.raises(ValueError, match="period_z = -1 m is not valid"):
        _core.VerletList(0.001, 3, -1.0)
    nl = _core.VerletList(0.001, 3)
    with pytest.raises(ValueError, match="equal length"):
        nl.build(np.zeros(3), np.zeros(2), np.zeros(3), np.ones(3))
    with pytest.raises(ValueError, match="equal length"):
        nl.spatial_order(np.zeros(3), np.zeros(3), np.zeros(3), np.ones(4))
    with pytest.raises(ValueError, match="1-D arrays of equal length"):
        nl.spatial_order(np.zeros(()), np.zeros(1), np.zeros(1), np.ones(1))
    with pytest.raises(ValueError, match="team = 0 is not valid; it must be >= 1"):
        nl.build(np.zeros(3), np.zeros(3), np.zeros(3), np.ones(3), team=0)

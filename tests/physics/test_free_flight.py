"""The kicks and the drift (cpp/src/step/motion_lanes-inl.hpp), on every SIMD path the CPU runs,
against ballistic flight.

Velocity Verlet integrates a constant force exactly: with gravity alone, after t = n dt,
x = x0 + v0 t - g t^2 / 2 (along -y), v = v0 - g t, and the spins do not change. The spheres
fly apart from one another and from the drum, so that nothing but gravity acts; their count
(37) is no multiple of any path's lanes, so that each path's vector loop and its remainder
both run. The list is rebuilt whenever the farthest-moved sphere has moved half the skin, so
the count of list builds checks the largest move that the drift reports.
"""

from __future__ import annotations

import numpy as np
import pytest

from millscope import _core

from .test_engine import G, make_engine

FLIGHT_S = 0.1
COUNT = 37
RADIUS = 0.01  # m
LENGTH = 0.315  # m, the drum's length (the period with periodic ends)


def _launch(periodic: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Positions, velocities and spins of COUNT spheres 5 cm apart, moving nearly alike (their
    relative moves over the flight stay under the gaps), none reaching the shell or an end wall
    within FLIGHT_S; with periodic ends they move along z fast enough to cross the period."""
    rng = np.random.default_rng(4)
    grid = np.array([(x, y, z) for x in (-0.1, -0.05, 0.0, 0.05, 0.1)
                     for y in (-0.1, -0.05, 0.0, 0.05, 0.1) for z in (0.12, 0.17, 0.22)])
    positions = grid[rng.permutation(len(grid))[:COUNT]]
    drift = np.array([0.3, 0.8, 2.0 if periodic else 0.1])  # m/s, common to all
    velocities = drift + rng.uniform(-0.05, 0.05, (COUNT, 3))
    spins = rng.uniform(-50.0, 50.0, (COUNT, 3))  # rad/s
    return positions, velocities, spins


@pytest.mark.parametrize("friction", [0.15, 0.0], ids=["friction", "frictionless"])
@pytest.mark.parametrize("periodic", [False, True], ids=["end walls", "periodic"])
@pytest.mark.parametrize("path", _core.simd_paths())
def test_free_flight_is_the_parabola_on_every_simd_path(path: str, periodic: bool,
                                                        friction: float) -> None:
    positions, velocities, spins = _launch(periodic)
    eng = make_engine(np.full(COUNT, RADIUS), friction=friction, end_walls=not periodic,
                      length=LENGTH, positions=positions, velocities=velocities, spins=spins,
                      track_energy=False, simd=path)
    assert eng.simd == path
    steps = round(FLIGHT_S / eng.dt)
    eng.advance(steps)
    t = steps * eng.dt
    gravity = np.array([0.0, -G, 0.0])
    expected_x = positions + velocities * t + 0.5 * gravity * t**2
    if periodic:
        assert np.all(expected_x[:, 2] > LENGTH)  # every sphere has crossed the period
        expected_x[:, 2] %= LENGTH
    assert eng.max_overlap_ratio() == 0.0
    np.testing.assert_allclose(eng.positions, expected_x, rtol=0, atol=1e-10)
    np.testing.assert_allclose(eng.velocities, velocities + gravity * t, rtol=0, atol=1e-10)
    assert np.array_equal(eng.spins, spins)
    # The list is built once at the start and again each time the farthest-moved sphere has
    # moved half the skin since the last build: as many times as half skins fit into the path
    # of the fastest sphere (speeds on a fine grid of times; the paths are nearly straight).
    times = np.linspace(0.0, t, 20001)
    speed = np.linalg.norm(velocities[None] + gravity * times[:, None, None], axis=2).max(axis=1)
    path_m = np.trapezoid(speed, times)
    expected_builds = 1 + path_m / (0.5 * eng.skin)
    assert expected_builds > 20
    assert abs(eng.list_builds - expected_builds) < 2


@pytest.mark.parametrize("path", _core.simd_paths())
def test_the_speed_guard_finds_a_sphere_inside_a_vector(path: str) -> None:
    """The drift's guard is reduced across the lanes: a sphere in the middle of the spheres
    (index 18 of 37, within a vector on every path) falling at just under the speed bound
    passes it within a few steps, and the guard's first look (step GUARD_INTERVAL) stops the
    run, naming that sphere."""
    positions, velocities, spins = _launch(periodic=False)
    bound = 30.0  # m/s
    velocities[18] = [0.0, -(bound - 2e-5), 0.0]  # gravity adds g dt, about 2e-5 m/s, a step
    eng = make_engine(np.full(COUNT, RADIUS), end_walls=True, length=LENGTH,
                      positions=positions, velocities=velocities, spins=spins,
                      track_energy=False, simd=path, max_speed=bound, reorder=False)
    assert G * eng.dt * _core.GUARD_INTERVAL > 4e-5  # past the bound before the look
    with pytest.raises(RuntimeError, match=r"particle 18 .*moves at 30(\.0+\d*)? m/s, above the "
                                           r"bound of 30 m/s"):
        eng.advance(2 * _core.GUARD_INTERVAL)
    assert eng.step_count == _core.GUARD_INTERVAL

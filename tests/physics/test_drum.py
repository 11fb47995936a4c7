"""Drum geometry: shell, end walls and the exact distance to a lifter prism (faces, edges,
corners), checked against scipy's bounded minimisation of the distance to the lifter's box."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import minimize

from millscope import _core

R, L, W, H = 0.44, 0.315, 0.030, 0.020  # the paper's pilot mill (Table 1), lifter 30 x 20 mm
N_LIFTERS = 16


def drum(end_walls: bool = True, lifters: int = N_LIFTERS) -> _core.DrumGeometry:
    return _core.DrumGeometry(R, L, end_walls, lifters, W, H)


def lifter_distance_scipy(x: np.ndarray, phi: float) -> float:
    """Distance from x to the box {a in [R-H, R+H], b in [-W/2, W/2], z in [0, L]} of the lifter
    at angle phi, by minimising |x - q|^2 over the box (a convex problem)."""
    c, s = np.cos(phi), np.sin(phi)

    def q_of(p: np.ndarray) -> np.ndarray:
        return np.array([c * p[0] - s * p[1], s * p[0] + c * p[1], p[2]])

    start = np.array([R, 0.0, L / 2])
    res = minimize(lambda p: np.sum((x - q_of(p)) ** 2), start, method="L-BFGS-B",
                   bounds=[(R - H, R + H), (-W / 2, W / 2), (0, L)],
                   options={"ftol": 1e-20, "gtol": 1e-14})
    return float(np.sqrt(res.fun))


def lifter_contacts(found):
    return [c for c in found if c["part"] == "lifter"]


@pytest.mark.parametrize("seed", range(6))
def test_shell_overlap_and_normal(seed: int) -> None:
    rng = np.random.default_rng(seed)
    r = 0.0125
    angle = rng.uniform(0, 2 * np.pi)
    rho = R - r + rng.uniform(1e-5, 5e-3)  # overlapping the shell
    x = np.array([rho * np.cos(angle), rho * np.sin(angle), L / 2])
    (c,) = _core.drum_contacts(drum(lifters=0), 0.3, x, r)
    assert c["part"] == "shell"
    assert c["overlap"] == pytest.approx(rho + r - R, rel=1e-12)
    np.testing.assert_allclose(c["normal"], [-np.cos(angle), -np.sin(angle), 0], atol=1e-15)
    assert np.hypot(*c["point"][:2]) == pytest.approx(R, rel=1e-15)


def test_end_walls_and_periodic_ends() -> None:
    r = 0.006
    x = np.array([0.1, 0.05, 0.004])
    found = _core.drum_contacts(drum(), 0.0, x, r)
    assert [c["part"] for c in found] == ["end_low"]
    assert found[0]["overlap"] == pytest.approx(r - 0.004)
    x_high = np.array([0.1, 0.05, L - 0.001])
    (c,) = _core.drum_contacts(drum(), 0.0, x_high, r)
    assert c["part"] == "end_high" and c["overlap"] == pytest.approx(r - 0.001)
    np.testing.assert_array_equal(c["normal"], [0, 0, -1])
    assert _core.drum_contacts(drum(end_walls=False), 0.0, x, r) == []


@pytest.mark.parametrize("seed", range(40))
def test_lifter_distance_matches_scipy_near_faces_edges_and_corners(seed: int) -> None:
    """Points scattered round lifter 3 of a drum turned by theta: above its top, beside its
    sides, off its edges, and past its ends (periodic ends, so the prism's corners count)."""
    rng = np.random.default_rng(100 + seed)
    theta = rng.uniform(-3, 3)
    k = 3
    phi = theta + 2 * np.pi * k / N_LIFTERS
    a = rng.uniform(R - H - 0.012, R - 0.004)
    b = rng.uniform(-W / 2 - 0.012, W / 2 + 0.012)
    z = rng.choice([rng.uniform(-0.01, 0.0), rng.uniform(0.0, L), rng.uniform(L, L + 0.01)])
    x = np.array([a * np.cos(phi) - b * np.sin(phi), a * np.sin(phi) + b * np.cos(phi), z])
    reference = lifter_distance_scipy(x, phi)
    inside = R - H <= a and abs(b) <= W / 2 and 0 <= z <= L
    if inside:
        return  # covered by the deep-penetration test below
    r = reference + 1e-3  # a sphere just reaching the lifter
    found = [c for c in lifter_contacts(_core.drum_contacts(drum(end_walls=False), theta, x, r))
             if c["index"] == k]
    assert len(found) == 1
    c = found[0]
    assert r - c["overlap"] == pytest.approx(reference, abs=1e-9)
    np.testing.assert_allclose(np.linalg.norm(x - c["point"]), reference, atol=1e-9)
    np.testing.assert_allclose(c["normal"], (x - c["point"]) / reference, atol=1e-9)
    # a sphere that stops short of it does not touch
    short = [c for c in lifter_contacts(_core.drum_contacts(drum(False), theta, x,
                                                            reference - 1e-4))
             if c["index"] == k]
    assert short == []


def test_deep_penetration_leaves_through_the_nearest_reachable_face() -> None:
    x = np.array([R - H + 0.003, 0.001, L / 2])  # inside lifter 0, 3 mm below its top
    (c,) = lifter_contacts(_core.drum_contacts(drum(), 0.0, x, 0.01))
    assert c["overlap"] == pytest.approx(0.01 + 0.003)
    np.testing.assert_allclose(c["normal"], [-1, 0, 0], atol=1e-15)


@pytest.mark.parametrize("alpha", [0.1, 1.0, -2.5])
def test_turning_drum_and_sphere_together_turns_the_contacts(alpha: float) -> None:
    x = np.array([R - H - 0.005, W / 2 + 0.004, 0.1])
    rot = np.array([[np.cos(alpha), -np.sin(alpha), 0], [np.sin(alpha), np.cos(alpha), 0],
                    [0, 0, 1]])
    before = _core.drum_contacts(drum(), 0.0, x, 0.0125)
    after = _core.drum_contacts(drum(), alpha, rot @ x, 0.0125)
    assert len(before) == len(after) >= 1
    for c0, c1 in zip(before, after, strict=True):
        assert c0["part"] == c1["part"] and c0["index"] == c1["index"]
        assert c1["overlap"] == pytest.approx(c0["overlap"], rel=1e-12)
        np.testing.assert_allclose(c1["normal"], rot @ c0["normal"], atol=1e-12)


def test_far_from_the_shell_nothing_touches() -> None:
    assert _core.drum_contacts(drum(), 0.7, np.array([0.0, 0.1, L / 2]), 0.0125) == []


@pytest.mark.parametrize(
    ("args", "message"),
    [
        ((-0.44, L, True, 16, W, H), "Drum.radius = -0.44 is not valid"),
        ((R, 0.0, True, 16, W, H), "Drum.length = 0 is not valid"),
        ((R, L, True, 16, W, 0.5), r"Drum.lifter_height = 0.5 is not valid; it must be in \(0, "),
        ((R, L, True, 16, 0.2, H), "Drum.lifter_width = 0.2 is not valid"),
        ((R, L, True, -1, W, H), "Drum.lifters = -1 is not valid"),
    ],
)
def test_bad_geometry_is_refused(args, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        _core.DrumGeometry(*args)

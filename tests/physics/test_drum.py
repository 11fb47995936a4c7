"""Drum geometry: shell, end walls and the exact distance to a lifter prism (faces, edges,
corners), checked against scipy's bounded minimisation of the distance to the lifter's box and,
for rectangular and trapezoidal lifters alike, against a brute-force distance to the lifter's
cross-section polygon (minimum over its edges) combined with the clamp along z."""

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
        ((R, L, True, 16, W, H, 0.0, 0.04),
         r"Drum.lifter_top_width = 0.04 is not valid; it must be in \(0, lifter_width\] m "
         r"\(lifter_width = 0.03 m\)"),
        ((R, L, True, 16, W, H, 0.0, 0.0), "Drum.lifter_top_width = 0 is not valid"),
        ((R, L, True, 16, W, H, 0.0, -0.01), "Drum.lifter_top_width = -0.01 is not valid"),
        ((R, L, True, 16, W, H, 0.0, float("nan")), "Drum.lifter_top_width = nan is not valid"),
        ((R, L, True, 16, 0.2, H, 0.0, 0.01), "Drum.lifter_width = 0.2 is not valid"),
    ],
)
def test_bad_geometry_is_refused(args, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        _core.DrumGeometry(*args)


# -- trapezoidal lifters ---------------------------------------------------------------------
#
# The reference below is written from the definition, independently of drum.hpp: the lifter's
# cross-section, in its local frame (a radial along the centre line, b tangential), is the convex
# polygon with corners (R - H, +-t/2) at the tip, through (R, +-w/2) at the shell, continued along
# the same side lines to a = R + H; the prism is that polygon times [0, L] in z.

SHAPES = {  # (base width w, tip width t, height h), m
    "rectangle": (W, W, H),
    "trapezoid": (W, 0.018, H),
    "steep": (0.040, 0.006, 0.012),  # side slope 1.4: the side face leans well towards the axis
    "pointed": (0.030, 1e-4, 0.030),
}


def polygon(w: float, t: float, h: float) -> dict[str, np.ndarray]:
    """Edges of the cross-section as (start, end) pairs of (a, b) points."""
    half_far = t / 2 + (w - t)  # the side lines reach R + h at this half width
    tip_lo, tip_hi = np.array([R - h, -t / 2]), np.array([R - h, t / 2])
    far_lo, far_hi = np.array([R + h, -half_far]), np.array([R + h, half_far])
    # counter-clockwise in the (a, b) plane: the interior is to the left of each edge
    return {"tip": np.array([tip_hi, tip_lo]), "side_low": np.array([tip_lo, far_lo]),
            "far": np.array([far_lo, far_hi]), "side_high": np.array([far_hi, tip_hi])}


def closest_on_segment(p: np.ndarray, seg: np.ndarray) -> np.ndarray:
    d = seg[1] - seg[0]
    u = np.clip(np.dot(p - seg[0], d) / np.dot(d, d), 0.0, 1.0)
    return seg[0] + u * d


def inside_polygon(p: np.ndarray, edges: dict[str, np.ndarray]) -> bool:
    """Inside (or on) the polygon: to the left of each counter-clockwise edge."""
    def left_of(e: np.ndarray) -> bool:
        d, v = e[1] - e[0], p - e[0]
        return d[0] * v[1] - d[1] * v[0] >= 0.0

    return all(left_of(e) for e in edges.values())


def outward_normal(seg: np.ndarray) -> np.ndarray:
    d = (seg[1] - seg[0]) / np.linalg.norm(seg[1] - seg[0])
    return np.array([d[1], -d[0]])  # right of a counter-clockwise edge


def reference(x_local: np.ndarray, shape: tuple[float, float, float]):
    """(inside, distance, closest point (a, b, z), outward normal (a, b) of the exit face) for a
    point (a, b, z). Outside: exact distance to the prism. Inside: depth below the nearest face
    reachable from the drum (tip or a side), the face's normal and the foot on it."""
    edges = polygon(*shape)
    p, z = x_local[:2], x_local[2]
    cz = min(max(z, 0.0), L)
    if inside_polygon(p, edges):
        if cz == z:
            faces = {k: edges[k] for k in ("tip", "side_high", "side_low")}
            feet = {k: closest_on_segment(p, e) for k, e in faces.items()}
            depth = {k: np.linalg.norm(p - q) for k, q in feet.items()}
            best = min(depth, key=depth.get)
            return True, depth[best], np.append(feet[best], z), outward_normal(faces[best])
        return False, abs(z - cz), np.array([p[0], p[1], cz]), None
    feet = [closest_on_segment(p, e) for e in edges.values()]
    q = min(feet, key=lambda f: np.linalg.norm(p - f))
    return False, float(np.hypot(np.linalg.norm(p - q), z - cz)), np.append(q, cz), None


def distance_to_surface(q_local: np.ndarray, shape: tuple[float, float, float]) -> float:
    """Distance of a point to the prism's surface (0 on it)."""
    edges = polygon(*shape)
    p, z = q_local[:2], q_local[2]
    if inside_polygon(p, edges) and 0.0 <= z <= L:
        to_edge = min(np.linalg.norm(p - closest_on_segment(p, e)) for e in edges.values())
        return min(to_edge, z, L - z)
    return reference(q_local, shape)[1]


def shaped_drum(shape: tuple[float, float, float], phase: float = 0.0,
                end_walls: bool = False) -> _core.DrumGeometry:
    w, t, h = shape
    return _core.DrumGeometry(R, L, end_walls, N_LIFTERS, w, h, phase, lifter_top_width=t)


def frame(phi: float) -> np.ndarray:
    """Columns e_a, e_b, e_z of the lifter at angle phi."""
    c, s = np.cos(phi), np.sin(phi)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def points_round_the_lifter(rng: np.random.Generator, shape, count: int) -> np.ndarray:
    """Local points near the polygon's corners and edges (offsets from 1 um to 2 cm, so outside
    and inside), near the prism's ends and away from them."""
    edges = list(polygon(*shape).values())
    out = []
    for _ in range(count):
        e = edges[rng.integers(len(edges))]
        on = e[0] + rng.choice([0.0, 1.0, rng.uniform()]) * (e[1] - e[0])  # corner or edge
        angle = rng.uniform(0, 2 * np.pi)
        p = on + 10 ** rng.uniform(-6, np.log10(0.02)) * np.array([np.cos(angle), np.sin(angle)])
        near_end = 10 ** rng.uniform(-6, -2)
        z = rng.choice([rng.uniform(0, L), -near_end, near_end, L - near_end, L + near_end])
        out.append([p[0], p[1], z])
    return np.array(out)


@pytest.mark.parametrize("name", SHAPES)
def test_lifter_contacts_match_the_polygon_reference(name: str) -> None:
    """Overlap, contact point and normal for points round lifter k of a turned drum, against the
    brute-force reference: outside (a sphere just reaching the lifter, and one stopping short) and
    inside (the guard case: overlap r + depth, leaving through the nearest reachable face)."""
    shape = SHAPES[name]
    rng = np.random.default_rng(sum(map(ord, name)))
    phase = 0.17
    geometry = shaped_drum(shape, phase)
    assert geometry.lifter_top_width == shape[1]
    checked = {"outside": 0, "inside": 0}
    for x_local in points_round_the_lifter(rng, shape, 600):
        theta, k = rng.uniform(-3, 3), int(rng.integers(N_LIFTERS))
        rot = frame(theta + phase + 2 * np.pi * k / N_LIFTERS)
        x = rot @ x_local
        inside, dist, q_local, n_local = reference(x_local, shape)
        r = 0.01 if inside else dist + 1e-3
        found = [c for c in lifter_contacts(_core.drum_contacts(geometry, theta, x, r))
                 if c["index"] == k]
        assert len(found) == 1, (name, x_local)
        c = found[0]
        normal, point = np.asarray(c["normal"]), np.asarray(c["point"])
        assert np.linalg.norm(normal) == pytest.approx(1.0, abs=1e-14)
        assert distance_to_surface(rot.T @ point, shape) < 1e-12
        np.testing.assert_allclose(point, rot @ q_local, atol=1e-12)
        if inside:
            checked["inside"] += 1
            assert c["overlap"] == pytest.approx(r + dist, abs=1e-12)
            np.testing.assert_allclose(normal, rot @ np.append(n_local, 0.0), atol=1e-12)
            # the centre lies behind the face, depth along the normal
            np.testing.assert_allclose(x, point - dist * normal, atol=1e-12)
        else:
            checked["outside"] += 1
            assert c["overlap"] == pytest.approx(r - dist, abs=1e-12)
            # from the wall into the sphere: along x - point (to the points' 1e-15 m over dist)
            np.testing.assert_allclose(normal, (x - rot @ q_local) / dist, atol=1e-15 / dist)
            assert np.dot(normal, x - point) > 0.0
            if dist > 2e-6:
                short = _core.drum_contacts(geometry, theta, x, dist - 1e-6)
                assert [c for c in lifter_contacts(short) if c["index"] == k] == []
    assert checked["outside"] > 300 and checked["inside"] > 30, checked


def test_sphere_on_a_sloped_side_face_touches_along_its_normal() -> None:
    """A hand-made case: a sphere centred at distance d from the middle of the side face along
    the face's outward normal (-s, 1) / sqrt(1 + s^2), s = (w - t) / (2 h)."""
    w, t, h = SHAPES["trapezoid"]
    s = (w - t) / (2 * h)
    n = np.array([-s, 1.0]) / np.hypot(s, 1.0)
    mid = np.array([R - h / 2, t / 2 + s * h / 2])  # half way up the face, below the shell
    d, r = 0.004, 0.005
    x = np.append(mid + d * n, 0.1)
    (c,) = lifter_contacts(_core.drum_contacts(shaped_drum(SHAPES["trapezoid"]), 0.0, x, r))
    assert c["index"] == 0
    assert c["overlap"] == pytest.approx(r - d, abs=1e-15)
    np.testing.assert_allclose(c["normal"], [n[0], n[1], 0.0], atol=1e-15)
    np.testing.assert_allclose(c["point"], [mid[0], mid[1], 0.1], atol=1e-15)


def test_deep_in_a_trapezoid_leaves_through_the_tilted_side() -> None:
    """Inside, 1 mm from the side line and far from the tip: the exit is the side face, with its
    tilted outward normal."""
    w, t, h = SHAPES["steep"]
    s = (w - t) / (2 * h)
    n = np.array([-s, 1.0]) / np.hypot(s, 1.0)
    on_side = np.array([R - 0.5 * h, t / 2 + s * 0.5 * h])
    x = np.append(on_side - 0.001 * n, L / 2)
    (c,) = lifter_contacts(_core.drum_contacts(shaped_drum(SHAPES["steep"]), 0.0, x, 0.01))
    assert c["overlap"] == pytest.approx(0.01 + 0.001, abs=1e-15)
    np.testing.assert_allclose(c["normal"], [n[0], n[1], 0.0], atol=1e-15)
    np.testing.assert_allclose(c["point"], [on_side[0], on_side[1], L / 2], atol=1e-15)


@pytest.mark.parametrize("seed", range(3))
def test_tip_as_wide_as_the_base_is_the_rectangular_lifter(seed: int) -> None:
    """lifter_top_width = lifter_width is the rectangle exactly, and a tip narrower by 1e-12 of
    the width (the trapezoid's own code path) agrees with it to within 1e-13 m."""
    rng = np.random.default_rng(7 + seed)
    rect = drum(end_walls=False)
    same = _core.DrumGeometry(R, L, False, N_LIFTERS, W, H, 0.0, lifter_top_width=W)
    almost = _core.DrumGeometry(R, L, False, N_LIFTERS, W, H, 0.0, lifter_top_width=W * (1 - 1e-12))
    assert same.lifter_top_width == rect.lifter_top_width == W
    for x_local in points_round_the_lifter(rng, SHAPES["rectangle"], 200):
        theta, r = rng.uniform(-3, 3), rng.uniform(0.003, 0.02)
        x = frame(theta + 2 * np.pi * 5 / N_LIFTERS) @ x_local
        expected = _core.drum_contacts(rect, theta, x, r)
        exact = _core.drum_contacts(same, theta, x, r)
        assert len(exact) == len(expected)
        for c0, c1 in zip(exact, expected, strict=True):
            assert c0.keys() == c1.keys()
            assert all(np.array_equal(c0[f], c1[f]) for f in c0)
        got = _core.drum_contacts(almost, theta, x, r)
        assert [(c["part"], c["index"]) for c in got] == [(c["part"], c["index"]) for c in expected]
        for c0, c1 in zip(got, expected, strict=True):
            assert c0["overlap"] == pytest.approx(c1["overlap"], abs=1e-13)
            np.testing.assert_allclose(c0["point"], c1["point"], atol=1e-13)
            # outside, the normal is (x - point) / distance: 1e-13 m over the distance
            dist = r - c1["overlap"]
            np.testing.assert_allclose(c0["normal"], c1["normal"],
                                       atol=1e-13 / dist if dist > 0 else 1e-12)


def test_geometry_reports_its_fields() -> None:
    g = _core.DrumGeometry(R, L, True, N_LIFTERS, W, H, 0.25, lifter_top_width=0.02)
    assert (g.radius, g.length, g.end_walls, g.lifters) == (R, L, True, N_LIFTERS)
    assert (g.lifter_width, g.lifter_height, g.lifter_phase, g.lifter_top_width) == (
        W, H, 0.25, 0.02)
    assert drum().lifter_top_width == W  # None: rectangular, the tip as wide as the base
    assert _core.DrumGeometry(R, L, True, 0, 0.0, 0.0).lifter_top_width == 0.0

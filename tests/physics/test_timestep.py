"""The time-step limit: velocity Verlet's bound on the damped normal and stick modes (issue 24.4).

The limit (:func:`millscope.stiffness.time_step_limit`) rests on three claims, each checked
here against something computed independently of it:

1. **The bound (S3)** of :func:`millscope.contact.verlet_stability_bound`: the engine's step,
   written out as a 3 x 3 linear map of (x, v, F) (half kick, drift, force with the half-step
   velocity, half kick) and iterated numerically, keeps its spectral radius <= 1 exactly up to
   w0 dt = 2 (sqrt(1 + zeta^2) - zeta).
2. **The modes (M1, M2)** of :func:`millscope.contact.contact_modes`: two bodies pressed
   together at a given overlap and integrated with the engine's contact law
   (``_core.sphere_contact`` / ``_core.wall_contact``, the engine's kick-drift-kick around it)
   lose a small normal or tangential disturbance at 0.99 x the mode's bound and blow it up by
   orders of magnitude at 1.01 x it; the stick mode's effective mass m*/3.5 (translation and
   rotation of both spheres) is also checked against the generic g^T M^-1 g.
3. **Impacts** (:func:`millscope.contact.impact`, the engine's integrator in C++): at
   0.95 x the limit (the safety factor 0.8 included) restitution and spin stay close to their
   converged values; at 1.25 x the bound they do not.

Then the refusal: :class:`~millscope.Simulation` accepts a step just below the limit and
refuses one just above it, naming the pair and the mode; the default step 0.2 T_R stays valid
for every preset.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

import millscope as ms
from millscope import _core, presets
from millscope.contact import (
    DEFAULT_DT_FRACTION,
    DT_SAFETY_FACTOR,
    MAX_DT_FRACTION,
    NORMAL_MODE,
    STICK_MODE,
    ContactMode,
    contact_modes,
    impact,
    pair_properties,
    verlet_stability_bound,
)
from millscope.stiffness import PairLimit, TimeStepLimit, time_step_limit

LD_TINY = presets.pilot_mill(0.71, "ceramic", 1, "tiny")  # the paper's e = 0.2 at G x 0.001
LIMIT = time_step_limit(LD_TINY)
PAIRS = {p.label: p for p in LIMIT.pairs}
CERAMIC_DRUM = "particles (ceramic) - drum (steel)"
BALL_BALL = "balls (steel) - balls (steel)"


def _beta(e: float) -> float:
    """Eq. 3."""
    return math.log(e) / math.sqrt(math.log(e) ** 2 + math.pi**2)


# -- 1. the bound of the scheme ----------------------------------------------------------------

def _engine_step_matrix(w0dt: float, zeta: float) -> np.ndarray:
    """The engine's step on m x'' = F, F = -k x - c v (m = 1, dt = 1), as the matrix of the
    linear map (x, v, F) -> (x', v', F'): half kick with the stored force, drift, force at the
    new position with the half-step velocity, half kick."""
    k, c = w0dt**2, 2.0 * zeta * w0dt

    def step(state: np.ndarray) -> np.ndarray:
        x, v, f = state
        v = v + 0.5 * f
        x = x + v
        f = -k * x - c * v
        v = v + 0.5 * f
        return np.array([x, v, f])

    return np.column_stack([step(e) for e in np.eye(3)])


def _spectral_radius(w0dt: float, zeta: float) -> float:
    return float(np.max(np.abs(np.linalg.eigvals(_engine_step_matrix(w0dt, zeta)))))


@pytest.mark.parametrize("zeta", [0.0, 0.05, 0.197, 0.416, 0.778, 1.0, 1.5, 3.0])
def test_the_bound_is_where_the_steps_spectral_radius_reaches_one(zeta: float) -> None:
    """Bisection on the numerical spectral radius of the engine's step finds (S3)."""
    lo, hi = 1e-3, 3.0  # radius <= 1 at lo, > 1 at hi
    assert _spectral_radius(lo, zeta) <= 1 + 1e-9 < _spectral_radius(hi, zeta)
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if _spectral_radius(mid, zeta) <= 1 + 1e-9 else (lo, mid)
    assert verlet_stability_bound(zeta) == pytest.approx(lo, rel=1e-6)
    assert verlet_stability_bound(zeta) == pytest.approx(2 * (math.sqrt(1 + zeta**2) - zeta))
    # strictly inside below it, outside above it (damped: decaying, not merely bounded)
    if zeta > 0:
        assert _spectral_radius(0.99 * lo, zeta) < 1
    assert _spectral_radius(1.01 * lo, zeta) > 1 + 1e-4


def test_the_bound_is_two_undamped_and_falls_with_damping() -> None:
    assert verlet_stability_bound(0.0) == 2.0
    zetas = np.linspace(0, 3, 31)
    bounds = [verlet_stability_bound(z) for z in zetas]
    assert all(np.diff(bounds) < 0)
    # the paper's e = 0.2: normal 1.33, stick mode (zeta x sqrt 3.5) 0.98
    zeta = -math.sqrt(5 / 6) * _beta(0.2)
    assert verlet_stability_bound(zeta) == pytest.approx(1.334, abs=1e-3)
    assert verlet_stability_bound(math.sqrt(3.5) * zeta) == pytest.approx(0.978, abs=1e-3)
    with pytest.raises(ValueError, match=r"damping_ratio = -0\.1 is not valid; it must be "
                                         r"finite and >= 0"):
        verlet_stability_bound(-0.1)


# -- 2. the modes ------------------------------------------------------------------------------

def test_modes_follow_the_paper_law() -> None:
    """S_n (4), S_t (6), m*, m*/3.5 and zeta from beta (3) by hand for a ceramic-steel pair."""
    cer, steel = LD_TINY.material("ceramic"), LD_TINY.material("steel")
    normal, stick = contact_modes(cer, steel, 0.012, 0.025, 5.0, 0.2, 0.4)
    p = pair_properties(cer, steel, 0.012, 0.025)
    d = (15 * p.m_star * 25.0 / (16 * p.e_star * math.sqrt(p.r_star))) ** 0.4
    zeta = -math.sqrt(5 / 6) * _beta(0.2)
    def fields(m: ContactMode) -> tuple[float, ...]:
        return m.stiffness, m.mass, m.damping_ratio, m.overlap

    assert (normal.name, stick.name) == (NORMAL_MODE, STICK_MODE)
    assert fields(normal) == pytest.approx(
        (2 * p.e_star * math.sqrt(p.r_star * d), p.m_star, zeta, d), rel=1e-12)
    assert fields(stick) == pytest.approx(
        (8 * p.g_star * math.sqrt(p.r_star * d), p.m_star / 3.5, math.sqrt(3.5) * zeta, d),
        rel=1e-12)
    assert stick.stability_dt == pytest.approx(
        verlet_stability_bound(math.sqrt(3.5) * zeta) / math.sqrt(3.5 * stick.stiffness / p.m_star))
    assert len(contact_modes(cer, steel, 0.012, 0.025, 5.0, 0.2, 0.0)) == 1  # no friction


@pytest.mark.parametrize("wall", [False, True])
def test_the_stick_mass_is_that_of_the_contact_points_slip(wall: bool) -> None:
    """1 / m_t = g^T M^-1 g for the slip s = (x_a - r_a th_a) - (x_b + r_b th_b) of two solid
    spheres (x: tangential positions, th: spins), = 3.5 / m*."""
    ra, rb, ma, mb = 0.006, 0.0125, 0.0025, 0.064
    inertia = [0.4 * ma * ra**2, 0.4 * mb * rb**2]
    g = np.array([1.0, -ra, -1.0, -rb])
    masses = np.array([ma, inertia[0], mb, inertia[1]])
    if wall:  # the wall neither moves nor turns
        g, masses = g[:2], masses[:2]
    m_star = ma if wall else ma * mb / (ma + mb)
    assert 1 / float(g @ (g / masses)) == pytest.approx(m_star / 3.5, rel=1e-12)


def _bodies(pair: str) -> tuple[ms.Fraction, ms.Fraction | None, ms.Material, ms.Material,
                                 ms.Pair]:
    """Fraction a, fraction b (None: the drum), their materials and the pair's coefficients,
    from a label ``"<fraction> (<material>) - <fraction or drum> (<material>)"``."""
    a_name, b_name = (side.split(" (")[0] for side in pair.split(" - "))
    fa = next(f for f in LD_TINY.charge if f.name == a_name)
    fb = None if b_name == "drum" else next(f for f in LD_TINY.charge if f.name == b_name)
    mat_a = LD_TINY.material(fa.material)
    mat_b = LD_TINY.material(LD_TINY.drum.material if fb is None else fb.material)
    return fa, fb, mat_a, mat_b, LD_TINY.pair(mat_a.name, mat_b.name)


def _pressed(mode: ContactMode, pair: str, dt_factor: float, steps: int = 300) -> float:
    """Two bodies of ``pair`` pressed together by a central load that holds ``mode.overlap``,
    disturbed along the mode (a normal or a tangential velocity of a) and integrated with the
    engine's contact law and kick-drift-kick at dt_factor x the mode's bound. Returns the
    largest disturbance force over the last 50 steps / over the first 10."""
    fa, fb, mat_a, mat_b, coeff = _bodies(pair)
    wall = fb is None
    core = [_core.Material(m.density, m.shear_modulus, m.poisson) for m in (mat_a, mat_b)]
    pc = _core.pair_constants(core[0], core[1], coeff.restitution, 1e6)  # never sliding
    ra, rb = fa.radius, (0.0 if fb is None else fb.radius)
    m_a = _core.sphere_mass(mat_a.density, ra)
    m_b = 1.0 if fb is None else _core.sphere_mass(mat_b.density, rb)  # a wall does not move
    i_a, i_b = 0.4 * m_a * ra**2, 0.4 * m_b * rb**2
    r_star = ra if wall else ra * rb / (ra + rb)
    load = 4 / 3 * pc.e_star * math.sqrt(r_star) * mode.overlap**1.5  # (1) at the overlap
    dt = dt_factor * mode.stability_dt

    x = [np.array([0.0, ra + rb - mode.overlap, 0.0]), np.zeros(3)]
    v, w = [np.zeros(3), np.zeros(3)], [np.zeros(3), np.zeros(3)]
    v[0][1 if mode.name == NORMAL_MODE else 0] = 1e-6 * mode.overlap / dt
    force, torque = [np.zeros(3), np.zeros(3)], [np.zeros(3), np.zeros(3)]
    history = [0.0, 0.0, 0.0]
    seen = []

    def kick() -> None:
        for k, (m, i) in enumerate(((m_a, i_a), (m_b, i_b))[:1 if wall else 2]):
            v[k] += 0.5 * dt * force[k] / m
            w[k] += 0.5 * dt * torque[k] / i

    for _ in range(steps):
        kick()
        x[0] += dt * v[0]
        x[1] += dt * v[1]  # stays at rest for a wall
        if wall:
            n = np.array([0.0, 1.0, 0.0])
            c = _core.wall_contact(pc, x[0], v[0], w[0], ra, m_a, n, ra - x[0][1], np.zeros(3),
                                   history, dt)
        else:
            n = (x[0] - x[1]) / np.linalg.norm(x[0] - x[1])
            c = _core.sphere_contact(pc, x[0], v[0], w[0], ra, m_a, x[1], v[1], w[1], rb, m_b,
                                     history, dt)
        history = list(c.history)
        force = [np.asarray(c.force_i) - load * n, -np.asarray(c.force_i) + load * n]
        torque = [np.asarray(c.torque_i), np.asarray(c.torque_j)]
        kick()
        seen.append(abs(c.normal - load) if mode.name == NORMAL_MODE
                    else float(np.linalg.norm(c.tangential)))
    return max(seen[-50:]) / max(seen[:10])


@pytest.mark.parametrize("pair", list(PAIRS))
@pytest.mark.parametrize("name", [NORMAL_MODE, STICK_MODE])
def test_a_pressed_contact_is_stable_just_below_its_bound_and_not_just_above(
        pair: str, name: str) -> None:
    """At 0.99 x the bound the disturbance dies out (damped, e < 1); at 1.01 x it grows by
    orders of magnitude within 300 steps (measured: 4e-10 to 3e-4, and 1e4 to 1e7). Every
    contact of the LD scene: like and unlike spheres, and spheres on the drum."""
    mode = next(m for m in PAIRS[pair].modes if m.name == name)
    assert _pressed(mode, pair, 0.99) < 1e-2
    assert _pressed(mode, pair, 1.01) > 1e2


# -- 3. impacts --------------------------------------------------------------------------------

def _impact_spec(pair: str) -> tuple[ms.Material, ms.Material, float, float | None, float,
                                     float]:
    fa, fb, mat_a, mat_b, coeff = _bodies(pair)
    return (mat_a, mat_b, fa.diameter, None if fb is None else fb.diameter, coeff.restitution,
            coeff.friction)


@pytest.mark.parametrize("pair", [CERAMIC_DRUM, BALL_BALL])
def test_an_impact_just_below_the_limit_is_accurate_and_above_the_bound_is_not(pair: str) -> None:
    """Oblique impacts at the scene's upper speed (5.65 m/s), tangential speeds 0.25-2 m/s,
    against the converged result (dt = limit / 100).

    At 0.95 x the limit: restitution within 6 %, spin within 20 % (measured: <= 5 % and
    <= 17 %; the spin error is mostly the touch-down slip, resolved to first order, which the
    default step 0.2 T_R misses as much). At 1.25 x the stick mode's bound (1.56 x the limit)
    the stick mode is unstable at the largest overlap and some spin is off by more than 50 %
    (measured 53-420 %)."""
    ma, mb, da, db, e, mu = _impact_spec(pair)
    limit = PAIRS[pair].dt
    assert PAIRS[pair].fastest.name == STICK_MODE
    spin_errors = {}
    for factor in (0.95, 1.25 / DT_SAFETY_FACTOR):
        worst_e = worst_w = 0.0
        for vt in (0.25, 0.5, 1.0, 2.0):
            ref = impact(ma, mb, da, db, LIMIT.speed, e, mu, dt=limit / 100, tangential_speed=vt)
            r = impact(ma, mb, da, db, LIMIT.speed, e, mu, dt=factor * limit, tangential_speed=vt)
            worst_e = max(worst_e, abs(r.restitution / ref.restitution - 1))
            worst_w = max(worst_w, abs(r.spin / ref.spin - 1))
        spin_errors[factor] = worst_w
        if factor < 1:
            assert worst_e < 0.06
            assert worst_w < 0.20
    assert spin_errors[1.25 / DT_SAFETY_FACTOR] > 0.5


# -- the refusal -------------------------------------------------------------------------------

def test_simulation_refuses_a_step_just_above_the_limit_naming_pair_and_mode() -> None:
    t_r = LD_TINY.min_rayleigh_time()[0]
    assert LIMIT.pair == CERAMIC_DRUM and LIMIT.mode.name == STICK_MODE
    assert LIMIT.dt == pytest.approx(DT_SAFETY_FACTOR * LIMIT.mode.stability_dt)
    assert LIMIT.dt < MAX_DT_FRACTION * t_r  # the old rule accepted up to 0.5 T_R
    for dt in (1.01 * LIMIT.dt, MAX_DT_FRACTION * t_r):
        with pytest.raises(ValueError) as err:
            ms.Simulation(LD_TINY, dt=dt, threads=1)
        text = str(err.value)
        assert text.startswith(f"dt = {dt!r} s is not valid; it must be in (0, {LIMIT.dt:.6g}] s")
        assert f"tangential-rotational stick mode of the contact {CERAMIC_DRUM}" in text
        assert f"{LIMIT.dt / t_r:.3g} x the Rayleigh time" in text
    sim = ms.Simulation(LD_TINY, dt=0.99 * LIMIT.dt, threads=1)
    assert sim.dt == 0.99 * LIMIT.dt


def test_paper_stiffness_keeps_the_rayleigh_cap() -> None:
    scene = presets.pilot_mill(0.71, "ceramic", 1, "paper")
    limit = time_step_limit(scene)
    t_r = scene.min_rayleigh_time()[0]
    assert limit.by_rayleigh and limit.dt == MAX_DT_FRACTION * t_r
    assert limit.rayleigh_ratio == pytest.approx(0.623, abs=2e-3)  # the stick mode's, unused
    assert limit.valid_range().endswith("0.5 x the Rayleigh time "
                                        f"{t_r:.6g} s of the fraction 'balls', the stiffest in "
                                        "the charge")


def test_a_scene_whose_default_step_is_unstable_defaults_to_its_limit() -> None:
    """Every pair at e = 0.01 (zeta_t = 1.41): the stick mode's limit falls below 0.2 T_R, and
    the default step is the limit; a step just above it is refused, naming the mode."""
    scene = LD_TINY.replace(pairs=tuple(replace(p, restitution=0.01) for p in LD_TINY.pairs))
    limit = time_step_limit(scene)
    assert limit.dt < DEFAULT_DT_FRACTION * limit.rayleigh_time
    assert ms.Simulation(scene, threads=1).dt == limit.dt
    with pytest.raises(ValueError, match=r"tangential-rotational stick"):
        ms.Simulation(scene, dt=1.01 * limit.dt, threads=1)


@pytest.mark.parametrize("particles", [None, "ceramic", "steel"])
@pytest.mark.parametrize("scale", ["paper", "small", "tiny", "soft"])
def test_the_default_step_is_valid_for_every_preset(particles: str | None, scale: str) -> None:
    """Up to 3 x critical speed (the upper impact speed grows with it)."""
    for speed in (0.62, 0.71, 0.80, 3.0):
        scene = presets.pilot_mill(speed, particles, 1, scale)
        limit = time_step_limit(scene)
        assert isinstance(limit, TimeStepLimit)
        assert all(isinstance(p, PairLimit) for p in limit.pairs)
        assert len(limit.pairs) == (2 if particles is None else 5)
        assert limit.dt >= 0.27 * limit.rayleigh_time > DEFAULT_DT_FRACTION * limit.rayleigh_time
        assert limit.default_dt() == DEFAULT_DT_FRACTION * limit.rayleigh_time

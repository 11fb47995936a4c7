"""The contact law (paper eqs. 1-8) against analytic results, through single impacts.

Materials, restitution and friction: paper Tables 2 and 3; steel balls 25 mm, ceramic particles
12 mm (docs/physics.md, The paper's pilot mill); the mill (walls) is steel.
"""

from __future__ import annotations

import math

import pytest

from millscope import _core
from millscope.contact import (
    DEFAULT_DT_FRACTION,
    MAX_DT_FRACTION,
    ContactMaterial,
    hertz_contact_time,
    hertz_max_overlap,
    impact,
    pair_properties,
    rayleigh_time,
)

STEEL = ContactMaterial(density=7860.0, shear_modulus=81e9, poisson=0.3)
CERAMIC = ContactMaterial(density=2800.0, shear_modulus=1.6e9, poisson=0.22)
BALL, PARTICLE = 0.025, 0.012  # diameters, m
WALL = None  # diameter_b of a flat wall

# (material_a, material_b, diameter_a, diameter_b, restitution, friction): Table 3
PAIRS = {
    "steel-steel": (STEEL, STEEL, BALL, BALL, 0.5, 0.15),
    "ceramic-ceramic": (CERAMIC, CERAMIC, PARTICLE, PARTICLE, 0.3, 0.66),
    "steel-ceramic": (STEEL, CERAMIC, BALL, PARTICLE, 0.2, 0.4),
    "steel-wall": (STEEL, STEEL, BALL, WALL, 0.5, 0.15),
    "ceramic-wall": (CERAMIC, STEEL, PARTICLE, WALL, 0.2, 0.4),
}


def _tc(a, b, da, db, speed):  # type: ignore[no-untyped-def]
    return hertz_contact_time(a, b, da, db, speed)


# --------------------------------------------------------------------------------------------
# Equivalent quantities
# --------------------------------------------------------------------------------------------


def _youngs(m: ContactMaterial) -> float:
    return 2 * m.shear_modulus * (1 + m.poisson)


@pytest.mark.parametrize("name", list(PAIRS))
def test_equivalent_quantities_match_hand_formulas(name: str) -> None:
    a, b, da, db, e, mu = PAIRS[name]
    p = pair_properties(a, b, da, db, e, mu)
    ea, eb = _youngs(a), _youngs(b)
    e_star = 1 / ((1 - a.poisson**2) / ea + (1 - b.poisson**2) / eb)
    g_star = 1 / (2 * (2 - a.poisson) * (1 + a.poisson) / ea
                  + 2 * (2 - b.poisson) * (1 + b.poisson) / eb)
    ra, ma = da / 2, a.density * math.pi * da**3 / 6
    if db is None:
        r_star, m_star = ra, ma
    else:
        rb, mb = db / 2, b.density * math.pi * db**3 / 6
        r_star, m_star = ra * rb / (ra + rb), ma * mb / (ma + mb)
    beta = math.log(e) / math.sqrt(math.log(e) ** 2 + math.pi**2)
    assert p.e_star == pytest.approx(e_star, rel=1e-12)
    assert p.g_star == pytest.approx(g_star, rel=1e-12)
    assert p.r_star == pytest.approx(r_star, rel=1e-12)
    assert p.m_star == pytest.approx(m_star, rel=1e-12)
    assert p.beta == pytest.approx(beta, rel=1e-12)
    assert (p.restitution, p.friction) == (e, mu)


def test_equivalent_quantities_by_hand_numbers() -> None:
    """Steel on steel, worked by hand: E = 2 x 81 GPa x 1.3 = 210.6 GPa,
    E* = E / (2 (1 - 0.09)) = 115.714 GPa, G* = E / (4 x 1.7 x 1.3) = 23.8235 GPa;
    beta(0.5) = ln 0.5 / sqrt(ln^2 0.5 + pi^2) = -0.215454."""
    p = pair_properties(STEEL, STEEL, BALL, BALL, 0.5, 0.15)
    assert p.e_star == pytest.approx(115.7142857e9, rel=1e-9)
    assert p.g_star == pytest.approx(23.82352941e9, rel=1e-9)
    assert p.beta == pytest.approx(-0.2154537620, rel=1e-9)
    assert p.r_star == pytest.approx(BALL / 4, rel=1e-12)
    assert pair_properties(STEEL, STEEL, BALL, BALL, 1.0).beta == 0.0
    # a wall: R* = R_a, m* = m_a
    w = pair_properties(STEEL, STEEL, BALL, WALL)
    assert w.r_star == BALL / 2
    assert w.m_star == pytest.approx(7860 * math.pi * BALL**3 / 6, rel=1e-12)


def test_pair_table_is_symmetric_and_matches_pair_constants() -> None:
    mats = [_core.Material(2800, 1.6e9, 0.22), _core.Material(7860, 81e9, 0.3)]
    table = _core.PairTable(mats, [[0.3, 0.2], [0.2, 0.5]], [[0.66, 0.4], [0.4, 0.15]])
    assert table.size == 2
    for i in range(2):
        for j in range(2):
            got, ref = table.get(i, j), table.get(j, i)
            assert (got.e_star, got.g_star, got.beta) == (ref.e_star, ref.g_star, ref.beta)
    pc = _core.pair_constants(mats[0], mats[1], 0.2, 0.4)
    assert table.get(0, 1).e_star == pc.e_star
    assert table.get(0, 1).friction == 0.4
    assert table.get(1, 1).restitution == 0.5


# --------------------------------------------------------------------------------------------
# One evaluation of the law: signs, hand formulas, the tangential history
# --------------------------------------------------------------------------------------------

_STEEL = _core.Material(7860.0, 81e9, 0.3)
_R = 0.0125
_M = 7860.0 * math.pi * BALL**3 / 6
_ZERO = [0.0, 0.0, 0.0]


def _pair(e: float = 0.5, mu: float = 0.15) -> _core.PairConstants:
    return _core.pair_constants(_STEEL, _STEEL, e, mu)


def _touching(overlap: float, *, v_i: list[float] = _ZERO, w_i: list[float] = _ZERO,
              w_j: list[float] = _ZERO, history: list[float] = _ZERO, e: float = 0.5,
              mu: float = 0.15, dt: float = 1e-7, clamp: bool = False) -> _core.ContactEvaluation:
    """Sphere i above sphere j (at the origin, at rest) along +y: n = +y."""
    x_i = [0.0, 2 * _R - overlap, 0.0]
    return _core.sphere_contact(_pair(e, mu), x_i, v_i, w_i, _R, _M, _ZERO, _ZERO, w_j, _R, _M,
                                history, dt, mu > 0, clamp)


def test_normal_force_is_hertz_plus_a_damper_opposing_the_normal_motion() -> None:
    """F_n = 4/3 E* sqrt(R*) d^1.5 (1) - gamma_n v_n, gamma_n = -2 sqrt(5/6) beta sqrt(S_n m*)
    (2, 4), v_n = (v_i - v_j) . n: approaching (v_n < 0) the damper pushes i away from j."""
    p, d, r_star, m_star = _pair(), 1e-5, _R / 2, _M / 2
    f_ne = 4 / 3 * p.e_star * math.sqrt(r_star) * d**1.5
    s_n = 2 * p.e_star * math.sqrt(r_star * d)
    gamma_n = -2 * math.sqrt(5 / 6) * p.beta * math.sqrt(s_n * m_star)
    assert gamma_n > 0
    for v_n in (-1.5, 0.0, 1.5):
        c = _touching(d, v_i=[0.0, v_n, 0.0])
        assert c.normal == pytest.approx(f_ne - gamma_n * v_n, rel=1e-12)
        assert list(c.force_i) == pytest.approx([0.0, c.normal, 0.0], rel=1e-12)
    assert _touching(d, v_i=[0.0, -1.5, 0.0]).normal > f_ne  # approaching: stiffer
    pulling = _touching(d, v_i=[0.0, 50.0, 0.0])  # separating fast: the damper pulls
    assert pulling.normal < 0
    assert _touching(d, v_i=[0.0, 50.0, 0.0], clamp=True).normal == 0.0
    assert not _touching(-1e-9).touching


def test_tangential_history_is_turned_into_the_tangent_plane_keeping_its_length() -> None:
    """A stored d_t with a normal component (n = +y) is projected and rescaled, then advanced by
    v_t dt; an elastic spring F_t = -S_t d_t (5), S_t = 8 G* sqrt(R* d_n) (6)."""
    p, d, dt = _pair(mu=10.0), 1e-5, 1e-7
    s_t = 8 * p.g_star * math.sqrt(_R / 2 * d)
    c = _touching(d, history=[3e-7, 4e-7, 0.0], mu=10.0, dt=dt)
    assert c.history == pytest.approx([5e-7, 0.0, 0.0], rel=1e-12, abs=1e-20)
    assert list(c.tangential) == pytest.approx([-s_t * 5e-7, 0.0, 0.0], rel=1e-12)
    assert not c.sliding
    # advanced by v_t dt after turning; v_t also drives the damper (7)
    c = _touching(d, v_i=[0.0, 0.0, 2.0], history=[0.0, 4e-7, 3e-7], mu=10.0, dt=dt, e=1.0)
    assert c.history == pytest.approx([0.0, 0.0, 5e-7 + 2.0 * dt], rel=1e-12, abs=1e-20)
    assert list(c.tangential) == pytest.approx([0.0, 0.0, -s_t * (5e-7 + 2.0 * dt)],
                                               rel=1e-12, abs=1e-9)


def test_tangential_damper_and_contact_point_velocity_include_spin() -> None:
    """v_rel = v_i + w_i x (-r_i n) - (v_j + w_j x (r_j n)); F_td = -gamma_t v_t (7)."""
    p, d, dt = _pair(mu=10.0), 1e-5, 1e-12  # dt tiny: the spring stays slack
    s_t = 8 * p.g_star * math.sqrt(_R / 2 * d)
    gamma_t = -2 * math.sqrt(5 / 6) * p.beta * math.sqrt(s_t * _M / 2)
    # spins about +z, n = +y: w_i x (-r n) = (w r, 0, 0); -(w_j x (r n)) = (w_j r, 0, 0)
    c = _touching(d, w_i=[0.0, 0.0, 40.0], w_j=[0.0, 0.0, 20.0], mu=10.0, dt=dt)
    v_t = 40.0 * _R + 20.0 * _R
    assert c.tangential[0] == pytest.approx(-gamma_t * v_t - s_t * v_t * dt, rel=1e-9)
    # torques: (-r_i n) x F_t on i and (r_j n) x (-F_t) on j, both -r n x F_t
    f = c.tangential[0]
    assert list(c.torque_i) == pytest.approx([0.0, 0.0, _R * f], rel=1e-12)
    assert list(c.torque_j) == pytest.approx([0.0, 0.0, _R * f], rel=1e-12)


def test_sliding_rescales_the_history_so_the_spring_alone_gives_mu_fn() -> None:
    p, d = _pair(e=1.0, mu=0.15), 1e-5
    s_t = 8 * p.g_star * math.sqrt(_R / 2 * d)
    c = _touching(d, history=[1e-5, 0.0, 0.0], e=1.0)
    assert c.sliding
    assert abs(c.tangential[0]) == pytest.approx(0.15 * c.normal, rel=1e-12)
    assert c.tangential[0] < 0
    assert c.history[0] == pytest.approx(-c.tangential[0] / s_t, rel=1e-12)


def test_a_moving_wall_drags_a_resting_sphere_along() -> None:
    """The wall's velocity at the contact (omega x r in a drum) enters v_rel: a sphere at rest
    on a wall moving along +x is pushed along +x."""
    c = _core.wall_contact(_pair(), [0.0, _R - 1e-5, 0.0], _ZERO, _ZERO, _R, _M, [0.0, 1.0, 0.0],
                           1e-5, [0.3, 0.0, 0.0], _ZERO, 1e-7)
    assert c.touching
    assert c.tangential[0] > 0
    assert c.torque_i[2] > 0  # and set spinning: (-r n) x F_t = r F_x z
    assert list(c.torque_j) == [0.0, 0.0, 0.0]


# --------------------------------------------------------------------------------------------
# Normal impacts: restitution, Hertz contact time and overlap, energy
# --------------------------------------------------------------------------------------------


@pytest.mark.parametrize("speed", [0.5, 5.0])
@pytest.mark.parametrize("name", list(PAIRS))
def test_head_on_restitution_is_the_pairs_value(name: str, speed: float) -> None:
    """Table 3's e = 0.2, 0.3, 0.5, recovered within 2 % with dt = contact time / 50
    (MercuryDPM's HertzContactRestitutionUnitTest uses the same resolution)."""
    a, b, da, db, e, _ = PAIRS[name]
    dt = _tc(a, b, da, db, speed) / 50
    r = impact(a, b, da, db, speed, e, 0.0, dt=dt)
    assert r.restitution == pytest.approx(e, rel=0.02)
    assert r.kinetic_energy_after < r.kinetic_energy_before  # the dampers take energy out


@pytest.mark.parametrize("speed", [0.5, 5.0])
@pytest.mark.parametrize("name", list(PAIRS))
def test_elastic_contact_time_and_overlap_are_hertz(name: str, speed: float) -> None:
    """e = 1 (beta = 0): t_c = 2.87 (m*^2/(R* E*^2 v))^(1/5) within 2 % and
    d_max = (15 m* v^2 / (16 E* sqrt(R*)))^(2/5) within 1 %, computed here by hand."""
    a, b, da, db, _, _ = PAIRS[name]
    p = pair_properties(a, b, da, db)
    t_c = 2.87 * (p.m_star**2 / (p.r_star * p.e_star**2 * speed)) ** 0.2
    d_max = (15 * p.m_star * speed**2 / (16 * p.e_star * math.sqrt(p.r_star))) ** 0.4
    assert hertz_contact_time(a, b, da, db, speed) == pytest.approx(t_c, rel=1e-12)
    assert hertz_max_overlap(a, b, da, db, speed) == pytest.approx(d_max, rel=1e-12)
    r = impact(a, b, da, db, speed, 1.0, 0.0, dt=t_c / 50)
    assert r.contact_time == pytest.approx(t_c, rel=0.02)
    assert r.max_overlap == pytest.approx(d_max, rel=0.01)


@pytest.mark.parametrize("name", ["steel-steel", "steel-ceramic", "ceramic-wall"])
def test_energy_is_conserved_without_damping_or_friction(name: str) -> None:
    """e = 1, no friction: kinetic energy (translation and rotation) after = before to 1e-6.
    Velocity Verlet's error here is O(dt^2) (about 1e-5 at t_c/50), hence t_c/1000."""
    a, b, da, db, _, _ = PAIRS[name]
    speed = 2.0
    dt = _tc(a, b, da, db, speed) / 1000
    r = impact(a, b, da, db, speed, 1.0, 0.0, dt=dt, tangential_speed=0.7, spin=30.0)
    assert r.kinetic_energy_after == pytest.approx(r.kinetic_energy_before, rel=1e-6)
    # no friction: no torque, no tangential force
    assert (r.spin, r.spin_b, r.tangential_impulse) == (30.0, 0.0, 0.0)
    if db is None:  # on a wall n stays fixed; between spheres it turns as they pass
        assert r.tangential_velocity == 0.7
        assert r.restitution == pytest.approx(1.0, abs=1e-6)


def test_clamped_normal_force_is_never_tensile() -> None:
    a, b, da, db, e, _ = PAIRS["steel-ceramic"]
    dt = _tc(a, b, da, db, 2.0) / 50
    free = impact(a, b, da, db, 2.0, e, 0.0, dt=dt)
    clamped = impact(a, b, da, db, 2.0, e, 0.0, dt=dt, clamp_normal=True)
    # unclamped, the damper pulls at the end of the contact; clamped it cannot
    assert free.normal_impulse_abs > free.normal_impulse
    assert clamped.normal_impulse_abs == clamped.normal_impulse
    assert clamped.restitution > free.restitution


# --------------------------------------------------------------------------------------------
# Oblique impacts on a wall: Coulomb friction, torque
# --------------------------------------------------------------------------------------------

OBLIQUE = [  # (tangential_speed, spin) x normal speed 2 m/s: sticking, partial, sliding
    (0.2, 0.0), (0.5, 0.0), (1.5, 0.0), (6.0, 0.0), (1.0, -300.0), (-2.0, 150.0)]


@pytest.mark.parametrize("clamp", [False, True])
@pytest.mark.parametrize("vt, spin", OBLIQUE)
@pytest.mark.parametrize("name", ["steel-wall", "ceramic-wall"])
def test_tangential_impulse_is_bounded_by_coulomb(name: str, vt: float, spin: float,
                                                  clamp: bool) -> None:
    """(8) |F_t| <= mu |F_n| every step, so |J_t| <= mu sum |F_n| dt; with a non-tensile normal
    force (clamp) that is mu times the normal impulse."""
    a, b, da, db, e, mu = PAIRS[name]
    dt = _tc(a, b, da, db, 2.0) / 50
    r = impact(a, b, da, db, 2.0, e, mu, dt=dt, tangential_speed=vt, spin=spin,
               clamp_normal=clamp)
    assert abs(r.tangential_impulse) <= mu * r.normal_impulse_abs * (1 + 1e-12)
    if clamp:
        assert abs(r.tangential_impulse) <= mu * r.normal_impulse * (1 + 1e-12)


@pytest.mark.parametrize("case", ["elastic", "clamped"])
@pytest.mark.parametrize("name", ["steel-wall", "ceramic-wall"])
def test_sliding_throughout_changes_tangential_velocity_by_mu_dvn(name: str, case: str) -> None:
    """Sliding the whole contact with F_n >= 0: |dv_t| = mu dv_n (Coulomb impact), within 2 %.
    The slip must outrun the friction: the contact point slows by 7/2 mu (1 + e) v_n at most."""
    a, b, da, db, e, mu = PAIRS[name]
    e = 1.0 if case == "elastic" else e
    speed, vt = 2.0, 8.0  # 8 > 7/2 x 0.4 x (1 + 1) x 2 = 5.6
    dt = _tc(a, b, da, db, speed) / 50
    r = impact(a, b, da, db, speed, e, mu, dt=dt, tangential_speed=vt,
               clamp_normal=case == "clamped")
    assert r.sliding_steps == r.contact_steps
    dv_n = speed * (1 + r.restitution)
    dv_t = r.tangential_velocity - vt
    assert dv_t < 0  # friction opposes the slip
    assert -dv_t == pytest.approx(mu * dv_n, rel=0.02)


@pytest.mark.parametrize("name", ["steel-wall", "ceramic-wall"])
def test_sliding_with_tensile_damping_keeps_coulomb_on_abs_normal_force(name: str) -> None:
    """Unclamped (the default), the damper's pull at the end of the contact keeps |F_n| > 0 and
    friction acts on it: the tangential impulse is mu sum |F_n| dt, which exceeds mu times the
    net normal impulse (by 7 % for steel e = 0.5, 21 % for ceramic e = 0.2)."""
    a, b, da, db, e, mu = PAIRS[name]
    dt = _tc(a, b, da, db, 2.0) / 50
    r = impact(a, b, da, db, 2.0, e, mu, dt=dt, tangential_speed=8.0)
    assert r.sliding_steps == r.contact_steps
    assert -r.tangential_impulse == pytest.approx(mu * r.normal_impulse_abs, rel=1e-9)
    assert r.normal_impulse_abs > r.normal_impulse


@pytest.mark.parametrize("vt, spin", OBLIQUE)
def test_angular_momentum_about_the_contact_point_is_conserved(vt: float, spin: float) -> None:
    """On a wall, friction acts at the contact point and the normal force through the centre, so
    I w_z - m r v_x is conserved: this checks the torque's sign and arm, (-r n) x F_t."""
    a, b, da, db, e, mu = PAIRS["steel-wall"]
    dt = _tc(a, b, da, db, 2.0) / 50
    r = impact(a, b, da, db, 2.0, e, mu, dt=dt, tangential_speed=vt, spin=spin)
    m, rad = r.pair.m_star, da / 2
    inertia = 0.4 * m * rad**2
    before = inertia * spin - m * rad * vt
    after = inertia * r.spin - m * rad * r.tangential_velocity
    assert after == pytest.approx(before, rel=1e-9, abs=1e-12 * m * rad * 2.0)
    assert r.tangential_impulse != 0.0


def test_slow_oblique_impact_ends_rolling_at_five_sevenths() -> None:
    """Starting without spin, sticking friction leaves the ball rolling: v_t = 5/7 v_t0."""
    a, b, da, db, e, mu = PAIRS["steel-wall"]
    vt = 0.5
    dt = _tc(a, b, da, db, 2.0) / 50
    r = impact(a, b, da, db, 2.0, e, mu, dt=dt, tangential_speed=vt)
    assert r.sliding_steps < r.contact_steps
    assert r.tangential_velocity == pytest.approx(5 / 7 * vt, rel=0.01)
    assert r.spin == pytest.approx(-r.tangential_velocity / (da / 2), rel=0.01)


def test_sphere_sphere_oblique_impact_obeys_coulomb() -> None:
    a, b, da, db, e, mu = PAIRS["steel-ceramic"]
    dt = _tc(a, b, da, db, 2.0) / 50
    r = impact(a, b, da, db, 2.0, e, mu, dt=dt, tangential_speed=3.0, spin=-100.0)
    assert abs(r.tangential_impulse) <= mu * r.normal_impulse_abs * (1 + 1e-12)
    assert r.sliding_steps > 0
    # friction turns both spheres the same way: torque -r n x F_t on each
    assert (r.spin - (-100.0)) * r.spin_b > 0
    assert r.kinetic_energy_after < r.kinetic_energy_before


# --------------------------------------------------------------------------------------------
# Time-step criteria
# --------------------------------------------------------------------------------------------


def test_rayleigh_time_by_hand() -> None:
    """Steel, 25 mm: pi x 0.0125 x sqrt(7860 / 81e9) / (0.1631 x 0.3 + 0.8766) = 13.217 us."""
    assert rayleigh_time(BALL, 7860.0, 81e9, 0.3) == pytest.approx(1.321716004e-5, rel=1e-9)


def test_default_dt_is_a_fifth_of_the_smaller_rayleigh_time() -> None:
    assert DEFAULT_DT_FRACTION == 0.2
    assert MAX_DT_FRACTION == 0.5
    t_r = min(rayleigh_time(BALL, 7860.0, 81e9, 0.3), rayleigh_time(PARTICLE, 2800.0, 1.6e9, 0.22))
    r = impact(STEEL, CERAMIC, BALL, PARTICLE, 2.0, 0.2, 0.4)
    assert r.dt == pytest.approx(0.2 * t_r, rel=1e-12)
    # even at 3 m/s a steel-on-steel impact spans many default steps
    r = impact(STEEL, STEEL, BALL, BALL, 3.0, 0.5, 0.15)
    assert r.samples_per_contact > 15
    assert _core.stable_dt_limit(t_r) == pytest.approx(0.5 * t_r)
    with pytest.raises(ValueError, match=r"dt = .* is not valid; it must be in \(0, .*\] s"):
        _core.require_stable_dt(0.6 * t_r, t_r)
    _core.require_stable_dt(0.5 * t_r, t_r)


def test_the_stability_limit_leaves_a_margin_for_mill_impacts() -> None:
    """At 0.5 T_R a single Hertz contact is stable (dt < 2 / w_max) with a margin of at least 2
    for impacts up to 10 m/s with the paper's moduli (timestep.hpp explains the choice)."""
    for a, b, da, db in [(STEEL, STEEL, BALL, BALL), (CERAMIC, STEEL, PARTICLE, None),
                         (CERAMIC, CERAMIC, PARTICLE, PARTICLE)]:
        p = pair_properties(a, b, da, db)
        t_r = rayleigh_time(da, a.density, a.shear_modulus, a.poisson)
        if db is not None:
            t_r = min(t_r, rayleigh_time(db, b.density, b.shear_modulus, b.poisson))
        limit = _core.hertz_stability_dt(p.m_star, p.r_star, p.e_star, 10.0)
        assert limit >= 2 * MAX_DT_FRACTION * t_r


# --------------------------------------------------------------------------------------------
# Bad input
# --------------------------------------------------------------------------------------------


@pytest.mark.parametrize("kwargs, message", [
    (dict(density=-1.0, shear_modulus=1e9, poisson=0.3),
     r"density = -1\.0 is not valid; it must be finite and > 0"),
    (dict(density=1000.0, shear_modulus=0.0, poisson=0.3), r"shear_modulus = 0\.0 is not valid"),
    (dict(density=1000.0, shear_modulus=1e9, poisson=0.5),
     r"poisson = 0\.5 is not valid; it must be in \(-1, 0\.5\)"),
    (dict(density=math.nan, shear_modulus=1e9, poisson=0.3), r"density = nan is not valid"),
])
def test_bad_material(kwargs: dict[str, float], message: str) -> None:
    with pytest.raises(ValueError, match=message):
        ContactMaterial(**kwargs)


@pytest.mark.parametrize("change, message", [
    (dict(restitution=0.0), r"restitution = 0\.0 is not valid; it must be in \[0\.01, 1\]"),
    (dict(restitution=1.2), r"restitution = 1\.2 is not valid; it must be in \[0\.01, 1\]"),
    (dict(friction=-0.1), r"friction = -0\.1 is not valid; it must be finite and >= 0"),
    (dict(speed=0.0), r"speed = 0\.0 is not valid; it must be finite and > 0 m/s"),
    (dict(diameter_a=-0.01), r"diameter_a = -0\.01 is not valid; it must be finite and > 0 m"),
    (dict(dt=-1e-7), r"dt = -1e-07 is not valid; it must be finite and > 0 s"),
    (dict(dt=1e-3), r"dt = 0\.001 s is not valid; it must be > 0 and below the elastic Hertz "
                    r"contact time"),
    (dict(tangential_speed=math.inf), r"tangential_speed = inf is not valid; it must be finite"),
    (dict(material_b=(7860.0, 81e9)), r"material_b = .* is not valid; a tuple must be"),
    (dict(material_b=(7860.0, -81e9, 0.3)),
     r"material_b\.shear_modulus = -81000000000\.0 is not valid"),
    (dict(material_b="steel"), r"material_b = 'steel' is not valid; it must have density"),
    (dict(material_b=None), r"material_b = None is not valid with diameter_b = 0\.025"),
])
def test_bad_impact_input(change: dict[str, object], message: str) -> None:
    kwargs: dict[str, object] = dict(material_a=STEEL, material_b=STEEL, diameter_a=BALL,
                                     diameter_b=BALL, speed=2.0, restitution=0.5,
                                     friction=0.15, dt=None)
    kwargs.update(change)
    with pytest.raises(ValueError, match=message):
        impact(**kwargs)  # type: ignore[arg-type]


def test_bad_input_reaching_the_core_is_a_value_error() -> None:
    steel = _core.Material(7860, 81e9, 0.3)
    with pytest.raises(ValueError, match=r"material\.poisson = -1 is not valid"):
        _core.Material(7860, 81e9, -1.0)
    with pytest.raises(ValueError, match=r"restitution = 2 is not valid; it must be in \(0, 1\]"):
        _core.pair_constants(steel, steel, 2.0, 0.1)
    with pytest.raises(ValueError, match=r"restitution is not symmetric: restitution\[0\]\[1\] "
                                         r"= 0\.2 but restitution\[1\]\[0\] = 0\.3"):
        _core.PairTable([steel, steel], [[0.5, 0.2], [0.3, 0.5]], [[0.1, 0.1], [0.1, 0.1]])
    with pytest.raises(ValueError, match=r"friction\[1\]\[1\] = -1 is not valid"):
        _core.PairTable([steel, steel], [[0.5, 0.2], [0.2, 0.5]], [[0.1, 0.1], [0.1, -1.0]])
    with pytest.raises(ValueError, match=r"friction\[1\] has 1 entries; it must have 2"):
        _core.PairTable([steel, steel], [[0.5, 0.2], [0.2, 0.5]], [[0.1, 0.1], [0.1]])
    with pytest.raises(ValueError, match=r"radius = 0 m is not valid"):
        _core.rayleigh_time(0.0, 7860, 81e9, 0.3)
    with pytest.raises(ValueError, match=r"speed = -1 m/s is not valid"):
        _core.hertz_contact_time(1.0, 0.01, 1e11, -1.0)
    with pytest.raises(ValueError, match=r"radius_b = 0 is not valid"):
        _core.contact_probe(steel, steel, False, 0.01, 0.0, 0.5, 0.1, 1.0, 0.0, 0.0, 1e-7, False)

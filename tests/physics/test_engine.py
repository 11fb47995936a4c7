"""The DEM engine (cpp/include/millscope/engine.hpp) against analytic results and conservation laws.

Each case builds a small scene directly on the engine, with the paper's materials (Tables 2-3)
where the check allows it.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from millscope import _core
from millscope.contact import hertz_contact_time, hertz_max_overlap, pair_properties, rayleigh_time

from ..cpu import x86_simd_paths

STEEL = (7860.0, 81e9, 0.3)  # density kg/m^3, shear modulus Pa, Poisson ratio (Table 2)
G = 9.81


def make_engine(radius, *, restitution=0.5, friction=0.15, material=STEEL, drum_radius=0.44,
                length=0.315, end_walls=True, lifters=0, gravity=G, dt_fraction=0.2, threads=1,
                positions=None, velocities=None, spins=None,
                **options):  # type: ignore[no-untyped-def]
    radius = np.atleast_1d(np.asarray(radius, dtype=float))
    geometry = _core.DrumGeometry(drum_radius, length, end_walls, lifters,
                                  0.03 if lifters else 0.0, 0.02 if lifters else 0.0)
    dt = dt_fraction * rayleigh_time(2 * radius.min(), *material)
    engine = _core.Engine([_core.Material(*material)], np.array([[restitution]]),
                          np.array([[friction]]), 0, geometry, radius,
                          np.zeros(len(radius), np.int32), dt, gravity=gravity, threads=threads,
                          **options)
    if positions is not None:
        engine.positions = np.asarray(positions, dtype=float)
    if velocities is not None:
        engine.velocities = np.asarray(velocities, dtype=float)
    if spins is not None:
        engine.spins = np.asarray(spins, dtype=float)
    return engine


def contact_duration_and_exit(engine, max_steps):  # type: ignore[no-untyped-def]
    """Steps one at a time through one collision: (contact time s, velocities after)."""
    steps_in_contact, touched = 0, False
    for _ in range(max_steps):
        engine.advance(1)
        if engine.max_overlap_ratio() > 0.0:
            steps_in_contact += 1
            touched = True
        elif touched:
            return steps_in_contact * engine.dt, np.asarray(engine.velocities)
    raise AssertionError("the collision did not end")


# -- impacts ---------------------------------------------------------------------------------

@pytest.mark.parametrize("e", [0.2, 0.3, 0.5])
def test_head_on_sphere_sphere_restitution(e: float) -> None:
    r, v = 0.0125, 1.0
    eng = make_engine([r, r], restitution=e, friction=0.0, gravity=0.0, dt_fraction=0.02,
                      positions=[[-r - 1e-4, 0, 0.15], [r + 1e-4, 0, 0.15]],
                      velocities=[[v / 2, 0, 0], [-v / 2, 0, 0]])
    _, after = contact_duration_and_exit(eng, 20000)
    measured = (after[1, 0] - after[0, 0]) / v
    assert measured == pytest.approx(e, rel=0.02)
    # momentum is conserved exactly by the pair force (equal and opposite)
    assert after[0, 0] + after[1, 0] == pytest.approx(0.0, abs=1e-12)


@pytest.mark.parametrize("e", [0.2, 0.3, 0.5])
def test_head_on_sphere_wall_restitution(e: float) -> None:
    r, v = 0.0125, 1.0  # onto the flat end wall z = 0
    eng = make_engine([r], restitution=e, friction=0.0, gravity=0.0, dt_fraction=0.02,
                      positions=[[0, 0, r + 1e-4]], velocities=[[0, 0, -v]])
    _, after = contact_duration_and_exit(eng, 20000)
    assert after[0, 2] / v == pytest.approx(e, rel=0.02)


def test_elastic_contact_time_matches_hertz() -> None:
    r, v = 0.0125, 1.0
    eng = make_engine([r, r], restitution=1.0, friction=0.0, gravity=0.0, dt_fraction=0.02,
                      positions=[[-r - 1e-5, 0, 0.15], [r + 1e-5, 0, 0.15]],
                      velocities=[[v / 2, 0, 0], [-v / 2, 0, 0]])
    assert "elastic" in eng.variant  # no damping compiled in when every e = 1
    t_c, after = contact_duration_and_exit(eng, 20000)
    assert t_c == pytest.approx(hertz_contact_time(STEEL, STEEL, 2 * r, 2 * r, v), rel=0.02)
    assert after[1, 0] - after[0, 0] == pytest.approx(v, rel=1e-3)  # e = 1


# -- friction: sliding and the rolling transition ----------------------------------------------

def test_sliding_sphere_decelerates_at_mu_g_and_rolls_at_five_sevenths() -> None:
    """A sphere launched without spin on a (nearly flat) floor: slides at a = mu g, then rolls
    at 5/7 of its initial speed (angular momentum about the contact point is conserved)."""
    mu, r, v0 = 0.3, 0.0125, 1.0
    big = 50.0  # drum radius, m: the floor's curvature over the 10 cm slide is negligible
    props = pair_properties(STEEL, STEEL, 2 * r, None)
    mass = props.m_star
    # start at the static overlap, m g = 4/3 E* sqrt(R*) d^(3/2)
    overlap = (mass * G / (4.0 / 3.0 * props.e_star * math.sqrt(r))) ** (2.0 / 3.0)
    eng = make_engine([r], restitution=0.5, friction=mu, drum_radius=big, length=0.1,
                      positions=[[0, -big + r - overlap, 0.05]], velocities=[[v0, 0, 0]])
    t_slide = 2.0 * v0 / (7.0 * mu * G)  # sliding ends when v = 5/7 v0
    dt = eng.dt
    n1 = int(0.25 * t_slide / dt)
    eng.advance(n1)
    v1 = eng.velocities[0, 0]
    eng.advance(n1)
    v2 = eng.velocities[0, 0]
    assert (v1 - v2) / (n1 * dt) == pytest.approx(mu * G, rel=0.02)
    eng.advance(int(1.0 * t_slide / dt))  # well into rolling
    v_roll = eng.velocities[0, 0]
    assert v_roll == pytest.approx(5.0 / 7.0 * v0, rel=0.02)
    # rolling without slipping: v = -w_z r for motion along +x on a floor below
    assert -eng.spins[0, 2] * r == pytest.approx(v_roll, rel=0.02)


# -- conservation ----------------------------------------------------------------------------

def lattice(n, r, drum_radius, length, rng, pitch=2.2):  # type: ignore[no-untyped-def]
    axis = np.arange(-drum_radius + 2 * r, drum_radius - 2 * r, pitch * r)
    zs = np.arange(2 * r, length - 2 * r, pitch * r)
    g = np.array(np.meshgrid(axis, axis, zs, indexing="ij")).reshape(3, -1).T
    g = g[np.hypot(g[:, 0], g[:, 1]) < drum_radius - 2 * r]
    g = g[np.argsort(g[:, 1], kind="stable")][:n]
    assert len(g) == n
    return g + rng.uniform(-0.05 * r, 0.05 * r, g.shape)


def test_energy_is_conserved_without_damping_and_friction() -> None:
    """e = 1, mu = 0, drum at rest: kinetic + potential + elastic energy drifts < 0.5 %
    over 100 000 steps (of the energy available for motion)."""
    rng = np.random.default_rng(3)
    r, R, L, n = 0.01, 0.15, 0.1, 150
    soft = (7860.0, 81e7, 0.3)  # G / 100: a coarser dt, the same dynamics per Rayleigh time
    pos = lattice(n, r, R, L, rng)
    vel = rng.normal(0.0, 0.5, (n, 3))
    eng = make_engine(np.full(n, r), restitution=1.0, friction=0.0, material=soft,
                      drum_radius=R, length=L, positions=pos, velocities=vel)
    mass = np.asarray(eng.mass)

    def total() -> float:
        return eng.kinetic_energy() + eng.potential_energy() + eng.elastic_energy()

    e0 = total()
    available = eng.kinetic_energy() + float(np.sum(mass * G * (pos[:, 1] - (-R + r))))
    worst = 0.0
    for _ in range(10):
        eng.advance(10_000)
        worst = max(worst, abs(total() - e0))
    assert eng.step_count == 100_000
    assert worst / available < 0.005
    assert eng.list_builds > 1  # the list was rebuilt as particles moved


def impact_energy_errors(body: str, dt_fraction: float) -> tuple[float, float]:
    """One damped, frictionless impact (e = 0.5, no gravity): relative errors of the ledger's
    exact `dissipated` and of its half-step split (damping_loss) against the kinetic energy lost."""
    r, v = 0.0125, 1.0
    if body == "wall":  # onto the flat end wall z = 0
        eng = make_engine([r], friction=0.0, gravity=0.0, dt_fraction=dt_fraction,
                          positions=[[0, 0, r + 1e-4]], velocities=[[0.3, 0, -v]])
    else:  # two spheres, obliquely, on two threads (the pair buffers of both are summed)
        eng = make_engine([r, r], friction=0.0, gravity=0.0, dt_fraction=dt_fraction,
                          threads=2, positions=[[-r - 1e-4, 0, 0.15], [r + 1e-4, 0.005, 0.15]],
                          velocities=[[v / 2, 0, 0], [-v / 2, 0, 0]])
    before = eng.kinetic_energy()
    contact_duration_and_exit(eng, 20000)
    lost = before - eng.kinetic_energy()  # apart again: no elastic energy, v(t) = v(t + dt/2)
    ledger = eng.ledger()
    assert ledger["friction_loss"] == 0.0
    return (ledger["dissipated"] - lost) / lost, (ledger["damping_loss"] - lost) / lost


@pytest.mark.parametrize("body", ["wall", "sphere"])
def test_dissipated_energy_is_second_order_and_its_split_first_order(body: str) -> None:
    """Velocity Verlet removes F_d . v(t + dt) per step, the dashpot's force with the full-step
    velocity (engine.hpp, Ledger): `dissipated` books exactly that, so it matches the lost
    kinetic energy up to the scheme's O(dt^2) error, while the split, which takes the
    half-step velocity the force came from, is O(dt) off. A 4x smaller step: errors 16x and 4x
    smaller."""
    coarse_exact, coarse_split = impact_energy_errors(body, 0.2)
    fine_exact, fine_split = impact_energy_errors(body, 0.05)
    assert abs(fine_exact) < abs(coarse_exact) / 8.0  # second order (16x)
    assert 2.5 < coarse_split / fine_split < 6.0  # first order (4x)
    assert abs(coarse_exact) < abs(coarse_split) / 5.0


def oblique_impact_residual(body: str, dt_fraction: float) -> tuple[float, float]:
    """One damped impact with friction (e = 0.5, mu = 0.5, no gravity), oblique and with spin
    so that the contact sticks and slides: the residual of the ledger's balance
    lost kinetic energy = dissipated - spring_work, and spring_work, both over the loss."""
    r, v = 0.0125, 1.0
    if body == "wall":  # onto the end wall z = 0, against the spin
        eng = make_engine([r], friction=0.5, gravity=0.0, dt_fraction=dt_fraction,
                          positions=[[0, 0, r + 1e-4]], velocities=[[0.6, 0, -v]],
                          spins=[[0, -30.0, 0]])
    else:  # two spheres, off-centre, spinning, on two threads
        eng = make_engine([r, r], friction=0.5, gravity=0.0, dt_fraction=dt_fraction,
                          threads=2, positions=[[-r - 1e-4, 0, 0.15], [r + 1e-4, 0.008, 0.15]],
                          velocities=[[v / 2, 0, 0], [-v / 2, 0, 0]],
                          spins=[[0, 0, 200.0], [0, 0, 0]])
    before = eng.kinetic_energy()
    contact_duration_and_exit(eng, 20000)
    lost = before - eng.kinetic_energy()  # apart again: nothing stored
    ledger = eng.ledger()
    assert ledger["friction_loss"] > 0.0  # it slid
    spring = ledger["spring_work"]
    return (lost - (ledger["dissipated"] - spring)) / lost, spring / lost


@pytest.mark.parametrize("body", ["wall", "sphere"])
def test_ledger_closes_on_an_oblique_impact_with_friction(body: str) -> None:
    """The Mindlin spring gains and loses energy without work as its stiffness follows the
    overlap, and keeps some when the contact slides out in tension (engine.hpp, Ledger).
    Booked, the balance closes to the scheme's O(dt^2): a 4x smaller step, at least 8x
    smaller residual."""
    coarse, spring = oblique_impact_residual(body, 0.2)
    fine, _ = oblique_impact_residual(body, 0.05)
    assert abs(spring) > 5 * abs(coarse)  # the booked term matters at this tolerance
    assert abs(fine) < abs(coarse) / 8.0


def test_charge_at_rest_torque_balances_gravity() -> None:
    """A charge at rest in a stopped drum: the drum holds it up, so the drive torque equals the
    moment of the charge's weight about the axis, M g x_cm (about zero for a centred bed),
    and every particle is inside the drum."""
    rng = np.random.default_rng(5)
    r, R, L, n = 0.0125, 0.44, 0.1, 300
    soft = (7860.0, 81e8, 0.3)
    # mu = 0.5: with mu = 0.15 a few balls keep rolling along the lifter troughs for long
    eng = make_engine(np.full(n, r), material=soft, friction=0.5, drum_radius=R, length=L,
                      lifters=16, positions=lattice(n, r, R - 0.02, L, rng))
    for _ in range(100):
        eng.advance(2000)
        if eng.kinetic_energy() / n < 1e-7:
            break
    assert eng.kinetic_energy() / n < 1e-7, "the charge did not come to rest"
    # At rest the balls still ring in their contacts (period ~ 1e-4 s here), so the
    # instantaneous torque scatters; its mean over 10 ms does not.
    eng.start_rotation(0.0)
    torque = float(eng.advance_sampled(0.01, True, 1)[0, 1])
    pos = eng.positions
    mass = np.asarray(eng.mass)
    weight_moment = float(np.sum(mass * G * pos[:, 0]))
    scale = float(mass.sum()) * G * R
    assert abs(torque - weight_moment) < 1e-3 * scale
    assert abs(torque) < 0.02 * scale
    assert np.all(np.hypot(pos[:, 0], pos[:, 1]) + r <= R * (1 + 1e-3))
    assert np.all((pos[:, 2] > 0) & (pos[:, 2] < L))


def test_a_lifter_sweeping_onto_a_ball_at_rest_pushes_it() -> None:
    """The kernel measures lifter distances only for particles it knows to be near a lifter,
    and looks again whenever the drum has turned far enough. A frictionless ball lies at rest
    on the shell (so it never moves on its own and never triggers a list build) while the drum
    turns under it: the first lifter to come round must push it, by contact, not pass through
    it. Without gravity, so the ball stays put until then, 20 degrees ahead of lifter 5 (at
    -135 degrees). Checked: no lifter touches it at first, then lifter torque appears, the ball
    never sinks into the lifter by more than the Hertz overlap of a head-on impact at the
    lifter's speed (ten times over), and it is carried round."""
    r, R = 0.0125, 0.44
    soft = (7860.0, 81e8, 0.3)
    at = np.radians(-115.0)
    eng = make_engine([r], material=soft, friction=0.0, lifters=8, drum_radius=R, gravity=0.0,
                      positions=[[(R - r) * np.cos(at), (R - r) * np.sin(at), 0.15]])
    omega = 2.0  # rad/s: lifter 5 reaches the ball after about 0.15 s
    eng.start_rotation(omega)
    # interval means, so that the short impact shows in the samples
    before = eng.advance_sampled(1e-3, True, 100)
    assert np.all(before[:, 3] == 0.0)
    assert eng.list_builds == 1  # nothing has moved the ball: no list build looks again
    lifters = eng.advance_sampled(1e-3, True, 500)[:, 3]
    assert np.any(lifters != 0.0), "no lifter ever touched the ball"
    impact = hertz_max_overlap(soft, soft, 2 * r, None, omega * R)  # ball on a steel wall, m
    assert eng.max_overlap_ratio() < 10 * impact / r
    x = eng.positions[0]
    assert np.arctan2(x[1], x[0]) > at + np.radians(45.0)  # carried round with the drum


# -- threads and determinism -----------------------------------------------------------------

def run_drum(threads: int, steps: int = 3000):  # type: ignore[no-untyped-def]
    rng = np.random.default_rng(11)
    r, R, L, n = 0.0125, 0.2, 0.15, 250
    soft = (7860.0, 81e8, 0.3)
    eng = make_engine(np.full(n, r), material=soft, drum_radius=R, length=L, lifters=8,
                      positions=lattice(n, r, R - 0.02, L, rng), threads=threads)
    eng.advance(steps)
    eng.start_rotation(3.0)
    samples = eng.advance_sampled(10 * eng.dt, False, steps // 10)
    return eng, samples


def test_same_threads_same_result_bit_for_bit() -> None:
    _, a = run_drum(2)
    _, b = run_drum(2)
    assert np.array_equal(a, b)


@pytest.mark.parametrize("threads", [2, 3])
def test_one_and_more_threads_agree_to_round_off_early_on(threads: int) -> None:
    """The threads split the rows and the particles by cost (touching pairs, drum contacts),
    so their blocks differ in size and the pair pass's blocks differ from the particle
    pass's; every particle must still be kicked once and receive every pair's force once."""
    eng1, a = run_drum(1, steps=400)
    eng2, b = run_drum(threads, steps=400)
    # summation order differs, so chaos amplifies round-off; early on they agree closely
    assert np.allclose(a[:5, 1], b[:5, 1], rtol=1e-6, atol=1e-9)
    assert np.allclose(eng1.positions, eng2.positions, rtol=0, atol=1e-9)


def test_storage_order_is_invisible_to_the_caller() -> None:
    """The engine re-stores the particles in cell order at each list build; what goes in and
    out stays in the caller's order. Against the same run without reordering: the same radii
    and masses exactly, and positions, velocities and torque equal to round-off (the order of
    floating-point sums differs) while chaos has not yet amplified it. With friction, so the
    tangential history must follow each pair through the reorders, sign included."""
    rng = np.random.default_rng(5)
    n, R, L = 300, 0.2, 0.15
    radius = rng.uniform(0.006, 0.0125, n)  # polydisperse: a mixed-up order would show
    soft = (7860.0, 81e8, 0.3)
    start = lattice(n, 0.0125, R - 0.02, L, rng)
    speed = rng.normal(0.0, 2.0, (n, 3))  # m/s: the list is rebuilt every ~50 steps
    runs = []
    for reorder in (True, False):
        eng = make_engine(radius, material=soft, drum_radius=R, length=L, lifters=8,
                          positions=start, velocities=speed, reorder=reorder, threads=2)
        eng.start_rotation(3.0)
        torque = eng.advance_sampled(eng.dt, False, 3000)[:, 1]
        runs.append((eng, torque))
    (a, torque_a), (b, torque_b) = runs
    assert a.list_builds >= 20  # many reorders happened
    assert np.abs(torque_b).max() > 0  # the charge reached the drum
    order = a.snapshot()["order"]
    assert not np.array_equal(order, np.arange(n)) and np.array_equal(np.sort(order), np.arange(n))
    assert np.array_equal(b.snapshot()["order"], np.arange(n))
    assert np.array_equal(a.radius, radius) and np.array_equal(b.radius, radius)
    assert np.array_equal(a.mass, b.mass)
    scale = np.abs(torque_b).max()
    assert np.allclose(torque_a, torque_b, rtol=0, atol=1e-9 * scale)
    assert np.allclose(a.positions, b.positions, rtol=0, atol=1e-12)
    assert np.allclose(a.velocities, b.velocities, rtol=0, atol=1e-9)


def test_the_simd_paths_are_those_the_cpu_has() -> None:
    """The engine's SIMD paths (Google Highway's dispatch) are those /proc/cpuinfo says this
    x86-64 CPU runs, widest first; "portable" is there on every CPU; an engine takes the widest
    unless told (simd=, MILLSCOPE_SIMD) and refuses a path the CPU does not run, naming it."""
    paths = _core.simd_paths()
    assert paths[-1] == "portable"
    expected = x86_simd_paths()
    if expected is not None:
        assert paths == expected
    eng = make_engine([0.01], simd="portable")
    assert eng.simd == "portable" and not eng.wide_pair_search
    with pytest.raises(ValueError, match="simd = 'mmx'.*'portable'"):
        make_engine([0.01], simd="mmx")


@pytest.mark.parametrize("end_walls", [True, False])
def test_every_simd_path_gives_the_same_run_to_the_bit(end_walls: bool) -> None:
    """The pair pass finds its touching pairs a vector at a time (touching_pairs.hpp: 8 with
    AVX-512, 4 with AVX2) or one at a time (the portable path), and computes their forces in the
    path's lanes. Every path this CPU runs must give the run that the energy ledger's kernel
    gives (contact::pair_force, a pair at a time): the same positions, velocities, spins and
    torque, to the bit; so must each wide search told to prefetch the partners' state (which
    it does unasked only where the data exceed the last-level cache). Polydisperse, with
    friction, periodic ends or end walls, and one big sphere stored first, whose list row holds
    more pairs than a block of the wide search (_core.WIDE_BLOCK_LISTED): that row makes a
    block of its own."""
    rng = np.random.default_rng(2)
    R, L, r_small, r_big = 0.2, 0.3, 0.008, 0.1
    centre = np.array([0.0, 0.0, L / 2])
    # 400 small spheres 0.5 mm off the big one (a Fibonacci lattice on the sphere: about
    # 19 mm apart, more than a small diameter), and more on a grid around them
    k = np.arange(400) + 0.5
    polar, azimuth = np.arccos(1 - 2 * k / 400), np.pi * (1 + 5**0.5) * k
    around = np.column_stack([np.sin(polar) * np.cos(azimuth), np.sin(polar) * np.sin(azimuth),
                              np.cos(polar)])
    shell = centre + (r_big + r_small + 0.0005) * around
    grid = lattice(4000, r_small, R - 0.01, L, rng, pitch=2.2)
    grid = grid[np.linalg.norm(grid - centre, axis=1) > r_big + 3.5 * r_small][:800]
    positions = np.vstack([centre, shell, grid])
    radius = np.concatenate([[r_big], np.full(len(shell), r_small),
                             rng.uniform(0.6 * r_small, r_small, len(grid))])
    speed = rng.normal(0.0, 1.0, positions.shape)  # m/s: the list is rebuilt now and then
    soft = (7860.0, 81e8, 0.3)
    wide_paths = [p for p in _core.simd_paths() if p != "portable"]
    options = {"ledger": dict(track_energy=True),
               "portable": dict(track_energy=False, simd="portable")}
    for path in wide_paths:
        options[path] = dict(track_energy=False, simd=path)
        options[path + " prefetching"] = dict(track_energy=False, simd=path,
                                              prefetch_partners=True)
    runs = {}
    for name, opts in options.items():
        eng = make_engine(radius, material=soft, drum_radius=R, length=L, lifters=8,
                          end_walls=end_walls, positions=positions, velocities=speed,
                          reorder=False, threads=2, **opts)
        eng.start_rotation(4.0)
        first = eng.advance_sampled(eng.dt, False, 1)[:, 1]
        start = eng.snapshot()["list_start"]
        # the big sphere's row (stored first: reorder=False)
        assert start[1] - start[0] > _core.WIDE_BLOCK_LISTED
        torque = np.concatenate([first, eng.advance_sampled(eng.dt, False, 1500)[:, 1]])
        runs[name] = (eng, torque)
    ledger = runs["ledger"][0]
    assert not runs["portable"][0].wide_pair_search and not ledger.wide_pair_search
    assert not runs["portable"][0].prefetch_partners and not ledger.prefetch_partners
    for path in wide_paths:
        eng, prefetching = runs[path][0], runs[path + " prefetching"][0]
        assert eng.simd == path and eng.wide_pair_search
        # 1201 spheres hold well under a megabyte: no prefetching unless asked
        assert eng.bytes_per_particle * eng.size < 2**20 and not eng.prefetch_partners
        assert prefetching.prefetch_partners
    assert ledger.list_builds >= 2 and np.abs(runs["ledger"][1]).max() > 0
    for name, (eng, torque) in runs.items():
        assert np.array_equal(torque, runs["ledger"][1]), name
        for field in ("positions", "velocities", "spins"):
            assert np.array_equal(getattr(eng, field), getattr(ledger, field)), (name, field)


def test_snapshot_restore_continues_bit_for_bit() -> None:
    eng, _ = run_drum(2, steps=1000)
    snap = eng.snapshot()
    first = eng.advance_sampled(10 * eng.dt, True, 50)
    other, _ = run_drum(2, steps=10)  # a different state, then overwritten
    other.restore(snap)
    second = other.advance_sampled(10 * other.dt, True, 50)
    assert np.array_equal(first, second)


def test_a_list_build_keeps_none_of_its_scratch() -> None:
    """Between builds the engine holds what a copy restored from its snapshot holds (the copy's
    own list replaced by the snapshot's): the cell grid, the reorder, the threads' rows and the
    list before the build are released, not only emptied (`v = {}` keeps a vector's
    capacity; kept, they came to 5.8 B per particle more here)."""
    eng, _ = run_drum(2)
    assert eng.list_builds >= 2
    other, _ = run_drum(2, steps=10)
    other.restore(eng.snapshot())
    # the wall history's blocks may differ by a few particles (refreshed at the restore)
    assert eng.bytes_per_particle == pytest.approx(other.bytes_per_particle, abs=2.0)


@pytest.mark.parametrize("threads", [2, 3])
def test_restore_between_list_builds_continues_bit_for_bit(threads: int) -> None:
    """The threads' shares of the work (set at each list build, by the contacts of then)
    decide the order of the sums; a snapshot taken between two builds must give back the
    shares of the last build, not shares from the contacts at the snapshot."""
    rng = np.random.default_rng(7)
    n, R, L = 300, 0.2, 0.15
    radius = rng.uniform(0.006, 0.0125, n)
    start = lattice(n, 0.0125, R - 0.02, L, rng)
    eng = make_engine(radius, material=(7860.0, 81e8, 0.3), drum_radius=R, length=L, lifters=8,
                      positions=start, velocities=rng.normal(0.0, 1.0, (n, 3)), threads=threads)
    eng.start_rotation(3.0)
    eng.advance(4000)  # falling and colliding, the list rebuilt many times
    builds = eng.list_builds
    eng.advance(1)
    while eng.list_builds == builds:  # to the step after a build ...
        eng.advance(1)
    eng.advance(10)  # ... and on, between two builds
    assert eng.list_builds == builds + 1
    snap = eng.snapshot()
    shares = (eng.thread_rows, eng.thread_particles)
    first = eng.advance_sampled(eng.dt, False, 300)
    other = make_engine(radius, material=(7860.0, 81e8, 0.3), drum_radius=R, length=L,
                        lifters=8, positions=start, threads=threads)
    other.restore(snap)
    assert (other.thread_rows, other.thread_particles) == shares
    for split in shares:  # every row and every particle goes to one thread
        assert len(split) == threads + 1 and split[0] == 0 and split[-1] == n
        assert np.all(np.diff(split) >= 0)
    second = other.advance_sampled(other.dt, False, 300)
    assert np.array_equal(first, second)
    assert np.array_equal(eng.positions, other.positions)


# -- sampling --------------------------------------------------------------------------------

def test_instant_and_mean_sampling_times_and_values() -> None:
    eng, _ = run_drum(1, steps=200)
    dt = eng.dt
    eng2, _ = run_drum(1, steps=200)
    # instant samples every 7 steps vs the per-step torque
    per_step = eng.advance_sampled(dt, False, 90)
    inst = eng2.advance_sampled(7 * dt, False, 10)
    assert np.allclose(np.diff(inst[:, 0]), 7 * dt)
    offsets = np.rint(inst[:, 0] / dt).astype(int)
    first = int(np.rint(per_step[0, 0] / dt))
    assert np.array_equal(inst[:, 1], per_step[offsets - first, 1])
    # the mean of (t_(k-1), t_k] equals the mean of those per-step values
    eng3, _ = run_drum(1, steps=200)
    mean = eng3.advance_sampled(7 * dt, True, 5)
    for row in range(5):
        hi = int(np.rint(mean[row, 0] / dt)) - first + 1
        assert mean[row, 1] == pytest.approx(per_step[hi - 7:hi, 1].mean(), rel=1e-12, abs=1e-12)


# -- bad input -------------------------------------------------------------------------------

def test_engine_refuses_a_time_step_above_the_limit() -> None:
    with pytest.raises(ValueError, match=r"dt = .* is not valid; it must be in \(0, "):
        make_engine([0.0125], dt_fraction=0.6)


@pytest.mark.parametrize("field, kwargs, pattern", [
    ("radius", {"radius": [-0.01]}, r"radius\[0\] = -0.01 is not valid"),
    ("restitution", {"restitution": 1.5}, r"restitution.* = 1.5 .*in \(0, 1\]"),
    ("friction", {"friction": -0.1}, r"friction.* = -0.1 .*>= 0"),
    ("threads", {"threads": 0}, r"threads = 0 is not valid"),
])
def test_engine_refuses_bad_settings(field: str, kwargs: dict, pattern: str) -> None:
    args = {"radius": [0.0125], **kwargs}
    radius = args.pop("radius")
    with pytest.raises(ValueError, match=pattern):
        if np.min(radius) <= 0:  # Rayleigh time needs a positive radius; build by hand
            _core.Engine([_core.Material(*STEEL)], np.array([[0.5]]), np.array([[0.1]]), 0,
                         _core.DrumGeometry(0.44, 0.3, True, 0, 0.0, 0.0),
                         np.array(radius, float), np.zeros(1, np.int32), 1e-6)
        else:
            make_engine(radius, **args)


# -- the materials a scene lists but does not use ------------------------------------------------

CERAMIC = (3900.0, 1.4e8, 0.25)  # density, shear modulus, Poisson ratio: far softer than steel


@pytest.mark.parametrize("order", ["steel first", "steel second"])
def test_an_unused_material_does_not_set_the_contact_law(order: str) -> None:
    """A steel ball dropped on the steel end wall of a drum whose table also lists ceramic (not
    used, e = 1, no friction): the ball must rebound with steel-steel e = 0.3 and touch for the
    steel-steel Hertz time, whichever index steel has."""
    r, v, e_steel = 0.0125, 1.0, 0.3
    materials = [STEEL, CERAMIC] if order == "steel first" else [CERAMIC, STEEL]
    steel = materials.index(STEEL)
    restitution = np.full((2, 2), 0.6)
    friction = np.full((2, 2), 0.4)
    restitution[1 - steel, 1 - steel], friction[1 - steel, 1 - steel] = 1.0, 0.0
    restitution[steel, steel], friction[steel, steel] = e_steel, 0.15
    dt = 0.02 * rayleigh_time(2 * r, *STEEL)
    geometry = _core.DrumGeometry(0.44, 0.315, True, 0, 0.0, 0.0)
    eng = _core.Engine([_core.Material(*m) for m in materials], restitution, friction, steel,
                       geometry, np.array([r]), np.array([steel], np.int32), dt, gravity=0.0,
                       threads=1)
    assert "one material" in eng.variant
    eng.positions = np.array([[0.0, 0.0, r + 1e-4]])
    eng.velocities = np.array([[0.0, 0.0, -v]])
    duration, after = contact_duration_and_exit(eng, 200000)
    assert after[0, 2] / v == pytest.approx(e_steel, rel=0.02)
    # Steel's stiffness, not ceramic's: the damped contact lasts somewhat longer than the
    # elastic Hertz time (by about a fifth at e = 0.3); with ceramic's stiffness it would last
    # several times longer.
    steel_time = hertz_contact_time(STEEL, None, 2 * r, None, v)
    assert steel_time < duration < 1.3 * steel_time

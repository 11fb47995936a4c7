"""The engine's guards (docs/physics.md, Guards): each builds the bad state on purpose and checks
that the run stops at once with a message naming the step, the particle, its values and a hint.

Guards: a particle outside the drum, a non-finite value, a speed above the scene's bound, a
contact deeper than a fraction of the radius; and a time step above the stability limit is
refused before anything runs.
"""

from __future__ import annotations

import math
import re
from typing import Any

import numpy as np
import pytest

import millscope as ms
from millscope import _core
from millscope.contact import MAX_DT_FRACTION
from millscope.simulation import MAX_OVERLAP_FRACTION, SPEED_BOUND_FACTOR
from millscope.stiffness import time_step_limit, upper_impact_speed

from .test_engine import STEEL, make_engine

R = 0.0125  # m, the paper's 25 mm balls
MID = 0.1575  # m, the middle of the drum along its axis (it spans 0 <= z <= 0.315 m)
# what every guard message holds: where the run stopped, which particle, its state, a hint
WHERE = (r"stopped at step \d+ \((?:during settling, )?t = [-+0-9.e]+ s since [^)]*\): "
         r"particle (\d+) \(radius 0.0125 m")
STATE = r"position [-+0-9.e]+, [-+0-9.e]+, [-+0-9.e]+ m; velocity "


def guarded_engine(positions, velocities=None, *, max_speed=math.inf,
                   max_overlap=MAX_OVERLAP_FRACTION, threads=1):  # type: ignore[no-untyped-def]
    """Steel balls of 25 mm in the pilot drum without gravity, with the guards given."""
    positions = np.asarray(positions, dtype=float)
    n = len(positions)
    engine = _core.Engine([_core.Material(*STEEL)], np.array([[0.5]]), np.array([[0.15]]), 0,
                          _core.DrumGeometry(0.44, 0.315, True, 0, 0.0, 0.0),
                          np.full(n, R), np.zeros(n, np.int32),
                          0.2 * ms.contact.rayleigh_time(2 * R, *STEEL), gravity=0.0,
                          threads=threads, max_speed=max_speed, max_overlap=max_overlap)
    engine.positions = positions
    if velocities is not None:
        engine.velocities = np.asarray(velocities, dtype=float)
    return engine


def test_a_particle_outside_the_drum_stops_the_run() -> None:
    eng = make_engine([R], gravity=0.0, positions=[[0.5, 0.0, 0.1]])
    with pytest.raises(RuntimeError, match=WHERE.replace(r"(\d+)", "0") + r".*has left the "
                       r"drum: its centre is 0.5 m from the axis, beyond the shell at 0.44 m.*"
                       + STATE + ".*Hint"):
        eng.advance(1)


@pytest.mark.parametrize("where", ["positions", "velocities", "spins"])
def test_non_finite_input_is_refused_before_anything_runs(where: str) -> None:
    eng = guarded_engine([[0.0, 0.0, MID], [0.1, 0.0, MID]])
    values = np.asarray(getattr(eng, where)).copy()
    values[1, 1] = math.nan
    with pytest.raises(ValueError, match=rf"{where}\[1\] is not finite"):
        setattr(eng, where, values)
    assert eng.step_count == 0


def corrupted_engine(bad: float, extra: list[float] | None = None) -> Any:
    """A ball resting on the end wall, 5 steps in, with its wall contact history made
    non-finite (as a corrupted checkpoint would): the history enters the force of step 6,
    whose kick at step 7 makes the velocity non-finite. `extra`: a second ball there, moving
    a whole neighbour-list skin per step along -x."""
    eng = guarded_engine([[0.0, 0.0, R - 1e-6], *([extra] if extra else [])])
    eng.velocities = [[0.01, 0.0, 0.0], *([[-eng.skin / eng.dt, 0.0, 0.0]] if extra else [])]
    eng.advance(5)
    assert extra is None or eng.list_builds == 1 + 5  # the first build, then one every step
    snap = eng.snapshot()
    history = np.asarray(snap["wall_history"]).copy()
    held = history != 0.0
    assert held.any()  # the contact with the end wall has a tangential spring
    history[held] = bad
    snap["wall_history"] = history
    eng.restore(snap)
    return eng


@pytest.mark.parametrize("bad", [math.nan, math.inf])
def test_a_non_finite_value_arising_in_the_run_stops_it(bad: float) -> None:
    """The state guards look every GUARD_INTERVAL steps: the run stops at the first look after
    step 7, not later."""
    eng = corrupted_engine(bad)
    with pytest.raises(RuntimeError, match=r"stopped at step (\d+) .*particle 0 .*has non-finite "
                       r"values.*Hint") as stop:
        eng.advance(3 * _core.GUARD_INTERVAL)
    step = int(re.search(r"stopped at step (\d+)", str(stop.value)).group(1))
    assert step == 7 + (-7) % _core.GUARD_INTERVAL
    assert eng.step_count == step


def test_the_last_step_of_a_call_is_always_guarded() -> None:
    """Whatever the interval, a call does not hand back a state it did not look at."""
    eng = corrupted_engine(math.nan)
    with pytest.raises(RuntimeError, match=r"stopped at step 7 .*has non-finite values"):
        eng.advance(2)


def test_a_non_finite_state_is_caught_before_a_list_build() -> None:
    """Between the looks of the state guards, a neighbour-list build looks first: a
    non-finite position must not be binned. Ball 0 turns non-finite at step 7 (as in
    corrupted_engine); ball 1 crosses a whole skin every step, so the list is built at every
    step, step 7 included, which is not a look of the state guards."""
    eng = corrupted_engine(math.nan, extra=[0.2, 0.0, MID])
    assert 7 % _core.GUARD_INTERVAL != 0
    with pytest.raises(RuntimeError, match=r"stopped at step 7 .*particle 0 .*non-finite"):
        eng.advance(3 * _core.GUARD_INTERVAL)


def test_a_speed_above_the_bound_stops_the_run() -> None:
    eng = guarded_engine([[0.0, 0.0, MID], [0.2, 0.0, MID]],
                         [[0.0, 0.0, 0.0], [0.0, 0.0, 10.5]], max_speed=10.0)
    with pytest.raises(RuntimeError, match=WHERE.replace(r"(\d+)", "1")
                       + r".*moves at 10.5 m/s, above the bound of 10 m/s.*Hint"):
        eng.advance(5)


def test_a_speed_just_below_the_bound_runs() -> None:
    eng = guarded_engine([[0.0, 0.0, MID], [0.2, 0.0, MID]],
                         [[0.0, 0.0, 0.0], [0.0, 0.0, 9.99]], max_speed=10.0)
    eng.advance(5)
    assert np.allclose(np.asarray(eng.velocities)[1], [0.0, 0.0, 9.99])


@pytest.mark.parametrize("threads", [1, 2])
def test_a_contact_deeper_than_the_limit_stops_the_run(threads: int) -> None:
    # two balls overlapping by 1.2 of their radius (the limit is 1), away from the walls
    gap = 2 * R - 1.2 * R
    eng = guarded_engine([[-gap / 2, 0.0, MID], [gap / 2, 0.0, MID]], threads=threads)
    with pytest.raises(RuntimeError, match=r"stopped at step 0 .*particle [01] .*overlaps "
                       r"another particle by 1.2 of the smaller radius, above the limit of "
                       rf"{MAX_OVERLAP_FRACTION:g} .*Hint: contacts this deep are outside Hertz"):
        eng.advance(1)


def test_a_contact_with_the_drum_deeper_than_the_limit_stops_the_run() -> None:
    # on the end wall z = 0 (the drum spans 0 <= z <= L), overlapping it by 1.3 of the radius
    eng = guarded_engine([[0.0, 0.0, -0.3 * R]])
    with pytest.raises(RuntimeError, match=r"particle 0 .*overlaps the drum by 1.3 of the "
                       r"particle's radius"):
        eng.advance(1)


def test_a_contact_within_the_limit_runs() -> None:
    gap = 2 * R - 0.9 * R  # deep, but within the limit of 1: pushed apart, no stop
    eng = guarded_engine([[-gap / 2, 0.0, MID], [gap / 2, 0.0, MID]])
    eng.advance(1)
    v = np.asarray(eng.velocities)
    assert v[0, 0] < 0 < v[1, 0]


def test_contacts_too_soft_for_the_impact_are_stopped_by_the_overlap_guard() -> None:
    """Ceramic-like balls of 12 mm with a shear modulus 10^5 times below the paper's meeting at
    3 m/s: Hertz theory (computed here) puts the deepest overlap beyond the radius, and the run
    stops there instead of letting the balls pass through each other."""
    soft = (2800.0, 1.6e4, 0.25)  # density kg/m^3, shear modulus Pa, Poisson ratio
    r, v = 0.006, 1.5
    assert ms.contact.hertz_max_overlap(soft, soft, 2 * r, 2 * r, 2 * v) > 1.2 * r
    d = 2 * r + 1e-4
    dt = 0.2 * ms.contact.rayleigh_time(2 * r, *soft)
    eng = _core.Engine([_core.Material(*soft)], np.array([[0.5]]), np.array([[0.15]]), 0,
                       _core.DrumGeometry(0.44, 0.315, True, 0, 0.0, 0.0), np.full(2, r),
                       np.zeros(2, np.int32), dt, gravity=0.0, max_overlap=MAX_OVERLAP_FRACTION)
    eng.positions = np.array([[-d / 2, 0.0, MID], [d / 2, 0.0, MID]])
    eng.velocities = np.array([[v, 0.0, 0.0], [-v, 0.0, 0.0]])
    steps = int(10 * d / v / dt)
    with pytest.raises(RuntimeError, match=r"overlaps another particle by 1\.\d+ of the "
                       r"smaller radius"):
        eng.advance(steps)
    assert eng.step_count < steps


@pytest.mark.parametrize("name, value, pattern", [
    ("max_speed", 0.0, r"max_speed = 0 is not valid; it must be > 0 m/s"),
    ("max_speed", math.nan, r"max_speed = nan is not valid"),
    ("max_overlap", 0.0, r"max_overlap = 0 is not valid; it must be in \(0, 1\]"),
    ("max_overlap", 1.5, r"max_overlap = 1.5 is not valid; it must be in \(0, 1\]"),
])
def test_guard_settings_are_validated(name: str, value: float, pattern: str) -> None:
    with pytest.raises(ValueError, match=pattern):
        guarded_engine([[0.0, 0.0, MID]], **{name: value})


def test_the_speed_bound_of_a_scene() -> None:
    """omega R + sqrt(2 g D): the pilot mill at 71 % of critical, computed here from the paper's
    numbers (D = 0.88 m, critical speed sqrt(2 g / (D - d)) with d = 25 mm)."""
    scene = ms.presets.pilot_mill(0.71, None, scale="tiny")
    omega = 0.71 * math.sqrt(2 * 9.81 / (0.88 - 0.025))
    expected = omega * 0.44 + math.sqrt(2 * 9.81 * 0.88)
    assert upper_impact_speed(scene) == pytest.approx(expected, rel=1e-3)
    sim = ms.Simulation(scene, seed=0, threads=1)
    assert sim._engine.max_speed == pytest.approx(SPEED_BOUND_FACTOR * expected, rel=1e-3)
    assert sim._engine.max_overlap == MAX_OVERLAP_FRACTION


def test_a_time_step_above_the_limit_is_refused_before_anything_runs() -> None:
    paper = ms.presets.pilot_mill(0.71, None, scale="paper")
    t_r = paper.min_rayleigh_time()[0]
    with pytest.raises(ValueError, match=rf"dt = .* s is not valid; it must be in \(0, "
                       rf"{MAX_DT_FRACTION * t_r:.6g}\] s, {MAX_DT_FRACTION} x the Rayleigh "
                       r"time"):
        ms.Simulation(paper, dt=1.01 * MAX_DT_FRACTION * t_r)
    # at the reduced moduli the stick mode of the balls' contacts sets a lower limit
    scene = ms.presets.pilot_mill(0.71, None, scale="tiny")
    limit = time_step_limit(scene).dt
    with pytest.raises(ValueError, match=rf"dt = .* s is not valid; it must be in \(0, "
                       rf"{limit:.6g}\] s = .* tangential-rotational stick mode of the contact "
                       r"balls \(steel\) - balls \(steel\)"):
        ms.Simulation(scene, dt=1.01 * limit)


@pytest.mark.parametrize("scale, deepest_seen", [("small", 0.15), ("tiny", 0.5)])
def test_a_sound_run_stays_inside_the_guards(scale: str, deepest_seen: float) -> None:
    """The pilot mill tumbling (level 1, 0.4 s from the drum's start, the deepest contacts of
    the charge): the contacts stay inside the overlap limit and the particles far below the
    speed bound, so the guards stop only broken runs. The deepest contact, about 15 % of the
    ceramic radius at the "small" scale and 50 % at the "tiny" one, is checked within a
    factor 1.5 of what was seen: the softened scales are deep in their contacts, and a change
    that made them deeper should show here."""
    sim = ms.Simulation(ms.presets.pilot_mill(0.71, "ceramic", 1, scale=scale), seed=0,
                        threads=1, track_energy=False)
    deepest, fastest = 0.0, 0.0
    sim.run(0.02, sample_dt=0.01, progress=False)  # fill, settle, start
    for _ in range(20):
        sim.run(0.02, sample_dt=0.01, progress=False)
        deepest = max(deepest, sim._engine.max_overlap_ratio())
        fastest = max(fastest, float(np.max(np.linalg.norm(sim._engine.velocities, axis=1))))
    assert deepest < min(MAX_OVERLAP_FRACTION, 1.5 * deepest_seen)
    assert fastest < SPEED_BOUND_FACTOR * upper_impact_speed(sim.scene) / 5


def stopped_at(message: str) -> tuple[int, float]:
    found = re.search(r"stopped at step (\d+) \((?:during settling, )?t = ([-+0-9.e]+) s", message)
    assert found, message
    return int(found.group(1)), float(found.group(2))


def test_a_guard_stopping_a_run_gives_the_record_s_time() -> None:
    """The engine counts time from the filling; the record from the start of rotation. A
    particle sent far beyond the speed bound 0.02 s into the rotation stops the next run at
    once: the message gives that moment on the record's axis (within one sample of the
    record's last time), not the time since filling (settling took at least 0.1 s more)."""
    sim = ms.Simulation(ms.presets.pilot_mill(0.71, None, scale="tiny"), seed=0, threads=1,
                        settle_tolerance=10.0, settle_min_s=0.1, settle_max_s=0.2)
    rec = sim.run(0.02, sample_dt=0.01, progress=False)
    v = sim.velocities.copy()
    v[5] = [0.0, 0.0, 2.0 * sim._engine.max_speed]  # along the periodic axis
    sim._engine.velocities = v
    with pytest.raises(RuntimeError, match=r"since the start of rotation, the record's time"
                       r"\): particle 5 .*moves at") as stop:
        sim.run(0.02, sample_dt=0.01, progress=False)
    step, t = stopped_at(str(stop.value))
    assert step == sim._engine.step_count
    assert t == pytest.approx(sim.time, rel=1e-5)
    assert abs(t - rec.time_s[-1]) <= 0.01


def test_a_guard_stopping_the_settling_says_so() -> None:
    sim = ms.Simulation(ms.presets.pilot_mill(0.71, None, scale="tiny"), seed=0, threads=1)
    sim.fill()
    v = sim.velocities.copy()
    v[5] = [0.0, 0.0, 2.0 * sim._engine.max_speed]
    sim._engine.velocities = v
    with pytest.raises(RuntimeError, match=r"\(during settling, t = .* s since filling\): "
                       r"particle 5 ") as stop:
        sim.settle(progress=False)
    step, t = stopped_at(str(stop.value))
    assert step == sim._engine.step_count and sim.time == 0.0
    assert t == pytest.approx(step * sim.dt, rel=1e-5)

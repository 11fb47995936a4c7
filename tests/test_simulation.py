"""Simulation: filling, checkpoints (bit-for-bit continuation), bad files."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import millscope as ms
from millscope.contact import hertz_max_overlap

from .cpu import needs_two_cores, usable_cores


def quick_sim(seed: int = 0) -> ms.Simulation:
    scene = ms.presets.pilot_mill(0.71, "ceramic", 1, scale="small")
    return ms.Simulation(scene, seed=seed, threads=min(2, usable_cores()), settle_tolerance=10.0,
                         settle_min_s=0.1, settle_max_s=0.2)


def hertz_overlap_bound(scene: ms.Scene, speed_fraction: float) -> float:
    """The largest overlap / smaller radius that Hertz theory allows in ``scene``: a head-on,
    undamped impact of each pair (and each fraction on the drum) at the fastest speed a particle
    can reach, a fall across the drum plus the shell's speed, sqrt(4 g R) + omega R."""
    radius = scene.drum.radius
    v = np.sqrt(4.0 * 9.81 * radius) + speed_fraction * scene.critical_speed_rad_s * radius
    drum = scene.material(scene.drum.material)
    worst = 0.0
    for a in scene.charge:
        mat_a = scene.material(a.material)
        overlap = hertz_max_overlap(mat_a, drum, a.diameter, None, v)
        worst = max(worst, overlap / a.radius)
        for b in scene.charge:
            overlap = hertz_max_overlap(mat_a, scene.material(b.material), a.diameter,
                                        b.diameter, v)
            worst = max(worst, overlap / min(a.radius, b.radius))
    return worst


def test_fill_places_every_particle_without_overlap_inside_the_drum() -> None:
    sim = quick_sim()
    sim.fill()
    x, r = sim.positions, sim.scene.particle_radii()
    assert len(x) == sim.scene.n_particles == 391 + 645
    from scipy.spatial import cKDTree

    pairs = cKDTree(x).query_pairs(2 * r.max())
    for i, j in pairs:
        assert np.linalg.norm(x[i] - x[j]) >= r[i] + r[j]
    assert np.all(np.hypot(x[:, 0], x[:, 1]) + r <= 0.44)  # inside the shell
    assert sim.max_overlap_ratio() == 0.0  # clear of the lifters too (the engine's geometry)


def test_checkpoint_continues_bit_for_bit(tmp_path) -> None:  # type: ignore[no-untyped-def]
    sim = quick_sim()
    sim.run(0.05, progress=False)
    path = sim.save(tmp_path / "case.ckpt.npz")
    a = sim.run(0.1, sampling="mean", progress=False)
    again = ms.Simulation.load(path)
    assert again.phase == "rotating" and again.threads == sim.threads
    b = again.run(0.1, sampling="mean", progress=False)
    assert np.array_equal(a.time_s, b.time_s)
    assert np.array_equal(a.torque_Nm, b.torque_Nm)


def test_damaged_checkpoint_is_refused(tmp_path) -> None:  # type: ignore[no-untyped-def]
    bad = tmp_path / "bad.npz"
    bad.write_bytes(b"not a zip file")
    with pytest.raises(ms.CheckpointError, match="damaged or not a millscope checkpoint"):
        ms.Simulation.load(bad)


def test_trapezoidal_lifters_end_to_end() -> None:
    """A slice with trapezoidal lifters (base 30 mm, tip 12 mm, 20 mm high) runs through
    Simulation: the lifters carry part of the drive torque, no particle centre sits inside a
    lifter's cross-section, and particles do sit by the slanted sides where a rectangular
    lifter of the same base would not let them (so the engine uses the profile)."""
    import dataclasses

    base = ms.presets.pilot_mill(0.71, "ceramic", 1, scale="small")
    trapezoid = ms.Lifters(16, 0.03, 0.02, profile="trapezoidal", top_width=0.012)
    scene = dataclasses.replace(base, drum=dataclasses.replace(base.drum, lifters=trapezoid))
    sim = ms.Simulation(scene, seed=0, threads=min(2, usable_cores()), settle_tolerance=10.0,
                        settle_min_s=0.1, settle_max_s=0.2)
    rec = sim.run(0.3, sampling="mean", progress=False)
    assert rec.meta["scene"]["drum"]["lifters"]["top_width"] == 0.012
    assert np.all(sim.last_parts["lifters"][10:] > 0.0)  # lifters push the charge up
    R, h = scene.drum.diameter / 2, trapezoid.height
    x, radius = sim.positions, scene.particle_radii()
    theta = sim.drum_angle
    near_slant = 0
    for k in range(16):
        phi = theta + trapezoid.phase + 2 * np.pi * k / 16
        a = x[:, 0] * np.cos(phi) + x[:, 1] * np.sin(phi)  # along the centre line
        b = -x[:, 0] * np.sin(phi) + x[:, 1] * np.cos(phi)  # across it
        # half width grows linearly from the tip (a = R - h) to the base (a = R)
        half = 0.006 + (0.015 - 0.006) * (a - (R - h)) / h
        inside = (a > R - h) & (np.abs(b) < half)
        assert not np.any(inside), f"particle centres inside lifter {k}"
        # distance to the rectangle a >= R - h, |b| <= 15 mm
        to_box = np.hypot(np.maximum(R - h - a, 0.0), np.maximum(np.abs(b) - 0.015, 0.0))
        near_slant += int(np.sum(to_box < 0.8 * radius))
    assert near_slant > 0
    # no particle is pushed into a lifter deeper than the hardest possible impact would press it
    assert sim.max_overlap_ratio() < hertz_overlap_bound(scene, 0.71)


@pytest.mark.parametrize("particles", [None, "ceramic"])
@pytest.mark.parametrize("threads", [1, pytest.param(2, marks=needs_two_cores)])
def test_energy_ledger_changes_nothing_in_the_motion(threads: int, particles: str | None) -> None:
    """Without the energy ledger the step sums the same forces in the same order: the torque
    and the positions are the same to the bit, the drive work too; only the losses go NaN.
    The two kernels compute the pair contacts apart (with the ledger contact::pair_force, one
    pair at a time; without it the lanes of contact_forces_in_lanes), so this also holds the
    lanes to the law, with one material and with a pair table."""
    scene = ms.presets.pilot_mill(0.71, particles, scale="tiny")
    runs = []
    for track in (True, False):
        sim = ms.Simulation(scene, seed=3, threads=threads, track_energy=track)
        assert sim.track_energy is track
        rec = sim.run(0.2, progress=False)
        runs.append((sim, rec))
    (on, rec_on), (off, rec_off) = runs
    assert np.abs(rec_on.torque_Nm).max() > 0  # the charge works against the drum
    assert np.array_equal(rec_on.torque_Nm, rec_off.torque_Nm)
    assert np.array_equal(on.positions, off.positions)
    e_on, e_off = on.energies(), off.energies()
    assert e_on["drive_work"] == e_off["drive_work"] and e_on["drive_work"] > 0
    assert e_on["dissipated"] > 0
    for k in ("dissipated", "damping_loss", "friction_loss", "spring_work"):
        with pytest.raises(ms.LedgerOffError, match=r"track_energy=True"):
            e_off[k]
    assert set(e_on) - set(e_off) == {"dissipated", "damping_loss", "friction_loss",
                                      "spring_work"}
    assert all(np.isfinite(v) for v in e_off.values())


def test_the_energy_ledger_is_off_unless_asked_for() -> None:
    """The default run pays for the torque alone; a key that is not an energy stays a plain
    KeyError."""
    sim = ms.Simulation(ms.presets.pilot_mill(0.71, None, scale="tiny"), seed=0, threads=1)
    assert sim.track_energy is False
    e = sim.energies()
    with pytest.raises(ms.LedgerOffError, match=r"\['dissipated'\] is not booked"):
        e["dissipated"]
    with pytest.raises(KeyError) as info:
        e["no such energy"]
    assert not isinstance(info.value, ms.LedgerOffError)


def test_track_energy_is_kept_by_a_checkpoint(tmp_path) -> None:  # type: ignore[no-untyped-def]
    scene = ms.presets.pilot_mill(0.71, None, scale="tiny")
    sim = ms.Simulation(scene, seed=0, threads=1, track_energy=False)
    path = sim.save(tmp_path / "c.npz")
    assert ms.Simulation.load(path).track_energy is False
    assert ms.Simulation.load(path, track_energy=True).track_energy is True
    # a run that did not book the losses from its start cannot give them later
    sim.run(0.05, progress=False)
    late = ms.Simulation.load(sim.save(tmp_path / "d.npz"), track_energy=True)
    late.run(0.05, progress=False)
    with pytest.raises(ms.LedgerOffError, match=r"ran before its checkpoint"):
        late.energies()["dissipated"]
    assert late.energies()["drive_work"] > 0
    with pytest.raises(ValueError, match=r"track_energy = 'no' is not valid"):
        ms.Simulation(scene, track_energy="no")  # type: ignore[arg-type]


@pytest.mark.parametrize("extra", [1, 100000])
def test_more_threads_than_the_cores_are_refused(tmp_path: Path, extra: int) -> None:
    """Simulation(threads=100000) crashed the OpenMP runtime and 10000 hung it: counts above
    the cores this process may use are refused, by the constructor and by load()."""
    n, too_many = usable_cores(), usable_cores() + extra
    scene = ms.presets.pilot_mill(0.71, None, scale="tiny")
    message = (rf"threads = {too_many} is not valid; it must be an integer in \[1, {n}\], the "
               "cores this process may use")
    with pytest.raises(ValueError, match=message):
        ms.Simulation(scene, threads=too_many)
    path = ms.Simulation(scene, threads=1).save(tmp_path / "empty.npz")
    with pytest.raises(ValueError, match=message):
        ms.Simulation.load(path, threads=too_many)
    assert ms.Simulation(scene, threads=n).threads == n


def test_a_checkpoint_of_each_phase_loads(tmp_path: Path) -> None:
    """The checks of load() accept what save() writes before rotation too: an empty drum, a
    filled one (nothing has stepped, no neighbour list) and a settled one."""
    scene = ms.presets.pilot_mill(0.71, None, scale="tiny")
    sim = ms.Simulation(scene, seed=3, threads=1, settle_tolerance=10.0, settle_min_s=0.02,
                        settle_max_s=0.04)
    for phase in ("empty", "filled", "settled"):
        if phase == "filled":
            sim.fill()
        elif phase == "settled":
            sim.settle(progress=False)
        again = ms.Simulation.load(sim.save(tmp_path / f"{phase}.npz"))
        assert again.phase == phase
        assert np.array_equal(again.positions, sim.positions)


@pytest.mark.parametrize(("particles", "scale"), [(None, "paper"), ("ceramic", "paper"),
                                                  (None, "tiny"), ("ceramic", "tiny")])
def test_the_default_skin_lets_the_fastest_particle_take_ten_steps_to_a_rebuild(
        particles: str | None, scale: str) -> None:
    """A rebuild is due once a particle has moved half the skin: at the upper impact speed that
    takes at least 10 steps, unless the skin is at its cap of 1.2 r_min; at the paper's
    stiffness the skin is the LIGGGHTS yardstick's 0.4 r_min (5 mm for the 12.5 mm balls)."""
    from millscope.engine.simulation import default_skin

    scene = ms.presets.pilot_mill(0.71, particles, 1 if particles is None else 4, scale)
    sim = ms.Simulation(scene, threads=1)
    r_min = float(scene.particle_radii().min())
    skin = sim._engine.skin
    assert skin == default_skin(scene, sim.dt)
    assert 0.4 * r_min <= skin <= 1.2 * r_min * (1 + 1e-12)
    steps_to_rebuild = skin / 2 / (ms.stiffness.upper_impact_speed(scene) * sim.dt)
    assert steps_to_rebuild >= 10 * (1 - 1e-12) or skin == pytest.approx(1.2 * r_min)
    if scale == "paper":
        assert skin == 0.4 * r_min
        if particles is None:
            assert skin == pytest.approx(0.005)


def test_the_skin_changes_no_contact() -> None:
    """The tiny scale's default skin (1.2 r_min) against the floor (0.4 r_min), from the same
    filling: three times fewer list builds, and the same motion to round-off after 1500 steps
    of the charge falling into the drum and colliding (positions within 1e-9 m)."""
    scene = ms.presets.pilot_mill(0.71, "ceramic", 1, "tiny")
    r_min = float(scene.particle_radii().min())
    runs = []
    for skin in (None, 0.4 * r_min):
        sim = ms.Simulation(scene, seed=3, threads=1, skin=skin)
        sim.fill()
        sim._engine.advance(1500)
        runs.append((sim.positions, sim._engine.list_builds))
    (wide, wide_builds), (narrow, narrow_builds) = runs
    assert wide_builds * 2 < narrow_builds
    np.testing.assert_allclose(wide, narrow, rtol=0, atol=1e-9)

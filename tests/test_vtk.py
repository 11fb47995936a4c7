"""See the charge: VTK snapshots for ParaView (read back with meshio, an independent reader), the
drum's surface against the engine's own geometry (``_core.drum_contacts``), snapshot runs against
plain runs, and the cross-section figure."""

from __future__ import annotations

import dataclasses
import math
import os
import xml.etree.ElementTree as ET
from pathlib import Path

import meshio
import numpy as np
import pytest

import millscope as ms
from millscope import _core, _drum_shape
from millscope.engine import snapshots
from millscope.report import plots
from millscope.scene import Drum, Fraction, Lifters, Material, Pair, Scene

SOFT_STEEL = Material("steel", 7860.0, 81e6, 0.3)  # shear modulus x 0.001
SOFT_CERAMIC = Material("ceramic", 2800.0, 1.6e6, 0.22)


def small_scene(lifters: Lifters | None = None) -> Scene:
    """30 soft steel balls and 20 ceramic ones in a 0.3 m drum with end walls."""
    lifters = lifters or Lifters(8, 0.02, 0.015, phase=0.2)
    return Scene(drum=Drum(0.3, 0.1, "steel", True, lifters),
                 charge=[Fraction("steel", 0.025, 30, "balls"),
                         Fraction("ceramic", 0.02, 20, "pebbles")],
                 materials=[SOFT_STEEL, SOFT_CERAMIC],
                 pairs=[Pair("steel", "steel", 0.5, 0.15), Pair("ceramic", "ceramic", 0.3, 0.6),
                        Pair("ceramic", "steel", 0.2, 0.4)],
                 speed_fraction=0.8)


def small_sim(scene: Scene | None = None) -> ms.Simulation:
    return ms.Simulation(scene or small_scene(), seed=3, threads=1, settle_tolerance=10.0,
                         settle_min_s=0.05, settle_max_s=0.1)


def collection(path: Path) -> list[tuple[float, str]]:
    """(time, file) of each DataSet of a .pvd, read with the standard library."""
    root = ET.parse(path).getroot()
    assert root.tag == "VTKFile" and root.get("type") == "Collection"
    return [(float(d.get("timestep", "nan")), str(d.get("file")))
            for d in root.iter("DataSet")]


def engine_geometry(drum: Drum) -> _core.DrumGeometry:
    lift = drum.lifters
    assert lift is not None
    return _core.DrumGeometry(drum.radius, drum.length, drum.end_walls, lift.count, lift.width,
                              lift.height, lift.phase, lift.top_width)


# -- the particle file -----------------------------------------------------------------------


def test_the_particle_file_holds_the_simulations_state(tmp_path) -> None:
    sim = small_sim()
    sim.run(0.1, progress=False)
    particles, drum = sim.write_vtk(tmp_path / "vtk")
    mesh = meshio.read(particles)
    n = sim.scene.n_particles
    assert len(mesh.points) == n == 50
    assert set(mesh.point_data) == {"velocity", "spin", "radius", "material", "id"}
    # binary float64: the values come back to the bit
    assert np.array_equal(mesh.points, sim.positions)
    assert np.array_equal(mesh.point_data["velocity"], sim.velocities)
    assert np.array_equal(mesh.point_data["spin"], sim.spins)
    assert np.array_equal(mesh.point_data["radius"], np.r_[np.full(30, 0.0125), np.full(20, 0.01)])
    assert list(mesh.point_data["material"]) == [0] * 30 + [1] * 20  # steel, ceramic
    assert np.array_equal(mesh.point_data["id"], np.arange(n))
    assert mesh.cells[0].type == "vertex" and len(mesh.cells[0].data) == n
    # the materials are named by index in the collection
    assert "0 = steel, 1 = ceramic" in (tmp_path / "vtk" / "particles.pvd").read_text()
    assert collection(tmp_path / "vtk" / "particles.pvd") == [(sim.time, particles.name)]
    assert collection(tmp_path / "vtk" / "drum.pvd") == [(sim.time, drum.name)]
    assert sim.time == pytest.approx(0.1, abs=sim.dt)


# -- the drum's surface ----------------------------------------------------------------------


def assert_on_engine_lifters(drum: Drum, theta: float, points: np.ndarray,
                             lifter: np.ndarray) -> None:
    """Each point lies on the surface of its lifter as the engine sees it: a sphere of radius r
    centred there overlaps that lifter by r (to round-off)."""
    geometry = engine_geometry(drum)
    r = 1e-4
    for p, k in zip(points, lifter, strict=True):
        found = [c for c in _core.drum_contacts(geometry, theta, p, r)
                 if c["part"] == "lifter" and c["index"] == k]
        assert len(found) == 1, (p, k)
        assert found[0]["overlap"] == pytest.approx(r, abs=1e-12)


def test_the_drum_file_has_the_shell_end_walls_and_lifters_at_the_drum_angle(tmp_path) -> None:
    sim = small_sim()
    sim.run(0.2, progress=False)
    snap = sim.snapshot()
    assert snap.drum_angle > 0.1  # the drum has turned: the lifters are not where they started
    _, drum_file = sim.write_vtk(tmp_path)
    mesh = meshio.read(drum_file)
    drum = sim.scene.drum
    radius, length = drum.radius, drum.length
    part = dict(zip([c.type for c in mesh.cells], mesh.cell_data["part"], strict=True))
    lifter = dict(zip([c.type for c in mesh.cells], mesh.cell_data["lifter"], strict=True))
    quads, triangles = mesh.cells_dict["quad"], mesh.cells_dict["triangle"]
    rho = np.hypot(mesh.points[:, 0], mesh.points[:, 1])
    shell = np.unique(quads[part["quad"] == 0])
    assert np.allclose(rho[shell], radius, rtol=1e-14)
    assert set(mesh.points[shell, 2]) == {0.0, length}
    # end walls: one at z = 0 and one at z = L, inside the shell, covering its disc
    for code, z in ((1, 0.0), (2, length)):
        tri = triangles[part["triangle"] == code]
        assert np.all(mesh.points[tri, 2] == z) and np.all(rho[tri] <= radius * (1 + 1e-14))
        corners = mesh.points[tri][:, :, :2]
        u, v = corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]
        area = 0.5 * np.abs(u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0])
        segments = len(tri)
        assert area.sum() == pytest.approx(0.5 * segments * radius**2 * math.sin(2 * math.pi
                                                                                 / segments))
    # lifters: 5 faces each, every vertex on that lifter as the engine models it
    on_lifter = part["quad"] == 3
    assert sorted(set(lifter["quad"][on_lifter])) == list(range(8))
    assert np.all(lifter["quad"][~on_lifter] == -1)
    vertices = quads[on_lifter]
    owner = np.repeat(lifter["quad"][on_lifter], 4)
    assert_on_engine_lifters(drum, snap.drum_angle, mesh.points[vertices.ravel()], owner)
    # the drum's surface moves with it: omega x r
    omega = np.array([0.0, 0.0, sim.scene.omega])
    assert np.allclose(mesh.point_data["velocity"], np.cross(omega, mesh.points), rtol=1e-14,
                       atol=1e-15)


@pytest.mark.parametrize("lifters", [Lifters(16, 0.03, 0.02),
                                     Lifters(6, 0.05, 0.04, "trapezoidal", 0.02, phase=-1.0)])
def test_lifter_outlines_are_the_engines_lifters(lifters) -> None:
    """Corners and points along the tip and side faces lie on the engine's lifter prism; the
    shell corners on the shell; a point just off the tip face, towards the axis, is clear."""
    drum = Drum(0.88, 0.3, "steel", True, lifters)
    theta = 1.234
    outlines = _drum_shape.lifter_outlines(drum, theta)
    assert outlines.shape == (lifters.count, 4, 2)
    assert np.allclose(np.hypot(*outlines[:, [0, 3]].T), drum.radius, rtol=1e-14)
    tip = outlines[:, 2] - outlines[:, 1]
    assert np.allclose(np.hypot(*tip.T), lifters.tip_width, rtol=1e-12)
    # points along the three visible faces, at mid-length
    t = np.linspace(0.0, 1.0, 7)[:, None, None]
    along = np.concatenate([outlines[:, k] + t * (outlines[:, k + 1] - outlines[:, k])
                            for k in range(3)])  # (21, n, 2)
    points = np.column_stack([along.reshape(-1, 2), np.full(along.shape[0] * along.shape[1],
                                                            0.15)])
    owner = np.tile(np.arange(lifters.count), along.shape[0])
    assert_on_engine_lifters(drum, theta, points, owner)
    geometry = engine_geometry(drum)
    mid_tip = 0.5 * (outlines[:, 1] + outlines[:, 2])
    inward = -mid_tip / np.hypot(*mid_tip.T)[:, None]
    for p in mid_tip + 2e-4 * inward:
        contacts = _core.drum_contacts(geometry, theta, np.r_[p, 0.15], 1e-4)
        assert not [c for c in contacts if c["part"] == "lifter"]


def test_periodic_ends_have_no_end_walls() -> None:
    drum = Drum(0.3, 0.05, "steel", False, Lifters(4, 0.02, 0.01))
    surface = _drum_shape.drum_surface(drum, 0.0, segments=16)
    assert len(surface.triangles) == 0 and len(surface.quads) == 16 + 4 * 5


# -- snapshots during a run --------------------------------------------------------------------


@pytest.mark.parametrize("sampling", ["instant", "mean"])
def test_a_run_with_snapshots_gives_the_torque_of_a_plain_run(tmp_path, sampling) -> None:
    plain, pictured = small_sim(), small_sim()
    ref = plain.run(0.2, sampling=sampling, progress=False)
    rec = pictured.run(0.2, sampling=sampling, progress=False, snapshot_every=4,
                       snapshot_dir=tmp_path)
    assert np.array_equal(rec.time_s, ref.time_s)
    assert np.array_equal(rec.torque_Nm, ref.torque_Nm)
    for name in ("shell", "lifters", "ends"):
        assert np.array_equal(pictured.last_parts[name], plain.last_parts[name])
    assert np.array_equal(pictured.positions, plain.positions)
    assert len(collection(tmp_path / "particles.pvd")) == 5  # samples 4, 8, ..., 20


def test_snapshots_come_every_n_samples_with_their_times(tmp_path) -> None:
    """Snapshots at the samples k = 3, 6, ... of the record's time axis, continued by a second
    run; each at the step its sample was taken (within a step of t_k), the last one the state
    the run ends in."""
    sim = small_sim()
    sim.run(0.1, progress=False, snapshot_every=3, snapshot_dir=tmp_path)  # samples 1..10
    end_of_first = sim.positions.copy()
    sim.run(0.08, progress=False, snapshot_every=3, snapshot_dir=tmp_path)  # samples 11..18
    listed = collection(tmp_path / "particles.pvd")
    times = [t for t, _ in listed]
    assert np.allclose(times, 0.01 * np.arange(3, 19, 3), rtol=0, atol=sim.dt)
    assert sorted(p.name for p in tmp_path.glob("particles_*.vtu")) == [f for _, f in listed]
    drums = collection(tmp_path / "drum.pvd")
    assert [t for t, _ in drums] == times
    assert sorted(p.name for p in tmp_path.glob("drum_*.vtu")) == [f for _, f in drums]
    assert not list(tmp_path.glob(".*"))  # no temporary file left
    last = meshio.read(tmp_path / listed[-1][1])
    assert np.array_equal(last.points, sim.positions)  # sample 18 ends the second run
    ninth = meshio.read(tmp_path / listed[2][1])  # sample 9: before the end of the first run
    assert not np.array_equal(ninth.points, end_of_first)
    # one sample (and at most a step) apart: no particle moved farther than the engine's
    # speed guard lets it in that time
    moved = np.linalg.norm(ninth.points - end_of_first, axis=1)
    assert np.max(moved) <= sim._engine.max_speed * (0.01 + sim.dt)


def test_a_run_continued_from_a_checkpoint_goes_on_with_its_series(tmp_path) -> None:
    """The collections keep the snapshots up to the checkpoint's step and list those of the
    continuation after them, as the uninterrupted run did; a new simulation, or collections
    that cannot be read, start a new series."""
    folder = tmp_path / "vtk"
    sim = small_sim()
    sim.run(0.1, progress=False, snapshot_every=3, snapshot_dir=folder)  # samples 3, 6, 9
    sim.save(tmp_path / "case.ckpt")
    sim.run(0.06, progress=False, snapshot_every=3, snapshot_dir=folder)  # 12, 15
    whole = collection(folder / "particles.pvd")
    assert len(whole) == 5
    again = ms.Simulation.load(tmp_path / "case.ckpt")
    again.run(0.06, progress=False, snapshot_every=3, snapshot_dir=folder)
    assert collection(folder / "particles.pvd") == whole
    assert [f for _, f in collection(folder / "drum.pvd")] == [
        f.replace("particles", "drum") for _, f in whole]

    fresh = small_sim()
    fresh.run(0.05, progress=False, snapshot_every=3, snapshot_dir=folder)  # sample 3
    assert collection(folder / "particles.pvd") == whole[:1]  # same seed: the same state

    for damaged in ("<VTKFile type='Collection'><DataSet", "<a>" * 100_000, "\x00\xff", None):
        (folder / "particles.pvd").unlink()
        if damaged is None:  # a pipe: reading it would wait for ever
            os.mkfifo(folder / "particles.pvd")
        else:
            (folder / "particles.pvd").write_text(damaged)
        other = small_sim()
        other.run(0.02, progress=False)
        other.write_vtk(folder)
        assert collection(folder / "particles.pvd") == [(other.time, f"particles_"
                                                         f"{other._engine.step_count:09d}.vtu")]


@pytest.mark.parametrize("every", [0, -2, 1.5, True, "5"])
def test_a_bad_snapshot_interval_is_refused_before_any_work(tmp_path, every) -> None:
    sim = small_sim()
    with pytest.raises(ValueError, match=r"snapshot_every = .* is not valid; it must be an "
                                         r"integer >= 1"):
        sim.run(0.1, progress=False, snapshot_every=every, snapshot_dir=tmp_path / "v")
    assert sim.phase == "empty" and not (tmp_path / "v").exists()


def test_a_folder_that_cannot_be_written_is_refused_before_any_work(tmp_path) -> None:
    sim = small_sim()
    a_file = tmp_path / "taken.txt"
    a_file.write_text("not a folder")
    with pytest.raises(ValueError, match=r"snapshot_dir = .*taken.txt' is not valid; it must "
                                         r"be a writable folder \(it is a file\)"):
        sim.run(0.1, progress=False, snapshot_every=5, snapshot_dir=a_file)
    with pytest.raises(ValueError, match=r"snapshot_dir = .*taken.txt/sub' is not valid; it "
                                         r"must be a writable folder"):
        sim.run(0.1, progress=False, snapshot_every=5, snapshot_dir=a_file / "sub")
    with pytest.raises(ValueError, match=r"snapshot_dir = None is not valid; it must be a "
                                         r"writable folder when snapshot_every is given"):
        sim.run(0.1, progress=False, snapshot_every=5)
    with pytest.raises(ValueError, match=r"snapshot_every = None is not valid"):
        sim.run(0.1, progress=False, snapshot_dir=tmp_path)
    with pytest.raises(ValueError, match=r"snapshot_dir = '' is not valid; it must be a path"):
        sim.run(0.1, progress=False, snapshot_every=5, snapshot_dir="")
    with pytest.raises(ValueError, match=r"folder = .*taken.txt' is not valid"):
        sim.write_vtk(a_file)
    with pytest.raises(RuntimeError, match="the drum is empty; call fill"):
        sim.write_vtk(tmp_path)
    with pytest.raises(RuntimeError, match="the drum is empty; call fill"):
        plots.plot_charge(sim)
    assert sim.phase == "empty" and a_file.read_text() == "not a folder"


def test_a_snapshot_that_fails_warns_and_the_run_goes_on(tmp_path, monkeypatch) -> None:
    """A write error (disk full) stops the snapshots, not the run; the failed file is not
    left behind half written."""
    plain, pictured = small_sim(), small_sim()
    ref = plain.run(0.1, progress=False)

    def full_disk(path, mesh, file_format=None):
        Path(path).write_text("<VTKFile half")
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(meshio, "write", full_disk)
    with pytest.warns(RuntimeWarning, match="could not be written .* No space left"):
        rec = pictured.run(0.1, progress=False, snapshot_every=2, snapshot_dir=tmp_path)
    assert np.array_equal(rec.torque_Nm, ref.torque_Nm)
    assert list(tmp_path.iterdir()) == []


# -- the figure --------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def tiny_snapshot() -> snapshots.ChargeSnapshot:
    """The paper's LDMS#1 at the tiny scale, filled (no step run), with made-up velocities and
    a turned drum."""
    scene = ms.presets.pilot_mill(speed_fraction=0.71, particles="ceramic", load_level=1,
                                  scale="tiny")
    sim = ms.Simulation(scene, seed=0, threads=1)
    sim.fill()
    rng = np.random.default_rng(5)
    velocities = rng.normal(0.0, 0.8, (scene.n_particles, 3))
    return dataclasses.replace(sim.snapshot(), velocities=velocities, drum_angle=0.4,
                               omega=scene.omega, time_s=1.25)


def test_the_charge_figure_draws_every_particle_of_the_slab(tiny_snapshot) -> None:
    snap = tiny_snapshot
    fig = plots.plot_charge(snap)
    ax = fig.axes[0]
    particles = ax.collections[0]
    # the tiny slice is two ball diameters long: the default slab holds the whole charge
    assert len(particles.get_offsets()) == snap.scene.n_particles
    speeds = np.linalg.norm(snap.velocities, axis=1)
    assert np.array_equal(np.sort(particles.get_array()), np.sort(speeds))
    shell_speed = snap.omega * snap.scene.drum.radius
    assert particles.get_clim() == (0.0, max(speeds.max(), shell_speed))
    assert np.allclose(np.sort(particles.get_widths()), np.sort(2 * snap.radii))
    assert len(ax.patches) == 1 + snap.scene.drum.lifters.count
    assert "m/s" in fig.axes[1].get_ylabel()
    assert ax.get_title() == "LDMS#1: charge at t = 1.25 s"
    # the lifters drawn where the engine has them at the snapshot's angle
    for k, patch in enumerate(ax.patches[1:]):
        xy = patch.get_xy()[:4]
        assert np.allclose(xy, _drum_shape.lifter_outlines(snap.scene.drum, 0.4)[k])


def test_a_thin_slab_and_a_colour_scale(tiny_snapshot) -> None:
    snap = tiny_snapshot
    z = snap.positions[:, 2]
    fig = plots.plot_charge(snap, z_range=(0.02, 0.03), vmax=2.5)
    particles = fig.axes[0].collections[0]
    inside = (z >= 0.02) & (z <= 0.03)
    assert 0 < np.count_nonzero(inside) < len(z)
    assert len(particles.get_offsets()) == np.count_nonzero(inside)
    assert particles.get_clim() == (0.0, 2.5)
    for bad, message in (((0.03, 0.02), r"z_range\[1\] = 0.02 m is not valid"),
                         ((0.0, math.nan), r"z_range\[1\] = nan m is not valid"),
                         (0.02, r"z_range = 0.02 is not valid; it must be None or a pair")):
        with pytest.raises(ValueError, match=message):
            plots.plot_charge(snap, z_range=bad)
    with pytest.raises(ValueError, match=r"vmax = 0 m/s is not valid; it must be > 0"):
        plots.plot_charge(snap, vmax=0)


def test_the_figure_of_a_simulation_is_that_of_its_snapshot() -> None:
    sim = small_sim()
    sim.run(0.05, progress=False)
    a = plots.plot_charge(sim).axes[0].collections[0]
    b = plots.plot_charge(sim.snapshot()).axes[0].collections[0]
    assert np.array_equal(a.get_offsets(), b.get_offsets())
    assert np.array_equal(a.get_array(), b.get_array())

"""benchmarks/liggghts_state.py: a millscope state written for LIGGGHTS reads back the same, and
the materials file holds E = 2 G (1 + nu) and the scene's pair table; compare_liggghts.sh
refuses an unknown scene before any work."""

from __future__ import annotations

import importlib.util
import subprocess
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

import millscope as ms
from millscope import bench

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def liggghts_state():
    spec = importlib.util.spec_from_file_location("liggghts_state",
                                                  ROOT / "benchmarks" / "liggghts_state.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def state():
    """A filled tiny LDMS#1 with random velocities and spins: what data_file reads of a
    Simulation."""
    sim = ms.Simulation(ms.presets.pilot_mill(0.71, "ceramic", 1, scale="tiny"), seed=3,
                        threads=1)
    sim.fill()
    rng = np.random.default_rng(0)
    n = len(sim.positions)
    return SimpleNamespace(scene=sim.scene, positions=sim.positions, time=0.25, drum_angle=0.5,
                           velocities=rng.normal(size=(n, 3)), spins=rng.normal(size=(n, 3)))


def _sections(text: str) -> dict[str, np.ndarray]:
    lines = text.splitlines()
    out = {}
    for name in ("Atoms", "Velocities"):
        start = lines.index(name) + 2
        end = next((k for k in range(start, len(lines)) if not lines[k].strip()), len(lines))
        out[name] = np.array([[float(v) for v in line.split()] for line in lines[start:end]])
    return out


def test_data_file_reads_back_the_state(liggghts_state, state):
    n = len(state.positions)
    text = liggghts_state.data_file(state)
    assert f"{n} atoms" in text
    assert f"{len(state.scene.materials)} atom types" in text
    sec = _sections(text)
    atoms, vel = sec["Atoms"], sec["Velocities"]
    np.testing.assert_array_equal(atoms[:, 0], np.arange(1, n + 1))
    scene = state.scene
    np.testing.assert_array_equal(atoms[:, 1], scene.particle_materials() + 1)
    np.testing.assert_allclose(atoms[:, 2], 2.0 * scene.particle_radii(), rtol=1e-9)
    density = np.array([m.density for m in scene.materials])[scene.particle_materials()]
    np.testing.assert_allclose(atoms[:, 3], density, rtol=1e-9)
    # centred on the origin along z, as the yardstick's mesh
    shift = np.array([0.0, 0.0, 0.5 * scene.drum.length])
    np.testing.assert_allclose(atoms[:, 4:7], state.positions - shift, rtol=0, atol=1e-12)
    assert np.all(np.abs(atoms[:, 6]) < 0.5 * scene.drum.length)
    np.testing.assert_allclose(vel[:, 1:4], state.velocities, rtol=1e-11)
    np.testing.assert_allclose(vel[:, 4:7], state.spins, rtol=1e-11)


def test_materials_file_holds_youngs_modulus_and_the_pair_table(liggghts_state):
    scene = bench.build_scene("ceramic4", "paper")
    text = liggghts_state.materials_file(scene)
    rows = {line.split()[4]: [float(v) for v in line.split()[6:]]
            for line in text.splitlines() if line.startswith("fix")}
    young = [2.0 * m.shear_modulus * (1.0 + m.poisson) for m in scene.materials]
    np.testing.assert_allclose(rows["youngsModulus"], young, rtol=1e-9)
    np.testing.assert_allclose(rows["poissonsRatio"], [m.poisson for m in scene.materials])
    k = len(scene.materials)
    e = np.array(rows["coefficientRestitution"][1:]).reshape(k, k)
    mu = np.array(rows["coefficientFriction"][1:]).reshape(k, k)
    assert rows["coefficientRestitution"][0] == k
    for a, ma in enumerate(scene.materials):
        for b, mb in enumerate(scene.materials):
            assert e[a, b] == scene.pair(ma.name, mb.name).restitution
            assert mu[a, b] == scene.pair(ma.name, mb.name).friction
    # steel-steel of the yardstick: E 210.6 GPa, e 0.5, mu 0.15
    steel = scene.material_index("steel")
    assert rows["youngsModulus"][steel] == pytest.approx(210.6e9)
    assert (e[steel, steel], mu[steel, steel]) == (0.5, 0.15)


def test_another_drum_is_refused(liggghts_state):
    with pytest.raises(SystemExit, match="drum.lifters = None"):
        liggghts_state._check_geometry(bench.build_scene("no_lifters", "paper"))
    liggghts_state._check_geometry(bench.build_scene("ceramic4", "paper"))


def test_compare_script_refuses_an_unknown_scene():
    out = subprocess.run(["bash", str(ROOT / "benchmarks" / "compare_liggghts.sh"), "10", "2",
                          "pebbles"], capture_output=True, text=True, cwd=ROOT)
    assert out.returncode == 2
    assert "SCENE = 'pebbles' is not valid" in out.stderr
    assert "balls or ceramic4" in out.stderr
    assert "==" not in out.stdout  # refused before any run


@pytest.mark.parametrize(("repeat", "message"),
                         [("0", "REPEAT = 0 is not valid; it must be >= 1"),
                          ("two", "'two' is not a positive integer")])
def test_compare_script_refuses_a_bad_repeat(repeat: str, message: str):
    out = subprocess.run(["bash", str(ROOT / "benchmarks" / "compare_liggghts.sh"), "10", "2",
                          "balls", repeat], capture_output=True, text=True, cwd=ROOT)
    assert out.returncode == 2
    assert message in out.stderr
    assert "==" not in out.stdout  # refused before any run


def test_write_state_writes_the_three_files(liggghts_state, tmp_path):
    """The .vars file gives LIGGGHTS the state's dt, the rotation period 2 pi / omega and
    where lifter 0 is (the drum angle plus the lifters' phase, in degrees)."""
    scene = bench.build_scene("ceramic4", "paper")
    sim = SimpleNamespace(scene=scene, positions=np.zeros((scene.n_particles, 3)) + 0.1,
                          velocities=np.zeros((scene.n_particles, 3)),
                          spins=np.zeros((scene.n_particles, 3)), time=1.0, drum_angle=7.0,
                          dt=2.5e-6)
    path = liggghts_state.write_state(sim, tmp_path / "w", "s")
    assert sorted(p.name for p in (tmp_path / "w").iterdir()) == ["s.data", "s.vars",
                                                                  "s_materials.in"]
    values = dict(line.split("=") for line in path.read_text().split())
    assert float(values["dt"]) == 2.5e-6
    assert float(values["period"]) == pytest.approx(2 * np.pi / scene.omega, rel=1e-11)
    phase = np.degrees(7.0 + scene.drum.lifters.phase) % 360.0
    assert float(values["phase_deg"]) == pytest.approx(phase, abs=1e-8)
    assert values["mesh_type"] == "1"  # steel, the yardstick's mesh type
    assert int(values["particles"]) == scene.n_particles


def test_write_state_refuses_another_drum(liggghts_state, state, tmp_path):
    with pytest.raises(SystemExit, match="not the yardstick's drum"):
        liggghts_state.write_state(state, tmp_path, "s")  # the tiny slice, 5 cm long
    assert not any(tmp_path.iterdir())

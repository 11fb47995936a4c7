"""Every SIMD path of the engine's vector kernels (cpp/src/lane_kernels.cpp) against the others
on real scenes: the same torque record and the same state, to the bit.

The pilot mill at the "tiny" scale, balls alone and mixed ceramic particles and balls (LDMS#1),
with lifters and periodic ends and with end walls, settled, saved, then loaded and run
through the spin-up by each path the CPU runs (MILLSCOPE_SIMD, read when an engine is made),
without the energy ledger (the pair pass in lanes: the wide search and the law in lanes). The
paths compute every operation alike and unfused (-ffp-contract=off), so nothing may differ.
A path this CPU does not run is skipped.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

import millscope as ms
from millscope import _core

PATHS = ("portable", "avx2", "avx512")


def _scene(particles: str | None, end_walls: bool) -> ms.Scene:
    scene = ms.presets.pilot_mill(0.71, particles, 1, scale="tiny")
    if not end_walls:
        return scene
    return dataclasses.replace(scene, drum=dataclasses.replace(scene.drum, end_walls=True))


SCENES = {"balls periodic": _scene(None, False), "LDMS#1 periodic": _scene("ceramic", False),
          "balls end walls": _scene(None, True), "LDMS#1 end walls": _scene("ceramic", True)}


@pytest.fixture(scope="module")
def settled(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """Each scene filled and settled (loosely: the charge at rest within a few per cent of
    m g d, no less than 0.2 s), saved (the widest path: the state does not depend on it)."""
    folder = tmp_path_factory.mktemp("settled")
    out = {}
    for name, scene in SCENES.items():
        sim = ms.Simulation(scene, seed=5, threads=1, track_energy=False,
                            settle_tolerance=0.03, settle_min_s=0.2, settle_max_s=2.0)
        sim.settle(progress=False)
        out[name] = sim.save(folder / f"{name.replace(' ', '_')}.ckpt")
    return out


def _run(checkpoint: Path, path: str,
         monkeypatch: pytest.MonkeyPatch) -> tuple[np.ndarray, ms.Simulation]:
    monkeypatch.setenv("MILLSCOPE_SIMD", path)
    sim = ms.Simulation.load(checkpoint, threads=1)
    record = sim.run(duration=0.2, sample_dt=0.002, progress=False)
    return np.asarray(record.torque_Nm), sim


@pytest.mark.parametrize("path", [p for p in PATHS if p != "portable"])
@pytest.mark.parametrize("name", list(SCENES))
def test_a_wide_path_runs_as_the_portable_one_to_the_bit(
        settled: dict[str, Path], name: str, path: str, monkeypatch: pytest.MonkeyPatch) -> None:
    if path not in _core.simd_paths():
        pytest.skip(f"this CPU does not run the {path} path")
    torque, sim = _run(settled[name], path, monkeypatch)
    reference, portable = _run(settled[name], "portable", monkeypatch)
    assert sim._engine.simd == path and sim._engine.wide_pair_search
    assert portable._engine.simd == "portable" and not portable._engine.wide_pair_search
    assert np.abs(reference).max() > 0  # the charge works the drum
    assert np.array_equal(torque, reference)
    for field in ("positions", "velocities", "spins"):
        assert np.array_equal(getattr(sim, field), getattr(portable, field)), field


def test_a_path_the_cpu_lacks_is_refused_as_such_not_as_a_bad_checkpoint(
        settled: dict[str, Path], monkeypatch: pytest.MonkeyPatch) -> None:
    """MILLSCOPE_SIMD naming no path of this CPU: a ValueError that names the variable, from
    Simulation and from Simulation.load alike (not a CheckpointError: the file is fine)."""
    monkeypatch.setenv("MILLSCOPE_SIMD", "mmx")
    with pytest.raises(ValueError, match="MILLSCOPE_SIMD = 'mmx'") as raised:
        ms.Simulation.load(settled["balls periodic"], threads=1)
    assert not isinstance(raised.value, ms.CheckpointError)
    with pytest.raises(ValueError, match="MILLSCOPE_SIMD = 'mmx'"):
        ms.Simulation(SCENES["balls periodic"], threads=1)

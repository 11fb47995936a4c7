"""Scene descriptions and the paper's presets (Tables 1-5) against the paper's numbers."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

import millscope as ms
from millscope.presets import paper_cases, pilot_mill
from millscope.scene import Drum, Fraction, Lifters, Material, Pair, Scene


def test_paper_ball_filling_is_19_3_percent() -> None:
    # Table 1: 19.3 % of the mill volume; 2466 balls of 25 mm at bed porosity 0.45
    assert pilot_mill().bed_filling(0.45) == pytest.approx(0.193, abs=0.005)


def test_critical_speed_convention() -> None:
    scene = pilot_mill(0.71)
    assert scene.omega == pytest.approx(0.71 * math.sqrt(2 * 9.81 / (0.88 - 0.025)))
    assert scene.omega == pytest.approx(3.401142, rel=1e-6)  # the LIGGGHTS yardstick's value
    drum_conv = scene.replace(critical_speed_convention="drum")
    assert drum_conv.omega == pytest.approx(0.71 * math.sqrt(2 * 9.81 / 0.88))


@pytest.mark.parametrize("level", range(1, 8))
def test_table5_particle_counts(level: int) -> None:
    scene = pilot_mill(0.62, "ceramic", level)
    assert [f.count for f in scene.charge] == [2466, 4062 * level]
    assert scene.name == f"LDLS#{level}"


def test_pair_matrices_follow_table3() -> None:
    scene = pilot_mill(0.8, "ceramic", 2)
    e, mu = scene.pair_matrices()
    s, c = scene.material_index("steel"), scene.material_index("ceramic")
    assert np.array_equal(e, e.T) and np.array_equal(mu, mu.T)
    assert (e[s, s], mu[s, s], e[c, c], mu[c, c], e[s, c], mu[s, c]) == (
        0.5, 0.15, 0.3, 0.66, 0.2, 0.4)
    assert pilot_mill(0.8, "steel", 1).name == "HDHS#1"


def test_rayleigh_time_of_the_steel_ball() -> None:
    t, which = pilot_mill().min_rayleigh_time()
    assert t == pytest.approx(1.3217e-5, rel=1e-4)  # yardstick README
    assert which == "balls"


def test_full_matrix_has_42_cases() -> None:
    assert len(paper_cases()) == 42


@pytest.mark.parametrize("scale", ["paper", "small", "soft"])
def test_dict_round_trip(scale: str) -> None:
    scene = pilot_mill(0.71, "ceramic", 3, scale)
    assert Scene.from_dict(json.loads(json.dumps(scene.to_dict()))) == scene


def test_trapezoidal_lifters_need_a_top_width() -> None:
    with pytest.raises(ValueError, match="Lifters.top_width = None"):
        Lifters(16, 0.03, 0.02, profile="trapezoidal")
    assert Lifters(16, 0.03, 0.02, "trapezoidal", 0.02).cross_section == pytest.approx(0.0005)


STEEL = Material("steel", 7860, 81e9, 0.3)
DRUM = Drum(0.88, 0.315, "steel", True, Lifters(16, 0.03, 0.02))


@pytest.mark.parametrize("build, pattern", [
    (lambda: Fraction("steel", -0.01, 10), r"Fraction.diameter = -0.01 m is not valid"),
    (lambda: Pair("steel", "steel", 1.2, 0.1), r"Pair.restitution = 1.2 .*\(0, 1\]"),
    (lambda: Pair("steel", "steel", 0.5, -0.1), r"Pair.friction = -0.1 .*>= 0"),
    (lambda: Material("x", 7860, -1.0, 0.3), r"Material.shear_modulus = -1.0 Pa"),
    (lambda: Scene(DRUM, [Fraction("steel", 0.5, 1)], [STEEL], [Pair("steel", "steel", 0.5, 0.1)],
                   speed_fraction=0.7), r"gap between the lifter tips and the axis"),
    (lambda: Scene(DRUM, [Fraction("steel", 0.025, 30000)], [STEEL],
                   [Pair("steel", "steel", 0.5, 0.1)], speed_fraction=0.7),
     r"more charge than the drum holds"),
    (lambda: Scene(DRUM, [Fraction("steel", 0.025, 10)], [STEEL], [], speed_fraction=0.7),
     r"missing steel-steel"),
    (lambda: pilot_mill(0.71, "glass"), r"particles = 'glass' is not valid"),
    (lambda: pilot_mill(0.71, "ceramic", 8), r"load_level = 8 is not valid"),
    (lambda: pilot_mill(0.71, scale="huge"), r"scale = 'huge' is not valid"),
])
def test_bad_scenes_raise_clear_errors(build, pattern: str) -> None:  # type: ignore[no-untyped-def]
    with pytest.raises(ValueError, match=pattern):
        build()


def test_simulation_refuses_too_large_a_time_step() -> None:
    scene = pilot_mill(0.71, "ceramic", 1, "small")
    with pytest.raises(ValueError, match=r"dt = 0.01 s is not valid.*Rayleigh time .*'balls'"):
        ms.Simulation(scene, dt=0.01)

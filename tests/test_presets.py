"""The paper's pilot mill (Tables 1-5) and its reduced scales, against the paper's numbers."""

from __future__ import annotations

import json
import math
import re
from typing import Any

import numpy as np
import pytest

from millscope.presets import (
    SCALES,
    axial_slice,
    case_key,
    case_name,
    paper_cases,
    pilot_mill,
)
from millscope.scene import Scene

TABLE5_COUNTS = [4062, 8124, 12186, 16248, 20310, 24372, 28434]  # Table 5, as printed
SMALL_COUNTS = [645, 1290, 1934, 2579, 3224, 3869, 4513]  # round(n x 0.05 / 0.315)


# -- paper scale -----------------------------------------------------------------------------


def test_paper_mill_follows_table1() -> None:
    s = pilot_mill()
    d = s.drum
    assert (d.diameter, d.length, d.material, d.end_walls) == (0.880, 0.315, "steel", True)
    assert d.lifters is not None
    lift = d.lifters
    assert (lift.count, lift.width, lift.height, lift.profile, lift.phase) == (
        16,
        0.030,
        0.020,
        "rectangular",
        0.0,
    )
    (balls,) = s.charge
    assert (balls.name, balls.material, balls.count, balls.diameter) == (
        "balls",
        "steel",
        2466,
        0.025,
    )
    assert s.speed_fraction == 0.71 and s.critical_speed_convention == "ball"
    assert s.gravity == 9.81 and not s.clamp_normal_force


def test_paper_ball_filling_is_19_3_percent() -> None:
    # Table 1: balls take 19.3 % of the mill volume; bulk = solid / (1 - 0.45)
    s = pilot_mill()
    solid = 2466 * math.pi / 6 * 0.025**3
    assert s.bed_filling(0.45) == pytest.approx(solid / 0.55 / (math.pi * 0.44**2 * 0.315))
    assert 100 * s.bed_filling(0.45) == pytest.approx(19.3, abs=0.5)


def test_paper_materials_follow_table2() -> None:
    s = pilot_mill(0.71, "ceramic", 1)
    steel, ceramic = s.material("steel"), s.material("ceramic")
    assert (steel.density, steel.shear_modulus, steel.poisson) == (7860, 81e9, 0.3)
    assert (ceramic.density, ceramic.shear_modulus, ceramic.poisson) == (2800, 1.6e9, 0.22)
    assert s.charge[1].material == "ceramic" and s.charge[1].name == "particles"


def test_ceramic_pairs_follow_table3() -> None:
    s = pilot_mill(0.62, "ceramic", 4)
    e, mu = s.pair_matrices()
    i = {m.name: k for k, m in enumerate(s.materials)}
    table3 = {
        ("ceramic", "ceramic"): (0.3, 0.66),
        ("ceramic", "steel"): (0.2, 0.4),
        ("steel", "ceramic"): (0.2, 0.4),
        ("steel", "steel"): (0.5, 0.15),
    }
    for (a, b), (ee, mm) in table3.items():
        assert (e[i[a], i[b]], mu[i[a], i[b]]) == (ee, mm)
        assert (s.pair(a, b).restitution, s.pair(a, b).friction) == (ee, mm)


def test_steel_like_particles_are_steel_with_a_name_of_their_own() -> None:
    s = pilot_mill(0.71, "steel", 3)
    p, steel = s.material("steel_particle"), s.material("steel")
    assert (p.density, p.shear_modulus, p.poisson) == (
        steel.density,
        steel.shear_modulus,
        steel.poisson,
    )
    assert s.charge[1].material == "steel_particle"
    np.testing.assert_array_equal(s.particle_materials()[2466:], 1)
    e, mu = s.pair_matrices()
    np.testing.assert_array_equal(e, np.full((2, 2), 0.5))
    np.testing.assert_array_equal(mu, np.full((2, 2), 0.15))
    assert not s.single_material and pilot_mill().single_material


@pytest.mark.parametrize("particles", ["ceramic", "steel"])
@pytest.mark.parametrize("level", range(1, 8))
def test_table5_particle_counts(particles: str, level: int) -> None:
    s = pilot_mill(0.80, particles, level)
    assert [f.count for f in s.charge] == [2466, TABLE5_COUNTS[level - 1]]
    assert s.n_particles == 2466 + TABLE5_COUNTS[level - 1]
    assert s.charge[1].diameter == 0.012


@pytest.mark.parametrize("level", range(1, 8))
def test_12mm_particles_give_table5_particle_filling(level: int) -> None:
    """Table 5: particle filling = share of the resting ball bed's voids the particles fill,
    40 % per level. With 12 mm particles and both beds at porosity 0.45 this is
    v_particles / (0.45 v_balls) = 40.5 % per level: within 1.5 % of Table 5."""
    s = pilot_mill(0.71, "ceramic", level)
    v_balls, v_particles = (f.volume for f in s.charge)
    assert 100 * v_particles / (0.45 * v_balls) == pytest.approx(40 * level, rel=0.015)


def test_speeds_of_the_paper() -> None:
    for fraction in (0.62, 0.71, 0.80):
        s = pilot_mill(fraction)
        assert s.omega == pytest.approx(fraction * math.sqrt(2 * 9.81 / 0.855), rel=1e-12)
    assert pilot_mill(0.71).omega == pytest.approx(3.401142, abs=5e-7)  # LIGGGHTS yardstick


# -- names -----------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "args, name",
    [
        (("steel", 0.71, 3), "HDMS#3"),
        (("ceramic", 0.62, 7), "LDLS#7"),
        (("steel", 0.80, 1), "HDHS#1"),
        (("ceramic", 0.80, 5), "LDHS#5"),
        ((None, 0.71, 1), "balls-MS"),
        ((None, 0.62, 1), "balls-LS"),
        (("ceramic", 0.75, 2), "LD-75%#2"),
        (("steel", 0.905, 6), "HD-90.5%#6"),
        ((None, 0.75, 1), "balls-75%"),
    ],
)
def test_case_names(args: tuple[Any, float, int], name: str) -> None:
    assert case_name(*args) == name
    particles, speed, level = args
    assert pilot_mill(speed, particles, level).name == name


@pytest.mark.parametrize(
    "args, pattern",
    [
        (("glass", 0.71, 1), "particles = 'glass'"),
        (("steel", "fast", 1), "speed_fraction = 'fast'"),
        (("steel", 0.71, 0), "load_level = 0"),
    ],
)
def test_case_name_refuses_bad_arguments(args: tuple[Any, Any, Any], pattern: str) -> None:
    with pytest.raises(ValueError, match=pattern):
        case_name(*args)


# -- reduced scales --------------------------------------------------------------------------


@pytest.mark.parametrize("scale", ["paper", "tiny"])
def test_case_key_reads_particles_speed_and_level_back(scale: str) -> None:
    for scene in paper_cases(["ceramic", "steel", None], [0.62, 0.80], [2, 7], scale):
        key = case_key(scene)
        assert key.speed_fraction == scene.speed_fraction
        assert key.rotation_hz == scene.rotation_hz
        assert key.group == scene.name.split("#")[0]
        if key.particles is None:
            assert key.load_level is None and key.group.startswith("balls-")
        else:
            assert key.load_level == float(scene.name[-1])
            assert scene.name.startswith({"ceramic": "LD", "steel": "HD"}[key.particles])


def test_case_key_of_a_renamed_scene_counts_particles_per_ball() -> None:
    """Without the case code in its name, the level is the particle count per ball in units
    of the paper's 4062 / 2466: exact at paper scale, within the rounding of the slice's
    counts (645 particles, 391 balls at level 1) at the reduced scales."""
    paper = pilot_mill(0.71, "ceramic", 3).replace(name="mine")
    assert case_key(paper).load_level == pytest.approx(3.0, rel=1e-12)
    tiny = pilot_mill(0.71, "steel", 1, scale="tiny").replace(name="mine", speed_fraction=None,
                                                               speed_hz=0.5)
    key = case_key(tiny)
    assert key.load_level == pytest.approx(645 / 391 * 2466 / 4062, rel=1e-12)
    assert key.particles == "steel" and key.group == "HD-0.5Hz" and key.speed_fraction is None


def test_scales_are_documented() -> None:
    assert set(SCALES) == {"paper", "small", "tiny", "soft"}
    assert all(len(text) > 80 for text in SCALES.values())
    for word in ("0.05 m", "periodic", "0.05/0.315", "391", "x 0.01", "x 10"):
        assert word in SCALES["small"], word
    for word in ("0.05 m", "periodic", "x 0.001"):
        assert word in SCALES["tiny"], word
    assert "x 0.001" in SCALES["soft"] and "0.315" in SCALES["paper"]
    with pytest.raises(TypeError):
        SCALES["huge"] = "no global mutable state"  # type: ignore[index]


@pytest.mark.parametrize("scale, stiffness", [("small", 0.01), ("tiny", 0.001)])
@pytest.mark.parametrize("level", range(1, 8))
def test_slice_scales(scale: str, stiffness: float, level: int) -> None:
    paper = pilot_mill(0.71, "ceramic", level)
    s = pilot_mill(0.71, "ceramic", level, scale)
    assert (s.drum.length, s.drum.end_walls) == (0.05, False)
    assert [f.count for f in s.charge] == [391, SMALL_COUNTS[level - 1]]
    assert s.drum.diameter == 0.88 and s.drum.lifters == paper.drum.lifters
    assert [f.diameter for f in s.charge] == [0.025, 0.012]
    for m, m0 in zip(s.materials, paper.materials, strict=True):
        assert m.shear_modulus == pytest.approx(stiffness * m0.shear_modulus, rel=1e-12)
        assert (m.name, m.density, m.poisson) == (m0.name, m0.density, m0.poisson)
    assert s.pairs == paper.pairs and s.omega == paper.omega and s.name == paper.name
    t, t0 = s.min_rayleigh_time()[0], paper.min_rayleigh_time()[0]
    assert t / t0 == pytest.approx(1 / math.sqrt(stiffness), rel=1e-9)


def test_soft_scale_is_the_paper_mill_softened() -> None:
    paper, soft = pilot_mill(0.71, "steel", 2), pilot_mill(0.71, "steel", 2, "soft")
    assert soft.drum == paper.drum and [f.count for f in soft.charge] == [2466, 8124]
    assert [m.shear_modulus for m in soft.materials] == pytest.approx([81e6, 81e6])


def test_small_balls_only() -> None:
    s = pilot_mill(0.62, None, scale="small")
    assert [(f.name, f.count) for f in s.charge] == [("balls", 391)]
    assert s.name == "balls-LS"


@pytest.mark.parametrize("scale", sorted(SCALES))
@pytest.mark.parametrize("particles", [None, "ceramic", "steel"])
def test_presets_round_trip_through_json(scale: str, particles: str | None) -> None:
    s = pilot_mill(0.8, particles, 1 if particles is None else 5, scale)
    assert Scene.from_dict(json.loads(json.dumps(s.to_dict()))) == s


def test_presets_are_deterministic() -> None:
    assert pilot_mill(0.71, "steel", 4, "small") == pilot_mill(0.71, "steel", 4, "small")


def test_custom_diameters() -> None:
    s = pilot_mill(0.71, "ceramic", 2, particle_diameter=0.010, ball_diameter=0.030)
    assert [(f.diameter, f.count) for f in s.charge] == [(0.030, 2466), (0.010, 8124)]
    assert s.critical_speed_rad_s == pytest.approx(math.sqrt(2 * 9.81 / (0.88 - 0.030)))


# -- the case matrix -------------------------------------------------------------------------


def test_full_matrix_has_42_cases_in_order() -> None:
    cases = paper_cases()
    names = [s.name for s in cases]
    assert len(cases) == 42 and len(set(names)) == 42
    assert all(re.fullmatch(r"[LH]D[HML]S#[1-7]", n) for n in names)
    assert names[:8] == [
        "LDHS#1",
        "LDHS#2",
        "LDHS#3",
        "LDHS#4",
        "LDHS#5",
        "LDHS#6",
        "LDHS#7",
        "LDMS#1",
    ]
    assert names[-1] == "HDLS#7"


def test_part_of_the_matrix() -> None:
    # the example of docs/architecture.md, Public API
    cases = paper_cases(
        particles=["ceramic"], speed_fractions=[0.71], load_levels=[1, 2, 3, 4], scale="paper"
    )
    assert [s.name for s in cases] == ["LDMS#1", "LDMS#2", "LDMS#3", "LDMS#4"]
    one = paper_cases("steel", 0.62, np.int64(7), scale="small")
    assert [(s.name, s.drum.length) for s in one] == [("HDLS#7", 0.05)]
    assert len(paper_cases(load_levels=np.arange(1, 3))) == 12
    balls = paper_cases([None, "ceramic"], (0.8, 0.71), load_levels=[2, 3])
    assert [s.name for s in balls] == [
        "balls-HS",
        "balls-MS",
        "LDHS#2",
        "LDHS#3",
        "LDMS#2",
        "LDMS#3",
    ]


@pytest.mark.parametrize(
    "kwargs, pattern",
    [
        ({"particles": []}, "particles = .* must not be empty"),
        ({"speed_fractions": ()}, "speed_fractions"),
        ({"load_levels": range(0)}, "load_levels"),
        ({"particles": 3}, "particles = 3"),
        ({"load_levels": [1, 8]}, "load_level = 8"),
        ({"scale": "huge"}, "scale = 'huge'"),
    ],
)
def test_paper_cases_refuses_bad_arguments(kwargs: dict[str, Any], pattern: str) -> None:
    with pytest.raises(ValueError, match=pattern):
        paper_cases(**kwargs)


# -- bad arguments ---------------------------------------------------------------------------


@pytest.mark.parametrize(
    "kwargs, pattern",
    [
        ({"particles": "glass"}, r"particles = 'glass' is not valid.*'ceramic', 'steel' or None"),
        ({"particles": "LD"}, r"particles = 'LD' is not valid"),
        ({"particles": "ceramic", "load_level": 0}, r"load_level = 0 .*1\.\.7"),
        ({"particles": "ceramic", "load_level": 8}, r"load_level = 8 .*1\.\.7"),
        ({"particles": "ceramic", "load_level": 2.0}, r"load_level = 2\.0"),
        ({"particles": "ceramic", "load_level": True}, r"load_level = True"),
        ({"load_level": 2}, r"load_level = 2 is not valid without particles"),
        ({"scale": "huge"}, r"scale = 'huge' .*'paper', 'small', 'tiny', 'soft'"),
        ({"speed_fraction": 0.0}, r"speed_fraction = 0\.0 .*\(0, 3\]"),
        ({"speed_fraction": 3.5}, r"speed_fraction = 3\.5"),
        ({"speed_fraction": math.nan}, r"speed_fraction = nan"),
        ({"speed_fraction": "fast"}, r"speed_fraction = 'fast'"),
        ({"particles": "ceramic", "particle_diameter": 0.5}, r"Scene.charge\['particles'\]"),
        ({"ball_diameter": -0.025}, r"Fraction.diameter = -0.025 m"),
    ],
)
def test_pilot_mill_refuses_bad_arguments(kwargs: dict[str, Any], pattern: str) -> None:
    with pytest.raises(ValueError, match=pattern):
        pilot_mill(**kwargs)


# -- axial slices (benchmarks) ---------------------------------------------------------------


@pytest.mark.parametrize("n", [392, 10_000, 200_000, 800_000, 3_914_285])
def test_axial_slice_holds_n_balls_at_the_papers_filling(n: int) -> None:
    paper = pilot_mill(0.71, None, scale="paper")
    s = axial_slice(n, "paper")
    assert s.n_particles == n and s.drum.end_walls is False
    assert s.drum.length == pytest.approx(0.315 * n / 2466, rel=1e-12)
    # ball volume over drum volume: the paper's 2466 balls in 0.88 m x 0.315 m
    filling = n * math.pi / 6 * 0.025**3 / (math.pi * 0.44**2 * s.drum.length)
    assert filling == pytest.approx(2466 * math.pi / 6 * 0.025**3 / (math.pi * 0.44**2 * 0.315))
    assert (s.drum.diameter, s.drum.lifters, s.materials, s.pairs, s.speed_fraction) == (
        paper.drum.diameter,
        paper.drum.lifters,
        paper.materials,
        paper.pairs,
        0.71,
    )
    assert s.name == f"balls-MS slice {n}"


def test_axial_slice_takes_the_stiffness_of_its_scale() -> None:
    small = pilot_mill(0.71, None, scale="small")
    s = axial_slice(392, "small")
    assert s.materials == small.materials and s.pairs == small.pairs
    assert s.drum.length == pytest.approx(small.drum.length, rel=2e-3)
    assert axial_slice(392, "tiny").materials[0].shear_modulus == pytest.approx(81e6)


@pytest.mark.parametrize(
    ("args", "message"),
    [
        ((391, "paper"), "n_particles = 391 is not valid; it must be an integer in [392, "),
        # a period above Drum's longest, 500 m: 0.315 m x 3914286 / 2466 = 500.0001 m
        ((3_914_286, "paper"), "it must be an integer in [392, 3914285]"),
        ((1000.0, "paper"), "n_particles = 1000.0 is not valid"),
        ((1000, "huge"), "scale = 'huge' is not valid"),
    ],
)
def test_axial_slice_refuses_bad_arguments(args: tuple[object, str], message: str) -> None:
    with pytest.raises(ValueError, match=re.escape(message)):
        axial_slice(*args)  # type: ignore[arg-type]

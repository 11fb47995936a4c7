"""Scene and its parts: validation, derived quantities against hand formulas and the LIGGGHTS
yardstick's numbers, dict round trips."""

from __future__ import annotations

import dataclasses
import json
import math
import pickle
from collections.abc import Callable
from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import millscope as ms
from millscope.presets import pilot_mill
from millscope.scene import SCENE_FORMAT, Drum, Fraction, Lifters, Material, Pair, Scene

STEEL = Material("steel", 7860.0, 81e9, 0.3)
CERAMIC = Material("ceramic", 2800.0, 1.6e9, 0.22)
LIFTERS = Lifters(16, 0.030, 0.020)
DRUM = Drum(0.880, 0.315, "steel", True, LIFTERS)
BALLS = Fraction("steel", 0.025, 100, "balls")
SS = Pair("steel", "steel", 0.5, 0.15)
CC = Pair("ceramic", "ceramic", 0.3, 0.66)
CS = Pair("ceramic", "steel", 0.2, 0.4)


def scene(**changes: Any) -> Scene:
    """A small valid scene (100 steel balls in the pilot drum at 71 %), with changes."""
    args: dict[str, Any] = dict(
        drum=DRUM, charge=[BALLS], materials=[STEEL], pairs=[SS], speed_fraction=0.71
    )
    args.update(changes)
    return Scene(**args)


def two_material_scene(**changes: Any) -> Scene:
    args: dict[str, Any] = dict(
        charge=[BALLS, Fraction("ceramic", 0.012, 50, "particles")],
        materials=[STEEL, CERAMIC],
        pairs=[SS, CC, CS],
    )
    args.update(changes)
    return scene(**args)


# -- validation: one parametrized test per class; message names the field and the value -------

Case = tuple[Callable[[], object], str, str]


def _cases(*rows: Case) -> Any:
    return pytest.mark.parametrize(
        "build, field, value", rows, ids=[f"{r[1]}={r[2]}" for r in rows]
    )


def _check(build: Callable[[], object], field: str, value: str) -> None:
    with pytest.raises(ValueError) as info:
        build()
    message = str(info.value)
    assert field in message, message
    assert value in message, message
    assert "must" in message, message  # states what is valid


def test_error_message_format() -> None:
    with pytest.raises(ValueError) as info:
        Fraction("steel", -0.01, 10)
    assert str(info.value) == ("Fraction.diameter = -0.01 m is not valid; it must be in "
                               "[0.0001, 20] m")


@_cases(
    (lambda: Material("", 7860, 81e9, 0.3), "Material.name", "''"),
    (lambda: Material(3, 7860, 81e9, 0.3), "Material.name", "3"),
    (lambda: Material("s", 0, 81e9, 0.3), "Material.density", "0 "),
    (lambda: Material("s", -7860, 81e9, 0.3), "Material.density", "-7860 kg/m^3"),
    (lambda: Material("s", math.nan, 81e9, 0.3), "Material.density", "nan"),
    (lambda: Material("s", math.inf, 81e9, 0.3), "Material.density", "inf"),
    (lambda: Material("s", True, 81e9, 0.3), "Material.density", "True"),
    (lambda: Material("s", "7860", 81e9, 0.3), "Material.density", "'7860'"),
    (lambda: Material("s", 7860, -1.0, 0.3), "Material.shear_modulus", "-1.0 Pa"),
    (lambda: Material("s", 7860, 81e9, 0.5), "Material.poisson", "0.5"),
    (lambda: Material("s", 7860, 81e9, -1), "Material.poisson", "-1"),
    (lambda: Material("s", 7860, 81e9, None), "Material.poisson", "None"),
    (lambda: STEEL.with_shear_modulus(0), "factor", "0"),
)
def test_material_validation(build: Callable[[], object], field: str, value: str) -> None:
    _check(build, field, value)


@_cases(
    (lambda: Pair("", "steel", 0.5, 0.1), "Pair.a", "''"),
    (lambda: Pair("steel", None, 0.5, 0.1), "Pair.b", "None"),
    (lambda: Pair("steel", "steel", 0.0, 0.1), "Pair.restitution", "0.0"),
    (lambda: Pair("steel", "steel", 1.2, 0.1), "Pair.restitution", "1.2"),
    (lambda: Pair("steel", "steel", math.nan, 0.1), "Pair.restitution", "nan"),
    (lambda: Pair("steel", "steel", 0.5, -0.1), "Pair.friction", "-0.1"),
    (lambda: Pair("steel", "steel", 0.5, math.inf), "Pair.friction", "inf"),
    (lambda: Pair("steel", "steel", 0.5, False), "Pair.friction", "False"),
)
def test_pair_validation(build: Callable[[], object], field: str, value: str) -> None:
    _check(build, field, value)


@_cases(
    (lambda: Lifters(0, 0.03, 0.02), "Lifters.count", "0"),
    (lambda: Lifters(16.0, 0.03, 0.02), "Lifters.count", "16.0"),
    (lambda: Lifters(True, 0.03, 0.02), "Lifters.count", "True"),
    (lambda: Lifters(16, -0.03, 0.02), "Lifters.width", "-0.03 m"),
    (lambda: Lifters(16, 0.03, 0.0), "Lifters.height", "0.0 m"),
    (lambda: Lifters(16, 0.03, 0.02, "round"), "Lifters.profile", "'round'"),
    (lambda: Lifters(16, 0.03, 0.02, top_width=0.02), "Lifters.top_width", "0.02 m"),
    (lambda: Lifters(16, 0.03, 0.02, "trapezoidal"), "Lifters.top_width", "None"),
    (lambda: Lifters(16, 0.03, 0.02, "trapezoidal", 0.04), "Lifters.top_width", "0.04 m"),
    (lambda: Lifters(16, 0.03, 0.02, "trapezoidal", 0.0), "Lifters.top_width", "0.0 m"),
    (lambda: Lifters(16, 0.03, 0.02, phase=math.nan), "Lifters.phase", "nan"),
)
def test_lifters_validation(build: Callable[[], object], field: str, value: str) -> None:
    _check(build, field, value)


@_cases(
    (lambda: Drum(0.0, 0.315, "steel"), "Drum.diameter", "0.0 m"),
    (lambda: Drum(0.88, -0.315, "steel"), "Drum.length", "-0.315 m"),
    (lambda: Drum(0.88, 51.0, "steel"), "Drum.length", "51.0 m"),
    (lambda: Drum(0.88, 501.0, "steel", end_walls=False), "Drum.length", "501.0 m"),
    (lambda: Drum(0.88, 0.315, ""), "Drum.material", "''"),
    (lambda: Drum(0.88, 0.315, "steel", end_walls=1), "Drum.end_walls", "1"),
    (lambda: Drum(0.88, 0.315, "steel", lifters="16"), "Drum.lifters", "'16'"),
    (lambda: Drum(0.88, 0.315, "steel", lifters=Lifters(16, 0.03, 0.44)), "lifters.height", "0.44"),
    # 70 x 40 mm = 2.8 m > 2 pi (0.44 - 0.02) = 2.639 m
    (lambda: Drum(0.88, 0.315, "steel", lifters=Lifters(70, 0.04, 0.02)), "lifters.count", "70"),
)
def test_drum_validation(build: Callable[[], object], field: str, value: str) -> None:
    _check(build, field, value)


def test_a_periodic_drums_length_is_a_period_up_to_500_m_a_walled_ones_up_to_50_m() -> None:
    """A periodic drum is a slice of a longer mill: its length is the simulation's period (the
    linear-cost benchmark's 800 000-ball slice is 102 m), not a mill's."""
    assert Drum(0.88, 102.0, "steel", end_walls=False).length == 102.0
    assert Drum(0.88, 500.0, "steel", end_walls=False).length == 500.0
    assert Drum(0.88, 50.0, "steel").length == 50.0
    with pytest.raises(ValueError, match=r"Drum\.length = 102\.0 m is not valid; .*\(0, 50\]"):
        Drum(0.88, 102.0, "steel")
    with pytest.raises(ValueError, match=r"\(0, 500\] m"):
        Drum(0.88, 500.5, "steel", end_walls=False)


@_cases(
    (lambda: Fraction("", 0.025, 10), "Fraction.material", "''"),
    (lambda: Fraction("steel", -0.01, 10), "Fraction.diameter", "-0.01 m"),
    (lambda: Fraction("steel", math.inf, 10), "Fraction.diameter", "inf"),
    (lambda: Fraction("steel", 0.025, 0), "Fraction.count", "0"),
    (lambda: Fraction("steel", 0.025, 2.5), "Fraction.count", "2.5"),
    (lambda: Fraction("steel", 0.025, 10, name=5), "Fraction.name", "5"),
)
def test_fraction_validation(build: Callable[[], object], field: str, value: str) -> None:
    _check(build, field, value)


@_cases(
    (lambda: scene(drum="drum"), "Scene.drum", "'drum'"),
    (lambda: scene(charge=[]), "Scene.charge", "[]"),
    (lambda: scene(charge=["balls"]), "Scene.charge[0]", "'balls'"),
    (lambda: scene(charge=BALLS), "Scene.charge", "Fraction("),
    (lambda: scene(materials=[STEEL, "ceramic"]), "Scene.materials[1]", "'ceramic'"),
    (lambda: scene(materials=[STEEL, STEEL]), "Scene.materials", "'steel' repeats"),
    (lambda: scene(materials=[CERAMIC], pairs=[CC]), "Scene.drum.material", "'steel'"),
    (
        lambda: scene(charge=[Fraction("glass", 0.01, 5)]),
        "Scene.charge[0].material",
        "'glass'",
    ),
    (
        lambda: scene(charge=[BALLS, Fraction("steel", 0.01, 5, "balls")]),
        "Scene.charge names",
        "'balls' repeats",
    ),
    (lambda: scene(pairs=[SS, Pair("glass", "steel", 0.5, 0.1)]), "Scene.pairs", "'glass'"),
    (lambda: scene(pairs=[]), "Scene.pairs", "steel-steel"),
    (lambda: two_material_scene(pairs=[SS, CC]), "Scene.pairs", "ceramic-steel"),
    (
        lambda: two_material_scene(pairs=[SS, CC, CS, Pair("steel", "ceramic", 0.3, 0.3)]),
        "Scene.pairs",
        "ceramic-steel repeats",
    ),
    (lambda: scene(speed_fraction=None), "Scene.speed_fraction", "None"),
    (lambda: scene(speed_hz=0.5), "Scene.speed_hz", "0.5"),
    (lambda: scene(speed_fraction=0), "Scene.speed_fraction", "0"),
    (lambda: scene(speed_fraction=3.5), "Scene.speed_fraction", "3.5"),
    (lambda: scene(speed_fraction=math.nan), "Scene.speed_fraction", "nan"),
    (lambda: scene(speed_fraction=None, speed_hz=-0.1), "Scene.speed_hz", "-0.1 Hz"),
    (
        lambda: scene(critical_speed_convention="shell"),
        "Scene.critical_speed_convention",
        "'shell'",
    ),
    (lambda: scene(gravity=0.0), "Scene.gravity", "0.0 m/s^2"),
    (lambda: scene(clamp_normal_force="no"), "Scene.clamp_normal_force", "'no'"),
    (lambda: scene(name=None), "Scene.name", "None"),
    # 0.44 - 0.02 = 0.42 m between the lifter tips and the axis
    (
        lambda: scene(charge=[Fraction("steel", 0.42, 1, "boulder")]),
        "Scene.charge['boulder'].diameter",
        "0.42 m",
    ),
    (
        lambda: scene(drum=Drum(0.88, 0.02, "steel", True, LIFTERS)),
        "Scene.charge['balls'].diameter",
        "0.025 m",
    ),
    (
        lambda: scene(drum=Drum(0.88, 0.049, "steel", False, LIFTERS)),
        "Scene.charge['balls'].diameter",
        "periodic",
    ),
    # 0.64 x (0.19158 - 0.00302) m^3 = 0.1207 m^3 < 15000 x 8.18e-6 m^3 = 0.1227 m^3
    (
        lambda: scene(charge=[Fraction("steel", 0.025, 15000)]),
        "Scene.charge",
        "more charge than the drum holds",
    ),
)
def test_scene_validation(build: Callable[[], object], field: str, value: str) -> None:
    _check(build, field, value)


def test_overfill_message_gives_the_numbers() -> None:
    with pytest.raises(ValueError, match=r"0\.1227 m\^3 of solid .* <= 0\.1207 m\^3"):
        scene(charge=[Fraction("steel", 0.025, 15000)])
    scene(charge=[Fraction("steel", 0.025, 14700)])  # 0.1203 m^3: fits


def test_periodic_slice_may_be_exactly_two_diameters_long() -> None:
    assert scene(drum=Drum(0.88, 0.05, "steel", False, LIFTERS)).drum.length == 0.05


# -- coercion, immutability ------------------------------------------------------------------


def test_numbers_are_coerced_to_python_types() -> None:
    m = Material(np.str_("steel"), np.int64(7860), 81_000_000_000, np.float32(0.25))
    assert type(m.density) is float and type(m.shear_modulus) is float
    assert m.poisson == 0.25 and type(m.poisson) is float
    f = Fraction("steel", np.float64(0.025), np.int64(10))
    assert type(f.diameter) is float and type(f.count) is int
    lift = Lifters(np.int32(16), 0.03, 0.02)
    assert type(lift.count) is int and type(lift.phase) is float
    d = Drum(1, 1, "steel", end_walls=np.bool_(False))
    assert d.end_walls is False and type(d.diameter) is float
    s = scene(speed_fraction=np.float64(0.5), charge=(f,))
    assert type(s.speed_fraction) is float
    json.dumps(s.to_dict())  # no numpy scalars left


def test_error_messages_print_numpy_numbers_plainly() -> None:
    with pytest.raises(ValueError, match=r"^Fraction.diameter = -0.5 m is not valid"):
        Fraction("steel", np.float64(-0.5), 1)


def test_objects_are_frozen() -> None:
    s = scene()
    with pytest.raises(dataclasses.FrozenInstanceError):
        s.name = "x"  # type: ignore[misc]
    with pytest.raises(dataclasses.FrozenInstanceError):
        STEEL.density = 1.0  # type: ignore[misc]


def test_sequences_are_stored_as_tuples() -> None:
    s = scene(charge=(f for f in [BALLS]), materials=[STEEL], pairs=[SS])
    assert s.charge == (BALLS,) and isinstance(s.materials, tuple) and isinstance(s.pairs, tuple)
    assert s == scene(charge=(BALLS,), materials=(STEEL,), pairs=(SS,))


def test_fraction_name_defaults_to_the_material() -> None:
    assert Fraction("ceramic", 0.012, 5).name == "ceramic"
    assert Fraction("ceramic", 0.012, 5, "particles").name == "particles"


# -- parts -----------------------------------------------------------------------------------


def test_youngs_modulus_and_reduced_stiffness() -> None:
    assert STEEL.youngs_modulus == pytest.approx(210.6e9, rel=1e-12)  # yardstick README
    soft = STEEL.with_shear_modulus(0.01)
    assert soft.shear_modulus == pytest.approx(0.81e9, rel=1e-12)
    assert (soft.name, soft.density, soft.poisson) == ("steel", 7860.0, 0.3)
    assert STEEL.shear_modulus == 81e9  # the original is untouched


def test_lifter_shapes() -> None:
    assert LIFTERS.tip_width == 0.03 and LIFTERS.top_width is None
    assert LIFTERS.cross_section == pytest.approx(0.03 * 0.02)
    trap = Lifters(16, 0.03, 0.02, "trapezoidal", 0.01, phase=0.1)
    assert trap.tip_width == 0.01
    assert trap.cross_section == pytest.approx(0.5 * (0.03 + 0.01) * 0.02)


def test_drum_volumes() -> None:
    assert DRUM.radius == 0.44
    assert DRUM.volume == pytest.approx(math.pi * 0.44**2 * 0.315)
    assert DRUM.volume == pytest.approx(0.1915869, rel=1e-6)
    assert DRUM.lifter_volume == pytest.approx(16 * 0.030 * 0.020 * 0.315)
    assert DRUM.free_volume == pytest.approx(DRUM.volume - 0.003024)
    assert DRUM.tip_radius == pytest.approx(0.42)
    bare = Drum(0.88, 0.315, "steel")
    assert bare.lifter_volume == 0.0 and bare.free_volume == bare.volume


def test_fraction_volume() -> None:
    assert BALLS.radius == 0.0125
    assert BALLS.volume == pytest.approx(100 * 4 / 3 * math.pi * 0.0125**3)


# -- scene quantities ------------------------------------------------------------------------


def test_charge_arrays_follow_the_charge_order() -> None:
    s = two_material_scene(materials=[CERAMIC, STEEL])
    assert s.n_particles == 150
    assert (s.max_diameter, s.min_diameter) == (0.025, 0.012)
    r = s.particle_radii()
    assert r.dtype == np.float64 and r.shape == (150,)
    assert np.all(r[:100] == 0.0125) and np.all(r[100:] == 0.006)
    m = s.particle_materials()
    assert m.dtype == np.int32 and m.shape == (150,)
    assert np.all(m[:100] == 1) and np.all(m[100:] == 0)  # steel is materials[1]


def test_charge_mass_and_volume_by_hand() -> None:
    s = two_material_scene()
    v_balls = 100 * math.pi / 6 * 0.025**3
    v_part = 50 * math.pi / 6 * 0.012**3
    assert s.charge_volume() == pytest.approx(v_balls + v_part)
    assert s.charge_mass() == pytest.approx(7860 * v_balls + 2800 * v_part)
    assert s.bed_filling(0.4) == pytest.approx((v_balls + v_part) / 0.6 / DRUM.volume)
    assert s.bed_filling(0.0) == pytest.approx((v_balls + v_part) / DRUM.volume)


@pytest.mark.parametrize("porosity", [-0.1, 1.0, math.nan, "0.4"])
def test_bed_filling_refuses_bad_porosity(porosity: Any) -> None:
    with pytest.raises(ValueError, match="porosity"):
        scene().bed_filling(porosity)


def test_material_lookup() -> None:
    s = two_material_scene()
    assert s.material_index("steel") == 0 and s.material_index("ceramic") == 1
    assert s.material("ceramic") is CERAMIC
    with pytest.raises(ValueError, match=r"'glass' is not in this scene.*'ceramic', 'steel'"):
        s.material("glass")
    with pytest.raises(ValueError, match="'glass'"):
        s.material_index("glass")
    assert s.used_materials() == ["steel", "ceramic"]


def test_pair_lookup_is_order_independent() -> None:
    s = two_material_scene()
    assert s.pair("steel", "ceramic") is CS and s.pair("ceramic", "steel") is CS
    assert s.pair("steel", "steel") is SS
    with pytest.raises(ValueError, match="no Pair for materials 'steel' and 'glass'"):
        s.pair("steel", "glass")


def test_pair_matrices_are_symmetric_and_follow_table3() -> None:
    s = two_material_scene(materials=[CERAMIC, STEEL], pairs=[CS, SS, CC])
    e, mu = s.pair_matrices()
    assert e.dtype == mu.dtype == np.float64 and e.shape == mu.shape == (2, 2)
    np.testing.assert_array_equal(e, e.T)
    np.testing.assert_array_equal(mu, mu.T)
    # rows/columns: ceramic, steel (Table 3)
    np.testing.assert_array_equal(e, [[0.3, 0.2], [0.2, 0.5]])
    np.testing.assert_array_equal(mu, [[0.66, 0.4], [0.4, 0.15]])


def test_unused_materials_need_no_pairs() -> None:
    s = scene(materials=[STEEL, CERAMIC])  # ceramic declared, not used: no ceramic pairs needed
    e, mu = s.pair_matrices()
    np.testing.assert_array_equal(e, [[0.5, 1.0], [1.0, 1.0]])
    np.testing.assert_array_equal(mu, [[0.15, 0.0], [0.0, 0.0]])
    assert s.single_material


def test_friction_and_single_material_flags() -> None:
    assert scene().has_friction and scene().single_material
    assert not two_material_scene().single_material
    frictionless = Pair("steel", "steel", 0.5, 0.0)
    assert not scene(pairs=[frictionless]).has_friction
    # friction only between materials that nothing uses does not count
    unused = scene(materials=[STEEL, CERAMIC], pairs=[frictionless, CC])
    assert not unused.has_friction


# -- speed -----------------------------------------------------------------------------------


def test_critical_speed_ball_convention() -> None:
    s = scene()  # D = 0.88 m, d_max = 0.025 m, 71 %
    assert s.critical_speed_rad_s == pytest.approx(math.sqrt(2 * 9.81 / (0.88 - 0.025)))
    assert s.omega == pytest.approx(0.71 * math.sqrt(2 * 9.81 / 0.855), rel=1e-12)
    assert s.omega == pytest.approx(3.401142, abs=5e-7)  # the LIGGGHTS yardstick's omega
    assert s.rotation_hz == pytest.approx(s.omega / (2 * math.pi))
    # this convention puts the LTH at 8.66 Hz (the paper reports 8.8): docs/physics.md, Critical
    # speed and the lifter harmonic
    assert 16 * s.rotation_hz == pytest.approx(8.66, abs=0.005)


def test_critical_speed_drum_convention_and_gravity() -> None:
    s = scene(critical_speed_convention="drum", gravity=9.80665, speed_fraction=0.8)
    assert s.critical_speed_rad_s == pytest.approx(math.sqrt(2 * 9.80665 / 0.88))
    assert s.omega == pytest.approx(0.8 * math.sqrt(2 * 9.80665 / 0.88))


def test_speed_in_hz() -> None:
    s = scene(speed_fraction=None, speed_hz=0.5)
    assert s.omega == pytest.approx(math.pi) and s.rotation_hz == pytest.approx(0.5)
    rest = scene(speed_fraction=None, speed_hz=0)
    assert rest.omega == 0.0 and rest.rotation_hz == 0.0


# -- Rayleigh time ---------------------------------------------------------------------------


def rayleigh_by_hand(d: float, rho: float, g: float, nu: float) -> float:
    return math.pi * (d / 2) * math.sqrt(rho / g) / (0.1631 * nu + 0.8766)


def test_rayleigh_time_of_the_steel_ball() -> None:
    t, which = scene().min_rayleigh_time()
    assert t == pytest.approx(1.3217e-5, rel=5e-5)  # yardstick README
    assert which == "balls"


def test_rayleigh_times_per_fraction() -> None:
    s = two_material_scene()
    (n1, t1), (n2, t2) = s.rayleigh_times()
    assert (n1, n2) == ("balls", "particles")
    assert t1 == pytest.approx(rayleigh_by_hand(0.025, 7860, 81e9, 0.3), rel=1e-12)
    assert t2 == pytest.approx(rayleigh_by_hand(0.012, 2800, 1.6e9, 0.22), rel=1e-12)
    assert s.min_rayleigh_time() == (t1, "balls")  # 1.32e-5 s < 2.73e-5 s
    stiff = two_material_scene(charge=[BALLS, Fraction("steel", 0.012, 50, "particles")])
    assert stiff.min_rayleigh_time()[1] == "particles"  # smaller steel spheres


# -- dicts, copies, pickling -----------------------------------------------------------------


def full_scene() -> Scene:
    """Every field away from its default."""
    return Scene(
        drum=Drum(1.2, 0.4, "liner", True, Lifters(8, 0.05, 0.04, "trapezoidal", 0.03, 0.2)),
        charge=[BALLS, Fraction("ceramic", 0.012, 50)],
        materials=[STEEL, CERAMIC, Material("liner", 1200, 2e8, 0.45)],
        pairs=[
            SS,
            CC,
            CS,
            Pair("liner", "liner", 0.9, 0.0),
            Pair("liner", "steel", 0.6, 0.3),
            Pair("ceramic", "liner", 0.4, 0.5),
        ],
        speed_hz=0.4,
        critical_speed_convention="drum",
        gravity=9.80665,
        clamp_normal_force=True,
        name="everything",
    )


def test_to_dict_is_plain_json() -> None:
    d = full_scene().to_dict()
    assert d["format"] == SCENE_FORMAT == "millscope-scene-1"
    text = json.dumps(d, allow_nan=False)
    assert json.loads(text) == d
    assert d["drum"]["lifters"]["top_width"] == 0.03
    assert d["charge"][1] == {
        "material": "ceramic",
        "diameter": 0.012,
        "count": 50,
        "name": "ceramic",
    }
    assert "_index" not in d


@pytest.mark.parametrize("make", [scene, two_material_scene, full_scene])
def test_dict_round_trip(make: Callable[[], Scene]) -> None:
    s = make()
    assert Scene.from_dict(s.to_dict()) == s
    assert Scene.from_dict(json.loads(json.dumps(s.to_dict()))) == s


def test_from_dict_fills_defaults() -> None:
    d = {
        "format": SCENE_FORMAT,
        "drum": {"diameter": 0.88, "length": 0.315, "material": "steel"},
        "charge": [{"material": "steel", "diameter": 0.025, "count": 100, "name": "balls"}],
        "materials": [{"name": "steel", "density": 7860, "shear_modulus": 81e9, "poisson": 0.3}],
        "pairs": [{"a": "steel", "b": "steel", "restitution": 0.5, "friction": 0.15}],
        "speed_fraction": 0.71,
    }
    assert Scene.from_dict(d) == scene(drum=Drum(0.88, 0.315, "steel"))


def _mutated(path: tuple[Any, ...], value: Any) -> dict[str, Any]:
    d = scene().to_dict()
    target = d
    for key in path[:-1]:
        target = target[key]
    if value is KeyError:
        del target[path[-1]]
    else:
        target[path[-1]] = value
    return d


@pytest.mark.parametrize(
    "d, pattern",
    [
        ([], r"needs a mapping"),
        (_mutated(("format",), "millscope-scene-2"), r"format = 'millscope-scene-2'.*'millscope"),
        (_mutated(("format",), KeyError), r"format = None"),
        (_mutated(("drum",), KeyError), r"scene lacks the keys \['drum'\]"),
        (_mutated(("colour",), "red"), r"scene has unknown keys \['colour'\]"),
        (_mutated(("drum", "lifters", "hight"), 0.02), r"\['drum'\]\['lifters'\] has unknown"),
        (_mutated(("charge", 0, "count"), KeyError), r"\['charge'\]\[0\] lacks the keys"),
        (_mutated(("charge",), {"a": 1}), r"scene\['charge'\] must be a list"),
        (_mutated(("materials", 0), "steel"), r"\['materials'\]\[0\] must be a mapping"),
        (_mutated(("charge", 0, "count"), -3), r"Fraction.count = -3"),
        (_mutated(("speed_fraction",), 5.0), r"Scene.speed_fraction = 5.0"),
    ],
)
def test_from_dict_refuses_bad_dicts(d: Any, pattern: str) -> None:
    with pytest.raises(ValueError, match=pattern):
        Scene.from_dict(d)


def test_replace_validates_again() -> None:
    s = scene()
    faster = s.replace(speed_fraction=0.8, name="fast")
    assert (faster.speed_fraction, faster.name, s.speed_fraction) == (0.8, "fast", 0.71)
    assert faster.material_index("steel") == 0
    with pytest.raises(ValueError, match="Scene.speed_fraction = -1"):
        s.replace(speed_fraction=-1)


def test_pickle_and_hash() -> None:
    s = full_scene()
    again = pickle.loads(pickle.dumps(s))
    assert again == s and hash(again) == hash(s)
    assert again.material_index("liner") == 2
    assert len({s, again, scene()}) == 2


def test_describe() -> None:
    text = pilot_mill(0.71, "ceramic", 2).describe()
    for part in [
        "LDMS#2",
        "drum 0.88 m x 0.315 m (steel)",
        "16 rectangular lifters 30 mm wide x 20 mm high",
        "end walls",
        "balls: 2466 x 25 mm steel",
        "particles: 8124 x 12 mm ceramic",
        "71.0 % of critical",
        "0.5413 Hz",
        "smallest Rayleigh time 1.322e-05 s (balls)",
    ]:
        assert part in text, (part, text)
    assert "periodic ends" in pilot_mill(scale="small").describe()
    assert "0.0 % of critical" in scene(speed_fraction=None, speed_hz=0).describe()


# -- property: random valid scenes survive the JSON round trip ---------------------------------


@st.composite
def scenes(draw: st.DrawFn) -> Scene:
    n_mat = draw(st.integers(1, 3))
    materials = [
        Material(
            f"m{k}",
            draw(st.floats(100, 2e4)),
            draw(st.floats(1e6, 1e12)),
            draw(st.floats(-0.99, 0.49)),
        )
        for k in range(n_mat)
    ]
    pairs = [
        Pair(f"m{i}", f"m{j}", draw(st.floats(0.01, 1.0)), draw(st.floats(0.0, 2.0)))
        for i in range(n_mat)
        for j in range(i, n_mat)
    ]
    lifters = draw(
        st.none()
        | st.builds(
            Lifters,
            st.integers(1, 20),
            st.floats(0.005, 0.05),
            st.floats(0.005, 0.05),
            st.just("rectangular"),
            st.none(),
            st.floats(-7, 7),
        )
    )
    drum = Drum(
        draw(st.floats(0.5, 2.0)), draw(st.floats(0.1, 1.0)), "m0", draw(st.booleans()), lifters
    )
    charge = [
        Fraction(
            f"m{draw(st.integers(0, n_mat - 1))}",
            draw(st.floats(0.001, 0.04)),
            draw(st.integers(1, 200)),
            f"f{k}",
        )
        for k in range(draw(st.integers(1, 3)))
    ]
    in_hz = draw(st.booleans())
    s = Scene(
        drum,
        charge,
        materials,
        pairs,
        speed_fraction=draw(st.floats(0.01, 3.0)),
        critical_speed_convention=draw(st.sampled_from(["ball", "drum"])),
        gravity=draw(st.floats(0.1, 30.0)),
        clamp_normal_force=draw(st.booleans()),
        name=draw(st.text(max_size=8)),
    )
    # speed_hz goes up to 3 x the critical speed, which depends on the drum and gravity drawn
    return s.replace(speed_fraction=None, speed_hz=s.rotation_hz) if in_hz else s


@settings(max_examples=60, deadline=None)
@given(scenes())
def test_random_scenes_round_trip_through_json(s: Scene) -> None:
    again = Scene.from_dict(json.loads(json.dumps(s.to_dict())))
    assert again == s
    e, mu = again.pair_matrices()
    np.testing.assert_array_equal(e, e.T)
    assert again.particle_radii().shape == again.particle_materials().shape == (s.n_particles,)


# -- with the engine -------------------------------------------------------------------------


def test_simulation_refuses_too_large_a_time_step() -> None:
    s = pilot_mill(0.71, "ceramic", 1, "small")
    with pytest.raises(ValueError, match=r"dt = 0.01 s is not valid.*Rayleigh time .*'balls'"):
        ms.Simulation(s, dt=0.01)

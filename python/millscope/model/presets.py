"""The paper's pilot mill and its case matrix (paper Tables 1-5; docs/physics.md).

:func:`pilot_mill` builds one case, :func:`paper_cases` the Table 4 x Table 5 matrix or part
of it, :func:`axial_slice` a periodic slice of the balls-only mill with a given ball count (for
benchmarks). Case names follow the paper (:func:`case_name`): HD/LD (steel-like/ceramic-like
particles), HS/MS/LS (80/71/62 % of critical), #1..#7 (load level), e.g. ``"LDMS#3"``;
``"balls-MS"`` for balls only; other speeds as a percentage, e.g. ``"LD-75%#2"``.

Scales (:data:`SCALES` says exactly what each changes):

* ``"paper"``: the paper's mill as published.
* ``"small"``: a 0.05 m axial slice with periodic ends, counts scaled to the slice, every
  shear modulus x 0.01; for quick looks at a case (3 simulated seconds of a level-1 case:
  about 35 s on 2 cores).
* ``"tiny"``: the small slice with every shear modulus x 0.001; for the main job
  (``millscope demo``: LDMS #1-#4 in about 10 minutes of CPU, 5 on 2 free cores) and unit
  tests.
* ``"soft"``: the paper's whole mill with every shear modulus x 0.001; for tests of
  whole-mill behaviour (lifter harmonic, mean torque).
"""

from __future__ import annotations

import dataclasses
import math
import re
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from numbers import Integral, Real
from types import MappingProxyType
from typing import Any

from .scene import (
    MAX_PERIOD_LENGTH,
    MAX_SPEED_FRACTION,
    Drum,
    Fraction,
    Lifters,
    Material,
    Pair,
    Scene,
)

__all__ = [
    "BALL_COUNT",
    "BALL_DIAMETER",
    "LOAD_LEVELS",
    "PAPER_SPEEDS",
    "PARTICLES_PER_LEVEL",
    "PARTICLE_DIAMETER",
    "SCALES",
    "SCALE_BIAS",
    "SLICE_MAX_BALLS",
    "SLICE_MIN_BALLS",
    "ScaleBias",
    "CaseKey",
    "axial_slice",
    "case_key",
    "case_name",
    "measured_bias",
    "paper_cases",
    "pilot_mill",
]

# Table 1: the mill
DRUM_DIAMETER = 0.880  # m, inner
DRUM_LENGTH = 0.315  # m, inner
LIFTER_COUNT = 16
LIFTER_WIDTH = 0.030  # m
LIFTER_HEIGHT = 0.020  # m
BALL_COUNT = 2466
BALL_DIAMETER = 0.025  # m: not in the paper; gives the 19.3 % ball filling at porosity 0.45
PARTICLE_DIAMETER = 0.012  # m: not in the paper; gives Table 5's 40 % particle filling per level
PARTICLES_PER_LEVEL = 4062  # Table 5: load level #k has k x 4062 particles
LOAD_LEVELS = range(1, 8)  # Table 5: #1..#7
PAPER_SPEEDS: Mapping[float, str] = MappingProxyType({0.80: "HS", 0.71: "MS", 0.62: "LS"})

# Table 2: materials; Table 3: (restitution, friction)
STEEL = Material("steel", density=7860.0, shear_modulus=81e9, poisson=0.3)
CERAMIC = Material("ceramic", density=2800.0, shear_modulus=1.6e9, poisson=0.22)
STEEL_PARTICLE = "steel_particle"  # steel-like (HD) particles: steel's properties, own name
STEEL_STEEL = (0.5, 0.15)
CERAMIC_CERAMIC = (0.3, 0.66)
CERAMIC_STEEL = (0.2, 0.4)
PARTICLE_KINDS: Mapping[str, str] = MappingProxyType({"ceramic": "LD", "steel": "HD"})

# Reduced scales
SMALL_LENGTH = 0.05  # m: an axial slice two ball diameters long, periodic ends
SMALL_STIFFNESS = 0.01  # "small": every shear modulus x this (Rayleigh time x 10)
TINY_STIFFNESS = 0.001  # "tiny": every shear modulus x this (Rayleigh time x 31.6)
SOFT_STIFFNESS = 0.001  # "soft": every shear modulus x this
# axial_slice: the fewest balls, so that the slice is >= 2 ball diameters long (Scene's rule
# for periodic ends) at the paper's 2466 balls per 0.315 m
SLICE_MIN_BALLS = math.ceil(2.0 * BALL_DIAMETER * BALL_COUNT / DRUM_LENGTH)
# ... and the most, so that its period is at most Drum's MAX_PERIOD_LENGTH
SLICE_MAX_BALLS = math.floor(MAX_PERIOD_LENGTH * BALL_COUNT / DRUM_LENGTH)


@dataclass(frozen=True)
class _Scale:
    length: float  # m
    end_walls: bool
    stiffness: float  # factor on every shear modulus


_SCALES = MappingProxyType(
    {
        "paper": _Scale(DRUM_LENGTH, True, 1.0),
        "small": _Scale(SMALL_LENGTH, False, SMALL_STIFFNESS),
        "tiny": _Scale(SMALL_LENGTH, False, TINY_STIFFNESS),
        "soft": _Scale(DRUM_LENGTH, True, SOFT_STIFFNESS),
    }
)
_SLICE_COUNTS = (
    f"ball and particle counts scaled by {SMALL_LENGTH}/{DRUM_LENGTH} and rounded to the "
    f"nearest integer ({round(BALL_COUNT * SMALL_LENGTH / DRUM_LENGTH)} balls; "
    f"round({PARTICLES_PER_LEVEL} x level x {SMALL_LENGTH}/{DRUM_LENGTH}) particles)"
)

SCALES: Mapping[str, str] = MappingProxyType(
    {
        "paper": (
            f"The paper's pilot mill (Tables 1-5): drum {DRUM_DIAMETER} m x {DRUM_LENGTH} m, "
            f"steel, flat end walls, {LIFTER_COUNT} rectangular lifters "
            f"{LIFTER_WIDTH * 1e3:g} mm wide x {LIFTER_HEIGHT * 1e3:g} mm high; {BALL_COUNT} "
            f"steel balls of {BALL_DIAMETER * 1e3:g} mm; {PARTICLES_PER_LEVEL} x level "
            f"particles of {PARTICLE_DIAMETER * 1e3:g} mm; the moduli of Table 2 (steel "
            f"G = 81 GPa, ceramic 1.6 GPa)."
        ),
        "small": (
            f"A thin axial slice of the pilot mill, {SMALL_LENGTH} m long with periodic ends "
            f"(no end walls); {_SLICE_COUNTS}; every shear modulus x {SMALL_STIFFNESS} "
            f"(Rayleigh time and default dt x {1 / math.sqrt(SMALL_STIFFNESS):.3g}). Drum "
            "diameter, lifters, sphere diameters, densities, Poisson ratios, restitution, "
            "friction and speeds as at paper scale. For quick looks at a case (notebook 01): "
            "3 simulated seconds, filling and settling included, took about 35 s on 2 cores "
            "at load level 1 and about 3.5 min at level 7."
        ),
        "tiny": (
            f"The small slice ({SMALL_LENGTH} m, periodic ends, {_SLICE_COUNTS}) with every "
            f"shear modulus x {TINY_STIFFNESS} (Rayleigh time and default dt "
            f"x {1 / math.sqrt(TINY_STIFFNESS):.3g}); everything else as at paper scale. "
            "Overlaps reach several % of the radius. For the main job (millscope demo: "
            "LDMS #1-#4, 1036 to 2970 particles, 8 s of rotation each: about 10 minutes of "
            "CPU, 5 on 2 free cores), the notebooks under test and unit tests. Cost: about "
            "8 ms of one core per particle and simulated second (LDMS #1-#4 for 14.7 s "
            "each, settling included: 16 minutes of CPU)."
        ),
        "soft": (
            f"The paper's whole mill and charge unchanged except every shear modulus "
            f"x {SOFT_STIFFNESS} (steel 81 MPa; Rayleigh time and default dt "
            f"x {1 / math.sqrt(SOFT_STIFFNESS):.3g}): for tests of whole-mill behaviour. "
            "Overlaps reach several % of the radius; the balls-only mean torque reads 3.6 % "
            "less than at the paper's stiffness, the spectral energy 88 % less (SCALE_BIAS)."
        ),
    }
)


@dataclass(frozen=True)
class ScaleBias:
    """What a paper-scale study measured for a scale and a case: the relative error of the
    seed mean against the paper's stiffness on the whole drum (dt 0.2 Rayleigh times, 4 s
    warm-up, a 10 s block of instantaneous 10 ms samples), with its standard error from the
    seeds.

    Torques are compared per length of drum and energies per length of drum and of block
    (:mod:`millscope.campaign.studies`); fractions, e.g. -0.85 for 85 % less.

    Attributes
    ----------
    case : str
        The case measured, e.g. ``"balls-MS"`` or ``"LDMS#4"`` (71 % of critical speed).
    seeds : int
        Seeds behind each mean.
    mean_torque, mean_torque_se : float
        Mean drive torque: error and its standard error.
    energy, energy_se : float
        Spectral energy with the mean and the LTH removed (eq. 11): error and its standard
        error.
    per_unit_energy, per_unit_energy_se : float or None
        For a level of a ladder (e.g. LDMS#4 of the study of LDMS #1 and #4): error of the
        per-unit energy, the level's energy over the first level's (the quantity the fill
        estimate reads), and its standard error; None where not measured.
    """

    case: str
    seeds: int
    mean_torque: float
    mean_torque_se: float
    energy: float
    energy_se: float
    per_unit_energy: float | None = None
    per_unit_energy_se: float | None = None

    def __post_init__(self) -> None:
        if (self.per_unit_energy is None) != (self.per_unit_energy_se is None):
            raise ValueError("ScaleBias.per_unit_energy and per_unit_energy_se must be given "
                             "together or not at all")

    def figures(self) -> str:
        """The errors ± their standard errors, e.g. ``"mean torque -7.3 % ± 0.7 %, spectral
        energy -89 % ± 4 %"``."""
        per_unit = ""
        if self.per_unit_energy is not None and self.per_unit_energy_se is not None:
            per_unit = (f", per-unit energy {100 * self.per_unit_energy:+.0f} % ± "
                        f"{100 * self.per_unit_energy_se:.0f} %")
        return (f"mean torque {100 * self.mean_torque:+.1f} % ± {100 * self.mean_torque_se:.1f} "
                f"%, spectral energy {100 * self.energy:+.0f} % ± {100 * self.energy_se:.0f} %"
                f"{per_unit}")

    def describe(self) -> str:
        """One sentence, e.g. for a report."""
        return (f"the paper-scale study measured, for {self.case} with {self.seeds} seeds, "
                f"{self.figures()} against the paper's stiffness on the whole drum (per unit "
                "of drum length)")


#: The bias of each scale, per case, that the paper-scale studies measured (the committed
#: studies data/study-paper-balls for balls-MS and data/study-paper-ldms for LDMS #1 and #4;
#: ``millscope report <study>`` remakes their tables, and a test checks these figures against
#: them). ``SCALE_BIAS[scale][case]``; a scale or case not listed was not measured. Most of
#: the energy bias comes from the softened contacts; the slice adds to it at LDMS (at the
#: paper's stiffness it reads 38 % and 46 % less energy at LDMS #1 and #4, and the whole
#: drum's within its noise for balls-MS).
SCALE_BIAS: Mapping[str, Mapping[str, ScaleBias]] = MappingProxyType({
    "tiny": MappingProxyType({
        "balls-MS": ScaleBias("balls-MS", 3, -0.060, 0.015, -0.851, 0.096),
        "LDMS#1": ScaleBias("LDMS#1", 3, -0.073, 0.007, -0.888, 0.040),
        "LDMS#4": ScaleBias("LDMS#4", 3, -0.101, 0.004, -0.912, 0.084, -0.192, 0.175),
    }),
    "soft": MappingProxyType({
        "balls-MS": ScaleBias("balls-MS", 3, -0.036, 0.006, -0.879, 0.096),
        "LDMS#1": ScaleBias("LDMS#1", 3, -0.040, 0.006, -0.879, 0.039),
        "LDMS#4": ScaleBias("LDMS#4", 3, -0.035, 0.003, -0.891, 0.082, -0.091, 0.087),
    }),
})


def measured_bias(scale: str, group: str) -> tuple[ScaleBias, ...]:
    """The biases :data:`SCALE_BIAS` holds for ``scale`` and the cases of ``group``.

    Parameters
    ----------
    scale : str
        One of :data:`SCALES`.
    group : str
        A case's name without its load level, e.g. ``"LDMS"`` or ``"balls-MS"``.

    Returns
    -------
    tuple of ScaleBias
        In load-level order; empty where the studies did not measure the scale or the group.
    """
    found = SCALE_BIAS.get(_scale(scale, "scale"), {})
    return tuple(found[c] for c in sorted(found) if c.partition("#")[0] == group)


def _speed(value: object, where: str) -> float:
    if (
        not isinstance(value, Real)
        or isinstance(value, bool)
        or not 0.0 < float(value) <= MAX_SPEED_FRACTION
    ):
        raise ValueError(
            f"{where} = {value!r} is not valid; it must be a number in "
            f"(0, {MAX_SPEED_FRACTION:g}] (a fraction of the critical speed; the paper's are "
            "0.62, 0.71, 0.80)"
        )
    return float(value)


def _particles(value: object, where: str) -> str | None:
    if value is not None and (not isinstance(value, str) or value not in PARTICLE_KINDS):
        raise ValueError(
            f"{where} = {value!r} is not valid; it must be one of "
            f"{', '.join(repr(k) for k in PARTICLE_KINDS)} or None (balls only)"
        )
    return value


def _scale(value: object, where: str) -> str:
    if not isinstance(value, str) or value not in _SCALES:
        raise ValueError(
            f"{where} = {value!r} is not valid; it must be one of "
            f"{', '.join(repr(k) for k in _SCALES)}"
        )
    return value


def _level(value: object, where: str) -> int:
    if not isinstance(value, Integral) or isinstance(value, bool) or value not in LOAD_LEVELS:
        raise ValueError(
            f"{where} = {value!r} is not valid; it must be an integer in 1..7 (paper Table 5)"
        )
    return int(value)


def case_name(particles: str | None, speed_fraction: float, load_level: int = 1) -> str:
    """The paper's code of a case (Table 4).

    Parameters
    ----------
    particles : {"ceramic", "steel"} or None
        LD (ceramic-like) or HD (steel-like) particles, or None for balls only.
    speed_fraction : float
        Fraction of critical speed: 0.80, 0.71, 0.62 give HS, MS, LS; others a percentage.
    load_level : int
        Table 5's level 1..7; not part of the name for balls only.

    Returns
    -------
    str
        E.g. ``"HDMS#3"``, ``"LDLS#7"``, ``"balls-MS"``, ``"LD-75%#2"``, ``"balls-75%"``.
    """
    kind = _particles(particles, "case_name particles")
    speed = _speed(speed_fraction, "case_name speed_fraction")
    level = _level(load_level, "case_name load_level")
    code = PAPER_SPEEDS.get(round(speed, 6))
    if kind is None:
        return f"balls-{code}" if code else f"balls-{speed * 100:g}%"
    prefix = PARTICLE_KINDS[kind]
    return f"{prefix}{code}#{level}" if code else f"{prefix}-{speed * 100:g}%#{level}"


_LEVEL_IN_NAME = re.compile(r"#(\d+)$")
_MATERIAL_KINDS: Mapping[str, str] = MappingProxyType({"ceramic": "ceramic",
                                                      STEEL_PARTICLE: "steel"})


@dataclass(frozen=True)
class CaseKey:
    """What a campaign's analysis groups a case by (:func:`case_key`).

    Attributes
    ----------
    particles : str or None
        "ceramic" (LD), "steel" (HD), another material's name, or None (balls only).
    speed_fraction : float or None
        Fraction of critical speed (None when the scene gives its speed in Hz).
    rotation_hz : float
        Rotation frequency, Hz.
    load_level : float or None
        Table 5's level (particle filling in units of 40 %); None for balls only.
    group : str
        The case code without its level, e.g. ``"LDMS"``, ``"HD-75%"``, ``"balls-MS"``.
    """

    particles: str | None
    speed_fraction: float | None
    rotation_hz: float
    load_level: float | None
    group: str


def case_key(scene: Scene) -> CaseKey:
    """The particles, speed and load level of a scene, as :func:`pilot_mill` built it.

    The particles are the material of the fraction named "particles" ("ceramic" stays
    "ceramic", "steel_particle" reads "steel"); without such a fraction the case is balls
    only. The load level is the ``#k`` that ends the scene's name (:func:`case_name`);
    a scene named otherwise gets the ratio of its particle count to its ball count in units
    of the paper's, 4062 / 2466 per level (exact at paper scale, within 1 % at the reduced
    scales whose counts are rounded).

    Parameters
    ----------
    scene : Scene

    Returns
    -------
    CaseKey
    """
    by_name = {f.name: f for f in scene.charge}
    particles = by_name.get("particles")
    speed = scene.speed_fraction
    if particles is None:
        kind, level = None, None
    else:
        kind = _MATERIAL_KINDS.get(particles.material, particles.material)
        match = _LEVEL_IN_NAME.search(scene.name)
        balls = by_name.get("balls")
        if match is not None:
            level = float(match.group(1))
        elif balls is not None:
            level = particles.count / balls.count * BALL_COUNT / PARTICLES_PER_LEVEL
        else:
            level = None
    if speed is not None and (kind is None or kind in PARTICLE_KINDS):
        group = case_name(kind, speed).split("#")[0]
    else:
        prefix = "balls" if kind is None else PARTICLE_KINDS.get(kind, kind)
        group = (f"{prefix}-{speed * 100:g}%" if speed is not None
                 else f"{prefix}-{scene.rotation_hz:.4g}Hz")
    return CaseKey(kind, speed, scene.rotation_hz, level, group)


def pilot_mill(
    speed_fraction: float = 0.71,
    particles: str | None = None,
    load_level: int = 1,
    scale: str = "paper",
    *,
    particle_diameter: float = PARTICLE_DIAMETER,
    ball_diameter: float = BALL_DIAMETER,
) -> Scene:
    """One case of the paper's pilot mill, named with its code (:func:`case_name`).

    Drum 0.880 m x 0.315 m of steel with flat end walls and 16 rectangular lifters 30 mm wide
    x 20 mm high (phase 0); 2466 steel balls of 25 mm (fraction "balls"); optionally
    4062 x ``load_level`` particles of 12 mm (fraction "particles"). Materials "steel"
    (7860 kg/m^3, G 81 GPa, nu 0.3), "ceramic" (2800 kg/m^3, G 1.6 GPa, nu 0.22) and, for
    steel-like particles, "steel_particle" with steel's properties. Pairs (e, mu):
    steel-steel 0.5, 0.15; ceramic-ceramic 0.3, 0.66; ceramic-steel 0.2, 0.4; steel_particle
    with itself and with steel as steel-steel.

    Parameters
    ----------
    speed_fraction : float
        Rotation speed as a fraction of critical (ball convention), in (0, 3]; the paper's
        are 0.62, 0.71, 0.80.
    particles : {"ceramic", "steel"} or None
        Ceramic-like (LD) or steel-like (HD) particles to grind, or None for balls only.
    load_level : int
        Table 5's level 1..7; with ``particles=None`` it must stay 1.
    scale : {"paper", "small", "tiny", "soft"}
        ``"paper"``: as above. ``"small"``: a 0.05 m slice with periodic ends, counts x
        0.05/0.315 rounded (391 balls; 645 particles per level at level 1), every shear
        modulus x 0.01. ``"tiny"``: the small slice with every shear modulus x 0.001.
        ``"soft"``: the paper's mill with every shear modulus x 0.001. :data:`SCALES` has
        the full descriptions.
    particle_diameter, ball_diameter : float
        Sphere diameters, m: 12 mm and 25 mm by default (neither is given in the paper).

    Returns
    -------
    Scene
    """
    scale = _scale(scale, "scale")
    kind = _particles(particles, "particles")
    level = _level(load_level, "load_level")
    if kind is None and level != 1:
        raise ValueError(
            f"load_level = {level} is not valid without particles; leave it at 1 or choose "
            "particles='ceramic' or 'steel'"
        )
    speed = _speed(speed_fraction, "speed_fraction")
    return _build(speed, kind, level, _SCALES[scale], particle_diameter, ball_diameter)


def axial_slice(n_particles: int, scale: str = "paper", speed_fraction: float = 0.71) -> Scene:
    """The balls-only pilot mill as a periodic axial slice holding ``n_particles`` balls.

    The slice is built exactly as the ``"small"`` scale builds its slice (periodic ends, no end
    walls, the ball count scaled with the length), but its length is chosen so that
    ``n_particles`` balls of 25 mm sit at the paper's filling: 2466 balls per 0.315 m of drum,
    so the length is 0.315 m x n_particles / 2466 (0.05 m hold 391 balls, 1.277 m hold
    10 000). Everything across the axis (drum diameter, lifters, materials, restitution,
    friction) is the paper's. For the linear-cost check of the engine: the work per
    particle-step should not grow with the particle count.

    Parameters
    ----------
    n_particles : int
        Number of balls, in [392, 3 914 285]: the slice must be at least two ball diameters,
        0.05 m, long so that a ball meets at most one periodic image of another, and at most
        500 m long (Drum's longest period).
    scale : {"paper", "small", "tiny", "soft"}
        Sets only the stiffness: every shear modulus x 1 ("paper"), x 0.01 ("small") or
        x 0.001 ("tiny", "soft"); see :data:`SCALES`. The length is always the one above.
    speed_fraction : float
        Rotation speed as a fraction of critical (ball convention), in (0, 3].

    Returns
    -------
    Scene
        Named ``"balls-MS slice N"`` (the case code, then the ball count).
    """
    scale = _scale(scale, "scale")
    if (
        not isinstance(n_particles, Integral)
        or isinstance(n_particles, bool)
        or not SLICE_MIN_BALLS <= n_particles <= SLICE_MAX_BALLS
    ):
        raise ValueError(
            f"n_particles = {n_particles!r} is not valid; it must be an integer in "
            f"[{SLICE_MIN_BALLS}, {SLICE_MAX_BALLS}] (a periodic slice from two ball "
            f"diameters, {2 * BALL_DIAMETER:g} m, to {MAX_PERIOD_LENGTH:g} m long)"
        )
    speed = _speed(speed_fraction, "speed_fraction")
    length = DRUM_LENGTH * int(n_particles) / BALL_COUNT
    sc = dataclasses.replace(_SCALES[scale], length=length, end_walls=False)
    scene = _build(speed, None, 1, sc, PARTICLE_DIAMETER, BALL_DIAMETER)
    return dataclasses.replace(scene, name=f"{scene.name} slice {n_particles}")


def _build(
    speed: float,
    kind: str | None,
    level: int,
    sc: _Scale,
    particle_diameter: float,
    ball_diameter: float,
) -> Scene:
    """The pilot mill at a scale: drum length and ends from ``sc``, counts scaled with the
    length, every shear modulus x ``sc.stiffness``. Arguments are already validated."""
    share = sc.length / DRUM_LENGTH

    steel = STEEL.with_shear_modulus(sc.stiffness)
    materials = [steel]
    pairs = [Pair("steel", "steel", *STEEL_STEEL)]
    charge = [Fraction("steel", ball_diameter, round(BALL_COUNT * share), "balls")]
    if kind is not None:
        if kind == "ceramic":
            mat = CERAMIC.with_shear_modulus(sc.stiffness)
            pairs += [
                Pair("ceramic", "ceramic", *CERAMIC_CERAMIC),
                Pair("ceramic", "steel", *CERAMIC_STEEL),
            ]
        else:
            mat = Material(STEEL_PARTICLE, steel.density, steel.shear_modulus, steel.poisson)
            pairs += [
                Pair(STEEL_PARTICLE, STEEL_PARTICLE, *STEEL_STEEL),
                Pair(STEEL_PARTICLE, "steel", *STEEL_STEEL),
            ]
        materials.append(mat)
        count = round(PARTICLES_PER_LEVEL * level * share)
        charge.append(Fraction(mat.name, particle_diameter, count, "particles"))
    drum = Drum(
        DRUM_DIAMETER,
        sc.length,
        "steel",
        end_walls=sc.end_walls,
        lifters=Lifters(LIFTER_COUNT, LIFTER_WIDTH, LIFTER_HEIGHT),
    )
    return Scene(
        drum=drum,
        charge=tuple(charge),
        materials=tuple(materials),
        pairs=tuple(pairs),
        speed_fraction=speed,
        name=case_name(kind, speed, level),
    )


def paper_cases(
    particles: str | None | Iterable[str | None] = ("ceramic", "steel"),
    speed_fractions: float | Iterable[float] = (0.80, 0.71, 0.62),
    load_levels: int | Iterable[int] = LOAD_LEVELS,
    scale: str = "paper",
) -> list[Scene]:
    """The Table 4 x Table 5 matrix (2 x 3 x 7 = 42 cases), or the part asked for.

    Parameters
    ----------
    particles : str, None or iterable of them
        "ceramic" (LD), "steel" (HD), None (balls only: one case per speed, whatever the
        load levels).
    speed_fractions : float or iterable of float
        Fractions of critical speed.
    load_levels : int or iterable of int
        Table 5's levels, 1..7.
    scale : str
        See :data:`SCALES`.

    Returns
    -------
    list of Scene
        Ordered by particles, then speed, then load level, as given.
    """
    kinds = _as_list(particles, "particles", (str, type(None)))
    speeds = _as_list(speed_fractions, "speed_fractions", (Real,))
    levels = _as_list(load_levels, "load_levels", (Integral,))
    out = []
    for kind in kinds:
        for speed in speeds:
            if kind is None:
                out.append(pilot_mill(speed, None, 1, scale))
            else:
                out.extend(pilot_mill(speed, kind, level, scale) for level in levels)
    return out


def _as_list(value: object, where: str, single: tuple[type, ...]) -> list[Any]:
    items = [value] if isinstance(value, single) else value
    if not isinstance(items, Iterable):
        raise ValueError(f"paper_cases {where} = {value!r} is not valid; it must be an iterable")
    out = list(items)
    if not out:
        raise ValueError(f"paper_cases {where} = {value!r} is not valid; it must not be empty")
    return out

"""The paper's pilot mill and its case matrix (paper Tables 1-5; DESIGN.md section 3).

:func:`pilot_mill` builds one case, :func:`paper_cases` the Table 4 x Table 5 matrix or part
of it. Case names follow the paper: HD/LD (steel-like/ceramic-like particles), HS/MS/LS
(80/71/62 % of critical), #1..#7 (load level), e.g. ``"LDMS#3"``.

Scales (:data:`SCALES` says what each changes):

* ``"paper"``: the paper's mill as published.
* ``"small"``: a thin axial slice with periodic ends and softer materials, for demos.
* ``"soft"``: the paper's mill with every shear modulus x 0.001, for tests of whole-mill
  behaviour (lifter harmonic, mean torque) at 1/32 of the steps.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence

from .scene import Drum, Fraction, Lifters, Material, Pair, Scene

__all__ = ["PAPER_SPEEDS", "SCALES", "paper_cases", "pilot_mill"]

# Table 1: the mill
DRUM_DIAMETER = 0.880  # m
DRUM_LENGTH = 0.315  # m
LIFTER_COUNT = 16
LIFTER_WIDTH = 0.030  # m
LIFTER_HEIGHT = 0.020  # m
BALL_COUNT = 2466
BALL_DIAMETER = 0.025  # m: gives the 19.3 % ball filling at a bed porosity of about 0.45
PARTICLE_DIAMETER = 0.012  # m: not in the paper, an assumption (DESIGN.md section 3)
PARTICLES_PER_LEVEL = 4062  # Table 5: level #k has k x 4062 particles
LOAD_LEVELS = range(1, 8)
PAPER_SPEEDS = {0.80: "HS", 0.71: "MS", 0.62: "LS"}  # Table 4

# Table 2: materials; Table 3: restitution and friction
STEEL = Material("steel", density=7860.0, shear_modulus=81e9, poisson=0.3)
CERAMIC = Material("ceramic", density=2800.0, shear_modulus=1.6e9, poisson=0.22)
STEEL_STEEL = (0.5, 0.15)
CERAMIC_CERAMIC = (0.3, 0.66)
CERAMIC_STEEL = (0.2, 0.4)
PARTICLE_KINDS = {"ceramic": "LD", "steel": "HD"}

# Reduced scales
SMALL_LENGTH = 0.05  # m: two ball diameters, periodic
SMALL_STIFFNESS = 0.01  # shear moduli x this
SOFT_STIFFNESS = 0.001

SCALES: dict[str, str] = {
    "paper": (
        "The paper's pilot mill: drum 0.880 m x 0.315 m with flat steel end walls, 16 lifters "
        "30 x 20 mm, 2466 steel balls of 25 mm, 4062 x level particles of 12 mm, the moduli of "
        "Table 2 (steel G = 81 GPa, ceramic 1.6 GPa)."),
    "small": (
        f"A thin axial slice of the pilot mill, {SMALL_LENGTH} m long with periodic ends (no end "
        f"walls); ball and particle counts scaled by {SMALL_LENGTH}/{DRUM_LENGTH} and rounded; "
        f"every shear modulus x {SMALL_STIFFNESS} (Rayleigh time and default dt x 10, overlaps "
        "a few % of the radius). Same diameters, speeds, restitution and friction."),
    "soft": (
        f"The paper's mill and charge unchanged except every shear modulus x {SOFT_STIFFNESS} "
        "(steel 81 MPa; Rayleigh time and default dt x 31.6): for tests of the whole mill. "
        "Overlaps reach several % of the radius; the balls-only mean torque stays within a few "
        "% of the paper-scale value."),
}


def _scale_numbers(scale: str) -> tuple[float, bool, float]:
    """(drum length m, end walls, shear-modulus factor) of a scale."""
    if scale == "paper":
        return DRUM_LENGTH, True, 1.0
    if scale == "small":
        return SMALL_LENGTH, False, SMALL_STIFFNESS
    if scale == "soft":
        return DRUM_LENGTH, True, SOFT_STIFFNESS
    raise ValueError(f"scale = {scale!r} is not valid; it must be one of {sorted(SCALES)}")


def case_name(particles: str | None, speed_fraction: float, load_level: int) -> str:
    """The paper's code of a case: "HDMS#3", "LDLS#7"; "balls-MS" without particles; speeds
    off the paper's three as a percentage ("LD-75%#2")."""
    speed = PAPER_SPEEDS.get(round(speed_fraction, 6))
    if particles is None:
        return f"balls-{speed}" if speed else f"balls-{speed_fraction * 100:g}%"
    kind = PARTICLE_KINDS[particles]
    return f"{kind}{speed}#{load_level}" if speed else \
        f"{kind}-{speed_fraction * 100:g}%#{load_level}"


def pilot_mill(speed_fraction: float = 0.71, particles: str | None = None, load_level: int = 1,
               scale: str = "paper", *, particle_diameter: float = PARTICLE_DIAMETER,
               ball_diameter: float = BALL_DIAMETER) -> Scene:
    """One case of the paper's pilot mill.

    Parameters
    ----------
    speed_fraction : float
        Rotation speed as a fraction of critical, in (0, 3]; the paper's are 0.62, 0.71, 0.80.
    particles : {"ceramic", "steel"} or None
        Ceramic-like (LD) or steel-like (HD) particles to grind, or None for balls only.
    load_level : int
        Table 5's level #1..#7 (4062 x level particles at paper scale); only with particles.
    scale : {"paper", "small", "soft"}
        See :data:`SCALES`.
    particle_diameter, ball_diameter : float
        m; 12 mm and 25 mm by default.
    """
    length, end_walls, stiffness = _scale_numbers(scale)
    if particles is not None and particles not in PARTICLE_KINDS:
        raise ValueError(f"particles = {particles!r} is not valid; it must be one of "
                         f"{sorted(PARTICLE_KINDS)} or None (balls only)")
    if isinstance(load_level, bool) or not isinstance(load_level, int) or \
            load_level not in LOAD_LEVELS:
        raise ValueError(f"load_level = {load_level!r} is not valid; it must be an integer in "
                         "1..7 (paper Table 5)")
    if particles is None and load_level != 1:
        raise ValueError(f"load_level = {load_level} is not valid without particles; leave it "
                         "at 1 or choose particles='ceramic' or 'steel'")
    share = length / DRUM_LENGTH

    steel = STEEL.with_shear_modulus(stiffness) if stiffness != 1.0 else STEEL
    materials = [steel]
    pairs = [Pair("steel", "steel", *STEEL_STEEL)]
    charge = [Fraction("steel", ball_diameter, round(BALL_COUNT * share), "balls")]
    if particles is not None:
        if particles == "ceramic":
            mat = CERAMIC.with_shear_modulus(stiffness) if stiffness != 1.0 else CERAMIC
            pairs += [Pair("ceramic", "ceramic", *CERAMIC_CERAMIC),
                      Pair("ceramic", "steel", *CERAMIC_STEEL)]
        else:  # steel-like particles: steel's properties, a material of their own
            mat = Material("steel_particle", steel.density, steel.shear_modulus, steel.poisson)
            pairs += [Pair("steel_particle", "steel_particle", *STEEL_STEEL),
                      Pair("steel_particle", "steel", *STEEL_STEEL)]
        materials.append(mat)
        charge.append(Fraction(mat.name, particle_diameter,
                               round(PARTICLES_PER_LEVEL * load_level * share), "particles"))
    drum = Drum(DRUM_DIAMETER, length, "steel", end_walls,
                Lifters(LIFTER_COUNT, LIFTER_WIDTH, LIFTER_HEIGHT))
    return Scene(drum=drum, charge=tuple(charge), materials=tuple(materials), pairs=tuple(pairs),
                 speed_fraction=speed_fraction,
                 name=case_name(particles, speed_fraction, load_level))


def paper_cases(particles: Sequence[str] = ("ceramic", "steel"),
                speed_fractions: Iterable[float] = (0.80, 0.71, 0.62),
                load_levels: Iterable[int] = LOAD_LEVELS, scale: str = "paper") -> list[Scene]:
    """The Table 4 x Table 5 matrix (42 cases), or the part asked for, in that order."""
    if isinstance(particles, str):
        particles = (particles,)
    speeds, levels = list(speed_fractions), list(load_levels)
    return [pilot_mill(s, p, level, scale) for p in particles for s in speeds for level in levels]

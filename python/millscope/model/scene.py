"""Scene: what is in the mill. Validated, immutable descriptions (docs/physics.md).

A :class:`Scene` is a drum (:class:`Drum`, with optional :class:`Lifters`), a charge (one
:class:`Fraction` per size class), the materials (:class:`Material`) and one :class:`Pair`
(restitution, friction) for every pair of materials in use, plus the rotation speed.
Everything is SI (m, kg, Pa, s, rad/s, Hz). Every class checks its fields on construction and
raises ``ValueError`` naming the class, the field, the value and the valid range, e.g.
``Fraction.diameter = -0.01 m is not valid; it must be in [0.0001, 20] m``. Numbers may be
given as Python or numpy ints and floats and are stored as ``float``; bools, NaN and infinities
are refused.

Scenes round-trip through plain JSON-able dicts (:meth:`Scene.to_dict`,
:meth:`Scene.from_dict`), which is how records and checkpoints carry them, and through JSON
files (:meth:`Scene.load`). Every number has a range a mill can have, so that nothing computed
from a scene overflows: a drum 0.05 to 20 m across and up to 50 m long (a periodic slice's
period up to 500 m), spheres of at least 0.1 mm, materials of 1 to 1e5 kg/m^3 and 1 to 1e12 Pa,
restitution in [0.01, 1], friction up to 10, gravity up to 1000 m/s^2, at most 2**31 - 1
spheres. A dict or file that is not a valid scene raises :class:`SceneError` (a
``ValueError``) naming the field, its value and the valid range.
"""

from __future__ import annotations

import dataclasses
import math
import os
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .. import _checks
from .._checks import MAX_LIFTERS
from .._files import MAX_JSON_BYTES, read_json
from .contact import MIN_RESTITUTION, rayleigh_time

__all__ = [
    "CRITICAL_SPEED_CONVENTIONS",
    "LIFTER_PROFILES",
    "MAX_SPEED_FRACTION",
    "RANDOM_CLOSE_PACKING",
    "SCENE_FORMAT",
    "Drum",
    "Fraction",
    "Lifters",
    "Material",
    "Pair",
    "Scene",
    "SceneError",
]

#: Standard gravitational acceleration, m/s^2: a scene's default, and the power models'.
GRAVITY = 9.81

SCENE_FORMAT = "millscope-scene-1"  # the "format" key of Scene.to_dict
RANDOM_CLOSE_PACKING = 0.64  # the largest solid fraction a random bed of spheres reaches
MAX_SPEED_FRACTION = 3.0  # speed_fraction in (0, 3]
CRITICAL_SPEED_CONVENTIONS = ("ball", "drum")
LIFTER_PROFILES = ("rectangular", "trapezoidal")
#: Drum diameters, m: a 5 cm laboratory jar to beyond the largest mills (about 12 m).
DRUM_DIAMETER_RANGE = (0.05, 20.0)
MAX_DRUM_LENGTH = 50.0  # m: tube mills are up to about 15 m long
#: The longest period of a drum with periodic ends, m: a slice of a longer mill, whose length
#: is a size of the simulation, not of a mill (the engine's linear-cost benchmark runs slices
#: of up to 800 000 balls, 102 m at the paper's filling).
MAX_PERIOD_LENGTH = 500.0
MIN_SPHERE_DIAMETER = 1e-4  # m: 0.1 mm
#: The engine indexes spheres with 32-bit integers.
MAX_SPHERES = 2**31 - 1
MAX_DENSITY = 1e5  # kg/m^3: osmium, the densest element, has 22590
MAX_SHEAR_MODULUS = 1e12  # Pa: diamond has 4.8e11
MAX_FRICTION = 10.0  # measured static friction coefficients stay below about 1.5
MAX_GRAVITY = 1000.0  # m/s^2


class SceneError(ValueError):
    """A scene dict or file that cannot be used; the message names the field, its value and the
    valid range."""


# -- validation helpers ------------------------------------------------------------------------


def _set(obj: object, **values: object) -> None:
    """Store coerced values on a frozen dataclass (from ``__post_init__`` only)."""
    for k, v in values.items():
        object.__setattr__(obj, k, v)


# -- the parts ---------------------------------------------------------------------------------


@dataclass(frozen=True)
class Material:
    """An elastic material (paper Table 2).

    Attributes
    ----------
    name : str
        Non-empty, unique within a scene.
    density : float
        rho, kg/m^3, in [1, 1e5] (osmium, the densest element, has 22590).
    shear_modulus : float
        G, Pa, in [1, 1e12] (diamond has 4.8e11).
    poisson : float
        Poisson ratio nu, in (-1, 0.5).
    """

    name: str
    density: float
    shear_modulus: float
    poisson: float

    def __post_init__(self) -> None:
        name = _checks.text("Material.name", self.name)
        density = _checks.between("Material.density", self.density, 1.0, MAX_DENSITY, "kg/m^3")
        shear_modulus = _checks.between("Material.shear_modulus", self.shear_modulus, 1.0,
                                        MAX_SHEAR_MODULUS, "Pa")
        nu = _checks.real("Material.poisson", self.poisson, "", "in (-1, 0.5)")
        if not -1.0 < nu < 0.5:
            raise _checks.fail("Material.poisson", self.poisson, "in (-1, 0.5)")
        _set(self, name=name, density=density, shear_modulus=shear_modulus, poisson=nu)

    @property
    def youngs_modulus(self) -> float:
        """Young's modulus E = 2 G (1 + nu), Pa."""
        return 2.0 * self.shear_modulus * (1.0 + self.poisson)

    def with_shear_modulus(self, factor: float) -> Material:
        """A copy with the shear modulus multiplied by ``factor`` (> 0).

        Reduced-stiffness scales use it: G x 0.01 makes the Rayleigh time, and the default
        time step, 10 times longer.
        """
        scale = _checks.positive("Material.with_shear_modulus factor", factor)
        return dataclasses.replace(self, shear_modulus=self.shear_modulus * scale)


@dataclass(frozen=True)
class Pair:
    """Contact coefficients of two materials (paper Table 3); ``a == b`` for like materials.

    Attributes
    ----------
    a, b : str
        Material names; the pair is unordered.
    restitution : float
        Coefficient of restitution e, in [0.01, 1] (``MIN_RESTITUTION``: below it the damped
        contact law does not give the asked rebound, :mod:`millscope.contact`).
    friction : float
        Static friction coefficient mu_s of eq. (8), in [0, 10].
    """

    a: str
    b: str
    restitution: float
    friction: float

    def __post_init__(self) -> None:
        a, b = _checks.text("Pair.a", self.a), _checks.text("Pair.b", self.b)
        e = _checks.between("Pair.restitution", self.restitution, MIN_RESTITUTION, 1.0)
        mu = _checks.between("Pair.friction", self.friction, 0.0, MAX_FRICTION)
        _set(self, a=a, b=b, restitution=e, friction=mu)

    @property
    def key(self) -> frozenset[str]:
        """The unordered pair of material names."""
        return frozenset((self.a, self.b))

    @property
    def label(self) -> str:
        """``"a-b"``, the names in alphabetical order."""
        return "-".join(sorted((self.a, self.b)))


@dataclass(frozen=True)
class Lifters:
    """Lifter bars along the full drum length, evenly spaced around the shell.

    Attributes
    ----------
    count : int
        Number of lifters, >= 1.
    width : float
        Width at the shell (the base), m, > 0.
    height : float
        Radial height, m, > 0 (below the drum radius: checked by :class:`Drum`).
    profile : {"rectangular", "trapezoidal"}
        Cross-section shape.
    top_width : float or None
        Width at the tip (towards the axis), m: None for rectangular lifters, in (0, width]
        and required for trapezoidal ones.
    phase : float
        Angle of lifter 0 when the drum angle is 0, rad (any finite value).
    """

    count: int
    width: float
    height: float
    profile: str = "rectangular"
    top_width: float | None = None
    phase: float = 0.0

    def __post_init__(self) -> None:
        count = _checks.count("Lifters.count", self.count, MAX_LIFTERS)
        width = _checks.positive("Lifters.width", self.width, "m")
        height = _checks.positive("Lifters.height", self.height, "m")
        profile = _checks.choice("Lifters.profile", self.profile, LIFTER_PROFILES)
        top_width: float | None = None
        if profile == "rectangular":
            if self.top_width is not None:
                raise _checks.fail(
                    "Lifters.top_width",
                    self.top_width,
                    "None for rectangular lifters (their tip is as wide as their base)",
                    "m",
                )
        else:
            valid = f"in (0, width = {width:g} m] for trapezoidal lifters"
            if self.top_width is None:
                raise _checks.fail("Lifters.top_width", None, valid)
            top_width = _checks.real("Lifters.top_width", self.top_width, "m", valid)
            if not 0.0 < top_width <= width:
                raise _checks.fail("Lifters.top_width", self.top_width, valid, "m")
        _set(
            self,
            count=count,
            width=width,
            height=height,
            profile=profile,
            top_width=top_width,
            phase=_checks.real("Lifters.phase", self.phase, "rad", ""),
        )

    @property
    def tip_width(self) -> float:
        """Width at the tip, m (the base width for rectangular lifters)."""
        return self.width if self.top_width is None else self.top_width

    @property
    def cross_section(self) -> float:
        """Cross-section area of one lifter, (width + tip width) / 2 x height, m^2."""
        return 0.5 * (self.width + self.tip_width) * self.height


@dataclass(frozen=True)
class Drum:
    """The mill's drum, rotating about +z; it spans 0 <= z <= length.

    Attributes
    ----------
    diameter : float
        Inner diameter D, m, in [0.05, 20].
    length : float
        Inner length L, m, in (0, 50]; with periodic ends (``end_walls`` False) the period
        along the axis, in (0, 500].
    material : str
        Name of the drum's material (shell, lifters and end walls).
    end_walls : bool
        Flat end walls at z = 0 and z = L; False for periodic ends (a thin axial slice).
    lifters : Lifters or None
        Lifter bars, or None for a smooth shell. Their height must be below the radius and
        they must fit around the circumference at their tips: count x width < 2 pi (R - height).
    """

    diameter: float
    length: float
    material: str
    end_walls: bool = True
    lifters: Lifters | None = None

    def __post_init__(self) -> None:
        diameter = _checks.between("Drum.diameter", self.diameter, *DRUM_DIAMETER_RANGE, "m")
        radius = 0.5 * diameter
        lift = self.lifters
        if lift is not None:
            if not isinstance(lift, Lifters):
                raise _checks.fail("Drum.lifters", lift, "a Lifters or None")
            if lift.height >= radius:
                raise _checks.fail(
                    "Drum.lifters.height", lift.height, f"< the drum radius {radius:g} m", "m"
                )
            room = 2.0 * math.pi * (radius - lift.height)
            if lift.count * lift.width >= room:
                raise ValueError(
                    f"Drum.lifters.count x width = {lift.count} x {lift.width:g} m = "
                    f"{lift.count * lift.width:.4g} m is not valid; it must be < "
                    f"2 pi (R - height) = {room:.4g} m, the circumference at the lifter tips"
                )
        end_walls = _checks.flag("Drum.end_walls", self.end_walls)
        longest = MAX_DRUM_LENGTH if end_walls else MAX_PERIOD_LENGTH
        _set(
            self,
            diameter=diameter,
            length=_checks.between("Drum.length", self.length, 0.0, longest, "m",
                                   low_open=True),
            material=_checks.text("Drum.material", self.material),
            end_walls=end_walls,
        )

    @property
    def radius(self) -> float:
        """Inner radius R = D / 2, m."""
        return 0.5 * self.diameter

    @property
    def volume(self) -> float:
        """Inner volume pi R^2 L, m^3 (lifters not subtracted)."""
        return math.pi * self.radius**2 * self.length

    @property
    def lifter_volume(self) -> float:
        """Volume of the lifters, count x cross-section x L, m^3 (0 without lifters)."""
        lift = self.lifters
        return 0.0 if lift is None else lift.count * lift.cross_section * self.length

    @property
    def free_volume(self) -> float:
        """Inner volume not taken by lifters, m^3."""
        return self.volume - self.lifter_volume

    @property
    def tip_radius(self) -> float:
        """Distance from the axis to the lifter tips (R without lifters), m."""
        return self.radius - (0.0 if self.lifters is None else self.lifters.height)


@dataclass(frozen=True)
class Fraction:
    """One size class of the charge: ``count`` spheres of one ``diameter`` and ``material``.

    Attributes
    ----------
    material : str
        Name of the material.
    diameter : float
        Sphere diameter d, m, in [0.0001, 20] (and below the gap to the axis, checked by
        :class:`Scene`).
    count : int
        Number of spheres, in [1, 2**31 - 1].
    name : str
        A label such as "balls" or "particles", unique within a scene; "" (the default)
        stands for the material name.
    """

    material: str
    diameter: float
    count: int
    name: str = ""

    def __post_init__(self) -> None:
        material = _checks.text("Fraction.material", self.material)
        _set(
            self,
            material=material,
            diameter=_checks.between("Fraction.diameter", self.diameter, MIN_SPHERE_DIAMETER,
                                     DRUM_DIAMETER_RANGE[1], "m"),
            count=_checks.count("Fraction.count", self.count, MAX_SPHERES),
            name=_checks.text("Fraction.name", self.name, empty=True) or material,
        )

    @property
    def radius(self) -> float:
        """Sphere radius d / 2, m."""
        return 0.5 * self.diameter

    @property
    def volume(self) -> float:
        """Solid volume of the whole fraction, count x pi d^3 / 6, m^3."""
        return self.count * math.pi * self.diameter**3 / 6.0


# -- the scene ---------------------------------------------------------------------------------


@dataclass(frozen=True)
class Scene:
    """A mill, its charge and its speed.

    Attributes
    ----------
    drum : Drum
        The drum; its material must be in ``materials``.
    charge : tuple of Fraction
        At least one fraction (any sequence is accepted and stored as a tuple); unique names,
        materials in ``materials``. Every sphere must fit between the lifter tips and the axis
        (d < R - lifter height) and along the drum (d < L with end walls; L >= 2 d with periodic
        ends, so that a sphere meets at most one periodic image of another). The solid volume
        must not exceed 0.64 (random close packing) x the drum's free volume.
    materials : tuple of Material
        Every material the drum and the charge use, unique names; unused ones are allowed.
    pairs : tuple of Pair
        Exactly one Pair for every unordered pair of materials in use (drum included, like
        pairs included); pairs involving unused materials are optional.
    speed_fraction : float or None
        Rotation speed as a fraction of the critical speed, in (0, 3].
    speed_hz : float or None
        Rotation frequency, Hz, in [0, 3 x the critical speed] (0: the drum at rest). Exactly
        one of ``speed_fraction`` and ``speed_hz`` is given.
    critical_speed_convention : {"ball", "drum"}
        omega_c = sqrt(2 g / (D - d_max)) ("ball", docs/physics.md) or sqrt(2 g / D)
        ("drum"), d_max the largest sphere diameter.
    gravity : float
        g, m/s^2, in (0, 1000], acting along -y.
    clamp_normal_force : bool
        Clamp the total normal force at zero (off by default, as in EDEM and LIGGGHTS).
    name : str
        A label, e.g. the paper's case code "HDMS#3".
    """

    drum: Drum
    charge: tuple[Fraction, ...]
    materials: tuple[Material, ...]
    pairs: tuple[Pair, ...]
    speed_fraction: float | None = None
    speed_hz: float | None = None
    critical_speed_convention: str = "ball"
    gravity: float = GRAVITY
    clamp_normal_force: bool = False
    name: str = ""
    _index: Mapping[str, int] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        if not isinstance(self.drum, Drum):
            raise _checks.fail("Scene.drum", self.drum, "a Drum")
        charge = _checks.tuple_of("Scene.charge", self.charge, Fraction, "Fraction")
        if not charge:
            raise _checks.fail("Scene.charge", self.charge, "a non-empty sequence of Fraction")
        materials = _checks.tuple_of("Scene.materials", self.materials, Material, "Material")
        pairs = _checks.tuple_of("Scene.pairs", self.pairs, Pair, "Pair")
        _set(self, charge=charge, materials=materials, pairs=pairs)

        index = _unique("Scene.materials", [m.name for m in materials], "material names")
        _set(self, _index=index)
        _unique(
            "Scene.charge names",
            [f.name for f in charge],
            "fraction names (give each Fraction its own name=...)",
        )
        known = f"one of the materials {sorted(index)}"
        if self.drum.material not in index:
            raise _checks.fail("Scene.drum.material", self.drum.material, known)
        for k, f in enumerate(charge):
            if f.material not in index:
                raise _checks.fail(f"Scene.charge[{k}].material", f.material, known)
        spheres = sum(f.count for f in charge)
        if spheres > MAX_SPHERES:
            raise _checks.fail(
                "Scene.charge", f"{spheres} spheres",
                f"at most {MAX_SPHERES} spheres (the engine indexes them with 32-bit "
                "integers)")
        self._check_pairs()
        _set(
            self,
            critical_speed_convention=_checks.choice(
                "Scene.critical_speed_convention",
                self.critical_speed_convention,
                CRITICAL_SPEED_CONVENTIONS,
            ),
            gravity=_checks.between("Scene.gravity", self.gravity, 0.0, MAX_GRAVITY, "m/s^2",
                                    low_open=True),
            clamp_normal_force=_checks.flag("Scene.clamp_normal_force", self.clamp_normal_force),
            name=_checks.text("Scene.name", self.name, empty=True),
        )
        self._check_room()
        self._check_speed()

    def _check_pairs(self) -> None:
        labels = [p.label for p in self.pairs]
        given = f"one Pair for every pair of materials in use; given: {labels}"
        seen: set[frozenset[str]] = set()
        for p in self.pairs:
            for end in (p.a, p.b):
                if end not in self._index:
                    raise _checks.fail(
                        f"Scene.pairs[{p.label!r}]",
                        end,
                        f"one of the materials {sorted(self._index)}",
                    )
            if p.key in seen:
                raise ValueError(
                    f"Scene.pairs = {labels} is not valid; it must hold each pair of materials "
                    f"once, and {p.label} repeats"
                )
            seen.add(p.key)
        used = self.used_materials()
        for i, a in enumerate(used):
            for b in used[i:]:
                if frozenset((a, b)) not in seen:
                    missing = "-".join(sorted((a, b)))
                    raise ValueError(
                        f"Scene.pairs is missing the pair {missing} (materials {a!r} and "
                        f"{b!r}); it must hold {given}"
                    )

    def _check_speed(self) -> None:
        if (self.speed_fraction is None) == (self.speed_hz is None):
            raise ValueError(
                f"Scene.speed_fraction = {_checks.shown(self.speed_fraction)} and Scene.speed_hz = "
                f"{_checks.shown(self.speed_hz)} are not valid; exactly one of them must be given"
            )
        if self.speed_fraction is not None:
            valid = f"in (0, {MAX_SPEED_FRACTION:g}] (a fraction of the critical speed)"
            s = _checks.real("Scene.speed_fraction", self.speed_fraction, "", valid)
            if not 0.0 < s <= MAX_SPEED_FRACTION:
                raise _checks.fail("Scene.speed_fraction", self.speed_fraction, valid)
            _set(self, speed_fraction=s)
        else:
            top = MAX_SPEED_FRACTION * self.critical_speed_rad_s / (2.0 * math.pi)
            _set(self, speed_hz=_checks.between("Scene.speed_hz", self.speed_hz, 0.0, top, "Hz"))

    def _check_room(self) -> None:
        drum = self.drum
        gap = drum.tip_radius
        for f in self.charge:
            where = f"Scene.charge[{f.name!r}].diameter"
            if f.diameter >= gap:
                raise _checks.fail(
                    where,
                    f.diameter,
                    f"< {gap:.4g} m, the gap between the lifter tips and the axis",
                    "m",
                )
            if drum.end_walls and f.diameter >= drum.length:
                raise _checks.fail(where, f.diameter, f"< the drum length {drum.length:g} m", "m")
            if not drum.end_walls and 2.0 * f.diameter > drum.length:
                raise _checks.fail(
                    where,
                    f.diameter,
                    f"<= {0.5 * drum.length:.4g} m: a drum with periodic ends needs a length "
                    f"of at least 2 x the largest diameter, and this one is {drum.length:g} m",
                    "m",
                )
        solid = self.charge_volume()
        room = RANDOM_CLOSE_PACKING * drum.free_volume
        if solid > room:
            raise ValueError(
                f"Scene.charge = {solid:.4g} m^3 of solid is not valid; it must be <= "
                f"{room:.4g} m^3 ({RANDOM_CLOSE_PACKING} x the drum's free volume "
                f"{drum.free_volume:.4g} m^3): more charge than the drum holds"
            )

    # -- materials and pairs -------------------------------------------------------------------
    def used_materials(self) -> list[str]:
        """Names of the materials in use (the drum's first, then the charge's), each once."""
        names = [self.drum.material] + [f.material for f in self.charge]
        return list(dict.fromkeys(names))

    def material(self, name: str) -> Material:
        """The Material called ``name``; ValueError if the scene has none."""
        return self.materials[self.material_index(name)]

    def material_index(self, name: str) -> int:
        """Index of the material called ``name`` in ``materials``; ValueError if unknown."""
        try:
            return self._index[name]
        except (KeyError, TypeError):
            raise ValueError(
                f"material {name!r} is not in this scene; it has {sorted(self._index)}"
            ) from None

    def pair(self, a: str, b: str) -> Pair:
        """The Pair of materials ``a`` and ``b`` (either order); ValueError if none."""
        key = frozenset((a, b))
        for p in self.pairs:
            if p.key == key:
                return p
        raise ValueError(
            f"no Pair for materials {a!r} and {b!r} in this scene; it has "
            f"{[p.label for p in self.pairs]}"
        )

    def pair_matrices(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Restitution and friction matrices.

        Returns
        -------
        restitution, friction : ndarray of float64, shape (n, n)
            Symmetric, rows and columns in ``materials`` order. Pairs of materials that no
            contact can involve (unused materials without a Pair) hold e = 1, mu = 0.
        """
        n = len(self.materials)
        e = np.ones((n, n), dtype=np.float64)
        mu = np.zeros((n, n), dtype=np.float64)
        for p in self.pairs:
            i, j = self._index[p.a], self._index[p.b]
            e[i, j] = e[j, i] = p.restitution
            mu[i, j] = mu[j, i] = p.friction
        return e, mu

    @property
    def has_friction(self) -> bool:
        """True if any pair of materials in use has friction > 0."""
        used = set(self.used_materials())
        return any(p.friction > 0.0 and p.key <= used for p in self.pairs)

    @property
    def single_material(self) -> bool:
        """True if the drum and the whole charge are of one material."""
        return len(self.used_materials()) == 1

    # -- charge --------------------------------------------------------------------------------
    @property
    def n_particles(self) -> int:
        """Number of spheres in the charge."""
        return sum(f.count for f in self.charge)

    @property
    def max_diameter(self) -> float:
        """Largest sphere diameter of the charge, m."""
        return max(f.diameter for f in self.charge)

    @property
    def min_diameter(self) -> float:
        """Smallest sphere diameter of the charge, m."""
        return min(f.diameter for f in self.charge)

    def particle_radii(self) -> NDArray[np.float64]:
        """Radii of all spheres, m, shape (N,), fractions concatenated in ``charge`` order."""
        return np.concatenate([np.full(f.count, f.radius, dtype=np.float64) for f in self.charge])

    def particle_materials(self) -> NDArray[np.int32]:
        """Material index (into ``materials``) of every sphere, shape (N,), ``charge`` order."""
        return np.concatenate(
            [np.full(f.count, self._index[f.material], dtype=np.int32) for f in self.charge]
        )

    def charge_volume(self) -> float:
        """Solid volume of the charge, m^3."""
        return sum(f.volume for f in self.charge)

    def charge_mass(self) -> float:
        """Mass of the charge, kg."""
        return sum(f.volume * self.material(f.material).density for f in self.charge)

    def bed_filling(self, porosity: float = 0.45) -> float:
        """Fraction of the drum volume the charge takes as a bed at rest.

        Parameters
        ----------
        porosity : float
            Void fraction of the bed, in [0, 1).

        Returns
        -------
        float
            (solid volume / (1 - porosity)) / (pi R^2 L), dimensionless.
        """
        valid = "in [0, 1)"
        phi = _checks.real("Scene.bed_filling porosity", porosity, "", valid)
        if not 0.0 <= phi < 1.0:
            raise _checks.fail("Scene.bed_filling porosity", porosity, valid)
        return self.charge_volume() / (1.0 - phi) / self.drum.volume

    def rayleigh_times(self) -> list[tuple[str, float]]:
        """Rayleigh time of every fraction.

        Returns
        -------
        list of (str, float)
            (fraction name, T_R = pi r sqrt(rho / G) / (0.1631 nu + 0.8766) in s), in
            ``charge`` order (:func:`millscope.contact.rayleigh_time`).
        """
        out = []
        for f in self.charge:
            m = self.material(f.material)
            out.append((f.name, rayleigh_time(f.diameter, m.density, m.shear_modulus, m.poisson)))
        return out

    def min_rayleigh_time(self) -> tuple[float, str]:
        """The smallest Rayleigh time of the charge, s, and the name of the fraction that has
        it (the first such fraction on a tie). The default time step is 0.2 x this."""
        name, t = min(self.rayleigh_times(), key=lambda item: item[1])
        return t, name

    # -- speed ---------------------------------------------------------------------------------
    @property
    def critical_speed_rad_s(self) -> float:
        """Critical speed omega_c, rad/s: sqrt(2 g / (D - d_max)) for the "ball" convention,
        sqrt(2 g / D) for "drum"."""
        span = self.drum.diameter
        if self.critical_speed_convention == "ball":
            span -= self.max_diameter
        return math.sqrt(2.0 * self.gravity / span)

    @property
    def omega(self) -> float:
        """Rotation speed, rad/s (about +z): speed_fraction x omega_c, or 2 pi speed_hz."""
        if self.speed_fraction is not None:
            return self.speed_fraction * self.critical_speed_rad_s
        assert self.speed_hz is not None  # one of the two is set (checked on construction)
        return 2.0 * math.pi * self.speed_hz

    @property
    def rotation_hz(self) -> float:
        """Rotation frequency omega / (2 pi), Hz."""
        return self.omega / (2.0 * math.pi)

    # -- dicts ---------------------------------------------------------------------------------
    def to_dict(self) -> dict[str, Any]:
        """A plain, JSON-serialisable dict: ``{"format": "millscope-scene-1", ...}`` and one
        key per field (nested dicts for the drum and lifters, lists for the rest)."""
        out: dict[str, Any] = {"format": SCENE_FORMAT}
        out.update(_plain(self))
        return out

    @classmethod
    def load(cls, path: str | os.PathLike[str]) -> Scene:
        """Read a scene JSON file (:meth:`to_dict` written with ``json.dump``); a missing or
        unreadable file, one larger than ``MAX_JSON_BYTES``, invalid JSON or an invalid scene
        (as :meth:`from_dict` checks it) raises :class:`SceneError` naming the file."""
        data = read_json(path, "scene", SceneError, MAX_JSON_BYTES)
        try:
            return cls.from_dict(data)
        except SceneError as exc:
            raise SceneError(f"{path}: {exc}") from None

    @classmethod
    def from_dict(cls, d: object) -> Scene:
        """The Scene of a :meth:`to_dict` dict, validated.

        Keys whose field has a default may be left out; an unknown key, a missing required
        key, a ``"format"`` other than ``"millscope-scene-1"`` or any field out of its range
        raises :class:`SceneError`.
        """
        try:
            return cls._from_dict(d)
        except SceneError:
            raise
        except ValueError as exc:
            raise SceneError(str(exc)) from None

    @classmethod
    def _from_dict(cls, d: object) -> Scene:
        """:meth:`from_dict`, raising ValueError."""
        if not isinstance(d, Mapping):
            raise ValueError(
                f"Scene.from_dict needs a mapping (a dict from Scene.to_dict), not "
                f"{type(d).__name__}"
            )
        fmt = d.get("format")
        if fmt != SCENE_FORMAT:
            raise _checks.fail("Scene.from_dict format", fmt, repr(SCENE_FORMAT))
        body = {k: v for k, v in d.items() if k != "format"}
        args = _arguments(cls, body, "scene")
        drum = _arguments(Drum, args["drum"], "scene['drum']")
        if drum.get("lifters") is not None:
            drum["lifters"] = Lifters(
                **_arguments(Lifters, drum["lifters"], "scene['drum']['lifters']")
            )
        args["drum"] = Drum(**drum)
        for key, kind in (("charge", Fraction), ("materials", Material), ("pairs", Pair)):
            items = args[key]
            if not isinstance(items, (list, tuple)):
                raise ValueError(
                    f"Scene.from_dict: scene[{key!r}] must be a list, not {type(items).__name__}"
                )
            args[key] = tuple(
                kind(**_arguments(kind, item, f"scene[{key!r}][{k}]"))
                for k, item in enumerate(items)
            )
        return cls(**args)

    def replace(self, **changes: Any) -> Scene:
        """A copy with some fields changed, validated again (``dataclasses.replace``)."""
        return dataclasses.replace(self, **changes)

    def describe(self) -> str:
        """A short human summary: drum, lifters, fractions, speed, smallest Rayleigh time."""
        d = self.drum
        if d.lifters is None:
            lift = "no lifters"
        else:
            lf = d.lifters
            tip = "" if lf.top_width is None else f" (tip {lf.top_width * 1e3:g} mm)"
            lift = (
                f"{lf.count} {lf.profile} lifters {lf.width * 1e3:g} mm wide{tip} x "
                f"{lf.height * 1e3:g} mm high"
            )
        ends = "end walls" if d.end_walls else "periodic ends"
        lines = [
            f"{self.name or 'scene'}: drum {d.diameter:g} m x {d.length:g} m ({d.material}), "
            f"{lift}, {ends}"
        ]
        for f in self.charge:
            lines.append(f"  {f.name}: {f.count} x {f.diameter * 1e3:g} mm {f.material}")
        lines.append(
            f"  charge: {self.n_particles} spheres, {self.charge_mass():.4g} kg, "
            f"bed filling {100.0 * self.bed_filling():.1f} % of the drum at porosity 0.45"
        )
        pct = 100.0 * self.omega / self.critical_speed_rad_s
        t, which = self.min_rayleigh_time()
        lines.append(
            f"  speed: {pct:.1f} % of critical ({self.critical_speed_convention} convention), "
            f"{self.rotation_hz:.4f} Hz; smallest Rayleigh time {t:.4g} s ({which})"
        )
        return "\n".join(lines)


# -- helpers of Scene ----------------------------------------------------------------------


def _unique(where: str, names: list[str], what: str) -> dict[str, int]:
    """``{name: index}``; ValueError naming the first repeated name."""
    index: dict[str, int] = {}
    for k, name in enumerate(names):
        if name in index:
            raise ValueError(
                f"{where} = {names} is not valid; it must hold unique {what}, and {name!r} repeats"
            )
        index[name] = k
    return index


def _plain(obj: Any) -> Any:
    """A dataclass (recursively, with tuples as lists) as plain JSON-able values."""
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        return {f.name: _plain(getattr(obj, f.name)) for f in dataclasses.fields(obj) if f.init}
    if isinstance(obj, (list, tuple)):
        return [_plain(x) for x in obj]
    return obj


def _arguments(cls: type, data: object, where: str) -> dict[str, Any]:
    """The constructor arguments of dataclass ``cls`` in ``data``, checked for missing and
    unknown keys (values are checked by the constructor)."""
    if not isinstance(data, Mapping):
        raise ValueError(
            f"Scene.from_dict: {where} must be a mapping of {cls.__name__} fields, "
            f"not {type(data).__name__}"
        )
    fields = [f for f in dataclasses.fields(cls) if f.init]
    names = {f.name for f in fields}
    unknown = sorted(str(k) for k in data if k not in names)
    if unknown:
        raise ValueError(
            f"Scene.from_dict: {where} has unknown keys {unknown}; {cls.__name__} has "
            f"{[f.name for f in fields]}"
        )
    missing = [
        f.name
        for f in fields
        if f.name not in data
        and f.default is dataclasses.MISSING
        and f.default_factory is dataclasses.MISSING
    ]
    if missing:
        raise ValueError(f"Scene.from_dict: {where} lacks the keys {missing}")
    return dict(data)

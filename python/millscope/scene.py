"""Scene: what is in the mill. Validated, immutable descriptions (DESIGN.md sections 2, 3, 6).

A :class:`Scene` is a drum (:class:`Drum`, with optional :class:`Lifters`), a charge (one
:class:`Fraction` per size class), the materials (:class:`Material`) and one :class:`Pair`
(restitution, friction) for every pair of materials present, plus the rotation speed.
Everything is SI (m, kg, Pa, s, rad/s, Hz). Every class checks its fields on construction and
raises ``ValueError`` naming the class, the field, the value and the valid range.

Scenes round-trip through plain dicts (:meth:`Scene.to_dict`, :meth:`Scene.from_dict`), which
is how records and checkpoints carry them.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = ["Drum", "Fraction", "Lifters", "Material", "Pair", "Scene"]

SCENE_FORMAT = "millscope-scene-1"
RANDOM_CLOSE_PACKING = 0.64  # largest solid fraction a random bed of spheres reaches
CRITICAL_SPEED_CONVENTIONS = ("ball", "drum")
LIFTER_PROFILES = ("rectangular", "trapezoidal")


def _fail(owner: str, name: str, value: object, unit: str, valid: str) -> ValueError:
    unit = f" {unit}" if unit else ""
    return ValueError(f"{owner}.{name} = {value!r}{unit} is not valid; it must be {valid}")


def _number(owner: str, name: str, value: object, unit: str = "") -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise _fail(owner, name, value, unit, "a real number")
    x = float(value)
    if not math.isfinite(x):
        raise _fail(owner, name, value, unit, "finite")
    return x


def _positive(owner: str, name: str, value: object, unit: str = "") -> float:
    x = _number(owner, name, value, unit)
    if not x > 0.0:
        raise _fail(owner, name, value, unit, "> 0")
    return x


def _count(owner: str, name: str, value: object, least: int = 1) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise _fail(owner, name, value, "", f"an integer >= {least}")
    if value < least:
        raise _fail(owner, name, value, "", f"an integer >= {least}")
    return int(value)


def _name(owner: str, name: str, value: object) -> str:
    if not isinstance(value, str) or not value:
        raise _fail(owner, name, value, "", "a non-empty string")
    return value


def _set(obj: object, **values: object) -> None:
    for k, v in values.items():
        object.__setattr__(obj, k, v)


@dataclass(frozen=True)
class Material:
    """An elastic material (paper Table 2).

    Attributes
    ----------
    name : str
        Unique within a scene.
    density : float
        kg/m^3, > 0.
    shear_modulus : float
        G, Pa, > 0.
    poisson : float
        Poisson ratio nu, in (-1, 0.5).
    """

    name: str
    density: float
    shear_modulus: float
    poisson: float

    def __post_init__(self) -> None:
        o = "Material"
        _set(self, name=_name(o, "name", self.name),
             density=_positive(o, "density", self.density, "kg/m^3"),
             shear_modulus=_positive(o, "shear_modulus", self.shear_modulus, "Pa"))
        nu = _number(o, "poisson", self.poisson)
        if not -1.0 < nu < 0.5:
            raise _fail(o, "poisson", self.poisson, "", "in (-1, 0.5)")
        _set(self, poisson=nu)

    @property
    def youngs_modulus(self) -> float:
        """E = 2 G (1 + nu), Pa."""
        return 2.0 * self.shear_modulus * (1.0 + self.poisson)

    def with_shear_modulus(self, factor: float) -> Material:
        """A copy with the shear modulus scaled by ``factor`` (> 0): reduced-stiffness scales."""
        return replace(self, shear_modulus=self.shear_modulus
                       * _positive("Material", "factor", factor))


@dataclass(frozen=True)
class Pair:
    """Contact coefficients of two materials (paper Table 3); ``a == b`` for like materials.

    Attributes
    ----------
    a, b : str
        Material names.
    restitution : float
        Coefficient of restitution e, in (0, 1].
    friction : float
        Static friction coefficient mu_s of eq. (8), >= 0.
    """

    a: str
    b: str
    restitution: float
    friction: float

    def __post_init__(self) -> None:
        o = "Pair"
        e = _number(o, "restitution", self.restitution)
        if not 0.0 < e <= 1.0:
            raise _fail(o, "restitution", self.restitution, "", "in (0, 1]")
        mu = _number(o, "friction", self.friction)
        if mu < 0.0:
            raise _fail(o, "friction", self.friction, "", ">= 0")
        _set(self, a=_name(o, "a", self.a), b=_name(o, "b", self.b), restitution=e, friction=mu)

    @property
    def key(self) -> frozenset[str]:
        return frozenset((self.a, self.b))


@dataclass(frozen=True)
class Lifters:
    """Lifter bars along the full drum length, evenly spaced.

    Attributes
    ----------
    count : int
        Number of lifters, >= 1.
    width : float
        Width at the shell (the base), m, > 0.
    height : float
        Radial height, m, > 0.
    profile : {"rectangular", "trapezoidal"}
        Cross-section shape.
    top_width : float or None
        Width at the tip (towards the axis), m, in (0, width]; only for trapezoidal lifters.
    phase : float
        Angle of lifter 0 when the drum angle is 0, rad.
    """

    count: int
    width: float
    height: float
    profile: str = "rectangular"
    top_width: float | None = None
    phase: float = 0.0

    def __post_init__(self) -> None:
        o = "Lifters"
        _set(self, count=_count(o, "count", self.count),
             width=_positive(o, "width", self.width, "m"),
             height=_positive(o, "height", self.height, "m"),
             phase=_number(o, "phase", self.phase, "rad"))
        if self.profile not in LIFTER_PROFILES:
            raise _fail(o, "profile", self.profile, "", f"one of {LIFTER_PROFILES}")
        if self.profile == "rectangular":
            if self.top_width is not None:
                raise _fail(o, "top_width", self.top_width, "m",
                            "None for rectangular lifters (their tip is as wide as the base)")
        else:
            if self.top_width is None:
                raise _fail(o, "top_width", None, "m", "given for trapezoidal lifters")
            tw = _positive(o, "top_width", self.top_width, "m")
            if tw > self.width:
                raise _fail(o, "top_width", self.top_width, "m",
                            f"<= width = {self.width} m")
            _set(self, top_width=tw)

    @property
    def tip_width(self) -> float:
        """Width at the tip, m (the base width for rectangular lifters)."""
        return self.width if self.top_width is None else self.top_width

    @property
    def cross_section(self) -> float:
        """Cross-section area, m^2."""
        return 0.5 * (self.width + self.tip_width) * self.height


@dataclass(frozen=True)
class Drum:
    """The mill's drum, rotating about +z; it spans 0 <= z <= length.

    Attributes
    ----------
    diameter : float
        Inner diameter, m, > 0.
    length : float
        Inner length, m, > 0 (the period along the axis when ``end_walls`` is False).
    material : str
        Name of the drum's material (shell, lifters and end walls).
    end_walls : bool
        Flat end walls at z = 0 and z = length; False for periodic ends (an axial slice).
    lifters : Lifters or None
        Lifter bars, or None for a smooth shell.
    """

    diameter: float
    length: float
    material: str
    end_walls: bool = True
    lifters: Lifters | None = None

    def __post_init__(self) -> None:
        o = "Drum"
        _set(self, diameter=_positive(o, "diameter", self.diameter, "m"),
             length=_positive(o, "length", self.length, "m"),
             material=_name(o, "material", self.material))
        if not isinstance(self.end_walls, bool):
            raise _fail(o, "end_walls", self.end_walls, "", "True or False")
        lift = self.lifters
        if lift is not None:
            if not isinstance(lift, Lifters):
                raise _fail(o, "lifters", lift, "", "a Lifters or None")
            if lift.height >= self.radius:
                raise _fail(o, "lifters", lift.height, "m",
                            f"lower than the drum radius {self.radius} m (Lifters.height)")
            room = 2.0 * math.pi * (self.radius - lift.height)
            if lift.count * lift.width >= room:
                raise _fail(o, "lifters", f"{lift.count} x {lift.width} m", "",
                            f"narrower in all than the circumference at their tips, {room:.4g} m")

    @property
    def radius(self) -> float:
        """Inner radius, m."""
        return 0.5 * self.diameter

    @property
    def volume(self) -> float:
        """pi R^2 L, m^3 (lifters included)."""
        return math.pi * self.radius**2 * self.length

    @property
    def lifter_volume(self) -> float:
        """Volume of the lifters, m^3."""
        lift = self.lifters
        return 0.0 if lift is None else lift.count * lift.cross_section * self.length

    @property
    def free_volume(self) -> float:
        """Volume inside the drum not taken by lifters, m^3."""
        return self.volume - self.lifter_volume


@dataclass(frozen=True)
class Fraction:
    """One size class of the charge: ``count`` spheres of one ``diameter`` and ``material``."""

    material: str
    diameter: float
    count: int
    name: str = ""

    def __post_init__(self) -> None:
        o = "Fraction"
        _set(self, material=_name(o, "material", self.material),
             diameter=_positive(o, "diameter", self.diameter, "m"),
             count=_count(o, "count", self.count))
        if not isinstance(self.name, str):
            raise _fail(o, "name", self.name, "", "a string")
        if not self.name:
            _set(self, name=self.material)

    @property
    def radius(self) -> float:
        return 0.5 * self.diameter

    @property
    def volume(self) -> float:
        """Solid volume of the whole fraction, m^3."""
        return self.count * math.pi * self.diameter**3 / 6.0


@dataclass(frozen=True)
class Scene:
    """A mill and its charge.

    Attributes
    ----------
    drum : Drum
    charge : tuple of Fraction
        At least one.
    materials : tuple of Material
        Every material the drum and the charge use (unique names).
    pairs : tuple of Pair
        Exactly one per unordered pair of materials in use (like pairs included).
    speed_fraction : float or None
        Rotation speed as a fraction of the critical speed, in (0, 3].
    speed_hz : float or None
        Rotation frequency, Hz, >= 0. Exactly one of ``speed_fraction`` and ``speed_hz``.
    critical_speed_convention : {"ball", "drum"}
        omega_c = sqrt(2 g / (D - d_max)) ("ball", DESIGN.md) or sqrt(2 g / D) ("drum").
    gravity : float
        m/s^2, > 0, acting along -y.
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
    gravity: float = 9.81
    clamp_normal_force: bool = False
    name: str = ""
    _index: dict[str, int] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        o = "Scene"
        if not isinstance(self.drum, Drum):
            raise _fail(o, "drum", self.drum, "", "a Drum")
        charge = tuple(self.charge) if isinstance(self.charge, Sequence) else ()
        if not charge or not all(isinstance(f, Fraction) for f in charge):
            raise _fail(o, "charge", self.charge, "", "a non-empty sequence of Fraction")
        materials = tuple(self.materials) if isinstance(self.materials, Sequence) else ()
        if not materials or not all(isinstance(m, Material) for m in materials):
            raise _fail(o, "materials", self.materials, "", "a non-empty sequence of Material")
        pairs = tuple(self.pairs) if isinstance(self.pairs, Sequence) else ()
        if not all(isinstance(p, Pair) for p in pairs):
            raise _fail(o, "pairs", self.pairs, "", "a sequence of Pair")
        _set(self, charge=charge, materials=materials, pairs=pairs)

        index: dict[str, int] = {}
        for k, m in enumerate(materials):
            if m.name in index:
                raise _fail(o, "materials", m.name, "", "unique names (this one repeats)")
            index[m.name] = k
        _set(self, _index=index)
        for where, name in [("drum.material", self.drum.material)] + [
                (f"charge[{k}].material", f.material) for k, f in enumerate(charge)]:
            if name not in index:
                raise _fail(o, where, name, "", f"one of the materials {sorted(index)}")
        used = self.used_materials()
        seen: set[frozenset[str]] = set()
        for p in pairs:
            for end in (p.a, p.b):
                if end not in index:
                    raise _fail(o, "pairs", f"{p.a}-{p.b}", "",
                                f"between known materials {sorted(index)}")
            if p.key in seen:
                raise _fail(o, "pairs", f"{p.a}-{p.b}", "", "given once (this pair repeats)")
            seen.add(p.key)
        for i, a in enumerate(used):
            for b in used[i:]:
                if frozenset((a, b)) not in seen:
                    raise _fail(o, "pairs", f"missing {a}-{b}", "",
                                "one Pair for every pair of materials in use")

        if (self.speed_fraction is None) == (self.speed_hz is None):
            raise _fail(o, "speed_fraction", self.speed_fraction, "",
                        "given, or speed_hz given, but not both")
        if self.speed_fraction is not None:
            s = _positive(o, "speed_fraction", self.speed_fraction)
            if s > 3.0:
                raise _fail(o, "speed_fraction", self.speed_fraction, "", "in (0, 3]")
            _set(self, speed_fraction=s)
        else:
            hz = _number(o, "speed_hz", self.speed_hz, "Hz")
            if hz < 0.0:
                raise _fail(o, "speed_hz", self.speed_hz, "Hz", ">= 0")
            _set(self, speed_hz=hz)
        if self.critical_speed_convention not in CRITICAL_SPEED_CONVENTIONS:
            raise _fail(o, "critical_speed_convention", self.critical_speed_convention, "",
                        f"one of {CRITICAL_SPEED_CONVENTIONS}")
        _set(self, gravity=_positive(o, "gravity", self.gravity, "m/s^2"))
        if not isinstance(self.clamp_normal_force, bool):
            raise _fail(o, "clamp_normal_force", self.clamp_normal_force, "", "True or False")
        if not isinstance(self.name, str):
            raise _fail(o, "name", self.name, "", "a string")

        # Geometry: every particle fits between the lifter tips and the axis.
        drum = self.drum
        gap = drum.radius - (0.0 if drum.lifters is None else drum.lifters.height)
        for f in charge:
            if f.diameter >= gap:
                raise _fail(o, f"charge[{f.name!r}].diameter", f.diameter, "m",
                            f"< {gap:.4g} m, the gap between the lifter tips and the axis")
            if not drum.end_walls and f.diameter > 0.5 * drum.length:
                raise _fail(o, f"charge[{f.name!r}].diameter", f.diameter, "m",
                            f"<= half the period {drum.length} m of a drum with periodic ends")
            if drum.end_walls and f.diameter >= drum.length:
                raise _fail(o, f"charge[{f.name!r}].diameter", f.diameter, "m",
                            f"< the drum length {drum.length} m")
        solid = self.charge_volume()
        room = RANDOM_CLOSE_PACKING * drum.free_volume
        if solid > room:
            raise _fail(o, "charge", f"{solid:.4g} m^3 of solid", "",
                        f"<= {room:.4g} m^3 ({RANDOM_CLOSE_PACKING} x the drum's free volume): "
                        "more charge than the drum holds")

    # -- materials and pairs -----------------------------------------------------------------
    def used_materials(self) -> list[str]:
        """Names of the materials in use (drum first), each once."""
        names = [self.drum.material] + [f.material for f in self.charge]
        return list(dict.fromkeys(names))

    def material(self, name: str) -> Material:
        return self.materials[self.material_index(name)]

    def material_index(self, name: str) -> int:
        """Index of material ``name`` in ``materials``."""
        try:
            return self._index[name]
        except KeyError:
            raise ValueError(f"material {name!r} is not in this scene; it has "
                             f"{sorted(self._index)}") from None

    def pair(self, a: str, b: str) -> Pair:
        """The Pair of materials a and b (either order)."""
        key = frozenset((a, b))
        for p in self.pairs:
            if p.key == key:
                return p
        raise ValueError(f"no Pair for materials {a!r} and {b!r} in this scene")

    def pair_matrices(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Restitution and friction, each (n, n) symmetric in ``materials`` order.

        Pairs of materials not in use (no Pair needed) get e = 1, mu = 0; no contact uses them.
        """
        n = len(self.materials)
        e = np.ones((n, n))
        mu = np.zeros((n, n))
        for p in self.pairs:
            i, j = self._index[p.a], self._index[p.b]
            e[i, j] = e[j, i] = p.restitution
            mu[i, j] = mu[j, i] = p.friction
        return e, mu

    @property
    def has_friction(self) -> bool:
        return any(p.friction > 0.0 for p in self.pairs)

    @property
    def single_material(self) -> bool:
        """The drum and the whole charge are of one material."""
        return len(self.used_materials()) == 1

    # -- charge ------------------------------------------------------------------------------
    @property
    def n_particles(self) -> int:
        return sum(f.count for f in self.charge)

    @property
    def max_diameter(self) -> float:
        return max(f.diameter for f in self.charge)

    @property
    def min_diameter(self) -> float:
        return min(f.diameter for f in self.charge)

    def particle_radii(self) -> NDArray[np.float64]:
        """(N,) radii, m, fractions in ``charge`` order."""
        return np.concatenate([np.full(f.count, f.radius) for f in self.charge])

    def particle_materials(self) -> NDArray[np.int32]:
        """(N,) material indices into ``materials``, fractions in ``charge`` order."""
        return np.concatenate([np.full(f.count, self._index[f.material], dtype=np.int32)
                               for f in self.charge])

    def charge_volume(self) -> float:
        """Solid volume of the charge, m^3."""
        return sum(f.volume for f in self.charge)

    def charge_mass(self) -> float:
        """Mass of the charge, kg."""
        return sum(f.volume * self.material(f.material).density for f in self.charge)

    def bed_filling(self, porosity: float = 0.45) -> float:
        """Fraction of the drum volume the charge takes at rest with bed ``porosity``."""
        if not 0.0 <= porosity < 1.0:
            raise ValueError(f"porosity = {porosity!r} is not valid; it must be in [0, 1)")
        return self.charge_volume() / (1.0 - porosity) / self.drum.volume

    def rayleigh_times(self) -> list[tuple[str, float]]:
        """(fraction name, Rayleigh time T_R = pi r sqrt(rho/G) / (0.1631 nu + 0.8766), s)."""
        from .contact import rayleigh_time

        out = []
        for f in self.charge:
            m = self.material(f.material)
            out.append((f.name, rayleigh_time(f.diameter, m.density, m.shear_modulus, m.poisson)))
        return out

    def min_rayleigh_time(self) -> tuple[float, str]:
        """The smallest Rayleigh time of the charge, s, and the fraction that sets it."""
        name, t = min(self.rayleigh_times(), key=lambda item: item[1])
        return t, name

    # -- speed -------------------------------------------------------------------------------
    @property
    def critical_speed_rad_s(self) -> float:
        """omega_c = sqrt(2 g / (D - d_max)) ("ball") or sqrt(2 g / D) ("drum"), rad/s."""
        span = self.drum.diameter - (self.max_diameter
                                     if self.critical_speed_convention == "ball" else 0.0)
        return math.sqrt(2.0 * self.gravity / span)

    @property
    def omega(self) -> float:
        """Rotation speed, rad/s (about +z)."""
        if self.speed_fraction is not None:
            return self.speed_fraction * self.critical_speed_rad_s
        return 2.0 * math.pi * float(self.speed_hz)  # type: ignore[arg-type]

    @property
    def rotation_hz(self) -> float:
        """Rotation frequency, Hz."""
        return self.omega / (2.0 * math.pi)

    # -- dicts -------------------------------------------------------------------------------
    def to_dict(self) -> dict[str, Any]:
        """A plain, JSON-serialisable dict (see :meth:`from_dict`)."""
        lift = self.drum.lifters
        return {
            "format": SCENE_FORMAT,
            "name": self.name,
            "drum": {"diameter": self.drum.diameter, "length": self.drum.length,
                     "material": self.drum.material, "end_walls": self.drum.end_walls,
                     "lifters": None if lift is None else {
                         "count": lift.count, "width": lift.width, "height": lift.height,
                         "profile": lift.profile, "top_width": lift.top_width,
                         "phase": lift.phase}},
            "charge": [{"material": f.material, "diameter": f.diameter, "count": f.count,
                        "name": f.name} for f in self.charge],
            "materials": [{"name": m.name, "density": m.density,
                           "shear_modulus": m.shear_modulus, "poisson": m.poisson}
                          for m in self.materials],
            "pairs": [{"a": p.a, "b": p.b, "restitution": p.restitution,
                       "friction": p.friction} for p in self.pairs],
            "speed_fraction": self.speed_fraction,
            "speed_hz": self.speed_hz,
            "critical_speed_convention": self.critical_speed_convention,
            "gravity": self.gravity,
            "clamp_normal_force": self.clamp_normal_force,
        }

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> Scene:
        """The Scene of a :meth:`to_dict` dict; validates everything."""
        if not isinstance(d, Mapping) or d.get("format") != SCENE_FORMAT:
            found = d.get("format") if isinstance(d, Mapping) else type(d).__name__
            raise ValueError(f"not a millscope scene: format {found!r}, expected "
                             f"{SCENE_FORMAT!r}")
        try:
            dd = d["drum"]
            lift = dd["lifters"]
            drum = Drum(dd["diameter"], dd["length"], dd["material"], dd["end_walls"],
                        None if lift is None else Lifters(**lift))
            return cls(drum=drum,
                       charge=tuple(Fraction(**f) for f in d["charge"]),
                       materials=tuple(Material(**m) for m in d["materials"]),
                       pairs=tuple(Pair(**p) for p in d["pairs"]),
                       speed_fraction=d["speed_fraction"], speed_hz=d["speed_hz"],
                       critical_speed_convention=d["critical_speed_convention"],
                       gravity=d["gravity"], clamp_normal_force=d["clamp_normal_force"],
                       name=d["name"])
        except (KeyError, TypeError) as exc:
            raise ValueError(f"a scene dict is incomplete or malformed: {exc!r}") from None

    def replace(self, **changes: Any) -> Scene:
        """A copy with some fields changed (validated again)."""
        return replace(self, **changes)

    def describe(self) -> str:
        """A short human summary."""
        d = self.drum
        lift = ("no lifters" if d.lifters is None else
                f"{d.lifters.count} {d.lifters.profile} lifters {d.lifters.width * 1e3:g} x "
                f"{d.lifters.height * 1e3:g} mm")
        ends = "end walls" if d.end_walls else "periodic ends"
        lines = [f"{self.name or 'scene'}: drum {d.diameter:g} m x {d.length:g} m "
                 f"({d.material}), {lift}, {ends}"]
        for f in self.charge:
            lines.append(f"  {f.name}: {f.count} x {f.diameter * 1e3:g} mm {f.material}")
        pct = self.omega / self.critical_speed_rad_s * 100.0
        t, which = self.min_rayleigh_time()
        lines.append(f"  speed {pct:.1f} % of critical ({self.rotation_hz:.4f} Hz); "
                     f"smallest Rayleigh time {t:.4g} s ({which})")
        return "\n".join(lines)

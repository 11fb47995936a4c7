"""The contact law on its own: pair constants, time-step criteria and single impacts.

The DEM engine's contact law is Hertz-Mindlin no-slip with damping (paper section 3.1,
eqs. 1-8; DESIGN.md section 2), implemented in C++ (``cpp/include/millscope/contact.hpp``).
This module exposes it for checks and advice:

- :func:`pair_properties`: E*, G*, R*, m*, beta of a pair of bodies;
- :func:`rayleigh_time`, :func:`hertz_contact_time`, :func:`hertz_max_overlap`,
  :func:`hertz_stability_dt`: time-step criteria (the engine's default step is
  ``DEFAULT_DT_FRACTION`` x the smallest Rayleigh time and it refuses steps above
  ``MAX_DT_FRACTION`` x that time; :mod:`millscope.stiffness` applies them to a scene);
- :func:`impact`: one collision of two spheres, or of a sphere and a flat wall, integrated with
  the engine's law and integrator (velocity Verlet, damping on half-step velocities). It reports
  the restitution obtained, the contact duration, the largest overlap and the state after the
  contact; ``result.samples_per_contact`` tells how many steps the impact spans at ``dt``.

Conventions: SI units; a material is a :class:`ContactMaterial`, any object with ``density``
(kg/m^3), ``shear_modulus`` (Pa) and ``poisson`` attributes, or a ``(density, shear_modulus,
poisson)`` tuple. ``diameter_b=None`` makes b a flat wall (R_b, m_b -> infinity) of
``material_b``, whose elastic constants enter E* and G*; ``material_b=None`` is a wall of
``material_a``'s constants. Bad input raises ``ValueError`` naming the parameter, its value and
the valid range.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Protocol, Union

from . import _core

__all__ = [
    "DEFAULT_DT_FRACTION",
    "MAX_DT_FRACTION",
    "ContactMaterial",
    "ImpactResult",
    "PairProperties",
    "hertz_contact_time",
    "hertz_max_overlap",
    "hertz_stability_dt",
    "impact",
    "pair_properties",
    "rayleigh_time",
]

#: Default time step as a fraction of the smallest Rayleigh time (DESIGN.md section 2).
DEFAULT_DT_FRACTION: float = float(_core.DEFAULT_DT_FRACTION)
#: Largest time step the engine accepts, as a fraction of the smallest Rayleigh time.
MAX_DT_FRACTION: float = float(_core.MAX_DT_FRACTION)


class _MaterialAttributes(Protocol):
    @property
    def density(self) -> float: ...
    @property
    def shear_modulus(self) -> float: ...
    @property
    def poisson(self) -> float: ...


MaterialLike = Union["ContactMaterial", _MaterialAttributes, tuple[float, float, float]]


def _number(value: object, name: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        try:
            value = float(value)  # type: ignore[arg-type]  # numpy scalars and the like
        except (TypeError, ValueError):
            raise ValueError(f"{name} = {value!r} is not valid; it must be a number") from None
    return float(value)  # type: ignore[arg-type]


def _positive(value: object, name: str, unit: str) -> float:
    x = _number(value, name)
    if not (math.isfinite(x) and x > 0):
        raise ValueError(f"{name} = {value!r} is not valid; it must be finite and > 0 {unit}")
    return x


def _finite(value: object, name: str, unit: str) -> float:
    x = _number(value, name)
    if not math.isfinite(x):
        raise ValueError(f"{name} = {value!r} is not valid; it must be finite ({unit})")
    return x


#: The smallest restitution the contact law takes. The damping of eq. (3) is nearly critical
#: below it: the rebound the law gives falls far below the asked e (0.0039 for 0.01, 6e-5 for
#: 0.001, two steel balls at 1 m/s), the contact lasts 3 to 8 times its elastic duration, and
#: from about 1e-10 on it never ends.
MIN_RESTITUTION = 0.01
RESTITUTION_RANGE = f"in [{MIN_RESTITUTION:g}, 1]"


def _restitution(value: object, name: str = "restitution") -> float:
    x = _number(value, name)
    if not (MIN_RESTITUTION <= x <= 1):
        raise ValueError(f"{name} = {value!r} is not valid; it must be {RESTITUTION_RANGE} "
                         "(below, the damped contact law no longer gives the asked rebound)")
    return x


def _friction(value: object, name: str = "friction") -> float:
    x = _number(value, name)
    if not (math.isfinite(x) and x >= 0):
        raise ValueError(f"{name} = {value!r} is not valid; it must be finite and >= 0")
    return x


def _poisson(value: object, name: str) -> float:
    x = _number(value, name)
    if not (-1 < x < 0.5):
        raise ValueError(f"{name} = {value!r} is not valid; it must be in (-1, 0.5)")
    return x


@dataclass(frozen=True)
class ContactMaterial:
    """An elastic material, validated on construction (paper Table 2).

    Attributes
    ----------
    density : float
        kg/m^3, > 0.
    shear_modulus : float
        G, Pa, > 0.
    poisson : float
        Poisson's ratio nu, in (-1, 0.5).
    """

    density: float
    shear_modulus: float
    poisson: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "density", _positive(self.density, "density", "kg/m^3"))
        object.__setattr__(self, "shear_modulus",
                           _positive(self.shear_modulus, "shear_modulus", "Pa"))
        object.__setattr__(self, "poisson", _poisson(self.poisson, "poisson"))

    @property
    def youngs_modulus(self) -> float:
        """E = 2 G (1 + nu), Pa."""
        return 2 * self.shear_modulus * (1 + self.poisson)


def _material(value: object, name: str) -> _core.Material:
    if isinstance(value, tuple):
        if len(value) != 3:
            raise ValueError(f"{name} = {value!r} is not valid; a tuple must be (density, "
                             "shear_modulus, poisson)")
        density, shear, poisson = value
    else:
        try:
            density = value.density  # type: ignore[attr-defined]
            shear = value.shear_modulus  # type: ignore[attr-defined]
            poisson = value.poisson  # type: ignore[attr-defined]
        except AttributeError:
            raise ValueError(f"{name} = {value!r} is not valid; it must have density, "
                             "shear_modulus and poisson (or be such a tuple)") from None
    return _core.Material(_positive(density, f"{name}.density", "kg/m^3"),
                          _positive(shear, f"{name}.shear_modulus", "Pa"),
                          _poisson(poisson, f"{name}.poisson"))


def _bodies(material_a: MaterialLike, material_b: MaterialLike | None, diameter_a: float,
            diameter_b: float | None) -> tuple[_core.Material, _core.Material, bool, float,
                                               float]:
    """(a, b, wall, radius_a, radius_b); diameter_b None is a wall, of a's material if b is None."""
    a = _material(material_a, "material_a")
    ra = _positive(diameter_a, "diameter_a", "m") / 2
    if diameter_b is None:
        return a, (a if material_b is None else _material(material_b, "material_b")), True, ra, 0.0
    if material_b is None:
        raise ValueError(f"material_b = None is not valid with diameter_b = {diameter_b!r}; a "
                         "wall (material_b None) takes diameter_b=None")
    return a, _material(material_b, "material_b"), False, ra, \
        _positive(diameter_b, "diameter_b", "m") / 2


@dataclass(frozen=True)
class PairProperties:
    """Equivalent quantities of a contact (DESIGN.md section 2).

    Attributes
    ----------
    e_star, g_star : float
        E* and G*, Pa.
    r_star : float
        R*, m (R_a for a wall).
    m_star : float
        m*, kg (m_a for a wall).
    beta : float
        ln(e) / sqrt(ln^2 e + pi^2) (eq. 3), in (-1, 0].
    restitution, friction : float
        The pair's values.
    """

    e_star: float
    g_star: float
    r_star: float
    m_star: float
    beta: float
    restitution: float
    friction: float


def _properties(a: _core.Material, b: _core.Material, wall: bool, ra: float, rb: float,
                restitution: float, friction: float) -> PairProperties:
    pc = _core.pair_constants(a, b, restitution, friction)
    ma = _core.sphere_mass(a.density, ra)
    mb = math.inf if wall else _core.sphere_mass(b.density, rb)
    return PairProperties(e_star=pc.e_star, g_star=pc.g_star,
                          r_star=_core.reduced(ra, math.inf if wall else rb),
                          m_star=_core.reduced(ma, mb), beta=pc.beta,
                          restitution=pc.restitution, friction=pc.friction)


def pair_properties(material_a: MaterialLike, material_b: MaterialLike | None,
                    diameter_a: float, diameter_b: float | None, restitution: float = 1.0,
                    friction: float = 0.0) -> PairProperties:
    """E*, G*, R*, m* and beta of sphere a against sphere b, or against a wall.

    Parameters
    ----------
    material_a, material_b : material
        ``material_b`` is the wall's material when ``diameter_b`` is None; None there means a wall
        with ``material_a``'s constants.
    diameter_a, diameter_b : float
        m; ``diameter_b=None``: b is a flat wall of infinite radius and mass.
    restitution : float
        Pair restitution e, in [``MIN_RESTITUTION``, 1] = [0.01, 1].
    friction : float
        Pair friction coefficient, >= 0.
    """
    a, b, wall, ra, rb = _bodies(material_a, material_b, diameter_a, diameter_b)
    return _properties(a, b, wall, ra, rb, _restitution(restitution), _friction(friction))


def rayleigh_time(diameter: float, density: float, shear_modulus: float,
                  poisson: float) -> float:
    """Rayleigh time T_R = pi r sqrt(rho/G) / (0.1631 nu + 0.8766), s, of a sphere.

    The engine's default step is ``DEFAULT_DT_FRACTION`` (0.2) x the smallest T_R of the charge
    and it refuses steps above ``MAX_DT_FRACTION`` (0.5) x that time.
    """
    return float(_core.rayleigh_time(_positive(diameter, "diameter", "m") / 2,
                                     _positive(density, "density", "kg/m^3"),
                                     _positive(shear_modulus, "shear_modulus", "Pa"),
                                     _poisson(poisson, "poisson")))


def hertz_contact_time(material_a: MaterialLike, material_b: MaterialLike | None,
                       diameter_a: float, diameter_b: float | None, speed: float) -> float:
    """Duration of an elastic head-on Hertz impact, t_c = 2.87 (m*^2 / (R* E*^2 v))^(1/5), s.

    ``speed`` is the normal approach speed v (m/s, > 0); the other parameters are those of
    :func:`pair_properties`.
    """
    p = pair_properties(material_a, material_b, diameter_a, diameter_b)
    return float(_core.hertz_contact_time(p.m_star, p.r_star, p.e_star,
                                          _positive(speed, "speed", "m/s")))


def hertz_max_overlap(material_a: MaterialLike, material_b: MaterialLike | None,
                      diameter_a: float, diameter_b: float | None, speed: float) -> float:
    """Largest overlap of an elastic head-on Hertz impact,
    d_max = (15 m* v^2 / (16 E* sqrt(R*)))^(2/5), m."""
    p = pair_properties(material_a, material_b, diameter_a, diameter_b)
    return float(_core.hertz_max_overlap(p.m_star, p.r_star, p.e_star,
                                         _positive(speed, "speed", "m/s")))


def hertz_stability_dt(material_a: MaterialLike, material_b: MaterialLike | None,
                       diameter_a: float, diameter_b: float | None, speed: float) -> float:
    """Velocity-Verlet stability limit of an elastic head-on Hertz impact, dt = 2 / w_max, s.

    w_max^2 = S_n(d_max) / m* = 2 E* sqrt(R* d_max) / m* is the contact's highest angular
    frequency, at its largest overlap (eq. 4; ``cpp/include/millscope/timestep.hpp``). Velocity
    Verlet on a spring of angular frequency w is stable for dt < 2 / w.
    """
    p = pair_properties(material_a, material_b, diameter_a, diameter_b)
    return float(_core.hertz_stability_dt(p.m_star, p.r_star, p.e_star,
                                          _positive(speed, "speed", "m/s")))


@dataclass(frozen=True)
class ImpactResult:
    """One impact integrated with the engine's contact law.

    Axes: b (or the wall) below a; n = +y from b to a; tangent t = +x; spins about +z.

    Attributes
    ----------
    restitution : float
        Normal separation speed / approach speed.
    contact_time : float
        s, from first touch to separation (interpolated within the last step).
    max_overlap : float
        m.
    tangential_velocity : float
        (v_a - v_b) . t after the impact, m/s.
    spin, spin_b : float
        Angular velocities of a and b about +z after the impact, rad/s (spin_b = 0 for a wall).
    slip_velocity : float
        Contact-point relative velocity along t after the impact, m/s (0: rolling).
    normal_impulse, normal_impulse_abs, tangential_impulse : float
        Sum of F_n dt, of |F_n| dt and of F_t . t dt on a, N s. Coulomb's law (8) bounds
        |tangential_impulse| by friction x normal_impulse_abs.
    kinetic_energy_before, kinetic_energy_after : float
        J, translation and rotation of both bodies.
    dt : float
        The step used, s.
    contact_steps, sliding_steps : int
        Steps in contact, and of those at the Coulomb limit.
    hertz_contact_time, hertz_max_overlap : float
        Elastic Hertz theory at this speed, s and m.
    pair : PairProperties
        The equivalent quantities used.
    """

    restitution: float
    contact_time: float
    max_overlap: float
    tangential_velocity: float
    spin: float
    spin_b: float
    slip_velocity: float
    normal_impulse: float
    normal_impulse_abs: float
    tangential_impulse: float
    kinetic_energy_before: float
    kinetic_energy_after: float
    dt: float
    contact_steps: int
    sliding_steps: int
    hertz_contact_time: float
    hertz_max_overlap: float
    pair: PairProperties

    @property
    def samples_per_contact(self) -> float:
        """contact_time / dt: how many steps the impact spans."""
        return self.contact_time / self.dt


def impact(material_a: MaterialLike, material_b: MaterialLike | None, diameter_a: float,
           diameter_b: float | None, speed: float, restitution: float, friction: float,
           dt: float | None = None, tangential_speed: float = 0.0, spin: float = 0.0, *,
           clamp_normal: bool = False) -> ImpactResult:
    """Integrates one impact of sphere a on sphere b (at rest) or on a flat wall.

    Parameters
    ----------
    material_a, material_b : material
        ``material_b`` is the wall's material when ``diameter_b`` is None; None there means a wall
        with ``material_a``'s constants.
    diameter_a, diameter_b : float
        m; ``diameter_b=None``: b is a flat wall of infinite radius and mass.
    speed : float
        Normal approach speed, m/s, > 0.
    restitution : float
        Pair restitution e, in [``MIN_RESTITUTION``, 1] = [0.01, 1] (eq. 3).
    friction : float
        Pair friction coefficient, >= 0; 0 runs the frictionless law.
    dt : float, optional
        Time step, s, below the elastic Hertz contact time. Default: the engine's default,
        ``DEFAULT_DT_FRACTION`` x the smaller Rayleigh time of the sphere(s).
    tangential_speed : float
        Initial velocity of a's centre along the tangent +x, m/s.
    spin : float
        Initial angular velocity of a about +z, rad/s. A rolling sphere on the wall has
        ``spin = -2 tangential_speed / diameter_a``.
    clamp_normal : bool
        Forbid a tensile total normal force (the engine's option; off by default).
    """
    a, b, wall, ra, rb = _bodies(material_a, material_b, diameter_a, diameter_b)
    e = _restitution(restitution)
    mu = _friction(friction)
    v = _positive(speed, "speed", "m/s")
    vt = _finite(tangential_speed, "tangential_speed", "m/s")
    w = _finite(spin, "spin", "rad/s")
    pair = _properties(a, b, wall, ra, rb, e, mu)
    if dt is None:
        t_r = _core.rayleigh_time(ra, a.density, a.shear_modulus, a.poisson)
        if not wall:
            t_r = min(t_r, _core.rayleigh_time(rb, b.density, b.shear_modulus, b.poisson))
        step = DEFAULT_DT_FRACTION * t_r
    else:
        step = _positive(dt, "dt", "s")
    r = _core.contact_probe(a, b, wall, ra, rb, e, mu, v, vt, w, step, bool(clamp_normal))
    return ImpactResult(
        restitution=r.restitution, contact_time=r.contact_time, max_overlap=r.max_overlap,
        tangential_velocity=r.tangential_velocity, spin=r.spin_a, spin_b=r.spin_b,
        slip_velocity=r.slip_velocity, normal_impulse=r.normal_impulse,
        normal_impulse_abs=r.normal_impulse_abs, tangential_impulse=r.tangential_impulse,
        kinetic_energy_before=r.kinetic_energy_before,
        kinetic_energy_after=r.kinetic_energy_after, dt=r.dt, contact_steps=r.contact_steps,
        sliding_steps=r.sliding_steps, hertz_contact_time=r.hertz_contact_time,
        hertz_max_overlap=r.hertz_max_overlap, pair=pair)

"""The contact law on its own: pair constants, time-step criteria and single impacts.

The DEM engine's contact law is Hertz-Mindlin no-slip with damping (paper section 3.1,
eqs. 1-8; docs/physics.md, The law), implemented in C++ (``cpp/include/millscope/contact.hpp``).
This module exposes it for checks and advice:

- :func:`pair_properties`: E*, G*, R*, m*, beta of a pair of bodies;
- :func:`rayleigh_time`, :func:`hertz_contact_time`, :func:`hertz_max_overlap`,
  :func:`hertz_stability_dt`: time-step criteria (the engine's default step is
  ``DEFAULT_DT_FRACTION`` x the smallest Rayleigh time and it never takes steps above
  ``MAX_DT_FRACTION`` x that time; :mod:`millscope.stiffness` applies them to a scene);
- :func:`verlet_stability_bound`, :func:`contact_modes`: the fastest modes of a contact (the
  damped normal mode and the tangential stick mode coupled with rotation) and the largest step
  velocity Verlet integrates them stably with (:func:`millscope.stiffness.time_step_limit` takes
  the smallest over a scene's pairs);
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

from .. import _core

__all__ = [
    "DEFAULT_DT_FRACTION",
    "MAX_DT_FRACTION",
    "DT_SAFETY_FACTOR",
    "NORMAL_MODE",
    "STICK_MODE",
    "ContactMaterial",
    "ContactMode",
    "ImpactResult",
    "PairProperties",
    "hertz_contact_time",
    "hertz_max_overlap",
    "hertz_stability_dt",
    "contact_modes",
    "impact",
    "pair_properties",
    "rayleigh_time",
    "verlet_stability_bound",
]

#: Default time step as a fraction of the smallest Rayleigh time (docs/physics.md, Time step).
DEFAULT_DT_FRACTION: float = float(_core.DEFAULT_DT_FRACTION)
#: Largest time step the engine accepts, as a fraction of the smallest Rayleigh time (its cap;
#: a scene's contacts may set a lower limit, :func:`millscope.stiffness.time_step_limit`).
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
    return float(value)


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
    """Equivalent quantities of a contact (docs/physics.md, Pair constants).

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
    and it refuses steps above ``MAX_DT_FRACTION`` (0.5) x that time, or above the lower limit
    its contacts' modes may set (:func:`millscope.stiffness.time_step_limit`).
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


# -- the fastest modes of a contact and velocity Verlet's stability bound ----------------------

#: Name of the damped normal mode (:func:`contact_modes`).
NORMAL_MODE = "damped normal"
#: Name of the tangential stick mode coupled with the spheres' rotation (:func:`contact_modes`).
STICK_MODE = "tangential-rotational stick"

#: The largest accepted time step is this fraction of the stability bound (S3) of a scene's
#: fastest contact mode (:func:`millscope.stiffness.time_step_limit`). Why 0.8:
#:
#: - a sphere struck while it touches a third body at a like overlap has faster modes than the
#:   pair alone: for three like spheres in a line the normal one is sqrt(3 k / m) against the
#:   pair's sqrt(2 k / m) (x 1.22) and the stick one sqrt(8.5 / 7) = 1.10 x the pair's (M2);
#:   1 / 1.22 = 0.82;
#: - measured on oblique impacts at the upper impact speed of the x 0.001 presets, against
#:   converged ones (``tests/physics/test_timestep.py``): at 0.8 x the bound the spin errs no
#:   more than at 0.2 x it (up to 19-28 % at low tangential speeds, the touch-down slip) and the
#:   restitution by at most 7 %; the steel pairs (e = 0.5, the least damped, whose elastic
#:   overlap overstates the damped one least) lose accuracy from 0.95 x the bound on (spin up to
#:   41 %, then 52 % at 1.0), and at 1.2 x it every pair has impacts whose spin is off by more
#:   than 100 %, often in sign;
#: - it keeps the default step, 0.2 x the Rayleigh time, valid for every preset: the smallest
#:   bound among them (ceramic particles on the drum, moduli x 0.001, 3 x critical speed) is
#:   0.345 Rayleigh times, and 0.8 x 0.345 = 0.276.
DT_SAFETY_FACTOR: float = 0.8

#: 1 / m_t = this / m* for the slip of two solid spheres' contact point (M2): 1 + r^2 m / I.
_STICK_MASS_FACTOR = 3.5


def verlet_stability_bound(damping_ratio: float) -> float:
    """Largest w0 dt at which the engine's velocity Verlet integrates a damped oscillator
    stably, 2 (sqrt(1 + zeta^2) - zeta) (dimensionless).

    The engine's step (``cpp/src/step/``; ``contact_probe.cpp`` the same): half a kick
    with the force of the step before, a drift, the contact force evaluated at the new
    position with the half-step velocity, the second half kick. The two half kicks between
    drifts join, so for m x'' + c x' + k x = 0 (w0^2 = k / m, zeta = c / (2 sqrt(k m)),
    W = w0 dt) the state z_n = (x_n, dt v_(n-1/2)) advances as::

        v_(n+1/2) = v_(n-1/2) - dt (k x_n + c v_(n-1/2)) / m,   x_(n+1) = x_n + dt v_(n+1/2)
        z_(n+1) = A z_n,   A = [[1 - W^2, 1 - 2 zeta W], [-W^2, 1 - 2 zeta W]]           (S1)
        tr A = 2 - W^2 - 2 zeta W,   det A = 1 - 2 zeta W                                  (S2)

    Both eigenvalues lie inside the unit circle iff |det A| < 1 and |tr A| < 1 + det A
    (Schur-Cohn). For W > 0 that is zeta W < 1 and W^2 + 4 zeta W - 4 < 0, the second
    implying the first::

        W < 2 (sqrt(1 + zeta^2) - zeta) = 2 / (sqrt(1 + zeta^2) + zeta)                  (S3)

    At the bound an eigenvalue leaves the circle through -1: the force changes sign every step
    and grows. zeta = 0 gives the undamped 2 (eigenvalues on the circle below it); damping
    lowers it: 1.65 at zeta = 0.197 (e = 0.5, normal), 1.33 at 0.416 (e = 0.2, normal), 0.98 at
    0.778 (e = 0.2, stick mode).

    Parameters
    ----------
    damping_ratio : float
        zeta, >= 0.
    """
    z = _number(damping_ratio, "damping_ratio")
    if not (math.isfinite(z) and z >= 0):
        raise ValueError(f"damping_ratio = {damping_ratio!r} is not valid; it must be finite "
                         "and >= 0")
    return 2.0 / (math.sqrt(1.0 + z * z) + z)


@dataclass(frozen=True)
class ContactMode:
    """One mode of a contact, linearised at an overlap (:func:`contact_modes`).

    Attributes
    ----------
    name : str
        :data:`NORMAL_MODE` or :data:`STICK_MODE`.
    stiffness : float
        S_n (4) or S_t (6) at ``overlap``, N/m.
    mass : float
        The mass the spring moves: m* (normal) or m_t = m* / 3.5 (stick), kg.
    damping_ratio : float
        zeta = gamma / (2 sqrt(stiffness x mass)) of the paper's dashpot (2) or (7).
    overlap : float
        The normal overlap the stiffness is evaluated at, m.
    """

    name: str
    stiffness: float
    mass: float
    damping_ratio: float
    overlap: float

    @property
    def angular_frequency(self) -> float:
        """w0 = sqrt(stiffness / mass), rad/s."""
        return math.sqrt(self.stiffness / self.mass)

    @property
    def stability_dt(self) -> float:
        """The largest stable step (S3), verlet_stability_bound(zeta) / w0, s (no safety)."""
        return verlet_stability_bound(self.damping_ratio) / self.angular_frequency


def contact_modes(material_a: MaterialLike, material_b: MaterialLike | None, diameter_a: float,
                  diameter_b: float | None, speed: float, restitution: float,
                  friction: float) -> tuple[ContactMode, ...]:
    """The damped normal mode and, with friction, the tangential stick mode of a contact, at
    the largest overlap of an elastic head-on impact at ``speed``.

    **Normal.** Hertz's force (1) has the tangent stiffness dF_ne/dd_n = 2 E* sqrt(R* d_n)
    = S_n (4); the dashpot (2) is gamma_n = -2 sqrt(5/6) beta sqrt(S_n m*) (beta of (3)), on
    the reduced mass m*::

        w_n = sqrt(S_n / m*),   zeta_n = gamma_n / (2 sqrt(S_n m*)) = -sqrt(5/6) beta      (M1)

    **Stick.** While the contact sticks, the spring S_t = 8 G* sqrt(R* d_n) (5-6) and the
    dashpot gamma_t = -2 sqrt(5/6) beta sqrt(S_t m*) (7) act on the slip of the contact point,
    which moves with the centres and with the spins: a force F along the tangent changes the
    slip rate by F (1/m_a + r_a^2/I_a + 1/m_b + r_b^2/I_b) = F / m_t, and for solid spheres
    (I = 2/5 m r^2) 1/m_t = 3.5/m_a + 3.5/m_b = 3.5/m* (a wall: 3.5/m_a, its mass and inertia
    infinite). Note the paper's dashpot takes m*, not m_t::

        w_t = sqrt(S_t / m_t) = sqrt(3.5 S_t / m*),   zeta_t = gamma_t / (2 sqrt(S_t m_t))
            = sqrt(3.5) zeta_n                                                              (M2)

    The engine advances the history d_t by the half-step slip velocity times dt and evaluates
    the dashpot with that velocity, the scheme of the normal direction, so (S3) holds for both.
    (The other tangential motion, rolling without slip, has no spring.) For like spheres
    S_t / S_n = 4 G*/E* = 2 (1 - nu) / (2 - nu), 0.82 at nu = 0.3: w_t = 1.7 w_n, and the
    stick mode sets the limit whenever friction > 0 (at e = 0.2, 0.98 / w_t = 0.58 / w_n
    against the normal mode's 1.33 / w_n).

    Both stiffnesses grow as sqrt(d_n); they are taken at the elastic impact's largest overlap
    d_max = (15 m* v^2 / (16 E* sqrt(R*)))^(2/5) (:func:`hertz_max_overlap`); a damped impact
    stays shallower.

    Parameters
    ----------
    material_a, material_b, diameter_a, diameter_b
        As for :func:`pair_properties`; ``diameter_b=None`` is a wall.
    speed : float
        Normal approach speed, m/s, > 0.
    restitution : float
        Pair restitution e, in (0, 1].
    friction : float
        Pair friction coefficient, >= 0; 0 has no stick mode.

    Returns
    -------
    tuple of ContactMode
        The normal mode, then the stick mode when ``friction > 0``.
    """
    a, b, wall, ra, rb = _bodies(material_a, material_b, diameter_a, diameter_b)
    e, mu = _restitution(restitution), _friction(friction)
    v = _positive(speed, "speed", "m/s")
    pc = _core.pair_constants(a, b, e, mu)
    p = _properties(a, b, wall, ra, rb, e, mu)
    d_max = float(_core.hertz_max_overlap(p.m_star, p.r_star, p.e_star, v))
    sqrt_rd = math.sqrt(p.r_star * d_max)
    zeta_n = 0.5 * pc.damping_factor  # gamma / (2 sqrt(S m*)) with gamma = factor sqrt(S m*)
    modes = [ContactMode(NORMAL_MODE, 2.0 * p.e_star * sqrt_rd, p.m_star, zeta_n, d_max)]
    if mu > 0:
        modes.append(ContactMode(STICK_MODE, 8.0 * p.g_star * sqrt_rd,
                                 p.m_star / _STICK_MASS_FACTOR,
                                 zeta_n * math.sqrt(_STICK_MASS_FACTOR), d_max))
    return tuple(modes)


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

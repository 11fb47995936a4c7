"""Empirical and semi-empirical mill-power models, as references for the simulated drive power.

Two models of the net power a tumbling mill draws (the power the charge takes, without the
drive's and bearings' losses), each a function of the mill (inner diameter and length, m), its
speed (fraction of critical), its filling (fraction of the mill volume the charge takes, voids
included) and the charge's bulk density:

* :func:`hogg_fuerstenau_power`: the charge as a segment of the cross-section held at its
  dynamic angle of repose; the drive holds the torque of its weight (Hogg & Fuerstenau 1972).
* :func:`morrell_c_power`: Morrell's C-model (Morrell 1996): the power to lift the charge
  from toe to shoulder and to give it its kinetic energy, with empirical toe and shoulder
  angles, times a factor for the losses the model does not see.

They are references, not truth: both were built for industrial wet mills, and the pilot mill of
the paper (0.88 m, dry steel balls) lies at the small end of what they describe. docs/power.md
compares them with the simulation and says where their constants come from.

Conventions: the critical speed of these models is that of the mill diameter,
omega_c = sqrt(2 g / D) (42.3 / sqrt(D) rpm), not the ball convention ``Scene`` uses by
default; :func:`critical_speed_rad_s` gives it. Angles follow :mod:`millscope.model.charge`:
counterclockwise from the horizontal on the rising side, rad.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from .. import _checks
from .scene import GRAVITY

__all__ = ["MORRELL_K", "MillPower", "critical_speed_rad_s", "hogg_fuerstenau_power",
           "morrell_c_power", "segment_half_angle"]

#: Morrell's lumped factor for the losses the C-model does not see (net = k x charge power).
MORRELL_K = 1.26

# Ranges the models accept (their formulas' domain and the practice they come from)
MAX_DIAMETER = 15.0  # m
MAX_LENGTH = 30.0  # m
MAX_FILLING = 0.5  # a tumbling mill is at most about half full
MAX_DENSITY = 10_000.0  # kg/m^3: denser than any bed of steel balls


@dataclass(frozen=True)
class MillPower:
    """One model's estimate of a mill's net power.

    Attributes
    ----------
    model : str
        ``"Hogg-Fuerstenau"`` or ``"Morrell C"``.
    net_power_W : float
        Net power the charge draws, W (what the simulated drive power compares with).
    charge_mass_kg : float
        Mass of the charge the model assumes, kg: density x filling x mill volume.
    toe_rad, shoulder_rad : float
        Toe and shoulder of the charge, rad (:mod:`millscope.model.charge` convention): the
        ends of the segment's chord (Hogg-Fuerstenau) or the model's empirical angles
        (Morrell).
    inner_radius_m : float
        Distance of the charge's inner surface from the axis, m: the chord's distance
        (Hogg-Fuerstenau) or r_i (Morrell).
    reference : str
        The publication the model comes from.
    """

    model: str
    net_power_W: float
    charge_mass_kg: float
    toe_rad: float
    shoulder_rad: float
    inner_radius_m: float
    reference: str


def critical_speed_rad_s(diameter_m: float) -> float:
    """Critical speed of a mill of inner diameter ``diameter_m`` (m), rad/s: sqrt(2 g / D)."""
    d = _checks.between("critical_speed_rad_s diameter_m", diameter_m, 0.0, MAX_DIAMETER, "m",
                        low_open=True)
    return math.sqrt(2.0 * GRAVITY / d)


def segment_half_angle(filling: float) -> float:
    """Half the angle, rad, that a circular segment filling ``filling`` of the circle
    subtends at the centre: the root theta of (2 theta - sin 2 theta) / (2 pi) = filling."""
    j = _checks.between("segment_half_angle filling", filling, 0.0, 1.0, low_open=True)
    # bisection (the filling grows monotonically with the angle); no scipy import here, so
    # that the model layer stays quick to import
    low, high = 0.0, math.pi
    for _ in range(60):  # pi / 2^60: below the resolution of a double
        mid = 0.5 * (low + high)
        if (2.0 * mid - math.sin(2.0 * mid)) / (2.0 * math.pi) < j:
            low = mid
        else:
            high = mid
    return 0.5 * (low + high)


def _mill(where: str, diameter_m: float, length_m: float, speed_fraction: float,
          filling: float, charge_density_kg_m3: float) -> tuple[float, float, float, float,
                                                                float]:
    """The common arguments, checked: D, L, phi, J, rho_c."""
    d = _checks.between(f"{where} diameter_m", diameter_m, 0.0, MAX_DIAMETER, "m",
                        low_open=True)
    length = _checks.between(f"{where} length_m", length_m, 0.0, MAX_LENGTH, "m",
                             low_open=True)
    phi = _checks.real(f"{where} speed_fraction", speed_fraction, "", "in (0, 1)")
    if not 0.0 < phi < 1.0:
        raise _checks.fail(f"{where} speed_fraction", speed_fraction,
                           "in (0, 1) (a fraction of the critical speed sqrt(2 g / D); at 1 "
                           "and above the charge centrifuges)")
    j = _checks.between(f"{where} filling", filling, 0.0, MAX_FILLING, low_open=True,
                        why="fraction of the mill volume the charge takes, voids included")
    rho = _checks.between(f"{where} charge_density_kg_m3", charge_density_kg_m3, 0.0,
                          MAX_DENSITY, "kg/m^3", low_open=True,
                          why="bulk density of the charge, voids included")
    return d, length, phi, j, rho


def hogg_fuerstenau_power(diameter_m: float, length_m: float, speed_fraction: float,
                          filling: float, charge_density_kg_m3: float,
                          repose_angle_rad: float) -> MillPower:
    """Net power of the charge held as a segment at its dynamic angle of repose.

    The charge (bulk density rho_c) fills the fraction J of the cross-section as a circular
    segment whose chord, the free surface, is inclined at alpha to the horizontal. Its centre
    of mass lies on the perpendicular to the chord through the axis, at
    d = (2/3) R sin^3(theta) / (theta - sin theta cos theta) from it, theta the segment's half
    angle ((2 theta - sin 2 theta) / (2 pi) = J); the drive holds the torque of its weight,
    M g d sin(alpha), so

        P = omega (2/3) rho_c g L R^3 sin^3(theta) sin(alpha),  omega = phi sqrt(2 g / D).

    This is the torque-arm model of Hogg & Fuerstenau (1972), "Power relationships for
    tumbling mills", Trans. SME-AIME 252, 418-423, for a cascading charge. It has no fitted
    constant: alpha is an input (measure it, e.g. :func:`millscope.model.charge.charge_shape`,
    or take it from experience, typically 30-45 degrees). The 1972 paper itself could not be
    consulted for this work: the form is the segment torque model as the literature states it,
    derived here from the geometry, and no worked example of the paper is reproduced.

    Parameters
    ----------
    diameter_m, length_m : float
        Inner diameter (inside the liners) and length of the mill, m; in (0, 15] and (0, 30].
    speed_fraction : float
        Speed as a fraction of sqrt(2 g / D), in (0, 1).
    filling : float
        Fraction J of the mill volume the charge takes, voids included, in (0, 0.5].
    charge_density_kg_m3 : float
        Bulk density of the charge, voids included, kg/m^3, in (0, 10000].
    repose_angle_rad : float
        Dynamic angle of repose alpha, rad, in (0, pi/2).

    Returns
    -------
    MillPower
        Toe and shoulder are the ends of the chord: 3 pi/2 - theta + alpha and
        -pi/2 + theta + alpha.
    """
    d, length, phi, j, rho = _mill("hogg_fuerstenau_power", diameter_m, length_m,
                                   speed_fraction, filling, charge_density_kg_m3)
    alpha = _checks.real("hogg_fuerstenau_power repose_angle_rad", repose_angle_rad, "rad",
                         "in (0, pi/2)")
    if not 0.0 < alpha < 0.5 * math.pi:
        raise _checks.fail("hogg_fuerstenau_power repose_angle_rad", repose_angle_rad,
                           "in (0, pi/2) (the free surface rises towards the rising side)",
                           "rad")
    r = 0.5 * d
    omega = phi * critical_speed_rad_s(d)
    theta = segment_half_angle(j)
    power = omega * (2.0 / 3.0) * rho * GRAVITY * length * r**3 * math.sin(theta) ** 3 \
        * math.sin(alpha)
    return MillPower(
        model="Hogg-Fuerstenau", net_power_W=power,
        charge_mass_kg=rho * j * math.pi * r * r * length,
        toe_rad=1.5 * math.pi - theta + alpha, shoulder_rad=-0.5 * math.pi + theta + alpha,
        inner_radius_m=r * math.cos(theta),
        reference="Hogg & Fuerstenau (1972), Trans. SME-AIME 252, 418-423")


def morrell_toe_shoulder(speed_fraction: float, filling: float) -> tuple[float, float]:
    """Toe and shoulder angles of Morrell's C-model, rad (:func:`morrell_c_power`)."""
    phi, j = speed_fraction, filling
    # the fraction of critical speed at which centrifuging is complete
    phi_c = max(phi, 0.35 * (3.364 - j))
    toe = 2.5307 * (1.2796 - j) * (1.0 - math.exp(-19.42 * (phi_c - phi))) + 0.5 * math.pi
    shoulder = 0.5 * math.pi - (toe - 0.5 * math.pi) * (
        (0.3386 + 0.1041 * phi) + (1.54 - 2.5673 * phi) * j)
    return toe, shoulder


def morrell_c_power(diameter_m: float, length_m: float, speed_fraction: float,
                    filling: float, charge_density_kg_m3: float) -> MillPower:
    """Net power of a cylindrical mill by Morrell's C-model (dry, flat ends).

    The charge between the shell (radius r_m) and its inner surface r_i turns with a
    tangential speed that grows linearly with the radius, from zero at z r_i to the shell's
    speed 2 pi N_m r_m at the shell; the power is that of lifting it from the toe theta_T to
    the shoulder theta_S plus the kinetic energy it is given:

        P_c = pi g L N_m r_m / (3 (r_m - z r_i)) (2 r_m^3 - 3 z r_m^2 r_i + r_i^3 (3 z - 2))
              rho_c (sin theta_S - sin theta_T)
            + L rho_c (N_m r_m pi / (r_m - z r_i))^3 ((r_m - z r_i)^4 - r_i^4 (z - 1)^4)

    with N_m the mill speed (rev/s) and the empirical relations

    * theta_T = 2.5307 (1.2796 - J) (1 - exp(-19.42 (phi_c - phi))) + pi/2, with
      phi_c = max(phi, 0.35 (3.364 - J));
    * theta_S = pi/2 - (theta_T - pi/2) ((0.3386 + 0.1041 phi) + (1.54 - 2.5673 phi) J);
    * z = (1 - J)^0.4532;
    * r_i = r_m (1 - 2 pi beta J / (2 pi + theta_S - theta_T))^0.5, beta = t_c / (t_f + t_c)
      the share of time a particle spends in the charge rather than in flight, with
      t_c = (2 pi - theta_T + theta_S) / (2 pi N_bar), t_f = (2 r_bar (sin theta_S -
      sin theta_T) / g)^0.5, N_bar = N_m / 2 and
      r_bar = (r_m / 2) (1 + (1 - 2 pi J / (2 pi + theta_S - theta_T))^0.5).

    The net power is k P_c with k = 1.26 (:data:`MORRELL_K`), Morrell's lumped factor for the
    losses the model does not describe. Dry charge: no slurry pool, so the slurry term of the
    full model (toe of the slurry theta_TO) vanishes; flat ends: no cone term; the no-load
    power of the empty mill is not included (the simulated drive power has none).

    Source: S. Morrell (1996), "Power draw of wet tumbling mills and its relationship to charge
    dynamics. Part 2: an empirical approach to modelling of mill power draw", Trans. Instn
    Min. Metall. (Sect. C) 105, C54-C62 (the C-model; its theoretical basis in Morrell 1993,
    PhD thesis, University of Queensland). The constants above are as that model is widely
    restated; the publications themselves could not be consulted for this work, so they have
    not been checked against the original text here, and no worked example from them is
    reproduced (docs/power.md).

    Parameters
    ----------
    diameter_m, length_m : float
        Inner diameter (inside the liners) and length of the cylinder, m; in (0, 15] and
        (0, 30].
    speed_fraction : float
        Speed phi as a fraction of sqrt(2 g / D), in (0, 1).
    filling : float
        Fraction J of the mill volume the charge takes, voids included, in (0, 0.5].
    charge_density_kg_m3 : float
        Bulk density of the charge rho_c, voids included, kg/m^3, in (0, 10000].

    Returns
    -------
    MillPower
        With the model's theta_T and theta_S as toe and shoulder.
    """
    d, length, phi, j, rho = _mill("morrell_c_power", diameter_m, length_m, speed_fraction,
                                   filling, charge_density_kg_m3)
    r_m = 0.5 * d
    n_m = phi * critical_speed_rad_s(d) / (2.0 * math.pi)  # rev/s
    toe, shoulder = morrell_toe_shoulder(phi, j)
    arc = 2.0 * math.pi + shoulder - toe  # the arc of the shell the charge covers
    lift = math.sin(shoulder) - math.sin(toe)
    if 2.0 * math.pi * j >= arc:
        # slow and full: the empirical toe and shoulder leave the charge too short an arc of
        # the shell to hold the filling (r_i would be imaginary)
        raise ValueError(
            f"morrell_c_power filling = {_checks.show(filling)} at speed_fraction = "
            f"{_checks.show(speed_fraction)} is not valid: the model's toe and shoulder "
            f"({toe:.3f}, {shoulder:.3f} rad) span an arc of {arc:.3f} rad, too short to hold "
            f"it; it must be < {arc / (2.0 * math.pi):.3f} at this speed (or the speed higher)")
    r_bar = 0.5 * r_m * (1.0 + math.sqrt(1.0 - 2.0 * math.pi * j / arc))
    t_c = (2.0 * math.pi - toe + shoulder) / (2.0 * math.pi * 0.5 * n_m)
    t_f = math.sqrt(2.0 * r_bar * lift / GRAVITY)
    beta = t_c / (t_f + t_c)
    r_i = r_m * math.sqrt(1.0 - 2.0 * math.pi * beta * j / arc)
    z = (1.0 - j) ** 0.4532
    span = r_m - z * r_i
    potential = (math.pi * GRAVITY * length * n_m * r_m / (3.0 * span)
                 * (2.0 * r_m**3 - 3.0 * z * r_m**2 * r_i + r_i**3 * (3.0 * z - 2.0))
                 * rho * lift)
    kinetic = length * rho * (n_m * r_m * math.pi / span) ** 3 \
        * (span**4 - r_i**4 * (z - 1.0) ** 4)
    return MillPower(
        model="Morrell C", net_power_W=MORRELL_K * (potential + kinetic),
        charge_mass_kg=rho * j * math.pi * r_m * r_m * length,
        toe_rad=toe, shoulder_rad=shoulder, inner_radius_m=r_i,
        reference="Morrell (1996), Trans. Instn Min. Metall. (C) 105, C54-C62")

"""The shape of the charge in a turning drum: toe, shoulder, centre of mass, angle of repose.

:func:`charge_shape` reads the particle state of a simulation (``Simulation.positions``, the
scene's radii and masses) or any other bed of spheres, one snapshot or several pooled, and
returns a :class:`ChargeShape`.

Conventions (docs/power.md, Charge shape). The drum axis is the z axis through the origin;
gravity points along -y; the drum turns counterclockwise about +z as the engine turns it
(docs/architecture.md, Units and axes), so its bottom moves towards +x and the charge is lifted
on the +x side. Angles in the x-y plane are measured counterclockwise (the drum's sense of
rotation) from the +x axis, i.e. from the horizontal on the rising side, and lie in
[-pi/2, 3 pi/2), so that the bottom of the drum (-pi/2 = 3 pi/2) bounds the range. The charge
then lies along the shell from the toe (typically 3.5 to 4.2 rad, lower left) counterclockwise
through the bottom to the shoulder (typically 0 to 1 rad, upper right). This is the convention
of Morrell's C-model for theta_T and theta_S (:func:`millscope.model.mill_power.morrell_c_power`),
so the two compare directly.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .. import _checks
from .scene import GRAVITY, Scene

__all__ = ["GRAVITY", "ChargeShape", "charge_shape", "particle_masses"]


#: A bin or cell belongs to the charge when it holds at least this share of the typical mass
#: of a full one (:data:`FULL_PERCENTILE`).
THRESHOLD = 0.5
#: The typical mass of a full bin or cell: this percentile of the non-empty ones.
FULL_PERCENTILE = 90.0
#: The share of the free surface's horizontal span left out at each end of the fit (where the
#: surface bends into the toe and the shoulder).
SURFACE_TRIM = 0.2


@dataclass(frozen=True)
class ChargeShape:
    """Where the charge lies in the drum (module docstring: axes and angle convention).

    Attributes
    ----------
    toe_rad : float
        Angle of the toe, rad, in (pi/2, 3 pi/2): the clockwise end of the arc along which the
        charge lies against the shell (where falling particles land).
    shoulder_rad : float
        Angle of the shoulder, rad, in (-pi/2, pi/2) for a charge that is not centrifuging: the
        counterclockwise end of that arc (where the charge leaves the shell).
    centre_of_mass_m : tuple of float
        (x, y) of the centre of mass of the charge in the drum's cross-section, m, axis at the
        origin.
    repose_angle_rad : float
        Dynamic angle of repose, rad: the inclination to the horizontal of a straight line
        fitted to the free surface of the dense charge; positive when the surface rises
        towards +x (the rising side).
    surface_points : int
        How many points of the free surface the line was fitted to.
    mass_kg : float
        Mass of the charge, kg (per snapshot).
    """

    toe_rad: float
    shoulder_rad: float
    centre_of_mass_m: tuple[float, float]
    repose_angle_rad: float
    surface_points: int
    mass_kg: float

    @property
    def toe_deg(self) -> float:
        """:attr:`toe_rad` in degrees."""
        return math.degrees(self.toe_rad)

    @property
    def shoulder_deg(self) -> float:
        """:attr:`shoulder_rad` in degrees."""
        return math.degrees(self.shoulder_rad)

    @property
    def repose_angle_deg(self) -> float:
        """:attr:`repose_angle_rad` in degrees."""
        return math.degrees(self.repose_angle_rad)

    @property
    def gravity_torque_Nm(self) -> float:
        """Torque of the charge's weight about the drum axis that the drive must hold, N m:
        mass x g x (x of the centre of mass). In a steady state the charge's angular
        momentum does not change on average, so the mean drive torque equals this."""
        return self.mass_kg * GRAVITY * self.centre_of_mass_m[0]


def particle_masses(scene: Scene) -> NDArray[np.float64]:
    """Mass of every sphere of a scene, kg, shape (N,), in the order of
    :meth:`Scene.particle_radii` (and of ``Simulation.positions``): density x 4/3 pi r^3."""
    density = np.array([m.density for m in scene.materials])[scene.particle_materials()]
    return density * (4.0 / 3.0) * np.pi * scene.particle_radii() ** 3


def charge_shape(positions_m: ArrayLike, radii_m: ArrayLike, masses_kg: ArrayLike,
                 drum_radius_m: float, *, band_m: float | None = None,
                 cell_m: float | None = None, bin_rad: float = math.radians(5.0),
                 smooth_rad: float = math.radians(15.0)) -> ChargeShape:
    """Toe, shoulder, centre of mass and dynamic angle of repose of a charge of spheres.

    Several snapshots of the same charge may be given at once; their particles are then pooled
    (a time-averaged shape). Only x and y are used: the shape is that of the charge projected
    onto the drum's cross-section.

    * **Toe and shoulder.** The particles whose centres lie within ``band_m`` of the shell
      (radius >= R - band_m, the shell layer) are binned by angle (``bin_rad`` wide) and the
      mass per bin is averaged over a moving window ``smooth_rad`` wide (so that the room a
      lifter takes in the layer does not read as a gap in the charge). A bin is *full* when its
      mass is at least half (:data:`THRESHOLD`) the typical mass of a full bin, the 90th
      percentile (:data:`FULL_PERCENTILE`) of the non-empty bins. Starting from the bin of the
      shell layer's mean direction, the arc of full bins is followed each way; each end is where
      the mass per bin crosses the threshold, interpolated linearly between bin centres. The
      counterclockwise end is the shoulder, the other the toe. Particles in flight rarely fill a
      shell bin to half, so the ends mark where the dense charge leaves and meets the shell.
    * **Centre of mass.** The mass-weighted mean of x and y.
    * **Angle of repose.** The cross-section is divided into square cells ``cell_m`` wide; a
      cell is *dense* when it holds at least half the typical mass of a full cell (the same
      rule as above). In every column of cells, going up from the lowest dense cell, the free
      surface is where the mass per cell falls below the threshold, interpolated linearly
      between cell centres; columns whose surface point lies within one cell of the shell are
      dropped (there the surface meets the shell, not the air), as are the outer 20 %
      (:data:`SURFACE_TRIM`) of the remaining points' horizontal span at each end. A
      least-squares line y = a x + b through the rest gives the angle atan(a).

    Parameters
    ----------
    positions_m : array_like
        Sphere centres, m: shape (N, 2) or (N, 3), or (K, N, 2|3) for K snapshots.
    radii_m : array_like
        Sphere radii, m, shape (N,).
    masses_kg : array_like
        Sphere masses, kg, shape (N,).
    drum_radius_m : float
        Inner radius of the shell, m (to the shell, not to the lifter tips).
    band_m : float, optional
        Thickness of the shell layer, m, in (0, R]; default 4 x the largest radius (one
        layer of the largest spheres beside lifters up to a diameter high).
    cell_m : float, optional
        Cell size for the free surface, m, in (0, R]; default 4 x the largest radius.
    bin_rad : float
        Angular bin width for the toe and shoulder, rad, in (0, pi/8].
    smooth_rad : float
        Width of the moving average over the bins, rad, in [0, pi/4]; at least the angle
        a lifter spans (0 turns the averaging off).

    Returns
    -------
    ChargeShape

    Raises
    ------
    ValueError
        For arrays of the wrong shape, non-finite or non-positive values, spheres outside the
        drum, or a charge whose shape is undefined: one that covers the whole shell
        (centrifuging) or whose free surface has fewer than 3 usable points.
    """
    radius = _checks.positive("charge_shape drum_radius_m", drum_radius_m, "m")
    x, y, m, r_max = _state(positions_m, radii_m, masses_kg, radius)
    band = 4.0 * r_max if band_m is None else _checks.between(
        "charge_shape band_m", band_m, 0.0, radius, "m", low_open=True)
    cell = 4.0 * r_max if cell_m is None else _checks.between(
        "charge_shape cell_m", cell_m, 0.0, radius, "m", low_open=True)
    width = _checks.between("charge_shape bin_rad", bin_rad, 0.0, math.pi / 8.0, "rad",
                            low_open=True)
    smooth = _checks.between("charge_shape smooth_rad", smooth_rad, 0.0, math.pi / 4.0, "rad")

    toe, shoulder = _toe_and_shoulder(x, y, m, radius, band, width, smooth)
    angle, points = _repose_angle(x, y, m, radius, cell)
    total = float(np.sum(m))
    centre = (float(np.sum(m * x) / total), float(np.sum(m * y) / total))
    snapshots = x.size // np.asarray(masses_kg).size
    return ChargeShape(toe, shoulder, centre, angle, points, total / snapshots)


def _state(positions: ArrayLike, radii: ArrayLike, masses: ArrayLike, radius: float
           ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], float]:
    """Checked, pooled x, y and mass of every sphere in every snapshot, and the largest
    radius."""
    pos = np.asarray(positions, dtype=np.float64)
    rad = np.asarray(radii, dtype=np.float64)
    mass = np.asarray(masses, dtype=np.float64)
    if rad.ndim != 1 or rad.size == 0:
        raise ValueError(f"charge_shape radii_m has shape {rad.shape}; it must be (N,), N >= 1")
    n = rad.size
    if pos.ndim not in (2, 3) or pos.shape[-2:] not in ((n, 2), (n, 3)):
        raise ValueError(f"charge_shape positions_m has shape {pos.shape}; it must be "
                         f"({n}, 2|3) or (K, {n}, 2|3) for the {n} radii")
    if mass.shape != (n,):
        raise ValueError(f"charge_shape masses_kg has shape {mass.shape}; it must be ({n},)")
    for name, values in (("positions_m", pos), ("radii_m", rad), ("masses_kg", mass)):
        if not np.all(np.isfinite(values)):
            raise ValueError(f"charge_shape {name} holds non-finite values; all must be finite")
    for name, values in (("radii_m", rad), ("masses_kg", mass)):
        if np.any(values <= 0.0):
            raise ValueError(f"charge_shape {name} = {_checks.show(float(values.min()))} is "
                             "not valid; every value must be > 0")
    flat = pos.reshape(-1, pos.shape[-1])
    x, y = flat[:, 0], flat[:, 1]
    reach = float(np.max(np.hypot(x, y)))
    if reach > radius:
        raise ValueError(f"charge_shape: a sphere centre lies {reach:.6g} m from the axis, "
                         f"outside drum_radius_m = {radius:g} m")
    return x, y, np.tile(mass, flat.shape[0] // n), float(rad.max())


def _full_level(mass_per_bin: NDArray[np.float64]) -> float:
    """Half the typical mass of a full bin (the threshold of the docstring)."""
    filled = mass_per_bin[mass_per_bin > 0.0]
    return THRESHOLD * float(np.percentile(filled, FULL_PERCENTILE))


def _crossing(inside: float, outside: float, level: float) -> float:
    """Where, as a fraction of the way from a bin at or above ``level`` to the next one below
    it, the mass crosses ``level`` (linear interpolation)."""
    return (inside - level) / (inside - outside)


def _toe_and_shoulder(x: NDArray[np.float64], y: NDArray[np.float64],
                      m: NDArray[np.float64], radius: float, band: float,
                      width: float, smooth: float) -> tuple[float, float]:
    layer = np.hypot(x, y) >= radius - band
    if not np.any(layer):
        raise ValueError(f"charge_shape: no sphere lies within band_m = {band:g} m of the "
                         "shell; the toe and shoulder are undefined")
    # psi: angle from the bottom of the drum, counterclockwise, in [-pi, pi)
    psi = np.arctan2(x[layer], -y[layer])
    count = max(int(round(2.0 * math.pi / width)), 16)
    step = 2.0 * math.pi / count
    mass = np.bincount(np.minimum(((psi + math.pi) / step).astype(np.int64), count - 1),
                       weights=m[layer], minlength=count).astype(np.float64)
    half = int(round(smooth / step / 2.0))  # the window spans 2 half + 1 bins
    if half > 0:
        wrapped = np.concatenate([mass[-half:], mass, mass[:half]])
        mass = np.convolve(wrapped, np.full(2 * half + 1, 1.0 / (2 * half + 1)), "valid")
    level = _full_level(mass)
    if np.all(mass >= level):
        raise ValueError("charge_shape: the charge covers the whole shell (centrifuging); "
                         "its toe and shoulder are undefined")
    mean_dir = math.atan2(float(np.sum(m[layer] * np.sin(psi))),
                          float(np.sum(m[layer] * np.cos(psi))))
    start = min(int((mean_dir + math.pi) / step), count - 1)
    if mass[start] < level:
        raise ValueError("charge_shape: the shell layer is not full in the charge's mean "
                         "direction; the charge does not lie on the shell as one arc")
    centre = -math.pi + (start + 0.5) * step  # psi of the start bin's centre
    ends = []
    for sense in (1, -1):  # counterclockwise (shoulder), then clockwise (toe)
        k = 0
        while mass[(start + sense * (k + 1)) % count] >= level:
            k += 1
        inner = mass[(start + sense * k) % count]
        outer = mass[(start + sense * (k + 1)) % count]
        ends.append(centre + sense * (k + _crossing(inner, outer, level)) * step)
    shoulder_psi, toe_psi = ends
    return toe_psi + 1.5 * math.pi, shoulder_psi - 0.5 * math.pi


def _repose_angle(x: NDArray[np.float64], y: NDArray[np.float64], m: NDArray[np.float64],
                  radius: float, cell: float) -> tuple[float, int]:
    count = int(math.ceil(2.0 * radius / cell))
    edges = -0.5 * count * cell + cell * np.arange(count + 1)
    grid, _, _ = np.histogram2d(x, y, bins=(edges, edges), weights=m)
    level = _full_level(grid.ravel())
    centres = 0.5 * (edges[:-1] + edges[1:])
    xs, ys = [], []
    for i in range(count):
        column = grid[i]
        dense = np.flatnonzero(column >= level)
        if dense.size == 0:
            continue
        j = int(dense[0])
        while j + 1 < count and column[j + 1] >= level:
            j += 1
        if j + 1 == count:
            continue
        height = centres[j] + _crossing(column[j], column[j + 1], level) * cell
        if math.hypot(centres[i], height) < radius - cell:
            xs.append(float(centres[i]))
            ys.append(float(height))
    if xs:
        low, high = min(xs), max(xs)
        span = high - low
        keep = [k for k, v in enumerate(xs)
                if low + SURFACE_TRIM * span <= v <= high - SURFACE_TRIM * span]
        xs = [xs[k] for k in keep]
        ys = [ys[k] for k in keep]
    if len(xs) < 3:
        raise ValueError(f"charge_shape: the free surface has {len(xs)} usable points with "
                         f"cell_m = {cell:g} m; at least 3 are needed (a smaller cell_m may "
                         "give more)")
    slope = float(np.polyfit(np.asarray(xs), np.asarray(ys), 1)[0])
    return math.atan(slope), len(xs)

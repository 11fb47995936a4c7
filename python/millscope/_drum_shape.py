"""The drum's surfaces at a drum angle, as the engine models them (cpp/include/millscope/drum.hpp),
for the VTK snapshots and the cross-section figure.

The drum is the cylinder rho = R for 0 <= z <= L about +z, with flat end walls at z = 0 and z = L
(when it has them). Lifter k is a prism along z whose centre line is at angle
phi_k = theta + phase + 2 pi k / n (theta the drum angle). In the frame of that line (a radial
along it, b tangential across it) its cross-section is the symmetric trapezoid with the tip face
a = R - h, |b| <= t / 2 and the side lines b = +-(t / 2 + s (a - (R - h))), s = (w - t) / (2 h)
(t the tip width, w the width at the shell, h the height; t = w for rectangular lifters). The
engine continues the prism beyond the shell; what the drum's interior sees is the tip face and the
two side faces up to where the side lines meet the shell circle, and that is what is drawn.

Here, below every layer, so that the figures can draw the drum without loading the simulation
side; the drum is passed in (a :class:`millscope.model.scene.Drum`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

if TYPE_CHECKING:
    from .model.scene import Drum

#: Part codes of the surface's faces, those of the engine's drum::Part.
SHELL, END_LOW, END_HIGH, LIFTER = 0, 1, 2, 3
#: Facets of the shell and the end walls around the circumference, by default.
DEFAULT_SEGMENTS = 128


def lifter_angles(drum: Drum, drum_angle: float) -> NDArray[np.float64]:
    """The lifters' centre-line angles phi_k = theta + phase + 2 pi k / n, rad (empty without
    lifters)."""
    lift = drum.lifters
    if lift is None:
        return np.empty(0)
    return drum_angle + lift.phase + 2.0 * math.pi * np.arange(lift.count) / lift.count


def lifter_outlines(drum: Drum, drum_angle: float) -> NDArray[np.float64]:
    """The visible cross-section of every lifter in the x-y plane, m.

    Parameters
    ----------
    drum : Drum
        The drum.
    drum_angle : float
        Angle the drum has turned through about +z, rad.

    Returns
    -------
    ndarray, shape (n_lifters, 4, 2)
        Per lifter the corners (x, y) in order round the outline: on the shell at b < 0, the tip
        at b < 0, the tip at b > 0, on the shell at b > 0. The shell corners lie on the circle
        of radius R where the side lines meet it.
    """
    lift = drum.lifters
    if lift is None:
        return np.empty((0, 4, 2))
    radius, h = drum.radius, lift.height
    a_tip, half_tip = radius - h, 0.5 * lift.tip_width
    slope = (lift.width - lift.tip_width) / (2.0 * h)
    # The side line (a_tip + u, half_tip + slope u) meets the circle a^2 + b^2 = R^2 at the
    # positive root of (1 + s^2) u^2 + 2 (a_tip + s half_tip) u + (a_tip^2 + half_tip^2 - R^2),
    # taken in the form without cancellation. A tip corner beyond the shell (a lifter low and
    # wide enough) leaves only the part of the tip face inside the shell to be seen.
    c = a_tip**2 + half_tip**2 - radius**2
    if c < 0.0:
        b_coef = a_tip + slope * half_tip
        u = -c / (b_coef + math.sqrt(b_coef**2 - (1.0 + slope**2) * c))
        base = (a_tip + u, half_tip + slope * u)
    else:
        half_tip = math.sqrt(max(radius**2 - a_tip**2, 0.0))
        base = (a_tip, half_tip)
    local = np.array([[base[0], -base[1]], [a_tip, -half_tip], [a_tip, half_tip],
                      [base[0], base[1]]])
    phi = lifter_angles(drum, drum_angle)
    cos, sin = np.cos(phi)[:, None], np.sin(phi)[:, None]
    # x = a e_a + b e_b with e_a = (cos phi, sin phi), e_b = (-sin phi, cos phi)
    x = local[None, :, 0] * cos - local[None, :, 1] * sin
    y = local[None, :, 0] * sin + local[None, :, 1] * cos
    return np.stack([x, y], axis=-1)


@dataclass(frozen=True)
class DrumSurface:
    """The drum as a surface mesh of quadrilaterals and triangles.

    Attributes
    ----------
    points : ndarray, shape (P, 3)
        Vertices, m.
    quads : ndarray, shape (Q, 4)
        Vertex indices of the quadrilaterals (shell facets, lifter faces and ends).
    quad_part, quad_lifter : ndarray, shape (Q,)
        Part code (:data:`SHELL`, :data:`LIFTER`) and lifter index (-1 for the shell) per
        quadrilateral.
    triangles : ndarray, shape (T, 3)
        Vertex indices of the end walls' triangles (a fan about the axis); empty with
        periodic ends.
    triangle_part : ndarray, shape (T,)
        :data:`END_LOW` or :data:`END_HIGH`.
    """

    points: NDArray[np.float64]
    quads: NDArray[np.int64]
    quad_part: NDArray[np.int32]
    quad_lifter: NDArray[np.int32]
    triangles: NDArray[np.int64]
    triangle_part: NDArray[np.int32]


def drum_surface(drum: Drum, drum_angle: float, segments: int = DEFAULT_SEGMENTS
                 ) -> DrumSurface:
    """The shell, the end walls (if any) and the lifters at ``drum_angle`` (rad).

    The shell is ``segments`` flat facets whose vertices lie on the circle of radius R at
    z = 0 and z = L; the end walls are fans of ``segments`` triangles from the axis; each lifter
    is its tip face, its two side faces and its two ends (:func:`lifter_outlines`).
    """
    radius, length = drum.radius, drum.length
    angle = 2.0 * math.pi * np.arange(segments) / segments
    ring = np.column_stack([radius * np.cos(angle), radius * np.sin(angle)])
    low = np.column_stack([ring, np.zeros(segments)])
    high = np.column_stack([ring, np.full(segments, length)])
    points = [low, high]
    k = np.arange(segments)
    nxt = (k + 1) % segments
    quads = [np.column_stack([k, nxt, segments + nxt, segments + k])]
    quad_part = [np.full(segments, SHELL)]
    quad_lifter = [np.full(segments, -1)]
    triangles: list[NDArray[np.int64]] = []
    triangle_part: list[NDArray[np.int32]] = []
    if drum.end_walls:
        axis = 2 * segments
        points.append(np.array([[0.0, 0.0, 0.0], [0.0, 0.0, length]]))
        triangles += [np.column_stack([np.full(segments, axis), nxt, k]),
                      np.column_stack([np.full(segments, axis + 1), segments + k,
                                       segments + nxt])]
        triangle_part += [np.full(segments, END_LOW), np.full(segments, END_HIGH)]
    start = sum(len(p) for p in points)
    # Per lifter 8 vertices: the outline's 4 corners at z = 0, then at z = L; faces: the shell
    # side b < 0 (0-1), the tip (1-2), the side b > 0 (2-3), and the two ends.
    faces = np.array([[0, 1, 5, 4], [1, 2, 6, 5], [2, 3, 7, 6], [3, 2, 1, 0], [4, 5, 6, 7]])
    for n, outline in enumerate(lifter_outlines(drum, drum_angle)):
        points += [np.column_stack([outline, np.zeros(4)]),
                   np.column_stack([outline, np.full(4, length)])]
        quads.append(start + 8 * n + faces)
        quad_part.append(np.full(len(faces), LIFTER))
        quad_lifter.append(np.full(len(faces), n))
    return DrumSurface(
        points=np.concatenate(points),
        quads=np.concatenate(quads).astype(np.int64),
        quad_part=np.concatenate(quad_part).astype(np.int32),
        quad_lifter=np.concatenate(quad_lifter).astype(np.int32),
        triangles=(np.concatenate(triangles) if triangles
                   else np.empty((0, 3))).astype(np.int64),
        triangle_part=(np.concatenate(triangle_part) if triangle_part
                       else np.empty(0)).astype(np.int32),
    )

"""Reading a checkpoint (:meth:`millscope.simulation.Simulation.save`) as untrusted input.

Everything the engine's ``restore`` takes is checked here first, in Python, against the
invariants the engine keeps (``cpp/src/engine.cpp``, ``Engine::snapshot`` and
``Engine::restore``; ``cpp/include/millscope/neighbors.hpp``, the half Verlet list), so that
a damaged or edited file is refused with one message instead of crashing or running on to
other results:

* the zip holds only the known members; each ``.npy`` header is read and its dtype (exactly
  the engine's: uint32 indices, int32 lifter slots, float64 values) and size checked before
  its data are read, so that a header claiming 10^11 values allocates nothing;
* the arrays of the particles (positions, velocities, spins, forces, torques, positions at the
  last list build, wall contact history) have 3 n (or n x slots x 3) finite values; the
  particles lie in the drum and move below the scene's speed bound;
* ``order`` is a permutation of the particles; ``wall_lifter`` holds a lifter index
  (< the lifter count) or the engine's "free" value -1, never the same lifter twice;
* the neighbour list is well formed (rows of strictly increasing partners after their row
  particle, history of the right length) and is the list of the positions it was built at
  (every pair within the skin listed, none beyond it, up to the float32 rounding of those
  positions): a list from other radii (a permuted ``order``) or other positions is refused;
* the counters: step >= 0, list builds >= 0 and none without a list, the rotation's start and
  the last sample between 0 and the step (or -1 before rotation), the drum's angle omega dt x
  the steps since the start of rotation (which pins those counters), the drum's speed that of
  the scene once rotating (0 before), forces valid exactly when a step ran, a known phase
  consistent with them;
* meta: the time step within [MIN_DT_FRACTION, MAX_DT_FRACTION] x the scene's smallest
  Rayleigh time, the skin, the seed and the random generator's state well formed.

Every check raises :class:`Refused` with a message naming the field, its value and what it
must be; :meth:`Simulation.load <millscope.simulation.Simulation.load>` turns it into a
``CheckpointError``.
"""

from __future__ import annotations

import math
import zipfile
from collections.abc import Mapping
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .._files import read_npy_header
from ..model.contact import MAX_DT_FRACTION
from ..model.scene import Scene

#: The shortest time step a checkpoint may hold, as a fraction of the scene's smallest Rayleigh
#: time (the default step is 0.2 of it): below, a second of simulated time takes more than
#: 10^3 times the default run's steps, far beyond what any study of the step asks for.
MIN_DT_FRACTION = 1e-3
#: The most characters of the checkpoint's JSON meta (a scene and a few numbers take a few kB).
MAX_META_CHARS = 1 << 22
_PHASES = ("empty", "filled", "settled", "rotating")
_NO_LIFTER = -1  # wall_lifter: a lifter slot that holds no lifter (engine.hpp)
_INT64 = (-(2**63), 2**63 - 1)


class Refused(Exception):
    """A checkpoint field that breaks an invariant; the message names it."""


def _refuse(name: str, value: object, must: str) -> Refused:
    shown = repr(value)
    if len(shown) > 80:
        shown = shown[:77] + "..."
    return Refused(f"{name} = {shown} is not valid; it must be {must}")


def integer(name: str, value: object, low: int, high: int = _INT64[1]) -> int:
    """``value`` as an int in [low, high] (JSON integers only: no bool, no float)."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)) \
            or not low <= value <= high:
        raise _refuse(name, value, f"an integer in [{low}, {high}]")
    return int(value)


def real(name: str, value: object, low: float, high: float, unit: str = "") -> float:
    """``value`` as a finite float in [low, high]."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, float, np.floating)) \
            or not (math.isfinite(value) and low <= value <= high):
        raise _refuse(name, value, f"a finite number in [{low:.6g}, {high:.6g}]{unit}")
    return float(value)


def boolean(name: str, value: object) -> bool:
    if not isinstance(value, (bool, np.bool_)):
        raise _refuse(name, value, "true or false")
    return bool(value)


# -- the file -----------------------------------------------------------------------------------

def members(zf: zipfile.ZipFile, allowed: set[str]) -> dict[str, zipfile.ZipInfo]:
    """The .npy members by name (without .npy); other or repeated members are refused."""
    out: dict[str, zipfile.ZipInfo] = {}
    for info in zf.infolist():
        name = info.filename.removesuffix(".npy")
        if name not in allowed or info.filename == name or name in out:
            raise Refused(f"it holds a member {info.filename!r}; a checkpoint holds "
                          f"{', '.join(sorted(allowed))} (.npy) once each")
        out[name] = info
    missing = allowed - out.keys()
    if missing:
        raise Refused(f"it has no {', '.join(sorted(missing))}")
    return out


def read_npy(zf: zipfile.ZipFile, info: zipfile.ZipInfo, dtype: np.dtype[Any],
             max_count: int, ndim: int = 1) -> NDArray[Any]:
    """An array member whose header says ``dtype`` (exactly), ``ndim`` dimensions and at most
    ``max_count`` values; the header is checked before any data are read."""
    name = info.filename.removesuffix(".npy")
    with zf.open(info) as f:
        try:
            shape, fortran, found = read_npy_header(f)
        except ValueError as exc:
            raise Refused(f"{name} has {exc}") from None
        if found != dtype or found.hasobject:
            raise _refuse(f"the dtype of {name}", str(found), f"{dtype} (as saved)")
        if len(shape) != ndim:
            raise _refuse(f"the shape of {name}", shape, f"{ndim}-dimensional")
        count = math.prod(shape)
        if count > max_count:
            raise _refuse(f"the size of {name}", count, f"at most {max_count} for this scene")
        nbytes = count * dtype.itemsize
        data = f.read(nbytes)
        if len(data) != nbytes:
            raise Refused(f"{name} is truncated: {len(data)} of {nbytes} bytes")
    array = np.frombuffer(data, dtype=dtype).reshape(shape, order="F" if fortran else "C")
    return np.array(array)  # writable, owned


def read_meta(zf: zipfile.ZipFile, info: zipfile.ZipInfo) -> dict[str, Any]:
    """The JSON meta (a 0-d unicode array), at most MAX_META_CHARS characters."""
    import json

    with zf.open(info) as f:
        try:
            shape, _, dtype = read_npy_header(f)
        except ValueError as exc:
            raise Refused(f"meta_json has {exc}") from None
    if dtype.kind != "U" or shape != () or dtype.itemsize > 4 * MAX_META_CHARS:
        raise _refuse("meta_json", f"{dtype} {shape}",
                      f"one string of at most {MAX_META_CHARS} characters")
    text = str(read_npy(zf, info, dtype, 1, ndim=0)[()])
    try:
        meta = json.loads(text)
    except (ValueError, RecursionError) as exc:
        raise Refused(f"meta_json is not valid JSON ({exc})") from None
    if not isinstance(meta, dict):
        raise _refuse("meta_json", type(meta).__name__, "a JSON object")
    return meta


# -- meta -------------------------------------------------------------------------------------

def check_dt(value: object, scene: Scene) -> float:
    t_rayleigh, which = scene.min_rayleigh_time()
    return real("dt", value, MIN_DT_FRACTION * t_rayleigh, MAX_DT_FRACTION * t_rayleigh,
                f" s ({MIN_DT_FRACTION:g} to {MAX_DT_FRACTION:g} x the Rayleigh time "
                f"{t_rayleigh:.6g} s of {which!r})")


def check_skin(value: object, scene: Scene) -> float:
    """The list's skin, m: > 0 and at most the drum's diameter (no pair is farther apart)."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, float)) \
            or not (math.isfinite(value) and 0.0 < value <= 2.0 * scene.drum.radius):
        raise _refuse("skin", value, f"in (0, {2.0 * scene.drum.radius:g}] m")
    return float(value)


def check_settle(value: object) -> tuple[float, float, float]:
    if not isinstance(value, list) or len(value) != 3:
        raise _refuse("settle", value, "[tolerance, least s, most s]")
    tol, t_min, t_max = (real(f"settle[{k}]", v, 0.0, math.inf) for k, v in enumerate(value))
    return tol, t_min, t_max


def check_rng_state(value: object, template: Mapping[str, Any]) -> dict[str, Any]:
    """The generator's state, shaped as ``template`` (a fresh generator's state): the same keys
    and bit generator, integers in range (PCG64: a 128-bit state and an odd increment)."""
    if not isinstance(value, dict) or value.keys() != template.keys() \
            or value.get("bit_generator") != template["bit_generator"]:
        raise _refuse("rng_state", value, f"a {template['bit_generator']} state with the keys "
                      f"{sorted(template)}")
    inner, inner_template = value["state"], template["state"]
    if not isinstance(inner, dict) or inner.keys() != inner_template.keys():
        raise _refuse("rng_state['state']", inner, f"a mapping of {sorted(inner_template)}")
    for key in inner:
        integer(f"rng_state['state'][{key!r}]", inner[key], 0, 2**128 - 1)
    if inner.get("inc", 1) % 2 != 1:
        raise _refuse("rng_state['state']['inc']", inner["inc"], "odd")
    integer("rng_state['has_uint32']", value["has_uint32"], 0, 1)
    integer("rng_state['uinteger']", value["uinteger"], 0, 2**32 - 1)
    return value


# -- the engine's state -----------------------------------------------------------------------

def check_scalars(scalars: object, template: Mapping[str, Any], phase: str, scene: Scene,
                  dt: float) -> dict[str, Any]:
    """The engine's counters and totals (Engine::Snapshot's scalars), against each other, the
    phase and the time step ``dt`` (s): the drum's angle is the sum of omega dt over the steps
    since the start of rotation (0 before it), which pins the step counters."""
    if not isinstance(scalars, dict) or scalars.keys() != template.keys():
        raise _refuse("engine_scalars", scalars, f"a mapping of {sorted(template)}")
    s = dict(scalars)
    step = integer("step", s["step"], 0, _INT64[1] // 2)
    builds = integer("list_builds", s["list_builds"], 0, step + 1)  # at most one per step
    rotating = phase == "rotating"
    if phase in ("empty", "filled") and step != 0:
        raise _refuse("step", step, f"0 in the phase {phase!r} (nothing has run)")
    start = -1
    if rotating:
        start = integer("rotation_start", s["rotation_start"], 0, step)
        integer("last_sample_offset", s["last_sample_offset"], -1, step - start)
        if s["omega"] != scene.omega:
            raise _refuse("omega", s["omega"], f"the scene's {scene.omega!r} rad/s once rotating")
    else:
        for key in ("rotation_start", "last_sample_offset"):
            integer(key, s[key], -1, -1)
        if s["omega"] != 0.0 or isinstance(s["omega"], bool):
            raise _refuse("omega", s["omega"], f"0 rad/s in the phase {phase!r}")
    theta = real("theta", s["theta"], -math.inf, math.inf, " rad")
    turned = step - start if rotating else 0
    expected = scene.omega * dt * turned if rotating else 0.0
    # half a step's angle, and the rounding the sum gathers over the steps
    slack = 0.5 * abs(scene.omega) * dt + 2.3e-16 * turned * abs(expected)
    if not abs(theta - expected) <= slack:
        raise _refuse("theta", theta, f"{expected:.9g} rad, omega x dt x the {turned} steps "
                      "since the start of rotation")
    s["theta"] = theta
    s["omega"] = float(s["omega"])
    # The forces are those of the last step once anything ran (Simulation sets positions only
    # when filling, at step 0); a run that recomputed them would advance the contacts'
    # tangential springs twice.
    s["forces_valid"] = boolean("forces_valid", s["forces_valid"])
    if s["forces_valid"] != (step > 0):
        raise _refuse("forces_valid", s["forces_valid"],
                      f"{str(step > 0).lower()} at step {step}")
    s["step"], s["list_builds"] = step, builds
    torque = s["torque"]
    if not isinstance(torque, list) or len(torque) != len(template["torque"]):
        raise _refuse("torque", torque, f"{len(template['torque'])} numbers, N m")
    s["torque"] = tuple(real(f"torque[{k}]", v, -math.inf, math.inf, " N m")
                        for k, v in enumerate(torque))
    ledger = s["ledger"]
    if not isinstance(ledger, list) or len(ledger) != len(template["ledger"]):
        raise _refuse("ledger", ledger, f"{len(template['ledger'])} numbers, J")
    values = []
    for k, v in enumerate(ledger):
        # the losses read NaN once a run went on without booking them (Simulation docstring),
        # whatever the run does now
        if k > 0 and isinstance(v, float) and math.isnan(v):
            values.append(v)
        else:
            values.append(real(f"ledger[{k}]", v, -math.inf, math.inf, " J"))
    s["ledger"] = tuple(values)
    return s


def check_arrays(a: dict[str, NDArray[Any]], s: Mapping[str, Any], scene: Scene, skin: float,
                 max_speed: float, history_size: int, wall_values: int) -> None:
    """The particles' arrays (slot order), the wall history and the neighbour list."""
    n = scene.n_particles
    for key in ("x", "v", "w", "f", "t", "x_ref", "wall_history", "list_history"):
        bad = np.flatnonzero(~np.isfinite(a[key]))
        if bad.size:
            raise _refuse(f"{key}[{bad[0]}]", a[key][bad[0]], "finite")
    for key in ("x", "v", "w", "f", "t", "x_ref"):
        if a[key].size != 3 * n:
            raise _refuse(f"the size of {key}", a[key].size, f"3 x {n} particles")
    if a["wall_history"].size != wall_values:
        raise _refuse("the size of wall_history", a["wall_history"].size, str(wall_values))
    order = a["order"]
    if order.size != n or not np.array_equal(np.sort(order), np.arange(n)):
        raise Refused(f"order is not a permutation of the {n} particles")
    radius = scene.particle_radii()[order]  # slot k holds particle order[k]
    x, v, w = (a[k].reshape(n, 3) for k in ("x", "v", "w"))
    drum = scene.drum
    rho = np.hypot(x[:, 0], x[:, 1])
    outside = np.flatnonzero(rho > drum.radius)
    if drum.end_walls:
        outside = np.union1d(outside, np.flatnonzero((x[:, 2] < 0.0) | (x[:, 2] > drum.length)))
    else:
        outside = np.union1d(outside, np.flatnonzero((x[:, 2] < 0.0) | (x[:, 2] >= drum.length)))
    if outside.size:
        k = outside[0]
        raise _refuse(f"x[{k}]", tuple(x[k]), f"inside the drum (radius {drum.radius:g} m, "
                      f"0 <= z <= {drum.length:g} m)")
    speed = np.sqrt(np.sum(v * v, axis=1))
    surface = np.sqrt(np.sum(w * w, axis=1)) * radius
    for key, value in (("v", speed), ("w", surface)):
        fast = np.flatnonzero(value > max_speed)
        if fast.size:
            k = fast[0]
            what = "speed" if key == "v" else "surface speed (spin x radius)"
            raise _refuse(f"the {what} of slot {k}", float(value[k]),
                          f"<= {max_speed:.6g} m/s, the scene's speed bound")
    lifters = 0 if drum.lifters is None else drum.lifters.count
    slots = a["wall_lifter"].reshape(n, 2)
    bad = np.flatnonzero((slots != _NO_LIFTER) & ((slots < 0) | (slots >= lifters)))
    if bad.size:
        raise _refuse(f"wall_lifter[{bad[0]}]", int(slots.flat[bad[0]]),
                      f"a lifter index in [0, {lifters}) or {_NO_LIFTER} (none)")
    twice = np.flatnonzero((slots[:, 0] == slots[:, 1]) & (slots[:, 0] != _NO_LIFTER))
    if twice.size:
        raise Refused(f"wall_lifter holds lifter {slots[twice[0], 0]} twice for slot "
                      f"{twice[0]}")
    _check_list(a, s["list_builds"], x, radius, skin, history_size, scene)


def max_partners(scene: Scene, skin: float) -> int:
    """The most pairs a neighbour list of the scene can hold: centres at least the smallest
    radius apart (the overlap guard stops a run deeper than that) packed within reach."""
    n = scene.n_particles
    radii = scene.particle_radii()
    r_min, r_max = float(np.min(radii)), float(np.max(radii))
    reach = 2.0 * r_max + skin
    per_row = math.ceil(((reach + r_min / 2.0) / (r_min / 2.0)) ** 3)
    return min(n * (n - 1) // 2, n * per_row)


def _check_list(a: Mapping[str, NDArray[Any]], builds: int, x: NDArray[np.float64],
                radius: NDArray[np.float64], skin: float, history_size: int,
                scene: Scene) -> None:
    start, partner, history = a["list_start"], a["list_partner"], a["list_history"]
    n = len(radius)
    if builds == 0:
        if start.size or partner.size or history.size:
            raise _refuse("list_builds", 0, ">= 1 with a saved neighbour list")
        return
    counts = np.diff(start.astype(np.int64)).astype(np.int64)
    if start.size != n + 1 or start[0] != 0 or int(start[-1]) != partner.size \
            or np.any(counts < 0):
        raise Refused(f"list_start is not the row starts of {n} particles over "
                      f"{partner.size} partners")
    if history.size != history_size * partner.size:
        raise _refuse("the size of list_history", history.size,
                      f"{history_size} x {partner.size} listed pairs")
    rows = np.repeat(np.arange(n), counts)
    cols = partner.astype(np.int64)
    if np.any(cols <= rows) or np.any(cols >= n):
        raise Refused("list_partner holds a partner not after its row particle or beyond the "
                      "particles")
    if np.any((np.diff(cols) <= 0) & (rows[1:] == rows[:-1])):
        raise Refused("list_partner holds a row whose partners are not strictly increasing")
    # The list is that of the positions at its build (x_ref, rounded to float32): every pair
    # closer than the skin listed, none farther; pairs within the rounding of it may go either way.
    x_ref = a["x_ref"].reshape(n, 3)
    drum = scene.drum
    period = 0.0 if drum.end_walls else drum.length
    delta = x - x_ref
    if period:
        delta[:, 2] -= period * np.round(delta[:, 2] / period)
    tol = 1e-6 * max(drum.radius, drum.length) + 1e-9 * skin
    moved = np.sqrt(np.sum(delta * delta, axis=1))
    far = np.flatnonzero(moved > 0.5 * skin + tol)
    if far.size:
        raise _refuse(f"x_ref[{far[0]}]", tuple(x_ref[far[0]]),
                      f"within skin / 2 = {skin / 2:.6g} m of the position {tuple(x[far[0]])}")
    listed = set(zip(rows.tolist(), cols.tolist(), strict=True))
    near, gaps = _pairs_within(x_ref, radius, skin + tol, period)
    must = {p for p, gap in zip(near, gaps, strict=True) if gap < skin - tol}
    may = set(near)
    if not must <= listed or not listed <= may:
        wrong = sorted((must - listed) | (listed - may))[0]
        raise Refused(f"the neighbour list is not that of the positions it was built at "
                      f"(x_ref, with the radii of order and skin {skin:.6g} m): pair {wrong} "
                      f"is {'missing' if wrong in must else 'listed but out of reach'}")


def _pairs_within(x: NDArray[np.float64], radius: NDArray[np.float64], gap_max: float,
                  period: float) -> tuple[list[tuple[int, int]], list[float]]:
    """The pairs i < j whose surfaces are closer than ``gap_max`` and their gaps (z periodic
    with ``period`` when > 0)."""
    from scipy.spatial import cKDTree

    r_max = float(np.max(radius)) if len(radius) else 0.0
    points = x.copy()
    box: NDArray[np.float64] | None = None
    if period:
        # cKDTree wraps every axis given a box: x and y get one far larger than the drum
        lo = points[:, :2].min(axis=0)
        points[:, :2] -= lo
        span = float(points[:, :2].max()) + 4.0 * (2.0 * r_max + gap_max) + 1.0
        points[:, 2] %= period
        box = np.array([span, span, period])
    tree = cKDTree(points) if box is None else cKDTree(points, boxsize=box)
    candidates = tree.query_pairs(2.0 * r_max + gap_max, output_type="ndarray")
    if len(candidates) == 0:
        return [], []
    i, j = candidates.min(axis=1), candidates.max(axis=1)
    d = x[j] - x[i]
    if period:
        d[:, 2] -= period * np.round(d[:, 2] / period)
    gap = np.sqrt(np.sum(d * d, axis=1)) - radius[i] - radius[j]
    keep = gap < gap_max
    return list(zip(i[keep].tolist(), j[keep].tolist(), strict=True)), gap[keep].tolist()


"""Stiffness advisor: how a scene's contact stiffness meets its time step and its torque sampling.

An impact lasts about the Hertz contact time t_c. The engine must resolve it in several time
steps, and the torque analysis must not resolve it: an impact's force pulse carries frequencies
up to about 1/t_c, so as long as 1/t_c lies far above the analysis band (0 .. the Nyquist
frequency of the torque samples, 50 Hz for the paper's 10 ms samples) the band sees each impact
as an impulse, whatever the stiffness. Once 1/t_c reaches the band, the band resolves the
pulses' shape and the torque spectrum there depends on the stiffness chosen; a reduced shear
modulus lengthens t_c as G^(-2/5) (eq. A2). :func:`advise_stiffness` reports, for a scene:

- the Rayleigh time, the smallest over the charge (the engine's default dt is 0.2 x it)::

      T_R = pi r sqrt(rho / G) / (0.1631 nu + 0.8766)                                    (A1)

- the expected impact speed v (A3-A5 below);
- for every pair of fractions and every fraction against the drum: the elastic Hertz contact
  time at v, its frequency 1/t_c, how many time steps and torque samples it spans, the same
  contact integrated with the engine's law at dt and the pair's restitution
  (:func:`millscope.contact.impact`), the largest overlap over the radius, and the margin of dt
  below the contact's stability limit 2/w_max at the upper speed (A6)::

      t_c = 2.87 (m*^2 / (R* E*^2 v))^(1/5)                                             (A2)

- a :class:`StiffnessWarning` when 1/t_c of some pair reaches the analysis band.

**Expected impact speed.** In the cataracting regime, 0 < w^2 R_p / g < 1 (w the drum's angular
speed, R_p = R - d_max/2 the radius of the outer layer's centres), a particle carried up at the
drum's speed w R_p leaves the shell where the normal force vanishes, at the angle alpha above
the horizontal, and flies a parabola back onto the shell (the Davis trajectory). Its landing
speed, from the parabola's second crossing of the circle (flight time 4 w R_p cos(alpha) / g)::

      sin(alpha) = w^2 R_p / g                                                          (A3)
      v = w R_p sqrt(1 + 8 cos^2(alpha))                                                (A4)

3.84 m/s in the paper's mill at 71 % of critical. With the drum at rest, or at or above the
critical speed (no cataract), the charge has no steady impacts to speak of and v is the upper
estimate::

      v = sqrt(2 g D)                                                                    (A5)

the speed of a free fall across the drum, which bounds A4 (whose largest value, at
sin(alpha) = sqrt(3/8), is 1.92 sqrt(g R_p) < 2 sqrt(g R)) and the transients (the filling drop,
the spin-up). The whole landing speed enters A2, not only its normal part: that errs towards
shorter contacts, slightly (t_c ~ v^(-1/5)). The stability margin takes the largest relative
speed a particle can reach, a fall across the drum onto a lifter moving at the rim speed::

      v_max = sqrt(2 g D) + w R                                                         (A6)

:func:`advise_stiffness` takes the speed as ``impact_speed`` when the caller knows better.

**The largest time step.** :func:`time_step_limit` takes, over the same contacts at v_max, the
smallest velocity-Verlet stability bound of their damped normal and tangential-rotational stick
modes (:func:`millscope.contact.contact_modes`, :func:`millscope.contact.verlet_stability_bound`),
times the safety factor :data:`millscope.contact.DT_SAFETY_FACTOR`, and at most the engine's
cap of MAX_DT_FRACTION Rayleigh times. :class:`~millscope.Simulation`, campaigns, the benchmark
and the advisor refuse a step above it, naming the pair and the mode.

Lives beside :mod:`millscope.contact` rather than in it: it reads a :class:`~millscope.scene.Scene`
(fractions, pairs, drum, speed) and sampling settings, while ``contact`` is the contact law on
its own and is imported by ``scene``.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass

from .. import _checks
from .contact import (
    DEFAULT_DT_FRACTION,
    DT_SAFETY_FACTOR,
    MAX_DT_FRACTION,
    ContactMode,
    PairProperties,
    contact_modes,
    hertz_contact_time,
    hertz_max_overlap,
    hertz_stability_dt,
    impact,
    pair_properties,
)
from .scene import Fraction, Scene

__all__ = [
    "ContactAdvice",
    "PairLimit",
    "StiffnessAdvice",
    "StiffnessWarning",
    "TimeStepLimit",
    "advise_stiffness",
    "expected_impact_speed",
    "time_step_limit",
    "upper_impact_speed",
    "wave_speed",
]

WALL = "wall"  # the name of the drum in pair labels
DRUM = "drum"  # the name of the drum in the time-step limit's pair labels


class StiffnessWarning(UserWarning):
    """A contact's frequency content (about 1 / contact time) reaches the analysis band."""


@dataclass(frozen=True)
class ContactAdvice:
    """One kind of contact of a scene at the expected impact speed.

    Attributes
    ----------
    label : str
        ``"<fraction>-<fraction>"`` or ``"<fraction>-wall"``.
    fraction_a, fraction_b : str
        Fraction names; ``fraction_b`` is ``"wall"`` for the drum.
    pair : PairProperties
        E*, G*, R*, m*, beta, restitution and friction of the contact.
    speed : float
        Normal approach speed assumed, m/s.
    contact_time : float
        Elastic Hertz contact time at ``speed`` (A2), s.
    integrated_contact_time : float
        The same impact integrated with the engine's law and integrator at ``dt``, with the
        pair's restitution and friction, s (damping lengthens it); NaN when
        ``contact_time <= dt`` (nothing to integrate).
    integrated_steps : int
        Steps that integrated impact spanned (0 when ``contact_time <= dt``).
    max_overlap : float
        Largest overlap of the elastic impact over the smaller radius (dimensionless).
    stability_dt : float
        2 / w_max of an elastic impact at the upper speed v_max (A6), s.
    dt, sample_dt : float
        Time step and torque sampling interval, s.
    """

    label: str
    fraction_a: str
    fraction_b: str
    pair: PairProperties
    speed: float
    contact_time: float
    integrated_contact_time: float
    integrated_steps: int
    max_overlap: float
    stability_dt: float
    dt: float
    sample_dt: float

    @property
    def contact_hz(self) -> float:
        """1 / contact_time, Hz: about where the impact's frequency content ends."""
        return 1.0 / self.contact_time

    @property
    def steps_per_contact(self) -> float:
        """contact_time / dt."""
        return self.contact_time / self.dt

    @property
    def samples_per_contact(self) -> float:
        """contact_time / sample_dt (well below 1 when the samples cannot see an impact)."""
        return self.contact_time / self.sample_dt

    @property
    def stability_margin(self) -> float:
        """stability_dt / dt: how far dt stays below the contact's stability limit."""
        return self.stability_dt / self.dt


@dataclass(frozen=True)
class StiffnessAdvice:
    """What :func:`advise_stiffness` found. ``str()`` gives a plain-text report,
    :meth:`to_markdown` a Markdown one.

    Attributes
    ----------
    scene_name : str
    rayleigh_time : float
        Smallest Rayleigh time of the charge (A1), s.
    rayleigh_fraction : str
        The fraction that has it.
    dt : float
        Time step, s.
    sample_dt : float
        Torque sampling interval, s.
    analysis_band_hz : float
        Upper end of the analysis band, Hz.
    band_is_nyquist : bool
        Whether the band is the Nyquist frequency 1 / (2 sample_dt) (no band given).
    impact_speed : float
        Expected impact speed, m/s.
    impact_speed_basis : str
        How it was obtained (A4, A5, or given).
    upper_speed : float
        v_max of A6, m/s.
    contacts : tuple of ContactAdvice
        Every pair of fractions, then every fraction against the drum.
    """

    scene_name: str
    rayleigh_time: float
    rayleigh_fraction: str
    dt: float
    sample_dt: float
    analysis_band_hz: float
    band_is_nyquist: bool
    impact_speed: float
    impact_speed_basis: str
    upper_speed: float
    contacts: tuple[ContactAdvice, ...]

    @property
    def dt_fraction(self) -> float:
        """dt / rayleigh_time."""
        return self.dt / self.rayleigh_time

    @property
    def longest(self) -> ContactAdvice:
        """The contact of the lowest frequency (the first to reach the band)."""
        return max(self.contacts, key=lambda c: c.contact_time)

    @property
    def shortest(self) -> ContactAdvice:
        """The contact of the fewest steps."""
        return min(self.contacts, key=lambda c: c.contact_time)

    @property
    def reaching_band(self) -> tuple[ContactAdvice, ...]:
        """The contacts whose frequency 1 / t_c is at or below the analysis band's upper end."""
        return tuple(c for c in self.contacts if c.contact_hz <= self.analysis_band_hz)

    @property
    def band_margin(self) -> float:
        """Lowest contact frequency / analysis band (<= 1: a warning)."""
        return self.longest.contact_hz / self.analysis_band_hz

    def _band_text(self) -> str:
        source = "the Nyquist frequency" if self.band_is_nyquist else "given"
        return f"0 .. {self.analysis_band_hz:.4g} Hz ({source})"

    def verdict(self) -> str:
        """One sentence: whether the contacts' frequency content stays out of the band."""
        low = self.longest
        if self.reaching_band:
            labels = ", ".join(c.label for c in self.reaching_band)
            return (f"WARNING: the contact frequency 1/t_c of {labels} (lowest "
                    f"{low.contact_hz:.4g} Hz, {low.label}) reaches the analysis band "
                    f"{self._band_text()}: the torque spectrum there depends on the stiffness. "
                    "Raise the shear modulus (a stiffer scale) or analyse a narrower band.")
        return (f"ok: the lowest contact frequency, {low.contact_hz:.4g} Hz ({low.label}), is "
                f"{self.band_margin:.3g} x the analysis band {self._band_text()}; the shortest "
                f"contact spans {self.shortest.steps_per_contact:.3g} steps.")

    def _rows(self) -> list[list[str]]:
        return [[c.label, f"{c.pair.restitution:g}", f"{c.contact_time:.4g}",
                 f"{c.contact_hz:.4g}", f"{c.steps_per_contact:.1f}", str(c.integrated_steps),
                 f"{c.samples_per_contact:.3g}", f"{100.0 * c.max_overlap:.3g}",
                 f"{c.stability_margin:.2f}"] for c in self.contacts]

    _HEADER = ("contact", "e", "t_c (s)", "1/t_c (Hz)", "steps", "steps (engine)",
               "samples", "overlap (% r)", "stability margin")

    def _facts(self) -> list[str]:
        return [
            f"Rayleigh time {self.rayleigh_time:.4g} s (fraction {self.rayleigh_fraction!r}); "
            f"dt = {self.dt:.4g} s = {self.dt_fraction:.3g} x the Rayleigh time",
            f"torque samples every {self.sample_dt:g} s; analysis band {self._band_text()}",
            f"impact speed {self.impact_speed:.3g} m/s: {self.impact_speed_basis}",
            f"stability margins at the upper speed {self.upper_speed:.3g} m/s (A6)",
        ]

    def __str__(self) -> str:
        rows = [list(self._HEADER), *self._rows()]
        widths = [max(len(r[k]) for r in rows) for k in range(len(self._HEADER))]
        table = ["  " + "  ".join(cell.rjust(w) if k else cell.ljust(w)
                                  for k, (cell, w) in enumerate(zip(r, widths, strict=True)))
                 for r in rows]
        return "\n".join([f"stiffness advice: {self.scene_name or 'scene'}",
                          *("  " + f for f in self._facts()), *table, self.verdict()])

    def to_markdown(self) -> str:
        """A Markdown section: the facts, the table of contacts and the verdict."""
        lines = [f"### Stiffness advice: {self.scene_name or 'scene'}", ""]
        lines += [f"- {f}" for f in self._facts()]
        lines += ["", "| " + " | ".join(self._HEADER) + " |",
                  "|" + "---|" * len(self._HEADER)]
        lines += ["| " + " | ".join(r) + " |" for r in self._rows()]
        lines += ["", ("**" + self.verdict() + "**") if self.reaching_band else self.verdict()]
        lines += ["", "steps: t_c / dt; steps (engine): the impact integrated with the engine's "
                  "law at dt and the pair's restitution; samples: t_c / sample_dt; stability "
                  "margin: (2 / w_max at the upper speed) / dt."]
        return "\n".join(lines)


# -- speeds ------------------------------------------------------------------------------------


def expected_impact_speed(scene: Scene) -> tuple[float, str]:
    """The expected impact speed of a scene, m/s, and how it was obtained (module docstring).

    Cataracting (0 < w^2 R_p / g < 1): the Davis landing speed, A3-A4. Otherwise: the free-fall
    speed across the drum, sqrt(2 g D) (A5).
    """
    _require_scene(scene)
    g, omega = scene.gravity, scene.omega
    r_p = scene.drum.radius - 0.5 * scene.max_diameter  # the outer layer's centres, m
    sin_alpha = omega * omega * r_p / g  # (A3)
    if 0.0 < sin_alpha < 1.0:
        speed = omega * r_p * math.sqrt(1.0 + 8.0 * (1.0 - sin_alpha**2))  # (A4)
        alpha_deg = math.degrees(math.asin(sin_alpha))
        return speed, (f"cataracting, the Davis landing speed (A3-A4; leaving the shell "
                       f"{alpha_deg:.3g} deg above the horizontal)")
    regime = "drum at rest" if omega == 0.0 else "at or above critical speed, no cataract"
    return math.sqrt(2.0 * g * scene.drum.diameter), f"{regime}: free fall across the drum (A5)"


def wave_speed(scene: Scene) -> tuple[float, str]:
    """The slowest bar wave speed sqrt(E / rho) of the materials in use, m/s, and the material
    that has it: impacts anywhere near it are not elastic, and Hertz contact theory does not
    hold for them."""
    _require_scene(scene)
    speeds = [(math.sqrt(m.youngs_modulus / m.density), m.name)
              for m in map(scene.material, scene.used_materials())]
    return min(speeds)


def upper_impact_speed(scene: Scene) -> float:
    """v_max = sqrt(2 g D) + w R (A6), m/s: a fall across the drum onto a lifter at rim speed."""
    _require_scene(scene)
    return math.sqrt(2.0 * scene.gravity * scene.drum.diameter) + scene.omega * scene.drum.radius


# -- the largest stable time step -------------------------------------------------------------


@dataclass(frozen=True)
class PairLimit:
    """The fastest modes of one kind of contact at the scene's upper impact speed.

    Attributes
    ----------
    label : str
        ``"<fraction> (<material>) - <fraction> (<material>)"``, or ``"... - drum (<material>)"``.
    modes : tuple of ContactMode
        The damped normal mode and, with friction, the stick mode
        (:func:`millscope.contact.contact_modes`).
    """

    label: str
    modes: tuple[ContactMode, ...]

    @property
    def fastest(self) -> ContactMode:
        """The mode of the smallest stability bound."""
        return min(self.modes, key=lambda m: m.stability_dt)

    @property
    def dt(self) -> float:
        """DT_SAFETY_FACTOR x the fastest mode's stability bound (S3), s."""
        return DT_SAFETY_FACTOR * self.fastest.stability_dt


@dataclass(frozen=True)
class TimeStepLimit:
    """The largest time step a scene accepts, and what sets it (:func:`time_step_limit`).

    Attributes
    ----------
    dt : float
        The limit, s: the smaller of ``modal_dt`` and ``rayleigh_bound``.
    pair : str
        Label of the limiting contact (:class:`PairLimit`).
    mode : ContactMode
        Its fastest mode.
    modal_dt : float
        DT_SAFETY_FACTOR x that mode's stability bound, s.
    rayleigh_time : float
        Smallest Rayleigh time of the charge (A1), s.
    rayleigh_fraction : str
        The fraction that has it.
    speed : float
        The upper impact speed the modes are evaluated at (A6), m/s.
    pairs : tuple of PairLimit
        Every pair of fractions, then every fraction against the drum.
    """

    dt: float
    pair: str
    mode: ContactMode
    modal_dt: float
    rayleigh_time: float
    rayleigh_fraction: str
    speed: float
    pairs: tuple[PairLimit, ...]

    @property
    def rayleigh_ratio(self) -> float:
        """modal_dt / rayleigh_time: the modal limit in Rayleigh times."""
        return self.modal_dt / self.rayleigh_time

    @property
    def rayleigh_bound(self) -> float:
        """MAX_DT_FRACTION x rayleigh_time, s: the engine's own cap (``timestep.hpp``)."""
        return MAX_DT_FRACTION * self.rayleigh_time

    @property
    def by_rayleigh(self) -> bool:
        """Whether the Rayleigh cap, not a contact mode, sets ``dt``."""
        return self.rayleigh_bound <= self.modal_dt

    def valid_range(self) -> str:
        """``"in (0, <dt>] s, ..."``: the valid range of a step and what sets it, for messages."""
        where = f"the Rayleigh time {self.rayleigh_time:.6g} s of the fraction " \
                f"{self.rayleigh_fraction!r}"
        if self.by_rayleigh:
            return (f"in (0, {self.dt:.6g}] s, {MAX_DT_FRACTION} x {where}, the stiffest in "
                    "the charge")
        m = self.mode
        return (f"in (0, {self.dt:.6g}] s = {self.rayleigh_ratio:.3g} x {where}: "
                f"{DT_SAFETY_FACTOR} x the velocity-Verlet stability bound of the {m.name} mode "
                f"of the contact {self.pair} at the upper impact speed {self.speed:.3g} m/s "
                f"(w0 = {m.angular_frequency:.4g} rad/s, zeta = {m.damping_ratio:.3g})")

    def check(self, dt: object, name: str = "dt") -> float:
        """``dt`` as float if finite and in (0, self.dt], else ValueError naming ``name``, the
        value, the limit, the pair and the mode."""
        x = _checks.as_float(dt)  # nan when not a real number
        if not (math.isfinite(x) and 0.0 < x <= self.dt):
            raise ValueError(f"{name} = {dt!r} s is not valid; it must be {self.valid_range()}")
        return x

    def default_dt(self) -> float:
        """The default step, s: DEFAULT_DT_FRACTION x rayleigh_time, or the limit itself where
        the scene's contacts need a smaller step (heavily damped stick modes, restitution of
        a few per cent)."""
        return min(DEFAULT_DT_FRACTION * self.rayleigh_time, self.dt)


def time_step_limit(scene: Scene) -> TimeStepLimit:
    """The largest time step the engine integrates a scene's contacts stably with.

    For every pair of fractions and every fraction against the drum (a flat wall of the
    drum's material), the damped normal mode and, with friction, the tangential stick mode
    coupled with rotation are linearised at the largest overlap of an elastic impact at the
    upper impact speed v_max (A6) (:func:`millscope.contact.contact_modes`, eqs. M1-M2); each
    mode of angular frequency w0 and damping ratio zeta is stable for
    dt < verlet_stability_bound(zeta) / w0 (S3). The limit is DT_SAFETY_FACTOR (0.8, justified
    in :mod:`millscope.contact`) x the smallest such bound, and never above the engine's cap
    MAX_DT_FRACTION (0.5) x the smallest Rayleigh time.

    With the paper's moduli the cap sets the limit (the modal one is 0.55-0.66 Rayleigh times
    for the presets); with the moduli x 0.001 ("tiny", "soft") the stick mode does (0.28-0.33
    Rayleigh times, 0.31 for the balls-only mill at 71 % of critical).

    Parameters
    ----------
    scene : Scene

    Returns
    -------
    TimeStepLimit
    """
    _require_scene(scene)
    t_rayleigh, stiffest = scene.min_rayleigh_time()
    speed = upper_impact_speed(scene)
    pairs = tuple(_pair_limit(scene, a, b, speed) for a, b in _contact_kinds(scene))
    worst = min(pairs, key=lambda p: p.dt)
    dt = min(worst.dt, MAX_DT_FRACTION * t_rayleigh)
    return TimeStepLimit(dt=dt, pair=worst.label, mode=worst.fastest, modal_dt=worst.dt,
                         rayleigh_time=t_rayleigh, rayleigh_fraction=stiffest, speed=speed,
                         pairs=pairs)


def _pair_limit(scene: Scene, a: Fraction, b: Fraction | None, speed: float) -> PairLimit:
    """One contact kind's modes; b None is the drum."""
    mat_a = scene.material(a.material)
    mat_b = scene.material(scene.drum.material if b is None else b.material)
    coeff = scene.pair(a.material, mat_b.name)
    other = DRUM if b is None else b.name
    label = f"{a.name} ({mat_a.name}) - {other} ({mat_b.name})"
    return PairLimit(label, contact_modes(mat_a, mat_b, a.diameter,
                                          None if b is None else b.diameter, speed,
                                          coeff.restitution, coeff.friction))


# -- the advisor -------------------------------------------------------------------------------


def advise_stiffness(scene: Scene, *, dt: float | None = None, sample_dt: float = 0.01,
                     analysis_band_hz: float | None = None,
                     impact_speed: float | None = None) -> StiffnessAdvice:
    """Contact times of a scene against its time step and its torque sampling.

    Parameters
    ----------
    scene : Scene
    dt : float, optional
        Time step, s, in (0, the scene's limit] (:func:`time_step_limit`, as the engine);
        default DEFAULT_DT_FRACTION x the smallest Rayleigh time (the engine's default).
    sample_dt : float
        Torque sampling interval, s, in [dt, 1 / (2 f)] (0.01 s in the paper), where f is the
        LTH (lifters x rotation frequency; the rotation frequency without lifters): the
        samples must resolve the line the method reads.
    analysis_band_hz : float, optional
        Upper end of the analysis band, Hz, in [f, 1 / (2 sample_dt)]; default the Nyquist
        frequency 1 / (2 sample_dt).
    impact_speed : float, optional
        Normal approach speed of the impacts, m/s, in (0, :func:`wave_speed`]; default
        :func:`expected_impact_speed`.

    Returns
    -------
    StiffnessAdvice

    Warns
    -----
    StiffnessWarning
        When 1 / t_c of some contact is at or below ``analysis_band_hz``.

    Raises
    ------
    ValueError
        A bad argument, naming it, its value and the valid range.
    """
    _require_scene(scene)
    t_rayleigh, stiffest = scene.min_rayleigh_time()
    limit = time_step_limit(scene)
    dt = limit.default_dt() if dt is None else limit.check(dt)
    # The band must hold the line the method reads: the LTH, or the mill turn without lifters
    # (none for a drum at rest, whose band only needs to be above 0 Hz).
    lifters = scene.drum.lifters
    line_hz, line = ((lifters.count * scene.rotation_hz, "the LTH") if lifters is not None
                     else (scene.rotation_hz, "the rotation frequency"))
    if line_hz > 0:
        sample_dt = _in_range("sample_dt", sample_dt, "s", dt, 0.5 / line_hz,
                              f"in [dt = {dt:.6g}, {0.5 / line_hz:.6g}] s, so that the Nyquist "
                              f"frequency is above {line} at {line_hz:.4g} Hz", low_open=False)
    else:
        sample_dt = _in_range("sample_dt", sample_dt, "s", dt, math.inf,
                              f">= the time step dt = {dt:.6g} s", low_open=False)
    nyquist = 0.5 / sample_dt
    band_is_nyquist = analysis_band_hz is None
    band_valid = (f"in [{line_hz:.4g}, {nyquist:.6g}] Hz: from {line} to the Nyquist "
                  f"frequency of sample_dt = {sample_dt:g} s" if line_hz > 0 else
                  f"in (0, {nyquist:.6g}] Hz, the Nyquist frequency of sample_dt = "
                  f"{sample_dt:g} s")
    band = nyquist if analysis_band_hz is None else _in_range(
        "analysis_band_hz", analysis_band_hz, "Hz", line_hz, nyquist, band_valid,
        low_open=line_hz <= 0)
    if impact_speed is None:
        speed, basis = expected_impact_speed(scene)
    else:
        sound, material = wave_speed(scene)
        speed = _in_range("impact_speed", impact_speed, "m/s", 0.0, sound,
                          f"in (0, {sound:.4g}] m/s, below the speed of sound sqrt(E / rho) "
                          f"in {material!r}, beyond which no contact is elastic (Hertz)")
        basis = "given"
    v_max = max(upper_impact_speed(scene), speed)

    contacts = tuple(_contact(scene, a, b, speed, v_max, dt, sample_dt)
                     for a, b in _contact_kinds(scene))
    advice = StiffnessAdvice(
        scene_name=scene.name, rayleigh_time=t_rayleigh, rayleigh_fraction=stiffest, dt=dt,
        sample_dt=sample_dt, analysis_band_hz=band, band_is_nyquist=band_is_nyquist,
        impact_speed=speed, impact_speed_basis=basis, upper_speed=v_max, contacts=contacts)
    if advice.reaching_band:
        warnings.warn(advice.verdict(), StiffnessWarning, stacklevel=2)
    return advice


def _contact_kinds(scene: Scene) -> list[tuple[Fraction, Fraction | None]]:
    """Every unordered pair of fractions (charge order), then every fraction with the drum."""
    charge = scene.charge
    pairs: list[tuple[Fraction, Fraction | None]] = [
        (a, b) for i, a in enumerate(charge) for b in charge[i:]]
    return pairs + [(a, None) for a in charge]


def _contact(scene: Scene, a: Fraction, b: Fraction | None, speed: float, v_max: float,
             dt: float, sample_dt: float) -> ContactAdvice:
    """One contact kind: b None is the drum (a flat wall of the drum's material)."""
    mat_a = scene.material(a.material)
    mat_b = scene.material(scene.drum.material if b is None else b.material)
    coeff = scene.pair(a.material, mat_b.name)
    d_b = None if b is None else b.diameter
    pair = pair_properties(mat_a, mat_b, a.diameter, d_b, coeff.restitution, coeff.friction)
    t_c = hertz_contact_time(mat_a, mat_b, a.diameter, d_b, speed)  # (A2)
    if t_c > dt:
        hit = impact(mat_a, mat_b, a.diameter, d_b, speed, coeff.restitution, coeff.friction, dt)
        integrated_time, integrated_steps = hit.contact_time, hit.contact_steps
    else:  # the contact is over within one step: nothing to integrate
        integrated_time, integrated_steps = math.nan, 0
    r_small = a.radius if b is None else min(a.radius, b.radius)
    return ContactAdvice(
        label=f"{a.name}-{WALL if b is None else b.name}", fraction_a=a.name,
        fraction_b=WALL if b is None else b.name, pair=pair, speed=speed, contact_time=t_c,
        integrated_contact_time=integrated_time, integrated_steps=integrated_steps,
        max_overlap=hertz_max_overlap(mat_a, mat_b, a.diameter, d_b, speed) / r_small,
        stability_dt=hertz_stability_dt(mat_a, mat_b, a.diameter, d_b, v_max), dt=dt,
        sample_dt=sample_dt)


# -- validation --------------------------------------------------------------------------------


def _require_scene(scene: object) -> None:
    if not isinstance(scene, Scene):
        raise ValueError(f"scene = {type(scene).__name__} is not valid; it must be a millscope "
                         "Scene (millscope.presets.pilot_mill builds the paper's)")


def _in_range(name: str, value: object, unit: str, low: float, high: float, valid: str, *,
              low_open: bool = True) -> float:
    """``value`` as float if finite and in (low, high] (or [low, high]); else ValueError
    ``"<name> = <value> <unit> is not valid; it must be <valid>"``."""
    x = _checks.as_float(value)  # nan when not a real number
    inside = (x > low if low_open else x >= low) and x <= high
    if not (math.isfinite(x) and inside):
        raise ValueError(f"{name} = {value!r} {unit} is not valid; it must be {valid}")
    return x

"""Synthetic torque records with known content, for demos, tests and checking an analysis.

A synthetic record is a mean torque, a lifter torque harmonic (LTH), optional drive-train lines,
and white Gaussian noise whose variance follows a chosen energy law of the load level,
s^2(x) = s_1^2 (a ln(x) + b), the shape the paper fits to DEM energies (Table 6). Everything is
known, so an analysis run on it can be checked: the spectral energy after removing the mean and
the lines is about s^2(x) TR (fraction of the band kept), and the log fit of the per-unit
energies recovers a and b up to noise. These records are not simulations of a mill.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass
from types import MappingProxyType

import numpy as np

from .record import TorqueRecord

__all__ = ["PAPER_HDMS_LAW", "PAPER_TABLE_6", "SyntheticTorque", "synthetic_record"]

#: The paper's Table 6: per group, the fit y = a ln(x) + b of the DEM energies per unit against
#: the load level x, as (a, b, R^2).
PAPER_TABLE_6: Mapping[str, tuple[float, float, float]] = MappingProxyType({
    "HDLS": (-0.423, 0.9279, 0.9650), "LDLS": (-0.451, 1.0057, 0.9881),
    "HDMS": (-0.454, 0.9987, 0.9959), "LDMS": (-0.408, 0.8738, 0.8982),
    "HDHS": (-0.476, 0.9868, 0.9849), "LDHS": (-0.429, 0.9646, 0.9882)})
#: HDMS fit of the paper's Table 6, y = -0.454 ln(x) + 0.9987.
PAPER_HDMS_LAW = PAPER_TABLE_6["HDMS"][:2]


@dataclass(frozen=True)
class SyntheticTorque:
    """What a synthetic record holds.

    Attributes
    ----------
    rotation_hz : float
        Mill rotation frequency, Hz.
    lifters : int
        Lifter count; the LTH sits at lifters x rotation_hz.
    mean_torque_Nm : float
        Mean drive torque, N m.
    lth_amplitude_Nm : float
        Amplitude of the LTH, N m.
    noise_std_Nm : float
        Standard deviation s_1 of the noise at load level 1, N m.
    energy_law : (float, float)
        (a, b) of s^2(x) = s_1^2 (a ln(x) + b); it must stay positive over the levels used.
    lines : sequence of (float, float)
        Further lines as (frequency Hz, amplitude N m), e.g. drive-train harmonics.
    """

    rotation_hz: float = 0.5413
    lifters: int = 16
    mean_torque_Nm: float = 265.0
    lth_amplitude_Nm: float = 6.0
    noise_std_Nm: float = 30.0
    energy_law: tuple[float, float] = PAPER_HDMS_LAW
    lines: tuple[tuple[float, float], ...] = ()

    def noise_variance(self, level: float) -> float:
        """s^2(level), (N m)^2."""
        a, b = self.energy_law
        share = a * np.log(level) + b
        if share <= 0:
            raise ValueError(f"level = {level!r}: the energy law a ln(x) + b = {share:.3g} is not "
                             "positive there; choose a level or law that keeps it > 0")
        return float(self.noise_std_Nm**2 * share)


def synthetic_record(level: float, *, content: SyntheticTorque | None = None,
                     duration_s: float = 14.0, sample_rate_hz: float = 100.0,
                     seed: int = 0, lines: Sequence[tuple[float, float]] = ()) -> TorqueRecord:
    """A synthetic torque record at load ``level`` (see the module docstring).

    Parameters
    ----------
    level : float
        Load level x (> 0; the paper's 1..7).
    content : SyntheticTorque, optional
        What the record holds; defaults to the pilot mill at 71 % critical.
    duration_s : float
        Record length, s.
    sample_rate_hz : float
        Sampling frequency, Hz (100 Hz = the paper's 10 ms).
    seed : int
        Seed of the noise and of the line phases.
    lines : sequence of (float, float)
        Extra (frequency Hz, amplitude N m) lines added to those of ``content``.
    """
    c = content or SyntheticTorque()
    if not level > 0:
        raise ValueError(f"level = {level!r} is not valid; it must be > 0")
    if not (duration_s > 0 and sample_rate_hz > 0):
        raise ValueError(f"duration_s = {duration_s!r} and sample_rate_hz = {sample_rate_hz!r} "
                         "must both be > 0")
    n = int(round(duration_s * sample_rate_hz))
    if n < 4:
        raise ValueError(f"duration_s x sample_rate_hz = {n} samples; at least 4 are needed")
    rng = np.random.default_rng(seed)
    t = np.arange(n) / sample_rate_hz
    lth_hz = c.lifters * c.rotation_hz
    torque = np.full(n, c.mean_torque_Nm)
    for f, amp in ((lth_hz, c.lth_amplitude_Nm), *c.lines, *lines):
        torque += amp * np.sin(2 * np.pi * f * t + rng.uniform(0, 2 * np.pi))
    torque += rng.normal(0.0, np.sqrt(c.noise_variance(level)), n)
    meta = {"synthetic": asdict(c), "level": float(level), "seed": seed,
            "rotation_hz": c.rotation_hz, "lifters": c.lifters, "sampling": "instant"}
    return TorqueRecord(t, torque, meta)

"""Drive power from a torque record: P = omega x mean torque.

The drive supplies the recorded torque (docs/architecture.md, Torque) at the drum's speed
omega, so the mean power it delivers is omega times the mean torque over the block. The
uncertainty of the mean comes from batch means: the block is cut into equal consecutive
batches and the scatter of their means gives the standard error (the torque of a mill is
correlated over a fraction of a revolution, so the scatter of single samples would
understate it).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .. import _checks
from .record import TorqueRecord

__all__ = ["DrivePower", "drive_power"]


@dataclass(frozen=True)
class DrivePower:
    """Mean drive power over a block of a torque record.

    Attributes
    ----------
    mean_torque_Nm : float
        Mean drive torque over the block, N m.
    omega_rad_s : float
        Drum speed, rad/s.
    power_W : float
        omega x mean torque, W.
    standard_error_W : float
        Standard error of ``power_W`` from the means of ``batches`` equal consecutive
        batches of the block, W.
    batches : int
        Number of batches.
    span_s : tuple of float
        Time of the first and of the last sample of the block, s.
    """

    mean_torque_Nm: float
    omega_rad_s: float
    power_W: float
    standard_error_W: float
    batches: int
    span_s: tuple[float, float]


def drive_power(record: TorqueRecord, rotation_hz: float | None = None, *,
                t_from: float | None = None, t_to: float | None = None,
                batches: int = 5) -> DrivePower:
    """Mean drive power of a record, or of its block ``t_from <= t < t_to``.

    Parameters
    ----------
    record : TorqueRecord
        Drive torque, N m (positive when the charge resists the rotation).
    rotation_hz : float, optional
        Drum rotation frequency, Hz (> 0); default the record's ``meta["rotation_hz"]``
        (simulated records carry it).
    t_from, t_to : float, optional
        The block, s; default the whole record. Leave out the start-up of the charge.
    batches : int
        Number of equal consecutive batches for the standard error, >= 2, and at most half
        the samples of the block.

    Returns
    -------
    DrivePower

    Raises
    ------
    ValueError
        For a missing or invalid rotation frequency, a block with too few samples, or a bad
        number of batches.
    """
    if not isinstance(record, TorqueRecord):
        raise TypeError(f"record must be a TorqueRecord, not {type(record).__name__}")
    if rotation_hz is None:
        if "rotation_hz" not in record.meta:
            raise ValueError("drive_power: the record's meta has no 'rotation_hz'; pass "
                             "rotation_hz (the drum's rotation frequency, Hz)")
        rotation_hz = record.meta["rotation_hz"]
    hz = _checks.positive("drive_power rotation_hz", rotation_hz, "Hz")
    if t_from is not None or t_to is not None:
        times = record.time_s
        low = float(times[0]) if t_from is None else t_from
        high = float(times[-1]) + record.dt if t_to is None else t_to
        record = record.block(low, high)
    n = len(record)
    count = _checks.integer("drive_power batches", batches, ValueError, low=2, high=n // 2,
                            why=f"the block holds {n} samples; a batch needs at least 2")
    omega = 2.0 * math.pi * hz
    torque = np.asarray(record.torque_Nm)
    # batches of (nearly) equal length; the means are weighted equally
    means = np.array([float(np.mean(part)) for part in np.array_split(torque, count)])
    mean = float(np.mean(torque))
    error = float(np.std(means, ddof=1) / math.sqrt(count))
    return DrivePower(mean_torque_Nm=mean, omega_rad_s=omega, power_W=omega * mean,
                      standard_error_W=omega * error, batches=count,
                      span_s=(float(record.time_s[0]), float(record.time_s[-1])))

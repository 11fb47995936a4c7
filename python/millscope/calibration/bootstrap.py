"""Bootstrap helpers: resampled means with the small-sample variance correction, pooled
residuals, and percentile intervals.

Energies of DEM torque scatter from block to block and from seed to seed (docs/architecture.md,
Spectra),
so every energy of a campaign comes with a bootstrap spread. The plain bootstrap of a mean of n
values has a variance (n - 1)/n times the usual unbiased estimate s^2/n, which matters for the
few values a campaign affords (half the variance with 2), so deviations are scaled by
sqrt(n/(n - 1)); and it is done on the log scale, so that energies stay positive.

* :func:`mean_factors` resamples the values of one mean (e.g. the sub-block energies of one
  record).
* :func:`log_residuals` and :func:`pooled_mean_factors` serve means of very few values (2 or 3
  repeats per level): the relative deviations of several such means are pooled, on the
  assumption that they share their relative spread, and each mean draws its resample from the
  pool. With 2 repeats at each of 7 levels, the 95 % intervals of a and b held the truth about
  80 % of the time when each level resampled its own 2 values, and about 91 % when drawing
  from the pool of 14 (tests/test_campaign_analysis.py): the pool's spread is still estimated from 7
  degrees of freedom, which a percentile interval does not allow for.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["log_residuals", "mean_factors", "percentile_interval", "pooled_mean_factors"]


def _positive_values(values: ArrayLike) -> NDArray[np.float64]:
    """``values`` as a 1-D float array of at least 2 finite, positive entries, or ValueError."""
    v = np.asarray(values, dtype=np.float64)
    if v.ndim != 1 or v.size < 2:
        raise ValueError(f"values must be 1-D with at least 2 entries; got shape {v.shape}")
    if not np.all(np.isfinite(v) & (v > 0)):
        raise ValueError(f"values must be finite and > 0; got {v.tolist()}")
    return v


def _replicates(replicates: int) -> int:
    """``replicates`` as an int >= 1, or ValueError."""
    if int(replicates) != replicates or replicates < 1:
        raise ValueError(f"replicates = {replicates!r} is not valid; it must be an integer >= 1")
    return int(replicates)


def mean_factors(values: ArrayLike, replicates: int, rng: np.random.Generator
                 ) -> NDArray[np.float64]:
    """Bootstrap replicates of mean(values) / mean(values) (dimensionless factors around 1).

    Parameters
    ----------
    values : array_like
        n >= 2 positive values whose mean is the estimate (e.g. energies, (N m)^2 s).
    replicates : int
        Number of bootstrap replicates, >= 1.
    rng : numpy.random.Generator

    Returns
    -------
    ndarray, shape (replicates,)
        (m* / m)^c with m* the mean of n values drawn with replacement, m the mean of all, and
        c = sqrt(n / (n - 1)): to first order m*/m - 1 scaled by c, so that the factors' variance
        matches s^2 / (n m^2) with s^2 the unbiased sample variance.

    Raises
    ------
    ValueError
        for fewer than 2 values, a value that is not finite and > 0, or replicates < 1.
    """
    v = _positive_values(values)
    count = _replicates(replicates)
    n = v.size
    means = v[rng.integers(0, n, size=(count, n))].mean(axis=1)
    return np.asarray((means / v.mean()) ** math.sqrt(n / (n - 1)), dtype=np.float64)


def log_residuals(values: ArrayLike) -> NDArray[np.float64]:
    """Relative deviations of n >= 2 positive values from their mean, for pooling:
    (ln v - mean(ln v)) x sqrt(n / (n - 1)).

    Raises
    ------
    ValueError
        for fewer than 2 values, or a value that is not finite and > 0.
    """
    v = _positive_values(values)
    logs = np.log(v)
    return np.asarray((logs - logs.mean()) * math.sqrt(v.size / (v.size - 1)), dtype=np.float64)


def pooled_mean_factors(pool: ArrayLike, n: int, replicates: int, rng: np.random.Generator
                        ) -> NDArray[np.float64]:
    """Bootstrap replicates of the relative change of a mean of ``n`` values whose relative
    deviations are like those in ``pool`` (:func:`log_residuals` of several means).

    Returns
    -------
    ndarray, shape (replicates,)
        exp(mean of ``n`` deviations drawn from ``pool`` with replacement).
    """
    d = np.asarray(pool, dtype=np.float64)
    if d.ndim != 1 or d.size < 2 or not np.all(np.isfinite(d)):
        raise ValueError(f"pool must be 1-D with at least 2 finite deviations; got {d.tolist()}")
    if int(n) != n or n < 1:
        raise ValueError(f"n = {n!r} is not valid; it must be an integer >= 1")
    count = _replicates(replicates)
    return np.asarray(np.exp(d[rng.integers(0, d.size, size=(count, int(n)))].mean(axis=1)),
                      dtype=np.float64)


def percentile_interval(samples: ArrayLike, confidence: float, axis: int = 0
                        ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The central ``confidence`` interval of bootstrap ``samples`` along ``axis``.

    Parameters
    ----------
    samples : array_like
        Replicates along ``axis``.
    confidence : float
        In (0, 1), e.g. 0.95: the (1 - confidence)/2 and (1 + confidence)/2 quantiles.
    axis : int

    Returns
    -------
    low, high : ndarray
        The quantiles (0-d arrays for 1-D samples).
    """
    if not 0 < confidence < 1:
        raise ValueError(f"confidence = {confidence!r} is not valid; it must be in (0, 1)")
    lo, hi = np.quantile(np.asarray(samples, dtype=np.float64),
                         [(1 - confidence) / 2, (1 + confidence) / 2], axis=axis)
    return lo, hi

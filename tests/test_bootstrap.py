"""Bootstrap helpers against their stated moments (the unbiased variance of a mean, the pooled
variance over n) and against the normal quantiles; bad input."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import stats

from millscope.bootstrap import (
    log_residuals,
    mean_factors,
    percentile_interval,
    pooled_mean_factors,
)

REPLICATES = 200_000  # the variance of 200 000 replicates is good to about 0.3 % (sqrt(2/R))


@pytest.mark.parametrize("n", [2, 3, 10])
def test_mean_factors_have_the_unbiased_variance_of_the_mean(n: int) -> None:
    """Small relative deviations (first order holds): var(factors) = s^2 / (n m^2), s^2 with
    n - 1 in the denominator, where the plain bootstrap gives (n - 1)/n of it."""
    v = 100.0 * (1 + 0.01 * np.random.default_rng(n).normal(size=n))
    f = mean_factors(v, REPLICATES, np.random.default_rng(1))
    expected = np.var(v, ddof=1) / (n * v.mean() ** 2)
    assert f.shape == (REPLICATES,)
    assert np.var(f) == pytest.approx(expected, rel=0.02)
    assert np.mean(f) == pytest.approx(1.0, abs=4 * math.sqrt(expected / REPLICATES) + 1e-6)


def test_log_residuals_carry_the_unbiased_variance_of_the_logs() -> None:
    v = np.array([3.0, 5.0, 4.0, 9.0])
    r = log_residuals(v)
    assert r.sum() == pytest.approx(0.0, abs=1e-12)
    assert np.var(r) == pytest.approx(np.var(np.log(v), ddof=1), rel=1e-12)


@pytest.mark.parametrize("n", [1, 2, 3])
def test_pooled_mean_factors_have_the_pools_variance_over_n(n: int) -> None:
    pool = np.concatenate([log_residuals([1.0, 1.3]), log_residuals([2.0, 1.7, 2.2])])
    f = pooled_mean_factors(pool, n, REPLICATES, np.random.default_rng(2))
    assert np.var(np.log(f)) == pytest.approx(np.var(pool) / n, rel=0.02)


def test_percentile_interval_of_normal_samples_is_the_normal_quantiles() -> None:
    samples = np.random.default_rng(3).normal(2.0, 0.5, size=(REPLICATES, 2))
    lo, hi = percentile_interval(samples, 0.9)
    z = stats.norm.ppf(0.95)
    np.testing.assert_allclose(lo, 2.0 - 0.5 * z, atol=0.01)
    np.testing.assert_allclose(hi, 2.0 + 0.5 * z, atol=0.01)
    lo1, hi1 = percentile_interval(samples[:, 0], 0.9)
    assert lo1.shape == hi1.shape == () and lo1 == lo[0]


def test_bad_input_names_what_is_wrong() -> None:
    rng = np.random.default_rng(0)
    with pytest.raises(ValueError, match="at least 2 entries"):
        mean_factors([1.0], 10, rng)
    with pytest.raises(ValueError, match="finite and > 0"):
        log_residuals([1.0, -2.0])
    with pytest.raises(ValueError, match="replicates = 0 is not valid"):
        mean_factors([1.0, 2.0], 0, rng)
    with pytest.raises(ValueError, match="replicates = 1.5 is not valid"):
        pooled_mean_factors([0.1, -0.1], 2, 1.5, rng)
    with pytest.raises(ValueError, match="n = 0 is not valid"):
        pooled_mean_factors([0.1, -0.1], 0, 10, rng)
    with pytest.raises(ValueError, match="pool must be 1-D"):
        pooled_mean_factors([0.1, math.nan], 1, 10, rng)
    with pytest.raises(ValueError, match="confidence = 1 is not valid"):
        percentile_interval([1.0, 2.0], 1)

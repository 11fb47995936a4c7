"""The log fit y = a ln(x) + b of energy against filling (paper section 6.4, Table 6).

The paper fits the per-unit spectral energy y against the load level x (1..7, particle filling in
units of 40 %). :func:`log_fit` makes one fit with its standard errors and what a prediction
interval needs; :func:`log_fit_coefficients` fits many rows at once (bootstrap replicates);
:func:`per_unit` makes energies per unit of the largest of their group.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["LogFit", "log_fit", "log_fit_coefficients", "per_unit"]


@dataclass(frozen=True)
class LogFit:
    """Least-squares fit y = a ln(x) + b.

    Attributes
    ----------
    a, b : float
        Slope against ln(x) and intercept (units of y).
    r2 : float
        Coefficient of determination.
    a_stderr, b_stderr : float
        Standard errors of a and b (nan with only 2 points).
    n : int
        Number of points.
    x_min, x_max : float
        Range of x fitted.
    ln_x_mean, ln_x_sxx, residual_std : float
        Mean of ln(x), sum of squared deviations of ln(x), and the residual standard deviation;
        they give prediction intervals.
    """

    a: float
    b: float
    r2: float
    a_stderr: float
    b_stderr: float
    n: int
    x_min: float
    x_max: float
    ln_x_mean: float
    ln_x_sxx: float
    residual_std: float

    def __call__(self, x: ArrayLike) -> NDArray[np.float64]:
        """y = a ln(x) + b."""
        return self.a * np.log(np.asarray(x, dtype=np.float64)) + self.b

    def inverse(self, y: ArrayLike) -> NDArray[np.float64] | float:
        """x = exp((y - b) / a)."""
        if self.a == 0:
            raise ValueError("the fit has slope a = 0; y does not determine x")
        result = np.exp((np.asarray(y, dtype=np.float64) - self.b) / self.a)
        return float(result) if np.ndim(result) == 0 else result

    def prediction_half_width(self, x: float, confidence: float = 0.95,
                              observation_std: float = 0.0) -> float:
        """Half-width of the prediction interval of a new y at x (units of y).

        The new observation's own scatter is the larger of the fit's residual standard
        deviation and ``observation_std`` (what the new y is known to scatter by, e.g. the
        sampling spread of its energy): a fit through few points can underestimate it.
        """
        if self.n < 3 or not np.isfinite(self.residual_std):
            return math.nan
        # scipy.stats takes most of a second to import: loaded here, on first use, so that
        # `import millscope` stays quick
        from scipy import stats

        t = stats.t.ppf(0.5 + confidence / 2, self.n - 2)
        u = math.log(x)
        mean_var = self.residual_std**2 * (1 / self.n + (u - self.ln_x_mean) ** 2 / self.ln_x_sxx)
        new_var = max(self.residual_std, observation_std) ** 2
        return float(t * math.sqrt(mean_var + new_var))

    def equation(self) -> str:
        """The fit as the paper writes it, e.g. ``y = -0.423 ln(x) + 0.9279``."""
        sign = "+" if self.b >= 0 else "-"
        return f"y = {self.a:.4g} ln(x) {sign} {abs(self.b):.4g}"


def _log_abscissae(x: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64], float]:
    """(x, u = ln x, sum of squared deviations of u), with x checked."""
    xs = np.asarray(x, dtype=np.float64)
    if xs.ndim != 1:
        raise ValueError(f"x must be 1-D; got shape {xs.shape}")
    if xs.size < 2:
        raise ValueError(f"log_fit needs at least 2 points; got {xs.size}")
    if not (np.all(np.isfinite(xs)) and np.all(xs > 0)):
        raise ValueError(f"x must be finite and > 0 for ln(x); got {xs.tolist()}")
    u = np.log(xs)
    sxx = float(np.sum((u - u.mean()) ** 2))
    if sxx == 0:
        raise ValueError("all x are equal; a slope cannot be fitted")
    return xs, u, sxx


def log_fit_coefficients(x: ArrayLike, y: ArrayLike
                         ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Least-squares a and b of y = a ln(x) + b for every row of ``y`` at once.

    Parameters
    ----------
    x : array_like, shape (n,)
        Positive abscissae (load levels).
    y : array_like, shape (n,) or (m, n)
        Values; each row is fitted on its own (e.g. bootstrap replicates).

    Returns
    -------
    a, b : ndarray
        Shape () for a 1-D ``y``, else (m,); units of y.

    Raises
    ------
    ValueError
        as :func:`log_fit`.
    """
    xs, u, sxx = _log_abscissae(x)
    ys = np.asarray(y, dtype=np.float64)
    if ys.shape[-1:] != xs.shape or ys.ndim > 2:
        raise ValueError(f"y must have shape ({xs.size},) or (m, {xs.size}) to pair with x; "
                         f"got {ys.shape}")
    if not np.all(np.isfinite(ys)):
        raise ValueError(f"y must be finite; got {ys.tolist()}")
    du = u - u.mean()
    a = (ys @ du) / sxx
    b = ys.mean(axis=-1) - a * u.mean()
    return a, b


def log_fit(x: ArrayLike, y: ArrayLike) -> LogFit:
    """Fit y = a ln(x) + b by least squares (paper Table 6).

    Parameters
    ----------
    x : array_like
        Positive abscissae (load levels).
    y : array_like
        Values (per-unit energies).

    Raises
    ------
    ValueError
        for fewer than 2 points, non-positive or non-finite x, non-finite y, mismatched lengths
        or all x equal.
    """
    xs = np.asarray(x, dtype=np.float64)
    ys = np.asarray(y, dtype=np.float64)
    if xs.ndim != 1 or xs.shape != ys.shape:
        raise ValueError(f"x and y must be 1-D of equal length; got shapes {xs.shape}, {ys.shape}")
    xs, u, sxx = _log_abscissae(xs)
    a, b = (float(c) for c in log_fit_coefficients(xs, ys))
    residuals = ys - (a * u + b)
    ss_res = float(np.sum(residuals**2))
    ss_tot = float(np.sum((ys - ys.mean()) ** 2))
    r2 = 1.0 - ss_res / ss_tot if ss_tot > 0 else 1.0
    n = xs.size
    if n > 2:
        s = math.sqrt(ss_res / (n - 2))
        a_se = s / math.sqrt(sxx)
        b_se = s * math.sqrt(1 / n + u.mean() ** 2 / sxx)
    else:
        s = a_se = b_se = math.nan
    return LogFit(a=a, b=b, r2=r2, a_stderr=a_se, b_stderr=b_se, n=n,
                  x_min=float(xs.min()), x_max=float(xs.max()), ln_x_mean=float(u.mean()),
                  ln_x_sxx=sxx, residual_std=s)


def per_unit(energies: ArrayLike) -> NDArray[np.float64]:
    """Energies divided by the largest of the group (docs/architecture.md, Spectra).

    A 2-D array is taken row by row (each row a group, e.g. a bootstrap replicate).
    """
    e = np.asarray(energies, dtype=np.float64)
    if (e.size == 0 or e.ndim > 2 or not np.all(np.isfinite(e))
            or np.any(e.max(axis=-1) <= 0)):
        raise ValueError(f"energies must be finite with a positive maximum; got {e.tolist()}")
    pu: NDArray[np.float64] = e / e.max(axis=-1, keepdims=True)
    return pu

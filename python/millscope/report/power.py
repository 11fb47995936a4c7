"""The power comparison: simulated drive power against the empirical mill-power models.

``scripts/power_comparison.py`` writes the table (``data/power/power_comparison.csv``, one row
per case and stiffness); :func:`read_power_table` reads it back and :func:`plot_power_comparison`
draws it in about a second, without re-running anything (docs/power.md).
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pandas as pd
from matplotlib.figure import Figure

__all__ = ["MODELS", "POWER_COLUMNS", "plot_power_comparison", "read_power_table"]

#: The models of the table: column prefix -> label.
MODELS = {"morrell": "Morrell C-model", "hogg_fuerstenau": "Hogg-Fuerstenau (simulated angle)"}

#: The columns the figure needs.
POWER_COLUMNS = ("case", "group", "speed_fraction", "stiffness_factor", "power_W", "power_se_W",
                 *(f"{m}_power_W" for m in MODELS), *(f"{m}_diff_pct" for m in MODELS))

#: Largest table read, bytes: the comparison is a few kB.
MAX_TABLE_BYTES = 10_000_000


def read_power_table(path: str | os.PathLike[str]) -> pd.DataFrame:
    """The comparison table written by ``scripts/power_comparison.py``.

    Parameters
    ----------
    path : str or path-like
        The CSV file.

    Returns
    -------
    pandas.DataFrame
        One row per case and stiffness factor.

    Raises
    ------
    ValueError
        If the file is missing, too large, not CSV, or lacks a column of
        :data:`POWER_COLUMNS` or holds a non-finite value in one.
    """
    source = Path(path)
    if not source.is_file():
        raise ValueError(f"power table {source}: no such file")
    if source.stat().st_size > MAX_TABLE_BYTES:
        raise ValueError(f"power table {source}: larger than {MAX_TABLE_BYTES} bytes; not a "
                         "power comparison")
    try:
        table = pd.read_csv(source)
    except (pd.errors.ParserError, pd.errors.EmptyDataError, UnicodeDecodeError) as exc:
        raise ValueError(f"power table {source}: not a CSV table ({exc})") from None
    missing = [c for c in POWER_COLUMNS if c not in table.columns]
    if missing:
        raise ValueError(f"power table {source}: missing column {', '.join(missing)}")
    numeric = [c for c in POWER_COLUMNS if c not in ("case", "group")]
    values = table[numeric].apply(pd.to_numeric, errors="coerce")
    if not np.all(np.isfinite(values.to_numpy(dtype=float))):
        raise ValueError(f"power table {source}: the columns {', '.join(numeric)} must hold "
                         "finite numbers")
    table[numeric] = values
    return table


def plot_power_comparison(table: pd.DataFrame, stiffness_factor: float | None = None
                          ) -> Figure:
    """Simulated drive power and each model's net power against speed, one panel per
    filling (the table's ``group``), and the models' differences from the simulation in %.
    Rows of the same filling at another stiffness factor show as open circles.

    Parameters
    ----------
    table : pandas.DataFrame
        As :func:`read_power_table` returns it.
    stiffness_factor : float, optional
        Which simulations to draw (the table may hold a stiffness check too); default the
        factor of most rows.

    Returns
    -------
    matplotlib.figure.Figure
    """
    if stiffness_factor is None:
        stiffness_factor = float(table["stiffness_factor"].mode().iloc[0])
    rows = table[np.isclose(table["stiffness_factor"], stiffness_factor)]
    if rows.empty:
        raise ValueError(f"stiffness_factor = {stiffness_factor!r} is not valid; the table "
                         f"holds {sorted(set(table['stiffness_factor']))}")
    others = table[~np.isclose(table["stiffness_factor"], stiffness_factor)]
    groups = rows["group"]
    labels = list(dict.fromkeys(groups))  # in the table's order
    fig = Figure(figsize=(4.2 * len(labels), 6.4), layout="constrained")
    axes = fig.subplots(2, len(labels), sharex=True, squeeze=False)
    markers = {"morrell": "s", "hogg_fuerstenau": "^"}
    for col, label in enumerate(labels):
        part = rows[groups == label].sort_values("speed_fraction")
        pct = 100.0 * part["speed_fraction"]
        top, bottom = axes[0][col], axes[1][col]
        top.errorbar(pct, part["power_W"], yerr=2.0 * part["power_se_W"], fmt="o-", color="k",
                     capsize=3, label="simulated (±2 s.e.)")
        for key, name in MODELS.items():
            top.plot(pct, part[f"{key}_power_W"], markers[key] + "--", label=name)
            bottom.plot(pct, part[f"{key}_diff_pct"], markers[key] + "--", label=name)
        # the same filling simulated at another stiffness (a check), as open circles
        for factor, other in others[others["group"] == label].groupby("stiffness_factor"):
            other = other.sort_values("speed_fraction")
            top.plot(100.0 * other["speed_fraction"], other["power_W"], "o", mfc="none",
                     color="0.4", label=f"simulated, G x {factor:g}")
        bottom.axhline(0.0, color="k", lw=0.8)
        top.set_title(f"{label} (G x {stiffness_factor:g})")
        top.set_ylabel("net power, W")
        bottom.set_ylabel("model - simulated, % of simulated")
        bottom.set_xlabel("speed, % of critical")
        for ax in (top, bottom):
            ax.grid(True, alpha=0.3)
        top.legend(fontsize="small")
    return fig

"""Figures of the paper's section 6. Every function returns a matplotlib Figure.

Figures are built with :class:`matplotlib.figure.Figure` directly, not pyplot, so they hold no
global state, work headless and show in Jupyter when returned as a cell's value. Nothing here
calls ``show()``.
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from numpy.typing import ArrayLike

from ._files import atomic_write
from .fit import LogFit
from .record import TorqueRecord
from .spectral import Spectrum

__all__ = ["plot_torque", "plot_spectrum", "plot_filtered", "plot_waterfall",
           "plot_energy_fit", "plot_energy_fits", "save_figure"]

LineSpec = float | tuple[str, float]


def _axes(ax: Axes | None, size: tuple[float, float] = (8.0, 4.0)) -> tuple[Figure, Axes]:
    if ax is not None:
        fig = ax.get_figure()
        assert isinstance(fig, Figure)
        return fig, ax
    fig = Figure(figsize=size, layout="constrained")
    return fig, fig.add_subplot()


def _without_mean_lobe(spec: Spectrum, fmax_hz: float | None
                       ) -> tuple[np.ndarray, np.ndarray]:
    """Frequencies and amplitudes past the main lobe of the 0 Hz line (the mean torque), which
    would otherwise flatten the plot: Hann leaks the mean into the bins up to 2/TR."""
    lobe_bins = 1 if spec.window == "rectangular" else 2
    keep = spec.freq > lobe_bins * spec.resolution_hz * (1 + 1e-9)
    if fmax_hz is not None:
        keep &= spec.freq <= fmax_hz
    return spec.freq[keep], spec.amplitude[keep]


def plot_torque(record: TorqueRecord, *, ax: Axes | None = None, title: str | None = None
                ) -> Figure:
    """Torque against time with its mean (paper Fig. 2)."""
    fig, ax = _axes(ax)
    ax.plot(record.time_s, record.torque_Nm, lw=0.7, color="tab:blue", label="torque")
    ax.axhline(record.mean_torque_Nm, ls="--", color="k", lw=1,
               label=f"mean {record.mean_torque_Nm:.4g} N m")
    ax.set(xlabel="time (s)", ylabel="torque (N m)", title=title or "Drive torque")
    ax.grid(alpha=0.3)
    ax.legend(loc="upper right")
    return fig


def plot_spectrum(spec: Spectrum, *, lth_hz: float | None = None,
                  lines_hz: Sequence[LineSpec] = (), ax: Axes | None = None,
                  title: str | None = None, fmax_hz: float | None = None,
                  log: bool = False) -> Figure:
    """Amplitude spectrum with the LTH marked (paper Fig. 10).

    The main lobe of the 0 Hz line (the mean torque; up to 2/TR for Hann) is left out, so the
    mean does not flatten the plot; drive-train lines, given as frequencies or (name, frequency)
    pairs in Hz, are marked with dotted lines.
    """
    fig, ax = _axes(ax)
    f, a = _without_mean_lobe(spec, fmax_hz)
    ax.plot(f, a, lw=0.8, color="tab:blue")
    if log:
        ax.set_yscale("log")
    if lth_hz is not None:
        k = int(np.argmin(np.abs(f - lth_hz)))
        peak = float(a[max(k - 2, 0):k + 3].max())
        ax.annotate(f"LTH {lth_hz:.2f} Hz", xy=(lth_hz, peak),
                    xytext=(lth_hz, peak * (3 if log else 1.25)),
                    ha="center", arrowprops={"arrowstyle": "->", "color": "tab:red"},
                    color="tab:red")
        if not log:
            ax.set_ylim(top=max(ax.get_ylim()[1], peak * 1.4))
    for item in lines_hz:
        name, freq = (item if isinstance(item, tuple) else ("", float(item)))
        ax.axvline(freq, ls=":", color="tab:gray", lw=1)
        if name:
            ax.text(freq, 0.98, name, rotation=90, va="top", ha="right", fontsize=8,
                    transform=ax.get_xaxis_transform(), color="tab:gray")
    ax.set(xlabel="frequency (Hz)", ylabel="amplitude (N m)", xlim=(0, f[-1] if f.size else 1),
           title=title or f"Torque spectrum ({spec.window} window, "
                          f"df = {spec.resolution_hz:.3g} Hz)")
    ax.grid(alpha=0.3)
    return fig


def plot_filtered(original: TorqueRecord, filtered: TorqueRecord, *, ax: Axes | None = None,
                  title: str | None = None) -> Figure:
    """The block's fluctuation (mean removed) and the filtered signal over it."""
    if len(original) != len(filtered):
        raise ValueError(f"original has {len(original)} samples but filtered has "
                         f"{len(filtered)}; pass the filtered version of the same block")
    fig, ax = _axes(ax)
    ax.plot(original.time_s, original.torque_Nm - original.mean_torque_Nm, lw=0.7,
            color="tab:gray", label="torque - mean")
    ax.plot(filtered.time_s, filtered.torque_Nm, lw=0.7, color="tab:blue",
            label="mean and lines removed")
    ax.set(xlabel="time (s)", ylabel="torque fluctuation (N m)",
           title=title or "Torque before and after removing the mean and the lines")
    ax.grid(alpha=0.3)
    ax.legend(loc="upper right")
    return fig


def plot_waterfall(spectra: Sequence[Spectrum], labels: Sequence[str], *,
                   fmax_hz: float | None = None, title: str | None = None) -> Figure:
    """3-D waterfall of several spectra in the given order, e.g. rising filling (Figs. 12-13).

    x is frequency (Hz), y the case (labelled), z the amplitude (N m); the main lobe of the 0 Hz
    line (the mean) is left out.
    """
    if len(spectra) != len(labels):
        raise ValueError(f"spectra has {len(spectra)} entries but labels has {len(labels)}; "
                         "give one label per spectrum")
    if not spectra:
        raise ValueError("spectra is empty; give at least one spectrum")
    fig = Figure(figsize=(9.0, 6.0), layout="constrained")
    ax = fig.add_subplot(projection="3d")
    for i, spec in enumerate(spectra):
        f, a = _without_mean_lobe(spec, fmax_hz)
        ax.plot(f, np.full_like(f, i), a, lw=0.7)
    ax.set_yticks(range(len(labels)), labels)
    ax.set_xlabel("frequency (Hz)")
    ax.set_ylabel("case")
    ax.set_zlabel("amplitude (N m)")
    ax.view_init(elev=25, azim=-60)
    ax.set_title(title or "Torque spectra")
    return fig


def _check_pairs(levels: ArrayLike, energies_pu: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    x = np.asarray(levels, dtype=np.float64)
    y = np.asarray(energies_pu, dtype=np.float64)
    if x.shape != y.shape or x.ndim != 1:
        raise ValueError(f"levels has {x.size} values but energies_pu has {y.size}; "
                         "they must pair up")
    return x, y


def plot_energy_fit(levels: ArrayLike, energies_pu: ArrayLike, fit: LogFit | None = None, *,
                    ax: Axes | None = None, label: str | None = None,
                    errors: ArrayLike | None = None, title: str | None = None) -> Figure:
    """Energy per unit against load level with the log fit y = a ln(x) + b (Figs. 14-15).

    ``errors`` are half-widths, or a (2, n) array of lower and upper distances.
    """
    x, y = _check_pairs(levels, energies_pu)
    fig, ax = _axes(ax, (6.5, 4.5))
    line = ax.errorbar(x, y, yerr=None if errors is None else np.asarray(errors), fmt="o",
                       capsize=3, label=label or "energy")
    if fit is not None:
        grid = np.linspace(min(x.min(), fit.x_min), max(x.max(), fit.x_max), 200)
        ax.plot(grid, fit(grid), "-", color=line[0].get_color(),
                label=f"{fit.equation()}, $R^2$ = {fit.r2:.4f}")
    ax.set(xlabel="load level (particle filling / 40 %)", ylabel="energy (per unit)",
           title=title or "Spectral energy against filling")
    ax.grid(alpha=0.3)
    ax.legend()
    return fig


def plot_energy_fits(groups: Mapping[str, tuple[ArrayLike, ArrayLike, LogFit]], *,
                     title: str | None = None) -> Figure:
    """Several groups (material x speed) with their log fits on one axes (Fig. 15)."""
    fig, ax = _axes(None, (7.5, 5.0))
    for name, (levels, energies, fit) in groups.items():
        plot_energy_fit(levels, energies, fit, ax=ax, label=name)
    ax.set_title(title or "Log fits of energy against filling")
    return fig


def save_figure(fig: Figure, path: str | os.PathLike[str], *, dpi: int = 150) -> Path:
    """Write ``fig`` atomically (format from the suffix); creates the parent folder."""
    target = Path(path)
    target.parent.mkdir(parents=True, exist_ok=True)
    with atomic_write(target, "wb") as fh:
        fig.savefig(fh, format=target.suffix.lstrip(".") or "png", dpi=dpi)
    return target

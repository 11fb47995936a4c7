"""Figures of the paper's section 6 (Figs. 2, 9-15) and a cross-section of the charge. Every
function returns a Figure.

Figures are built with :class:`matplotlib.figure.Figure` directly, never through pyplot, so they
hold no global state (nothing to close, nothing leaks), work headless without choosing a backend,
and show in Jupyter when returned as a cell's value. Nothing here calls ``show()``.

Functions that draw on a single axes take ``ax=None``: given an Axes, they draw into it (for
panels of a larger figure, as in Fig. 10 a-g) and return the figure that holds it. Titles and
labels are set only when the function made the figure or when they are passed explicitly.

Units: time in s, frequency in Hz, torque and spectral amplitude in N m; energies are shown per
unit of the group's largest energy (docs/architecture.md, Spectra); lengths in m, speeds in m/s.
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np
from matplotlib.axes import Axes
from matplotlib.collections import EllipseCollection
from matplotlib.colors import Normalize
from matplotlib.container import ErrorbarContainer
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Circle, Polygon
from matplotlib.text import Annotation
from matplotlib.ticker import FuncFormatter, NullFormatter
from matplotlib.transforms import Bbox
from numpy.typing import ArrayLike, NDArray

from .. import _checks
from .._drum_shape import lifter_outlines
from .._files import atomic_write
from ..calibration.fit import LogFit
from ..signal.record import TorqueRecord
from ..signal.spectral import Spectrum

if TYPE_CHECKING:  # the figures stay below the simulation side (docs/architecture.md, Layers)
    from ..campaign.studies import StudyResult
    from ..engine.simulation import Simulation
    from ..engine.snapshots import ChargeSnapshot

__all__ = ["plot_torque", "plot_spectrum", "plot_filtered", "plot_waterfall",
           "plot_spectra_grid", "plot_torque_levels", "plot_lth_levels", "plot_energy_levels",
           "plot_energy_fit", "plot_energy_fits", "plot_accuracy", "plot_charge", "save_figure",
           "torque_change"]


class _NamedLine(Protocol):
    """Anything with a name and a frequency, e.g. :class:`millscope.drivetrain.InterferenceLine`."""

    name: str
    frequency_hz: float


LineSpec = float | tuple[str, float] | _NamedLine


def _grid(ax: Axes) -> None:
    """The light grid every figure uses."""
    ax.grid(True, alpha=0.35, lw=0.6)


_MARKERS = ("o", "s", "^", "D", "v", "P", "X", "<", ">")
_LTH_COLOR = "tab:red"
_LINE_COLOR = "0.45"


# -- helpers -------------------------------------------------------------------------------
def _axes(ax: Axes | None, size: tuple[float, float]) -> tuple[Figure, Axes, bool]:
    """(figure, axes, made): a new constrained-layout figure unless ``ax`` is given."""
    if ax is not None:
        fig: Any = ax.figure
        while not isinstance(fig, Figure):  # an Axes in a SubFigure: return the root figure
            fig = fig.figure
        return fig, ax, False
    fig = Figure(figsize=size, layout="constrained")
    return fig, fig.add_subplot(), True


# Highest bin the mean (a 0 Hz line) leaks into, per window. Hann's coherent-gain-corrected
# spectrum reads the mean at full height in bin 1 as well. The symmetric Hann (eq. 10) is not
# exactly periodic in the block, so bin 2, its main-lobe edge, still holds about 0.7 mean / N
# (1.2 N m for a 265 N m mean over 150 samples; less beyond). Periodic Hann has a null there,
# and the rectangular window leaks a constant into no other bin.
_MEAN_LOBE_BINS = {"hann": 2, "hann_periodic": 1, "rectangular": 0}


def _mean_lobe_hz(spec: Spectrum) -> float:
    """Upper edge of the bins the mean torque leaks into (the 0 Hz line's main lobe), Hz."""
    return _MEAN_LOBE_BINS.get(spec.window, 2) * spec.resolution_hz * (1 + 1e-9)


def _spectrum_part(spec: Spectrum, fmax_hz: float | None
                   ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Frequencies and amplitudes past the mean's main lobe, up to ``fmax_hz``."""
    freq = np.asarray(spec.freq)
    amp = np.asarray(spec.amplitude)
    if freq.shape != amp.shape or freq.ndim != 1:
        raise ValueError(f"spec.freq has shape {freq.shape} but spec.amplitude has {amp.shape}; "
                         "they must be 1-D of equal length")
    keep = freq > _mean_lobe_hz(spec)  # the 0 Hz bin always goes
    if fmax_hz is not None:
        if not (np.isfinite(fmax_hz) and fmax_hz > 0):
            raise ValueError(f"fmax_hz = {fmax_hz!r} is not valid; it must be > 0 Hz")
        keep &= freq <= fmax_hz
    if not np.any(keep):
        raise ValueError(f"the spectrum has no bins between its mean's main lobe "
                         f"({_mean_lobe_hz(spec):.3g} Hz) and fmax_hz = {fmax_hz!r}")
    return freq[keep], amp[keep]


def _line(item: LineSpec) -> tuple[str, float]:
    if isinstance(item, tuple):
        name, freq = item
        return str(name), float(freq)
    if hasattr(item, "frequency_hz"):
        return str(getattr(item, "name", "")), float(item.frequency_hz)
    return "", float(item)


def _set_title(ax: Axes, title: str | None, default: str, made: bool) -> None:
    if title is not None:
        ax.set_title(title)
    elif made:
        ax.set_title(default)


# -- time domain -----------------------------------------------------------------------------
def plot_torque(record: TorqueRecord, *, ax: Axes | None = None, title: str | None = None,
                color: str = "tab:blue", linewidth: float = 0.7, show_mean: bool = True
                ) -> Figure:
    """Drive torque against time, with its mean as a dashed line (paper Fig. 2).

    Parameters
    ----------
    record : TorqueRecord
        Torque (N m) against time (s).
    ax : Axes, optional
        Draw here instead of in a new figure.
    title : str, optional
        Axes title; default "Drive torque" on a new figure.
    color, linewidth
        Style of the torque trace.
    show_mean : bool
        Draw the mean torque T_c as a dashed horizontal line, labelled with its value.

    Returns
    -------
    Figure
        The figure holding the axes: ``ax.lines[0]`` is the torque, ``ax.lines[1]`` the mean.
    """
    fig, ax, made = _axes(ax, (8.0, 3.8))
    ax.plot(record.time_s, record.torque_Nm, lw=linewidth, color=color, label="torque")
    if show_mean:
        ax.axhline(record.mean_torque_Nm, ls="--", color="k", lw=1.1,
                   label=f"mean $T_c$ = {record.mean_torque_Nm:.4g} N m")
    ax.set_xlabel("time (s)")
    ax.set_ylabel("torque (N m)")
    ax.set_xlim(record.time_s[0], record.time_s[-1])
    _set_title(ax, title, "Drive torque", made)
    _grid(ax)
    ax.legend(loc="upper right", fontsize="small")
    return fig


def plot_filtered(original: TorqueRecord, filtered: TorqueRecord, *, ax: Axes | None = None,
                  title: str | None = None) -> Figure:
    """The filtered block over the original's fluctuation (paper section 6.4, Fig. 3).

    The original is drawn with its mean subtracted (T - T_c, grey) so both traces share one
    scale; the filtered record (mean and lines removed, e.g. by :func:`~millscope.band_stop`)
    is drawn over it.

    Parameters
    ----------
    original : TorqueRecord
        The block before filtering, N m.
    filtered : TorqueRecord
        The same block after removal, N m; same sample times.
    ax : Axes, optional
        Draw here instead of in a new figure.
    title : str, optional
        Axes title.

    Returns
    -------
    Figure
        ``ax.lines[0]`` is the fluctuation, ``ax.lines[1]`` the filtered signal.

    Raises
    ------
    ValueError
        if the two records do not have the same sample times.
    """
    if len(original) != len(filtered):
        raise ValueError(f"original has {len(original)} samples but filtered has "
                         f"{len(filtered)}; pass the filtered version of the same block")
    if not np.allclose(original.time_s, filtered.time_s, rtol=0, atol=1e-6 * original.dt):
        raise ValueError("original and filtered have different sample times; pass the filtered "
                         "version of the same block")
    fig, ax, made = _axes(ax, (8.0, 3.8))
    ax.plot(original.time_s, original.torque_Nm - original.mean_torque_Nm, lw=0.7,
            color="0.6", label="torque - mean")
    ax.plot(filtered.time_s, filtered.torque_Nm, lw=0.7, color="tab:blue",
            label="mean and lines removed")
    ax.axhline(0.0, color="k", lw=0.6)
    ax.set_xlabel("time (s)")
    ax.set_ylabel("torque fluctuation (N m)")
    ax.set_xlim(original.time_s[0], original.time_s[-1])
    _set_title(ax, title, "Torque before and after removing the mean and the lines", made)
    _grid(ax)
    ax.legend(loc="upper right", fontsize="small")
    return fig


# -- spectra ---------------------------------------------------------------------------------
def plot_spectrum(spec: Spectrum, *, lth_hz: float | None = None, lth_distinct: bool = True,
                  lines_hz: Sequence[LineSpec] = (), ax: Axes | None = None,
                  title: str | None = None, fmax_hz: float | None = None, log: bool = False,
                  color: str = "tab:blue", linewidth: float = 0.8, label: str | None = None
                  ) -> Figure:
    """Single-sided amplitude spectrum with the LTH marked by an arrow (paper Fig. 10).

    The 0 Hz bin, and with a Hann window the rest of the mean's main lobe, are left out of the
    trace and so of the autoscale: the mean torque, hundreds of N m, would otherwise flatten
    the plot. With Hann the coherent-gain-corrected spectrum reads the mean at full height in
    bin 1 (1/TR) too, so dropping 0 Hz alone is not enough. Left out: 0 .. 2/TR for ``"hann"``,
    0 .. 1/TR for ``"hann_periodic"``, only 0 Hz for ``"rectangular"``; these bins lie inside
    the band ``remove=["mean"]`` discards anyway.

    Parameters
    ----------
    spec : Spectrum
        From :func:`millscope.spectrum`; amplitude in N m.
    lth_hz : float, optional
        Frequency of the lifter torque harmonic, Hz (n_lifters x rotation frequency, or the
        located peak); marked with an arrow to the largest amplitude within +-2 bins.
    lth_distinct : bool
        Whether the located LTH stands out of the noise (:attr:`millscope.Peak.distinct`);
        when False the arrow is grey and its text says "LTH? ... not above the noise", so that
        a noise peak is not labelled as the harmonic.
    lines_hz : sequence, optional
        Drive-train lines to mark with dotted vertical lines: frequencies in Hz, ``(name, hz)``
        pairs, or objects with ``name`` and ``frequency_hz`` (drive-train ``InterferenceLine``).
        Lines outside the plotted range are skipped.
    ax : Axes, optional
        Draw here instead of in a new figure.
    title : str, optional
        Axes title; default names the window and resolution on a new figure.
    fmax_hz : float, optional
        Highest frequency shown, Hz; default the Nyquist frequency.
    log : bool
        Logarithmic amplitude axis.
    color, linewidth, label
        Style and legend label of the spectrum trace.

    Returns
    -------
    Figure
        ``ax.lines[0]`` is the spectrum; the LTH arrow is the annotation in ``ax.texts`` whose
        text starts with "LTH"; drive-train lines follow in ``ax.lines``.

    Raises
    ------
    ValueError
        for an LTH outside the plotted frequency range, or a bad ``fmax_hz``.
    """
    f, a = _spectrum_part(spec, fmax_hz)
    fig, ax, made = _axes(ax, (8.0, 4.0))
    ax.plot(f, a, lw=linewidth, color=color, label=label)
    f_hi = float(f[-1])
    if log:
        ax.set_yscale("log")
    else:
        ax.set_ylim(bottom=0.0)
    if lth_hz is not None:
        if not float(f[0]) - spec.resolution_hz <= lth_hz <= f_hi + spec.resolution_hz:
            raise ValueError(f"lth_hz = {lth_hz!r} Hz lies outside the plotted range "
                             f"{f[0]:.3g} .. {f_hi:.3g} Hz")
        k = int(np.argmin(np.abs(f - lth_hz)))
        peak = float(a[max(k - 2, 0):k + 3].max())
        # room above the peak for the arrow and its text, in data units so that it also fits
        # small panels (a fixed offset in points would run into the title)
        if log:
            ax.set_ylim(top=max(ax.get_ylim()[1], peak * 6.0))
            text_y = peak * 2.2
        else:
            ax.set_ylim(top=max(ax.get_ylim()[1], peak * 1.45))
            text_y = peak * 1.2
        text, mark = ((f"LTH {lth_hz:.2f} Hz", _LTH_COLOR) if lth_distinct else
                      (f"LTH? {lth_hz:.2f} Hz\nnot above the noise", _LINE_COLOR))
        ax.annotate(text, xy=(lth_hz, peak), xytext=(lth_hz, text_y),
                    ha="center", va="bottom", color=mark, fontsize="small",
                    arrowprops={"arrowstyle": "-|>", "color": mark, "lw": 1.2,
                                "shrinkA": 0, "shrinkB": 1})
    for item in lines_hz:
        name, freq = _line(item)
        if not 0 < freq <= f_hi:
            continue
        ax.axvline(freq, ls=":", color=_LINE_COLOR, lw=1.0)
        if name:
            ax.text(freq, 0.97, f" {name}", rotation=90, va="top",
                    ha="left" if freq < 0.5 * f_hi else "right",
                    fontsize="x-small", color=_LINE_COLOR, transform=ax.get_xaxis_transform())
    ax.set_xlim(0.0, f_hi)
    ax.set_xlabel("frequency (Hz)")
    ax.set_ylabel("amplitude (N m)")
    _set_title(ax, title, f"Torque spectrum ({spec.window} window, "
                          f"df = {spec.resolution_hz:.3g} Hz)", made)
    _grid(ax)
    if label is not None:
        ax.legend(fontsize="small")
    return fig


def plot_waterfall(spectra: Sequence[Spectrum], labels: Sequence[str], *,
                   fmax_hz: float | None = None, title: str | None = None,
                   ylabel: str = "filling level", cmap: str = "viridis",
                   elev: float = 28.0, azim: float = -62.0) -> Figure:
    """3-D waterfall of several spectra, one behind the other (paper Figs. 12-13).

    Give the spectra in the order to show them, e.g. increasing filling level: x is frequency
    (Hz), y the position in that order with ``labels`` as tick labels, z the amplitude (N m).
    As in :func:`plot_spectrum`, each spectrum's 0 Hz bin and mean lobe are left out.

    Parameters
    ----------
    spectra : sequence of Spectrum
        The spectra, front to back.
    labels : sequence of str
        One label per spectrum (e.g. "HDMS1" ... or "#1" ...).
    fmax_hz : float, optional
        Highest frequency shown, Hz.
    title : str, optional
        Figure title.
    ylabel : str
        Label of the case axis.
    cmap : str
        Colormap the traces are coloured from, front to back.
    elev, azim : float
        Viewing angles, degrees.

    Returns
    -------
    Figure
        One 3-D axes with one line per spectrum (``ax.lines``, in the given order).

    Raises
    ------
    ValueError
        if ``spectra`` and ``labels`` differ in length, or are empty.
    """
    from matplotlib import colormaps

    if len(spectra) != len(labels):
        raise ValueError(f"spectra has {len(spectra)} entries but labels has {len(labels)}; "
                         "give one label per spectrum")
    if not spectra:
        raise ValueError("spectra is empty; give at least one spectrum")
    # a 3-D axes is square-ish and constrained layout leaves wide margins; fill the figure
    fig = Figure(figsize=(9.0, 6.0))
    fig.subplots_adjust(left=0.0, right=0.97, bottom=0.0, top=1.0)
    ax = fig.add_subplot(projection="3d")
    colours = colormaps[cmap](np.linspace(0.0, 0.85, len(spectra)))
    f_hi = 0.0
    for i, spec in enumerate(spectra):
        f, a = _spectrum_part(spec, fmax_hz)
        ax.plot(f, np.full_like(f, i), a, lw=0.8, color=colours[i])
        f_hi = max(f_hi, float(f[-1]))
    ax.set_xlim(0.0, f_hi)
    ax.set_ylim(-0.5, len(spectra) - 0.5)
    ax.set_zlim(bottom=0.0)
    ax.set_yticks(range(len(labels)), [str(s) for s in labels])
    ax.set_xlabel("frequency (Hz)")
    ax.set_ylabel(ylabel, labelpad=22)
    ax.set_zlabel("amplitude (N m)", labelpad=8)
    ax.view_init(elev=elev, azim=azim)
    ax.set_box_aspect((1.7, 1.2, 0.75), zoom=1.1)
    fig.suptitle(title or "Torque spectra", y=0.96)
    return fig


def plot_spectra_grid(spectra: Sequence[Spectrum], labels: Sequence[str], *,
                      lth_hz: Sequence[float | None] | None = None,
                      lth_distinct: Sequence[bool] | None = None, fmax_hz: float | None = None,
                      ncols: int = 2, same_scale: bool = True, title: str | None = None
                      ) -> Figure:
    """Several spectra in a grid of panels a), b), ... with the LTH marked (paper Fig. 10).

    Each panel is :func:`plot_spectrum` of one spectrum (a shared frequency axis), titled with
    its letter and label, e.g. "a) HDMS1". With ``same_scale`` every panel gets the amplitude
    range of the tallest, so that the noise falling with the filling shows (paper section 6.3).

    Parameters
    ----------
    spectra : sequence of Spectrum
        Amplitude in N m, in panel order (e.g. rising filling level).
    labels : sequence of str
        One label per spectrum.
    lth_hz : sequence of float or None, optional
        Per spectrum, the LTH to mark, Hz (None: no arrow in that panel).
    lth_distinct : sequence of bool, optional
        Per spectrum, whether its LTH stands out of the noise (see :func:`plot_spectrum`);
        default all True.
    fmax_hz : float, optional
        Highest frequency shown, Hz.
    ncols : int
        Panels per row, >= 1.
    same_scale : bool
        One amplitude range for all panels (else each its own).
    title : str, optional
        Figure title.

    Returns
    -------
    Figure
        One axes per spectrum, in order (``fig.axes``).

    Raises
    ------
    ValueError
        if ``spectra``, ``labels`` and ``lth_hz`` differ in length or are empty, or for a bad
        ``ncols``.
    """
    n = len(spectra)
    if n == 0:
        raise ValueError("spectra is empty; give at least one spectrum")
    marks = [None] * n if lth_hz is None else list(lth_hz)
    distinct = [True] * n if lth_distinct is None else list(lth_distinct)
    if len(labels) != n or len(marks) != n or len(distinct) != n:
        raise ValueError(f"spectra has {n} entries, labels {len(labels)}, lth_hz "
                         f"{len(marks)} and lth_distinct {len(distinct)}; give one label and "
                         "one LTH (or None) per spectrum")
    if not isinstance(ncols, int) or isinstance(ncols, bool) or ncols < 1:
        raise ValueError(f"ncols = {ncols!r} is not valid; it must be an integer >= 1")
    cols = min(ncols, n)
    rows = -(-n // cols)
    fig = Figure(figsize=(4.6 * cols, 2.7 * rows + 0.4), layout="constrained")
    axes = fig.subplots(rows, cols, sharex=True, squeeze=False).ravel()
    letters = "abcdefghijklmnopqrstuvwxyz"
    for i, (spec, label, mark, clear) in enumerate(zip(spectra, labels, marks, distinct,
                                                         strict=True)):
        prefix = f"{letters[i]}) " if i < len(letters) else ""
        plot_spectrum(spec, lth_hz=mark, lth_distinct=clear, ax=axes[i], fmax_hz=fmax_hz,
                      title=f"{prefix}{label}")
        if i % cols:
            axes[i].set_ylabel("")
        if i < n - cols:
            axes[i].set_xlabel("")
        else:  # the lowest panel of its column: its frequency ticks are the column's
            axes[i].xaxis.set_tick_params(labelbottom=True)
    if same_scale:
        top = max(ax.get_ylim()[1] for ax in axes[:n])
        for ax in axes[:n]:
            ax.set_ylim(0.0, top)
    for ax in axes[n:]:
        fig.delaxes(ax)
    fig.suptitle(title or "Torque spectra with the LTH marked")
    return fig


# -- energy against filling ------------------------------------------------------------------
GroupSeries = tuple[ArrayLike, ArrayLike] | tuple[ArrayLike, ArrayLike, ArrayLike | None]


def _plot_against_level(groups: Mapping[str, GroupSeries], *, ylabel: str, title: str,
                        ax: Axes | None, intervals: bool) -> Figure:
    """One line of markers per group, a quantity against load level; with ``intervals``, the
    third item of a group's entry is a (2, n) array of absolute (low, high) bounds drawn as
    error bars (None: no bars)."""
    if not groups:
        raise ValueError("groups is empty; give at least one group")
    fig, ax, made = _axes(ax, (6.5, 4.5))
    for i, (name, entry) in enumerate(groups.items()):
        if not isinstance(entry, tuple) or len(entry) not in (2, 3):
            raise ValueError(f"groups[{name!r}] must be (levels, values) or "
                             "(levels, values, bounds)")
        try:
            x, y = _check_pairs(entry[0], entry[1])
        except ValueError as exc:
            raise ValueError(f"groups[{name!r}]: {exc}") from None
        yerr = None
        bounds = entry[2] if len(entry) == 3 else None
        if bounds is not None:
            if not intervals:
                raise ValueError(f"groups[{name!r}] has bounds, which this figure does not draw")
            b = np.asarray(bounds, dtype=np.float64)
            if b.shape != (2, x.size):
                raise ValueError(f"groups[{name!r}]: bounds has shape {b.shape}; give a "
                                 f"(2, {x.size}) array of low and high values")
            if np.all(np.isfinite(b)):
                # a percentile interval need not hold its estimate: clip the bar at the point
                yerr = np.clip(np.vstack([y - b[0], b[1] - y]), 0.0, None)
        order = np.argsort(x)
        ax.errorbar(x[order], y[order], yerr=None if yerr is None else yerr[:, order],
                    fmt="-", marker=_MARKERS[i % len(_MARKERS)], ms=6, lw=1.1, capsize=3,
                    label=name)
    ax.set_xlabel("load level x (particle filling in units of 40 %)")
    ax.set_ylabel(ylabel)
    _set_title(ax, title, title, made)
    _grid(ax)
    ax.legend(fontsize="small")
    return fig


#: Default lower edge of Fig. 9's y axis, per unit: the mean torque changes by well under 1 %
#: over the load levels, and an autoscaled axis would blow that up to fill the figure.
TORQUE_PU_FLOOR = 0.9


#: The paper's Fig. 9: the mean torque changes by less than this fraction over the load levels
#: of a group.
PAPER_TORQUE_CHANGE = 0.09


def torque_change(torque_pu: ArrayLike) -> float:
    """The largest change of the mean torque within a group, (max - min) / max of its values
    per level (dimensionless; the paper's Fig. 9 stays under :data:`PAPER_TORQUE_CHANGE`);
    nan when a value is not finite or none is positive."""
    y = np.asarray(torque_pu, dtype=np.float64)
    if y.size == 0 or not np.all(np.isfinite(y)) or not np.max(y) > 0:
        return math.nan
    return float((np.max(y) - np.min(y)) / np.max(y))


def plot_torque_levels(groups: Mapping[str, tuple[ArrayLike, ArrayLike]], *,
                       ax: Axes | None = None, title: str | None = None,
                       floor: float | None = TORQUE_PU_FLOOR) -> Figure:
    """Mean torque per unit of each group's largest against load level (paper Fig. 9).

    The paper's point is that the mean torque barely changes with filling, so the y axis is
    not autoscaled: it runs from ``floor`` (0.9 per unit by default, lower if a value is) to
    just above 1 (or the largest value), so a change of 0.4 % looks like one. The largest
    change within a group, (max - min) / max, is written in the legend's title.

    Parameters
    ----------
    groups : mapping of str to (levels, torque_pu)
        Per group (e.g. "HDMS"): load levels and mean torques per unit (dimensionless).
    ax : Axes, optional
        Draw here instead of in a new figure.
    title : str, optional
    floor : float or None
        Lower edge of the y axis, per unit, in (0, 1); None: autoscale (zoomed in on the
        variation).

    Returns
    -------
    Figure
        One errorbar container per group (``ax.containers``), labelled with its name.
    """
    if floor is not None and not (isinstance(floor, (int, float)) and 0 < floor < 1):
        raise ValueError(f"floor = {floor!r} is not valid; it must be in (0, 1) per unit, "
                         "or None to autoscale")
    fig = _plot_against_level(groups, ylabel="mean torque (per unit)",
                              title=title or "Average torque against filling level", ax=ax,
                              intervals=False)
    axes = ax if ax is not None else fig.axes[0]
    changes = {name: torque_change(values) for name, (_, values) in groups.items()}
    changes = {name: change for name, change in changes.items() if math.isfinite(change)}
    if changes:
        name = max(changes, key=lambda k: changes[k])
        axes.legend(fontsize="small", title_fontsize="small",
                    title=f"largest change within a group: {100 * changes[name]:.2g} % "
                          f"({name})")
    if floor is not None:
        finite = np.concatenate([np.asarray(v, dtype=np.float64) for _, v in groups.values()])
        finite = finite[np.isfinite(finite)]
        low = min(floor, float(finite.min())) if finite.size else floor
        high = max(1.0, float(finite.max())) if finite.size else 1.0
        pad = 0.02 * (high - low)
        axes.set_ylim(low - pad, high + pad)
    return fig


def plot_lth_levels(groups: Mapping[str, tuple[ArrayLike, ...]], *,
                    ax: Axes | None = None, title: str | None = None) -> Figure:
    """Amplitude of the lifter torque harmonic against load level (paper Fig. 11).

    A level whose LTH does not stand out of the noise (:attr:`millscope.Peak.distinct`) gets
    an open marker: what was located there is a noise peak, and its amplitude says little
    about the lifters.

    Parameters
    ----------
    groups : mapping of str to (levels, amplitude) or (levels, amplitude, distinct)
        Per group: load levels, LTH amplitudes, N m, and optionally per level whether the LTH
        stands out of the noise (bools; left out: all do).
    ax : Axes, optional
    title : str, optional

    Returns
    -------
    Figure
        One errorbar container per group; the open markers are one more line per group
        that has them, labelled ``"_"`` + the group's name.

    Raises
    ------
    ValueError
        for an empty mapping, or levels, values and ``distinct`` that do not pair up.
    """
    masks: dict[str, NDArray[np.bool_]] = {}
    for name, entry in groups.items():
        if isinstance(entry, tuple) and len(entry) == 3:
            mask = np.asarray(entry[2])
            if mask.dtype != np.bool_ or mask.shape != np.shape(entry[0]):
                raise ValueError(f"groups[{name!r}]: distinct must be one bool per level "
                                 f"({np.size(entry[0])}), not {entry[2]!r}")
            masks[name] = ~mask
    fig = _plot_against_level({name: (entry[0], entry[1]) for name, entry in groups.items()},
                              ylabel="LTH amplitude (N m)",
                              title=title or "Lifter torque harmonic against filling level",
                              ax=ax, intervals=False)
    axes = ax if ax is not None else fig.axes[0]
    lines = {c.get_label(): c.lines[0] for c in axes.containers
             if isinstance(c, ErrorbarContainer)}
    for name, noise in masks.items():
        if not noise.any():
            continue
        x = np.asarray(groups[name][0], dtype=np.float64)[noise]
        y = np.asarray(groups[name][1], dtype=np.float64)[noise]
        axes.plot(x, y, linestyle="none", marker=lines[name].get_marker(), ms=6, mfc="white",
                  mec=lines[name].get_color(), zorder=3, label=f"_{name}")
    if any(noise.any() for noise in masks.values()):
        handles, labels = axes.get_legend_handles_labels()
        handles.append(Line2D([], [], linestyle="none", marker="o", ms=6, mfc="white",
                              mec=_LINE_COLOR))
        labels.append("open: not above the noise")
        axes.legend(handles, labels, fontsize="small")
    return fig


def plot_energy_levels(groups: Mapping[str, GroupSeries], *, ax: Axes | None = None,
                       title: str | None = None) -> Figure:
    """Spectral energy per unit of each group's largest against load level (paper Fig. 14).

    Parameters
    ----------
    groups : mapping of str to (levels, energy_pu) or (levels, energy_pu, bounds)
        Per group: load levels, per-unit energies and optionally their interval as a (2, n)
        array of (low, high) values (e.g. ``GroupAnalysis.energy_pu_interval``), drawn as error
        bars; all-nan bounds draw none.
    ax : Axes, optional
    title : str, optional

    Returns
    -------
    Figure
        One errorbar container per group.

    Raises
    ------
    ValueError
        for an empty mapping, levels and values that do not pair up, or bounds of the wrong
        shape (the message names the group).
    """
    return _plot_against_level(groups, ylabel="spectral energy (per unit)",
                               title=title or "Spectrum energy against filling level", ax=ax,
                               intervals=True)


def _check_pairs(levels: ArrayLike, energies_pu: ArrayLike
                 ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    x = np.asarray(levels, dtype=np.float64)
    y = np.asarray(energies_pu, dtype=np.float64)
    if x.ndim != 1 or y.ndim != 1 or x.shape != y.shape:
        raise ValueError(f"levels has {x.size} values but energies_pu has {y.size}; "
                         "they must be 1-D and pair up")
    if x.size == 0:
        raise ValueError("levels and energies_pu are empty; give at least one point")
    return x, y


def _check_errors(errors: ArrayLike | None, n: int) -> NDArray[np.float64] | None:
    if errors is None:
        return None
    e = np.asarray(errors, dtype=np.float64)
    if e.ndim == 0:
        e = np.full(n, float(e))
    if e.shape not in ((n,), (2, n)):
        raise ValueError(f"errors has shape {e.shape}; give {n} half-widths or a (2, {n}) "
                         "array of lower and upper distances, one per level")
    if not np.all(np.isfinite(e)) or np.any(e < 0):
        raise ValueError("errors must be finite and >= 0 (distances from each point)")
    return e


def plot_energy_fit(levels: ArrayLike, energies_pu: ArrayLike, fit: LogFit | None = None, *,
                    ax: Axes | None = None, label: str | None = None,
                    errors: ArrayLike | None = None, title: str | None = None,
                    color: str | None = None, marker: str = "o",
                    xlabel: str = "load level x (particle filling in units of 40 %)",
                    ylabel: str = "spectral energy (per unit)") -> Figure:
    """Per-unit spectral energy against load level, with the log fit (paper Figs. 14-15).

    Parameters
    ----------
    levels : array_like
        Load levels x (1..7 in the paper).
    energies_pu : array_like
        Energies per unit of the group's largest (dimensionless).
    fit : LogFit, optional
        y = a ln(x) + b, drawn as a curve over the levels' range; its equation and R^2 go into
        the legend.
    ax : Axes, optional
        Draw here instead of in a new figure (several groups on one axes: Fig. 15).
    label : str, optional
        Name of the group in the legend (e.g. "HDMS").
    errors : array_like, optional
        Error bars: a scalar or n half-widths, or a (2, n) array of lower and upper distances.
    title : str, optional
        Axes title.
    color, marker
        Colour (default: the axes' next colour) and marker of the points; the curve shares
        the colour.
    xlabel, ylabel : str
        Axis labels.

    Returns
    -------
    Figure
        The points are an errorbar container (``ax.containers``); the fit curve is the line in
        ``ax.lines`` labelled ``"_fit <label>"``, followed by an empty line that is its legend
        entry (marker over line).

    Raises
    ------
    ValueError
        if ``levels`` and ``energies_pu`` differ in length, or ``errors`` has the wrong shape.
    """
    x, y = _check_pairs(levels, energies_pu)
    yerr = _check_errors(errors, x.size)
    fig, ax, made = _axes(ax, (6.5, 4.5))
    points = ax.errorbar(x, y, yerr=yerr, fmt=marker, ms=6, capsize=3, color=color,
                         label=(label or "energy") if fit is None else "_nolegend_")
    colour = points[0].get_color()
    if fit is not None:
        lo, hi = min(float(x.min()), fit.x_min), max(float(x.max()), fit.x_max)
        grid = np.linspace(lo, hi, 200)
        ax.plot(grid, fit(grid), "-", lw=1.4, color=colour, label=f"_fit {label or ''}")
        # one legend entry per group, marker over line, naming the group and its fit
        name = f"{label}: " if label else ""
        ax.plot([], [], "-", marker=marker, ms=6, lw=1.4, color=colour,
                label=f"{name}{fit.equation()}, $R^2$ = {fit.r2:.4f}")
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    _set_title(ax, title, "Spectral energy against filling level", made)
    _grid(ax)
    ax.legend(fontsize="small")
    return fig


def plot_energy_fits(groups: Mapping[str, tuple[ArrayLike, ArrayLike, LogFit | None]], *,
                     title: str | None = None) -> Figure:
    """Several groups (material x speed, e.g. the paper's HDLS ... LDHS) with their log fits on
    one axes (paper Fig. 15).

    Parameters
    ----------
    groups : mapping of str to (levels, energies_pu, fit)
        Per group: load levels, per-unit energies and its :class:`LogFit` (or None).
    title : str, optional
        Axes title.

    Returns
    -------
    Figure
        One axes; per group one set of points and one fit curve, with distinct colours and
        markers, and a legend holding each group's equation and R^2.

    Raises
    ------
    ValueError
        for an empty mapping, or a group whose levels and energies do not pair up (the message
        names the group).
    """
    if not groups:
        raise ValueError("groups is empty; give at least one group")
    fig, ax, _ = _axes(None, (7.5, 5.0))
    for i, (name, entry) in enumerate(groups.items()):
        try:
            levels, energies, fit = entry
        except (TypeError, ValueError):
            raise ValueError(f"groups[{name!r}] must be (levels, energies_pu, fit)") from None
        try:
            plot_energy_fit(levels, energies, fit, ax=ax, label=name,
                            marker=_MARKERS[i % len(_MARKERS)])
        except ValueError as exc:
            raise ValueError(f"groups[{name!r}]: {exc}") from None
    ax.set_title(title or "Log fits of spectral energy against filling level")
    ax.legend(fontsize="small")
    return fig


# -- error against run time (millscope.studies) ---------------------------------------------
_QUANTITY_NAMES = {"mean_torque": "mean torque", "energy": "spectral energy",
                   "lth_amplitude": "LTH amplitude", "slope_a": "log-fit slope a",
                   "energy_ratio": "per-unit energy E(last level) / E(first)"}
_COST_NAMES = {"wall_s": "wall-clock time per run (s)", "particle_steps": "particle-steps per run"}


_KNOB_FORMATS = {"dt_fraction": "dt {} T_R", "shear_modulus_factor": "G x{}",
                 "record_s": "block {} s", "warm_up_s": "warm-up {} s", "sampling": "{} samples",
                 "scale": "{} scale"}


def _knob_changes(setting: Any, reference: Any) -> str:
    """What a setting changes from the reference, e.g. ``"dt 0.4 T_R, block 2 s"``."""
    ref, own = reference.to_dict(), setting.to_dict()
    changed = [_KNOB_FORMATS.get(k, k + " {}").format(
        "of scale" if v is None else format(v, "g") if isinstance(v, float) else v)
        for k, v in own.items() if v != ref[k]]
    return ", ".join(changed) or "reference"


def _labels_apart(labels: Sequence[Annotation]) -> None:
    """Moves each annotation up, in turn, until its box overlaps none of those before it
    (points whose costs and errors nearly coincide would otherwise print their labels over
    each other)."""
    placed: list[Bbox] = []
    for label in labels:
        box = label.get_window_extent()  # in display units, by the figure's renderer
        while any(box.overlaps(other) for other in placed):
            dx, dy = label.xyann
            label.xyann = (dx, dy + 0.8 * float(label.get_fontsize()))  # points: a line
            box = label.get_window_extent()
        placed.append(box)


def plot_accuracy(result: StudyResult, quantity: str = "energy", *, cost: str = "wall_s",
                  ax: Axes | None = None, title: str | None = None,
                  annotate: bool = True) -> Figure:
    """Error against run time of a study (:class:`millscope.studies.StudyResult`), with the
    Pareto front.

    One point per setting: x its cost (summed over the load levels), y the |relative error| of
    its seed mean against the reference's, in % (the largest over the load levels). The bars
    reach 2 standard errors of that error either way (the seed noise of both means; clipped at
    0): an error whose bar does not reach 0 is a bias, not noise. The settings on the Pareto
    front (none cheaper and more accurate) are joined by a step line and ringed; the reference
    is drawn as a star.

    Parameters
    ----------
    result : StudyResult
    quantity : {"mean_torque", "energy", "lth_amplitude", "slope_a", "energy_ratio"}
    cost : {"wall_s", "particle_steps"}
        The x axis (log scale).
    ax : Axes, optional
        Draw here instead of in a new figure.
    title : str, optional
        Axes title.
    annotate : bool
        Write next to each point what it changes from the reference.

    Returns
    -------
    Figure
    """
    points = [p for p in result.summary(quantity, cost) if np.isfinite(p.error)]
    if not points:
        raise ValueError(f"quantity = {quantity!r} has no error in this study (the slope a "
                         "needs 2 or more load levels)")
    front = set(result.pareto(quantity, cost))
    fig, ax, made = _axes(ax, (7.5, 5.0))
    x = np.array([p.cost for p in points])
    y = 100.0 * np.array([p.error for p in points])
    se = 100.0 * 2.0 * np.nan_to_num(np.array([p.error_se for p in points]))
    ax.errorbar(x, y, yerr=np.vstack([np.minimum(se, y), se]), fmt="o", ms=5, capsize=3,
                color="tab:blue", label="setting (bars: 2 standard errors)")
    on_front = sorted((p for p in points if p.setting in front), key=lambda p: p.cost)
    if on_front:
        ax.step([p.cost for p in on_front], [100.0 * p.error for p in on_front], where="post",
                color="tab:red", lw=1.2, label="Pareto front")
        ax.plot([p.cost for p in on_front], [100.0 * p.error for p in on_front], "o", ms=11,
                mfc="none", mec="tab:red", mew=1.4, label="_nolegend_")
    ref = next((p for p in points if p.reference), None)
    if ref is not None:
        ax.plot([ref.cost], [0.0], "*", ms=14, color="tab:orange", label="reference")
    ax.set_xscale("log")
    plain = FuncFormatter(lambda value, _: f"{value:g}")
    ax.xaxis.set_major_formatter(plain)
    # within about a decade the log axis has no major tick: label the minor ones plainly
    ax.xaxis.set_minor_formatter(plain if x.max() < 30.0 * x.min() else NullFormatter())
    ax.set_ylim(bottom=0.0)
    reference = result.reference
    labels = [ax.annotate(_knob_changes(p.setting, reference), (p.cost, 100.0 * p.error),
                          xytext=(5, 4), textcoords="offset points", fontsize="x-small")
              for p in sorted(points, key=lambda p: (p.error, p.cost))] if annotate else []
    ax.set_xlabel(_COST_NAMES.get(cost, cost))
    ax.set_ylabel(f"|error| of the {_QUANTITY_NAMES.get(quantity, quantity)} (%)")
    _set_title(ax, title, f"Error against run time: {_QUANTITY_NAMES.get(quantity, quantity)}",
               made)
    _grid(ax)
    ax.legend(fontsize="small")
    if labels:  # where the points land once the figure is laid out, as it will be drawn
        fig.draw_without_rendering()
        _labels_apart(labels)
    return fig


# -- the charge ------------------------------------------------------------------------------
def charge_slab(snap: ChargeSnapshot, z_range: tuple[float, float] | None = None
                ) -> NDArray[np.bool_]:
    """Which particles :func:`plot_charge` draws: those whose centre z lies in ``z_range``
    (m, both ends included); by default within one largest sphere diameter of mid-length
    (the whole charge of a slice up to two diameters long, such as the "small" and "tiny"
    scales)."""
    z = np.asarray(snap.positions)[:, 2]
    if z_range is None:
        half, mid = snap.scene.max_diameter, 0.5 * snap.scene.drum.length
        return np.asarray(np.abs(z - mid) <= half)
    if not (isinstance(z_range, tuple) and len(z_range) == 2):
        raise _checks.fail("z_range", z_range, "None or a pair (z_low, z_high) in m")
    low = _checks.real("z_range[0]", z_range[0], "m", "")
    high = _checks.real("z_range[1]", z_range[1], "m", f"> z_range[0] = {low:g} m")
    if not high > low:
        raise _checks.fail("z_range[1]", z_range[1], f"> z_range[0] = {low:g} m", "m")
    return np.asarray((z >= low) & (z <= high))


def plot_charge(source: Simulation | ChargeSnapshot, *, z_range: tuple[float, float] | None = None,
                ax: Axes | None = None, title: str | None = None, cmap: str = "viridis",
                vmax: float | None = None) -> Figure:
    """A cross-section of the charge coloured by speed, with the shell and the lifters at the
    same drum angle.

    The particles whose centres lie in a slab along the axis are drawn as circles of their
    radius at their (x, y), seen from +z (x to the right, y up; the drum turns
    counter-clockwise), the farther ones (lower z) first.

    Parameters
    ----------
    source : Simulation or ChargeSnapshot
        A simulation (its state now) or a snapshot (:meth:`millscope.Simulation.snapshot`).
    z_range : (float, float), optional
        The slab, m: particles with z_range[0] <= z <= z_range[1]. Default: within one largest
        sphere diameter of mid-length (:func:`charge_slab`).
    ax : Axes, optional
        Draw here instead of in a new figure.
    title : str, optional
        Default "<scene name>: charge at t = <time> s" on a new figure.
    cmap : str
        Matplotlib colour map of the speed.
    vmax : float, optional
        Top of the colour scale, m/s (> 0). Default: the highest of the drawn particles' speeds
        and the shell's speed omega R (1 m/s when both are 0).

    Returns
    -------
    Figure
        The figure holding the axes: ``ax.collections[0]`` holds the particles (its array the
        speeds, m/s), ``ax.patches`` the shell and the lifters; the colour bar is labelled in m/s.
    """
    snap: ChargeSnapshot = source.snapshot() if hasattr(source, "snapshot") else source
    keep = charge_slab(snap, z_range)
    if vmax is not None:
        vmax = _checks.positive("vmax", vmax, "m/s")
    drum = snap.scene.drum
    order = np.argsort(np.asarray(snap.positions)[keep, 2], kind="stable")
    xy = np.asarray(snap.positions)[keep][order, :2]
    diameters = 2.0 * np.asarray(snap.radii)[keep][order]
    speeds = snap.speeds[keep][order]
    if vmax is None:
        top = max(float(speeds.max(initial=0.0)), abs(snap.omega) * drum.radius)
        vmax = top if top > 0.0 else 1.0

    fig, ax, made = _axes(ax, (6.4, 5.4))
    particles = EllipseCollection(diameters, diameters, np.zeros(len(xy)), units="xy",
                                  offsets=xy, offset_transform=ax.transData, cmap=cmap,
                                  norm=Normalize(0.0, vmax), edgecolors="face")
    particles.set_array(speeds)
    ax.add_collection(particles)
    ax.add_patch(Circle((0.0, 0.0), drum.radius, fill=False, ec="0.15", lw=1.4))
    for outline in lifter_outlines(drum, snap.drum_angle):
        ax.add_patch(Polygon(outline, closed=True, fc="0.6", ec="0.15", lw=0.8))
    fig.colorbar(particles, ax=ax, label="speed (m/s)")
    reach = 1.04 * drum.radius
    ax.set_xlim(-reach, reach)
    ax.set_ylim(-reach, reach)
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    when = f"harge at t = {snap.time_s:.3g} s"
    _set_title(ax, title, f"{snap.scene.name}: c{when}" if snap.scene.name else f"C{when}", made)
    return fig


# -- files -----------------------------------------------------------------------------------
def save_figure(fig: Figure, path: str | os.PathLike[str], *, dpi: int = 150) -> Path:
    """Write ``fig`` atomically, in the format its suffix names (png, pdf, svg ...).

    The parent folder is created if needed; the file is written under a temporary name and
    renamed, so a reader never sees half a figure and a failure leaves nothing behind.

    Parameters
    ----------
    fig : Figure
    path : path-like
        Target file; its suffix chooses the format.
    dpi : int
        Resolution of raster formats, dots per inch.

    Returns
    -------
    Path
        The written file.

    Raises
    ------
    ValueError
        for a missing or unsupported suffix (the message lists the supported ones).
    """
    target = Path(path)
    fmt = target.suffix.lstrip(".").lower()
    supported = fig.canvas.get_supported_filetypes()
    if fmt not in supported:
        raise ValueError(f"{target}: suffix {target.suffix!r} is not a figure format; use one "
                         f"of {', '.join('.' + s for s in sorted(supported))}")
    target.parent.mkdir(parents=True, exist_ok=True)
    with atomic_write(target, "wb") as fh:
        fig.savefig(fh, format=fmt, dpi=dpi)
    return target

"""Figures: they draw the data they are given, mark what they say, keep no global state and
save atomically."""

from __future__ import annotations

import os

os.environ.setdefault("MPLBACKEND", "Agg")  # headless even if some test touches pyplot

import numpy as np
import pytest
from matplotlib.axes import Axes
from matplotlib.figure import Figure

import millscope as ms
from millscope import plots
from millscope.drivetrain import InterferenceLine

from .conftest import sine_record

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
MEAN, AMP, F_LTH = 265.0, 5.0, 8.8


@pytest.fixture(scope="module")
def record() -> ms.TorqueRecord:
    """10 s at 100 Hz: 265 N m mean, a 5 N m LTH at 8.8 Hz, 1 N m of noise."""
    return sine_record(1000, 100.0, mean=MEAN, amplitude=AMP, freq_hz=F_LTH, noise_std=1.0)


@pytest.fixture(scope="module")
def spec(record) -> ms.Spectrum:
    return ms.spectrum(record)


def _lth_annotation(ax: Axes):
    (arrow,) = [t for t in ax.texts if t.get_text().startswith("LTH")]
    return arrow


# -- spectrum --------------------------------------------------------------------------------
def test_spectrum_plot_draws_the_spectrum_without_the_mean(spec) -> None:
    fig = plots.plot_spectrum(spec, lth_hz=F_LTH, lines_hz=[("motor", 23.0), 31.0])
    assert isinstance(fig, Figure)
    (ax,) = fig.axes
    x, y = ax.lines[0].get_data()
    # Hann: the mean reads ~265 N m at 0 Hz and again in bin 1; its main lobe (<= 2/TR) is out
    assert spec.amplitude[0] == pytest.approx(MEAN, rel=0.01)
    assert spec.amplitude[1] > 0.5 * MEAN
    keep = spec.freq > 2 * spec.resolution_hz * (1 + 1e-9)
    np.testing.assert_array_equal(x, spec.freq[keep])
    np.testing.assert_array_equal(y, spec.amplitude[keep])
    assert x[0] > 0  # no DC bin
    lo, hi = ax.get_ylim()
    assert lo == 0.0
    assert AMP < hi < 0.1 * MEAN  # the mean does not set the scale; the LTH fits
    assert "(Hz)" in ax.get_xlabel() and "(N m)" in ax.get_ylabel()


def test_spectrum_plot_points_the_lth_arrow_at_the_peak(spec) -> None:
    ax = plots.plot_spectrum(spec, lth_hz=F_LTH).axes[0]
    arrow = _lth_annotation(ax)
    k = int(np.argmin(np.abs(spec.freq - F_LTH)))
    assert arrow.xy[0] == pytest.approx(F_LTH)
    assert arrow.xy[1] == pytest.approx(spec.amplitude[k - 2:k + 3].max())
    assert arrow.xy[1] == pytest.approx(AMP, rel=0.15)
    assert arrow.arrow_patch is not None
    assert arrow.xyann[1] < ax.get_ylim()[1]  # the text sits inside the axes
    log_ax = plots.plot_spectrum(spec, lth_hz=F_LTH, log=True).axes[0]
    assert log_ax.get_yscale() == "log"
    assert _lth_annotation(log_ax).xyann[1] < log_ax.get_ylim()[1]


def test_spectrum_plot_marks_drive_lines_in_range(spec) -> None:
    lines = [("motor", 23.0), 31.0, InterferenceLine("gear mesh", 12.5, "gear stage 1"), 80.0]
    ax = plots.plot_spectrum(spec, lines_hz=lines, fmax_hz=40.0).axes[0]
    assert ax.lines[0].get_xdata()[-1] <= 40.0
    assert ax.get_xlim() == pytest.approx((0.0, ax.lines[0].get_xdata()[-1]))
    assert sorted(line.get_xdata()[0] for line in ax.lines[1:]) == [12.5, 23.0, 31.0]  # 80 > fmax
    assert {t.get_text().strip() for t in ax.texts} == {"motor", "gear mesh"}


def test_spectrum_plot_rectangular_window_drops_only_the_dc_bin(record) -> None:
    rect = ms.spectrum(record, window="rectangular")
    x, y = plots.plot_spectrum(rect).axes[0].lines[0].get_data()
    np.testing.assert_array_equal(x, rect.freq[1:])
    np.testing.assert_array_equal(y, rect.amplitude[1:])


def test_spectrum_plot_draws_into_a_given_axes(spec) -> None:
    fig = Figure()
    axes = fig.subplots(1, 2)
    out = plots.plot_spectrum(spec, lth_hz=F_LTH, ax=axes[1], title="HDMS1")
    assert out is fig
    assert len(axes[0].lines) == 0 and len(axes[1].lines) == 1
    assert axes[1].get_title() == "HDMS1"
    sub = Figure().subfigures(1, 2)[0]
    assert isinstance(plots.plot_spectrum(spec, ax=sub.add_subplot()), Figure)


def test_spectrum_plot_refuses_an_lth_it_cannot_show(spec) -> None:
    with pytest.raises(ValueError, match="lth_hz = 45.0 Hz lies outside the plotted range"):
        plots.plot_spectrum(spec, lth_hz=45.0, fmax_hz=20.0)
    with pytest.raises(ValueError, match="fmax_hz"):
        plots.plot_spectrum(spec, fmax_hz=-1.0)


# -- waterfall -------------------------------------------------------------------------------
def test_waterfall_has_one_trace_per_spectrum_with_labels(record, spec) -> None:
    quiet = ms.spectrum(sine_record(1000, 100.0, mean=MEAN, amplitude=2.0, freq_hz=F_LTH))
    spectra, labels = [spec, quiet, spec], ["#1", "#2", "#3"]
    fig = plots.plot_waterfall(spectra, labels, fmax_hz=20)
    (ax,) = fig.axes
    assert ax.name == "3d"
    assert len(ax.lines) == 3
    keep = (spec.freq > 2 * spec.resolution_hz * (1 + 1e-9)) & (spec.freq <= 20)
    for i, (line, s) in enumerate(zip(ax.lines, spectra, strict=True)):
        xs, ys, zs = line.get_data_3d()
        np.testing.assert_array_equal(xs, s.freq[keep])  # DC and mean lobe dropped
        np.testing.assert_array_equal(ys, i)
        np.testing.assert_array_equal(zs, s.amplitude[keep])
    assert [t.get_text() for t in ax.get_yticklabels()] == labels
    assert "(Hz)" in ax.get_xlabel() and "(N m)" in ax.get_zlabel()
    assert ax.get_zlim()[1] < 0.1 * MEAN


def test_waterfall_rejects_mismatched_labels(spec) -> None:
    with pytest.raises(ValueError, match="spectra has 2 entries but labels has 3"):
        plots.plot_waterfall([spec, spec], ["#1", "#2", "#3"])
    with pytest.raises(ValueError, match="spectra is empty"):
        plots.plot_waterfall([], [])


# -- energy against filling ------------------------------------------------------------------
LEVELS = np.arange(1, 8)
ENERGY = -0.45 * np.log(LEVELS) + 1.0 + 0.01 * np.sin(LEVELS)


def _fit_curve(ax: Axes):
    (curve,) = [line for line in ax.lines if line.get_label().startswith("_fit")]
    return curve


def test_energy_fit_curve_is_the_fit() -> None:
    fit = ms.log_fit(LEVELS, ENERGY)
    fig = plots.plot_energy_fit(LEVELS, ENERGY, fit, label="HDMS", errors=0.02 * np.ones(7))
    (ax,) = fig.axes
    gx, gy = _fit_curve(ax).get_data()
    assert gx[0] == 1 and gx[-1] == 7 and gx.size > 50
    np.testing.assert_allclose(gy, fit(gx), rtol=1e-12)
    px, py = ax.containers[0].lines[0].get_data()  # the points
    np.testing.assert_array_equal(px, LEVELS)
    np.testing.assert_array_equal(py, ENERGY)
    legend = [t.get_text() for t in ax.get_legend().get_texts()]
    assert len(legend) == 1
    assert legend[0].startswith("HDMS: ")
    assert fit.equation() in legend[0] and f"$R^2$ = {fit.r2:.4f}" in legend[0]
    assert "per unit" in ax.get_ylabel()


def test_energy_fit_error_bars() -> None:
    low, high = 0.01 * LEVELS, 0.03 * np.ones(7)
    ax = plots.plot_energy_fit(LEVELS, ENERGY, errors=np.vstack([low, high])).axes[0]
    container = ax.containers[0]
    assert container.has_yerr
    (bars,) = container.lines[2]
    segments = np.asarray(bars.get_segments())  # per point: [(x, y - low), (x, y + high)]
    np.testing.assert_allclose(segments[:, 0, 1], ENERGY - low)
    np.testing.assert_allclose(segments[:, 1, 1], ENERGY + high)
    with pytest.raises(ValueError, match=r"errors has shape \(3,\)"):
        plots.plot_energy_fit(LEVELS, ENERGY, errors=[0.1, 0.1, 0.1])
    with pytest.raises(ValueError, match="errors must be finite and >= 0"):
        plots.plot_energy_fit(LEVELS, ENERGY, errors=-0.1)


def test_energy_fit_rejects_mismatched_lengths() -> None:
    with pytest.raises(ValueError, match="levels has 7 values but energies_pu has 6"):
        plots.plot_energy_fit(LEVELS, ENERGY[:-1])


def test_energy_fits_put_each_group_in_one_legend_entry() -> None:
    groups = {name: (LEVELS, scale * ENERGY, ms.log_fit(LEVELS, scale * ENERGY))
              for name, scale in (("HDMS", 1.0), ("LDMS", 0.9), ("HDHS", 0.8))}
    (ax,) = plots.plot_energy_fits(groups).axes
    legend = [t.get_text() for t in ax.get_legend().get_texts()]
    assert len(legend) == 3
    for text, (name, (_, _, fit)) in zip(legend, groups.items(), strict=True):
        assert text.startswith(name) and fit.equation() in text
    markers = {c.lines[0].get_marker() for c in ax.containers}
    colours = {c.lines[0].get_color() for c in ax.containers}
    assert len(markers) == len(colours) == 3
    with pytest.raises(ValueError, match="groups\\['bad'\\]: levels has 7 values but "
                                         "energies_pu has 5"):
        plots.plot_energy_fits({**groups, "bad": (LEVELS, ENERGY[:5], None)})


# -- quantities against filling level (Figs. 9, 11, 14) and the spectra grid (Fig. 10) ------
def test_level_plots_draw_each_group_in_level_order() -> None:
    levels = np.array([3.0, 1.0, 2.0])
    torque = np.array([0.98, 0.95, 1.0])
    for make, word in ((plots.plot_torque_levels, "torque"), (plots.plot_lth_levels, "LTH")):
        (ax,) = make({"HDMS": (levels, torque), "LDMS": (levels, 0.9 * torque)}).axes
        assert word in ax.get_ylabel() and "load level" in ax.get_xlabel()
        assert [c.get_label() for c in ax.containers] == ["HDMS", "LDMS"]
        x, y = ax.containers[0].lines[0].get_data()
        np.testing.assert_array_equal(x, [1.0, 2.0, 3.0])
        np.testing.assert_array_equal(y, [0.95, 1.0, 0.98])
        assert not ax.containers[0].has_yerr
    with pytest.raises(ValueError, match="groups is empty"):
        plots.plot_torque_levels({})
    with pytest.raises(ValueError, match=r"groups\['x'\]: levels has 3 values but"):
        plots.plot_lth_levels({"x": (levels, torque[:2])})
    with pytest.raises(ValueError, match="does not draw"):
        plots.plot_torque_levels({"x": (levels, torque, np.zeros((2, 3)))})


def test_the_lth_plot_opens_the_markers_of_levels_whose_lth_is_noise() -> None:
    """Fig. 11: the levels whose LTH does not stand out get an open marker over the group's
    point, in its colour and shape; the legend says what an open marker means."""
    levels = np.array([1.0, 2.0, 3.0, 4.0])
    amplitude = np.array([17.0, 15.0, 12.0, 8.0])
    distinct = np.array([False, True, False, True])
    (ax,) = plots.plot_lth_levels({"instant": (levels, amplitude, distinct),
                                   "mean": (levels, 0.6 * amplitude)}).axes
    (open_marks,) = [line for line in ax.lines if line.get_label() == "_instant"]
    x, y = open_marks.get_data()
    np.testing.assert_array_equal(x, levels[~distinct])
    np.testing.assert_array_equal(y, amplitude[~distinct])
    group = ax.containers[0].lines[0]
    assert open_marks.get_markerfacecolor() == "white"
    assert open_marks.get_markeredgecolor() == group.get_color()
    assert open_marks.get_marker() == group.get_marker()
    assert [t.get_text() for t in ax.get_legend().get_texts()] == [
        "instant", "mean", "open: not above the noise"]
    # every LTH distinct: no open marker, no legend note
    (ax,) = plots.plot_lth_levels({"mean": (levels, amplitude, np.ones(4, bool))}).axes
    assert not [line for line in ax.lines if line.get_label().startswith("_mean")]
    assert [t.get_text() for t in ax.get_legend().get_texts()] == ["mean"]
    with pytest.raises(ValueError, match=r"groups\['x'\]: distinct must be one bool per level"):
        plots.plot_lth_levels({"x": (levels, amplitude, [1, 0, 1, 0])})


def test_torque_level_plot_shows_a_small_change_at_its_true_scale() -> None:
    """Fig. 9: torques within 0.4 % of each other. The y axis runs from 0.9 per unit (or
    below the smallest value) to above 1, so the change takes a few per cent of the height
    rather than all of it; the legend states the largest change, (max - min) / max."""
    levels = np.arange(1.0, 8.0)
    ldms = 1.0 - 0.004 * (levels - 1) / 6  # falls by 0.4 % from level 1 to 7
    hdms = np.array([0.999, 1.0, 0.9995, 0.999, 0.9985, 0.998, 0.9975])
    (ax,) = plots.plot_torque_levels({"LDMS": (levels, ldms), "HDMS": (levels, hdms)}).axes
    low, high = ax.get_ylim()
    assert low <= 0.9 and high >= 1.0
    assert (ldms.max() - ldms.min()) / (high - low) < 0.05
    change = (ldms.max() - ldms.min()) / ldms.max()
    assert ax.get_legend().get_title().get_text() == (
        f"largest change within a group: {100 * change:.2g} % (LDMS)")
    # a value below the floor widens the axis to hold it
    (ax,) = plots.plot_torque_levels({"x": (levels[:3], np.array([1.0, 0.85, 0.95]))}).axes
    assert ax.get_ylim()[0] < 0.85 and ax.get_ylim()[1] >= 1.0
    # floor=None autoscales: the 0.4 % change fills the axis, as before
    (ax,) = plots.plot_torque_levels({"LDMS": (levels, ldms)}, floor=None).axes
    low, high = ax.get_ylim()
    assert (ldms.max() - ldms.min()) / (high - low) > 0.5
    with pytest.raises(ValueError, match="floor = 1.2 is not valid"):
        plots.plot_torque_levels({"LDMS": (levels, ldms)}, floor=1.2)


def test_energy_level_plot_draws_intervals_clipped_at_the_point() -> None:
    y = ENERGY
    bounds = np.vstack([y - 0.05, y + 0.02])
    bounds[1, 0] = y[0] - 0.01  # a percentile interval that misses its estimate from above
    (ax,) = plots.plot_energy_levels({"LDMS": (LEVELS, y, bounds),
                                      "HDMS": (LEVELS, y, np.full((2, 7), np.nan))}).axes
    first, second = ax.containers
    assert first.has_yerr and not second.has_yerr
    (bars,) = first.lines[2]
    segments = np.asarray(bars.get_segments())
    np.testing.assert_allclose(segments[:, 0, 1], y - 0.05)
    np.testing.assert_allclose(segments[1:, 1, 1], y[1:] + 0.02)
    assert segments[0, 1, 1] == pytest.approx(y[0])  # clipped: no bar above the point
    with pytest.raises(ValueError, match=r"bounds has shape \(7,\)"):
        plots.plot_energy_levels({"LDMS": (LEVELS, y, y)})


def test_spectra_grid_has_a_lettered_panel_per_spectrum_with_its_lth(spec) -> None:
    fig = plots.plot_spectra_grid([spec, spec, spec], ["HDMS1", "HDMS2", "HDMS3"],
                                  lth_hz=[F_LTH, None, F_LTH], ncols=2)
    assert len(fig.axes) == 3  # the fourth cell of the 2 x 2 grid is removed
    assert [ax.get_title() for ax in fig.axes] == ["a) HDMS1", "b) HDMS2", "c) HDMS3"]
    arrows = [[t for t in ax.texts if t.get_text().startswith("LTH")] for ax in fig.axes]
    assert [len(a) for a in arrows] == [1, 0, 1]
    np.testing.assert_array_equal(fig.axes[1].lines[0].get_ydata(),
                                  fig.axes[0].lines[0].get_ydata())
    half = ms.spectrum(sine_record(1000, 100.0, mean=MEAN, amplitude=AMP / 2, freq_hz=F_LTH,
                                   noise_std=0.5))
    same = plots.plot_spectra_grid([spec, half], ["full", "half"])
    assert same.axes[0].get_ylim() == same.axes[1].get_ylim()  # the noise falls visibly
    own = plots.plot_spectra_grid([spec, half], ["full", "half"], same_scale=False)
    assert own.axes[1].get_ylim()[1] < own.axes[0].get_ylim()[1]
    with pytest.raises(ValueError, match="one label and one LTH"):
        plots.plot_spectra_grid([spec], ["a", "b"])
    with pytest.raises(ValueError, match="ncols = 0"):
        plots.plot_spectra_grid([spec], ["a"], ncols=0)


# -- time domain -----------------------------------------------------------------------------
def test_torque_plot_draws_torque_and_dashed_mean(record) -> None:
    (ax,) = plots.plot_torque(record).axes
    np.testing.assert_array_equal(ax.lines[0].get_xdata(), record.time_s)
    np.testing.assert_array_equal(ax.lines[0].get_ydata(), record.torque_Nm)
    mean = ax.lines[1]
    assert mean.get_ydata()[0] == pytest.approx(record.mean_torque_Nm)
    assert mean.get_linestyle() == "--"
    assert ax.get_xlabel() == "time (s)" and "(N m)" in ax.get_ylabel()


def test_filtered_plot_draws_fluctuation_and_filtered(record) -> None:
    filtered = ms.band_stop(record, ["mean", F_LTH], window="rectangular")
    (ax,) = plots.plot_filtered(record, filtered).axes
    np.testing.assert_allclose(ax.lines[0].get_ydata(),
                               record.torque_Nm - record.mean_torque_Nm)
    np.testing.assert_array_equal(ax.lines[1].get_ydata(), filtered.torque_Nm)
    assert np.std(ax.lines[1].get_ydata()) < np.std(ax.lines[0].get_ydata())  # LTH gone
    with pytest.raises(ValueError, match="original has 1000 samples but filtered has 100"):
        plots.plot_filtered(record, record.block(0, 1))
    shifted = ms.TorqueRecord(record.time_s + 1.0, record.torque_Nm)
    with pytest.raises(ValueError, match="different sample times"):
        plots.plot_filtered(record, shifted)


# -- state and files -------------------------------------------------------------------------
def test_figures_leave_no_pyplot_state(record, spec) -> None:
    import matplotlib.pyplot as plt

    before = plt.get_fignums()
    fit = ms.log_fit(LEVELS, ENERGY)
    plots.plot_torque(record)
    plots.plot_spectrum(spec, lth_hz=F_LTH)
    plots.plot_waterfall([spec], ["#1"])
    plots.plot_energy_fits({"HDMS": (LEVELS, ENERGY, fit)})
    assert plt.get_fignums() == before


def test_save_figure_writes_png_atomically(tmp_path, spec) -> None:
    path = plots.save_figure(plots.plot_spectrum(spec, lth_hz=F_LTH), tmp_path / "sub" / "s.png")
    assert path == tmp_path / "sub" / "s.png"
    assert path.read_bytes()[:8] == PNG_SIGNATURE
    assert os.listdir(tmp_path / "sub") == ["s.png"]
    pdf = plots.save_figure(plots.plot_torque(sine_record(100, 10.0)), tmp_path / "t.pdf")
    assert pdf.read_bytes()[:5] == b"%PDF-"


def test_save_figure_failure_leaves_nothing(tmp_path, spec, monkeypatch) -> None:
    fig = plots.plot_spectrum(spec)
    with pytest.raises(ValueError, match=r"suffix '\.xyz' is not a figure format"):
        plots.save_figure(fig, tmp_path / "s.xyz")
    with pytest.raises(ValueError, match="suffix '' is not a figure format"):
        plots.save_figure(fig, tmp_path / "noext")

    def broken(*args, **kwargs):
        raise RuntimeError("disk full")

    monkeypatch.setattr(fig, "savefig", broken)
    with pytest.raises(RuntimeError, match="disk full"):
        plots.save_figure(fig, tmp_path / "s.png")
    assert os.listdir(tmp_path) == []

"""Figures: they draw the data they are given, mark what they say, and save atomically."""

from __future__ import annotations

import os

import numpy as np
import pytest
from matplotlib.figure import Figure

import millscope as ms
from millscope import plots

from .conftest import sine_record

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


@pytest.fixture(scope="module")
def spec() -> ms.Spectrum:
    return ms.spectrum(sine_record(1000, 100.0, mean=265.0, amplitude=5.0, freq_hz=8.8,
                                   noise_std=1.0))


def test_spectrum_plot_draws_the_spectrum_without_the_mean(spec) -> None:
    fig = plots.plot_spectrum(spec, lth_hz=8.8, lines_hz=[("motor", 23.0), 31.0])
    assert isinstance(fig, Figure)
    ax = fig.axes[0]
    x, y = ax.lines[0].get_data()
    keep = spec.freq > 2 * spec.resolution_hz * (1 + 1e-9)
    np.testing.assert_array_equal(x, spec.freq[keep])
    np.testing.assert_array_equal(y, spec.amplitude[keep])
    assert ax.get_ylim()[1] < 0.2 * spec.amplitude[0]  # the 265 N m mean does not set the scale
    (arrow,) = [c for c in ax.texts if c.get_text().startswith("LTH")]
    assert arrow.xy[0] == pytest.approx(8.8)
    assert {line.get_xdata()[0] for line in ax.lines[1:]} == {23.0, 31.0}


def test_waterfall_has_one_trace_per_spectrum_with_labels(spec) -> None:
    labels = ["#1", "#2", "#3"]
    fig = plots.plot_waterfall([spec, spec, spec], labels, fmax_hz=20)
    ax = fig.axes[0]
    assert len(ax.lines) == 3
    assert [t.get_text() for t in ax.get_yticklabels()] == labels
    with pytest.raises(ValueError, match="spectra has 2 entries but labels has 3"):
        plots.plot_waterfall([spec, spec], labels)


def test_energy_fit_curve_is_the_fit() -> None:
    levels = np.arange(1, 8)
    y = -0.45 * np.log(levels) + 1.0 + 0.01 * np.sin(levels)
    fit = ms.log_fit(levels, y)
    fig = plots.plot_energy_fit(levels, y, fit, errors=0.02 * np.ones(7))
    ax = fig.axes[0]
    (curve,) = ax.lines[-1:]
    gx, gy = curve.get_data()
    np.testing.assert_allclose(gy, fit(gx), rtol=1e-12)
    legend = " ".join(t.get_text() for t in ax.get_legend().get_texts())
    assert fit.equation() in legend and f"{fit.r2:.4f}" in legend
    with pytest.raises(ValueError, match="levels has 7 values but energies_pu has 6"):
        plots.plot_energy_fit(levels, y[:-1])
    many = plots.plot_energy_fits({"HDMS": (levels, y, fit), "LDMS": (levels, 0.9 * y, fit)})
    assert len(many.axes[0].get_legend().get_texts()) == 4


def test_torque_and_filtered_plots() -> None:
    rec = sine_record(500, 100.0, mean=100.0, amplitude=3.0, freq_hz=5.0, noise_std=0.5)
    fig = plots.plot_torque(rec)
    np.testing.assert_array_equal(fig.axes[0].lines[0].get_ydata(), rec.torque_Nm)
    assert fig.axes[0].lines[1].get_ydata()[0] == pytest.approx(rec.mean_torque_Nm)
    filtered = ms.band_stop(rec, ["mean", 5.0], window="rectangular")
    fig = plots.plot_filtered(rec, filtered)
    np.testing.assert_array_equal(fig.axes[0].lines[1].get_ydata(), filtered.torque_Nm)
    with pytest.raises(ValueError, match="original has 500 samples but filtered has 100"):
        plots.plot_filtered(rec, rec.block(0, 1))


def test_save_figure_writes_png_atomically(tmp_path, spec) -> None:
    path = plots.save_figure(plots.plot_spectrum(spec), tmp_path / "sub" / "s.png")
    assert path.read_bytes()[:8] == PNG_SIGNATURE
    assert os.listdir(tmp_path / "sub") == ["s.png"]

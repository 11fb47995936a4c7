"""Charge shape (toe, shoulder, centre of mass, angle of repose), drive power and the empirical
mill-power models, against analytic references and independent numerical integrals."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from scipy import integrate

import millscope as ms
from millscope.model.charge import GRAVITY, ChargeShape, charge_shape, particle_masses
from millscope.model.mill_power import (
    MORRELL_K,
    critical_speed_rad_s,
    hogg_fuerstenau_power,
    morrell_c_power,
    segment_half_angle,
)
from millscope.report.power import plot_power_comparison, read_power_table
from millscope.signal.power import drive_power

R = 0.44  # m, the pilot mill's shell radius
SPACING = 0.004  # m, lattice pitch of the synthetic beds
SPHERE = 0.002  # m, radius of the synthetic spheres


def segment_bed(alpha: float, chord: float, radius: float = R) -> np.ndarray:
    """Lattice points (x, y) filling the segment below a chord inclined at ``alpha`` (rising
    towards +x) at distance ``chord`` from the axis, within radius - SPHERE of it."""
    g = np.arange(-radius, radius + SPACING, SPACING)
    x, y = (a.ravel() for a in np.meshgrid(g, g))
    normal = np.array([math.sin(alpha), -math.cos(alpha)])  # into the bed
    keep = (x * normal[0] + y * normal[1] >= chord) & (np.hypot(x, y) <= radius - SPHERE)
    return np.column_stack([x[keep], y[keep]])


def shape_of(points: np.ndarray, **kw: float) -> ChargeShape:
    n = len(points)
    return charge_shape(points, np.full(n, SPHERE), np.full(n, 1e-3), R, **kw)


@pytest.mark.parametrize("alpha_deg, chord", [(35.0, 0.15), (20.0, 0.05), (45.0, 0.25)])
def test_synthetic_segment_bed_has_its_known_shape(alpha_deg: float, chord: float) -> None:
    alpha = math.radians(alpha_deg)
    bed = segment_bed(alpha, chord)
    band = 0.02
    shape = shape_of(bed, band_m=band, cell_m=0.03)
    # toe and shoulder: where the chord crosses the radius that halves the filled part of the
    # shell layer (centres from R - band to R - SPHERE), by area
    rho = math.sqrt(((R - band) ** 2 + (R - SPHERE) ** 2) / 2.0)
    half = math.acos(chord / rho)
    assert math.degrees(shape.shoulder_rad) == pytest.approx(
        math.degrees(alpha - math.pi / 2 + half), abs=1.0)
    assert math.degrees(shape.toe_rad) == pytest.approx(
        math.degrees(alpha + 1.5 * math.pi - half), abs=1.0)
    # the free surface is the chord
    assert shape.repose_angle_deg == pytest.approx(alpha_deg, abs=0.5)
    # centre of mass of a circular segment (radius r0 = R - SPHERE, half angle theta):
    # (2/3) r0 sin^3(theta) / (theta - sin theta cos theta) from the axis, along the normal
    r0 = R - SPHERE
    theta = math.acos(chord / r0)
    dist = 2.0 / 3.0 * r0 * math.sin(theta) ** 3 / (theta - math.sin(theta) * math.cos(theta))
    assert shape.centre_of_mass_m[0] == pytest.approx(dist * math.sin(alpha), abs=5e-4)
    assert shape.centre_of_mass_m[1] == pytest.approx(-dist * math.cos(alpha), abs=5e-4)
    assert shape.mass_kg == pytest.approx(1e-3 * len(bed))
    assert shape.gravity_torque_Nm == pytest.approx(
        shape.mass_kg * GRAVITY * shape.centre_of_mass_m[0])


def test_default_settings_and_snapshots() -> None:
    """With the defaults (band and cell 4 x the largest radius) the toe and shoulder of a
    thin layer land within a bin of the chord's ends; K identical snapshots give the shape
    of one, with the mass of one."""
    alpha, chord = math.radians(30.0), 0.2
    bed = segment_bed(alpha, chord)
    n = len(bed)
    one = charge_shape(bed, np.full(n, 0.005), np.full(n, 2e-3), R)
    half = math.acos(chord / (R - 0.01))  # the layer: centres from R - 0.02 to R - SPHERE
    assert one.shoulder_deg == pytest.approx(math.degrees(alpha - math.pi / 2 + half), abs=2.5)
    assert one.toe_deg == pytest.approx(math.degrees(alpha + 1.5 * math.pi - half), abs=2.5)
    three = charge_shape(np.stack([np.column_stack([bed, np.zeros(n)])] * 3),
                         np.full(n, 0.005), np.full(n, 2e-3), R)
    assert three.mass_kg == pytest.approx(one.mass_kg)
    assert three.toe_rad == pytest.approx(one.toe_rad)
    assert three.repose_angle_rad == pytest.approx(one.repose_angle_rad)
    assert three.centre_of_mass_m == pytest.approx(one.centre_of_mass_m)


def test_a_lifter_gap_does_not_end_the_charge() -> None:
    """A lifter-sized gap (30 mm) in the shell layer at the bottom is bridged by the moving
    average: the arc still reaches the chord's ends."""
    alpha, chord = math.radians(30.0), 0.2
    bed = segment_bed(alpha, chord)
    gap = (np.hypot(bed[:, 0], bed[:, 1]) > R - 0.02) & (np.abs(bed[:, 0]) < 0.015) \
        & (bed[:, 1] < 0)
    with_gap = shape_of(bed[~gap], band_m=0.02, cell_m=0.03)
    whole = shape_of(bed, band_m=0.02, cell_m=0.03)
    assert with_gap.toe_rad == pytest.approx(whole.toe_rad, abs=math.radians(1.0))
    assert with_gap.shoulder_rad == pytest.approx(whole.shoulder_rad, abs=math.radians(1.0))


def test_particle_masses_add_up_to_the_charge() -> None:
    scene = ms.presets.pilot_mill(0.71, "ceramic", 2)
    masses = particle_masses(scene)
    assert masses.shape == (scene.n_particles,)
    assert masses.sum() == pytest.approx(scene.charge_mass(), rel=1e-12)
    assert masses[0] == pytest.approx(7860.0 * math.pi / 6 * 0.025**3)  # a steel ball, first


def test_undefined_shapes_and_bad_inputs() -> None:
    ring = np.array([[R * 0.98 * math.cos(a), R * 0.98 * math.sin(a)]
                     for a in np.linspace(0, 2 * math.pi, 720, endpoint=False)])
    with pytest.raises(ValueError, match="centrifuging"):
        shape_of(ring, band_m=0.02)
    bed = segment_bed(math.radians(30.0), 0.2)
    n = len(bed)
    with pytest.raises(ValueError, match="positions_m has shape"):
        charge_shape(bed[:, :1], np.full(n, SPHERE), np.full(n, 1.0), R)
    with pytest.raises(ValueError, match=r"masses_kg has shape \(3,\)"):
        charge_shape(bed, np.full(n, SPHERE), np.ones(3), R)
    with pytest.raises(ValueError, match="outside drum_radius_m"):
        charge_shape(bed, np.full(n, SPHERE), np.ones(n), 0.3)
    bad = bed.copy()
    bad[0, 0] = np.nan
    with pytest.raises(ValueError, match="non-finite"):
        charge_shape(bad, np.full(n, SPHERE), np.ones(n), R)
    with pytest.raises(ValueError, match="masses_kg = -1.0 is not valid"):
        charge_shape(bed, np.full(n, SPHERE), -np.ones(n), R)
    with pytest.raises(ValueError, match=r"band_m = 1.0 m is not valid; it must be in \(0, 0.44\]"):
        charge_shape(bed, np.full(n, SPHERE), np.ones(n), R, band_m=1.0)
    with pytest.raises(ValueError, match="drum_radius_m = 0"):
        charge_shape(bed, np.full(n, SPHERE), np.ones(n), 0)
    with pytest.raises(ValueError, match="free surface has"):
        shape_of(bed, band_m=0.02, cell_m=0.4)


# -- drive power --------------------------------------------------------------------------------


def test_drive_power_is_omega_times_mean_torque() -> None:
    t = 0.01 * np.arange(1, 1001)
    torque = 300.0 + 40.0 * np.sin(2 * math.pi * 8.66 * t)
    rec = ms.TorqueRecord(t, torque, {"rotation_hz": 0.54})
    p = drive_power(rec, t_from=2.0, t_to=8.0)
    keep = (t >= 2.0 - 1e-9) & (t < 8.0 - 1e-9)
    assert p.mean_torque_Nm == pytest.approx(float(np.mean(torque[keep])), rel=1e-12)
    assert p.power_W == pytest.approx(2 * math.pi * 0.54 * float(np.mean(torque[keep])))
    assert p.span_s == pytest.approx((2.0, 7.99))
    # an explicit speed wins over the meta
    assert drive_power(rec, 1.0).power_W == pytest.approx(2 * math.pi * float(np.mean(torque)))


def test_drive_power_standard_error_of_white_noise() -> None:
    """Batch means of white noise of standard deviation s over n samples: the standard error
    of the mean is s / sqrt(n) (within the scatter of a 50-batch estimate)."""
    rng = np.random.default_rng(1)
    n, s = 20_000, 25.0
    rec = ms.TorqueRecord(0.001 * np.arange(n), 250.0 + rng.normal(0.0, s, n))
    p = drive_power(rec, 1.0 / (2 * math.pi), batches=50)
    assert p.standard_error_W == pytest.approx(s / math.sqrt(n), rel=0.35)
    assert p.power_W == pytest.approx(250.0, abs=4 * s / math.sqrt(n))


def test_drive_power_bad_inputs() -> None:
    rec = ms.TorqueRecord(0.01 * np.arange(100), np.ones(100))
    with pytest.raises(ValueError, match="no 'rotation_hz'"):
        drive_power(rec)
    with pytest.raises(ValueError, match="rotation_hz = -1.0 Hz is not valid"):
        drive_power(rec, -1.0)
    with pytest.raises(ValueError,
                       match=r"batches = 1 is not valid; it must be an integer in \[2, 50\]"):
        drive_power(rec, 1.0, batches=1)
    with pytest.raises(ValueError, match="holds 1 samples"):
        drive_power(rec, 1.0, t_from=0.5, t_to=0.505)
    with pytest.raises(TypeError):
        drive_power(np.ones(10), 1.0)  # type: ignore[arg-type]


# -- empirical models ---------------------------------------------------------------------------

D, L = 0.88, 0.315


def test_hogg_fuerstenau_is_the_torque_of_a_segment_of_charge() -> None:
    """P = omega x (torque of the weight of a uniform segment about the axis), the torque
    integrated numerically over the segment (scipy dblquad), independent of the closed form."""
    j, rho, alpha, phi = 0.3, 4500.0, math.radians(38.0), 0.75
    p = hogg_fuerstenau_power(D, L, phi, j, rho, alpha)
    r = D / 2
    theta = segment_half_angle(j)
    c = r * math.cos(theta)
    # in coordinates (u along the chord, w along the normal into the bed): x = u cos a + w sin a
    torque_per_length, _ = integrate.dblquad(
        lambda u, w: rho * GRAVITY * (u * math.cos(alpha) + w * math.sin(alpha)),
        c, r, lambda w: -math.sqrt(r * r - w * w), lambda w: math.sqrt(r * r - w * w))
    omega = phi * math.sqrt(2 * GRAVITY / D)
    assert p.net_power_W == pytest.approx(omega * torque_per_length * L, rel=1e-8)
    assert p.charge_mass_kg == pytest.approx(rho * j * math.pi * r * r * L)


def test_hogg_fuerstenau_matches_the_torque_of_a_synthetic_bed() -> None:
    """The segment model with the bed's own angle gives omega x M g x_c of a lattice bed
    (charge_shape), within the lattice's discretisation."""
    alpha, chord = math.radians(35.0), 0.15
    bed = segment_bed(alpha, chord, radius=D / 2)
    shape = shape_of(bed, band_m=0.02, cell_m=0.03)
    r0 = D / 2 - SPHERE
    theta = math.acos(chord / r0)
    j = (2 * theta - math.sin(2 * theta)) / (2 * math.pi)
    rho = shape.mass_kg / (j * math.pi * r0 * r0 * L)
    p = hogg_fuerstenau_power(2 * r0, L, 0.7, j, rho, shape.repose_angle_rad)
    omega = 0.7 * math.sqrt(2 * GRAVITY / (2 * r0))
    assert p.net_power_W == pytest.approx(omega * shape.gravity_torque_Nm, rel=0.01)


def test_segment_half_angle() -> None:
    assert segment_half_angle(0.5) == pytest.approx(math.pi / 2, abs=1e-12)
    t = segment_half_angle(0.2)
    assert (2 * t - math.sin(2 * t)) / (2 * math.pi) == pytest.approx(0.2, abs=1e-12)


def test_morrell_closed_form_is_its_integrals() -> None:
    """Morrell's closed form is the integral over the charge (r_i to r_m) of the potential
    power rho g L dh v r dr and the kinetic power rho L v^3 / 2 dr, with the tangential speed
    v(r) = 2 pi N_m r_m (r - z r_i) / (r_m - z r_i) (Morrell 1996): integrated here with
    scipy quad, at the model's own r_i, toe and shoulder."""
    j, rho, phi = 0.3, 4500.0, 0.75
    p = morrell_c_power(D, L, phi, j, rho)
    r_m = D / 2
    n_m = phi * critical_speed_rad_s(D) / (2 * math.pi)
    z = (1 - j) ** 0.4532  # Morrell (1996)
    r_i = p.inner_radius_m
    lift = math.sin(p.shoulder_rad) - math.sin(p.toe_rad)

    def v(r: float) -> float:
        return 2 * math.pi * n_m * r_m * (r - z * r_i) / (r_m - z * r_i)

    potential, _ = integrate.quad(lambda r: rho * GRAVITY * L * lift * v(r) * r, r_i, r_m)
    kinetic, _ = integrate.quad(lambda r: 0.5 * rho * L * v(r) ** 3, r_i, r_m)
    assert p.net_power_W == pytest.approx(MORRELL_K * (potential + kinetic), rel=1e-9)
    assert 0 < r_i < r_m


def test_models_scale_as_d_to_the_2_5_times_length_times_density() -> None:
    """At a fixed fraction of critical speed and filling, mill power goes as
    D^2.5 L rho_c (dimensional analysis; Bond 1961 and Morrell 1996 state the D^2.5 law)."""
    for model in (lambda *a: morrell_c_power(*a),
                  lambda *a: hogg_fuerstenau_power(*a, math.radians(35))):
        base = model(1.0, 1.0, 0.7, 0.3, 4000.0).net_power_W
        assert model(4.0, 1.0, 0.7, 0.3, 4000.0).net_power_W == pytest.approx(32 * base)
        assert model(1.0, 2.5, 0.7, 0.3, 4000.0).net_power_W == pytest.approx(2.5 * base)
        assert model(1.0, 1.0, 0.7, 0.3, 2000.0).net_power_W == pytest.approx(0.5 * base)


def test_morrell_toe_and_shoulder_trends() -> None:
    """The shoulder rises with speed (the charge is carried higher, as every observation of
    tumbling charges shows) while the toe stays below the horizontal on the falling side."""
    low = morrell_c_power(D, L, 0.6, 0.3, 4000.0)
    high = morrell_c_power(D, L, 0.85, 0.3, 4000.0)
    assert high.shoulder_rad > low.shoulder_rad
    for p in (low, high):
        assert math.pi < p.toe_rad < 1.5 * math.pi
        assert 0 < p.shoulder_rad < math.pi / 2


@pytest.mark.parametrize("kwargs, message", [
    ({"diameter_m": 0.0}, r"diameter_m = 0.0 m is not valid; it must be in \(0, 15\] m"),
    ({"length_m": math.nan}, "length_m = nan m is not valid"),
    ({"speed_fraction": 1.0}, r"speed_fraction = 1.0 is not valid; it must be in \(0, 1\)"),
    ({"filling": 0.6}, r"filling = 0.6 is not valid; it must be in \(0, 0.5\]"),
    ({"charge_density_kg_m3": -5.0}, "charge_density_kg_m3 = -5.0 kg/m\\^3 is not valid"),
])
def test_model_bad_inputs(kwargs: dict[str, float], message: str) -> None:
    args = {"diameter_m": D, "length_m": L, "speed_fraction": 0.7, "filling": 0.2,
            "charge_density_kg_m3": 4000.0, **kwargs}
    with pytest.raises(ValueError, match=f"morrell_c_power {message}"):
        morrell_c_power(**args)
    with pytest.raises(ValueError, match=f"hogg_fuerstenau_power {message}"):
        hogg_fuerstenau_power(**args, repose_angle_rad=0.6)
    with pytest.raises(ValueError, match="filling = 0.5 at speed_fraction = 0.3 is not valid"):
        morrell_c_power(D, L, 0.3, 0.5, 4000.0)
    with pytest.raises(ValueError, match=r"repose_angle_rad = 2.0 rad is not valid"):
        hogg_fuerstenau_power(D, L, 0.7, 0.2, 4000.0, 2.0)


# -- the comparison table and figure -------------------------------------------------------------


def comparison_table() -> pd.DataFrame:
    rows = []
    for case, group in (("balls-{}", "balls"), ("LD{}#2", "LD")):
        for code, speed in (("LS", 0.62), ("MS", 0.71), ("HS", 0.80)):
            sim = 800.0 + 300.0 * (speed - 0.62) + (50.0 if group == "LD" else 0.0)
            rows.append({"case": case.format(code), "group": group, "speed_fraction": speed,
                         "stiffness_factor": 0.001, "power_W": sim, "power_se_W": 10.0,
                         "morrell_power_W": 1.1 * sim, "morrell_diff_pct": 10.0,
                         "hogg_fuerstenau_power_W": 0.95 * sim,
                         "hogg_fuerstenau_diff_pct": -5.0})
    return pd.DataFrame(rows)


def test_power_figure_draws_the_table(tmp_path: Path) -> None:
    path = tmp_path / "power.csv"
    comparison_table().to_csv(path, index=False)
    table = read_power_table(path)
    fig = plot_power_comparison(table)
    axes = fig.axes
    assert len(axes) == 4  # two fillings x (power, difference)
    # the simulated line of the first panel is the table's power, in speed order
    balls = table[table["case"].str.startswith("balls")].sort_values("speed_fraction")
    panel = next(ax for ax in axes if ax.get_title().startswith("balls"))
    line = panel.lines[0]
    assert np.allclose(line.get_xdata(), 100 * balls["speed_fraction"])
    assert np.allclose(line.get_ydata(), balls["power_W"])
    with pytest.raises(ValueError, match="stiffness_factor = 0.5 is not valid"):
        plot_power_comparison(table, 0.5)
    # a stiffness check of one filling: drawn as extra points in its panel only
    check = table[table["case"].str.startswith("balls")].assign(stiffness_factor=0.01,
                                                                  power_W=900.0)
    fig = plot_power_comparison(pd.concat([table, check]))
    panel = next(ax for ax in fig.axes if ax.get_title().startswith("balls"))
    extra = [ln for ln in panel.lines if ln.get_label() == "simulated, G x 0.01"]
    assert len(extra) == 1 and np.allclose(extra[0].get_ydata(), 900.0)
    assert not any(ln.get_label() == "simulated, G x 0.01" for ax in fig.axes
                   if ax is not panel for ln in ax.lines)


def test_power_table_bad_files(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="no such file"):
        read_power_table(tmp_path / "missing.csv")
    table = comparison_table()
    table.drop(columns="power_se_W").to_csv(tmp_path / "a.csv", index=False)
    with pytest.raises(ValueError, match="missing column power_se_W"):
        read_power_table(tmp_path / "a.csv")
    text = table.to_csv(index=False).replace("800.0", "lots", 1)
    (tmp_path / "b.csv").write_text(text)
    with pytest.raises(ValueError, match="must hold finite numbers"):
        read_power_table(tmp_path / "b.csv")
    (tmp_path / "c.csv").write_bytes(b"\xff\xfe\x00garbage")
    with pytest.raises(ValueError, match="power table"):
        read_power_table(tmp_path / "c.csv")

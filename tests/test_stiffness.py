"""The stiffness advisor (millscope.stiffness) against values computed here by hand: the Rayleigh
time, the Hertz contact time t_c = 2.87 (m*^2 / (R* E*^2 v))^(1/5) with E*, R*, m* from the
materials (docs/physics.md, Pair constants), the Davis landing speed from the flight integrated
here, the warning exactly at its threshold, and bad input."""

from __future__ import annotations

import math
import warnings
from dataclasses import replace

import numpy as np
import pytest

import millscope as ms
from millscope import cli, presets
from millscope.stiffness import (
    StiffnessAdvice,
    StiffnessWarning,
    advise_stiffness,
    expected_impact_speed,
    upper_impact_speed,
)

LD_TINY = presets.pilot_mill(0.71, "ceramic", 1, "tiny")  # steel balls, ceramic particles


def quiet_advice(scene: ms.Scene, **kwargs: object) -> StiffnessAdvice:
    """The advice with every warning an error: the call must not warn."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        return advise_stiffness(scene, **kwargs)  # type: ignore[arg-type]


# -- by hand ---------------------------------------------------------------------------------

def youngs(m: ms.Material) -> float:
    return 2.0 * m.shear_modulus * (1.0 + m.poisson)


def hertz_time_by_hand(scene: ms.Scene, a: str, b: str | None, speed: float) -> float:
    """t_c of fraction a against fraction b (None: the drum, a flat wall of its material)."""
    fa = next(f for f in scene.charge if f.name == a)
    ma = scene.material(fa.material)
    mass_a = ma.density * math.pi * fa.diameter**3 / 6.0
    if b is None:
        mb, r_star, m_star = scene.material(scene.drum.material), fa.radius, mass_a
    else:
        fb = next(f for f in scene.charge if f.name == b)
        mb = scene.material(fb.material)
        mass_b = mb.density * math.pi * fb.diameter**3 / 6.0
        r_star = 1.0 / (1.0 / fa.radius + 1.0 / fb.radius)
        m_star = 1.0 / (1.0 / mass_a + 1.0 / mass_b)
    e_star = 1.0 / ((1.0 - ma.poisson**2) / youngs(ma) + (1.0 - mb.poisson**2) / youngs(mb))
    return 2.87 * (m_star**2 / (r_star * e_star**2 * speed)) ** 0.2


def rayleigh_by_hand(scene: ms.Scene) -> float:
    def one(f: ms.Fraction) -> float:
        m = scene.material(f.material)
        return math.pi * f.radius * math.sqrt(m.density / m.shear_modulus) / (
            0.1631 * m.poisson + 0.8766)
    return min(one(f) for f in scene.charge)


KINDS = [("balls", "balls"), ("balls", "particles"), ("particles", "particles"),
         ("balls", None), ("particles", None)]


# -- values ----------------------------------------------------------------------------------

def test_rayleigh_time_and_default_dt_by_hand() -> None:
    advice = quiet_advice(LD_TINY)
    t_r = rayleigh_by_hand(LD_TINY)
    assert advice.rayleigh_time == pytest.approx(t_r, rel=1e-12)
    assert advice.rayleigh_fraction == "balls"  # steel: stiffer per radius than the ceramic
    assert advice.dt == pytest.approx(0.2 * t_r, rel=1e-12)
    assert advice.dt_fraction == pytest.approx(0.2, rel=1e-12)


@pytest.mark.parametrize("scale", ["paper", "tiny"])
def test_hertz_contact_time_of_every_contact_by_hand(scale: str) -> None:
    scene = presets.pilot_mill(0.71, "ceramic", 1, scale)
    advice = quiet_advice(scene, impact_speed=2.5)
    assert [(c.fraction_a, c.fraction_b) for c in advice.contacts] == [
        (a, "wall" if b is None else b) for a, b in KINDS]
    for c, (a, b) in zip(advice.contacts, KINDS, strict=True):
        t_c = hertz_time_by_hand(scene, a, b, 2.5)
        assert c.contact_time == pytest.approx(t_c, rel=1e-9), c.label
        assert c.contact_hz == pytest.approx(1.0 / t_c, rel=1e-9)
        assert c.steps_per_contact == pytest.approx(t_c / advice.dt, rel=1e-9)
        assert c.samples_per_contact == pytest.approx(t_c / 0.01, rel=1e-9)


def test_contact_time_scales_as_the_shear_modulus_to_the_minus_two_fifths() -> None:
    """Every G x 0.001 (tiny against small: the same slice, G x 0.01): t_c x 10^(2/5)."""
    small = quiet_advice(presets.pilot_mill(0.71, "ceramic", 1, "small"), impact_speed=3.0)
    tiny = quiet_advice(LD_TINY, impact_speed=3.0)
    for s, t in zip(small.contacts, tiny.contacts, strict=True):
        assert t.contact_time / s.contact_time == pytest.approx(10.0**0.4, rel=1e-9)


def test_the_engine_integrates_an_elastic_contact_in_the_hertz_number_of_steps() -> None:
    """With e = 1 the integrated impact (the engine's law and integrator) lasts t_c: its step
    count is t_c / dt within one step and 2 %."""
    elastic = LD_TINY.replace(pairs=tuple(replace(p, restitution=1.0, friction=0.0)
                                          for p in LD_TINY.pairs))
    for c in quiet_advice(elastic).contacts:
        assert abs(c.integrated_steps - c.steps_per_contact) <= 1 + 0.02 * c.steps_per_contact
        assert c.integrated_contact_time == pytest.approx(c.contact_time, rel=0.02)


def davis_landing_speed(omega: float, r_p: float, g: float) -> float:
    """The flight integrated here: leave the shell (radius r_p, turning at omega about +z)
    where omega^2 r_p = g sin(alpha), then fall freely until back on the circle."""
    alpha = math.asin(omega**2 * r_p / g)
    x0 = np.array([r_p * math.cos(alpha), r_p * math.sin(alpha)])
    v0 = omega * r_p * np.array([-math.sin(alpha), math.cos(alpha)])
    acc = np.array([0.0, -g])
    # from 1 ms (the path leaves the circle only as t^3) to past the landing, 4 w r_p cos(a) / g
    t = np.linspace(1e-3, 8.0 * omega * r_p / g, 400_001)
    path = x0 + np.outer(t, v0) + 0.5 * np.outer(t**2, acc)
    inside = np.hypot(path[:, 0], path[:, 1]) <= r_p
    land = t[np.argmax(~inside[1:] & inside[:-1]) + 1]  # the first exit after the start
    return float(np.hypot(*(v0 + acc * land)))


@pytest.mark.parametrize("fraction", [0.62, 0.71, 0.80])
def test_expected_impact_speed_is_the_davis_landing_speed(fraction: float) -> None:
    scene = presets.pilot_mill(fraction, None, 1, "paper")
    speed, basis = expected_impact_speed(scene)
    r_p = scene.drum.radius - 0.0125
    assert "Davis" in basis
    assert speed == pytest.approx(davis_landing_speed(scene.omega, r_p, 9.81), rel=1e-4)
    assert speed < math.sqrt(2 * 9.81 * scene.drum.diameter)  # bounded by the free fall


@pytest.mark.parametrize("changes", [dict(speed_fraction=None, speed_hz=0.0),
                                     dict(speed_fraction=1.5)])
def test_without_cataract_the_speed_is_the_free_fall_across_the_drum(changes: dict) -> None:
    scene = presets.pilot_mill(0.71, None, 1, "tiny").replace(**changes)
    speed, basis = expected_impact_speed(scene)
    assert speed == pytest.approx(math.sqrt(2 * 9.81 * 0.88), rel=1e-12)
    assert "free fall" in basis
    assert upper_impact_speed(scene) == pytest.approx(speed + scene.omega * 0.44, rel=1e-12)


def test_paper_settings_resolve_contacts_and_keep_them_out_of_the_band() -> None:
    """The paper's moduli, dt and 10 ms samples: every contact spans >= 20 steps and a small
    fraction of a sample; its frequency lies more than 100 x above 50 Hz."""
    advice = quiet_advice(presets.pilot_mill(0.71, "ceramic", 1, "paper"))
    assert advice.analysis_band_hz == 50.0 and advice.band_is_nyquist
    assert advice.reaching_band == ()
    assert advice.band_margin > 100
    assert all(c.steps_per_contact > 20 and c.samples_per_contact < 0.01
               for c in advice.contacts)
    assert all(c.stability_margin > 2 for c in advice.contacts)


# -- the warning -----------------------------------------------------------------------------

def lowest_contact_hz(scene: ms.Scene, speed: float) -> float:
    return min(1.0 / hertz_time_by_hand(scene, a, b, speed) for a, b in KINDS)


def test_warns_exactly_when_the_band_reaches_the_lowest_contact_frequency() -> None:
    f_low = lowest_contact_hz(LD_TINY, 3.0)
    sample_dt = 1e-4  # Nyquist 5 kHz, above f_low (about 1 kHz)
    below = quiet_advice(LD_TINY, impact_speed=3.0, sample_dt=sample_dt,
                         analysis_band_hz=f_low * (1 - 1e-9))
    assert below.reaching_band == () and below.band_margin > 1
    with pytest.warns(StiffnessWarning, match=r"reaches the analysis band") as caught:
        at = advise_stiffness(LD_TINY, impact_speed=3.0, sample_dt=sample_dt,
                              analysis_band_hz=f_low * (1 + 1e-9))
    assert len(caught) == 1
    assert [c.label for c in at.reaching_band] == [at.longest.label]
    assert at.longest.contact_hz == pytest.approx(f_low, rel=1e-9)


def test_the_default_band_is_the_nyquist_frequency() -> None:
    f_low = lowest_contact_hz(LD_TINY, 3.0)
    dt = 0.2 * rayleigh_by_hand(LD_TINY)
    quiet_advice(LD_TINY, impact_speed=3.0, sample_dt=0.5 / f_low * (1 + 1e-9), dt=dt)
    with pytest.warns(StiffnessWarning):
        advice = advise_stiffness(LD_TINY, impact_speed=3.0, sample_dt=0.5 / f_low * (1 - 1e-9),
                                  dt=dt)
    assert advice.analysis_band_hz == pytest.approx(f_low / (1 - 1e-9), rel=1e-12)


# -- reports ---------------------------------------------------------------------------------

def test_text_and_markdown_reports_name_every_contact_and_the_verdict() -> None:
    advice = quiet_advice(LD_TINY)
    text, md = str(advice), advice.to_markdown()
    for c in advice.contacts:
        assert c.label in text and f"| {c.label} |" in md
    assert text.splitlines()[-1].startswith("ok: the lowest contact frequency")
    assert f"{advice.longest.contact_hz:.4g} Hz" in text
    assert md.startswith("### Stiffness advice: LDMS#1")
    with pytest.warns(StiffnessWarning):
        warned = advise_stiffness(LD_TINY, sample_dt=1e-4, analysis_band_hz=4000.0)
    assert "WARNING" in str(warned) and "**WARNING" in warned.to_markdown()


# -- bad input -------------------------------------------------------------------------------

@pytest.mark.parametrize("kwargs, message", [
    (dict(dt=-1e-5), r"dt = -1e-05 s is not valid; it must be in \(0, .*\] s = 0\.312 x the "
                     r"Rayleigh time .* of the fraction 'balls': 0\.8 x the velocity-Verlet "
                     r"stability bound of the tangential-rotational stick mode of the contact "
                     r"particles \(ceramic\) - drum \(steel\)"),
    (dict(dt=1.0), r"dt = 1\.0 s is not valid; it must be in \(0, "),
    (dict(dt=math.nan), r"dt = nan s is not valid"),
    (dict(sample_dt=1e-6), r"sample_dt = 1e-06 s is not valid; it must be in \[dt = "),
    # above 1 / (2 LTH), the samples cannot resolve the LTH at 16 x 0.5413 Hz
    (dict(sample_dt=1e308), r"sample_dt = 1e\+308 s is not valid; it must be in \[dt = .*, "
                            r"0\.0577.*\] s, so that the Nyquist frequency is above the LTH "
                            r"at 8\.661 Hz"),
    (dict(sample_dt="0.01"), r"sample_dt = '0\.01' s is not valid"),
    (dict(analysis_band_hz=80.0), r"analysis_band_hz = 80\.0 Hz is not valid; it must be in "
                                  r"\[8\.661, 50\] Hz: from the LTH to the Nyquist frequency of "
                                  r"sample_dt = 0\.01 s"),
    (dict(analysis_band_hz=0.0), r"analysis_band_hz = 0\.0 Hz is not valid"),
    (dict(analysis_band_hz=1e-308), r"analysis_band_hz = 1e-308 Hz is not valid; it must be in "
                                    r"\[8\.661, 50\]"),
    (dict(impact_speed=-2.0), r"impact_speed = -2\.0 m/s is not valid; it must be in \(0, "),
    (dict(impact_speed=math.inf), r"impact_speed = inf m/s is not valid"),
])
def test_bad_input_names_parameter_value_and_range(kwargs: dict, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        advise_stiffness(LD_TINY, **kwargs)


def test_a_scene_is_required() -> None:
    with pytest.raises(ValueError, match=r"scene = dict is not valid; it must be a millscope "
                                         r"Scene"):
        advise_stiffness({"drum": 0.88})  # type: ignore[arg-type]


# -- command line ----------------------------------------------------------------------------

def test_cli_advise_prints_the_report(capsys: pytest.CaptureFixture[str]) -> None:
    assert cli.main(["advise", "--scale", "tiny", "--particles", "ceramic"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("stiffness advice: LDMS#1") and "balls-particles" in out
    assert cli.main(["advise", "--scale", "tiny", "--sample-dt", "1e-4", "--band-hz", "4000",
                     "--markdown"]) == 0
    assert "**WARNING" in capsys.readouterr().out


def test_cli_advise_reads_a_scene_file(tmp_path, capsys) -> None:  # type: ignore[no-untyped-def]
    import json

    path = tmp_path / "scene.json"
    path.write_text(json.dumps(LD_TINY.to_dict()))
    assert cli.main(["advise", "--scene", str(path)]) == 0
    assert "particles-wall" in capsys.readouterr().out


@pytest.mark.parametrize("argv, message", [
    (["--particles", "glass"], "millscope: error: particles = 'glass' is not valid"),
    (["--band-hz", "80"], "millscope: error: analysis_band_hz = 80.0 Hz is not valid"),
    (["--dt", "1"], "millscope: error: dt = 1.0 s is not valid"),
    (["--level", "9", "--particles", "ceramic"], "millscope: error: load_level = 9 is not valid"),
])
def test_cli_advise_bad_input_is_one_line_and_exit_2(argv: list[str], message: str,
                                                     capsys: pytest.CaptureFixture[str]) -> None:
    assert cli.main(["advise", *argv]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith(message) and "\n" not in err


def test_a_drum_at_rest_is_advised_on_with_the_nyquist_band() -> None:
    """No rotation, no LTH: sample_dt and the band have only their lower limits (the LTH range
    of a turning drum divided by its zero frequency)."""
    scene = LD_TINY.replace(speed_fraction=None, speed_hz=0.0)
    advice = quiet_advice(scene, sample_dt=0.5)
    assert advice.analysis_band_hz == pytest.approx(1.0)
    with pytest.raises(ValueError, match=r"analysis_band_hz = 0\.0 Hz is not valid; it must be "
                                         r"in \(0, 50\] Hz"):
        advise_stiffness(scene, analysis_band_hz=0.0)

"""Drive-train lines of the paper's rig (sections 5 and 6.5, Table 7) and decimation.

Expected values are hand calculations from the paper's numbers (four-pole motor fed at 46 Hz,
total ratio 36.27, 18-tooth pinion at 3.55 Hz, 16 lifters), and numpy FFT amplitudes for
:func:`decimate`. The split of the first two gear stages (2.5 and the rest) is an assumption of
these tests only: the paper does not publish it.
"""

from __future__ import annotations

import json
import math
import re
from typing import Any

import numpy as np
import pytest
import scipy.signal as ss

import millscope as ms
from millscope import drivetrain
from millscope.drivetrain import (
    DECIMATE_FACTOR,
    DriveTrain,
    GearStage,
    InterferenceLine,
    Motor,
    decimate,
    decimate_record,
)

TOTAL_RATIO = 36.27
PINION_TEETH, PINION_HZ = 18, 3.55
SUPPLY_HZ, POLE_PAIRS, LIFTERS = 46.0, 2, 16
MOTOR_HZ = SUPPLY_HZ / POLE_PAIRS  # 23 Hz, no slip
STAGE_1 = 2.5  # assumed (tests only)
STAGES_1_2 = MOTOR_HZ / PINION_HZ  # motor / pinion shaft, so that the pinion turns at 3.55 Hz


def rig_stages() -> tuple[GearStage, ...]:
    return (GearStage(ratio=STAGE_1), GearStage(ratio=STAGES_1_2 / STAGE_1),
            GearStage(driver_teeth=PINION_TEETH, ratio=TOTAL_RATIO / STAGES_1_2))


def paper_rig() -> DriveTrain:
    return DriveTrain(Motor(POLE_PAIRS, supply_hz=SUPPLY_HZ), rig_stages(), lifters=LIFTERS)


def lines_by_name(drive: DriveTrain, max_hz: float | None = None) -> dict[str, float]:
    return {line.name: line.frequency_hz for line in drive.interference_lines(max_hz)}


# -- lines ----------------------------------------------------------------------------------------
def test_pinion_mesh_line_is_18_x_3_55_hz() -> None:
    lines = lines_by_name(paper_rig())
    assert lines["stage 2 output shaft turn"] == pytest.approx(PINION_HZ, rel=1e-12)
    assert lines["stage 3 gear mesh"] == pytest.approx(18 * 3.55, rel=1e-9)
    assert lines["stage 3 gear mesh"] == pytest.approx(63.9, rel=1e-9)


def test_mesh_from_either_tooth_count() -> None:
    # driver side: teeth x input turn; driven side: teeth x output turn = 90 x 10 / 5
    assert GearStage(driver_teeth=18, ratio=5.6).mesh_hz(3.55) == pytest.approx(63.9, rel=1e-12)
    assert GearStage(driven_teeth=90, ratio=5.0).mesh_hz(10.0) == pytest.approx(180.0, rel=1e-12)
    teeth = GearStage(driver_teeth=18, driven_teeth=105)
    assert teeth.speed_ratio == pytest.approx(105 / 18, rel=1e-12)
    assert teeth.mesh_hz(3.55) == pytest.approx(63.9, rel=1e-12)
    assert GearStage(ratio=5.6).mesh_hz(3.55) is None


def test_table_7_lines_of_the_rig() -> None:
    drive = paper_rig()
    mill_hz = 23.0 / 36.27
    assert drive.motor.shaft_hz == pytest.approx(23.0, rel=1e-15)
    assert drive.total_ratio == pytest.approx(36.27, rel=1e-12)
    assert drive.mill_hz == pytest.approx(drive.motor.shaft_hz / 36.27, rel=1e-12)
    assert drive.shaft_hz == pytest.approx((23.0 / 2.5, 3.55, mill_hz), rel=1e-12)
    assert drive.lth_hz == pytest.approx(16 * mill_hz, rel=1e-12)

    lines = drive.interference_lines()
    freqs = [line.frequency_hz for line in lines]
    assert freqs == sorted(freqs)
    expected = {"mill turn": mill_hz, "2 x mill turn": 2 * mill_hz, "LTH": 16 * mill_hz,
                "stage 1 output shaft turn": 9.2, "stage 2 output shaft turn": 3.55,
                "motor turn": 23.0, "stage 3 gear mesh": 63.9}
    assert set(lines_by_name(drive)) == set(expected)
    for name, value in expected.items():
        assert lines_by_name(drive)[name] == pytest.approx(value, rel=1e-9), name
    assert {line.source for line in lines} == {"mill", "lifters", "motor", "stage 1", "stage 2",
                                                "stage 3"}


def test_max_hz_keeps_the_analysis_band() -> None:
    drive = paper_rig()
    band = lines_by_name(drive, max_hz=50.0)
    assert "stage 3 gear mesh" not in band  # 63.9 Hz is above the paper's 0-50 Hz band
    assert len(band) == 6 and max(band.values()) <= 50.0
    mesh_hz = lines_by_name(drive)["stage 3 gear mesh"]
    assert "stage 3 gear mesh" in lines_by_name(drive, max_hz=mesh_hz)  # the limit is inclusive
    assert set(lines_by_name(drive, max_hz=1.0)) == {"mill turn"}  # 0.634 Hz; 2x is 1.268 Hz

    freqs = drive.frequencies_hz(max_hz=50.0)
    assert freqs == sorted(band.values())
    without = drive.frequencies_hz(max_hz=50.0, include_lth=False)
    assert len(without) == 5
    assert not any(math.isclose(f, 16 * 23.0 / 36.27, rel_tol=1e-9) for f in without)


def test_direct_drive_has_no_separate_motor_line() -> None:
    drive = DriveTrain(Motor(2, speed_hz=0.55), (), lifters=16)
    assert drive.total_ratio == 1.0 and drive.mill_hz == 0.55
    assert drive.frequencies_hz() == pytest.approx([0.55, 1.1, 8.8], rel=1e-12)


def test_stage_names_label_the_lines() -> None:
    drive = DriveTrain(Motor(2, supply_hz=46.0),
                       [GearStage(ratio=STAGES_1_2, name="stages 1-2"),
                        GearStage(driver_teeth=18, ratio=TOTAL_RATIO / STAGES_1_2,
                                  name="pinion-crown")], lifters=16)
    assert isinstance(drive.stages, tuple)  # a list is stored as a tuple
    lines = lines_by_name(drive)
    assert lines["stages 1-2 output shaft turn"] == pytest.approx(3.55, rel=1e-12)
    assert lines["pinion-crown gear mesh"] == pytest.approx(63.9, rel=1e-9)
    assert drive.mill_hz == pytest.approx(paper_rig().mill_hz, rel=1e-12)


def test_motor_speed_from_supply_and_slip() -> None:
    # the paper's other operating point: fed at 41 Hz; a slip of 4.2 % (assumed)
    assert Motor(2, supply_hz=41.0, slip=0.042).shaft_hz == pytest.approx(20.5 * 0.958,
                                                                          rel=1e-12)
    assert Motor(3, speed_hz=15.5).shaft_hz == 15.5


def test_from_mill_speed_matches_the_direct_construction() -> None:
    direct = DriveTrain(Motor(2, supply_hz=46.0, slip=0.038), rig_stages(), lifters=16)
    back = DriveTrain.from_mill_speed(direct.mill_hz, rig_stages(), 16, pole_pairs=2)
    assert back.motor.shaft_hz == pytest.approx(23.0 * 0.962, rel=1e-12)
    assert back.mill_hz == pytest.approx(direct.mill_hz, rel=1e-12)
    assert back.stages == direct.stages and back.lifters == 16
    pairs = list(zip(back.interference_lines(), direct.interference_lines(), strict=True))
    assert len(pairs) == 7
    for mine, theirs in pairs:
        assert mine.name == theirs.name and mine.source == theirs.source
        assert mine.frequency_hz == pytest.approx(theirs.frequency_hz, rel=1e-12)
    # by hand: a mill at 0.61 Hz needs the motor at 0.61 x 36.27 Hz
    assert DriveTrain.from_mill_speed(0.61, rig_stages(), 16).motor.shaft_hz == pytest.approx(
        0.61 * 36.27, rel=1e-12)


# -- JSON -----------------------------------------------------------------------------------------
def test_json_round_trip(tmp_path) -> None:
    drive = DriveTrain(Motor(2, supply_hz=46.0, slip=0.038),
                       (*rig_stages()[:2], GearStage(driver_teeth=18, driven_teeth=103),
                        GearStage(driven_teeth=40, ratio=1.5, name="crown")), lifters=16)
    path = tmp_path / "drive.json"
    path.write_text(json.dumps(drive.to_dict()))
    assert DriveTrain.load(path) == drive
    saved = tmp_path / "saved.json"
    drive.save(saved)
    assert DriveTrain.load(saved) == drive
    assert json.loads(saved.read_text()) == drive.to_dict()
    assert "speed_hz" not in drive.to_dict()["motor"]  # unset fields are left out


def test_the_documented_example_reproduces_the_paper() -> None:
    doc = drivetrain.__doc__
    assert doc is not None
    example = re.search(r"\n    (\{\n.*?\n    \})\n", doc, re.DOTALL)
    assert example is not None
    drive = DriveTrain.from_dict(json.loads(example.group(1)))
    lines = lines_by_name(drive)
    assert drive.total_ratio == pytest.approx(36.27, rel=1e-4)
    assert lines["stages 1-2 (lumped) output shaft turn"] == pytest.approx(3.55, rel=1e-3)
    assert lines["pinion-crown gear mesh"] == pytest.approx(63.9, rel=1e-3)
    assert drive.motor.shaft_hz == pytest.approx(46 / 2 * (1 - 0.038), rel=1e-12)


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("{", "not valid JSON"),
        ("[]", "expected a JSON object with keys motor, stages, lifters; got list"),
        ('{"motor": {"pole_pairs": 2, "speed_hz": 20}, "lifters": 16}', "missing key 'stages'"),
        ('{"motor": {"pole_pairs": 2, "speed_hz": 20}, "stages": [], "lifters": 16, '
         '"lifter": 3}', "unknown key 'lifter'; the keys are motor, stages, lifters"),
        ('{"motor": 3, "stages": [], "lifters": 16}', "'motor' must be an object; got int"),
        ('{"motor": {"speed_hz": 20}, "stages": [], "lifters": 16}',
         "motor: missing key 'pole_pairs'"),
        ('{"motor": {"pole_pairs": 2, "rpm": 1200}, "stages": [], "lifters": 16}',
         "motor: unknown key 'rpm'"),
        ('{"motor": {"pole_pairs": "2", "speed_hz": 20}, "stages": [], "lifters": 16}',
         "motor: Motor.pole_pairs = '2' is not valid; it must be an integer in \\[1, 1000\\]"),
        ('{"motor": {"pole_pairs": 2, "speed_hz": 20}, "stages": {"ratio": 2}, "lifters": 16}',
         "'stages' must be an array of objects; got dict"),
        ('{"motor": {"pole_pairs": 2, "speed_hz": 20}, "stages": [2.0], "lifters": 16}',
         r"stages\[0\] must be an object; got float"),
        ('{"motor": {"pole_pairs": 2, "speed_hz": 20}, "stages": [{"ratio": 2}, '
         '{"ratio": 2, "teeth": 3}], "lifters": 16}', r"stages\[1\]: unknown key 'teeth'"),
        ('{"motor": {"pole_pairs": 2, "speed_hz": 20}, "stages": [{"ratio": -2}], '
         '"lifters": 16}', r"stages\[0\]: GearStage.ratio = -2 is not valid"),
        ('{"motor": {"pole_pairs": 2, "speed_hz": 20}, "stages": [], "lifters": 16.5}',
         "DriveTrain.lifters = 16.5 is not valid; it must be an integer in \\[1, 10000\\]"),
    ],
)
def test_bad_drive_files_name_file_and_problem(tmp_path, text: str, message: str) -> None:
    path = tmp_path / "my_drive.json"
    path.write_text(text)
    with pytest.raises(ValueError, match=message) as info:
        DriveTrain.load(path)
    assert str(info.value).startswith(str(path))


def test_missing_drive_file_is_named(tmp_path) -> None:
    path = tmp_path / "absent.json"
    with pytest.raises(ValueError, match="absent.json: no such drive file"):
        DriveTrain.load(path)


# -- validation -----------------------------------------------------------------------------------
def _drive(**changes: Any) -> DriveTrain:
    args: dict[str, Any] = {"motor": Motor(2, speed_hz=20.0), "stages": (), "lifters": 16}
    return DriveTrain(**{**args, **changes})


@pytest.mark.parametrize(
    ("make", "message"),
    [
        (lambda: Motor(0, supply_hz=50),
         r"Motor.pole_pairs = 0 is not valid; it must be an integer in \[1, 1000\]"),
        (lambda: Motor(2.0, supply_hz=50), r"Motor.pole_pairs = 2.0 is not valid"),
        (lambda: Motor(True, supply_hz=50), r"Motor.pole_pairs = True is not valid"),
        (lambda: Motor(2), "give exactly one of supply_hz and speed_hz; got supply_hz = None, "
                           "speed_hz = None"),
        (lambda: Motor(2, supply_hz=50, speed_hz=20),
         "give exactly one of supply_hz and speed_hz; got supply_hz = 50, speed_hz = 20"),
        (lambda: Motor(2, supply_hz=-50),
         r"Motor.supply_hz = -50 Hz is not valid; it must be a finite number in \(0, 10000\] Hz"),
        (lambda: Motor(2, supply_hz=float("nan")), r"Motor.supply_hz = nan Hz is not valid"),
        (lambda: Motor(2, speed_hz=0.0),
         r"Motor.speed_hz = 0.0 Hz is not valid; .* in \(0, 10000\] Hz"),
        (lambda: Motor(2, supply_hz=50, slip=1.0),
         r"Motor.slip = 1.0 is not valid; it must be a number in \[0, 1\)"),
        (lambda: Motor(2, supply_hz=50, slip=-0.1), r"Motor.slip = -0.1 is not valid"),
        (lambda: Motor(2, supply_hz=50, slip="0.1"), r"Motor.slip = '0.1' is not valid"),
        (lambda: Motor(2, speed_hz=20, slip=0.04),
         r"Motor.slip = 0.04 is not valid with speed_hz"),
        (lambda: GearStage(driver_teeth=18),
         "give both driver_teeth and driven_teeth, or a ratio; got driver_teeth = 18, "
         "driven_teeth = None"),
        (lambda: GearStage(), "give both driver_teeth and driven_teeth, or a ratio"),
        (lambda: GearStage(ratio=0.0),
         r"GearStage.ratio = 0.0 is not valid; .* in \[0.001, 1000\]"),
        (lambda: GearStage(ratio=float("inf")), r"GearStage.ratio = inf is not valid"),
        (lambda: GearStage(driver_teeth=0, driven_teeth=3),
         r"GearStage.driver_teeth = 0 is not valid; it must be an integer in \[1, 10000\]"),
        (lambda: GearStage(driver_teeth=3, driven_teeth=-3),
         r"GearStage.driven_teeth = -3 is not valid"),
        (lambda: GearStage(driver_teeth=18.5, ratio=5.0),
         r"GearStage.driver_teeth = 18.5 is not valid"),
        (lambda: GearStage(18, 105, ratio=5.8),
         "give the ratio or both tooth counts, not both; got ratio = 5.8, driver_teeth = 18, "
         "driven_teeth = 105"),
        (lambda: GearStage(ratio=5.0, name=""), "GearStage.name = '' is not valid"),
        (lambda: _drive(lifters=0),
         r"DriveTrain.lifters = 0 is not valid; it must be an integer in \[1, 10000\]"),
        (lambda: _drive(motor=23.0), r"DriveTrain.motor = 23.0 is not valid; it must be a Motor"),
        (lambda: _drive(stages=GearStage(ratio=2.0)),
         r"DriveTrain.stages = GearStage\(.*\) is not valid; it must be a tuple of GearStage"),
        (lambda: _drive(stages=(GearStage(ratio=2.0), 3.0)),
         r"DriveTrain.stages\[1\] = 3.0 is not valid; it must be a GearStage"),
        (lambda: DriveTrain.from_mill_speed(-0.6, (), 16),
         r"mill_hz = -0.6 is not valid; it must be a finite number > 0 Hz"),
        (lambda: _drive().interference_lines(max_hz=0.0), r"max_hz = 0.0 is not valid; .* > 0"),
        (lambda: _drive().frequencies_hz(max_hz=-5), r"max_hz = -5 is not valid"),
        (lambda: InterferenceLine("mill turn", 0.0, "mill"),
         r"InterferenceLine.frequency_hz = 0.0 is not valid"),
        (lambda: InterferenceLine("", 1.0, "mill"), r"InterferenceLine.name = '' is not valid"),
    ],
)
def test_validation_names_parameter_and_value(make, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        make()


def test_values_are_frozen() -> None:
    drive = paper_rig()
    with pytest.raises(AttributeError):
        drive.lifters = 8  # type: ignore[misc]
    assert hash(drive) == hash(paper_rig())


# -- decimation -----------------------------------------------------------------------------------
def _fft_amplitude(x: np.ndarray, fs: float, f: float) -> float:
    """Amplitude of a sinusoid at f, which must fall on an FFT bin of x."""
    k = f * x.size / fs
    assert abs(k - round(k)) < 1e-9
    return float(np.abs(np.fft.rfft(x))[round(k)] * 2 / x.size)


@pytest.mark.parametrize(("f_high", "f_alias"), [(130.0, 30.0), (63.9, 36.1)])
def test_decimation_keeps_the_band_and_rejects_what_would_alias(f_high: float,
                                                                f_alias: float) -> None:
    """1 kHz to 100 Hz: 130 Hz would fold onto 30 Hz, the rig's 63.9 Hz mesh onto 36.1 Hz."""
    fs, n, t0 = 1000.0, 30000, 2.5
    t = t0 + np.arange(n) / fs
    x = 3.0 * np.sin(2 * np.pi * 5.0 * t) + 2.0 * np.sin(2 * np.pi * f_high * t)
    t2, y = decimate(t, x, 100.0)
    assert y.size == 3000 and t2.size == 3000
    assert t2[0] == t0
    np.testing.assert_allclose(np.diff(t2), 0.01, rtol=1e-9)

    body = slice(500, 2500)  # 20 s away from the ends: whole periods of 5 Hz and of the alias
    assert _fft_amplitude(y[body], 100.0, 5.0) == pytest.approx(3.0, rel=0.01)
    naive = x[::10][body]  # plain sample dropping: the line folds in at full amplitude
    assert _fft_amplitude(naive, 100.0, f_alias) == pytest.approx(2.0, rel=0.01)
    assert _fft_amplitude(y[body], 100.0, f_alias) < 2.0 * 10 ** (-40 / 20)  # >= 40 dB down


def test_decimation_with_a_rational_ratio() -> None:
    """2048 Hz to 100 Hz is up 25, down 512."""
    fs, n = 2048.0, 2048 * 30
    t = np.arange(n) / fs
    x = 1.5 * np.cos(2 * np.pi * 7.0 * t) + np.sin(2 * np.pi * 180.0 * t)  # 180 -> 20 Hz
    t2, y = decimate(t, x, 100.0)
    assert y.size == 3000
    np.testing.assert_allclose(np.diff(t2), 0.01, rtol=1e-9)
    assert _fft_amplitude(y[500:2500], 100.0, 7.0) == pytest.approx(1.5, rel=0.01)
    assert _fft_amplitude(y[500:2500], 100.0, 20.0) < 10 ** (-40 / 20)


def test_decimation_leaves_mean_and_drift_without_edge_transients() -> None:
    t = np.arange(5000) / 1000.0
    x = 20.0 + 0.5 * t  # a mean torque of 20 N m drifting by 0.5 N m/s
    t2, y = decimate(t, x, 100.0)
    np.testing.assert_allclose(y, 20.0 + 0.5 * t2, atol=1e-9)
    # scipy's default zero padding would ramp the first samples down from 20 N m
    assert abs(ss.resample_poly(x, 1, 10)[0] - 20.0) > 1.0


@pytest.mark.parametrize(
    ("time_s", "torque", "target_hz", "message"),
    [
        (np.arange(100) / 100.0, np.zeros(100), 200.0,
         r"target_hz = 200.0 is not valid; it must be in \(0, 100\) Hz"),
        (np.arange(100) / 100.0, np.zeros(100), 100.0, r"target_hz = 100.0 is not valid"),
        (np.arange(100) / 100.0, np.zeros(100), 0.0, r"target_hz = 0.0 is not valid"),
        (np.arange(100) / 100.0, np.zeros(100), float("nan"), r"target_hz = nan is not valid"),
        (np.arange(20000) / 10000.0, np.zeros(20000), 5.0,
         r"target_hz = 5.0 is not valid for a record sampled at 10000 Hz"),
        (np.arange(100) / 100.0, np.zeros(99), 10.0, "time_s has 100 samples but torque has 99"),
        (np.zeros((2, 50)), np.zeros((2, 50)), 10.0, "must be 1-D arrays"),
        (np.array([0.0]), np.array([1.0]), 10.0, "at least 2 samples"),
        (np.array([0.0, 0.01, 0.03, 0.04]), np.zeros(4), 10.0, "sampling is not uniform"),
        (np.array([0.0, 0.02, 0.01, 0.03]), np.zeros(4), 10.0, "not strictly increasing"),
        (np.arange(4) / 100.0, np.array([0.0, np.nan, 1.0, 2.0]), 10.0,
         r"torque\[1\] = nan is not finite"),
    ],
)
def test_decimation_refuses_bad_input(time_s, torque, target_hz: float, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        decimate(time_s, torque, target_hz)


def test_decimate_record_brings_a_fast_record_to_the_band() -> None:
    """1 kHz to 2.5 x 50 Hz; a record already at or below that rate is returned as it is."""
    t = np.arange(4000) / 1000.0
    fast = ms.TorqueRecord(t, 100.0 + np.sin(2 * np.pi * 9.0 * t), {"lifters": 16})
    slow = decimate_record(fast, 50.0)
    assert slow.sample_rate_hz == pytest.approx(DECIMATE_FACTOR * 50.0)
    assert slow.meta == {"lifters": 16, "decimated_to_hz": 125.0}
    _, xs = decimate(fast.time_s, fast.torque_Nm, 125.0)
    np.testing.assert_array_equal(slow.torque_Nm, xs)
    assert decimate_record(slow, 50.0) is slow
    with pytest.raises(ValueError, match="band_hz = 0 is not valid"):
        decimate_record(fast, 0)

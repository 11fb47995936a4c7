"""Drive-train lines of the paper's rig (section 5, 6.5, Table 7) and decimation."""

from __future__ import annotations

import json

import numpy as np
import pytest

from millscope.drivetrain import DriveTrain, GearStage, Motor, decimate

PINION_HZ, PINION_TEETH, TOTAL_RATIO = 3.55, 18, 36.27


def paper_rig(mill_hz: float = 0.61) -> DriveTrain:
    """Two stages reproducing the paper's numbers: total ratio 36.27, pinion at 3.55 Hz."""
    pinion_to_mill = PINION_HZ / mill_hz
    return DriveTrain.from_mill_speed(
        mill_hz, (GearStage(ratio=TOTAL_RATIO / pinion_to_mill),
                  GearStage(driver_teeth=PINION_TEETH, ratio=pinion_to_mill)), lifters=16)


def test_pinion_mesh_line_is_63_9_hz() -> None:
    lines = {line.name: line.frequency_hz for line in paper_rig().interference_lines()}
    assert lines["stage 2 gear mesh"] == pytest.approx(PINION_TEETH * PINION_HZ, rel=1e-9)
    assert lines["stage 2 gear mesh"] == pytest.approx(63.9)


def test_table_7_lines_of_the_rig() -> None:
    drive = paper_rig()
    motor_hz = drive.motor.shaft_hz
    assert drive.total_ratio == pytest.approx(TOTAL_RATIO, rel=1e-12)
    assert drive.mill_hz == pytest.approx(motor_hz / TOTAL_RATIO, rel=1e-12)
    lines = drive.interference_lines(max_hz=50.0)
    freqs = [line.frequency_hz for line in lines]
    assert freqs == sorted(freqs)
    by_name = {line.name: line.frequency_hz for line in lines}
    assert by_name["mill turn"] == pytest.approx(0.61)
    assert by_name["2 x mill turn"] == pytest.approx(1.22)
    assert by_name["LTH"] == pytest.approx(16 * 0.61)
    assert by_name["stage 1 output shaft turn"] == pytest.approx(PINION_HZ)
    assert by_name["motor turn"] == pytest.approx(0.61 * TOTAL_RATIO)
    assert "stage 2 gear mesh" not in by_name  # 63.9 Hz lies above the 50 Hz band
    assert 16 * 0.61 not in drive.frequencies_hz(max_hz=50, include_lth=False)


def test_motor_speed_from_supply_and_slip() -> None:
    # the paper's four-pole motor fed at 46 Hz by the drive, 4 % slip
    assert Motor(2, supply_hz=46.0, slip=0.04).shaft_hz == pytest.approx(46 / 2 * 0.96)
    teeth = GearStage(driver_teeth=18, driven_teeth=105)
    assert teeth.speed_ratio == pytest.approx(105 / 18)


def test_from_mill_speed_matches_the_direct_construction() -> None:
    stages = (GearStage(driver_teeth=20, driven_teeth=80), GearStage(ratio=9.0))
    direct = DriveTrain(Motor(2, speed_hz=24.0), stages, lifters=16)
    back = DriveTrain.from_mill_speed(direct.mill_hz, stages, lifters=16)
    assert back.motor.shaft_hz == pytest.approx(24.0, rel=1e-12)
    pairs = zip(back.interference_lines(), direct.interference_lines(), strict=True)
    for mine, theirs in pairs:
        assert mine.name == theirs.name
        assert mine.frequency_hz == pytest.approx(theirs.frequency_hz, rel=1e-12)


def test_json_round_trip(tmp_path) -> None:
    drive = paper_rig()
    path = tmp_path / "drive.json"
    path.write_text(json.dumps(drive.to_dict()))
    assert DriveTrain.load(path) == drive


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("{", "not valid JSON"),
        ("[]", "expected a JSON object"),
        ('{"motor": {"pole_pairs": 2, "speed_hz": 20}, "lifters": 16}', "missing key stages"),
        ('{"motor": 3, "stages": [], "lifters": 16}', "'motor' must be an object"),
        ('{"motor": {"pole_pairs": 2, "speed_hz": 20}, "stages": [{"ratio": 2, "teeth": 3}], '
         '"lifters": 16}', "unexpected keyword argument 'teeth'"),
        ('{"motor": {"pole_pairs": 0, "speed_hz": 20}, "stages": [], "lifters": 16}',
         "Motor.pole_pairs = 0 is not valid"),
    ],
)
def test_bad_drive_files_name_file_and_problem(tmp_path, text: str, message: str) -> None:
    path = tmp_path / "drive.json"
    path.write_text(text)
    with pytest.raises(ValueError, match=message) as info:
        DriveTrain.load(path)
    assert "drive.json" in str(info.value)


@pytest.mark.parametrize(
    ("make", "message"),
    [
        (lambda: Motor(0, supply_hz=50), "Motor.pole_pairs = 0 is not valid; it must be an "
                                         "integer >= 1"),
        (lambda: Motor(2), "exactly one of supply_hz and speed_hz"),
        (lambda: Motor(2, supply_hz=50, speed_hz=20), "exactly one of supply_hz and speed_hz"),
        (lambda: Motor(2, supply_hz=-50), "Motor.supply_hz = -50 is not valid"),
        (lambda: Motor(2, supply_hz=50, slip=1.0), r"Motor.slip = 1.0 is not valid; .*\[0, 1\)"),
        (lambda: GearStage(driver_teeth=18), "give both driver_teeth and driven_teeth, or a ratio"),
        (lambda: GearStage(ratio=0.0), "GearStage.ratio = 0.0 is not valid"),
        (lambda: GearStage(driver_teeth=0, driven_teeth=3), "GearStage.driver_teeth = 0"),
        (lambda: GearStage(18, 105, ratio=5.8), "the ratio or both tooth counts, not both"),
        (lambda: DriveTrain(Motor(2, speed_hz=20), (), lifters=0), "DriveTrain.lifters = 0"),
    ],
)
def test_validation_names_parameter_and_value(make, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        make()


def _amplitude_at(x: np.ndarray, fs: float, f: float) -> float:
    spec = np.abs(np.fft.rfft(x)) * 2 / x.size
    return float(spec[int(round(f * x.size / fs))])


def test_decimation_keeps_the_band_and_rejects_what_would_alias() -> None:
    fs, n = 1000.0, 20000
    t = np.arange(n) / fs
    x = 3.0 * np.sin(2 * np.pi * 5 * t) + 2.0 * np.sin(2 * np.pi * 130 * t)  # 130 -> 30 Hz alias
    t2, y = decimate(t, x, 100.0)
    np.testing.assert_allclose(np.diff(t2), 0.01, rtol=1e-9)
    assert t2[0] == 0.0
    body = y[200:-200]  # away from the filter's edge transients
    assert _amplitude_at(body, 100.0, 5.0) == pytest.approx(3.0, rel=0.01)
    naive = x[::10][200:-200]  # plain sample dropping aliases 130 Hz onto 30 Hz
    assert _amplitude_at(naive, 100.0, 30.0) == pytest.approx(2.0, rel=0.01)
    assert _amplitude_at(body, 100.0, 30.0) < 2.0 * 10 ** (-40 / 20)  # at least 40 dB down


def test_decimation_refuses_upsampling() -> None:
    t = np.arange(100) / 100.0
    with pytest.raises(ValueError, match=r"target_hz = 200.0 is not valid; it must be in "
                                         r"\(0, 100\) Hz"):
        decimate(t, np.sin(t), 200.0)

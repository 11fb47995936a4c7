"""Option values far outside what the code can do are refused up front, with their valid range
(issue 25, item 8): one error line and exit code 2, before any case runs."""

from __future__ import annotations

import json
import math

import pytest

from millscope.cli import main
from millscope.fit import Calibration
from millscope.logfit import log_fit
from millscope.presets import pilot_mill
from millscope.synthetic import SyntheticTorque, synthetic_record

CONTENT = SyntheticTorque()
LTH = CONTENT.lifters * CONTENT.rotation_hz
STEEL = pilot_mill(0.71, None, 1, "tiny").material("steel")
#: The bar wave speed sqrt(E / rho), E = 2 G (1 + nu), of the tiny scale's steel, m/s.
SOUND = math.sqrt(2 * STEEL.shear_modulus * (1 + STEEL.poisson) / STEEL.density)


@pytest.fixture
def files(tmp_path):
    """A 40 s record, a calibration of 10 s blocks and the tiny pilot mill's scene."""
    record = tmp_path / "long.csv"
    synthetic_record(2, content=CONTENT, seed=9, duration_s=40.0).to_csv(record)
    fit = log_fit([1.0, 2.0, 3.0, 4.0], [1.0, 0.71, 0.55, 0.43])
    cal = Calibration(fit=fit, reference_energy=2e4, lifters=CONTENT.lifters,
                      rotation_hz=CONTENT.rotation_hz, block_s=10.0, band_hz=50.0)
    scene = pilot_mill(0.71, None, 1, "tiny").to_dict()
    return {"record": str(record), "cal": str(cal.save(tmp_path / "cal.json")),
            "scene": scene, "tmp": tmp_path}


def _scene_file(files, change) -> str:
    data = json.loads(json.dumps(files["scene"]))
    change(data)
    path = files["tmp"] / "scene.json"
    path.write_text(json.dumps(data))
    return str(path)


CASES = [
    # an hour of rotation per case at most (RunSettings.MAX_DURATION_S)
    (lambda f: ["demo", "--duration", "1e308", "--out", str(f["tmp"] / "demo"),
                "--no-progress"],
     "DemoPlan.duration_s = 1e+308 is not valid; it must be a number in [0, 3600] s"),
    (lambda f: ["study", "accuracy", "--record", "1e308", "--vary-shear", "0.5", "--out",
                str(f["tmp"] / "study"), "--no-progress"],
     "Setting.record_s = 1e+308 s is not valid; it must be in (0, 3598] s"),
    (lambda f: ["study", "accuracy", "--warm-up", "1e308", "--vary-shear", "0.5", "--out",
                str(f["tmp"] / "study"), "--no-progress"],
     "Setting.warm_up_s = 1e+308 s is not valid; it must be in [0, 3600] s"),
    # removed bands no wider than the LTH frequency (the energy was 0, "0.0 % kept", exit 0)
    (lambda f: ["analyze", f["record"], "--lifters", "16", "--rotation-hz",
                str(CONTENT.rotation_hz), "--out", str(f["tmp"]), "--bandwidth", "1e308"],
     f"bandwidth = 1e+308 Hz is not valid; it must be a finite number in (0, {LTH:g}] Hz"),
    # a step of at most the record's length
    (lambda f: ["monitor", f["record"], "--calibration", f["cal"], "--step", "1e308"],
     "step_s = 1e+308 is not valid; it must be in (0, 40] s"),
    # impacts slower than sound in the softest material (tiny scale: G x 0.001)
    (lambda f: ["advise", "--scale", "tiny", "--impact-speed", "1e308"],
     f"impact_speed = 1e+308 m/s is not valid; it must be in (0, {SOUND:.4g}] m/s"),
    (lambda f: ["advise", "--scene", _scene_file(
        f, lambda d: d["pairs"][0].update(restitution=5e-324))],
     "Pair.restitution = 5e-324 is not valid; it must be in [0.01, 1]"),
    (lambda f: ["advise", "--scene", _scene_file(f, lambda d: d["drum"].update(diameter=1e200))],
     "Drum.diameter = 1e+200 m is not valid; it must be in [0.05, 20] m"),
]


@pytest.mark.parametrize(("args", "message"), CASES)
def test_an_absurd_value_is_one_line_and_exit_2(files, capsys, args, message) -> None:
    """Each used to end in a traceback (OverflowError, ZeroDivisionError, RuntimeError from
    the contact probe) or in a silent result and exit 0 (one window for --step, an energy of
    0 for --bandwidth)."""
    code = main(args(files))
    captured = capsys.readouterr()
    assert code == 2, captured.out
    assert captured.err.count("\n") == 1 and message in captured.err, captured.err
    assert not (files["tmp"] / "demo").exists() and not (files["tmp"] / "study").exists()


def test_the_largest_values_in_range_are_taken(files, capsys) -> None:
    """The bounds are not too tight: a step of the whole record, an impact just below the
    speed of sound and a restitution of 0.01 are advised on."""
    assert main(["monitor", files["record"], "--calibration", files["cal"], "--step",
                 "40"]) == 0
    assert main(["advise", "--scale", "tiny", "--impact-speed", f"{0.999 * SOUND}"]) == 0
    scene = _scene_file(files, lambda d: d["pairs"][0].update(restitution=0.01))
    assert main(["advise", "--scene", scene]) == 0
    assert "error" not in capsys.readouterr().err

"""Calibration, drive and scene files are untrusted input (issue 25, item 7).

Every field of a valid file is replaced by values of a hostile family (wrong types, bools for
integers, NaN, infinities, 1e308, 5e-324, negative numbers, huge integers, nested containers):
the loader either raises its format's error (CalibrationError, DriveError, SceneError) or
returns an object that passes the format's checks again and computes finite numbers; never
another exception. The command line (``monitor --calibration``, ``analyze --drive``,
``advise --scene``) ends such a file with one error line and exit code 2.
"""

from __future__ import annotations

import copy
import json
import math
import warnings
from collections.abc import Callable
from typing import Any

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import millscope as ms
from millscope.cli import main
from millscope.drivetrain import DriveError, DriveTrain
from millscope.fit import CalibrationError
from millscope.presets import pilot_mill
from millscope.scene import Scene, SceneError
from millscope.synthetic import SyntheticTorque, synthetic_record

CONTENT = SyntheticTorque()
HOSTILE = [None, True, False, 0, -1, 2, 0.0, -0.5, 5e-324, 1e308, -1e308, math.nan, math.inf,
           -math.inf, 10**400, "", "16", [], [1.0], {}, {"a": 1}, [[[[]]]]]


def calibration_data() -> dict[str, Any]:
    levels = np.arange(1.0, 6.0)
    fit = ms.log_fit(levels, 1.0 - 0.4 * np.log(levels) + 0.01 * np.sin(3 * levels))
    cal = ms.Calibration(fit=fit, reference_energy=2.5e4, lifters=CONTENT.lifters,
                         rotation_hz=CONTENT.rotation_hz, block_s=10.0, band_hz=50.0,
                         block_relative_std=0.05, extra_lines_hz=(12.5,), label="test")
    data = {"format": "millscope-calibration-2",
            **json.loads(json.dumps(cal.__dict__, default=lambda o: o.__dict__))}
    data["fit"] = {k: v for k, v in data["fit"].items()}
    return data


def drive_data() -> dict[str, Any]:
    return {"motor": {"pole_pairs": 2, "supply_hz": 46.0, "slip": 0.038},
            "stages": [{"ratio": 6.2315, "name": "lumped"},
                       {"driver_teeth": 18, "ratio": 5.8204, "name": "pinion-crown"}],
            "lifters": 16}


def scene_data() -> dict[str, Any]:
    return pilot_mill(0.71, "ceramic", 1, "tiny").to_dict()


def _paths(node: Any, prefix: tuple[Any, ...] = ()) -> list[tuple[Any, ...]]:
    """Every place in a JSON tree (inner ones too), as key/index paths."""
    out = [prefix] if prefix else []
    if isinstance(node, dict):
        for k, v in node.items():
            out += _paths(v, (*prefix, k))
    elif isinstance(node, list):
        for i, v in enumerate(node):
            out += _paths(v, (*prefix, i))
    return out


def _mutated(data: Any, path: tuple[Any, ...], value: Any) -> Any:
    out = copy.deepcopy(data)
    node = out
    for key in path[:-1]:
        node = node[key]
    node[path[-1]] = value
    return out


# -- what a loaded object must satisfy -------------------------------------------------------


def _calibration_is_sound(cal: ms.Calibration, tmp_path) -> None:
    """Saved and loaded again it is the same; its fit is one a least-squares fit of per-unit
    energies can be; and a block analysed with it gives a finite level or a ValueError."""
    assert ms.Calibration.load(cal.save(tmp_path / "again.json")) == cal
    fit = cal.fit
    assert type(fit.n) is int and fit.n >= 2 and type(cal.lifters) is int
    for v in (fit.a, fit.b, fit.r2, fit.x_min, fit.x_max, fit.ln_x_mean, fit.ln_x_sxx,
              cal.reference_energy, cal.rotation_hz, cal.block_s, cal.bandwidth):
        assert isinstance(v, float) and math.isfinite(v)
    assert 0 < fit.x_min < fit.x_max and fit.ln_x_sxx > 0 and 0 <= fit.r2 <= 1 and fit.a != 0
    if not 1.0 <= cal.block_s <= 10.0:
        return  # no 100 Hz block of the synthetic record has that length
    block = synthetic_record(2, content=CONTENT, seed=1).block(4.0, 4.0 + cal.block_s)
    if abs(block.duration_s - cal.block_s) < block.dt:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            try:
                est = ms.estimate_fill(block, cal)
            except ValueError:
                return
        assert math.isfinite(est.level)


def _drive_is_sound(drive: DriveTrain, tmp_path) -> None:
    assert DriveTrain.from_dict(json.loads(json.dumps(drive.to_dict()))) == drive
    lines = drive.frequencies_hz()
    assert lines and all(math.isfinite(f) and f > 0 for f in lines)


def _scene_is_sound(scene: Scene, tmp_path) -> None:
    assert Scene.from_dict(json.loads(json.dumps(scene.to_dict()))) == scene
    t, _ = scene.min_rayleigh_time()
    for v in (t, scene.charge_mass(), scene.drum.free_volume, scene.omega,
              ms.stiffness.upper_impact_speed(scene)):
        assert math.isfinite(v)
    assert t > 0


FORMATS: dict[str, tuple[Callable[[], Any], Callable[[Any], Any], type[ValueError],
                         Callable[[Any, Any], None]]] = {
    "calibration": (calibration_data, ms.Calibration.load, CalibrationError,
                    _calibration_is_sound),
    "drive": (drive_data, DriveTrain.load, DriveError, _drive_is_sound),
    "scene": (scene_data, Scene.load, SceneError, _scene_is_sound),
}


@pytest.mark.parametrize("kind", FORMATS)
def test_the_valid_file_loads(kind: str, tmp_path) -> None:
    make, load, _, sound = FORMATS[kind]
    path = tmp_path / f"{kind}.json"
    path.write_text(json.dumps(make()))
    sound(load(path), tmp_path)


@pytest.mark.parametrize("kind", FORMATS)
@settings(max_examples=150, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(data=st.data())
def test_every_field_mutated_gives_the_format_error_or_a_sound_object(kind: str, tmp_path,
                                                                        data) -> None:
    make, load, error, sound = FORMATS[kind]
    valid = make()
    path_in_tree = data.draw(st.sampled_from(_paths(valid)), label="field")
    value = data.draw(st.sampled_from(HOSTILE), label="value")
    file = tmp_path / f"{kind}.json"
    file.write_text(json.dumps(_mutated(valid, path_in_tree, value)))
    try:
        loaded = load(file)
    except error as exc:
        message = str(exc)
        assert message.startswith(str(file)) and "\n" not in message.strip()
        return
    sound(loaded, tmp_path)


# -- named cases and the command line --------------------------------------------------------

CALIBRATION_CASES = [
    (("fit", "n"), True, "Calibration.fit.n = True is not valid; it must be an integer"),
    (("fit", "n"), 4.0, "Calibration.fit.n = 4.0 is not valid"),
    (("fit", "r2"), 1e308, "Calibration.fit.r2 = 1e+308 is not valid; it must be a finite "
                           "number in [0, 1]"),
    (("fit", "x_min"), 9.0, "Calibration.fit.x_max = 5.0 is not valid"),
    (("fit", "b"), math.nan, "Calibration.fit.b = nan is not valid"),
    (("fit", "b"), None, "Calibration.fit.b = None is not valid"),
    (("fit", "ln_x_sxx"), 0, "Calibration.fit.ln_x_sxx = 0 is not valid"),
    (("fit", "a"), 1e308, "Calibration.fit.a = 1e+308, b = "),
    (("fit", "a_stderr"), 0.5, "Calibration.fit.a_stderr = 0.5 is not valid; it must be"),
    (("lifters",), True, "Calibration.lifters = True is not valid"),
    (("rotation_hz",), "0.54", "Calibration.rotation_hz = '0.54' is not valid"),
    (("band_hz",), -50, "Calibration.band_hz = -50 Hz is not valid"),
    (("extra_lines_hz",), [[1]], "Calibration.extra_lines_hz[0] = [1] is not valid"),
]


@pytest.mark.parametrize(("where", "value", "message"), CALIBRATION_CASES)
def test_monitor_refuses_a_mutated_calibration_in_one_line(tmp_path, capsys, where, value,
                                                           message) -> None:
    """Each of these used to load as it was (n: true, r2: 1e308, x_min > x_max, b: NaN ...)
    and monitor printed nan levels with exit 0, or a traceback."""
    cal = tmp_path / "cal.json"
    cal.write_text(json.dumps(_mutated(calibration_data(), where, value)))
    record = tmp_path / "long.csv"
    synthetic_record(2, content=CONTENT, seed=5, duration_s=20.0).to_csv(record)
    code = main(["monitor", str(record), "--calibration", str(cal)])
    captured = capsys.readouterr()
    assert code == 2 and captured.out == ""
    assert captured.err.count("\n") == 1 and message in captured.err, captured.err


def _deep(depth: int) -> str:
    return "[" * depth + "]" * depth


@pytest.mark.parametrize("kind, option", [("calibration", "--calibration"),
                                          ("drive", "--drive"), ("scene", "--scene")])
@pytest.mark.parametrize("content, message", [
    ("/dev/zero", "larger than 4194304 bytes"),
    (_deep(100_000), "nested too deeply"),
    ("\xff\xfe{", "not a UTF-8 text file"),
    ('{"a": 1' + "0" * 5000 + "}", "not valid JSON"),
    ("[]", ""),
])
def test_the_command_line_ends_a_bad_file_in_one_line(tmp_path, capsys, kind, option, content,
                                                      message) -> None:
    """/dev/zero used to be read without limit, deep nesting raised RecursionError."""
    if content == "/dev/zero":
        path = content
    else:
        path = str(tmp_path / f"{kind}.json")
        with open(path, "w", encoding="latin-1") as fh:
            fh.write(content)
    record = tmp_path / "rec.csv"
    synthetic_record(2, content=CONTENT, seed=5, duration_s=20.0).to_csv(record)
    args = {"calibration": ["monitor", str(record), "--calibration", path],
            "drive": ["analyze", str(record), "--lifters", "16", "--rotation-hz",
                      str(CONTENT.rotation_hz), "--out", str(tmp_path), "--drive", path],
            "scene": ["advise", "--scene", path]}[kind]
    code = main(args)
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and err.startswith(f"millscope: error: {path}")
    assert message in err


@pytest.mark.parametrize("where, value, message", [
    (("drum", "diameter"), 1e200, "Drum.diameter = 1e+200 m is not valid; it must be in "
                                  "[0.05, 20] m"),
    (("pairs", 0, "restitution"), 5e-324, "Pair.restitution = 5e-324 is not valid; it must be "
                                          "in [0.01, 1]"),
    (("materials", 0, "shear_modulus"), 1e308, "Material.shear_modulus = 1e+308 Pa"),
    (("speed_fraction",), None, "exactly one of them must be given"),
])
def test_advise_refuses_a_scene_out_of_range(tmp_path, capsys, where, value, message) -> None:
    """A 1e200 m drum ended in an OverflowError traceback; a restitution of 5e-324 in a
    RuntimeError from the contact probe (the contact never ends)."""
    path = tmp_path / "scene.json"
    path.write_text(json.dumps(_mutated(scene_data(), where, value)))
    code = main(["advise", "--scene", str(path)])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and message in err, err


@pytest.mark.parametrize("where, value, message", [
    (("motor", "supply_hz"), 1e308, "Motor.supply_hz = 1e+308 Hz is not valid; it must be a "
                                    "finite number in (0, 10000] Hz"),
    (("stages",), [{"ratio": 0.001}] * 120, "give speeds and ratios of a real drive"),
    (("stages", 1, "driver_teeth"), 10**400, "GearStage.driver_teeth = "),
    (("lifters",), 10**400, "DriveTrain.lifters = "),
])
def test_analyze_refuses_a_drive_that_overflows(tmp_path, capsys, where, value,
                                                message) -> None:
    path = tmp_path / "drive.json"
    path.write_text(json.dumps(_mutated(drive_data(), where, value)))
    record = tmp_path / "rec.csv"
    synthetic_record(2, content=CONTENT, seed=5).to_csv(record)
    code = main(["analyze", str(record), "--lifters", "16", "--rotation-hz",
                 str(CONTENT.rotation_hz), "--out", str(tmp_path), "--drive", str(path)])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and message in err, err

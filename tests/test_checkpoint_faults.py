"""A checkpoint is untrusted input: every edited field is refused with a CheckpointError or
the run continues exactly as from the file as saved (issue 25, item 2).

One real checkpoint of a small, fast scene (the tiny pilot mill with ceramic particles: two
sizes, lifters, friction, periodic ends) saved while the drum turns; each test edits one field
of it and loads the result. The reference is the continuation of the unedited file.
"""

from __future__ import annotations

import json
import math
import tempfile
import zipfile
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

import millscope as ms

ARRAYS = ("order", "x", "v", "w", "f", "t", "x_ref", "wall_history", "wall_lifter",
          "list_start", "list_partner", "list_history")
STEPS_PER_SAMPLE, SAMPLES = 5, 4  # the continuation compared: 20 steps
Saved = tuple[Path, np.ndarray]  # the checkpoint and its continuation


def read(path: Path) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
    with np.load(path, allow_pickle=False) as z:
        meta = json.loads(str(z["meta_json"]))
        return meta, {k: z[k] for k in z.files if k != "meta_json"}


def write(path: Path, meta: dict[str, Any], arrays: dict[str, np.ndarray]) -> Path:
    with open(path, "wb") as f:
        np.savez(f, meta_json=np.array(json.dumps(meta)), **arrays)
    return path


def continuation(path: Path) -> np.ndarray:
    """Time and torque of 20 steps from the checkpoint."""
    sim = ms.Simulation.load(path)
    sample_dt = STEPS_PER_SAMPLE * sim.dt
    rec = sim.run(SAMPLES * sample_dt, sample_dt=sample_dt, progress=False)
    return np.column_stack([rec.time_s, rec.torque_Nm])


@pytest.fixture(scope="module")
def saved(tmp_path_factory: pytest.TempPathFactory) -> Saved:
    """The checkpoint, saved 0.03 s after the drum started, and its continuation."""
    scene = ms.presets.pilot_mill(0.71, "ceramic", 1, scale="tiny")
    sim = ms.Simulation(scene, seed=0, threads=1, settle_tolerance=10.0, settle_min_s=0.1,
                        settle_max_s=0.2)
    sim.run(0.03, progress=False)
    path = sim.save(tmp_path_factory.mktemp("ckpt") / "case.npz")
    meta, arrays = read(path)
    # what the mutations below reach: lifter contacts held, a built list, a rotating drum
    assert (arrays["wall_lifter"] >= 0).any() and arrays["list_partner"].size > 0
    assert meta["phase"] == "rotating" and meta["threads"] == 1
    return path, continuation(path)


def edited(saved_path: Path, folder: Path, *, meta_edit: Any = None,
           array_edit: Any = None) -> Path:
    meta, arrays = read(saved_path)
    if meta_edit is not None:
        meta_edit(meta)
    if array_edit is not None:
        array_edit(arrays)
    return write(folder / "edited.npz", meta, arrays)


def refused_or_same(path: Path, reference: np.ndarray) -> str:
    try:
        got = continuation(path)
    except ms.CheckpointError:
        return "refused"
    assert np.array_equal(got, reference)
    return "same"


# -- the cases of the issue -------------------------------------------------------------------

def set_item(key: str, index: int, value: Any) -> Any:
    def edit(arrays: dict[str, np.ndarray]) -> None:
        a = arrays[key].copy()
        a[index] = value
        arrays[key] = a
    return edit


def set_meta(*keys: str, value: Any) -> Any:
    def edit(meta: dict[str, Any]) -> None:
        target = meta
        for k in keys[:-1]:
            target = target[k]
        target[keys[-1]] = value
    return edit


def reverse_order(arrays: dict[str, np.ndarray]) -> None:
    arrays["order"] = arrays["order"][::-1].copy()


def integer_velocities(arrays: dict[str, np.ndarray]) -> None:
    arrays["v"] = arrays["v"].astype(np.int64)


@pytest.mark.parametrize("meta_edit, array_edit, message", [
    (None, set_item("wall_lifter", 0, 2**31 - 1), r"wall_lifter\[0\] = 2147483647 is not "
     r"valid; it must be a lifter index in \[0, 16\) or -1"),
    (set_meta("threads", value=100000), None, r"threads = 100000 is not valid; it must be an "
     r"integer in \[1, \d+\].*pass threads="),
    (None, reverse_order, r"neighbour list is not that of the positions"),
    (set_meta("engine_scalars", "list_builds", value=-1), None,
     r"list_builds = -1 is not valid; it must be an integer in \[0, "),
    (set_meta("phase", value="spinning"), None, r"phase = 'spinning' is not valid; it must be "
     r"one of empty, filled, settled, rotating"),
    (set_meta("dt", value=1e-300), None, r"dt = 1e-300 is not valid; it must be a finite "
     r"number in \[.* s \(0.001 to 0.5 x the Rayleigh time"),
    (None, integer_velocities, r"the dtype of v = 'int64' is not valid; it must be float64"),
    (set_meta("rng_state", "state", "inc", value=-3), None,
     r"rng_state\['state'\]\['inc'\] = -3 is not valid"),
    (set_meta("engine_scalars", "step", value=2**40), None, r"theta = .* is not valid"),
    (None, set_item("list_partner", 0, 0), r"list_partner holds a partner not after its row"),
    # found by the family below: recomputing the forces advances the tangential springs twice
    (set_meta("engine_scalars", "forces_valid", value=False), None,
     r"forces_valid = False is not valid; it must be true at step \d+"),
])
def test_the_edits_of_the_issue_are_refused(saved: Saved, tmp_path: Path, meta_edit: Any,
                                            array_edit: Any, message: str) -> None:
    path = edited(saved[0], tmp_path, meta_edit=meta_edit, array_edit=array_edit)
    with pytest.raises(ms.CheckpointError, match=message):
        ms.Simulation.load(path)


def test_a_checkpoint_of_more_threads_than_here_loads_with_threads_given(
        saved: Saved, tmp_path: Path) -> None:
    """The saved thread count is the default, not a must: threads=1 loads it here."""
    path = edited(saved[0], tmp_path, meta_edit=set_meta("threads", value=100000))
    sim = ms.Simulation.load(path, threads=1)
    assert sim.threads == 1 and sim.phase == "rotating"


def test_a_header_claiming_huge_arrays_is_refused_before_reading(saved: Saved,
                                                               tmp_path: Path) -> None:
    """The .npy header of "x" claims 10^11 values (800 GB) with no data behind it: refused
    from the header, without allocating."""
    path = tmp_path / "huge.npz"
    with zipfile.ZipFile(saved[0]) as src, zipfile.ZipFile(path, "w") as dst:
        for info in src.infolist():
            if info.filename == "x.npy":
                with dst.open("x.npy", "w") as f:
                    np.lib.format.write_array_header_1_0(
                        f, {"descr": "<f8", "fortran_order": False, "shape": (10**11,)})
            else:
                dst.writestr(info, src.read(info))
    with pytest.raises(ms.CheckpointError, match=r"the size of x = 100000000000 is not valid"):
        ms.Simulation.load(path)


@pytest.mark.parametrize("content", [b"", b"PK\x05\x06" + bytes(18), b"\x93NUMPY"])
def test_files_that_are_no_checkpoint_raise_only_checkpoint_error(tmp_path: Path,
                                                                 content: bytes) -> None:
    path = tmp_path / "bad.npz"
    path.write_bytes(content)
    with pytest.raises(ms.CheckpointError, match="damaged or not a millscope checkpoint"):
        ms.Simulation.load(path)


def test_a_truncated_checkpoint_is_refused(saved: Saved, tmp_path: Path) -> None:
    data = saved[0].read_bytes()
    for keep in (len(data) // 3, len(data) - 30):
        path = tmp_path / f"cut{keep}.npz"
        path.write_bytes(data[:keep])
        with pytest.raises(ms.CheckpointError):
            ms.Simulation.load(path)


def test_a_compressed_checkpoint_is_smaller_and_continues_the_same(saved: Saved,
                                                                   tmp_path: Path) -> None:
    """save(compress=True) of the loaded state: fewer bytes, every member deflated, and the
    same continuation to the bit as the file saved plain."""
    path = ms.Simulation.load(saved[0]).save(tmp_path / "deflated.npz", compress=True)
    with zipfile.ZipFile(path) as z:
        assert {info.compress_type for info in z.infolist()} == {zipfile.ZIP_DEFLATED}
    assert path.stat().st_size < saved[0].stat().st_size
    np.testing.assert_array_equal(continuation(path), saved[1])


def test_the_unedited_checkpoint_continues_the_same(saved: Saved, tmp_path: Path) -> None:
    """The reference of the family below: a rewrite of the very same fields loads and
    continues to the bit (so an edit that changes nothing is not refused)."""
    assert refused_or_same(edited(saved[0], tmp_path), saved[1]) == "same"


# -- the family: one field of the checkpoint edited ---------------------------------------------

POOL = [None, True, False, -1, 0, 1, 2**31 - 1, 2**64, 1e-300, 1e308, math.nan, math.inf,
        "x", [], {}, [1.0, 2.0, 3.0]]
META_KEYS = ("format", "millscope_version", "scene", "seed", "dt", "threads", "skin",
             "track_energy", "phase", "settle", "rng_state")
SCALAR_KEYS = ("step", "rotation_start", "last_sample_offset", "list_builds", "theta", "omega",
               "forces_valid", "torque", "ledger")
DTYPES = (np.int32, np.int64, np.uint32, np.float32, np.float64, np.bool_)


@st.composite
def array_edits(draw: st.DrawFn) -> tuple[str, Any]:
    key = draw(st.sampled_from(ARRAYS))
    op = draw(st.sampled_from(["delete", "empty", "drop_last", "append", "2d", "cast", "set"]))
    if op == "cast":
        return key, ("cast", draw(st.sampled_from(DTYPES)))
    if op == "set":
        index = draw(st.integers(0, 10**6))
        integral = key in ("order", "wall_lifter", "list_start", "list_partner")
        if integral:
            value = draw(st.sampled_from([2**31 - 1, 2**32 - 1, 1037, 10**9, -2, -(2**31)]))
        else:
            bounded = key in ("x", "v", "w", "x_ref")  # positions and speeds have bounds
            value = draw(st.sampled_from([math.nan, math.inf, -math.inf]
                                         + ([1e308, -1e308] if bounded else [])))
        return key, ("set", index, value)
    return key, (op,)


def apply_array_edit(arrays: dict[str, np.ndarray], key: str, edit: tuple[Any, ...]) -> None:
    a = arrays[key]
    op = edit[0]
    with np.errstate(all="ignore"):  # the casts may overflow: that is the point
        if op == "delete":
            del arrays[key]
        elif op == "empty":
            arrays[key] = a[:0]
        elif op == "drop_last":
            arrays[key] = a[:-1]
        elif op == "append":
            arrays[key] = np.concatenate([a, a[-1:]])
        elif op == "2d":
            arrays[key] = a.reshape(1, -1)
        elif op == "cast":
            arrays[key] = a.astype(edit[1])
        elif op == "set" and a.size:
            a = a.copy()
            value = edit[2]
            if a.dtype.kind in "iu":
                value = np.array(value, dtype=np.int64).astype(a.dtype)
            a[edit[1] % a.size] = value
            arrays[key] = a


@settings(max_examples=100, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(edit=st.one_of(
    array_edits(),
    st.tuples(st.sampled_from(META_KEYS), st.one_of(st.just(("delete",)),
                                                    st.tuples(st.just("value"),
                                                              st.sampled_from(POOL)))),
    st.tuples(st.sampled_from(SCALAR_KEYS).map(lambda k: "engine_scalars." + k),
              st.one_of(st.just(("delete",)),
                        st.tuples(st.just("value"), st.sampled_from(POOL))))))
def test_an_edited_field_is_refused_or_changes_nothing(saved: Saved,
                                                      edit: tuple[str, Any]) -> None:
    key, change = edit
    meta, arrays = read(saved[0])
    if key in ARRAYS:
        apply_array_edit(arrays, key, change)
    else:
        target = meta
        *parents, last = key.split(".")
        for k in parents:
            target = target[k]
        if change[0] == "delete":
            del target[last]
        else:
            target[last] = change[1]
    with tempfile.TemporaryDirectory() as folder:
        event(refused_or_same(write(Path(folder) / "edited.npz", meta, arrays), saved[1]))

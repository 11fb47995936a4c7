"""TorqueRecord: validation, blocks, CSV and npz I/O, atomic writes."""

from __future__ import annotations

import os

import numpy as np
import pytest

import millscope as ms


def make(n: int = 50, dt: float = 0.01) -> ms.TorqueRecord:
    t = np.arange(n) * dt
    return ms.TorqueRecord(t, 100 + np.sin(t), {"lifters": 16, "rotation_hz": 0.54})


def test_basic_properties() -> None:
    rec = make(1000)
    assert len(rec) == 1000
    assert rec.dt == pytest.approx(0.01)
    assert rec.sample_rate_hz == pytest.approx(100.0)
    assert rec.duration_s == pytest.approx(10.0)  # TR = N dt, so df = 1/TR = 0.1 Hz
    assert rec.mean_torque_Nm == pytest.approx(np.mean(100 + np.sin(rec.time_s)))
    with pytest.raises(ValueError):
        rec.torque_Nm[0] = 1.0  # immutable
    rec.meta["lifters"] = 3
    assert rec.meta["lifters"] == 16


def test_block_takes_t1_inclusive_t2_exclusive() -> None:
    rec = make(1500)
    blk = rec.block(4.0, 14.0)
    assert len(blk) == 1000  # 4.00 .. 13.99 s: the paper's 10 s block at 10 ms
    assert blk.time_s[0] == pytest.approx(4.0) and blk.time_s[-1] == pytest.approx(13.99)
    assert blk.meta["block_s"] == [4.0, 14.0] and blk.meta["lifters"] == 16
    with pytest.raises(ValueError, match=r"block\(t1=20.0, t2=30.0\) holds 0 samples; the record "
                                         r"spans 0 .. 14.99 s"):
        rec.block(20.0, 30.0)
    with pytest.raises(ValueError, match="need finite t1 < t2"):
        rec.block(5.0, 4.0)


@pytest.mark.parametrize(
    ("time", "torque", "message"),
    [
        ([0, 1, 2], [1, np.nan, 3], r"torque_Nm\[1\] = nan is not finite"),
        ([0, np.inf, 2], [1, 2, 3], r"time_s\[1\] = inf is not finite"),
        ([0, 2, 1], [1, 2, 3], "not strictly increasing at sample 2"),
        ([0, 1, 1], [1, 2, 3], "not strictly increasing at sample 2"),
        ([0, 1, 2.5, 3], [1, 2, 3, 4], "sampling is not uniform: step 2 is 1.5 s"),
        ([0, 1, 2], [1, 2], "time_s has 3 samples but torque_Nm has 2"),
        ([0], [1], "at least 2 samples"),
    ],
)
def test_bad_samples_are_refused_with_the_place(time, torque, message: str) -> None:
    with pytest.raises(ms.RecordError, match=message):
        ms.TorqueRecord(time, torque)


def test_meta_must_be_json() -> None:
    with pytest.raises(ms.RecordError, match="JSON-serialisable"):
        ms.TorqueRecord([0, 1], [1, 2], {"x": object()})


@pytest.mark.parametrize("suffix", [".csv", ".npz"])
def test_round_trip_is_exact(tmp_path, suffix: str) -> None:
    rec = ms.TorqueRecord(np.arange(200) * 0.01, np.random.default_rng(1).normal(265, 40, 200),
                          {"lifters": 16, "note": "x,y"})
    path = rec.save(tmp_path / f"r{suffix}")
    back = ms.TorqueRecord.load(path)
    np.testing.assert_array_equal(back.time_s, rec.time_s)
    np.testing.assert_array_equal(back.torque_Nm, rec.torque_Nm)
    assert back.meta == rec.meta
    assert sorted(os.listdir(tmp_path)) == [f"r{suffix}"]  # no temporary file left behind


def test_csv_extra_columns_and_comments(tmp_path) -> None:
    path = tmp_path / "m.csv"
    path.write_text("# measured on the rig\nspeed_rpm,time_s,torque_Nm\n1,0.0,5\n1,0.5,6\n"
                    "\n1,1.0,7\n")
    rec = ms.TorqueRecord.from_csv(path)
    np.testing.assert_array_equal(rec.torque_Nm, [5, 6, 7])


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("time_s,torque\n0,1\n", r"line 1: missing column 'torque_Nm'"),
        ("time_s,torque_Nm\n0,1\n0.1,abc\n", r"line 3: column 'torque_Nm': 'abc' is not a number"),
        ("time_s,torque_Nm\n0,1\n0.1,nan\n0.2,3\n", r"torque_Nm\[1\] = nan is not finite"),
        ("time_s,torque_Nm\n0,1\n0.1,2\n0.3,3\n", "sampling is not uniform"),
        ("time_s,torque_Nm\n0,1\n0.2,2\n0.1,3\n", "not strictly increasing"),
        ("time_s,torque_Nm\n0,1\n0.1\n", r"line 3: column 'torque_Nm' is missing"),
        ("", "no header line"),
        ("# meta: {oops\ntime_s,torque_Nm\n", "meta is not valid JSON"),
    ],
)
def test_bad_csv_says_file_line_and_column(tmp_path, text: str, message: str) -> None:
    path = tmp_path / "bad.csv"
    path.write_text(text)
    with pytest.raises(ms.RecordError, match=message) as info:
        ms.TorqueRecord.from_csv(path)
    assert "bad.csv" in str(info.value)


def test_missing_and_foreign_files(tmp_path) -> None:
    with pytest.raises(ms.RecordError, match="no such file"):
        ms.TorqueRecord.load(tmp_path / "none.csv")
    junk = tmp_path / "junk.npz"
    junk.write_bytes(b"not a zip")
    with pytest.raises(ms.RecordError, match="not a millscope record"):
        ms.TorqueRecord.load(junk)


def test_failed_write_keeps_the_old_file(tmp_path, monkeypatch) -> None:
    path = make().save(tmp_path / "r.npz")
    before = path.read_bytes()

    def boom(*args, **kwargs):
        raise OSError("disk full")

    monkeypatch.setattr(np, "savez", boom)
    with pytest.raises(OSError, match="disk full"):
        make(80).save(path)
    assert path.read_bytes() == before
    assert sorted(os.listdir(tmp_path)) == ["r.npz"]


def test_written_files_follow_the_umask_not_mkstemp(tmp_path) -> None:
    old = os.umask(0o022)
    try:
        path = make().save(tmp_path / "r.npz")
    finally:
        os.umask(old)
    assert path.stat().st_mode & 0o777 == 0o644

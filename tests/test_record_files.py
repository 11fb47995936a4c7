"""Damaged and hostile record files (issue 25, items 6 and 11): each ends in one RecordError
naming the file (the command line: one line, exit code 2), never a traceback, a MemoryError
or a silently different record."""

from __future__ import annotations

import io
import tracemalloc
import zipfile
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import millscope as ms
from millscope.cli import main

SETTINGS = settings(max_examples=60, deadline=None,
                    suppress_health_check=[HealthCheck.function_scoped_fixture])
RECORD = ms.TorqueRecord(np.arange(8) * 0.01, 265.0 + np.arange(8.0), {"lifters": 16})


def npz_bytes(**arrays: np.ndarray) -> bytes:
    buffer = io.BytesIO()
    np.savez(buffer, **arrays)
    return buffer.getvalue()


def good_npz() -> bytes:
    return npz_bytes(time_s=RECORD.time_s, torque_Nm=RECORD.torque_Nm,
                     meta_json=np.array('{"lifters": 16}'))


def forged_npz(count: int, data: bytes) -> bytes:
    """A record whose torque_Nm.npy header claims ``count`` float64 values over ``data``."""
    member = io.BytesIO()
    np.lib.format.write_array_header_1_0(
        member, {"descr": "<f8", "fortran_order": False, "shape": (count,)})
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w") as archive:
        archive.writestr("time_s.npy", npz_member(good_npz(), "time_s.npy"))
        archive.writestr("torque_Nm.npy", member.getvalue() + data)
    return buffer.getvalue()


def npz_member(content: bytes, name: str) -> bytes:
    with zipfile.ZipFile(io.BytesIO(content)) as archive:
        return archive.read(name)


def cli_error(path: Path, capsys: pytest.CaptureFixture[str]) -> str:
    """The command line's one error line for ``path`` (asserting exit code 2)."""
    code = main(["analyze", str(path), "--lifters", "16", "--rotation-hz", "0.55", "--out",
                 str(path.parent / "out")])
    err = capsys.readouterr().err
    assert code == 2 and err.startswith("millscope: error: ") and err.count("\n") == 1, err
    assert len(err) < 600  # one readable line, also for a 200,000-character field
    return err


BAD_FILES = {
    "a CSV field over 131,072 characters (text)": (
        "m.csv", b"time_s,torque_Nm\n0,1\n0.01," + b"x" * 200_000 + b"\n",
        r"line 3: column 'torque_Nm': 'x{40}'... \(200000 characters\) is not a number"),
    "a CSV field over 131,072 characters (digits)": (
        "m.csv", b"time_s,torque_Nm\n0,1\n0.01," + b"9" * 200_000 + b"\n",
        r"torque_Nm\[1\] = inf is not finite"),
    "a quoted CSV header field over 131,072 characters": (
        "m.csv", b"time_s,torque_Nm,\"" + b"y" * 200_000 + b"\"\n0,1,2\n0.01,1,2\n",
        r"line 1: field larger than field limit \(131072\)"),
    "a '# meta:' line that is a list": (
        "m.csv", b"# meta: [1, 2]\ntime_s,torque_Nm\n0,1\n0.01,2\n",
        r"line 1: meta must be a JSON object \{...\}; got list"),
    "a '# meta:' line nested 100,000 deep": (
        "m.csv", b"# meta: " + b"[" * 100_000 + b"\ntime_s,torque_Nm\n0,1\n0.01,2\n",
        r"line 1: meta is (nested too deeply to read|not valid JSON)"),
    "an npz whose meta is a list": (
        "r.npz", npz_bytes(time_s=RECORD.time_s, torque_Nm=RECORD.torque_Nm,
                           meta_json=np.array("[1, 2]")),
        r"meta must be a JSON object \{...\}; got list"),
    "an npz whose meta is a number array": (
        "r.npz", npz_bytes(time_s=RECORD.time_s, torque_Nm=RECORD.torque_Nm,
                           meta_json=np.arange(3.0)),
        r"meta_json.npy holds float64 values, not a text"),
    "an empty npz": ("r.npz", b"", r"not a millscope record \(an empty file"),
    "a truncated npz": ("r.npz", good_npz()[:300], r"not a millscope record \(BadZipFile"),
    "a .npy named .npz": ("r.npz", b"", r"a single .npy array, not a record"),
    "an npz claiming 10^11 values": (
        "r.npz", forged_npz(10**11, b"\0" * 8),
        r"torque_Nm.npy claims shape \(100000000000,\); a record holds 1-D arrays of at "
        r"most 1e\+09 samples"),
    "an npz claiming 10^8 values over 8 bytes": (
        "r.npz", forged_npz(10**8, b"\0" * 8),
        r"torque_Nm.npy claims 100000000 values of float64 \(800000000 bytes\) but holds 8 "
        r"bytes"),
    "an npz with complex torque": (
        "r.npz", npz_bytes(time_s=RECORD.time_s, torque_Nm=RECORD.torque_Nm + 1j),
        r"torque_Nm.npy holds complex128 values, not real numbers"),
    "an npz with object torque": (
        "r.npz", npz_bytes(time_s=RECORD.time_s, torque_Nm=np.array([1, "a"], dtype=object)),
        r"torque_Nm.npy holds object values, not real numbers"),
    "a zip without the record's arrays": (
        "r.npz", npz_bytes(x=np.arange(3)), r"it holds no 'time_s' array \(found \['x.npy'\];"),
    "an npz without its meta": (
        "r.npz", npz_bytes(time_s=RECORD.time_s, torque_Nm=RECORD.torque_Nm),
        r"it holds no 'meta_json' array .* a record holds time_s, torque_Nm and meta_json"),
}


@pytest.mark.parametrize("name", list(BAD_FILES))
def test_a_bad_record_file_is_one_record_error_and_one_cli_line(tmp_path, capsys,
                                                                name: str) -> None:
    filename, content, message = BAD_FILES[name]
    path = tmp_path / filename
    if name == "a .npy named .npz":
        np.save(tmp_path / "a.npy", RECORD.torque_Nm)
        content = (tmp_path / "a.npy").read_bytes()
    path.write_bytes(content)
    with pytest.raises(ms.RecordError, match=message) as info:
        ms.TorqueRecord.load(path)
    assert str(path) in str(info.value)
    assert "millscope: error: " + str(info.value).splitlines()[0] in cli_error(path, capsys)


def test_an_npz_header_is_refused_before_its_claim_is_allocated(tmp_path) -> None:
    """10^8 claimed float64 values would be 800 MB; the refusal allocates next to nothing."""
    path = tmp_path / "r.npz"
    path.write_bytes(forged_npz(10**8, b"\0" * 8))
    tracemalloc.start()
    try:
        with pytest.raises(ms.RecordError, match="claims 100000000 values"):
            ms.TorqueRecord.load(path)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 1_000_000


@SETTINGS
@given(cut=st.integers(min_value=0, max_value=len(good_npz()) - 1))
def test_a_truncated_npz_is_a_record_error(tmp_path, cut: int) -> None:
    path = tmp_path / "r.npz"
    path.write_bytes(good_npz()[:cut])
    with pytest.raises(ms.RecordError, match="r.npz"):
        ms.TorqueRecord.load(path)


@settings(max_examples=150, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(position=st.integers(min_value=0, max_value=len(good_npz()) - 1),
       mask=st.integers(min_value=1, max_value=255))
def test_a_byte_flipped_npz_is_refused_or_reads_the_same_record(tmp_path, position: int,
                                                                mask: int) -> None:
    """A flipped byte either lies where the record does not depend on it (a time stamp of the
    zip, a copy of the CRC that is not checked) or is caught (the CRC, the headers)."""
    content = bytearray(good_npz())
    content[position] ^= mask
    path = tmp_path / "r.npz"
    path.write_bytes(bytes(content))
    try:
        back = ms.TorqueRecord.load(path)
    except ms.RecordError as exc:
        assert "r.npz" in str(exc)
        return
    np.testing.assert_array_equal(back.time_s, RECORD.time_s)
    np.testing.assert_array_equal(back.torque_Nm, RECORD.torque_Nm)
    assert back.meta == RECORD.meta


CSV_FILES = (b'# meta: {"a": 1}\ntime_s,torque_Nm\n0,1\n0.01,2\n0.02,3\n',
             "Mühle\nZeit [s];Drehmoment [kNm]\n0,00;1,5\n0,01;2,5\n0,02;3,5\n".encode("latin-1"),
             b"Timestamp,Torque [Nm]\n2024-03-01T12:00:00.000,1\n2024-03-01T12:00:00.010,2\n"
             b"2024-03-01T12:00:00.020,3\n",
             b'Title\nTime;Torque\ns;Nm\n"0";"1"\n"0.01";"2"\n0.02;3\n')


@settings(max_examples=200, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(base=st.sampled_from(CSV_FILES), position=st.integers(min_value=0, max_value=120),
       inserted=st.sampled_from([b'"', b"\x00", b"\n", b";", b","]) | st.binary(max_size=3),
       removed=st.integers(min_value=0, max_value=4))
def test_an_edited_csv_is_a_record_or_one_record_error(tmp_path, base: bytes, position: int,
                                                       inserted: bytes, removed: int) -> None:
    """Bytes inserted or removed anywhere (a quote left open, a NUL, a line break, a
    separator ...): a record, or a RecordError naming the file; never another exception, a
    warning (errors under pytest) or pandas joining lines."""
    position = min(position, len(base))
    path = tmp_path / "m.csv"
    path.write_bytes(base[:position] + inserted + base[position + removed:])
    try:
        rec = ms.TorqueRecord.load(path)
    except ms.RecordError as exc:
        assert "m.csv" in str(exc)
        return
    assert 2 <= len(rec) <= 3 and np.all(np.isfinite(rec.torque_Nm))


# -- item 11: numbers are ASCII numbers, rows fit the header, torque is real -----------------
@pytest.mark.parametrize(
    ("row", "message"),
    [
        ("0.01,1,5", r"line 3: 3 fields, more than the 2 of the header"),
        ("0.01,1_0", r"line 3: column 'torque_Nm': '1_0' is not a number"),
        ("0.01,١٢", r"line 3: column 'torque_Nm': '١٢' is not a number"),
        ("0.01,２", r"line 3: column 'torque_Nm': '２' is not a number"),
        ("0.01,1+2j", r"line 3: column 'torque_Nm': '1\+2j' is not a number"),
        ('"0.01,2', r'line 3: a quote " is not closed on its line'),  # pandas would join lines
    ],
)
def test_a_row_that_is_not_two_ascii_numbers_is_refused(tmp_path, capsys, row: str,
                                                        message: str) -> None:
    path = tmp_path / "m.csv"
    path.write_text(f"time_s,torque_Nm\n0,1\n{row}\n0.02,3\n")
    with pytest.raises(ms.RecordError, match=message):
        ms.TorqueRecord.from_csv(path)
    cli_error(path, capsys)


@SETTINGS
@given(digits=st.text(st.characters(categories=["Nd"], exclude_characters="0123456789"),
                      min_size=1, max_size=4))
def test_digits_of_other_scripts_are_not_numbers(tmp_path, digits: str) -> None:
    """Python's float() reads '١٢' as 12; a torque file's numbers are ASCII."""
    path = tmp_path / "m.csv"
    path.write_text(f"time_s,torque_Nm\n0,{digits}\n0.01,2\n", encoding="utf-8")
    with pytest.raises(ms.RecordError, match="is not a number"):
        ms.TorqueRecord.from_csv(path)


@pytest.mark.parametrize(
    ("torque", "message"),
    [
        ([1 + 2j, 3], r"torque_Nm is complex \(complex128\); a record holds real values"),
        (np.array([1, 3], dtype=np.complex64), r"torque_Nm is complex \(complex64\)"),
        (["1", "3"], r"torque_Nm holds <U1 values, not real numbers"),
        (np.array([1, 2j], dtype=object), r"torque_Nm holds values that are not real numbers"),
    ],
)
def test_the_constructor_refuses_complex_and_text_torque(torque, message: str) -> None:
    with pytest.raises(ms.RecordError, match=message):
        ms.TorqueRecord([0.0, 0.01], torque)
    with pytest.raises(ms.RecordError, match=message.replace("torque_Nm", "time_s")):
        ms.TorqueRecord(torque, [0.0, 0.01])

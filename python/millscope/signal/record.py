"""Torque records: uniformly sampled drive torque with its metadata, blocks and file I/O.

A :class:`TorqueRecord` is where simulated and measured torque meet. It holds the sample times
``time_s`` (s) and the drive torque ``torque_Nm`` (N m, positive when the charge resists the
rotation, docs/architecture.md, Torque), plus a JSON-serialisable ``meta`` dict (scene, dt,
seed, rotation frequency, lifter count, sampling mode ... whatever produced it).

Files:

* ``.npz`` (default): arrays ``time_s`` and ``torque_Nm`` plus ``meta_json``.
* ``.csv``: a header line ``time_s,torque_Nm`` (other columns are ignored on reading); the meta
  goes on a first comment line ``# meta: {...json...}``.

Both are written atomically (temporary file, then rename). Reading takes plant exports too
(:meth:`TorqueRecord.from_csv`: separators, decimal commas, units, titles, encodings, ISO
times, jittered time stamps). Files are untrusted input: every problem raises
:class:`RecordError` naming the file, and an npz is checked before its arrays are allocated.
"""

from __future__ import annotations

import json
import math
import os
import stat
import zipfile
import zlib
from collections.abc import Mapping
from pathlib import Path
from typing import IO, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._files import atomic_write, read_npy_header
from .._samples import RecordError, bad_option, check_samples, real_option, step_jitter
from ._torque_csv import CsvOptions, parse_meta, read_torque_csv

__all__ = ["TorqueRecord", "RecordError"]

TIME_COLUMN = "time_s"
TORQUE_COLUMN = "torque_Nm"
_META_PREFIX = "# meta:"
MAX_RECORD_SAMPLES = 10**9  # an npz array claiming more is refused before it is read
_NPZ_ERRORS = (zipfile.BadZipFile, zlib.error, OSError, EOFError, ValueError, KeyError,
               NotImplementedError, RuntimeError, OverflowError)  # what a damaged zip raises


def _real_array(values: ArrayLike, name: str) -> NDArray[np.float64]:
    """``values`` as float64; complex, text and other non-real data raise RecordError."""
    array = np.asarray(values)
    kind = array.dtype.kind
    if kind == "c":
        raise RecordError(f"TorqueRecord: {name} is complex ({array.dtype}); a record holds "
                          "real values: pass the real part (or the magnitude) explicitly")
    if kind not in "biufO":
        raise RecordError(f"TorqueRecord: {name} holds {array.dtype} values, not real numbers")
    try:
        return np.array(array, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise RecordError(f"TorqueRecord: {name} holds values that are not real numbers "
                          f"({exc})") from None


def _file_start(source: Path) -> bytes:
    """The first bytes of a regular file; a missing file, a directory or a device raises."""
    try:
        mode = source.stat().st_mode
    except FileNotFoundError:
        raise RecordError(f"{source}: no such file") from None
    if stat.S_ISDIR(mode):
        raise RecordError(f"{source}: is a directory, not a record file")
    if not stat.S_ISREG(mode):
        raise RecordError(f"{source}: not a regular file")
    with source.open("rb") as fh:
        return fh.read(8)


def _npz_member(archive: zipfile.ZipFile, key: str, where: str) -> NDArray[Any]:
    """The array ``key`` of an npz, its npy header checked against the member's size (and a
    sane bound) before the data are read."""
    try:
        info = archive.getinfo(f"{key}.npy")
    except KeyError:
        raise RecordError(f"{where}: not a millscope record: it holds no {key!r} array (found "
                          f"{archive.namelist()[:5]}; a record holds time_s, torque_Nm and "
                          "meta_json, a JSON object as text)") from None
    with archive.open(info) as fp:
        try:
            shape, fortran, dtype = read_npy_header(fp)
        except ValueError as exc:
            raise RecordError(f"{where}: {key}.npy has {exc}") from None
        size = info.file_size - fp.tell()
        count = math.prod(shape)
        wanted = "a text (meta_json)" if key == "meta_json" else "real numbers"
        if dtype.hasobject or dtype.kind not in ("U" if key == "meta_json" else "iuf"):
            raise RecordError(f"{where}: {key}.npy holds {dtype} values, not {wanted}")
        if len(shape) != (0 if key == "meta_json" else 1) or count > MAX_RECORD_SAMPLES:
            raise RecordError(f"{where}: {key}.npy claims shape {shape}; a record holds 1-D "
                              f"arrays of at most {MAX_RECORD_SAMPLES:.0e} samples")
        if count * dtype.itemsize != size:
            raise RecordError(f"{where}: {key}.npy claims {count} values of {dtype} "
                              f"({count * dtype.itemsize} bytes) but holds {size} bytes")
        data = _read_exactly(fp, size)
    return np.frombuffer(data, dtype=dtype).reshape(shape, order="F" if fortran else "C")


def _read_exactly(fp: IO[bytes], size: int) -> bytes:
    """``size`` bytes and the end of ``fp`` (where zipfile checks the CRC)."""
    data = fp.read(size + 1)
    if len(data) != size:
        raise EOFError(f"{size} bytes expected, {len(data)} found")
    return data


def _read_npz(source: Path) -> tuple[NDArray[Any], NDArray[Any], dict[str, Any]]:
    """(time, torque, meta) of an npz record; any damage raises RecordError."""
    where = str(source)
    try:
        with zipfile.ZipFile(source) as archive:
            members = archive.infolist()
            if len(members) > 64:
                raise RecordError(f"{where}: not a millscope record: {len(members)} members; a "
                                  "record has 3 (time_s, torque_Nm, meta_json)")
            for info in members:  # a name differing from its local header raises
                archive.open(info).close()
            time = _npz_member(archive, TIME_COLUMN, where)
            torque = _npz_member(archive, TORQUE_COLUMN, where)
            # meta_json is required (save always writes it): a damaged central directory can
            # hide a member, and a record without its meta would be read as another record
            meta = parse_meta(str(_npz_member(archive, "meta_json", where)[()]), where)
    except RecordError:
        raise
    except _NPZ_ERRORS as exc:
        raise RecordError(f"{where}: not a millscope record ({type(exc).__name__}: "
                          f"{str(exc)[:200]})") from None
    return time, torque, meta


class TorqueRecord:
    """Uniformly sampled drive torque.

    Parameters
    ----------
    time_s : array_like
        Sample times in s; strictly increasing and uniformly spaced.
    torque_Nm : array_like
        Drive torque in N m at those times.
    meta : mapping, optional
        JSON-serialisable facts about the record (``rotation_hz``, ``lifters``, ``sampling`` ...).
    uniform_rtol : float, optional
        Largest allowed deviation of a time step from the mean step, relative to it.

    Raises
    ------
    RecordError
        (a ``ValueError``) for complex or text values, non-finite samples, non-monotonic or
        uneven time, mismatched lengths or fewer than 2 samples; the message names the sample
        and the values.
    """

    __slots__ = ("_time", "_torque", "_meta")

    def __init__(self, time_s: ArrayLike, torque_Nm: ArrayLike,
                 meta: Mapping[str, Any] | None = None, *, uniform_rtol: float = 1e-6) -> None:
        time = _real_array(time_s, "time_s")
        torque = _real_array(torque_Nm, "torque_Nm")
        check_samples(time, torque, uniform_rtol, "TorqueRecord")
        time.flags.writeable = False
        torque.flags.writeable = False
        self._time = time
        self._torque = torque
        if meta is not None and not isinstance(meta, Mapping):
            raise RecordError(f"TorqueRecord: meta must be a mapping; got {type(meta).__name__}")
        self._meta = dict(meta or {})
        try:
            json.dumps(self._meta)
        except TypeError as exc:
            raise RecordError(f"TorqueRecord: meta must be JSON-serialisable: {exc}") from None

    # -- samples ---------------------------------------------------------------------------
    @property
    def time_s(self) -> NDArray[np.float64]:
        """Sample times, s (read-only view)."""
        return self._time

    @property
    def torque_Nm(self) -> NDArray[np.float64]:
        """Drive torque, N m (read-only view)."""
        return self._torque

    @property
    def meta(self) -> dict[str, Any]:
        """Metadata (a copy: the record itself is immutable)."""
        return dict(self._meta)

    @property
    def dt(self) -> float:
        """Sampling interval, s."""
        return float((self._time[-1] - self._time[0]) / (self._time.size - 1))

    @property
    def sample_rate_hz(self) -> float:
        """Sampling frequency, Hz."""
        return 1.0 / self.dt

    @property
    def duration_s(self) -> float:
        """Record length TR = N dt, s (the span the spectrum resolves, df = 1/TR, eq. 9)."""
        return self._time.size * self.dt

    def __len__(self) -> int:
        return int(self._time.size)

    def __repr__(self) -> str:
        return (f"TorqueRecord({len(self)} samples, t = {self._time[0]:g} .. {self._time[-1]:g} s, "
                f"dt = {self.dt:g} s, mean torque = {self.mean_torque_Nm:.6g} N m)")

    @property
    def mean_torque_Nm(self) -> float:
        """Mean torque T_c over the record, N m (paper section 2)."""
        return float(np.mean(self._torque))

    def with_meta(self, **updates: Any) -> TorqueRecord:
        """A copy with ``meta`` updated by the keyword arguments."""
        return TorqueRecord(self._time, self._torque, {**self._meta, **updates})

    # -- blocks ----------------------------------------------------------------------------
    def block(self, t1: float, t2: float) -> TorqueRecord:
        """The samples with ``t1 <= t < t2`` (s), as a new record with the same meta.

        Raises
        ------
        ValueError
            if ``t1 >= t2``, or if the interval holds fewer than 2 samples (the message gives
            the record's time span).
        """
        if not (np.isfinite(t1) and np.isfinite(t2)) or t1 >= t2:
            raise ValueError(f"block(t1={t1!r}, t2={t2!r}): need finite t1 < t2 (s)")
        # a tolerance of a millionth of a step keeps t = 4.0 in block(4.0, ...) despite round-off
        eps = 1e-6 * self.dt
        keep = (self._time >= t1 - eps) & (self._time < t2 - eps)
        if np.count_nonzero(keep) < 2:
            raise ValueError(
                f"block(t1={t1!r}, t2={t2!r}) holds {np.count_nonzero(keep)} samples; the record "
                f"spans {self._time[0]:g} .. {self._time[-1]:g} s")
        meta = {**self._meta, "block_s": [float(t1), float(t2)]}
        return TorqueRecord(self._time[keep], self._torque[keep], meta)

    # -- files -----------------------------------------------------------------------------
    def save(self, path: str | os.PathLike[str]) -> Path:
        """Write the record to ``path`` (``.npz``, or ``.csv``) atomically; returns the path."""
        target = Path(path)
        if target.suffix.lower() == ".csv":
            return self.to_csv(target)
        if target.suffix.lower() != ".npz":
            raise ValueError(f"save: path suffix {target.suffix!r} is not supported; use .npz "
                             "or .csv")
        with atomic_write(target, "wb") as fh:
            np.savez(fh, time_s=self._time, torque_Nm=self._torque,
                     meta_json=np.array(json.dumps(self._meta)))
        return target

    def to_csv(self, path: str | os.PathLike[str]) -> Path:
        """Write ``time_s,torque_Nm`` CSV with full precision, meta on a comment line."""
        target = Path(path)
        with atomic_write(target, "w") as fh:
            fh.write(f"{_META_PREFIX} {json.dumps(self._meta)}\n")
            fh.write(f"{TIME_COLUMN},{TORQUE_COLUMN}\n")
            for t, q in zip(self._time.tolist(), self._torque.tolist(), strict=True):
                fh.write(f"{t!r},{q!r}\n")
        return target

    @classmethod
    def load(cls, path: str | os.PathLike[str], **csv_options: Any) -> TorqueRecord:
        """Read a record: an ``.npz`` record (a zip archive, told by its content) or else a
        text file read by :meth:`from_csv`, whatever its suffix (``.csv``, ``.tsv``, ``.txt``).

        Parameters
        ----------
        path : str or path-like
        **csv_options
            Keyword options of :meth:`from_csv` (refused for an npz record).

        Raises
        ------
        RecordError
            for a missing, damaged or foreign file (a ``.npy`` array, a zip without the
            record's arrays, an npz header claiming more data than the file holds ...).
        """
        source = Path(path)
        start = _file_start(source)
        if start.startswith(b"\x93NUMPY"):
            raise RecordError(f"{source}: a single .npy array, not a record; a record .npz holds "
                              "time_s, torque_Nm and meta_json (TorqueRecord.save)")
        if not start.startswith(b"PK"):
            if source.suffix.lower() == ".npz":
                what = "an empty file" if not start else "not a zip archive"
                raise RecordError(f"{source}: not a millscope record ({what}; an .npz record is "
                                  "a zip of .npy arrays)")
            return cls.from_csv(source, **csv_options)
        given = sorted(k for k, v in csv_options.items() if v is not None and v is not False)
        if given:
            raise RecordError(f"{source}: an npz record; the CSV options {', '.join(given)} "
                              "apply to text files only")
        time, torque, meta = _read_npz(source)
        return cls._validated(time, torque, meta, str(source))

    @classmethod
    def from_csv(cls, path: str | os.PathLike[str], *, uniform_rtol: float = 1e-6,
                 time_column: str | int | None = None, torque_column: str | int | None = None,
                 time_unit: str | None = None, torque_unit: str | None = None,
                 sep: str | None = None, decimal: str | None = None,
                 skiprows: int | None = None, encoding: str | None = None,
                 resample: bool = False, jitter_rtol: float = 0.01) -> TorqueRecord:
        """Read a torque CSV: millscope's own (``time_s,torque_Nm``, a ``# meta: {json}``
        line) or a plant export.

        Every option left None is sniffed (:mod:`millscope._torque_csv`): the encoding (BOM,
        UTF-8, else latin-1), the separator (tab, ``;``, ``,``, ``|``), the decimal mark, the
        header below any title lines and a units line beside it, the time and torque columns
        (``time_s``/``torque_Nm``, else names like ``Time [ms]``, ``Zeit``, ``Timestamp``,
        ``Torque (kN m)``, ``Drehmoment``) and their units (in the header or the units line;
        ISO 8601 date-times become seconds since the first, kept as ``meta["time_origin"]``).
        Lines starting with ``#`` are comments; further columns are ignored.

        Parameters
        ----------
        path : str or path-like
        uniform_rtol : float, default 1e-6
            Largest deviation of a time step from the mean step, relative, taken as uniform.
        time_column, torque_column : str or int, optional
            The columns by header name (exact, or without the unit in any case) or index from 0.
        time_unit : {"s", "ms", "min", "h", "iso"}, optional
            Unit of the time column ("iso": ISO 8601 date-times); converted to s.
        torque_unit : {"N m", "kN m", "MN m"}, optional
            Unit of the torque column; converted to N m.
        sep : str, optional
            Field separator (one character).
        decimal : {".", ","}, optional
            Decimal mark.
        skiprows : int, optional
            Lines at the top of the file skipped before the header is looked for.
        encoding : str, optional
            Text encoding, e.g. "utf-8", "latin-1".
        resample : bool, default False
            When the time steps deviate from their mean by more than `uniform_rtol` but at
            most `jitter_rtol` (a logger's jittered stamps), interpolate the torque linearly
            onto the uniform times ``t0 + k dt`` (same count and span) and note it in
            ``meta["resampled"]``; otherwise such a file is refused.
        jitter_rtol : float, default 0.01
            Largest step deviation, relative to the mean step, that `resample` accepts; in
            (0, 0.5).

        Raises
        ------
        ValueError
            for an option out of its range (before the file is read).
        RecordError
            for every problem with the file, naming the file, the line and the column (a
            field that is not an ASCII number, a row with more fields than the header,
            unknown units, uneven sampling with the measured deviation ...).
        """
        options = CsvOptions(time_column, torque_column, time_unit, torque_unit, sep, decimal,
                             skiprows, encoding)
        rtol = real_option("uniform_rtol", uniform_rtol, 0.0, math.inf, "a finite number >= 0")
        jitter = real_option("jitter_rtol", jitter_rtol, 0.0, 0.5, "a number in (0, 0.5)")
        if jitter == 0.0:
            raise bad_option("jitter_rtol", jitter_rtol, "a number in (0, 0.5)")
        if not isinstance(resample, (bool, np.bool_)):
            raise bad_option("resample", resample, "True or False")
        source = Path(path)
        _file_start(source)
        time, torque, meta = read_torque_csv(source, options)
        if resample:
            time, torque, meta = _resampled(time, torque, meta, str(source), rtol, jitter)
        hint = ("resample it first, or read it with resample=True (command line: --resample) "
                "when the deviation is a logger's jitter")
        return cls._validated(time, torque, meta, str(source), rtol, hint)

    @classmethod
    def _validated(cls, time: NDArray[Any], torque: NDArray[Any], meta: dict[str, Any],
                   where: str, uniform_rtol: float = 1e-6,
                   hint: str = "resample the record first") -> TorqueRecord:
        time = _real_array(time, "time_s")
        torque = _real_array(torque, "torque_Nm")
        check_samples(time, torque, uniform_rtol, where, hint=hint)
        return cls(time, torque, meta, uniform_rtol=uniform_rtol)


def _resampled(time: NDArray[np.float64], torque: NDArray[np.float64], meta: dict[str, Any],
               where: str, uniform_rtol: float, jitter_rtol: float
               ) -> tuple[NDArray[np.float64], NDArray[np.float64], dict[str, Any]]:
    """Samples at jittered times brought onto the uniform times ``t0 + k dt`` by linear
    interpolation, when the largest step deviation lies in (`uniform_rtol`, `jitter_rtol`]."""
    check_samples(time, torque, math.inf, where)  # finite, increasing, 2 or more
    jitter, worst = step_jitter(time)
    if jitter <= uniform_rtol:
        return time, torque, meta
    dt = (time[-1] - time[0]) / (time.size - 1)
    if jitter > jitter_rtol:
        raise RecordError(
            f"{where}: sampling is not uniform: step {worst + 1} is "
            f"{float(time[worst + 1] - time[worst])!r} s against a mean step of {float(dt)!r} s, "
            f"a jitter of {jitter:.3g} relative; resampling accepts up to jitter_rtol = "
            f"{jitter_rtol:g}: this is a gap or a change of rate, not jitter")
    grid = time[0] + np.arange(time.size) * dt
    resampled = np.interp(grid, time, torque)
    return grid, resampled, {**meta, "resampled": {"max_jitter": jitter, "method": "linear"}}

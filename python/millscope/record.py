"""Torque records: uniformly sampled drive torque with its metadata, blocks and file I/O.

A :class:`TorqueRecord` is where simulated and measured torque meet. It holds the sample times
``time_s`` (s) and the drive torque ``torque_Nm`` (N m, positive when the charge resists the
rotation, DESIGN.md section 2), plus a JSON-serialisable ``meta`` dict (scene, dt, seed, rotation
frequency, lifter count, sampling mode ... whatever produced it).

Files:

* ``.npz`` (default): arrays ``time_s`` and ``torque_Nm`` plus ``meta_json``.
* ``.csv``: a header line ``time_s,torque_Nm`` (other columns are ignored on reading); the meta
  goes on a first comment line ``# meta: {...json...}``.

Both are written atomically (temporary file, then rename).
"""

from __future__ import annotations

import csv
import io
import json
import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ._files import atomic_write
from ._samples import RecordError, check_samples

__all__ = ["TorqueRecord", "RecordError"]

TIME_COLUMN = "time_s"
TORQUE_COLUMN = "torque_Nm"
_META_PREFIX = "# meta:"


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
        (a ``ValueError``) for non-finite samples, non-monotonic or uneven time, mismatched
        lengths or fewer than 2 samples; the message names the sample and the values.
    """

    __slots__ = ("_time", "_torque", "_meta")

    def __init__(self, time_s: ArrayLike, torque_Nm: ArrayLike,
                 meta: Mapping[str, Any] | None = None, *, uniform_rtol: float = 1e-6) -> None:
        time = np.array(time_s, dtype=np.float64)
        torque = np.array(torque_Nm, dtype=np.float64)
        check_samples(time, torque, uniform_rtol, "TorqueRecord")
        time.flags.writeable = False
        torque.flags.writeable = False
        self._time = time
        self._torque = torque
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
    def load(cls, path: str | os.PathLike[str]) -> TorqueRecord:
        """Read a record from ``.npz`` or ``.csv`` (chosen by suffix)."""
        source = Path(path)
        if source.suffix.lower() == ".csv":
            return cls.from_csv(source)
        if not source.is_file():
            raise RecordError(f"{source}: no such file")
        try:
            with np.load(source, allow_pickle=False) as data:
                time, torque = data[TIME_COLUMN], data[TORQUE_COLUMN]
                meta = json.loads(str(data["meta_json"])) if "meta_json" in data else {}
        except (OSError, KeyError, ValueError) as exc:
            raise RecordError(f"{source}: not a millscope record ({exc})") from None
        return cls._validated(time, torque, meta, str(source))

    @classmethod
    def from_csv(cls, path: str | os.PathLike[str], *, uniform_rtol: float = 1e-6) -> TorqueRecord:
        """Read a CSV with columns ``time_s`` (s) and ``torque_Nm`` (N m).

        Lines starting with ``#`` are comments (a ``# meta: {json}`` line becomes the meta);
        further columns are ignored. Every problem raises :class:`RecordError` naming the file,
        the line and the column.
        """
        source = Path(path)
        if not source.is_file():
            raise RecordError(f"{source}: no such file")
        try:
            text = source.read_text()
        except UnicodeDecodeError:
            raise RecordError(f"{source}: not a text file") from None
        meta: dict[str, Any] = {}
        rows: list[tuple[int, list[str]]] = []
        for lineno, line in enumerate(io.StringIO(text), start=1):
            stripped = line.strip()
            if not stripped:
                continue
            if stripped.startswith(_META_PREFIX):
                try:
                    meta = json.loads(stripped[len(_META_PREFIX):])
                except json.JSONDecodeError as exc:
                    raise RecordError(f"{source} line {lineno}: meta is not valid JSON ({exc})"
                                      ) from None
                continue
            if stripped.startswith("#"):
                continue
            rows.append((lineno, next(csv.reader([stripped]))))
        if not rows:
            raise RecordError(f"{source}: no header line; expected columns "
                              f"{TIME_COLUMN},{TORQUE_COLUMN}")
        header_line, header = rows[0]
        header = [h.strip() for h in header]
        missing = [c for c in (TIME_COLUMN, TORQUE_COLUMN) if c not in header]
        if missing:
            raise RecordError(f"{source} line {header_line}: missing column "
                              f"{', '.join(repr(m) for m in missing)}; found {header}")
        columns = [header.index(TIME_COLUMN), header.index(TORQUE_COLUMN)]
        values = np.empty((len(rows) - 1, 2))
        for r, (lineno, fields) in enumerate(rows[1:]):
            for c, col in enumerate(columns):
                name = header[col]
                if col >= len(fields):
                    raise RecordError(f"{source} line {lineno}: column {name!r} is missing "
                                      f"(the line has {len(fields)} fields)")
                try:
                    values[r, c] = float(fields[col])
                except ValueError:
                    raise RecordError(f"{source} line {lineno}: column {name!r}: "
                                      f"{fields[col]!r} is not a number") from None
        return cls._validated(values[:, 0], values[:, 1], meta, str(source), uniform_rtol)

    @classmethod
    def _validated(cls, time: NDArray[np.float64], torque: NDArray[np.float64],
                   meta: dict[str, Any], where: str, uniform_rtol: float = 1e-6) -> TorqueRecord:
        time = np.asarray(time, dtype=np.float64)
        torque = np.asarray(torque, dtype=np.float64)
        check_samples(time, torque, uniform_rtol, where)
        return cls(time, torque, meta, uniform_rtol=uniform_rtol)

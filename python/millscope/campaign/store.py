"""The result store of a campaign: one file per case, written atomically, read as untrusted
input; the manifest rebuilt from the files; the lock held while a campaign runs on it.
"""

from __future__ import annotations

import contextlib
import json
import os
import time
from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from .. import _checks, _core
from .._files import atomic_write, read_json
from ..signal.analysis import AnalysisSettings
from ..signal.record import RecordError, TorqueRecord
from .cases import Case, Status
from .partial import PARTIAL_DIR

__all__ = ["MANIFEST_FORMAT", "UnreadableCase", "read_manifest", "unreadable_cases"]

MANIFEST_FORMAT = "millscope-campaign-1"


# -- the store ---------------------------------------------------------------------------------


def _case_path(store: Path, digest: str) -> Path:
    return store / "cases" / f"{digest}.npz"


def _failure_path(store: Path, digest: str) -> Path:
    return store / "cases" / f"{digest}.failed.json"


class _Unreadable(Exception):
    """Why a case file cannot be read (one line)."""


def _open_done(path: Path, digest: str | None = None) -> tuple[dict[str, Any], TorqueRecord]:
    """The ``meta["campaign"]`` and the record of a finished case's file.

    Raises :class:`_Unreadable` saying why unless the file is a whole, consistent case file:
    a zip whose checksums hold, the three arrays of record.py's format, samples a
    :class:`~millscope.record.TorqueRecord` accepts (finite, uniform), a stored case that
    hashes to ``digest`` (by default the file's name) and the number of samples its settings
    give.
    """
    try:
        record = TorqueRecord.load(path)  # every check of a record file (record.py)
        info = record.meta.get("campaign")
        if not isinstance(info, dict):
            raise _Unreadable('its meta holds no "campaign" mapping')
        case = Case.from_dict(info.get("case"))
    except _Unreadable:
        raise
    except RecordError as exc:  # its message starts with the path, which the caller names
        raise _Unreadable(str(exc).removeprefix(f"{path}: ")) from None
    except (OSError, KeyError, TypeError, ValueError) as exc:
        raise _Unreadable(f"not a valid case file ({_one_line(exc)})") from None
    if case.hash() != (path.stem if digest is None else digest):
        raise _Unreadable(f"it holds case {case.hash()[:12]}, not the one its name says")
    expected = case.settings.total_samples - case.settings.warm_up_samples
    if len(record) != expected:
        raise _Unreadable(f"it holds {len(record)} samples; its case gives {expected}")
    return info, record


def _open_failed(path: Path) -> dict[str, Any]:
    """The content of a failed case's file; :class:`_Unreadable` saying why when it is not a
    whole failure record of the case its name says."""
    try:
        if path.is_dir():
            raise _Unreadable("a directory, not a case file")
        try:
            info = read_json(path, "failed case")
        except ValueError as exc:  # the message starts with the path, which the caller names
            raise _Unreadable(str(exc).removeprefix(f"{path}: ")) from None
        if not isinstance(info, dict):
            raise _Unreadable(f"holds a JSON {type(info).__name__}, not a failed case")
        digest = Case.from_dict(info.get("case")).hash()
    except _Unreadable:
        raise
    except (OSError, KeyError, TypeError, ValueError, RecursionError) as exc:
        raise _Unreadable(f"not a valid failed-case file ({_one_line(exc)})") from None
    if digest != path.name.split(".")[0]:
        raise _Unreadable(f"it holds case {digest[:12]}, not the one its name says")
    return info


def _one_line(exc: BaseException) -> str:
    text = " ".join(str(exc).split())
    return f"{type(exc).__name__}: {text}" if text else type(exc).__name__


def _read_done(path: Path) -> dict[str, Any] | None:
    """:func:`_open_done`'s info, or None when the file cannot be read."""
    try:
        return _open_done(path)[0]
    except _Unreadable:
        return None


def _read_failed(path: Path) -> dict[str, Any] | None:
    """:func:`_open_failed`'s info, or None when the file cannot be read."""
    try:
        return _open_failed(path)
    except _Unreadable:
        return None


def _case_files(store: Path) -> Iterator[tuple[Status, Path]]:
    """Every case file in ``store/cases`` (not the temporaries of unfinished writes):
    failures first, so that a finished case's file wins over a failure of the same case."""
    folder = store / "cases"
    patterns: tuple[tuple[Status, str], ...] = (("failed", "*.failed.json"), ("done", "*.npz"))
    if folder.is_dir():
        for status, pattern in patterns:
            for path in sorted(folder.glob(pattern)):
                if not path.name.startswith("."):
                    yield status, path


def _stored(store: Path) -> dict[str, tuple[Status, Path, dict[str, Any]]]:
    """Every whole case file in ``store`` by hash: (status, path, its case info); a finished
    case's file wins over a failure of the same case."""
    found: dict[str, tuple[Status, Path, dict[str, Any]]] = {}
    for status, path in _case_files(store):
        info = _read_done(path) if status == "done" else _read_failed(path)
        if info is not None:
            found[path.name.split(".")[0]] = (status, path, info)
    return found


@dataclass(frozen=True)
class UnreadableCase:
    """A case a store should hold but cannot give: its file is damaged, or missing although
    the manifest lists the case as finished or failed.

    Attributes
    ----------
    file : str
        The case file, relative to the store (``cases/<hash>.npz`` or
        ``cases/<hash>.failed.json``).
    hash : str
        The case's hash, from the file's name.
    name : str or None
        ``"<scene> seed <seed>"`` as the manifest lists the case; None when it does not.
    reason : str
        Why the file cannot be read (one line).
    """

    file: str
    hash: str
    name: str | None
    reason: str

    def __str__(self) -> str:
        named = f" ({self.name})" if self.name else ""
        return f"{self.file}{named}: {self.reason}"


def _listing(cases: list[UnreadableCase], most: int = 5) -> str:
    """The first ``most`` unreadable cases on one line, then how many more."""
    text = "; ".join(str(c) for c in cases[:most])
    return text + (f"; and {len(cases) - most} more" if len(cases) > most else "")


def unreadable_cases(store: str | os.PathLike[str]) -> list[UnreadableCase]:
    """Every case of ``store`` whose file cannot be read, with the reason.

    A case file (``cases/*.npz``, ``cases/*.failed.json``) that is not whole and consistent
    (truncated, altered, empty, a directory, without its meta, with samples a
    :class:`~millscope.record.TorqueRecord` refuses, or named for another case), and a case
    the manifest lists as done or failed whose file is missing. Temporary files of writes a
    killed campaign left are not cases (the next run removes them). A finished case's file
    wins over a failure of the same case, so a readable ``.npz`` hides a damaged
    ``.failed.json`` beside it.

    Parameters
    ----------
    store : str or path
        A campaign store directory.

    Returns
    -------
    list of UnreadableCase
        In file-name order; empty for a store whose every case can be read.

    Raises
    ------
    ValueError
        when ``store`` is not a directory or its manifest is damaged.
    """
    path = Path(store)
    if not path.is_dir():
        raise _checks.fail("store", str(store), "an existing campaign store directory")
    listed: dict[str, dict[str, Any]] = {}
    if (path / "manifest.json").exists():
        listed = {e["hash"]: e for e in read_manifest(path).get("cases", [])
                  if isinstance(e, dict) and isinstance(e.get("hash"), str)}

    def name(digest: str) -> str | None:
        entry = listed.get(digest)
        if entry is None or not isinstance(entry.get("name"), str):
            return None
        return f"{entry['name'] or 'scene'} seed {entry.get('seed')}"

    found: dict[str, UnreadableCase] = {}
    readable: set[str] = set()
    for status, file in _case_files(path):
        digest = file.name.split(".")[0]
        try:
            _open_done(file) if status == "done" else _open_failed(file)
        except _Unreadable as exc:
            found[file.name] = UnreadableCase(file.relative_to(path).as_posix(), digest,
                                              name(digest), str(exc))
        else:
            readable.add(digest)
    for digest in readable:  # a whole finished case outweighs a damaged failure record
        found.pop(_failure_path(path, digest).name, None)
    for digest, entry in listed.items():
        said = entry.get("status")
        if said in ("done", "failed") and digest not in readable:
            file = (_case_path if said == "done" else _failure_path)(path, digest)
            if not file.exists() and not file.is_symlink():
                found[file.name] = UnreadableCase(
                    file.relative_to(path).as_posix(), digest, name(digest),
                    f"missing, although manifest.json lists the case as {said}")
    return [found[k] for k in sorted(found)]


def _scan(store: Path) -> dict[str, dict[str, Any]]:
    """Manifest entries of every case file in ``store``."""
    return {digest: _entry(info, status, path, store)
            for digest, (status, path, info) in _stored(store).items()}


def _entry(info: Mapping[str, Any], status: Status, path: Path | None,
           store: Path) -> dict[str, Any]:
    case = info["case"]
    settings = case["settings"]
    return {
        "hash": info["hash"],
        "name": case["scene"].get("name", ""),
        "seed": settings["seed"],
        "status": status,
        "file": None if path is None else path.relative_to(store).as_posix(),
        "wall_time_s": info.get("wall_time_s"),
        "cpu_time_s": info.get("cpu_time_s"),
        "error": info.get("error"),
        "traceback": info.get("traceback"),
    }


def read_manifest(store: str | os.PathLike[str]) -> dict[str, Any]:
    """The manifest of a store as written by :meth:`Campaign.run` (it may be stale after a
    kill; the next run rebuilds it from the case files)."""
    path = Path(store) / "manifest.json"
    data = read_json(path, "campaign manifest")
    if not isinstance(data, dict) or data.get("format") != MANIFEST_FORMAT:
        raise ValueError(f"{path}: not a millscope campaign manifest (expected format "
                         f"{MANIFEST_FORMAT!r})")
    return data


def _write_manifest(store: Path, entries: Mapping[str, Mapping[str, Any]],
                    analysis: AnalysisSettings | None) -> None:
    counts = {s: sum(1 for e in entries.values() if e["status"] == s)
              for s in ("done", "failed", "pending")}
    data = {
        "format": MANIFEST_FORMAT,
        "millscope_version": _core.build_info()["version"],
        "updated": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
        "counts": counts,
        "analysis": None if analysis is None else analysis.to_dict(),
        "cases": list(entries.values()),
    }
    with atomic_write(store / "manifest.json", "w") as fh:
        json.dump(data, fh, indent=1)
        fh.write("\n")


@contextlib.contextmanager
def _locked(store: Path) -> Iterator[None]:
    """Holds an exclusive flock on ``store/.lock`` (released by the OS if the process dies)."""
    try:
        import fcntl
    except ImportError:  # not POSIX: no lock
        yield
        return
    with open(store / ".lock", "a+") as fh:
        try:
            fcntl.flock(fh.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            raise RuntimeError(f"the store {store} is in use by another campaign; run one "
                               "campaign per store at a time") from None
        try:
            yield
        finally:
            fcntl.flock(fh.fileno(), fcntl.LOCK_UN)


def _remove_temporaries(store: Path) -> None:
    """Deletes what atomic writes of a killed campaign left (``.<name>.<random>.tmp``)."""
    for folder in (store, store / "cases", store / PARTIAL_DIR):
        if folder.is_dir():
            for tmp in folder.glob(".*.tmp"):
                with contextlib.suppress(FileNotFoundError):
                    tmp.unlink()

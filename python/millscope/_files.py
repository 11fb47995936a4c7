"""File helpers: atomic writes (a temporary file beside the target, then ``os.replace``) and
size-capped JSON and TOML reads whose errors name the file."""

from __future__ import annotations

import contextlib
import json
import os
import sys
import tempfile
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import IO, Any

import numpy as np

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib


def _new_file_mode() -> int:
    """0o666 less the process umask, the mode ``open()`` would give a new file."""
    umask = os.umask(0)
    os.umask(umask)
    return 0o666 & ~umask


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike[str]) -> Iterator[Path]:
    """A temporary file's path beside ``path``, for a writer that opens files by name (such as
    meshio); on success the file is synced to disk and renamed over ``path``.

    On any error the temporary file is removed and ``path`` is left as it was, so a reader never
    sees a half-written file. The result has the mode an ordinary ``open()`` would give it (the
    old file's mode when replacing one), not mkstemp's private 0600.
    """
    target = Path(path)
    permissions = target.stat().st_mode & 0o7777 if target.exists() else _new_file_mode()
    fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".tmp", dir=target.parent)
    os.close(fd)
    try:
        os.chmod(tmp, permissions)
        yield Path(tmp)
        fd = os.open(tmp, os.O_RDONLY)
        try:
            os.fsync(fd)
        finally:
            os.close(fd)
        os.replace(tmp, target)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)
        raise


@contextlib.contextmanager
def atomic_write(path: str | os.PathLike[str], mode: str = "w") -> Iterator[IO[Any]]:
    """Open a temporary file beside ``path``; on success rename it over ``path``
    (:func:`atomic_path`, with the file opened in ``mode``)."""
    with atomic_path(path) as tmp, open(tmp, mode) as fh:
        yield fh


#: The largest JSON file :func:`read_json` reads, bytes. Calibrations, drives and scenes are a
#: few kilobytes; a file of megabytes is not one of them (or is /dev/zero), and is refused
#: before it fills the memory.
MAX_JSON_BYTES = 4 * 1024 * 1024


def read_bytes(path: str | os.PathLike[str], what: str, error: type[ValueError] = ValueError,
               max_bytes: int | None = None) -> bytes:
    """The bytes of ``path``, at most ``max_bytes`` of them.

    Parameters
    ----------
    path : path-like
        The file.
    what : str
        What the file should hold (e.g. "calibration"), for the messages.
    error : type
        The ``ValueError`` subclass raised for every problem of the file.
    max_bytes : int, optional
        Larger files are refused unread (at most ``max_bytes + 1`` bytes are read). None: no
        limit.

    Raises
    ------
    error
        Naming the file: missing, not a regular file, unreadable, or larger than ``max_bytes``.
    """
    source = Path(path)
    try:
        with open(source, "rb") as fh:
            raw = fh.read(-1 if max_bytes is None else max_bytes + 1)
    except FileNotFoundError:
        raise error(f"{source}: no such {what} file") from None
    except OSError as exc:  # a directory, no permission ...
        raise error(f"{source}: cannot read the {what} file ({exc.strerror or exc})") from None
    if max_bytes is not None and len(raw) > max_bytes:
        raise error(f"{source}: larger than {max_bytes} bytes; a {what} file is a small text "
                    f"file, at most {max_bytes} bytes")
    return raw


def _parse_text(path: str | os.PathLike[str], what: str, error: type[ValueError],
                max_bytes: int | None, kind: str, parse: Callable[[str], Any]) -> Any:
    """``parse`` of the UTF-8 text of ``path``; every problem an ``error`` naming the file."""
    source = Path(path)
    raw = read_bytes(source, what, error, max_bytes)
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise error(f"{source}: not a UTF-8 text file (byte {exc.start}); a {what} file is "
                    f"{kind} text") from None
    try:
        return parse(text)
    except RecursionError:
        raise error(f"{source}: {kind} nested too deeply to read; not a {what} file") from None
    except ValueError as exc:  # a syntax error, or an integer of over 4300 digits
        raise error(f"{source}: not valid {kind} ({exc})") from None


def read_json(path: str | os.PathLike[str], what: str, error: type[ValueError] = ValueError,
              max_bytes: int | None = None) -> Any:
    """The parsed JSON of ``path``.

    Parameters
    ----------
    path, what, error, max_bytes
        As :func:`read_bytes`; loaders of small formats pass ``MAX_JSON_BYTES``.

    Raises
    ------
    error
        Naming the file: as :func:`read_bytes`, or not UTF-8, not valid JSON, or nested too
        deeply to parse.
    """
    return _parse_text(path, what, error, max_bytes, "JSON", json.loads)


def read_toml(path: str | os.PathLike[str], what: str, error: type[ValueError] = ValueError,
              max_bytes: int | None = MAX_JSON_BYTES) -> dict[str, Any]:
    """The parsed TOML of ``path`` (``tomllib``; ``tomli`` before Python 3.11).

    Parameters
    ----------
    path, what, error, max_bytes
        As :func:`read_bytes`; by default at most ``MAX_JSON_BYTES``.

    Raises
    ------
    error
        Naming the file: as :func:`read_bytes`, or not UTF-8, or not valid TOML (with the line
        and column of the fault).
    """
    data: dict[str, Any] = _parse_text(path, what, error, max_bytes, "TOML", tomllib.loads)
    return data


def read_npy_header(fp: IO[bytes]) -> tuple[tuple[int, ...], bool, np.dtype[Any]]:
    """(shape, fortran_order, dtype) from the header of a ``.npy`` stream, read before its
    data so that a caller can check what the header claims before allocating it. A format
    other than 1.0 or 2.0, or a header that does not parse, raises ValueError."""
    try:
        version = np.lib.format.read_magic(fp)
        read = {(1, 0): np.lib.format.read_array_header_1_0,
                (2, 0): np.lib.format.read_array_header_2_0}.get(version)
        if read is None:
            raise ValueError(f"npy format {version}; 1.0 or 2.0 is read")
        shape, fortran, dtype = read(fp)
    except (SyntaxError, EOFError) as exc:
        raise ValueError(f"no readable npy header ({exc})") from None
    return tuple(shape), bool(fortran), dtype

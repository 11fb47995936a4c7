"""File helpers: atomic writes (a temporary file beside the target, then ``os.replace``) and
JSON reads whose errors name the file."""

from __future__ import annotations

import contextlib
import json
import os
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import IO, Any

import numpy as np


def _new_file_mode() -> int:
    """0o666 less the process umask, the mode ``open()`` would give a new file."""
    umask = os.umask(0)
    os.umask(umask)
    return 0o666 & ~umask


@contextlib.contextmanager
def atomic_write(path: str | os.PathLike[str], mode: str = "w") -> Iterator[IO[Any]]:
    """Open a temporary file beside ``path``; on success rename it over ``path``.

    On any error the temporary file is removed and ``path`` is left as it was, so a reader never
    sees a half-written file. The result has the mode an ordinary ``open()`` would give it (the
    old file's mode when replacing one), not mkstemp's private 0600.
    """
    target = Path(path)
    permissions = target.stat().st_mode & 0o7777 if target.exists() else _new_file_mode()
    fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".tmp", dir=target.parent)
    os.chmod(tmp, permissions)
    try:
        with os.fdopen(fd, mode) as fh:
            yield fh
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, target)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)
        raise


#: The largest JSON file :func:`read_json` reads, bytes. Calibrations, drives and scenes are a
#: few kilobytes; a file of megabytes is not one of them (or is /dev/zero), and is refused
#: before it fills the memory.
MAX_JSON_BYTES = 4 * 1024 * 1024


def read_json(path: str | os.PathLike[str], what: str, error: type[ValueError] = ValueError,
              max_bytes: int | None = None) -> Any:
    """The parsed JSON of ``path``.

    Parameters
    ----------
    path : path-like
        The file.
    what : str
        What the file should hold (e.g. "calibration"), for the messages.
    error : type
        The ``ValueError`` subclass raised for every problem of the file.
    max_bytes : int, optional
        Larger files are refused unread (at most ``max_bytes + 1`` bytes are read); loaders of
        small formats pass ``MAX_JSON_BYTES``. None: no limit.

    Raises
    ------
    error
        Naming the file: missing, not a regular file, unreadable, larger than ``max_bytes``,
        not UTF-8, not valid JSON, or nested too deeply to parse.
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
        raise error(f"{source}: larger than {max_bytes} bytes; a {what} file is a small JSON "
                    f"file, at most {max_bytes} bytes")
    try:
        return json.loads(raw.decode("utf-8"))
    except UnicodeDecodeError as exc:
        raise error(f"{source}: not a UTF-8 text file (byte {exc.start}); a {what} file is "
                    "JSON text") from None
    except RecursionError:
        raise error(f"{source}: JSON nested too deeply to read; not a {what} file") from None
    except ValueError as exc:  # JSONDecodeError, or an integer of over 4300 digits
        raise error(f"{source}: not valid JSON ({exc})") from None


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

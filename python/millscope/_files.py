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
def atomic_write(path: str | os.PathLike[str], mode: str = "w") -> Iterator[IO]:
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


def read_json(path: str | os.PathLike[str], what: str) -> Any:
    """The parsed JSON of ``path``; a missing or malformed file raises ValueError naming the file
    and ``what`` it should have been (e.g. "calibration")."""
    source = Path(path)
    try:
        return json.loads(source.read_text())
    except FileNotFoundError:
        raise ValueError(f"{source}: no such {what} file") from None
    except json.JSONDecodeError as exc:
        raise ValueError(f"{source}: not valid JSON ({exc})") from None


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

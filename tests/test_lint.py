"""The checkout follows the project's lint rules (pyproject.toml, [tool.ruff]: pycodestyle,
pyflakes, import order, bugbear, pyupgrade and numpy's deprecations, lines of at most 100
characters), in the package, the tests, the benchmarks, the examples and the notebooks."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def test_ruff_finds_nothing() -> None:
    done = subprocess.run([sys.executable, "-m", "ruff", "check", "--no-cache",
                           "--output-format", "concise", "."],
                          cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stdout + done.stderr

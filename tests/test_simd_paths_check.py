"""cpp/tools/simd_paths_check.cpp: the SIMD paths' check that needs no Python.

benchmarks/arm_paths.sh cross-compiles it with the core library (CMake with
MILLSCOPE_PYTHON_MODULE=OFF) and runs Arm's paths under emulation. Here it is built the same
way for this machine, so that the build without Python and the program keep working: every
path this CPU runs (as the Python module lists them) must end each scene in the same state,
the scenes must have contacts, and bad input is refused.
"""

from __future__ import annotations

import re
import shutil
import subprocess
from collections import defaultdict
from pathlib import Path

import pytest

from millscope import _core

ROOT = Path(__file__).resolve().parents[1]
LINE = re.compile(r"(\S+)\s+(periodic ends|end walls)\s+(one material|two materials)\s+"
                  r"threads=(\d+) overlap=(\S+) ([0-9a-f]{16})(  DIFFERS)?")


@pytest.fixture(scope="module")
def program(tmp_path_factory: pytest.TempPathFactory) -> Path:
    if shutil.which("cmake") is None or shutil.which("c++") is None:
        pytest.skip("no cmake and C++ compiler to build cpp/tools/simd_paths_check.cpp")
    build = tmp_path_factory.mktemp("simd-paths-check")
    subprocess.run(["cmake", "-S", str(ROOT), "-B", str(build), "-DCMAKE_BUILD_TYPE=Release",
                    "-DMILLSCOPE_PYTHON_MODULE=OFF", "-DMILLSCOPE_TOOLS=ON"],
                   check=True, capture_output=True)
    subprocess.run(["cmake", "--build", str(build), "--target", "simd_paths_check", "-j", "2"],
                   check=True, capture_output=True)
    return build / "simd_paths_check"


def test_every_path_ends_each_scene_in_the_same_state(program: Path) -> None:
    out = subprocess.run([str(program), "1", "2"], capture_output=True, text=True, timeout=600)
    assert out.returncode == 0, out.stdout + out.stderr
    prints: dict[tuple[str, str, str], dict[str, str]] = defaultdict(dict)
    for line in out.stdout.splitlines()[:-1]:
        match = LINE.fullmatch(line)
        assert match, line
        path, ends, materials, threads, overlap, fingerprint, differs = match.groups()
        assert differs is None, line
        assert float(overlap) > 0.0, f"no contact at the end of {line!r}"
        prints[(ends, materials, threads)][path] = fingerprint
    assert out.stdout.splitlines()[-1] == "every path gives the same state"
    # 2 ends x 2 material sets x 2 thread counts, each run on every path of this CPU
    assert len(prints) == 8
    for scene, by_path in prints.items():
        assert set(by_path) == set(_core.simd_paths()), scene
        assert len(set(by_path.values())) == 1, (scene, by_path)
    # the scenes differ from one another: the fingerprint sees what they do
    assert len({next(iter(by_path.values())) for by_path in prints.values()}) == 8


@pytest.mark.parametrize("argument", ["0", "65", "two", "2x"])
def test_a_bad_thread_count_is_refused(program: Path, argument: str) -> None:
    out = subprocess.run([str(program), argument], capture_output=True, text=True, timeout=60)
    assert out.returncode == 2
    assert out.stdout == ""
    assert f"threads = {argument} is not valid; it must be an integer in [1, 64]" in out.stderr

"""benchmarks/core_handoff.cpp: the time a cache line takes from one core to the other.

No timing is asserted: only that the program builds, prints its figure in the documented
form, that the figure fits the run's own wall time, and that bad input is refused.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import time
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SOURCE = ROOT / "benchmarks" / "core_handoff.cpp"


@pytest.fixture(scope="module")
def program(tmp_path_factory: pytest.TempPathFactory) -> Path:
    compiler = shutil.which("g++")
    if compiler is None:
        pytest.skip("no g++ to build benchmarks/core_handoff.cpp")
    exe = tmp_path_factory.mktemp("handoff") / "core_handoff"
    subprocess.run([compiler, "-O2", "-Wall", "-Wextra", "-Werror", "-pthread", str(SOURCE),
                    "-o", str(exe)], check=True)
    return exe


def test_the_figure_is_positive_and_fits_the_run_s_wall_time(program: Path) -> None:
    handoffs, rounds = 20000, 3
    begin = time.perf_counter()
    out = subprocess.run([str(program), str(handoffs), str(rounds)], capture_output=True,
                         text=True, timeout=60)
    wall_ns = (time.perf_counter() - begin) * 1e9
    assert out.returncode == 0, out.stderr
    match = re.fullmatch(r"core_handoff_ns=(\d+\.\d)\n", out.stdout)
    assert match, out.stdout
    ns = float(match.group(1))
    assert ns > 0.0
    # The median round's mean hand-off: at least half of the rounds took as long, and all ran
    # within the process's wall time.
    assert ns * handoffs * (rounds // 2 + 1) <= wall_ns


def test_two_threads_on_one_core_hand_off_by_yielding(program: Path) -> None:
    """Both threads pinned to one core (a one-core machine, or a busy one where they land on
    the same core): each must give the core to the other, or every hand-off costs a whole
    time slice and 20000 of them take minutes. The figure then counts the switches."""
    core = min(os.sched_getaffinity(0))
    handoffs, rounds = 20000, 3
    out = subprocess.run([str(program), str(handoffs), str(rounds)], capture_output=True,
                         text=True, timeout=60,
                         preexec_fn=lambda: os.sched_setaffinity(0, {core}))
    assert out.returncode == 0, out.stderr
    assert re.fullmatch(r"core_handoff_ns=(\d+\.\d)\n", out.stdout), out.stdout


@pytest.mark.parametrize(("args", "name", "value"), [
    (["0"], "HANDOFFS", "0"),
    (["ten"], "HANDOFFS", "ten"),
    (["100", "-1"], "ROUNDS", "-1"),
])
def test_bad_counts_are_refused_naming_the_parameter(program: Path, args: list[str], name: str,
                                                     value: str) -> None:
    out = subprocess.run([str(program), *args], capture_output=True, text=True, timeout=10)
    assert out.returncode == 2
    assert out.stdout == ""
    assert f"{name} = '{value}' is not valid; it must be an integer >= 1" in out.stderr


def test_too_many_arguments_print_the_usage(program: Path) -> None:
    out = subprocess.run([str(program), "1", "2", "3"], capture_output=True, text=True,
                         timeout=10)
    assert out.returncode == 2
    assert "usage:" in out.stderr

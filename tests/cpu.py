"""What this machine's CPU offers, read from /proc/cpuinfo (Linux), independently of the build,
and how many cores this process may use."""

from __future__ import annotations

import os
import platform

import pytest


def cpu_flags() -> set[str]:
    """The CPU's feature flags (empty where /proc/cpuinfo cannot be read)."""
    try:
        with open("/proc/cpuinfo") as f:
            return next((set(line.split(":")[1].split()) for line in f
                         if line.startswith("flags")), set())
    except OSError:
        return set()


#: The CPU features each x86-64 SIMD path of the engine needs (Google Highway's targets AVX3 and
#: AVX2 as it detects them), as /proc/cpuinfo names them.
SIMD_PATH_FLAGS = {"avx512": {"avx512f", "avx512vl", "avx512dq", "avx512bw", "avx2", "fma",
                              "bmi1", "bmi2", "f16c"},
                   "avx2": {"avx2", "fma", "bmi1", "bmi2", "f16c"}}


def x86_simd_paths() -> list[str] | None:
    """The engine's SIMD paths this CPU should run, widest first, "portable" last, read from
    /proc/cpuinfo independently of the build; None off x86-64 or where it cannot be read."""
    flags = cpu_flags()
    if platform.machine() not in ("x86_64", "AMD64") or not flags:
        return None
    return [p for p, need in SIMD_PATH_FLAGS.items() if need <= flags] + ["portable"]


def usable_cores() -> int:
    """The cores this process may use (its affinity; the machine's count where there is none)."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:
        return os.cpu_count() or 1


#: For a test whose point is a run on two threads: Simulation refuses more threads than the
#: process may use, so on one core it is skipped (tests that only need some run use
#: ``min(2, usable_cores())`` instead).
needs_two_cores = pytest.mark.skipif(usable_cores() < 2,
                                     reason="this process may use one core only")

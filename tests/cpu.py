"""What this machine's CPU offers, read from /proc/cpuinfo (Linux), independently of the build,
and how many cores this process may use."""

from __future__ import annotations

import os

import pytest


def cpu_flags() -> set[str]:
    """The CPU's feature flags (empty where /proc/cpuinfo cannot be read)."""
    try:
        with open("/proc/cpuinfo") as f:
            return next((set(line.split(":")[1].split()) for line in f
                         if line.startswith("flags")), set())
    except OSError:
        return set()


def runs_wide_pair_search() -> bool:
    """Whether the engine's AVX-512 pair search (touching_pairs.hpp) runs here: the CPU has it
    and MILLSCOPE_NO_WIDE_PAIRS does not turn it off."""
    turned_off = os.environ.get("MILLSCOPE_NO_WIDE_PAIRS", "") not in ("", "0")
    return {"avx512f", "avx512vl"} <= cpu_flags() and not turned_off


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

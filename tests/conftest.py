"""Shared fixtures: synthetic signals whose content is known exactly."""

from __future__ import annotations

import numpy as np
import pytest

import millscope as ms


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(20261122)


def sine_record(n: int, fs: float, *, mean: float = 0.0, amplitude: float = 0.0,
                freq_hz: float = 1.0, noise_std: float = 0.0, phase: float = 0.3,
                seed: int = 0) -> ms.TorqueRecord:
    """mean + amplitude sin(2 pi f t + phase) + N(0, noise_std^2), n samples at fs."""
    t = np.arange(n) / fs
    x = mean + amplitude * np.sin(2 * np.pi * freq_hz * t + phase)
    if noise_std:
        x = x + np.random.default_rng(seed).normal(0.0, noise_std, n)
    return ms.TorqueRecord(t, x)

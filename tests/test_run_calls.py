"""Simulation.run hands the engine short calls, so that Ctrl-C acts within a second whatever dt,
and refuses absurd step counts before any work (issue "Bad input and faults", item 4)."""

from __future__ import annotations

import signal
import threading
from typing import Any

import numpy as np
import pytest

import millscope as ms
from millscope import simulation
from millscope.scene import Drum, Fraction, Lifters, Material, Pair, Scene

SOFT_STEEL = Material("steel", 7860.0, 81e6, 0.3)  # shear modulus x 0.001


def small_sim(dt: float | None = None) -> ms.Simulation:
    """40 soft steel balls in a 0.3 m drum with 8 lifters."""
    scene = Scene(drum=Drum(0.3, 0.1, "steel", True, Lifters(8, 0.02, 0.015)),
                  charge=[Fraction("steel", 0.025, 40, "balls")], materials=[SOFT_STEEL],
                  pairs=[Pair("steel", "steel", 0.5, 0.15)], speed_fraction=0.71)
    return ms.Simulation(scene, seed=1, dt=dt, threads=1, settle_tolerance=10.0,
                         settle_min_s=0.05, settle_max_s=0.1)


class CountingEngine:
    """Forwards to the engine and keeps the steps each advance_sampled call took."""

    def __init__(self, engine: Any) -> None:
        object.__setattr__(self, "_engine", engine)
        object.__setattr__(self, "calls", [])

    def __getattr__(self, name: str) -> Any:
        return getattr(self._engine, name)

    def __setattr__(self, name: str, value: Any) -> None:
        setattr(self._engine, name, value)

    def advance_sampled(self, *args: Any) -> Any:
        before = self._engine.step_count
        rows = self._engine.advance_sampled(*args)
        self.calls.append(self._engine.step_count - before)
        return rows


@pytest.mark.parametrize("sampling", ["instant", "mean"])
def test_a_run_in_short_calls_gives_the_samples_of_long_ones(monkeypatch, sampling) -> None:
    """With calls cut to 7 steps (samples every 25 steps, so every sample spans several calls)
    the record is the same, to the bit, as with the default calls."""
    reference, cut = small_sim(), small_sim()
    for sim in (reference, cut):
        sim.settle(progress=False)
    sample_dt = 25 * reference.dt
    whole = reference.run(40 * sample_dt, sample_dt, sampling, progress=False)
    monkeypatch.setattr(simulation, "_CHUNK_STEPS", 7)
    counting = CountingEngine(cut._engine)
    cut._engine = counting
    parts = cut.run(40 * sample_dt, sample_dt, sampling, progress=False)
    assert max(counting.calls) == 7 and len(counting.calls) >= 40 * 25 // 7
    assert np.array_equal(parts.time_s, whole.time_s)
    assert np.array_equal(parts.torque_Nm, whole.torque_Nm)


def test_no_call_takes_more_than_the_chunk_of_particle_steps() -> None:
    sim = small_sim()
    assert sim._steps_per_call() * sim.scene.n_particles <= simulation._CHUNK_PARTICLE_STEPS
    assert sim._steps_per_call() <= simulation._CHUNK_STEPS


def test_ctrl_c_stops_a_run_between_calls() -> None:
    """SIGINT during a run of 1000 s: the run returns early with what it sampled."""
    sim = small_sim()
    sim.settle(progress=False)
    # Python's own Ctrl-C handler, as in a terminal, whatever the test runner inherited (a job
    # started in the background of a shell ignores SIGINT, and so does Python then)
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    timer = threading.Timer(0.3, signal.raise_signal, (signal.SIGINT,))
    timer.start()
    try:
        with pytest.warns(RuntimeWarning, match="run interrupted"):
            rec = sim.run(1000.0, progress=False)
    finally:
        timer.cancel()
        signal.signal(signal.SIGINT, previous)
    assert rec.meta["interrupted"] is True
    assert len(rec) < 100_000


@pytest.mark.parametrize("make, call, name", [
    (lambda: small_sim(), lambda sim: sim.run(1e300, progress=False), "duration"),
    (lambda: small_sim(dt=1e-14), lambda sim: sim.run(0.002, 0.001, progress=False),
     "settle_max_s"),
    (lambda: small_sim(dt=1e-14), lambda sim: sim.settle(progress=False), "settle_max_s"),
])
def test_absurd_step_counts_are_refused_before_any_work(make, call, name) -> None:
    sim = make()
    with pytest.raises(ValueError, match=rf"^{name} = .* steps; one call may take at most"):
        call(sim)
    assert sim.phase == "empty" and sim.positions.shape == (40, 3)


def test_a_process_that_ignores_ctrl_c_keeps_ignoring_it_during_a_run() -> None:
    """A campaign's pool worker ignores SIGINT (its campaign handles Ctrl-C): a run in it must
    not turn SIGINT back on and end its case as interrupted."""
    sim = small_sim()
    sim.settle(progress=False)
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    timer = threading.Timer(0.05, signal.raise_signal, (signal.SIGINT,))
    try:
        timer.start()
        rec = sim.run(3.0, progress=False)
        timer.join()
    finally:
        signal.signal(signal.SIGINT, previous)
    assert rec.meta["interrupted"] is False and len(rec) == 300

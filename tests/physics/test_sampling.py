"""Torque samples of the engine: every interval-mean sample covers exactly its own interval, and
a run cut into calls of any length gives the same samples (issue "Trust the numbers", item 3;
"Bad input and faults", item 4)."""

from __future__ import annotations

import numpy as np
import pytest

from .test_engine import lattice, make_engine

SOFT = (7860.0, 81e8, 0.3)


def drum(steps_before: int):  # type: ignore[no-untyped-def]
    """A small tumbling charge; the drum starts, then `steps_before` plain steps."""
    rng = np.random.default_rng(11)
    r, R, L, n = 0.0125, 0.2, 0.15, 120
    eng = make_engine(np.full(n, r), material=SOFT, drum_radius=R, length=L, lifters=8,
                      positions=lattice(n, r, R - 0.02, L, rng), threads=1)
    eng.advance(500)
    eng.start_rotation(3.0)
    eng.advance(steps_before)
    return eng


@pytest.mark.parametrize("steps_before", [0, 3, 10, 11])
def test_each_mean_sample_averages_exactly_its_interval(steps_before: int) -> None:
    """Reference: the same run's torque at every step (a twin engine, same bits), averaged by
    numpy over the steps that end in (t_(k-1), t_k]."""
    per_sample, count = 10, 6
    eng, twin = drum(steps_before), drum(steps_before)
    sample_dt = per_sample * eng.dt
    means = eng.advance_sampled(sample_dt, True, count)
    steps = twin.advance_sampled(twin.dt, False, (count + 2) * per_sample)
    offsets = np.rint(steps[:, 0] / twin.dt).astype(int)  # steps since the start of rotation
    for t_k, mean in zip(means[:, 0], means[:, 1], strict=True):
        k = int(round(t_k / sample_dt))
        inside = (offsets > (k - 1) * per_sample) & (offsets <= k * per_sample)
        assert inside.sum() == per_sample
        assert mean == pytest.approx(steps[inside, 1].mean(), rel=1e-12, abs=1e-12)
    # a call that starts between sample times begins with the first whole interval
    assert means[0, 0] == pytest.approx(sample_dt * (1 + -(-steps_before // per_sample)))


@pytest.mark.parametrize("steps_before", [0, 13])
def test_a_row_holds_both_modes_of_the_same_steps(steps_before: int) -> None:
    """Columns 1-4 in the mode asked for, 5-8 in the other: an instant run's last four columns
    are a mean run's first four to the bit (twin engines, same steps), and the other way
    round; and the instant samples are the per-step torque at the sample steps."""
    sample_dt_steps, count = 10, 7
    inst_eng, mean_eng, steps_eng = drum(steps_before), drum(steps_before), drum(steps_before)
    sample_dt = sample_dt_steps * inst_eng.dt
    inst = inst_eng.advance_sampled(sample_dt, False, count)
    mean = mean_eng.advance_sampled(sample_dt, True, count)
    assert inst.shape == mean.shape == (count, 9)
    assert np.array_equal(inst[:, 0], mean[:, 0])
    assert np.array_equal(inst[:, 5:], mean[:, 1:5])
    assert np.array_equal(mean[:, 5:], inst[:, 1:5])
    steps = steps_eng.advance_sampled(steps_eng.dt, False, (count + 3) * sample_dt_steps)
    at = {int(round(t / steps_eng.dt)): row for t, row in zip(steps[:, 0], steps[:, 1:5],
                                                               strict=True)}
    for t_k, row in zip(inst[:, 0], inst[:, 1:5], strict=True):
        assert np.array_equal(at[int(round(t_k / inst_eng.dt))], row)


@pytest.mark.parametrize("mean", [True, False])
def test_a_run_cut_into_short_calls_gives_the_same_samples(mean: bool) -> None:
    """Calls of at most 7 steps each (samples every 10 steps) that resume the sample under way
    give the samples of one long call, to the bit."""
    one, cut = drum(3), drum(3)
    sample_dt = 10 * one.dt
    whole = one.advance_sampled(sample_dt, mean, 8)
    parts, taken = [], 0
    while taken < 8:
        rows = cut.advance_sampled(sample_dt, mean, 8 - taken, 7, bool(parts))
        parts.append(rows)
        taken += len(rows)
    assert np.array_equal(np.concatenate(parts), whole)
    assert one.step_count == cut.step_count


def test_resume_refuses_a_call_that_does_not_follow_the_sampling() -> None:
    eng = drum(0)
    eng.advance_sampled(10 * eng.dt, True, 1, 4)
    eng.advance(1)
    with pytest.raises(RuntimeError, match="resume"):
        eng.advance_sampled(10 * eng.dt, True, 1, 4, True)

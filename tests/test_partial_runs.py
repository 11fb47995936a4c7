"""In-case checkpoints: a case continued from what a killed run saved gives the record of a
run that was never stopped, to the bit; unusable files are set aside, never trusted.

Cases are the balls-only tiny pilot mill (391 balls), settled for 0.05 s and run for 0.3 s.
"""

from __future__ import annotations

import contextlib
import dataclasses
import json
import math
import os
import warnings
from concurrent.futures import Future
from pathlib import Path

import numpy as np
import pytest

import millscope as ms
from millscope.campaign import Case, RunSettings, run_case, runs
from millscope.campaign.cases import distinct_runs
from millscope.campaign.executors import simulate_case
from millscope.campaign.partial import (
    PARTIAL_DIR,
    PartialFiles,
    RunTime,
    _CpuClock,
    _Progress,
    _save,
)

QUICK = RunSettings(duration_s=0.3, warm_up_s=0.05, settle_tolerance=10.0, settle_min_s=0.05,
                    settle_max_s=0.1)


def tiny_case(sampling: str = "instant") -> Case:
    return Case(ms.presets.pilot_mill(0.71, None, 1, scale="tiny"),
                QUICK.replace(sampling=sampling))


def killed_after(case: Case, folder: Path, samples: int, extra: int = 0) -> PartialFiles:
    """What a run killed after ``samples`` samples leaves: its checkpoint there and its
    samples, with ``extra`` samples more that were saved before the kill hit the checkpoint."""
    s = case.settings
    sim = case.simulation()
    report = sim.settle(progress=False)
    done = _Progress(np.empty(0), np.empty(0), np.empty(0), RunTime(1.5, 0.75), report)
    other = "mean" if s.sampling == "instant" else "instant"
    sim.run(samples * s.sample_dt, s.sample_dt, s.sampling, progress=False)
    done.extend([(sim.last_records[s.sampling], sim.last_records[other])])
    files = PartialFiles(folder, case.hash())
    _save(files, sim, done)
    if extra:
        sim.run(extra * s.sample_dt, s.sample_dt, s.sampling, progress=False)
        done.extend([(sim.last_records[s.sampling], sim.last_records[other])])
        checkpoint = files.checkpoint.read_bytes()
        _save(files, sim, done)
        files.checkpoint.write_bytes(checkpoint)  # the kill came before the new checkpoint
    return files


@pytest.fixture(scope="module")
def reference() -> dict[str, dict[str, object]]:
    """Each sampling mode's case run in one go (one Simulation.run of the whole record), in
    the layout of run_case's outcome."""
    out: dict[str, dict[str, object]] = {}
    for sampling in ("instant", "mean"):
        case = tiny_case(sampling)
        sim, rec = simulate_case(case)
        other = "mean" if sampling == "instant" else "instant"
        keep = slice(case.settings.warm_up_samples, None)
        out[sampling] = {
            "status": "done", "time_s": rec.time_s[keep], "torque_Nm": rec.torque_Nm[keep],
            "meta": {**rec.meta, "settle": dataclasses.asdict(sim.settle_report)},
            "other": {"sampling": other, "torque_Nm": sim.last_records[other].torque_Nm[keep]},
            "wall_time_s": 0.1}
    return out


def assert_same_record(outcome: dict[str, object], ref: dict[str, object]) -> None:
    assert outcome["status"] == "done", outcome.get("error")
    np.testing.assert_array_equal(outcome["time_s"], ref["time_s"])
    np.testing.assert_array_equal(outcome["torque_Nm"], ref["torque_Nm"])
    assert outcome["other"]["sampling"] == ref["other"]["sampling"]  # type: ignore[index]
    np.testing.assert_array_equal(outcome["other"]["torque_Nm"],  # type: ignore[index]
                                  ref["other"]["torque_Nm"])  # type: ignore[index]
    meta, ref_meta = outcome["meta"], ref["meta"]
    assert isinstance(meta, dict) and isinstance(ref_meta, dict)
    assert meta["settle"] == ref_meta["settle"]
    assert meta["sampling"] == ref_meta["sampling"]


@pytest.mark.parametrize("sampling", ["instant", "mean"])
@pytest.mark.parametrize("samples", [0, 7, 23])
def test_a_killed_case_goes_on_to_the_same_record(tmp_path: Path, reference: dict, sampling: str,
                                                  samples: int) -> None:
    case = tiny_case(sampling)
    files = killed_after(case, tmp_path, samples) if samples else None
    if files is None:  # killed right after settling: a checkpoint with no samples
        sim = case.simulation()
        report = sim.settle(progress=False)
        files = PartialFiles(tmp_path, case.hash())
        _save(files, sim,
              _Progress(np.empty(0), np.empty(0), np.empty(0), RunTime(1.5, 0.75), report))
    outcome = run_case(case.to_dict(), str(tmp_path), checkpoint_every_s=1e9)
    assert_same_record(outcome, reference[sampling])
    # the time the killed run had spent counts, wall and CPU; this run's CPU time is at most
    # its wall time on every core of the machine
    wall, cpu = float(outcome["wall_time_s"]) - 1.5, float(outcome["cpu_time_s"]) - 0.75
    assert 0.0 < wall and 0.0 < cpu <= wall * (os.cpu_count() or 1)


def read_samples_meta(files: PartialFiles) -> tuple[dict, dict]:
    with np.load(files.samples) as z:
        return json.loads(str(z["meta_json"][()])), {k: z[k] for k in ("time_s", "torque_Nm",
                                                                        "other_Nm")}


def test_a_checkpoint_without_cpu_time_goes_on_with_it_unknown(tmp_path: Path,
                                                                reference: dict) -> None:
    """An older version's checkpoint saved no CPU time: the case goes on to the same record,
    its CPU time not known (None), and its cost falls back on wall time x threads."""
    case = tiny_case()
    files = killed_after(case, tmp_path, 9)
    meta, arrays = read_samples_meta(files)
    assert meta["cpu_time_s"] == 0.75
    del meta["cpu_time_s"]
    np.savez(files.samples, meta_json=np.array(json.dumps(meta)), **arrays)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # not set aside
        outcome = run_case(case.to_dict(), str(tmp_path), checkpoint_every_s=1e9)
    assert_same_record(outcome, reference["instant"])
    assert outcome["cpu_time_s"] is None and float(outcome["wall_time_s"]) > 1.5


def test_samples_past_the_checkpoint_are_dropped(tmp_path: Path, reference: dict) -> None:
    case = tiny_case()
    killed_after(case, tmp_path, 11, extra=5)
    outcome = run_case(case.to_dict(), str(tmp_path), checkpoint_every_s=1e9)
    assert_same_record(outcome, reference["instant"])


def test_saving_at_every_segment_changes_nothing(tmp_path: Path, reference: dict) -> None:
    outcome = run_case(tiny_case("mean").to_dict(), str(tmp_path), checkpoint_every_s=0.0)
    assert_same_record(outcome, reference["mean"])
    files = PartialFiles(tmp_path, tiny_case("mean").hash())
    assert files.checkpoint.exists() and files.samples.exists()  # the campaign deletes them


@pytest.mark.parametrize("damage", ["checkpoint", "samples", "other_case", "too_long",
                                    "no_checkpoint", "cpu_time"])
def test_unusable_files_are_set_aside(tmp_path: Path, reference: dict, damage: str) -> None:
    case = tiny_case()
    files = killed_after(case, tmp_path, 9)
    if damage == "checkpoint":
        data = bytearray(files.checkpoint.read_bytes())
        data[len(data) // 2] ^= 0xFF
        files.checkpoint.write_bytes(bytes(data))
    elif damage == "samples":
        files.samples.write_bytes(b"not a zip")
    elif damage == "other_case":
        with np.load(files.samples) as z:
            meta = json.loads(str(z["meta_json"][()]))
            t, y, o = z["time_s"], z["torque_Nm"], z["other_Nm"]
        meta["hash"] = "0" * 64
        np.savez(files.samples, meta_json=np.array(json.dumps(meta)), time_s=t, torque_Nm=y,
                 other_Nm=o)
    elif damage == "too_long":  # more samples than the case has: refused unread
        with np.load(files.samples) as z:
            meta_json, t = z["meta_json"], z["time_s"]
        long = np.tile(t, 200)
        np.savez(files.samples, meta_json=meta_json, time_s=long, torque_Nm=long, other_Nm=long)
    elif damage == "cpu_time":
        meta, arrays = read_samples_meta(files)
        meta["cpu_time_s"] = -1.0
        np.savez(files.samples, meta_json=np.array(json.dumps(meta)), **arrays)
    else:
        files.checkpoint.unlink()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        outcome = run_case(case.to_dict(), str(tmp_path), checkpoint_every_s=1e9)
    assert_same_record(outcome, reference["instant"])
    said = [str(w.message) for w in caught if "starts afresh" in str(w.message)]
    assert len(said) == (0 if damage == "no_checkpoint" else 1)
    if said:
        assert case.hash()[:12] in said[0]


def test_a_campaign_deletes_a_stored_case_s_partial_files(tmp_path: Path) -> None:
    store = tmp_path / "store"
    camp = ms.Campaign([tiny_case().scene], store, settings=QUICK, block=(0.1, 0.3))
    killed_after(camp.cases[0], store / PARTIAL_DIR, 12)
    fresh = ms.Campaign([tiny_case().scene], tmp_path / "fresh", settings=QUICK,
                        block=(0.1, 0.3))
    ran = camp.run(max_workers=1, progress=False, checkpoint_every_s=0.0)
    ref = fresh.run(max_workers=1, progress=False, checkpoint_every_s=None)
    assert ran[0].energy == ref[0].energy and ran[0].mean_torque == ref[0].mean_torque
    left = sorted(p.name for p in (store / PARTIAL_DIR).iterdir())
    assert left == [".gitignore"]
    assert (store / PARTIAL_DIR / ".gitignore").read_text().splitlines()[-1] == "*"
    assert not (tmp_path / "fresh" / PARTIAL_DIR).exists()


@pytest.mark.parametrize("bad", [-1.0, float("nan"), "600"])
def test_a_bad_checkpoint_interval_is_refused_before_any_work(tmp_path: Path, bad: object) -> None:
    camp = ms.Campaign([tiny_case().scene], tmp_path / "store", settings=QUICK, block=None)
    with pytest.raises(ValueError, match="checkpoint_every_s"):
        camp.run(progress=False, checkpoint_every_s=bad)  # type: ignore[arg-type]
    assert not (tmp_path / "store").exists()


def test_one_run_gives_both_sampling_modes_to_the_bit(reference: dict) -> None:
    """The instant case's run carries the mean case's record, equal to the mean case's own."""
    for mine, other in (("instant", "mean"), ("mean", "instant")):
        carried = reference[mine]["other"]
        assert carried["sampling"] == other
        np.testing.assert_array_equal(carried["torque_Nm"], reference[other]["torque_Nm"])
    # the two modes differ: the mean of an interval is not the torque of one of its steps
    assert not np.array_equal(reference["mean"]["torque_Nm"], reference["instant"]["torque_Nm"])


def test_a_campaign_runs_two_sampling_twins_once(tmp_path: Path, reference: dict) -> None:
    cases = [tiny_case("instant"), tiny_case("mean")]
    camp = ms.Campaign(cases, tmp_path / "store", block=(0.1, 0.3))
    results = camp.run(max_workers=1, progress=False)
    assert all(r.ok for r in results)
    for r, sampling in zip(results, ("instant", "mean"), strict=True):
        assert r.record is not None and r.record.meta["sampling"] == sampling
        np.testing.assert_array_equal(r.record.torque_Nm, reference[sampling]["torque_Nm"])
    # one run: both cases were made by the same worker process in the same time
    infos = [r.record.meta["campaign"] for r in results if r.record is not None]
    assert infos[0]["pid"] == infos[1]["pid"]
    assert infos[0]["wall_time_s"] == infos[1]["wall_time_s"]
    assert infos[0]["cpu_time_s"] == infos[1]["cpu_time_s"]
    # the worker's CPU time: more than none, at most its wall time on every core
    assert 0.0 < results[0].cpu_time_s <= results[0].wall_time_s * (os.cpu_count() or 1)
    manifest = runs.read_manifest(tmp_path / "store")["cases"]
    assert [e["cpu_time_s"] for e in manifest] == [r.cpu_time_s for r in results]
    # times a case file states are taken only when they are numbers >= 0 (files are untrusted)
    path = tmp_path / "store" / manifest[0]["file"]
    rec = ms.TorqueRecord.load(path)
    for wall, cpu in ((True, -1.0), ("12", float("inf")), (-3.0, None)):
        rec.meta["campaign"].update(wall_time_s=wall, cpu_time_s=cpu)
        rec.save(path)
        read = camp.results()[0]
        assert read.ok and math.isnan(read.wall_time_s) and math.isnan(read.cpu_time_s)
        assert math.isnan(read.core_hours)


def test_the_cpu_clock_of_cases_that_overlap_in_one_process_is_not_known() -> None:
    """The process's CPU clock counts every thread: a case during which another ran in the same
    process (threads of a dask worker) reads nan, a case alone its process's CPU time."""
    with _CpuClock() as alone:
        start = os.times()
        sum(i * i for i in range(200_000))  # some CPU time
        spent = alone.elapsed()
        end = os.times()
    ticks = 2 / os.sysconf("SC_CLK_TCK")  # os.times counts whole clock ticks
    assert 0.0 < spent <= (end.user + end.system) - (start.user + start.system) + ticks
    with _CpuClock() as first:
        assert math.isfinite(first.elapsed())
        with _CpuClock() as second:
            assert math.isnan(second.elapsed()) and math.isnan(first.elapsed())
        assert math.isnan(first.elapsed())  # its clock counted the other case's time
    with _CpuClock() as after:
        assert math.isfinite(after.elapsed())


def test_twins_from_one_run_cost_one_run_of_the_engines_particle_steps(tmp_path: Path) -> None:
    """distinct_runs keeps one of two twins one run stored and both of twins run apart (other
    wall times); a case's particle-steps are its particles x the steps the engine took to
    settle and rotate; its core-hours are its CPU time, or wall time x threads when that is
    not known."""
    cases = [tiny_case("instant"), tiny_case("mean")]
    results = ms.Campaign(cases, tmp_path / "store", block=None).run(max_workers=1,
                                                                     progress=False)
    assert [r.hash for r in distinct_runs(results)] == [results[0].hash]
    apart = dataclasses.replace(results[1], wall_time_s=results[1].wall_time_s + 1.0)
    assert [r.hash for r in distinct_runs([results[0], apart])] == [r.hash for r in results]
    sim = cases[0].simulation()
    sim.settle(progress=False)
    sim.run(QUICK.duration_s, QUICK.sample_dt, "instant", progress=False)
    steps = sim._engine.step_count  # every step since the fill
    assert steps > QUICK.duration_s / sim.dt  # settling took steps too
    for r in results:
        assert r.particle_steps == r.scene.n_particles * steps
    assert results[0].core_hours == results[0].cpu_time_s / 3600.0
    doubled = dataclasses.replace(results[0], case=Case(cases[0].scene,
                                                        QUICK.replace(threads=2)),
                                  cpu_time_s=math.nan)
    assert doubled.core_hours == pytest.approx(2 * results[0].wall_time_s / 3600.0, rel=1e-15)


def test_a_twin_whose_run_brings_no_other_mode_is_failed_not_lost(tmp_path: Path) -> None:
    """An executor whose results lack the other mode's samples (an older worker): the case it
    ran is stored, its twin is recorded as failed with the reason, and a rerun retries it."""
    class Stripping:
        def submit(self, fn, case, *rest):  # noqa: ANN001, ANN202 - runs in the caller
            future: Future = Future()
            outcome = fn(case, *rest)
            outcome.pop("other", None)
            future.set_result(outcome)
            return future

    camp = ms.Campaign([tiny_case("instant"), tiny_case("mean")], tmp_path / "store",
                       block=None)
    first, second = camp.run(Stripping(), progress=False)
    assert first.ok and second.status == "failed"
    assert second.error is not None and "returned no samples in the other sampling mode" in \
        second.error
    again = camp.run(max_workers=1, progress=False)  # the failed twin is retried, alone
    assert all(r.ok for r in again)


def test_the_saved_share_is_what_the_last_checkpoint_holds(tmp_path: Path) -> None:
    from millscope.campaign.partial import saved_share

    case = tiny_case()
    files = PartialFiles(tmp_path, case.hash())
    assert saved_share(files, case.settings.total_samples) is None  # nothing saved yet
    killed_after(case, tmp_path, 12)
    assert saved_share(files, case.settings.total_samples) == 12 / case.settings.total_samples
    files.samples.write_bytes(b"half written")
    assert saved_share(files, case.settings.total_samples) is None


def test_the_campaign_bar_shows_how_far_a_long_case_has_saved(tmp_path: Path) -> None:
    """A case under way is shown by its last checkpoint's share of its samples, beside the
    failed cases; an executor that answers only after its case was saved makes the bar tick
    on it."""

    notes: list[str] = []

    class Recording:
        def __init__(self, **kwargs: object) -> None:
            self.kwargs = kwargs

        def __enter__(self) -> Recording:
            return self

        def __exit__(self, *exc: object) -> None:
            return None

        def set_postfix_str(self, text: str, refresh: bool = True) -> None:
            notes.append(text)

        def refresh(self) -> None:
            return None

        def update(self, n: int) -> None:
            return None

    class Slow:
        """Saves 12 samples of the case as a killed run would, then lets the campaign wait
        one tick before the result comes."""

        def submit(self, fn, case, partial, every):  # noqa: ANN001, ANN202
            killed_after(Case.from_dict(case), Path(partial), 12)
            self.future: Future = Future()
            self.outcome = fn(case, partial, every)
            return self.future

    slow = Slow()
    real_completed = runs._completed

    def completed(executor, futures, tick=None):  # noqa: ANN001, ANN202
        assert tick is not None
        tick()  # the campaign waits: the bar shows the saved share
        slow.future.set_result(slow.outcome)
        yield from real_completed(executor, futures, tick)

    camp = ms.Campaign([tiny_case()], tmp_path / "store", block=None)
    total = camp.cases[0].settings.total_samples
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(runs, "_completed", completed)
        mp.setattr(runs, "_bar", lambda *a: contextlib.nullcontext(Recording()))
        assert camp.run(slow, progress=False)[0].ok
    assert notes[0] == f"saved {100 * 12 / total:.0f} %"
    assert notes[-1] == ""  # the case is done: nothing under way


def test_the_pace_of_a_case_under_way_gives_the_time_it_has_left() -> None:
    """Shares seen at known times (a fake clock): the time left is the share still to run over
    the pace between the saves seen, less the time since the last save, worked by hand. The
    share first seen (an older save, perhaps of a case still queued) starts no pace."""
    from millscope.campaign.partial import SavedPace

    now = [0.0]
    pace = SavedPace(clock=lambda: now[0])
    seen = []
    for t, share in [(0.0, 0.40), (3000.0, 0.40), (3600.0, 0.46), (3900.0, 0.46),
                     (4200.0, 0.52), (5400.0, 0.64), (9400.0, 0.97)]:
        now[0] = t
        seen.append((pace.left_s("a", share), pace.note("a", share)))
    # the queue: no pace from 0.40, seen long before the case ran; one save: still none
    assert [x[0] for x in seen[:4]] == [None] * 4
    assert [x[1] for x in seen[:4]] == ["40 %", "40 %", "46 %", "46 %"]
    # 6 % from 3600 s to 4200 s: 1e-4 per s, 0.48 left: 4800 s
    assert seen[4][0] == pytest.approx(4800.0) and seen[4][1] == "52 % (~1.3 h left)"
    assert seen[5][0] == pytest.approx(0.36 / 1e-4)  # 18 % in 1800 s
    # 51 % in 5800 s: 0.03 left at 8.793e-5 per s
    assert seen[6][0] == pytest.approx(0.03 / (0.51 / 5800)) and seen[6][1] == "97 % (~6 min left)"
    now[0] = 9400.0 + 60.0  # a minute after the last save, a minute less
    assert pace.left_s("a", 0.97) == pytest.approx(0.03 / (0.51 / 5800) - 60.0)
    now[0] = 1e5  # long past the pace's end: nothing left, not a negative time
    assert pace.left_s("a", 0.97) == 0.0
    assert pace.left_s("b", 0.10) is None  # another case has its own saves

"""Campaign: resumable store, kill and resume, dask against local processes, failures, hashes.

Cases are the balls-only tiny pilot mill (391 balls) settled for 0.05 s and run for 0.3 s:
about half a second each, plus about 2 s to start a pool of spawned processes.
"""

from __future__ import annotations

import contextlib
import dataclasses
import fcntl
import json
import os
import select
import signal
import subprocess
import sys
import textwrap
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np
import pytest

import millscope as ms
from millscope.campaign import (
    CASE_FORMAT,
    Case,
    RunSettings,
    case_matrix,
    paper_matrix,
    read_manifest,
    unreadable_cases,
)
from millscope.simulation import _available_cores

QUICK = RunSettings(duration_s=0.3, settle_tolerance=10.0, settle_min_s=0.05, settle_max_s=0.1)
BLOCK = (0.1, 0.3)
SPEEDS = (0.62, 0.71, 0.80)


def tiny(speed: float = 0.71) -> ms.Scene:
    return ms.presets.pilot_mill(speed, None, 1, scale="tiny")


def campaign(store: Path, speeds: tuple[float, ...] = SPEEDS) -> ms.Campaign:
    return ms.Campaign([tiny(s) for s in speeds], store, settings=QUICK, block=BLOCK)


def temporaries(store: Path) -> list[Path]:
    return sorted(store.rglob("*.tmp"))


def file_ids(paths: list[Path]) -> dict[str, tuple[int, int]]:
    return {p.name: (p.stat().st_ino, p.stat().st_mtime_ns) for p in paths}


def live_processes(group: int) -> list[int]:
    """Processes of a process group that are not zombies (Linux /proc)."""
    out = []
    for stat in Path("/proc").glob("[0-9]*/stat"):
        with contextlib.suppress(OSError):
            fields = stat.read_text().rsplit(")", 1)[1].split()
            if int(fields[2]) == group and fields[0] != "Z":
                out.append(int(stat.parent.name))
    return out


def assert_manifest_matches_files(store: Path, camp: ms.Campaign) -> None:
    manifest = read_manifest(store)
    entries = {e["hash"]: e for e in manifest["cases"]}
    on_disk = {p.stem for p in (store / "cases").glob("*.npz")}
    done = {h for h, e in entries.items() if e["status"] == "done"}
    assert done == on_disk
    for h in done:
        assert entries[h]["file"] == f"cases/{h}.npz"
    assert [e["hash"] for e in manifest["cases"][: len(camp)]] == list(camp.hashes)
    assert manifest["counts"]["done"] == len(done)


# -- (a) killed, then resumed --------------------------------------------------------------------

KILLED_RUN = """
import sys
import millscope as ms
from millscope.campaign import RunSettings

if __name__ == "__main__":
    settings = RunSettings(duration_s=0.3, settle_tolerance=10.0, settle_min_s=0.05,
                           settle_max_s=0.1)
    scenes = [ms.presets.pilot_mill(s, None, 1, scale="tiny") for s in (0.62, 0.71, 0.80)]
    camp = ms.Campaign(scenes, sys.argv[1], settings=settings, block=(0.1, 0.3))
    camp.run(max_workers=1, progress=False)
"""


def test_a_killed_campaign_resumes_without_recomputing_finished_cases(tmp_path: Path) -> None:
    store = tmp_path / "store"
    script = tmp_path / "run.py"
    script.write_text(textwrap.dedent(KILLED_RUN))
    proc = subprocess.Popen([sys.executable, str(script), str(store)], start_new_session=True,
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    deadline = time.monotonic() + 120.0
    try:
        while not list((store / "cases").glob("*.npz")):
            assert proc.poll() is None, proc.stderr.read().decode() if proc.stderr else ""
            assert time.monotonic() < deadline, "no case finished within 120 s"
            time.sleep(0.01)
    finally:
        os.killpg(proc.pid, signal.SIGKILL)  # the campaign and its worker processes
        proc.wait()
        if proc.stderr:
            proc.stderr.close()
    assert proc.returncode == -signal.SIGKILL
    finished = sorted((store / "cases").glob("*.npz"))
    assert 1 <= len(finished) < 3
    before = file_ids(finished)
    # as a kill can leave them: a manifest that knows nothing, a temporary file of a write
    manifest = read_manifest(store)
    (store / "manifest.json").write_text(json.dumps({**manifest, "cases": []}))
    (store / "cases" / f".{finished[0].name}.x1y2z3.tmp").write_bytes(b"half a file")

    camp = campaign(store)
    results = camp.run(progress=False)

    assert [r.status for r in results] == ["done"] * 3
    assert file_ids(finished) == before  # the finished cases were not run again
    assert temporaries(store) == []
    assert_manifest_matches_files(store, camp)
    assert {p.stem for p in (store / "cases").iterdir()} == set(camp.hashes)
    for r in results:
        assert r.record is not None and len(r.record) == 30
        assert r.record.meta["campaign"]["hash"] == r.hash
        assert np.isfinite([r.mean_torque, r.lth_amplitude, r.energy]).all()
        assert r.mean_torque > 0  # the drive supplies torque to the charge


INTERRUPTED_RUN = KILLED_RUN.replace(
    "    camp.run(max_workers=1, progress=False)",
    """    try:
        camp.run(max_workers=1, progress=False)
    except KeyboardInterrupt:
        print("interrupted:", " ".join(r.status for r in camp.results()))""")


def test_ctrl_c_stops_at_once_and_keeps_finished_cases(tmp_path: Path) -> None:
    store = tmp_path / "store"
    script = tmp_path / "run.py"
    script.write_text(textwrap.dedent(INTERRUPTED_RUN))
    proc = subprocess.Popen([sys.executable, str(script), str(store)], start_new_session=True,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    deadline = time.monotonic() + 120.0
    try:
        while not list((store / "cases").glob("*.npz")):
            assert proc.poll() is None and time.monotonic() < deadline
            time.sleep(0.01)
        os.kill(proc.pid, signal.SIGINT)  # the campaign only, not its workers
        out, err = proc.communicate(timeout=30.0)
    finally:
        with contextlib.suppress(ProcessLookupError):
            os.killpg(proc.pid, signal.SIGKILL)
    assert proc.returncode == 0, err
    statuses = out.split("interrupted:")[1].split()
    assert statuses[0] == "done" and "pending" in statuses
    deadline = time.monotonic() + 10.0  # multiprocessing's resource tracker ends on its own
    while live_processes(proc.pid) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert live_processes(proc.pid) == []  # no worker process is left running
    assert temporaries(store) == []
    assert_manifest_matches_files(store, campaign(store))
    assert [e["status"] for e in read_manifest(store)["cases"]] == statuses


# -- a script without a main guard; workers that end with their campaign -----------------------

UNGUARDED_RUN = """
import sys
import millscope as ms
from millscope.campaign import RunSettings

print("the script runs", flush=True)
settings = RunSettings(duration_s=0.3, settle_tolerance=10.0, settle_min_s=0.05,
                       settle_max_s=0.1)
scenes = [ms.presets.pilot_mill(0.71, None, 1, scale="tiny")]
camp = ms.Campaign(scenes, sys.argv[1], settings=settings, block=(0.1, 0.3))
print(" ".join(r.status for r in camp.run(max_workers=1, progress=False)))
"""


@pytest.mark.parametrize("how", ["path", "module"])
def test_a_script_without_a_main_guard_runs_its_campaign(tmp_path: Path, how: str) -> None:
    """The README's snippet as a plain script (``python camp.py``, or ``python -m camp``):
    the pool's workers must not run it again (before, each started the campaign anew and
    failed on the store's lock, and the pool broke)."""
    store = tmp_path / "store"
    (tmp_path / "camp.py").write_text(textwrap.dedent(UNGUARDED_RUN))
    start = [str(tmp_path / "camp.py")] if how == "path" else ["-m", "camp"]
    out = subprocess.run([sys.executable, *start, str(store)], cwd=tmp_path, timeout=120,
                         capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    assert out.stdout.splitlines() == ["the script runs", "done"]  # its body ran once
    assert read_manifest(store)["counts"] == {"done": 1, "failed": 0, "pending": 0}
    (result,) = campaign(store, (0.71,)).results()
    assert result.status == "done" and result.record is not None and len(result.record) == 30


def reads_to_eof(fd: int, seconds: float) -> bool:
    """True when the pipe ``fd`` reaches end of file (every writer closed it) in time."""
    deadline = time.monotonic() + seconds
    while (left := deadline - time.monotonic()) > 0:
        if select.select([fd], [], [], left)[0] and not os.read(fd, 65536):
            return True
    return False


@pytest.mark.parametrize("sig", [signal.SIGKILL, signal.SIGTERM])
def test_workers_end_with_a_killed_campaign(tmp_path: Path, sig: int) -> None:
    """The campaign process alone is killed while its worker runs the second of three cases:
    the worker must end at once, multiprocessing's resource tracker with it, and nothing may
    keep the campaign's stdout open (before, the worker finished its cases and then waited on
    its queue for ever)."""
    store = tmp_path / "store"
    script = tmp_path / "run.py"
    script.write_text(textwrap.dedent(KILLED_RUN))
    proc = subprocess.Popen([sys.executable, str(script), str(store)], start_new_session=True,
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT)
    assert proc.stdout is not None
    deadline = time.monotonic() + 120.0
    try:
        while not list((store / "cases").glob("*.npz")):
            assert proc.poll() is None and time.monotonic() < deadline
            time.sleep(0.01)
        os.kill(proc.pid, sig)  # the campaign only, not its process group
        assert proc.wait(timeout=30.0) == -sig
        assert reads_to_eof(proc.stdout.fileno(), 30.0), "a process still holds the stdout"
        deadline = time.monotonic() + 30.0
        while live_processes(proc.pid) and time.monotonic() < deadline:
            time.sleep(0.05)
        assert live_processes(proc.pid) == []
    finally:
        with contextlib.suppress(ProcessLookupError):
            os.killpg(proc.pid, signal.SIGKILL)
        proc.stdout.close()
    assert unreadable_cases(store) == []  # every file the campaign wrote is whole
    finished = [r for r in campaign(store).results() if r.status == "done"]
    assert 1 <= len(finished) < 3


# -- (b) dask against local processes ----------------------------------------------------------


def test_b_dask_cluster_gives_the_same_torque_as_local_processes(tmp_path: Path) -> None:
    distributed = pytest.importorskip("distributed")
    local = campaign(tmp_path / "local", (0.62, 0.80)).run(
        max_workers=min(2, _available_cores()), progress=False)
    with distributed.LocalCluster(n_workers=1, processes=True, threads_per_worker=1,
                                  dashboard_address=None) as cluster, \
            distributed.Client(cluster) as client:
        remote = campaign(tmp_path / "dask", (0.62, 0.80)).run(executor=client, progress=False)
    for a, b in zip(local, remote, strict=True):
        assert a.status == b.status == "done"
        assert a.hash == b.hash
        assert a.record is not None and b.record is not None
        assert a.record.time_s.tobytes() == b.record.time_s.tobytes()
        assert a.record.torque_Nm.tobytes() == b.record.torque_Nm.tobytes()
        assert a.record.meta["campaign"]["pid"] != b.record.meta["campaign"]["pid"]
        assert (a.mean_torque, a.lth_amplitude, a.energy) == (b.mean_torque, b.lth_amplitude,
                                                              b.energy)


# -- (c) a failing case --------------------------------------------------------------------------


def unfillable() -> ms.Scene:
    """Passes the Scene's check (solid volume < 0.64 x free volume: up to 2341 balls) but not
    the filling lattice (1707 sites in the 0.05 m slice): fails inside the worker."""
    scene = tiny()
    (balls,) = scene.charge
    return scene.replace(charge=(dataclasses.replace(balls, count=2000),), name="too-many")


def test_c_a_failing_case_is_recorded_and_the_others_finish(tmp_path: Path) -> None:
    store = tmp_path / "store"
    camp = ms.Campaign([unfillable(), tiny(0.71)], store, settings=QUICK, block=BLOCK)
    bad, good = camp.run(progress=False)

    assert good.status == "done" and good.ok and good.record is not None
    assert bad.status == "failed" and not bad.ok and bad.record is None
    assert bad.error is not None and bad.error.startswith("ValueError: the charge does not fit")
    assert bad.traceback is not None and "fill_positions" in bad.traceback
    assert np.isnan(bad.energy)
    failure = store / "cases" / f"{bad.hash}.failed.json"
    info = json.loads(failure.read_text())
    assert info["error"] == bad.error and Case.from_dict(info["case"]).hash() == bad.hash
    entries = {e["hash"]: e for e in read_manifest(store)["cases"]}
    assert entries[bad.hash]["status"] == "failed"
    assert entries[bad.hash]["error"] == bad.error
    assert entries[bad.hash]["file"] == f"cases/{bad.hash}.failed.json"
    assert_manifest_matches_files(store, camp)

    kept = file_ids([store / "cases" / f"{good.hash}.npz", failure])
    assert camp.run(progress=False, retry_failed=False)[0].status == "failed"
    assert file_ids([store / "cases" / f"{good.hash}.npz", failure]) == kept  # nothing ran
    with ThreadPoolExecutor(1) as pool:  # any concurrent.futures executor
        bad2, good2 = camp.run(pool, progress=False)
    assert bad2.status == "failed" and good2.status == "done"
    assert file_ids([store / "cases" / f"{good.hash}.npz"]) == {
        f"{good.hash}.npz": kept[f"{good.hash}.npz"]}
    assert temporaries(store) == []


# -- (d) the hash --------------------------------------------------------------------------------

HASH_SCRIPT = """
import millscope as ms
from millscope.campaign import Case, RunSettings
scene = ms.presets.pilot_mill(0.71, "ceramic", 3, scale="small")
print(Case(scene, RunSettings(seed=2, duration_s=3.0, threads=2)).hash())
"""


def test_d_hash_is_stable_across_processes() -> None:
    case = Case(ms.presets.pilot_mill(0.71, "ceramic", 3, scale="small"),
                RunSettings(seed=2, duration_s=3.0, threads=2))
    env = {**os.environ, "PYTHONHASHSEED": "12345"}
    out = subprocess.run([sys.executable, "-c", HASH_SCRIPT], env=env, check=True,
                         capture_output=True, text=True).stdout.strip()
    assert out == case.hash()
    assert len(out) == 64 and int(out, 16) >= 0
    # equal cases built apart hash alike; ints and floats of the same value too
    again = Case(ms.presets.paper_cases("ceramic", 0.71, 3, scale="small")[0],
                 RunSettings(seed=2, duration_s=3, threads=2))
    assert again.hash() == case.hash()
    assert json.loads(case.canonical_json())["format"] == CASE_FORMAT


@pytest.mark.parametrize("change", [
    {"seed": 1}, {"duration_s": 3.01}, {"warm_up_s": 1.0}, {"sample_dt": 0.005},
    {"sampling": "mean"}, {"threads": 1}, {"dt": 1e-5}, {"settle_tolerance": 1e-3},
    {"settle_min_s": 0.3}, {"settle_max_s": 4.0},
])
def test_d_hash_changes_with_every_setting(change: dict[str, object]) -> None:
    scene = ms.presets.pilot_mill(0.71, "ceramic", 3, scale="small")
    settings = RunSettings(seed=2, duration_s=3.0, threads=2)
    assert Case(scene, settings.replace(**change)).hash() != Case(scene, settings).hash()


def test_d_hash_changes_with_the_scene() -> None:
    settings = RunSettings()
    hashes = {Case(s, settings).hash() for s in (
        tiny(0.71), tiny(0.72), tiny(0.71).replace(name="other"),
        ms.presets.pilot_mill(0.71, None, 1, scale="small"),
        ms.presets.pilot_mill(0.71, "steel", 1, scale="tiny"),
        ms.presets.pilot_mill(0.71, "steel", 2, scale="tiny"))}
    assert len(hashes) == 6
    fields = {f.name for f in dataclasses.fields(RunSettings)}
    assert set(json.loads(Case(tiny(), settings).canonical_json())["settings"]) == fields


# -- the case matrix -----------------------------------------------------------------------------


def test_case_matrix_and_paper_matrix() -> None:
    cases = paper_matrix(["ceramic", "steel"], [0.80, 0.71, 0.62], range(1, 8), "tiny")
    assert len(cases) == 42
    assert [c.scene.name for c in cases[:8]] == [
        "LDHS#1", "LDHS#2", "LDHS#3", "LDHS#4", "LDHS#5", "LDHS#6", "LDHS#7", "LDMS#1"]
    assert len({c.hash() for c in cases}) == 42
    seeded = case_matrix([tiny(0.62), tiny(0.80)], seeds=[0, 1, 2], duration_s=2.0)
    assert [(c.scene.name, c.settings.seed) for c in seeded] == [
        (n, s) for n in ("balls-LS", "balls-HS") for s in (0, 1, 2)]
    assert {c.settings.duration_s for c in seeded} == {2.0}
    camp = ms.Campaign([tiny(0.62), seeded[3]], "unused", seeds=[3, 4], duration=5.0,
                       block=None)
    assert [(c.scene.name, c.settings.seed, c.settings.duration_s) for c in camp.cases] == [
        ("balls-LS", 3, 5.0), ("balls-LS", 4, 5.0), ("balls-HS", 0, 2.0)]


# -- the store without running -----------------------------------------------------------------


def test_results_before_running_and_a_damaged_file_are_pending(tmp_path: Path) -> None:
    camp = campaign(tmp_path / "store")
    assert [r.status for r in camp.results()] == ["pending"] * 3
    assert not (tmp_path / "store").exists()  # nothing is written before run()
    camp.case_file(0).parent.mkdir(parents=True)
    camp.case_file(0).write_bytes(b"PK\x03\x04 not a whole file")
    damaged = camp.results()[0]
    assert damaged.status == "pending"  # the next run computes it again
    assert damaged.error == (f"unreadable case file cases/{camp.hashes[0]}.npz: not a "
                             "millscope record (BadZipFile: File is not a zip file)")


def test_a_case_file_with_nan_torque_is_computed_again(tmp_path: Path) -> None:
    """A finished case's file whose torque holds a NaN counted as done for the run (never
    computed again) but as pending for the results; now it is unreadable, and a rerun
    computes it. Cases answered with synthetic records (tests/synthetic_campaign.py)."""
    from .synthetic_campaign import SyntheticExecutor, synthetic_store

    store = tmp_path / "store"
    scenes = ms.presets.paper_cases("ceramic", 0.71, [1, 2], scale="tiny")
    first = synthetic_store(store, scenes)
    path = store / "cases" / f"{first[1].hash}.npz"
    with np.load(path) as npz:
        arrays = {name: npz[name] for name in npz.files}
    arrays["torque_Nm"] = np.where(np.arange(arrays["torque_Nm"].size) == 3, np.nan,
                                   arrays["torque_Nm"])
    path.unlink()
    np.savez(path, **arrays)
    (bad,) = unreadable_cases(store)
    assert bad.file == f"cases/{path.name}" and "torque_Nm[3] = nan is not finite" in bad.reason
    camp = ms.Campaign(scenes, store, duration=14.0, block=(4.0, 14.0))
    assert [r.status for r in camp.results()] == ["done", "pending"]
    executor = SyntheticExecutor()
    again = camp.run(executor=executor, progress=False)
    assert executor.submitted == 1
    assert [r.status for r in again] == ["done", "done"]
    assert again[1].energy == first[1].energy  # the same synthetic record as before
    assert unreadable_cases(store) == []


def test_a_damaged_failure_record_is_unreadable_unless_the_case_finished(tmp_path: Path
                                                                         ) -> None:
    """A failed case's JSON cut short is listed with its reason (and its case is pending with
    that reason); beside a whole finished file of the same case it does not matter."""
    from .synthetic_campaign import synthetic_store

    store = tmp_path / "store"
    scenes = ms.presets.paper_cases("ceramic", 0.71, [1, 2], scale="tiny")
    done, failed = synthetic_store(store, scenes, fail=["LDMS#2"])
    failure = store / "cases" / f"{failed.hash}.failed.json"
    whole = failure.read_text()
    failure.write_text(whole[:40])
    (bad,) = unreadable_cases(store)
    assert (bad.file, bad.name) == (f"cases/{failure.name}", "LDMS#2 seed 0")
    assert bad.reason.startswith("not valid JSON (Expecting ")
    result = ms.Campaign(scenes, store, duration=14.0).results()[1]
    assert result.status == "pending" and result.error is not None and bad.reason in result.error
    (store / "cases" / f"{done.hash}.failed.json").write_text(whole[:40])  # beside a whole npz
    failure.write_text(whole)
    assert unreadable_cases(store) == []


def test_a_store_in_use_is_refused(tmp_path: Path) -> None:
    store = tmp_path / "store"
    store.mkdir()
    with open(store / ".lock", "a+") as fh:
        fcntl.flock(fh.fileno(), fcntl.LOCK_EX)
        with pytest.raises(RuntimeError, match="in use by another campaign"):
            campaign(store).run(progress=False)


# -- bad input, refused before any work -----------------------------------------------------


@pytest.mark.parametrize(("make", "match"), [
    (lambda: RunSettings(seed=-1), r"RunSettings.seed = -1 is not valid; it must be an integer "
                                   r">= 0"),
    (lambda: RunSettings(duration_s=0.0), r"RunSettings.duration_s = 0.0 s .* in \(0, 3600\] s"),
    (lambda: RunSettings(duration_s=1e308), r"RunSettings.duration_s = 1e\+308 s .* in \(0, 3600"),
    (lambda: RunSettings(duration_s=1.0, warm_up_s=1.0),
     r"RunSettings.warm_up_s = 1.0 s .* in \[0, duration_s = 1\) s"),
    (lambda: RunSettings(duration_s=1.0, warm_up_s=0.995),
     r"RunSettings.warm_up_s = 0.995 s .* 2 samples remain"),
    (lambda: RunSettings(sampling="median"), r"RunSettings.sampling = 'median' .* 'instant', "
                                             r"'mean'"),
    (lambda: RunSettings(threads=0), r"RunSettings.threads = 0 .* >= 1"),
    (lambda: RunSettings(settle_min_s=2.0, settle_max_s=1.0),
     r"RunSettings.settle_max_s = 1.0 s .* >= settle_min_s = 2 s"),
    (lambda: Case(tiny(), RunSettings(dt=1.0)), r"RunSettings.dt = 1.0 s .* in \(0, "),
    (lambda: Case(tiny(), RunSettings(sample_dt=1e-6)),
     r"RunSettings.sample_dt = 1e-06 s .* >= the time step"),
    (lambda: ms.Campaign([tiny()], "x", settings=QUICK, block=(0.2, 0.5)),
     r"block = \(0.2, 0.5\) is not valid; it must be within the record of cases\[0\] "
     r"\(balls-MS seed 0\), \[warm_up_s, duration_s\] = \[0, 0.3\] s"),
    (lambda: ms.Campaign([tiny()], "x", settings=QUICK, block=(0.1, 0.12)),
     r"block = .* at least 4 samples"),
    (lambda: ms.Campaign([tiny()], "x", settings=QUICK.replace(sample_dt=0.1, duration_s=1.0),
                         block=(0.2, 1.0)),
     r"RunSettings.sample_dt = 0.1 s .* below the Nyquist frequency"),
    (lambda: ms.Campaign([tiny(), tiny()], "x"), r"cases\[0\] and cases\[1\] are the same case"),
    (lambda: ms.Campaign([tiny(), "LDMS#1"], "x"), r"cases\[1\] = 'LDMS#1' .* Scene or a Case"),
    (lambda: ms.Campaign([], "x"), r"cases = \[\] .* non-empty"),
    (lambda: ms.Campaign([tiny()], "x", seeds=[0, 0]), r"seeds = \[0, 0\] .* free of repeats"),
    (lambda: ms.Campaign([tiny()], "x", duration=-1.0), r"duration = -1.0 s .* > 0"),
    (lambda: ms.Campaign([tiny()], "x", bandwidth=0), r"bandwidth = 0 Hz .* > 0"),
    (lambda: ms.Campaign([tiny()], "x", window="hamming"), r"window = 'hamming' .* 'hann'"),
])
def test_bad_input_is_refused_with_name_value_and_range(make, match) -> None:  # type: ignore[no-untyped-def]
    with pytest.raises(ValueError, match=match):
        make()


def test_bad_run_arguments_are_refused_before_any_work(tmp_path: Path) -> None:
    store = tmp_path / "store"
    camp = campaign(store)
    cores = _available_cores()
    with pytest.raises(ValueError, match=rf"max_workers = {cores + 1} .* <= {cores}"):
        camp.run(max_workers=cores + 1)
    with pytest.raises(ValueError, match="max_workers = 0 .* >= 1"):
        camp.run(max_workers=0)
    with pytest.raises(ValueError, match="executor = 'local' .* submit"):
        camp.run("local")
    with ThreadPoolExecutor(1) as pool, pytest.raises(ValueError, match="max_workers = 2"):
        camp.run(pool, max_workers=2)
    heavy = ms.Campaign([tiny()], store, settings=QUICK.replace(threads=cores + 1), block=BLOCK)
    with pytest.raises(ValueError, match=rf"RunSettings.threads = {cores + 1} .* <= {cores}"):
        heavy.run()
    (tmp_path / "file").write_text("")
    with pytest.raises(ValueError, match="store = .* a directory"):
        ms.Campaign([tiny()], tmp_path / "file")
    assert not store.exists()


# -- (f) reading a store back, as analysed -------------------------------------------------------


def test_a_store_is_read_back_as_its_campaign_analysed_it(tmp_path: Path) -> None:
    """Cases answered with synthetic records (tests/synthetic_campaign.py) instead of DEM runs:
    the store code is the real one."""
    from millscope.analysis import AnalysisSettings

    from .synthetic_campaign import synthetic_store

    store = tmp_path / "store"
    scenes = ms.presets.paper_cases("ceramic", 0.71, [1, 2], scale="tiny")
    results = synthetic_store(store, scenes, seeds=(0, 1), fail=["LDMS#2"], block=(3.0, 13.0))
    assert [r.status for r in results] == ["done", "done", "failed", "failed"]
    settings = AnalysisSettings((3.0, 13.0), 0.3, "hann")
    assert read_manifest(store)["analysis"] == settings.to_dict()
    camp = ms.Campaign.from_store(store)
    assert camp.analysis == settings
    again = camp.results()
    assert [r.hash for r in again] == [r.hash for r in results]
    for a, b in zip(results, again, strict=True):
        assert (b.status, b.analysis) == (a.status, a.analysis)
        if a.status == "done":
            assert (b.energy, b.lth_amplitude) == (a.energy, a.lth_amplitude)
    assert ms.Campaign.from_store(store, block=(1.0, 11.0)).analysis.block == (1.0, 11.0)
    # a store written before the manifest recorded the analysis gets the Campaign defaults
    manifest = json.loads((store / "manifest.json").read_text())
    del manifest["analysis"]
    (store / "manifest.json").write_text(json.dumps(manifest))
    assert ms.Campaign.from_store(store).analysis == AnalysisSettings((4.0, 14.0), 0.3, "hann")
    (store / "manifest.json").unlink()  # no manifest at all: the case files alone
    assert len(ms.Campaign.from_store(store).cases) == 4


def test_from_store_refuses_what_is_not_a_store(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="store = .* an existing campaign store directory"):
        ms.Campaign.from_store(tmp_path / "none")
    with pytest.raises(ValueError, match="holds no case file"):
        ms.Campaign.from_store(tmp_path)


# -- cases shared with another store ------------------------------------------------------


def test_adopt_copies_the_finished_cases_another_store_holds(tmp_path: Path) -> None:
    """A campaign sharing cases with an earlier one copies their files (the same bytes, so the
    same results) and runs only the rest; a damaged, misnamed or failed case there is not taken.
    Synthetic records stand in for the runs (tests/synthetic_campaign.py)."""
    from .synthetic_campaign import SyntheticExecutor, synthetic_store

    scenes = ms.presets.paper_cases("ceramic", 0.71, [1, 2, 3, 4], scale="tiny")
    earlier = tmp_path / "earlier"
    first = synthetic_store(earlier, scenes[:3], fail=["LDMS#3"])
    assert [r.status for r in first] == ["done", "done", "failed"]
    damaged = earlier / "cases" / f"{first[1].hash}.npz"
    damaged.write_bytes(damaged.read_bytes()[:-100])  # cut short: not a case any more

    other = tmp_path / "other"  # a store without these cases: the search goes on
    other.mkdir()
    camp = ms.Campaign(scenes, tmp_path / "store", duration=14.0, block=(4.0, 14.0))
    # A whole case file under another case's name is not that case.
    misnamed = earlier / "cases" / camp.case_file(3).name
    misnamed.write_bytes((earlier / "cases" / f"{first[0].hash}.npz").read_bytes())
    assert camp.adopt([other, earlier]) == (first[0].hash,)
    copied = camp.case_file(0)
    assert copied.read_bytes() == (earlier / "cases" / copied.name).read_bytes()
    assert [r.status for r in camp.results()] == ["done", "pending", "pending", "pending"]
    assert_manifest_matches_files(tmp_path / "store", camp)
    assert temporaries(tmp_path / "store") == []

    executor = SyntheticExecutor()
    results = camp.run(executor=executor, progress=False)
    assert executor.submitted == 3  # the copied case does not run again
    assert results[0].energy == first[0].energy
    assert camp.adopt([earlier]) == ()  # nothing left to take


def test_adopt_refuses_what_is_not_another_store(tmp_path: Path) -> None:
    camp = campaign(tmp_path / "store")
    with pytest.raises(ValueError, match=r"stores\[0\] = '.*nowhere' is not valid; it must "
                                         r"be an existing campaign store directory"):
        camp.adopt([tmp_path / "nowhere"])
    with pytest.raises(ValueError, match=r"stores = '.*' is not valid; it must be an iterable"):
        camp.adopt(str(tmp_path))  # a path is a str, which iterates over characters
    (tmp_path / "store").mkdir()
    with pytest.raises(ValueError, match=r"stores\[1\] = .* another store than this "
                                         r"campaign's own"):
        camp.adopt([tmp_path, tmp_path / "store" / "."])
    assert list((tmp_path / "store").iterdir()) == []  # refused before anything is written

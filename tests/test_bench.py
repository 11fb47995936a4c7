"""The throughput bench (millscope.bench, ``python -m millscope bench``) at tiny scale.

No timing is asserted: only that what the bench reports agrees with what the engine itself
counts (steps, memory) and with the rest of its own output (table, ratios, final line).
"""

from __future__ import annotations

import io
import math
import re
import subprocess
import sys
from pathlib import Path

import pytest

import millscope as ms
from millscope import bench, presets
from millscope.cli import main
from millscope.stiffness import time_step_limit

from .cpu import needs_two_cores, usable_cores

ROOT = Path(__file__).resolve().parents[1]
SPIN_UP = "0.05"  # s of rotation before timing: enough for a tumbling state at tiny scale
FLOAT = r"[-+0-9.eE]+"
ROW = re.compile(rf"^(\S+)\s+(\d+)\s+(\d+)\s+({FLOAT})\s+(\d+)\s+({FLOAT})\s+({FLOAT})\s+"
                 rf"({FLOAT})\s+(\d+)$")


@pytest.fixture(scope="module")
def cache(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Tumbling tiny-scale states of the scenes the tests time, prepared once on one thread
    (several threads on a busy 2-core machine make the preparation many times slower)."""
    folder = tmp_path_factory.mktemp("bench-cache")
    for name in ("balls", "frictionless", "slice-392", "slice-784"):
        bench.tumbling_state(name, "tiny", float(SPIN_UP), cache_dir=folder, threads=1,
                             progress=False, out=io.StringIO())
    return folder


def _rows(text: str) -> dict[tuple[str, int], dict[str, float]]:
    rows = {}
    for line in text.splitlines():
        m = ROW.match(line)
        if m:
            name, particles, threads, dt, steps, wall, psps, ns, nbytes = m.groups()
            rows[name, int(threads)] = {
                "particles": int(particles), "dt": float(dt), "steps": int(steps),
                "wall": float(wall), "psps": float(psps), "ns": float(ns), "bytes": int(nbytes)}
    return rows


def _bench(cache: Path, *extra: str) -> list[str]:
    return ["bench", "--scale", "tiny", "--spin-up", SPIN_UP, "--cache-dir", str(cache),
            "--no-progress", *extra]


# -- the measurement against the engine's own counters ----------------------------------------

@pytest.mark.parametrize("steps", [200, 333])
def test_particle_steps_are_the_engines_steps_times_particles(cache: Path, steps: int) -> None:
    path = bench.tumbling_state("balls", "tiny", float(SPIN_UP), cache_dir=cache)
    sim = ms.Simulation.load(path, threads=1)
    before = sim._engine.step_count
    m = bench.measure(sim, steps, "balls")
    taken = sim._engine.step_count - before
    assert m.steps == taken
    assert m.particle_steps == sim.scene.n_particles * taken == 391 * taken
    assert steps <= taken <= math.ceil(1.01 * steps) + 1  # whole samples: at most 1 % more
    assert m.particle_steps_per_s == pytest.approx(391 * taken / m.wall_s, rel=1e-12)
    assert m.ns_per_particle_step * m.particle_steps_per_s == pytest.approx(1e9, rel=1e-12)
    assert (m.particles, m.threads, m.dt) == (391, 1, sim.dt)


def test_cached_states_are_kept_apart_by_checkpoint_format(
        cache: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """A build that writes another checkpoint format does not pick up (and fail to load) a
    state cached by an older one: it prepares its own."""
    path = bench.tumbling_state("balls", "tiny", float(SPIN_UP), cache_dir=cache)
    ms.Simulation.load(path)  # this build reads what it cached
    monkeypatch.setattr(bench, "CHECKPOINT_FORMAT", "millscope-checkpoint-999")
    other = bench._cache_path(cache, "balls", "tiny", float(SPIN_UP), None)
    assert other != path and not other.exists()


def test_bytes_per_particle_is_the_engines_report(cache: Path) -> None:
    path = bench.tumbling_state("balls", "tiny", float(SPIN_UP), cache_dir=cache)
    sim = ms.Simulation.load(path, threads=1)
    m = bench.measure(sim, 100)
    assert m.bytes_per_particle == sim._engine.bytes_per_particle
    # The engine holds at least what a checkpoint saves of the arrays it keeps whole:
    # positions, velocities, spins, forces, torques (float64), the neighbour list with its
    # history, the storage order, and the reference positions (kept as float32, saved as
    # float64). The wall history is left out: the engine keeps it only for particles near
    # the drum, the checkpoint for every particle.
    state = sim._engine.snapshot()
    whole = ("x", "v", "w", "f", "t", "list_history", "list_partner", "list_start", "order")
    floor = sum(state[k].nbytes for k in whole) + state["x_ref"].nbytes // 2
    assert m.bytes_per_particle >= floor / 391 >= 5 * 3 * 8


def test_measure_refuses_a_simulation_at_rest_and_too_few_steps() -> None:
    sim = ms.Simulation(presets.pilot_mill(0.71, None, scale="tiny"), threads=1)
    with pytest.raises(ValueError, match="rotating drum"):
        bench.measure(sim, 100)
    with pytest.raises(ValueError, match="steps = 1 is not valid"):
        bench.measure(sim, 1)


# -- the command line -------------------------------------------------------------------------

@needs_two_cores
def test_cli_table_ratios_and_final_line_agree(cache: Path, capsys) -> None:
    # few steps: two threads on a busy 2-core machine can be very slow (no timing is checked)
    code = main(_bench(cache, "--scenes", "balls", "frictionless", "--threads", "1", "2",
                       "--steps", "20"))
    text = capsys.readouterr().out
    assert code == 0
    rows = _rows(text)
    assert set(rows) == {(s, t) for s in ("balls", "frictionless") for t in (1, 2)}
    dt = ms.Simulation(presets.pilot_mill(0.71, None, scale="tiny")).dt
    for r in rows.values():
        assert r["particles"] == 391 and r["dt"] == pytest.approx(dt, rel=1e-3)
        assert r["steps"] == 20  # 20 samples of one step each
        assert r["ns"] * r["psps"] == pytest.approx(1e9, rel=2e-3)
        assert r["bytes"] > 6 * 3 * 8
    assert "prepared" not in text  # every state came from the cache
    ratio = float(re.search(rf"balls: 2 threads / 1 thread\(s\) = ({FLOAT})x", text)[1])
    assert ratio == pytest.approx(rows["balls", 2]["psps"] / rows["balls", 1]["psps"], rel=0.01)
    for t in (1, 2):
        line = re.search(rf"frictionless vs balls, {t} thread\(s\): ({FLOAT})x", text)
        assert float(line[1]) == pytest.approx(
            rows["frictionless", t]["psps"] / rows["balls", t]["psps"], rel=0.01)
    last = text.rstrip().splitlines()[-1]
    assert re.fullmatch(rf"particle_steps_per_s={FLOAT}", last)
    assert float(last.split("=")[1]) == pytest.approx(rows["balls", 2]["psps"], rel=1e-3)


def test_cli_slice_sizes_report_the_cost_spread(cache: Path, capsys) -> None:
    code = main(_bench(cache, "--slice-sizes", "392", "784", "--threads", "1", "--steps", "100"))
    text = capsys.readouterr().out
    assert code == 0
    rows = _rows(text)
    assert [k for k in rows] == [("slice-392", 1), ("slice-784", 1)]
    assert [r["particles"] for r in rows.values()] == [392, 784]
    line = re.search(rf"slice, 1 thread\(s\): ns/p-step by particles 392: ({FLOAT}), "
                     rf"784: ({FLOAT}); max/min = ({FLOAT})", text)
    assert line is not None
    ns = [float(line[1]), float(line[2])]
    assert ns == pytest.approx([rows["slice-392", 1]["ns"], rows["slice-784", 1]["ns"]],
                               abs=0.051)
    # The ratio is taken before the two costs are rounded to 0.1 ns, so it must lie within what
    # that rounding allows (each cost +-0.05), itself printed to 0.001 (+-0.0005).
    half = 0.05
    low, high = (max(ns) - half) / (min(ns) + half), (max(ns) + half) / (min(ns) - half)
    assert low - 0.0005 <= float(line[3]) <= high + 0.0005
    last = text.rstrip().splitlines()[-1]
    assert float(last.split("=")[1]) == pytest.approx(rows["slice-392", 1]["psps"], rel=1e-3)


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (["--steps", "1"], "--steps: '1' is not valid; it must be >= 2"),
        (["--threads", "1", "0"], "--threads: '0' is not valid; it must be an integer in [1, "),
        (["--threads", "1", str(usable_cores() + 1)],
         f"--threads: '{usable_cores() + 1}' is not valid; it must be an integer in "
         f"[1, {usable_cores()}], the cores this process may use"),
        (["--threads", "100000"], "--threads: '100000' is not valid; it must be an integer in "),
        (["--spin-up", "0.001"], "--spin-up: '0.001' is not valid; it must be finite and >= 0.02"),
        (["--dt", "0"], "--dt: '0' is not valid; it must be finite and > 0 s"),
        (["--slice-sizes", "100"], "--slice-sizes: '100' is not valid; it must be in [392, "),
        (["--slice-sizes", "1000", "5000000"],
         "--slice-sizes: '5000000' is not valid; it must be in [392, 3914285]"),
        (["--scenes", "mill"], "--scenes: invalid choice: 'mill'"),
        (["--scale", "huge"], "--scale: invalid choice: 'huge'"),
    ],
)
def test_bad_options_exit_2_naming_the_option(tmp_path: Path, capsys, extra: list[str],
                                              message: str) -> None:
    with pytest.raises(SystemExit) as exc:
        main(_bench(tmp_path, *extra))
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err
    assert not list(tmp_path.iterdir())  # nothing was prepared


def test_unstable_dt_is_one_line_with_the_limit(tmp_path: Path, capsys) -> None:
    assert main(_bench(tmp_path, "--dt", "1e-3", "--scenes", "balls")) == 2
    err = capsys.readouterr().err
    limit = time_step_limit(presets.pilot_mill(0.71, None, scale="tiny")).dt
    assert err.startswith("millscope: error: --dt = 0.001 s is not valid; it must be in (0, ")
    assert f"{limit:.6g}] s" in err and err.count("\n") == 1
    assert not list(tmp_path.iterdir())


def test_throughput_script_is_the_same_bench(cache: Path) -> None:
    script = [sys.executable, str(ROOT / "benchmarks" / "throughput.py")]
    run = subprocess.run([*script, *_bench(cache, "--scenes", "balls", "--threads", "1",
                                           "--steps", "50")[1:]],
                         capture_output=True, text=True, check=True)
    rows = _rows(run.stdout)
    assert list(rows) == [("balls", 1)]
    assert run.stdout.rstrip().splitlines()[-1].startswith("particle_steps_per_s=")


def test_throughput_main_refuses_bad_options(capsys) -> None:
    with pytest.raises(SystemExit) as exc:
        bench.main(["--threads", "0"], prog="throughput.py")
    assert exc.value.code == 2
    assert "throughput.py: error: argument --threads: '0' is not valid" in capsys.readouterr().err


def test_run_refuses_a_bad_scene_before_preparing_any(tmp_path: Path) -> None:
    """A slice too long for a drum was refused only when its turn came, after minutes of the
    sizes before it: every scene is built first."""
    with pytest.raises(ValueError, match=re.escape("n_particles = 4000000 is not valid")):
        bench.run("tiny", threads=[1], steps=2, spin_up_s=0.02, slice_sizes=[1000, 4_000_000],
                  cache_dir=tmp_path, progress=False, out=io.StringIO())
    assert not list(tmp_path.iterdir())


def test_run_refuses_more_threads_than_the_cores_before_preparing(tmp_path: Path) -> None:
    """A thread count above the cores this process may use crashed or hung the OpenMP runtime
    (100000 and 10000 threads): it is refused before anything is prepared."""
    n = usable_cores() + 1
    with pytest.raises(ValueError, match=rf"threads = {n} is not valid; it must be an integer "
                       rf"in \[1, {n - 1}\], the cores this process may use"):
        bench.run("tiny", ["balls"], [1, n], steps=2, spin_up_s=0.02, cache_dir=tmp_path,
                  progress=False, out=io.StringIO())
    assert not list(tmp_path.iterdir())

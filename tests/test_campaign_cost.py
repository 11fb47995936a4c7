"""What a campaign has left to run and what it costs (millscope.campaign.costs), on real runs of
the tiny balls-only mill: the states, the particle-steps against the engine's own time step
and step count, the pace against the store's manifest, reuse, and the CLI's ``--cost``."""

from __future__ import annotations

import math
from concurrent.futures import Future
from pathlib import Path

import pytest

import millscope as ms
from millscope.campaign import Case, read_manifest
from millscope.campaign.costs import campaign_cost
from millscope.cli import main

from .test_partial_runs import QUICK, killed_after, tiny_case


def both_modes(store: Path) -> ms.Campaign:
    return ms.Campaign([tiny_case("instant"), tiny_case("mean")], store, block=None)


def test_before_a_run_one_twin_runs_and_its_steps_are_the_engines(tmp_path: Path) -> None:
    camp = both_modes(tmp_path / "store")
    cost = campaign_cost(camp)
    assert list(cost.cases["state"]) == ["to run", "twin"]
    sim = camp.cases[0].simulation()  # the engine's own step for the case
    rotation = camp.cases[0].scene.n_particles * round(QUICK.duration_s / sim.dt)
    assert list(cost.cases["particle_steps_left"]) == [rotation, 0.0]
    assert math.isnan(cost.pace) and cost.measured_runs == 0
    groups = cost.by_group()
    assert list(groups["runs_left"]) == [1, 1] and list(groups["done"]) == [0, 0]
    assert math.isnan(groups["core_hours_left"].iloc[0])
    assert "has no core-hours" in str(cost)
    assert not (tmp_path / "store").exists()  # nothing written


def test_a_case_under_way_costs_what_its_checkpoint_has_not_saved(tmp_path: Path) -> None:
    camp = both_modes(tmp_path / "store")
    killed_after(camp.cases[0], tmp_path / "store" / "partial", 12)
    cost = campaign_cost(camp)
    share = 12 / QUICK.total_samples
    assert cost.cases["saved"].iloc[0] == pytest.approx(share, rel=1e-12)
    planned = cost.cases["particle_steps"].iloc[0]
    assert cost.cases["particle_steps_left"].iloc[0] == pytest.approx(planned * (1 - share))
    assert f"{100 * share:.0f} %" in str(cost)


def test_after_the_run_the_pace_is_the_stores(tmp_path: Path) -> None:
    camp = both_modes(tmp_path / "store")
    results = camp.run(max_workers=1, progress=False)
    cost = campaign_cost(camp)
    assert list(cost.cases["state"]) == ["done", "done"]
    assert float(cost.cases["particle_steps_left"].sum()) == 0.0
    # one run made both cases: the pace is its particle-steps over its CPU time
    cpu = [c["cpu_time_s"] for c in read_manifest(camp.store)["cases"]]
    assert cpu[0] == cpu[1] > 0 and cost.measured_runs == 1
    assert cost.pace == pytest.approx(results[0].particle_steps / cpu[0], rel=1e-12)
    groups = cost.by_group()
    assert groups["core_hours_left"].iloc[0] == 0.0
    # the run is counted once, with its particle-steps and its CPU time in hours
    assert list(cost.cases["run"]) == [True, False]
    assert groups["runs_done"].iloc[0] == 1
    assert groups["particle_steps_done"].iloc[0] == results[0].particle_steps
    assert groups["core_hours_done"].iloc[0] == pytest.approx(cpu[0] / 3600.0, rel=1e-15)

    # a campaign reusing that store has nothing left to run
    other = both_modes(tmp_path / "other")
    again = campaign_cost(other, [camp.store])
    assert list(again.cases["state"]) == ["reused", "reused"]
    assert float(again.cases["particle_steps_left"].sum()) == 0.0


class Failing:
    """An executor whose every case fails at once."""

    def submit(self, fn: object, case: dict, *_rest: object) -> Future:
        future: Future = Future()
        future.set_result({"status": "failed", "hash": Case.from_dict(case).hash(),
                           "error": "RuntimeError: made up", "traceback": None,
                           "wall_time_s": 0.0})
        return future


def test_a_failure_costs_a_run_only_when_retried(tmp_path: Path) -> None:
    camp = both_modes(tmp_path / "store")
    assert [r.status for r in camp.run(Failing(), progress=False)] == ["failed", "failed"]
    assert list(campaign_cost(camp).cases["state"]) == ["to run", "twin"]
    kept = campaign_cost(camp, retry_failed=False)
    assert list(kept.cases["state"]) == ["failed", "failed"]
    assert float(kept.cases["particle_steps_left"].sum()) == 0.0


@pytest.mark.parametrize("bad", ["store", 3, [Path("a"), None]])
def test_bad_arguments_are_refused(tmp_path: Path, bad: object) -> None:
    camp = both_modes(tmp_path / "store")
    with pytest.raises(ValueError, match="reuse"):
        campaign_cost(camp, bad)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="campaign"):
        campaign_cost("store")  # type: ignore[arg-type]


def test_the_cli_prints_the_cost_and_runs_nothing(tmp_path: Path, monkeypatch, capsys) -> None:
    monkeypatch.chdir(tmp_path)
    (tmp_path / "spec.toml").write_text(
        '[campaign]\nstore = "store"\nseeds = [0, 1]\nblock = [0.1, 0.3]\n\n'
        '[matrix]\nparticles = ["ceramic"]\nspeed_fractions = [0.71]\nload_levels = [1, 2]\n'
        'scale = "tiny"\n\n'
        '[settings]\nduration_s = 0.3\nwarm_up_s = 0.1\nsampling = ["instant", "mean"]\n')
    assert main(["campaign", "spec.toml", "--cost"]) == 0
    rows = [[c.strip() for c in line.split("|")[1:-1]]
            for line in capsys.readouterr().out.splitlines() if line.startswith("| ")]
    assert rows[0][0] == "group" and rows[1][:4] == ["LDMS", "1,2", "8", "0"]
    assert rows[1][7] == "4"  # runs left: each of the 4 runs stores its twin
    assert not (tmp_path / "store").exists()

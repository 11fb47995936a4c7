"""What a campaign's runs cost so far and what is left to run: read from its store, nothing run.

:func:`campaign_cost` gives, per case of a :class:`~millscope.campaign.Campaign`, its state in
the store ("done", "reused": finished in a store the campaign copies from, "twin": stored by
the run of its twin in the other sampling mode, "to run", with the share its last in-case
checkpoint holds), what its run cost and the particle-steps left; per group of cases (the case
code without its level, both sampling modes together, since one run gives both) those summed,
what is left turned into core-hours at the pace of the store's own finished runs.
``millscope campaign FILE --cost`` prints it and the campaign report (:mod:`millscope.report`)
has its table.

Particle-steps are the particles x the time steps; a finished run's count includes its
settling (:attr:`~millscope.campaign.CaseResult.particle_steps`), a planned one counts the
rotation only (settling, a few per cent of a case at the paper's scale, is known only once it
ran). Core-hours are a run's CPU time where it was recorded, else its wall time x engine
threads (:attr:`CaseResult.core_hours`).
"""

from __future__ import annotations

import math
import os
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from .. import _checks
from ..model.presets import case_key
from .cases import CaseResult, distinct_runs, rotation_particle_steps
from .partial import PARTIAL_DIR, PartialFiles, saved_share
from .runs import Campaign
from .store import _case_path

if TYPE_CHECKING:
    from pandas import DataFrame

__all__ = ["CampaignCost", "campaign_cost"]


@dataclass(frozen=True)
class CampaignCost:
    """A campaign's cases with their state and cost (:func:`campaign_cost`).

    Attributes
    ----------
    store : Path
        The campaign's store.
    cases : pandas.DataFrame
        One row per case, in the campaign's order: ``case`` (scene name), ``group``,
        ``load_level`` (nan for balls only), ``seed``, ``sampling``, ``hash`` (12 digits),
        ``state`` ("done", "reused", "twin", "to run", or "failed" when failures are not
        retried), ``saved`` (share of its samples its last in-case checkpoint holds, 0 to 1;
        1 when done), ``run`` (True for the case whose run is counted: a finished run, once
        for the twins it stored, or a run to come), ``particle_steps`` (of that run: counted
        when done, planned otherwise; 0 when ``run`` is False), ``core_hours`` (of a finished
        run, nan when neither its CPU time nor its wall time is known; 0 otherwise) and
        ``particle_steps_left`` (planned x (1 - saved) for a case to run, else 0).
    pace : float
        Particle-steps per core-second of the store's finished runs (their particle-steps
        over their core-hours); nan when the store has none.
    measured_runs : int
        The finished runs the pace is taken from.
    """

    store: Path
    cases: DataFrame
    pace: float
    measured_runs: int

    def by_group(self) -> DataFrame:
        """One row per group, then one ``"all"``: ``levels`` (the load levels, text),
        ``cases``, ``done`` (finished or reused), ``runs_done``, ``particle_steps_done``,
        ``core_hours_done`` (both nan when a run does not say them), ``runs_left``,
        ``particle_steps_left`` and ``core_hours_left`` (at :attr:`pace`; nan without one, when
        something is left)."""
        import pandas as pd

        rows = []
        for name, g in [*self.cases.groupby("group", sort=True), ("all", self.cases)]:
            levels = sorted({float(v) for v in g["load_level"] if math.isfinite(float(v))})
            ran = g[g["run"] & (g["state"] == "done")]
            left = float(g["particle_steps_left"].sum())
            rows.append({"group": name, "levels": ",".join(f"{v:g}" for v in levels) or "-",
                         "cases": len(g),
                         "done": int(g["state"].isin(["done", "reused"]).sum()),
                         "runs_done": len(ran),
                         "particle_steps_done": float(ran["particle_steps"].sum(skipna=False)),
                         "core_hours_done": float(ran["core_hours"].sum(skipna=False)),
                         "runs_left": int((g["state"] == "to run").sum()),
                         "particle_steps_left": left,
                         "core_hours_left": left / self.pace / 3600.0 if left else 0.0})
        return pd.DataFrame(rows)

    def to_markdown(self) -> str:
        """:meth:`by_group` as a Markdown table (without its "all" row when there is one
        group), then what the numbers are."""
        groups = self.by_group()
        if len(groups) == 2:  # one group: its "all" row says the same
            groups = groups.iloc[:1]
        lines = ["| group | load levels | cases | done | runs done | particle-steps done | "
                 "core-hours done | runs left | particle-steps left | core-hours left |",
                 "|---|---|---|---|---|---|---|---|---|---|"]
        lines += [f"| {row['group']} | {row['levels']} | {row['cases']} | {row['done']} | "
                  f"{row['runs_done']} | {_amount(row['particle_steps_done'])} | "
                  f"{_amount(row['core_hours_done'])} | {row['runs_left']} | "
                  f"{_amount(row['particle_steps_left'])} | {_amount(row['core_hours_left'])} |"
                  for row in groups.to_dict("records")]
        under_way = [f"{100 * s:.0f} %" for s in self.cases["saved"][
            (self.cases["state"] == "to run") & (self.cases["saved"] > 0)]]
        notes = [
            "One run samples both modes: a case and its twin in the other sampling mode that "
            "one run stored count as one run. Particle-steps: the particles x the time steps "
            "(a finished run's with its settling; a run to come counts its rotation only). "
            "Core-hours: a run's CPU time where it was recorded, else its wall time x engine "
            "threads, the cores it held, including any time other work on a shared machine "
            "took from it."]
        if under_way:
            notes.append(f"Runs under way have saved {', '.join(under_way)} of their samples.")
        if (groups["runs_left"] > 0).any():
            notes.append(
                f"What is left is in core-hours at the pace of the store's "
                f"{self.measured_runs} finished run(s), {self.pace:.3g} particle-steps per "
                "core-second." if math.isfinite(self.pace) else
                "What is left has no core-hours: the store has no finished run to take a pace "
                "from (`millscope bench` measures the engine's on this machine).")
        return "\n".join(lines) + "\n\n" + " ".join(notes)

    def __str__(self) -> str:
        return self.to_markdown()


def _amount(value: float) -> str:
    if not math.isfinite(value):
        return "-"
    return "0" if value == 0 else f"{value:.3g}"


def campaign_cost(campaign: Campaign, reuse: Iterable[str | os.PathLike[str]] = (), *,
                  retry_failed: bool = True,
                  results: Sequence[CaseResult] | None = None) -> CampaignCost:
    """What ``campaign``'s runs cost so far and what it has left to run, from its store
    (nothing runs, and nothing is written).

    Parameters
    ----------
    campaign : Campaign
    reuse : iterable of str or path
        Stores the run copies finished cases from (:meth:`Campaign.adopt`): a case whose file
        one of them holds is "reused" and costs nothing (its file is checked only when
        copied).
    retry_failed : bool
        Whether the run retries failed cases (:meth:`Campaign.run`); if not, they are left
        as they are and cost nothing.
    results : sequence of CaseResult, optional
        ``campaign.results()``, when the caller has them already; default read from the
        store.

    Returns
    -------
    CampaignCost

    Raises
    ------
    ValueError
        for a ``campaign`` that is not a Campaign or a ``reuse`` that is not an iterable of
        store paths.
    """
    import pandas as pd

    if not isinstance(campaign, Campaign):
        raise _checks.fail("campaign", campaign, "a millscope Campaign")
    if isinstance(reuse, (str, bytes, os.PathLike)) or not isinstance(reuse, Iterable):
        raise _checks.fail("reuse", reuse, "an iterable of campaign store directories")
    given = list(reuse)
    for k, src in enumerate(given):
        if not isinstance(src, (str, os.PathLike)):
            raise _checks.fail(f"reuse[{k}]", src, "a campaign store directory (str or path)")
    sources = [Path(s) for s in given]
    if results is None:
        results = campaign.results()
    elif [r.hash for r in results] != list(campaign.hashes):
        raise _checks.fail("results", f"{len(results)} results",
                           "campaign.results(): one per case of the campaign, in its order")
    todo = [k for k, r in enumerate(results)
            if r.status == "pending" or (retry_failed and r.status == "failed")]
    reused = {k for k in todo
              if any(_case_path(src, results[k].hash).is_file() for src in sources)}
    runs, carries = campaign._runs_of([k for k in todo if k not in reused])
    twins = set(carries.values())
    ran = distinct_runs(results)
    finished = {id(r) for r in ran}
    rows = []
    for k, r in enumerate(results):
        key = case_key(r.scene)
        saved, steps, hours = 0.0, 0.0, 0.0
        if r.ok:
            state, saved = "done", 1.0
            if id(r) in finished:
                steps, hours = r.particle_steps, r.core_hours
        elif k in reused:
            state, saved = "reused", 1.0
        elif k in twins:
            state = "twin"
        elif k in runs:
            share = saved_share(PartialFiles(campaign.store / PARTIAL_DIR, r.hash),
                                r.case.settings.total_samples)
            state, saved, steps = "to run", share or 0.0, rotation_particle_steps(r.case)
        else:  # a failure that is not retried
            state = "failed"
        rows.append({"case": r.scene.name, "group": key.group,
                     "load_level": math.nan if key.load_level is None else key.load_level,
                     "seed": r.case.settings.seed, "sampling": r.case.settings.sampling,
                     "hash": r.hash[:12], "state": state, "saved": saved,
                     "run": (state == "done" and id(r) in finished) or state == "to run",
                     "particle_steps": steps, "core_hours": hours,
                     "particle_steps_left": steps * (1.0 - saved) if state == "to run" else 0.0})
    measured = [r for r in ran if math.isfinite(r.particle_steps) and r.core_hours > 0]
    pace = (math.fsum(r.particle_steps for r in measured)
            / (3600.0 * math.fsum(r.core_hours for r in measured)) if measured else math.nan)
    return CampaignCost(campaign.store, pd.DataFrame(rows), pace, len(measured))

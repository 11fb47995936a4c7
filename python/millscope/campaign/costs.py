"""What a campaign has left to run, and what it costs: read from its store, nothing run.

:func:`campaign_cost` gives, per case of a :class:`~millscope.campaign.Campaign`, its state in
the store ("done", "reused": finished in a store the campaign copies from, "twin": stored by
the run of its twin in the other sampling mode, "to run", with the share its last in-case
checkpoint holds) and the particle-steps left; per group of cases (the case code without its
level, both sampling modes together, since one run gives both) those summed, and turned into
core-hours at the pace of the store's own finished runs. ``millscope campaign FILE --cost``
prints it.

Particle-steps are the particles x the time steps; a finished run's count includes its
settling (:attr:`~millscope.campaign.CaseResult.particle_steps`), a planned one counts the
rotation only (settling, a few per cent of a case at the paper's scale, is known only once it
ran). Core-hours are wall time x engine threads (:attr:`CaseResult.core_hours`).
"""

from __future__ import annotations

import math
import os
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from .. import _checks
from ..model.presets import case_key
from .cases import distinct_runs, rotation_particle_steps
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
        retried), ``saved`` (share of its samples its
        last in-case checkpoint holds, 0 to 1; 1 when done), ``particle_steps`` (its run's:
        counted when done, planned otherwise; 0 for a twin or a reused case) and
        ``particle_steps_left`` (planned x (1 - saved) for a case to run, else 0).
    pace : float
        Particle-steps per core-second of the store's finished runs (their particle-steps
        over their wall time x threads); nan when the store has none.
    measured_runs : int
        The finished runs the pace is taken from.
    """

    store: Path
    cases: DataFrame
    pace: float
    measured_runs: int

    def by_group(self) -> DataFrame:
        """One row per group and one ``"all"``: ``levels`` (the load levels, text),
        ``cases``, ``done`` (finished or reused), ``runs_left``, ``particle_steps_left`` and
        ``core_hours_left`` (at :attr:`pace`; nan without one)."""
        import pandas as pd

        rows = []
        for name, g in [*self.cases.groupby("group", sort=True), ("all", self.cases)]:
            levels = sorted({float(v) for v in g["load_level"] if math.isfinite(float(v))})
            left = float(g["particle_steps_left"].sum())
            rows.append({"group": name, "levels": ",".join(f"{v:g}" for v in levels) or "-",
                         "cases": len(g),
                         "done": int(g["state"].isin(["done", "reused"]).sum()),
                         "runs_left": int((g["state"] == "to run").sum()),
                         "particle_steps_left": left,
                         "core_hours_left": left / self.pace / 3600.0})
        return pd.DataFrame(rows)

    def __str__(self) -> str:
        groups = self.by_group()
        if len(groups) == 2:  # one group: its "all" row says the same
            groups = groups.iloc[:1]
        lines = [f"{'group':<12} {'levels':<16} {'cases':>5} {'done':>5} {'runs left':>9} "
                 f"{'particle-steps left':>19} {'core-hours left':>15}"]
        for row in groups.itertuples():
            left = float(row.core_hours_left)  # type: ignore[arg-type]
            hours = f"{left:.3g}" if math.isfinite(left) else "-"
            lines.append(f"{row.group:<12} {row.levels:<16} {row.cases:>5} {row.done:>5} "
                         f"{row.runs_left:>9} {row.particle_steps_left:>19.3g} {hours:>15}")
        under_way = [f"{100 * s:.0f} %" for s in self.cases["saved"][
            (self.cases["state"] == "to run") & (self.cases["saved"] > 0)]]
        if under_way:
            lines.append(f"Under way (saved in {self.store / PARTIAL_DIR}): "
                         f"{', '.join(under_way)}.")
        if math.isfinite(self.pace):
            lines.append(f"Core-hours at the pace of the store's {self.measured_runs} finished "
                         f"run(s): {self.pace:.3g} particle-steps per core-second (wall time x "
                         "threads, so a run that shared its cores counts slow); settling is "
                         "not counted in what is left.")
        else:
            lines.append("No core-hours: the store has no finished run to take a pace from "
                         "(`millscope bench` measures the engine's on this machine).")
        return "\n".join(lines)


def campaign_cost(campaign: Campaign, reuse: Iterable[str | os.PathLike[str]] = (), *,
                  retry_failed: bool = True) -> CampaignCost:
    """What ``campaign`` has left to run and what it costs, from its store (nothing runs, and
    nothing is written).

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

    Returns
    -------
    CampaignCost

    Raises
    ------
    ValueError
        for a ``reuse`` that is not an iterable of store paths.
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
    results = campaign.results()
    todo = [k for k, r in enumerate(results)
            if r.status == "pending" or (retry_failed and r.status == "failed")]
    reused = {k for k in todo
              if any(_case_path(src, results[k].hash).is_file() for src in sources)}
    runs, carries = campaign._runs_of([k for k in todo if k not in reused])
    twins = set(carries.values())
    rows = []
    for k, r in enumerate(results):
        key = case_key(r.scene)
        if r.ok:
            state, saved, steps = "done", 1.0, r.particle_steps
        elif k in reused:
            state, saved, steps = "reused", 1.0, 0.0
        elif k in twins:
            state, saved, steps = "twin", 0.0, 0.0
        elif k in runs:
            share = saved_share(PartialFiles(campaign.store / PARTIAL_DIR, r.hash),
                                r.case.settings.total_samples)
            state, saved, steps = "to run", share or 0.0, rotation_particle_steps(r.case)
        else:  # a failure that is not retried
            state, saved, steps = "failed", 0.0, 0.0
        rows.append({"case": r.scene.name, "group": key.group,
                     "load_level": math.nan if key.load_level is None else key.load_level,
                     "seed": r.case.settings.seed, "sampling": r.case.settings.sampling,
                     "hash": r.hash[:12], "state": state, "saved": saved,
                     "particle_steps": steps,
                     "particle_steps_left": steps * (1.0 - saved) if state == "to run" else 0.0})
    measured = [r for r in distinct_runs(results)
                if math.isfinite(r.particle_steps) and r.core_hours > 0]
    pace = (math.fsum(r.particle_steps for r in measured)
            / (3600.0 * math.fsum(r.core_hours for r in measured)) if measured else math.nan)
    return CampaignCost(campaign.store, pd.DataFrame(rows), pace, len(measured))

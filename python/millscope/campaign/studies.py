"""Error against run time: what each speed-up knob costs in accuracy (issue "Error against run
time", item 1).

A study runs the pilot mill (:func:`millscope.presets.pilot_mill`) under a ladder of
:class:`Setting` s and reports, for each, the run time and the error of what the analysis gives
(mean torque, spectral energy with the mean and the LTH removed, LTH amplitude and, for several
load levels, the log-fit slope a) against one **reference** setting, by default the most
expensive one. The knobs of a setting:

* ``dt_fraction``: the time step as a fraction of the smallest Rayleigh time (the engine's
  default is 0.2, its limit 0.5);
* ``shear_modulus_factor``: every shear modulus as a fraction of the paper's (1, 0.1, 0.01,
  0.001), or None for the scale's own;
* ``record_s`` and ``warm_up_s``: the analysed block and the rotation before it, s;
* ``sampling``: ``"instant"`` (as the paper) or ``"mean"`` (anti-aliased);
* ``scale``: a scale of :data:`millscope.presets.SCALES` (the whole mill or an axial slice).

Each setting runs with several filling seeds, so that noise can be told from bias: a row
gives the error of the seed mean against the reference's seed mean, the spread of one run (the
standard deviation over the seeds) and the standard error of the error (both means' seed
noise). An error well above its standard error is a bias of the setting; one within it is
noise.

The runs are the cases of one :class:`~millscope.campaign.Campaign` (store, resume, executors,
progress bar as there; each case is analysed as the campaign analyses its cases,
:meth:`~millscope.campaign.CaseResult.from_record`), one case per setting, load level and seed::

    from millscope.studies import Setting, StudyPlan, run_study
    plan = StudyPlan.ladder("dt_fraction", [0.05, 0.1, 0.2, 0.3], seeds=(0, 1, 2))
    result = run_study(plan, "out/dt-study/store")
    result.to_csv("out/dt-study/accuracy.csv"); print(result.to_markdown())
    result.pareto("energy")               # the settings no other beats in both cost and error

**Comparing unlike settings.** Quantities are put on the reference's footing before they are
compared: torques (mean, LTH amplitude) are scaled by the ratio of drum lengths L_ref / L (a
periodic slice stands for its share of the mill's length), and energies by
(L_ref / L) x (T_ref / T), T the block length: the energy of eq. (11) grows in proportion to
the block length for a stationary signal, and in proportion to the drum length for torque
noise from independent impacts along the axis (the aliased impact noise that dominates
instantaneous samples). Per-unit energies and the slope a need no scaling.

**Cost.** ``wall_s`` is the wall-clock time of one run (engine set-up, filling, settling, the
warm-up and the block; the mean over the seeds), ``particle_steps`` the particles x the time
steps of that run, settling included. With several load levels a setting's cost is the sum over
its levels (one run per level, as a campaign needs).

Units: s, m, N m, (N m)^2 s; errors and spreads are dimensionless fractions of the reference's
seed mean.
"""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any

from .. import _checks
from .._files import MAX_JSON_BYTES, atomic_write, read_json
from ..signal.analysis import AnalysisSettings
from .cases import CaseResult, run_particle_steps
from .runs import Campaign
from .study_plans import KNOBS, QUANTITIES, Setting, StudyPlan
from .study_results import QuantityError, SettingSummary, StudyResult, StudyRow, StudyRun

__all__ = [
    "KNOBS",
    "QUANTITIES",
    "QuantityError",
    "Setting",
    "SettingSummary",
    "StudyPlan",
    "StudyResult",
    "StudyRow",
    "StudyRun",
    "PLAN_FILE",
    "read_study",
    "read_study_plan",
    "run_study",
    "save_study_plan",
]

#: The file in a study's folder that holds its plan (:func:`save_study_plan`); the runs are in
#: the campaign store ``<folder>/store``.
PLAN_FILE = "study.json"
_PLAN_FORMAT = "millscope-study-1"


# -- running -----------------------------------------------------------------------------------


def _run_of(plan: StudyPlan, index: int, result: CaseResult) -> StudyRun:
    """Case ``index`` of the plan analysed as the campaign does, with what it cost.

    ``result`` is that case's, or its donor's (:meth:`StudyPlan.donor`): a run of the same
    scene, seed, time step, sampling and warm-up with a longer block, whose record begins with
    exactly the samples the shorter run would take. The shorter block is then cut from it, its
    particle-steps counted for its own length and its wall time estimated as the donor's in
    proportion to particle-steps.
    """
    k, level, seed, case = plan._cases[index]
    setting = plan.settings[k]
    analysis = AnalysisSettings((setting.warm_up_s, setting.duration_s), plan.bandwidth,
                                plan.window)
    assert result.record is not None  # done cases have a record
    analysed = CaseResult.from_record(case, result.record, analysis,
                                      wall_time_s=result.wall_time_s,
                                      cpu_time_s=result.cpu_time_s)
    # The kept samples are stamped warm-up + sample_dt .. duration (the end of their
    # intervals), so the campaign's block [warm-up, duration) holds one sample fewer than
    # the record: energies are compared per the block length actually analysed.
    block_s = result.record.block(*analysis.block).duration_s
    n = case.scene.n_particles
    steps = run_particle_steps(result.record, n, case.settings.duration_s)
    ran = result.particle_steps  # the donor's run, when it is longer
    return StudyRun(setting=k, load_level=level, seed=seed, hash=result.hash,
                    wall_s=float(result.wall_time_s) * steps / ran,
                    particle_steps=steps, n_particles=n, dt_s=float(result.record.meta["dt"]),
                    length_m=case.scene.drum.length, block_s=block_s,
                    mean_torque=analysed.mean_torque, lth_amplitude=analysed.lth_amplitude,
                    energy=analysed.energy, derived=result.case != case)


def run_study(plan: StudyPlan, store: str | os.PathLike[str], *, executor: Any = None,
              max_workers: int | None = None, progress: bool = True,
              cheapest_first: bool = False) -> StudyResult:
    """Runs a study's cases through a :class:`~millscope.campaign.Campaign` and tabulates them.

    The cases go to the campaign from the most expensive to the cheapest (so that the
    longest do not start last), or with ``cheapest_first`` the other way round. The store
    keeps every finished case: a rerun of the same plan (or of a plan sharing cases) runs only
    what is missing, goes on with a case that was killed half-way from its in-case
    checkpoint, and reports the wall times the cases took when they ran.

    Parameters
    ----------
    plan : StudyPlan
    store : path
        The campaign store (a directory; created if needed).
    executor : optional
        A ``concurrent.futures`` executor or a ``dask.distributed`` Client
        (:meth:`Campaign.run`); None: a local process pool.
    max_workers : int, optional
        Processes of the local pool (only with ``executor=None``). Default 1: one case at a
        time, so that the measured wall times do not disturb each other.
    progress : bool
        Show the campaign's progress bar.
    cheapest_first : bool
        Run the cheapest cases first: a study spread over several sittings then has its
        cheap settings finished early, and its longest cases go on from their in-case
        checkpoints (:meth:`Campaign.run`) from one sitting to the next.

    Returns
    -------
    StudyResult

    Raises
    ------
    ValueError
        for a bad argument, before any work.
    RuntimeError
        when a case failed (the finished ones are kept in the store; a rerun retries).
    """
    if not isinstance(plan, StudyPlan):
        raise _checks.fail("plan", plan, "a StudyPlan")
    _checks.flag("cheapest_first", cheapest_first)
    sign = 1.0 if cheapest_first else -1.0
    order = sorted((i for i in range(len(plan.cases())) if plan.donor(i) is None),
                   key=lambda i: sign * plan.case_particle_steps(i))
    campaign = Campaign([plan._cases[i][3] for i in order], store, block=None)
    if executor is None and max_workers is None:
        max_workers = 1
    results = campaign.run(executor=executor, max_workers=max_workers, progress=progress)
    failed = [r for r in results if not r.ok]
    if failed:
        raise RuntimeError(f"{len(failed)} of {len(results)} runs failed, first "
                           f"{failed[0].case.name}: {failed[0].error}; see "
                           f"{campaign.store / 'manifest.json'} (a rerun retries them)")
    return _tabulate(plan, campaign.store, results, partial=False)


def _tabulate(plan: StudyPlan, store: Path, results: list[CaseResult], *,
              partial: bool) -> StudyResult:
    """The table of the finished ones of a plan's cases (``results`` of any order); a case
    with a donor (:meth:`StudyPlan.donor`) is cut from the donor's record."""
    by_hash = {r.hash: r for r in results if r.ok}
    hashes = [c.hash() for c in plan.cases()]
    runs = []
    for i, own in enumerate(hashes):
        donor = plan.donor(i)
        source = own if donor is None else hashes[donor]
        if source in by_hash:
            runs.append(_run_of(plan, i, by_hash[source]))
    return StudyResult.from_runs(plan, runs, store=store, partial=partial)


def save_study_plan(plan: StudyPlan, folder: str | os.PathLike[str]) -> Path:
    """Writes the plan into ``<folder>/study.json`` (atomically), so that the study's report
    can be made again from its store (:func:`read_study`) without the command that ran it.

    Returns
    -------
    Path
    """
    if not isinstance(plan, StudyPlan):
        raise _checks.fail("plan", plan, "a StudyPlan")
    path = Path(folder) / PLAN_FILE
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_write(path, "w") as fh:
        json.dump({"format": _PLAN_FORMAT, "plan": plan.to_dict()}, fh, indent=1)
        fh.write("\n")
    return path


def read_study_plan(folder: str | os.PathLike[str]) -> StudyPlan:
    """The plan :func:`save_study_plan` wrote into ``folder`` (an untrusted file: checked).

    Raises
    ------
    ValueError
        naming the file, when it is missing, not a study plan or out of range.
    """
    path = Path(folder) / PLAN_FILE
    data = read_json(path, "study plan", max_bytes=MAX_JSON_BYTES)
    if not isinstance(data, dict) or data.get("format") != _PLAN_FORMAT or "plan" not in data:
        raise ValueError(f"{path} is not a millscope study plan (format {_PLAN_FORMAT!r})")
    return StudyPlan.from_dict(data["plan"], where=str(path))


def read_study(folder: str | os.PathLike[str]) -> StudyResult:
    """The table of a study from what its folder holds, without running anything.

    Reads the plan (``<folder>/study.json``) and the finished runs of its campaign store
    (``<folder>/store``) and tabulates every setting at the load levels where its runs and
    the reference's are all finished; settings that lack runs are listed in
    :attr:`StudyResult.pending` (a study still under way, or stopped).

    Parameters
    ----------
    folder : path
        The study's folder (the ``--out`` of ``millscope study accuracy``).

    Returns
    -------
    StudyResult

    Raises
    ------
    ValueError
        when the plan cannot be read, or the reference has no load level whose runs are all
        finished.
    """
    plan = read_study_plan(folder)
    store = Path(folder) / "store"
    if not store.is_dir():
        raise ValueError(f"{store} is not valid; the study's campaign store must be a folder")
    ran = [c for i, c in enumerate(plan.cases()) if plan.donor(i) is None]
    results = Campaign(ran, store, block=None).results()
    return _tabulate(plan, store, results, partial=True)

"""The report of a campaign store: the paper's section 6 as Markdown with PNG figures.

:func:`write_report` reads a store (:meth:`~millscope.campaign.Campaign.from_store`), analyses
it (:func:`~millscope.campaign_analysis.analyze_campaign`) and writes into one folder:

* ``report.md``: the campaign at a glance, the Table 6 analogue (log fits with bootstrap
  intervals), a table per group (per level: mean torque, LTH, energy per unit with its interval),
  how well one block tells each level from the next
  (:func:`~millscope.calibration.discrimination.discrimination`) and its fill estimates with
  each seed held out of the calibration (:func:`~millscope.calibration.discrimination.held_out`),
  the cost of the runs per group, done and left (:func:`~millscope.campaign.costs.campaign_cost`),
  a table of every case, and the figures below;
* ``fig09_torque.png`` (average torque per unit against filling), ``fig10_spectra_<group>.png``
  (the spectra of a group with the LTH marked), ``fig11_lth.png`` (LTH amplitude against
  filling), ``fig12_waterfall_<group>.png`` (Figs. 12-13, a waterfall per group),
  ``fig14_energy.png`` (energy per unit against filling), ``fig15_fits.png`` (the log fits);
* ``calibration_<group>.json``: a :class:`~millscope.Calibration` per group with a fit through
  at least 3 load levels. A group with 2 levels gets none, and its section says why: the fit
  is exact (R^2 = 1 trivially) and could give a filling estimate no interval
  (:class:`~millscope.fit.NoIntervalWarning`); Table 6 marks such fits "exact".

``python -m millscope report STORE [--out DIR]`` runs it. Every file is written atomically.
"""

from __future__ import annotations

import math
import os
import re
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure
from numpy.typing import NDArray
from tqdm.auto import tqdm

from .. import _core
from .._files import atomic_write
from ..calibration.discrimination import discrimination, held_out
from ..calibration.fit import MIN_LEVELS_FOR_INTERVALS, Calibration, no_interval_reason
from ..calibration.groups import GroupAnalysis, analyze_campaign, r2_text, table6_markdown
from ..campaign.cases import CaseResult
from ..campaign.costs import campaign_cost
from ..campaign.runs import Campaign
from ..campaign.store import UnreadableCase, _listing, unreadable_cases
from ..campaign.studies import StudyResult
from ..model.presets import case_key
from ..signal.spectral import PEAK_DISTINCT_RATIO, Spectrum, spectrum
from ..signal.synthetic import PAPER_TABLE_6
from . import plots

__all__ = ["UnreadableCasesError", "calibration_file_name", "write_report", "write_study"]

REPORT_NAME = "report.md"


class UnreadableCasesError(ValueError):
    """Some case files of the store could not be read; raised by :func:`write_report` after
    it wrote the report of the cases it could read.

    Attributes
    ----------
    report : Path
        The written ``report.md`` (its "Unreadable case files" section lists the cases).
    cases : list of UnreadableCase
        Every case that could not be read, with the reason.
    """

    def __init__(self, report: Path, cases: list[UnreadableCase]) -> None:
        self.report = report
        self.cases = cases
        super().__init__(f"{len(cases)} case file{'s' if len(cases) > 1 else ''} could not be "
                         f"read, so the report at {report} leaves them out: {_listing(cases)}")


def _slug(name: str) -> str:
    """A file-name-safe form of a group's name ("LD-75%" -> "LD-75pct")."""
    return re.sub(r"[^A-Za-z0-9_-]+", "_", name.replace("%", "pct")).strip("_") or "group"


def calibration_file_name(group: str) -> str:
    """The file name :func:`write_report` gives the calibration of a group
    (``"LDMS"`` -> ``"calibration_LDMS.json"``)."""
    return f"calibration_{_slug(group)}.json"


def _number(value: float, digits: int = 4) -> str:
    return f"{value:.{digits}g}" if math.isfinite(value) else "-"


@dataclass(frozen=True)
class _Figure:
    file: str
    heading: str
    caption: str
    make: Callable[[], Figure]


def _first_per_level(group: GroupAnalysis) -> list[CaseResult]:
    """The case with the lowest seed at each level (the results are by level, then seed)."""
    seen: dict[float, CaseResult] = {}
    for r in group.results:
        level = case_key(r.scene).load_level
        if level is not None:
            seen.setdefault(level, r)
    return list(seen.values())


def _spectra(group: GroupAnalysis
             ) -> tuple[list[Spectrum], list[str], list[float | None], list[bool]]:
    cases = _first_per_level(group)
    spectra: list[Spectrum] = []
    for r in cases:
        assert r.record is not None
        spectra.append(spectrum(r.record.block(*group.settings.block),
                                window=group.settings.window))
    labels = [r.scene.name.replace("#", "") for r in cases]
    marks = [r.lth_hz if math.isfinite(r.lth_hz) else None for r in cases]
    return spectra, labels, marks, [r.lth_distinct for r in cases]


def _torque_changes(groups: list[GroupAnalysis]) -> str:
    """Each group's largest change of the mean torque, beside the paper's bound."""
    each = {g.name: plots.torque_change(g.torque_pu) for g in groups if len(g.levels) > 1}
    changes = [f"{name} {100 * change:.1f} %" for name, change in each.items()
               if math.isfinite(change)]
    if not changes:
        return ""
    return (" Largest change within a group, (max - min) / max: " + ", ".join(changes)
            + f" (the paper's Fig. 9: under {100 * plots.PAPER_TORQUE_CHANGE:g} %).")


def _paper_range() -> str:
    """The span of the paper's six fits, and which of our sampling modes they compare with."""
    a = [fit[0] for fit in PAPER_TABLE_6.values()]
    r2 = [fit[2] for fit in PAPER_TABLE_6.values()]
    return (f"The paper's six fits (its Table 6): a from {min(a):g} to {max(a):g}, R² from "
            f"{min(r2):.3g} to {max(r2):.3g}. The paper sampled the torque at instants 10 ms "
            "apart, so its fits compare with the groups sampled that way (\"instant\").")


def _lth_distinct(g: GroupAnalysis) -> NDArray[np.bool_]:
    """Per level of the group: whether its LTH stands out of the noise in every case."""
    noise = {case_key(r.scene).load_level for r in g.results if r.ok and not r.lth_distinct}
    return np.array([level not in noise for level in g.levels], dtype=bool)


def _figures(groups: list[GroupAnalysis]) -> list[_Figure]:
    figs = [_Figure("fig09_torque.png", "Fig. 9: average torque",
                    "Mean torque over the block per unit of each group's largest, against the "
                    "load level (mean over the repeats of a level). The axis starts at "
                    f"{plots.TORQUE_PU_FLOOR:g} per unit, not at the smallest value, so the "
                    "change with filling shows at its true size; the legend gives the largest "
                    "change within a group." + _torque_changes(groups),
                    lambda: plots.plot_torque_levels(
                        {g.name: (g.levels, g.torque_pu) for g in groups}))]
    for g in groups:
        def grid(g: GroupAnalysis = g) -> Figure:
            spectra, labels, marks, distinct = _spectra(g)
            return plots.plot_spectra_grid(spectra, labels, lth_hz=marks, lth_distinct=distinct,
                                           title=f"{g.name} torque spectra, LTH marked")
        figs.append(_Figure(f"fig10_spectra_{_slug(g.name)}.png",
                            f"Fig. 10: {g.name} spectra",
                            "Amplitude spectra of the block (lowest seed of each level), the "
                            "located LTH marked.", grid))
    figs.append(_Figure("fig11_lth.png", "Fig. 11: lifter torque harmonic",
                        "Amplitude of the LTH located in each block against the load level "
                        "(the mean over a level's repeats). An open marker: at that level the "
                        "LTH does not stand out of the noise in some case, so what was located "
                        "is a noise peak.",
                        lambda: plots.plot_lth_levels(
                            {g.name: (g.levels, g.lth_amplitude, _lth_distinct(g))
                             for g in groups if g.lifters > 0})))
    for g in groups:
        def waterfall(g: GroupAnalysis = g) -> Figure:
            spectra, labels, _, _ = _spectra(g)
            return plots.plot_waterfall(spectra, labels, title=f"{g.name} torque spectra")
        figs.append(_Figure(f"fig12_waterfall_{_slug(g.name)}.png",
                            f"Figs. 12-13: {g.name} waterfall",
                            "The spectra of the group by rising load level.", waterfall))
    figs.append(_Figure("fig14_energy.png", "Fig. 14: spectrum energy",
                        "Spectral energy with the mean and the LTH removed, per unit of each "
                        "group's largest, with its bootstrap interval.",
                        lambda: plots.plot_energy_levels(
                            {g.name: (g.levels, g.energy_pu, g.energy_pu_interval)
                             for g in groups})))
    figs.append(_Figure("fig15_fits.png", "Fig. 15: logarithmic fits",
                        "y = a ln(x) + b fitted to the per-unit energies of each group.",
                        lambda: plots.plot_energy_fits(
                            {g.name: (g.levels, g.energy_pu, g.fit) for g in groups})))
    if not any(g.lifters > 0 for g in groups):
        figs = [f for f in figs if f.file != "fig11_lth.png"]
    return figs


def _held_out_section(g: GroupAnalysis, confidence: float) -> list[str]:
    """The group's fill estimates with each seed held out of the calibration, or why there are
    none (a campaign without repeats)."""
    try:
        result = held_out(g, confidence=confidence)
    except ValueError as err:
        return [f"No held-out estimates: {err}.", ""]
    return [result.to_markdown(),
            "Held out: each seed's blocks estimated against a calibration made from the other "
            "seeds' cases alone, as a new block from the plant would be. The share of true "
            "levels inside their intervals should be near the intervals' confidence; the RMS "
            "error is the estimates' distance from the true level.", ""]


def _group_table(g: GroupAnalysis) -> list[str]:
    rows = ["| level | cases | mean torque (N m) | torque p.u. | LTH (Hz) | LTH (N m) | "
            "energy ((N m)² s) | energy p.u. [interval] | spread of one case | interval from |",
            "|---|---|---|---|---|---|---|---|---|---|"]
    for k, level in enumerate(g.levels):
        lo, hi = g.energy_pu_interval[:, k]
        interval = f" [{lo:.3g}, {hi:.3g}]" if math.isfinite(lo) else ""
        spread = g.energy_relative_std[k]
        rows.append(f"| {level:g} | {g.repeats[k]} | {_number(g.mean_torque[k], 5)} | "
                    f"{g.torque_pu[k]:.4f} | {_number(g.lth_hz[k])} | "
                    f"{_number(g.lth_amplitude[k])} | {_number(g.energy[k])} | "
                    f"{g.energy_pu[k]:.4f}{interval} | "
                    f"{f'{100 * spread:.1f} %' if math.isfinite(spread) else '-'} | "
                    f"{g.interval_source[k]} |")
    noise = [r for r in g.results if r.ok and g.lifters > 0 and not r.lth_distinct]
    if noise:
        rows += ["", f"The LTH does not stand out of the noise (amplitude below "
                 f"{PEAK_DISTINCT_RATIO:g} x the median of the bins around it, or no line in the "
                 f"search window) in {len(noise)} of {sum(r.ok for r in g.results)} cases: "
                 f"{', '.join(f'{r.scene.name} seed {r.case.settings.seed}' for r in noise)}. "
                 "Their LTH frequency and amplitude are those of a noise peak."]
    return rows


def _lth_contrast(r: CaseResult) -> str:
    """The LTH's amplitude over the noise around it, flagged when it does not stand out."""
    if not math.isfinite(r.lth_snr):
        return "-"
    return f"{r.lth_snr:.3g}" + ("" if r.lth_distinct else " (noise)")


def _case_table(results: list[CaseResult]) -> list[str]:
    rows = ["| case | seed | status | level | mean torque (N m) | LTH (Hz) | LTH (N m) | "
            "LTH / noise | energy ((N m)² s) | wall time (s) | hash |",
            "|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in results:
        level = case_key(r.scene).load_level
        rows.append(f"| {r.scene.name} | {r.case.settings.seed} | {r.status} | "
                    f"{'-' if level is None else f'{level:g}'} | {_number(r.mean_torque, 5)} | "
                    f"{_number(r.lth_hz)} | {_number(r.lth_amplitude)} | "
                    f"{_lth_contrast(r)} | {_number(r.energy)} | "
                    f"{_number(r.wall_time_s, 3)} | `{r.hash[:12]}` |")
    return rows


def write_report(store: str | os.PathLike[str], out: str | os.PathLike[str] | None = None, *,
                 progress: bool = True, block: tuple[float, float] | None = None,
                 bootstrap: int = 1000, confidence: float = 0.95, seed: int = 0,
                 sub_blocks: int = 10, sections: Sequence[str] = ()) -> Path:
    """Write the report of a campaign store (see the module docstring).

    Parameters
    ----------
    store : str or path
        A campaign store directory (:class:`~millscope.Campaign`).
    out : str or path, optional
        Folder for the report, created if needed; default ``STORE/report``.
    progress : bool
        Show a tqdm bar over the figures.
    block : (float, float), optional
        Block to analyse, s; default: as the store's campaign analysed its cases.
    bootstrap, confidence, seed, sub_blocks
        As :func:`~millscope.campaign_analysis.analyze_campaign`.
    sections : sequence of str
        Markdown put into the report after the Table 6 analogue, each with its own ``##``
        heading (the main job's verdict and leave-one-out check, :mod:`millscope.demo`).

    Returns
    -------
    Path
        The written ``report.md``.

    Raises
    ------
    ValueError
        before anything is written: for a path that is not a campaign store, a store without
        a finished case, or a bad argument.
    UnreadableCasesError
        (a ValueError) after the report of the other cases is written, when case files of
        the store cannot be read (:func:`~millscope.campaign.unreadable_cases`): damaged, or
        missing although the manifest lists their case. The report counts and names them too.
    """
    if isinstance(sections, str) or not all(isinstance(text, str) for text in sections):
        raise ValueError(f"sections = {sections!r} is not valid; it must be a sequence of "
                         "Markdown strings")
    campaign = Campaign.from_store(store, block=block)
    unreadable = unreadable_cases(campaign.store)
    results = campaign.results()
    done = [r for r in results if r.status == "done"]
    if not done:
        damaged = (f"; {len(unreadable)} cannot be read: {_listing(unreadable)}"
                   if unreadable else "")
        raise ValueError(f"store {campaign.store} holds no finished case ({len(results)} "
                         f"failed{damaged}); nothing to report")
    if campaign.analysis is None:
        raise ValueError(f"store {campaign.store} does not say which block to analyse (its "
                         "campaign ran with block=None); pass block=(t1, t2)")
    with_levels = [r for r in done if case_key(r.scene).load_level is not None]
    groups = (analyze_campaign(results, bootstrap=bootstrap, confidence=confidence, seed=seed,
                               sub_blocks=sub_blocks) if with_levels else [])
    target = Path(out) if out is not None else campaign.store / "report"
    target.mkdir(parents=True, exist_ok=True)

    figures = _figures(groups) if groups else []
    written: list[_Figure] = []
    for fig in tqdm(figures, desc="report figures", unit="figure", disable=not progress):
        plots.save_figure(fig.make(), target / fig.file)
        written.append(fig)
    calibrations: dict[str, str] = {}
    for g in groups:
        if g.fit is not None and g.fit.n >= MIN_LEVELS_FOR_INTERVALS:
            name = calibration_file_name(g.name)
            Calibration.from_group(g).save(target / name)
            calibrations[g.name] = name

    settings = campaign.analysis
    t1, t2 = settings.block
    counts = {s: sum(r.status == s for r in results) for s in ("done", "failed", "pending")}
    cases = len({r.hash for r in results} | {c.hash for c in unreadable})  # each case once
    lines = [
        "# millscope campaign report",
        "",
        f"Store `{campaign.store}`: {cases} cases, {counts['done']} done, {counts['failed']} failed"
        + (f", **{len(unreadable)} could not be read** (listed under \"Unreadable case "
           "files\", left out of the rest)" if unreadable else "")
        + f". millscope {_core.build_info()['version']}, {time.strftime('%Y-%m-%d %H:%M')}.",
        "",
        f"Analysis (paper section 6): block {t1:g} <= t < {t2:g} s (TR = {t2 - t1:g} s, "
        f"df = {1 / (t2 - t1):.3g} Hz), {settings.window} window; the mean and the LTH "
        f"(located near lifters x rotation frequency) removed in bands of {settings.bandwidth:g}"
        " Hz (widened to the window's main lobe when narrower); energy is eq. (11). Per unit: "
        "divided by the group's largest level energy (the lowest filling).",
        "",
    ]
    if groups:
        percent = f"{100 * confidence:g} %"
        lines += [
            "## Table 6 analogue: log fits of energy against filling",
            "",
            table6_markdown(groups),
            _paper_range(),
            "",
            f"Intervals: {percent} percentile bootstrap, {bootstrap} replicates (seed {seed}). "
            "At a level with repeats (other seeds), the mean of its repeats is resampled from "
            "the relative seed-to-seed deviations pooled over all such levels of the group; at "
            f"a level with one case, the energies of up to {sub_blocks} sub-blocks of its block "
            "are resampled, widened to the block spectrum's sampling spread where that is "
            "larger. Every replicate is made per unit and fitted again. *seeds* / "
            "*blocks* / *none* in the last column say which; *none* (a block too short to cut) "
            "leaves the group without intervals. The level with the largest energy is the "
            "per-unit reference: its value is 1 by construction, and so, nearly always, is its "
            "interval.",
            "",
        ]
    else:
        lines += ["No group to analyse: no finished case has particles to grind and a load "
                  "level (balls-only cases have none).", ""]
    for section in sections:
        lines += [section.strip("\n"), ""]
    for g in groups:
        speed = ("" if g.speed_fraction is None
                 else f"{100 * g.speed_fraction:g} % of critical, ")
        lines += [f"## {g.name}", "",
                  f"Particles: {g.particles}; {speed}{g.rotation_hz:.4f} Hz, {g.lifters} lifters "
                  f"(LTH expected at {g.lifters * g.rotation_hz:.3f} Hz).", ""]
        if g.fit is not None:
            lines += [f"Fit: {g.fit.equation()}, R² = {r2_text(g.fit)}.", ""]
        lines += _group_table(g) + [""]
        if g.levels.size >= 2:
            lines += [discrimination(g, confidence=confidence).to_markdown(),
                      "How well one block tells each level from the next: the share of block "
                      "pairs whose energies fall in the right order (the lower level's larger), "
                      "the same from normal log energies, and each block's fill estimate "
                      "against the group's own calibration (which has seen the block, so the "
                      "estimates are optimistic; the interval widths are the method's).", ""]
            lines += _held_out_section(g, confidence)
        if g.name in calibrations:
            lines += [f"Calibration: [`{calibrations[g.name]}`]({calibrations[g.name]}).", ""]
        elif g.fit is not None:
            lines += [f"No calibration file: {no_interval_reason(g.fit)}, so the filling "
                      "estimates it gave would have no interval.", ""]
    if written:
        lines += ["## Figures", ""]
        for fig in written:
            lines += [f"### {fig.heading}", "", fig.caption, "", f"![{fig.heading}]({fig.file})",
                      ""]
    lines += ["## Cost", "", campaign_cost(campaign, results=results).to_markdown(), ""]
    lines += ["## Cases", ""] + _case_table(results) + [""]
    failed = [r for r in results if r.status == "failed"]
    if failed:
        lines += ["## Failed cases", ""]
        lines += [f"- {r.scene.name} seed {r.case.settings.seed} (`{r.hash[:12]}`): "
                  f"{(r.error or '').splitlines()[0] if r.error else 'no message'}"
                  for r in failed]
        lines += [""]
    if unreadable:
        lines += ["## Unreadable case files", "",
                  "These cases are in the store but could not be read, so the tables, fits and "
                  "figures above leave them out. A rerun of the campaign computes them again.",
                  ""]
        lines += [f"- `{c.file}`{f' ({c.name})' if c.name else ''}: {c.reason}"
                  for c in unreadable]
        lines += [""]
    report = target / REPORT_NAME
    with atomic_write(report, "w") as fh:
        fh.write("\n".join(lines))
    if unreadable:
        raise UnreadableCasesError(report, unreadable)
    return report


def write_study(result: StudyResult, folder: str | os.PathLike[str], stem: str = "accuracy", *,
                quantity: str = "energy", cost: str = "wall_s") -> list[Path]:
    """Writes a study's ``<stem>.csv``, ``<stem>.md`` and ``<stem>.png`` (error against cost,
    ``"wall_s"`` or ``"particle_steps"``, :func:`millscope.plots.plot_accuracy`) into
    ``folder``, each atomically. Particle-steps do not depend on the machine or its load.
    The figure is left out while no finished setting has an error of ``quantity`` (a study
    under way whose settings are not finished at every level).

    Returns
    -------
    list of Path
    """
    out = Path(folder)
    out.mkdir(parents=True, exist_ok=True)
    csv_path, md_path = out / f"{stem}.csv", out / f"{stem}.md"
    result.to_csv(csv_path)
    with atomic_write(md_path, "w") as fh:
        fh.write(result.to_markdown(quantity, cost))
    if not any(math.isfinite(p.error) and not p.reference
               for p in result.summary(quantity, cost)):
        return [csv_path, md_path]
    png = plots.save_figure(plots.plot_accuracy(result, quantity, cost=cost), out / f"{stem}.png")
    return [csv_path, md_path, png]

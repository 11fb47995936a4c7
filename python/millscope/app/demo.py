"""The main job: a small DEM campaign of the pilot mill and its report (paper sections 4-6).

:func:`run_demo` runs one material at one speed at several load levels through
:class:`~millscope.campaign.Campaign` into ``<out>/store`` (resumable: a rerun reuses the
finished cases), then writes the campaign report into ``<out>``
(:func:`millscope.report.write_report`: the Table 6 analogue, Figs. 9-15 with the waterfall and
the log fit y = a ln(x) + b, a :class:`~millscope.fit.Calibration` per group) with a main-job
section (:func:`main_job_section`): the torque, spectrum and filtered signal of the lowest
level, whether the energy falls monotonically with the filling, and a leave-one-out check.
The defaults (:class:`DemoPlan`) are the LDMS case (ceramic-like particles, 71 % of critical)
at load levels 1..4 at the ``"tiny"`` scale, 8 s of rotation each of which the block 2-8 s is
analysed: about 2 minutes on 2 free cores (README, "Two commands").

:func:`run_synthetic_demo` (``millscope demo --synthetic``) runs the same analysis in seconds on
synthetic records whose energy law is known, so that the analysis can be seen to recover it.

All quantities are SI (s, N m, Hz, (N m)^2 s).
"""

from __future__ import annotations

import math
import os
import time
import warnings
from collections.abc import Sequence
from dataclasses import dataclass
from numbers import Integral, Real
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure
from tqdm.auto import tqdm

from .._files import atomic_write
from ..calibration.fit import (
    MIN_LEVELS_FOR_INTERVALS,
    Calibration,
    LogFit,
    NoIntervalWarning,
    OutsideCalibrationWarning,
    estimate_fill,
    log_fit,
    per_unit,
)
from ..campaign.cases import MAX_DURATION_S, CaseResult, RunSettings
from ..campaign.runs import Campaign
from ..campaign.tables import CaseResults
from ..engine.simulation import _available_cores
from ..model.presets import (
    LIFTER_COUNT,
    LOAD_LEVELS,
    PARTICLE_KINDS,
    SCALES,
    measured_bias,
    paper_cases,
    pilot_mill,
)
from ..report import plots
from ..report.reports import calibration_file_name, write_report
from ..signal.analysis import analyze_block
from ..signal.record import TorqueRecord
from ..signal.spectral import LTH_CLEAR_BINS, band_stop, lifter_harmonic_hz, spectrum
from ..signal.synthetic import PAPER_HDMS_LAW, SyntheticTorque, synthetic_record

__all__ = ["DemoPlan", "DemoResult", "main_job_section", "run_demo",
           "run_synthetic_demo"]




@dataclass(frozen=True)
class DemoPlan:
    """What the main job simulates. Validated on construction.

    Attributes
    ----------
    scale : str
        A scale of :data:`millscope.presets.SCALES`; ``"tiny"`` by default, the one that fits
        four levels into about 2 minutes on 2 free cores (LDMS#1..#4: 1036 to 2970 particles,
        8 s of rotation each after the fill and settling).
    particles : {"ceramic", "steel"}
        Ceramic-like (LD) or steel-like (HD) particles to grind.
    speed_fraction : float
        Rotation speed as a fraction of critical, in (0, 1]; the paper's are 0.62, 0.71, 0.80.
    load_levels : tuple of int
        Table 5's levels (1..7), at least 2 different ones (the main job uses 4).
    duration_s : float
        Simulated time after the drum starts, s, > warm_up_s and at most 3600
        (``MAX_DURATION_S``); 8 s by default (the paper: 14).
    warm_up_s : float
        Simulated but not kept, s, >= 0; 2 s by default (the paper: 4), past which the mean
        torque of the tiny LDMS cases no longer drifts. The analysed block is the kept record,
        ``warm_up_s <= t < duration_s``: 2-8 s by default, a resolution of 0.17 Hz (the
        paper's 4-14 s gives 0.1 Hz).
        It must hold at least 6 periods of the LTH (0.69 s at 71 % of critical), so that the
        LTH, searched within 3 bins of lifters x rotation frequency, lies clear of the mean's
        main lobe (2 bins with the Hann window).
    seed : int
        Filling seed of every case, >= 0.
    threads : int
        Engine threads per case, >= 1; the cases run in parallel processes, so 1 uses the
        cores best.
    """

    scale: str = "tiny"
    particles: str = "ceramic"
    speed_fraction: float = 0.71
    load_levels: tuple[int, ...] = (1, 2, 3, 4)
    duration_s: float = 8.0
    warm_up_s: float = 2.0
    seed: int = 0
    threads: int = 1

    def __post_init__(self) -> None:
        if not isinstance(self.scale, str) or self.scale not in SCALES:
            raise ValueError(f"DemoPlan.scale = {self.scale!r} is not valid; it must be one of "
                             f"{', '.join(repr(k) for k in SCALES)}")
        if not isinstance(self.particles, str) or self.particles not in PARTICLE_KINDS:
            raise ValueError(f"DemoPlan.particles = {self.particles!r} is not valid; it must be "
                             f"one of {', '.join(repr(k) for k in PARTICLE_KINDS)}")
        if (not isinstance(self.speed_fraction, Real) or isinstance(self.speed_fraction, bool)
                or not 0.0 < float(self.speed_fraction) <= 1.0):
            raise ValueError(f"DemoPlan.speed_fraction = {self.speed_fraction!r} is not valid; "
                             "it must be a number in (0, 1] (fraction of critical speed)")
        levels = self.load_levels
        if (isinstance(levels, (str, bytes)) or not isinstance(levels, Sequence)
                or not all(isinstance(v, Integral) and not isinstance(v, bool)
                           and v in LOAD_LEVELS for v in levels)
                or len(set(levels)) != len(levels) or len(levels) < 2):
            raise ValueError(f"DemoPlan.load_levels = {levels!r} is not valid; it must be at "
                             "least 2 different integers in 1..7 (paper Table 5)")
        object.__setattr__(self, "load_levels", tuple(sorted(int(v) for v in levels)))
        for name in ("duration_s", "warm_up_s"):
            value = getattr(self, name)
            if (not isinstance(value, Real) or isinstance(value, bool)
                    or not 0 <= float(value) <= MAX_DURATION_S):
                raise ValueError(f"DemoPlan.{name} = {value!r} is not valid; it must be a "
                                 f"number in [0, {MAX_DURATION_S:g}] s (the longest rotation "
                                 "a case simulates)")
        if not float(self.warm_up_s) < float(self.duration_s):
            raise ValueError(f"DemoPlan.duration_s = {self.duration_s!r} is not valid; it must "
                             f"be > warm_up_s = {self.warm_up_s!r} s")
        # the LTH is searched within 3 bins of lifters x rotation frequency; the mean's main
        # lobe (Hann) covers 2 bins: the search must clear it, with a bin to spare
        f_lth = lifter_harmonic_hz(LIFTER_COUNT, pilot_mill(self.speed_fraction).rotation_hz)
        shortest = LTH_CLEAR_BINS / f_lth
        if float(self.duration_s) - float(self.warm_up_s) < shortest:
            raise ValueError(
                f"DemoPlan.duration_s - warm_up_s = "
                f"{float(self.duration_s) - float(self.warm_up_s):g} s is not valid; the "
                f"analysed block must be >= {shortest:.3g} s at {self.speed_fraction:g} of "
                f"critical speed, so that the LTH ({f_lth:.3g} Hz) is resolved apart from "
                "the mean")
        for name in ("seed", "threads"):
            value = getattr(self, name)
            lowest = 0 if name == "seed" else 1
            if not isinstance(value, Integral) or isinstance(value, bool) or value < lowest:
                raise ValueError(f"DemoPlan.{name} = {value!r} is not valid; it must be an "
                                 f"integer >= {lowest}")

    @property
    def block(self) -> tuple[float, float]:
        """The analysed block (t1, t2), s: the kept record."""
        return (float(self.warm_up_s), float(self.duration_s))

    @property
    def settings(self) -> RunSettings:
        """The :class:`RunSettings` of every case."""
        return RunSettings(seed=self.seed, duration_s=float(self.duration_s),
                           warm_up_s=float(self.warm_up_s), threads=self.threads)

    def campaign(self, store: str | os.PathLike[str]) -> Campaign:
        """The campaign of this plan with its store at ``store``.

        Cases are handed to the pool from the most particles to the fewest (the highest level
        first), so that the longest cases do not start last; results come back in level order
        from :func:`run_demo`.
        """
        scenes = paper_cases(particles=[self.particles], speed_fractions=[self.speed_fraction],
                             load_levels=sorted(self.load_levels, reverse=True),
                             scale=self.scale)
        return Campaign(scenes, store=store, settings=self.settings, block=self.block)


@dataclass(frozen=True)
class DemoResult:
    """What :func:`run_demo` did.

    Attributes
    ----------
    plan : DemoPlan
    results : list of CaseResult
        One per load level, in rising level order.
    report : Path
        The report (``report.md``).
    wall_time_s : float
        Wall-clock time of the campaign (cases already in the store cost nothing), s.
    calibration : Path or None
        The group's calibration written by the report (``calibration_<group>.json``); None
        with fewer than 3 load levels, whose fit is exact and gives no interval.
    """

    plan: DemoPlan
    results: list[CaseResult]
    report: Path
    wall_time_s: float
    calibration: Path | None = None


def run_demo(out: str | os.PathLike[str], plan: DemoPlan | None = None, *,
             progress: bool = True, max_workers: int | None = None,
             executor: object = None) -> DemoResult:
    """Run the demo campaign into ``out/store`` and write its report into ``out``.

    Parameters
    ----------
    out : path
        Output folder, created if needed. A rerun with the same plan reuses the finished cases
        of ``out/store``.
    plan : DemoPlan, optional
        What to simulate; default :class:`DemoPlan()`.
    progress : bool
        Show the campaign's progress bar and a line on what runs.
    max_workers : int, optional
        Processes of the local pool (default: the cores / threads per case).
    executor : optional
        A ``concurrent.futures`` executor or ``dask.distributed`` Client to run the cases on
        instead (see :meth:`Campaign.run`).

    Returns
    -------
    DemoResult

    Raises
    ------
    RuntimeError
        when a case failed (its error is in ``out/store/manifest.json``); the finished cases are
        kept and a rerun retries the failed ones.
    """
    plan = plan or DemoPlan()
    if not isinstance(plan, DemoPlan):
        raise ValueError(f"plan = {plan!r} is not valid; it must be a DemoPlan or None")
    folder = Path(out)
    if folder.exists() and not folder.is_dir():
        raise ValueError(f"out = {str(folder)!r} is not valid; it must be a folder")
    folder.mkdir(parents=True, exist_ok=True)
    campaign = plan.campaign(folder / "store")
    if progress:
        workers = max_workers or max(1, min(len(campaign), _available_cores() // plan.threads))
        names = ", ".join(c.scene.name for c in reversed(campaign.cases))
        where = "the given executor" if executor is not None else \
            f"{workers} process{'es' if workers > 1 else ''} x {plan.threads} thread" \
            f"{'s' if plan.threads > 1 else ''}"
        print(f"millscope demo: DEM campaign {names} at scale {plan.scale!r}, "
              f"{plan.duration_s:g} s of rotation each (the first {plan.warm_up_s:g} s not "
              f"kept), on {where}; store {campaign.store}")
        group = _group_of(campaign.cases[0].scene.name)
        print(f"millscope demo: measured bias of scale {plan.scale!r}: "
              f"{_scale_bias_text(plan.scale, group)}")
    start = time.perf_counter()
    results = campaign.run(executor=executor, max_workers=max_workers, progress=progress)
    wall = time.perf_counter() - start
    failed = [r for r in results if not r.ok]
    if failed:
        raise RuntimeError(f"{len(failed)} of {len(results)} cases failed, first "
                           f"{failed[0].scene.name}: {failed[0].error}; see "
                           f"{campaign.store / 'manifest.json'} (a rerun retries them)")
    results = CaseResults(sorted(results, key=_level))
    section = main_job_section(results, folder, plan=plan, campaign_wall_s=wall)
    report = write_report(campaign.store, folder, progress=progress, sections=[section])
    calibration = folder / calibration_file_name(_group(results[0]))
    if progress:
        print(f"millscope demo: report written to {report}")
    return DemoResult(plan, results, report, wall,
                      calibration if calibration.is_file() else None)


def _level(result: CaseResult) -> int:
    """Load level of a case (Table 5), from its name (``"LDMS#3"``: :func:`presets.case_name`)."""
    name = result.scene.name
    return int(name.rsplit("#", 1)[1])


def _group(result: CaseResult) -> str:
    """The group (material x speed) of a case, as
    :func:`~millscope.campaign_analysis.analyze_campaign` names it."""
    return _group_of(result.scene.name)


def _group_of(name: str) -> str:
    """The group of a case's name: ``"LDMS#3"`` -> ``"LDMS"``."""
    return name.rsplit("#", 1)[0]


@dataclass(frozen=True)
class _Row:
    level: int
    result: CaseResult
    block: TorqueRecord


def main_job_section(results: Sequence[CaseResult], out: str | os.PathLike[str], *,
                     plan: DemoPlan, campaign_wall_s: float = math.nan) -> str:
    """The main job's part of the report: what ran, whether the energy falls with the filling,
    and a leave-one-out check of the calibration.

    Writes into ``out`` the torque, spectrum (LTH marked) and filtered signal of the lowest
    level (``torque_level<k>.png``, ``spectrum_level<k>.png``, ``filtered_level<k>.png``: the
    paper's Figs. 2, 10 and 3 for one case) and returns a Markdown section that shows them and
    gives the energies per unit with the verdict (monotonic fall or not, paper section 6.4) and,
    with 3 or more levels, each level's filling estimated from a calibration fitted without it.
    :func:`run_demo` puts it into the report of :func:`millscope.report.write_report`.

    Parameters
    ----------
    results : sequence of CaseResult
        Done cases of one material and speed, analysed over ``plan.block``, one per level.
    out : path
        Output folder for the figures.
    plan : DemoPlan
        The plan the results came from.
    campaign_wall_s : float
        Wall-clock time of the campaign, s (reported).

    Returns
    -------
    str
        The Markdown section, headed ``## Main job``.

    Raises
    ------
    ValueError
        with fewer than 2 done cases, or two cases at one level.
    """
    folder = Path(out)
    records = [r.record for r in results if r.ok and r.record is not None]
    if len(results) < 2 or len(records) != len(results):
        raise ValueError(f"main_job_section needs at least 2 done cases; got {len(results)} "
                         f"of which {sum(r.ok for r in results)} done")
    rows = sorted((_Row(_level(r), r, record.block(*plan.block))
                   for r, record in zip(results, records, strict=True)), key=lambda row: row.level)
    levels = np.array([row.level for row in rows], dtype=np.float64)
    if len(set(levels.tolist())) != len(rows):
        raise ValueError(f"main_job_section needs one case per level; got levels "
                         f"{levels.tolist()}")
    folder.mkdir(parents=True, exist_ok=True)
    first = rows[0]
    meta = first.block.meta
    lifters, rotation_hz = int(meta["lifters"]), float(meta["rotation_hz"])
    written: list[str] = []

    def save(fig: Figure, name: str) -> None:
        plots.save_figure(fig, folder / name)
        written.append(name)

    k = first.level
    name = first.result.scene.name
    save(plots.plot_torque(first.block, title=f"{name}: drive torque ({plan.scale} scale, DEM)"),
         f"torque_level{k}.png")
    save(plots.plot_spectrum(spectrum(first.block), lth_hz=first.result.lth_hz,
                             lth_distinct=first.result.lth_distinct,
                             title=f"{name}: torque spectrum"), f"spectrum_level{k}.png")
    filtered = band_stop(first.block, ["mean", first.result.lth_hz], window="rectangular")
    save(plots.plot_filtered(first.block, filtered), f"filtered_level{k}.png")

    energies = np.array([row.result.energy for row in rows])
    energies_pu = per_unit(energies)
    fit = log_fit(levels, energies_pu)
    falls = bool(np.all(np.diff(energies_pu) < 0))
    held_out = _leave_one_out(rows, levels, energies, lifters, rotation_hz,
                              plan.block[1] - plan.block[0])
    return _section_markdown(plan, rows, energies_pu, fit, falls, held_out, campaign_wall_s,
                             written, lifters, rotation_hz)


def _leave_one_out(rows: Sequence[_Row], levels: np.ndarray, energies: np.ndarray,
                   lifters: int, rotation_hz: float, block_s: float
                   ) -> list[tuple[float, tuple[float, float], bool]]:
    """For each level, the filling estimated from a calibration made without that level:
    (level, 95 % interval, outside the calibrated range). Empty with fewer than 3 levels; with
    3, every calibration left goes through 2 levels and the intervals are nan."""
    if len(rows) < 3:
        return []
    out = []
    for i, row in enumerate(rows):
        keep = np.arange(len(rows)) != i
        ref = float(energies[keep].max())
        cal = Calibration(fit=log_fit(levels[keep], energies[keep] / ref),
                          reference_energy=ref, lifters=lifters, rotation_hz=rotation_hz,
                          block_s=block_s)
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", OutsideCalibrationWarning)
            # with 3 levels each calibration left goes through 2 and gives no interval: the
            # report says so in the row instead of warning
            warnings.simplefilter("ignore", NoIntervalWarning)
            try:
                est = estimate_fill(row.block, cal)
            except (ValueError, FloatingPointError):
                out.append((math.nan, (math.nan, math.nan), True))
                continue
        outside = any(issubclass(w.category, OutsideCalibrationWarning) for w in caught)
        out.append((est.level, est.interval, outside))
    return out


def _scale_bias_text(scale: str, group: str) -> str:
    """What the paper-scale studies measured for ``scale`` and the cases of ``group``
    (presets.SCALE_BIAS), or that they were not measured."""
    if scale == "paper":
        return "none: this is the paper's scale and stiffness"
    biases = measured_bias(scale, group)
    if not biases:
        return (f"not measured by the paper-scale studies for {group} (data/study-paper-balls, "
                "data/study-paper-ldms)")
    if len(biases) == 1:
        measured = biases[0].describe()
    else:
        measured = ("the paper-scale study measured these errors (± standard error) against the "
                    "paper's stiffness on the whole drum, per unit of drum length: "
                    + "; ".join(f"{b.case} ({b.seeds} seeds): {b.figures()}"
                                for b in biases))
    return f"{measured}; read this scale's energies as trends, not as the paper's values"


def _section_markdown(plan: DemoPlan, rows: Sequence[_Row], energies_pu: np.ndarray,
                      fit: LogFit, falls: bool,
                      held_out: Sequence[tuple[float, tuple[float, float], bool]],
                      campaign_wall_s: float, written: Sequence[str], lifters: int,
                      rotation_hz: float) -> str:
    group = _group(rows[0].result)
    t1, t2 = plan.block
    verdict = ("falls monotonically with the filling, as in the paper (section 6.4)"
               if falls else
               "does NOT fall monotonically with the filling at this scale and record length "
               "(the paper's DEM energies do)")
    lines = [
        f"## Main job: {group} #{rows[0].level}..#{rows[-1].level}, DEM at {plan.scale!r} "
        "scale",
        "",
        "A small campaign of the paper's pilot mill simulated with millscope's DEM engine "
        "(not synthetic data), analysed as in the paper's section 6.",
        "",
        f"- scale `{plan.scale}`: {SCALES[plan.scale]}",
        f"- measured bias of this scale: {_scale_bias_text(plan.scale, group)}",
        f"- particles: {plan.particles}; speed {100 * plan.speed_fraction:g} % of critical "
        f"(rotation {rotation_hz:.4f} Hz, {lifters} lifters, LTH expected at "
        f"{lifters * rotation_hz:.3f} Hz)",
        f"- each case: fill, settle, then {plan.duration_s:g} s of rotation sampled every 10 ms "
        f"(instantaneous torque, as the paper); the first {plan.warm_up_s:g} s are not kept; "
        f"block {t1:g}-{t2:g} s (resolution {1 / (t2 - t1):.3g} Hz)",
        f"- seed {plan.seed}, {plan.threads} engine thread(s) per case; campaign wall time "
        f"{campaign_wall_s:.0f} s (cases already in the store are not rerun)",
        "",
        f"**Energy p.u.: {', '.join(f'{y:.3f}' for y in energies_pu)}** (levels "
        f"{', '.join(str(row.level) for row in rows)}): the energy {verdict}. "
        f"Log fit: {fit.equation()}, R² = {fit.r2:.4f}. The paper's six cases have a between "
        "-0.48 and -0.41, b between 0.87 and 1.01.",
    ]
    if held_out:
        lines += [
            "",
            "Leave-one-out check: each level estimated from a calibration fitted without it "
            "(levels outside the others' range are extrapolations):",
            "",
            "| level | estimate | 95 % interval | extrapolated |",
            "|---|---|---|---|",
        ]
        for row, (est, (lo, hi), outside) in zip(rows, held_out, strict=True):
            interval = (f"{lo:.2f} .. {hi:.2f}" if math.isfinite(lo) and math.isfinite(hi)
                        else f"none (fit through {len(rows) - 1} levels)")
            lines.append(f"| {row.level} | {est:.2f} | {interval} | "
                         f"{'yes' if outside else 'no'} |")
        if len(rows) - 1 < MIN_LEVELS_FOR_INTERVALS:
            lines += ["", f"With {len(rows)} levels, each calibration left is fitted through "
                      f"{len(rows) - 1}: exactly (R² = 1 trivially), so it gives no interval."]
    lines += ["", f"The lowest level, #{rows[0].level}: torque, spectrum, filtered signal.", ""]
    lines += [f"![{name}]({name})" for name in written]
    return "\n".join(lines) + "\n"


# -- synthetic records ----------------------------------------------------------------------------

SYNTHETIC_LEVELS = (1, 2, 3, 4, 5, 6, 7)
SYNTHETIC_BLOCK_S = (4.0, 14.0)


def run_synthetic_demo(out: str | os.PathLike[str], *, progress: bool = True) -> str:
    """The analysis alone on synthetic records (``millscope demo --synthetic``), in seconds.

    Seven synthetic records of the pilot mill at 71 % critical (load levels 1..7), white noise
    whose energy follows the paper's HDMS law y = -0.454 ln(x) + 0.9987 plus the mean torque and
    the LTH (:mod:`millscope.synthetic`; not a simulation), go through the whole pipeline:
    spectrum with the LTH, band removal, spectral energy, per-unit energies, the log fit, a
    calibration, and a filling estimate for a record the calibration has not seen. The fit
    should recover the law up to noise. Written into ``out``: ``synthetic_level1.csv``,
    ``synthetic_spectrum_level1.png``, ``synthetic_filtered_level1.png``,
    ``synthetic_waterfall.png``, ``synthetic_energy_fit.png``, ``synthetic_calibration.json``
    and ``synthetic_report.txt``.

    Returns
    -------
    str
        The report text.
    """
    folder = Path(out)
    folder.mkdir(parents=True, exist_ok=True)
    content = SyntheticTorque(rotation_hz=pilot_mill(0.71).rotation_hz)
    analyses, spectra = [], []
    for level in tqdm(SYNTHETIC_LEVELS, desc="synthetic cases", disable=not progress):
        record = synthetic_record(level, content=content, seed=level)
        block = record.block(*SYNTHETIC_BLOCK_S)
        analyses.append(analyze_block(block, lifters=content.lifters,
                                      rotation_hz=content.rotation_hz, resolution_hz=0.1))
        spectra.append(spectrum(block))
        if level == 1:
            record.to_csv(folder / "synthetic_level1.csv")
            fig = plots.plot_spectrum(spectra[-1], lth_hz=analyses[-1].lth.frequency_hz,
                                      lth_distinct=analyses[-1].lth.distinct,
                                      title="Synthetic torque, level #1: spectrum")
            plots.save_figure(fig, folder / "synthetic_spectrum_level1.png")
            filtered = band_stop(block, ["mean", analyses[-1].lth.frequency_hz],
                                 window="rectangular")
            plots.save_figure(plots.plot_filtered(block, filtered),
                              folder / "synthetic_filtered_level1.png")

    labels = [f"#{lv}" for lv in SYNTHETIC_LEVELS]
    fig = plots.plot_waterfall(spectra, labels, title="Synthetic torque spectra, levels 1..7")
    plots.save_figure(fig, folder / "synthetic_waterfall.png")

    energies = np.array([a.energy.energy for a in analyses])
    energies_pu = per_unit(energies)
    fit = log_fit(SYNTHETIC_LEVELS, energies_pu)
    plots.save_figure(plots.plot_energy_fit(SYNTHETIC_LEVELS, energies_pu, fit,
                                            label="synthetic HDMS"),
                      folder / "synthetic_energy_fit.png")

    block_s = SYNTHETIC_BLOCK_S[1] - SYNTHETIC_BLOCK_S[0]
    calibration = Calibration(fit=fit, reference_energy=float(energies.max()),
                              lifters=content.lifters, rotation_hz=content.rotation_hz,
                              block_s=block_s, label="synthetic HDMS")
    calibration.save(folder / "synthetic_calibration.json")
    unseen_level = 3.0
    unseen = synthetic_record(unseen_level, content=content, seed=1000).block(*SYNTHETIC_BLOCK_S)
    estimate = estimate_fill(unseen, calibration)

    a_true, b_true = PAPER_HDMS_LAW
    rows = [f"  #{lv}  {a.mean_torque_Nm:10.2f}  {a.lth.frequency_hz:8.3f}  "
            f"{a.lth.amplitude:8.3f}  {a.energy.energy:12.5g}  {y:6.3f}"
            for lv, a, y in zip(SYNTHETIC_LEVELS, analyses, energies_pu, strict=True)]
    report = "\n".join([
        "millscope: the paper's torque analysis on SYNTHETIC records",
        "(white noise whose energy follows y = -0.454 ln(x) + 0.9987, the paper's HDMS fit,",
        " plus mean torque and LTH; not a DEM simulation: `millscope demo` runs one)",
        "",
        f"rotation {content.rotation_hz:.4f} Hz (71 % critical), {content.lifters} lifters, "
        f"LTH expected at {content.lifters * content.rotation_hz:.3f} Hz, block "
        f"{SYNTHETIC_BLOCK_S[0]:g}-{SYNTHETIC_BLOCK_S[1]:g} s, Hann window",
        "",
        "  lvl  mean T (N m)  LTH (Hz)  LTH (N m)  E ((N m)^2 s)  E p.u.",
        *rows,
        "",
        f"log fit      {fit.equation()}   R^2 = {fit.r2:.4f}",
        f"             a = {fit.a:.3f} +- {fit.a_stderr:.3f}, b = {fit.b:.3f} +- "
        f"{fit.b_stderr:.3f}   (law used: a = {a_true}, b = {b_true})",
        f"fill estimate of an unseen level-{unseen_level:g} record: {estimate.level:.2f} "
        f"(95 % interval {estimate.interval[0]:.2f} .. {estimate.interval[1]:.2f})",
        "",
        "files: synthetic_level1.csv, synthetic_spectrum_level1.png, "
        "synthetic_filtered_level1.png,",
        "       synthetic_waterfall.png, synthetic_energy_fit.png, synthetic_calibration.json,",
        "       synthetic_report.txt",
    ])
    with atomic_write(folder / "synthetic_report.txt") as fh:
        fh.write(report + "\n")
    print(report)
    return report

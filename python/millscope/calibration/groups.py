"""The analysis of a campaign (paper section 6, Table 6): its finished cases, group by group.

:func:`analyze_campaign` takes the results of a :class:`~millscope.campaign.Campaign` and makes
the paper's section 6 per group of cases (particles x speed): mean torque per unit (Fig. 9),
LTH frequency and amplitude (Figs. 10-11), energy per unit (Fig. 14) and its log fit with R^2
(Fig. 15, Table 6), each energy and the fit's a and b with a bootstrap interval.
:func:`table6_markdown` writes the Table 6 analogue.

Each case's block was analysed by the campaign (:func:`~millscope.analysis.analyze_block`);
this module reads the attributes of :class:`~millscope.campaign.CaseResult` (``status``,
``analysis``, ``record``, ``scene``, ``key``, ...) without importing the campaign, so that it
sits below the campaign in the layering, where :meth:`millscope.Calibration.from_results` and
:mod:`millscope.report` use it.

Units: s, Hz, N m, (N m)^2 s; per-unit values are dimensionless.
"""

from __future__ import annotations

import math
import zlib
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Literal

import numpy as np
from numpy.typing import NDArray

from .. import _checks
from ..signal.analysis import MIN_SUB_BLOCKS, AnalysisSettings, sub_block_energies
from ..signal.synthetic import PAPER_TABLE_6
from .bootstrap import log_residuals, mean_factors, percentile_interval, pooled_mean_factors
from .logfit import LogFit, log_fit, log_fit_coefficients, per_unit

if TYPE_CHECKING:  # for annotations only: the campaign sits above this layer
    from ..campaign.cases import CaseResult

__all__ = ["GroupAnalysis", "analyze_campaign", "table6_markdown"]

IntervalSource = Literal["seeds", "blocks", "none"]


def _frozen(values: Iterable[float] | NDArray[Any], dtype: type = np.float64) -> NDArray[Any]:
    """A read-only copy (the analysis is frozen)."""
    array: NDArray[Any] = np.array(values, dtype=dtype)
    array.flags.writeable = False
    return array


@dataclass(frozen=True, eq=False)
class GroupAnalysis:
    """The analysis of one group of cases: one kind of particles at one speed (paper Table 4).

    Per-level arrays are ordered by rising ``levels``; a level's value is the mean over its
    repeats (cases at that level with other seeds).

    Attributes
    ----------
    name : str
        The paper's code of the group, e.g. ``"LDMS"`` (:func:`~millscope.presets.case_key`);
        when the campaign holds cases in both sampling modes, one group per mode, named with
        the mode: ``"LDMS-instant"``, ``"LDMS-mean"``.
    particles : str
        "ceramic" (LD), "steel" (HD) or another material's name.
    speed_fraction : float or None
        Fraction of critical speed (None when the scenes give their speed in Hz).
    rotation_hz : float
        Rotation frequency, Hz.
    lifters : int
        Lifter count (0: no lifters, no LTH).
    sampling : {"instant", "mean"}
        How the group's torque was sampled (:class:`~millscope.campaign.RunSettings`).
    levels : ndarray
        Load levels x (Table 5: particle filling in units of 40 %).
    repeats : ndarray of int
        Finished cases per level.
    mean_torque : ndarray
        Mean drive torque over the block, N m.
    torque_pu : ndarray
        ``mean_torque`` per unit of the group's largest (Fig. 9).
    lth_hz, lth_amplitude : ndarray
        The LTH located in each block, Hz and N m (nan without lifters; Figs. 10-11).
    energy : ndarray
        Spectral energy of the block with the mean and the LTH removed, (N m)^2 s (eq. 11).
    energy_relative_std : ndarray
        How much one case's energy scatters, standard deviation over mean: between repeats
        (``"seeds"``), or for the one record (``"blocks"``) the larger of its sub-blocks'
        scatter and its spectrum's sampling spread; nan for ``"none"``.
    energy_pu : ndarray
        ``energy`` per unit of the group's largest (the lowest filling; Fig. 14).
    energy_pu_interval : ndarray, shape (2, n_levels)
        Bootstrap interval (low, high) of ``energy_pu``.
    fit : LogFit or None
        y = a ln(x) + b fitted to ``energy_pu`` against ``levels`` (Table 6; None with one
        level). :attr:`log_fit` is the same fit, typed ``LogFit``: it raises when there is none.
    a_interval, b_interval : (float, float)
        Bootstrap intervals of a and b (nan when no interval is available).
    interval_source : tuple of str
        Per level: ``"seeds"`` (repeats: the pooled deviations of the group's repeats are
        resampled), ``"blocks"`` (one case: the sub-blocks of its block are resampled) or
        ``"none"`` (one case too short to cut into sub-blocks; then the group has no
        intervals).
    confidence : float
        Confidence of the intervals.
    bootstrap : int
        Bootstrap replicates (0: no intervals).
    settings : AnalysisSettings
        How the cases were analysed.
    results : tuple of CaseResult
        The group's cases, by level then seed.
    """

    name: str
    particles: str
    speed_fraction: float | None
    rotation_hz: float
    lifters: int
    sampling: str
    levels: NDArray[np.float64]
    repeats: NDArray[np.int64]
    mean_torque: NDArray[np.float64]
    torque_pu: NDArray[np.float64]
    lth_hz: NDArray[np.float64]
    lth_amplitude: NDArray[np.float64]
    energy: NDArray[np.float64]
    energy_relative_std: NDArray[np.float64]
    energy_pu: NDArray[np.float64]
    energy_pu_interval: NDArray[np.float64]
    fit: LogFit | None
    a_interval: tuple[float, float]
    b_interval: tuple[float, float]
    interval_source: tuple[str, ...]
    confidence: float
    bootstrap: int
    settings: AnalysisSettings
    results: tuple[CaseResult, ...] = field(repr=False)

    @property
    def log_fit(self) -> LogFit:
        """The group's log fit (:attr:`fit`); ValueError when the group has a single load level,
        so no fit."""
        if self.fit is None:
            raise ValueError(f"group {self.name} has a single load level ({self.levels[0]:g}); "
                             "a fit needs at least 2")
        return self.fit

    @property
    def has_intervals(self) -> bool:
        """True when a and b have bootstrap intervals."""
        return bool(np.all(np.isfinite(self.a_interval)))

    def block_relative_std(self) -> float | None:
        """The typical scatter of one block's energy in this group, standard deviation over
        mean: the root mean square of ``energy_relative_std`` over the levels that have it
        (None when none has)."""
        known = self.energy_relative_std[np.isfinite(self.energy_relative_std)]
        return float(np.sqrt(np.mean(known**2))) if known.size else None


def analyze_campaign(results: Iterable[CaseResult], *, bootstrap: int = 1000,
                     confidence: float = 0.95, seed: int = 0,
                     sub_blocks: int = 10) -> list[GroupAnalysis]:
    """The paper's section 6 for the finished cases of a campaign, group by group.

    Cases are grouped by their particles and speed (:func:`~millscope.presets.case_key`) and,
    when both are present, their sampling mode (one group per mode, named ``"LDMS-instant"``,
    ``"LDMS-mean"``);
    balls-only cases (no load level) are left out. Within a group, cases at the same load level
    are repeats (other seeds): each level's mean torque, LTH and energy are their means. The
    energies are made per unit of the largest level's (the lowest filling) and fitted with
    y = a ln(x) + b (:func:`~millscope.log_fit`, Table 6).

    **Intervals** come from a bootstrap of the energies, ``bootstrap`` replicates:

    * at levels with repeats (``"seeds"``), the seed-to-seed spread: the relative deviations
      of the repeats' energies from their level's mean are pooled over all such levels of the
      group (assuming the levels share their relative spread; ``energy_relative_std`` shows
      whether they do), and each level's mean of n repeats is resampled from the pool
      (:func:`~millscope.bootstrap.pooled_mean_factors`); a campaign affords few repeats, and
      resampling 2 or 3 values per level alone gives intervals far too narrow;
    * at a level with one case (``"blocks"``), the spread within the run: the energies of
      ``sub_blocks`` consecutive sub-blocks of its block
      (:func:`~millscope.analysis.sub_block_energies`) are resampled and scale the block's
      energy (:func:`~millscope.bootstrap.mean_factors`), their log deviations widened to
      the block spectrum's sampling spread (``SpectralEnergy.relative_std``) where that is
      larger: sub-blocks do not see the slow fluctuations that make whole blocks scatter.

    Deviations are scaled by sqrt(n/(n-1)) and taken on the log scale. Every replicate is made
    per unit and fitted again, which gives percentile intervals for each per-unit energy and
    for a and b. A level with one case whose block holds fewer than 96 samples (3 sub-blocks of
    32) gives the group no intervals (nan), and ``interval_source`` says ``"none"`` there. The
    replicates of a group depend only on ``seed`` and the group's name.

    Parameters
    ----------
    results : iterable of CaseResult
        E.g. ``Campaign.run()`` or ``Campaign.results()``; only cases with status "done" count,
        and they must have been analysed over a block (the campaign's ``block``).
    bootstrap : int
        Replicates, >= 0 (0: no intervals).
    confidence : float
        Confidence of the intervals, in (0, 1).
    seed : int
        Seed of the resampling, >= 0.
    sub_blocks : int
        Sub-blocks per block for levels with one case, >= 3.

    Returns
    -------
    list of GroupAnalysis
        Ordered by speed, then group name (HDLS, LDLS, HDMS, ... as in Table 6).

    Raises
    ------
    ValueError
        for a bad argument; when no case is done, a finished case was not analysed, no case
        has a load level, or the cases of a group were analysed, built or sampled differently
        (block, bandwidth, window, lifters, rotation, drum, materials, sample_dt, sampling);
        the message names the cases.
    """
    bootstrap = _checks.integer("bootstrap", bootstrap, ValueError, low=0)
    seed = _checks.integer("seed", seed, ValueError, low=0)
    sub_blocks = _checks.integer("sub_blocks", sub_blocks, ValueError, low=MIN_SUB_BLOCKS)
    if not (isinstance(confidence, (int, float)) and 0 < confidence < 1):
        raise ValueError(f"confidence = {confidence!r} is not valid; it must be in (0, 1)")
    all_results = list(results)
    done = [r for r in all_results if r.status == "done"]
    if not done:
        counts = {s: sum(r.status == s for r in all_results) for s in ("pending", "failed")}
        raise ValueError(f"results holds no finished case (status 'done') among "
                         f"{len(all_results)} ({counts['pending']} pending, {counts['failed']} "
                         "failed); nothing to analyse")
    groups: dict[tuple[str, float, str], list[tuple[float, CaseResult]]] = {}
    names: dict[tuple[str, float, str], tuple[str, float | None]] = {}
    for r in done:
        if r.analysis is None or not math.isfinite(r.energy):
            raise ValueError(f"case {r.case.name} ({r.hash[:12]}) was not analysed over a block; "
                             "give the Campaign a block=(t1, t2)")
        key = r.key
        if key.load_level is None or key.particles is None:
            continue
        speed = key.speed_fraction if key.speed_fraction is not None else key.rotation_hz
        gk = (key.particles, round(speed, 9), r.case.settings.sampling)
        groups.setdefault(gk, []).append((key.load_level, r))
        names[gk] = (key.group, key.speed_fraction)
    if not groups:
        raise ValueError(f"none of the {len(done)} finished cases has particles to grind and a "
                         "load level (balls-only cases have none); no group to analyse")
    if len({gk[2] for gk in groups}) > 1:  # both modes: a group per mode, named by it
        names = {gk: (f"{code}-{gk[2]}", speed) for gk, (code, speed) in names.items()}
    out = [_analyze_group(names[gk][0], gk[0], names[gk][1], members, bootstrap=bootstrap,
                          confidence=float(confidence), seed=seed, sub_blocks=sub_blocks)
           for gk, members in groups.items()]
    return sorted(out, key=lambda g: (g.speed_fraction if g.speed_fraction is not None
                                      else g.rotation_hz, g.name))  # -instant before -mean


def _same(name: str, what: str, members: Sequence[tuple[float, CaseResult]],
          value: Any) -> Any:
    """The one value of ``value(result)`` over a group's members, or ValueError naming two
    cases that differ."""
    first = members[0][1]
    ref = value(first)
    for _, r in members[1:]:
        v = value(r)
        if v != ref and not (isinstance(v, float) and math.isclose(v, ref, rel_tol=1e-9)):
            raise ValueError(f"group {name}: cases {first.case.name} and {r.case.name} differ in "
                             f"{what} ({ref!r} and {v!r}); a group must share it")
    return ref


def _level_spread(repeats: list[CaseResult], settings: AnalysisSettings, sub_blocks: int
                  ) -> tuple[IntervalSource, NDArray[np.float64] | None, float]:
    """(source, the values to resample, relative std of one case's energy) for one level:
    the repeats' energies, or the sub-block energies of its one case.

    For one case the spread is the larger of the sub-blocks' and the block spectrum's
    (:attr:`~millscope.SpectralEnergy.relative_std`): sub-blocks lose the content below their
    own, coarser, removal bands (+-2 Hz around the mean and the LTH for 1 s Hann sub-blocks),
    so a torque with slow fluctuations scatters from block to block more than they show.
    """
    energies = np.array([r.energy for r in repeats])
    if len(repeats) >= 2:
        return "seeds", energies, float(np.std(energies, ddof=1) / np.mean(energies))
    case = repeats[0]
    assert case.record is not None
    parts = sub_block_energies(case.record.block(*settings.block), lth_hz=case.lth_hz,
                               sub_blocks=sub_blocks, bandwidth=settings.bandwidth,
                               window=settings.window)
    if parts is None or not np.all(parts > 0):
        return "none", None, math.nan
    spread = _sub_block_spread(parts)
    if math.isfinite(case.energy_relative_std):
        spread = max(spread, case.energy_relative_std)
    return "blocks", parts, spread


def _sub_block_spread(parts: NDArray[np.float64]) -> float:
    """Relative std of the mean of the sub-block energies (that of the whole block's)."""
    return float(np.std(parts, ddof=1) / np.mean(parts) / math.sqrt(parts.size))


def _replicate_factors(spreads: list[tuple[IntervalSource, NDArray[np.float64] | None, float]],
                       replicates: int, rng: np.random.Generator) -> NDArray[np.float64]:
    """Bootstrap factors on each level's energy, shape (replicates, levels): levels with
    repeats draw from the pooled relative deviations of all such levels, a level with one case
    resamples its sub-blocks, its deviations scaled up to the level's spread when the block's
    spectrum says it scatters more (:func:`_level_spread`)."""
    seeds = [values for source, values, _ in spreads if source == "seeds" and values is not None]
    pool = np.concatenate([log_residuals(v) for v in seeds]) if seeds else None
    columns = []
    for source, values, spread in spreads:
        assert values is not None
        if source == "seeds":
            assert pool is not None
            columns.append(pooled_mean_factors(pool, values.size, replicates, rng))
        else:
            own = _sub_block_spread(values)
            widen = spread / own if own > 0 else 1.0
            columns.append(mean_factors(values, replicates, rng) ** widen)
    return np.column_stack(columns)


def _analyze_group(name: str, particles: str, speed_fraction: float | None,
                   members: list[tuple[float, CaseResult]], *, bootstrap: int,
                   confidence: float, seed: int, sub_blocks: int) -> GroupAnalysis:
    members = sorted(members, key=lambda m: (m[0], m[1].case.settings.seed))
    settings = _same(name, "analysis settings", members, lambda r: r.analysis)
    lifters = _same(name, "lifters", members, lambda r: (
        0 if r.scene.drum.lifters is None else r.scene.drum.lifters.count))
    rotation_hz = _same(name, "rotation frequency (Hz)", members, lambda r: r.scene.rotation_hz)
    # the group key (particles x speed x sampling mode) does not see the scale or the sampling
    # interval: cases that differ there are not repeats of one another and must not be
    # averaged
    _same(name, "drum", members, lambda r: r.scene.drum)
    _same(name, "materials", members, lambda r: r.scene.materials)
    _same(name, "sampling (sample_dt, sampling)", members,
          lambda r: (r.case.settings.sample_dt, r.case.settings.sampling))
    levels = sorted({lv for lv, _ in members})
    by_level = [[r for lv, r in members if lv == level] for level in levels]

    def level_means(attribute: str) -> NDArray[np.float64]:
        return _frozen([np.mean([getattr(r, attribute) for r in rs]) for rs in by_level])

    energy = level_means("energy")
    mean_torque = level_means("mean_torque")
    spreads = [_level_spread(rs, settings, sub_blocks) for rs in by_level]
    sources = tuple(s for s, _, _ in spreads)
    energy_pu = per_unit(energy)
    fit = log_fit(levels, energy_pu) if len(levels) >= 2 else None

    nan_pair = (math.nan, math.nan)
    a_interval = b_interval = nan_pair
    pu_interval = np.full((2, len(levels)), np.nan)
    if bootstrap > 0 and "none" not in sources:
        rng = np.random.default_rng([seed, zlib.crc32(name.encode())])
        replicates = per_unit(energy * _replicate_factors(spreads, bootstrap, rng))
        pu_interval = np.vstack(percentile_interval(replicates, confidence))
        if fit is not None:
            a_star, b_star = log_fit_coefficients(levels, replicates)
            a_lo, a_hi = percentile_interval(a_star, confidence)
            b_lo, b_hi = percentile_interval(b_star, confidence)
            a_interval, b_interval = (float(a_lo), float(a_hi)), (float(b_lo), float(b_hi))
    return GroupAnalysis(
        name=name, particles=particles, speed_fraction=speed_fraction,
        rotation_hz=float(rotation_hz), lifters=int(lifters),
        sampling=members[0][1].case.settings.sampling, levels=_frozen(levels),
        repeats=_frozen([len(rs) for rs in by_level], np.int64), mean_torque=mean_torque,
        torque_pu=_frozen(mean_torque / np.max(mean_torque)),
        lth_hz=level_means("lth_hz"), lth_amplitude=level_means("lth_amplitude"),
        energy=energy, energy_relative_std=_frozen([s for _, _, s in spreads]),
        energy_pu=_frozen(energy_pu), energy_pu_interval=_frozen(pu_interval), fit=fit,
        a_interval=a_interval, b_interval=b_interval,
        interval_source=sources, confidence=confidence, bootstrap=bootstrap,
        settings=settings, results=tuple(r for _, r in members))


# -- Table 6 -----------------------------------------------------------------------------------
def _level_range(levels: NDArray[np.float64]) -> str:
    return f"{levels[0]:g}..{levels[-1]:g}" if levels.size > 1 else f"{levels[0]:g}"


def _with_interval(value: float, interval: tuple[float, float]) -> str:
    if not all(math.isfinite(v) for v in interval):
        return f"{value:.4g}"
    return f"{value:.4g} [{interval[0]:.4g}, {interval[1]:.4g}]"


def r2_text(fit: LogFit) -> str:
    """R^2 to 4 decimals, marked when the fit is exact by construction (2 points)."""
    return f"{fit.r2:.4f}" if fit.n > 2 else f"{fit.r2:.4g} (exact: {fit.n} levels)"


def table6_markdown(groups: Sequence[GroupAnalysis]) -> str:
    """The paper's Table 6 for these groups, as a Markdown table (header and one row each).

    Columns: the group's code, the fit's equation, R^2, a and b each with its bootstrap
    interval, the load levels, the cases, where the intervals come from, and the paper's fit
    for the same group (Table 6, :data:`~millscope.synthetic.PAPER_TABLE_6`; the paper's a
    range from -0.476 to -0.408, its R^2 from 0.898 to 0.996). A fit through 2 levels passes
    through both exactly: its R^2 of 1 says nothing and reads "1 (exact: 2 levels)".
    """
    if not groups:
        raise ValueError("groups is empty; give at least one GroupAnalysis")
    percent = f"{100 * groups[0].confidence:g} %"
    rows = [f"| Case | Equation | R² | a [{percent}] | b [{percent}] | levels | cases | "
            "interval from | paper's fit (Table 6) |",
            "|---|---|---|---|---|---|---|---|---|"]
    for g in groups:
        source = ", ".join(sorted(set(g.interval_source)))
        paper = PAPER_TABLE_6.get(g.name.removesuffix(f"-{g.sampling}"))
        published = ("-" if paper is None
                     else f"y = {paper[0]:g} ln(x) + {paper[1]:g}, R² = {paper[2]:g}")
        if g.fit is None:
            rows.append(f"| {g.name} | one level: no fit | | | | {_level_range(g.levels)} | "
                        f"{len(g.results)} | {source} | {published} |")
            continue
        rows.append(f"| {g.name} | {g.fit.equation()} | "
                    f"{r2_text(g.fit)} | {_with_interval(g.fit.a, g.a_interval)} | "
                    f"{_with_interval(g.fit.b, g.b_interval)} | {_level_range(g.levels)} | "
                    f"{len(g.results)} | {source} | {published} |")
    return "\n".join(rows) + "\n"

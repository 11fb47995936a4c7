"""How well one block of torque tells a load level from the next: the number a plant engineer
needs before trusting a fill estimate, which the paper does not give.

For neighbouring load levels k < k' of a group (paper section 6.4: the energy falls as the
filling rises), one block at each gives the energies in the right order when E(k) > E(k'). Over
the group's repeats (blocks of other seeds) that probability is estimated two ways:

* ``p_order``: the share of all (k block, k' block) pairs in the right order, ties counting
  one half: the Mann-Whitney statistic U / (n_k n_k'), unbiased for P(E(k) > E(k'));
* ``p_order_lognormal``: Phi(d / sqrt(s_k^2 + s_k'^2)), d the difference of the mean log
  energies and s the standard deviations of the log energies: the same probability when
  log energies are normal, which resolves it beyond 1 / (n_k n_k') with few repeats.

And per level, the fill estimate of each block (:func:`~millscope.calibration.estimate_fill`
against the group's calibration): the spread of the point estimates over the repeats and the
mean width of their prediction intervals, in load levels. An interval narrower than the
spacing of the levels tells neighbouring levels apart; one wider does not.

The group's own calibration has seen the blocks it estimates. :func:`held_out` estimates each
seed's blocks against a calibration of the group's other seeds instead, as a plant's new block
would be: how far the estimates land from the true level, and how many true levels their
intervals hold (the intervals' coverage, which should be near their confidence).
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from scipy.special import ndtr

from .. import _checks
from ..signal.record import TorqueRecord
from .fit import (
    Calibration,
    FillEstimate,
    NoIntervalWarning,
    OutsideCalibrationWarning,
    estimate_fill,
)
from .groups import GroupAnalysis, analyze_campaign

if TYPE_CHECKING:  # for annotations only: the campaign sits above this layer
    from ..campaign.cases import CaseResult

__all__ = ["Discrimination", "HeldOut", "HeldOutLevel", "LevelPair", "LevelSpread",
           "discrimination", "held_out", "order_probability"]


@dataclass(frozen=True)
class LevelPair:
    """Two neighbouring load levels and how often one block each orders their energies right.

    Attributes
    ----------
    low, high : float
        The load levels, low < high (Table 5 units).
    blocks : (int, int)
        Blocks (repeats) at each.
    p_order : float
        Share of block pairs with E(low) > E(high), ties one half (Mann-Whitney U / n n').
    p_order_lognormal : float
        P(E(low) > E(high)) with normal log energies; nan with fewer than 2 blocks at a level.
    """

    low: float
    high: float
    blocks: tuple[int, int]
    p_order: float
    p_order_lognormal: float


@dataclass(frozen=True)
class LevelSpread:
    """The fill estimates of one level's blocks against the group's calibration.

    Attributes
    ----------
    level : float
        The true load level.
    blocks : int
        Blocks estimated.
    estimate_mean, estimate_std : float
        Mean and standard deviation (ddof 1; nan for one block) of the point estimates, load
        levels.
    interval_width : float
        Mean width of the estimates' prediction intervals, load levels (nan when the
        calibration gives none: a fit through 2 levels).
    """

    level: float
    blocks: int
    estimate_mean: float
    estimate_std: float
    interval_width: float


@dataclass(frozen=True)
class Discrimination:
    """How well one block tells the levels of a group apart (:func:`discrimination`).

    Attributes
    ----------
    group : str
        The group's name, e.g. ``"LDMS"``.
    sampling : str
        How its torque was sampled ("instant" or "mean").
    confidence : float
        Confidence of the prediction intervals.
    pairs : tuple of LevelPair
        Neighbouring levels, by rising level.
    levels : tuple of LevelSpread
        Per level, by rising level.
    """

    group: str
    sampling: str
    confidence: float
    pairs: tuple[LevelPair, ...]
    levels: tuple[LevelSpread, ...]

    def to_markdown(self) -> str:
        """Two small tables: the right-order probability per pair of neighbouring levels, and
        the fill estimates' spread and interval width per level."""
        lines = [f"**{self.group}, {self.sampling} samples**: one block per level", "",
                 "| levels | blocks | P(right order) | P(right order), log-normal |",
                 "|---|---|---|---|"]
        for p in self.pairs:
            lines.append(f"| {p.low:g} / {p.high:g} | {p.blocks[0]} / {p.blocks[1]} | "
                         f"{p.p_order:.2f} | {_number(p.p_order_lognormal, '.3f')} |")
        lines += ["", f"| level | blocks | estimate | estimate std | "
                      f"{100 * self.confidence:g} % interval width |", "|---|---|---|---|---|"]
        for s in self.levels:
            lines.append(f"| {s.level:g} | {s.blocks} | {s.estimate_mean:.2f} | "
                         f"{_number(s.estimate_std, '.2f')} | "
                         f"{_number(s.interval_width, '.2f')} |")
        return "\n".join(lines) + "\n"


def _number(value: float, spec: str) -> str:
    return format(value, spec) if math.isfinite(value) else "-"


def order_probability(higher: Sequence[float], lower: Sequence[float]) -> tuple[float, float]:
    """P(X > Y) for one draw of each, X from ``higher``, Y from ``lower`` (positive values).

    Returns
    -------
    (float, float)
        The share of (x, y) pairs with x > y, ties counting one half (Mann-Whitney U / n m);
        and Phi(d / sqrt(s_x^2 + s_y^2)) from the means d and standard deviations s (ddof 1)
        of the logs (nan unless both hold 2 or more values and some spread).

    Raises
    ------
    ValueError
        when either is empty or holds a value that is not finite and positive.
    """
    x = _positive("higher", higher)
    y = _positive("lower", lower)
    diff = x[:, None] - y[None, :]
    share = float((np.count_nonzero(diff > 0) + 0.5 * np.count_nonzero(diff == 0)) / diff.size)
    if x.size < 2 or y.size < 2:
        return share, math.nan
    lx, ly = np.log(x), np.log(y)
    spread = math.hypot(float(lx.std(ddof=1)), float(ly.std(ddof=1)))
    if spread == 0.0:
        return share, math.nan
    return share, float(ndtr((lx.mean() - ly.mean()) / spread))


def _positive(name: str, values: Sequence[float]) -> np.ndarray:
    v = np.asarray(values, dtype=np.float64).ravel()
    if v.size == 0 or not np.all(np.isfinite(v)) or np.any(v <= 0):
        raise _checks.fail(name, list(values), "a non-empty sequence of finite energies > 0")
    return v


def discrimination(group: GroupAnalysis, calibration: Calibration | None = None, *,
                   confidence: float = 0.95) -> Discrimination:
    """How well one block tells each load level of a group from the next.

    Parameters
    ----------
    group : GroupAnalysis
        A group of :func:`~millscope.campaign_analysis.analyze_campaign` with 2 or more load
        levels; its cases' blocks are the blocks compared and estimated.
    calibration : Calibration, optional
        What the fill is estimated against; default the group's own
        (:meth:`Calibration.from_group`), which has seen these blocks: its intervals are the
        method's, its point estimates optimistic. Give one fitted to other seeds for an
        out-of-sample answer.
    confidence : float
        Of the prediction intervals, in (0, 1).

    Returns
    -------
    Discrimination

    Raises
    ------
    ValueError
        when the group has fewer than 2 levels, or for a bad ``confidence``.
    """
    if not isinstance(group, GroupAnalysis):
        raise _checks.fail("group", group, "a GroupAnalysis (millscope.analyze_campaign)")
    if group.levels.size < 2:
        raise _checks.fail("group", group.name, "a group with 2 or more load levels")
    confidence = _checks.number("confidence", confidence, ValueError, low=0.0, high=1.0,
                                low_open=True, high_open=True)
    if calibration is None:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", NoIntervalWarning)  # a 2-level group: no interval
            calibration = Calibration.from_group(group)
    by_level: dict[float, list[float]] = {float(v): [] for v in group.levels}
    blocks: dict[float, list[TorqueRecord]] = {float(v): [] for v in group.levels}
    for r in group.results:
        by_level[_level(r)].append(r.energy)
        blocks[_level(r)].append(_block(r))
    levels = sorted(by_level)
    pairs = []
    for low, high in zip(levels, levels[1:], strict=False):
        share, lognormal = order_probability(by_level[low], by_level[high])
        pairs.append(LevelPair(low, high, (len(by_level[low]), len(by_level[high])), share,
                               lognormal))
    spreads = []
    for level in levels:
        estimates = [_estimate(block, calibration, confidence) for block in blocks[level]]
        e = np.array([est.level for est in estimates])
        spreads.append(LevelSpread(level, e.size, float(e.mean()),
                                   float(e.std(ddof=1)) if e.size > 1 else math.nan,
                                   float(np.mean([_width(est) for est in estimates]))))
    return Discrimination(group.name, _sampling(group), confidence, tuple(pairs),
                          tuple(spreads))


@dataclass(frozen=True)
class HeldOutLevel:
    """The fill estimates of one level's blocks, each against a calibration that has not seen
    its seed (:func:`held_out`).

    Attributes
    ----------
    level : float
        The true load level.
    blocks : int
        Blocks estimated (one a seed).
    estimate_mean : float
        Mean of the point estimates, load levels.
    error_rms : float
        Root mean square of estimate - true level over the blocks, load levels.
    covered : int
        Blocks whose prediction interval holds the true level (0 when no calibration gives an
        interval).
    interval_width : float
        Mean width of the prediction intervals, load levels (nan when no calibration gives
        one: a fit through 2 levels).
    """

    level: float
    blocks: int
    estimate_mean: float
    error_rms: float
    covered: int
    interval_width: float


@dataclass(frozen=True)
class HeldOut:
    """Each seed's blocks of a group estimated against a calibration of its other seeds
    (:func:`held_out`): the out-of-sample fill estimate a plant's new block would get.

    Attributes
    ----------
    group : str
        The group's name, e.g. ``"LDMS-instant"``.
    sampling : str
        How its torque was sampled ("instant" or "mean").
    confidence : float
        Confidence of the prediction intervals.
    seeds : tuple of int
        The seeds held out in turn.
    levels : tuple of HeldOutLevel
        Per level, by rising level.
    """

    group: str
    sampling: str
    confidence: float
    seeds: tuple[int, ...]
    levels: tuple[HeldOutLevel, ...]

    @property
    def blocks(self) -> int:
        """Blocks estimated, over all levels."""
        return sum(s.blocks for s in self.levels)

    @property
    def covered(self) -> int:
        """Blocks whose interval holds their true level, over all levels."""
        return sum(s.covered for s in self.levels)

    @property
    def error_rms(self) -> float:
        """Root mean square error of the estimates over all blocks, load levels."""
        squares = sum(s.blocks * s.error_rms**2 for s in self.levels)
        return math.sqrt(squares / self.blocks)

    def to_markdown(self) -> str:
        """A table of the held-out estimates per level, and a line for the coverage."""
        percent = f"{100 * self.confidence:g} %"
        lines = [f"**{self.group}, {self.sampling} samples, held out**: each seed's blocks "
                 "against a calibration of the other seeds", "",
                 f"| level | blocks | estimate | RMS error | inside the {percent} interval | "
                 f"{percent} interval width |", "|---|---|---|---|---|---|"]
        for s in self.levels:
            lines.append(f"| {s.level:g} | {s.blocks} | {s.estimate_mean:.2f} | "
                         f"{s.error_rms:.2f} | {s.covered} of {s.blocks} | "
                         f"{_number(s.interval_width, '.2f')} |")
        lines += ["", f"In all: {self.covered} of {self.blocks} true levels inside their "
                      f"{percent} interval; RMS error {self.error_rms:.2f} load levels."]
        return "\n".join(lines) + "\n"


def held_out(group: GroupAnalysis, *, confidence: float = 0.95) -> HeldOut:
    """Leave one seed out: each seed's blocks estimated against a calibration of the rest.

    For each seed of the group in turn, its cases are set aside, the other seeds' cases are
    analysed as a group (:func:`~millscope.campaign_analysis.analyze_campaign`) and calibrated
    (:meth:`Calibration.from_group`), and each set-aside block's fill is estimated against that
    calibration (:func:`~millscope.calibration.estimate_fill`). Unlike :func:`discrimination`,
    no estimate comes from a calibration that has seen its block: the errors and the share of
    true levels inside the intervals are those a new block would meet. With 2 seeds each
    calibration has one case a level, so it is the calibration of a campaign without repeats.

    Parameters
    ----------
    group : GroupAnalysis
        A group of :func:`~millscope.campaign_analysis.analyze_campaign` with 2 or more seeds;
        without each seed, 2 or more load levels must remain.
    confidence : float
        Of the prediction intervals, in (0, 1).

    Returns
    -------
    HeldOut

    Raises
    ------
    ValueError
        when the group has fewer than 2 seeds, or without one of its seeds fewer than 2 load
        levels; for a bad ``confidence``.
    """
    if not isinstance(group, GroupAnalysis):
        raise _checks.fail("group", group, "a GroupAnalysis (millscope.analyze_campaign)")
    confidence = _checks.number("confidence", confidence, ValueError, low=0.0, high=1.0,
                                low_open=True, high_open=True)
    seeds = sorted({_seed(r) for r in group.results})
    if len(seeds) < 2:
        raise _checks.fail("group", group.name, "a group with cases of 2 or more seeds")
    estimates: dict[float, list[FillEstimate]] = {float(v): [] for v in group.levels}
    for seed in seeds:
        rest = [r for r in group.results if _seed(r) != seed]
        if len({_level(r) for r in rest}) < 2:
            raise _checks.fail("group", group.name, "a group whose cases of other seeds than "
                               f"{seed} span 2 or more load levels")
        (others,) = analyze_campaign(rest, bootstrap=0)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", NoIntervalWarning)  # 2 levels left: no interval
            calibration = Calibration.from_group(others)
        for r in group.results:
            if _seed(r) == seed:
                estimates[_level(r)].append(_estimate(_block(r), calibration, confidence))
    levels = []
    for level in sorted(estimates):
        e = np.array([est.level for est in estimates[level]])
        covered = sum(est.interval[0] <= level <= est.interval[1] for est in estimates[level])
        levels.append(HeldOutLevel(level, e.size, float(e.mean()),
                                   float(np.sqrt(np.mean((e - level) ** 2))), int(covered),
                                   float(np.mean([_width(est) for est in estimates[level]]))))
    return HeldOut(group.name, _sampling(group), confidence, tuple(seeds), tuple(levels))


def _level(result: CaseResult) -> float:
    """A group case's load level (a group's cases all have one)."""
    level = result.key.load_level
    assert level is not None
    return float(level)


def _seed(result: CaseResult) -> int:
    return int(result.case.settings.seed)


def _block(result: CaseResult) -> TorqueRecord:
    """The block a group case was analysed over (a group's cases are done and analysed)."""
    assert result.record is not None and result.analysis is not None
    return result.record.block(*result.analysis.block)


def _estimate(block: TorqueRecord, calibration: Calibration, confidence: float
              ) -> FillEstimate:
    """:func:`estimate_fill`, quiet: a 2-level calibration's missing interval and an estimate
    outside the calibrated range are what the tables show, not news."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", NoIntervalWarning)
        warnings.simplefilter("ignore", OutsideCalibrationWarning)
        return estimate_fill(block, calibration, confidence=confidence)


def _width(estimate: FillEstimate) -> float:
    return estimate.interval[1] - estimate.interval[0]


def _sampling(group: GroupAnalysis) -> str:
    return str(group.results[0].case.settings.sampling)

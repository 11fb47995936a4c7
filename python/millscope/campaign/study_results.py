"""The results of a study of error against run time: one run (:class:`StudyRun`), the
errors of a setting (:class:`StudyRow`, :class:`QuantityError`, :class:`SettingSummary`)
and the study's table, CSV and Markdown (:class:`StudyResult`); see
:mod:`millscope.campaign.studies`.
"""

from __future__ import annotations

import csv
import dataclasses
import io
import math
import os
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from .. import _checks
from .._files import atomic_write
from .._frames import Kind, frame, frame_text
from ..calibration.logfit import log_fit, per_unit
from ..engine.simulation import other_sampling
from ..model.presets import pilot_mill
from ..signal.record import TorqueRecord
from .study_plans import COSTS, KNOBS, LEVEL_QUANTITIES, QUANTITIES, Setting, StudyPlan

if TYPE_CHECKING:
    from pandas import DataFrame

__all__ = ["QuantityError", "SettingSummary", "StudyResult", "StudyRow", "StudyRun"]


# -- results -----------------------------------------------------------------------------------


@dataclass(frozen=True)
class StudyRun:
    """One run of a study (a campaign case): what it cost and what its block gives.

    Attributes
    ----------
    setting : int
        Index of the setting in the plan.
    load_level : int
        Table 5's level.
    seed : int
        Filling seed.
    hash : str
        The campaign case's hash: its record is ``<store>/cases/<hash>.npz``.
    wall_s : float
        Wall-clock time of the run (set-up, filling, settling, warm-up, block), s.
    particle_steps : float
        Particles x time steps of the run, settling included.
    n_particles : int
        Spheres in the charge.
    dt_s : float
        Time step, s.
    length_m : float
        Drum length, m.
    block_s : float
        Length of the analysed block, N samples x sample_dt, s.
    mean_torque, lth_amplitude, energy : float
        Of the block as the campaign analyses it: N m, N m, (N m)^2 s (not normalised).
    derived : bool
        Cut from the record of a longer run (:meth:`StudyPlan.donor`, whose hash ``hash``
        is); ``wall_s`` is then an estimate, the donor's in proportion to particle-steps.
    """

    setting: int
    load_level: int
    seed: int
    hash: str
    wall_s: float
    particle_steps: float
    n_particles: int
    dt_s: float
    length_m: float
    block_s: float
    mean_torque: float
    lth_amplitude: float
    energy: float
    derived: bool = False

    def value(self, quantity: str, length_m: float, block_s: float) -> float:
        """``quantity`` of this run on the footing of a run of drum length ``length_m`` (m)
        and block ``block_s`` (s): torques x L_ref / L, energies x (L_ref / L) (T_ref / T)."""
        length = length_m / self.length_m
        if quantity == "energy":
            return self.energy * length * (block_s / self.block_s)
        return float(getattr(self, quantity)) * length


@dataclass(frozen=True)
class QuantityError:
    """One quantity of one row: its seed statistics and its error against the reference.

    Attributes
    ----------
    mean : float
        Mean over the seeds, on the reference's footing (see the module docstring); in the
        quantity's unit (:data:`QUANTITIES`).
    std : float
        Standard deviation over the seeds (ddof 1), same unit.
    error : float
        (mean - reference mean) / |reference mean|: the relative error of the seed mean,
        signed; 0 for the reference.
    spread : float
        std / |reference mean|: the relative scatter of one run.
    error_se : float
        Standard error of ``error`` from the seed noise of both means,
        sqrt(std^2 / n + std_ref^2 / n_ref) / |reference mean|; 0 for the reference (which
        is compared with itself).
    """

    mean: float
    std: float
    error: float
    spread: float
    error_se: float


@dataclass(frozen=True)
class StudyRow:
    """One row of the table: a setting at one load level.

    Attributes
    ----------
    setting : Setting
    reference : bool
        True for the reference setting's rows.
    load_level : int
    n_particles : int
    dt_s : float
        Time step, s.
    shear_modulus_ratio : float
        The shear modulus used / the paper's (the setting's factor, or the scale's own).
    length_m : float
        Drum length, m.
    seeds : int
        Runs (seeds) behind the statistics.
    wall_s : float
        Wall-clock time of one run, s (mean over the seeds).
    particle_steps : float
        Particles x time steps of one run, settling included (mean over the seeds).
    quantities : mapping of str to QuantityError
        ``"mean_torque"``, ``"energy"``, ``"lth_amplitude"``, ``"slope_a"`` and
        ``"energy_ratio"`` (the last two compare load levels: the same on each of the
        setting's levels; nan entries with one load level).
    """

    setting: Setting
    reference: bool
    load_level: int
    n_particles: int
    dt_s: float
    shear_modulus_ratio: float
    length_m: float
    seeds: int
    wall_s: float
    particle_steps: float
    quantities: Mapping[str, QuantityError]

    @property
    def label(self) -> str:
        return self.setting.label


@dataclass(frozen=True)
class SettingSummary:
    """A setting as one point of the error-against-cost plane (all load levels together).

    Attributes
    ----------
    setting : Setting
    reference : bool
    cost : float
        Summed over the load levels: s of wall-clock time or particle-steps per seed.
    error : float
        The largest |error| over the load levels (dimensionless).
    error_se : float
        The standard error at that level.
    spread : float
        The seed spread at that level.
    """

    setting: Setting
    reference: bool
    cost: float
    error: float
    error_se: float
    spread: float


_NAN_ERROR = QuantityError(math.nan, math.nan, math.nan, math.nan, math.nan)


def _statistics(values: Sequence[float], ref_values: Sequence[float],
                is_reference: bool) -> QuantityError:
    """Seed mean and spread of ``values`` and their error against ``ref_values``."""
    v = np.asarray(values, dtype=np.float64)
    r = np.asarray(ref_values, dtype=np.float64)
    if v.size == 0 or not np.all(np.isfinite(v)) or not np.all(np.isfinite(r)):
        return _NAN_ERROR
    mean, ref_mean = float(v.mean()), float(r.mean())
    std = float(v.std(ddof=1)) if v.size > 1 else math.nan
    ref_std = float(r.std(ddof=1)) if r.size > 1 else math.nan
    scale = abs(ref_mean)
    if scale == 0.0:
        return QuantityError(mean, std, math.nan, math.nan, math.nan)
    if is_reference:
        return QuantityError(mean, std, 0.0, std / scale, 0.0)
    se = math.sqrt(std**2 / v.size + ref_std**2 / r.size) / scale
    return QuantityError(mean, std, (mean - ref_mean) / scale, std / scale, se)


@dataclass(frozen=True)
class StudyResult:
    """The table of a study, with its runs when it was run here (not when read from CSV).

    Attributes
    ----------
    rows : tuple of StudyRow
        By setting (plan order), then load level.
    plan : StudyPlan or None
        The plan (None when read from CSV).
    runs : tuple of StudyRun
        Every run (empty when read from CSV).
    store : Path or None
        The campaign store holding the runs' records.
    description : str
        The case studied, e.g. ``"balls-MS, 3 seeds, 0.71 of critical speed"``.
    pending : tuple of Setting
        Settings of the plan some of whose runs are not finished (:meth:`from_runs` with
        ``partial``): their finished levels are in the rows, but not in :meth:`summary`.
    """

    rows: tuple[StudyRow, ...]
    plan: StudyPlan | None = None
    runs: tuple[StudyRun, ...] = ()
    store: Path | None = None
    description: str = ""
    pending: tuple[Setting, ...] = ()

    @classmethod
    def from_runs(cls, plan: StudyPlan, runs: Iterable[StudyRun], *,
                  store: Path | None = None, partial: bool = False) -> StudyResult:
        """The table of a plan's runs (one per setting, load level and seed).

        Parameters
        ----------
        plan : StudyPlan
        runs : iterable of StudyRun
        store : Path, optional
            The campaign store holding the runs' records.
        partial : bool
            A study still under way: tabulate each setting at the load levels where its runs
            and the reference's are all there, and list the settings that lack runs in
            :attr:`pending` (they have no per-unit energy or slope, and stay off the Pareto
            front); the reference must have one finished level.

        Raises
        ------
        ValueError
            when a run is missing (with ``partial``, a run of the reference).
        """
        run_list = tuple(runs)
        by_key = {(r.setting, r.load_level, r.seed): r for r in run_list}

        def finished_levels(k: int) -> list[int]:
            return [level for level in plan.load_levels
                    if all((k, level, seed) in by_key for seed in plan.seeds)]

        def first_missing(k: int) -> str:
            level, seed = next((level, seed) for level in plan.load_levels
                               for seed in plan.seeds if (k, level, seed) not in by_key)
            return (f"runs lack setting {k} ({plan.settings[k].label}) at load level {level}, "
                    f"seed {seed}")

        ref = plan.reference_index
        ref_levels = finished_levels(ref)
        if not ref_levels or (not partial and len(ref_levels) < len(plan.load_levels)):
            raise ValueError(first_missing(ref) + (" (the reference: nothing to compare with "
                                                   "yet)" if partial else ""))
        tabulated: list[tuple[int, list[int]]] = []
        pending = []
        for k in range(len(plan.settings)):
            done = finished_levels(k)
            if len(done) < len(plan.load_levels):
                if not partial:
                    raise ValueError(first_missing(k))
                pending.append(plan.settings[k])
            levels = [level for level in done if level in ref_levels]
            if levels:
                tabulated.append((k, levels))
        first_ref = by_key[(ref, ref_levels[0], plan.seeds[0])]
        length_ref, block_ref = first_ref.length_m, first_ref.block_s

        def values(k: int, level: int, quantity: str) -> list[float]:
            return [by_key[(k, level, s)].value(quantity, length_ref, block_ref)
                    for s in plan.seeds]

        def level_values(k: int, quantity: str) -> list[float]:
            """Per seed: the slope a of the log fit, or E(last level) / E(first level)."""
            if len(plan.load_levels) < 2:
                return []
            out = []
            for s in plan.seeds:
                energies = [by_key[(k, level, s)].energy for level in plan.load_levels]
                out.append(log_fit(plan.load_levels, per_unit(energies)).a
                           if quantity == "slope_a" else energies[-1] / energies[0])
            return out

        rows = []
        every = len(plan.load_levels)
        for k, levels in tabulated:
            setting = plan.settings[k]
            across = {q: (_statistics(level_values(k, q), level_values(ref, q), k == ref)
                          if every > 1 and len(levels) == every else _NAN_ERROR)
                      for q in LEVEL_QUANTITIES}
            for level in levels:
                group = [by_key[(k, level, s)] for s in plan.seeds]
                stats = {q: _statistics(values(k, level, q), values(ref, level, q), k == ref)
                         for q in QUANTITIES if q not in LEVEL_QUANTITIES}
                stats.update(across)
                first = group[0]
                scene = plan.scene(setting, level)
                paper = pilot_mill(plan.speed_fraction, plan.particles, level, "paper")
                ratio = (scene.material(scene.drum.material).shear_modulus
                         / paper.material(paper.drum.material).shear_modulus)
                rows.append(StudyRow(
                    setting=setting, reference=k == ref, load_level=level,
                    n_particles=first.n_particles, dt_s=first.dt_s,
                    shear_modulus_ratio=ratio, length_m=first.length_m, seeds=len(group),
                    wall_s=float(np.mean([r.wall_s for r in group])),
                    particle_steps=float(np.mean([r.particle_steps for r in group])),
                    quantities={q: stats[q] for q in QUANTITIES}))
        name = pilot_mill(plan.speed_fraction, plan.particles, plan.load_levels[0]).name
        if len(plan.load_levels) > 1:
            name = f"{name.split('#')[0]} #{', #'.join(str(v) for v in plan.load_levels)}"
        return cls(tuple(rows), plan, run_list, store,
                   f"{name}, {len(plan.seeds)} seeds, {plan.speed_fraction:g} of critical speed",
                   tuple(pending))

    # -- queries -------------------------------------------------------------------------------
    @property
    def settings(self) -> tuple[Setting, ...]:
        """The settings, in table order, each once."""
        return tuple(dict.fromkeys(r.setting for r in self.rows))

    @property
    def reference(self) -> Setting:
        """The reference setting."""
        return next(r.setting for r in self.rows if r.reference)

    def summary(self, quantity: str = "energy", cost: str = "wall_s") -> list[SettingSummary]:
        """Every setting whose runs are all finished as a point (cost, |error|), in table
        order.

        Parameters
        ----------
        quantity : str
            One of :data:`QUANTITIES`.
        cost : {"wall_s", "particle_steps"}
            Summed over the load levels.

        Returns
        -------
        list of SettingSummary
            The error is the largest |error| over the setting's load levels (nan when the
            quantity is not available, e.g. the slope with one level).
        """
        _checks.choice("quantity", quantity, tuple(QUANTITIES))
        _checks.choice("cost", cost, COSTS)
        out = []
        for s in self.settings:
            if s in self.pending:  # a part of its levels: neither its cost nor its error
                continue
            rows = [r for r in self.rows if r.setting == s]
            total = float(sum(getattr(r, cost) for r in rows))
            worst = max(rows, key=lambda r: (abs(r.quantities[quantity].error)
                                             if math.isfinite(r.quantities[quantity].error)
                                             else -1.0))
            q = worst.quantities[quantity]
            out.append(SettingSummary(s, worst.reference, total, abs(q.error), q.error_se,
                                      q.spread))
        return out

    def pareto(self, quantity: str = "energy", cost: str = "wall_s") -> tuple[Setting, ...]:
        """The settings on the Pareto front of cost against |error|, cheapest first.

        A setting is on the front when no other setting costs no more and errs no more, and
        is better in one of the two. Settings whose error is nan are left out.

        Parameters
        ----------
        quantity : str
            One of :data:`QUANTITIES`.
        cost : {"wall_s", "particle_steps"}

        Returns
        -------
        tuple of Setting
        """
        points = [p for p in self.summary(quantity, cost) if math.isfinite(p.error)]
        points.sort(key=lambda p: (p.cost, p.error))
        front: list[SettingSummary] = []
        best = math.inf
        for p in points:
            if p.error < best:
                front.append(p)
                best = p.error
            elif front and (p.cost, p.error) == (front[-1].cost, front[-1].error):
                front.append(p)  # equal to a point of the front: not dominated
        return tuple(p.setting for p in front)

    def cheapest(self, quantity: str = "energy", within: float = 0.05, *,
                 cost: str = "wall_s", with_se: bool = True,
                 also: Mapping[str, float] | None = None) -> Setting | None:
        """The cheapest finished setting whose error stays within ``within`` at every load
        level (and within the bounds of ``also``).

        The reference qualifies (its error is 0), so a result equal to :meth:`reference`
        means that none of the cheaper settings does.

        Parameters
        ----------
        quantity : str
            One of :data:`QUANTITIES`.
        within : float
            Largest acceptable |error| (a fraction, e.g. 0.05 for 5 %).
        cost : {"wall_s", "particle_steps"}
        with_se : bool
            Require |error| + 2 standard errors <= the bound (the error is below the bound
            with about 97.5 % confidence), not just |error| <= the bound.
        also : mapping of str to float, optional
            Further bounds, quantity to largest |error|, that every level must keep too,
            e.g. ``{"mean_torque": 0.02}``.

        Returns
        -------
        Setting or None
            None when none qualifies (a table without its reference's finished levels).
        """
        bounds = self._bounds(quantity, within, also)
        ok = [p for p in self.summary(quantity, cost)
              if self._keeps(p.setting, bounds, with_se)]
        return min(ok, key=lambda p: p.cost).setting if ok else None

    def seeds_to_show(self, setting: Setting, quantity: str = "energy",
                      within: float = 0.05) -> float:
        """About how many seeds of both ``setting`` and the reference would show its error of
        ``quantity`` within ``within`` (|error| + 2 standard errors <= the bound at every
        level), were its error and seed spreads what they are now: the standard error falls
        as 1 / sqrt(seeds). inf when its error is not below the bound, nan when unknown.
        """
        self._bounds(quantity, within, None)
        need = math.nan
        for r in self.rows:
            if r.setting != setting:
                continue
            e = r.quantities[quantity]
            if r.reference:
                return float(r.seeds)
            if not (math.isfinite(e.error) and math.isfinite(e.error_se)):
                return math.nan
            room = within - abs(e.error)
            if room <= 0.0:
                return math.inf
            level = r.seeds * (2.0 * e.error_se / room) ** 2
            need = level if math.isnan(need) else max(need, level)
        return need

    @staticmethod
    def _bounds(quantity: str, within: float,
                also: Mapping[str, float] | None) -> dict[str, float]:
        _checks.choice("quantity", quantity, tuple(QUANTITIES))
        bounds = {quantity: _checks.positive("within", within)}
        for q, bound in (also or {}).items():
            _checks.choice("also", q, tuple(QUANTITIES))
            bounds[q] = _checks.positive(f"also[{q!r}]", bound)
        return bounds

    def _keeps(self, setting: Setting, bounds: Mapping[str, float], with_se: bool) -> bool:
        """Whether every level of ``setting`` keeps every quantity within its bound."""
        for r in self.rows:
            if r.setting != setting:
                continue
            for q, bound in bounds.items():
                e = r.quantities[q]
                margin = 2.0 * e.error_se if with_se else 0.0
                if not abs(e.error) + margin <= bound:  # nan fails
                    return False
        return True

    def record(self, run: StudyRun) -> TorqueRecord:
        """The stored torque record of a run (after the warm-up; N m against s)."""
        if self.store is None:
            raise ValueError("this result has no store (it was read from CSV)")
        return TorqueRecord.load(self.store / "cases" / f"{run.hash}.npz")

    # -- tables --------------------------------------------------------------------------------
    def to_frame(self) -> DataFrame:
        """The table as a pandas DataFrame, one row per row of :attr:`rows` (setting and load
        level), in order; the columns of :meth:`to_csv`.

        Columns: ``label`` (str), ``reference`` (bool), the knobs (:data:`KNOBS`:
        ``dt_fraction`` (time step / Rayleigh time), ``shear_modulus_factor`` (nan for the
        scale's own), ``record_s`` and ``warm_up_s`` (s), float64; ``sampling`` and ``scale``,
        str), ``load_level`` (int64), ``n_particles`` (int64), ``dt_s`` (s),
        ``shear_modulus_ratio``, ``length_m`` (m), float64, ``seeds`` (int64), ``wall_s``
        (s, one run), ``particle_steps`` (one run), float64, then per quantity ``<q>`` of
        :data:`QUANTITIES` (its unit there: N m, (N m)^2 s or none) the five float64 columns
        ``<q>``, ``<q>_std``, ``<q>_error``, ``<q>_spread``, ``<q>_error_se``
        (:class:`QuantityError`), and ``description`` (str, the same on every row).
        """
        rows = []
        for r in self.rows:
            row: dict[str, Any] = {"label": r.label, "reference": r.reference,
                                   **r.setting.to_dict(), "load_level": r.load_level,
                                   "n_particles": r.n_particles, "dt_s": r.dt_s,
                                   "shear_modulus_ratio": r.shear_modulus_ratio,
                                   "length_m": r.length_m, "seeds": r.seeds, "wall_s": r.wall_s,
                                   "particle_steps": r.particle_steps,
                                   "description": self.description}
            for q in QUANTITIES:
                row.update(zip(_quantity_columns(q), dataclasses.astuple(r.quantities[q]),
                               strict=True))
            rows.append(row)
        return frame(_COLUMNS, rows)

    def to_csv(self, path: str | os.PathLike[str] | None = None) -> str:
        """The table as CSV, one line per row (setting and load level); written atomically to
        ``path`` when given. Returns the text.

        The columns of :meth:`to_frame`, ``reference`` written 1/0; floats are written
        exactly, nan (e.g. ``shear_modulus_factor`` for the scale's own) as an empty field.
        """
        table = self.to_frame()
        table["reference"] = table["reference"].astype("int64")
        text = frame_text(table, "csv")
        if path is not None:
            with atomic_write(path, "w") as fh:
                fh.write(text)
        return text

    @classmethod
    def from_csv(cls, path: str | os.PathLike[str]) -> StudyResult:
        """A table written by :meth:`to_csv` (without plan, runs or store).

        Raises
        ------
        ValueError
            naming the file, for a missing column or a value that does not parse.
        """
        source = Path(path)
        try:
            text = source.read_text()
        except FileNotFoundError:
            raise ValueError(f"{source}: no such study table") from None
        reader = csv.DictReader(io.StringIO(text))
        # Quantities added after a table was written read as nan; everything else must be there.
        optional = {c for q in LEVEL_QUANTITIES for c in _quantity_columns(q)}
        missing = [c for c in _csv_columns()
                   if c not in (reader.fieldnames or []) and c not in optional]
        if missing:
            raise ValueError(f"{source}: not a millscope study table; missing columns "
                             f"{missing}")
        rows, description = [], ""
        for n, line in enumerate(reader, start=2):
            try:
                knobs: dict[str, Any] = {k: line[k] for k in KNOBS}
                for k in ("dt_fraction", "record_s", "warm_up_s"):
                    knobs[k] = float(knobs[k])
                g = _float(knobs["shear_modulus_factor"])
                knobs["shear_modulus_factor"] = None if math.isnan(g) else g
                quantities = {q: QuantityError(*(_float(line.get(c) or "")
                                                 for c in _quantity_columns(q)))
                              for q in QUANTITIES}
                rows.append(StudyRow(
                    setting=Setting(**knobs), reference=line["reference"] == "1",
                    load_level=int(line["load_level"]), n_particles=int(line["n_particles"]),
                    dt_s=float(line["dt_s"]),
                    shear_modulus_ratio=float(line["shear_modulus_ratio"]),
                    length_m=float(line["length_m"]), seeds=int(line["seeds"]),
                    wall_s=float(line["wall_s"]), particle_steps=float(line["particle_steps"]),
                    quantities=quantities))
            except (TypeError, ValueError) as exc:
                raise ValueError(f"{source}, line {n}: {exc}") from None
            description = line["description"]
        if sum(r.reference for r in rows) == 0:
            raise ValueError(f"{source}: no row is marked as the reference")
        return cls(tuple(rows), description=description)

    def to_markdown(self, pareto_quantity: str = "energy", cost: str = "wall_s") -> str:
        """The table in Markdown: per row the setting, its cost, and per quantity the error of
        the seed mean with the seed spread of one run, ``+3.1 % ± 2.0 %``; the reference row
        gives its seed means instead. Settings on the Pareto front of ``pareto_quantity``
        against ``cost`` (``"wall_s"`` or ``"particle_steps"``) are marked with a ◆.
        """
        front = set(self.pareto(pareto_quantity, cost))
        shown = [q for q in QUANTITIES
                 if any(math.isfinite(r.quantities[q].error) for r in self.rows)]
        multi = (len({r.load_level for r in self.rows}) > 1
                 or (self.plan is not None and len(self.plan.load_levels) > 1))
        names = {"mean_torque": "mean torque", "energy": "energy",
                 "lth_amplitude": "LTH amplitude", "slope_a": "slope a",
                 "energy_ratio": "per-unit energy"}
        head = ["setting", *(["level"] if multi else []), "dt (s)", "G / paper's",
                "wall s / run", "particle-steps / run", *(names[q] for q in shown)]
        lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
        ref_row = next(r for r in self.rows if r.reference)
        for r in self.rows:
            mark = " ◆" if r.setting in front else ""
            label = f"**{r.label}** (reference){mark}" if r.reference else f"{r.label}{mark}"
            cells = [label, *([str(r.load_level)] if multi else []), f"{r.dt_s:.3g}",
                     f"{r.shear_modulus_ratio:g}", f"{r.wall_s:.3g}", f"{r.particle_steps:.3g}"]
            for q in shown:
                e = r.quantities[q]
                if r.reference:
                    cells.append(f"{e.mean:.4g} ± {100 * e.spread:.1f} %")
                elif math.isfinite(e.error):
                    cells.append(f"{100 * e.error:+.1f} % ± {100 * e.spread:.1f} %")
                else:
                    cells.append("-")
            lines.append("| " + " | ".join(cells) + " |")
        units = ", ".join(f"{names[q]} in {QUANTITIES[q]}" for q in shown if QUANTITIES[q])
        notes = [
            f"Study of {self.description or 'the pilot mill'}; reference: {ref_row.label}.",
            "",
            *lines,
            "",
            "Each cell: the relative error of the seed mean against the reference's seed mean, "
            "± the seed-to-seed spread of one run (standard deviation over the seeds), both "
            "in % of the reference; the reference row gives its seed means "
            f"({units}) ± its spread. An error within about 2 x spread x sqrt(2 / seeds) "
            "is not told apart from noise (the CSV gives each error's standard error). "
            "Torques are compared per length of drum and energies per length of drum and of "
            "block (see millscope.studies). Wall time: one run (engine set-up, filling, "
            "settling, warm-up and block) on the plan's engine threads. ◆: on the Pareto front "
            f"of {'wall time' if cost == 'wall_s' else 'particle-steps'} against the "
            f"{names[pareto_quantity]} error.",
        ]
        # The per-unit energy itself, of the reference and of the reference in the other
        # sampling mode (a measure of its own, not an error of the reference's).
        other = ref_row.setting.replace(sampling=other_sampling(ref_row.setting.sampling))
        modes = {"instant": "instantaneous", "mean": "interval-mean"}
        for whose, row in (("the reference", ref_row),
                           (f"the reference's setting with {modes[other.sampling]} samples",
                            next((r for r in self.rows if r.setting == other
                                  and other not in self.pending), None))):
            if row is None:
                continue
            ratio = row.quantities["energy_ratio"]
            if not (math.isfinite(ratio.std) and ratio.mean != 0.0):
                continue
            se = ratio.std / abs(ratio.mean) / math.sqrt(row.seeds)
            need = math.ceil(row.seeds * (se / 0.05) ** 2)
            notes += ["", f"Per-unit energy of {whose}: {ratio.mean:.4g}, standard error "
                      f"{100 * se:.1f} % from {row.seeds} seeds; a 5 % standard error needs "
                      f"{max(need, 2)} seeds" + (" (met)." if se <= 0.05 else ".")]
        notes += ["", self._recommendation(pareto_quantity, cost, names)]
        if self.pending:
            notes += ["", "Not finished yet (only their finished levels are shown, and they "
                      "stay off the Pareto front): "
                      + "; ".join(s.label for s in self.pending) + "."]
        return "\n".join(notes) + "\n"

    def _recommendation(self, quantity: str, cost: str, names: Mapping[str, str]) -> str:
        """The report's paragraph on the recommended setting (:data:`RECOMMENDED_WITHIN`)."""
        torque, bound = RECOMMENDED_WITHIN
        also = {"mean_torque": torque}
        rule = (f"the cheapest setting whose mean torque stays within {100 * torque:g} % and "
                f"whose {names[quantity]} stays within {100 * bound:g} % of the reference's "
                "at every level, each error with 2 standard errors")
        best = self.cheapest(quantity, bound, cost=cost, also=also)
        unfinished = " among the finished settings" if self.pending else ""
        if best is None:
            return f"Recommended setting ({rule}): none yet, the reference is not finished."
        if best != self.reference:
            return f"Recommended setting ({rule}){unfinished}: **{best.label}**."
        text = (f"Recommended setting ({rule}){unfinished}: **none of the cheaper settings "
                "qualifies**.")
        likely = [p for p in self.summary(quantity, cost) if not p.reference
                  and self._keeps(p.setting, {quantity: bound, **also}, with_se=False)]
        if not likely:
            return text + " None is within the bounds even by its errors alone."
        first = min(likely, key=lambda p: p.cost).setting
        needs = (self.seeds_to_show(first, quantity, bound),
                 self.seeds_to_show(first, "mean_torque", torque))
        seeds = (f"about {math.ceil(max(needs))} seeds of it and of the reference"
                 if all(math.isfinite(n) for n in needs)
                 else "seeds in a number its standard errors do not tell")
        labels = [p.setting.label for p in sorted(likely, key=lambda p: p.cost)]
        which = (f"{labels[0]} keeps" if len(labels) == 1
                 else f"{', '.join(labels[:-1])} and {labels[-1]} keep")
        return (text + f" By their errors alone, without the noise, {which} the bounds; "
                f"showing it for {first.label} would take {seeds}.")


#: The bounds of the recommended setting: the mean torque's |error| and the study quantity's
#: (the per-unit energy, or the energy), as fractions of the reference.
RECOMMENDED_WITHIN = (0.02, 0.05)


def _float(text: str) -> float:
    """A CSV field as a float; an empty field (a missing value) is nan."""
    return math.nan if text == "" else float(text)


def _quantity_columns(quantity: str) -> tuple[str, ...]:
    return (quantity, f"{quantity}_std", f"{quantity}_error", f"{quantity}_spread",
            f"{quantity}_error_se")


def _csv_columns() -> list[str]:
    return list(_COLUMNS)


#: The columns of the table (:meth:`StudyResult.to_frame`) with how each is stored.
_COLUMNS: dict[str, Kind] = {
    "label": "str", "reference": "bool",
    **{k: "str" if k in ("sampling", "scale") else "float" for k in KNOBS},
    "load_level": "int", "n_particles": "int",
    "dt_s": "float", "shear_modulus_ratio": "float", "length_m": "float", "seeds": "int",
    "wall_s": "float", "particle_steps": "float",
    **{c: "float" for q in QUANTITIES for c in _quantity_columns(q)},
    "description": "str",
}

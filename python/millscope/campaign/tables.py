"""Campaign results as one table: :class:`CaseResults` (what :meth:`Campaign.run` and
:meth:`Campaign.results` return) and the rows of a store's cases that cannot be read
(:func:`millscope.read_store` puts them together).

One row per case; the columns are :data:`CASE_COLUMNS`. Units: s, Hz, N m, (N m)^2 s.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

from .._frames import Kind, frame
from .cases import CaseResult
from .store import read_manifest, unreadable_cases

if TYPE_CHECKING:
    from pandas import DataFrame

__all__ = ["CASE_COLUMNS", "CaseResults"]

#: The columns of a campaign's table, in order, with how each is stored
#: (:data:`millscope._frames.Kind`).
CASE_COLUMNS: dict[str, Kind] = {
    "scene": "str", "hash": "str", "status": "str", "group": "str", "particles": "str",
    "load_level": "level", "seed": "int", "speed_fraction": "float", "rotation_hz": "float",
    "lifters": "int", "n_particles": "int", "sampling": "str", "sample_dt_s": "float",
    "duration_s": "float", "warm_up_s": "float", "threads": "int", "block_start_s": "float",
    "block_end_s": "float", "bandwidth_hz": "float", "window": "str",
    "mean_torque_Nm": "float", "lth_hz": "float", "lth_amplitude_Nm": "float",
    "lth_noise_Nm": "float", "lth_snr": "float", "lth_distinct": "bool",
    "energy_Nm2s": "float", "energy_relative_std": "float", "wall_time_s": "float",
    "cpu_time_s": "float", "error": "str",
}


def case_row(r: CaseResult) -> dict[str, Any]:
    """One case as a row of :data:`CASE_COLUMNS`."""
    key = r.key
    settings = r.case.settings
    lifters = r.scene.drum.lifters
    a = r.analysis
    return {
        "scene": r.scene.name, "hash": r.hash, "status": r.status, "group": key.group,
        "particles": key.particles, "load_level": key.load_level, "seed": settings.seed,
        "speed_fraction": key.speed_fraction, "rotation_hz": key.rotation_hz,
        "lifters": 0 if lifters is None else lifters.count, "n_particles": r.scene.n_particles,
        "sampling": settings.sampling, "sample_dt_s": settings.sample_dt,
        "duration_s": settings.duration_s, "warm_up_s": settings.warm_up_s,
        "threads": settings.threads,
        "block_start_s": None if a is None else a.block[0],
        "block_end_s": None if a is None else a.block[1],
        "bandwidth_hz": None if a is None else a.bandwidth,
        "window": None if a is None else a.window,
        "mean_torque_Nm": r.mean_torque, "lth_hz": r.lth_hz, "lth_amplitude_Nm": r.lth_amplitude,
        "lth_noise_Nm": r.lth_noise, "lth_snr": r.lth_snr, "lth_distinct": r.lth_distinct,
        "energy_Nm2s": r.energy, "energy_relative_std": r.energy_relative_std,
        "wall_time_s": r.wall_time_s, "cpu_time_s": r.cpu_time_s, "error": r.error,
    }


class CaseResults(list[CaseResult]):
    """The results of a campaign, one :class:`CaseResult` per case (a list, with a table)."""

    def to_frame(self) -> DataFrame:
        """The results as a pandas DataFrame, one row per case in order, failed and pending
        cases included (their figures nan, ``error`` saying why).

        Columns (:data:`CASE_COLUMNS`):

        * ``scene`` (its name, e.g. ``"LDMS#3"``), ``hash`` (:meth:`Case.hash`), ``status``
          (``"done"``, ``"failed"``, ``"pending"``; :func:`millscope.read_store` adds
          ``"unreadable"``): str;
        * ``group`` (the case code without its level, e.g. ``"LDMS"``), ``particles``
          (``"ceramic"``, ``"steel"``, missing for balls only): str
          (:func:`~millscope.presets.case_key`);
        * ``load_level``: Table 5's level, int64 (float64 when a scene's level is not a whole
          number; missing for balls only); ``seed``: the filling seed, int64;
        * ``speed_fraction``: fraction of critical speed (dimensionless; nan when the scene
          gives its speed in Hz); ``rotation_hz``: rotation frequency, Hz; float64;
        * ``lifters``, ``n_particles`` (spheres in the charge), ``threads``: int64;
        * ``sampling`` (``"instant"`` or ``"mean"``): str; ``sample_dt_s``, ``duration_s``,
          ``warm_up_s``: s, float64 (:class:`RunSettings`);
        * the analysis (:class:`~millscope.analysis.AnalysisSettings`): ``block_start_s``,
          ``block_end_s`` (s), ``bandwidth_hz`` (Hz), float64, and ``window``, str; missing
          when the campaign has no block;
        * the figures of the block, float64: ``mean_torque_Nm`` (N m), ``lth_hz`` (Hz),
          ``lth_amplitude_Nm`` and ``lth_noise_Nm`` (N m), ``lth_snr`` (dimensionless),
          ``energy_Nm2s`` ((N m)^2 s, eq. 11), ``energy_relative_std`` (dimensionless),
          ``wall_time_s`` (s), ``cpu_time_s`` (s, the worker process's CPU time; nan when not
          recorded); ``lth_distinct``: bool;
        * ``error``: why a case failed, str, missing when done.

        Integer columns with a missing value are pandas' nullable Int64. Per-unit energies
        belong to a group (:func:`~millscope.analyze_campaign`); from the table,
        ``df.energy_Nm2s / df.groupby("group").energy_Nm2s.transform("max")`` for one case
        per level.
        """
        return frame(CASE_COLUMNS, [case_row(r) for r in self])


def unlisted_rows(store: Path, known: set[str]) -> list[dict[str, Any]]:
    """Rows for the cases ``store`` names but cannot give, other than ``known`` hashes: a
    damaged case file (status ``"unreadable"``, ``error`` saying why) and a case the manifest
    lists without a file (``"pending"``), with the name and seed the manifest gives."""
    rows: dict[str, dict[str, Any]] = {}
    for damaged in unreadable_cases(store):
        if damaged.hash not in known:
            rows.setdefault(damaged.hash, {"hash": damaged.hash, "status": "unreadable",
                                           "error": f"{damaged.file}: {damaged.reason}"})
    if (store / "manifest.json").is_file():
        for entry in read_manifest(store).get("cases", []):
            digest = entry.get("hash") if isinstance(entry, dict) else None
            if not isinstance(digest, str) or digest in known:
                continue
            row = rows.setdefault(digest, {"hash": digest, "status": "pending"})
            name, seed = entry.get("name"), entry.get("seed")
            if isinstance(name, str):
                row["scene"] = name
            if isinstance(seed, int) and not isinstance(seed, bool) and seed >= 0:
                row["seed"] = seed
    return list(rows.values())

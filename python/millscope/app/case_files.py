"""Case files: ``millscope run case.toml`` (one case) and ``millscope campaign spec.toml``.

A case file is TOML with three tables::

    [scene]                      # a preset by name, with the preset function's arguments ...
    preset = "pilot_mill"        # or "axial_slice" (millscope.presets)
    speed_fraction = 0.71
    particles = "ceramic"        # left out: balls only
    load_level = 1
    scale = "tiny"
    # ... or an explicit scene: the keys of Scene.to_dict without "format" ([scene.drum],
    # [scene.drum.lifters], [[scene.materials]], [[scene.charge]], [[scene.pairs]], ...)

    [settings]                   # the fields of RunSettings, plus dt_fraction, energy_ledger
    seed = 0
    duration_s = 3.0             # rotation simulated, warm-up included, s
    warm_up_s = 1.0              # not kept: the record is warm_up_s .. duration_s
    sample_dt = 0.01
    sampling = "mean"
    threads = 1
    dt_fraction = 0.2            # or dt = ... s; neither: the engine's default step
    energy_ledger = false        # book the dissipated energy and print the ledger

    [output]
    record = "out/case.npz"      # or .csv (TorqueRecord.save)
    checkpoint = "out/case.ckpt" # optional: Simulation.save after the run
    analysis = true              # optional: print mean torque, LTH and spectral energy
    spectrum = "out/case.png"    # optional: the spectrum figure of the kept record

A campaign file has ``[campaign]`` (``store``, and optionally ``block``, ``seeds``,
``bandwidth``, ``window``, ``retry_failed`` as :class:`~millscope.Campaign` takes them, and
``reuse``: other stores whose finished cases of this campaign are copied in instead of run,
:meth:`~millscope.Campaign.adopt`),
the scenes as ``[matrix]`` (the arguments of :func:`millscope.presets.paper_cases`) and/or
``[[scenes]]`` (each one as ``[scene]`` above), ``[settings]`` as above (without
``energy_ledger``; ``sampling`` may list both modes, ``["instant", "mean"]``: every case is
then stored in both, from one run) and ``[executor]`` (``kind = "local"``, ``max_workers`` as
:meth:`Campaign.run` takes it). A rerun on the same
store resumes it, as :meth:`Campaign.run` does.

Every value goes through the Python API's own checks (the preset functions, Scene.from_dict,
RunSettings, Case, Campaign), so a bad value gets the API's message, prefixed with the file
and the table: ``case.toml: [settings] RunSettings.seed = -1 is not valid; it must be an
integer >= 0``. Unknown keys and tables are refused, naming the allowed ones. Everything is
checked before any simulation starts. Relative paths are relative to the working directory.
"""

from __future__ import annotations

import argparse
import contextlib
import dataclasses
import inspect
import math
import os
import sys
import warnings
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from tqdm import TqdmWarning

from .. import _checks
from .._files import read_toml
from ..campaign.cases import SAMPLINGS, Case, CaseResult, RunSettings, case_matrix
from ..campaign.executors import simulate_case
from ..campaign.runs import Campaign
from ..campaign.study_plans import Setting
from ..model.presets import axial_slice, paper_cases, pilot_mill
from ..model.scene import SCENE_FORMAT, Scene
from ..model.stiffness import time_step_limit
from ..signal.analysis import BlockAnalysis, analyze_block
from ..signal.record import TorqueRecord
from ..signal.spectral import spectral_energy

__all__ = ["CampaignPlan", "CaseFileError", "RunPlan", "load_campaign", "load_run",
           "run_campaign", "run_case_file"]

#: The presets a case file names with ``preset = "..."``; their keyword arguments are the
#: table's other keys.
PRESETS: Mapping[str, Callable[..., Scene]] = {"pilot_mill": pilot_mill,
                                               "axial_slice": axial_slice}
_SETTINGS = (*(f.name for f in dataclasses.fields(RunSettings)), "dt_fraction")
_RECORD_SUFFIXES = (".npz", ".csv")
_EXECUTORS = ("local",)


class CaseFileError(ValueError):
    """A case or campaign file that cannot be used; the message names the file, the table,
    the key, its value and what is valid."""


# -- reading -----------------------------------------------------------------------------------


def _kind(value: object) -> str:
    """The TOML type of a value, for messages."""
    names = {bool: "a boolean", int: "an integer", float: "a float", str: "a string",
             list: "an array", dict: "a table"}
    return names.get(type(value), type(value).__name__)


@contextlib.contextmanager
def _api(where: str) -> Iterator[None]:
    """Turns an error of the Python API's checks into a CaseFileError prefixed by ``where``
    (the file and the table), the API's message unchanged."""
    try:
        yield
    except CaseFileError:
        raise
    except (ValueError, TypeError) as exc:
        raise CaseFileError(f"{where} {exc}") from None


def _table(data: Mapping[str, Any], name: str, where: str, allowed: tuple[str, ...],
           required: tuple[str, ...] = ()) -> Mapping[str, Any]:
    """``data[name]`` (empty when absent) when it is a table of ``allowed`` keys holding the
    ``required`` ones."""
    value = data.get(name, {})
    if not isinstance(value, Mapping):
        raise CaseFileError(f"{where}: {name} = {_checks.show(value)} is not valid; it must be "
                            f"a table [{name}], not {_kind(value)}")
    return _checks.keys(f"{where}: [{name}]", value, CaseFileError, allowed, required)


def _read(path: str | os.PathLike[str], what: str, tables: tuple[str, ...],
          required: tuple[str, ...]) -> dict[str, Any]:
    data = read_toml(path, what, CaseFileError)
    _checks.keys(f"{path}", data, CaseFileError, tables, required)
    return data


def _scene(table: object, where: str) -> Scene:
    """A preset (``preset = "name"`` and its arguments) or an explicit scene (Scene.from_dict
    keys)."""
    if not isinstance(table, Mapping):
        raise CaseFileError(f"{where}: the scene must be a table, not {_kind(table)}")
    if "preset" not in table:
        with _api(where):
            return Scene.from_dict({"format": SCENE_FORMAT, **table})
    with _api(where):
        name = _checks.choice("preset", table["preset"], tuple(PRESETS))
    build = PRESETS[name]
    options = tuple(inspect.signature(build).parameters)
    _checks.keys(f"{where} (preset {name!r})", table, CaseFileError, ("preset", *options))
    with _api(where):
        return build(**{k: v for k, v in table.items() if k != "preset"})


def _settings(table: Mapping[str, Any], where: str) -> tuple[RunSettings, float | None]:
    """RunSettings of the ``[settings]`` keys, and the time step as a fraction of the
    smallest Rayleigh time when given (``Setting.dt_fraction``'s check)."""
    fields = {k: v for k, v in table.items() if k in _SETTINGS and k != "dt_fraction"}
    with _api(where):
        settings = RunSettings(**fields)
        fraction = None
        if "dt_fraction" in table:
            fraction = Setting(dt_fraction=table["dt_fraction"]).dt_fraction
    if fraction is not None and settings.dt is not None:
        raise CaseFileError(f"{where} dt = {_checks.show(settings.dt)} and dt_fraction = "
                            f"{_checks.show(fraction)} are not valid together; give one of "
                            "them (neither: the engine's default step)")
    return settings, fraction


def _sampling_modes(value: object, where: str) -> tuple[str, ...]:
    """A campaign's sampling modes: one, or a list of distinct ones (each case then runs once
    and is stored in every mode listed, :meth:`Campaign.run`)."""
    items = value if isinstance(value, list) else [value]
    valid = (f"one of {', '.join(repr(m) for m in SAMPLINGS)}, or a list of them (each case "
             "is stored in every mode listed, from one run)")
    if not items or len(set(map(str, items))) != len(items) or \
            not all(isinstance(m, str) and m in SAMPLINGS for m in items):
        raise CaseFileError(f"{where} sampling = {_checks.show(value)} is not valid; it must be "
                            f"{valid}")
    return tuple(items)


def _case(scene: Scene, settings: RunSettings, fraction: float | None, where: str) -> Case:
    if fraction is not None:
        settings = settings.replace(dt=fraction * scene.min_rayleigh_time()[0])
    with _api(where):
        return Case(scene, settings)


def _output_path(table: Mapping[str, Any], key: str, where: str,
                 suffixes: tuple[str, ...] = ()) -> Path | None:
    """The path of output ``key``, checked to be writable."""
    if key not in table:
        return None
    with _api(where):
        text = _checks.text(key, table[key])
    path = Path(text)
    if suffixes and path.suffix.lower() not in suffixes:
        valid = "a path ending in " + " or ".join(suffixes)
        raise CaseFileError(f"{where} {_checks.fail(key, text, valid)}")
    if path.is_dir():
        raise CaseFileError(f"{where} {_checks.fail(key, text, 'a file path, not a folder')}")
    # the folder is created when the file is written; here its nearest existing ancestor
    # must be a folder this process may write in
    ancestor = path.absolute().parent
    while not ancestor.exists() and ancestor != ancestor.parent:
        ancestor = ancestor.parent
    if not ancestor.is_dir() or not os.access(ancestor, os.W_OK | os.X_OK):
        raise CaseFileError(f"{where} {key} = {text!r}: cannot write there ({ancestor} is "
                            f"{'not writable' if ancestor.is_dir() else 'not a folder'})")
    return path


def _save(path: Path, write: Callable[[Path], Path]) -> Path:
    """``write(path)`` after creating the folder of ``path``."""
    path.parent.mkdir(parents=True, exist_ok=True)
    return write(path)


def _figure_suffixes() -> tuple[str, ...]:
    from matplotlib.backend_bases import FigureCanvasBase

    return tuple(f".{s}" for s in FigureCanvasBase.get_supported_filetypes())


# -- millscope run -----------------------------------------------------------------------------


@dataclass(frozen=True)
class RunPlan:
    """A case file, read and checked.

    Attributes
    ----------
    case : Case
        The scene and its RunSettings (the time step resolved from ``dt_fraction``).
    energy_ledger : bool
        Book the dissipated energy (``Simulation(track_energy=True)``).
    record : Path
        The kept record (``warm_up_s .. duration_s``), ``.npz`` or ``.csv``.
    checkpoint, spectrum : Path or None
        The simulation's state after the run, and the spectrum figure.
    analysis : bool
        Print mean torque, LTH and spectral energy of the kept record.
    """

    case: Case
    energy_ledger: bool
    record: Path
    checkpoint: Path | None
    analysis: bool
    spectrum: Path | None


def load_run(path: str | os.PathLike[str]) -> RunPlan:
    """Read and check a case file (see the module docstring); CaseFileError for any fault,
    naming the file, the table and the key, before anything runs."""
    data = _read(path, "case", ("scene", "settings", "output"), ("scene", "output"))
    scene = _scene(data["scene"], f"{path}: [scene]")
    table = _table(data, "settings", str(path), (*_SETTINGS, "energy_ledger"))
    where = f"{path}: [settings]"
    settings, fraction = _settings(table, where)
    with _api(where):
        ledger = _checks.flag("energy_ledger", table.get("energy_ledger", False))
    case = _case(scene, settings, fraction, where)

    out = _table(data, "output", str(path), ("record", "checkpoint", "analysis", "spectrum"),
                 ("record",))
    where = f"{path}: [output]"
    with _api(where):
        analysis = _checks.flag("analysis", out.get("analysis", False))
    if analysis or "spectrum" in out:
        _check_analysable(case, where)
    record = _output_path(out, "record", where, _RECORD_SUFFIXES)
    checkpoint = _output_path(out, "checkpoint", where)
    spectrum = _output_path(out, "spectrum", where, _figure_suffixes()) \
        if "spectrum" in out else None
    given = [p.resolve() for p in (record, checkpoint, spectrum) if p is not None]
    if len(set(given)) != len(given):
        raise CaseFileError(f"{where} record, checkpoint and spectrum must be different files")
    assert record is not None
    return RunPlan(case, ledger, record, checkpoint, analysis, spectrum)


def _check_analysable(case: Case, where: str) -> None:
    """The analysis's lifter harmonic must lie below the Nyquist frequency of the record."""
    lifters = case.scene.drum.lifters
    sample_dt = case.settings.sample_dt
    lth = 0.0 if lifters is None else lifters.count * case.scene.rotation_hz
    if lth >= 0.5 / sample_dt:
        valid = f"< {0.5 / lth:.6g} s so that the LTH at {lth:.4g} Hz lies below the Nyquist " \
                "frequency, for the analysis"
        problem = _checks.fail("RunSettings.sample_dt", sample_dt, valid, "s")
        raise CaseFileError(f"{where} {problem}")


def run_case_file(args: argparse.Namespace) -> int | None:
    """``millscope run FILE``: run one case file and write its outputs; 0, or None when
    interrupted (Ctrl-C; nothing is written)."""
    plan = load_run(args.file)
    case, s = plan.case, plan.case.settings
    print(case.scene.describe())
    print(f"seed {s.seed}, dt {case_dt(case):.4g} s, {s.threads} thread(s); {s.duration_s:g} s "
          f"of rotation, {s.warm_up_s:g} s warm-up, {s.sampling} samples every "
          f"{s.sample_dt:g} s", flush=True)
    with warnings.catch_warnings(record=True) as caught:  # printed below, one line each
        warnings.simplefilter("always")
        # a bar's rounding past its total is not the user's concern
        warnings.filterwarnings("ignore", category=TqdmWarning)
        try:
            sim, full = simulate_case(case, track_energy=plan.energy_ledger,
                                      progress=not args.no_progress)
        except KeyboardInterrupt:
            sim = None
    for w in caught:
        print(f"millscope: warning: {w.message}", file=sys.stderr)
    if sim is None or full.meta.get("interrupted"):
        print("millscope: interrupted; nothing written", file=sys.stderr)
        return None
    meta = dict(full.meta)
    meta["settle"] = None if sim.settle_report is None else \
        dataclasses.asdict(sim.settle_report)
    meta["warm_up_s"] = s.warm_up_s
    if plan.energy_ledger:
        meta["energies"] = sim.energies()
    n = s.warm_up_samples
    record = TorqueRecord(full.time_s[n:], full.torque_Nm[n:], meta)
    written = [_save(plan.record, record.save)]
    if plan.checkpoint is not None:
        written.append(_save(plan.checkpoint, sim.save))
    result = _analysis(case, record) if plan.analysis or plan.spectrum else None
    if plan.analysis:
        print(_summary(result, record))
    if plan.spectrum is not None:
        written.append(_spectrum(case, record, result, plan.spectrum))
    if plan.energy_ledger:
        for name, value in meta["energies"].items():
            print(f"{name:<22} {value:.6g} J")
    for path in written:
        print(f"wrote {path}")
    return 0


def case_dt(case: Case) -> float:
    """The time step the case runs at, s (its own, or the scene's default)."""
    return case.settings.dt or time_step_limit(case.scene).default_dt()


def _analysis(case: Case, record: TorqueRecord) -> BlockAnalysis | None:
    """The whole record's analysis (:func:`~millscope.analysis.analyze_block`); None
    without lifters."""
    lifters = case.scene.drum.lifters
    if lifters is None:
        return None
    return analyze_block(record, lifters=lifters.count, rotation_hz=case.scene.rotation_hz)


def _summary(result: BlockAnalysis | None, record: TorqueRecord) -> str:
    if result is not None:
        return result.summary()
    e = spectral_energy(record, ["mean"])
    return (f"mean torque            {record.mean_torque_Nm:.6g} N m\n"
            f"spectral energy        {e.energy:.6g} (N m)^2 s (mean removed; no lifters)")


def _spectrum(case: Case, record: TorqueRecord, result: BlockAnalysis | None,
              path: Path) -> Path:
    """The spectrum figure with the located LTH marked (grey when it does not stand out of
    the noise), as ``millscope analyze`` draws it."""
    from ..report import plots
    from ..signal.spectral import spectrum

    spec = spectrum(record)
    title = f"{case.scene.name or 'scene'}: torque spectrum"
    try:
        fig = plots.plot_spectrum(
            spec, title=title, lth_hz=None if result is None else result.lth.frequency_hz,
            lth_distinct=result is None or result.lth.distinct)
    except ValueError:  # a record so short that the LTH falls in the mean's bins
        print("millscope: warning: the LTH is not marked: the record is too short to show it "
              "apart from the mean", file=sys.stderr)
        fig = plots.plot_spectrum(spec, title=title)
    return plots.save_figure(fig, path)


# -- millscope campaign ------------------------------------------------------------------------


@dataclass(frozen=True)
class CampaignPlan:
    """A campaign file, read and checked: the Campaign and how to run it."""

    campaign: Campaign
    max_workers: Any  # as read; Campaign.run checks it
    retry_failed: bool
    reuse: tuple[str, ...]  # other stores whose finished cases are copied in (Campaign.adopt)
    executor_table: str  # "<file>: [executor]", for the messages of Campaign.run's checks


_CAMPAIGN_KEYS = ("store", "block", "seeds", "bandwidth", "window", "retry_failed", "reuse")


def load_campaign(path: str | os.PathLike[str]) -> CampaignPlan:
    """Read and check a campaign file (see the module docstring); CaseFileError for any
    fault, before anything runs."""
    data = _read(path, "campaign", ("campaign", "matrix", "scenes", "settings", "executor"),
                 ("campaign",))
    top = _table(data, "campaign", str(path), _CAMPAIGN_KEYS, ("store",))
    where = f"{path}: [campaign]"
    if "matrix" not in data and "scenes" not in data:
        raise CaseFileError(f"{path}: no scenes; give a [matrix] table (the arguments of "
                            "paper_cases) or [[scenes]] tables, or both")
    scenes: list[Scene] = []
    if "matrix" in data:
        arguments = tuple(inspect.signature(paper_cases).parameters)
        matrix = _table(data, "matrix", str(path), arguments)
        with _api(f"{path}: [matrix]"):
            scenes += paper_cases(**matrix)
    listed = data.get("scenes", [])
    if not isinstance(listed, list):
        raise CaseFileError(f"{path}: scenes = {_checks.show(listed)} is not valid; it must "
                            f"be an array of tables [[scenes]], not {_kind(listed)}")
    scenes += [_scene(t, f"{path}: [[scenes]] #{k + 1}") for k, t in enumerate(listed)]

    table = _table(data, "settings", str(path), _SETTINGS)
    modes = _sampling_modes(table.get("sampling", "instant"), f"{path}: [settings]")
    settings, fraction = _settings({**table, "sampling": modes[0]}, f"{path}: [settings]")
    with _api(where):
        cases = [case for scene in scenes
                 for case in case_matrix([scene], seeds=top.get("seeds"), settings=settings)]
    cases = [_case(c.scene, c.settings.replace(sampling=mode), fraction, f"{path}: [settings]")
             for c in cases for mode in modes]
    options = {k: top[k] for k in ("block", "bandwidth", "window") if k in top}
    store = top["store"]
    with _api(where):
        _checks.text("store", store)
        retry = _checks.flag("retry_failed", top.get("retry_failed", True))
        reuse = _store_list(top.get("reuse", []), where)
        campaign = Campaign(cases, store, **options)

    executor = _table(data, "executor", str(path), ("kind", "max_workers"))
    with _api(f"{path}: [executor]"):
        _checks.choice("kind", executor.get("kind", "local"), _EXECUTORS)
    return CampaignPlan(campaign, executor.get("max_workers"), retry, reuse,
                        f"{path}: [executor]")


def _store_list(value: object, where: str) -> tuple[str, ...]:
    """``reuse``: a list of existing store directories."""
    if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
        raise CaseFileError(f"{where} reuse = {_checks.show(value)} is not valid; it must be "
                            "a list of campaign store directories, e.g. "
                            "[\"data/study-paper-ldms/store\"]")
    for v in value:
        if not Path(v).is_dir():
            raise CaseFileError(f"{where} reuse = {_checks.show(value)} is not valid; it must "
                                f"list existing campaign store directories ({v!r} is not one; "
                                "relative paths are relative to the working directory)")
    return tuple(value)


def run_campaign(plan: CampaignPlan, *, progress: bool = True) -> int:
    """``millscope campaign FILE``: run (or resume) a checked campaign file and print one line
    per case; 0 when every case is done.

    Raises
    ------
    RuntimeError
        naming the failed cases (they are kept in the store and a rerun retries them), or
        when another campaign holds the store.
    KeyboardInterrupt
        on Ctrl-C, as :meth:`Campaign.run`.
    """
    camp = plan.campaign
    if plan.reuse:
        adopted = camp.adopt(plan.reuse)
        print(f"millscope campaign: {len(adopted)} finished case(s) copied from "
              f"{', '.join(plan.reuse)}", flush=True)
    before = sum(1 for r in camp.results() if r.ok)
    print(f"millscope campaign: {len(camp)} cases, {before} already done in {camp.store}",
          flush=True)
    # Campaign.run checks max_workers (and the threads against the cores) before any work,
    # raising ValueError: reported with the [executor] table
    with _api(plan.executor_table):
        results = camp.run(max_workers=plan.max_workers,
                           progress=progress, retry_failed=plan.retry_failed)
    print(_table_of(results))
    failed = [r for r in results if not r.ok]
    if failed:  # as millscope demo reports them: one error line, exit code 2
        raise RuntimeError(f"{len(failed)} of {len(results)} cases failed, first "
                           f"{failed[0].case.name}: {failed[0].error}; see "
                           f"{camp.store / 'manifest.json'}; a rerun retries them")
    return 0


def _table_of(results: list[CaseResult]) -> str:
    lines = [f"{'case':<20} {'seed':>4} {'sampling':<8} {'status':<7} {'mean_Nm':>10} "
             f"{'lth_amp_Nm':>10} {'energy':>11} {'wall_s':>7}"]
    for r in results:
        def num(x: float, fmt: str) -> str:
            return format(x, fmt) if math.isfinite(x) else "-"
        lines.append(f"{r.scene.name or 'scene':<20} {r.case.settings.seed:>4} "
                     f"{r.case.settings.sampling:<8} {r.status:<7} "
                     f"{num(r.mean_torque, '10.4g'):>10} {num(r.lth_amplitude, '10.4g'):>10} "
                     f"{num(r.energy, '11.4g'):>11} {num(r.wall_time_s, '7.1f'):>7}")
    return "\n".join(lines)

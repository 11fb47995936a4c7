"""Command line: ``python -m millscope`` and the ``millscope`` script.

Subcommands: ``info`` (build facts), ``analyze`` (one torque file), ``monitor`` (a filling
estimate per window of a long record), ``report`` (a campaign store's report), ``demo`` (the
main job: a small DEM campaign and its report), ``bench`` (engine throughput,
:mod:`millscope.bench`), ``advise`` (contact times against dt and the torque sampling,
:mod:`millscope.stiffness`), ``study accuracy`` (error against run time of the engine's
settings, :mod:`millscope.studies`). The commands that print results (analyze, monitor,
report, demo, study accuracy) print them as CSV or JSON with ``--format csv|json``.
Bad input ends with one line ``millscope: error: ...`` on stderr and exit code 2.
"""

from __future__ import annotations

import argparse
import contextlib
import math
import os
import sys
import warnings
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypeVar

from .. import __version__
from .._frames import FORMATS

if TYPE_CHECKING:
    from pandas import DataFrame

EXIT_BAD_INPUT = 2
T = TypeVar("T")
EXIT_INTERRUPTED = 130  # Ctrl-C, as a shell reports it


class CliError(Exception):
    """An error to report in one line with exit code 2."""


def _positive_float(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not value > 0:
        raise argparse.ArgumentTypeError(f"{text!r} is not valid; it must be > 0")
    return value


def _positive_int(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not an integer") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"{text!r} is not valid; it must be >= 1")
    return value


def _add_format_argument(p: argparse.ArgumentParser, what: str) -> None:
    """``--format``: the command's own text, or ``what`` as CSV or JSON on stdout."""
    p.add_argument("--format", default="text", choices=FORMATS,
                   help=f"text (default), or {what} as a table: csv (a header line) or json (a "
                        "list of records), on stdout; other messages then go to stderr")


def _note(args: argparse.Namespace, text: str) -> None:
    """A message line: on stdout with the text format, on stderr when stdout holds a table."""
    print(text, file=sys.stdout if args.format == "text" else sys.stderr)


def _print_table(table: DataFrame, fmt: str) -> None:
    """``table`` on stdout as CSV or JSON (:func:`millscope._frames.frame_text`)."""
    from .._frames import frame_text

    sys.stdout.write(frame_text(table, fmt))


#: How ``info`` names the SIMD paths of the engine's kernels (``_core.simd_paths``).
_SIMD_LABELS = {"avx512": "AVX-512", "avx2": "AVX2", "neon": "NEON", "sve": "SVE", "sve2": "SVE2"}


def pair_search_line(path: str, pair_lanes: int, asked: bool) -> str:
    """What ``info`` says of the pair search of SIMD path ``path`` (``_core.simd_path``), which
    tests ``pair_lanes`` listed pairs at a time; ``asked``: chosen by MILLSCOPE_SIMD."""
    if pair_lanes > 1:
        return f"{_SIMD_LABELS.get(path, path.upper())}, {pair_lanes} listed pairs at a time"
    why = "MILLSCOPE_SIMD=portable" if asked else "no AVX2, AVX-512, NEON or SVE here"
    return f"portable, one listed pair at a time ({why})"


def cmd_info(_: argparse.Namespace) -> int:
    """Print version and build facts."""
    from .._core import build_info, simd_path

    info = build_info()
    print(f"millscope {__version__}")
    print(f"python            {sys.version.split()[0]}")
    print(f"compiler          {info['compiler']} (C++ {info['cxx_standard']})")
    print(f"build type        {info['build_type']}")
    print(f"flags             {info['flags'].strip()}")
    print(f"OpenMP            {info['openmp_version']}, {info['openmp_max_threads']} threads")
    print(f"FFTW              {info['fftw_version']}")
    print(f"Eigen             {info['eigen_version']}")
    print(f"SIMD paths        {', '.join(info['simd_paths'])} (MILLSCOPE_SIMD picks one)")
    path, pair_lanes = simd_path()  # a MILLSCOPE_SIMD this CPU cannot run: ValueError
    print(f"pair search       "
          f"{pair_search_line(path, pair_lanes, os.environ.get('MILLSCOPE_SIMD', '') != '')}")
    return 0


def cmd_analyze(args: argparse.Namespace) -> int:
    """Analyse one torque file: mean, LTH, spectral energy; write plots."""
    from ..report import plots
    from ..signal.analysis import analyze_block
    from ..signal.drivetrain import DriveTrain, decimate_record
    from ..signal.record import TorqueRecord
    from ..signal.spectral import RemoveItem, band_stop, spectrum

    raw = TorqueRecord.load(args.file, **torque_file_options(args))
    lines: list[float] = []
    if args.drive is not None:
        drive = DriveTrain.load(args.drive)
        lines = drive.frequencies_hz(max_hz=args.band_hz, include_lth=False)
    # only the band itself is counted, from a record decimated to 2.5x the band when faster
    record = decimate_record(raw, args.band_hz)
    if record is not raw:
        _note(args, f"decimated from {raw.sample_rate_hz:g} Hz to {record.sample_rate_hz:g} Hz "
                    "(anti-aliased)")
    start, end = float(record.time_s[0]), float(record.time_s[-1] + record.dt)
    for option, value in (("--from", args.t_from), ("--to", args.t_to)):
        # a block past the record's ends would silently be cut to them
        slack = 1e-6 * record.dt
        if value is not None and not start - slack <= value <= end + slack:
            raise CliError(f"{option} {value:g} s is not valid; it must lie within the record, "
                           f"which spans {start:g} .. {end:g} s")
    t1 = start if args.t_from is None else args.t_from
    t2 = end if args.t_to is None else args.t_to
    block = record.block(t1, t2)
    result = analyze_block(block, lifters=args.lifters, rotation_hz=args.rotation_hz,
                           lines_hz=lines, window=args.window, bandwidth=args.bandwidth,
                           search_hz=args.search_hz, resolution_hz=args.resolution,
                           band_hz=(0.0, min(args.band_hz, block.sample_rate_hz / 2)))
    if args.format == "text":
        print(f"file                   {args.file}")
        print(f"block                  {t1:g} .. {t2:g} s, {len(block)} samples at "
              f"{block.sample_rate_hz:g} Hz")
        print(result.summary())
    else:
        table = result.to_frame()
        for k, (name, value) in enumerate((("file", str(args.file)), ("block_start_s", t1),
                                           ("block_end_s", t2), ("samples", len(block)),
                                           ("sample_rate_hz", block.sample_rate_hz))):
            table.insert(k, name, [value])
        _print_table(table, args.format)

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    stem = Path(args.file).stem
    spec = spectrum(block, window=args.window)
    fig = plots.plot_spectrum(spec, lth_hz=result.lth.frequency_hz,
                              lth_distinct=result.lth.distinct, lines_hz=list(lines),
                              title=f"{stem}: torque spectrum")
    written = [plots.save_figure(fig, out / f"{stem}_spectrum.png")]
    remove: list[RemoveItem] = ["mean", result.lth.frequency_hz, *result.lines_hz]
    filtered = band_stop(block, remove, bandwidth=args.bandwidth, window="rectangular")
    fig = plots.plot_filtered(block, filtered)
    written.append(plots.save_figure(fig, out / f"{stem}_filtered.png"))
    for path in written:
        _note(args, f"wrote                  {path}")
    return 0


def _confidence(text: str) -> float:
    value = _positive_float(text)
    if not value < 1:
        raise argparse.ArgumentTypeError(f"{text!r} is not valid; it must be in (0, 1)")
    return value


def cmd_monitor(args: argparse.Namespace) -> int:
    """A filling estimate per window of a long torque record."""
    from ..calibration.fit import Calibration
    from ..calibration.monitoring import monitor_record
    from ..signal.drivetrain import DriveTrain
    from ..signal.record import TorqueRecord

    calibration = Calibration.load(args.calibration)
    drive = None if args.drive is None else DriveTrain.load(args.drive)
    record = TorqueRecord.load(args.file, **torque_file_options(args))
    with warnings.catch_warnings(record=True) as caught:  # printed with the header below
        warnings.simplefilter("always")
        result = monitor_record(record, calibration, step_s=args.step, drive=drive,
                                confidence=args.confidence, band_hz=args.band_hz)
    if args.format != "text":
        for caught_warning in caught:
            print(f"millscope: warning: {caught_warning.message}", file=sys.stderr)
        _print_table(result.to_frame(), args.format)
        return 0
    fit = calibration.fit
    label = f"{calibration.label} " if calibration.label else ""
    decimated = ("" if result.decimated_from_hz is None else
                 f", decimated from {result.decimated_from_hz:g} Hz to "
                 f"{result.sample_rate_hz:g} Hz")
    lines = ", ".join(f"{f:.3f}" for f in result.lines_hz) + " Hz" if result.lines_hz else "none"
    print(f"# calibration {args.calibration}: {label}{fit.equation()}, R^2 = {fit.r2:.4f}, "
          f"levels {fit.x_min:g}..{fit.x_max:g}")
    print(f"# record {args.file}: {record.duration_s:g} s at {record.sample_rate_hz:g} Hz"
          f"{decimated}")
    print(f"# windows of {result.window_s:g} s every {result.step_s:g} s: "
          f"{len(result.windows)}; removed: mean, LTH near "
          f"{calibration.lifters * calibration.rotation_hz:.3f} Hz, drive lines: {lines}")
    for caught_warning in caught:
        print(f"# warning: {caught_warning.message}")
    percent = f"{100 * args.confidence:g}"
    print(f"{'start_s':>9} {'end_s':>9} {'level':>8} {'low_' + percent:>8} "
          f"{'high_' + percent:>8}  flag")
    for w in result.windows:
        flag = "outside" if w.outside else "ok"
        low, high = (f"{v:8.3f}" if math.isfinite(v) else f"{'-':>8}" for v in w.interval)
        print(f"{w.start_s:9.2f} {w.end_s:9.2f} {w.level:8.3f} {low} {high}  {flag}")
    return 0


def cmd_report(args: argparse.Namespace) -> int:
    """The report of a campaign store, or of a study's folder (its plan, ``study.json``, and
    its store): exit code 2 with one error line naming the case files it could not read,
    after writing the report of the others."""
    from ..campaign.runs import read_store
    from ..campaign.studies import PLAN_FILE, read_study
    from ..report.reports import UnreadableCasesError, write_report, write_study

    folder = Path(args.store)
    if folder.name == "store" and (folder.parent / PLAN_FILE).is_file():
        folder = folder.parent  # a study's store: report the study
    if (folder / PLAN_FILE).is_file():
        if args.block is not None:
            raise CliError("--block is not valid for a study: each setting's block is in "
                           f"its plan ({folder / PLAN_FILE})")
        try:
            result = read_study(folder)
        except ValueError as exc:
            raise CliError(str(exc)) from None
        assert result.plan is not None  # read from a plan file
        quantity = "energy_ratio" if len(result.plan.load_levels) > 1 else "energy"
        written = write_study(result, args.out or folder, quantity=quantity, cost=args.cost)
        _print_study(args, result, quantity)
        for path in written:
            _note(args, f"wrote {path}")
        return 0
    block = None if args.block is None else tuple(args.block)
    unreadable = None
    try:
        path = write_report(args.store, args.out, progress=not args.no_progress, block=block,
                            bootstrap=args.bootstrap)
    except UnreadableCasesError as exc:
        path, unreadable = exc.report, exc
    _note(args, f"wrote {path}")
    if args.format != "text":  # the store's cases, those it cannot read included
        _print_table(read_store(args.store, block=block), args.format)
    if unreadable is not None:
        raise unreadable
    return 0


def _resumable(run: Callable[[], T], store: Path, what: str) -> T | None:
    """``run()`` of a campaign-backed command: a failed case becomes one error line (the
    finished ones are kept), Ctrl-C a note on where the finished ``what`` are, and None."""
    try:
        return run()
    except RuntimeError as exc:
        raise CliError(str(exc)) from None
    except KeyboardInterrupt:
        print(f"millscope: interrupted; the finished {what} are kept in {store} and a rerun "
              "goes on from there", file=sys.stderr)
        return None


def cmd_demo(args: argparse.Namespace) -> int:
    """The main job: a small DEM campaign and its report (or the synthetic analysis)."""
    from .demo import DemoPlan, run_demo, run_synthetic_demo

    if args.synthetic:
        if args.format != "text":
            raise CliError(f"--format {args.format} is not valid with --synthetic, which runs "
                           "no campaign; it must be text")
        run_synthetic_demo(Path(args.out), progress=not args.no_progress)
        return 0
    given = {"scale": args.scale, "particles": args.particles, "speed_fraction": args.speed,
             "load_levels": None if args.levels is None else tuple(args.levels),
             "duration_s": args.duration, "warm_up_s": args.warm_up, "seed": args.seed,
             "threads": args.threads}
    plan = DemoPlan(**{k: v for k, v in given.items() if v is not None})  # else its defaults
    # with a table on stdout, the demo's own messages go to stderr
    with contextlib.redirect_stdout(sys.stdout if args.format == "text" else sys.stderr):
        result = _resumable(lambda: run_demo(Path(args.out), plan,
                                             progress=not args.no_progress,
                                             max_workers=args.workers),
                            Path(args.out) / "store", "cases")
    if result is None:
        return EXIT_INTERRUPTED
    if args.format == "text":
        top = max(r.energy for r in result.results)
        for r in result.results:
            print(f"  {r.scene.name:<8} mean torque {r.mean_torque:8.2f} N m   "
                  f"E = {r.energy:10.4g} (N m)^2 s   E p.u. = {r.energy / top:.3f}")
    else:
        from ..campaign.tables import CaseResults

        _print_table(CaseResults(result.results).to_frame(), args.format)
    _note(args, f"campaign {result.wall_time_s:.0f} s; report {result.report}")
    return 0


_STUDY_LADDERS = (("dt_fraction", "vary_dt_fraction"), ("shear_modulus_factor", "vary_shear"),
                  ("record_s", "vary_record"), ("warm_up_s", "vary_warm_up"),
                  ("sampling", "vary_sampling"), ("scale", "vary_scale"))


#: The knobs of ``study accuracy --also``, as the reference's options name them.
_ALSO_KNOBS = {"dt-fraction": ("dt_fraction", float), "shear": ("shear_modulus_factor", float),
               "record": ("record_s", float), "warm-up": ("warm_up_s", float),
               "sampling": ("sampling", str), "scale": ("scale", str)}


def _setting_changes(text: str) -> dict[str, Any]:
    """``"scale=tiny,shear=0.001"`` as Setting fields, for ``--also``."""
    out: dict[str, Any] = {}
    for item in text.split(","):
        knob, sep, value = item.partition("=")
        knob = knob.strip()
        if not sep or knob not in _ALSO_KNOBS or _ALSO_KNOBS[knob][0] in out:
            raise argparse.ArgumentTypeError(
                f"{text!r} is not valid; it must be KNOB=VALUE pairs joined by commas, each "
                f"knob once, of {', '.join(_ALSO_KNOBS)}")
        name, kind = _ALSO_KNOBS[knob]
        try:
            out[name] = kind(value.strip())
        except ValueError:
            raise argparse.ArgumentTypeError(f"{knob} = {value!r} is not valid; it must be a "
                                             "number") from None
    return out


def _print_study(args: argparse.Namespace, result: Any, quantity: str) -> None:
    """A study's table on stdout: Markdown, or the frame as CSV or JSON (--format)."""
    if args.format == "text":
        print(result.to_markdown(quantity, args.cost))
    else:
        _print_table(result.to_frame(), args.format)


def cmd_study_accuracy(args: argparse.Namespace) -> int:
    """Error against run time: a reference setting and one-knob ladders around it."""
    from ..campaign.studies import Setting, StudyPlan, run_study, save_study_plan
    from ..report.reports import write_study

    reference = Setting(dt_fraction=args.dt_fraction, shear_modulus_factor=args.shear,
                        record_s=args.record, warm_up_s=args.warm_up, sampling=args.sampling,
                        scale=args.scale)
    ladders = {knob: getattr(args, option) for knob, option in _STUDY_LADDERS
               if getattr(args, option)}
    if not ladders:
        raise CliError("give at least one ladder: --vary-dt-fraction, --vary-shear, "
                       "--vary-record, --vary-warm-up, --vary-sampling or --vary-scale")
    extra = [reference.replace(**changes) for changes in args.also or []]
    if args.quantity in ("slope_a", "energy_ratio") and len(set(args.levels)) < 2:
        raise CliError(f"--quantity {args.quantity} needs 2 or more --levels (and --particles)")
    plan = StudyPlan.around(reference, ladders, seeds=tuple(range(args.seeds)),
                            speed_fraction=args.speed,
                            particles=None if args.particles == "none" else args.particles,
                            load_levels=tuple(args.levels), threads=args.threads,
                            extra=extra, combine=args.combine)
    out = Path(args.out)
    if out.exists() and not out.is_dir():
        raise CliError(f"--out {str(out)!r} is not valid; it must be a folder")
    save_study_plan(plan, out)  # so that `millscope report OUT` remakes the tables from the store
    runs = len(plan.cases())
    _note(args, f"millscope study accuracy: {len(plan.settings)} settings x "
                f"{len(plan.load_levels)} level(s) x {len(plan.seeds)} seeds = {runs} runs, "
                f"{args.workers} at a time on {plan.threads} engine thread(s); store "
                f"{out / 'store'}")
    sys.stdout.flush()
    result = _resumable(lambda: run_study(plan, out / "store", max_workers=args.workers,
                                          progress=not args.no_progress,
                                          cheapest_first=args.cheapest_first),
                        out / "store", "runs")
    if result is None:
        return EXIT_INTERRUPTED
    written = write_study(result, out, quantity=args.quantity, cost=args.cost)
    _print_study(args, result, args.quantity)
    for path in written:
        _note(args, f"wrote {path}")
    return 0


def cmd_run(args: argparse.Namespace) -> int:
    """One case described in a TOML file (millscope.app.case_files)."""
    from .case_files import run_case_file

    code = run_case_file(args)
    return EXIT_INTERRUPTED if code is None else code


def cmd_campaign(args: argparse.Namespace) -> int:
    """A campaign described in a TOML file (millscope.app.case_files)."""
    from .case_files import load_campaign, run_campaign

    plan = load_campaign(args.file)
    if args.cost:
        from ..campaign.costs import campaign_cost

        print(campaign_cost(plan.campaign, plan.reuse, retry_failed=plan.retry_failed))
        return 0
    code = _resumable(lambda: run_campaign(plan, progress=not args.no_progress),
                      plan.campaign.store, "cases")
    return EXIT_INTERRUPTED if code is None else code


def cmd_bench(args: argparse.Namespace) -> int:
    """Engine throughput on the pilot mill (millscope.bench)."""
    from .bench import run_from_args

    return run_from_args(args)


def cmd_advise(args: argparse.Namespace) -> int:
    """Stiffness advice for a preset case or a scene file (millscope.stiffness)."""
    from ..model.presets import pilot_mill
    from ..model.scene import Scene
    from ..model.stiffness import StiffnessWarning, advise_stiffness

    if args.scene is not None:
        scene = Scene.load(args.scene)
    else:
        particles = None if args.particles == "none" else args.particles
        scene = pilot_mill(args.speed, particles, args.level, args.scale)
    with warnings.catch_warnings():  # the verdict line of the report says it
        warnings.simplefilter("ignore", StiffnessWarning)
        advice = advise_stiffness(scene, dt=args.dt, sample_dt=args.sample_dt,
                                  analysis_band_hz=args.band_hz, impact_speed=args.impact_speed)
    print(advice.to_markdown() if args.markdown else advice)
    return 0


def add_torque_file_arguments(p: argparse.ArgumentParser) -> None:
    """The torque file argument and the options of :meth:`millscope.TorqueRecord.from_csv`."""
    p.add_argument("file", help="torque record: a CSV or text export (columns, units, separator "
                   "and decimal mark sniffed, or given by the options below) or a .npz record")
    g = p.add_argument_group("torque text file", "how to read a CSV or text torque file "
                             "(plant exports); what is not given is sniffed from the file")
    g.add_argument("--time-column", type=_column, help="time column: header name or index from 0")
    g.add_argument("--torque-column", type=_column,
                   help="torque column: header name or index from 0")
    g.add_argument("--time-unit", help="unit of the time column: s, ms, min, h, or iso (ISO "
                                       "8601 date-times)")
    g.add_argument("--torque-unit", help="unit of the torque column: 'N m', 'kN m' or 'MN m'")
    g.add_argument("--sep", type=_separator, help="field separator, one character ('\\t': tab)")
    g.add_argument("--decimal", help="decimal mark, '.' or ','")
    g.add_argument("--skip-rows", type=int, help="lines at the top skipped before the header")
    g.add_argument("--encoding", help="text encoding, e.g. utf-8 or latin-1")
    g.add_argument("--resample", action="store_true",
                   help="interpolate jittered time stamps onto uniform times (within --jitter-tol)")
    g.add_argument("--jitter-tol", type=float,
                   help="largest time-step deviation --resample accepts, relative to the mean "
                        "step, in (0, 0.5) (default 0.01)")


def _column(text: str) -> str | int:
    return int(text) if text.isascii() and text.isdigit() else text


def _separator(text: str) -> str:
    return "\t" if text in ("\\t", "tab") else text


def torque_file_options(args: argparse.Namespace) -> dict[str, object]:
    """The from_csv keyword options given on the command line."""
    given = {"time_column": args.time_column, "torque_column": args.torque_column,
             "time_unit": args.time_unit, "torque_unit": args.torque_unit, "sep": args.sep,
             "decimal": args.decimal, "skiprows": args.skip_rows, "encoding": args.encoding,
             "resample": args.resample or None, "jitter_rtol": args.jitter_tol}
    return {k: v for k, v in given.items() if v is not None}


def _add_cost_argument(p: argparse.ArgumentParser) -> None:
    p.add_argument("--cost", default="wall_s", choices=["wall_s", "particle_steps"],
                   help="a study's cost axis: wall-clock s per run, or particle-steps per run "
                        "(the same on any machine and load; default wall_s)")


def build_parser() -> argparse.ArgumentParser:
    from .bench import thread_count

    parser = argparse.ArgumentParser(
        prog="millscope",
        description="Ball-mill DEM and filling-level estimation from drive torque spectra.")
    parser.add_argument("--version", action="version", version=f"millscope {__version__}")
    sub = parser.add_subparsers(dest="command", required=True)

    p = sub.add_parser("info", help="version and build facts (compiler, OpenMP, FFTW)")
    p.set_defaults(func=cmd_info)

    p = sub.add_parser("analyze", help="analyse a torque record (CSV or npz)",
                       description="Mean torque, lifter torque harmonic and spectral energy of a "
                                   "torque record; writes spectrum and filtered-signal plots.")
    p.add_argument("--lifters", type=_positive_int, required=True, help="number of lifters")
    p.add_argument("--rotation-hz", type=_positive_float, required=True,
                   help="mill rotation frequency, Hz")
    p.add_argument("--from", dest="t_from", type=float,
                   help="block start, s (default: record start)")
    p.add_argument("--to", dest="t_to", type=float, help="block end, s (default: record end)")
    p.add_argument("--drive", help="drive.json describing motor and gears: their lines are removed")
    p.add_argument("--window", default="hann", choices=["hann", "hann_periodic", "rectangular"])
    p.add_argument("--bandwidth", type=_positive_float, default=0.3,
                   help="full width of each removed band, Hz (default 0.3)")
    p.add_argument("--search-hz", type=_positive_float, default=None,
                   help="half-width of the LTH search, Hz (default 3 bins)")
    p.add_argument("--resolution", type=_positive_float, default=None,
                   help="required resolution, Hz: refuse shorter blocks (eq. 9)")
    p.add_argument("--band-hz", type=_positive_float, default=50.0,
                   help="analysis band 0..BAND_HZ, Hz (default 50, the paper's); records sampled "
                        "faster than 2.5 x BAND_HZ are decimated to that rate first")
    p.add_argument("--out", default="out", help="folder for the plots (default out)")
    _add_format_argument(p, "the figures (one row)")
    add_torque_file_arguments(p)
    p.set_defaults(func=cmd_analyze)

    p = sub.add_parser("monitor", help="filling estimate per window of a long torque record",
                       description="Slides windows of the calibration's block length over a "
                                   "torque record and prints one line per window: start and "
                                   "end (s), estimated load level, its interval, and 'outside' "
                                   "when the level lies outside the calibrated range.")
    p.add_argument("--calibration", required=True,
                   help="calibration JSON (Calibration.save, or report's calibration_*.json)")
    p.add_argument("--drive", help="drive.json describing motor and gears: their lines are removed")
    p.add_argument("--step", type=_positive_float, default=None,
                   help="step between windows, s (default: the window length)")
    p.add_argument("--confidence", type=_confidence, default=0.95,
                   help="confidence of the intervals, in (0, 1) (default 0.95)")
    p.add_argument("--band-hz", type=_positive_float, default=None,
                   help="analysis band 0..BAND_HZ, Hz, for a calibration that does not give "
                        "one (format 1): the Nyquist frequency of its records (50 for 10 ms "
                        "samples); default: the calibration's")
    _add_format_argument(p, "the windows (one row each)")
    add_torque_file_arguments(p)
    p.set_defaults(func=cmd_monitor)

    p = sub.add_parser("report", help="report of a campaign store or a study (Markdown + figures)",
                       description="Analyses a campaign store (paper section 6) and writes "
                                   "report.md with the Table 6 analogue, per-group and per-case "
                                   "tables, Figs. 9-15 as PNG and a calibration per group. "
                                   "Case files it cannot read are listed in the report, and "
                                   "it then exits with code 2 naming them. Given a study's "
                                   "folder (the --out of 'study accuracy', holding study.json "
                                   "and store/), it writes the study's accuracy.csv, .md and "
                                   ".png from the finished runs instead, simulating nothing.")
    p.add_argument("store", help="campaign store directory, or a study's folder")
    p.add_argument("--out", default=None,
                   help="output folder (default STORE/report; a study's own folder)")
    p.add_argument("--block", type=float, nargs=2, metavar=("T1", "T2"), default=None,
                   help="block to analyse, s (default: as the campaign analysed it)")
    p.add_argument("--bootstrap", type=_positive_int, default=1000,
                   help="bootstrap replicates (default 1000)")
    _add_cost_argument(p)
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    _add_format_argument(p, "the store's cases (one row each, failed and unreadable ones "
                            "included; the report is written as well)")
    p.set_defaults(func=cmd_report)

    p = sub.add_parser("demo", help="the main job: a small DEM campaign and its report in --out",
                       description="Runs one material at one speed at several load levels "
                                   "through a Campaign into OUT/store (a rerun reuses finished "
                                   "cases) and writes the campaign report into OUT (as 'report' "
                                   "does: report.md, Table 6, Figs. 9-15 with the waterfall and "
                                   "the log fit, a calibration) with a section on the energy's "
                                   "fall with filling and a leave-one-out check. The "
                                   "defaults take about 2 minutes on 2 free cores.")
    p.add_argument("--out", default="out", help="output folder (default out)")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.add_argument("--synthetic", action="store_true",
                   help="analyse synthetic records of known content instead (seconds, no DEM)")
    p.add_argument("--scale", help="scale of millscope.presets.SCALES "
                   "(default tiny: see README, 'Simulating a mill')")
    p.add_argument("--particles", help="ceramic (LD) or steel (HD); "
                   "default ceramic")
    p.add_argument("--speed", type=_positive_float,
                   help="fraction of critical speed (default 0.71)")
    p.add_argument("--levels", type=_positive_int, nargs="+",
                   help="load levels of Table 5, at least 2 (default 1 2 3 4)")
    p.add_argument("--duration", type=_positive_float,
                   help="simulated rotation per case, s (default 8; the paper's 14)")
    p.add_argument("--warm-up", type=float,
                   help="first seconds not kept; the block is WARM_UP..DURATION (default 2; "
                        "the paper's 4)")
    p.add_argument("--seed", type=int, help="filling seed (default 0)")
    p.add_argument("--threads", type=thread_count,
                   help="engine threads per case, at most the cores this process may use "
                        "(default 1)")
    p.add_argument("--workers", type=_positive_int, default=None,
                   help="parallel cases (default: cores / threads)")
    _add_format_argument(p, "the cases (one row each)")
    p.set_defaults(func=cmd_demo)

    p = sub.add_parser("run", help="run one case described in a TOML file",
                       description="Reads a case file ([scene]: a preset such as pilot_mill "
                                   "or an explicit scene; [settings]: seed, duration, warm-up, "
                                   "sampling, time step, threads; [output]: the torque record "
                                   ".npz or .csv, a checkpoint, an analysis, a spectrum figure), "
                                   "checks all of it, then fills, settles and runs the mill "
                                   "and writes the outputs. See examples/*.toml.")
    p.add_argument("file", help="case file (TOML)")
    p.add_argument("--no-progress", action="store_true", help="no progress bars")
    p.set_defaults(func=cmd_run)

    p = sub.add_parser("campaign", help="run or resume a campaign described in a TOML file",
                       description="Reads a campaign file ([campaign]: store, block, seeds; "
                                   "[matrix] and/or [[scenes]]; [settings]; [executor]), checks "
                                   "all of it, runs the cases not yet in the store (a rerun "
                                   "resumes) and prints one line per case; failed cases end "
                                   "with one error line and exit code 2. See examples/*.toml.")
    p.add_argument("file", help="campaign file (TOML)")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.add_argument("--cost", action="store_true",
                   help="run nothing: print what the store holds and what is left to run, "
                        "per group, in particle-steps and in core-hours at the pace of the "
                        "store's finished runs")
    p.set_defaults(func=cmd_campaign)

    p = sub.add_parser("advise", help="stiffness advice: contact times against dt and the "
                                      "torque sampling",
                       description="Reports the Rayleigh time, the Hertz contact time of every "
                                   "kind of contact at the expected impact speed, how many time "
                                   "steps and torque samples a contact spans, and whether the "
                                   "contact frequency 1/t_c reaches the analysis band (then the "
                                   "torque spectrum there depends on the stiffness).")
    p.add_argument("--scene", help="scene JSON (Scene.to_dict) instead of a preset case")
    p.add_argument("--scale", default="paper",
                   help="preset scale: paper, small, tiny or soft (default paper)")
    p.add_argument("--particles", default="none",
                   help="preset particles: ceramic, steel or none (default none: balls only)")
    p.add_argument("--speed", type=_positive_float, default=0.71,
                   help="preset speed, fraction of critical (default 0.71)")
    p.add_argument("--level", type=_positive_int, default=1,
                   help="preset load level 1..7 (default 1)")
    p.add_argument("--dt", type=_positive_float, default=None,
                   help="time step, s (default 0.2 x the smallest Rayleigh time)")
    p.add_argument("--sample-dt", type=_positive_float, default=0.01,
                   help="torque sampling interval, s (default 0.01)")
    p.add_argument("--band-hz", type=_positive_float, default=None,
                   help="analysis band 0..BAND_HZ, Hz (default the Nyquist frequency)")
    p.add_argument("--impact-speed", type=_positive_float, default=None,
                   help="impact speed, m/s (default: from the scene, see millscope.stiffness)")
    p.add_argument("--markdown", action="store_true", help="print Markdown")
    p.set_defaults(func=cmd_advise)

    p = sub.add_parser("study", help="studies of the engine's settings (study accuracy)")
    studies = p.add_subparsers(dest="study", required=True)
    p = studies.add_parser(
        "accuracy", help="error against run time of the speed-up knobs",
        description="Runs the pilot mill at a reference setting and at one-knob ladders around "
                    "it (time step, stiffness, record length, warm-up, sampling, scale), each "
                    "with several seeds, through a campaign store (a rerun reuses finished "
                    "runs); writes accuracy.csv, accuracy.md and accuracy.png (error against "
                    "wall time with the Pareto front) into --out and prints the table.")
    p.add_argument("--out", default="out/study-accuracy",
                   help="output folder; the runs go to OUT/store (default out/study-accuracy)")
    p.add_argument("--particles", default="none", choices=["none", "ceramic", "steel"],
                   help="particles to grind (default none: balls only)")
    p.add_argument("--speed", type=_positive_float, default=0.71,
                   help="fraction of critical speed (default 0.71)")
    p.add_argument("--levels", type=_positive_int, nargs="+", default=[1],
                   help="load levels of Table 5 (default 1; 2 or more add the log-fit slope a)")
    p.add_argument("--seeds", type=_positive_int, default=3,
                   help="filling seeds per setting, 0..SEEDS-1, at least 2 (default 3)")
    group = p.add_argument_group("the reference setting")
    group.add_argument("--dt-fraction", type=float, default=0.1,
                       help="time step / Rayleigh time, in (0, 0.5] (default 0.1)")
    group.add_argument("--shear", type=float, default=None,
                       help="shear moduli as a fraction of the paper's, in (0, 1] "
                            "(default: the scale's own)")
    group.add_argument("--record", type=float, default=4.0,
                       help="analysed block, s (default 4)")
    group.add_argument("--warm-up", type=float, default=2.0,
                       help="rotation before the block, s (default 2)")
    group.add_argument("--sampling", default="mean", choices=["instant", "mean"],
                       help="torque sampling (default mean, anti-aliased)")
    group.add_argument("--scale", default="tiny",
                       help="scale of millscope.presets.SCALES (default tiny)")
    group = p.add_argument_group("the ladders: other values of one knob each")
    group.add_argument("--vary-dt-fraction", type=float, nargs="+", metavar="F")
    group.add_argument("--vary-shear", type=float, nargs="+", metavar="G")
    group.add_argument("--vary-record", type=float, nargs="+", metavar="S")
    group.add_argument("--vary-warm-up", type=float, nargs="+", metavar="S")
    group.add_argument("--vary-sampling", nargs="+", choices=["instant", "mean"])
    group.add_argument("--vary-scale", nargs="+", metavar="SCALE")
    group.add_argument("--combine", action="store_true",
                       help="also run the cheapest value of every ladder together")
    group.add_argument("--also", type=_setting_changes, action="append", metavar="KNOB=V,...",
                       help="also run the reference with several knobs changed at once, e.g. "
                            "scale=tiny,shear=0.001 (knobs: " + ", ".join(_ALSO_KNOBS)
                            + "); may be repeated")
    p.add_argument("--quantity", default="energy",
                   choices=["mean_torque", "energy", "lth_amplitude", "slope_a",
                            "energy_ratio"],
                   help="the error plotted and whose Pareto front is marked (default energy)")
    _add_cost_argument(p)
    p.add_argument("--threads", type=thread_count, default=1,
                   help="engine threads per run, at most the cores this process may use "
                        "(default 1)")
    p.add_argument("--workers", type=_positive_int, default=1,
                   help="runs at a time (default 1, so that their wall times do not disturb "
                        "each other)")
    p.add_argument("--cheapest-first", action="store_true",
                   help="run the cheapest cases first (default: the most expensive first); "
                        "a study spread over several sittings then finishes its cheap settings "
                        "early, and a long case goes on from its in-case checkpoint")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    _add_format_argument(p, "the table (one row per setting and level, as accuracy.csv)")
    p.set_defaults(func=cmd_study_accuracy)

    from .bench import add_arguments as add_bench_arguments

    p = sub.add_parser("bench", help="engine throughput on the pilot mill (particle-steps/s)",
                       description="Times the DEM engine on the pilot mill from a cached "
                                   "tumbling state: particle-steps per second, ns per "
                                   "particle-step and bytes per particle per scene and thread "
                                   "count; the last line is particle_steps_per_s=<value>.")
    add_bench_arguments(p)
    p.set_defaults(func=cmd_bench)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        code = int(args.func(args))
        sys.stdout.flush()  # a closed pipe shows here, not in the interpreter's exit
        return code
    except BrokenPipeError:
        # the reader of stdout left (e.g. `millscope analyze ... | head`): stop quietly, as the
        # Python documentation says (signal module, "Note on SIGPIPE"); point stdout at devnull
        # so that the flush at exit does not fail again
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        return 1
    except (ValueError, OSError, CliError) as exc:
        message = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        print(f"millscope: error: {message}", file=sys.stderr)
        return EXIT_BAD_INPUT


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())

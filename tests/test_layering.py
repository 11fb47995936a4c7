"""The layering of the package, read from the sources: every import of every module (at module
level and inside functions alike) runs one way down the layers, and no modules import each
other in a circle.

The layers, lowest first: the private helpers and the extension (``_core``, ``_files``,
``_checks``, ``_samples``, ``_old_paths``); ``model`` and ``signal`` side by side, neither
importing the other; ``engine`` (model, signal) and ``calibration`` (signal); ``campaign``;
``report``; the package's ``__init__`` (the public API); ``app``; ``__main__``. The analysis
side (signal, calibration, the figures) thus never loads scenes, presets, the engine or the
campaign machinery for a fill estimate.

Imports under ``if TYPE_CHECKING:`` never run; they name types for annotations and are not
counted. An import inside a function is counted like any other: a late import does not
excuse an import that runs up a layer.
"""

from __future__ import annotations

import ast
import functools
from pathlib import Path

import pytest

import millscope

PACKAGE = Path(millscope.__file__).parent
NAME = "millscope"

#: layer -> the layers its modules may import (itself included)
ALLOWED: dict[str, set[str]] = {"util": {"util"}}
ALLOWED["model"] = {"util", "model"}
ALLOWED["signal"] = {"util", "signal"}
ALLOWED["engine"] = ALLOWED["model"] | ALLOWED["signal"] | {"engine"}
ALLOWED["calibration"] = ALLOWED["signal"] | {"calibration"}
ALLOWED["campaign"] = ALLOWED["engine"] | ALLOWED["calibration"] | {"campaign"}
ALLOWED["report"] = ALLOWED["campaign"] | {"report"}
ALLOWED["package"] = ALLOWED["report"] | {"package"}
ALLOWED["app"] = ALLOWED["package"] | {"app"}
ALLOWED["main"] = ALLOWED["app"] | {"main"}

SUBPACKAGES = ("model", "signal", "engine", "calibration", "campaign", "report", "app")
ANALYSIS_SIDE = ("signal.record", "signal.spectral", "signal.drivetrain", "signal.analysis",
                 "calibration.logfit", "calibration.bootstrap", "calibration.groups",
                 "calibration.fit", "calibration.monitoring", "report.plots")
SIMULATION_SIDE = ("model", "engine", "campaign")


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(PACKAGE.parent).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


@functools.cache
def _all_modules() -> dict[str, Path]:
    """Every module of the sources; the extension by its stub, which imports no module."""
    return {_module_name(p): p for p in sorted([*PACKAGE.rglob("*.py"), PACKAGE / "_core.pyi"])}


def _is_module(name: str) -> bool:
    """True when ``name`` (dotted, from millscope) is a module or package of the sources."""
    rel = Path(*name.split("."))
    base = PACKAGE.parent / rel
    return (base.with_suffix(".py").exists() or (base / "__init__.py").exists()
            or any(base.parent.glob(f"{base.name}.*.so")))


def layer(module: str) -> str:
    """The layer of ``millscope[.<...>]``."""
    parts = module.split(".")
    if len(parts) == 1:
        return "package"
    if parts[1] in SUBPACKAGES:
        return parts[1]
    if parts[1] == "__main__":
        return "main"
    assert parts[1].startswith("_"), f"{module} is public but in no layer"
    return "util"


def _is_type_checking(test: ast.expr) -> bool:
    return (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING") or (
        isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING")


def _skipped_blocks(tree: ast.AST) -> set[int]:
    """The ids of the statements under ``if TYPE_CHECKING:``."""
    skipped: set[int] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.If) and _is_type_checking(node.test):
            skipped.update(id(n) for s in node.body for n in ast.walk(s))
    return skipped


def _top_level(tree: ast.Module) -> set[int]:
    """The ids of the statements that run when the module is imported (not in a def)."""
    ran: set[int] = set()

    def visit(statements: list[ast.stmt]) -> None:
        for node in statements:
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                continue
            ran.add(id(node))
            for field in ("body", "orelse", "finalbody"):
                visit(getattr(node, field, []))
            for handler in getattr(node, "handlers", []):
                visit(handler.body)

    visit(tree.body)
    return ran


@functools.cache
def imports(module: str, *, at_import_time: bool = False) -> set[str]:
    """The modules of the package that ``module`` imports: anywhere in its source, or only
    those imports that run when it is imported."""
    path = _all_modules()[module]
    tree = ast.parse(path.read_text())
    skipped = _skipped_blocks(tree)
    ran = _top_level(tree) if at_import_time else None
    package = module.split(".") if path.name == "__init__.py" else module.split(".")[:-1]
    found: set[str] = set()
    for node in ast.walk(tree):
        if id(node) in skipped or (ran is not None and id(node) not in ran):
            continue
        if isinstance(node, ast.ImportFrom):
            if node.level:
                base = package[:len(package) - node.level + 1]
                target = ".".join(base + ([node.module] if node.module else []))
            elif node.module and node.module.split(".")[0] == NAME:
                target = node.module
            else:
                continue
            subs = [f"{target}.{a.name}" for a in node.names if _is_module(f"{target}.{a.name}")]
            found.update(subs)
            if len(subs) < len(node.names):
                found.add(target)
        elif isinstance(node, ast.Import):
            found.update(a.name for a in node.names if a.name.split(".")[0] == NAME)
    return {m for m in found if m != module}


def _closure(module: str) -> set[str]:
    seen: set[str] = set()
    todo = [module]
    while todo:
        for m in imports(todo.pop(), at_import_time=True) - seen:
            seen.add(m)
            todo.append(m)
    return seen


def test_the_reader_sees_imports_at_every_level_and_skips_type_checking() -> None:
    """The checker itself, on modules whose imports are known: the report imports the
    campaign, the calibration and the figures at module level; the command line imports its
    subcommands' modules inside the subcommands, which count; the calibration names the
    campaign's CaseResult for annotations only, which does not."""
    reports = imports("millscope.report.reports", at_import_time=True)
    assert {"millscope.campaign.runs", "millscope.campaign.store", "millscope.calibration.fit",
            "millscope.report.plots"} <= reports
    cli = imports("millscope.app.cli")
    assert {"millscope.report.plots", "millscope.app.demo", "millscope.campaign.studies"} <= cli
    assert "millscope.report.plots" not in imports("millscope.app.cli", at_import_time=True)
    assert not any(m.startswith("millscope.campaign") for m in imports("millscope.calibration.fit"))
    assert imports("millscope.model.presets") == {"millscope.model.scene"}
    assert layer("millscope.signal._torque_csv") == "signal" and layer("millscope._core") == "util"


@pytest.mark.parametrize("module", sorted(_all_modules()))
def test_every_import_runs_down_the_layers(module: str) -> None:
    """Module-level and function-level imports alike."""
    up = {m for m in imports(module) if layer(m) not in ALLOWED[layer(module)]}
    assert not up, f"{module} ({layer(module)}) imports {sorted(up)} above or beside it"


def test_the_import_graph_has_no_circle() -> None:
    graph = {m: imports(m) for m in _all_modules()}
    unknown = {t for targets in graph.values() for t in targets} - set(graph)
    assert not unknown, f"imports of modules not in the sources: {sorted(unknown)}"
    state: dict[str, int] = {}  # 1: on the current path, 2: done
    path: list[str] = []

    def visit(m: str) -> None:
        state[m] = 1
        path.append(m)
        for t in sorted(graph[m]):
            assert state.get(t) != 1, "circle: " + " -> ".join(path[path.index(t):] + [t])
            if t not in state:
                visit(t)
        path.pop()
        state[m] = 2

    for m in sorted(graph):
        if m not in state:
            visit(m)


@pytest.mark.parametrize("module", ANALYSIS_SIDE)
def test_the_analysis_side_does_not_import_the_simulation_side(module: str) -> None:
    reached = {m for m in _closure(f"{NAME}.{module}") if m.split(".")[1:2] and
               m.split(".")[1] in SIMULATION_SIDE}
    assert not reached, f"millscope.{module} imports {sorted(reached)} when imported"

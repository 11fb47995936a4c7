"""The layering of docs/architecture.md (Layers), read from the sources: the analysis side
(plots -> fit -> spectral -> record) does not import the simulation side (campaign -> simulation
-> scene), which would load scenes, presets and the engine's campaign machinery for a fill estimate.

Only imports that run when a module is imported count: those at module level, outside
``if TYPE_CHECKING:``; imports inside functions are deliberate late binding.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

import millscope

PACKAGE = Path(millscope.__file__).parent
ANALYSIS_SIDE = ("record", "spectral", "logfit", "bootstrap", "analysis", "fit", "monitoring",
                 "drivetrain", "plots")
SIMULATION_SIDE = {"scene", "presets", "simulation", "campaign", "campaign_analysis", "report",
                   "contact", "studies", "stiffness"}


def _is_type_checking(test: ast.expr) -> bool:
    return (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING") or (
        isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING")


def _imported_at_import_time(module: str) -> set[str]:
    """The sibling modules ``millscope.<module>`` imports when it is imported."""
    tree = ast.parse((PACKAGE / f"{module}.py").read_text())
    found: set[str] = set()

    def visit(statements: list[ast.stmt]) -> None:
        for node in statements:
            if isinstance(node, ast.ImportFrom) and node.level == 1:
                if node.module:  # from .x import y
                    found.add(node.module.split(".")[0])
                else:  # from . import x, y
                    found.update(alias.name for alias in node.names)
            elif isinstance(node, ast.ImportFrom) and node.module and (
                    node.module.startswith("millscope.")):
                found.add(node.module.split(".")[1])
            elif isinstance(node, ast.If) and not _is_type_checking(node.test):
                visit(node.body)
                visit(node.orelse)
            elif isinstance(node, (ast.Try,)):
                visit(node.body)
                for handler in node.handlers:
                    visit(handler.body)
                visit(node.orelse)
                visit(node.finalbody)

    visit(tree.body)
    return {m for m in found if (PACKAGE / f"{m}.py").exists()}


def _closure(module: str) -> set[str]:
    seen: set[str] = set()
    todo = [module]
    while todo:
        for m in _imported_at_import_time(todo.pop()) - seen:
            seen.add(m)
            todo.append(m)
    return seen


def test_the_reader_sees_imports_and_skips_type_checking_and_function_bodies() -> None:
    """The checker itself, on modules whose imports are known: report imports the campaign
    and the figures at module level; fit names CaseResult for annotations only; the command
    line imports its subcommands' modules inside the subcommands."""
    assert {"campaign", "fit", "plots"} <= _imported_at_import_time("report")
    assert "campaign" not in _imported_at_import_time("fit")
    assert _imported_at_import_time("cli") == set()


@pytest.mark.parametrize("module", ANALYSIS_SIDE)
def test_the_analysis_side_does_not_import_the_simulation_side(module: str) -> None:
    reached = _closure(module) & SIMULATION_SIDE
    assert not reached, f"millscope.{module} imports {sorted(reached)} when imported"

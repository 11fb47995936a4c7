"""The module paths of the flat layout (``millscope.presets``, ``millscope.fit``, ...), kept
importable for code written against them.

Each old path names the module that holds its code now: ``millscope.fit`` *is*
``millscope.calibration.fit``, so patching a name through one patches it in the other. An old
path is loaded when it is first imported (or read as an attribute of :mod:`millscope`), like
the module it names, so the figures still load matplotlib only when asked for. The old
``millscope.analysis`` also held the three names of the groups' analysis; its path gives the
analysis of one block with those names added.
"""

from __future__ import annotations

import importlib
import importlib.abc
import importlib.machinery
import sys
from types import ModuleType

__all__ = ["MOVED", "install", "module"]

_PACKAGE = __name__.rpartition(".")[0]

#: The old module name (under millscope) -> where its code lives now.
MOVED: dict[str, str] = {
    "contact": "model.contact",
    "scene": "model.scene",
    "presets": "model.presets",
    "stiffness": "model.stiffness",
    "simulation": "engine.simulation",
    "_checkpoint": "engine.checkpoint",
    "record": "signal.record",
    "_torque_csv": "signal._torque_csv",
    "spectral": "signal.spectral",
    "drivetrain": "signal.drivetrain",
    "analysis": "signal.analysis",
    "synthetic": "signal.synthetic",
    "logfit": "calibration.logfit",
    "bootstrap": "calibration.bootstrap",
    "campaign_analysis": "calibration.groups",
    "fit": "calibration.fit",
    "monitoring": "calibration.monitoring",
    "studies": "campaign.studies",
    "plots": "report.plots",
    "cli": "app.cli",
    "demo": "app.demo",
    "bench": "app.bench",
}
_GROUP_NAMES = ("GroupAnalysis", "analyze_campaign", "table6_markdown")


class _OldPathFinder(importlib.abc.MetaPathFinder, importlib.abc.Loader):
    """Finds ``millscope.<old name>`` and loads it as the module named in :data:`MOVED`."""

    def find_spec(self, fullname: str, path: object = None, target: object = None
                  ) -> importlib.machinery.ModuleSpec | None:
        package, _, name = fullname.rpartition(".")
        if package != _PACKAGE or name not in MOVED:
            return None
        return importlib.machinery.ModuleSpec(fullname, self)

    def create_module(self, spec: importlib.machinery.ModuleSpec) -> None:
        return None  # the default module, replaced in exec_module

    def exec_module(self, module: ModuleType) -> None:
        name = module.__name__.rpartition(".")[2]
        new = importlib.import_module(f"{_PACKAGE}.{MOVED[name]}")
        if name == "analysis":
            groups = importlib.import_module(f"{_PACKAGE}.calibration.groups")
            module.__dict__.update({k: v for k, v in vars(new).items() if not k.startswith("__")})
            module.__dict__.update({k: getattr(groups, k) for k in _GROUP_NAMES})
            module.__doc__ = new.__doc__
        else:
            # the import system returns what sys.modules holds once the loader has run
            sys.modules[module.__name__] = new


def install() -> None:
    """Puts the finder of the old paths last on :data:`sys.meta_path` (once)."""
    if not any(isinstance(f, _OldPathFinder) for f in sys.meta_path):
        sys.meta_path.append(_OldPathFinder())


def module(name: str) -> ModuleType:
    """The module of the old path ``millscope.<name>``."""
    return importlib.import_module(f"{_PACKAGE}.{name}")

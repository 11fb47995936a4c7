"""millscope: DEM simulation of tumbling ball mills and filling-level estimation from torque.

The public API (docs/architecture.md, Public API) is re-exported here; submodules hold the details.
"""

from importlib import import_module as _import_module
from typing import Any as _Any

from . import campaign, contact, drivetrain, presets, studies
from ._core import build_info as _build_info
from .campaign import Campaign, Case, CaseResult, RunSettings
from .campaign_analysis import GroupAnalysis, analyze_campaign
from .fit import Calibration, FillEstimate, LogFit, estimate_fill, log_fit
from .monitoring import WindowEstimate, monitor
from .record import RecordError, TorqueRecord
from .scene import Drum, Fraction, Lifters, Material, Pair, Scene
from .simulation import CheckpointError, SettleWarning, Simulation
from .spectral import (
    Peak,
    SpectralEnergy,
    Spectrum,
    band_stop,
    find_peak,
    lifter_harmonic_hz,
    spectral_energy,
    spectrum,
    window_factors,
)
from .studies import StudyPlan, StudyResult, run_study

__version__: str = _build_info()["version"]

_LAZY_SUBMODULES = ("plots", "report")  # matplotlib is imported only when figures are asked for


def __getattr__(name: str) -> _Any:
    if name in _LAZY_SUBMODULES:
        return _import_module(f".{name}", __name__)
    raise AttributeError(f"module 'millscope' has no attribute {name!r}")

__all__ = [
    "Calibration",
    "Campaign",
    "Case",
    "CaseResult",
    "CheckpointError",
    "Drum",
    "Fraction",
    "Lifters",
    "Material",
    "Pair",
    "Scene",
    "SettleWarning",
    "Simulation",
    "FillEstimate",
    "GroupAnalysis",
    "LogFit",
    "Peak",
    "RecordError",
    "RunSettings",
    "SpectralEnergy",
    "Spectrum",
    "StudyPlan",
    "StudyResult",
    "TorqueRecord",
    "WindowEstimate",
    "__version__",
    "analyze_campaign",
    "band_stop",
    "campaign",
    "contact",
    "drivetrain",
    "estimate_fill",
    "find_peak",
    "lifter_harmonic_hz",
    "log_fit",
    "monitor",
    "plots",
    "presets",
    "report",
    "run_study",
    "spectral_energy",
    "spectrum",
    "studies",
    "window_factors",
]

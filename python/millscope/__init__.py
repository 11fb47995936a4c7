"""millscope: DEM simulation of tumbling ball mills and filling-level estimation from torque.

The public API (docs/architecture.md, Public API) is re-exported here; submodules hold the details.
"""

from typing import Any as _Any

from . import _old_paths
from ._core import build_info as _build_info
from .calibration.fit import Calibration, FillEstimate, LogFit, estimate_fill, log_fit
from .calibration.groups import GroupAnalysis, analyze_campaign
from .calibration.monitoring import WindowEstimate, monitor
from .campaign import Campaign, Case, CaseResult, RunSettings, read_store, studies
from .campaign.studies import StudyPlan, StudyResult, run_study
from .engine.simulation import CheckpointError, LedgerOffError, SettleWarning, Simulation
from .model import contact, presets
from .model.scene import Drum, Fraction, Lifters, Material, Pair, Scene
from .signal import drivetrain
from .signal.record import RecordError, TorqueRecord
from .signal.spectral import (
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

__version__: str = _build_info()["version"]

_old_paths.install()


def __getattr__(name: str) -> _Any:
    # the report (it loads matplotlib) and the old module paths load on first use
    if name == "report" or name in _old_paths.MOVED:
        return _old_paths.module(name)
    raise AttributeError(f"module 'millscope' has no attribute {name!r}")


__all__ = [
    "Calibration",
    "Campaign",
    "Case",
    "CaseResult",
    "CheckpointError",
    "LedgerOffError",
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
    "read_store",
    "report",
    "run_study",
    "spectral_energy",
    "spectrum",
    "studies",
    "window_factors",
]

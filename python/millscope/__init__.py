"""millscope: DEM simulation of tumbling ball mills and filling-level estimation from torque.

The public API (DESIGN.md section 5) is re-exported here; submodules hold the details.
"""

from ._core import build_info as _build_info
from .fit import Calibration, FillEstimate, LogFit, estimate_fill, log_fit
from .record import RecordError, TorqueRecord
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

__version__: str = _build_info()["version"]

__all__ = [
    "Calibration",
    "FillEstimate",
    "LogFit",
    "Peak",
    "RecordError",
    "SpectralEnergy",
    "Spectrum",
    "TorqueRecord",
    "__version__",
    "band_stop",
    "estimate_fill",
    "find_peak",
    "lifter_harmonic_hz",
    "log_fit",
    "spectral_energy",
    "spectrum",
    "window_factors",
]

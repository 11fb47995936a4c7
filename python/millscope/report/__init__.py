"""The report layer: :mod:`~millscope.report.plots` (figures, never shown) and
:mod:`~millscope.report.reports` (a campaign store's report, a study's files). Imports matplotlib,
so :mod:`millscope` loads it only when asked for. The names of :mod:`~millscope.report.reports`
are importable from here (``millscope.report.write_report``).
"""

from .reports import UnreadableCasesError, calibration_file_name, write_report, write_study

__all__ = ["UnreadableCasesError", "calibration_file_name", "write_report", "write_study"]

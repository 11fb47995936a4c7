"""The campaign layer: many cases run into a resumable store, and studies built on campaigns.

:mod:`~millscope.campaign.runs` (cases, store, locks, executors, :class:`Campaign`) and
:mod:`~millscope.campaign.studies` (error against run time). Imports the engine, the model, the
calibration and the signal layers. The names of :mod:`~millscope.campaign.runs` are importable
from here (``millscope.campaign.Campaign``).
"""

from .runs import (
    CASE_FORMAT,
    MANIFEST_FORMAT,
    Campaign,
    Case,
    CaseResult,
    RunSettings,
    UnreadableCase,
    case_matrix,
    paper_matrix,
    read_manifest,
    run_case,
    unreadable_cases,
)

__all__ = [
    "CASE_FORMAT",
    "MANIFEST_FORMAT",
    "Campaign",
    "Case",
    "CaseResult",
    "RunSettings",
    "UnreadableCase",
    "case_matrix",
    "paper_matrix",
    "read_manifest",
    "run_case",
    "unreadable_cases",
]

"""The campaign layer: many cases run into a resumable store, and studies built on campaigns.

:mod:`~millscope.campaign.cases` (RunSettings, Case, their matrices, CaseResult),
:mod:`~millscope.campaign.store` (the result store: case files, manifest, lock),
:mod:`~millscope.campaign.executors` (the worker side and the wait on any executor),
:mod:`~millscope.campaign.runs` (:class:`Campaign`, which runs cases into a store, and
:func:`read_store`, a store as one table), :mod:`~millscope.campaign.tables` (the results as a
pandas DataFrame), :mod:`~millscope.campaign.costs` (what a campaign has left to run, and its
cost) and the study of error against run time:
:mod:`~millscope.campaign.study_plans` (settings, plans),
:mod:`~millscope.campaign.study_results` (rows, tables, CSV, Markdown) and
:mod:`~millscope.campaign.studies` (:func:`run_study`, and every name of the study). Imports
the engine, the model, the calibration and the signal layers. The public names of the first
five are importable from here (``millscope.campaign.Campaign``), as from the former
``millscope.campaign`` module.
"""

from .cases import CASE_FORMAT, Case, CaseResult, RunSettings, case_matrix, paper_matrix
from .executors import run_case
from .runs import Campaign, read_store
from .store import MANIFEST_FORMAT, UnreadableCase, read_manifest, unreadable_cases
from .tables import CaseResults

__all__ = [
    "CASE_FORMAT",
    "MANIFEST_FORMAT",
    "Campaign",
    "Case",
    "CaseResult",
    "CaseResults",
    "RunSettings",
    "UnreadableCase",
    "case_matrix",
    "paper_matrix",
    "read_manifest",
    "read_store",
    "run_case",
    "unreadable_cases",
]

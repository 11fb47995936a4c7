"""The calibration layer: from analysed blocks to a filling estimate.

:mod:`~millscope.calibration.logfit` (the log fit), :mod:`~millscope.calibration.bootstrap`
(resampling helpers), :mod:`~millscope.calibration.groups` (a campaign's results analysed group
by group, read through their attributes), :mod:`~millscope.calibration.fit` (Calibration and
the fill estimate), :mod:`~millscope.calibration.monitoring` (a calibration slid over a long
record). Imports the signal layer only.
"""

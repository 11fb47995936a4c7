"""The signal layer: torque records and what is computed from one.

:mod:`~millscope.signal.record` (TorqueRecord, its files), :mod:`~millscope.signal.spectral`
(spectra, peaks, spectral energy), :mod:`~millscope.signal.drivetrain` (drive-train lines),
:mod:`~millscope.signal.analysis` (the analysis of one block),
:mod:`~millscope.signal.synthetic` (records of known content). Imports neither the scenes nor
the engine, so that analysing a measured record loads no simulation code.
"""

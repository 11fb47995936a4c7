"""The engine layer: :mod:`~millscope.engine.simulation` (fill, settle, run in chunks, save and
load) and :mod:`~millscope.engine.checkpoint` (a checkpoint read as untrusted input). Imports
the model (scenes) and the signal layer (the torque record it returns).
"""

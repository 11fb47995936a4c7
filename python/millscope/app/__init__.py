"""The application layer: :mod:`~millscope.app.cli` (``python -m millscope`` and the
``millscope`` script), :mod:`~millscope.app.demo` (the main job) and :mod:`~millscope.app.bench`
(throughput). Top of the layering: it may import every layer below.
"""

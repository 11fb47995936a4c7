"""The model layer: what is in the mill, checked before anything runs.

:mod:`~millscope.model.contact` (the contact law on its own), :mod:`~millscope.model.scene`
(drum, materials, charge), :mod:`~millscope.model.presets` (the paper's pilot mill and case
matrix), :mod:`~millscope.model.stiffness` (time step and stiffness advice). Imports only the
private helpers and the extension below it.
"""

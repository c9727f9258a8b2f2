"""Stability and accuracy of the integration schemes (``./pd analyze``).

The sweeps themselves are :mod:`pd_core.dynamics.analysis` (the stability check uses them);
this package is the command (:mod:`.analyze`) and its table and figures (:mod:`.figures`).
"""

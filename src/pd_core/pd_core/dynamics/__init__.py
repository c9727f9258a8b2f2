"""Structural dynamics: the structure, ground motions, stability and accuracy of the schemes.

* :mod:`.structure` — mass, damping, initial stiffness, modal analysis, effective loads;
* :mod:`.ground_motion` — the record: a sampled acceleration history, scaling, resampling;
* :mod:`.record_readers` — record files (two-column, single, multi-column, PEER ``.AT2``),
  units;
* :mod:`.stability` — ``ω_max·Δt`` against a scheme's limit (thesis eq. 3.14), period
  distortion (eq. 3.19); the pre-test report;
* :mod:`.analysis` — spectral radius, numerical damping and period error of every scheme
  from its amplification matrix (``./pd analyze``);
* :mod:`.analysis_figures` — the CSV table and the figures of those sweeps.
"""

from __future__ import annotations

from .ground_motion import GroundMotion
from .record_readers import read_ground_motion
from .stability import StabilityReport, check_stability, period_distortion, require_stable
from .structure import Structure, damping_from_ratio, modal_analysis, omega_max

__all__ = [
    'GroundMotion',
    'StabilityReport',
    'Structure',
    'check_stability',
    'damping_from_ratio',
    'modal_analysis',
    'omega_max',
    'period_distortion',
    'read_ground_motion',
    'require_stable',
]

"""Tracking controllers / delay compensators of the bridge's control layer (registry)."""

from __future__ import annotations

from . import adaptive, model_based, pi_p, polynomial  # noqa: F401  (register them)
from .base import (
    COMPENSATORS,
    Compensator,
    CompensatorParameter,
    CompensatorSpec,
    NoCompensation,
    compensator_names,
    compensator_spec,
    make_compensator,
    register_compensator,
)

#: The name of the best compensator on the vRTHS benchmark (``bench/rths_compensators.py``).
DEFAULT_COMPENSATOR: str = 'adaptive'

__all__ = [
    'COMPENSATORS',
    'DEFAULT_COMPENSATOR',
    'Compensator',
    'CompensatorParameter',
    'CompensatorSpec',
    'NoCompensation',
    'compensator_names',
    'compensator_spec',
    'make_compensator',
    'register_compensator',
]

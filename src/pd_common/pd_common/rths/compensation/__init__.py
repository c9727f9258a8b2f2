"""Tracking controllers / delay compensators of the bridge's control layer (registry)."""

from __future__ import annotations

from . import pi_p  # noqa: F401  (registers 'pi_p')
from .base import (
    Compensator,
    CompensatorParameter,
    CompensatorSpec,
    NoCompensation,
    compensator_names,
    compensator_spec,
    make_compensator,
    register_compensator,
)

__all__ = [
    'Compensator',
    'CompensatorParameter',
    'CompensatorSpec',
    'NoCompensation',
    'compensator_names',
    'compensator_spec',
    'make_compensator',
    'register_compensator',
]

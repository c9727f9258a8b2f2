"""Experimental errors (thesis section 3.4.3), tracking monitors (command vs measured) and
experimental setups (an element's basic DOFs ↔ its site's actuator strokes)."""

from __future__ import annotations

from ..errors import SetupError
from .error_model import ERRORS_KEY, ErroneousStep, ErrorInjector, ErrorModel
from .setups import (
    SETUP_TYPES,
    ColumnSetup,
    ExperimentalSetup,
    OneToOneSetup,
    PlanarActuators,
    PlanarThreeActuators,
    RigidLinkTwoActuators,
    setup_from_config,
)
from .tracking import TrackingMonitor, TrackingSample, tracking_error, tracking_indicator

__all__ = [
    'ERRORS_KEY',
    'SETUP_TYPES',
    'ColumnSetup',
    'ErroneousStep',
    'ErrorInjector',
    'ErrorModel',
    'ExperimentalSetup',
    'OneToOneSetup',
    'PlanarActuators',
    'PlanarThreeActuators',
    'RigidLinkTwoActuators',
    'SetupError',
    'TrackingMonitor',
    'TrackingSample',
    'setup_from_config',
    'tracking_error',
    'tracking_indicator',
]

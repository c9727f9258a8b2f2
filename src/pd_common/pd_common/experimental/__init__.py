"""Experimental errors, tracking monitors, experimental setups and the bridge's safety limits.

Experimental errors (thesis section 3.4.3), tracking monitors (command vs measured),
experimental setups (an element's basic DOFs ↔ its site's actuator strokes) and the actuator
bridge's safety limits (:mod:`.limits`: the bridge and the ROS-free rehearsals apply them).
"""

from __future__ import annotations

from ..errors import SetupError
from .error_model import ERRORS_KEY, ErroneousStep, ErrorInjector, ErrorModel
from .limits import (
    LIMIT_PARAMETERS,
    ON_LIMIT_OPTIONS,
    LimitViolation,
    SafetyLimits,
    Saturation,
    bridge_parameters,
    check_command,
    check_control,
    check_feedback,
    check_strokes,
    check_target_force,
    check_tracking,
    limits_from_parameters,
    on_limit_from_parameters,
    saturate_command,
)
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
    'LIMIT_PARAMETERS',
    'ON_LIMIT_OPTIONS',
    'SETUP_TYPES',
    'ColumnSetup',
    'ErroneousStep',
    'ErrorInjector',
    'ErrorModel',
    'ExperimentalSetup',
    'LimitViolation',
    'OneToOneSetup',
    'PlanarActuators',
    'PlanarThreeActuators',
    'RigidLinkTwoActuators',
    'SafetyLimits',
    'Saturation',
    'SetupError',
    'TrackingMonitor',
    'TrackingSample',
    'bridge_parameters',
    'check_command',
    'check_control',
    'check_feedback',
    'check_strokes',
    'check_target_force',
    'check_tracking',
    'limits_from_parameters',
    'on_limit_from_parameters',
    'saturate_command',
    'setup_from_config',
    'tracking_error',
    'tracking_indicator',
]

"""Safety limits of the actuator bridge and the checks applied to commands and measurements.

Implemented once, in :mod:`pd_common.experimental.limits` (the shared library), and re-exported
here: the bridge enforces them, and the ROS-free rehearsals (``./pd offline``, ``./pd
pretest``), which may not import the bridge, apply the same checks to the same floats.

The limits are the bridge's own: they are enforced whatever the integrator sends. A value exactly
at a limit is allowed; anything beyond it is rejected. There is deliberately no tolerance.
Two kinds of violation are distinguished: ``LIMIT`` (a finite value beyond a safety limit) and
``FAULT`` (malformed, non-finite or inconsistent data, or an actuator that does not follow its
command: see :func:`check_tracking`). :func:`saturate_command` clips a target to the nearest
allowed value for the bridge's ``on_limit='saturate'`` mode; a fault is never saturated.
"""

from __future__ import annotations

from pd_common.experimental.limits import (
    KIND_FAULT,
    KIND_LIMIT,
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
    dof_label,
    format_value,
    limits_from_parameters,
    on_limit_from_parameters,
    saturate_command,
)

__all__ = [
    'KIND_FAULT',
    'KIND_LIMIT',
    'LIMIT_PARAMETERS',
    'ON_LIMIT_OPTIONS',
    'LimitViolation',
    'SafetyLimits',
    'Saturation',
    'bridge_parameters',
    'check_command',
    'check_control',
    'check_feedback',
    'check_strokes',
    'check_target_force',
    'check_tracking',
    'dof_label',
    'format_value',
    'limits_from_parameters',
    'on_limit_from_parameters',
    'saturate_command',
]

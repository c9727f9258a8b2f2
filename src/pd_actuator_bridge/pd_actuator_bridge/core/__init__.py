"""Pure core of the actuator bridge: safety limits, actuator drivers and the bridge state machine.

Pure Python (no ``rclpy``): the node shell wires it to the step command and feedback topics.
"""

from __future__ import annotations

from .bridge import ActuatorBridge, BridgeReply
from .driver import ActuatorDriver, LoopbackDriver, MeasurementCallback
from .errors import BridgeConfigError, BridgeError, DriverError, LimitError
from .limits import LimitViolation, SafetyLimits, check_command, check_feedback

__all__ = [
    'ActuatorBridge',
    'ActuatorDriver',
    'BridgeConfigError',
    'BridgeError',
    'BridgeReply',
    'DriverError',
    'LimitError',
    'LimitViolation',
    'LoopbackDriver',
    'MeasurementCallback',
    'SafetyLimits',
    'check_command',
    'check_feedback',
]

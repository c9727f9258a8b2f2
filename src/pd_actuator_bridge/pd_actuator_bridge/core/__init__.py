"""Pure core of the actuator bridge: safety limits, actuator drivers and the bridge state machine.

Pure Python (no ``rclpy``): the node shell wires it to the step command and feedback topics.
"""

from __future__ import annotations

from .bridge import ActuatorBridge, BridgeReply
from .driver import ActuatorDriver, LoopbackDriver, MeasurementCallback, RemoteDriver
from .errors import BridgeConfigError, BridgeError, DriverError, LimitError
from .limits import (
    LimitViolation,
    SafetyLimits,
    Saturation,
    check_command,
    check_feedback,
    check_tracking,
    saturate_command,
)

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
    'RemoteDriver',
    'SafetyLimits',
    'Saturation',
    'check_command',
    'check_feedback',
    'check_tracking',
    'saturate_command',
]

from .daqmx import DaqmxChannelConfig, DaqmxConfig, DaqmxDriver  # noqa: E402

__all__ += ['DaqmxChannelConfig', 'DaqmxConfig', 'DaqmxDriver']

from .generic_tcp import (  # noqa: E402
    DaqResponse,
    GenericTCPClient,
    GenericTCPDriver,
    GenericTCPError,
    SizeID,
    TrialResponse,
)

__all__ += [
    'DaqResponse',
    'GenericTCPClient',
    'GenericTCPDriver',
    'GenericTCPError',
    'SizeID',
    'TrialResponse',
]

from .opensees_adapter import OpenSeesAdapterDriver, OpenSeesAdapterError  # noqa: E402

__all__ += ['OpenSeesAdapterDriver', 'OpenSeesAdapterError']

from .emulator import EmulatorParameters, Measurement, ServoHydraulicEmulator  # noqa: E402
from .error_models import (  # noqa: E402
    ErroneousStep,
    ErrorInjector,
    ErrorModel,
    apply_error_model,
)
from .ramp_hold import (  # noqa: E402
    EmulatorDriver,
    RampHoldExecutor,
    RampHoldParameters,
    SettleTimeoutError,
    StepExecution,
)

__all__ += [
    'EmulatorDriver',
    'EmulatorParameters',
    'ErroneousStep',
    'ErrorInjector',
    'ErrorModel',
    'Measurement',
    'RampHoldExecutor',
    'RampHoldParameters',
    'ServoHydraulicEmulator',
    'SettleTimeoutError',
    'StepExecution',
    'apply_error_model',
]

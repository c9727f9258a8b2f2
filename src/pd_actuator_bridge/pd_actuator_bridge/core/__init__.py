"""Pure core of the actuator bridge: safety limits, actuator drivers and the bridge state machine.

Pure Python (no ``rclpy``): the node shell wires it to the step command and feedback topics.
The bridge (:mod:`.bridge`) answers in the protocol's :class:`pd_common.protocol.Feedback`; its
force ramps are in :mod:`.force_control`; drivers report
:class:`~.drivers.base.ActuatorMeasurement` records.
The drivers, one module per controller family, and their registry are in :mod:`.drivers`;
importing this package registers the built-in ones.
"""

from __future__ import annotations

from pd_common.experimental.limits import (
    LimitViolation,
    SafetyLimits,
    Saturation,
    check_command,
    check_feedback,
    check_tracking,
    saturate_command,
)

from .bridge import ActuatorBridge
from .drivers.base import (
    ActuatorDriver,
    ActuatorMeasurement,
    MeasurementCallback,
    RemoteDriver,
    StepId,
    force_substep_key,
)
from .drivers.daqmx import DaqmxDriver
from .drivers.daqmx_config import DaqmxChannelConfig, DaqmxConfig
from .drivers.emulator import Measurement, ServoHydraulicEmulator
from .drivers.emulator_driver import EmulatorDriver
from .drivers.emulator_parameters import EmulatorParameters
from .drivers.generic_tcp import GenericTCPClient, GenericTCPDriver
from .drivers.generic_tcp_protocol import DaqResponse, GenericTCPError, SizeID, TrialResponse
from .drivers.opensees_adapter import OpenSeesAdapterDriver, OpenSeesAdapterError
from .drivers.ramp_hold import (
    RampHoldExecutor,
    RampHoldParameters,
    SettleTimeoutError,
    StepExecution,
)
from .drivers.registry import (
    DriverContext,
    DriverParameter,
    DriverSpec,
    driver_names,
    driver_parameters,
    driver_spec,
    make_driver,
    register_driver,
)
from .drivers.transfer_system import TransferSystemDriver
from .error_models import ErroneousStep, ErrorInjector, ErrorModel, apply_error_model
from .errors import BridgeConfigError, BridgeError, DriverError, LimitError
from .force_control import MAX_FORCE_SUBSTEPS, ForceControl, ForceRamp

__all__ = [
    'MAX_FORCE_SUBSTEPS',
    'ActuatorBridge',
    'ActuatorDriver',
    'ActuatorMeasurement',
    'BridgeConfigError',
    'BridgeError',
    'DaqResponse',
    'DaqmxChannelConfig',
    'DaqmxConfig',
    'DaqmxDriver',
    'DriverContext',
    'DriverError',
    'DriverParameter',
    'DriverSpec',
    'EmulatorDriver',
    'EmulatorParameters',
    'ErroneousStep',
    'ErrorInjector',
    'ErrorModel',
    'ForceControl',
    'ForceRamp',
    'GenericTCPClient',
    'GenericTCPDriver',
    'GenericTCPError',
    'LimitError',
    'LimitViolation',
    'Measurement',
    'MeasurementCallback',
    'OpenSeesAdapterDriver',
    'OpenSeesAdapterError',
    'RampHoldExecutor',
    'RampHoldParameters',
    'RemoteDriver',
    'SafetyLimits',
    'Saturation',
    'ServoHydraulicEmulator',
    'SettleTimeoutError',
    'SizeID',
    'StepExecution',
    'StepId',
    'TransferSystemDriver',
    'TrialResponse',
    'apply_error_model',
    'check_command',
    'check_feedback',
    'check_tracking',
    'driver_names',
    'driver_parameters',
    'driver_spec',
    'force_substep_key',
    'make_driver',
    'register_driver',
    'saturate_command',
]

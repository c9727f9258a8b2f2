"""The ``emulator`` driver: the bridge drives the servo-hydraulic emulator step by step.

:class:`EmulatorDriver` is the synchronous :class:`~.base.ActuatorDriver` through which the
:class:`~..bridge.ActuatorBridge` drives the emulator, each step executed by ramp-and-hold
(:class:`~.ramp_hold.RampHoldExecutor`): the ``emulator`` driver (:data:`EMULATOR`, built by
:func:`make_emulator_driver` on the specimen of a test file).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any, cast

from pd_common.protocol import StateOrigin
from pd_common.specimen import load_specimen_section, specimen_from_config

from ..error_models import ErrorModel
from ..errors import BridgeConfigError, DriverError
from .base import ActuatorDriver, ActuatorMeasurement
from .emulator import ServoHydraulicEmulator
from .emulator_parameters import EmulatorParameters
from .ramp_hold import RampHoldExecutor, RampHoldParameters, SettleTimeoutError, StepExecution
from .registry import (
    DriverContext,
    DriverParameter,
    DriverSpec,
    read_driver_settings,
    register_driver,
)

TrajectoryCallback = Callable[[Any, 'StepExecution'], None]
"""``cb(step, execution)``: receives every step's execution (also a failed one)."""


class EmulatorDriver(ActuatorDriver):
    """Synchronous actuator driver executing each step on the emulator by ramp-and-hold.

    It answers inside :meth:`command` through the measurement callback, with the averaged
    measurement. It keeps the last :class:`StepExecution` (its trajectory is what the node
    records at the controller rate) and passes every execution to an optional trajectory
    callback. A settling timeout, or any emulator failure, raises :class:`~..errors.DriverError`
    (the bridge then holds with a fault).

    Attributes:
        is_open: Whether :meth:`open` was called (and :meth:`close` not since).
        hold_count: Number of :meth:`hold` calls.
        last_execution: The last step's execution (also a failed one), or ``None``.
    """

    driver_name = 'emulator'

    def force_control_problem(self) -> str | None:
        """Why this driver refuses force-controlled actuators (always: see the docs)."""
        return ('force control not supported; '
                'the emulated servo-valve has a displacement loop only (use sim_servo '
                'for a simulated force-controlled actuator)')

    @property
    def state_origin(self) -> StateOrigin:
        """``FRESH``: the emulated specimen lives in the bridge's process.

        A restarted bridge has a new one.
        """
        return StateOrigin.FRESH


    def __init__(
        self,
        emulator: ServoHydraulicEmulator,
        parameters: RampHoldParameters | Mapping[str, Any] | None = None,
        *,
        errors: ErrorModel | None = None,
        **settings: Any,
    ) -> None:
        """Create the driver; the arguments are those of :class:`RampHoldExecutor`."""
        super().__init__()
        self._executor = RampHoldExecutor(emulator, parameters, errors=errors, **settings)
        self._trajectory_callback: TrajectoryCallback | None = None
        self.is_open = False
        self.hold_count = 0
        self.last_execution: StepExecution | None = None

    @property
    def n_dof(self) -> int:
        """Number of DOF."""
        return self._executor.n_dof

    @property
    def executor(self) -> RampHoldExecutor:
        """The ramp-and-hold executor."""
        return self._executor

    @property
    def emulator(self) -> ServoHydraulicEmulator:
        """The emulator."""
        return self._executor.emulator

    def set_trajectory_callback(self, callback: TrajectoryCallback | None) -> None:
        """Set (or clear) the function receiving ``(step, execution)`` after each step."""
        self._trajectory_callback = callback

    def open(self) -> None:
        """Mark the driver open (the emulator is already running at rest)."""
        self.is_open = True

    def close(self) -> None:
        """Mark the driver closed."""
        self.is_open = False

    def command(self, step: Any, target: Sequence[float]) -> None:
        """Execute ``target`` by ramp-and-hold and report the averaged measurement.

        Raises:
            DriverError: If the driver is not open, the target is malformed, the actuator does
                not settle in time or the emulator fails.
        """
        if not self.is_open:
            msg = 'EmulatorDriver: command() called before open()'
            raise DriverError(msg)
        try:
            execution = self._executor.execute(target)
        except SettleTimeoutError as exc:
            self._record(step, exc.execution)
            raise
        self._record(step, execution)
        self._emit(ActuatorMeasurement(
            step, tuple(execution.displacement.tolist()), tuple(execution.force.tolist()),
            float(execution.time[-1]) if len(execution.time) else None))

    def hold(self) -> None:
        """Hold the actuator where it is (the next ramp starts from the measured position)."""
        self.hold_count += 1
        self._executor.hold()

    def position(self) -> list[float]:
        """Return the last measured displacement per DOF, m."""
        return [float(x) for x in self._executor.emulator.measured_displacement]

    def _record(self, step: Any, execution: StepExecution) -> None:
        self.last_execution = execution
        if self._trajectory_callback is not None:
            self._trajectory_callback(step, execution)


def make_emulator_driver(context: DriverContext) -> EmulatorDriver:
    """The emulator driver on the specimen of ``test_file`` (settings from ``driver_config``).

    ``driver_config`` (optional) may hold ``emulator`` (emulator parameters), ``ramp_hold``
    (ramp-and-hold settings) and ``errors`` (injected experimental errors) sections. Every step's
    execution goes to ``context.on_trajectory``.

    Raises:
        BridgeConfigError: Without a test file, on a specimen with another number of DOF or on
            bad settings.
    """
    test_file = context.parameters['test_file']
    driver_config = context.parameters['driver_config']
    n_dof = context.n_dof
    if not test_file:
        msg = 'parameter test_file: the emulator needs a test file with a specimen section'
        raise BridgeConfigError(msg)
    section, dof_names = load_specimen_section(test_file)
    # Without a site, load_specimen_section always returns the test's DOF names (a list).
    specimen = specimen_from_config(section, base_dir=Path(test_file).resolve().parent,
                                    source=Path(test_file).name,
                                    dof_names=cast('list[str]', dof_names))
    if specimen.n_dof != n_dof:
        msg = (f'parameter dof_names: {n_dof} DOF but the specimen of {test_file} has '
               f'{specimen.n_dof}')
        raise BridgeConfigError(msg)
    from pd_common.config.schema_driver import (  # noqa: PLC0415 (the models: on first use)
        DriverConfigFile,
    )

    settings = (read_driver_settings(driver_config, 'driver_config') if driver_config
                else DriverConfigFile())
    parameters = (None if settings.emulator is None
                  else EmulatorParameters.from_section(settings.emulator))
    errors = None if settings.errors is None else ErrorModel(**dict(settings.errors))
    ramp_hold = (None if settings.ramp_hold is None
                 else RampHoldParameters.from_section(settings.ramp_hold))
    emulator = ServoHydraulicEmulator(specimen, parameters)
    driver = EmulatorDriver(emulator, ramp_hold, errors=errors)
    driver.set_trajectory_callback(context.on_trajectory)
    return driver


EMULATOR = DriverSpec(
    name='emulator',
    factory=make_emulator_driver,
    parameters=(
        DriverParameter('test_file', '', 'YAML test file whose specimen section is driven'),
        DriverParameter('driver_config', '', 'YAML file with the driver settings'),
    ),
    description='in-process servo-hydraulic actuator emulator driving the specimen of '
                'test_file by ramp-and-hold; sub-step trajectories on bridge/trajectory',
)
register_driver(EMULATOR)

"""Ramp-and-hold: the classic pseudo-dynamic execution of one step on a servo-controlled actuator.

For each target the command is ramped linearly from the current command to the target (over a
set duration, or at a set velocity), then held; once the measured displacement has stayed within
a tolerance of the target for a settling time (and at least a minimum hold has elapsed), ``N``
samples of displacement and force, each also within the tolerance (else the wait goes on), are
averaged and reported. If that does not happen within a timeout the step is a fault. This is how
pseudo-dynamic tests are executed on servo-hydraulic actuators (Takanashi and Nakashima,
"Japanese activities on on-line testing", J. Eng. Mech. 113(7), 1987; Shing and Mahin,
"Cumulative experimental errors in pseudodynamic tests", Earthquake Eng. Struct. Dyn. 15, 1987):
the hold removes the actuator's dynamics from the measurement, and averaging reduces the sensor
noise.

:class:`RampHoldExecutor` runs it on a :class:`~.emulator.ServoHydraulicEmulator` and returns a
:class:`StepExecution` with the sub-step trajectory at the controller rate. The driver through
which the :class:`~..bridge.ActuatorBridge` drives the emulator (the ``emulator`` driver) is
:class:`~.emulator_driver.EmulatorDriver`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, fields
from typing import TYPE_CHECKING, Any

import numpy as np

from ..error_models import ErrorInjector, ErrorModel, validated
from ..errors import BridgeConfigError, DriverError
from .emulator import ServoHydraulicEmulator

if TYPE_CHECKING:
    from pd_common.config.schema_driver import RampHoldSection

DEFAULT_RAMP_TIME = 0.1
"""Ramp duration used when neither ``ramp_time`` nor ``ramp_velocity`` is set, s."""

PHASE_RAMP = 0
"""Trajectory phase code: the command ramps towards the target."""
PHASE_HOLD = 1
"""Trajectory phase code: the command holds the target, waiting for the measurement to settle."""
PHASE_SAMPLE = 2
"""Trajectory phase code: settled; the samples averaged into the step's answer."""


@dataclass(frozen=True)
class RampHoldParameters:
    """How each step is executed.

    Attributes:
        ramp_time: Ramp duration, s (0: a step command). Exclusive with ``ramp_velocity``;
            :data:`DEFAULT_RAMP_TIME` if neither is set.
        ramp_velocity: Ramp velocity of the DOF with the largest increment, m/s (all DOFs
            ramp together over the same duration).
        hold_time: Minimum time the target is held before sampling, s.
        settle_tolerance: The measured displacement of every DOF must stay within this
            distance of the target, m.
        settle_time: ... continuously for this long, s (0: one sample within tolerance).
        samples: Number of samples averaged into the answer (after settling; each within the
            tolerance too).
        timeout: Longest hold after the ramp (settling and sampling), s; beyond it the step is a
            fault.

    Raises:
        BridgeConfigError: One line naming the parameter, if a value is invalid.
    """

    ramp_time: float | None = None
    ramp_velocity: float | None = None
    hold_time: float = 0.0
    settle_tolerance: float = 1.0e-5
    settle_time: float = 0.02
    samples: int = 10
    timeout: float = 2.0

    def __post_init__(self) -> None:
        """Validate (the schema's ``RampHoldSection``) and normalise the values."""
        from pd_common.config.schema_driver import RampHoldSection  # noqa: PLC0415 (first use)

        values = {field.name: getattr(self, field.name) for field in fields(self)}
        for name, value in validated(RampHoldSection, values, 'RampHoldParameters'):
            object.__setattr__(self, name, value)

    @classmethod
    def from_mapping(
        cls, mapping: Mapping[str, Any], source: str = 'RampHoldParameters', path: str = ''
    ) -> RampHoldParameters:
        """Build the parameters from a mapping (a parsed YAML section or ROS parameters).

        Args:
            mapping: Any subset of the attribute names (``None`` means not set).
            source: Name of the file or parameter namespace, used in error messages.
            path: The mapping's dotted path in its file (``'ramp_hold'``), in error messages.

        Raises:
            BridgeConfigError: On a non-mapping, an unknown key or a bad value.
        """
        from pd_common.config.schema_driver import RampHoldSection  # noqa: PLC0415 (first use)

        return cls.from_section(validated(RampHoldSection, mapping, source, path))

    @classmethod
    def from_section(cls, section: RampHoldSection) -> RampHoldParameters:
        """The parameters of a typed ``ramp_hold`` section (a driver's settings file)."""
        return cls(**dict(section))

    def ramp_duration(self, increment: float) -> float:
        """Ramp duration for a largest absolute increment ``increment`` (m), s."""
        if self.ramp_velocity is not None:
            return abs(increment) / self.ramp_velocity
        return DEFAULT_RAMP_TIME if self.ramp_time is None else self.ramp_time


@dataclass(frozen=True)
class StepExecution:
    """One executed step: its answer and its trajectory at the controller rate.

    The trajectory arrays have one row per controller period (``n_ticks x n_dof``, ``time``
    and ``phase`` ``n_ticks``); row ``i`` holds the command of period ``i`` and the sensors'
    sample at its end.

    Attributes:
        target: Requested target displacement per DOF, m.
        driven_target: Target actually commanded (differs with an error model), m.
        displacement: Averaged measured displacement per DOF (with the error model's
            measurement errors), m; for a step that did not settle, the last sample.
        force: Averaged measured force per DOF, N; same remark.
        settled: Whether the measurement settled (``False`` only in a timeout fault).
        ramp_ticks: Number of ramp periods.
        hold_ticks: Number of periods held before the samples (all of them on a timeout).
        time: Emulator time of each sample, s.
        command: Command of each period, m.
        measured_displacement: Measured displacement of each sample, m.
        measured_force: Measured force of each sample, N.
        phase: :data:`PHASE_RAMP`, :data:`PHASE_HOLD` or :data:`PHASE_SAMPLE` per period.
    """

    target: np.ndarray
    driven_target: np.ndarray
    displacement: np.ndarray
    force: np.ndarray
    settled: bool
    ramp_ticks: int
    hold_ticks: int
    time: np.ndarray
    command: np.ndarray
    measured_displacement: np.ndarray
    measured_force: np.ndarray
    phase: np.ndarray

    @property
    def duration(self) -> float:
        """Time the step took, s."""
        if self.time.size == 0:
            return 0.0
        return float(self.time[-1] - self.time[0]) + _period(self.time)


def _period(time: np.ndarray) -> float:
    return float(time[1] - time[0]) if time.size > 1 else 0.0


class SettleTimeoutError(DriverError):
    """The actuator did not settle within the timeout (a fault).

    Attributes:
        execution: The unsettled step with its trajectory, for recording.
    """

    def __init__(self, message: str, execution: StepExecution) -> None:
        """Create the error with its one-line ``message`` and the partial ``execution``."""
        super().__init__(message)
        self.execution = execution


class RampHoldExecutor:
    """Executes steps on an emulator by ramp-and-hold (see the module docstring).

    The ramp starts from the executor's current command: the previous driven target, the
    emulator's command when the executor was created, or the position set by :meth:`hold` or
    :meth:`sync`. The command path is therefore continuous.
    """

    def __init__(
        self,
        emulator: ServoHydraulicEmulator,
        parameters: RampHoldParameters | Mapping[str, Any] | None = None,
        *,
        errors: ErrorModel | None = None,
        **settings: Any,
    ) -> None:
        """Create the executor.

        Args:
            emulator: The emulator to drive (``tick``, ``rate``, ``n_dof``, ``command``,
                ``measured_displacement``).
            parameters: The parameters, or a mapping of them; defaults if omitted.
            errors: Optional experimental errors injected per step: the driven target gets the
                systematic error and the delay, the averaged measurement the noise and bias.
            **settings: Individual parameters (``ramp_time=0.2``, ``samples=20``, ...),
                overriding ``parameters``.

        Raises:
            BridgeConfigError: On invalid parameters or error model.
        """
        if parameters is None:
            parameters = RampHoldParameters()
        elif isinstance(parameters, Mapping):
            parameters = RampHoldParameters.from_mapping(parameters)
        elif not isinstance(parameters, RampHoldParameters):
            msg = (
                'RampHoldExecutor: parameters must be RampHoldParameters or a mapping, got '
                f'{type(parameters).__name__}'
            )
            raise BridgeConfigError(msg)
        if settings:
            merged = {f.name: getattr(parameters, f.name) for f in fields(parameters)}
            if 'ramp_velocity' in settings and 'ramp_time' not in settings:
                merged['ramp_time'] = None
            if 'ramp_time' in settings and 'ramp_velocity' not in settings:
                merged['ramp_velocity'] = None
            parameters = RampHoldParameters.from_mapping({**merged, **settings},
                                                         'RampHoldExecutor')
        self._emulator = emulator
        self._p = parameters
        self._n = int(emulator.n_dof)
        self._errors = errors
        self._injector = (
            None if errors is None else ErrorInjector(errors, self._n, emulator.command)
        )
        self._command = np.array(emulator.command, dtype=float)

    @property
    def emulator(self) -> ServoHydraulicEmulator:
        """The emulator."""
        return self._emulator

    @property
    def parameters(self) -> RampHoldParameters:
        """The ramp-and-hold parameters."""
        return self._p

    @property
    def errors(self) -> ErrorModel | None:
        """The injected error model, if any."""
        return self._errors

    @property
    def n_dof(self) -> int:
        """Number of DOF."""
        return self._n

    @property
    def command(self) -> np.ndarray:
        """Current (held) command per DOF, m."""
        return self._command.copy()

    def hold(self) -> None:
        """Hold where the actuator is: the command becomes the last measured displacement.

        Nothing is simulated until the next :meth:`execute`, whose ramp starts from there.
        """
        self._command = np.array(self._emulator.measured_displacement, dtype=float)

    def sync(self) -> None:
        """Take the emulator's last command as the current command (e.g. after its reset)."""
        self._command = np.array(self._emulator.command, dtype=float)

    def execute(self, target: Sequence[float] | np.ndarray) -> StepExecution:
        """Ramp to ``target``, hold until settled, average the samples.

        Args:
            target: Target displacement per DOF, m.

        Returns:
            The executed step.

        Raises:
            SettleTimeoutError: If the measurement does not settle within the timeout (the
                command stays at the target).
            DriverError: On a malformed target or an emulator failure.
        """
        p, n, emulator = self._p, self._n, self._emulator
        goal = _target(target, n)
        start = self._command
        if self._injector is None:
            driven = goal
        else:
            driven = self._injector.impose(goal, start)
        rate = float(emulator.rate)
        increment = driven - start
        ramp_ticks = _ticks(p.ramp_duration(float(np.max(np.abs(increment)))), rate)
        settle_ticks = max(1, _ticks(p.settle_time, rate))
        min_hold = _ticks(p.hold_time, rate)
        timeout_ticks = max(1, _ticks(p.timeout, rate))

        times: list[float] = []
        commands: list[np.ndarray] = []
        displacements: list[np.ndarray] = []
        forces: list[np.ndarray] = []
        phases: list[int] = []

        def run(command: np.ndarray, phase: int) -> np.ndarray:
            measurement = emulator.tick(command)
            times.append(float(measurement.time))
            commands.append(command)
            displacements.append(np.array(measurement.displacement, dtype=float))
            forces.append(np.array(measurement.force, dtype=float))
            phases.append(phase)
            return displacements[-1]

        def execution(settled: bool, displacement: np.ndarray, force: np.ndarray,
                      hold_ticks: int) -> StepExecution:
            return StepExecution(
                target=goal.copy(),
                driven_target=driven.copy(),
                displacement=displacement,
                force=force,
                settled=settled,
                ramp_ticks=ramp_ticks,
                hold_ticks=hold_ticks,
                time=np.array(times),
                command=_rows(commands, n),
                measured_displacement=_rows(displacements, n),
                measured_force=_rows(forces, n),
                phase=np.array(phases, dtype=int),
            )

        for i in range(1, ramp_ticks + 1):
            run(start + increment * (i / ramp_ticks), PHASE_RAMP)
        self._command = driven.copy()

        # Settled once every DOF stayed within the tolerance for settle_ticks periods after at
        # least min_hold periods; the next `samples` periods must stay within it too, else the
        # wait goes on. So every averaged sample is within the tolerance of the target.
        inside = 0
        held = 0
        while True:
            measured = run(driven, PHASE_HOLD)
            held += 1
            error = np.abs(measured - driven)
            inside = inside + 1 if bool(np.all(error < p.settle_tolerance)) else 0
            if inside >= settle_ticks + p.samples and held >= min_hold + p.samples:
                break
            if held >= timeout_ticks:
                dof = int(np.argmax(error))
                partial = execution(False, displacements[-1].copy(), forces[-1].copy(), held)
                msg = (
                    f'ramp-and-hold: DOF {dof} did not settle within {p.settle_tolerance:g} m of '
                    f'the target {driven[dof]:.6g} m for {p.settle_time:g} s in {p.timeout:g} s '
                    f'(last error {error[dof]:.3g} m)'
                )
                raise SettleTimeoutError(
                    msg,
                    partial,
                )
        phases[-p.samples:] = [PHASE_SAMPLE] * p.samples
        held -= p.samples

        displacement = np.mean(displacements[-p.samples:], axis=0)
        force = np.mean(forces[-p.samples:], axis=0)
        if self._injector is not None:
            displacement, force = self._injector.measure(displacement, force)
        return execution(True, displacement, force, held)


def _target(values: Any, n: int) -> np.ndarray:
    try:
        target = np.array(values, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        msg = f'ramp-and-hold: target must be {n} numbers, got {values!r}'
        raise DriverError(msg) from None
    if target.size != n:
        msg = f'ramp-and-hold: target has {target.size} values, expected {n}'
        raise DriverError(msg)
    if not np.all(np.isfinite(target)):
        msg = f'ramp-and-hold: non-finite target {target.tolist()}'
        raise DriverError(msg)
    return target


def _ticks(duration: float, rate: float) -> int:
    """Whole controller periods covering ``duration`` (rounding up, robust to float noise)."""
    return max(0, math.ceil(duration * rate - 1e-9))


def _rows(rows: list[np.ndarray], n: int) -> np.ndarray:
    return np.array(rows, dtype=float) if rows else np.zeros((0, n))

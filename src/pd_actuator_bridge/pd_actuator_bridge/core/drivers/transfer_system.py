"""The ``transfer_system`` driver: the bridge drives an actuator in continuous motion (RTHS).

The site's ``transfer_system`` section of the test file (plant, compensator, sensors,
capacity: :mod:`pd_common.rths.site`) is one :class:`pd_common.rths.ContinuousActuator` in
the bridge's process. Two clocks (parameter ``clock``):

``simulated``
    Each command is answered, before :meth:`TransferSystemDriver.command` returns, by
    :meth:`pd_common.rths.ContinuousSiteServer.handle` — the code path of the ROS-free runner
    (``./pd offline``), so the run through the node graph computes the same floats. The bridge's
    step ids ``(step, iteration)`` are the server's keys.
``realtime``
    The actuator ticks at the controller rate against the wall clock in a thread
    (:class:`pd_common.rths.realtime.RealtimeLoop`): a command sets the step's target
    (:meth:`~pd_common.rths.ContinuousActuator.set_next_target`; until it arrives the actuator
    follows the predictor and slows down), and the measurement is reported from the ticking
    thread when the step completes. Step 0 is the reading at rest (no time passes), as in
    simulated time; the ticking starts with step 1 and stops (the actuator holds) after the
    test's last step or on a hold. The deadline statistics are written to ``realtime_report``
    (a JSON file; ``run_test`` puts it next to the run's ``summary.json``: ``rths-<site>.json``)
    at the test's last step, on a hold and when the driver closes.

One actuator per site, displacement control only (force control is refused). The actuator
lives in the bridge's process: a restarted bridge has a new one at rest (``state_origin``
FRESH: the integrator holds rather than continue on it). A FAULT answer (a step whose
samples reached the actuator's capacity, a malformed command) raises
:class:`~..errors.DriverError`: the bridge holds.
"""

from __future__ import annotations

import json
import math
import threading
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from pd_common.config import SchemaError, read_test_file
from pd_common.errors import RthsError
from pd_common.protocol import Feedback, FeedbackStatus, StateOrigin
from pd_common.rths import ContinuousMeasurement, ContinuousSiteServer, continuous_from_config
from pd_common.rths.realtime import RealtimeLoop
from pd_common.specimen import HYSTERESIS_MODELS

from ..errors import BridgeConfigError, DriverError
from .base import ActuatorDriver, ActuatorMeasurement, StepId
from .registry import (
    DriverContext,
    DriverParameter,
    DriverSpec,
    FaultCallback,
    register_driver,
)

__all__ = ['CLOCKS', 'TRANSFER_SYSTEM', 'TransferSystemDriver', 'make_transfer_system_driver',
           'read_transfer_system']

#: The values of the ``clock`` parameter.
CLOCKS = ('simulated', 'realtime')
#: The test id the driver gives the site server (the bridge keeps the test ids itself).
_TEST_ID = 'bridge'
#: The interpreter's thread switch interval while ticking in real time, s (the default 5 ms
#: would let the node's executor thread hold the GIL over many controller periods).
SWITCH_INTERVAL = 2.0e-4
#: Seconds before a tick's deadline at which the ticking thread stops sleeping and spins
#: (holding the GIL): short, as its sleeps end on time (the loop's timer slack), so that the
#: executor thread that takes the next target is not kept waiting for the GIL.
SPIN = 2.0e-5


def _key(step: StepId) -> tuple[int, int]:
    """The server's ``(step, iteration)`` of a bridge step id (an int: iteration 0)."""
    if isinstance(step, tuple):
        number = int(step[0]) if step else 0
        iteration = int(step[1]) if len(step) > 1 else 0
        return number, iteration
    return int(step), 0


def _measurement(step: StepId, answer: Feedback) -> ActuatorMeasurement:
    """The measurement of the server's answer, reported for the bridge's ``step``."""
    return ActuatorMeasurement(step, tuple(answer.measured_displacement),
                               tuple(answer.restoring_force))


class TransferSystemDriver(ActuatorDriver):
    """One continuous actuator behind the bridge, in simulated or wall-clock time.

    Args:
        server: The site server (its actuator is the one driven, in both clocks).
        clock: ``'simulated'`` or ``'realtime'``.
        n_steps: The test's integration steps (the realtime report is written after the
            last); 0: unknown.
        report_path: Where the realtime statistics go (JSON); '': nowhere.
        loop: The realtime loop to use (tests: a fake clock); built on ``server.actuator``
            when ``None``.

    Attributes:
        is_open: Whether :meth:`open` was called (and :meth:`close` not since).
        hold_count: Number of :meth:`hold` calls.
        server: The :class:`~pd_common.rths.ContinuousSiteServer`.
        loop: The realtime loop (``None`` in simulated time).
    """

    driver_name = 'transfer_system'

    def __init__(self, server: ContinuousSiteServer, *, clock: str = 'simulated',
                 n_steps: int = 0, report_path: str = '',
                 loop: RealtimeLoop | None = None) -> None:
        """Create the driver (not open)."""
        super().__init__()
        if clock not in CLOCKS:
            msg = f'parameter clock: must be one of {", ".join(CLOCKS)}, got {clock!r}'
            raise BridgeConfigError(msg)
        self.server = server
        self.clock = clock
        self.n_steps = int(n_steps)
        self.report_path = report_path
        self.is_open = False
        self.hold_count = 0
        self.loop: RealtimeLoop | None = None
        if clock == 'realtime':
            self.loop = loop if loop is not None else RealtimeLoop(
                server.actuator, switch_interval=SWITCH_INTERVAL, spin=SPIN,
                cpu_latency=server.actuator.config.cpu_latency)
            self.loop.on_measurement = self._on_realtime_measurement
            self.loop.on_error = self._on_realtime_error
        self._lock = threading.Lock()
        self._pending: StepId | None = None  # realtime: the step whose target ticks
        self._position = [server.actuator.measured_displacement]
        self._force = [0.0]
        self._fault = ''
        #: Receives a fault found in the ticking thread (the node's ``on_fault``).
        self.on_fault: FaultCallback | None = None

    # -- ActuatorDriver ------------------------------------------------------------------------
    @property
    def n_dof(self) -> int:
        """One actuator."""
        return 1

    @property
    def state_origin(self) -> StateOrigin:
        """``FRESH``: the actuator lives in the bridge's process.

        A restarted bridge has a new one, at rest.
        """
        return StateOrigin.FRESH

    def force_control_problem(self) -> str | None:
        """Why force control is refused (always: continuous motion is displacement control)."""
        return ('force control not supported; the continuous actuator (transfer_system) is '
                'displacement-controlled')

    @property
    def last_force(self) -> list[float]:
        """Force of the last measurement, N (0 at rest)."""
        with self._lock:
            return list(self._force)

    def position(self) -> list[float]:
        """The measured displacement of the last answer (the reading at rest before), m."""
        with self._lock:
            return list(self._position)

    def open(self) -> None:
        """Mark the driver open (the actuator is at rest)."""
        self.is_open = True

    def close(self) -> None:
        """Stop the ticking (realtime), write the realtime report, mark the driver closed."""
        if self.loop is not None:
            self.loop.stop()
            self._write_report()
        self.is_open = False

    def hold(self) -> None:
        """Hold: in real time the ticking stops (the actuator keeps its state)."""
        self.hold_count += 1
        if self.loop is not None:
            # Not waiting: the ticking thread may be waiting for the bridge that holds.
            self.loop.stop(wait=False)
            self._write_report()

    def command(self, step: StepId, target: Sequence[float]) -> None:
        """Execute ``target`` for ``step`` (simulated: answered before returning).

        Raises:
            DriverError: Not open, a FAULT answer (the capacity reached, a malformed command),
                a step older than the last, or (realtime) a step while another is in flight.
        """
        if not self.is_open:
            msg = 'transfer_system: command() called before open()'
            raise DriverError(msg)
        if self.loop is not None:
            self._command_realtime(step, target)
            return
        number, iteration = _key(step)
        answer = self.server.handle(_TEST_ID, number, target, iteration=iteration)
        if answer is None:
            last = self.server.last
            msg = (f'transfer_system: step {number} iteration {iteration} is older than the '
                   f'last one served ({last.step if last else "?"}): the actuator moves on')
            raise DriverError(msg)
        with self._lock:
            self._position = [float(x) for x in answer.measured_displacement]
            self._force = [float(f) for f in answer.restoring_force]
        if answer.status is FeedbackStatus.FAULT:
            msg = f'transfer_system: {answer.message}'
            raise DriverError(msg)
        self._emit(_measurement(step, answer))

    # -- real time -----------------------------------------------------------------------------
    def _command_realtime(self, step: StepId, target: Sequence[float]) -> None:
        loop = self.loop
        assert loop is not None
        if self._fault:
            msg = f'transfer_system: {self._fault}'
            raise DriverError(msg)
        number, iteration = _key(step)
        values = [float(value) for value in target]
        if iteration != 0 or len(values) != 1 or not math.isfinite(values[0]):
            # The same refusals as in simulated time (one command per step, one actuator).
            answer = self.server.handle(_TEST_ID, number, values, iteration=iteration)
            text = answer.message if answer is not None else f'invalid step {step}'
            msg = f'transfer_system: {text}'
            raise DriverError(msg)
        if number == 0:  # the reading at rest: no time passes
            if loop.ticks:
                msg = ('transfer_system: continuous motion starts from rest: step 0 after '
                       f'{loop.ticks} ticks (a new test needs a new bridge)')
                raise DriverError(msg)
            answer = self.server.handle(_TEST_ID, 0, values)
            assert answer is not None
            if answer.status is FeedbackStatus.FAULT:
                msg = f'transfer_system: {answer.message}'
                raise DriverError(msg)
            self._emit(_measurement(step, answer))
            return
        with self._lock:
            if self._pending is not None:
                msg = (f'transfer_system: step {number} commanded while step '
                       f'{_key(self._pending)[0]} is in flight')
                raise DriverError(msg)
            self._pending = step
        try:
            loop.set_next_target(values[0])
            loop.start()
        except RthsError as error:
            with self._lock:
                self._pending = None
            msg = f'transfer_system: {error}'
            raise DriverError(msg) from None

    def _on_realtime_measurement(self, measurement: ContinuousMeasurement) -> None:
        """From the ticking thread: a step completed."""
        with self._lock:
            step, self._pending = self._pending, None
            self._position = [measurement.displacement]
            self._force = [measurement.force]
        server = self.server
        server.steps_served += 1
        server.peak_force = max(server.peak_force, measurement.peak_force)
        if step is None:
            return
        if measurement.capacity_exceeded:
            self._fault = (f'actuator force {measurement.peak_force:.1f} N reached the capacity '
                           f'{server.actuator.config.capacity:g} N: the run is invalid')
            if self.loop is not None:
                self.loop.stop(wait=False)
            self._report_fault(self._fault)
            return
        last = bool(self.n_steps) and measurement.step >= self.n_steps
        if last and self.loop is not None:
            self.loop.stop(wait=False)  # the test's last step: the actuator holds there
        self._emit(ActuatorMeasurement(step, (measurement.displacement,), (measurement.force,),
                                       measurement.time))
        if last:
            self._write_report()

    def _on_realtime_error(self, error: BaseException) -> None:
        """From the ticking thread: it failed (the actuator refused a tick)."""
        self._fault = f'the realtime loop stopped: {error}'
        self._report_fault(self._fault)

    def _report_fault(self, message: str) -> None:
        callback = self.on_fault
        if callback is not None:
            callback(f'transfer_system: {message}')

    def report(self) -> dict[str, Any]:
        """The realtime statistics (deadlines, slow-down, tick and step times)."""
        if self.loop is None:
            return {'clock': self.clock, 'steps': self.server.steps_served}
        return {'clock': self.clock, **self.loop.statistics().as_dict()}

    def _write_report(self) -> None:
        if not self.report_path or self.loop is None:
            return
        path = Path(self.report_path)
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
            temporary = path.with_name(path.name + '.tmp')
            temporary.write_text(json.dumps(self.report(), indent=2) + '\n', encoding='utf-8')
            temporary.replace(path)
        except OSError:
            pass  # a report must never stop the actuator


def read_transfer_system(test_file: str, site: str) -> tuple[ContinuousSiteServer, int]:
    """The site server of a site's transfer system and the test's number of steps.

    The site server of ``sites.<site>.transfer_system`` of ``test_file`` and the test's
    number of integration steps (as the ROS-free runner builds it: ``test.dt`` the
    integration step).

    Raises:
        BridgeConfigError: No test file or site, an unreadable file, no such section, or a bad
            section (one line naming the file and the key).
    """
    if not test_file:
        msg = 'parameter test_file: the transfer_system driver needs the test file'
        raise BridgeConfigError(msg)
    if not site:
        msg = 'parameter site: the transfer_system driver needs the site of the test file'
        raise BridgeConfigError(msg)
    try:
        test = read_test_file(test_file, hysteresis_models=tuple(HYSTERESIS_MODELS),
                              broken_models=HYSTERESIS_MODELS.broken)
    except SchemaError as err:  # (cannot be read, not YAML, refused: one line)
        raise BridgeConfigError(str(err)) from None
    sites = test.model.sites or {}
    settings = sites.get(site)
    where = f'{test.source}: sites.{site}.transfer_system'
    if settings is None or settings.transfer_system is None:
        msg = f'{where}: missing (the transfer_system driver runs that section)'
        raise BridgeConfigError(msg)
    dt = test.model.test.dt
    duration = test.model.test.duration
    n_steps = 0 if duration is None else round(duration / dt)
    try:
        config = continuous_from_config(test.data['sites'][site]['transfer_system'], where)
        return ContinuousSiteServer(config, dt), n_steps
    except RthsError as err:
        text = str(err)
        msg = text if text.startswith(where) else f'{where}: {text}'
        raise BridgeConfigError(msg) from None


def make_transfer_system_driver(context: DriverContext) -> TransferSystemDriver:
    """The driver of ``sites.<site>.transfer_system`` of ``test_file``.

    Raises:
        BridgeConfigError: Not one DOF, a bad clock, or what :func:`read_transfer_system`
            refuses.
    """
    parameters = context.parameters
    if context.n_dof != 1:
        msg = (f'parameter dof_names: the transfer_system driver drives one actuator, got '
               f'{context.n_dof}')
        raise BridgeConfigError(msg)
    clock = str(parameters['clock'])
    if clock not in CLOCKS:
        msg = f'parameter clock: must be one of {", ".join(CLOCKS)}, got {clock!r}'
        raise BridgeConfigError(msg)
    server, n_steps = read_transfer_system(str(parameters['test_file']),
                                           str(parameters['site']))
    driver = TransferSystemDriver(server, clock=clock, n_steps=n_steps,
                                  report_path=str(parameters['realtime_report']))
    driver.on_fault = context.on_fault
    return driver


TRANSFER_SYSTEM = DriverSpec(
    name='transfer_system',
    factory=make_transfer_system_driver,
    parameters=(
        DriverParameter('test_file', '', 'YAML test file whose specimen section is driven'),
        DriverParameter('site', '', 'the site of test_file whose transfer_system is driven'),
        DriverParameter('clock', 'simulated',
                        'simulated (each step computed at once) or realtime (wall clock)'),
        DriverParameter('realtime_report', '',
                        'JSON file of the realtime deadline statistics (empty: none)'),
    ),
    description='in-process continuous actuator (RTHS transfer system) of '
                'sites.<site>.transfer_system of test_file, simulated or wall-clock time',
)
register_driver(TRANSFER_SYSTEM)

"""The actuator bridge: a pure state machine between step commands and an actuator driver.

States:

``ready``
    Idle; the next new step is checked against the limits and, if safe, sent to the driver.
``busy``
    A step was sent to an asynchronous driver and its measurement has not arrived yet.
``holding``
    A limit or a fault occurred. The driver was told to hold position and nothing is commanded
    until an operator calls :meth:`ActuatorBridge.reset` (the hold is latched).

Steps are compared by equality and order only, so a step may be an ``int`` or a totally
ordered key such as ``(step, iteration)`` (the node uses that for implicit schemes).

Step bookkeeping (per test id; a new test id starts fresh but the actuator keeps its position):
a repeated step returns the last reply without moving, a duplicate of the step in flight returns
``None``, and a step older than the last answered one is ignored and counted.
"""

from __future__ import annotations

import math
import threading
from collections.abc import Callable, Sequence
from dataclasses import dataclass

from .driver import ActuatorDriver
from .errors import BridgeConfigError
from .limits import (
    KIND_FAULT,
    KIND_LIMIT,
    LimitViolation,
    SafetyLimits,
    check_command,
    check_feedback,
)

STATUS_OK = 'ok'
STATUS_LIMIT = KIND_LIMIT
STATUS_FAULT = KIND_FAULT

STATE_READY = 'ready'
STATE_BUSY = 'busy'
STATE_HOLDING = 'holding'

ON_LIMIT_OPTIONS = ('hold',)

ReplyCallback = Callable[['BridgeReply'], None]


@dataclass(frozen=True)
class BridgeReply:
    """The bridge's answer to one step command (published as the step feedback).

    Attributes:
        test_id: Test id of the command answered.
        step: Step number of the command answered.
        displacement: Measured (or, when holding, current) displacement per DOF, m.
        force: Measured (or, when holding, last measured) force per DOF, N; NaN before the
            first measurement.
        status: ``'ok'``, ``'limit'`` or ``'fault'``.
        message: Empty for ``'ok'``, else the one-line reason.
    """

    test_id: str
    step: int
    displacement: tuple[float, ...]
    force: tuple[float, ...]
    status: str
    message: str


class ActuatorBridge:
    """Enforces the bridge's safety limits between the integrator and an actuator driver.

    The bridge registers itself as the driver's measurement callback. A synchronous driver
    answers inside :meth:`ActuatorDriver.command`; :meth:`handle_command` then returns that
    reply. An asynchronous driver answers later; that reply is returned by
    :meth:`handle_measurement` and passed to the callback set with :meth:`set_reply_callback`.
    Every reply is delivered exactly once through one of those two paths (repeated steps and
    hold replies are returned by :meth:`handle_command`).

    Public methods are serialised by a re-entrant lock, so a driver may call back from another
    thread.
    """

    def __init__(
        self,
        driver: ActuatorDriver,
        limits: SafetyLimits,
        dof_names: Sequence[str],
        on_limit: str = 'hold',
    ) -> None:
        """Create the bridge.

        Args:
            driver: The actuator driver; the bridge sets its measurement callback.
            limits: The safety limits to enforce.
            dof_names: One unique non-empty name per driver DOF, used in messages.
            on_limit: Reaction to a limit or a fault; only ``'hold'`` is supported.

        Raises:
            BridgeConfigError: On an invalid argument.
        """
        if not isinstance(driver, ActuatorDriver):
            raise BridgeConfigError(
                f'ActuatorBridge: driver must be an ActuatorDriver, got {type(driver).__name__}'
            )
        if not isinstance(limits, SafetyLimits):
            raise BridgeConfigError(
                f'ActuatorBridge: limits must be SafetyLimits, got {type(limits).__name__}'
            )
        if on_limit not in ON_LIMIT_OPTIONS:
            raise BridgeConfigError(
                f'ActuatorBridge: on_limit must be one of {", ".join(ON_LIMIT_OPTIONS)}, '
                f'got {on_limit!r}'
            )
        if isinstance(dof_names, str):
            raise BridgeConfigError('ActuatorBridge: dof_names must be a list of names, got str')
        names = list(dof_names)
        n_dof = driver.n_dof
        if len(names) != n_dof:
            raise BridgeConfigError(
                f'ActuatorBridge: dof_names has {len(names)} names but the driver has '
                f'{n_dof} DOF'
            )
        for name in names:
            if not isinstance(name, str) or not name:
                raise BridgeConfigError(
                    f'ActuatorBridge: dof_names must be non-empty strings, got {name!r}'
                )
        if len(set(names)) != len(names):
            raise BridgeConfigError(f'ActuatorBridge: dof_names must be unique, got {names}')

        self._driver = driver
        self._limits = limits
        self._dof_names = tuple(names)
        self._n_dof = n_dof
        self._on_limit = on_limit
        self._lock = threading.RLock()
        self._reply_callback: ReplyCallback | None = None

        self._state = STATE_READY
        self._hold_status = ''
        self._hold_reason = ''
        self._displacement: tuple[float, ...] | None = None
        self._force: tuple[float, ...] = (math.nan,) * n_dof
        # Step bookkeeping.
        self._last_test_id: str | None = None
        self._last_step: int | None = None
        self._last_reply: BridgeReply | None = None
        self._in_flight: tuple[str, int] | None = None
        # Capture of a synchronous driver's answer during driver.command().
        self._capturing = False
        self._captured: BridgeReply | None = None
        # Counters.
        self._commands_received = 0
        self._ignored_commands = 0
        self._ignored_measurements = 0
        self._repeated_steps = 0
        self._violations = 0

        driver.set_measurement_callback(self._on_driver_measurement)

    # ------------------------------------------------------------------ properties

    @property
    def state(self) -> str:
        """``'ready'``, ``'busy'`` or ``'holding'``."""
        return self._state

    @property
    def hold_reason(self) -> str:
        """Why the bridge is holding (empty unless holding)."""
        return self._hold_reason

    @property
    def hold_status(self) -> str:
        """``'limit'`` or ``'fault'``: what caused the hold (empty unless holding)."""
        return self._hold_status

    @property
    def limits(self) -> SafetyLimits:
        """The enforced safety limits."""
        return self._limits

    @property
    def dof_names(self) -> tuple[str, ...]:
        """The DOF names."""
        return self._dof_names

    @property
    def in_flight(self) -> tuple[str, int] | None:
        """``(test_id, step)`` commanded and not answered yet, or ``None``."""
        return self._in_flight

    @property
    def last_reply(self) -> BridgeReply | None:
        """The reply a repeat of the last answered step would return, or ``None``."""
        return self._last_reply

    @property
    def commands_received(self) -> int:
        """Number of :meth:`handle_command` calls."""
        return self._commands_received

    @property
    def ignored_commands(self) -> int:
        """Commands ignored: stale steps, or new steps while another is in flight."""
        return self._ignored_commands

    @property
    def ignored_measurements(self) -> int:
        """Measurements ignored because they were not for the step in flight."""
        return self._ignored_measurements

    @property
    def repeated_steps(self) -> int:
        """Commands repeating the last answered step or the step in flight (no motion)."""
        return self._repeated_steps

    @property
    def violations(self) -> int:
        """Number of limits or faults that made the bridge hold."""
        return self._violations

    # ------------------------------------------------------------------ public API

    def set_reply_callback(self, callback: ReplyCallback | None) -> None:
        """Set (or clear) the function receiving replies produced by asynchronous measurements."""
        with self._lock:
            self._reply_callback = callback

    def handle_command(
        self, test_id: str, step: int, target: Sequence[float]
    ) -> BridgeReply | None:
        """Handle one step command from the integrator.

        Args:
            test_id: Test id of the command.
            step: Step number (0 is the initial displacement).
            target: Target displacement per DOF, m.

        Returns:
            The reply to publish now, or ``None`` when there is nothing to publish now (the
            command is in flight with an asynchronous driver, a duplicate of the step in flight,
            or ignored).
        """
        with self._lock:
            self._commands_received += 1
            if self._state == STATE_HOLDING:
                return self._reply(test_id, step, self._hold_status, self._hold_reason)

            same_test = test_id == self._last_test_id
            if self._in_flight is not None:
                if self._in_flight == (test_id, step):
                    self._repeated_steps += 1
                else:
                    self._ignored_commands += 1
                return None
            if same_test and self._last_reply is not None and step == self._last_step:
                self._repeated_steps += 1
                return self._last_reply
            if same_test and self._last_step is not None and step < self._last_step:
                self._ignored_commands += 1
                return None
            # A new test id has no step history: nothing is a repeat or stale. Its first answer
            # (or rejection) is recorded under the new id by _record().

            try:
                current = [float(x) for x in self._driver.position()]
            except Exception as exc:  # noqa: BLE001 - any driver failure means hold
                return self._enter_hold(
                    test_id, step, STATUS_FAULT, f'driver position() failed: {_describe(exc)}',
                    record=True,
                )
            if len(current) != self._n_dof:
                violation: LimitViolation | None = LimitViolation(
                    KIND_FAULT, 0,
                    f'driver position() has {len(current)} values but the driver has '
                    f'{self._n_dof} DOF',
                )
            else:
                violation = check_command(target, current, self._limits, self._dof_names)
            if violation is not None:
                return self._enter_hold(
                    test_id, step, violation.kind, violation.message, record=True
                )

            checked = [float(x) for x in target]
            self._in_flight = (test_id, step)
            self._state = STATE_BUSY
            self._capturing = True
            self._captured = None
            try:
                self._driver.command(step, list(checked))
            except Exception as exc:  # noqa: BLE001 - any driver failure means hold
                self._capturing = False
                if self._state == STATE_HOLDING:
                    # The driver answered with a violation (already held) and then raised.
                    captured, self._captured = self._captured, None
                    return captured
                # Record the fault as the step's answer unless the driver answered it already.
                return self._enter_hold(
                    test_id, step, STATUS_FAULT,
                    f'driver command() failed at step {step}: {_describe(exc)}',
                    record=self._in_flight == (test_id, step),
                )
            finally:
                self._capturing = False
            captured, self._captured = self._captured, None
            return captured

    def handle_measurement(
        self, step: int, displacement: Sequence[float], force: Sequence[float]
    ) -> BridgeReply | None:
        """Handle a measurement reported by the driver (normally through its callback).

        Args:
            step: Step the measurement answers.
            displacement: Measured displacement per DOF, m.
            force: Measured force per DOF, N.

        Returns:
            The reply for the step in flight (``'ok'``, or ``'limit'``/``'fault'`` after which
            the bridge holds), or ``None`` if the measurement is not for the step in flight.
        """
        with self._lock:
            if self._in_flight is None or self._in_flight[1] != step:
                self._ignored_measurements += 1
                return None
            test_id = self._in_flight[0]
            violation = check_feedback(
                displacement, force, self._limits, self._dof_names, n_dof=self._n_dof
            )
            if violation is None or violation.kind == KIND_LIMIT:
                # Finite and well formed: it is the actuator's true state.
                self._displacement = tuple(float(x) for x in displacement)
                self._force = tuple(float(f) for f in force)
            if violation is not None:
                reply = self._enter_hold(
                    test_id, step, violation.kind, violation.message, record=True
                )
            else:
                self._in_flight = None
                self._state = STATE_READY
                reply = BridgeReply(
                    test_id, step, self._displacement, self._force, STATUS_OK, ''
                )
                self._record(reply)
            if self._capturing:
                self._captured = reply
            return reply

    def handle_fault(self, message: str) -> BridgeReply | None:
        """Hold because of a fault detected outside the core (e.g. a driver timeout).

        Args:
            message: One-line reason.

        Returns:
            A ``'fault'`` reply for the step in flight, if any; else ``None``.
        """
        with self._lock:
            if self._state == STATE_HOLDING:
                return None
            if self._in_flight is not None:
                test_id, step = self._in_flight
                return self._enter_hold(test_id, step, STATUS_FAULT, message, record=True)
            self._enter_hold('', -1, STATUS_FAULT, message, record=False)
            return None

    def reset(self) -> None:
        """Leave the latched hold. This is an explicit operator action.

        The next command is checked against the limits from the actuator's current position. A
        repeat of the step that caused the hold is evaluated afresh (not answered from the hold
        reply); older steps of the same test stay ignored. Does nothing unless holding.
        """
        with self._lock:
            if self._state != STATE_HOLDING:
                return
            self._state = STATE_READY
            self._hold_status = ''
            self._hold_reason = ''
            self._in_flight = None
            self._last_reply = None

    # ------------------------------------------------------------------ internals

    def _on_driver_measurement(
        self, step: int, displacement: list[float], force: list[float]
    ) -> None:
        with self._lock:
            reply = self.handle_measurement(step, displacement, force)
            capturing = self._capturing
            callback = self._reply_callback
        if reply is not None and not capturing and callback is not None:
            callback(reply)

    def _enter_hold(
        self, test_id: str, step: int, status: str, message: str, record: bool
    ) -> BridgeReply:
        """Hold the actuator, latch the hold and return the reply for ``(test_id, step)``."""
        try:
            self._driver.hold()
        except Exception as exc:  # noqa: BLE001 - still latch the hold
            message = f'{message}; driver hold() failed: {_describe(exc)}'
        self._violations += 1
        self._state = STATE_HOLDING
        self._hold_status = status
        self._hold_reason = message
        self._in_flight = None
        reply = self._reply(test_id, step, status, message)
        if record:
            self._record(reply)
        return reply

    def _record(self, reply: BridgeReply) -> None:
        self._last_test_id = reply.test_id
        self._last_step = reply.step
        self._last_reply = reply

    def _reply(self, test_id: str, step: int, status: str, message: str) -> BridgeReply:
        return BridgeReply(
            test_id, step, self._current_displacement(), self._force, status, message
        )

    def _current_displacement(self) -> tuple[float, ...]:
        """The driver's position if readable and sane, else the last measured displacement."""
        try:
            position = tuple(float(x) for x in self._driver.position())
        except Exception:  # noqa: BLE001 - fall back to the last measurement
            position = ()
        if len(position) == self._n_dof:
            return position
        if self._displacement is not None:
            return self._displacement
        return (math.nan,) * self._n_dof


def _describe(exc: BaseException) -> str:
    return f'{type(exc).__name__}: {exc}'

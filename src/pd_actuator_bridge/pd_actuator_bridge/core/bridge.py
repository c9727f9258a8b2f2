"""The actuator bridge: a pure state machine between step commands and an actuator driver.

States:

``ready``
    Idle; the next new step is checked against the limits and, if safe, sent to the driver.
``busy``
    A step was sent to an asynchronous driver and its measurement has not arrived yet.
``holding``
    A limit or a fault occurred. The driver was told to hold position and nothing is commanded
    until an operator calls :meth:`ActuatorBridge.reset` (the hold is latched).

Safety interlocks (all enforced here, whatever the integrator sends):

* Command limits (:func:`~.limits.check_command`): non-finite or malformed targets are faults;
  |x| <= max_displacement, |x - position| <= max_increment and the mean velocity over
  step_duration <= max_velocity, where position is the driver's own :meth:`position`.
* Measurement checks when a step is answered: non-finite or malformed values (fault),
  |f| <= max_force (limit), and feedback plausibility |measured - commanded| <=
  tracking_tolerance (fault, :func:`~.limits.check_tracking`).
* Command watchdog (:meth:`ActuatorBridge.check_watchdog`): while armed (a command was received
  since the start or the last reset) and not holding, more than ``watchdog_timeout`` seconds
  without a command holds with a fault. It is evaluated on every command and every
  :meth:`~ActuatorBridge.check_watchdog` call, so it does not depend on how often the node polls.
* Emergency stop (:meth:`ActuatorBridge.emergency_stop`): holds at once from any state and is
  latched: a plain :meth:`~ActuatorBridge.reset` refuses to clear it; only
  ``reset(clear_emergency=True)`` does. It is a software stop and no substitute for the
  hardware emergency-stop circuit of the hydraulics.

Behaviour on a command beyond a limit (``on_limit``):

``'hold'`` (default)
    Hold and answer the step with ``'limit'`` and the reason; nothing moves until a reset.
``'saturate'``
    Clip each DOF to the nearest allowed value (:func:`~.limits.saturate_command`), send the
    clipped target and answer the step with the measured values, status ``'limit'`` and a
    message ``'saturated: ...'`` naming what was clipped: never silently. The bridge does not
    hold. Meant for quasi-static and manual moves (e.g. jogging an actuator to a position):
    the integrator holds on any non-``'ok'`` status anyway. Faults (NaN, inf, malformed data),
    measurement violations, the watchdog and the emergency stop always hold.

Mixed control (``docs/force_control.md``): a command may give each DOF a control mode and a
target force (:meth:`handle_command`'s ``control_mode`` and ``target_force``, as in
:class:`pd_common.protocol.Command`). Inconsistent modes or forces are a FAULT (nothing moves),
and so is force control with a driver that does not support it
(:meth:`~.drivers.base.ActuatorDriver.force_control_problem`). Before anything moves:
the displacement limits above on the displacement-controlled DOFs (from the measured
position) and |target_force| <= max_force on the force-controlled ones (LIMIT). The force of
each force-controlled DOF then goes from the force it holds (its last commanded force, 0 at
the start) to the target through
:func:`pd_common.experimental.force_ramp.force_ramp` sub-steps of at most
``max_force_increment`` (each DOF along its own ramp; one that arrives earlier holds its
target; the displacement-controlled DOFs at their targets from the first sub-step), each sent
to the driver (:meth:`~.drivers.base.ActuatorDriver.command_force`) and answered before the
next. After each sub-step: the measurement checks above (max_force on every DOF; tracking on
the displacement-controlled ones) and, on every DOF, the measured stroke within
max_displacement and its change since the step began within max_increment
(:func:`~.limits.check_strokes`): a force-controlled actuator running away holds the test
with a LIMIT naming it, and no further sub-step is sent. The step is answered with the last
sub-step's measurement. :meth:`ramp_down` (lifecycle deactivation) ramps the force-controlled
DOFs down to 0 N through the same sub-steps and checks. A mixed command is never saturated
(``on_limit='saturate'`` clips displacement-only commands); a command whose modes are all
displacement is served exactly as a plain one.

Steps are compared by equality and order only, so a step may be an ``int`` or a totally
ordered key such as ``(step, iteration)`` (the node uses that for implicit schemes). A key that
cannot be ordered against the test's last step (e.g. an ``int`` after tuples) is foreign: it is
ignored and counted like a stale step.

Step bookkeeping (per test id; a new test id starts fresh but the actuator keeps its position):
a repeated step returns the last reply without moving, a duplicate of the step in flight returns
``None``, and a step older than the last answered one is ignored and counted.
"""

from __future__ import annotations

import math
import operator
import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass

from pd_common.experimental.force_ramp import force_ramp
from pd_common.protocol import ControlMode, FeedbackStatus

from .drivers.base import ActuatorDriver, StepId
from .errors import BridgeConfigError
from .limits import (
    KIND_FAULT,
    KIND_LIMIT,
    LimitViolation,
    SafetyLimits,
    check_command,
    check_control,
    check_feedback,
    check_strokes,
    check_target_force,
    check_tracking,
    saturate_command,
)
from .limits import dof_label as _dof_label
from .limits import format_value as _fmt

STATUS_OK = FeedbackStatus.OK
STATUS_LIMIT = FeedbackStatus.LIMIT
STATUS_FAULT = FeedbackStatus.FAULT

STATE_READY = 'ready'
STATE_BUSY = 'busy'
STATE_HOLDING = 'holding'

ON_LIMIT_HOLD = 'hold'
ON_LIMIT_SATURATE = 'saturate'
ON_LIMIT_OPTIONS = (ON_LIMIT_HOLD, ON_LIMIT_SATURATE)

SATURATED_PREFIX = 'saturated: '

#: Most sub-steps of one force ramp (a command's, or a ramp-down's): a command's sub-steps and
#: its ramp-down's are numbered together below ``2 * MAX_FORCE_SUBSTEPS`` (=
#: :data:`~.drivers.base.SUBSTEP_STRIDE`, what :func:`~.drivers.base.force_substep_key`
#: carries).
MAX_FORCE_SUBSTEPS = 32768

ReplyCallback = Callable[['BridgeReply'], None]


@dataclass(frozen=True)
class BridgeReply:
    """The bridge's answer to one step command (published as the step feedback).

    Attributes:
        test_id: Test id of the command answered.
        step: Step (number or ``(step, iteration)`` key) of the command answered.
        displacement: Measured (or, when holding, current) displacement per DOF, m.
        force: Measured (or, when holding, last measured) force per DOF, N; NaN before the
            first measurement.
        status: ``OK``, ``LIMIT`` or ``FAULT`` (:class:`pd_common.protocol.FeedbackStatus`).
        message: Empty for ``'ok'``, else the one-line reason; it starts with ``'saturated: '``
            for a step executed with a clipped target (``on_limit='saturate'``).
    """

    test_id: str
    step: StepId
    displacement: tuple[float, ...]
    force: tuple[float, ...]
    status: FeedbackStatus
    message: str


@dataclass
class _ForceRamp:
    """The sub-steps of a mixed command (or a ramp-down) being executed."""

    test_id: str
    step: StepId | None  # the integrator's step answered at the end; None: a ramp-down
    key: tuple[int, ...]  # the driver's sub-step ids are (*key, first + index)
    first: int
    modes: tuple[int, ...]
    force_controlled: tuple[bool, ...]
    targets: tuple[float, ...]  # the displacement-controlled DOFs' targets
    forces: list[tuple[float, ...]]  # per sub-step, the force targets
    start: tuple[float, ...]  # the strokes when the step began
    index: int = 0

    @property
    def current_id(self) -> tuple[int, ...]:
        """The driver's id of the sub-step in flight."""
        return (*self.key, self.first + self.index)

    @property
    def where(self) -> str:
        """`` at force ramp sub-step i of n`` (or of the ramp-down) for messages."""
        what = 'force ramp-down' if self.step is None else 'force ramp'
        return f' at {what} sub-step {self.index + 1} of {len(self.forces)}'


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
        on_limit: str = ON_LIMIT_HOLD,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        """Create the bridge.

        Args:
            driver: The actuator driver; the bridge sets its measurement callback.
            limits: The safety limits to enforce.
            dof_names: One unique non-empty name per driver DOF, used in messages.
            on_limit: Reaction to a command beyond a limit: ``'hold'`` (hold and report) or
                ``'saturate'`` (clip, send and report; for quasi-static and manual moves only).
                Faults always hold.
            clock: Monotonic time in seconds, used by the command watchdog when no explicit
                time is passed to :meth:`handle_command` or :meth:`check_watchdog`.

        Raises:
            BridgeConfigError: On an invalid argument.
        """
        if not isinstance(driver, ActuatorDriver):
            msg = f'ActuatorBridge: driver must be an ActuatorDriver, got {type(driver).__name__}'
            raise BridgeConfigError(msg)
        if not isinstance(limits, SafetyLimits):
            msg = f'ActuatorBridge: limits must be SafetyLimits, got {type(limits).__name__}'
            raise BridgeConfigError(msg)
        if on_limit not in ON_LIMIT_OPTIONS:
            msg = (
                f'ActuatorBridge: on_limit must be one of {ON_LIMIT_HOLD}, got {on_limit!r} '
                f'(or {ON_LIMIT_SATURATE!r}, for quasi-static and manual moves only)'
            )
            raise BridgeConfigError(msg)
        if not callable(clock):
            msg = 'ActuatorBridge: clock must be callable'
            raise BridgeConfigError(msg)
        if isinstance(dof_names, str):
            msg = 'ActuatorBridge: dof_names must be a list of names, got str'
            raise BridgeConfigError(msg)
        names = list(dof_names)
        n_dof = driver.n_dof
        if len(names) != n_dof:
            msg = (
                f'ActuatorBridge: dof_names has {len(names)} names but the driver has '
                f'{n_dof} DOF'
            )
            raise BridgeConfigError(msg)
        for name in names:
            if not isinstance(name, str) or not name:
                msg = f'ActuatorBridge: dof_names must be non-empty strings, got {name!r}'
                raise BridgeConfigError(msg)
        if len(set(names)) != len(names):
            msg = f'ActuatorBridge: dof_names must be unique, got {names}'
            raise BridgeConfigError(msg)

        self._driver = driver
        self._limits = limits
        self._dof_names = tuple(names)
        self._n_dof = n_dof
        self._on_limit = on_limit
        self._clock = clock
        self._lock = threading.RLock()
        self._reply_callback: ReplyCallback | None = None

        self._state = STATE_READY
        self._hold_status: FeedbackStatus | None = None
        self._hold_reason = ''
        self._displacement: tuple[float, ...] | None = None
        self._force: tuple[float, ...] = (math.nan,) * n_dof
        # Step bookkeeping.
        self._last_test_id: str | None = None
        self._last_step: StepId | None = None
        self._last_reply: BridgeReply | None = None
        self._in_flight: tuple[str, StepId] | None = None
        self._commanded: tuple[float, ...] | None = None  # target sent for the step in flight
        self._saturation_note = ''  # what was clipped for the step in flight
        self._last_command: tuple[str, StepId] | None = None  # last (test_id, step) received
        # Interlocks.
        self._emergency: str | None = None  # the latched emergency-stop reason
        self._watchdog_armed = False
        self._last_command_time = math.nan
        # Capture of a synchronous driver's answer during driver.command().
        self._capturing = False
        self._captured: BridgeReply | None = None
        # Counters.
        self._commands_received = 0
        self._ignored_commands = 0
        self._ignored_measurements = 0
        self._repeated_steps = 0
        self._violations = 0
        self._saturations = 0
        self._watchdog_trips = 0
        self._emergency_stops = 0
        # Force control.
        self._held_force: tuple[float, ...] = (0.0,) * n_dof  # last commanded force per DOF
        self._force_modes: tuple[bool, ...] = (False,) * n_dof  # of the last command executed
        self._ramp: _ForceRamp | None = None  # sub-steps in execution
        self._substep_done = False  # a synchronous driver answered the sub-step just sent
        self._next_substep: tuple[str, tuple[int, ...], int] | None = None  # after the last ramp
        self._ramp_down_note = ''
        self._force_substeps = 0

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
    def hold_status(self) -> FeedbackStatus | None:
        """``LIMIT`` or ``FAULT``: what caused the hold (``None`` unless holding)."""
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
    def in_flight(self) -> tuple[str, StepId] | None:
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

    @property
    def on_limit(self) -> str:
        """``'hold'`` or ``'saturate'``."""
        return self._on_limit

    @property
    def saturations(self) -> int:
        """Number of commands sent with a clipped target (``on_limit='saturate'``)."""
        return self._saturations

    @property
    def emergency_stopped(self) -> bool:
        """Whether an emergency stop is latched (clear it with ``reset(clear_emergency=True)``)."""
        return self._emergency is not None

    @property
    def emergency_stops(self) -> int:
        """Number of :meth:`emergency_stop` calls."""
        return self._emergency_stops

    @property
    def watchdog_armed(self) -> bool:
        """Whether the command watchdog runs (a command arrived since the start or last reset)."""
        return self._watchdog_armed and self._limits.watchdog_timeout is not None

    @property
    def watchdog_trips(self) -> int:
        """Number of holds caused by the command watchdog."""
        return self._watchdog_trips

    @property
    def held_force(self) -> tuple[float, ...]:
        """Per DOF the force last commanded to it under force control, N (0 at the start, or
        the measured force a restarted bridge adopted: :meth:`adopt_held_force`)."""
        return self._held_force

    def adopt_held_force(self, measured: Sequence[float]) -> bool:
        """Take the actuators' measured forces as the forces they hold, before this bridge has
        commanded any: a restarted bridge ramps from the load the specimen carries (e.g. a
        column's axial load), never from 0 N back up. ``False`` (nothing changed) once a force
        was commanded, or for a measurement of the wrong size or with a non-finite value.
        """
        values = [float(value) for value in measured]
        if (self._force_substeps or len(values) != len(self._held_force)
                or not all(math.isfinite(value) for value in values)):
            return False
        self._held_force = tuple(values)
        return True

    @property
    def force_controlled(self) -> tuple[bool, ...]:
        """Per DOF whether the last command executed force-controlled it."""
        return self._force_modes

    @property
    def force_substeps(self) -> int:
        """Number of force sub-steps sent to the driver (commands and ramp-downs)."""
        return self._force_substeps

    @property
    def ramping_down(self) -> bool:
        """Whether a :meth:`ramp_down` is still executing (an asynchronous driver)."""
        return self._ramp is not None and self._ramp.step is None

    @property
    def ramp_down_note(self) -> str:
        """One line on the last :meth:`ramp_down`: what it did, or why it stopped."""
        return self._ramp_down_note

    # ------------------------------------------------------------------ public API

    def set_reply_callback(self, callback: ReplyCallback | None) -> None:
        """Set (or clear) the function receiving replies produced by asynchronous measurements."""
        with self._lock:
            self._reply_callback = callback

    def handle_command(
        self, test_id: str, step: StepId, target: Sequence[float], now: float | None = None,
        *, control_mode: Sequence[int] = (), target_force: Sequence[float] = (),
    ) -> BridgeReply | None:
        """Handle one step command from the integrator.

        Args:
            test_id: Test id of the command.
            step: Step number (0 is the initial displacement), or a totally ordered key such as
                ``(step, iteration)``.
            target: Target displacement per DOF, m (a force-controlled DOF: the displacement
                last measured there, checked finite, not imposed).
            now: Arrival time (monotonic seconds) for the command watchdog; the bridge's clock
                if omitted. If the watchdog has expired, the bridge holds before anything else.
            control_mode: Per DOF :class:`pd_common.protocol.ControlMode` (0 displacement,
                1 force); empty (the default): every DOF displacement-controlled.
            target_force: Per DOF the force a force-controlled DOF is to hold, N (one per DOF
                with modes, none without).

        Returns:
            The reply to publish now, or ``None`` when there is nothing to publish now (the
            command is in flight with an asynchronous driver, a duplicate of the step in flight,
            or ignored).
        """
        with self._lock:
            self._commands_received += 1
            self._last_command = (test_id, step)
            if self._state != STATE_HOLDING:
                time_now = self._time(now)
                self._check_watchdog_locked(time_now)
                if self._state != STATE_HOLDING:
                    self._watchdog_armed = True
                    self._last_command_time = time_now
            if self._state == STATE_HOLDING:
                return self._reply(test_id, step, self._hold_status or STATUS_FAULT,
                                   self._hold_reason)

            same_test = test_id == self._last_test_id
            if self._in_flight is not None:
                if self._in_flight == (test_id, step):
                    self._repeated_steps += 1
                else:
                    self._ignored_commands += 1
                return None
            if self._ramp is not None:  # ramping down (deactivation): nothing else moves
                self._ignored_commands += 1
                return None
            if same_test and self._last_reply is not None and step == self._last_step:
                self._repeated_steps += 1
                return self._last_reply
            if same_test and self._last_step is not None and _older(step, self._last_step):
                self._ignored_commands += 1
                return None
            # A new test id has no step history: nothing is a repeat or stale. Its first answer
            # (or rejection) is recorded under the new id by _record().

            force_controlled, forces, control = check_control(
                control_mode, target_force, self._n_dof, self._dof_names)
            if control is not None:
                return self._enter_hold(test_id, step, STATUS_FAULT,
                                        f'invalid control: {control.message}', record=True)
            if any(force_controlled):
                return self._start_mixed(test_id, step, target, force_controlled, forces)

            current = self._measured_position(test_id, step)
            if isinstance(current, BridgeReply):
                return current
            violation = self._command_violation(target, current)
            note = ''
            checked: list[float] = []
            if (violation is not None and violation.kind == KIND_LIMIT
                    and self._on_limit == ON_LIMIT_SATURATE):
                saturation = saturate_command(target, current, self._limits, self._dof_names)
                violation = saturation.violation
                if saturation.target is not None:
                    checked = list(saturation.target)
                    note = saturation.message
            if violation is not None:
                return self._enter_hold(
                    test_id, step, violation.kind, violation.message, record=True
                )
            if not note:
                checked = [float(x) for x in target]
            else:
                self._saturations += 1

            self._commanded = tuple(checked)
            self._saturation_note = note
            self._force_modes = (False,) * self._n_dof
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
        self, step: StepId, displacement: Sequence[float], force: Sequence[float]
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
            if self._ramp is not None:
                if step != self._ramp.current_id:
                    self._ignored_measurements += 1
                    return None
                return self._ramp_measurement(displacement, force)
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
            if violation is None and self._commanded is not None:
                violation = check_tracking(
                    displacement, self._commanded, self._limits, self._dof_names
                )
            if violation is not None:
                reply = self._enter_hold(
                    test_id, step, violation.kind, violation.message, record=True
                )
            else:
                note = self._saturation_note
                self._in_flight = None
                self._commanded = None
                self._saturation_note = ''
                self._state = STATE_READY
                if note:
                    status, message = STATUS_LIMIT, SATURATED_PREFIX + note
                else:
                    status, message = STATUS_OK, ''
                # No violation: the measurement was stored as the displacement above.
                assert self._displacement is not None
                reply = BridgeReply(
                    test_id, step, self._displacement, self._force, status, message
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

    def check_watchdog(self, now: float | None = None) -> BridgeReply | None:
        """Hold if no command arrived for longer than ``watchdog_timeout`` while armed.

        The watchdog is armed by the first command received while not holding and disarmed by
        :meth:`reset`; it is idle while holding and when ``watchdog_timeout`` is ``None``.
        Exactly ``watchdog_timeout`` seconds since the last command is still allowed. A
        non-finite time holds (a broken clock must not disable the watchdog).

        Args:
            now: Current time (monotonic seconds, the same clock as the command times); the
                bridge's clock if omitted.

        Returns:
            When the watchdog trips, the ``'fault'`` reply for the step in flight, or else for the
            last command received (not recorded as its answer); ``None`` otherwise.
        """
        with self._lock:
            if self._state == STATE_HOLDING:
                return None
            return self._check_watchdog_locked(self._time(now))

    def emergency_stop(self, reason: str = '') -> BridgeReply | None:
        """Hold at once from any state and latch the emergency stop.

        The driver is told to hold even if the bridge was already holding (the hold reason then
        becomes the emergency stop). Only ``reset(clear_emergency=True)`` clears it. This is a
        software stop: it takes the bridge lock, so it waits for a driver ``command()`` call in
        progress (drivers only start a move there); it does not replace the hardware
        emergency-stop circuit.

        Args:
            reason: One-line reason (e.g. ``'operator button'``), included in the hold reason.

        Returns:
            The ``'fault'`` reply for the step in flight, or else for the last command received
            (not recorded as its answer); ``None`` if the bridge was already holding or has not
            received a command yet. The hold reason is :attr:`hold_reason` in every case.
        """
        text = ' '.join(str(reason).split())
        message = f'emergency stop: {text}' if text else 'emergency stop'
        with self._lock:
            self._emergency = message
            self._emergency_stops += 1
            if self._state != STATE_HOLDING:
                return self._hold_now(STATUS_FAULT, message)
            try:
                self._driver.hold()
            except Exception as exc:  # noqa: BLE001 - still latch the emergency stop
                message = f'{message}; driver hold() failed: {_describe(exc)}'
            self._hold_status = STATUS_FAULT
            self._hold_reason = message
            return None

    def reset(self, clear_emergency: bool = False) -> bool:
        """Leave the latched hold. This is an explicit operator action.

        The next command is checked against the limits from the actuator's current position. A
        repeat of the step that caused the hold is evaluated afresh (not answered from the hold
        reply); older steps of the same test stay ignored. The command watchdog is disarmed
        until the next command. Does nothing unless holding.

        A latched emergency stop is not cleared by a plain reset: the call is refused (returns
        ``False``, nothing changes). ``clear_emergency=True`` clears it together with the hold.

        Args:
            clear_emergency: Also clear a latched emergency stop.

        Returns:
            ``False`` if refused because of a latched emergency stop, else ``True``.
        """
        with self._lock:
            if self._emergency is not None and not clear_emergency:
                return False
            self._emergency = None
            if self._state != STATE_HOLDING:
                return True
            self._state = STATE_READY
            self._hold_status = None
            self._hold_reason = ''
            self._in_flight = None
            self._commanded = None
            self._saturation_note = ''
            self._last_reply = None
            self._watchdog_armed = False
            self._ramp = None
            return True

    def ramp_down(self) -> str:
        """Ramp the force-controlled DOFs down to 0 N (lifecycle deactivation), never a jump.

        The DOFs the last command force-controlled go from the force they hold to 0 through
        the force ramp's sub-steps (``max_force_increment``), the other DOFs held where they
        are measured; each sub-step is checked like a mixed command's (a runaway or a force
        beyond max_force holds). A synchronous driver finishes inside this call; with an
        asynchronous one the sub-steps continue as its measurements arrive
        (:attr:`ramping_down`) and :attr:`ramp_down_note` says how it ended. Nothing is
        ramped while holding (the hold is latched: the forces stay; reset first) or while a
        step is in flight.

        Returns:
            One line saying what is ramped down (or why not); empty if no force is held.
        """
        with self._lock:
            controlled = self._force_modes
            loaded = [dof for dof in range(self._n_dof)
                      if controlled[dof] and self._held_force[dof] != 0.0]
            if not loaded:
                return ''
            held = ', '.join(f'{_dof_label(dof, self._dof_names)} at '
                             f'{_fmt(self._held_force[dof])} N' for dof in loaded)
            if self._state == STATE_HOLDING:
                note = (f'force not ramped down (holding: {self._hold_reason}): {held} '
                        'kept; reset the hold, then deactivate again to ramp down')
                self._ramp_down_note = note
                return note
            if self._state != STATE_READY or self._in_flight is not None:
                note = f'force not ramped down (a step is in flight): {held} kept'
                self._ramp_down_note = note
                return note
            try:
                current = tuple(float(x) for x in self._driver.position())
            except Exception as exc:  # noqa: BLE001 - any driver failure means hold
                current = ()
                problem = f'driver position() failed: {_describe(exc)}'
            else:
                problem = (f'driver position() has {len(current)} values but the driver has '
                           f'{self._n_dof} DOF') if len(current) != self._n_dof else ''
            if not problem and not all(math.isfinite(x) for x in current):
                problem = f'driver position() is not finite: {list(current)}'
            if problem:
                self._enter_hold('', -1, STATUS_FAULT, f'force ramp-down: {problem}',
                                 record=False)
                note = f'force not ramped down ({problem}): {held} kept; holding'
                self._ramp_down_note = note
                return note
            zeros = tuple(0.0 if on else force
                          for on, force in zip(controlled, self._held_force))
            forces = self._force_plan(controlled, zeros)
            if len(forces) > MAX_FORCE_SUBSTEPS:
                note = (f'force not ramped down (it needs {len(forces)} sub-steps, more than '
                        f'{MAX_FORCE_SUBSTEPS}): {held} kept')
                self._ramp_down_note = note
                return note
            test_id, key, first = self._next_substep or (self._last_test_id or '', (0,), 0)
            self._ramp = _ForceRamp(
                test_id=test_id, step=None, key=key, first=first,
                modes=tuple(int(ControlMode.FORCE if on else ControlMode.DISPLACEMENT)
                            for on in controlled),
                force_controlled=controlled, targets=current, forces=forces, start=current)
            self._next_substep = (test_id, key, first + len(forces))
            self._ramp_down_note = (f'ramping force down to 0 N in {len(forces)} sub-steps '
                                    f'(max_force_increment '
                                    f'{_fmt(self._limits.max_force_increment)} N): {held}')
            note = self._ramp_down_note
            self._state = STATE_BUSY
            self._run_ramp()
            return note

    # ------------------------------------------------------------------ force control

    def _force_plan(self, force_controlled: tuple[bool, ...], forces: Sequence[float]
                    ) -> list[tuple[float, ...]]:
        """Per sub-step the force targets (0 on the displacement-controlled DOFs).

        Each force-controlled DOF follows ``force_ramp(held, target, max_force_increment)``; one
        that arrives earlier holds its target; at least one sub-step.
        """
        increment = self._limits.max_force_increment
        ramps = {dof: force_ramp(self._held_force[dof], float(forces[dof]), increment)
                 for dof in range(self._n_dof) if force_controlled[dof]}
        count = max([1, *(len(ramp) for ramp in ramps.values())])
        plan = []
        for sub in range(count):
            values = [0.0] * self._n_dof
            for dof, ramp in ramps.items():
                values[dof] = ramp[min(sub, len(ramp) - 1)] if ramp else float(forces[dof])
            plan.append(tuple(values))
        return plan

    def _measured_position(self, test_id: str, step: StepId) -> list[float] | BridgeReply:
        """The driver's measured position, or the hold reply if reading it failed."""
        try:
            return [float(x) for x in self._driver.position()]
        except Exception as exc:  # noqa: BLE001 - any driver failure means hold
            return self._enter_hold(
                test_id, step, STATUS_FAULT, f'driver position() failed: {_describe(exc)}',
                record=True,
            )

    def _command_violation(self, target: Sequence[float], current: list[float],
                           displacement_controlled: Sequence[bool] | None = None
                           ) -> LimitViolation | None:
        """What is wrong with commanding ``target`` from ``current`` (``None``: nothing)."""
        if len(current) != self._n_dof:
            return LimitViolation(
                KIND_FAULT, 0,
                f'driver position() has {len(current)} values but the driver has '
                f'{self._n_dof} DOF',
            )
        return check_command(target, current, self._limits, self._dof_names,
                             displacement_controlled=displacement_controlled)

    def _start_mixed(self, test_id: str, step: StepId, target: Sequence[float],
                     force_controlled: tuple[bool, ...], forces: tuple[float, ...]
                     ) -> BridgeReply | None:
        """Check a mixed command before anything moves, then run its force ramp."""
        problem = self._driver.force_control_problem()
        if problem is not None:
            name = self._driver.driver_name or type(self._driver).__name__
            return self._enter_hold(test_id, step, STATUS_FAULT, f'driver {name}: {problem}',
                                    record=True)
        current = self._measured_position(test_id, step)
        if isinstance(current, BridgeReply):
            return current
        violation = self._command_violation(
            target, current, tuple(not flag for flag in force_controlled))
        if violation is None:
            violation = check_target_force(forces, force_controlled, self._limits,
                                           self._dof_names)
        plan: list[tuple[float, ...]] = []
        if violation is None:
            plan = self._force_plan(force_controlled, forces)
            if len(plan) > MAX_FORCE_SUBSTEPS:
                violation = LimitViolation(
                    KIND_LIMIT, 0,
                    f'force ramp needs {len(plan)} sub-steps, more than {MAX_FORCE_SUBSTEPS} '
                    f'(max_force_increment {_fmt(self._limits.max_force_increment)} N); '
                    'nothing moved')
        if violation is not None:
            return self._enter_hold(test_id, step, violation.kind, violation.message,
                                    record=True)
        key = tuple(int(x) for x in step) if isinstance(step, tuple) else (int(step),)
        targets = tuple(float(x) for x in target)
        self._ramp = _ForceRamp(
            test_id=test_id, step=step, key=key, first=0,
            modes=tuple(int(ControlMode.FORCE if flag else ControlMode.DISPLACEMENT)
                        for flag in force_controlled),
            force_controlled=force_controlled, targets=targets, forces=plan,
            start=tuple(current))
        self._next_substep = (test_id, key, len(plan))
        self._force_modes = force_controlled
        self._commanded = targets
        self._in_flight = (test_id, step)
        self._state = STATE_BUSY
        return self._run_ramp()

    def _run_ramp(self) -> BridgeReply | None:
        """Send sub-steps of the ramp in execution while the driver answers synchronously.

        Returns:
            The step's reply (its last sub-step answered, or a hold); ``None`` while an
            asynchronous driver has a sub-step in flight, or for a ramp-down.
        """
        while self._ramp is not None:
            ramp = self._ramp
            forces = ramp.forces[ramp.index]
            measured = self._displacement if self._displacement is not None else ramp.start
            if len(measured) != self._n_dof:  # pragma: no cover - checked when stored
                measured = ramp.start
            targets = [measured[dof] if ramp.force_controlled[dof] else ramp.targets[dof]
                       for dof in range(self._n_dof)]
            self._held_force = tuple(
                forces[dof] if ramp.force_controlled[dof] else self._held_force[dof]
                for dof in range(self._n_dof))
            self._force_substeps += 1
            self._capturing = True
            self._captured = None
            self._substep_done = False
            try:
                self._driver.command_force(ramp.current_id, targets, ramp.modes, list(forces))
            except Exception as exc:  # noqa: BLE001 - any driver failure means hold
                self._capturing = False
                if self._state == STATE_HOLDING:
                    captured, self._captured = self._captured, None
                    return captured
                where = ramp.where
                return self._ramp_hold(
                    STATUS_FAULT, f'driver command_force() failed{where}: {_describe(exc)}')
            finally:
                self._capturing = False
            if self._substep_done and self._ramp is ramp:
                self._substep_done = False
                continue  # answered synchronously: the next sub-step
            captured, self._captured = self._captured, None
            return captured
        return None

    def _ramp_measurement(self, displacement: Sequence[float], force: Sequence[float]
                          ) -> BridgeReply | None:
        """A sub-step answered: check it, then the next sub-step or the step's reply."""
        ramp = self._ramp
        assert ramp is not None
        violation = check_feedback(
            displacement, force, self._limits, self._dof_names, n_dof=self._n_dof
        )
        if violation is None or violation.kind == KIND_LIMIT:
            self._displacement = tuple(float(x) for x in displacement)
            self._force = tuple(float(f) for f in force)
        if violation is None:
            violation = check_tracking(
                displacement, ramp.targets, self._limits, self._dof_names,
                displacement_controlled=tuple(not flag for flag in ramp.force_controlled))
        if violation is not None:
            violation = LimitViolation(violation.kind, violation.dof,
                                       f'{violation.message}{ramp.where}')
        elif self._displacement is not None:  # stored above: finite and well formed
            violation = check_strokes(self._displacement, ramp.start, ramp.force_controlled,
                                      self._limits, self._dof_names, ramp.where)
        if violation is not None:
            reply = self._ramp_hold(violation.kind, violation.message)
        else:
            ramp.index += 1
            if ramp.index < len(ramp.forces):
                if self._capturing:
                    self._substep_done = True  # _run_ramp sends the next one
                    return None
                return self._run_ramp()  # an asynchronous driver: send the next one now
            self._ramp = None
            self._in_flight = None
            self._commanded = None
            self._state = STATE_READY
            if ramp.step is None:
                self._ramp_down_note = (f'ramped force down to 0 N in {len(ramp.forces)} '
                                        'sub-steps')
                return None
            assert self._displacement is not None
            reply = BridgeReply(ramp.test_id, ramp.step, self._displacement, self._force,
                                STATUS_OK, '')
            self._record(reply)
        if self._capturing:
            self._captured = reply
        return reply

    def _ramp_hold(self, status: FeedbackStatus, message: str) -> BridgeReply | None:
        """Hold in the middle of a ramp: the step's reply (``None`` for a ramp-down)."""
        ramp = self._ramp
        assert ramp is not None
        if ramp.step is None:
            self._enter_hold(ramp.test_id, -1, status, message, record=False)
            return None
        return self._enter_hold(ramp.test_id, ramp.step, status, message, record=True)

    # ------------------------------------------------------------------ internals

    def _on_driver_measurement(
        self, step: StepId, displacement: list[float], force: list[float]
    ) -> None:
        with self._lock:
            reply = self.handle_measurement(step, displacement, force)
            capturing = self._capturing
            callback = self._reply_callback
        if reply is not None and not capturing and callback is not None:
            callback(reply)

    def _time(self, now: float | None) -> float:
        """``now`` as a float, else the clock; NaN if either is unusable (the watchdog holds)."""
        try:
            return float(self._clock() if now is None else now)
        except Exception:  # noqa: BLE001 - a broken clock must trip the watchdog, not crash
            return math.nan

    def _check_watchdog_locked(self, now: float) -> BridgeReply | None:
        """Trip the watchdog if armed and expired (the caller holds the lock, not holding)."""
        timeout = self._limits.watchdog_timeout
        if timeout is None or not self._watchdog_armed:
            return None
        elapsed = now - self._last_command_time
        if math.isfinite(elapsed) and elapsed <= timeout:
            return None
        if math.isfinite(elapsed):
            message = (
                f'watchdog: no command for more than {_fmt(timeout)} s '
                f'(last command {_fmt(elapsed, timeout)} s ago)'
            )
        else:
            message = (
                f'watchdog: invalid time {now!r} (last command at {self._last_command_time!r}); '
                f'no command for more than {_fmt(timeout)} s cannot be ruled out'
            )
        self._watchdog_trips += 1
        return self._hold_now(STATUS_FAULT, message)

    def _hold_now(self, status: FeedbackStatus, message: str) -> BridgeReply | None:
        """Hold because of an event outside a command; reply for the step in flight or last."""
        if self._in_flight is not None:
            test_id, step = self._in_flight
            return self._enter_hold(test_id, step, status, message, record=True)
        if self._last_command is not None:
            test_id, step = self._last_command
            return self._enter_hold(test_id, step, status, message, record=False)
        self._enter_hold('', -1, status, message, record=False)
        return None

    def _enter_hold(
        self, test_id: str, step: StepId, status: FeedbackStatus, message: str, record: bool
    ) -> BridgeReply:
        """Hold the actuator, latch the hold and return the reply for ``(test_id, step)``."""
        try:
            self._driver.hold()
        except Exception as exc:  # noqa: BLE001 - still latch the hold
            message = f'{message}; driver hold() failed: {_describe(exc)}'
        self._violations += 1
        if self._ramp is not None and self._ramp.step is None:
            self._ramp_down_note = f'force ramp-down stopped: {message}'
        self._state = STATE_HOLDING
        self._hold_status = status
        self._hold_reason = message
        self._in_flight = None
        self._commanded = None
        self._saturation_note = ''
        self._ramp = None
        reply = self._reply(test_id, step, status, message)
        if record:
            self._record(reply)
        return reply

    def _record(self, reply: BridgeReply) -> None:
        self._last_test_id = reply.test_id
        self._last_step = reply.step
        self._last_reply = reply

    def _reply(
        self, test_id: str, step: StepId, status: FeedbackStatus, message: str
    ) -> BridgeReply:
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


def _older(step: StepId, last_step: StepId) -> bool:
    """Whether ``step`` is older than ``last_step``; a key that cannot be ordered is foreign."""
    try:
        # operator.lt is ``<``; an int against a tuple raises TypeError (a foreign key).
        return bool(operator.lt(step, last_step))
    except (TypeError, ValueError):
        return True


def _describe(exc: BaseException) -> str:
    return f'{type(exc).__name__}: {exc}'

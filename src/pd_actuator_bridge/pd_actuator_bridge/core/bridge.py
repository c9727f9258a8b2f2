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
(:meth:`~.drivers.base.ActuatorDriver.force_control_problem`). Before anything moves: the
displacement limits above on the displacement-controlled DOFs (from the measured position) and
|target_force| <= max_force on the force-controlled ones (LIMIT). The force then goes to its
target through the checked sub-steps of a force ramp (:mod:`.force_control`, which keeps the
held forces and plans the ramps; the bridge sends each sub-step and holds on a violation). The
step is answered with the last sub-step's measurement. :meth:`ramp_down` (lifecycle
deactivation) ramps the force-controlled DOFs down to 0 N through the same sub-steps and
checks. A mixed command is never saturated (``on_limit='saturate'`` clips displacement-only
commands); a command whose modes are all displacement is served exactly as a plain one.

Steps are compared by equality and order only, so a step may be an ``int`` or a totally
ordered key such as ``(step, iteration)`` (the node uses that for implicit schemes). A key that
cannot be ordered against the test's last step (e.g. an ``int`` after tuples) is foreign: it is
ignored and counted like a stale step.

Step bookkeeping (per test id; a new test id starts fresh but the actuator keeps its position),
the receiver's rule of :func:`pd_common.protocol.arrival`: a repeated step returns the last
answer without moving, a duplicate of the step in flight returns ``None``, and a step older than
the last answered one is ignored and counted.

The bridge answers in the protocol's own record, :class:`pd_common.protocol.Feedback`: the
``test_id`` as given to :meth:`~ActuatorBridge.handle_command`, the step split into ``step`` and
``iteration`` (an ``int`` step: iteration 0), the measured (or, when holding, current)
displacement, the measured (or last measured; NaN before the first) force, the status and the
one-line reason (``'saturated: ...'`` for a step executed with a clipped target). ``epoch`` and
``state_origin`` keep their defaults: the node shell stamps its own. The driver reports
measurements as :class:`~.drivers.base.ActuatorMeasurement`.
"""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable, Sequence

from pd_common.experimental.limits import (
    KIND_FAULT,
    KIND_LIMIT,
    LimitViolation,
    SafetyLimits,
    check_command,
    check_control,
    check_feedback,
    check_tracking,
    saturate_command,
)
from pd_common.experimental.limits import format_value as _fmt
from pd_common.protocol import Arrival, Feedback, FeedbackStatus, StateOrigin, arrival

from .drivers.base import ActuatorDriver, ActuatorMeasurement, StepId
from .errors import BridgeConfigError
from .force_control import ForceControl

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

ReplyCallback = Callable[[Feedback], None]


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
        #: What alone made the current hold: '' (anything else, or several causes),
        #: 'timeout' (a driver timeout) or 'supervisor' (the supervisor's hold).
        self._hold_cause = ''
        self._displacement: tuple[float, ...] | None = None
        self._force: tuple[float, ...] = (math.nan,) * n_dof
        # Step bookkeeping.
        self._last_test_id: str | None = None
        self._last_step: StepId | None = None
        self._last_reply: Feedback | None = None
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
        self._captured: Feedback | None = None
        # Counters.
        self._commands_received = 0
        self._ignored_commands = 0
        self._ignored_measurements = 0
        self._repeated_steps = 0
        self._violations = 0
        self._saturations = 0
        self._watchdog_trips = 0
        self._emergency_stops = 0
        # Force control (the held forces and the ramp in execution).
        self._force_control = ForceControl(limits, self._dof_names)
        self._substep_done = False  # a synchronous driver answered the sub-step just sent

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
    def held_by_supervisor(self) -> bool:
        """Whether the bridge holds for the supervisor's hold alone (:meth:`hold_for_supervisor`).

        Only such a hold may the supervisor leave again (the node's ``auto_reset``); any other
        cause since (a fault, a person's hold, an emergency stop) or a reset ends it.
        """
        return self._state == STATE_HOLDING and self._hold_cause == 'supervisor'

    def hold_for_supervisor(self, message: str) -> Feedback | None:
        """The supervisor's hold: a process of the test died or hung.

        Holds if not holding (as :meth:`handle_fault`), the hold then the supervisor's. A
        hold already there becomes the supervisor's only if it is one: its own (a hold sent
        again), or a driver timeout with nothing since whose specimen is simulated (its state
        is not the hardware's) — the driver waited for the very process the supervisor reports
        and restarts. A limit's, a fault's, a person's, an emergency stop's or a physical
        actuator's timeout's hold stays what it is.

        Returns:
            A ``'fault'`` reply for the step in flight, if it held now; else ``None``.
        """
        with self._lock:
            if self._state != STATE_HOLDING:
                reply = self._fault_hold(message)
                self._hold_cause = 'supervisor'
                return reply
            if self._hold_cause == 'supervisor' or (
                    self._hold_cause == 'timeout'
                    and self._driver.state_origin is not StateOrigin.HARDWARE):
                self._hold_cause = 'supervisor'
            return None

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
    def last_reply(self) -> Feedback | None:
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
        """Per DOF the force last commanded to it under force control, N.

        0 at the start, or the measured force a restarted bridge adopted:
        :meth:`adopt_held_force`.
        """
        return self._force_control.held_force

    def adopt_held_force(self, measured: Sequence[float]) -> bool:
        """Take the actuators' measured forces as the forces they hold.

        Before this bridge has commanded any: a restarted bridge ramps from the load the specimen
        carries (e.g. a column's axial load), never from 0 N back up. ``False`` (nothing changed)
        once a force was commanded, or for a measurement of the wrong size or with a non-finite
        value.
        """
        with self._lock:
            return self._force_control.adopt(measured)

    @property
    def force_controlled(self) -> tuple[bool, ...]:
        """Per DOF whether the last command executed force-controlled it."""
        return self._force_control.force_controlled

    @property
    def force_substeps(self) -> int:
        """Number of force sub-steps sent to the driver (commands and ramp-downs)."""
        return self._force_control.substeps

    @property
    def ramping_down(self) -> bool:
        """Whether a :meth:`ramp_down` is still executing (an asynchronous driver)."""
        return self._force_control.ramping_down

    @property
    def ramp_down_note(self) -> str:
        """One line on the last :meth:`ramp_down`: what it did, or why it stopped."""
        return self._force_control.ramp_down_note

    # ------------------------------------------------------------------ public API

    def set_reply_callback(self, callback: ReplyCallback | None) -> None:
        """Set (or clear) the function receiving replies produced by asynchronous measurements."""
        with self._lock:
            self._reply_callback = callback

    def handle_command(
        self, test_id: str, step: StepId, target: Sequence[float], now: float | None = None,
        *, control_mode: Sequence[int] = (), target_force: Sequence[float] = (),
    ) -> Feedback | None:
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
            if self._force_control.ramp is not None:  # ramping down: nothing else moves
                self._ignored_commands += 1
                return None
            order = arrival(step, self._last_step) if same_test else Arrival.NEW
            if order is Arrival.REPEAT and self._last_reply is not None:
                self._repeated_steps += 1
                return self._last_reply
            if order is Arrival.STALE:
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
            if isinstance(current, Feedback):
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
            self._force_control.plain_command()
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

    def handle_measurement(self, measurement: ActuatorMeasurement) -> Feedback | None:
        """Handle a measurement reported by the driver (normally through its callback).

        Args:
            measurement: The step it answers, the measured displacement (m) and force (N)
                per DOF.

        Returns:
            The reply for the step in flight (``'ok'``, or ``'limit'``/``'fault'`` after which
            the bridge holds), or ``None`` if the measurement is not for the step in flight.
        """
        step, displacement = measurement.step, measurement.displacement
        with self._lock:
            ramp = self._force_control.ramp
            if ramp is not None:
                if step != ramp.current_id:
                    self._ignored_measurements += 1
                    return None
                return self._ramp_measurement(measurement)
            if self._in_flight is None or self._in_flight[1] != step:
                self._ignored_measurements += 1
                return None
            test_id = self._in_flight[0]
            violation = self._check_and_store(measurement)
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
                reply = _feedback(test_id, step, self._displacement, self._force, status,
                                  message)
                self._record(reply, step)
            if self._capturing:
                self._captured = reply
            return reply

    def handle_fault(self, message: str, *, timeout: bool = False) -> Feedback | None:
        """Hold because of a fault detected outside the core (e.g. a driver timeout).

        Args:
            message: One-line reason.
            timeout: the driver did not answer in time (see :meth:`hold_for_supervisor`).

        Returns:
            A ``'fault'`` reply for the step in flight, if any; else ``None``.
        """
        with self._lock:
            if self._state == STATE_HOLDING:
                self._hold_cause = ''  # a cause of its own now, too
                return None
            reply = self._fault_hold(message)
            self._hold_cause = 'timeout' if timeout else ''
            return reply

    def _fault_hold(self, message: str) -> Feedback | None:
        """Hold for a fault (not holding yet): the reply for the step in flight, if any."""
        if self._in_flight is not None:
            test_id, step = self._in_flight
            return self._enter_hold(test_id, step, STATUS_FAULT, message, record=True)
        self._enter_hold('', -1, STATUS_FAULT, message, record=False)
        return None

    def check_watchdog(self, now: float | None = None) -> Feedback | None:
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

    def emergency_stop(self, reason: str = '') -> Feedback | None:
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
            self._hold_cause = ''
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
            self._hold_cause = ''
            self._in_flight = None
            self._commanded = None
            self._saturation_note = ''
            self._last_reply = None
            self._watchdog_armed = False
            self._force_control.cancel()
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
            force_control = self._force_control
            held = force_control.loaded()
            if not held:
                return ''
            if self._state == STATE_HOLDING:
                note = (f'force not ramped down (holding: {self._hold_reason}): {held} '
                        'kept; reset the hold, then deactivate again to ramp down')
                force_control.ramp_down_note = note
                return note
            if self._state != STATE_READY or self._in_flight is not None:
                note = f'force not ramped down (a step is in flight): {held} kept'
                force_control.ramp_down_note = note
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
                force_control.ramp_down_note = note
                return note
            note = force_control.start_ramp_down(current, self._last_test_id or '')
            if force_control.ramp is not None:
                self._state = STATE_BUSY
                self._run_ramp()
            return note

    # ------------------------------------------------------------------ force control

    def _measured_position(self, test_id: str, step: StepId) -> list[float] | Feedback:
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
                     ) -> Feedback | None:
        """Check a mixed command before anything moves, then run its force ramp."""
        problem = self._driver.force_control_problem()
        if problem is not None:
            name = self._driver.driver_name or type(self._driver).__name__
            return self._enter_hold(test_id, step, STATUS_FAULT, f'driver {name}: {problem}',
                                    record=True)
        current = self._measured_position(test_id, step)
        if isinstance(current, Feedback):
            return current
        violation = self._command_violation(
            target, current, tuple(not flag for flag in force_controlled))
        if violation is None:
            violation = self._force_control.start_step(test_id, step, target, force_controlled,
                                                       forces, current)
        if violation is not None:
            return self._enter_hold(test_id, step, violation.kind, violation.message,
                                    record=True)
        self._commanded = tuple(float(x) for x in target)
        self._in_flight = (test_id, step)
        self._state = STATE_BUSY
        return self._run_ramp()

    def _run_ramp(self) -> Feedback | None:
        """Send sub-steps of the ramp in execution while the driver answers synchronously.

        Returns:
            The step's reply (its last sub-step answered, or a hold); ``None`` while an
            asynchronous driver has a sub-step in flight, or for a ramp-down.
        """
        while self._force_control.ramp is not None:
            ramp, targets, forces = self._force_control.next_substep(self._displacement)
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
            if self._substep_done and self._force_control.ramp is ramp:
                self._substep_done = False
                continue  # answered synchronously: the next sub-step
            captured, self._captured = self._captured, None
            return captured
        return None

    def _ramp_measurement(self, measurement: ActuatorMeasurement) -> Feedback | None:
        """A sub-step answered: check it, then the next sub-step or the step's reply."""
        force_control = self._force_control
        ramp = force_control.ramp
        assert ramp is not None
        violation = force_control.substep_violation(
            self._check_and_store(measurement), measurement.displacement, self._displacement)
        if violation is not None:
            reply = self._ramp_hold(violation.kind, violation.message)
        else:
            if force_control.advance():
                if self._capturing:
                    self._substep_done = True  # _run_ramp sends the next one
                    return None
                return self._run_ramp()  # an asynchronous driver: send the next one now
            self._in_flight = None
            self._commanded = None
            self._state = STATE_READY
            if ramp.step is None:
                return None
            assert self._displacement is not None
            reply = _feedback(ramp.test_id, ramp.step, self._displacement, self._force,
                              STATUS_OK, '')
            self._record(reply, ramp.step)
        if self._capturing:
            self._captured = reply
        return reply

    def _ramp_hold(self, status: FeedbackStatus, message: str) -> Feedback | None:
        """Hold in the middle of a ramp: the step's reply (``None`` for a ramp-down)."""
        ramp = self._force_control.ramp
        assert ramp is not None
        if ramp.step is None:
            self._enter_hold(ramp.test_id, -1, status, message, record=False)
            return None
        return self._enter_hold(ramp.test_id, ramp.step, status, message, record=True)

    # ------------------------------------------------------------------ internals

    def _on_driver_measurement(self, measurement: ActuatorMeasurement) -> None:
        with self._lock:
            reply = self.handle_measurement(measurement)
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

    def _check_watchdog_locked(self, now: float) -> Feedback | None:
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

    def _hold_now(self, status: FeedbackStatus, message: str) -> Feedback | None:
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
    ) -> Feedback:
        """Hold the actuator, latch the hold and return the reply for ``(test_id, step)``."""
        try:
            self._driver.hold()
        except Exception as exc:  # noqa: BLE001 - still latch the hold
            message = f'{message}; driver hold() failed: {_describe(exc)}'
        self._violations += 1
        self._force_control.stop(message)
        self._state = STATE_HOLDING
        self._hold_status = status
        self._hold_reason = message
        self._hold_cause = ''
        self._in_flight = None
        self._commanded = None
        self._saturation_note = ''
        reply = self._reply(test_id, step, status, message)
        if record:
            self._record(reply, step)
        return reply

    def _record(self, reply: Feedback, step: StepId) -> None:
        """Keep ``reply`` as the answer to ``step`` (what a repeat of it gets)."""
        self._last_test_id = reply.test_id
        self._last_step = step
        self._last_reply = reply

    def _reply(
        self, test_id: str, step: StepId, status: FeedbackStatus, message: str
    ) -> Feedback:
        return _feedback(
            test_id, step, self._current_displacement(), self._force, status, message
        )

    def _check_and_store(self, measurement: ActuatorMeasurement) -> LimitViolation | None:
        """Check a measurement and keep it if it is the actuator's true state.

        Check a measurement (:func:`~.limits.check_feedback`) and, if it is finite and well
        formed (no violation or a LIMIT), keep it: it is the actuator's true state.
        """
        displacement, force = measurement.displacement, measurement.force
        violation = check_feedback(
            displacement, force, self._limits, self._dof_names, n_dof=self._n_dof
        )
        if violation is None or violation.kind == KIND_LIMIT:
            self._displacement = tuple(float(x) for x in displacement)
            self._force = tuple(float(f) for f in force)
        return violation

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


def _feedback(test_id: str, step: StepId, displacement: tuple[float, ...],
              force: tuple[float, ...], status: FeedbackStatus, message: str) -> Feedback:
    """The protocol's answer for ``step`` (an ``int``: iteration 0; else ``(step, iteration)``)."""
    if isinstance(step, tuple):
        number = int(step[0]) if step else 0
        iteration = int(step[1]) if len(step) > 1 else 0
    else:
        number, iteration = int(step), 0
    return Feedback(test_id, number, displacement, force, status, message, iteration)


def _describe(exc: BaseException) -> str:
    return f'{type(exc).__name__}: {exc}'

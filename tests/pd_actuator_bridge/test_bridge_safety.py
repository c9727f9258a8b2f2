"""Safety interlocks of the actuator bridge core: watchdog, plausibility, saturation, e-stop.

The property-based tests feed random and adversarial command streams (hypothesis) to a bridge
whose driver records every command it receives, and check that nothing beyond a limit ever
reaches the driver, and that nothing at all reaches it while the bridge holds.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from fractions import Fraction
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from pd_actuator_bridge.core import (
    ActuatorBridge,
    ActuatorDriver,
    ActuatorMeasurement,
    BridgeConfigError,
    SafetyLimits,
    check_command,
    check_tracking,
    saturate_command,
)
from pd_common.protocol import Feedback, FeedbackStatus
from support.loopback import LoopbackDriver

NAN = math.nan
INF = math.inf

# Binary-exact values so that "exactly at the limit" is exact in floating point.
LIMITS = SafetyLimits(max_displacement=0.25, max_increment=0.125, max_force=1000.0)
VELOCITY_LIMITS = SafetyLimits(
    max_displacement=0.25,
    max_increment=0.125,
    max_force=1000.0,
    max_velocity=0.5,
    step_duration=0.125,
)
TOLERANCE = 2.0**-10
TRACKING_LIMITS = SafetyLimits(
    max_displacement=0.25, max_increment=0.125, max_force=1000.0, tracking_tolerance=TOLERANCE
)
WATCHDOG = 0.5
WATCHDOG_LIMITS = SafetyLimits(
    max_displacement=0.25, max_increment=0.125, max_force=1000.0, watchdog_timeout=WATCHDOG
)

HYPOTHESIS_SETTINGS = settings(
    max_examples=300,
    deadline=None,
    derandomize=True,
    database=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
)


def just_above(value: float) -> float:
    """The next float beyond ``value`` away from zero."""
    return math.nextafter(value, math.copysign(INF, value))


def just_below(value: float) -> float:
    """The next float from ``value`` towards zero."""
    return math.nextafter(value, 0.0)


def spring(stiffness: float):
    """A restoring force f = k x per DOF."""

    def restoring_force(x: list[float]) -> list[float]:
        return [stiffness * xi for xi in x]

    return restoring_force


class Clock:
    """Injected monotonic time, advanced by the test (no sleeping)."""

    def __init__(self, t: float = 100.0) -> None:
        self.t = t

    def __call__(self) -> float:
        return self.t


def make_bridge(
    limits: SafetyLimits = LIMITS,
    n_dof: int = 1,
    on_limit: str = 'hold',
    stiffness: float = 1000.0,
    initial_position: Sequence[float] | None = None,
    clock: Clock | None = None,
) -> tuple[ActuatorBridge, LoopbackDriver]:
    driver = LoopbackDriver(spring(stiffness), n_dof, initial_position)
    driver.open()
    names = ['top', 'mid', 'bottom'][:n_dof]
    bridge = ActuatorBridge(driver, limits, names, on_limit=on_limit, clock=clock or Clock())
    return bridge, driver


class RecordingDriver(ActuatorDriver):
    """Records every command with the position it started from; sync or async; tracking error.

    Attributes:
        sent: ``(step, target, position before the command)`` for every command received.
        error: Added to each displacement a synchronous move reaches (a tracking error).
        pending: The asynchronous move waiting for :meth:`deliver`.
    """

    def __init__(
        self,
        n_dof: int,
        stiffness: float,
        synchronous: bool = True,
        initial_position: Sequence[float] | None = None,
    ) -> None:
        super().__init__()
        self._n = n_dof
        self._stiffness = stiffness
        self.synchronous = synchronous
        self._position = list(initial_position) if initial_position else [0.0] * n_dof
        self.sent: list[tuple[Any, tuple[float, ...], tuple[float, ...]]] = []
        self.error = 0.0
        self.pending: tuple[Any, tuple[float, ...]] | None = None
        self.hold_count = 0

    @property
    def n_dof(self) -> int:
        return self._n

    def command(self, step: Any, target: Sequence[float]) -> None:
        values = tuple(float(x) for x in target)
        self.sent.append((step, values, tuple(self._position)))
        if self.synchronous:
            self._move(step, values, self.error, 1.0)
        else:
            self.pending = (step, values)

    def deliver(self, error: float, force_scale: float) -> None:
        """Answer the pending asynchronous move (even after a hold: a late measurement)."""
        if self.pending is not None:
            step, values = self.pending
            self.pending = None
            self._move(step, values, error, force_scale)

    def _move(self, step: Any, values: tuple[float, ...], error: float, scale: float) -> None:
        measured = [x + error for x in values]
        self._position = measured
        self._emit(ActuatorMeasurement(
            step, tuple(measured), tuple(scale * self._stiffness * x for x in measured)))

    def hold(self) -> None:
        self.hold_count += 1

    def position(self) -> list[float]:
        return list(self._position)


# ---------------------------------------------------------------------------- configuration


def test_new_limits_from_mapping() -> None:
    limits = SafetyLimits.from_mapping(
        {
            'max_displacement': 0.25,
            'max_increment': 0.01,
            'max_force': 5000,
            'tracking_tolerance': 0.001,
            'watchdog_timeout': 2,
        },
        'bridge.yaml',
    )
    assert limits.tracking_tolerance == 0.001
    assert limits.watchdog_timeout == 2.0 and isinstance(limits.watchdog_timeout, float)
    default = SafetyLimits(0.25, 0.01, 5000.0)
    assert default.tracking_tolerance is None and default.watchdog_timeout is None


@pytest.mark.parametrize(
    ('key', 'value', 'expected'),
    [
        ('tracking_tolerance', 0.0, 'tracking_tolerance must be a positive finite number'),
        ('tracking_tolerance', NAN, 'tracking_tolerance must be a positive finite number'),
        ('watchdog_timeout', -1.0, 'watchdog_timeout must be a positive finite number'),
        ('watchdog_timeout', INF, 'watchdog_timeout must be a positive finite number'),
        ('watchdog_timeout', '2', 'watchdog_timeout must be a positive finite number, got str'),
    ],
)
def test_new_limits_are_validated(key: str, value: Any, expected: str) -> None:
    mapping = {'max_displacement': 0.25, 'max_increment': 0.01, 'max_force': 1.0, key: value}
    with pytest.raises(BridgeConfigError, match=f'^bridge.yaml: {expected}'):
        SafetyLimits.from_mapping(mapping, 'bridge.yaml')


def test_max_step_is_the_tighter_of_increment_and_velocity() -> None:
    assert LIMITS.max_step == 0.125
    assert VELOCITY_LIMITS.max_step == 0.0625


def test_on_limit_option() -> None:
    driver = LoopbackDriver(spring(1.0), 1)
    assert ActuatorBridge(driver, LIMITS, ['a'], on_limit='saturate').on_limit == 'saturate'
    assert ActuatorBridge(driver, LIMITS, ['a']).on_limit == 'hold'
    with pytest.raises(BridgeConfigError, match="got 'clip' \\(or 'saturate'"):
        ActuatorBridge(driver, LIMITS, ['a'], on_limit='clip')
    with pytest.raises(BridgeConfigError, match='clock must be callable'):
        ActuatorBridge(driver, LIMITS, ['a'], clock=1.0)  # type: ignore[arg-type]


# ---------------------------------------------------------------------------- watchdog


def test_watchdog_exactly_at_timeout_does_not_hold_just_above_does() -> None:
    clock = Clock(10.0)
    bridge, driver = make_bridge(WATCHDOG_LIMITS, clock=clock)
    assert bridge.handle_command('t', 0, [0.0]).status is FeedbackStatus.OK
    assert bridge.watchdog_armed
    assert bridge.check_watchdog(10.0 + WATCHDOG) is None  # exactly T: still allowed
    assert bridge.state == 'ready'
    reply = bridge.check_watchdog(just_above(10.0 + WATCHDOG))
    assert reply is not None
    assert reply.status is FeedbackStatus.FAULT
    assert (reply.test_id, reply.step) == ('t', 0)  # reported against the last command
    assert reply.message.startswith('watchdog: no command for more than 0.5 s (last command ')
    assert bridge.state == 'holding' and bridge.hold_status is FeedbackStatus.FAULT
    assert bridge.hold_reason == reply.message
    assert driver.hold_count == 1 and bridge.watchdog_trips == 1
    # Idle while holding; a command is answered with the hold.
    assert bridge.check_watchdog(1e9) is None
    held = bridge.handle_command('t', 1, [0.0], now=20.0)
    assert held is not None and held.message == reply.message
    assert len(driver.commands) == 1


def test_watchdog_uses_the_clock_when_no_time_is_given() -> None:
    clock = Clock(0.0)
    bridge, _driver = make_bridge(WATCHDOG_LIMITS, clock=clock)
    bridge.handle_command('t', 0, [0.0])
    clock.t = WATCHDOG
    assert bridge.check_watchdog() is None
    clock.t = just_above(WATCHDOG)
    assert bridge.check_watchdog() is not None
    assert bridge.state == 'holding'


def test_late_command_trips_the_watchdog_before_moving() -> None:
    bridge, driver = make_bridge(WATCHDOG_LIMITS)
    bridge.handle_command('t', 0, [0.0], now=1.0)
    assert bridge.handle_command('t', 1, [0.01], now=1.0 + WATCHDOG).status is FeedbackStatus.OK
    reply = bridge.handle_command('t', 2, [0.02], now=just_above(1.0 + 2 * WATCHDOG))
    assert reply is not None and reply.status is FeedbackStatus.FAULT
    assert reply.step == 2 and 'watchdog: no command for more than 0.5 s' in reply.message
    assert [target for _, target in driver.commands] == [(0.0,), (0.01,)]


def test_any_command_feeds_the_watchdog() -> None:
    bridge, _driver = make_bridge(WATCHDOG_LIMITS)
    bridge.handle_command('t', 0, [0.0], now=0.0)
    bridge.handle_command('t', 1, [0.01], now=0.4)
    bridge.handle_command('t', 1, [0.01], now=0.8)  # a repeat (the integrator re-sending)
    bridge.handle_command('t', 0, [0.0], now=1.2)  # stale, ignored, but a sign of life
    assert bridge.check_watchdog(1.2 + WATCHDOG) is None
    assert bridge.state == 'ready'


def test_watchdog_is_off_without_timeout_and_unarmed_before_the_first_command() -> None:
    bridge, _driver = make_bridge(LIMITS)
    bridge.handle_command('t', 0, [0.0], now=0.0)
    assert bridge.check_watchdog(1e9) is None and not bridge.watchdog_armed
    bridge, _driver = make_bridge(WATCHDOG_LIMITS)
    assert bridge.check_watchdog(1e9) is None  # no test started
    assert bridge.state == 'ready'


def test_reset_disarms_the_watchdog_until_the_next_command() -> None:
    bridge, _driver = make_bridge(WATCHDOG_LIMITS)
    bridge.handle_command('t', 0, [0.0], now=0.0)
    assert bridge.check_watchdog(5.0) is not None
    assert bridge.reset()
    assert not bridge.watchdog_armed
    assert bridge.check_watchdog(100.0) is None
    assert bridge.handle_command('t', 1, [0.01], now=100.0).status is FeedbackStatus.OK
    assert bridge.check_watchdog(100.0 + WATCHDOG) is None
    assert bridge.check_watchdog(101.0) is not None


def test_watchdog_answers_the_step_in_flight() -> None:
    driver = RecordingDriver(1, 1000.0, synchronous=False)
    bridge = ActuatorBridge(driver, WATCHDOG_LIMITS, ['top'], clock=Clock())
    published: list[Feedback] = []
    bridge.set_reply_callback(published.append)
    assert bridge.handle_command('t', (3, 0), [0.01], now=0.0) is None
    assert bridge.state == 'busy'
    reply = bridge.check_watchdog(1.0)
    assert reply is not None and reply.key == (3, 0) and reply.status is FeedbackStatus.FAULT
    assert bridge.last_reply == reply  # recorded as the answer of the step in flight
    driver.deliver(0.0, 1.0)  # the late measurement is ignored
    assert published == [] and bridge.ignored_measurements == 1


@pytest.mark.parametrize('bad_time', [NAN, INF])
def test_watchdog_holds_on_an_invalid_time(bad_time: float) -> None:
    bridge, _driver = make_bridge(WATCHDOG_LIMITS)
    bridge.handle_command('t', 0, [0.0], now=0.0)
    reply = bridge.check_watchdog(bad_time)
    assert reply is not None and reply.status is FeedbackStatus.FAULT
    assert bridge.state == 'holding'


def test_broken_clock_trips_the_watchdog() -> None:
    def broken() -> float:
        raise OSError('clock gone')

    driver = LoopbackDriver(spring(1.0), 1)
    driver.open()
    bridge = ActuatorBridge(driver, WATCHDOG_LIMITS, ['top'], clock=broken)
    bridge.handle_command('t', 0, [0.0], now=0.0)
    assert bridge.check_watchdog() is not None
    assert 'watchdog: invalid time nan' in bridge.hold_reason


# ---------------------------------------------------------------------------- plausibility


def test_check_tracking_just_inside_and_outside() -> None:
    commanded = [0.0, 0.0625, 0.0]
    inside = [0.0, 0.0625 + TOLERANCE, 0.0]
    assert check_tracking(inside, commanded, TRACKING_LIMITS) is None
    assert check_tracking([0.0, 0.0625 - TOLERANCE, 0.0], commanded, TRACKING_LIMITS) is None
    outside = [0.0, just_above(0.0625 + TOLERANCE), 0.0]
    violation = check_tracking(outside, commanded, TRACKING_LIMITS, ['a', 'b', 'c'])
    assert violation is not None
    assert (violation.kind, violation.dof) == (FeedbackStatus.FAULT, 1)
    assert violation.message.startswith('DOF 1 (b): tracking error ')
    assert 'commanded 0.0625 m' in violation.message
    assert violation.message.endswith('exceeds tracking_tolerance 0.000976562 m')
    assert '0.000976562 m (measured' not in violation.message  # never printed equal to it
    # Off without a tolerance; malformed input is a fault.
    assert check_tracking([1.0], [0.0], LIMITS) is None
    assert check_tracking([NAN], [0.0], TRACKING_LIMITS).kind is FeedbackStatus.FAULT
    assert check_tracking([0.0, 0.0], [0.0], TRACKING_LIMITS).kind is FeedbackStatus.FAULT


def test_plausibility_just_inside_tolerance_answers_ok() -> None:
    driver = RecordingDriver(1, 1000.0)
    driver.error = TOLERANCE
    bridge = ActuatorBridge(driver, TRACKING_LIMITS, ['top'], clock=Clock())
    reply = bridge.handle_command('t', 0, [0.0])
    assert reply == Feedback('t', 0, (TOLERANCE,), (1000.0 * TOLERANCE,), FeedbackStatus.OK, '')
    assert bridge.state == 'ready'


def test_plausibility_just_outside_tolerance_holds() -> None:
    driver = RecordingDriver(3, 1000.0)
    driver.error = just_above(TOLERANCE)
    bridge = ActuatorBridge(driver, TRACKING_LIMITS, ['a', 'b', 'c'], clock=Clock())
    reply = bridge.handle_command('t', 0, [0.0, 0.0, 0.0])
    assert reply is not None and reply.status is FeedbackStatus.FAULT
    assert reply.message.startswith('DOF 0 (a): tracking error ')
    assert 'exceeds tracking_tolerance' in reply.message
    assert reply.measured_displacement == (driver.error,) * 3  # the measured (true) state
    assert bridge.state == 'holding' and driver.hold_count == 1
    assert bridge.handle_command('t', 1, [0.0, 0.0, 0.0]).status is FeedbackStatus.FAULT
    assert len(driver.sent) == 1


def test_plausibility_async_measurement() -> None:
    driver = RecordingDriver(1, 1000.0, synchronous=False)
    bridge = ActuatorBridge(driver, TRACKING_LIMITS, ['top'], clock=Clock())
    bridge.handle_command('t', 0, [0.0625])
    first = bridge.handle_measurement(ActuatorMeasurement(0, (0.0625 - TOLERANCE,), (1.0,)))
    assert first.status is FeedbackStatus.OK
    bridge.handle_command('t', 1, [0.0625])
    reply = bridge.handle_measurement(
        ActuatorMeasurement(1, (just_above(0.0625 + TOLERANCE),), (1.0,)))
    assert (reply is not None and reply.status is FeedbackStatus.FAULT
            and 'tracking error' in reply.message)


def test_plausibility_compares_with_the_saturated_target() -> None:
    driver = RecordingDriver(1, 1000.0)
    bridge = ActuatorBridge(driver, TRACKING_LIMITS, ['top'], on_limit='saturate',
                            clock=Clock())
    reply = bridge.handle_command('t', 0, [0.5])  # clipped to 0.125 (max_increment)
    assert reply is not None and reply.status is FeedbackStatus.LIMIT
    assert reply.message.startswith('saturated: ')
    assert bridge.state == 'ready'


# ---------------------------------------------------------------------------- saturation


def test_saturate_clips_absolute_displacement() -> None:
    bridge, driver = make_bridge(on_limit='saturate', stiffness=2000.0,
                                 initial_position=[0.1875])
    reply = bridge.handle_command('t', 0, [0.3])
    assert reply == Feedback(
        't', 0, (0.25,), (500.0,), FeedbackStatus.LIMIT,
        'saturated: DOF 0 (top): target 0.3 m clipped to 0.25 m (max_displacement 0.25 m)',
    )
    assert driver.commands == [(0, (0.25,))]
    assert bridge.state == 'ready' and bridge.saturations == 1 and bridge.violations == 0
    # A repeat returns the same answer without moving; the next safe step is normal.
    assert bridge.handle_command('t', 0, [0.3]) is reply
    assert bridge.handle_command('t', 1, [0.125]).status is FeedbackStatus.OK
    # The negative side.
    reply = bridge.handle_command('t', 2, [-0.5])
    assert reply is not None and driver.commands[-1] == (2, (0.0,))
    assert 'clipped to 0 m (max_increment 0.125 m from 0.125 m)' in reply.message


def test_saturate_clips_increment() -> None:
    bridge, driver = make_bridge(on_limit='saturate', initial_position=[0.0625])
    reply = bridge.handle_command('t', 0, [0.2])  # within max_displacement, beyond increment
    assert driver.commands == [(0, (0.1875,))]
    assert reply.message == (
        'saturated: DOF 0 (top): target 0.2 m clipped to 0.1875 m '
        '(max_increment 0.125 m from 0.0625 m)'
    )
    reply = bridge.handle_command('t', 1, [-1e300])
    assert driver.commands[-1] == (1, (0.0625,))
    assert reply.status is FeedbackStatus.LIMIT


def test_saturate_clips_velocity() -> None:
    bridge, driver = make_bridge(VELOCITY_LIMITS, on_limit='saturate')
    reply = bridge.handle_command('t', 0, [-0.1])
    assert driver.commands == [(0, (-0.0625,))]
    assert reply.message == (
        'saturated: DOF 0 (top): target -0.1 m clipped to -0.0625 m '
        '(max_velocity 0.5 m/s over step_duration 0.125 s from 0 m)'
    )


def test_saturate_only_touches_the_offending_dofs() -> None:
    bridge, driver = make_bridge(n_dof=3, on_limit='saturate')
    reply = bridge.handle_command('t', 0, [0.0625, 0.5, -0.03])
    assert driver.commands == [(0, (0.0625, 0.125, -0.03))]
    assert reply.message == (
        'saturated: DOF 1 (mid): target 0.5 m clipped to 0.125 m (max_increment 0.125 m from 0 m)'
    )
    assert reply.measured_displacement == (0.0625, 0.125, -0.03)


def test_saturate_exactly_at_a_limit_is_not_a_saturation() -> None:
    bridge, _driver = make_bridge(on_limit='saturate')
    assert bridge.handle_command('t', 0, [0.125]) == Feedback(
        't', 0, (0.125,), (125.0,), FeedbackStatus.OK, ''
    )
    assert bridge.saturations == 0


@pytest.mark.parametrize('bad', [NAN, INF, -INF])
def test_saturate_never_saturates_non_finite_values(bad: float) -> None:
    bridge, driver = make_bridge(n_dof=3, on_limit='saturate')
    reply = bridge.handle_command('t', 0, [0.5, bad, 0.0])
    assert reply is not None and reply.status is FeedbackStatus.FAULT
    assert reply.message == f'non-finite target displacement for DOF 1 (mid): {bad}'
    assert driver.commands == [] and bridge.state == 'holding'


@pytest.mark.parametrize('target', [[0.1, 0.2], [None], 'xy'])
def test_saturate_never_saturates_malformed_commands(target: Any) -> None:
    bridge, driver = make_bridge(on_limit='saturate')
    reply = bridge.handle_command('t', 0, target)
    assert reply is not None and reply.status is FeedbackStatus.FAULT
    assert driver.commands == [] and bridge.state == 'holding'


def test_saturate_holds_when_no_allowed_value_is_reachable() -> None:
    # The actuator is 0.25 m beyond max_displacement: one step of 0.125 m cannot get back.
    bridge, driver = make_bridge(on_limit='saturate', initial_position=[0.5])
    reply = bridge.handle_command('t', 0, [0.0])
    assert reply is not None and reply.status is FeedbackStatus.LIMIT
    assert reply.message.startswith('DOF 0 (top): cannot saturate target 0 m')
    assert driver.commands == [] and bridge.state == 'holding'
    # Within one step of the allowed range, it moves back into it.
    bridge, driver = make_bridge(on_limit='saturate', initial_position=[0.3125])
    reply = bridge.handle_command('t', 0, [0.0])
    assert driver.commands == [(0, (0.1875,))] and reply.status is FeedbackStatus.LIMIT


def test_measurement_violations_still_hold_in_saturate_mode() -> None:
    bridge, _driver = make_bridge(on_limit='saturate', stiffness=10000.0)
    reply = bridge.handle_command('t', 0, [0.5])  # clipped to 0.125 m: 1250 N > 1000 N
    assert reply is not None and reply.status is FeedbackStatus.LIMIT
    assert reply.message == 'DOF 0 (top): measured force 1250 N exceeds max_force 1000 N'
    assert bridge.state == 'holding'


def test_saturate_command_returns_nearest_value_even_with_rounding() -> None:
    limits = SafetyLimits(max_displacement=1.0, max_increment=0.3, max_force=1.0)
    result = saturate_command([5.0], [0.1], limits)
    assert result.target is not None and result.clipped
    (value,) = result.target
    assert check_command([value], [0.1], limits) is None
    assert check_command([math.nextafter(value, 5.0)], [0.1], limits) is not None
    assert saturate_command([0.2], [0.1], limits).message == ''
    fault = saturate_command([NAN], [0.0], limits)
    assert fault.target is None and fault.violation.kind is FeedbackStatus.FAULT


# ---------------------------------------------------------------------------- emergency stop


def test_emergency_stop_is_latched_until_explicitly_cleared() -> None:
    bridge, driver = make_bridge(WATCHDOG_LIMITS)
    bridge.handle_command('t', 0, [0.0], now=0.0)
    reply = bridge.emergency_stop('operator\nbutton')
    assert reply is not None
    assert (reply.test_id, reply.step, reply.status) == ('t', 0, FeedbackStatus.FAULT)
    assert reply.message == 'emergency stop: operator button'
    assert bridge.state == 'holding' and bridge.emergency_stopped
    assert driver.hold_count == 1
    # A plain reset is refused; commands are answered with the e-stop; no watchdog while held.
    assert bridge.reset() is False
    assert bridge.state == 'holding' and bridge.emergency_stopped
    held = bridge.handle_command('t', 1, [0.01], now=0.1)
    assert (held.status is FeedbackStatus.FAULT
            and held.message == 'emergency stop: operator button')
    assert bridge.check_watchdog(100.0) is None
    assert bridge.handle_fault('something else') is None
    assert bridge.hold_reason == 'emergency stop: operator button'
    assert len(driver.commands) == 1
    # Explicit clearing.
    assert bridge.reset(clear_emergency=True) is True
    assert bridge.state == 'ready' and not bridge.emergency_stopped
    assert bridge.handle_command('t', 1, [0.01], now=200.0).status is FeedbackStatus.OK
    assert len(driver.commands) == 2


def test_emergency_stop_while_holding_overrides_the_hold() -> None:
    bridge, driver = make_bridge()
    bridge.handle_command('t', 0, [1.0])  # limit: holding
    assert driver.hold_count == 1
    assert bridge.emergency_stop() is None
    assert driver.hold_count == 2  # told to hold again, at once
    assert bridge.hold_reason == 'emergency stop' and bridge.hold_status is FeedbackStatus.FAULT
    assert bridge.reset() is False
    assert bridge.reset(clear_emergency=True) is True and bridge.state == 'ready'
    assert bridge.emergency_stops == 1


def test_emergency_stop_answers_the_step_in_flight() -> None:
    driver = RecordingDriver(1, 1000.0, synchronous=False)
    bridge = ActuatorBridge(driver, LIMITS, ['top'], clock=Clock())
    published: list[Feedback] = []
    bridge.set_reply_callback(published.append)
    bridge.handle_command('t', 0, [0.05])
    reply = bridge.emergency_stop('pressure drop')
    assert reply is not None and reply.step == 0 and reply.status is FeedbackStatus.FAULT
    driver.deliver(0.0, 1.0)
    assert published == []
    assert bridge.handle_command('t', 0, [0.05]).message == 'emergency stop: pressure drop'


def test_emergency_stop_before_any_command() -> None:
    bridge, driver = make_bridge()
    assert bridge.emergency_stop('startup check') is None
    assert bridge.state == 'holding' and bridge.hold_reason == 'emergency stop: startup check'
    assert bridge.handle_command('t', 0, [0.0]).status is FeedbackStatus.FAULT
    assert driver.commands == []


def test_reset_without_emergency_behaves_as_before() -> None:
    bridge, _driver = make_bridge()
    assert bridge.reset() is True  # not holding: nothing to do
    bridge.handle_command('t', 0, [1.0])
    assert bridge.reset() is True and bridge.state == 'ready'


def test_step_keys_of_another_type_are_ignored_not_crashing() -> None:
    bridge, driver = make_bridge()
    bridge.handle_command('t', (1, 0), [0.0])
    assert bridge.handle_command('t', 2, [0.01]) is None
    assert bridge.ignored_commands == 1 and len(driver.commands) == 1


# ---------------------------------------------------------------------------- properties

SPECIALS = [NAN, INF, -INF, 1e308, -1e308, 5e-324, -5e-324, 0.0, -0.0, 1e-300, 1e300]

FIXED_LIMITS = [
    LIMITS,
    VELOCITY_LIMITS,
    SafetyLimits(0.25, 0.125, 1000.0, 0.5, 0.125, tracking_tolerance=TOLERANCE,
                 watchdog_timeout=WATCHDOG),
]


@st.composite
def random_limits(draw: st.DrawFn) -> SafetyLimits:
    """Limits with arbitrary (not binary-exact) values, so that rounding is exercised."""
    max_displacement = draw(st.floats(1e-3, 10.0))
    max_increment = draw(st.floats(1e-3, 0.5)) * max_displacement
    # The velocity limit is sometimes tighter than max_increment, sometimes not.
    velocity = draw(st.one_of(st.none(), st.tuples(st.floats(0.1, 2.0), st.floats(1e-3, 1.0))))
    if velocity is not None:
        velocity = (velocity[0] * max_increment / velocity[1], velocity[1])
    return SafetyLimits(
        max_displacement=max_displacement,
        max_increment=max_increment,
        max_force=draw(st.floats(1.0, 1e6)),
        max_velocity=None if velocity is None else velocity[0],
        step_duration=None if velocity is None else velocity[1],
        tracking_tolerance=draw(st.one_of(st.none(), st.floats(1e-6, 1e-2))),
        watchdog_timeout=draw(st.one_of(st.none(), st.floats(1e-2, 10.0))),
    )


ANY_LIMITS = st.one_of(st.sampled_from(FIXED_LIMITS), random_limits())

# One DOF of a target: (selector, any float, fraction in [-1, 1]).
DOF_RAW = st.tuples(
    st.integers(0, 99), st.floats(allow_nan=True, allow_infinity=True), st.floats(-1.0, 1.0)
)
# An operation is drawn as a few integers (their digits are the choices) and one arbitrary float:
# far cheaper to generate than a nest of tuples, which keeps the property tests fast. Hypothesis
# favours small integers (zero above all), so each is offset by the operation's position and
# scrambled (times a prime, modulo its range) before its digits are read; otherwise most
# operations would decode to the same few choices.
_CHOICES = 100**4  # kind, aux, shape, time choice
_SELECTORS = 100**3  # one per DOF
_FRACTIONS = 1001 * 2001**3  # the time fraction, one fraction per DOF
_SCRAMBLE = 2_654_435_761  # a prime dividing none of the ranges


def decode_operation(raw: tuple[int, int, int, float], index: int) -> tuple:
    """``(kind, aux, shape, three DOF_RAW values, time choice, fraction in [0, 1])``."""
    choices, selectors, fractions, anything = raw
    salt = 7919 * (index + 1)
    choices = (choices + salt) * _SCRAMBLE % _CHOICES
    selectors = (selectors + salt) * _SCRAMBLE % _SELECTORS
    fractions = (fractions + salt) * _SCRAMBLE % _FRACTIONS
    choices, kind = divmod(choices, 100)
    choices, shape = divmod(choices, 100)
    time_selector, aux = divmod(choices, 100)
    fractions, fraction = divmod(fractions, 1001)
    dofs = []
    for dof in range(3):
        selectors, selector = divmod(selectors, 100)
        fractions, step = divmod(fractions, 2001)
        dofs.append((selector, anything if dof % 2 == 0 else -anything, (step - 1000) / 1000))
    return kind, aux, shape, dofs, time_selector, fraction / 1000


OP_RAW = st.tuples(
    st.integers(0, _CHOICES - 1),
    st.integers(0, _SELECTORS - 1),
    st.integers(0, _FRACTIONS - 1),
    st.floats(allow_nan=True, allow_infinity=True),
)
# Cumulative weights (out of 100) of the operation kinds.
OP_KINDS = [(53, 'cmd'), (71, 'measure'), (88, 'reset'), (91, 'error'), (92, 'estop'),
            (97, 'watchdog'), (99, 'advance'), (100, 'fault')]
TEST_IDS = ['t'] * 6 + ['t:probe', 'other']
KEY_MODES = ['next'] * 5 + ['iteration', 'repeat', 'stale', 'int']
FORCE_SCALES = [1.0] * 15 + [NAN, INF, 1e9]


def op_kind(selector: int) -> str:
    return next(kind for bound, kind in OP_KINDS if selector < bound)


def edge_value(kind: str, sign: float, where: str, current: float, limits: SafetyLimits) -> float:
    """At, just beyond or just inside a limit: absolute, increment or velocity (max_step)."""
    if kind == 'disp':
        base = sign * limits.max_displacement
    elif kind == 'inc':
        base = current + sign * limits.max_increment
    else:
        base = current + sign * limits.max_step
    if where == 'at':
        return base
    return math.nextafter(base, sign * INF if where == 'above' else -sign * INF)


def safe_value(raw: tuple, current: float, limits: SafetyLimits) -> float:
    """Usually (not always: positions drift and rounding bites) within the limits."""
    selector, _, fraction = raw
    if selector < 65:
        value = current + 0.95 * fraction * limits.max_step
        if abs(value) > 0.8 * limits.max_displacement:  # drift back towards zero
            value = current - math.copysign(0.95 * abs(fraction) * limits.max_step, current)
        return value
    if selector < 80:
        return current
    sign = 1.0 if selector % 2 else -1.0
    if abs(current) > 0.5 * limits.max_displacement:
        sign = -math.copysign(1.0, current)
    return current + sign * 0.999 * limits.max_step  # a full step (exact edges: adversarial)


def adversarial_value(raw: tuple, current: float, limits: SafetyLimits) -> float:
    """Any float, NaN, inf, huge, tiny, exactly at or just beyond a limit, or a large jump."""
    selector, anything, fraction = raw
    sign = 1.0 if selector % 2 == 0 else -1.0
    where = ('at', 'above', 'below')[selector % 3]
    if selector < 20:
        return anything
    if selector < 40:
        return SPECIALS[selector % len(SPECIALS)]
    if selector < 55:
        return edge_value('disp', sign, where, current, limits)
    if selector < 70:
        return edge_value('inc', sign, where, current, limits)
    if selector < 85:
        return edge_value('vel', sign, where, current, limits)
    if selector < 95:
        return current + 3.0 * fraction * limits.max_step
    return current


def build_target(shape: int, aux: int, dofs: list[tuple], current: list[float],
                 limits: SafetyLimits) -> Any:
    """Decode a target: all safe, one adversarial DOF, all adversarial, wrong length or junk."""
    n_dof = len(current)
    if shape < 84:
        return [safe_value(raw, c, limits) for raw, c in zip(dofs, current)]
    if shape < 92:
        bad = aux % n_dof
        return [adversarial_value(raw, c, limits) if dof == bad else safe_value(raw, c, limits)
                for dof, (raw, c) in enumerate(zip(dofs, current))]
    if shape < 96:
        return [adversarial_value(raw, c, limits) for raw, c in zip(dofs, current)]
    if shape < 98:
        return [0.0] * (aux % 6)
    return [None, 'x', object()][:n_dof]


def time_step(selector: int, fraction: float, limits: SafetyLimits) -> float:
    """Mostly no or little time; sometimes long; sometimes exactly at/around the timeout."""
    timeout = limits.watchdog_timeout
    span = timeout if timeout is not None else 1.0
    if selector < 30:
        return 0.0
    if selector < 70:
        return fraction * 0.5 * span
    if selector < 90:
        return fraction * 2.0 * span
    if timeout is None:
        return span
    return [timeout, just_above(timeout), just_below(timeout)][selector % 3]


def tracking_errors(limits: SafetyLimits) -> list[float]:
    tolerance = limits.tracking_tolerance or 1e-3
    return [0.0] * 12 + [tolerance, -tolerance, just_above(tolerance), 10 * tolerance, NAN]


@st.composite
def scenarios(draw: st.DrawFn) -> dict:
    """A bridge configuration and a random, adversarial stream of operations."""
    limits = draw(ANY_LIMITS)
    initial = draw(st.lists(st.sampled_from([0.0] * 8 + [0.5, 1.0, -1.0, 1.5]),
                            min_size=3, max_size=3))
    return {
        'limits': limits,
        'n_dof': draw(st.sampled_from([1, 3])),
        'synchronous': draw(st.booleans()),
        'stiffness': draw(st.floats(0.1, 1.2)) * limits.max_force / limits.max_displacement,
        'initial': [f * limits.max_displacement for f in initial],
        'ops': draw(st.lists(OP_RAW, min_size=20, max_size=80)),
    }


def assert_within_limits(
    limits: SafetyLimits, target: tuple[float, ...], before: tuple[float, ...], n_dof: int
) -> None:
    """Independent statement of the limits for one command that reached the driver."""
    assert len(target) == n_dof
    for x, x_before in zip(target, before):
        assert math.isfinite(x)
        assert abs(x) <= limits.max_displacement
        assert abs(x - x_before) <= limits.max_increment
        if limits.max_velocity is not None and limits.step_duration is not None:
            assert abs(x - x_before) / limits.step_duration <= limits.max_velocity


@dataclass
class Model:
    """What the test expects of the bridge, kept independently of it."""

    holding: bool = False
    emergency: bool = False
    armed: bool = False
    last_command_time: float = NAN
    step: int = 0
    iteration: int = 0
    last_key: Any = None
    clipped_in_flight: bool = False


def next_key(model: Model, how: str) -> Any:
    """The step key of the next command: new, next iteration, repeated, stale or foreign."""
    if how == 'next':
        model.step += 1
        model.iteration = 0
    elif how == 'iteration':
        model.iteration += 1
    elif how == 'repeat' and model.last_key is not None:
        return model.last_key
    elif how == 'stale':
        return (max(model.step - 1, 0), 0)
    elif how == 'int':
        return model.step  # a key of another type: foreign
    return (model.step, model.iteration)


def expect_watchdog(model: Model, limits: SafetyLimits, now: float) -> bool:
    timeout = limits.watchdog_timeout
    return (not model.holding and model.armed and timeout is not None
            and not now - model.last_command_time <= timeout)


def run_stream(scenario: dict, on_limit: str) -> dict[str, int]:
    """Run one stream and check every safety property after every operation."""
    limits: SafetyLimits = scenario['limits']
    n_dof: int = scenario['n_dof']
    driver = RecordingDriver(n_dof, scenario['stiffness'], scenario['synchronous'],
                             scenario['initial'][:n_dof])
    clock = Clock(1000.0)
    bridge = ActuatorBridge(driver, limits, ['a', 'b', 'c'][:n_dof], on_limit=on_limit,
                            clock=clock)
    published: list[Feedback] = []
    bridge.set_reply_callback(published.append)
    model = Model()
    errors = tracking_errors(limits)
    stats = {'sent': 0, 'saturated': 0, 'holds': 0, 'watchdog': 0}

    for index, raw in enumerate(scenario['ops']):
        selector, aux, shape, dofs, time_selector, fraction = decode_operation(raw, index)
        kind = op_kind(selector)
        dt = time_step(time_selector, fraction, limits)
        n_sent = len(driver.sent)
        published.clear()
        returned: Feedback | None = None
        requested: Any = None
        was_holding = model.holding
        if kind == 'cmd':
            clock.t += dt
            tripped = expect_watchdog(model, limits, clock.t)
            key = next_key(model, KEY_MODES[(aux // 8) % len(KEY_MODES)])
            model.last_key = key
            requested = build_target(shape, aux, dofs, driver.position(), limits)
            returned = bridge.handle_command(TEST_IDS[aux % len(TEST_IDS)], key, requested)
            if tripped:
                assert returned is not None and returned.status is FeedbackStatus.FAULT
                assert returned.message.startswith('watchdog: ')
                stats['watchdog'] += 1
            elif not model.holding:
                model.armed = True
                model.last_command_time = clock.t
        elif kind == 'measure':
            driver.deliver(errors[aux % len(errors)], FORCE_SCALES[shape % len(FORCE_SCALES)])
            if model.clipped_in_flight:
                # A clipped move is never answered silently.
                assert all(reply.status is not FeedbackStatus.OK for reply in published)
        elif kind == 'error':
            driver.error = errors[aux % len(errors)]
        elif kind == 'reset':
            clear = aux % 3 != 0
            expected = not (model.emergency and not clear)
            assert bridge.reset(clear_emergency=clear) is expected
            if expected:
                model.emergency = False
                if model.holding:
                    model.holding = False
                    model.armed = False
        elif kind == 'estop':
            returned = bridge.emergency_stop('stream')
            model.holding = model.emergency = True
        elif kind == 'watchdog':
            clock.t += dt
            tripped = expect_watchdog(model, limits, clock.t)
            returned = bridge.check_watchdog()
            if tripped:
                assert returned is not None and returned.message.startswith('watchdog: ')
                stats['watchdog'] += 1
            else:
                assert returned is None
        elif kind == 'advance':
            clock.t += dt
        else:
            bridge.handle_fault('stream fault')
            model.holding = True

        new = driver.sent[n_sent:]
        # At most one motion, only for a command, never while holding, never beyond a limit.
        assert len(new) <= 1
        if new:
            assert kind == 'cmd' and not was_holding
            _, target, before = new[0]
            assert_within_limits(limits, target, before, n_dof)
            stats['sent'] += 1
            clipped = target != tuple(float(x) for x in requested)
            if on_limit == 'hold':
                assert not clipped  # 'hold' never alters a command
            model.clipped_in_flight = clipped
            if clipped and driver.synchronous:
                assert returned is not None and returned.status is not FeedbackStatus.OK
        replies = ([returned] if returned is not None else []) + published
        for reply in replies:
            assert reply.status in (FeedbackStatus.OK, FeedbackStatus.LIMIT, FeedbackStatus.FAULT)
            assert '\n' not in reply.message
            assert len(reply.measured_displacement) == n_dof
            assert len(reply.restoring_force) == n_dof
            if reply.message.startswith('saturated: '):
                assert on_limit == 'saturate' and reply.status is FeedbackStatus.LIMIT
                stats['saturated'] += 1
            elif reply.status is not FeedbackStatus.OK:
                model.holding = True  # every other non-'ok' answer is a hold
            else:
                assert reply.message == ''
        if model.holding and not was_holding:
            stats['holds'] += 1
        # The model and the bridge agree on whether it holds and whether an e-stop is latched.
        assert (bridge.state == 'holding') == model.holding
        assert bridge.emergency_stopped == model.emergency
        assert bridge.state != 'busy' or not driver.synchronous
    # Cross-check with the driver's own log: each command started where the driver was.
    for _, target, before in driver.sent:
        assert_within_limits(limits, target, before, n_dof)
    return stats


@pytest.mark.parametrize('on_limit', ['hold', 'saturate'])
def test_adversarial_streams_never_command_beyond_limits(on_limit: str) -> None:
    """Random streams: nothing beyond a limit reaches the driver; nothing at all while held."""
    totals = {'examples': 0, 'sent': 0, 'saturated': 0, 'holds': 0, 'watchdog': 0}

    @HYPOTHESIS_SETTINGS
    @given(scenarios())
    def check(scenario: dict) -> None:
        stats = run_stream(scenario, on_limit)
        totals['examples'] += 1
        for key, value in stats.items():
            totals[key] += value

    check()
    # The streams exercised every path, not just the rejections (about half of these counts are
    # reached with hypothesis 6.170 and derandomize=True).
    assert totals['examples'] >= 200
    assert totals['sent'] > 800
    assert totals['holds'] > 300
    assert totals['watchdog'] > 40
    if on_limit == 'saturate':
        assert totals['saturated'] > 60
    else:
        assert totals['saturated'] == 0


def exactly_allowed(target: float, current: float, limits: SafetyLimits) -> bool:
    """The limits of one DOF in exact rational arithmetic."""
    increment = abs(Fraction(target) - Fraction(current))
    if abs(target) > limits.max_displacement or increment > Fraction(limits.max_increment):
        return False
    if limits.max_velocity is not None and limits.step_duration is not None:
        return increment <= Fraction(limits.max_velocity) * Fraction(limits.step_duration)
    return True


@HYPOTHESIS_SETTINGS
@given(
    limits=ANY_LIMITS,
    n_dof=st.sampled_from([1, 3]),
    positions=st.lists(st.floats(-1.5, 1.5), min_size=3, max_size=3),
    dofs=st.lists(DOF_RAW, min_size=3, max_size=3),
)
def test_saturate_command_is_safe_and_nearest(
    limits: SafetyLimits, n_dof: int, positions: list[float], dofs: list[tuple]
) -> None:
    """Any finite request is clipped to the allowed value nearest to it, DOF by DOF."""
    current = [f * limits.max_displacement for f in positions[:n_dof]]
    target = [adversarial_value(raw, c, limits) for raw, c in zip(dofs, current)]
    result = saturate_command(target, current, limits)
    if not all(math.isfinite(x) for x in target):
        assert result.target is None and result.violation is not None
        assert result.violation.kind is FeedbackStatus.FAULT
        return
    if result.target is None:
        assert result.violation is not None and result.violation.kind is FeedbackStatus.LIMIT
        assert 'cannot saturate' in result.violation.message
        # Only a DOF that starts more than one step beyond max_displacement cannot be clipped.
        dof = result.violation.dof
        assert abs(current[dof]) > limits.max_displacement
        return
    assert check_command(result.target, current, limits) is None
    for x_sent, x_wanted, x_current in zip(result.target, target, current):
        if check_command([x_wanted], [x_current], limits) is None:
            assert x_sent == x_wanted  # an allowed DOF is not touched
        else:
            assert exactly_allowed(x_sent, x_current, limits)
            further = math.nextafter(x_sent, x_wanted)
            assert (check_command([further], [x_current], limits) is not None
                    or not exactly_allowed(further, x_current, limits))
    assert result.clipped == (tuple(result.target) != tuple(target))

"""Tests of the actuator bridge core: safety limits, the loopback driver, the bridge and the
driver registry."""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pytest
import yaml

from pd_actuator_bridge.core import (
    ActuatorBridge,
    ActuatorDriver,
    ActuatorMeasurement,
    BridgeConfigError,
    BridgeError,
    DriverContext,
    DriverError,
    DriverParameter,
    DriverSpec,
    EmulatorDriver,
    GenericTCPDriver,
    LimitViolation,
    OpenSeesAdapterDriver,
    SafetyLimits,
    check_command,
    check_feedback,
    driver_names,
    driver_parameters,
    driver_spec,
    make_driver,
    register_driver,
)
from pd_actuator_bridge.core.drivers import registry
from pd_common.protocol import Feedback, FeedbackStatus, StateOrigin
from pd_common.registry import ParameterError
from support.loopback import LoopbackDriver
from support.sections import INLINE_GROUND_MOTION

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


def just_above(value: float) -> float:
    """The next float beyond ``value`` away from zero."""
    return float(np.nextafter(value, math.copysign(INF, value)))


def linear_spring(stiffness: float):
    """A restoring force f = k x per DOF."""

    def restoring_force(x: list[float]) -> list[float]:
        return [stiffness * xi for xi in x]

    return restoring_force


def make_bridge(
    limits: SafetyLimits = LIMITS,
    stiffness: float = 1000.0,
    n_dof: int = 1,
    initial_position: Sequence[float] | None = None,
) -> tuple[ActuatorBridge, LoopbackDriver]:
    driver = LoopbackDriver(linear_spring(stiffness), n_dof, initial_position)
    driver.open()
    names = ['top', 'bottom', 'third'][:n_dof]
    return ActuatorBridge(driver, limits, names), driver


class AsyncDriver(ActuatorDriver):
    """A driver that answers later, when the test calls ``answer``."""

    def __init__(self, n_dof: int = 1) -> None:
        super().__init__()
        self._n = n_dof
        self._position = [0.0] * n_dof
        self.commands: list[tuple[int, tuple[float, ...]]] = []
        self.hold_count = 0

    @property
    def n_dof(self) -> int:
        return self._n

    def command(self, step: int, target: Sequence[float]) -> None:
        self.commands.append((step, tuple(target)))

    def hold(self) -> None:
        self.hold_count += 1

    def position(self) -> list[float]:
        return list(self._position)

    def answer(self, step: int, displacement: list[float], force: list[float]) -> None:
        self._position = list(displacement)
        self._emit(ActuatorMeasurement(step, displacement, force))


class FailingDriver(LoopbackDriver):
    """A loopback driver whose command() raises after recording."""

    def command(self, step: int, target: Sequence[float]) -> None:
        self.commands.append((step, tuple(target)))
        raise DriverError('controller offline')


# ---------------------------------------------------------------------------- errors


def test_error_hierarchy() -> None:
    assert issubclass(BridgeConfigError, BridgeError)
    assert issubclass(BridgeConfigError, ValueError)
    assert issubclass(DriverError, BridgeError)
    assert not issubclass(DriverError, ValueError)


# ---------------------------------------------------------------------------- config


def test_from_mapping_reads_all_keys() -> None:
    limits = SafetyLimits.from_mapping(
        {
            'max_displacement': 0.25,
            'max_increment': 0.01,
            'max_force': 5000,
            'max_velocity': 0.1,
            'step_duration': 0.05,
        },
        'bridge.yaml',
    )
    assert limits == SafetyLimits(0.25, 0.01, 5000.0, 0.1, 0.05)
    assert isinstance(limits.max_force, float)
    assert limits.velocity_checked


def test_from_mapping_optional_keys_default_to_none() -> None:
    limits = SafetyLimits.from_mapping(
        {'max_displacement': 0.25, 'max_increment': 0.01, 'max_force': 5000.0}, 'bridge.yaml'
    )
    assert limits.max_velocity is None
    assert limits.step_duration is None
    assert not limits.velocity_checked


@pytest.mark.parametrize(
    ('mapping', 'expected'),
    [
        (
            {'max_displacement': 0.25, 'max_increment': 0.01, 'max_force': 1.0, 'max_disp': 1},
            "bridge.yaml: unknown safety limit 'max_disp'",
        ),
        (
            {'max_displacement': 0.25, 'max_increment': 0.01},
            "bridge.yaml: missing required safety limit 'max_force'",
        ),
        (
            {'max_displacement': -0.25, 'max_increment': 0.01, 'max_force': 1.0},
            'bridge.yaml: max_displacement must be a positive finite number, got -0.25',
        ),
        (
            {'max_displacement': 0.25, 'max_increment': 0.0, 'max_force': 1.0},
            'bridge.yaml: max_increment must be a positive finite number, got 0.0',
        ),
        (
            {'max_displacement': 0.25, 'max_increment': 0.01, 'max_force': NAN},
            'bridge.yaml: max_force must be a positive finite number, got nan',
        ),
        (
            {'max_displacement': INF, 'max_increment': 0.01, 'max_force': 1.0},
            'bridge.yaml: max_displacement must be a positive finite number, got inf',
        ),
        (
            {'max_displacement': 0.25, 'max_increment': '1e-3', 'max_force': 1.0},
            "bridge.yaml: max_increment must be a positive finite number, got str '1e-3'",
        ),
        (
            {'max_displacement': 0.25, 'max_increment': 0.01, 'max_force': True},
            'bridge.yaml: max_force must be a positive finite number, got bool True',
        ),
        (
            {'max_displacement': 0.25, 'max_increment': 0.01, 'max_force': 1.0,
             'max_velocity': 0.1, 'step_duration': -1.0},
            'bridge.yaml: step_duration must be a positive finite number, got -1.0',
        ),
        (
            {'max_displacement': 0.25, 'max_increment': 0.01, 'max_force': 1.0,
             'max_velocity': 0.1},
            'bridge.yaml: max_velocity requires step_duration',
        ),
    ],
)
def test_from_mapping_rejects_bad_config(mapping: dict, expected: str) -> None:
    with pytest.raises(BridgeConfigError) as info:
        SafetyLimits.from_mapping(mapping, 'bridge.yaml')
    message = str(info.value)
    assert message.startswith(expected)
    assert '\n' not in message


def test_from_mapping_rejects_non_mapping() -> None:
    with pytest.raises(BridgeConfigError, match=r'bridge.yaml: safety limits must be a mapping'):
        SafetyLimits.from_mapping([0.25, 0.01, 1.0], 'bridge.yaml')  # type: ignore[arg-type]


def test_direct_construction_is_validated() -> None:
    with pytest.raises(BridgeConfigError, match='SafetyLimits: max_force must be a positive'):
        SafetyLimits(max_displacement=0.25, max_increment=0.01, max_force=-1.0)


def test_bridge_config_validation() -> None:
    driver = LoopbackDriver(linear_spring(1.0), 2)
    with pytest.raises(BridgeConfigError, match="on_limit must be one of hold, got 'continue'"):
        ActuatorBridge(driver, LIMITS, ['a', 'b'], on_limit='continue')
    with pytest.raises(BridgeConfigError, match='dof_names has 1 names but the driver has 2 DOF'):
        ActuatorBridge(driver, LIMITS, ['a'])
    with pytest.raises(BridgeConfigError, match='dof_names must be unique'):
        ActuatorBridge(driver, LIMITS, ['a', 'a'])
    with pytest.raises(BridgeConfigError, match='dof_names must be non-empty strings'):
        ActuatorBridge(driver, LIMITS, ['a', ''])
    with pytest.raises(BridgeConfigError, match='limits must be SafetyLimits, got dict'):
        ActuatorBridge(driver, {'max_force': 1.0}, ['a', 'b'])  # type: ignore[arg-type]
    with pytest.raises(BridgeConfigError, match='n_dof must be a positive integer'):
        LoopbackDriver(linear_spring(1.0), 0)
    with pytest.raises(BridgeConfigError, match='initial_position has 1 values, expected 2'):
        LoopbackDriver(linear_spring(1.0), 2, [0.0])


# ---------------------------------------------------------------------------- check_command


@pytest.mark.parametrize('sign', [1.0, -1.0])
def test_displacement_limit_each_way(sign: float) -> None:
    at = sign * 0.25
    assert check_command([at], [at], LIMITS) is None
    violation = check_command([just_above(at)], [at], LIMITS)
    assert violation is not None
    assert (violation.kind, violation.dof) == (FeedbackStatus.LIMIT, 0)
    assert 'max_displacement 0.25 m' in violation.message


@pytest.mark.parametrize('sign', [1.0, -1.0])
def test_increment_limit_each_way(sign: float) -> None:
    current = [0.0, 0.0625]
    assert check_command([sign * 0.125, 0.0625], current, LIMITS) is None
    assert check_command([0.0, 0.0625 + sign * 0.125], current, LIMITS) is None
    violation = check_command([0.0, 0.0625 + sign * just_above(0.125)], current, LIMITS)
    assert violation is not None
    assert (violation.kind, violation.dof) == (FeedbackStatus.LIMIT, 1)
    assert 'exceeds max_increment 0.125 m' in violation.message


@pytest.mark.parametrize('sign', [1.0, -1.0])
def test_velocity_limit_each_way(sign: float) -> None:
    # max_velocity * step_duration = 0.0625 m per step, tighter than max_increment.
    assert check_command([sign * 0.0625], [0.0], VELOCITY_LIMITS) is None
    violation = check_command([sign * just_above(0.0625)], [0.0], VELOCITY_LIMITS)
    assert violation is not None
    assert violation.kind is FeedbackStatus.LIMIT
    assert 'exceeds max_velocity 0.5 m/s' in violation.message
    # Without the velocity limit the same increment is allowed.
    assert check_command([sign * 0.1], [0.0], LIMITS) is None


def test_limit_message_names_dof_value_and_limit() -> None:
    violation = check_command([0.31], [0.25], LIMITS, ['top'])
    assert violation == LimitViolation(
        FeedbackStatus.LIMIT, 0,
        'DOF 0 (top): target displacement 0.31 m exceeds max_displacement 0.25 m',
    )
    # A value just beyond the limit never prints equal to it.
    violation = check_command([just_above(0.25)], [0.25], LIMITS, ['top'])
    assert violation is not None
    assert '0.25 m exceeds' not in violation.message


@pytest.mark.parametrize('bad', [NAN, INF, -INF])
def test_non_finite_target_is_a_fault(bad: float) -> None:
    violation = check_command([0.0, bad], [0.0, 0.0], LIMITS)
    assert violation is not None
    assert (violation.kind, violation.dof) == (FeedbackStatus.FAULT, 1)
    assert violation.message == f'non-finite target displacement for DOF 1: {bad}'
    assert check_command([NAN], [0.0], LIMITS) == LimitViolation(
        FeedbackStatus.FAULT, 0, 'non-finite target displacement for DOF 0: nan'
    )


@pytest.mark.parametrize(
    ('target', 'current', 'fragment'),
    [
        ([0.0], [0.0, 0.0], 'target displacement has 1 values but the actuator has 2 DOF'),
        ([0.0, 0.0, 0.0], [0.0, 0.0], 'has 3 values but the actuator has 2 DOF'),
        ('00', [0.0, 0.0], 'target displacement must be a sequence of numbers, got str'),
        (0.1, [0.0], 'target displacement must be a sequence of numbers, got float'),
        ([None, 0.0], [0.0, 0.0], 'target displacement for DOF 0 is not a number: None'),
        ([10**400], [0.0], 'target displacement for DOF 0 is not a number'),
        ([0.0], [NAN], 'non-finite current displacement for DOF 0: nan'),
    ],
)
def test_malformed_command_is_a_fault(target, current, fragment: str) -> None:
    violation = check_command(target, current, LIMITS)
    assert violation is not None
    assert violation.kind is FeedbackStatus.FAULT
    assert fragment in violation.message


def test_check_order_fault_then_displacement_then_increment() -> None:
    # DOF 0 beyond every limit, DOF 1 NaN: the fault wins.
    violation = check_command([10.0, NAN], [0.0, 0.0], LIMITS)
    assert violation is not None and violation.kind is FeedbackStatus.FAULT
    # DOF 0 beyond the increment only, DOF 1 beyond the displacement: displacement wins.
    violation = check_command([0.2, 0.3], [0.0, 0.25], LIMITS)
    assert violation is not None and violation.dof == 1 and 'max_displacement' in violation.message
    # Beyond increment and velocity: increment wins.
    violation = check_command([0.2], [0.0], VELOCITY_LIMITS)
    assert violation is not None and 'max_increment' in violation.message


def test_check_command_accepts_numpy() -> None:
    assert check_command(np.array([0.1, -0.1]), np.zeros(2), LIMITS) is None


# ---------------------------------------------------------------------------- check_feedback


@pytest.mark.parametrize('sign', [1.0, -1.0])
def test_force_limit_each_way(sign: float) -> None:
    assert check_feedback([0.0], [sign * 1000.0], LIMITS) is None
    violation = check_feedback([0.0], [sign * just_above(1000.0)], LIMITS, ['top'])
    assert violation is not None
    assert (violation.kind, violation.dof) == (FeedbackStatus.LIMIT, 0)
    assert violation.message.startswith('DOF 0 (top): measured force')
    assert violation.message.endswith('exceeds max_force 1000 N')


@pytest.mark.parametrize(
    ('displacement', 'force', 'fragment'),
    [
        ([NAN], [0.0], 'non-finite measured displacement for DOF 0: nan'),
        ([0.0], [INF], 'non-finite measured force for DOF 0: inf'),
        ([0.0], [-INF], 'non-finite measured force for DOF 0: -inf'),
        ([0.0], [0.0, 0.0], 'measured force has 2 values but the actuator has 1 DOF'),
    ],
)
def test_bad_feedback_is_a_fault(displacement, force, fragment: str) -> None:
    violation = check_feedback(displacement, force, LIMITS)
    assert violation is not None
    assert violation.kind is FeedbackStatus.FAULT
    assert violation.message == fragment


def test_feedback_length_checked_against_n_dof() -> None:
    violation = check_feedback([0.0], [0.0], LIMITS, n_dof=2)
    assert violation is not None and violation.kind is FeedbackStatus.FAULT
    assert check_feedback([0.0, 0.0], [0.0, 0.0], LIMITS, n_dof=2) is None


# ---------------------------------------------------------------------------- loopback driver


def test_loopback_driver_answers_synchronously_and_records() -> None:
    driver = LoopbackDriver(linear_spring(2000.0), 2, [0.01, 0.0])
    received = []
    driver.set_measurement_callback(
        lambda m: received.append((m.step, list(m.displacement), list(m.force))))
    assert driver.position() == [0.01, 0.0]
    with pytest.raises(DriverError, match='before open'):
        driver.command(0, [0.0, 0.0])
    driver.open()
    driver.command(3, [0.02, -0.01])
    assert received == [(3, [0.02, -0.01], [40.0, -20.0])]
    assert driver.position() == [0.02, -0.01]
    assert driver.commands[-1] == (3, (0.02, -0.01))


def test_loopback_driver_wraps_model_errors() -> None:
    def broken(x: list[float]) -> list[float]:
        raise ZeroDivisionError('boom')

    driver = LoopbackDriver(broken, 1)
    driver.open()
    with pytest.raises(DriverError, match='restoring_force failed at step 4: ZeroDivisionError'):
        driver.command(4, [0.0])


# ---------------------------------------------------------------------------- bridge


def test_ok_step_returns_measurement() -> None:
    bridge, driver = make_bridge(stiffness=4000.0)
    published: list[Feedback] = []
    bridge.set_reply_callback(published.append)
    reply = bridge.handle_command('t1', 0, [0.0])
    assert reply == Feedback('t1', 0, (0.0,), (0.0,), FeedbackStatus.OK, '')
    reply = bridge.handle_command('t1', 1, np.array([0.0625]))
    assert reply == Feedback('t1', 1, (0.0625,), (250.0,), FeedbackStatus.OK, '')
    assert bridge.state == 'ready'
    assert driver.commands == [(0, (0.0,)), (1, (0.0625,))]
    assert bridge.commands_received == 2
    assert bridge.violations == 0
    assert published == []  # a synchronous answer is returned, not published twice


def test_repeated_step_returns_identical_reply_without_moving() -> None:
    bridge, driver = make_bridge()
    bridge.handle_command('t1', 0, [0.0])
    first = bridge.handle_command('t1', 1, [0.1])
    n_commands = len(driver.commands)
    again = bridge.handle_command('t1', 1, [0.1])
    # Even a repeat carrying a different target does not move.
    different = bridge.handle_command('t1', 1, [0.2])
    assert again is first
    assert different is first
    assert len(driver.commands) == n_commands
    assert bridge.repeated_steps == 2
    assert driver.position() == [0.1]


def test_stale_step_is_ignored_and_counted() -> None:
    bridge, driver = make_bridge()
    for step, x in enumerate([0.0, 0.05, 0.1]):
        bridge.handle_command('t1', step, [x])
    n_commands = len(driver.commands)
    assert bridge.handle_command('t1', 1, [0.05]) is None
    assert bridge.handle_command('t1', 0, [0.0]) is None
    assert bridge.ignored_commands == 2
    assert len(driver.commands) == n_commands
    assert driver.position() == [0.1]
    assert bridge.state == 'ready'


def test_new_test_id_starts_fresh_but_keeps_position() -> None:
    bridge, driver = make_bridge()
    for step, x in enumerate([0.0, 0.1, 0.2]):
        bridge.handle_command('t1:probe', step, [x])
    # Step 0 of a new test is not stale, and is checked from the actual position (0.2).
    reply = bridge.handle_command('t1', 0, [0.125])
    assert reply is not None and reply.status is FeedbackStatus.OK and reply.step == 0
    assert bridge.ignored_commands == 0
    # Same step number as the last answered one, but under another test id: it moves.
    reply = bridge.handle_command('t2', 0, [0.1])
    assert reply == Feedback('t2', 0, (0.1,), (100.0,), FeedbackStatus.OK, '')
    assert len(driver.commands) == 5
    reply = bridge.handle_command('t2', 1, [-0.05])
    assert reply is not None and reply.status is FeedbackStatus.LIMIT
    assert 'max_increment' in reply.message


@pytest.mark.parametrize('bad', [NAN, INF, -INF])
def test_non_finite_command_never_reaches_driver(bad: float) -> None:
    bridge, driver = make_bridge(n_dof=2)
    bridge.handle_command('t1', 0, [0.0, 0.05])
    reply = bridge.handle_command('t1', 1, [0.01, bad])
    assert reply is not None
    assert reply.status is FeedbackStatus.FAULT
    assert reply.message == f'non-finite target displacement for DOF 1 (bottom): {bad}'
    assert reply.measured_displacement == (0.0, 0.05)
    assert reply.restoring_force == (0.0, 50.0)
    assert driver.commands == [(0, (0.0, 0.05))]
    assert driver.hold_count == 1
    assert bridge.state == 'holding'
    assert bridge.violations == 1


def test_limit_holds_and_the_hold_is_latched_until_reset() -> None:
    bridge, driver = make_bridge(stiffness=2000.0)
    bridge.handle_command('t1', 0, [0.0])
    bridge.handle_command('t1', 1, [0.1])
    reply = bridge.handle_command('t1', 2, [0.3])
    expected_reason = 'DOF 0 (top): target displacement 0.3 m exceeds max_displacement 0.25 m'
    assert reply == Feedback('t1', 2, (0.1,), (200.0,), FeedbackStatus.LIMIT, expected_reason)
    assert bridge.state == 'holding'
    assert bridge.hold_reason == expected_reason
    assert bridge.hold_status is FeedbackStatus.LIMIT
    # Safe commands, repeats and new tests do not move while holding.
    for test_id, step, x in [('t1', 2, [0.15]), ('t1', 3, [0.1]), ('t2', 0, [0.1])]:
        held = bridge.handle_command(test_id, step, x)
        assert held == Feedback(
            test_id, step, (0.1,), (200.0,), FeedbackStatus.LIMIT, expected_reason
        )
    assert len(driver.commands) == 2
    assert driver.position() == [0.1]
    assert driver.hold_count == 1
    assert bridge.violations == 1

    bridge.reset()
    assert bridge.state == 'ready'
    assert bridge.hold_reason == ''
    # The rejected step is evaluated afresh after the reset; older steps stay stale.
    assert bridge.handle_command('t1', 1, [0.1]) is None
    reply = bridge.handle_command('t1', 2, [0.15])
    assert reply == Feedback('t1', 2, (0.15,), (300.0,), FeedbackStatus.OK, '')
    assert len(driver.commands) == 3


def test_reset_when_not_holding_does_nothing() -> None:
    bridge, _driver = make_bridge()
    first = bridge.handle_command('t1', 0, [0.0])
    bridge.reset()
    assert bridge.handle_command('t1', 0, [0.0]) is first


def test_force_limit_on_feedback_triggers_hold() -> None:
    bridge, driver = make_bridge(stiffness=10000.0)  # 1000 N at 0.1 m
    # Exactly at max_force.
    assert bridge.handle_command('t1', 0, [0.1]).status is FeedbackStatus.OK
    reply = bridge.handle_command('t1', 1, [0.125])
    assert reply is not None
    assert reply.status is FeedbackStatus.LIMIT
    assert reply.measured_displacement == (0.125,)
    assert reply.restoring_force == (1250.0,)
    assert reply.message == 'DOF 0 (top): measured force 1250 N exceeds max_force 1000 N'
    assert bridge.state == 'holding'
    assert driver.hold_count == 1
    assert bridge.handle_command('t1', 2, [0.0]).status is FeedbackStatus.LIMIT
    assert len(driver.commands) == 2


def test_non_finite_feedback_is_a_fault_and_keeps_last_good_values() -> None:
    load_cell = {'broken': False}

    def restoring_force(x: list[float]) -> list[float]:
        return [NAN if load_cell['broken'] else 1000.0 * x[0]]

    driver = LoopbackDriver(restoring_force, 1)
    driver.open()
    bridge = ActuatorBridge(driver, LIMITS, ['top'])
    bridge.handle_command('t1', 0, [0.05])
    load_cell['broken'] = True
    reply = bridge.handle_command('t1', 1, [0.1])
    assert reply is not None
    assert reply.status is FeedbackStatus.FAULT
    assert reply.message == 'non-finite measured force for DOF 0 (top): nan'
    assert reply.restoring_force == (50.0,)
    assert bridge.state == 'holding'


def test_driver_failure_is_a_fault_hold() -> None:
    driver = FailingDriver(linear_spring(1.0), 1)
    bridge = ActuatorBridge(driver, LIMITS, ['top'])
    reply = bridge.handle_command('t1', 0, [0.0])
    assert reply is not None
    assert reply.status is FeedbackStatus.FAULT
    assert reply.message == 'driver command() failed at step 0: DriverError: controller offline'
    assert math.isnan(reply.restoring_force[0])  # no measurement yet
    assert bridge.state == 'holding'
    assert driver.hold_count == 1


def test_model_failure_in_loopback_is_a_fault_hold() -> None:
    driver = LoopbackDriver(lambda x: 1 / 0, 1)
    driver.open()
    bridge = ActuatorBridge(driver, LIMITS, ['top'])
    reply = bridge.handle_command('t1', 0, [0.0])
    assert reply is not None and reply.status is FeedbackStatus.FAULT
    assert 'restoring_force failed at step 0' in reply.message


def test_async_driver_in_flight_bookkeeping() -> None:
    driver = AsyncDriver()
    bridge = ActuatorBridge(driver, LIMITS, ['top'])
    published: list[Feedback] = []
    bridge.set_reply_callback(published.append)

    assert bridge.handle_command('t1', 0, [0.05]) is None
    assert bridge.state == 'busy'
    assert bridge.in_flight == ('t1', 0)
    # Duplicate of the step in flight: no second motion.
    assert bridge.handle_command('t1', 0, [0.05]) is None
    assert bridge.repeated_steps == 1
    # Another step while busy: ignored.
    assert bridge.handle_command('t1', 1, [0.06]) is None
    assert bridge.ignored_commands == 1
    assert driver.commands == [(0, (0.05,))]
    # A measurement for another step is ignored.
    driver.answer(7, [0.05], [1.0])
    assert published == [] and bridge.ignored_measurements == 1
    driver.answer(0, [0.05], [12.5])
    assert published == [Feedback('t1', 0, (0.05,), (12.5,), FeedbackStatus.OK, '')]
    assert bridge.state == 'ready'
    # Now a repeat of step 0 is answered from the last reply.
    assert bridge.handle_command('t1', 0, [0.05]) is published[0]

    # A timeout detected by the node layer holds and answers the step in flight.
    assert bridge.handle_command('t1', 1, [0.06]) is None
    reply = bridge.handle_fault('no measurement for step 1 within 2 s')
    assert reply == Feedback(
        't1', 1, (0.05,), (12.5,), FeedbackStatus.FAULT, 'no measurement for step 1 within 2 s'
    )
    assert bridge.state == 'holding'
    assert driver.hold_count == 1
    # The late measurement is ignored.
    driver.answer(1, [0.06], [15.0])
    assert len(published) == 1


class SimulatedAsyncDriver(AsyncDriver):
    """An AsyncDriver whose specimen is simulated (a restarted process may restore it)."""

    @property
    def state_origin(self) -> StateOrigin:
        return StateOrigin.RESTORED


def test_the_supervisor_leaves_only_its_own_hold_or_a_simulated_specimens_timeout() -> None:
    """hold_for_supervisor / held_by_supervisor: the holds the supervisor's auto_reset may leave.
    Its own hold (also when sent again), or a simulated specimen's driver timeout with nothing
    since (the process behind the driver died); never a physical actuator's timeout, a limit's,
    another fault's, a person's or an emergency stop's; a reset ends it."""
    physical = ActuatorBridge(AsyncDriver(), LIMITS, ['top'])
    physical.handle_command('t1', 0, [0.05])
    physical.handle_fault('actuator did not reach step 0 within 5.0 s', timeout=True)
    assert physical.hold_for_supervisor('held by run_test') is None
    assert physical.state == 'holding' and not physical.held_by_supervisor

    bridge = ActuatorBridge(SimulatedAsyncDriver(), LIMITS, ['top'])
    bridge.handle_command('t1', 0, [0.05])
    assert not bridge.held_by_supervisor
    reply = bridge.hold_for_supervisor('held by run_test')  # not holding: it holds now
    assert reply is not None and reply.status is FeedbackStatus.FAULT
    assert bridge.held_by_supervisor
    assert bridge.hold_for_supervisor('held by run_test') is None  # sent again: still its own
    assert bridge.held_by_supervisor
    bridge.handle_fault('held by ana (pd control)')  # a person's hold on top: theirs now
    assert bridge.state == 'holding' and not bridge.held_by_supervisor
    bridge.hold_for_supervisor('held by run_test')
    assert not bridge.held_by_supervisor
    assert bridge.reset() and not bridge.held_by_supervisor

    bridge.handle_command('t1', 1, [0.05])
    bridge.handle_fault('actuator did not reach step 1 within 5.0 s', timeout=True)
    assert not bridge.held_by_supervisor  # a timeout is its own until the supervisor says so
    bridge.hold_for_supervisor('held by run_test')
    assert bridge.held_by_supervisor
    assert bridge.reset() and not bridge.held_by_supervisor

    bridge.handle_command('t1', 2, [0.05])
    bridge.handle_fault('actuator did not reach step 2 within 5.0 s', timeout=True)
    bridge.emergency_stop('button')  # a later cause: no longer the timeout's alone
    bridge.hold_for_supervisor('held by run_test')
    assert bridge.state == 'holding' and not bridge.held_by_supervisor
    assert bridge.reset(clear_emergency=True)

    # A limit's hold, then a timeout while it holds: still the limit's.
    bridge.handle_command('t1', 3, [0.05])
    limit = bridge.handle_measurement(ActuatorMeasurement(3, (0.05,), (-1500.0,)))
    assert limit is not None and limit.status is FeedbackStatus.LIMIT
    assert bridge.handle_fault('actuator did not reach step 3 within 5.0 s', timeout=True) is None
    bridge.hold_for_supervisor('held by run_test')
    assert bridge.state == 'holding' and not bridge.held_by_supervisor
    # Another fault (a driver's own report) is not a timeout.
    assert bridge.reset()
    bridge.handle_command('t1', 4, [0.05])
    bridge.handle_fault('driver: the specimen refused the move')
    bridge.hold_for_supervisor('held by run_test')
    assert bridge.state == 'holding' and not bridge.held_by_supervisor


def test_async_force_limit_holds() -> None:
    driver = AsyncDriver()
    bridge = ActuatorBridge(driver, LIMITS, ['top'])
    bridge.handle_command('t1', 0, [0.05])
    reply = bridge.handle_measurement(ActuatorMeasurement(0, (0.05,), (-1500.0,)))
    assert reply is not None and reply.status is FeedbackStatus.LIMIT
    assert bridge.state == 'holding'
    assert driver.hold_count == 1


def test_hold_before_any_measurement_reports_nan_force() -> None:
    bridge, driver = make_bridge()
    reply = bridge.handle_command('t1', 0, [1.0])
    assert reply is not None and reply.status is FeedbackStatus.LIMIT
    assert reply.measured_displacement == (0.0,)
    assert math.isnan(reply.restoring_force[0])
    assert driver.commands == []


# ---------------------------------------------------------------------------- safety property


def plausible_value(rng: np.random.Generator, current: float, limits: SafetyLimits) -> float:
    """A small step drifting back towards zero, or now and then a step towards a bound."""
    if rng.random() < 0.05:
        return float(np.clip(current + rng.choice([1.0, -1.0]) * 0.0625, -0.25, 0.25))
    return 0.9 * current + float(rng.normal(0.0, 0.3 * limits.max_increment))


def adversarial_value(rng: np.random.Generator, current: float, limits: SafetyLimits) -> float:
    """NaN, inf, huge jumps, values exactly at or just beyond a limit, or random jumps."""
    sign = float(rng.choice([1.0, -1.0]))
    step_limit = limits.max_increment
    if limits.max_velocity is not None and limits.step_duration is not None:
        step_limit = min(step_limit, limits.max_velocity * limits.step_duration)
    choice = rng.integers(10)
    if choice == 0:
        return NAN
    if choice == 1:
        return sign * INF
    if choice == 2:
        return sign * float(rng.choice([1e300, 1e3, 1.0]))
    if choice == 3:
        return sign * limits.max_displacement
    if choice == 4:
        return just_above(sign * limits.max_displacement)
    if choice == 5:
        return current + sign * limits.max_increment
    if choice == 6:
        return current + sign * just_above(limits.max_increment)
    if choice == 7:
        return current + sign * step_limit
    if choice == 8:
        return current + sign * just_above(step_limit)
    return float(rng.uniform(-2.0, 2.0) * limits.max_displacement)


@pytest.mark.parametrize('limits', [LIMITS, VELOCITY_LIMITS], ids=['no-velocity', 'velocity'])
def test_randomised_stream_never_commands_beyond_limits(limits: SafetyLimits) -> None:
    """Thousands of random and adversarial commands: nothing beyond a limit reaches the driver."""
    rng = np.random.default_rng(20240611)
    n_dof = 2
    # 5000 N/m: the force limit (1000 N) is reached at 0.2 m, inside max_displacement.
    bridge, driver = make_bridge(limits, stiffness=5000.0, n_dof=n_dof)
    test_id, step = 'rand', 0
    statuses: dict[object, int] = {FeedbackStatus.OK: 0, FeedbackStatus.LIMIT: 0,
                                   FeedbackStatus.FAULT: 0, 'none': 0}
    new_holds = force_holds = 0
    for _ in range(6000):
        current = driver.position()
        action = rng.integers(20)
        target = [plausible_value(rng, c, limits) for c in current]
        if action == 0:
            target = (target + target)[: rng.integers(0, 4)]  # wrong length (or right)
        elif action == 1:
            target = [None, 'x'][:n_dof]  # type: ignore[list-item]
        elif action < 8:
            dof = int(rng.integers(n_dof))
            target[dof] = adversarial_value(rng, current[dof], limits)
        if action == 8:
            use_step = max(0, step - int(rng.integers(0, 3)))  # repeated or stale
        elif action == 9:
            test_id, step = f'rand{rng.integers(1000)}', 0
            use_step = step
        else:
            step += 1
            use_step = step
        was_holding = bridge.state == 'holding'
        n_before = len(driver.commands)
        reply = bridge.handle_command(test_id, use_step, target)
        statuses['none' if reply is None else reply.status] += 1
        moved = len(driver.commands) - n_before
        assert moved in (0, 1)
        if was_holding:
            assert moved == 0 and reply is not None and reply.status is not FeedbackStatus.OK
        elif reply is not None and reply.status is not FeedbackStatus.OK:
            new_holds += 1
            # Only a measured force beyond the limit may follow a motion.
            assert moved == 0 or reply.message.endswith('exceeds max_force 1000 N')
            force_holds += moved
        if bridge.state == 'holding' and rng.random() < 0.7:
            bridge.reset()
        assert bridge.state != 'busy'

    previous = [0.0] * n_dof  # LoopbackDriver starts at zero and moves exactly to each target
    at_increment = at_displacement = 0
    for _, target in driver.commands:
        assert len(target) == n_dof
        for x, x_prev in zip(target, previous):
            assert math.isfinite(x)
            assert abs(x) <= limits.max_displacement
            assert abs(x - x_prev) <= limits.max_increment
            if limits.max_velocity is not None and limits.step_duration is not None:
                assert abs(x - x_prev) / limits.step_duration <= limits.max_velocity
            at_displacement += abs(x) == limits.max_displacement
            at_increment += abs(x - x_prev) == 0.0625
        previous = list(target)

    # The stream exercised both sides of every boundary.
    assert statuses[FeedbackStatus.OK] > 1000
    assert statuses[FeedbackStatus.LIMIT] > 500
    assert statuses[FeedbackStatus.FAULT] > 500
    assert statuses['none'] > 10
    assert force_holds > 10
    assert at_displacement > 0
    assert at_increment > 10
    assert bridge.violations == new_holds
    assert bridge.ignored_commands > 0
    assert bridge.repeated_steps > 0


class BrokenDriver(AsyncDriver):
    """An asynchronous driver whose position() and hold() can be made to fail."""

    def __init__(self) -> None:
        super().__init__()
        self.broken = False

    def position(self) -> list[float]:
        if self.broken:
            raise DriverError('encoder lost')
        return super().position()

    def hold(self) -> None:
        super().hold()
        if self.broken:
            raise DriverError('valve stuck')


def test_broken_driver_faults_and_reports_last_measurement() -> None:
    driver = BrokenDriver()
    bridge = ActuatorBridge(driver, LIMITS, ['top'])
    bridge.handle_command('t1', 0, [0.05])
    bridge.handle_measurement(ActuatorMeasurement(0, (0.05,), (10.0,)))
    driver.broken = True
    reply = bridge.handle_command('t1', 1, [0.06])
    assert reply == Feedback(
        't1', 1, (0.05,), (10.0,), FeedbackStatus.FAULT,
        'driver position() failed: DriverError: encoder lost; '
        'driver hold() failed: DriverError: valve stuck',
    )
    assert bridge.state == 'holding'
    assert driver.hold_count == 1
    assert driver.commands == [(0, (0.05,))]


def test_fault_while_idle_holds_without_reply() -> None:
    bridge, driver = make_bridge()
    bridge.handle_command('t1', 0, [0.0])
    assert bridge.handle_fault('emergency stop pressed') is None
    assert bridge.state == 'holding'
    assert bridge.hold_reason == 'emergency stop pressed'
    assert bridge.hold_status is FeedbackStatus.FAULT
    reply = bridge.handle_command('t1', 1, [0.01])
    assert reply is not None and reply.status is FeedbackStatus.FAULT
    assert reply.message == 'emergency stop pressed'
    assert len(driver.commands) == 1
    # A second fault while already holding changes nothing.
    assert bridge.handle_fault('again') is None
    assert bridge.hold_reason == 'emergency stop pressed'
    assert bridge.violations == 1


def test_bridge_accepts_step_iteration_keys() -> None:
    driver = LoopbackDriver(lambda x: [1000.0 * v for v in x], n_dof=1)
    driver.open()
    bridge = ActuatorBridge(driver, SafetyLimits(max_displacement=0.1, max_increment=0.05,
                                                 max_force=1.0e4), ['u'])
    first = bridge.handle_command('t', (2, 0), [0.01])
    second = bridge.handle_command('t', (2, 1), [0.02])
    assert first is not None and first.key == (2, 0) and first.status is FeedbackStatus.OK
    assert second is not None and second.restoring_force == (20.0,)
    assert bridge.handle_command('t', (2, 1), [0.09]) is second  # repeat: no motion
    assert bridge.handle_command('t', (2, 0), [0.03]) is None  # stale iteration: ignored
    assert [target for _, target in driver.commands] == [(0.01,), (0.02,)]


# --------------------------------------------------------------------------- driver registry


BUILT_IN = ('daqmx', 'emulator', 'generic_tcp', 'opensees_adapter')


@pytest.fixture
def scratch_registry(monkeypatch: pytest.MonkeyPatch) -> None:
    """A copy of the registry for the test, so that its registrations do not leak."""
    monkeypatch.setattr(registry, 'DRIVERS', registry.DRIVERS.copy())


def loopback_spec(name: str = 'loopback', **parameters: object) -> DriverSpec:
    declared = tuple(DriverParameter(key, value, f'{key} of the test')
                     for key, value in parameters.items())
    return DriverSpec(name, lambda context: LoopbackDriver(linear_spring(1.0), context.n_dof),
                      declared, 'test driver')


def test_importing_the_core_registers_the_built_in_drivers() -> None:
    names = driver_names()
    assert set(BUILT_IN) <= set(names)
    assert list(names) == sorted(names)
    assert driver_spec('generic_tcp').parameter_names == ('tcp_host', 'tcp_port',
                                                          'driver_timeout')
    assert driver_spec('emulator').parameter_names == ('test_file', 'driver_config')
    assert driver_spec('daqmx').parameter_names == ('driver_config',)
    for name in BUILT_IN:
        assert driver_spec(name).description


def test_unknown_driver_is_one_line_listing_the_names() -> None:
    with pytest.raises(BridgeConfigError) as info:
        driver_spec('moog')
    message = str(info.value)
    assert '\n' not in message
    assert message.startswith("parameter driver: unknown driver 'moog' (available: ")
    for name in BUILT_IN:
        assert name in message
    with pytest.raises(BridgeConfigError, match='unknown driver'):
        make_driver('moog', DriverContext(1))


def test_a_driver_name_is_registered_once(scratch_registry: None) -> None:
    with pytest.raises(BridgeConfigError, match='generic_tcp: a driver of that name is already'):
        register_driver(driver_spec('generic_tcp'))
    spec = register_driver(loopback_spec())
    assert spec is driver_spec('loopback') and 'loopback' in driver_names()
    with pytest.raises(BridgeConfigError, match='already registered'):
        register_driver(loopback_spec())
    with pytest.raises(BridgeConfigError, match='expected a DriverSpec'):
        register_driver('loopback')  # type: ignore[arg-type]


def test_a_shared_parameter_has_one_default(scratch_registry: None) -> None:
    with pytest.raises(BridgeConfigError,
                       match=r"parameter tcp_port: default 44001 differs from 44000 of driver"):
        register_driver(loopback_spec(tcp_port=44001))
    with pytest.raises(BridgeConfigError, match=r'parameter tcp_port: default 44000.0 differs'):
        register_driver(loopback_spec(tcp_port=44000.0))
    register_driver(loopback_spec(tcp_port=44000))
    shared = {parameter.name: drivers for parameter, drivers in driver_parameters()}
    assert shared['tcp_port'] == ('generic_tcp', 'loopback', 'opensees_adapter')
    assert shared['driver_config'][:2] == ('daqmx', 'emulator')


def test_spec_and_parameter_fields_are_checked() -> None:
    # A parameter's declaration is checked by the one parameter type of every plug-in kind.
    with pytest.raises(ParameterError, match='name must match'):
        DriverParameter('Port', 1, 'a port')
    with pytest.raises(ParameterError, match='parameter port: default must be a bool'):
        DriverParameter('port', [1], 'a port')  # type: ignore[arg-type]
    with pytest.raises(ParameterError, match='description must be a non-empty string'):
        DriverParameter('port', 1, '')
    with pytest.raises(BridgeConfigError, match='driver x: parameter port needs a default'):
        DriverSpec('x', LoopbackDriver, (DriverParameter('port', None, 'a port'),))
    with pytest.raises(BridgeConfigError, match='driver x: factory must be callable'):
        DriverSpec('x', None)  # type: ignore[arg-type]
    with pytest.raises(BridgeConfigError, match='driver x: parameter port is declared twice'):
        DriverSpec('x', LoopbackDriver, (DriverParameter('port', 1, 'a'),
                                         DriverParameter('port', 1, 'b')))
    with pytest.raises(BridgeConfigError, match='parameters must be a tuple of DriverParameter'):
        listed: list[DriverParameter] = [DriverParameter('port', 1, 'a')]
        DriverSpec('x', LoopbackDriver, listed)  # type: ignore[arg-type]


def test_make_driver_completes_defaults_and_refuses_unknown_parameters() -> None:
    driver = make_driver('generic_tcp', DriverContext(2))
    assert isinstance(driver, GenericTCPDriver)
    assert driver.n_dof == 2 and driver.address == '127.0.0.1:44000' and not driver.connected
    driver = make_driver('opensees_adapter', DriverContext(1, {'tcp_port': 45000}))
    assert isinstance(driver, OpenSeesAdapterDriver) and driver.address == '127.0.0.1:45000'
    with pytest.raises(BridgeConfigError) as info:
        make_driver('generic_tcp', DriverContext(1, {'tcp_prot': 45000}))
    assert str(info.value) == ("driver generic_tcp: unknown parameter 'tcp_prot' "
                               '(its parameters: tcp_host, tcp_port, driver_timeout)')
    with pytest.raises(BridgeConfigError, match="driver daqmx: unknown parameter 'test_file'"):
        make_driver('daqmx', DriverContext(1, {'test_file': 'x.yaml'}))


def test_the_factory_gets_the_resolved_parameters(scratch_registry: None) -> None:
    seen: list[DriverContext] = []

    def factory(context: DriverContext) -> ActuatorDriver:
        seen.append(context)
        return LoopbackDriver(linear_spring(1.0), context.n_dof)

    host = object()
    register_driver(DriverSpec('loopback', factory, (DriverParameter('gain', 1.5, 'gain'),
                                                     DriverParameter('label', 'a', 'label'))))
    driver = make_driver('loopback', DriverContext(3, {'label': 'b'}, host=host))
    assert isinstance(driver, LoopbackDriver) and driver.n_dof == 3
    assert dict(seen[0].parameters) == {'gain': 1.5, 'label': 'b'}
    assert seen[0].host is host
    register_driver(DriverSpec('broken', lambda context: object()))  # type: ignore[arg-type]
    with pytest.raises(BridgeConfigError, match='driver broken: the factory returned object'):
        make_driver('broken', DriverContext(1))


def test_emulator_factory_builds_the_driver_on_the_test_files_specimen(tmp_path: Path) -> None:
    test_file = tmp_path / 'test.yaml'
    test_file.write_text(yaml.safe_dump({
        'test': {'dt': 0.01}, 'ground_motion': INLINE_GROUND_MOTION,
        'structure': {'dof_names': ['top'], 'mass': 1000.0, 'initial_stiffness': 312559.0},
        'specimen': {'elements': [{'model': 'elastic', 'stiffness': 312559.0}]},
    }), encoding='utf-8')
    config = tmp_path / 'driver.yaml'
    config.write_text(yaml.safe_dump({'ramp_hold': {'ramp_time': 0.02, 'samples': 5}}),
                      encoding='utf-8')
    trajectories: list[tuple[object, object]] = []
    driver = make_driver('emulator', DriverContext(
        1, {'test_file': str(test_file), 'driver_config': str(config)},
        on_trajectory=lambda step, execution: trajectories.append((step, execution))))
    assert isinstance(driver, EmulatorDriver)
    assert driver.executor.parameters.ramp_time == 0.02
    assert driver.executor.parameters.samples == 5
    driver.open()
    driver.command(0, [0.001])
    assert [step for step, _ in trajectories] == [0]
    with pytest.raises(BridgeConfigError, match='parameter test_file: the emulator needs'):
        make_driver('emulator', DriverContext(1))
    with pytest.raises(BridgeConfigError, match='parameter dof_names: 2 DOF but the specimen'):
        make_driver('emulator', DriverContext(2, {'test_file': str(test_file)}))
    with pytest.raises(BridgeConfigError, match='parameter driver_config: a YAML file is'):
        make_driver('daqmx', DriverContext(1))

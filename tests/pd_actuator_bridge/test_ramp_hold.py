"""Tests of ramp-and-hold execution, the emulator driver and the experimental error models."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pd_actuator_bridge.core import ActuatorBridge, DriverError, SafetyLimits
from pd_actuator_bridge.core.drivers.emulator import ServoHydraulicEmulator
from pd_actuator_bridge.core.drivers.emulator_driver import EmulatorDriver
from pd_actuator_bridge.core.drivers.emulator_parameters import EmulatorParameters
from pd_actuator_bridge.core.drivers.ramp_hold import (
    DEFAULT_RAMP_TIME,
    PHASE_HOLD,
    PHASE_RAMP,
    PHASE_SAMPLE,
    RampHoldExecutor,
    RampHoldParameters,
    SettleTimeoutError,
    StepExecution,
)
from pd_actuator_bridge.core.error_models import ErrorInjector, ErrorModel, apply_error_model
from pd_actuator_bridge.core.errors import BridgeConfigError
from pd_common.experimental import TrackingMonitor, tracking_error, tracking_indicator
from pd_common.protocol import FeedbackStatus
from pd_common.specimen import Elastic, Specimen

K_COLUMN = 312559.0
"""Initial stiffness of the thesis column, N/m."""


def emulator(stiffness: float = K_COLUMN, **parameters: object) -> ServoHydraulicEmulator:
    return ServoHydraulicEmulator(Specimen([Elastic(stiffness)]), EmulatorParameters(**parameters))


def linear(stiffness: float):
    def restoring_force(x: np.ndarray) -> np.ndarray:
        return stiffness * np.asarray(x, dtype=float)

    return restoring_force


# ---------------------------------------------------------------------- ramp-and-hold


def test_final_averaged_measurement_is_within_tolerance_of_the_target() -> None:
    executor = RampHoldExecutor(emulator(), settle_tolerance=1.0e-5, samples=10)
    for target in (1.0e-3, 4.0e-3, -2.5e-3, -2.5e-3, 0.0):
        execution = executor.execute([target])
        assert execution.settled
        assert abs(execution.displacement[0] - target) < 1.0e-5
        assert execution.force[0] == pytest.approx(K_COLUMN * execution.displacement[0])
        assert execution.force[0] == pytest.approx(K_COLUMN * target, abs=K_COLUMN * 1.0e-5)
        # The answer is the mean of the sample phase.
        samples = execution.phase == PHASE_SAMPLE
        assert samples.sum() == 10
        assert execution.displacement[0] == pytest.approx(
            execution.measured_displacement[samples, 0].mean(), rel=1e-12
        )


def test_trajectory_arrays_are_consistent() -> None:
    emu = emulator()
    executor = RampHoldExecutor(emu, ramp_time=0.05, hold_time=0.08, samples=7)
    first = executor.execute([2.0e-3])
    second = executor.execute([1.0e-3])
    for execution, start, target in ((first, 0.0, 2.0e-3), (second, 2.0e-3, 1.0e-3)):
        n = execution.time.size
        assert execution.command.shape == (n, 1)
        assert execution.measured_displacement.shape == (n, 1)
        assert execution.measured_force.shape == (n, 1)
        assert execution.phase.shape == (n,)
        # One row per controller period.
        np.testing.assert_allclose(np.diff(execution.time), emu.dt, rtol=1e-9)
        assert execution.duration == pytest.approx(n * emu.dt)
        # Phases in order: ramp, hold, sample.
        assert execution.ramp_ticks == 50
        np.testing.assert_array_equal(execution.phase[:50], PHASE_RAMP)
        np.testing.assert_array_equal(execution.phase[50:-7], PHASE_HOLD)
        np.testing.assert_array_equal(execution.phase[-7:], PHASE_SAMPLE)
        assert execution.hold_ticks == n - 57 >= 80  # hold_time respected
        # A linear, monotone ramp from the previous target, then the target held.
        ramp = execution.command[:50, 0]
        np.testing.assert_allclose(ramp, start + (target - start) * np.arange(1, 51) / 50)
        assert np.all(np.diff(ramp) * np.sign(target - start) > 0.0)
        np.testing.assert_array_equal(execution.command[50:, 0], target)
        # Every sample is within the tolerance.
        assert np.all(np.abs(execution.measured_displacement[-7:, 0] - target) < 1.0e-5)
    # The emulator's measurements were recorded.
    assert second.measured_displacement[-1, 0] == emu.measured_displacement[0]
    assert second.time[0] == pytest.approx(first.time[-1] + emu.dt)
    assert first.time[0] == pytest.approx(emu.dt)


def test_ramp_duration_from_a_velocity() -> None:
    executor = RampHoldExecutor(emulator(), ramp_velocity=0.02)
    assert executor.execute([3.0e-3]).ramp_ticks == 150  # 3 mm at 20 mm/s
    assert executor.execute([2.0e-3]).ramp_ticks == 50
    assert executor.execute([2.0e-3]).ramp_ticks == 0  # no motion: straight to the hold
    assert RampHoldExecutor(emulator()).execute([1e-3]).ramp_ticks == round(
        DEFAULT_RAMP_TIME * 1000
    )


def test_timeout_is_a_fault_when_the_plant_cannot_settle() -> None:
    """A huge step with the valve saturated cannot settle: 0.1 m/s at most."""
    emu = emulator()
    executor = RampHoldExecutor(emu, ramp_time=0.0, timeout=0.3)
    with pytest.raises(SettleTimeoutError) as info:
        executor.execute([0.2])
    assert isinstance(info.value, DriverError)
    message = str(info.value)
    assert 'did not settle' in message and '\n' not in message
    partial = info.value.execution
    assert isinstance(partial, StepExecution)
    assert not partial.settled
    assert partial.time.size == partial.hold_ticks == 300
    assert abs(emu.last_measurement.valve[0]) == 10.0
    assert partial.measured_displacement[-1, 0] < 0.035
    # The command stays at the target.
    np.testing.assert_array_equal(executor.command, [0.2])


def test_hold_restarts_the_ramp_from_the_measured_position() -> None:
    emu = emulator()
    executor = RampHoldExecutor(emu, ramp_time=0.0, timeout=0.05)
    with pytest.raises(SettleTimeoutError):
        executor.execute([0.1])
    executor.hold()
    np.testing.assert_array_equal(executor.command, emu.measured_displacement)
    execution = RampHoldExecutor(emu, timeout=1.0).execute(emu.measured_displacement)
    assert execution.settled


@pytest.mark.parametrize(
    ('values', 'name'),
    [
        ({'ramp_time': 0.1, 'ramp_velocity': 0.01}, 'ramp_velocity'),
        ({'ramp_time': -0.1}, 'ramp_time'),
        ({'ramp_velocity': 0.0}, 'ramp_velocity'),
        ({'settle_tolerance': 0.0}, 'settle_tolerance'),
        ({'samples': 0}, 'samples'),
        ({'samples': 2.5}, 'samples'),
        ({'timeout': math.inf}, 'timeout'),
        ({'hold_time': 'long'}, 'hold_time'),
    ],
)
def test_invalid_ramp_hold_parameters(values: dict[str, object], name: str) -> None:
    with pytest.raises(BridgeConfigError) as info:
        RampHoldParameters(**values)
    assert name in str(info.value) and '\n' not in str(info.value)


def test_ramp_hold_parameters_from_mapping_and_overrides() -> None:
    p = RampHoldParameters.from_mapping({'ramp_velocity': 0.05, 'samples': 4}, source='b.yaml')
    assert p.ramp_velocity == 0.05 and p.ramp_time is None and p.samples == 4
    with pytest.raises(BridgeConfigError, match=r'^b.yaml: ramp_hold.ramp: unknown key$'):
        RampHoldParameters.from_mapping({'ramp': 1.0}, source='b.yaml', path='ramp_hold')
    # Keyword overrides replace the other ramp definition.
    executor = RampHoldExecutor(emulator(), p, ramp_time=0.2)
    assert executor.parameters.ramp_time == 0.2 and executor.parameters.ramp_velocity is None
    with pytest.raises(BridgeConfigError, match=r'^RampHoldExecutor: hold: unknown key$'):
        RampHoldExecutor(emulator(), hold=1.0)


@pytest.mark.parametrize('target', [[1.0, 2.0], [math.inf], ['a']])
def test_malformed_targets_are_driver_errors(target: list[object]) -> None:
    emu = emulator()
    with pytest.raises(DriverError):
        RampHoldExecutor(emu).execute(target)
    assert emu.ticks == 0


def test_undershoot_through_the_executor() -> None:
    errors = ErrorModel(systematic=-0.05)
    executor = RampHoldExecutor(emulator(), errors=errors, settle_tolerance=2.0e-6)
    execution = executor.execute([2.0e-3])
    assert execution.driven_target[0] == pytest.approx(2.0e-3 - 0.05 * 2.0e-3, rel=1e-12)
    assert execution.displacement[0] == pytest.approx(1.9e-3, abs=2.0e-6)
    # The increment is taken from where the actuator is.
    execution = executor.execute([3.0e-3])
    assert execution.driven_target[0] == pytest.approx(3.0e-3 - 0.05 * (3.0e-3 - 1.9e-3))


# ---------------------------------------------------------------------- emulator driver


def make_bridge(**limits: float) -> tuple[ActuatorBridge, EmulatorDriver]:
    values = {'max_displacement': 0.05, 'max_increment': 5.0e-3, 'max_force': 1.0e5}
    values.update(limits)
    driver = EmulatorDriver(emulator(), ramp_time=0.05, timeout=0.5)
    driver.open()
    return ActuatorBridge(driver, SafetyLimits(**values), ['top']), driver


def test_emulator_driver_completes_steps_through_the_bridge() -> None:
    bridge, driver = make_bridge()
    recorded: list[tuple[object, StepExecution]] = []
    driver.set_trajectory_callback(lambda step, execution: recorded.append((step, execution)))
    targets = [0.0, 1.0e-3, 3.5e-3, 2.0e-3, -1.0e-3]
    for step, target in enumerate(targets):
        reply = bridge.handle_command('t1', step, [target])
        assert reply is not None and reply.status is FeedbackStatus.OK, reply
        assert reply.step == step
        assert reply.measured_displacement[0] == pytest.approx(target, abs=1.0e-5)
        assert reply.restoring_force[0] == pytest.approx(K_COLUMN * target, abs=K_COLUMN * 1.0e-5)
        assert driver.last_execution is recorded[-1][1]
        assert driver.last_execution.target[0] == target
    assert [step for step, _ in recorded] == list(range(len(targets)))
    # A repeated step is answered without moving.
    ticks = driver.emulator.ticks
    assert bridge.handle_command('t1', 4, [-1.0e-3]).status is FeedbackStatus.OK
    assert driver.emulator.ticks == ticks
    assert driver.position() == pytest.approx([-1.0e-3], abs=1.0e-5)


def test_bridge_limits_still_apply_to_the_emulator_driver() -> None:
    bridge, driver = make_bridge(max_increment=2.0e-3)
    assert bridge.handle_command('t1', 0, [1.0e-3]).status is FeedbackStatus.OK
    ticks = driver.emulator.ticks
    reply = bridge.handle_command('t1', 1, [4.0e-3])  # 3 mm increment > 2 mm
    assert reply.status is FeedbackStatus.LIMIT and 'max_increment' in reply.message
    assert driver.emulator.ticks == ticks  # nothing reached the emulator
    assert driver.hold_count == 1 and bridge.state == 'holding'

    bridge, driver = make_bridge(max_force=200.0)
    reply = bridge.handle_command('t1', 0, [1.0e-3])  # 313 N > 200 N
    assert reply.status is FeedbackStatus.LIMIT and 'max_force' in reply.message
    assert driver.hold_count == 1

    bridge, driver = make_bridge(max_displacement=2.0e-3)
    reply = bridge.handle_command('t1', 0, [2.5e-3])
    assert reply.status is FeedbackStatus.LIMIT and driver.emulator.ticks == 0


def test_settling_timeout_through_the_bridge_is_a_fault() -> None:
    bridge, driver = make_bridge(max_increment=0.05)
    driver.executor.emulator.reset()
    slow = EmulatorDriver(emulator(valve_flow=1.0e-6), ramp_time=0.0, timeout=0.2)
    slow.open()
    bridge = ActuatorBridge(slow, SafetyLimits(0.05, 0.05, 1.0e5), ['top'])
    reply = bridge.handle_command('t1', 0, [0.01])
    assert reply.status is FeedbackStatus.FAULT and 'did not settle' in reply.message
    assert slow.last_execution is not None and not slow.last_execution.settled
    assert bridge.state == 'holding'


def test_emulator_driver_requires_open() -> None:
    driver = EmulatorDriver(emulator())
    with pytest.raises(DriverError, match='before open'):
        driver.command(0, [0.0])
    assert driver.n_dof == 1
    driver.open()
    driver.close()
    assert not driver.is_open


# ---------------------------------------------------------------------- error models


def test_undershoot_gives_target_minus_fraction_of_the_increment() -> None:
    model = ErrorModel(systematic=-0.05)
    step = apply_error_model(model, [3.0e-3], [1.0e-3], linear(K_COLUMN))
    assert step.displacement[0] == pytest.approx(3.0e-3 - 0.05 * 2.0e-3, rel=1e-12)
    assert step.imposed[0] == step.displacement[0]
    assert step.force[0] == pytest.approx(K_COLUMN * step.imposed[0], rel=1e-12)
    overshoot = apply_error_model(ErrorModel(systematic=0.05), [3.0e-3], [1.0e-3], linear(1.0))
    assert overshoot.displacement[0] == pytest.approx(3.1e-3, rel=1e-12)
    # Step after step the increment is measured from the achieved position.
    injector = ErrorInjector(model, initial_position=[0.0])
    previous = 0.0
    for target in (1.0e-3, 2.0e-3, 1.5e-3, -1.0e-3):
        imposed = injector.impose([target])[0]
        assert imposed == pytest.approx(target - 0.05 * (target - previous), rel=1e-12)
        previous = imposed


def test_constant_delay_in_steps() -> None:
    injector = ErrorInjector(ErrorModel(delay_steps=2), initial_position=[0.5])
    imposed = [injector.impose([t])[0] for t in (1.0, 2.0, 3.0, 4.0)]
    assert imposed == [0.5, 0.5, 1.0, 2.0]
    with pytest.raises(BridgeConfigError, match='ErrorInjector'):
        apply_error_model(ErrorModel(delay_steps=1), [1.0], [0.0], linear(1.0))


def test_bias_shifts_the_force_by_exactly_the_bias() -> None:
    model = ErrorModel(force_bias=123.25)
    step = apply_error_model(model, [2.0e-3, -1.0e-3], [0.0, 0.0], linear(K_COLUMN))
    np.testing.assert_allclose(step.force - step.true_force, 123.25, atol=1e-9)
    np.testing.assert_array_equal(step.displacement, [2.0e-3, -1.0e-3])
    executor = RampHoldExecutor(emulator(), errors=model)
    execution = executor.execute([1.0e-3])
    assert execution.force[0] - K_COLUMN * execution.displacement[0] == pytest.approx(
        123.25, abs=1e-6
    )


def test_random_errors_are_seeded_and_have_the_given_std() -> None:
    model = ErrorModel(displacement_noise=1.0e-5, force_noise=20.0, seed=3)

    def draw(m: ErrorModel) -> np.ndarray:
        injector = ErrorInjector(m)
        return np.array([np.concatenate(injector.measure([1.0e-3], [300.0]))
                         for _ in range(3000)])

    first, again = draw(model), draw(model)
    np.testing.assert_array_equal(first, again)
    assert np.std(first[:, 0]) == pytest.approx(1.0e-5, rel=0.05)
    assert np.std(first[:, 1]) == pytest.approx(20.0, rel=0.05)
    assert not np.array_equal(first, draw(ErrorModel(displacement_noise=1e-5, seed=4)))


@pytest.mark.parametrize(
    ('values', 'name'),
    [
        ({'systematic': -1.0}, 'systematic'),
        ({'systematic': math.nan}, 'systematic'),
        ({'delay_steps': -1}, 'delay_steps'),
        ({'force_noise': -1.0}, 'force_noise'),
        ({'force_bias': math.inf}, 'force_bias'),
        ({'seed': 1.5}, 'seed'),
    ],
)
def test_invalid_error_models(values: dict[str, object], name: str) -> None:
    with pytest.raises(BridgeConfigError) as info:
        ErrorModel(**values)
    assert name in str(info.value) and '\n' not in str(info.value)


def test_error_model_from_mapping() -> None:
    model = ErrorModel.from_mapping({'systematic': -0.02, 'seed': 1})
    assert model.systematic == -0.02 and not model.is_ideal
    assert ErrorModel().is_ideal
    with pytest.raises(BridgeConfigError, match=r'^driver.yaml: errors.bias: unknown key$'):
        ErrorModel.from_mapping({'bias': 1.0}, source='driver.yaml', path='errors')


# ---------------------------------------------------------------------- monitors


def cycle(phase: float, n: int = 4000, amplitude: float = 2.0e-3):
    theta = 2.0 * np.pi * np.arange(n + 1) / n
    return amplitude * np.sin(theta), amplitude * np.sin(theta - phase)


def test_tracking_indicator_sign_lag_adds_energy_lead_removes_it() -> None:
    amplitude, phase = 2.0e-3, math.radians(10.0)
    command, lagging = cycle(phase)
    ti_lag = tracking_indicator(command, lagging)
    expected = -math.pi * amplitude**2 * math.sin(phase)
    assert ti_lag[0] == 0.0
    assert ti_lag[-1] < 0.0  # lag: energy added (negative)
    assert ti_lag[-1] == pytest.approx(expected, rel=1e-4)
    command, leading = cycle(-phase)
    assert tracking_indicator(command, leading)[-1] == pytest.approx(-expected, rel=1e-4)
    # Perfect tracking, even on an open path, gives zero.
    np.testing.assert_array_equal(tracking_indicator(command[:1000], command[:1000]), 0.0)


def test_tracking_indicator_of_the_emulator_is_negative() -> None:
    """The emulated actuator lags the command: it adds energy to the test."""
    emu = emulator()
    t = np.arange(1, 1501) / 1000.0
    command = 1.0e-3 * np.sin(2.0 * np.pi * 2.0 * t)
    measured = np.array([emu.tick([c]).displacement[0] for c in command])
    indicator = tracking_indicator(command[500:], measured[500:])
    assert indicator[-1] < 0.0
    assert np.all(tracking_error(command[500:], measured[500:]) < 1.0e-3 * 0.35)


def test_tracking_error_and_incremental_monitor() -> None:
    command, measured = cycle(math.radians(5.0), n=200)
    both_c = np.column_stack([command, -command])
    both_m = np.column_stack([measured, -measured + 1.0e-4])
    np.testing.assert_allclose(tracking_error(both_c, both_m), both_m - both_c)
    monitor = TrackingMonitor(n_dof=2)
    for c, m in zip(both_c, both_m):
        sample = monitor.update(c, m)
    np.testing.assert_allclose(monitor.errors, tracking_error(both_c, both_m))
    np.testing.assert_allclose(monitor.indicators, tracking_indicator(both_c, both_m))
    np.testing.assert_allclose(sample.indicator, monitor.indicator)
    assert monitor.count == 201
    # The live monitor (the bridge's) in constant memory: the same running indicator.
    live = TrackingMonitor(n_dof=2, keep_history=False)
    for c, m in zip(both_c, both_m):
        live_sample = live.update(c, m)
    assert live.count == 201
    assert live.commands.shape == (1, 2)
    np.testing.assert_allclose(live_sample.indicator, tracking_indicator(both_c, both_m)[-1])
    np.testing.assert_allclose(live_sample.error, (both_m - both_c)[-1])
    with pytest.raises(ValueError, match='same shape'):
        tracking_indicator(command, measured[:-1])
    with pytest.raises(ValueError, match='finite'):
        tracking_error([0.0, math.nan], [0.0, 0.0])

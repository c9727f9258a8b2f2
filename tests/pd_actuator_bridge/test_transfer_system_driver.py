"""The ``transfer_system`` driver: a continuous actuator behind the bridge (issue 12).

Through :class:`ActuatorBridge` (the core, no ROS) the driver answers with exactly the floats
of :class:`pd_common.rths.ContinuousSiteServer` (the ROS-free runner's site) for the same
targets; the bridge's limits act on the measured position; a FAULT answer holds.
"""

from __future__ import annotations

import json
import math
import threading
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml

from pd_actuator_bridge.core import (
    ActuatorBridge,
    BridgeConfigError,
    DriverContext,
    SafetyLimits,
    TransferSystemDriver,
    make_driver,
)
from pd_actuator_bridge.core.drivers.transfer_system import read_transfer_system
from pd_common.protocol import FeedbackStatus, StateOrigin, StepKey
from pd_common.rths import (
    BENCHMARK_NOISE,
    BENCHMARK_QUANTUM,
    ContinuousSiteServer,
    continuous_from_config,
)
from support.sections import INLINE_GROUND_MOTION, ONE_DOF_STRUCTURE

DT = 1.0 / 1024.0
SECTION: dict[str, Any] = {
    'plant': {'model': 'benchmark'},
    'compensator': {'name': 'pi_p'},
    'noise': {'displacement_power': BENCHMARK_NOISE.displacement_power,
              'force_power': BENCHMARK_NOISE.force_power, 'seed': 3},
    'quantum': BENCHMARK_QUANTUM,
    'capacity': 8900.0,
    'inertia': 'subtract',
}
LIMITS = SafetyLimits(max_displacement=0.05, max_increment=0.002, max_force=20000.0)


def server(**changes: Any) -> ContinuousSiteServer:
    return ContinuousSiteServer(continuous_from_config({**SECTION, **changes}, 'test'), DT)


def targets(n: int) -> list[float]:
    """A 4 Hz sine of 2 mm, growing in over the first steps."""
    time = np.arange(n) * DT
    return [float(x) for x in 2e-3 * np.sin(2 * math.pi * 4.0 * time) * np.minimum(1, time)]


def bridge_of(driver: TransferSystemDriver, limits: SafetyLimits = LIMITS) -> ActuatorBridge:
    driver.open()
    return ActuatorBridge(driver, limits, ['x1'])


def test_the_bridge_answers_with_the_floats_of_the_site_server() -> None:
    reference = server()
    driver = TransferSystemDriver(server())
    bridge = bridge_of(driver)
    assert driver.state_origin is StateOrigin.FRESH
    assert driver.n_dof == 1
    assert driver.position() == [reference.actuator.measured_displacement]
    values = targets(600)
    for step, target in enumerate(values):
        expected = reference.handle('t', step, [target])
        reply = bridge.handle_command('run-1', StepKey(step, 0), [target])
        assert expected is not None and reply is not None
        assert reply.status is FeedbackStatus.OK, reply.message
        # exactly the same floats
        assert reply.measured_displacement == expected.measured_displacement
        assert reply.restoring_force == expected.restoring_force
        assert driver.position() == list(expected.measured_displacement)
        assert driver.last_force == list(expected.restoring_force)
    assert driver.server.steps_served == 599
    assert max(abs(x) for x in driver.position()) > 0.0
    # A repeated command: the bridge's last answer, the actuator does not move.
    again = bridge.handle_command('run-1', StepKey(599, 0), [values[-1]])
    assert again is not None
    assert list(again.measured_displacement) == driver.position() == list(reference.position)
    assert driver.server.steps_served == 599


def test_plain_int_steps_are_iteration_zero() -> None:
    reference, driver = server(), TransferSystemDriver(server())
    bridge = bridge_of(driver)
    for step, target in enumerate(targets(20)):
        expected = reference.handle('t', step, [target])
        reply = bridge.handle_command('run', step, [target])
        assert reply is not None and expected is not None
        assert reply.measured_displacement == expected.measured_displacement


def test_limits_act_on_the_measured_position() -> None:
    driver = TransferSystemDriver(server())
    bridge = bridge_of(driver)
    values = targets(200)
    for step, target in enumerate(values):
        reply = bridge.handle_command('run', StepKey(step, 0), [target])
        assert reply is not None and reply.status is FeedbackStatus.OK
    measured = driver.position()[0]
    assert measured != values[-1]  # the actuator lags its target
    # Within max_increment of the measured position: executed.
    inside = measured + 0.99 * LIMITS.max_increment
    reply = bridge.handle_command('run', StepKey(200, 0), [inside])
    assert reply is not None and reply.status is FeedbackStatus.OK
    measured = driver.position()[0]
    served = driver.server.steps_served
    # Beyond it: the bridge holds, nothing moves.
    beyond = measured + 1.01 * LIMITS.max_increment
    reply = bridge.handle_command('run', StepKey(201, 0), [beyond])
    assert reply is not None and reply.status is FeedbackStatus.LIMIT
    assert 'max_increment' in reply.message
    assert bridge.state == 'holding'
    assert driver.server.steps_served == served
    assert driver.position() == [measured]


def test_a_fault_answer_holds_the_bridge() -> None:
    driver = TransferSystemDriver(server(capacity=1.0))  # any motion reaches 1 N
    bridge = bridge_of(driver)
    reply = bridge.handle_command('run', StepKey(0, 0), [0.0])
    assert reply is not None and reply.status is FeedbackStatus.OK
    reply = bridge.handle_command('run', StepKey(1, 0), [1e-3])
    assert reply is not None and reply.status is FeedbackStatus.FAULT
    assert 'capacity' in reply.message and 'transfer_system' in reply.message
    assert bridge.state == 'holding'
    served = driver.server.steps_served
    reply = bridge.handle_command('run', StepKey(2, 0), [1e-3])
    assert reply is not None and reply.status is FeedbackStatus.FAULT
    assert driver.server.steps_served == served  # held: nothing moves


def test_step_zero_away_from_rest_and_iterations_fault() -> None:
    bridge = bridge_of(TransferSystemDriver(server()))
    reply = bridge.handle_command('run', StepKey(0, 0), [1e-4])
    assert reply is not None and reply.status is FeedbackStatus.FAULT
    assert 'starts from rest' in reply.message
    bridge = bridge_of(TransferSystemDriver(server()))
    bridge.handle_command('run', StepKey(0, 0), [0.0])
    reply = bridge.handle_command('run', StepKey(1, 1), [1e-4])
    assert reply is not None and reply.status is FeedbackStatus.FAULT
    assert 'iteration' in reply.message


def test_force_control_is_refused() -> None:
    driver = TransferSystemDriver(server())
    assert driver.force_control_problem() is not None
    bridge = bridge_of(driver)
    reply = bridge.handle_command('run', StepKey(0, 0), [0.0], control_mode=[1],
                                  target_force=[10.0])
    assert reply is not None and reply.status is FeedbackStatus.FAULT
    assert 'force control' in reply.message
    assert driver.server.steps_served == 0


def write_test_file(path: Path, **section: Any) -> Path:
    raw = {'test': {'id': 't', 'dt': DT, 'duration': 100 * DT},
           'structure': ONE_DOF_STRUCTURE, 'ground_motion': INLINE_GROUND_MOTION,
           'sites': {'lab1': {'transfer_system': {**SECTION, **section},
                              'bridge': {'driver': 'transfer_system'}}}}
    path.write_text(yaml.safe_dump(raw), encoding='utf-8')
    return path


def test_the_registry_builds_it_from_the_test_file(tmp_path: Path) -> None:
    test_file = write_test_file(tmp_path / 't.yaml')
    driver = make_driver('transfer_system', DriverContext(
        1, {'test_file': str(test_file), 'site': 'lab1'}))
    assert isinstance(driver, TransferSystemDriver)
    assert driver.clock == 'simulated' and driver.loop is None and driver.n_steps == 100
    reference = server()
    bridge = bridge_of(driver)
    for step, target in enumerate(targets(50)):
        expected = reference.handle('t', step, [target])
        reply = bridge.handle_command('t', StepKey(step, 0), [target])
        assert reply is not None and expected is not None
        assert reply.restoring_force == expected.restoring_force


@pytest.mark.parametrize(('parameters', 'n_dof', 'message'), [
    ({'site': 'lab1'}, 1, 'parameter test_file'),
    ({'test_file': 'FILE'}, 1, 'parameter site'),
    ({'test_file': 'FILE', 'site': 'lab2'}, 1, 't.yaml: sites.lab2.transfer_system: missing'),
    ({'test_file': 'FILE', 'site': 'lab1'}, 2, 'one actuator'),
    ({'test_file': 'FILE', 'site': 'lab1', 'clock': 'sundial'}, 1, 'parameter clock'),
])
def test_bad_parameters_are_one_line(tmp_path: Path, parameters: dict[str, Any], n_dof: int,
                                     message: str) -> None:
    test_file = write_test_file(tmp_path / 't.yaml')
    values = {key: str(test_file) if value == 'FILE' else value
              for key, value in parameters.items()}
    with pytest.raises(BridgeConfigError, match=message):
        make_driver('transfer_system', DriverContext(n_dof, values))


def test_a_bad_section_names_the_file_and_key(tmp_path: Path) -> None:
    test_file = write_test_file(tmp_path / 't.yaml', interpolation='spline')
    with pytest.raises(BridgeConfigError,
                       match=r't\.yaml: sites\.lab1\.transfer_system\.interpolation'):
        read_transfer_system(str(test_file), 'lab1')


@pytest.mark.parametrize(('realtime', 'asked'), [({}, 0), ({'cpu_latency': 2e-5}, 20),
                                                  ({'cpu_latency': None}, None)])
def test_the_ticking_loop_asks_for_the_cpu_latency_of_the_test_file(
        tmp_path: Path, realtime: dict[str, Any], asked: int | None) -> None:
    test_file = write_test_file(tmp_path / 't.yaml', realtime=realtime)
    driver = make_driver('transfer_system', DriverContext(
        1, {'test_file': str(test_file), 'site': 'lab1', 'clock': 'realtime'}))
    assert isinstance(driver, TransferSystemDriver) and driver.loop is not None
    request = driver.loop.cpu_latency
    assert (None if request is None else request.latency_us) == asked


def test_realtime_clock_answers_every_step_from_the_ticking_thread(tmp_path: Path) -> None:
    """Wall clock (no timing asserted): each command's measurement comes from the thread, in
    order; the report counts the ticks."""
    report = tmp_path / 'rths.json'
    steps = 40
    driver = TransferSystemDriver(server(), clock='realtime', n_steps=steps,
                                  report_path=str(report))
    bridge = bridge_of(driver)
    replies: list[Any] = []
    arrived = threading.Event()

    def on_reply(reply: Any) -> None:
        replies.append(reply)
        arrived.set()

    bridge.set_reply_callback(on_reply)
    first = bridge.handle_command('rt', StepKey(0, 0), [0.0])
    assert first is not None and first.status is FeedbackStatus.OK  # at rest, at once
    assert driver.loop is not None and not driver.loop.running
    for step, target in enumerate(targets(steps + 1)[1:], start=1):
        arrived.clear()
        answer = bridge.handle_command('rt', StepKey(step, 0), [target])
        if answer is None:
            assert arrived.wait(10.0), f'step {step} not answered'
            answer = replies[-1]
        assert answer.key == StepKey(step, 0) and answer.status is FeedbackStatus.OK
    driver.close()
    assert not driver.loop.running
    statistics = driver.report()
    assert statistics['clock'] == 'realtime' and statistics['steps'] == steps
    assert statistics['ticks'] >= steps * 4
    assert report.is_file()
    assert json.loads(report.read_text(encoding='utf-8'))['steps'] == steps


def test_realtime_capacity_fault_holds_the_bridge_through_on_fault() -> None:
    driver = TransferSystemDriver(server(capacity=1.0), clock='realtime')
    bridge = bridge_of(driver)
    faults: list[Any] = []
    arrived = threading.Event()

    def on_fault(message: str) -> None:
        faults.append(bridge.handle_fault(message))
        arrived.set()

    driver.on_fault = on_fault
    assert bridge.handle_command('rt', StepKey(0, 0), [0.0]) is not None
    assert bridge.handle_command('rt', StepKey(1, 0), [1e-3]) is None  # in flight
    assert arrived.wait(10.0)
    driver.close()
    reply = faults[0]
    assert reply is not None and reply.status is FeedbackStatus.FAULT
    assert reply.key == StepKey(1, 0) and 'capacity' in reply.message
    assert bridge.state == 'holding'
    assert driver.loop is not None and not driver.loop.running

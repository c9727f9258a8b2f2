"""The bridge in the protocol's own types: the driver's typed measurement, the node's neutral
driver hooks (the node names no driver class) and the receiver's rules in one home."""

from __future__ import annotations

import ast
import math
from collections.abc import Sequence
from pathlib import Path

import pytest

from pd_actuator_bridge.core import (
    ActuatorBridge,
    ActuatorDriver,
    ActuatorMeasurement,
    SafetyLimits,
    StepId,
)
from pd_common.protocol import Arrival, Command, Feedback, FeedbackStatus, StepKey, arrival
from support.loopback import LoopbackDriver

NODE = (Path(__file__).resolve().parents[2] / 'src' / 'pd_actuator_bridge' / 'pd_actuator_bridge'
        / 'node.py')
LIMITS = SafetyLimits(max_displacement=0.1, max_increment=0.05, max_force=1.0e4)


class MinimalDriver(ActuatorDriver):
    """Only the abstract methods: every hook keeps its default."""

    @property
    def n_dof(self) -> int:
        return 1

    def command(self, step: StepId, target: Sequence[float]) -> None:
        self._emit(ActuatorMeasurement(step, tuple(target), (0.0,)))

    def hold(self) -> None:
        pass

    def position(self) -> list[float]:
        return [0.0]


def test_the_hooks_default_to_a_synchronous_driver() -> None:
    driver = MinimalDriver()
    assert driver.ready() is True
    assert driver.waiting_for() == 'the driver'
    assert driver.waiting_since() is None
    assert driver.last_force is None and driver.carried_force is None
    assert driver.refusals() == {}
    driver.poll()
    driver.set_test_id('t#2')
    driver.repeat()  # nothing in flight: nothing to do


def test_a_measurement_is_one_typed_record_delivered_to_the_callback() -> None:
    driver = LoopbackDriver(lambda x: [1000.0 * xi for xi in x], 2, [0.0, 0.0])
    driver.open()
    received: list[ActuatorMeasurement] = []
    driver.set_measurement_callback(received.append)
    driver.command((4, 1), [0.01, -0.02])
    assert received == [ActuatorMeasurement((4, 1), (0.01, -0.02), (10.0, -20.0))]
    assert received[0].time is None
    with pytest.raises(AttributeError):
        received[0].step = 5  # type: ignore[misc]  # frozen


def test_the_bridge_answers_in_the_protocol_feedback() -> None:
    driver = LoopbackDriver(lambda x: [1000.0 * xi for xi in x], 1, [0.0])
    driver.open()
    bridge = ActuatorBridge(driver, LIMITS, ['top'])
    reply = bridge.handle_command('run#2', StepKey(3, 2), [0.02])
    assert isinstance(reply, Feedback)
    assert reply == Feedback('run#2', 3, (0.02,), (20.0,), FeedbackStatus.OK, '', 2)
    assert reply.key == StepKey(3, 2)
    assert bridge.last_reply is reply
    plain = bridge.handle_command('other', 0, [0.02])
    assert plain is not None and (plain.step, plain.iteration) == (0, 0)


def test_the_node_names_no_driver_class_and_duck_types_no_driver() -> None:
    tree = ast.parse(NODE.read_text(encoding='utf-8'))
    for node in ast.walk(tree):
        if isinstance(node, ast.Call) and isinstance(node.func, ast.Name):
            if node.func.id == 'isinstance' and len(node.args) == 2:
                checked = ast.unparse(node.args[1])
                assert 'Driver' not in checked, f'node.py line {node.lineno}: {checked}'
            if node.func.id in {'getattr', 'hasattr'} and node.args:
                subject = ast.unparse(node.args[0])
                assert 'driver' not in subject, f'node.py line {node.lineno}: {subject}'
        if isinstance(node, ast.ImportFrom) and node.module == 'sim_servo':
            pytest.fail(f'node.py line {node.lineno} imports names from sim_servo')


@pytest.mark.parametrize(('key', 'last', 'expected'), [
    (StepKey(2, 0), None, Arrival.NEW),
    (StepKey(2, 0), StepKey(2, 0), Arrival.REPEAT),
    (StepKey(2, 1), StepKey(2, 0), Arrival.NEW),
    (StepKey(1, 5), StepKey(2, 0), Arrival.STALE),
    (3, 2, Arrival.NEW),
    (3, 3, Arrival.REPEAT),
    (1, (2, 0), Arrival.STALE),  # cannot be ordered against the last key: foreign
])
def test_the_repeat_ignore_rule_has_one_home(key: int | tuple[int, ...],
                                             last: int | tuple[int, ...] | None,
                                             expected: Arrival) -> None:
    assert arrival(key, last) is expected


def test_the_bridge_and_the_protocol_name_a_bad_control_the_same_way() -> None:
    driver = LoopbackDriver(lambda x: [0.0 for _ in x], 2, [0.0, 0.0])
    driver.open()
    bridge = ActuatorBridge(driver, LIMITS, ['a', 'b'])
    command = Command(test_id='t', step=1, test_time=0.0, dof_names=('a', 'b'),
                      target_displacement=(0.0, 0.0), control_mode=(0, 1),
                      target_force=(0.0, math.nan))
    reply = bridge.handle_command('t', 1, [0.0, 0.0], control_mode=command.control_mode,
                                  target_force=command.target_force)
    assert reply is not None and reply.status is FeedbackStatus.FAULT
    assert reply.message == 'invalid control: DOF 1 (b): target force nan is not finite'
    assert command.control_error() == 'DOF 1: target force nan is not finite'

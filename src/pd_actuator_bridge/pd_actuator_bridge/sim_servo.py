"""The ``sim_servo`` driver: a simulated servo that forwards each checked move to a specimen node.

A shell-side driver (it needs ``rclpy``): each move goes out as a ``StepCommand`` on
``<specimen_namespace>/step_command`` and the specimen node's ``StepFeedback`` on
``<specimen_namespace>/step_feedback`` is the measurement. Importing this module registers it
(:data:`SIM_SERVO`); the node imports it. The node also enforces ``driver_timeout`` on the move
in flight, re-sends the move for a re-sent command (:meth:`SimServoDriver.repeat`) and waits for
:meth:`SimServoDriver.ready` before activating.
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable, Sequence
from typing import Any

from rclpy.node import Node

from pd_common.protocol import FeedbackStatus
from pd_common.ros import STEP_QOS, now_stamp
from pd_msgs.msg import StepCommand, StepFeedback

from .core import (
    ActuatorDriver,
    BridgeConfigError,
    DriverContext,
    DriverParameter,
    DriverSpec,
    register_driver,
)


class SimServoDriver(ActuatorDriver):
    """A simulated servo actuator: forwards each move to a specimen node over ROS 2.

    Each move goes out as a ``StepCommand`` of the driver's own session (test id
    ``bridge-<pid>``, a step counter of its own), so the specimen's repeat handling applies:
    :meth:`repeat` re-sends the move in flight and the specimen answers it without moving.

    Attributes:
        sent_at: ``time.monotonic()`` of the last (re-)sent move.
        on_fault: Receives the message of a specimen fault (the bridge then holds).
    """

    def __init__(self, node: Node, n_dof: int, namespace: str) -> None:
        """Create the publisher and subscription under ``namespace`` on ``node``."""
        super().__init__()
        self._node = node
        self._n_dof = n_dof
        self._session = f'bridge-{os.getpid()}'
        self._publisher = node.create_publisher(StepCommand, f'{namespace}/step_command',
                                                STEP_QOS)
        self._subscription = node.create_subscription(
            StepFeedback, f'{namespace}/step_feedback', self._on_feedback, STEP_QOS)
        self._position = [0.0] * n_dof
        self._sequence = 0
        self._in_flight: tuple[Any, int] | None = None  # (bridge step, driver sequence)
        self._message: StepCommand | None = None
        self.sent_at = 0.0
        self.on_fault: Callable[[str], None] | None = None

    @property
    def n_dof(self) -> int:
        """Number of actuated DOF."""
        return self._n_dof

    def ready(self) -> bool:
        """Whether a specimen node listens and talks back."""
        return (self._publisher.get_subscription_count() > 0
                and self._subscription.get_publisher_count() > 0)

    @property
    def in_flight(self) -> bool:
        """Whether a move is waiting for the specimen's answer."""
        return self._in_flight is not None

    def command(self, step: Any, target: Sequence[float]) -> None:
        """Forward a checked move to the specimen."""
        self._sequence += 1
        message = StepCommand()
        message.header.stamp = now_stamp()
        message.test_id = self._session
        message.step = self._sequence
        message.dof_names = [f'dof{i}' for i in range(self._n_dof)]
        message.target_displacement = [float(value) for value in target]
        self._in_flight = (step, self._sequence)
        self._message = message
        self.repeat()

    def repeat(self) -> None:
        """Re-send the move in flight (the specimen answers it again without moving)."""
        if self._message is not None and self._in_flight is not None:
            self.sent_at = time.monotonic()
            self._publisher.publish(self._message)

    def hold(self) -> None:
        """Stop: forget the move in flight; the specimen stays where it is."""
        self._in_flight = None

    def position(self) -> list[float]:
        """Last measured displacement."""
        return list(self._position)

    def close(self) -> None:
        """Release the topics."""
        self._in_flight = None
        self._node.destroy_publisher(self._publisher)
        self._node.destroy_subscription(self._subscription)

    def _on_feedback(self, message: StepFeedback) -> None:
        """Report the specimen's answer to the move in flight (ignore anything else)."""
        if (self._in_flight is None or message.test_id != self._session
                or message.step != self._in_flight[1]):
            return
        step = self._in_flight[0]
        self._in_flight = None
        if message.status != FeedbackStatus.OK:
            if self.on_fault is not None:
                self.on_fault(f'specimen fault at step {step}: {message.message}')
            return
        self._position = list(message.measured_displacement)
        self._emit(step, list(message.measured_displacement), list(message.restoring_force))


def make_sim_servo_driver(context: DriverContext) -> SimServoDriver:
    """The ``sim_servo`` driver on ``context.host`` (the node), faults to ``context.on_fault``.

    Raises:
        BridgeConfigError: If ``context.host`` is not an ``rclpy`` node.
    """
    if not isinstance(context.host, Node):
        msg = (f'driver sim_servo: needs the rclpy node as DriverContext.host, got '
               f'{type(context.host).__name__}')
        raise BridgeConfigError(msg)
    driver = SimServoDriver(context.host, context.n_dof, context.parameters['specimen_namespace'])
    driver.on_fault = context.on_fault
    return driver


SIM_SERVO = DriverSpec(
    name='sim_servo',
    factory=make_sim_servo_driver,
    parameters=(
        DriverParameter('specimen_namespace', 'specimen', 'namespace of the specimen node'),
        DriverParameter('driver_timeout', 5.0,
                        'seconds one move may take before the bridge holds'),
    ),
    description='simulated servo: forwards each checked move to a pd_specimen_sim node '
                '(<specimen_namespace>/step_command) and returns its measurement',
)
register_driver(SIM_SERVO)

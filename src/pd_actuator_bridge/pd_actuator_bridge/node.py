"""The actuator bridge node (``ros2 run pd_actuator_bridge main``).

The boundary between the test loop and the hardware. It answers the integrator's
``step_command`` with ``step_feedback`` like a specimen does, but every command first passes the
bridge's own safety limits (:class:`pd_actuator_bridge.core.ActuatorBridge`): a NaN, a jump or a
target beyond a limit never reaches the driver; the actuator holds position, the command is
answered with a limit/fault status and the reason is published on ``bridge/status``. The hold
is latched until an operator sends ``reset`` on ``bridge/control``.

Drivers (parameter ``driver``):

* ``sim_servo``: a simulated servo actuator that forwards each checked command to a specimen
  node (``<specimen_namespace>/step_command``) and returns its measured displacement and force.

Topics (relative; namespace ``/pd``): ``step_command`` (in), ``step_feedback`` (out),
``bridge/status`` (latched ``pd_msgs/TestStatus``), ``bridge/control`` (``std_msgs/String``:
``reset`` or ``hold``); for ``sim_servo`` also ``specimen/step_command`` (out) and
``specimen/step_feedback`` (in).
"""

from __future__ import annotations

import os
import sys
import time
from collections.abc import Sequence
from typing import Any

import rclpy
from rcl_interfaces.msg import ParameterDescriptor
from rclpy.executors import ExternalShutdownException
from rclpy.experimental import EventsExecutor
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from builtin_interfaces.msg import Time
from std_msgs.msg import String

from pd_msgs.msg import StepCommand, StepFeedback, TestStatus

from .core import (
    ActuatorBridge,
    ActuatorDriver,
    BridgeConfigError,
    BridgeError,
    BridgeReply,
    SafetyLimits,
)

STEP_QOS = QoSProfile(history=HistoryPolicy.KEEP_ALL, reliability=ReliabilityPolicy.RELIABLE,
                      durability=DurabilityPolicy.VOLATILE)
LATCHED_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1,
                         reliability=ReliabilityPolicy.RELIABLE,
                         durability=DurabilityPolicy.TRANSIENT_LOCAL)

_STATUS_CODES = {'ok': StepFeedback.STATUS_OK, 'limit': StepFeedback.STATUS_LIMIT,
                 'fault': StepFeedback.STATUS_FAULT}


def now_stamp() -> Time:
    """The wall-clock time as a message stamp (cheaper than the node clock)."""
    t_ns = time.time_ns()
    return Time(sec=t_ns // 1_000_000_000, nanosec=t_ns % 1_000_000_000)


class SimServoDriver(ActuatorDriver):
    """A simulated servo actuator: forwards each move to a specimen node over ROS 2.

    Each move goes out as a ``StepCommand`` of the driver's own session (test id
    ``bridge-<pid>``, a step counter of its own), so the specimen's repeat handling applies:
    :meth:`repeat` re-sends the move in flight and the specimen answers it without moving.
    """

    def __init__(self, node: Node, n_dof: int, namespace: str) -> None:
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
        self._in_flight: tuple[int, int] | None = None  # (bridge step, driver sequence)
        self._message: StepCommand | None = None
        self.sent_at = 0.0
        self.on_fault: Any = None  # callable(message) set by the node

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

    def command(self, step: int, target: Sequence[float]) -> None:
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

    def _on_feedback(self, message: StepFeedback) -> None:
        if (self._in_flight is None or message.test_id != self._session
                or message.step != self._in_flight[1]):
            return
        step = self._in_flight[0]
        self._in_flight = None
        if message.status != StepFeedback.STATUS_OK:
            if self.on_fault is not None:
                self.on_fault(f'specimen fault at step {step}: {message.message}')
            return
        self._position = list(message.measured_displacement)
        self._emit(step, list(message.measured_displacement), list(message.restoring_force))


class ActuatorBridgeNode(Node):
    """Enforces the bridge's limits between the integrator and the actuator driver."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__('pd_actuator_bridge', namespace='pd', **kwargs)
        describe = ParameterDescriptor
        self.declare_parameter('driver', 'sim_servo', describe(
            description='actuator driver: sim_servo'))
        self.declare_parameter('dof_names', ['top'], describe(
            description='one name per actuator DOF'))
        self.declare_parameter('specimen_namespace', 'specimen', describe(
            description='sim_servo: namespace of the specimen node, relative to this node'))
        self.declare_parameter('driver_timeout', 5.0, describe(
            description='seconds the driver may take for one move before the bridge holds'))
        self.declare_parameter('max_displacement', 0.25, describe(
            description='absolute displacement limit of every DOF [m]'))
        self.declare_parameter('max_increment', 0.02, describe(
            description='largest displacement change in one step [m]'))
        self.declare_parameter('max_force', 1.0e5, describe(
            description='absolute measured force limit [N]'))
        self.declare_parameter('max_velocity', 0.0, describe(
            description='velocity limit [m/s] (0 = off; needs step_duration)'))
        self.declare_parameter('step_duration', 0.0, describe(
            description='time the actuator takes for one step [s] (0 = off)'))

        value = self.get_parameter
        names = list(value('dof_names').value)
        limits = {key: float(value(key).value) for key in
                  ('max_displacement', 'max_increment', 'max_force')}
        for key in ('max_velocity', 'step_duration'):
            if float(value(key).value) > 0.0:
                limits[key] = float(value(key).value)
        self.limits = SafetyLimits.from_mapping(limits, source='pd_actuator_bridge parameters')
        driver_name = value('driver').value
        if driver_name != 'sim_servo':
            msg = f"parameter driver: unknown driver {driver_name!r} (available: sim_servo)"
            raise BridgeConfigError(msg)
        self.driver_timeout = float(value('driver_timeout').value)
        self.driver = SimServoDriver(self, len(names), value('specimen_namespace').value)
        self.driver.on_fault = self._on_driver_fault
        self.bridge = ActuatorBridge(self.driver, self.limits, names)
        self.bridge.set_reply_callback(self._publish_reply)
        self._status_pub = self.create_publisher(TestStatus, 'bridge/status', LATCHED_QOS)
        self.create_subscription(String, 'bridge/control', self._on_control, 10)
        self._feedback_pub: Any = None
        self._feedback = StepFeedback()
        self._test_id = ''
        self._step = 0
        self.publish_status(TestStatus.STATE_IDLE, 'waiting for the actuator driver')

    def connect(self) -> None:
        """Start answering the integrator (once the driver is ready)."""
        self._feedback_pub = self.create_publisher(StepFeedback, 'step_feedback', STEP_QOS)
        self.create_subscription(StepCommand, 'step_command', self._on_command, STEP_QOS)
        limits = self.limits
        self.publish_status(TestStatus.STATE_RUNNING, (
            f'ready: |x| <= {limits.max_displacement} m, |dx| <= {limits.max_increment} m per '
            f'step, |f| <= {limits.max_force} N'))

    def publish_status(self, state: int, message: str) -> None:
        """Publish the bridge's latched status."""
        status = TestStatus()
        status.header.stamp = self.get_clock().now().to_msg()
        status.test_id = self._test_id
        status.state = state
        status.step = self._step
        status.message = message
        self._status_pub.publish(status)

    def _on_command(self, message: StepCommand) -> None:
        self._test_id, self._step = message.test_id, message.step
        key = (message.step, message.iteration)  # the bridge core orders steps by this key
        was_holding = self.bridge.state == 'holding'
        reply = self.bridge.handle_command(message.test_id, key,  # type: ignore[arg-type]
                                           tuple(message.target_displacement))
        if reply is None and self.bridge.in_flight == (message.test_id, key):
            self.driver.repeat()  # a re-sent command: ask the specimen again, no new motion
        if reply is not None:
            self._publish_reply(reply)
            if reply.status != 'ok' and not was_holding:
                self.get_logger().error(f'holding: {reply.message}')

    def _on_driver_fault(self, message: str) -> None:
        reply = self.bridge.handle_fault(message)
        if reply is not None:
            self.get_logger().error(f'holding: {message}')
            self._publish_reply(reply)

    def check_driver(self) -> None:
        """Hold if the driver did not answer the move in flight in time."""
        if (self.driver.in_flight and self.bridge.state == 'busy'
                and time.monotonic() - self.driver.sent_at > self.driver_timeout):
            self._on_driver_fault(f'actuator did not reach step {self._step} within '
                                  f'{self.driver_timeout} s')

    def _publish_reply(self, reply: BridgeReply) -> None:
        feedback = self._feedback
        feedback.header.stamp = now_stamp()
        feedback.test_id = reply.test_id
        step, iteration = reply.step if isinstance(reply.step, tuple) else (reply.step, 0)
        feedback.step = step
        feedback.iteration = iteration
        feedback.measured_displacement = list(reply.displacement)
        feedback.restoring_force = list(reply.force)
        feedback.status = _STATUS_CODES[reply.status]
        feedback.message = reply.message
        self._feedback_pub.publish(feedback)
        if reply.status != 'ok':
            self.publish_status(TestStatus.STATE_HOLDING, reply.message)

    def _on_control(self, message: String) -> None:
        request = message.data.strip().lower()
        if request == 'reset':
            self.bridge.reset()
            self.get_logger().warning('hold reset by operator')
            self.publish_status(TestStatus.STATE_RUNNING, 'hold reset by operator')
        elif request == 'hold':
            self._on_driver_fault('hold requested by operator')
            self.publish_status(TestStatus.STATE_HOLDING, 'hold requested by operator')
        else:
            self.get_logger().warning(f'bridge/control: unknown request {message.data!r}')


def main(args: list[str] | None = None) -> int:
    """Entry point of ``ros2 run pd_actuator_bridge main``."""
    rclpy.init(args=args)
    node: ActuatorBridgeNode | None = None
    executor: EventsExecutor | None = None
    try:
        try:
            node = ActuatorBridgeNode()
        except (BridgeError, ValueError) as err:
            print(f'pd_actuator_bridge: error: {err}', file=sys.stderr)
            return 2
        executor = EventsExecutor()
        executor.add_node(node)
        while rclpy.ok() and not node.driver.ready():
            executor.spin_once(timeout_sec=0.05)
        node.connect()
        while rclpy.ok():
            executor.spin_once(timeout_sec=0.1)
            node.check_driver()
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        if executor is not None:
            executor.shutdown()
        if node is not None:
            node.driver.hold()
            node.destroy_node()
        rclpy.try_shutdown()
    return 0


if __name__ == '__main__':
    sys.exit(main())

"""A fault-injection proxy between a step-command sender and its receiver (``fault_proxy``).

``ros2 run pd_bringup fault_proxy --ros-args -p front:=/pd -p back:=/pd/behind
-p faults:=drop=0.1,duplicate=0.1,delay=0.1,reorder=0.1,seed=7 -p report_file:=faults.json``

The sender (the integrator) talks to the namespace ``front``; the receiver (a simulator or an
actuator bridge) really is in ``back``. The proxy forwards

* ``<front>/step_command`` → ``<back>/step_command`` and ``<back>/step_feedback`` →
  ``<front>/step_feedback`` with the faults of the plan applied (one
  :class:`~pd_bringup.faults.FaultInjector` per direction: drop, duplicate, delay, reorder;
  its direction is the topic it takes from, so the proxies of two sites draw different fates);
* ``<back>/session/offer`` → ``<front>/session/offer`` (latched, re-published latched) and
  ``<front>/session/start`` → ``<back>/session/start``, without faults.

Every message is forwarded as the serialized bytes it arrived as: the proxy holds no key and
cannot forge or re-sign anything, so authentication works end to end (a duplicated or
reordered message reaches its receiver as a replay, and is refused there). The receiver's offer
is passed on only once the proxy's back-side endpoints are matched with the receiver, so the
sender never opens a session through a half-connected proxy.

Parameters: ``front``, ``back`` (absolute namespaces), ``faults`` (the plan, see
:meth:`~pd_bringup.faults.FaultPlan.parse`; ``none``: forward everything), ``report_file``
(JSON counters per direction and kind, written every second and at exit; '' = none). A proxy
that finds its report file (of the same plan and namespaces) when it starts is a restarted one:
it continues the counters and the fates from the last one's last report (what that one held,
and what it handled after its last report, is lost).

Exit codes: 0 stopped by SIGINT/SIGTERM (the report is written), 2 invalid parameters.
"""

from __future__ import annotations

import json
import os
import sys
import time
from collections import Counter
from pathlib import Path
from typing import Any

import rclpy
from rcl_interfaces.msg import ParameterDescriptor
from rclpy.exceptions import InvalidNamespaceException
from rclpy.executors import Executor
from rclpy.node import Node
from rclpy.publisher import Publisher
from rclpy.qos import QoSProfile
from rclpy.subscription import Subscription
from rclpy.validate_namespace import validate_namespace

from pd_common.ros import (
    LATCHED_QOS,
    STEP_QOS,
    TEARDOWN_TIMEOUT,
    init_with_stop_flag,
    run_node,
    seal_parameters,
)
from pd_common.signals import StopFlag
from pd_msgs.msg import SessionOffer, SessionStart, StepCommand, StepFeedback

from .faults import FaultInjector, FaultPlan, FaultPlanError

#: Seconds between two writes of the report file.
REPORT_INTERVAL = 1.0
#: Longest wait of the spin loop for an event, s (shorter when a held message is due sooner).
SPIN_TIMEOUT = 0.05
#: QoS of session starts (as :class:`pd_common.ros.SessionSender` publishes them).
START_QOS = QoSProfile(depth=10, reliability=STEP_QOS.reliability)
#: The node's parameters: name -> (default, description).
PARAMETERS = {
    'front': ('/pd', 'namespace the sender (the integrator) talks to'),
    'back': ('/pd/behind', 'namespace the receiver (simulator or bridge) really is in'),
    'faults': ('none', 'fault plan, e.g. drop=0.1,delay=0.1,seed=7,delay_s=0.05 (or none)'),
    'report_file': ('', 'JSON file of the counters, written every second and at exit (or none)'),
}


class ProxyError(ValueError):
    """A parameter of the proxy is invalid (the message is one line)."""


def _namespace(node: Node, name: str) -> str:
    value = _text(node, name).strip()
    if len(value) > 1:
        value = value.rstrip('/')
    try:
        validate_namespace(value)
    except InvalidNamespaceException as err:
        reason = str(err).splitlines()[0]
        msg = f'parameter {name}: {value!r} is not an absolute ROS namespace ({reason})'
        raise ProxyError(msg) from None
    return '' if value == '/' else value


def _text(node: Node, name: str) -> str:
    value = node.get_parameter(name).value
    if not isinstance(value, str):
        msg = f'parameter {name}: {value!r} is not a string'
        raise ProxyError(msg)
    return value


class _Direction:
    """One faulted direction: a raw subscription, an injector and a raw publisher."""

    def __init__(self, node: Node, message_type: Any, source: str, target: str,
                 injector: FaultInjector[bytes]) -> None:
        self.source = source
        self.target = target
        self.injector = injector
        self.publisher: Publisher[Any] = node.create_publisher(message_type, target, STEP_QOS)
        self.subscription: Subscription[Any] = node.create_subscription(
            message_type, source, self._on_message, STEP_QOS, raw=True)

    def _on_message(self, data: bytes) -> None:
        self._send(self.injector.submit(data, time.monotonic()))

    def poll(self, now: float) -> None:
        """Send the held messages that are due."""
        self._send(self.injector.poll(now))

    def _send(self, messages: list[bytes]) -> None:
        for data in messages:
            self.publisher.publish(data)


class FaultProxyNode(Node):
    """Forwards the step protocol between two namespaces, with faults on the step messages.

    Raises:
        ProxyError: a namespace parameter is invalid, or front and back are the same.
        FaultPlanError: the fault plan is invalid.
    """

    def __init__(self, **kwargs: Any) -> None:
        super().__init__('pd_fault_proxy', namespace='pd', **kwargs)
        # Dynamically typed: a value the command line reads as a number (faults:=0.1) gets a
        # one-line error of ours instead of rclpy's type exception.
        for name, (default, description) in PARAMETERS.items():
            self.declare_parameter(name, default, ParameterDescriptor(
                description=description, dynamic_typing=True))
        self.front = _namespace(self, 'front')
        self.back = _namespace(self, 'back')
        if self.front == self.back:
            msg = f'parameters front and back: both are {self.front or "/"!r} (a loop)'
            raise ProxyError(msg)
        try:
            self.plan = FaultPlan.parse(_text(self, 'faults'))
        except FaultPlanError as err:
            msg = f'parameter faults: {err}'
            raise FaultPlanError(msg) from None
        report = _text(self, 'report_file')
        self.report_file = Path(report) if report else None

        self.commands = _Direction(self, StepCommand, f'{self.front}/step_command',
                                   f'{self.back}/step_command',
                                   FaultInjector(self.plan, f'{self.front}/step_command'))
        self.feedback = _Direction(self, StepFeedback, f'{self.back}/step_feedback',
                                   f'{self.front}/step_feedback',
                                   FaultInjector(self.plan, f'{self.back}/step_feedback'))
        self.session_counts = {'offers_received': 0, 'offers_forwarded': 0,
                               'starts_forwarded': 0}
        self._offer: bytes | None = None
        self._offer_forwarded = True
        self._offer_pub = self.create_publisher(SessionOffer, f'{self.front}/session/offer',
                                                LATCHED_QOS)
        self.create_subscription(SessionOffer, f'{self.back}/session/offer', self._on_offer,
                                 LATCHED_QOS, raw=True)
        self._start_pub = self.create_publisher(SessionStart, f'{self.back}/session/start',
                                                START_QOS)
        self.create_subscription(SessionStart, f'{self.front}/session/start', self._on_start,
                                 START_QOS, raw=True)
        self.state = 'running'
        self.starts = 1
        # (its faults as given at start: nobody on the domain changes them while it runs)
        seal_parameters(self, 'the fault proxy', 'restart it', Counter(),
                        because='its fault plan is fixed')
        self._reported_at = 0.0
        self._restore()
        self.get_logger().info(f'fault proxy {self.front or "/"} -> {self.back}: {self.plan}'
                               + (f' (start {self.starts}: continuing the counters and the '
                                  'fates of the last one)' if self.starts > 1 else ''))

    def _restore(self) -> None:
        """A restarted proxy (its report file is there, of the same plan and namespaces).

        Continue its counters, and its fates where they stopped.
        """
        if self.report_file is None or not self.report_file.is_file():
            return
        try:
            data = json.loads(self.report_file.read_text(encoding='utf-8'))
            if (data.get('faults') != str(self.plan) or data.get('back') != self.back
                    or data.get('front') != (self.front or '/')):
                self.get_logger().warning(f'report_file {self.report_file}: of another plan '
                                          'or namespaces; starting from zero')
                return
            self.commands.injector.restore(data['step_command'])
            self.feedback.injector.restore(data['step_feedback'])
            for name in self.session_counts:
                self.session_counts[name] = int(data['session'][name])
            self.starts = int(data.get('starts', 1)) + 1
        except (OSError, ValueError, KeyError, TypeError, AttributeError) as err:
            self.commands.injector = FaultInjector(self.plan, self.commands.source)
            self.feedback.injector = FaultInjector(self.plan, self.feedback.source)
            self.session_counts = dict.fromkeys(self.session_counts, 0)
            self.starts = 1
            self.get_logger().warning(f'report_file {self.report_file}: cannot continue from '
                                      f'it ({err}); starting from zero')

    # -- session messages (no faults) ------------------------------------------------------------
    def _on_offer(self, data: bytes) -> None:
        self.session_counts['offers_received'] += 1
        self._offer = data
        self._offer_forwarded = False
        self._forward_offer()

    def _back_matched(self) -> bool:
        """Whether the receiver hears our commands and starts and we hear its feedback."""
        return (self.commands.publisher.get_subscription_count() > 0
                and self._start_pub.get_subscription_count() > 0
                and self.feedback.subscription.get_publisher_count() > 0)

    def _forward_offer(self) -> None:
        if self._offer_forwarded or self._offer is None or not self._back_matched():
            return
        self._offer_pub.publish(self._offer)
        self._offer_forwarded = True
        self.session_counts['offers_forwarded'] += 1

    def _on_start(self, data: bytes) -> None:
        self._start_pub.publish(data)
        self.session_counts['starts_forwarded'] += 1

    # -- loop -----------------------------------------------------------------------------------
    def poll(self) -> float:
        """Release due messages, pass on a pending offer, write the report when it is time.

        Returns:
            How long the spin loop may wait for events before calling again, s.
        """
        now = time.monotonic()
        self.commands.poll(now)
        self.feedback.poll(now)
        self._forward_offer()
        if now - self._reported_at >= REPORT_INTERVAL:
            self.write_report()
            self._reported_at = now
        wait = SPIN_TIMEOUT
        for direction in (self.commands, self.feedback):
            release = direction.injector.next_release()
            if release is not None:
                wait = min(wait, max(0.0, release - now))
        return wait

    def report(self) -> dict[str, Any]:
        """The counters per direction and kind, and the plan."""
        return {'front': self.front or '/', 'back': self.back, 'faults': str(self.plan),
                'plan': self.plan.as_dict(), 'state': self.state, 'starts': self.starts,
                'step_command': self.commands.injector.report(),
                'step_feedback': self.feedback.injector.report(),
                'session': dict(self.session_counts)}

    def write_report(self) -> None:
        """Write the report file (atomically; nothing without one)."""
        if self.report_file is None:
            return
        try:
            self.report_file.parent.mkdir(parents=True, exist_ok=True)
            partial = self.report_file.with_name(self.report_file.name + '.partial')
            partial.write_text(json.dumps(self.report(), indent=2) + '\n', encoding='utf-8')
            os.replace(partial, self.report_file)
        except OSError as err:
            self.get_logger().error(f'report_file {self.report_file}: {err}')


def run(node: FaultProxyNode, executor: Executor, stop: StopFlag) -> None:
    """Forward until ``stop`` is set (or the context shuts down); write the final report."""
    wait = 0.0
    try:
        while not stop.is_set() and rclpy.ok():
            executor.spin_once(timeout_sec=wait)
            wait = node.poll()
    finally:
        node.state = 'stopped'
        node.write_report()
        held = node.commands.injector.held + node.feedback.injector.held
        node.get_logger().info(
            f'stopped: step_command {_summary(node.commands.injector)}; step_feedback '
            f'{_summary(node.feedback.injector)}' + (f'; {held} held messages discarded'
                                                     if held else ''))


def _summary(injector: FaultInjector[bytes]) -> str:
    counts = injector.counts
    return (f"{counts['received']} in, {counts['forwarded']} out ({counts['dropped']} dropped, "
            f"{counts['duplicated']} duplicated, {counts['delayed']} delayed, "
            f"{counts['reordered']} reordered)")


def main(args: list[str] | None = None) -> int:
    """Entry point of ``ros2 run pd_bringup fault_proxy``."""
    stop = init_with_stop_flag(args)
    return run_node('fault_proxy', FaultProxyNode, (ProxyError, FaultPlanError),
                    lambda node, executor: run(node, executor, stop),
                    teardown_timeout=TEARDOWN_TIMEOUT)


if __name__ == '__main__':
    sys.exit(main())

"""The launcher's hands on the graph: signed controls, and what the nodes say of themselves.

:class:`Operator` is a small rclpy node of ``run_test`` (and the sender of ``./pd control``):
it signs controls with the test's key (the launcher is the test's owner, as the operator at
the console is) and sends them to the integrator (``/pd/test_control``) or to a bridge
(``/pd/[<site>/]bridge/control``); it keeps the last status of the integrator and of every
bridge, and every session offer it saw (which tells when a restarted process is up again).
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Any

from rclpy.node import Node

from pd_common.auth import Key, Signer
from pd_common.protocol import site_topic_name
from pd_common.ros import CONTROL_DEPTH, LATCHED_QOS, signed_control
from pd_msgs.msg import Control as ControlMessage
from pd_msgs.msg import SessionOffer, TestStatus

__all__ = ['Operator', 'SeenOffer', 'signed_control']


@dataclass(frozen=True)
class SeenOffer:
    """A session offer and when (``time.monotonic()``) it arrived."""

    at: float
    epoch: str
    challenge: str
    active_session: str
    authenticated: bool


class Operator:
    """Signed controls to the integrator and the bridges; their statuses and offers.

    Args:
        node: the rclpy node to work on.
        key: the test's key (``None``: authentication is off, controls go unsigned).
    """

    def __init__(self, node: Node, key: Key | None) -> None:
        self.node = node
        self._signer = Signer(key) if key is not None else None
        self._publishers: dict[str, Any] = {}
        self.statuses: dict[str, Any] = {}
        self.offers: dict[str, SeenOffer] = {}

    def _publisher(self, topic: str) -> Any:
        if topic not in self._publishers:
            self._publishers[topic] = self.node.create_publisher(ControlMessage, topic,
                                                                 CONTROL_DEPTH)
        return self._publishers[topic]

    def send(self, command: str, *, bridge_site: str | None = None, reason: str = '') -> bool:
        """Send one control (to a bridge when ``bridge_site`` is given); whether anyone
        listens."""
        topic = (site_topic_name(bridge_site, 'bridge/control') if bridge_site is not None
                 else site_topic_name('', 'test_control'))
        publisher = self._publisher(topic)
        if publisher.get_subscription_count() == 0:
            return False
        publisher.publish(signed_control(self._signer, command, bridge_site or '', reason))
        return True

    def watch_status(self, topic: str) -> None:
        """Keep the last status published on ``topic`` (latched)."""
        def keep(message: Any, topic: str = topic) -> None:
            self.statuses[topic] = message

        self.node.create_subscription(TestStatus, topic, keep, LATCHED_QOS)

    def watch_offer(self, namespace: str) -> None:
        """Keep the last session offer of the receiver in ``namespace``."""
        def keep(message: Any, namespace: str = namespace) -> None:
            self.offers[namespace] = SeenOffer(
                at=time.monotonic(), epoch=str(message.epoch), challenge=str(message.challenge),
                active_session=str(message.active_session),
                authenticated=bool(message.authenticated))

        self.node.create_subscription(SessionOffer, f'{namespace}/session/offer', keep,
                                      LATCHED_QOS)

    def status_state(self, topic: str) -> int | None:
        """The state of the last status on ``topic`` (``None``: none seen)."""
        status = self.statuses.get(topic)
        return int(status.state) if status is not None else None

    def status_message(self, topic: str) -> str:
        """The message of the last status on ``topic``."""
        status = self.statuses.get(topic)
        return str(status.message) if status is not None else ''

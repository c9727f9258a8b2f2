"""Sending a person's (or the supervisor's) controls: bound, signed, and confirmed.

A control is obeyed only if it names its receiver, the receiver's instance session and its
test (:class:`pd_common.auth.ControlGate`), and the receiver acknowledges the last control it
took in its signed status. So :class:`ControlSender` first reads the receiver's status (it
watches the status topic), binds the control to what that status names, publishes it, and
then reads the acknowledgement: a control whose receipt is not acknowledged is sent again
(signed anew: a repeat of the same signature would be refused as a replay); its sender learns
whether it was carried out, or why not. ``./pd control``, ``run_test`` and ``./pd console``
all send their controls through it.
"""

from __future__ import annotations

import itertools
import time
from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import Any

from rclpy.node import Node

from pd_msgs.msg import Control as ControlMessage
from pd_msgs.msg import TestStatus

from ..auth.gates import StatusGate
from ..auth.keys import Key
from ..auth.payloads import control_payload
from ..auth.signing import Signer, new_session
from ..protocol.controls import Acknowledgement, find_acknowledgement
from ..protocol.messages import Control, Status
from ..protocol.signature import Signature
from .messages import control_message
from .qos import CONTROL_DEPTH, LATCHED_QOS
from .statements import read_status

__all__ = ['RESEND_S', 'ControlSender', 'Sent', 'emergency_stop_receivers', 'listens']

#: Seconds to wait for an acknowledgement before the control is sent again.
RESEND_S = 1.0


@dataclass(frozen=True)
class Sent:
    """A control sent, waiting for its acknowledgement.

    Attributes:
        control: what was sent (bound to its receiver).
        topic: the control topic.
        status_topic: where its receiver acknowledges.
        signature: its signature (unsigned without a key: a nonce and a sequence only).
        sent_at: ``time.monotonic()`` when it left.
        attempts: how many times it was sent.
    """

    control: Control
    topic: str
    status_topic: str
    signature: Signature
    sent_at: float
    attempts: int = 1


class ControlSender:
    """Bound, signed controls and their acknowledgements (see the module).

    Args:
        node: the rclpy node to work on.
        key: the key (``None``: authentication off, controls go unsigned).
        sender: who sends (``operator <user>@<host> (<tool>)``, ``run_test``, ``console``).

    Attributes:
        statuses: the last genuine status per status topic.
        heard: ``time.monotonic()`` of the last genuine status per status topic.
        gate: the check of the receivers' statuses (refusals counted by reason).
    """

    def __init__(self, node: Node, key: Key | None, sender: str) -> None:
        self.node = node
        self.sender = sender
        self.signer = Signer(key) if key is not None else None
        self._unsigned = (new_session(), itertools.count(1))
        self.gate = StatusGate(key)
        self.statuses: dict[str, Status] = {}
        self.heard: dict[str, float] = {}
        self._publishers: dict[str, Any] = {}
        self._watched: set[str] = set()

    def watch(self, status_topic: str,
              on_status: Callable[[Status], None] | None = None) -> None:
        """Keep the last genuine status published on ``status_topic`` (latched).

        Hand each to ``on_status`` too.
        """
        if status_topic in self._watched:
            return
        self._watched.add(status_topic)

        def keep(message: Any, topic: str = status_topic) -> None:
            status, _ = read_status(self.gate, topic, message)
            if status is not None:
                self.statuses[topic] = status
                self.heard[topic] = time.monotonic()
                if on_status is not None:
                    on_status(status)

        self.node.create_subscription(TestStatus, status_topic, keep, LATCHED_QOS)

    def publisher(self, topic: str) -> Any:
        """The control publisher of ``topic`` (made once)."""
        if topic not in self._publishers:
            self._publishers[topic] = self.node.create_publisher(ControlMessage, topic,
                                                                 CONTROL_DEPTH)
        return self._publishers[topic]

    def ready(self, topic: str, status_topic: str) -> bool:
        """Whether the receiver's status is known and the receiver listens on ``topic``.

        Whether the receiver's status is known and the receiver itself listens on
        ``topic`` (another listener there is not the receiver).
        """
        self.watch(status_topic)
        status = self.statuses.get(status_topic)
        return (status is not None and self.publisher(topic).get_subscription_count() > 0
                and listens(self.node, topic, status.node))

    def send(self, command: str, topic: str, status_topic: str, reason: str = ''
             ) -> Sent | None:
        """Send ``command`` on ``topic`` to the node whose status is on ``status_topic``.

        ``None`` when its status is not known yet or it does not listen (nothing was sent).
        """
        if not self.ready(topic, status_topic):
            return None
        status = self.statuses[status_topic]
        control = Control(command=command, target=status.node, reason=reason,
                          stamp=time.time(), test_id=status.test_id, session=status.session,
                          sender=self.sender)
        return self._publish(Sent(control, topic, status_topic, Signature(), 0.0, 0))

    def _publish(self, sent: Sent) -> Sent:
        control = replace(sent.control, stamp=time.time())
        if self.signer is not None:
            signature = self.signer.sign(control_payload(control))
        else:  # unsigned: a nonce and a sequence, so that its acknowledgement is its own
            signature = Signature(session=self._unsigned[0], sequence=next(self._unsigned[1]))
        self.publisher(sent.topic).publish(control_message(control, signature))
        return replace(sent, control=control, signature=signature, sent_at=time.monotonic(),
                       attempts=sent.attempts + 1)

    def acknowledgement(self, sent: Sent) -> Acknowledgement | None:
        """The receiver's acknowledgement of ``sent`` (``None``: not yet)."""
        status = self.statuses.get(sent.status_topic)
        if status is None:
            return None
        return find_acknowledgement(status.acknowledged, sent.signature)

    def resend(self, sent: Sent) -> Sent:
        """Send ``sent`` again, signed anew and bound to the receiver's current status.

        Send ``sent`` again, signed anew and bound to the receiver as its status names it
        now (a receiver that restarted has a new session).
        """
        status = self.statuses.get(sent.status_topic)
        control = sent.control
        if status is not None:
            control = replace(control, target=status.node, test_id=status.test_id,
                              session=status.session)
        return self._publish(replace(sent, control=control))


#: The nodes that take the lab-wide emergency stop, by name: where each says it holds.
_STOP_STATUS = {'pd_actuator_bridge': 'bridge/status', 'pd_integrator': 'test_status'}


def emergency_stop_receivers(node: Node, topic: str) -> dict[str, str]:
    """The bridges and integrators listening on the emergency stop ``topic`` now.

    Their fully qualified names and the status topic where each confirms that it holds.
    """
    receivers = {}
    for info in node.get_subscriptions_info_by_topic(topic):
        status = _STOP_STATUS.get(info.node_name)
        if status is None:
            continue
        namespace = info.node_namespace.rstrip('/')
        receivers[f'{namespace}/{info.node_name}'] = f'{namespace}/{status}'
    return receivers


def listens(node: Node, topic: str, identity: str) -> bool:
    """Whether the node named ``identity`` (fully qualified) subscribes to ``topic``."""
    return any(f'{info.node_namespace.rstrip("/")}/{info.node_name}' == identity
               for info in node.get_subscriptions_info_by_topic(topic))

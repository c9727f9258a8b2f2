"""The launcher's hands on the graph: signed controls, and what the nodes say of themselves.

:class:`Operator` is a small rclpy node part of ``run_test``: it sends the supervisor's
controls (``auto_hold``, ``auto_resume``, ``restarted`` to the integrator on
``/pd/test_control``; ``auto_hold``, ``auto_reset`` to a bridge on
``/pd/[<site>/]bridge/control``), bound to their receivers and signed with the test's key (the
launcher is the test's owner), through :class:`pd_common.ros.ControlSender`, which also reads
their acknowledgements. It keeps the last genuine status of the integrator and of every bridge
and every genuine session offer it saw (which tells when a restarted process is up again, and
that a live one still answers): a status or an offer its node did not sign is not believed.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Any

from rclpy.node import Node

from pd_common.auth import Key, StatusGate
from pd_common.protocol import SUPERVISOR, Acknowledgement, site_topic_name
from pd_common.ros import LATCHED_QOS, ControlSender, Sent, read_offer
from pd_msgs.msg import SessionOffer

__all__ = ['Operator', 'SeenOffer', 'control_topics']


def control_topics(bridge_site: str | None) -> tuple[str, str]:
    """The control and status topics of the integrator or of a site's bridge.

    The control topic and the status topic of the integrator (``None``) or of the bridge
    of ``bridge_site`` ('' = the default site).
    """
    if bridge_site is None:
        return site_topic_name('', 'test_control'), site_topic_name('', 'test_status')
    return (site_topic_name(bridge_site, 'bridge/control'),
            site_topic_name(bridge_site, 'bridge/status'))


@dataclass(frozen=True)
class SeenOffer:
    """A genuine session offer and when (``time.monotonic()``) it arrived."""

    at: float
    epoch: str
    challenge: str
    active_session: str
    authenticated: bool


class Operator:
    """The supervisor's signed controls; the nodes' statuses and offers (see the module).

    Args:
        node: the rclpy node to work on.
        key: the test's key (``None``: authentication is off, controls go unsigned).
    """

    def __init__(self, node: Node, key: Key | None) -> None:
        self.node = node
        self.controls = ControlSender(node, key, SUPERVISOR)
        self._offer_gate = StatusGate(key)
        self.offers: dict[str, SeenOffer] = {}
        self.pending: list[Sent] = []

    @property
    def statuses(self) -> dict[str, Any]:
        """The last genuine status per status topic."""
        return self.controls.statuses

    def send(self, command: str, *, bridge_site: str | None = None, reason: str = ''
             ) -> Sent | None:
        """Send one control to the integrator (or to the bridge of ``bridge_site``).

        ``None`` when its receiver is not known or not listening. Its acknowledgement is awaited by
        :meth:`check` (sent again if it does not come).
        """
        topic, status_topic = control_topics(bridge_site)
        sent = self.controls.send(command, topic, status_topic, reason)
        if sent is not None:
            self.pending.append(sent)
        return sent

    def check(self, resend_after: float = 1.0, attempts: int = 5
              ) -> list[tuple[Sent, Acknowledgement | None]]:
        """The controls whose fate is known now.

        Acknowledged, or given up after ``attempts`` sends; the others are sent again after
        ``resend_after`` s of silence.
        """
        done: list[tuple[Sent, Acknowledgement | None]] = []
        waiting: list[Sent] = []
        now = time.monotonic()
        for sent in self.pending:
            ack = self.controls.acknowledgement(sent)
            if ack is not None:
                done.append((sent, ack))
            elif now - sent.sent_at < resend_after:
                waiting.append(sent)
            elif sent.attempts >= attempts:
                done.append((sent, None))
            else:
                waiting.append(self.controls.resend(sent))
        self.pending = waiting
        return done

    def watch_status(self, topic: str) -> None:
        """Keep the last genuine status published on ``topic`` (latched)."""
        self.controls.watch(topic)

    def watch_offer(self, namespace: str) -> None:
        """Keep the last genuine session offer of the receiver in ``namespace``."""
        topic = f'{namespace}/session/offer'

        def keep(message: Any) -> None:
            offer, _ = read_offer(self._offer_gate, topic, message)
            if offer is None:
                return
            self.offers[namespace] = SeenOffer(
                at=time.monotonic(), epoch=offer.epoch, challenge=offer.challenge,
                active_session=offer.active_session, authenticated=offer.authenticated)

        self.node.create_subscription(SessionOffer, topic, keep, LATCHED_QOS)

    def status_state(self, topic: str) -> int | None:
        """The state of the last status on ``topic`` (``None``: none seen)."""
        status = self.statuses.get(topic)
        return int(status.state) if status is not None else None

    def status_message(self, topic: str) -> str:
        """The message of the last status on ``topic``."""
        status = self.statuses.get(topic)
        return str(status.message) if status is not None else ''

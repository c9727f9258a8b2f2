"""Signed sessions over ROS: the receiver's offer and the sender's start (pd_msgs wiring).

A receiver of step commands (a bridge, a simulator) publishes a latched
:class:`pd_msgs.msg.SessionOffer` on ``session/offer`` (its challenge, the session it obeys,
its epoch and state, what configuration is in force), signed by its
:class:`~.statements.Announcer` and published again at least every :data:`OFFER_REFRESH_S`
(a heartbeat), and takes :class:`pd_msgs.msg.SessionStart` on ``session/start``. A sender (the
integrator; a bridge driving a simulator) believes only signed offers (an unsigned or forged
one, or a recording of an earlier one, is refused and counted), opens a session with
:class:`SessionSender` before its first command and checks every reply. The logic lives in
:mod:`pd_common.auth`; this module only moves the messages.
"""

from __future__ import annotations

import secrets
import time
from collections.abc import Callable, Sequence
from typing import Any

from rclpy.node import Node
from rclpy.qos import QoSProfile

from pd_msgs.msg import SessionOffer
from pd_msgs.msg import SessionStart as SessionStartMessage

from ..auth.gates import CommandGate, ReplyGate, StatusGate
from ..auth.keys import Key
from ..auth.payloads import command_payload, feedback_payload, session_start_payload
from ..auth.signing import WIRE_COMMAND, WIRE_FEEDBACK, Refusal, Signer, sign_wire_reply
from ..protocol.bounds import MAX_NAME, MalformedMessageError, check_text, clip_reason
from ..protocol.cdr import Decoded, encode_command, encode_feedback
from ..protocol.convert import signature_from_message
from ..protocol.messages import Command, Feedback, Offer, SessionStart, StateOrigin, StepKey
from ..protocol.signature import Signature
from ..types import FloatArray
from .messages import fill_signature, now_stamp, offer_message
from .qos import LATCHED_QOS, STEP_QOS
from .statements import Announcer, read_offer

__all__ = ['OFFER_REFRESH_S', 'RefusalLog', 'SessionReceiver', 'SessionSender', 'new_epoch']

#: Seconds between two publications of a receiver's offer (at once when its state moved).
OFFER_REFRESH_S = 1.0
#: Seconds after which a session start whose challenge is still offered is sent again.
START_RESEND_S = 1.0

_UNSIGNED = Signature()


def new_epoch() -> str:
    """A new random epoch (a process start of a specimen side)."""
    return secrets.token_hex(8)


class RefusalLog:
    """One log line per kind of refusal (and the key mismatch said plainly), not per message."""

    def __init__(self, warn: Callable[[str], object], key: Key | None, what: str) -> None:
        self._warn = warn
        self._key = key
        self._what = what
        self._said: set[str] = set()

    def __call__(self, reason: Refusal, signature: Signature, source: str = '') -> None:
        """Report a refused message (the first of its kind only)."""
        if reason.value in self._said:
            return
        self._said.add(reason.value)
        where = f' on {source}' if source else ''
        if reason is Refusal.WRONG_KEY and self._key is not None:
            self._warn(f'refusing every {self._what}{where} signed with key '
                       f'{clip_reason(signature.key_id, 40)}: this node has key '
                       f'{self._key.key_id} (wrong key file?)')
        else:
            self._warn(f'refused {self._what}{where}: {reason.value} (counted; further ones '
                       'are counted silently)')


class SessionReceiver:
    """The receiver's side: its latched offer, session starts, and command admission.

    Args:
        node: the node (topics relative to its namespace).
        key: the key (``None``: authentication off).
        n_dof: number of DOFs (for the state in the offer).
        epoch: the specimen state's epoch (:func:`new_epoch`).
        origin: where the state comes from.
        on_refused: called for each refused session start.
        accepting: whether sessions are offered from the start (a lifecycle node offers none
            until it is active: its very first offer then carries no challenge, so no sender
            can open a session that is closed a moment later).
        announcer: the node's signer of statements (default: one of its own).

    Attributes:
        configuration: JSON of what is in force, published with the offer (a bridge's driver
            and limits).
    """

    def __init__(self, node: Node, key: Key | None, n_dof: int, epoch: str,
                 origin: StateOrigin = StateOrigin.FRESH,
                 on_refused: Callable[[Refusal, Signature], None] | None = None,
                 accepting: bool = True, announcer: Announcer | None = None) -> None:
        self._node = node
        self.key = key
        self.announcer = announcer if announcer is not None else Announcer(node, key)
        self.configuration = ''
        self._published_at = 0.0
        self.gate = CommandGate(key)
        self.epoch = epoch
        self.origin = origin
        self.restored: tuple[str, StepKey] | None = None
        self.position: list[float] = [0.0] * n_dof
        self.force: list[float] = [0.0] * n_dof
        self._on_refused = on_refused
        self._published: tuple[str, int, tuple[float, ...], tuple[float, ...]] = ('', 0, (), ())
        self.accepting = accepting
        self._offer_pub = node.create_publisher(SessionOffer, 'session/offer', LATCHED_QOS)
        node.create_subscription(SessionStartMessage, 'session/start', self._on_start,
                                 QoSProfile(depth=10, reliability=STEP_QOS.reliability))
        self.publish_offer()

    @property
    def session(self) -> str | None:
        """The session whose commands are obeyed."""
        return self.gate.session

    def publish_offer(self) -> None:
        """Publish the current offer and state (latched, signed)."""
        restored = ((self.restored[0], int(self.restored[1][0]), int(self.restored[1][1]))
                    if self.restored is not None else ('', 0, 0))
        offer = Offer(stamp_ns=time.time_ns(), node=self.announcer.identity,
                      challenge=self.gate.challenge if self.accepting else '',
                      active_session=self.gate.session or '', authenticated=self.gate.enabled,
                      epoch=self.epoch, state_origin=int(self.origin), restored=restored,
                      position=tuple(float(x) for x in self.position),
                      force=tuple(float(f) for f in self.force),
                      configuration=self.configuration)
        self._published = (self.epoch, int(self.origin), offer.position, offer.force)
        self._published_at = time.monotonic()
        self._offer_pub.publish(offer_message(offer, self.announcer.signer))

    def refresh(self) -> None:
        """Publish the offer again if the state changed or the last one is old.

        Publish the offer again if the state (epoch, origin, position, force) changed since
        it was last published, or ``OFFER_REFRESH_S`` after the last one (called on a timer: a
        late joiner, such as a restarted bridge, reads where the specimen is now, and whose
        state it is; a sender sees that the receiver still answers).
        """
        if (self._published != (self.epoch, int(self.origin), tuple(self.position),
                                tuple(self.force))
                or time.monotonic() - self._published_at >= OFFER_REFRESH_S * 0.9):
            self.publish_offer()

    def set_state(self, position: Sequence[float] | FloatArray,
                  force: Sequence[float] | FloatArray) -> None:
        """The specimen side's measured state (published with the next offer)."""
        self.position = [float(x) for x in position]
        self.force = [float(f) for f in force]

    def close(self) -> None:
        """End the session (a new signed start is needed) and offer a new challenge."""
        self.gate.close()
        self.publish_offer()

    def set_accepting(self, accepting: bool) -> None:
        """Offer sessions, or not (an inactive bridge): either way the current one ends."""
        self.accepting = accepting
        self.close()

    def admit(self, command: Decoded[Command]) -> Refusal | None:
        """``None`` if the command (as its bytes arrived, decoded) may be obeyed."""
        return self.gate.admit(command_payload(command.covered), command.signature)

    def encode_reply(self, feedback: Feedback, stamp_ns: int, request: Signature) -> bytes:
        """The bytes of ``feedback`` answering the command signed ``request``, signed as sent.

        Unsigned without a key or for an unsigned request.
        """
        if self.key is None or not request.signed:
            return encode_feedback(feedback, stamp_ns)
        data, _ = sign_wire_reply(
            self.key, WIRE_FEEDBACK,
            lambda signature: encode_feedback(feedback, stamp_ns, signature), request)
        return data

    def _on_start(self, message: Any) -> None:
        try:
            start = SessionStart(test_id=check_text('test_id', message.test_id, MAX_NAME),
                                 challenge=check_text('challenge', message.challenge, MAX_NAME))
            signature = signature_from_message(message.signature)
        except MalformedMessageError:
            self.gate.refused[Refusal.MALFORMED.value] += 1
            if self._on_refused is not None:
                self._on_refused(Refusal.MALFORMED, Signature())
            return
        if not self.accepting:
            if self._on_refused is not None:
                self._on_refused(Refusal.NO_SESSION, signature)
            return
        reason = self.gate.start(session_start_payload(start), message.challenge, signature)
        if reason is not None and self._on_refused is not None:
            self._on_refused(reason, signature)
        self.publish_offer()


class SessionSender:
    """The sender's side towards one receiver: open a session, sign commands, check replies.

    Args:
        node: the node.
        prefix: topic prefix of the receiver relative to the node (``''``, ``'lab1/'``,
            ``'specimen/'``): its offer is ``<prefix>session/offer``.
        signer: the sender's signer (one session per sender and run), or ``None`` (no key).
        key: the key (``None``: authentication off).
        on_refused: called with each refused offer's reason, its signature (empty for a
            malformed one) and the offer topic.
    """

    def __init__(self, node: Node, prefix: str, signer: Signer | None,
                 key: Key | None,
                 on_refused: Callable[[Refusal, Signature, str], None] | None = None) -> None:
        self._signer = signer
        self._on_refused_offer = on_refused
        self.key = key
        self.offer: Offer | None = None
        #: Offers refused (unsigned, forged, replayed, malformed), counted by reason.
        self.offer_gate = StatusGate(key)
        self._offer_topic = node.resolve_topic_name(f'{prefix}session/offer')
        self._started_with = ''
        self._started_at = 0.0
        self._offer_doubted = False
        self.reply_gate = ReplyGate(key, signer.session if signer is not None else '')
        self._start_pub = node.create_publisher(
            SessionStartMessage, f'{prefix}session/start',
            QoSProfile(depth=10, reliability=STEP_QOS.reliability))
        node.create_subscription(SessionOffer, f'{prefix}session/offer', self._on_offer,
                                 LATCHED_QOS)

    @property
    def opened(self) -> bool:
        """Whether the receiver obeys this sender's session (or neither side has a key)."""
        if self.offer is None or self._offer_doubted:
            return False
        if self._signer is None:
            return not self.offer.authenticated
        return bool(self.offer.authenticated and self.offer.active_session == self._signer.session)

    @property
    def mismatch(self) -> str:
        """Why the two sides cannot work together ('' if they can)."""
        if self.offer is None:
            return ''
        if self._signer is not None and not self.offer.authenticated:
            return f'{self.offer.node} runs without authentication (no key)'
        if self._signer is None and self.offer.authenticated:
            return f'{self.offer.node} requires authentication (give this node the key file)'
        return ''

    def open(self, test_id: str) -> None:
        """Send a signed session start for the receiver's current challenge.

        Once each, again if it is still offered ``START_RESEND_S`` later: the first was lost.
        """
        offer = self.offer
        if (offer is None or not offer.challenge or self.opened or self._signer is None
                or self.mismatch):
            return
        if self._start_pub.get_subscription_count() == 0:
            return  # the receiver does not hear starts yet (discovery): this one would be lost
        now = time.monotonic()
        if offer.challenge == self._started_with and now - self._started_at < START_RESEND_S:
            return
        # A start whose challenge is still offered after START_RESEND_S was lost: sent again
        # (signed anew; the receiver takes one start per challenge, so never two sessions).
        self._started_at = now
        start = SessionStart(test_id=test_id, challenge=offer.challenge)
        message = SessionStartMessage()
        message.header.stamp = now_stamp()
        message.test_id = test_id
        message.challenge = offer.challenge
        fill_signature(message.signature, self._signer.sign(session_start_payload(start)))
        self._started_with = offer.challenge
        self._start_pub.publish(message)

    def receiver_ready(self) -> bool:
        """Whether a receiver has offered a session (its offer arrived)."""
        return self.offer is not None

    def encode(self, command: Command, stamp_ns: int) -> tuple[bytes, Signature]:
        """The bytes of the next command, signed as sent, and their signature.

        Unsigned without a key.
        """
        if self._signer is None:
            return encode_command(command, stamp_ns), _UNSIGNED
        return self._signer.sign_wire(
            WIRE_COMMAND, lambda signature: encode_command(command, stamp_ns, signature))

    def admit(self, feedback: Decoded[Feedback]) -> Refusal | None:
        """``None`` if the reply is genuine, for this session, and new.

        ``feedback``: the reply as its bytes arrived, decoded.
        """
        return self.reply_gate.admit(feedback_payload(feedback.covered), feedback.signature)

    def reopen(self) -> None:
        """A process of the test restarted.

        The last offer may be a dead receiver's (its session gone with it), so the session counts
        as closed until the receiver offers again, and is then opened anew (a live receiver whose
        session was intact takes the new start as well: the same session, started again).
        """
        self._offer_doubted = True
        self._started_with = ''

    def _on_offer(self, message: Any) -> None:
        offer, reason = read_offer(self.offer_gate, self._offer_topic, message)
        if offer is None:  # not the receiver's word: believed in nothing
            if reason is not None and self._on_refused_offer is not None:
                # (a well-formed offer's signature says which key signed it: the log names it)
                signature = (Signature() if reason is Refusal.MALFORMED
                             else signature_from_message(message.signature))
                self._on_refused_offer(reason, signature, self._offer_topic)
            return
        self.offer = offer
        self._offer_doubted = False

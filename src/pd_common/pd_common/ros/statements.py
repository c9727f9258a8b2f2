"""What nodes say of themselves, signed: statuses, session offers, trajectories (pd_msgs wiring).

Every node of a test has one :class:`Announcer`: a signer of its own whose session nonce is the
node's *instance session* (random per process start). It signs the node's statuses (and a
receiver's session offers), and an operator's control names that session, so a control meant
for another node, or for a process that has since restarted, is refused.

A reader (the integrator of its bridges' statuses and offers, the launcher, the console,
``./pd control``) takes a status or an offer only through a :class:`~pd_common.auth.StatusGate`:
:func:`read_status` and :func:`read_offer` convert the message, check its bounds and its
signature, and return the record, or ``None`` with the reason counted on the gate; the recorder
of a run takes a bridge's actuator trajectory (signed by :func:`sign_trajectory`) only through
:func:`admit_trajectory`.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Collection
from typing import Any, TypeVar

from builtin_interfaces.msg import Time
from rclpy.node import Node

from pd_msgs.msg import TestStatus

from ..auth.gates import StatusGate
from ..auth.keys import Key
from ..auth.payloads import TRAJECTORY_ARRAYS, offer_payload, status_payload, trajectory_payload
from ..auth.signing import Refusal, Signer, new_session
from ..protocol.bounds import MAX_NAME, MalformedMessageError, check_text
from ..protocol.convert import (
    offer_from_message,
    signature_from_message,
    signed_from_message,
    stamp_ns_of,
    status_from_message,
)
from ..protocol.messages import Offer, Status
from .messages import fill_signature, status_message

__all__ = ['HEARTBEAT_S', 'STATUS_TOPICS', 'TRAJECTORY_TOPIC', 'Announcer', 'admit_trajectory',
           'at_home', 'read_offer', 'read_status', 'remember_trajectory', 'sign_trajectory',
           'trajectory_source']

Item = TypeVar('Item')

#: Seconds between two publications of an unchanged status or offer (a heartbeat: a node
#: whose statements stop coming has stopped answering).
HEARTBEAT_S = 1.0


class Announcer:
    """A node's signed statements (see the module).

    Args:
        node: the node (its fully qualified name is :attr:`identity`).
        key: the key (``None``: authentication off, statements go unsigned).

    Attributes:
        identity: the node's fully qualified name (what a control's ``target`` names).
        session: the node's instance session (what a control's ``session`` names).
        signer: the signer of its statements (``None`` without a key).
    """

    def __init__(self, node: Node, key: Key | None) -> None:
        self.identity = node.get_fully_qualified_name()
        self.signer = Signer(key) if key is not None else None
        self.session = self.signer.session if self.signer is not None else new_session()

    def status(self, status: Status, stamp: Time | None = None) -> TestStatus:
        """The signed message of ``status`` (this node's name and session filled in)."""
        return status_message(dataclasses.replace(status, node=self.identity,
                                                  session=self.session), stamp, self.signer)


def read_status(gate: StatusGate, source: str, message: Any
                ) -> tuple[Status | None, Refusal | None]:
    """The status in ``message`` published on ``source``, if it is genuine, new and at home.

    At home: with a key, the node the status names (signed) publishes ``source`` itself
    (:func:`at_home`), so a genuine status of one node copied onto another's status topic —
    one bridge's "holding" onto another's, confirming a stop it never heard — is refused
    (``misdirected``).
    """
    def home(status: Status) -> Refusal | None:
        return (None if not gate.enabled or at_home(source, status.node)
                else Refusal.MISDIRECTED)

    return _read(gate, source, message, status_from_message,
                 lambda status: status_payload(status, stamp_ns_of(message)),
                 stamp_ns_of(message), home)


#: The status topics, relative to their node's namespace.
STATUS_TOPICS = ('test_status', 'bridge/status')


def own_topic(node: str, name: str) -> str:
    """The topic ``name`` (relative) of the node named ``node`` (fully qualified)."""
    return f'{node.rpartition("/")[0]}/{name}'


def at_home(source: str, node: str) -> bool:
    """Whether ``source`` is a status topic of the node named ``node`` (fully qualified)."""
    return any(source == own_topic(node, name) for name in STATUS_TOPICS)


#: A bridge's actuator trajectories, relative to its node's namespace.
TRAJECTORY_TOPIC = 'bridge/trajectory'


def _trajectory_payload(message: Any) -> bytes:
    return trajectory_payload(message.node, message.test_id, message.step, message.iteration,
                              message.rate, message.n_dof, stamp_ns_of(message),
                              [getattr(message, name) for name in TRAJECTORY_ARRAYS])


def sign_trajectory(message: Any, signer: Signer | None, node: str) -> None:
    """Name ``node`` in an ``ActuatorTrajectory`` message and sign it (unsigned without a key).

    Its header stamp and every other field must be filled in first.
    """
    message.node = node
    if signer is not None:
        fill_signature(message.signature, signer.sign(_trajectory_payload(message)))


def trajectory_source(node: str) -> str:
    """The trajectory topic of the bridge node named ``node`` (fully qualified)."""
    return own_topic(node, TRAJECTORY_TOPIC)


def admit_trajectory(gate: StatusGate, source: str, message: Any, test_ids: Collection[str],
                     not_before_ns: int) -> Refusal | None:
    """``None`` if the trajectory ``message`` published on ``source`` may be recorded; else why.

    ``message``: decoded, its arrays checked (:func:`pd_core.run.record.bag.read_trajectory`);
    a refusal is counted on ``gate``. With a key: its signature is good; the node it names
    publishes ``source`` itself (one bridge's genuine trajectory copied onto another's topic is
    ``misdirected``); it is of the test (one of ``test_ids``: the test's id, and its probe's)
    (``foreign_test``) and stamped no earlier than ``not_before_ns`` (the recorder's start less
    the controls' 30 s for clocks: ``stale``); and it is new on ``source`` (a recording of an
    earlier one is ``replayed``). Without a key: every one.
    """
    if not gate.enabled:
        return None
    try:
        check_text('node', message.node, MAX_NAME)
        check_text('test_id', message.test_id, MAX_NAME)
        signature = signature_from_message(message.signature)
        stamp_ns = stamp_ns_of(message)
        payload = _trajectory_payload(message)
    except (MalformedMessageError, AttributeError, TypeError, ValueError):
        gate.refused[Refusal.MALFORMED.value] += 1
        return Refusal.MALFORMED
    def where() -> Refusal | None:  # (asked after the signature: what is not the bridge's
        # is counted as what it is, not as stale)
        if source != trajectory_source(message.node):
            return Refusal.MISDIRECTED
        if message.test_id not in test_ids:
            return Refusal.FOREIGN_TEST
        return Refusal.STALE if stamp_ns < not_before_ns else None

    return gate.admit(source, payload, signature, stamp_ns, where)


def remember_trajectory(gate: StatusGate, message: Any) -> None:
    """A trajectory a run's record holds (decoded): a resumed recorder never takes it again."""
    try:
        signature = signature_from_message(message.signature)
        gate.remember(trajectory_source(message.node), signature, stamp_ns_of(message))
    except (MalformedMessageError, AttributeError, TypeError, ValueError):
        return  # (recorded before trajectories were signed: nothing to remember)


def read_offer(gate: StatusGate, source: str, message: Any) -> tuple[Offer | None, Refusal | None]:
    """The session offer in ``message`` published on ``source``, if it is genuine and new."""
    return _read(gate, source, message, offer_from_message, offer_payload,
                 stamp_ns_of(message))


def _read(gate: StatusGate, source: str, message: Any, convert: Callable[[Any], Item],
          payload: Callable[[Item], bytes], stamp_ns: int,
          where: Callable[[Item], Refusal | None] | None = None
          ) -> tuple[Item | None, Refusal | None]:
    """A statement if it is well-formed, where it belongs, genuine and new; else ``None`` and why.

    (Counted on ``gate``.) ``where``: why the well-formed statement does not belong on
    ``source`` (checked before the gate remembers anything of it).
    """
    signed = signed_from_message(convert, message)
    if signed is None:
        gate.refused[Refusal.MALFORMED.value] += 1
        return None, Refusal.MALFORMED
    item, signature = signed
    reason = where(item) if where is not None else None
    if reason is not None:
        gate.refused[reason.value] += 1
        return None, reason
    reason = gate.admit(source, payload(item), signature, stamp_ns)
    return (None, reason) if reason is not None else (item, None)

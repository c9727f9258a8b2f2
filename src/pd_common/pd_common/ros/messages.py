"""``pd_msgs`` messages from the step protocol's data, and message stamps."""

from __future__ import annotations

import time

from builtin_interfaces.msg import Time

from pd_msgs.msg import Control as ControlMessage
from pd_msgs.msg import SessionOffer, StepCommand, StepFeedback, TestStatus
from pd_msgs.msg import Signature as SignatureMessage

from ..auth.payloads import control_payload, offer_payload, status_payload
from ..auth.signing import Signer
from ..protocol.messages import Command, Control, Feedback, Offer, Status
from ..protocol.signature import Signature

__all__ = ['command_message', 'control_message', 'feedback_message', 'fill_signature',
           'now_stamp', 'offer_message', 'signed_control', 'stamp_from_ns', 'status_message']

_UNSIGNED = Signature()


def stamp_from_ns(t_ns: int) -> Time:
    """``builtin_interfaces/Time`` from nanoseconds since the epoch."""
    return Time(sec=t_ns // 1_000_000_000, nanosec=t_ns % 1_000_000_000)


def now_stamp() -> Time:
    """The wall-clock time as a message stamp (cheaper than a node clock)."""
    return stamp_from_ns(time.time_ns())


def fill_signature(message: SignatureMessage, signature: Signature) -> None:
    """Write ``signature`` into a ``pd_msgs/Signature`` field."""
    message.key_id = signature.key_id
    message.session = signature.session
    message.sequence = signature.sequence
    message.mac = signature.mac


def command_message(command: Command, stamp: Time | None = None,
                    message: StepCommand | None = None,
                    signature: Signature = _UNSIGNED) -> StepCommand:
    """``pd_msgs/StepCommand`` of ``command`` (fills ``message`` if given; stamp: now)."""
    message = StepCommand() if message is None else message
    message.header.stamp = now_stamp() if stamp is None else stamp
    message.test_id = command.test_id
    message.step = command.step
    message.iteration = command.iteration
    message.test_time = float(command.test_time)
    message.dof_names = list(command.dof_names)
    message.target_displacement = list(command.target_displacement)
    message.control_mode = [int(mode) for mode in command.control_mode]
    message.target_force = list(command.target_force)
    fill_signature(message.signature, signature)
    return message


def feedback_message(feedback: Feedback, stamp: Time | None = None,
                     message: StepFeedback | None = None,
                     signature: Signature = _UNSIGNED) -> StepFeedback:
    """``pd_msgs/StepFeedback`` of ``feedback`` (fills ``message`` if given; stamp: now)."""
    message = StepFeedback() if message is None else message
    message.header.stamp = now_stamp() if stamp is None else stamp
    message.test_id = feedback.test_id
    message.step = feedback.step
    message.iteration = feedback.iteration
    message.measured_displacement = list(feedback.measured_displacement)
    message.restoring_force = list(feedback.restoring_force)
    message.status = int(feedback.status)
    message.message = feedback.message
    message.epoch = feedback.epoch
    message.state_origin = int(feedback.state_origin)
    fill_signature(message.signature, signature)
    return message


def control_message(control: Control, signature: Signature = _UNSIGNED) -> ControlMessage:
    """``pd_msgs/Control`` of ``control``."""
    message = ControlMessage()
    message.header.stamp = now_stamp()
    message.command = control.command
    message.target = control.target
    message.test_id = control.test_id
    message.session = control.session
    message.sender = control.sender
    message.reason = control.reason
    message.stamp = float(control.stamp)
    fill_signature(message.signature, signature)
    return message


def signed_control(signer: Signer | None, command: str, *, target: str = '', test_id: str = '',
                   session: str = '', sender: str = '', reason: str = '') -> ControlMessage:
    """A control message stamped now.

    Bound to its receiver (``target``, its ``test_id`` and instance ``session``, from the
    receiver's status), signed (unsigned without a signer): what ``./pd control``, ``run_test`` and
    ``./pd console`` send.
    """
    control = Control(command=command, target=target, reason=reason, stamp=time.time(),
                      test_id=test_id, session=session, sender=sender)
    if signer is None:
        return control_message(control)
    return control_message(control, signer.sign(control_payload(control)))


def status_message(status: Status, stamp: Time | None = None, signer: Signer | None = None
                   ) -> TestStatus:
    """``pd_msgs/TestStatus`` of ``status`` (stamp: now), signed by ``signer`` if given."""
    message = TestStatus()
    message.header.stamp = now_stamp() if stamp is None else stamp
    message.test_id = status.test_id
    message.state = int(status.state)
    message.step = status.step
    message.total_steps = status.total_steps
    message.omega_dt = float(status.omega_dt)
    message.retries = status.retries
    message.ignored_messages = status.ignored_messages
    message.message = status.message
    message.refused_messages = status.refused_messages
    message.refused_by_reason = status.refused_by_reason
    message.node = status.node
    message.session = status.session
    message.emergency_stop = bool(status.emergency_stop)
    message.operator_hold = bool(status.operator_hold)
    message.acknowledged = status.acknowledged
    message.definition_digest = status.definition_digest
    if signer is not None:
        stamp_ns = message.header.stamp.sec * 1_000_000_000 + message.header.stamp.nanosec
        fill_signature(message.signature, signer.sign(status_payload(status, stamp_ns)))
    return message


def offer_message(offer: Offer, signer: Signer | None = None) -> SessionOffer:
    """``pd_msgs/SessionOffer`` of ``offer`` (its stamp), signed by ``signer`` if given."""
    message = SessionOffer()
    message.header.stamp = stamp_from_ns(offer.stamp_ns)
    message.node = offer.node
    message.challenge = offer.challenge
    message.active_session = offer.active_session
    message.authenticated = bool(offer.authenticated)
    message.epoch = offer.epoch
    message.state_origin = int(offer.state_origin)
    message.restored_test_id = offer.restored[0]
    message.restored_step, message.restored_iteration = offer.restored[1], offer.restored[2]
    message.position = [float(x) for x in offer.position]
    message.force = [float(f) for f in offer.force]
    message.configuration = offer.configuration
    if signer is not None:
        fill_signature(message.signature, signer.sign(offer_payload(offer)))
    return message

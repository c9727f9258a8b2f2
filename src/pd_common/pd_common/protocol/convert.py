"""Step-protocol data from message objects: ``pd_msgs`` messages of rclpy or of rosbags.

Both kinds have the same field names and arrays with ``tolist()`` (``array.array`` in rclpy,
numpy arrays in rosbags), so one duck-typed conversion serves the nodes and the bag reader.
Values are taken unchanged (Python floats), so a history built from either is the same.

Every string and array is checked against its bound (:mod:`.bounds`) first: a message beyond
one raises :class:`~.bounds.MalformedMessageError` (a node refuses it as ``malformed``, before it
verifies, logs or records anything of it).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, TypeVar

from .bounds import (
    MAX_NAME,
    MAX_REASON,
    MAX_TEXT,
    MalformedMessageError,
    check_array,
    check_names,
    check_text,
)
from .messages import (
    Command,
    Control,
    Feedback,
    FeedbackStatus,
    Offer,
    StateOrigin,
    Status,
    TestState,
)
from .signature import Signature

__all__ = ['command_from_message', 'control_from_message', 'feedback_from_message',
           'offer_from_message', 'signature_from_message', 'signed_from_message',
           'stamp_ns_of', 'status_from_message']

Item = TypeVar('Item')


def command_from_message(message: Any) -> Command:
    """A :class:`Command` from a ``StepCommand`` message."""
    check_text('test_id', message.test_id, MAX_NAME)
    check_names('dof_names', message.dof_names)
    check_array('target_displacement', message.target_displacement)
    check_array('control_mode', message.control_mode)
    check_array('target_force', message.target_force)
    return Command(test_id=message.test_id, step=int(message.step),
                   test_time=float(message.test_time), dof_names=tuple(message.dof_names),
                   target_displacement=tuple(message.target_displacement.tolist()),
                   iteration=int(message.iteration),
                   control_mode=tuple(int(mode) for mode in message.control_mode),
                   target_force=tuple(message.target_force.tolist()))


def feedback_from_message(message: Any) -> Feedback:
    """A :class:`Feedback` from a ``StepFeedback`` message (an unknown status is a fault)."""
    check_text('test_id', message.test_id, MAX_NAME)
    check_text('message', message.message, MAX_TEXT)
    check_text('epoch', message.epoch, MAX_NAME)
    check_array('measured_displacement', message.measured_displacement)
    check_array('restoring_force', message.restoring_force)
    try:
        status = FeedbackStatus(message.status)
    except ValueError:
        status = FeedbackStatus.FAULT
    origin = StateOrigin.of(message.state_origin)
    return Feedback(test_id=message.test_id, step=int(message.step),
                    measured_displacement=tuple(message.measured_displacement.tolist()),
                    restoring_force=tuple(message.restoring_force.tolist()), status=status,
                    message=message.message, iteration=int(message.iteration),
                    epoch=message.epoch, state_origin=origin)


def status_from_message(message: Any) -> Status:
    """A :class:`Status` from a ``TestStatus`` message (an unknown state reads as idle)."""
    # (a bag recorded before statuses were signed has no node, session, ... : read as '')
    text = {field: getattr(message, field, '') for field, _ in _STATUS_TEXT}
    for field, limit in _STATUS_TEXT:
        check_text(field, text[field], limit)
    try:
        state = TestState(message.state)
    except ValueError:
        state = TestState.IDLE
    return Status(test_id=text['test_id'], state=state, step=int(message.step),
                  total_steps=int(message.total_steps), omega_dt=float(message.omega_dt),
                  retries=int(message.retries), ignored_messages=int(message.ignored_messages),
                  message=text['message'], refused_messages=int(message.refused_messages),
                  refused_by_reason=text['refused_by_reason'], node=text['node'],
                  session=text['session'],
                  emergency_stop=bool(getattr(message, 'emergency_stop', False)),
                  operator_hold=bool(getattr(message, 'operator_hold', False)),
                  acknowledged=text['acknowledged'],
                  definition_digest=text['definition_digest'])


_STATUS_TEXT = (('test_id', MAX_NAME), ('message', MAX_TEXT), ('refused_by_reason', MAX_TEXT),
                ('node', MAX_NAME), ('session', MAX_NAME), ('acknowledged', MAX_TEXT),
                ('definition_digest', MAX_NAME))


def stamp_ns_of(message: Any) -> int:
    """A message's header stamp, ns since the epoch."""
    stamp = message.header.stamp
    return int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec)


def offer_from_message(message: Any) -> Offer:
    """An :class:`Offer` from a ``SessionOffer`` message."""
    for field in ('node', 'challenge', 'active_session', 'epoch', 'restored_test_id'):
        check_text(field, getattr(message, field), MAX_NAME)
    check_text('configuration', message.configuration, MAX_TEXT)
    check_array('position', message.position)
    check_array('force', message.force)
    return Offer(stamp_ns=stamp_ns_of(message), node=message.node, challenge=message.challenge,
                 active_session=message.active_session,
                 authenticated=bool(message.authenticated), epoch=message.epoch,
                 state_origin=int(message.state_origin),
                 restored=(message.restored_test_id, int(message.restored_step),
                           int(message.restored_iteration)),
                 position=tuple(float(x) for x in message.position),
                 force=tuple(float(f) for f in message.force),
                 configuration=message.configuration)


def signature_from_message(message: Any) -> Signature:
    """A :class:`~pd_common.auth.Signature` from a ``Signature`` message (its ``mac`` array)."""
    check_text('signature.key_id', message.key_id, MAX_NAME)
    check_text('signature.session', message.session, MAX_NAME)
    check_array('signature.mac', message.mac, 64)
    return Signature(key_id=message.key_id, session=message.session,
                     sequence=int(message.sequence), mac=bytes(message.mac))


def control_from_message(message: Any) -> Control:
    """A :class:`Control` from a ``Control`` message."""
    for field in ('command', 'target', 'test_id', 'session', 'sender'):
        check_text(field, getattr(message, field), MAX_NAME)
    check_text('reason', message.reason, MAX_REASON)
    return Control(command=message.command, target=message.target, reason=message.reason,
                   stamp=float(message.stamp), test_id=message.test_id,
                   session=message.session, sender=message.sender)


def signed_from_message(convert: Callable[[Any], Item], message: Any
                        ) -> tuple[Item, Signature] | None:
    """A signed message's item (``convert(message)``) and its signature.

    Or ``None`` when a field is beyond its bound (a malformed message: refuse it, count it, nothing
    else).
    """
    try:
        return convert(message), signature_from_message(message.signature)
    except MalformedMessageError:
        return None

"""Step-protocol data from message objects: ``pd_msgs`` messages of rclpy or of rosbags.

Both kinds have the same field names and arrays with ``tolist()`` (``array.array`` in rclpy,
numpy arrays in rosbags), so one duck-typed conversion serves the nodes and the bag reader.
Values are taken unchanged (Python floats), so a history built from either is the same.
"""

from __future__ import annotations

from typing import Any

from .messages import Command, Control, Feedback, FeedbackStatus, StateOrigin, Status, TestState
from .signature import Signature

__all__ = ['command_from_message', 'control_from_message', 'feedback_from_message',
           'signature_from_message', 'status_from_message']


def command_from_message(message: Any) -> Command:
    """A :class:`Command` from a ``StepCommand`` message."""
    return Command(test_id=message.test_id, step=int(message.step),
                   test_time=float(message.test_time), dof_names=tuple(message.dof_names),
                   target_displacement=tuple(message.target_displacement.tolist()),
                   iteration=int(message.iteration),
                   control_mode=tuple(int(mode) for mode in message.control_mode),
                   target_force=tuple(message.target_force.tolist()))


def feedback_from_message(message: Any) -> Feedback:
    """A :class:`Feedback` from a ``StepFeedback`` message (an unknown status is a fault)."""
    try:
        status = FeedbackStatus(message.status)
    except ValueError:
        status = FeedbackStatus.FAULT
    try:
        origin = StateOrigin(message.state_origin)
    except ValueError:
        origin = StateOrigin.FRESH
    return Feedback(test_id=message.test_id, step=int(message.step),
                    measured_displacement=tuple(message.measured_displacement.tolist()),
                    restoring_force=tuple(message.restoring_force.tolist()), status=status,
                    message=message.message, iteration=int(message.iteration),
                    epoch=message.epoch, state_origin=origin)


def status_from_message(message: Any) -> Status:
    """A :class:`Status` from a ``TestStatus`` message (an unknown state reads as idle)."""
    try:
        state = TestState(message.state)
    except ValueError:
        state = TestState.IDLE
    return Status(test_id=message.test_id, state=state, step=int(message.step),
                  total_steps=int(message.total_steps), omega_dt=float(message.omega_dt),
                  retries=int(message.retries), ignored_messages=int(message.ignored_messages),
                  message=message.message, refused_messages=int(message.refused_messages),
                  refused_by_reason=message.refused_by_reason)


def signature_from_message(message: Any) -> Signature:
    """A :class:`~pd_common.auth.Signature` from a ``Signature`` message (its ``mac`` array)."""
    return Signature(key_id=message.key_id, session=message.session,
                     sequence=int(message.sequence), mac=bytes(message.mac))


def control_from_message(message: Any) -> Control:
    """A :class:`Control` from a ``Control`` message."""
    return Control(command=message.command, target=message.target, reason=message.reason,
                   stamp=float(message.stamp))

"""``pd_msgs`` messages from the step protocol's data, and message stamps."""

from __future__ import annotations

import time

from builtin_interfaces.msg import Time

from pd_msgs.msg import Control as ControlMessage
from pd_msgs.msg import Signature as SignatureMessage
from pd_msgs.msg import StepCommand, StepFeedback, TestStatus

from ..auth.payloads import control_payload
from ..auth.signing import Signer
from ..protocol.messages import Command, Control, Feedback, Status
from ..protocol.signature import Signature

__all__ = ['command_message', 'control_message', 'feedback_message', 'fill_signature',
           'now_stamp', 'signed_control', 'stamp_from_ns', 'status_message']

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
    message.reason = control.reason
    message.stamp = float(control.stamp)
    fill_signature(message.signature, signature)
    return message


def signed_control(signer: Signer | None, command: str, site: str = '', reason: str = ''
                   ) -> ControlMessage:
    """A control message stamped now, signed (unsigned without a signer): what
    ``./pd control``, ``run_test`` and ``./pd console`` send."""
    control = Control(command=command, target=site, reason=reason, stamp=time.time())
    if signer is None:
        return control_message(control)
    return control_message(control, signer.sign(control_payload(control)))


def status_message(status: Status, stamp: Time | None = None) -> TestStatus:
    """``pd_msgs/TestStatus`` of ``status`` (stamp: now)."""
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
    return message

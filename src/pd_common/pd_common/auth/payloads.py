"""The fields each signed message kind authenticates, in a fixed order.

A MAC covers every field that matters: for a command the test id, the step and iteration,
the test time, the DOF names and the targets (and, under mixed control, each DOF's control
mode and target force); for feedback the same key fields, the measured
displacements and forces, the status and its message, the answering node's epoch and state
origin; for a control the command, the receiving node, its test and instance session, the
sender, the reason and the stamp; for a session start the test id and the receiver's
challenge; for a status and a session offer every field and the time it was published.
"""

from __future__ import annotations

from typing import Any

from ..protocol.messages import Command, Control, Feedback, Offer, SessionStart, Status
from .signing import canonical

__all__ = ['command_payload', 'control_payload', 'feedback_payload', 'offer_payload',
           'session_start_payload', 'status_payload']


def command_payload(command: Command) -> bytes:
    """The authenticated bytes of a step command."""
    fields: tuple[Any, ...] = (
        command.test_id, command.step, command.iteration, float(command.test_time),
        tuple(command.dof_names), tuple(command.target_displacement))
    if command.control_mode or command.target_force:  # mixed control: the modes and forces too
        fields += (tuple(int(mode) for mode in command.control_mode),
                   tuple(float(force) for force in command.target_force))
    return canonical('StepCommand', fields)


def feedback_payload(feedback: Feedback) -> bytes:
    """The authenticated bytes of a step feedback."""
    return canonical('StepFeedback', (
        feedback.test_id, feedback.step, feedback.iteration,
        tuple(feedback.measured_displacement), tuple(feedback.restoring_force),
        int(feedback.status), feedback.message, feedback.epoch, int(feedback.state_origin)))


def control_payload(control: Control) -> bytes:
    """The authenticated bytes of an operator control."""
    return canonical('Control', (control.command, control.target, control.test_id,
                                 control.session, control.sender, control.reason,
                                 float(control.stamp)))


def session_start_payload(start: SessionStart) -> bytes:
    """The authenticated bytes of a session start."""
    return canonical('SessionStart', (start.test_id, start.challenge))


def status_payload(status: Status, stamp_ns: int) -> bytes:
    """The authenticated bytes of a node's status published at ``stamp_ns``."""
    return canonical('TestStatus', (
        int(stamp_ns), status.test_id, int(status.state), int(status.step),
        int(status.total_steps), float(status.omega_dt), int(status.retries),
        int(status.ignored_messages), status.message, int(status.refused_messages),
        status.refused_by_reason, status.node, status.session, bool(status.emergency_stop),
        bool(status.operator_hold), status.acknowledged))


def offer_payload(offer: Offer) -> bytes:
    """The authenticated bytes of a receiver's session offer."""
    return canonical('SessionOffer', (
        int(offer.stamp_ns), offer.node, offer.challenge, offer.active_session,
        bool(offer.authenticated), offer.epoch, int(offer.state_origin), offer.restored[0],
        int(offer.restored[1]), int(offer.restored[2]), tuple(offer.position),
        tuple(offer.force), offer.configuration))

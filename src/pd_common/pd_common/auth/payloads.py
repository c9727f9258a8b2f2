"""The fields each signed message kind authenticates, in a fixed order.

A MAC covers every field that matters: for a command the test id, the step and iteration,
the test time, the DOF names and the targets (and, under mixed control, each DOF's control
mode and target force); for feedback the same key fields, the measured
displacements and forces, the status and its message, the answering node's epoch and state
origin; for a control the command, its target,
its reason and its stamp; for a session start the test id and the receiver's challenge.
"""

from __future__ import annotations

from typing import Any

from ..protocol.messages import Command, Control, Feedback, SessionStart
from .signing import canonical

__all__ = ['command_payload', 'control_payload', 'feedback_payload', 'session_start_payload']


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
    return canonical('Control', (control.command, control.target, control.reason,
                                 float(control.stamp)))


def session_start_payload(start: SessionStart) -> bytes:
    """The authenticated bytes of a session start."""
    return canonical('SessionStart', (start.test_id, start.challenge))

"""What each signed message kind authenticates.

A step command and a step feedback are signed as the bytes that travel: the MAC covers their
CDR bytes through the signature's sequence, every field included (header stamp, test id, step
and iteration, targets or measurements, status, epoch, ...; :class:`~.signing.WirePayload`).
The other kinds are signed over the fields that matter, in a fixed order: for a control the
command, the receiving node, its test and instance session, the sender, the reason and the
stamp; for a session start the test id and the receiver's challenge; for a status and a
session offer every field and the time it was published; for an actuator trajectory its node,
test, step, iteration, rate, DOF count and publication time, and the SHA-256 of its four
arrays (each as its length and its little-endian float64 values).
"""

from __future__ import annotations

import hashlib
import struct
from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike

from ..protocol.messages import Control, Offer, SessionStart, Status
from .signing import WIRE_COMMAND, WIRE_FEEDBACK, WirePayload, canonical

__all__ = ['command_payload', 'control_payload', 'feedback_payload', 'offer_payload',
           'session_start_payload', 'status_payload', 'trajectory_payload']

#: The arrays of an actuator trajectory, in the order its payload hashes them.
TRAJECTORY_ARRAYS = ('time', 'command', 'measured_displacement', 'measured_force')
_LENGTH = struct.Struct('<Q')


def command_payload(covered: bytes) -> WirePayload:
    """The authenticated bytes of a step command: its covered CDR bytes.

    (:attr:`pd_common.protocol.cdr.Decoded.covered` of the bytes that arrived, or
    :func:`~pd_common.protocol.cdr.covered_part` of the bytes encoded with an empty MAC.)
    """
    return WirePayload(WIRE_COMMAND, covered)


def feedback_payload(covered: bytes) -> WirePayload:
    """The authenticated bytes of a step feedback: its covered CDR bytes."""
    return WirePayload(WIRE_FEEDBACK, covered)


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
        bool(status.operator_hold), status.acknowledged, status.definition_digest))


def offer_payload(offer: Offer) -> bytes:
    """The authenticated bytes of a receiver's session offer."""
    return canonical('SessionOffer', (
        int(offer.stamp_ns), offer.node, offer.challenge, offer.active_session,
        bool(offer.authenticated), offer.epoch, int(offer.state_origin), offer.restored[0],
        int(offer.restored[1]), int(offer.restored[2]), tuple(offer.position),
        tuple(offer.force), offer.configuration))


def trajectory_payload(node: str, test_id: str, step: int, iteration: int, rate: float,
                       n_dof: int, stamp_ns: int, arrays: Sequence[ArrayLike]) -> bytes:
    """The authenticated bytes of an actuator trajectory published at ``stamp_ns``.

    ``arrays``: its :data:`TRAJECTORY_ARRAYS`, in that order (any sequence of numbers: a list,
    an ``array.array`` or a numpy array give the same bytes).
    """
    digest = hashlib.sha256()
    for values in arrays:
        data = np.ascontiguousarray(values, dtype='<f8')
        digest.update(_LENGTH.pack(data.size))
        digest.update(data.tobytes())
    return canonical('ActuatorTrajectory', (
        node, test_id, int(step), int(iteration), float(rate), int(n_dof), int(stamp_ns),
        digest.digest()))

"""The trial/commit state machine of one ``genericClient`` connection, without a socket.

:class:`ElementExchange` takes the element's messages one by one. It answers the queries at
once (stiffness, damping, mass, the trial's own values) and stops on the three messages the
test must act on: a force request (``getForce``: move the specimen to the trial displacement,
measure), a ``commitState`` (the step is committed) and ``DIE`` (the analysis ended).

Out-of-order messages are refused (:class:`~pd_common.errors.ElementProtocolError`): a force
request or a commit before any trial, a commit before any force was measured in the step, a
trial whose time runs backwards, any message while a force is owed.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from ..errors import ElementProtocolError
from . import wire
from .wire import SizeMessage, Trial

FORCE = 'force'
COMMIT = 'commit'
END = 'end'


@dataclass(frozen=True)
class Event:
    """What the test must act on.

    Attributes:
        kind: ``'force'`` (measure at :attr:`trial`), ``'commit'`` or ``'end'``.
        trial: The element's last trial (``None`` for an end before any trial).
    """

    kind: str
    trial: Trial | None


class ElementExchange:
    """One connection's state: the last trial, whether a force is owed, what was measured.

    Args:
        size: The element's size message.
        stiffness: The ``n`` x ``n`` stiffness answered to ``getInitialStiff`` and
            ``getTangentStiff`` (a physical specimen's tangent is not measured: OpenFresco's
            experimental elements answer the initial stiffness too).
    """

    def __init__(self, size: SizeMessage, stiffness: Sequence[Sequence[float]]) -> None:
        n = size.n_dof
        if len(stiffness) != n or any(len(row) != n for row in stiffness):
            msg = f'stiffness: expected {n} x {n} for the element\'s {n} DOFs'
            raise ElementProtocolError(msg)
        self.size = size
        self._stiffness = wire.matrix_values(stiffness)
        self.trial: Trial | None = None
        self.force: tuple[float, ...] = (0.0,) * n
        self.measured: tuple[float, ...] = (0.0,) * n
        self.owing_force = False
        self.measured_in_step = False
        self.committed_time = float('-inf')
        self.messages = 0

    def take(self, payload: bytes) -> tuple[Event | None, bytes | None]:
        """Take one message: ``(event to act on or None, reply to send now or None)``.

        Raises:
            ElementProtocolError: Malformed or out of order (the connection is to be closed).
        """
        action, values = wire.decode_message(payload, self.size)
        self.messages += 1
        name = wire.ACTION_NAMES[action]
        if self.owing_force:
            msg = f'{name}: out of order (a getForce is still being answered)'
            raise ElementProtocolError(msg)
        n = self.size.n_dof
        if action == wire.SET_TRIAL_RESPONSE:
            trial = wire.decode_trial(values, n)
            if trial.time < self.committed_time - 1e-12 * max(1.0, abs(trial.time)):
                msg = (f'setTrialResponse: out of order: time {trial.time:g} s is before the '
                       f'committed {self.committed_time:g} s')
                raise ElementProtocolError(msg)
            self.trial = trial
            return None, None
        if action in (wire.GET_FORCE, wire.GET_DAQ_RESPONSE):
            if self.trial is None:
                msg = f'{name}: out of order (no setTrialResponse yet)'
                raise ElementProtocolError(msg)
            self.owing_force = True
            return Event(FORCE, self.trial), None
        if action == wire.COMMIT_STATE:
            if self.trial is None or not self.measured_in_step:
                msg = 'commitState: out of order (no force measured since the last commit)'
                raise ElementProtocolError(msg)
            self.measured_in_step = False
            self.committed_time = self.trial.time
            return Event(COMMIT, self.trial), None
        if action == wire.DIE:
            return Event(END, self.trial), None
        return None, wire.encode_reply(self._query(action), self.size)

    def _query(self, action: int) -> list[float]:
        """The values answering a query."""
        n = self.size.n_dof
        trial = self.trial
        if action in (wire.GET_INITIAL_STIFF, wire.GET_TANGENT_STIFF):
            return self._stiffness
        if action in (wire.GET_DAMP, wire.GET_MASS):
            return [0.0] * (n * n)  # the model's mass and damping stay in OpenSees
        if action == wire.GET_DISP:
            return list(self.measured)
        if action == wire.GET_VEL:
            return list(trial.velocity) if trial else [0.0] * n
        if action == wire.GET_ACCEL:
            return list(trial.acceleration) if trial else [0.0] * n
        return [trial.time if trial else 0.0]  # getTime

    def answer_force(self, force: Sequence[float], measured: Sequence[float]) -> bytes:
        """The reply to the owed ``getForce``: the measured force.

        Raises:
            ElementProtocolError: No force is owed, or the wrong number of values.
        """
        n = self.size.n_dof
        if not self.owing_force:
            msg = 'answer_force: no getForce is owed'
            raise ElementProtocolError(msg)
        if len(force) != n or len(measured) != n:
            msg = f'answer_force: expected {n} forces and displacements'
            raise ElementProtocolError(msg)
        self.force = tuple(float(f) for f in force)
        self.measured = tuple(float(x) for x in measured)
        self.owing_force = False
        self.measured_in_step = True
        return wire.encode_reply(self.force, self.size)

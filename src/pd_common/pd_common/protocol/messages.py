"""The step protocol's data: plain mirrors of the ``pd_msgs`` interfaces (no ROS types).

One definition for every package: the integrator, the bridge and the simulator exchange these;
the node shells convert them to and from ``pd_msgs`` (:mod:`pd_common.ros.convert`), and the
integrator's bag module serializes them with the same message definitions, so a run without ROS
writes the same bag.
"""

from __future__ import annotations

import hashlib
import math
from collections.abc import Sequence
from dataclasses import dataclass
from enum import IntEnum
from numbers import Integral
from typing import Any, NamedTuple

from ..types import FloatArray

__all__ = ['Command', 'Control', 'ControlMode', 'Feedback', 'FeedbackStatus', 'Offer',
           'SessionStart', 'StateOrigin', 'Status', 'StepKey', 'TestState', 'control_problem',
           'definition_digest', 'dof_label']


class FeedbackStatus(IntEnum):
    """``StepFeedback.status`` codes: the one encoding of a step's outcome."""

    OK = 0
    LIMIT = 1
    FAULT = 2

    @property
    def label(self) -> str:
        """``'ok'``, ``'limit'`` or ``'fault'`` (for messages and summaries)."""
        return self.name.lower()


class ControlMode(IntEnum):
    """What a step command imposes on an actuator (``StepCommand.CONTROL_*``).

    ``DISPLACEMENT``: the actuator goes to ``target_displacement`` (the integrator's trial);
    ``FORCE``: the actuator holds ``target_force`` (e.g. a column's axial load) and its
    displacement is whatever the specimen takes, measured and recorded.
    """

    DISPLACEMENT = 0
    FORCE = 1

    @property
    def label(self) -> str:
        """``'displacement'`` or ``'force'``."""
        return self.name.lower()


class StateOrigin(IntEnum):
    """Where a specimen side's state comes from (``SessionOffer.ORIGIN_*``)."""

    FRESH = 0       # a new state: the process started without a history
    RESTORED = 1    # restored from a run's record (its commanded history replayed)
    HARDWARE = 2    # the hardware's own state (read from the controller)

    @classmethod
    def of(cls, value: int) -> StateOrigin:
        """The origin ``value`` names; an unknown one is ``FRESH`` (no history is claimed)."""
        try:
            return cls(value)
        except ValueError:
            return cls.FRESH


class StepKey(NamedTuple):
    """``(step, iteration)``: what identifies one command and its answer within a test.

    Ordered like a tuple: a later step, or a later iteration of the same step, is greater.
    ``iteration`` is 0 for one-command-per-step schemes.
    """

    step: int
    iteration: int = 0


class TestState(IntEnum):
    """``TestStatus.state`` codes."""

    IDLE = 0
    RUNNING = 1
    PAUSED = 2
    HOLDING = 3
    FINISHED = 4
    ABORTED = 5
    INTERRUPTED = 6  # its process was stopped (signal): the record is intact, resumable


@dataclass(frozen=True)
class Command:
    """A step command: drive the DOFs to ``target_displacement`` [m].

    ``iteration`` is 0 for explicit schemes; an implicit scheme with a fixed number of
    iterations commands ``(step, 0)``, ``(step, 1)``, ... within one step.

    Mixed control: ``control_mode`` gives each DOF's :class:`ControlMode` (empty: every DOF is
    displacement-controlled, as in a plain pseudo-dynamic test) and ``target_force`` [N] the
    force a force-controlled DOF holds (one value per DOF; 0.0 and ignored for
    displacement-controlled ones). For a force-controlled DOF ``target_displacement`` holds
    the displacement last measured there: it is not imposed.
    """

    test_id: str
    step: int
    test_time: float
    dof_names: tuple[str, ...]
    target_displacement: tuple[float, ...]
    iteration: int = 0
    control_mode: tuple[int, ...] = ()
    target_force: tuple[float, ...] = ()

    @property
    def key(self) -> StepKey:
        """``(step, iteration)``: what a feedback must match."""
        return StepKey(self.step, self.iteration)

    @property
    def mixed(self) -> bool:
        """Whether some DOF is force-controlled."""
        return any(mode == ControlMode.FORCE for mode in self.control_mode)

    def force_controlled(self) -> tuple[bool, ...]:
        """Per DOF: whether it is force-controlled (all ``False`` without modes)."""
        if not self.control_mode:
            return (False,) * len(self.target_displacement)
        return tuple(mode == ControlMode.FORCE for mode in self.control_mode)

    def control_error(self) -> str | None:
        """Why the modes and forces are inconsistent with the DOFs (``None``: they are not).

        Modes must be empty or one known :class:`ControlMode` per DOF, and forces one finite
        value per DOF when modes are given (none otherwise): :func:`control_problem`.
        """
        problem = control_problem(self.control_mode, self.target_force,
                                  len(self.target_displacement))
        return None if problem is None else problem[1]


def dof_label(dof: int, dof_names: Sequence[str] | None) -> str:
    """``'DOF 0 (top)'`` (or ``'DOF 0'`` without a name): how the messages name a DOF."""
    if dof_names is not None and 0 <= dof < len(dof_names):
        return f'DOF {dof} ({dof_names[dof]})'
    return f'DOF {dof}'


def control_problem(control_mode: Sequence[Any], target_force: Sequence[float], n_dof: int,
                    dof_names: Sequence[str] | None = None) -> tuple[int, str] | None:
    """The control-mode check of a command, the one home of it: every receiver applies it.

    Modes must be empty (every DOF displacement-controlled; then no forces either) or one
    known :class:`ControlMode` per DOF (an integer, not a ``bool``), with one finite target
    force per DOF.

    Args:
        control_mode: Per DOF 0 (displacement) or 1 (force), or empty.
        target_force: Per DOF the force a force-controlled DOF holds, N, or empty.
        n_dof: Number of DOF.
        dof_names: Optional DOF names used in messages (:func:`dof_label`).

    Returns:
        ``None`` if they are consistent, else ``(dof, one-line reason)``.
    """
    modes, forces = list(control_mode), list(target_force)
    if not modes:
        if forces:
            return 0, f'{len(forces)} target forces without control modes'
        return None
    if len(modes) != n_dof or len(forces) != n_dof:
        return (min(len(modes), len(forces), n_dof),
                f'{len(modes)} control modes and {len(forces)} target forces for {n_dof} DOFs')
    known = {int(mode) for mode in ControlMode}
    for dof, mode in enumerate(modes):
        if isinstance(mode, bool) or not isinstance(mode, Integral) or int(mode) not in known:
            return dof, (f'{dof_label(dof, dof_names)}: unknown control mode {mode!r} '
                         '(0 displacement, 1 force)')
    for dof, force in enumerate(forces):
        if not math.isfinite(force):
            return dof, f'{dof_label(dof, dof_names)}: target force {force} is not finite'
    return None


@dataclass(frozen=True)
class Feedback:
    """The specimen's answer to the command of the same ``test_id`` and ``step``."""

    test_id: str
    step: int
    measured_displacement: tuple[float, ...] | FloatArray  # a read-only array is fine
    restoring_force: tuple[float, ...] | FloatArray
    status: FeedbackStatus = FeedbackStatus.OK
    message: str = ''
    iteration: int = 0
    epoch: str = ''
    state_origin: StateOrigin = StateOrigin.FRESH

    @property
    def key(self) -> StepKey:
        """``(step, iteration)`` of the command answered."""
        return StepKey(self.step, self.iteration)


@dataclass(frozen=True)
class Status:
    """The state of a node taking part in a test (``TestStatus``).

    Attributes:
        node: the publishing node's fully qualified name.
        session: its instance session (random per process start): a control names it, so a
            control meant for another node, or for an earlier process, is refused.
        emergency_stop: an emergency stop is latched (only a signed reset clears it).
        operator_hold: a person paused or held it (only a person's signed resume clears it).
        acknowledged: the last control the node took, ``"<session>:<sequence> <command>:
            <outcome>"``: how its sender knows it arrived and what it did.
        definition_digest: the SHA-256 (hex) of the test definition the integrator publishes
            (:func:`~pd_common.protocol.definition_digest`; '' for a bridge): a reader believes
            a definition on ``test_definition`` only when a genuine status names its digest.
    """

    test_id: str
    state: TestState
    step: int
    total_steps: int
    omega_dt: float
    retries: int = 0
    ignored_messages: int = 0
    message: str = ''
    refused_messages: int = 0
    refused_by_reason: str = ''
    node: str = ''
    session: str = ''
    emergency_stop: bool = False
    operator_hold: bool = False
    acknowledged: str = ''
    definition_digest: str = ''


def definition_digest(text: str) -> str:
    """The SHA-256 (hex) of a test definition's JSON text, as a status names it."""
    return hashlib.sha256(text.encode('utf-8')).hexdigest()


@dataclass(frozen=True)
class Control:
    """An operator's request to a node (``pause``, ``resume``, ``abort``, ``reset``, ...).

    A signed control is bound to its purpose: the receiving node (``target``), that node's
    instance (``session``) and the test it serves (``test_id``), all three as the receiver's
    signed status names them (:mod:`pd_common.protocol.controls`).

    Attributes:
        command: what to do.
        target: the receiving node's fully qualified name ('' = whoever receives it, only
            without authentication).
        reason: why (shown in logs and statuses).
        stamp: when it was issued, s since the epoch (a signed control is obeyed only within
            a time window of the receiver's clock, and only once).
        test_id: the test the receiver serves.
        session: the receiver's instance session.
        sender: who sent it (``operator <user>@<host>``, ``run_test``, ``console``): the audit
            trail names it.
    """

    command: str
    target: str = ''
    reason: str = ''
    stamp: float = 0.0
    test_id: str = ''
    session: str = ''
    sender: str = ''


@dataclass(frozen=True)
class SessionStart:
    """A sender's request to open a signed session with a receiver of step commands.

    Attributes:
        test_id: the test the session is for.
        challenge: the receiver's current challenge (from its session offer).
    """

    test_id: str
    challenge: str


@dataclass(frozen=True)
class Offer:
    """A receiver's session offer and state (``SessionOffer``), as its signature covers it.

    Attributes:
        stamp_ns: when it was published (the header stamp), ns since the epoch.
        node: the receiver's fully qualified name.
        challenge: its current challenge ('' while it offers no session).
        active_session: the session it obeys ('' = none).
        authenticated: whether it runs with a key.
        epoch: its specimen state's epoch.
        state_origin: where that state comes from.
        restored: ``(test id, step, iteration)`` of the last command replayed into a restored
            state (``('', 0, 0)`` otherwise).
        position: the measured displacement now [m].
        force: the measured force now [N].
        configuration: JSON of what is in force (a bridge: its driver and limits).
    """

    stamp_ns: int
    node: str
    challenge: str
    active_session: str
    authenticated: bool
    epoch: str
    state_origin: int
    restored: tuple[str, int, int]
    position: tuple[float, ...]
    force: tuple[float, ...]
    configuration: str = ''

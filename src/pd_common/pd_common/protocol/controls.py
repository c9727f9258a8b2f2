"""The operator controls: their names, who may send which, and how their receipt is told.

A *person* steers a test with ``./pd control`` or the console; ``run_test`` (the supervisor)
acts on its own only to recover from a crash, with controls of its own (``auto_*``), so that
a receiver can tell the two apart and never lets an automatic action undo a person's stop:

* to the integrator (``/pd/test_control``): a person's :data:`TEST_CONTROLS`; the
  supervisor's :data:`SUPERVISOR_TEST_CONTROLS` (``auto_hold`` holds without latching,
  ``auto_resume`` resumes only a test no person holds, ``restarted`` notes a restart);
* to a bridge (``/pd/[<site>/]bridge/control``): a person's :data:`BRIDGE_CONTROLS` (the hold
  resets and the lifecycle transitions, which need the owner's signature); the supervisor's
  :data:`SUPERVISOR_BRIDGE_CONTROLS` (``auto_reset`` leaves only a hold ``auto_hold`` made).

Every receiver acknowledges the last controls it took (:data:`ACKNOWLEDGED`, one per line) in
its signed status (:attr:`~pd_common.protocol.Status.acknowledged`): :class:`Acknowledgements`
writes them, :func:`find_acknowledgement` reads one, so a sender knows that its control
arrived and what it did, even when other controls followed it at once.
"""

from __future__ import annotations

import getpass
import socket

from .signature import Signature

__all__ = ['ACKNOWLEDGED', 'BRIDGE_CONTROLS', 'LIFECYCLE_CONTROLS', 'SUPERVISOR',
           'SUPERVISOR_BRIDGE_CONTROLS', 'SUPERVISOR_TEST_CONTROLS', 'TEST_CONTROLS',
           'Acknowledgement', 'Acknowledgements', 'acknowledgement', 'find_acknowledgement',
           'operator_name', 'parse_acknowledgement']

#: A person's controls of a test (the integrator).
TEST_CONTROLS = ('pause', 'resume', 'hold', 'abort')
#: The supervisor's controls of a test.
SUPERVISOR_TEST_CONTROLS = ('auto_hold', 'auto_resume', 'restarted')
#: The bridge's lifecycle transitions, as signed controls (the ROS services cannot be signed).
LIFECYCLE_CONTROLS = ('configure', 'activate', 'deactivate', 'cleanup')
#: A person's controls of a bridge.
BRIDGE_CONTROLS = ('reset', 'reset_emergency_stop', 'hold', *LIFECYCLE_CONTROLS)
#: The supervisor's controls of a bridge.
SUPERVISOR_BRIDGE_CONTROLS = ('auto_hold', 'auto_reset')
#: The sender name of the supervisor's controls.
SUPERVISOR = 'run_test'
#: How many of the last controls a status acknowledges.
ACKNOWLEDGED = 8


def operator_name(tool: str) -> str:
    """The sender of a person's control: ``operator <user>@<host> (<tool>)``."""
    try:
        user = getpass.getuser()
    except (KeyError, OSError):
        user = 'unknown'
    return f'operator {user}@{socket.gethostname()} ({tool})'


def acknowledgement(signature: Signature, command: str, outcome: str) -> str:
    """The acknowledgement of a control signed ``signature``.

    ``"<session>:<sequence> <command>: <outcome>"`` (``outcome`` is ``ok`` or ``refused: <why>``).
    """
    return f'{signature.session}:{signature.sequence} {command}: {outcome}'


class Acknowledgement:
    """A parsed acknowledgement (see :func:`acknowledgement`)."""

    __slots__ = ('command', 'outcome', 'sequence', 'session')

    def __init__(self, session: str, sequence: int, command: str, outcome: str) -> None:
        self.session = session
        self.sequence = sequence
        self.command = command
        self.outcome = outcome

    @property
    def ok(self) -> bool:
        """Whether the control was carried out."""
        return self.outcome == 'ok'

    def answers(self, signature: Signature) -> bool:
        """Whether this acknowledges the control signed ``signature``."""
        return self.session == signature.session and self.sequence == signature.sequence


class Acknowledgements:
    """The last :data:`ACKNOWLEDGED` acknowledgements of a receiver (its status' text)."""

    def __init__(self) -> None:
        self._lines: list[str] = []

    def add(self, signature: Signature, command: str, outcome: str) -> None:
        """Acknowledge a control taken."""
        self._lines = [*self._lines, acknowledgement(signature, command, outcome)][
            -ACKNOWLEDGED:]

    @property
    def text(self) -> str:
        """The status' ``acknowledged`` field (one per line, the latest last)."""
        return '\n'.join(self._lines)


def find_acknowledgement(text: str, signature: Signature) -> Acknowledgement | None:
    """The acknowledgement of the control signed ``signature`` among a status' lines."""
    for line in reversed(text.splitlines()):
        ack = parse_acknowledgement(line)
        if ack is not None and ack.answers(signature):
            return ack
    return None


def parse_acknowledgement(text: str) -> Acknowledgement | None:
    """The acknowledgement in one line of a status, or ``None`` (none, or not one)."""
    head, sep, outcome = text.partition(': ')
    ident, _, command = head.partition(' ')
    session, colon, sequence = ident.rpartition(':')
    if not (sep and colon and command and sequence.isascii() and sequence.isdigit()):
        return None
    return Acknowledgement(session, int(sequence), command, outcome)

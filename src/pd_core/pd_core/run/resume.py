"""Continuing a stopped run: which runs can be, and whether the specimen side is where it was.

A run stopped by a crash or a signal is continued from its record (the journal) by
re-running it through a new step loop (:func:`.runner.restore_dispatcher`), bit for bit. Before
anything moves again, each site's specimen side is compared with the record
(:func:`check_sites`):

* its state must be the specimen the test drove: the same epoch (the process never stopped),
  or a restored simulator (``RESTORED``), or the hardware's own state (``HARDWARE``) — a
  ``FRESH`` state that replaced it is refused (see :mod:`.epochs`);
* its position (from its session offer) must be within the tolerance of the last measured
  displacement on record, or of the target of the command still owed (the specimen may have
  executed it before the crash);
* a physical site (``HARDWARE``) stood still, unsupervised by this test, for the gap: its
  position and the gap are reported and motion waits for the operator's confirmation (a signed
  ``resume``, or the integrator's ``confirm_resume`` parameter).

What the restored run then does is :func:`decide_resume`'s policy (the node only applies it):
a check that refused holds the test; a person's stop on record (an e-stop or an operator's
pause or hold, :class:`~pd_common.protocol.holds.PersonHolds`) or ``hold_on_resume`` waits for
a person's signed ``resume``; a physical site waits for the operator's confirmation; a run
that was running goes on; a run held or paused on record stays so.

A served run (OpenSees integrates: the ``opensees_element`` scheme) is re-run the same way with
the model itself: the restarted OpenSees script connects again and runs from its beginning;
each trial it sends is checked against the recorded command and answered with the recorded
force, so nothing moves until it reaches the journal's last committed step, and a model whose
trials differ from the record is refused (:func:`.runner.restore_dispatcher`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from enum import Enum
from pathlib import Path

from pd_common.config import read_text
from pd_common.protocol import Command, Feedback, FeedbackStatus, StateOrigin, TestState

from ..errors import ConfigError
from .definition import TestDefinition
from .loop.epochs import EpochGuard
from .record.bag import TOPIC_STATUS, RecordedRun, site_of
from .record.journal import JOURNAL_FILE
from .record.journal_format import MAX_RECORD_BYTES
from .runner import DEFINITION_JSON, load_run
from .test_file import from_json

__all__ = ['RESUMABLE', 'ResumeAction', 'ResumeCheck', 'ResumeDecision', 'SiteState',
           'check_sites', 'decide_resume', 'last_measured', 'load_resumable']

#: States a record can be resumed from (a killed run's last status is RUNNING).
RESUMABLE = (TestState.IDLE, TestState.RUNNING, TestState.PAUSED, TestState.HOLDING,
             TestState.INTERRUPTED)


@dataclass(frozen=True)
class SiteState:
    """A site's specimen side as it offers itself now (its session offer)."""

    epoch: str
    origin: StateOrigin
    position: tuple[float, ...]


@dataclass
class ResumeCheck:
    """What :func:`check_sites` found.

    Attributes:
        refused: why the run cannot go on (a fresh specimen, a position off the record).
        confirm: why the operator must confirm before anything moves (a physical site).
        report: one line per site: its state and position against the record.
    """

    refused: list[str] = field(default_factory=list)
    confirm: list[str] = field(default_factory=list)
    report: list[str] = field(default_factory=list)


def load_resumable(run_dir: str | Path) -> tuple[Path, TestDefinition, RecordedRun]:
    """The folder, test and record of a run that can be resumed.

    Raises:
        ConfigError: no such run, no journal, or the test finished or was aborted.
    """
    directory = Path(run_dir)
    definition_file = directory / DEFINITION_JSON
    if not definition_file.is_file():
        msg = f'{directory}: not a run folder (no {DEFINITION_JSON})'
        raise ConfigError(msg)
    if not (directory / JOURNAL_FILE).is_file():
        msg = f'{directory}: no {JOURNAL_FILE} (a run recorded before journals cannot resume)'
        raise ConfigError(msg)
    try:  # a regular file, bounded, UTF-8: a damaged one is one line, never a hang
        text = read_text(definition_file, limit=MAX_RECORD_BYTES, what='a test definition')
    except OSError as err:
        msg = f'{definition_file}: cannot read the test definition ({err.strerror})'
        raise ConfigError(msg) from None
    definition = from_json(text, source=definition_file.name)
    record = load_run(directory / JOURNAL_FILE)
    last = record.statuses[-1][1] if record.statuses else None
    if last is not None and last.state not in RESUMABLE:
        msg = (f'{directory}: the test is {last.state.name.lower()} ({last.message}); nothing '
               'to resume')
        raise ConfigError(msg)
    return directory, definition, record


def last_measured(run: RecordedRun, structured: bool) -> dict[str, tuple[float, ...]]:
    """Per site, the last measured displacement an OK feedback on record reported."""
    measured: dict[str, tuple[float, ...]] = {}
    for topic, _, item, _ in run.ordered:
        if (topic == TOPIC_STATUS or not isinstance(item, Feedback)
                or item.status is not FeedbackStatus.OK
                or (structured and '/structure/' in topic)):
            continue
        measured[site_of(topic) if structured else ''] = tuple(item.measured_displacement)
    return measured


def _distance(a: Sequence[float], b: Sequence[float]) -> float:
    if len(a) != len(b):
        return math.inf
    return max((abs(x - y) for x, y in zip(a, b, strict=True)), default=0.0)


def check_sites(sites: Mapping[str, SiteState], guard: EpochGuard,
                measured: Mapping[str, tuple[float, ...]],
                owed: Sequence[tuple[str, Command]], tolerance: float) -> ResumeCheck:
    """Compare each site's specimen side with the record (see the module).

    Args:
        sites: each site's offered state.
        guard: the restored run's epochs (the record's last per site).
        measured: :func:`last_measured` of the record.
        owed: the site commands the restored loop still owes.
        tolerance: largest position difference [m] (0: not checked).
    """
    check = ResumeCheck()
    targets = {site: tuple(command.target_displacement) for site, command in owed}
    for site, state in sites.items():
        name = site or 'default'
        recorded = guard.epochs.get(site)
        same = recorded is None or not state.epoch or state.epoch == recorded
        origin = state.origin.name.lower()
        if not same and state.origin is StateOrigin.FRESH:
            check.refused.append(
                f'site {name}: a fresh specimen state (epoch {state.epoch}, the record has '
                f'{recorded}): its process restarted without its state; restart it with its '
                'state (state_file) or abort')
        position = ', '.join(f'{x:.6g}' for x in state.position)
        line = f'site {name}: {"same process" if same else origin} state, at [{position}] m'
        candidates = [value for value in (measured.get(site), targets.get(site))
                      if value is not None]
        if candidates:
            gap = min(_distance(state.position, value) for value in candidates)
            line += f', {gap:.3g} m from the record'
            if tolerance > 0.0 and gap > tolerance:
                check.refused.append(
                    f'site {name}: at [{position}] m, {gap:.3g} m from where the record leaves '
                    f'it (tolerance {tolerance:g} m): not the state the test left')
        check.report.append(line)
        if state.origin is StateOrigin.HARDWARE:
            check.confirm.append(f'site {name}: physical specimen, {line.split(": ", 1)[1]}')
    return check


class ResumeAction(Enum):
    """What a restored run does first (:func:`decide_resume`)."""

    GO_ON = 'go_on'  #: the run was running: the loop re-sends what it owes and goes on
    STAY = 'stay'  #: held or paused on record: it stays so until the operator resumes it
    WAIT_FOR_PERSON = 'wait_for_person'  #: a person's stop on record: a person resumes
    WAIT_FOR_CONFIRMATION = 'wait_for_confirmation'  #: a physical site: the operator confirms
    REFUSE = 'refuse'  #: the specimen side is not the one the test left: the test holds


@dataclass(frozen=True)
class ResumeDecision:
    """:func:`decide_resume`'s answer, applied by the integrator's shell.

    Attributes:
        action: what happens first.
        state: the session's state before anything moves (for :attr:`ResumeAction.REFUSE`,
            the state the session then holds from).
        message: the session's message (why it waits, or why it cannot resume); ``None``:
            the record's message stands (a run held or paused on record says why itself).
    """

    action: ResumeAction
    state: TestState
    message: str | None


def decide_resume(recorded: TestState, check: ResumeCheck, *, person_hold: str | None,
                  hold_on_resume: bool, confirm_resume: bool, note: str,
                  gap_s: float) -> ResumeDecision:
    """The resume policy of a run restored from its record (see the module).

    Args:
        recorded: the session's state as the record leaves it.
        check: :func:`check_sites` of the specimen sides.
        person_hold: why a person's stop on record blocks automatic actions (``None``: none;
            :attr:`~pd_common.protocol.holds.PersonHolds.blocks_automatic`).
        hold_on_resume: hold for a person's resume whatever the record says (the launcher's
            restart of a crashed integrator under the hold policy).
        confirm_resume: the operator confirmed beforehand that a physical site may move.
        note: why the run is resumed (in the message of a hold on resume).
        gap_s: how long the run stood still [s] (in the confirmation's message).
    """
    interrupted = recorded in (TestState.RUNNING, TestState.INTERRUPTED)
    state = TestState.HOLDING if interrupted else recorded
    if check.refused:
        reason = 'cannot resume: ' + '; '.join(check.refused)
        return ResumeDecision(ResumeAction.REFUSE, state, reason)
    blocked = person_hold
    if blocked is None and hold_on_resume:
        blocked = f'restored after a stop ({note or "resumed"}); the test holds'
    if blocked is not None:  # a person stopped it before the crash: a person resumes it
        return ResumeDecision(ResumeAction.WAIT_FOR_PERSON, state,
                              f'{blocked}; resume with ./pd control resume')
    if check.confirm and not confirm_resume:
        message = (f'resumed after a gap of {gap_s:.0f} s: ' + '; '.join(check.confirm)
                   + '; check the specimen, then confirm with ./pd control resume')
        return ResumeDecision(ResumeAction.WAIT_FOR_CONFIRMATION, state, message)
    if interrupted:
        return ResumeDecision(ResumeAction.GO_ON, state, 'resumed from the record')
    return ResumeDecision(ResumeAction.STAY, state, None)

"""Steering a running test: what each control does, and the holds only a person clears.

The integrator takes controls from a person (``./pd control``, the console: ``pause``,
``resume``, ``hold``, ``abort``) and from its supervisor (``run_test``: ``auto_hold``,
``auto_resume``, ``restarted``), and emergency stops from anyone. :class:`Steering` decides what
each does to the :class:`~.session.TestSession` and keeps :class:`~pd_common.protocol.PersonHolds`:

* a person's ``pause`` or ``hold``, an emergency stop, and a step the specimen side refused on
  a safety limit or an emergency stop latch a hold that only a person's ``resume`` clears;
* the supervisor's ``auto_resume`` (after it restarted a process) is refused while such a hold
  stands: a crash never undoes a person's stop;
* every latch and every control taken is an event for the run's journal, put on disk before
  the integrator answers anything else, and :meth:`Steering.restore` replays them, so a
  restarted integrator holds what the crashed one held.

The node wires it to the topics; the decisions are here, without ROS.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass
from typing import Any

from pd_common.protocol import (
    SUPERVISOR_TEST_CONTROLS,
    TEST_CONTROLS,
    Feedback,
    FeedbackStatus,
    PersonHolds,
    TestState,
    clip_reason,
)

from .session import TestSession

__all__ = ['EMERGENCY_MARK', 'Decision', 'Steering']

#: How a bridge's answer names an emergency stop (its hold reason starts a part with it).
EMERGENCY_MARK = 'EMERGENCY STOP'
_ENDED = (TestState.FINISHED, TestState.ABORTED, TestState.INTERRUPTED)


@dataclass(frozen=True)
class Decision:
    """What a control did.

    Attributes:
        outcome: ``'ok'`` or ``'refused: why'`` (the acknowledgement's outcome).
        resume: the node must re-open the sites' sessions and resume (checked there).
        restarted: a process of the test was restarted (the node doubts every site's offer).
    """

    outcome: str
    resume: bool = False
    restarted: bool = False


class Steering:
    """The controls' effects on a test, and its durable person holds (see the module).

    Args:
        session: the test.
        record: writes one event (a mapping with ``what``) to the journal, durably.
    """

    def __init__(self, session: TestSession, record: Callable[[dict[str, Any]], None]) -> None:
        self.session = session
        self.holds = PersonHolds()
        self._record = record

    def restore(self, events: Iterable[Mapping[str, Any]]) -> None:
        """The holds a restored run's journal leaves latched (before anything is answered)."""
        self.holds = PersonHolds.replay(events)

    def emergency_stop(self, reason: str) -> bool:
        """An emergency stop (anyone's): hold, latched; whether it is a new one."""
        event = self.holds.emergency_stop(reason)
        self.session.hold(f'emergency stop: {self.holds.emergency}')
        if event is None:
            return False
        self._record(event)
        return True

    def after_feedback(self, feedback: Feedback, was: TestState) -> None:
        """A feedback that put the test on hold.

        A safety limit or an emergency stop at the specimen side is a person's to clear.
        """
        if was is TestState.HOLDING or self.session.state is not TestState.HOLDING:
            return
        if EMERGENCY_MARK in feedback.message:
            event = self.holds.emergency_stop(f'at the specimen side: {feedback.message}')
            if event is not None:
                self._record(event)
        elif feedback.status is FeedbackStatus.LIMIT:
            self._record(self.holds.operator_hold(
                f'held on a safety limit at step {feedback.step}: {feedback.message}'))

    def control(self, request: str, sender: str, reason: str) -> Decision:
        """Carry out an admitted control ``request`` from ``sender``."""
        why = f' ({clip_reason(reason)})' if reason else ''
        session = self.session
        if request in ('pause', 'hold', 'abort') and session.state in _ENDED:
            return Decision(f'refused: the test is {session.state.name.lower()}')
        if request == 'pause':
            session.pause()  # (held already: it stays held, and now a person holds it)
            self._record(self.holds.operator_hold(f'paused by {sender}{why}'))
        elif request == 'hold':
            session.hold(f'held by {sender}{why}')
            self._record(self.holds.operator_hold(f'held by {sender}{why}'))
        elif request == 'abort':
            session.abort(f'aborted by {sender}{why}')
        elif request == 'resume':
            event = self.holds.clear(emergency=True, by=sender)
            if event is not None:
                self._record(event)
            return Decision('ok', resume=True)
        elif request == 'auto_hold':
            session.hold(f'held by {sender}{why}')
        elif request == 'auto_resume':
            blocked = self.holds.blocks_automatic
            if blocked is not None:
                return Decision(f'refused: {blocked}; a person resumes it (./pd control resume)')
            return Decision('ok', resume=True)
        elif request == 'restarted':
            return Decision('ok', restarted=True)
        else:
            known = ', '.join((*TEST_CONTROLS, *SUPERVISOR_TEST_CONTROLS))
            return Decision(f'refused: unknown request {request!r} ({known})')
        return Decision('ok')

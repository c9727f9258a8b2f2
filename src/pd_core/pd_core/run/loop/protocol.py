"""The step protocol: which feedback advances the test, when to re-send, when to hold.

The integrator sends the command for step k and advances only on the feedback for step k of the
same test id. Everything else is ignored and counted by reason:

* ``foreign``: another test id;
* ``stale``: an older step than the last one answered (e.g. a late answer to a re-sent
  command, or a delayed message), answered before or not;
* ``duplicate``: a second answer to the step accepted last (a re-sent command answered twice,
  or a message delivered twice);
* ``unexpected``: a step that was never commanded (a future step, or no command pending).

Feedback for the pending step whose status is not OK (a limit or a fault) is ``refused``: the
step stays pending and the test holds.

A timeout re-sends the same command; after ``max_retries`` re-sends the protocol holds: it
never invents a force. Transport-free; the node shell owns the timers.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from enum import Enum
from typing import TYPE_CHECKING

from ...errors import ProtocolError

if TYPE_CHECKING:
    from pd_common.protocol import Command, Feedback


class Verdict(Enum):
    """How a feedback message was classified."""

    ACCEPTED = 'accepted'
    FOREIGN = 'foreign'
    STALE = 'stale'
    DUPLICATE = 'duplicate'
    UNEXPECTED = 'unexpected'
    REFUSED = 'refused'


class TimeoutAction(Enum):
    """What to do when the feedback timeout expires."""

    RESEND = 'resend'
    HOLD = 'hold'


@dataclass
class StepProtocol:
    """Bookkeeping of the pending command.

    Attributes:
        max_retries: re-sends allowed before :meth:`on_timeout` answers ``HOLD``.
        pending: the command waiting for its feedback, if any.
        retries: total re-sends over the test.
        ignored: ignored feedback, counted per :class:`Verdict`.
    """

    max_retries: int
    pending: Command | None = None
    retries: int = 0
    attempts: int = 0
    ignored: dict[Verdict, int] = field(default_factory=dict)
    # Per test id, the highest (step, iteration) answered: a test's keys are answered in order,
    # so this one pair stands for every key answered before it (a set of every key answered grew
    # by a tuple a step, about 130 bytes, over a long test).
    _answered_through: dict[str, tuple[int, int]] = field(default_factory=dict)
    _last_answered: tuple[str, int, int] | None = None

    @property
    def ignored_total(self) -> int:
        """Number of feedback messages ignored so far."""
        return sum(self.ignored.values())

    def send(self, command: Command) -> None:
        """Record that ``command`` was sent (a new step; use :meth:`on_timeout` to re-send).

        Raises:
            ProtocolError: a command is still pending.
        """
        if self.pending is not None:
            msg = (f'cannot send step {command.step}: step {self.pending.step} of '
                   f'{self.pending.test_id!r} is still pending')
            raise ProtocolError(msg)
        self.pending = command
        self.attempts = 0

    def classify(self, feedback: Feedback) -> Verdict:
        """Classify ``feedback``: ``ACCEPTED`` clears the pending command, others are counted."""
        verdict = self.verdict(feedback)
        if verdict is Verdict.ACCEPTED:
            self.accept(feedback)
        else:
            self.ignore(verdict)
        return verdict

    def accept(self, feedback: Feedback) -> None:
        """Take ``feedback`` just found ``ACCEPTED`` as the answer to the pending command.

        Take ``feedback``, whose :meth:`verdict` was just found ``ACCEPTED`` (nothing changed
        since): it answers the pending command, which is cleared (:meth:`classify` without
        classifying it a second time).
        """
        answered = (feedback.test_id, feedback.step, feedback.iteration)
        through = self._answered_through.get(feedback.test_id)
        if through is None or through < answered[1:]:
            self._answered_through[feedback.test_id] = answered[1:]
        self._last_answered = answered
        self.pending = None

    def ignore(self, verdict: Verdict) -> None:
        """Count one ignored feedback message."""
        self.ignored[verdict] = self.ignored.get(verdict, 0) + 1

    def verdict(self, feedback: Feedback) -> Verdict:
        """Classify ``feedback`` without changing any state."""
        pending = self.pending
        test_id, step, iteration = feedback.test_id, feedback.step, feedback.iteration
        answered = (test_id, step, iteration)
        through = self._answered_through.get(test_id)
        if through is not None and (step, iteration) <= through:
            return (Verdict.DUPLICATE if answered == self._last_answered
                    else Verdict.STALE)
        if pending is None:
            return Verdict.UNEXPECTED
        if test_id != pending.test_id:
            return Verdict.FOREIGN
        if step == pending.step and iteration == pending.iteration:
            return Verdict.ACCEPTED
        return Verdict.STALE if (step, iteration) < (pending.step, pending.iteration) \
            else Verdict.UNEXPECTED

    def on_timeout(self) -> TimeoutAction:
        """The feedback timeout expired: re-send the pending command, or hold.

        Raises:
            ProtocolError: nothing is pending.
        """
        if self.pending is None:
            msg = 'feedback timeout with no pending command'
            raise ProtocolError(msg)
        if self.attempts >= self.max_retries:
            return TimeoutAction.HOLD
        self.attempts += 1
        self.retries += 1
        return TimeoutAction.RESEND

"""Answering keyed step commands once: the bookkeeping every simulated step receiver shares.

A receiver that moves something (a simulated specimen, a continuous actuator) answers each new
``(step, iteration)`` of a test by moving; the command answered last, again (a re-sent
command), gets the same answer without moving; an older one of the same test is ignored
(``None``). A new test id starts fresh bookkeeping. :func:`arrival` is that rule, the one
home of it: :class:`KeyedAnswers` applies it, and so does the actuator bridge (which answers
later, through its driver).
"""

from __future__ import annotations

import abc
import enum
import operator
from collections.abc import Sequence

from .messages import Feedback, StepKey

__all__ = ['RUN_SEPARATOR', 'Arrival', 'KeyedAnswers', 'RunTags', 'arrival', 'untag']


class Arrival(enum.Enum):
    """How a keyed command stands to the command of the same test answered last."""

    NEW = 'new'  #: a later key (or the first command of a test): move
    REPEAT = 'repeat'  #: the key answered last, again (a re-sent command): the same answer
    STALE = 'stale'  #: an older key (or one that cannot be ordered against it): ignored


def arrival(key: int | tuple[int, ...], last_key: int | tuple[int, ...] | None) -> Arrival:
    """The repeat / ignore rule of a step receiver, keys compared by equality and order only.

    Args:
        key: The command's key: ``(step, iteration)`` (a :class:`~.messages.StepKey`), or any
            totally ordered key (the actuator bridge also takes an ``int``).
        last_key: The key of the same test's command answered last; ``None``: none (a new
            test id starts fresh).

    Returns:
        ``REPEAT`` for the same key, ``STALE`` for an older one or a foreign one (a key that
        cannot be ordered against it, e.g. an ``int`` after tuples), else ``NEW``.
    """
    if last_key is None:
        return Arrival.NEW
    if key == last_key:
        return Arrival.REPEAT
    try:
        # operator.lt is ``<``; an int against a tuple raises TypeError (a foreign key).
        older = bool(operator.lt(key, last_key))
    except (TypeError, ValueError):
        return Arrival.STALE
    return Arrival.STALE if older else Arrival.NEW


class KeyedAnswers(abc.ABC):
    """The repeat / ignore bookkeeping of :meth:`handle`; a subclass moves in :meth:`_move`.

    Attributes:
        repeated: Commands answered again without moving.
        ignored: Older commands of the same test, not answered.
    """

    def __init__(self) -> None:
        """No command answered yet."""
        self._last: Feedback | None = None
        self.repeated = 0
        self.ignored = 0

    @property
    def last(self) -> Feedback | None:
        """The answer to the command served last (what a repeat of it gets)."""
        return self._last

    def handle(self, test_id: str, step: int, target: Sequence[float], *, iteration: int = 0,
               control_mode: Sequence[int] = (), target_force: Sequence[float] = ()
               ) -> Feedback | None:
        """Answer the command for ``(step, iteration)`` of ``test_id``; ``None`` if ignored.

        ``control_mode`` and ``target_force`` as in :class:`~.messages.Command` (empty: every
        actuator displacement-controlled).
        """
        last = self._last
        if last is not None and last.test_id == test_id:
            order = arrival(StepKey(step, iteration), last.key)
            if order is Arrival.REPEAT:
                self.repeated += 1
                return last
            if order is Arrival.STALE:
                self.ignored += 1
                return None
        answer = self._move(test_id, step, iteration, target, control_mode, target_force)
        self._last = answer
        return answer

    @abc.abstractmethod
    def _move(self, test_id: str, step: int, iteration: int, target: Sequence[float],
              control_mode: Sequence[int], target_force: Sequence[float]) -> Feedback:
        """Move for a new command and return the answer."""


#: Separates a test id from its run number in a run tag (a test id never holds it).
RUN_SEPARATOR = '#'


class RunTags:
    """Which run of a test a command belongs to.

    A receiver started by hand serves the same test file run twice (two integrators, one after the
    other) as two runs.

    A command for step 0 (iteration 0) of a test whose later steps this receiver answered,
    from another sender session (a new integrator process), starts a new run: its commands
    are keyed ``<test id>#<n>`` inside the receiver, so they are new commands, not stale ones
    to ignore (a resumed run never goes back to step 0 after later steps: it re-sends the
    step it owes). :meth:`tag` gives the key, :func:`untag` the test id back for the answer.
    """

    def __init__(self) -> None:
        self._runs: dict[str, tuple[int, str, StepKey]] = {}  # id -> (run, session, last)

    def tag(self, test_id: str, key: StepKey, session: str) -> str:
        """The run tag of the command ``key`` of ``test_id`` sent in ``session``."""
        run, last_session, last = self._runs.get(test_id, (1, session, key))
        if key == StepKey(0, 0) and last > key and (not session or session != last_session):
            run, last = run + 1, key
        self._runs[test_id] = (run, session, max(key, last))
        return test_id if run == 1 else f'{test_id}{RUN_SEPARATOR}{run}'


def untag(tagged: str) -> str:
    """The test id of a run tag (:class:`RunTags`)."""
    return tagged.split(RUN_SEPARATOR, 1)[0]

"""Answering keyed step commands once: the bookkeeping every simulated step receiver shares.

A receiver that moves something (a simulated specimen, a continuous actuator) answers each new
``(step, iteration)`` of a test by moving; the command answered last, again (a re-sent
command), gets the same answer without moving; an older one of the same test is ignored
(``None``). A new test id starts fresh bookkeeping.
"""

from __future__ import annotations

import abc
from collections.abc import Sequence

from .messages import Feedback

__all__ = ['KeyedAnswers']


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
            key, last_key = (step, iteration), (last.step, last.iteration)
            if key == last_key:
                self.repeated += 1
                return last
            if key < last_key:
                self.ignored += 1
                return None
        answer = self._move(test_id, step, iteration, target, control_mode, target_force)
        self._last = answer
        return answer

    @abc.abstractmethod
    def _move(self, test_id: str, step: int, iteration: int, target: Sequence[float],
              control_mode: Sequence[int], target_force: Sequence[float]) -> Feedback:
        """Move for a new command and return the answer."""

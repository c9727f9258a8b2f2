"""A stop flag a signal handler may set: no lock, so a second signal cannot deadlock it.

``threading.Event.set`` takes the event's lock. A handler that calls it runs in the main
thread between two bytecodes, possibly while that same thread holds the lock inside
``Event.wait`` or ``Event.is_set``'s caller chain; the handler then waits forever for a lock its
own thread holds (a process stopped by SIGTERM while a second SIGTERM arrived hung this way, an
orphaned integrator among them). :class:`StopFlag` is a plain attribute write, which a handler
can always do, and its :meth:`~StopFlag.wait` polls.
"""

from __future__ import annotations

import signal
import time
from collections.abc import Callable, Iterable
from types import FrameType

__all__ = ['POLL_S', 'StopFlag', 'restore_handlers', 'stop_on_signals']

#: Seconds between two looks at the flag in :meth:`StopFlag.wait`.
POLL_S = 0.02

Handler = Callable[[int, FrameType | None], object] | int | signal.Handlers | None


class StopFlag:
    """Set once to ask a loop to stop; safe to set from a signal handler (no lock is taken).

    Has the part of :class:`threading.Event`'s interface the loops use: :meth:`set`,
    :meth:`is_set`, :meth:`clear` and :meth:`wait`.
    """

    __slots__ = ('_set', 'signal_number')

    def __init__(self) -> None:
        self._set = False
        #: The signal that set the flag (``None``: not set by a signal).
        self.signal_number: int | None = None

    def set(self) -> None:
        """Ask to stop."""
        self._set = True

    def clear(self) -> None:
        """Forget a request to stop."""
        self._set = False
        self.signal_number = None

    def is_set(self) -> bool:
        """Whether a stop was asked."""
        return self._set

    def wait(self, timeout: float | None = None) -> bool:
        """Wait until the flag is set or ``timeout`` seconds have passed; return the flag."""
        deadline = None if timeout is None else time.monotonic() + max(timeout, 0.0)
        while not self._set:
            if deadline is None:
                time.sleep(POLL_S)
                continue
            left = deadline - time.monotonic()
            if left <= 0.0:
                break
            time.sleep(min(POLL_S, left))
        return self._set

    def on_signal(self, signum: int, _frame: FrameType | None = None) -> None:
        """A signal handler that sets the flag (and notes the signal)."""
        self.signal_number = signum
        self._set = True


def stop_on_signals(flag: StopFlag,
                    numbers: Iterable[int] = (signal.SIGINT, signal.SIGTERM)
                    ) -> dict[int, Handler]:
    """Make ``numbers`` set ``flag``; return their handlers (for :func:`restore_handlers`)."""
    return {number: signal.signal(number, flag.on_signal) for number in numbers}


def restore_handlers(previous: dict[int, Handler]) -> None:
    """Put back the handlers :func:`stop_on_signals` replaced."""
    for number, handler in previous.items():
        signal.signal(number, handler)

"""When a file written step by step is ``fsync``-ed: the run's journal, a simulator's state file.

Each write hands its records to the operating system at once (a killed process loses nothing
written); the ``fsync`` that puts them on the disk (a power loss) comes at most every ``interval``
seconds, or after every write with an interval of 0. With ``background`` the interval's ``fsync``
runs in a thread of its own (:class:`BackgroundSync`): the step that falls due asks for it and goes
on, so a slow disk does not hold up the loop. One that has been under way for a whole interval and
at least :data:`STUCK_SYNC_S` (a stuck disk) is waited for by the step that asks for the next,
however short the interval: no record stays unsynced unnoticed for longer than that and one
``fsync``. A failed one (EIO: what reached the disk is unknown) is raised by the next
:meth:`IntervalSync.check` or :meth:`IntervalSync.written`, so the owner writes nothing after it.
An interval of 0, an ``fsync`` asked for now (:meth:`IntervalSync.sync_now`) and the one at close
always run in the caller.
"""

from __future__ import annotations

import os
import threading
import time
from collections.abc import Callable

__all__ = ['STUCK_SYNC_S', 'BackgroundSync', 'IntervalSync']

#: Seconds (at least) a background ``fsync`` may run before the step that asks for the next one
#: waits for it: a stuck disk, not a busy one (its thread may wait for the interpreter too).
STUCK_SYNC_S = 1.0


class BackgroundSync:
    """``fsync`` of one open file in a thread of its own: the caller asks and goes on.

    Requests that arrive while one runs are served by one more ``fsync`` after it (it covers
    every write made before it started). :attr:`busy` tells whether one asked is not done yet
    and :meth:`wait` waits for it. The first error is kept in :attr:`error` and ends the
    thread; the owner raises it.

    Args:
        fd: the file descriptor; it must stay open until :meth:`stop` returns.
        name: the thread's name.
    """

    def __init__(self, fd: int, name: str = 'fsync') -> None:
        self._fd = fd
        self._changed = threading.Condition()
        self._asked = 0  # requests made
        self._done = 0  # requests a finished fsync covered
        self._stopping = False
        self.error: OSError | None = None
        self._thread = threading.Thread(target=self._run, name=name, daemon=True)
        self._thread.start()

    @property
    def busy(self) -> bool:
        """Whether an ``fsync`` asked for has not ended yet."""
        with self._changed:
            return self._done < self._asked and self.error is None

    def request(self) -> None:
        """Ask for an ``fsync`` (returns at once)."""
        with self._changed:
            self._asked += 1
            self._changed.notify_all()

    def wait(self) -> None:
        """Wait until every ``fsync`` asked for has ended (or failed, or the thread stopped)."""
        with self._changed:
            while self._done < self._asked and self.error is None and not self._stopping:
                self._changed.wait()

    def _run(self) -> None:
        while True:
            with self._changed:
                while self._done == self._asked and not self._stopping:
                    self._changed.wait()
                if self._stopping:
                    return
                covers = self._asked
            try:
                os.fsync(self._fd)
            except OSError as err:
                with self._changed:
                    self.error = err
                    self._changed.notify_all()
                return
            with self._changed:
                self._done = covers
                self._changed.notify_all()

    def stop(self) -> None:
        """End the thread once the ``fsync`` under way (if any) returns."""
        with self._changed:
            self._stopping = True
            self._changed.notify_all()
        self._thread.join()


class IntervalSync:
    """The ``fsync`` policy of one file open for appending (see the module).

    Args:
        fd: the file descriptor; it must stay open until :meth:`stop` or :meth:`close`.
        interval: most seconds between two ``fsync`` calls (0: after every write).
        background: the interval's ``fsync`` in a thread of its own (:class:`BackgroundSync`).
        clock: monotonic clock for the interval.
        name: the background thread's name.
    """

    def __init__(self, fd: int, interval: float, *, background: bool = False,
                 clock: Callable[[], float] = time.monotonic, name: str = 'fsync') -> None:
        self._fd = fd
        self.interval = interval
        self._clock = clock
        self._synced = clock()
        self._syncer = BackgroundSync(fd, name) if background and interval > 0.0 else None
        self._error: OSError | None = None
        self._outstanding_since = 0.0  # when the background fsync under way was asked for

    def check(self) -> None:
        """Raise the failure of a background ``fsync``, if one failed (before writing more).

        Raises:
            OSError: that failure.
        """
        error = self._error or (self._syncer.error if self._syncer is not None else None)
        if error is not None:
            raise error

    def written(self) -> None:
        """Records were handed to the operating system: ``fsync`` if the interval is over.

        Raises:
            OSError: the ``fsync`` (in the caller), or the last background one, failed.
        """
        now = self._clock()
        if now - self._synced < self.interval:
            return
        syncer = self._syncer
        if syncer is None:
            os.fsync(self._fd)
        else:
            busy = syncer.busy
            if busy and now - self._outstanding_since >= max(self.interval, STUCK_SYNC_S):
                syncer.wait()  # the one under way has run that long: a stuck disk
                busy = False
            self.check()
            if not busy:  # (else the request waits behind the one under way, still owed)
                self._outstanding_since = now
            syncer.request()
        self._synced = now

    def sync_now(self) -> None:
        """``fsync`` in the caller now (a record that must be on disk before anything else).

        Raises:
            OSError: it failed.
        """
        os.fsync(self._fd)
        self._synced = self._clock()

    def stop(self) -> None:
        """End the background thread (its failure, if any, is kept for :meth:`check`)."""
        syncer, self._syncer = self._syncer, None
        if syncer is not None:
            syncer.stop()
            self._error = self._error or syncer.error

    def close(self) -> None:
        """End the background thread, then ``fsync`` in the caller (the file stays open).

        Raises:
            OSError: a background ``fsync`` failed, or this one did.
        """
        self.stop()
        self.check()
        os.fsync(self._fd)

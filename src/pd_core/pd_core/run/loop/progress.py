"""Console progress of a running test: step/total, percentage, rate and ETA."""

from __future__ import annotations

import time
from collections.abc import Callable


class ProgressMeter:
    """Formats a progress line at most every ``interval`` seconds.

    Args:
        total: number of steps of the test.
        interval: minimum seconds between two lines.
        clock: monotonic clock (injectable for tests).
        first_step: the step the meter starts at (a resumed run: its first step after the
            record), so the rate counts only the steps stepped since.
    """

    def __init__(self, total: int, interval: float = 1.0,
                 clock: Callable[[], float] = time.monotonic, first_step: int = 0) -> None:
        self.total = total
        self.interval = interval
        self.first_step = first_step
        self._clock = clock
        self._start = clock()
        self._last_time = -float('inf')

    @property
    def elapsed(self) -> float:
        """Seconds since the meter started."""
        return self._clock() - self._start

    def line(self, step: int) -> str:
        """The progress line for ``step`` (unconditionally)."""
        elapsed = self.elapsed
        rate = (step - self.first_step) / elapsed if elapsed > 0 else 0.0
        remaining = (self.total - step) / rate if rate > 0 else float('nan')
        percent = 100.0 * step / self.total if self.total else 100.0
        eta = f'{remaining:6.1f} s' if remaining == remaining else '     ? s'
        return (f'step {step:>{len(str(self.total))}}/{self.total} ({percent:5.1f} %) '
                f'{rate:8.0f} steps/s  ETA {eta}')

    def update(self, step: int) -> str | None:
        """The progress line if ``interval`` has passed since the last one (or at the end)."""
        now = self._clock()
        if step < self.total and now - self._last_time < self.interval:
            return None
        self._last_time = now
        return self.line(step)

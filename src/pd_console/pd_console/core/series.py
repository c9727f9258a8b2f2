"""Bounded, decimated histories: what the console keeps of a test of any length."""

from __future__ import annotations

import math
from collections.abc import Sequence

__all__ = ['DecimatedRows', 'rounded']


def rounded(value: float, digits: int = 6) -> float | None:
    """``value`` to ``digits`` significant digits for the page (``None`` if not finite)."""
    if not math.isfinite(value):
        return None
    if value == 0.0:
        return 0.0
    return float(f'{value:.{digits}g}')


class DecimatedRows:
    """Rows (tuples of floats) of a history kept in at most ``capacity`` rows.

    Every row is counted; rows are grouped in windows of ``stride`` rows and one row per
    window is kept: the first, or with ``key`` the one of the largest ``|row[key]|`` (peaks
    survive: a hysteresis loop keeps its turning points). When the buffer is full, each
    pair of kept rows is merged the same way and the stride doubles, so the rows cover the
    whole history evenly at any length, in memory bounded by ``capacity``. The last row is
    always returned too (the latest value is always drawn).

    Args:
        capacity: the largest number of rows kept (at least 2).
        key: the column whose peaks are kept (``None``: the first row of each window).
    """

    def __init__(self, capacity: int, key: int | None = None) -> None:
        if capacity < 2:
            msg = f'DecimatedRows: capacity must be at least 2, got {capacity}'
            raise ValueError(msg)
        self.capacity = capacity
        self.key = key
        self.stride = 1
        self.count = 0
        self._rows: list[tuple[float, ...]] = []
        self._window: tuple[float, ...] | None = None
        self._last: tuple[float, ...] | None = None

    def _pick(self, a: tuple[float, ...], b: tuple[float, ...]) -> tuple[float, ...]:
        if self.key is None:
            return a
        return b if abs(b[self.key]) > abs(a[self.key]) else a

    def append(self, row: Sequence[float]) -> None:
        """Count one row; keep it if it is its window's choice."""
        item = tuple(float(value) for value in row)
        self._last = item
        self._window = item if self._window is None else self._pick(self._window, item)
        self.count += 1
        if self.count % self.stride == 0:
            self._rows.append(self._window)
            self._window = None
            if len(self._rows) > self.capacity:
                if len(self._rows) % 2:
                    self._window = self._rows.pop()
                pairs = zip(self._rows[::2], self._rows[1::2], strict=True)
                self._rows = [self._pick(a, b) for a, b in pairs]
                self.stride *= 2

    def rows(self) -> list[tuple[float, ...]]:
        """The kept rows in order, then the window being filled, then the last row."""
        rows = list(self._rows)
        if self._window is not None and self._window is not self._last:
            rows.append(self._window)
        if self._last is not None and (not rows or rows[-1] is not self._last):
            rows.append(self._last)
        return rows

    def columns(self, width: int) -> list[list[float | None]]:
        """The rows as ``width`` columns, rounded for the page."""
        rows = self.rows()
        return [[rounded(row[i]) for row in rows] for i in range(width)]

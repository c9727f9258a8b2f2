"""Append-only JSON-lines files that survive a crash.

A simulated specimen's state file, a bridge's record (the run's journal is binary:
``pd_core.run.record.journal_format``).
"""

from __future__ import annotations

import json
import os
import time
from pathlib import Path
from typing import Any

__all__ = ['EventFile', 'end_last_line']


def end_last_line(path: Path) -> None:
    """Before appending to ``path``, make its last line complete or drop it.

    Before appending to ``path``: drop a last line a crash cut short (the readers ignore it),
    or end a complete one that lost only its newline, so that the next record starts a line of
    its own. Nothing to do for a file that does not exist yet.
    """
    if not path.is_file():
        return
    with path.open('rb+') as file:
        data = file.read()
        end = data.rfind(b'\n') + 1
        if end == len(data):
            return
        try:
            json.loads(data[end:])
        except ValueError:
            file.truncate(end)
        else:
            file.write(b'\n')


class EventFile:
    """An append-only JSON-lines file of events.

    Each on disk (``fsync``) before :meth:`append` returns: a node's durable record of what must
    survive its crash (an emergency stop, a person's hold, the controls it took).

    Args:
        path: the file (created with its folder when missing).

    Raises:
        ValueError: the file holds a line that is not a JSON object (one line naming the file
            and the line); a last line cut by a crash is dropped, not an error.
    """

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)
        self.events: list[dict[str, Any]] = self._read()
        self.path.parent.mkdir(parents=True, exist_ok=True)
        end_last_line(self.path)
        self._file = self.path.open('ab')

    def _read(self) -> list[dict[str, Any]]:
        if not self.path.exists():
            return []
        if not self.path.is_file():
            msg = f'{self.path}: not a regular file'
            raise ValueError(msg)
        lines = self.path.read_bytes().split(b'\n')
        events = []
        for number, line in enumerate(lines, start=1):
            if not line.strip():
                continue
            try:
                event = json.loads(line)
            except ValueError:
                if number == len(lines):  # a last line a crash cut short
                    break
                msg = f'{self.path}: line {number} is not JSON'
                raise ValueError(msg) from None
            if not isinstance(event, dict):
                msg = f'{self.path}: line {number} is not a JSON object'
                raise ValueError(msg)
            events.append(event)
        return events

    def append(self, event: dict[str, Any]) -> None:
        """Add ``event`` (with its wall-clock time ``t``) and put it on disk."""
        record = {'t': time.time(), **event}
        self._file.write(json.dumps(record, separators=(',', ':')).encode('utf-8') + b'\n')
        self._file.flush()
        os.fsync(self._file.fileno())
        self.events.append(record)

    def close(self) -> None:
        """Close the file."""
        self._file.close()

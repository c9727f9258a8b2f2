"""Append-only JSON-lines files that survive a crash (the journal, a simulator's state file)."""

from __future__ import annotations

import json
from pathlib import Path

__all__ = ['end_last_line']


def end_last_line(path: Path) -> None:
    """Before appending to ``path``: drop a last line a crash cut short (the readers ignore it),
    or end a complete one that lost only its newline, so that the next record starts a line of
    its own. Nothing to do for a file that does not exist yet."""
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

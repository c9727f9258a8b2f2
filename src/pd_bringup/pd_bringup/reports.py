"""Reports that child processes leave in the run folder, and adding them to ``summary.json``.

The fault proxies' counters (``faults-<site>.json``) and the continuous sites' wall-clock
statistics (``rths-<site>.json``) are read the same way and added to the run's summary as one
block each, the summary rewritten atomically.
"""

from __future__ import annotations

import json
import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

__all__ = ['add_to_summary', 'read_reports']


def read_reports(report_files: Mapping[str, Path]) -> dict[str, Mapping[str, Any]]:
    """Per name, its report file's JSON object.

    A file not written is left out, one that cannot be read (or is not an object) is ``{'error':
    ...}``.
    """
    reports: dict[str, Mapping[str, Any]] = {}
    for name, path in report_files.items():
        try:
            data = json.loads(path.read_text(encoding='utf-8'))
        except FileNotFoundError:
            continue
        except (OSError, ValueError) as err:
            data = {'error': f'{path.name}: unreadable ({err})'}
        reports[name] = data if isinstance(data, dict) else {'error': f'{path.name}: not a '
                                                                       'JSON object'}
    return reports


def add_to_summary(summary_file: Path, key: str, block: Any) -> None:
    """Set ``key`` of ``summary.json`` to ``block`` (left alone when the summary does not exist).

    Through a partial file and an atomic rename.

    Raises:
        OSError, ValueError: The summary cannot be read or written.
    """
    if not summary_file.is_file():
        return
    summary = json.loads(summary_file.read_text(encoding='utf-8'))
    summary[key] = block
    partial = summary_file.with_name(summary_file.name + '.partial')
    partial.write_text(json.dumps(summary, indent=2) + '\n', encoding='utf-8')
    os.replace(partial, summary_file)

"""``bench/results.json``: the figures of every bench, each bench merging its own keys in."""

from __future__ import annotations

import json
from collections.abc import Mapping
from pathlib import Path

RESULTS = Path(__file__).resolve().parent / 'results.json'


def merge_results(figures: Mapping[str, object], *, drop_prefixes: tuple[str, ...] = (),
                  path: Path = RESULTS) -> None:
    """Add ``figures`` to ``path`` (an unreadable file counts as empty; other keys are kept).

    Old keys starting with one of ``drop_prefixes`` that ``figures`` does not hold are dropped
    (names a bench no longer measures).
    """
    results: dict[str, object] = {}
    if path.is_file():
        try:
            results = json.loads(path.read_text(encoding='utf-8'))
        except json.JSONDecodeError:
            results = {}
    if drop_prefixes:
        results = {key: value for key, value in results.items()
                   if not key.startswith(drop_prefixes) or key in figures}
    results.update(figures)
    path.write_text(json.dumps(results, indent=2, sort_keys=True) + '\n', encoding='utf-8')

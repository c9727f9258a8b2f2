"""Print a run's journal: ``ros2 run pd_integrator journal RUN [--tail N] [--kind K] [--json]``.

``RUN`` is a run folder or its ``journal.pdj``. One line per record (its number, time, kind,
topic and what it says: a command's targets, a feedback's measurement and status, a status's
state, an event), or with ``--json`` one JSON object per record, every field by its protocol
name (for ``jq`` and scripts). A last record a crash tore is reported on stderr; a damaged
journal is one line naming the record, exit code 2.
"""

from __future__ import annotations

import argparse
import collections
import json
import sys
from collections.abc import Iterable, Iterator
from pathlib import Path

from pd_core.errors import PdIntegratorError
from pd_core.run.record.journal import JOURNAL_FILE, JournalRecord, iter_journal_records
from pd_core.run.record.journal_view import record_line, record_object

KINDS = ('def', 'cmd', 'fb', 'st', 'raw', 'ev')


def _kinds(text: str) -> set[str]:
    kinds = {kind.strip() for kind in text.split(',') if kind.strip()}
    unknown = sorted(kinds - set(KINDS))
    if unknown or not kinds:
        msg = f'{", ".join(unknown) or repr(text)}: not a record kind ({", ".join(KINDS)})'
        raise argparse.ArgumentTypeError(msg)
    return kinds


def _count(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        value = -1
    if value < 1:
        msg = f'{text!r}: not a number of records >= 1'
        raise argparse.ArgumentTypeError(msg)
    return min(value, sys.maxsize)  # (more than any journal holds: all of them)


def _numbered(records: Iterable[JournalRecord], kinds: set[str] | None
              ) -> Iterator[tuple[int, JournalRecord]]:
    for number, record in enumerate(records, start=1):
        if kinds is None or record.kind in kinds:
            yield number, record


def main(argv: list[str] | None = None) -> int:
    """Entry point; 0, or 2 if the journal cannot be read."""
    parser = argparse.ArgumentParser(prog='journal', description=__doc__.splitlines()[0])
    parser.add_argument('run', help=f'a run folder or its {JOURNAL_FILE}')
    parser.add_argument('--tail', type=_count, metavar='N', help='only the last N records')
    parser.add_argument('--kind', type=_kinds, metavar='K[,K]',
                        help=f'only records of these kinds ({", ".join(KINDS)})')
    parser.add_argument('--json', action='store_true', help='one JSON object per record')
    args = parser.parse_args(argv)
    path = Path(args.run)
    if path.is_dir():
        path = path / JOURNAL_FILE
    notes: list[str] = []
    counted = [0]  # the journal's records (before --kind and --tail)

    def counting(records: Iterable[JournalRecord]) -> Iterator[JournalRecord]:
        for record in records:
            counted[0] += 1
            yield record

    try:
        selected: Iterable[tuple[int, JournalRecord]] = _numbered(
            counting(iter_journal_records(path, notes)), args.kind)
        if args.tail:
            selected = collections.deque(selected, maxlen=args.tail)
        for number, record in selected:
            if args.json:
                print(json.dumps(record_object(number, record)))
            else:
                print(record_line(number, record))
    except PdIntegratorError as err:
        print(f'journal: error: {err}', file=sys.stderr)
        return 2
    except BrokenPipeError:  # | head: the reader has what it wanted
        sys.stderr.close()
        return 0
    for note in notes:
        print(f'journal: {note}', file=sys.stderr)
    if not counted[0]:  # (an empty file: a run killed as it made its journal, or no journal)
        print(f'journal: {path}: no records', file=sys.stderr)
    return 0


if __name__ == '__main__':
    sys.exit(main())

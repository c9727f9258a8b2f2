"""Rebuild a run's outputs from its bag alone: ``ros2 run pd_integrator replay BAG``.

``BAG`` is a run's bag folder, its run folder, or its journal: a killed run (no bag, or an
unfinished one) is read from its journal, up to its last committed step. Reads the bag with
``rosbags``, re-runs the recorded commands and feedback through the same
step protocol and integrator (checking every recomputed command against the recorded one) and
writes ``response.csv``, ``summary.json`` and the figures. With ``--key FILE`` it also checks
every recorded authentication code (exit 1 if any fails; a key that signed none of them is
refused, exit 2, nothing written); without it the bag is analysed all the same.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from pd_common.auth import AuthError, load_key
from pd_common.config import existing_path
from pd_core.errors import PdIntegratorError
from pd_core.run.record.journal import JOURNAL_FILE, LEGACY_JOURNAL_FILE
from pd_core.run.record.signatures import ForeignKeyError
from pd_core.run.runner import BAG_DIRECTORY, rebuild_outputs

#: What only a run's own folder holds: an output folder with one of them is a run's (its
#: journal, its bag, run_test's launch plan, an earlier version's journal).
RUN_RECORDS = (JOURNAL_FILE, BAG_DIRECTORY, 'launch.json', LEGACY_JOURNAL_FILE)


def _run_record_in(folder: Path) -> str | None:
    """The first of :data:`RUN_RECORDS` in ``folder``; ``None`` if none (or no folder)."""
    for name in RUN_RECORDS:
        if (folder / name).exists():
            return name
    return None


def main(argv: list[str] | None = None) -> int:
    """Entry point; returns the exit status.

    Entry point; returns 0 on success, 1 if a signature fails or the outputs cannot be
    written, 2 if the bag cannot be replayed.
    """
    parser = argparse.ArgumentParser(prog='replay', description=__doc__.splitlines()[0])
    parser.add_argument('bag', help="the run's bag folder (e.g. runs/<run>/bag), its run "
                        'folder or its journal.pdj')
    parser.add_argument('--out', help='output folder (default: <run folder>/replay)')
    parser.add_argument('--no-figures', action='store_true', help='skip the PNG figures')
    parser.add_argument('--key', help="the test's key file: check the recorded signatures")
    args = parser.parse_args(argv)
    bag = Path(args.bag)
    try:
        resolved = existing_path(bag)  # (a symbolic link loop: one line, not a RuntimeError)
    except OSError as err:
        print(f'replay: error: {bag}: {err.strerror or type(err).__name__}', file=sys.stderr)
        return 2
    run_dir = resolved if resolved.is_dir() and bag.name != 'bag' else resolved.parent
    out = Path(args.out) if args.out else run_dir / 'replay'
    held = _run_record_in(out)
    if held is not None:  # its outputs would replace the run's own (its summary knows more)
        print(f'replay: error: {out}: a run folder ({held} in it): its outputs are not '
              'replaced; --out a new folder (default: <run folder>/replay)', file=sys.stderr)
        return 2
    try:
        key = load_key(args.key) if args.key else None
        result = rebuild_outputs(bag, out, figures=not args.no_figures, key=key)
    except ForeignKeyError as err:  # a wrong key file: refused before anything is written
        print(f'replay: error: --key {args.key}: {err}; nothing written', file=sys.stderr)
        return 2
    except (PdIntegratorError, AuthError, ValueError) as err:
        print(f'replay: error: {err}', file=sys.stderr)
        return 2
    except OSError as err:  # the outputs cannot be written (a full disk, a read-only folder)
        where = err.filename or out
        print(f'replay: error: {where}: cannot write ({err.strerror or type(err).__name__})',
              file=sys.stderr)
        return 1
    print(f'replayed {result.summary["steps"]} steps ({result.summary["state"]}); outputs in '
          f'{result.directory}')
    for note in result.summary.get('record_notes', []):  # (what reading the record left out)
        print(f'replay: note: {note}')
    check = result.summary.get('signature_check')
    if check is not None:
        print(f'replay: signatures (key {check["key_id"]}): {check["verified"]} verified, '
              f'{check["failed"]} failed, {check["unsigned"]} unsigned')
        if check['failed']:
            return 1
    return 0


if __name__ == '__main__':
    sys.exit(main())

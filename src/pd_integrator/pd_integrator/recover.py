"""Make a killed run's folder whole again: ``ros2 run pd_integrator recover RUN_DIR``.

A run whose integrator was killed (SIGKILL, a power loss) has its journal, on disk up to its
last committed step, but no bag and no outputs. This writes the bag from the journal and the
outputs (``response.csv``, ``summary.json`` marked ``recovered`` and ``partial``, figures) up
to the last committed step, in the run folder itself. The run can still be continued
afterwards (``./pd run --resume RUN_DIR``). A run that ended and wrote its own bag and summary is
left as it is (exit 0, one line saying so).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from pd_core.errors import NothingToRecoverError, PdIntegratorError
from pd_core.run.runner import recover_run


def main(argv: list[str] | None = None) -> int:
    """Entry point; returns 0 on success (or nothing to do), 2 if it cannot be recovered."""
    parser = argparse.ArgumentParser(prog='recover', description=__doc__.splitlines()[0])
    parser.add_argument('run_dir', help='the run folder (with its journal.pdj)')
    parser.add_argument('--no-figures', action='store_true', help='skip the PNG figures')
    args = parser.parse_args(argv)
    try:
        result = recover_run(Path(args.run_dir), figures=not args.no_figures)
    except NothingToRecoverError as err:  # a run that ended whole: left as it is
        print(f'recover: {err}')
        return 0
    except (PdIntegratorError, ValueError) as err:
        print(f'recover: error: {err}', file=sys.stderr)
        return 2
    except OSError as err:  # the outputs cannot be written (a full disk, a read-only folder)
        where = f'{err.filename}: ' if err.filename else ''
        print(f'recover: error: {where}cannot write ({err.strerror or type(err).__name__}); '
              f'once there is room, ./pd recover {args.run_dir} again', file=sys.stderr)
        return 1
    summary = result.summary
    notes = ''.join(f'; {note}' for note in summary.get('record_notes', []))
    print(f'recovered {summary["steps"]} committed steps ({summary["state"]}) of '
          f'{summary.get("test_id", "the test")}: bag and outputs in {result.directory}'
          f'{notes}')
    return 0


if __name__ == '__main__':
    sys.exit(main())

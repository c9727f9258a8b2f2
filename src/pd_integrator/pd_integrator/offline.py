"""ROS-free run of a test: ``ros2 run pd_integrator offline [TEST_FILE]``.

The same core, test file and specimen models as the node graph, in one process: it writes the
same run folder (bag, ``response.csv``, ``summary.json``, figures). For a simulated specimen its
history equals the node-graph run's, float for float.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from pd_core.errors import PdIntegratorError
from pd_core.run.bridge_limits import limits_report, site_limits
from pd_core.run.record.journal import JOURNAL_FILE, RecordWriteError
from pd_core.run.runner import check_new_run_folder, default_run_directory, run_offline
from pd_core.run.test_file import default_test_file, load_test_file, parse_overrides


def write_failure(err: OSError, out: Path | None) -> str:
    """One line about a run file that cannot be written (a full disk, a read-only folder).

    With what to do: a run whose journal has records is rebuilt by ``./pd recover``.
    """
    where = err.filename or out or ''
    line = f'{where}: cannot write ({err.strerror or type(err).__name__})'
    journal = out / JOURNAL_FILE if out is not None else None
    try:
        recorded = journal is not None and journal.is_file() and journal.stat().st_size > 0
    except OSError:
        recorded = False
    if recorded:
        line += f'; once there is room, ./pd recover {out} rebuilds its outputs from the journal'
    return line


def main(argv: list[str] | None = None) -> int:
    """Entry point; returns the exit status.

    Entry point; returns 0 when the test finished, 1 if it stopped (or its files could not
    be written), 2 on invalid input.
    """
    parser = argparse.ArgumentParser(prog='offline', description=__doc__.splitlines()[0])
    parser.add_argument('test_file', nargs='?', help='YAML test file (default: the thesis '
                        'section 5.1 test)')
    parser.add_argument('--out', help='run folder (default: runs/<test_id>-<UTC time>)')
    parser.add_argument('--no-figures', action='store_true', help='skip the PNG figures')
    parser.add_argument('--quiet', action='store_true', help='no progress lines')
    parser.add_argument('--bridge', help="the bridges' ROS parameter file (default: "
                        "pd_actuator_bridge's config/bridge.yaml, as ./pd run); a site's "
                        'sites.<site>.bridge overrides it')
    parser.add_argument('--past-limits', action='store_true', help="check the bridges' limits "
                        'but run past them (for study): report where they would have held')
    parser.add_argument('--param', '-p', action='append', default=[], metavar='NAME:=VALUE',
                        help='a test parameter, as ./pd run takes it: e.g. -p scale_factor:=0.5')
    args = parser.parse_args(argv)
    out: Path | None = None
    try:
        test_file = Path(args.test_file) if args.test_file else default_test_file()
        definition = load_test_file(test_file, parse_overrides(args.param))
        for warning in definition.warnings:
            print(f'offline: warning: {warning}', file=sys.stderr)
        if report := definition.modal_report():
            print(report)
        out = Path(args.out) if args.out else default_run_directory('runs', definition.test_id)
        check_new_run_folder(out)
        limits = site_limits(definition, args.bridge)
        if args.past_limits:
            print("offline: warning: --past-limits: the bridges' limits are checked, not "
                  'applied: the run goes on where ./pd run would hold', file=sys.stderr)
        result = run_offline(definition, out, figures=not args.no_figures,
                             progress=None if args.quiet else print, limits=limits,
                             past_limits=args.past_limits)
    except RecordWriteError as err:  # the journal or the bag: a full disk
        print(f'offline: error: {err}', file=sys.stderr)
        return 1
    except (PdIntegratorError, ValueError) as err:
        print(f'offline: error: {err}', file=sys.stderr)
        return 2
    except OSError as err:  # the run folder or an output (a full disk, a read-only folder)
        print(f'offline: error: {write_failure(err, out)}', file=sys.stderr)
        return 1
    stability = result.session.stability
    if stability is not None:
        print(stability.message)
    summary = result.summary
    if collapse := summary.get('collapse'):
        print(collapse['message'])
    for line in limits_report(summary):
        print(line)
    print(f'{summary["state"]}: {summary["steps"]} steps in {summary["wall_time"]:.3f} s; '
          f'outputs in {result.directory}')
    return 0 if summary['state'] == 'finished' else 1


if __name__ == '__main__':
    sys.exit(main())

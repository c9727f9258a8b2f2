r"""The thesis's chapter 5 study: ``ros2 run pd_studies study_ch5`` (or ``./pd study_ch5``).

Runs the section 5.1 SDOF column (m = 2543.4 kg, k_ini = 312.559 kN/m, 5 % damping, the default
bilinear pushover specimen, dt = 0.01 s) under each record with each scheme through the
ROS-free runner (:func:`~pd_core.run.runner.run_offline`: the same session and specimen
models as the node graph), and compares the schemes as the thesis's Figures 5.4-5.15 do::

    study_ch5                                   # El Centro (shipped), both schemes
    study_ch5 --records elcentro northridge=/data/RSN953_NORTHR_MUL009.AT2 \
              kobe=/data/RSN1106_KOBE_KJM000.AT2 --out runs/ch5
    study_ch5 --records /data/RSN1106_KOBE_KJM000.AT2 --schemes newmark_explicit,alpha_os

A record is a study name (``elcentro``, ``northridge``, ``kobe``: the test files of
``config/study_ch5``), ``NAME=PATH`` (that test file with your record file), or a ``PATH`` (the
test file whose ``match`` words occur in the file name, else the SDOF of the generic record under
the file's own name). PEER's records are not shipped; bring your own ``.AT2`` files.

Output folder (``--out``, default ``runs/study_ch5-<UTC time>``)::

    <record>/<scheme>/          one run folder per scheme (bag, response.csv, summary.json, ...)
    <record>/displacement.png   the schemes overlaid, with their difference below
    <record>/velocity.png, acceleration.png, force_deformation.png
    peak_differences.csv        per record and response quantity: the peak of each scheme,
    peak_differences.md         the difference and relative difference to the first scheme
                                (the reference), and ω·Δt per record
    study.json                  what was run (records, files, schemes, run folders)

Exit status: 0 when every run finished, 1 if a run stopped early, 2 on invalid input (a missing
or invalid record file, an unknown scheme or record, an output folder that already holds runs).

This module is the command and runs the records; the study file and the records are read by
:mod:`.study_ch5_records`, the table and the comparison figures written by
:mod:`.study_ch5_figures`.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from datetime import UTC, datetime
from pathlib import Path
from typing import TYPE_CHECKING, Any

from pd_core.errors import PdIntegratorError
from pd_core.run.runner import BAG_DIRECTORY, run_offline

from .study_ch5_figures import comparison_figures, markdown_table, peak_rows, write_table_csv
from .study_ch5_records import (
    RecordResult,
    Study,
    StudyError,
    StudyRecord,
    default_study_directory,
    load_study,
    parse_schemes,
    prepare_records,
)

if TYPE_CHECKING:
    from collections.abc import Callable

    from pd_core.run.record.history import ResponseHistory

__all__ = [
    'PROG',
    'STUDY_JSON',
    'TABLE_CSV',
    'TABLE_MD',
    'build_parser',
    'check_output_directory',
    'default_output_directory',
    'main',
    'run_record',
]

PROG = 'study_ch5'
TABLE_CSV = 'peak_differences.csv'
TABLE_MD = 'peak_differences.md'
STUDY_JSON = 'study.json'


# -- running ------------------------------------------------------------------------------------
def check_output_directory(out: Path, records: list[StudyRecord]) -> None:
    """Refuse an output folder that already holds one of the runs (nothing is overwritten).

    Raises:
        StudyError: a run folder already holds a bag, or the folder cannot be made.
    """
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as err:  # a file in the way, a folder that cannot be written
        msg = f'{err.filename or out}: cannot make the output folder ({err.strerror or err})'
        raise StudyError(msg) from None
    for record in records:
        for scheme in record.definitions:
            run = out / record.label / scheme
            if (run / BAG_DIRECTORY).exists():
                msg = f'{run}: already holds a run (bag/); choose a new --out folder'
                raise StudyError(msg)


def run_record(record: StudyRecord, out: Path, *, run_figures: bool = True,
               progress: Callable[[str], None] | None = None) -> RecordResult:
    """Run one record with each scheme (ROS-free runner) and read the summaries back."""
    directories: dict[str, Path] = {}
    histories: dict[str, ResponseHistory] = {}
    summaries: dict[str, dict[str, Any]] = {}
    for scheme, definition in record.definitions.items():
        directory = out / record.label / scheme
        result = run_offline(definition, directory, figures=run_figures)
        directories[scheme] = directory
        histories[scheme] = result.session.history
        summaries[scheme] = json.loads((directory / 'summary.json').read_text(encoding='utf-8'))
        if progress is not None:
            summary = summaries[scheme]
            dof = next(iter(summary['dofs'].values()))
            progress(f'{record.label} / {scheme}: {summary["state"]}, {summary["steps"]} steps '
                     f'in {summary["wall_time"]:.2f} s; peak displacement '
                     f'{dof["peaks"]["displacement"]["abs"] * 1e3:.2f} mm')
    return RecordResult(record=record, run_directories=directories, histories=histories,
                        summaries=summaries)


# -- the command --------------------------------------------------------------------------------
def default_output_directory() -> Path:
    """``runs/study_ch5-<UTC timestamp>``."""
    stamp = datetime.now(tz=UTC).strftime('%Y%m%d-%H%M%S')
    return Path('runs') / f'study_ch5-{stamp}'


def _manifest(study: Study, results: list[RecordResult], schemes: list[str],
              duration: float | None) -> dict[str, Any]:
    return {
        'study': str(study.directory),
        'schemes': schemes,
        'reference_scheme': schemes[0],
        'scheme_parameters': {scheme: study.scheme_parameters.get(scheme, {})
                              for scheme in schemes},
        'duration_override': duration,
        'records': [{
            'label': result.record.label,
            'title': result.record.title,
            'test_file': str(result.record.spec.test_file),
            'record_file': str(result.record.record_file),
            'thesis': result.record.spec.thesis if result.record.label
            == result.record.spec.name else None,
            'omega_dt': result.omega_dt,
            'runs': {scheme: {'directory': str(path),
                              'state': result.summaries[scheme]['state'],
                              'steps': result.summaries[scheme]['steps']}
                     for scheme, path in result.run_directories.items()},
        } for result in results],
    }


def _positive(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and value > 0.0):
        msg = f'expected a positive number of seconds, got {text!r}'
        raise argparse.ArgumentTypeError(msg)
    return value


def build_parser() -> argparse.ArgumentParser:
    """The command-line parser."""
    parser = argparse.ArgumentParser(
        prog=PROG, description='The thesis chapter 5 study: the section 5.1 SDOF under each '
        'record with each scheme (ROS-free), compared as in Figures 5.4-5.15.',
        epilog='Records: a study name (elcentro, northridge, kobe), NAME=PATH, or a PATH to '
        'your own record file (PEER .AT2, or a two-column file in g). PEER records are not '
        'shipped. Example: study_ch5 --records elcentro northridge=RSN953_NORTHR_MUL009.AT2 '
        'kobe=RSN1106_KOBE_KJM000.AT2')
    parser.add_argument('--records', nargs='+', metavar='RECORD',
                        help='records to run (default: the study file\'s default_records, '
                        'El Centro)')
    parser.add_argument('--schemes', help='comma-separated schemes, the first is the reference '
                        '(default: newmark_explicit,linear_acceleration)')
    parser.add_argument('--out', help='output folder (default: runs/study_ch5-<UTC time>)')
    parser.add_argument('--config', help='study folder with study.yaml and the test files '
                        '(default: the shipped config/study_ch5)')
    parser.add_argument('--duration', type=_positive, metavar='SECONDS',
                        help='simulate only this long (default: each record\'s duration)')
    parser.add_argument('--no-run-figures', action='store_true',
                        help='skip each run folder\'s own figures (the comparison figures are '
                        'always written)')
    parser.add_argument('--quiet', action='store_true', help='print only errors')
    return parser


def main(argv: list[str] | None = None) -> int:
    """Entry point; 0 when every run finished, 1 if one stopped, 2 on invalid input."""
    args = build_parser().parse_args(argv)

    def say(text: str) -> None:
        if not args.quiet:
            print(text, flush=True)

    try:
        study = load_study(Path(args.config) if args.config else default_study_directory())
        schemes = parse_schemes(args.schemes) if args.schemes else list(study.schemes)
        records = prepare_records(study, args.records, schemes, args.duration)
        out = Path(args.out) if args.out else default_output_directory()
        check_output_directory(out, records)
        if not args.records:
            others = [name for name in study.records if name not in study.default_records]
            if others:
                say(f'(not shipped: {", ".join(others)}; add them with --records '
                    + ' '.join(f'{name}=/path/to/record.AT2' for name in others) + ')')
        results: list[RecordResult] = []
        for record in records:
            result = run_record(record, out, run_figures=not args.no_run_figures,
                                progress=say)
            comparison_figures(result, out / record.label)
            results.append(result)
        rows = [row for result in results for row in peak_rows(result)]
        write_table_csv(rows, out / TABLE_CSV)
        markdown = markdown_table(results, rows)
        (out / TABLE_MD).write_text(markdown, encoding='utf-8')
        (out / STUDY_JSON).write_text(json.dumps(_manifest(study, results, schemes,
                                                           args.duration),
                                                 indent=2, default=str) + '\n', encoding='utf-8')
    except (PdIntegratorError, ValueError) as err:
        print(f'{PROG}: error: {" ".join(str(err).split())}', file=sys.stderr)
        return 2
    except OSError as err:  # an output that cannot be written (a full disk)
        print(f'{PROG}: error: {err.filename or out}: cannot write '
              f'({err.strerror or type(err).__name__})', file=sys.stderr)
        return 1
    say('')
    say(markdown)
    say(f'outputs in {out}')
    finished = all(summary['state'] == 'finished'
                   for result in results for summary in result.summaries.values())
    return 0 if finished else 1


if __name__ == '__main__':
    sys.exit(main())

"""Growth of experimental errors: ``ros2 run pd_studies study_errors`` (``./pd study_errors``).

Shing and Mahin ("Cumulative experimental errors in pseudodynamic tests", Earthquake Eng.
Struct. Dyn. 15, 1987) showed that the errors of a pseudo-dynamic test accumulate through the
step-by-step integration, and that *systematic* errors (an actuator that consistently
undershoots or overshoots the commanded increment) are the harmful ones, while *random* errors
of comparable size (noise) largely average out. This command reproduces that finding on the
default test (thesis section 5.1: the SDOF column under El Centro, Newmark explicit), run
without ROS (:func:`~pd_core.run.runner.run_offline`, the same session and simulated
specimen as the node graph) with errors injected by the simulated specimen
(``specimen.errors``, see :mod:`pd_specimen_sim.core.server`):

* a clean reference run (no error);
* for each level ``f`` (default 1, 2 and 5 %): a systematic **undershoot** (``systematic: -f``)
  and **overshoot** (``systematic: +f``) of every displacement increment;
* for each level ``f``: **random** errors of comparable magnitude, i.e. with the same RMS
  per-step displacement error as the systematic error of that level: ``f`` times the RMS
  displacement increment per step ``δ`` of the clean run, as displacement measurement noise
  (``displacement_noise = f δ``) and, since the integrator only uses the measured *force*, as
  the force noise that a random actuator error of that size produces on the initial stiffness
  (``force_noise = k_ini f δ``); one run per seed (``--seeds``, default 3).

Measures per run (of the first DOF): the peak displacement and its relative error to the clean
run, the RMS of the displacement history's difference to the clean run (relative to the clean
RMS), the energy error (largest and final ``|E_input - E_kinetic - E_viscous - E_strain|`` over
the largest energy term, from ``summary.json``) and the final tracking indicator.

Output folder (``--out``, default ``runs/study_errors-<UTC time>``)::

    errors_table.csv          one row per run (kind, level, the injected errors, the measures)
    errors_summary.csv        per kind and level: the measures (random: mean and max over seeds)
    errors_growth.png         peak-displacement error, response error and energy error against
                              the error level, for undershoot, overshoot and random errors
    errors_response.png       the displacement history of the clean run and of the largest
                              level of each kind, and their differences to the clean run
    study.json                what was run
    runs/<case>/              the run folders (only with --keep-runs)

What the figures show (default test, full record, 3 seeds): the energy error and the RMS
response error grow linearly with the systematic error, to 3.0-3.5 % and 10-12 % at 5 %, while
random errors of the same RMS size reach 0.14 % (the clean run's own is 0.07 %) and 1.2 %:
about 25 and 10 times less. Random errors average out; systematic ones accumulate, step after
step, into a drift of the yielding column's permanent set (about 1.5 mm at 5 %, visible in
``errors_response.png``). The peak displacement (at 4.97 s, early in the record) moves by
0.5-1.7 % at 5 % systematic error against 0.2 % (worst seed 0.3 %) for random errors. An
undershoot lags the command (negative tracking indicator): it feeds energy into the test like
negative damping; an overshoot leads it and removes energy. On the yielding column the peak
does not grow monotonically with the undershoot (the peak follows plastic excursions), which is
why the table also reports the response and energy errors.

Exit status: 0 when every run finished, 1 if a run stopped early, 2 on invalid input.
"""

from __future__ import annotations

import argparse
import csv
import dataclasses
import json
import math
import shutil
import sys
import tempfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from pd_core.errors import ConfigError, PdIntegratorError
from pd_core.plotting import pyplot
from pd_core.run.runner import default_run_directory, run_offline
from pd_core.run.test_file import default_test_file, load_test_file

if TYPE_CHECKING:
    from pd_core.run.definition import TestDefinition
    from pd_core.run.runner import RunResult

PROG = 'study_errors'
TABLE_CSV = 'errors_table.csv'
SUMMARY_CSV = 'errors_summary.csv'
GROWTH_PNG = 'errors_growth.png'
RESPONSE_PNG = 'errors_response.png'
STUDY_JSON = 'study.json'
DEFAULT_LEVELS = (0.01, 0.02, 0.05)
KINDS = ('undershoot', 'overshoot', 'random')
TABLE_COLUMNS = (
    'case', 'kind', 'level', 'seed', 'systematic', 'displacement_noise', 'force_noise',
    'peak_displacement', 'peak_time', 'peak_error', 'response_error', 'energy_error_max',
    'energy_error_final', 'tracking_indicator', 'tracking_error_rms', 'state',
)
SUMMARY_COLUMNS = (
    'kind', 'level', 'runs', 'peak_error', 'peak_error_max', 'response_error',
    'energy_error_max', 'energy_error_final', 'tracking_indicator',
)


@dataclass(frozen=True)
class Case:
    """One run of the study.

    Attributes:
        name: Folder name of the run, e.g. ``undershoot-0.05``.
        kind: ``clean``, ``undershoot``, ``overshoot`` or ``random``.
        level: Error level as a fraction (0 for the clean run).
        errors: The ``specimen.errors`` mapping injected (empty for the clean run).
        seed: Noise seed of a random case, else ``None``.
    """

    name: str
    kind: str
    level: float
    errors: dict[str, Any] = field(default_factory=dict)
    seed: int | None = None


def build_cases(levels: list[float], seeds: int, increment_rms: float, stiffness: float
                ) -> list[Case]:
    """The error cases for each level (the clean run is not included).

    Args:
        levels: Error levels as fractions of the increment, e.g. ``[0.01, 0.02, 0.05]``.
        seeds: Number of random runs (seeds 1..seeds) per level.
        increment_rms: RMS displacement increment per step of the clean run, m.
        stiffness: Initial stiffness turning a displacement error into a force error, N/m.

    Returns:
        Undershoot, overshoot and random cases, level by level.
    """
    cases: list[Case] = []
    for level in levels:
        cases.append(Case(f'undershoot-{level:g}', 'undershoot', level,
                          {'systematic': -level}))
        cases.append(Case(f'overshoot-{level:g}', 'overshoot', level, {'systematic': level}))
        sigma = level * increment_rms
        for seed in range(1, seeds + 1):
            cases.append(Case(f'random-{level:g}-seed{seed}', 'random', level,
                              {'displacement_noise': sigma, 'force_noise': stiffness * sigma,
                               'seed': seed}, seed=seed))
    return cases


def with_errors(definition: TestDefinition, errors: dict[str, Any]) -> TestDefinition:
    """The definition with ``errors`` as the ``errors`` mapping of its specimen section."""
    specimen = {key: value for key, value in (definition.specimen or {}).items()
                if key != 'errors'}
    if errors:
        specimen['errors'] = dict(errors)
    return dataclasses.replace(definition, specimen=specimen)


def measure(case: Case, result: RunResult, clean: np.ndarray | None) -> dict[str, Any]:
    """The table row of one run (``clean``: the clean run's displacement, or ``None``)."""
    history = result.session.history
    x = history.displacement[:history.n_committed, 0]
    summary = result.summary
    dof = history.dof_names[0]
    peak = summary['dofs'][dof]['peaks']['displacement']
    energy = summary.get('energy') or {}
    tracking = summary['tracking']['dofs'][dof]
    row: dict[str, Any] = {
        'case': case.name, 'kind': case.kind, 'level': case.level,
        'seed': '' if case.seed is None else case.seed,
        'systematic': case.errors.get('systematic', 0.0),
        'displacement_noise': case.errors.get('displacement_noise', 0.0),
        'force_noise': case.errors.get('force_noise', 0.0),
        'peak_displacement': peak['abs'], 'peak_time': peak['time'],
        'peak_error': 0.0, 'response_error': 0.0,
        'energy_error_max': energy.get('max_error_ratio', math.nan),
        'energy_error_final': energy.get('final_error_ratio', math.nan),
        'tracking_indicator': tracking['final_indicator'],
        'tracking_error_rms': tracking['rms_error'],
        'state': summary['state'],
    }
    if clean is not None:
        reference = float(np.max(np.abs(clean)))
        rows = min(len(clean), len(x))
        difference = x[:rows] - clean[:rows]
        row['peak_error'] = abs(peak['abs'] - reference) / reference
        row['response_error'] = float(np.sqrt(np.mean(difference ** 2))
                                      / np.sqrt(np.mean(clean[:rows] ** 2)))
    return row


def summarize_rows(rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """Per kind and level: the measures (random cases: mean over seeds, and the worst peak)."""
    clean = [row for row in rows if row['kind'] == 'clean']
    result: list[dict[str, Any]] = []
    for row in clean:
        result.append({'kind': 'clean', 'level': 0.0, 'runs': 1,
                       'peak_error': 0.0, 'peak_error_max': 0.0, 'response_error': 0.0,
                       'energy_error_max': row['energy_error_max'],
                       'energy_error_final': row['energy_error_final'],
                       'tracking_indicator': row['tracking_indicator']})
    levels = sorted({row['level'] for row in rows if row['kind'] != 'clean'})
    for kind in KINDS:
        for level in levels:
            group = [row for row in rows if row['kind'] == kind and row['level'] == level]
            if not group:
                continue

            def mean(key: str, items: list[dict[str, Any]] = group) -> float:
                return float(np.mean([item[key] for item in items]))

            result.append({'kind': kind, 'level': level, 'runs': len(group),
                           'peak_error': mean('peak_error'),
                           'peak_error_max': max(item['peak_error'] for item in group),
                           'response_error': mean('response_error'),
                           'energy_error_max': mean('energy_error_max'),
                           'energy_error_final': mean('energy_error_final'),
                           'tracking_indicator': mean('tracking_indicator')})
    return result


def write_table(rows: list[dict[str, Any]], columns: tuple[str, ...], path: Path) -> Path:
    """Write rows as CSV (floats with 10 significant digits)."""
    with path.open('w', encoding='utf-8', newline='') as stream:
        writer = csv.writer(stream)
        writer.writerow(columns)
        for row in rows:
            writer.writerow([f'{row[key]:.10g}' if isinstance(row[key], float) else row[key]
                             for key in columns])
    return path


def read_table(path: str | Path) -> list[dict[str, Any]]:
    """Read a table written by :func:`write_table` (numbers as floats where they parse)."""
    with Path(path).open(encoding='utf-8', newline='') as stream:
        rows = list(csv.DictReader(stream))
    result: list[dict[str, Any]] = []
    for row in rows:
        parsed: dict[str, Any] = {}
        for key, value in row.items():
            try:
                parsed[key] = float(value)
            except ValueError:
                parsed[key] = value
        result.append(parsed)
    return result


_STYLE = {'undershoot': ('tab:red', 'o', 'systematic undershoot'),
          'overshoot': ('tab:blue', 's', 'systematic overshoot'),
          'random': ('tab:green', '^', 'random (same RMS size)')}


def plot_growth(summary: list[dict[str, Any]], path: Path, *, title: str) -> Path:
    """Peak, response and energy errors against the error level, per kind (``errors_growth``)."""
    plt = pyplot()
    clean = next((row for row in summary if row['kind'] == 'clean'), None)
    panels = (('peak_error', 'Peak displacement error [%]'),
              ('response_error', 'RMS response error [%]'),
              ('energy_error_max', 'Energy error (max) [%]'))
    figure, axes = plt.subplots(1, 3, figsize=(14, 4.5), layout='constrained')
    for item, (key, label) in zip(axes, panels, strict=True):
        for kind in KINDS:
            rows = [row for row in summary if row['kind'] == kind]
            if not rows:
                continue
            color, marker, legend = _STYLE[kind]
            levels = [0.0] + [100.0 * row['level'] for row in rows]
            start = clean[key] if clean is not None else 0.0
            values = [100.0 * start] + [100.0 * row[key] for row in rows]
            item.plot(levels, values, color=color, marker=marker, label=legend)
            if kind == 'random' and key == 'peak_error':
                item.plot(levels, [100.0 * start] + [100.0 * row['peak_error_max']
                                                     for row in rows],
                          color=color, linestyle=':', linewidth=1.0,
                          label='random, worst seed')
        item.set_xlabel('Error level [% of the increment]')
        item.set_ylabel(label)
        item.grid(visible=True, alpha=0.4)
    axes[0].legend(fontsize='small')
    figure.suptitle(f'Growth of experimental errors — {title}')
    figure.savefig(path, dpi=110)
    plt.close(figure)
    return path


def plot_response(histories: dict[str, tuple[np.ndarray, np.ndarray]], path: Path, *,
                  title: str) -> Path:
    """Displacement histories of the clean and the largest-level runs, and the differences."""
    plt = pyplot()
    figure, (top, bottom) = plt.subplots(2, 1, figsize=(10, 6.5), sharex=True,
                                         layout='constrained',
                                         gridspec_kw={'height_ratios': (3, 2)})
    time, clean = histories['clean']
    top.plot(time, 1e3 * clean, color='k', linewidth=1.2, label='clean')
    colors = {'undershoot': 'tab:red', 'overshoot': 'tab:blue', 'random': 'tab:green'}
    for label, (t, x) in histories.items():
        if label == 'clean':
            continue
        color = colors.get(label.split()[0])
        top.plot(t, 1e3 * x, linewidth=0.8, color=color, label=label)
        rows = min(len(x), len(clean))
        bottom.plot(t[:rows], 1e3 * (x[:rows] - clean[:rows]), linewidth=0.8, color=color,
                    label=label)
    top.set_ylabel('Displacement [mm]')
    top.set_title(f'Response with experimental errors — {title}')
    top.legend(fontsize='small')
    bottom.set_ylabel('Difference to clean [mm]')
    bottom.set_xlabel('Time [s]')
    for item in (top, bottom):
        item.grid(visible=True, alpha=0.4)
        item.set_xlim(0.0, float(time[-1]) if time.size else 1.0)
    figure.savefig(path, dpi=110)
    plt.close(figure)
    return path


def run_study(definition: TestDefinition, out: Path, *, levels: list[float], seeds: int,
              keep_runs: bool = False, figures: bool = True,
              progress: Any = None) -> tuple[list[dict[str, Any]], list[dict[str, Any]]]:
    """Run the clean case and every error case; write the tables and figures into ``out``.

    Returns:
        The table rows (one per run) and the summary rows (per kind and level).

    Raises:
        ConfigError: The definition has no ``specimen`` section.
    """
    if definition.specimen is None:
        msg = f'{definition.source}: specimen: section is required for the error study'
        raise ConfigError(msg)
    out.mkdir(parents=True, exist_ok=True)
    runs_root = out / 'runs' if keep_runs else Path(tempfile.mkdtemp(prefix='study_errors-'))
    title = definition.test_id
    rows: list[dict[str, Any]] = []
    histories: dict[str, tuple[np.ndarray, np.ndarray]] = {}
    try:
        clean_case = Case('clean', 'clean', 0.0)
        clean_run = run_offline(with_errors(definition, {}), runs_root / clean_case.name,
                                figures=False)
        history = clean_run.session.history
        clean = history.displacement[:history.n_committed, 0].copy()
        rows.append(measure(clean_case, clean_run, None))
        histories['clean'] = (history.time.copy(), clean)
        increments = np.diff(history.displacement[:history.n_committed], axis=0)
        increment_rms = float(np.sqrt(np.mean(increments ** 2))) if increments.size else 0.0
        stiffness_matrix = clean_run.session.definition.initial_stiffness
        stiffness = (float(np.mean(np.diag(stiffness_matrix)))
                     if stiffness_matrix is not None else 0.0)
        cases = build_cases(levels, seeds, increment_rms, stiffness)
        largest = max(levels) if levels else None
        for index, case in enumerate(cases, start=1):
            if progress is not None:
                progress(f'[{index}/{len(cases)}] {case.name}: {case.errors}')
            result = run_offline(with_errors(definition, case.errors), runs_root / case.name,
                                 figures=False)
            rows.append(measure(case, result, clean))
            if case.level == largest and (case.seed is None or case.seed == 1):
                run_history = result.session.history
                label = f'{case.kind} {100 * case.level:g} %'
                histories[label] = (run_history.time.copy(),
                                    run_history.displacement[:run_history.n_committed,
                                                             0].copy())
    finally:
        if not keep_runs:
            shutil.rmtree(runs_root, ignore_errors=True)
    summary = summarize_rows(rows)
    write_table(rows, TABLE_COLUMNS, out / TABLE_CSV)
    write_table(summary, SUMMARY_COLUMNS, out / SUMMARY_CSV)
    if figures:
        plot_growth(summary, out / GROWTH_PNG, title=title)
        plot_response(histories, out / RESPONSE_PNG, title=title)
    study = {'test_id': definition.test_id, 'source': definition.source,
             'duration': definition.duration, 'dt': definition.dt, 'levels': list(levels),
             'seeds': seeds, 'increment_rms': increment_rms, 'stiffness': stiffness,
             'cases': [{'name': case.name, 'kind': case.kind, 'level': case.level,
                        'errors': case.errors} for case in cases],
             'runs': str(runs_root) if keep_runs else None}
    (out / STUDY_JSON).write_text(json.dumps(study, indent=2) + '\n', encoding='utf-8')
    return rows, summary


def _level(text: str) -> float:
    try:
        value = float(text.rstrip('%')) / (100.0 if text.endswith('%') else 1.0)
    except ValueError:
        msg = f'not a number: {text!r}'
        raise argparse.ArgumentTypeError(msg) from None
    if not 0.0 < value < 1.0:
        msg = f'an error level must be in (0, 1) (or 0-100 %), got {text!r}'
        raise argparse.ArgumentTypeError(msg)
    return value


def main(argv: list[str] | None = None) -> int:
    """Entry point; returns 0 when every run finished, 1 if one stopped, 2 on invalid input."""
    parser = argparse.ArgumentParser(prog=PROG, description=__doc__.splitlines()[0],
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument('test_file', nargs='?',
                        help='YAML test file (default: the thesis section 5.1 test)')
    parser.add_argument('--out', help='output folder (default: runs/study_errors-<UTC time>)')
    parser.add_argument('--duration', type=float,
                        help='shorten the test to this many seconds (default: the record)')
    parser.add_argument('--levels', nargs='+', type=_level, default=list(DEFAULT_LEVELS),
                        help='error levels as fractions or percentages (default: 0.01 0.02 '
                        '0.05)')
    parser.add_argument('--seeds', type=int, default=3,
                        help='random runs (seeds) per level (default: 3)')
    parser.add_argument('--keep-runs', action='store_true',
                        help='keep every run folder under <out>/runs')
    parser.add_argument('--no-figures', action='store_true', help='skip the PNG figures')
    parser.add_argument('--quiet', action='store_true', help='no progress lines')
    args = parser.parse_args(argv)
    if args.seeds < 1:
        parser.error('--seeds must be at least 1')
    try:
        test_file = Path(args.test_file) if args.test_file else default_test_file()
        overrides = {'duration': args.duration} if args.duration is not None else None
        definition = load_test_file(test_file, overrides)
        out = Path(args.out) if args.out else default_run_directory('runs', PROG)
        if (out / TABLE_CSV).exists():
            print(f'{PROG}: error: {out} already holds a study; choose a new --out',
                  file=sys.stderr)
            return 2
        rows, summary = run_study(definition, out, levels=sorted(set(args.levels)),
                                  seeds=args.seeds, keep_runs=args.keep_runs,
                                  figures=not args.no_figures,
                                  progress=None if args.quiet else print)
    except (PdIntegratorError, ValueError) as err:
        print(f'{PROG}: error: {err}', file=sys.stderr)
        return 2
    print(f'{"kind":<11} {"level":>6} {"peak err":>9} {"resp err":>9} {"energy err":>10}')
    for row in summary:
        print(f'{row["kind"]:<11} {100 * row["level"]:5.1f}% {100 * row["peak_error"]:8.3f}% '
              f'{100 * row["response_error"]:8.3f}% {100 * row["energy_error_max"]:9.3f}%')
    print(f'tables and figures in {out}')
    return 0 if all(row['state'] == 'finished' for row in rows) else 1


if __name__ == '__main__':
    sys.exit(main())

"""Batch pre-test simulation: ``ros2 run pd_pretest pretest [TEST_FILE] [options]``.

Runs the test's numerical model (an SDOF specimen: epp, bilinear, pushover, elastic; Newmark
explicit) for every record × scale × ``--vary`` value at once, vectorised across the systems,
and reports per run the actuator's predicted peak stroke, largest increment per step, peak
velocity (increment / the bridge's ``step_duration``) and peak force against the bridge's
limits, plus the records' 5 % response spectra. Writes ``pretest.csv`` (one row per run),
``spectra.csv``, ``spectra.png`` and ``demand.png`` to ``--out`` (default
``runs/pretest-<test id>``). Each run equals ``./pd offline`` of the same test to the last bit.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path
from typing import NoReturn

from pd_common.config import default_bridge_parameter_file
from pd_common.errors import SpecimenError
from pd_core.errors import PdIntegratorError
from pd_core.run.test_file import default_test_file

from .core import (
    BridgeLimits,
    Plan,
    RunOutcome,
    build_plan,
    execute,
    parse_scales,
    parse_variation,
    read_bridge_limits,
)
from .core.figures import plot_demand, plot_spectra
from .core.report import summary_table, write_runs_csv, write_spectra_csv
from .core.spectra import response_spectrum

PROG = 'pretest'
LIMIT_KEYS = ('max_displacement', 'max_increment', 'max_velocity', 'max_force', 'step_duration')


class _Parser(argparse.ArgumentParser):
    """Bad arguments: one line and exit 2 (no usage block)."""

    def error(self, message: str) -> NoReturn:
        print(f'{PROG}: error: {message} (see --help)', file=sys.stderr)
        raise SystemExit(2)


def _parser() -> argparse.ArgumentParser:
    parser = _Parser(prog=PROG, description=__doc__.splitlines()[0])
    parser.add_argument('test_file', nargs='?', help='YAML test file (default: the thesis '
                        'section 5.1 test)')
    parser.add_argument('--records', nargs='+', default=[], metavar='FILE',
                        help="ground motions (.AT2, CSV, ...; default: the test's own record)")
    parser.add_argument('--scales', help='scale factors LO:HI:STEP, a comma list or one value '
                        "(replace ground_motion.scale; default: the test's)")
    parser.add_argument('--vary', action='append', default=[], metavar='NAME=LO:HI:N',
                        help='N values of a test file parameter (dotted path, e.g. '
                        'specimen.elements.0.yield_force); several multiply')
    parser.add_argument('--out', help='output folder (default: runs/pretest-<test id>)')
    parser.add_argument('--bridge', help="the bridge's ROS parameter file (default: "
                        "pd_actuator_bridge's config/bridge.yaml)")
    parser.add_argument('--step-duration', type=float, metavar='S',
                        help="s per actuator step (overrides the bridge's step_duration)")
    parser.add_argument('--limit', action='append', default=[], metavar='NAME=VALUE',
                        help='override a bridge limit (max_displacement, max_increment, '
                        'max_velocity, max_force, step_duration; 0 = off for the last two)')
    parser.add_argument('--workers', type=int, default=min(2, os.cpu_count() or 1),
                        help='processes for large batches (default: up to 2)')
    parser.add_argument('--rows', type=int, default=40, help='runs shown in the table')
    parser.add_argument('--no-figures', action='store_true', help='skip the PNG figures')
    return parser


def _print_summary(plan: Plan, outcomes: list[RunOutcome], limits: BridgeLimits,
                   elapsed: float, n_scales: int, rows: int) -> None:
    system_steps = sum(plan.loads[run.load_key].n_steps for run in plan.runs)
    counts = f'{len(plan.records)} record(s) × {n_scales} scale(s)'
    for variation in plan.variations:
        counts += f' × {len(variation.values)} {variation.name}'
    print(f'{plan.test_id}: {len(outcomes)} runs ({counts}), {plan.scheme}, '
          f'{system_steps:,} system-steps in {elapsed:.3f} s '
          f'({system_steps / max(elapsed, 1e-9):.3g} system-steps/s)')
    print(summary_table(plan, outcomes, limits, max_rows=rows), flush=True)


def main(argv: list[str] | None = None) -> int:
    """Entry point: 0 when every run was simulated, 2 on invalid or unsupported input."""
    args = _parser().parse_args(argv)
    try:
        test_file = Path(args.test_file) if args.test_file else default_test_file()
        scales = parse_scales(args.scales) if args.scales is not None else None
        variations = [parse_variation(text) for text in args.vary]
        if args.workers < 1:
            msg = f'--workers: must be >= 1, got {args.workers}'
            raise ValueError(msg)
        plan = build_plan(test_file, records=args.records, scales=scales, variations=variations)
        overrides: list[tuple[dict[str, object] | None, str]] = []
        limit_overrides: dict[str, object] = {}
        for text in args.limit:
            name, sep, value = text.partition('=')
            try:
                limit_overrides[name.strip()] = float(value)
            except ValueError:
                sep = ''
            if not sep or name.strip() not in LIMIT_KEYS:
                msg = (f'--limit: expected NAME=VALUE with NAME one of {", ".join(LIMIT_KEYS)}, '
                       f'got {text!r}')
                raise ValueError(msg)
        if limit_overrides:
            overrides.append((limit_overrides, '--limit'))
        if args.step_duration is not None:
            overrides.append(({'step_duration': args.step_duration}, '--step-duration'))
        bridge = Path(args.bridge) if args.bridge else default_bridge_parameter_file()
        limits = read_bridge_limits(bridge, *overrides)
        for warning in plan.warnings:
            print(f'{PROG}: warning: {warning}', file=sys.stderr)
        start = time.perf_counter()
        outcomes = execute(plan, limits, workers=args.workers)
        elapsed = time.perf_counter() - start
        out = Path(args.out) if args.out else Path('runs') / f'pretest-{plan.test_id}'
        out.mkdir(parents=True, exist_ok=True)
        write_runs_csv(plan, outcomes, out / 'pretest.csv')
        spectra = [response_spectrum(r.motion.acceleration, r.motion.dt) for r in plan.records]
        write_spectra_csv(plan, spectra, out / 'spectra.csv')
        _print_summary(plan, outcomes, limits, elapsed, len(scales or [0]), args.rows)
        if not args.no_figures:
            period = plan.structures[plan.runs[0].structure_key].period
            plot_spectra(plan, spectra, period, out / 'spectra.png')
            plot_demand(plan, outcomes, limits, out / 'demand.png')
    except (PdIntegratorError, SpecimenError, ValueError, OSError) as err:
        print(f'{PROG}: error: {err}', file=sys.stderr)
        return 2
    print(f'outputs in {out}')
    return 0


if __name__ == '__main__':
    sys.exit(main())

"""The vRTHS benchmark problem: ``ros2 run pd_rths_benchmark rths_benchmark [options]``.

Runs the virtual real-time hybrid simulation benchmark (Silva, Dyke et al., MSSP 2020): the
three-storey frame of Case 1–4 partitioned into a numerical substructure and a physical
spring–mass–damper on floor 1 behind the benchmark's transfer system (servo-valve, actuator,
control–structure interaction), at 4096 Hz, under a record ×``--intensity`` with 5 s of
zeros before and after (added only where the record does not hold them: the benchmark's own
``.mat`` records carry them and run as they are, to their last time). ``--loop benchmark``
is the benchmark's own model (RK4, one-sample force delay); ``--loop native`` couples the
same plant to this project's integrator and step protocol. Prints J1–J9 and writes
``j_values.json``, ``histories.csv`` and the figures ``tracking.png`` (x_d vs x_m) and
``floors.png`` (each floor against the reference) to ``--out``; with ``--perturbed N`` also
the mean, std and worst of each J over N perturbed plants (``perturbed.csv``).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path
from typing import NoReturn

import numpy as np

from pd_common.errors import RthsError, SpecimenError
from pd_common.rths import compensator_names
from pd_common.rths.compensation import DEFAULT_COMPENSATOR
from pd_core.errors import PdIntegratorError

from .core.benchmark import (
    DEFAULT_RECORD_UNITS,
    BenchmarkOptions,
    BenchmarkRecord,
    j_table,
    load_record,
    perturbed_csv,
    perturbed_statistics,
    run_benchmark,
    statistics_table,
    write_test_file,
)

PROG = 'rths_benchmark'
#: The largest peak ground acceleration ``--intensity`` may give the record [m/s²]: 100 g, far
#: beyond any earthquake (a larger one only overflows the floats of the loop on its way).
MAX_PEAK_ACCELERATION = 100.0 * 9.81


class _Parser(argparse.ArgumentParser):
    """Bad arguments: one line and exit 2 (no usage block)."""

    def error(self, message: str) -> NoReturn:
        print(f'{PROG}: error: {message} (see --help)', file=sys.stderr)
        raise SystemExit(2)


def _parser() -> argparse.ArgumentParser:
    parser = _Parser(prog=PROG, description=__doc__.splitlines()[0])
    parser.add_argument('--case', type=int, default=1, choices=(1, 2, 3, 4),
                        help='benchmark case: structure mass and damping (default 1)')
    parser.add_argument('--record', help='ground motion (two-column CSV/text, .AT2, or a '
                        'MATLAB .mat with rows [time; acceleration m/s2]; default: the '
                        'shipped El Centro 1940 NS)')
    parser.add_argument('--units', choices=('g', 'm/s2'),
                        help=f'units of --record (default {DEFAULT_RECORD_UNITS} for text '
                        'files; .mat files are m/s2, .AT2 g)')
    parser.add_argument('--intensity', type=float, default=0.4,
                        help='factor on the record (default 0.4, the benchmark\'s)')
    parser.add_argument('--controller',
                        help=f'tracking controller / delay compensator: '
                        f'{", ".join(compensator_names())} (default {DEFAULT_COMPENSATOR}, '
                        'none with --ideal; pi_p is the benchmark\'s example)')
    parser.add_argument('--set', action='append', default=[], metavar='NAME=VALUE',
                        help='a parameter of the controller (repeatable)')
    parser.add_argument('--loop', choices=('benchmark', 'native'), default='benchmark',
                        help="the benchmark's own model, or this project's integrator "
                        '(default benchmark)')
    parser.add_argument('--dt', type=float, default=1.0 / 1024.0,
                        help='native loop: the integration step, a whole multiple of 1/4096 s '
                        '(default 1/1024)')
    parser.add_argument('--scheme', default='newmark_explicit',
                        help='native loop: the integration scheme (default newmark_explicit)')
    parser.add_argument('--interpolation', choices=('linear', 'cubic'), default='cubic',
                        help='native loop: predictor-corrector polynomial of the targets '
                        '(default cubic)')
    parser.add_argument('--ideal', action='store_true',
                        help='an ideal transfer system without sensor noise or converters: '
                        'x_m = x_d at every sample, no delay (benchmark loop: the perfect '
                        'actuator x_m = u = x_d; native loop: the ideal plant behind the '
                        "next sample's target); the loop's own error; controller none")
    parser.add_argument('--perturbed', type=int, default=0, metavar='N',
                        help='also run N perturbed plants (the benchmark\'s distributions)')
    parser.add_argument('--seed', type=int, default=0,
                        help='seed of the perturbed plants and of the sensor noise (default 0)')
    parser.add_argument('--out', help='output folder (default runs/rths-case<N>-<controller>'
                        '-<loop>)')
    parser.add_argument('--no-figures', action='store_true', help='skip the PNG figures')
    parser.add_argument('--write-test', metavar='FILE',
                        help='write the native loop as a test file (for ./pd run FILE --site '
                        'bridge: the bridge runs the transfer system) and exit')
    return parser


def _controller_parameters(texts: list[str]) -> dict[str, object]:
    parameters: dict[str, object] = {}
    for text in texts:
        name, sep, value = text.partition('=')
        if not sep or not name.strip():
            msg = f'--set: expected NAME=VALUE, got {text!r}'
            raise ValueError(msg)
        parsed: object
        lowered = value.strip().lower()
        if lowered in ('true', 'false'):
            parsed = lowered == 'true'
        else:
            try:
                parsed = int(value)
            except ValueError:
                try:
                    parsed = float(value)
                except ValueError:
                    parsed = value.strip()
        parameters[name.strip()] = parsed
    return parameters


def _check_intensity(intensity: float, record: BenchmarkRecord) -> None:
    """Refuse an ``--intensity`` that takes the record's peak too high.

    Refuse an ``--intensity`` that takes the record's peak beyond
    :data:`MAX_PEAK_ACCELERATION` (one line, before anything runs).

    Raises:
        ValueError: naming ``--intensity``, the record's peak and the bound.
    """
    peak = float(np.max(np.abs(record.acceleration))) if record.acceleration.size else 0.0
    scaled = intensity * peak  # (a float product: inf past the largest float, no warning)
    if not scaled <= MAX_PEAK_ACCELERATION:
        msg = (f"--intensity: {intensity:g} takes the record's peak {peak:.4g} m/s2 to "
               f'{scaled:.4g} m/s2; at most {MAX_PEAK_ACCELERATION:g} m/s2 (100 g)')
        raise ValueError(msg)


def _number(value: float) -> float | None:
    """A finite value, or ``None`` (JSON null: a criterion of a run that stopped at rest)."""
    return float(value) if math.isfinite(value) else None


#: Most perturbed plants of one run (each a whole benchmark run; the tables use 20).
MAX_PERTURBED = 10_000


def main(argv: list[str] | None = None) -> int:
    """Entry point; returns the exit status.

    Entry point: 0 when the run is valid, 1 if the actuator's capacity was reached, 2 on
    invalid input.
    """
    args = _parser().parse_args(argv)
    if args.controller is None:
        args.controller = 'none' if args.ideal else DEFAULT_COMPENSATOR
    try:
        if not 0 <= args.perturbed <= MAX_PERTURBED:
            msg = f'--perturbed: must be 0 to {MAX_PERTURBED:,} plants, got {args.perturbed:,}'
            raise ValueError(msg)
        if args.ideal and args.perturbed:
            msg = '--perturbed: an ideal transfer system has no perturbed plants'
            raise ValueError(msg)
        options = BenchmarkOptions(
            case=args.case, intensity=args.intensity, controller=args.controller,
            controller_parameters=_controller_parameters(args.set), loop=args.loop,
            seed=args.seed, integration_dt=args.dt, scheme=args.scheme,
            interpolation=args.interpolation, ideal=args.ideal)
        record = load_record(args.record, args.units)
        _check_intensity(options.intensity, record)
        if args.write_test:
            try:
                path = write_test_file(options, record, Path(args.write_test))
            except FileExistsError:
                msg = f'--write-test {args.write_test}: exists already (never replaced)'
                raise ValueError(msg) from None
            print(f'wrote {path}: ./pd run {path} --site bridge')
            return 0
        out = Path(args.out) if args.out else Path('runs') / (
            f'rths-case{args.case}-{args.controller}-{args.loop}')
        start = time.perf_counter()
        # A diverging run overflows on its way: it is reported as invalid, not with warnings.
        np.seterr(over='ignore', invalid='ignore')
        nominal = run_benchmark(options, record)
        elapsed = time.perf_counter() - start
        out.mkdir(parents=True, exist_ok=True)
        values: dict[str, float | None] = {key: _number(value)
                                           for key, value in nominal.j.items()}
        values['noise_floor_percent'] = nominal.noise_floor_percent
        document: dict[str, object] = {
            **values,
            'case': args.case, 'controller': args.controller,
            'controller_parameters': nominal.controller_parameters, 'loop': args.loop,
            'record': record.source, 'intensity': args.intensity, 'seed': args.seed,
            'capacity_reached': nominal.capacity_reached,
            'peak_actuator_force': nominal.peak_force, 'completed': nominal.completed,
            'state': nominal.state,
        }
        if args.loop == 'native':
            document.update(integration_dt=args.dt, scheme=args.scheme,
                            interpolation=args.interpolation)
        if args.ideal:
            document['ideal'] = True
        print(f'case {args.case}, {record.source} ×{args.intensity:g}, controller '
              f'{args.controller}, loop {args.loop}: {nominal.samples:,} samples in '
              f'{elapsed:.2f} s')
        print(j_table({'nominal': nominal.j}, nominal.noise_floor_percent))
        if args.perturbed:
            runs = [run_benchmark(options, record, perturbed=index)
                    for index in range(args.perturbed)]
            stats = perturbed_statistics(runs)
            document['perturbed'] = {
                'n': args.perturbed, 'seed': args.seed,
                **{key: {name: _number(value) for name, value in row.items()}
                   for key, row in stats.items()}}
            print(f'{args.perturbed} perturbed plants (seed {args.seed}):')
            print(statistics_table(stats))
            (out / 'perturbed.csv').write_text(perturbed_csv(runs), encoding='utf-8')
        (out / 'j_values.json').write_text(json.dumps(document, indent=2) + '\n',
                                           encoding='utf-8')
        nominal.write_histories(out / 'histories.csv')
        if not args.no_figures:
            from .core.figures import plot_floors, plot_tracking  # noqa: PLC0415

            plot_tracking(nominal, out / 'tracking.png')
            plot_floors(nominal, out / 'floors.png')
    except (PdIntegratorError, SpecimenError, RthsError, ValueError, OSError) as err:
        print(f'{PROG}: error: {err}', file=sys.stderr)
        return 2
    except ArithmeticError as err:  # a diverging loop past the largest float
        print(f'{PROG}: error: the run overflowed ({err}); lower --intensity', file=sys.stderr)
        return 1
    if not nominal.completed:
        print(f'the run did not finish: {nominal.state}')
    if nominal.capacity_reached:
        print(f'INVALID: the actuator reached its capacity (peak {nominal.peak_force:.0f} N)')
    print(f'outputs in {out}')
    return 1 if nominal.capacity_reached else 0


if __name__ == '__main__':
    sys.exit(main())

"""The vRTHS benchmark's J tables for every compensator, case and loop (docs/rths.md).

Run inside the sourced workspace (``. scripts/env.sh``)::

    python bench/rths_tables.py [--cases 1,2,3,4] [--loops benchmark,native]
                                [--compensators pi_p,polynomial,model_based,adaptive]
                                [--perturbed 20] [--perturbed-compensators model_based,adaptive]
                                [--seed 0] [--jobs 2] [--markdown FILE]

Every run is :func:`pd_rths_benchmark.core.benchmark.run_benchmark` (what
``./pd rths_benchmark`` runs): El Centro 1940 NS ×0.4 with 5 s of zeros before and after, the
benchmark's sensor noise (seed ``--seed``), converters and capacity. It prints (and writes as
markdown with ``--markdown``):

1. the nominal plant: J1 (ms) … J9 (%), the noise floor, J2 / floor, J4 / floor and the peak
   actuator force (``*``: the capacity was reached, the run is invalid);
2. ``--perturbed`` plants of the seed: mean / std / worst of J2, the worst J2 / floor, the
   worst J4 and J6–J9, the largest J1 and the runs that reached the capacity;
3. the ideal plant (x_m = u, no noise, controller ``none``) in the native loop at
   Δt_int = 1/256 … 1/4096 s: J4–J9 and the observed order of convergence; and the same plant
   in the benchmark's loop (its one-sample force delay and backward differences).

A measurement, not a test: it asserts nothing.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time
from collections.abc import Sequence
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

from pd_rths_benchmark.core.benchmark import BenchmarkOptions, load_record, run_benchmark
from pd_rths_benchmark.core.criteria import J_KEYS

Job = tuple[str, int, str, int | None, float, bool]   # loop, case, controller, plant, dt, ideal


def _run(job: Job) -> tuple[Job, dict[str, float], float, float, bool]:
    loop, case, controller, perturbed, dt, ideal = job
    np.seterr(over='ignore', invalid='ignore')
    options = BenchmarkOptions(case=case, controller=controller, loop=loop, integration_dt=dt,
                               ideal=ideal, seed=_SEED)
    run = run_benchmark(options, load_record(None), perturbed)
    return job, run.j, run.noise_floor_percent, run.peak_force, run.capacity_reached


_SEED = 0


def _init(seed: int) -> None:
    global _SEED  # the worker's seed, set once per process
    _SEED = seed


def _f(value: float, digits: int = 3) -> str:
    return f'{value:.{digits}f}' if math.isfinite(value) else 'n/a'


def _table(header: Sequence[str], rows: list[list[str]]) -> str:
    lines = ['| ' + ' | '.join(header) + ' |', '|' + '---|' * len(header)]
    lines += ['| ' + ' | '.join(row) + ' |' for row in rows]
    return '\n'.join(lines)


def main(argv: list[str] | None = None) -> int:
    """Run the tables and print them."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--cases', default='1,2,3,4')
    parser.add_argument('--loops', default='benchmark,native')
    parser.add_argument('--compensators', default='pi_p,polynomial,model_based,adaptive')
    parser.add_argument('--perturbed', type=int, default=20)
    parser.add_argument('--perturbed-compensators', default='pi_p,model_based,adaptive')
    parser.add_argument('--seed', type=int, default=0)
    parser.add_argument('--jobs', type=int, default=os.cpu_count() or 1)
    parser.add_argument('--markdown', help='also write the tables to this file')
    parser.add_argument('--no-ideal', action='store_true', help='skip the ideal-plant table')
    args = parser.parse_args(argv)
    cases = [int(c) for c in args.cases.split(',')]
    loops = args.loops.split(',')
    controllers = args.compensators.split(',')
    perturbed_controllers = [c for c in args.perturbed_compensators.split(',') if c]
    dt = 1.0 / 1024.0
    jobs: list[Job] = [(loop, case, c, None, dt, False)
                       for loop in loops for case in cases for c in controllers]
    jobs += [(loop, case, c, i, dt, False) for loop in loops for case in cases
             for c in perturbed_controllers if not (loop == 'native' and c == 'pi_p')
             for i in range(args.perturbed)]
    divisors = (256, 512, 1024, 2048, 4096)
    if not args.no_ideal:
        jobs += [('native', 1, 'none', None, 1.0 / d, True) for d in divisors]
        jobs += [('benchmark', case, 'none', None, dt, True) for case in cases]
    start = time.perf_counter()
    with ProcessPoolExecutor(max_workers=args.jobs, initializer=_init,
                             initargs=(args.seed,)) as pool:
        results = list(pool.map(_run, jobs))
    elapsed = time.perf_counter() - start
    by_job = {job: rest for job, *rest in results}
    summary = (f'El Centro 1940 NS x0.4, noise seed {args.seed}, perturbed plants of seed '
               f'{args.seed}; native loop at dt_int = 1/1024 s, Newmark explicit, cubic '
               f'predictor-corrector ({len(jobs)} runs in {elapsed:.0f} s)')
    out: list[str] = [summary]
    header = ['loop', 'case', 'controller', *[f'{k}' for k in J_KEYS], 'floor', 'J2/floor',
              'J4/floor', 'peak N']
    rows = []
    for loop in loops:
        for case in cases:
            for c in controllers:
                j, floor, peak, invalid = by_job[(loop, case, c, None, dt, False)]
                rows.append([loop, str(case), c, *[_f(j[k]) for k in J_KEYS], _f(floor),
                             _f(j['J2'] / floor, 2), _f(j['J4'] / floor, 2),
                             f'{peak:.0f}' + ('*' if invalid else '')])
    out += ['', '### Nominal plant', '', _table(header, rows)]
    if args.perturbed and perturbed_controllers:
        header = ['loop', 'case', 'controller', 'J2 mean', 'J2 std', 'J2 worst',
                  'worst J2/floor', 'worst J4', 'worst J6-J9', 'worst J1 ms', 'invalid runs']
        rows = []
        for loop in loops:
            for case in cases:
                for c in perturbed_controllers:
                    if loop == 'native' and c == 'pi_p':
                        continue
                    runs = [by_job[(loop, case, c, i, dt, False)] for i in range(args.perturbed)]
                    j2 = np.array([r[0]['J2'] for r in runs])
                    ratio = max(r[0]['J2'] / r[1] for r in runs)
                    rows.append([
                        loop, str(case), c, _f(float(j2.mean())), _f(float(j2.std(ddof=1))),
                        _f(float(j2.max())), _f(ratio, 3),
                        _f(max(r[0]['J4'] for r in runs)),
                        _f(max(max(r[0][k] for k in ('J6', 'J7', 'J8', 'J9')) for r in runs)),
                        _f(max(r[0]['J1'] for r in runs)), str(sum(r[3] for r in runs))])
        out += ['', f'### {args.perturbed} perturbed plants (seed {args.seed})', '',
                _table(header, rows)]
    if not args.no_ideal:
        header = ['dt_int', *J_KEYS[3:], 'order (J6)']
        rows = []
        previous = None
        for d in divisors:
            j = by_job[('native', 1, 'none', None, 1.0 / d, True)][0]
            order = (_f(math.log2(previous / j['J6']), 2)
                     if previous is not None and j['J6'] > 0 else '')
            previous = j['J6']
            rows.append([f'1/{d} s', *[_f(j[k], 4) for k in J_KEYS[3:]], order])
        out += ['', '### Ideal plant, native loop (case 1, controller none)', '',
                _table(header, rows)]
        header = ['case', *J_KEYS]
        rows = [[str(case), *[_f(by_job[('benchmark', case, 'none', None, dt, True)][0][k])
                              for k in J_KEYS]] for case in cases]
        out += ['', "### Ideal plant, the benchmark's loop (controller none)", '',
                _table(header, rows)]
    text = '\n'.join(out) + '\n'
    print(text)
    if args.markdown:
        Path(args.markdown).write_text(text, encoding='utf-8')
    return 0


if __name__ == '__main__':
    sys.exit(main())

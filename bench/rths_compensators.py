"""The compensators of the bridge's control layer on the vRTHS benchmark: prints J tables.

Run inside the sourced workspace (``. scripts/env.sh``)::

    python bench/rths_compensators.py [--cases 1,2,3,4] [--perturbed 20] [--jobs 2]
                                      [--compensators none,pi_p,...]

In the benchmark's own loop (``pd_integrator.core.rths.benchmark_loop``: RK4 at 4096 Hz, the
benchmark's sensor noise, 2⁻¹⁸ m converters, 8,900 N capacity), El Centro 1940 NS ×0.4 with
5 s of zeros before and after, each registered compensator at its defaults:

1. per case, the nominal plant: J1 (ms) … J9 (%), the noise floor (%), J2 / floor and the
   peak actuator force (N, ``*`` if the capacity was reached);
2. per case, ``--perturbed`` plants (``BenchmarkPlantParameters.perturbed`` drawn in sequence
   from ``numpy.random.default_rng(0)``; the specimen of each is its drawn ``k_e``): the mean,
   std and worst of J2, the mean floor, the worst J2 / floor, the worst peak force and the
   largest J1.

The floor is 100 σ_noise / std(x_d) of the run (the J2 no controller can go below).

A measurement, not a test: it asserts nothing. About 3-4 minutes on 2 cores with the defaults.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time
import warnings
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

from pd_common.rths import (
    BENCHMARK_CAPACITY,
    BENCHMARK_NOISE,
    BENCHMARK_QUANTUM,
    make_compensator,
)
from pd_common.rths.compensation import DEFAULT_COMPENSATOR
from pd_common.rths.plant import BenchmarkPlant, BenchmarkPlantParameters
from pd_integrator.core.rths.benchmark_loop import run_benchmark_loop
from pd_integrator.core.rths.criteria import J_KEYS, j_criteria, noise_floor_percent
from pd_integrator.core.rths.problem import (
    benchmark_case,
    prepare_ground_motion,
    reference_response,
)

DT = 1.0 / 4096.0
RECORD = (Path(__file__).resolve().parents[1]
          / 'src/pd_integrator/data/ground_motions/elcentro_1940_ns_chopra.csv')
COMPENSATORS = ('none', 'pi_p', 'polynomial', 'model_based', 'adaptive')
#: Shown instead of a J of a run that diverged.
UNSTABLE = 1e6


def _ground_motion() -> tuple[np.ndarray, np.ndarray]:
    data = np.loadtxt(RECORD, delimiter=',', comments='#')
    return prepare_ground_motion(data[:, 1] * 9.80665, float(data[1, 0] - data[0, 0]), 0.4)


def _run(job: tuple[str, int, int]) -> tuple[str, int, int, dict[str, float]]:
    """One run: (compensator, case, plant index; −1 the nominal plant) → its J's."""
    name, case_number, index = job
    t, ag = _ground_motion()
    if index < 0:
        params = BenchmarkPlantParameters.nominal()
    else:
        rng = np.random.default_rng(0)
        for _ in range(index + 1):
            params = BenchmarkPlantParameters.perturbed(rng)
    case = benchmark_case(case_number)
    reference = reference_response(case, t, ag)
    with warnings.catch_warnings(), np.errstate(all='ignore'):
        warnings.simplefilter('ignore')
        result = run_benchmark_loop(case, t, ag, make_compensator(name, DT),
                                    BenchmarkPlant(DT, params), params.specimen,
                                    BENCHMARK_NOISE, BENCHMARK_QUANTUM, BENCHMARK_CAPACITY)
        j = j_criteria(result.x_d, result.x_m, result.floors, reference, DT)
    j = {k: (v if math.isfinite(v) and v < UNSTABLE else math.inf) for k, v in j.items()}
    j['floor'] = noise_floor_percent(BENCHMARK_NOISE.displacement_std(DT), result.x_d)
    j['peak'] = result.peak_force if math.isfinite(result.peak_force) else math.inf
    j['capacity'] = float(result.capacity_reached)
    if not all(math.isfinite(v) for v in j.values()):    # diverged: no floor or peak to print
        j['floor'] = j['peak'] = math.inf
    return name, case_number, index, j


def _ratio(j: dict[str, float]) -> float:
    """J2 / floor (inf for a run that diverged)."""
    return j['J2'] / j['floor'] if math.isfinite(j['floor']) else math.inf


def _fmt(value: float, width: int = 8, digits: int = 3) -> str:
    return f'{"unstable":>{width}}' if not math.isfinite(value) else f'{value:{width}.{digits}f}'


def main(argv: list[str] | None = None) -> int:
    """Run the benchmark and print the tables."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--cases', default='1,2,3,4', help='cases, comma-separated')
    parser.add_argument('--perturbed', type=int, default=20, help='perturbed plants per case')
    parser.add_argument('--compensators', default=','.join(COMPENSATORS))
    parser.add_argument('--jobs', type=int, default=os.cpu_count() or 1)
    args = parser.parse_args(argv)
    cases = [int(c) for c in args.cases.split(',')]
    names = args.compensators.split(',')
    jobs = [(n, c, i) for c in cases for n in names for i in range(-1, args.perturbed)]
    start = time.monotonic()
    with ProcessPoolExecutor(max_workers=max(1, args.jobs)) as pool:
        results = {(n, c, i): j for n, c, i, j in pool.map(_run, jobs, chunksize=4)}
    print(f'vRTHS benchmark loop, El Centro x0.4, 4096 Hz, benchmark noise/quantum/capacity; '
          f'default compensator: {DEFAULT_COMPENSATOR}')
    head = ' '.join(f'{k:>8}' for k in J_KEYS)
    for c in cases:
        print(f'\nCase {c}, nominal plant (J1 ms, J2-J9 %)')
        print(f'{"":12} {head} {"floor":>8} {"J2/floor":>8} {"peak N":>8}')
        for n in names:
            j = results[(n, c, -1)]
            row = ' '.join(_fmt(j[k]) for k in J_KEYS)
            flag = '*' if j['capacity'] else ' '
            print(f'{n:12} {row} {_fmt(j["floor"])} {_fmt(_ratio(j))} '
                  f'{_fmt(j["peak"], 8, 0)}{flag}')
    if args.perturbed:
        for c in cases:
            print(f'\nCase {c}, {args.perturbed} perturbed plants (rng seed 0): J2 %')
            print(f'{"":12} {"mean":>8} {"std":>8} {"worst":>8} {"floor":>8} '
                  f'{"worst/fl":>8} {"peak N":>8} {"J1 max":>8}')
            for n in names:
                runs = [results[(n, c, i)] for i in range(args.perturbed)]
                j2 = np.array([r['J2'] for r in runs])
                floor = float(np.mean([r['floor'] for r in runs]))
                ratio = max(_ratio(r) for r in runs)
                stable = bool(np.all(np.isfinite(j2)))
                mean = float(np.mean(j2)) if stable else math.inf
                std = float(np.std(j2)) if stable else math.inf
                worst = float(np.max(j2))
                peak = max(r['peak'] for r in runs)
                flag = '*' if any(r['capacity'] for r in runs) else ' '
                j1 = max(r['J1'] for r in runs)
                print(f'{n:12} {_fmt(mean)} {_fmt(std)} {_fmt(worst)} {_fmt(floor)} '
                      f'{_fmt(ratio)} {_fmt(peak, 8, 0)}{flag}{_fmt(j1)}')
    print(f'\n({len(jobs)} runs in {time.monotonic() - start:.0f} s; * = capacity reached)')
    return 0


if __name__ == '__main__':
    sys.exit(main())

"""Benchmark of the batch pre-test (``./pd pretest``): system-steps per second.

Run inside the sourced workspace (``. scripts/env.sh``)::

    python bench/bench_pretest.py [--quick] [--systems 10000] [--workers 2]

A measurement, not a test: it asserts nothing. For each element model — the EPP SDOF of the
issue-13 core benchmark (m 1 kg, k 39.478 N/m, c 0.251 N s/m, u_y 0.025 m), the same as a
softening bilinear (b = −0.05, residual force 0.3 F_y) and as the thesis's pushover hysteresis
(bilinear backbone, b = 0.01) — ``--systems`` systems (100 scale factors 0.5–1.5 of El Centro ×
yield forces ±20 %) under El Centro at its own dt = 0.02 s (1,559 steps), Newmark explicit,
integrated by :func:`pd_pretest.core.integrate` (building the vectorised model from
the scalar models included), best of 3, in one process and in ``--workers`` processes.

Figures (printed, and merged into ``bench/results.json``; other keys are kept):
``pretest_<model>_system_steps_per_s`` (``--workers`` processes) and
``pretest_<model>_system_steps_per_s_1proc``, for model ``epp``, ``bilinear``, ``pushover``;
``pretest_system_steps_per_s``: the smallest of the three (the goal: >= 1e7 on 2 cores).
"""

from __future__ import annotations

import argparse
import os
import time
from pathlib import Path

import numpy as np

from _results import RESULTS, merge_results
from pd_common.specimen import (
    BilinearKinematic,
    ElasticPerfectlyPlastic,
    HysteresisModel,
    PushoverHysteresis,
    bilinear_backbone,
)
from pd_core.dynamics.record_readers import read_ground_motion
from pd_pretest.core import BatchSystems, integrate

REPO = Path(__file__).resolve().parents[1]
RECORD = (REPO / 'src' / 'pd_integrator' / 'data' / 'ground_motions'
          / 'elcentro_1940_ns_chopra.csv')
MASS, STIFFNESS, DAMPING, YIELD_DISPLACEMENT = 1.0, 39.478, 0.251, 0.025
SCALES = 100
GOAL = 1.0e7


def _models(kind: str, yield_forces: np.ndarray) -> list[HysteresisModel]:
    if kind == 'epp':
        return [ElasticPerfectlyPlastic(STIFFNESS, fy) for fy in yield_forces]
    if kind == 'bilinear':
        return [BilinearKinematic(STIFFNESS, fy, -0.05, 0.3 * fy) for fy in yield_forces]
    return [PushoverHysteresis(bilinear_backbone(STIFFNESS, fy, 0.01, 1.0))
            for fy in yield_forces]


def _systems(n: int, ground: np.ndarray, dt: float) -> BatchSystems:
    scales = np.linspace(0.5, 1.5, SCALES)
    return BatchSystems(mass=np.full(n, MASS), damping=np.full(n, DAMPING),
                        load_factor=np.full(n, MASS), motions=np.outer(ground, scales),
                        motion_index=np.arange(n) % SCALES, dt=dt)


def measure(kind: str, n: int, workers: int, repeats: int, ground: np.ndarray, dt: float
            ) -> tuple[float, float]:
    """Best system-steps/s over ``repeats`` and the largest peak (a sanity figure)."""
    fy = STIFFNESS * YIELD_DISPLACEMENT * np.repeat(np.linspace(0.8, 1.2, -(-n // SCALES)),
                                                    SCALES)[:n]
    models = _models(kind, fy)
    systems = _systems(n, ground, dt)
    best = float('inf')
    peak = 0.0
    for _ in range(repeats):
        start = time.perf_counter()
        result = integrate(systems, models, workers=workers)
        best = min(best, time.perf_counter() - start)
        peak = float(np.max(result.peak_displacement))
    return n * systems.n_steps / best, peak


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--quick', action='store_true', help='1 repeat instead of 3')
    parser.add_argument('--systems', type=int, default=10_000)
    parser.add_argument('--workers', type=int, default=min(2, os.cpu_count() or 1))
    parser.add_argument('--no-save', action='store_true', help='do not write results.json')
    args, _ = parser.parse_known_args()  # ./pd bench passes every bench the same options
    motion = read_ground_motion(RECORD, units='g', g=9.81)
    ground = motion.acceleration
    repeats = 1 if args.quick else 3
    figures: dict[str, float] = {}
    rows = []
    for kind in ('epp', 'bilinear', 'pushover'):
        one, peak = measure(kind, args.systems, 1, repeats, ground, motion.dt)
        many, _ = measure(kind, args.systems, args.workers, repeats, ground, motion.dt)
        figures[f'pretest_{kind}_system_steps_per_s_1proc'] = round(one)
        figures[f'pretest_{kind}_system_steps_per_s'] = round(many)
        rows.append((kind, one, many, peak))
    figures['pretest_system_steps_per_s'] = min(figures[f'pretest_{k}_system_steps_per_s']
                                                for k in ('epp', 'bilinear', 'pushover'))
    steps = ground.size - 1
    print(f'pretest: {args.systems:,} SDOF systems x El Centro ({steps} steps at dt '
          f'{motion.dt:g} s), Newmark explicit, best of {repeats}')
    print(f'{"model":<10} {"1 process":>14} {f"{args.workers} processes":>14} '
          f'{"us/step":>9} {"max peak m":>11}')
    for kind, one, many, peak in rows:
        print(f'{kind:<10} {one:14.3g} {many:14.3g} {args.systems / many * 1e6:9.1f} '
              f'{peak:11.5f}')
    value = figures['pretest_system_steps_per_s']
    verdict = 'met' if value >= GOAL else 'NOT met'
    print(f'pretest_system_steps_per_s = {value:.3g} (goal >= {GOAL:.0e}: {verdict})')
    if not args.no_save:
        merge_results(figures)
        print(f'merged into {RESULTS.relative_to(REPO)}')


if __name__ == '__main__':
    main()

"""The implicit scheme's history error against the implicit (Newton) solution, per iterations.

    python bench/iterations_table.py [--iterations 1,2,3,5,10,20,50] [--reduction 0.9]

The case of the issue (and of ``tests/pd_core/test_implicit_convergence.py``): an
elastic-perfectly-plastic SDOF (m 1 kg, k 39.478 N/m, c 0.251 N·s/m, u_y 0.025 m) under the
whole El Centro 1940 NS record (a_g in m/s², load −m a_g), Δt = 0.02 s, ``average_acceleration``.
The reference is :func:`pd_core.verification.newmark_epp` (average acceleration,
Newton with the consistent tangent to 1e-14 m, no code shared with the scheme).

Printed: the largest |x − x_Newton| over the history, per number of iterations N, for

* ``forward_only=true`` (the default) and ``forward_only=false`` with an EPP spring evaluated
  from its committed state and committed at the step's end (the structure model's numerical
  springs);
* ``forward_only=false`` with the spring committed at every command (what the simulated
  site's ``SpecimenServer`` does, and what a physical specimen does);

then the forward-only plateau (at N = 50) for other increment reductions s, and the smallest
N at which ``forward_only=false`` is within 1e-9 m. A measurement, not a test: it asserts
nothing (about a minute on one core).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

from pd_common.specimen import ElasticPerfectlyPlastic
from pd_core.dynamics.record_readers import read_ground_motion
from pd_core.schemes import make_integrator
from pd_core.verification import newmark_epp

REPO = Path(__file__).resolve().parents[1]
RECORD = REPO / 'src' / 'pd_integrator' / 'data' / 'ground_motions' / (
    'elcentro_1940_ns_chopra.csv')
MASS, STIFFNESS, DAMPING, YIELD_DISPLACEMENT, DT = 1.0, 39.478, 0.251, 0.025, 0.02
YIELD_FORCE = STIFFNESS * YIELD_DISPLACEMENT
TARGET = 1e-9  # m


def run(load: np.ndarray, iterations: int, reduction: float, forward_only: bool,
        commit_every_command: bool = False) -> tuple[np.ndarray, int]:
    """Committed displacements and the scheme's ``reversals`` count."""
    integrator = make_integrator(
        'average_acceleration', mass=MASS, damping=DAMPING, dt=DT,
        initial_stiffness=STIFFNESS, iterations=iterations, increment_reduction=reduction,
        forward_only=forward_only)
    spring = ElasticPerfectlyPlastic(STIFFNESS, YIELD_FORCE)
    integrator.initialize(0.0, 0.0, float(load[0]), spring.set_trial_displacement(0.0))
    spring.commit()
    xs = np.zeros(load.size)
    for i in range(1, load.size):
        p = float(load[i])
        while True:
            force = spring.set_trial_displacement(float(integrator.predict()[0]))
            if commit_every_command:
                spring.commit()
            integrator.correct(force, p)
            if integrator.phase == 'corrected':
                break
        integrator.commit()
        spring.commit()
        xs[i] = float(integrator.x[0])
    return xs, integrator.reversals


def main(argv: list[str] | None = None) -> int:
    """Entry point."""
    parser = argparse.ArgumentParser(prog='iterations_table',
                                     description=__doc__.splitlines()[0])
    parser.add_argument('--iterations', default='1,2,3,5,10,20,50',
                        help='numbers of iterations per step (comma-separated)')
    parser.add_argument('--reduction', type=float, default=0.9,
                        help='increment_reduction s of the main table (default 0.9)')
    parser.add_argument('--plateau-reductions', default='1.0,0.9,0.7,0.5',
                        help='s values of the forward-only plateau lines (at N = 50)')
    args = parser.parse_args(argv)
    counts = [int(text) for text in args.iterations.split(',') if text.strip()]
    reductions = [float(text) for text in args.plateau_reductions.split(',') if text.strip()]
    start = time.perf_counter()
    load = -MASS * read_ground_motion(RECORD).resampled(DT).acceleration
    reference = newmark_epp(MASS, STIFFNESS, YIELD_FORCE, DAMPING, DT, load).x

    def history_error(x: np.ndarray) -> float:
        return float(np.max(np.abs(x - reference)))

    print(f'EPP SDOF (m {MASS:g} kg, k {STIFFNESS:g} N/m, c {DAMPING:g} N·s/m, u_y '
          f'{YIELD_DISPLACEMENT:g} m), El Centro NS {load.size} samples, dt {DT:g} s, '
          f'average_acceleration, s = {args.reduction:g}; peak |x_Newton| = '
          f'{float(np.max(np.abs(reference))):.6f} m')
    print('max |x - x_Newton| over the history (m); in brackets the reversals count '
          '(held with forward_only=true, commanded with false)')
    header = ('iterations', 'forward_only=true', 'forward_only=false',
              'false, committed every command')
    print(f'{header[0]:>10} | {header[1]:>22} | {header[2]:>22} | {header[3]:>30}')
    for n in counts:
        cells = []
        for forward_only, every in ((True, False), (False, False), (False, True)):
            x, reversals = run(load, n, args.reduction, forward_only, every)
            cells.append(f'{history_error(x):.3e} ({reversals})')
        print(f'{n:>10} | {cells[0]:>22} | {cells[1]:>22} | {cells[2]:>30}')
    print('forward_only=true plateau at N = 50 (forward_only=false at N = 50 alongside):')
    for s in reductions:
        held, _ = run(load, 50, s, True)
        free, _ = run(load, 50, s, False)
        print(f'  s = {s:<4g} {history_error(held):.3e} m   ({history_error(free):.3e} m)')
    for n in range(1, 51):
        x, _ = run(load, n, args.reduction, False)
        if history_error(x) <= TARGET:
            print(f'forward_only=false, s = {args.reduction:g}: within {TARGET:g} m from N = {n} '
                  f'({history_error(x):.3e} m)')
            break
    else:
        print(f'forward_only=false, s = {args.reduction:g}: not within {TARGET:g} m at N <= 50')
    print(f'({time.perf_counter() - start:.0f} s)')
    return 0


if __name__ == '__main__':
    sys.exit(main())

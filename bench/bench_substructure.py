"""Benchmark of substructured tests: prints per-step wall time and steps/s. Asserts nothing.

Run inside the sourced workspace (``. scripts/env.sh``)::

    python bench/bench_substructure.py [--quick] [--dofs 1000,10000] [--no-graph] [--no-save]

or ``./pd bench`` (after the loop benchmark). Figures:

1. Core time of large numerical substructures with one physical DOF: an N-story linear shear
   building (default N = 1,000 and 10,000; lumped masses, 5 % Rayleigh damping) whose first
   story is an experimental element at a site served in-process by a simulated elastic
   specimen (``runner.serve_queue``: no ROS, no bag): milliseconds per step (session + site
   coordinator + numerical elements + specimen) and steps/s, best of 3 sessions, per scheme
   of ``--large-schemes`` (default Newmark explicit, alpha-OS and KR-alpha); plus the one-off
   set-up (reading the test file once: parsing, Rayleigh damping; and the fastest session
   set-up: integrator, factorisations, stability check). Goal: under 1 ms per step at 10,000
   DOF. Merged into ``bench/results.json`` (other keys kept) as
   ``substructure_<N>dof_ms_per_step`` (Newmark explicit),
   ``substructure_<N>dof_alpha_os_ms_per_step``, ``substructure_<N>dof_kr_alpha_ms_per_step``
   and ``substructure_<N>dof[_<scheme>]_setup_s``.
2. A two-site test through the node graph (the example
   ``config/three_story_two_sites.yaml``: stories 1 and 3 at sites ``lab1`` and ``lab3``, one
   process per node started by ``run_test``), with ``--site direct``
   (a simulator per site) and ``--site bridge`` (a bridge and a simulator per site): steps/s
   and the median / p99 step round trip from ``summary.json``, best of 2.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from collections import deque
from pathlib import Path
from typing import Any

import numpy as np

REPO = Path(__file__).resolve().parents[1]
RECORD = REPO / 'src' / 'pd_integrator' / 'data' / 'ground_motions' / (
    'elcentro_1940_ns_chopra.csv')
GOAL_MS = 1.0
RESULTS = REPO / 'bench' / 'results.json'


def large_model(n: int, steps: int, scheme: str = 'newmark_explicit') -> dict[str, Any]:
    """An ``n``-story shear building, story 1 at site ``lab`` (raw test definition)."""
    names = [f'u{i + 1}' for i in range(n)]
    k, m = 1.0e8, 1.0e4
    elements: list[dict[str, Any]] = [
        {'type': 'experimental', 'name': 'story1', 'site': 'lab', 'dofs': ['u1'],
         'initial_stiffness': k}]
    elements += [{'type': 'story', 'dofs': [names[i - 1], names[i]], 'stiffness': k}
                 for i in range(1, n)]
    dt = 0.005  # ω_max < 2 sqrt(k/m) = 200 rad/s: ω_max·Δt < 1
    return {
        'test': {'id': f'bench-{n}-dof', 'scheme': scheme, 'dt': dt, 'duration': steps * dt},
        'structure': {'dof_names': names, 'mass': [m] * n, 'elements': elements,
                      'damping': {'rayleigh': {'modes': [1, 2], 'ratios': [0.05, 0.05]}}},
        'ground_motion': {'file': str(RECORD)},
        'sites': {'lab': {'specimen': {'elements': [{'model': 'elastic', 'stiffness': k}]}}},
    }


def core_large(n: int, steps: int, scheme: str = 'newmark_explicit',
               repeats: int = 3) -> dict[str, float]:
    """Per-step core time of the large model (best of ``repeats``), and the set-up time.

    The test file is read once (``from_dict``: parsing, condensation, Rayleigh damping); each
    repeat builds a fresh session (integrator, factorisations, stability check) and site
    servers. ``setup_s`` is the reading plus the fastest session set-up.
    """
    from pd_common.protocol import Command
    from pd_core.run.loop.dispatch import StepDispatcher
    from pd_core.run.loop.session import TestSession
    from pd_core.run.runner import serve_queue, site_servers
    from pd_core.run.test_file import from_dict

    raw = large_model(n, steps, scheme)
    start = time.perf_counter()
    definition = from_dict(raw, source='bench.yaml')
    read = time.perf_counter() - start
    best = float('inf')
    setup = float('inf')
    for _ in range(repeats):
        start = time.perf_counter()
        session = TestSession(definition)
        servers = site_servers(definition)
        setup = min(setup, time.perf_counter() - start)
        queue: deque[tuple[str, Command]] = deque()
        dispatcher = StepDispatcher(
            session, lambda site, command, queue=queue: queue.append((site, command)))
        start = time.perf_counter()
        dispatcher.start()
        serve_queue(queue, servers, dispatcher)
        elapsed = time.perf_counter() - start
        if session.state.name != 'FINISHED':
            msg = f'the {n}-DOF run stopped: {session.message}'
            raise RuntimeError(msg)
        best = min(best, elapsed / (definition.n_steps + 1))
    return {'ms_per_step': best * 1e3, 'steps_per_s': 1.0 / best, 'setup_s': read + setup}


def result_key(n: int, scheme: str, figure: str = 'ms_per_step') -> str:
    """The ``results.json`` name of a large-model figure: ``substructure_<n>dof_ms_per_step``
    for Newmark explicit, ``substructure_<n>dof_<scheme>_ms_per_step`` for the others."""
    middle = '' if scheme == 'newmark_explicit' else f'{scheme}_'
    return f'substructure_{n}dof_{middle}{figure}'


def merge_results(figures: dict[str, float]) -> None:
    """Add ``figures`` to ``bench/results.json`` (other benches' keys are kept)."""
    results = {}
    if RESULTS.is_file():
        try:
            results = json.loads(RESULTS.read_text(encoding='utf-8'))
        except json.JSONDecodeError:
            results = {}
    results.update(figures)
    RESULTS.write_text(json.dumps(results, indent=2, sort_keys=True) + '\n', encoding='utf-8')


EXAMPLE = REPO / 'src' / 'pd_integrator' / 'config' / 'three_story_two_sites.yaml'


def graph_two_sites(mode: str, duration: float, directory: Path, domain: int
                    ) -> dict[str, float]:
    """One launcher run; figures from its summary."""
    env = dict(os.environ, ROS_DOMAIN_ID=str(domain), ROS_AUTOMATIC_DISCOVERY_RANGE='LOCALHOST')
    out = directory / f'{mode}-{time.monotonic_ns()}'
    command = [sys.executable, '-m', 'pd_bringup.launcher', str(EXAMPLE), '--site', mode,
               '--out', str(out), '--no-figures', '-p', f'duration:={duration}']
    result = subprocess.run(command, env=env, capture_output=True, text=True, timeout=600,
                            check=False)
    if result.returncode != 0:
        msg = f'run_test --site {mode} failed:\n{result.stderr[-2000:]}'
        raise RuntimeError(msg)
    summary = json.loads((out / 'summary.json').read_text(encoding='utf-8'))
    trip = summary.get('step_round_trip', {})
    return {'steps_per_s': summary['steps'] / summary['wall_time'],
            'median_ms': trip.get('median_ms', float('nan')),
            'p99_ms': trip.get('p99_ms', float('nan'))}


def main(argv: list[str] | None = None) -> int:
    """Print the figures."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--quick', action='store_true', help='shorter runs')
    parser.add_argument('--dofs', default='1000,10000',
                        help='DOFs of the large models (comma-separated)')
    parser.add_argument('--no-save', action='store_true', help='do not write results.json')
    parser.add_argument('--domain-id', type=int, default=63,
                        help='ROS domain of the graph runs')
    parser.add_argument('--no-graph', action='store_true', help='skip the node-graph runs')
    parser.add_argument('--large-schemes', default='newmark_explicit,alpha_os,kr_alpha',
                        help='schemes of the large-model figure (comma-separated)')
    # (./pd bench passes the loop benchmark's options too: those are not ours)
    args, _ = parser.parse_known_args(argv)
    os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')
    steps = 200 if args.quick else 1000
    print(f'Substructured tests ({os.cpu_count()} CPUs, numpy {np.__version__})')
    figures: dict[str, float] = {}
    for n in [int(value) for value in args.dofs.split(',') if value]:
        for scheme in [name for name in args.large_schemes.split(',') if name]:
            large = core_large(n, steps, scheme)
            figures[result_key(n, scheme)] = large['ms_per_step']
            figures[result_key(n, scheme, 'setup_s')] = large['setup_s']
            verdict = 'meets' if large['ms_per_step'] < GOAL_MS else 'misses'
            print(f'  {n}-DOF numerical substructure + 1 physical DOF, {scheme}, core only '
                  f'({steps} steps, best of 3): {large["ms_per_step"]:.3f} ms/step = '
                  f'{large["steps_per_s"]:,.0f} steps/s ({verdict} the {GOAL_MS:g} ms goal); '
                  f'set-up {large["setup_s"]:.2f} s  [{result_key(n, scheme)}]', flush=True)
    if figures and not args.no_save:
        merge_results(figures)
        print(f'  merged into {RESULTS.relative_to(REPO)}')
    if args.no_graph:
        return 0
    duration = 2.5 if args.quick else 10.0
    with tempfile.TemporaryDirectory(prefix='pd-bench-sites-') as tmp:
        for mode in ('direct', 'bridge'):
            runs = [graph_two_sites(mode, duration, Path(tmp), args.domain_id)
                    for _ in range(2)]
            best = max(runs, key=lambda run: run['steps_per_s'])
            print(f'  two sites through the graph, --site {mode:6s} '
                  f'({int(duration / 0.005)} steps, best of 2): '
                  f'{best["steps_per_s"]:,.0f} steps/s = '
                  f'{1e3 / best["steps_per_s"]:.2f} ms/step; step round trip median '
                  f'{best["median_ms"]:.2f} ms, p99 {best["p99_ms"]:.2f} ms')
    return 0


if __name__ == '__main__':
    sys.exit(main())

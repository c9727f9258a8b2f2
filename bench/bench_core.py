"""The ROS-free core's time per step against openseespy's on the same EPP SDOF (issue 13 goal 2).

Run inside the sourced workspace (``. scripts/env.sh``)::

    python bench/bench_core.py [--repeats 5] [--no-save]

or ``./pd bench``. It asserts nothing. The system: an elastic-perfectly-plastic SDOF (m 1 kg,
k 39.478 N/m, c 0.251 N·s/m, u_y 0.025 m) under the El Centro 1940 NS record (m/s², as
``bench/iterations_table.py`` reads it), Δt 0.02 s, Newmark explicit, in one bench run:

* ``core_us_per_step``: the ROS-free session loop exactly as ``run_offline`` runs it, without
  the recorder (``TestSession`` + ``StepDispatcher`` + ``SpecimenServer`` through
  ``runner.serve_queue``), best of ``--repeats``; set-up not timed;
* ``opensees_us_per_step``: openseespy (``zeroLength`` + ``ElasticPP``, Rayleigh on the
  initial stiffness for c, ``UniformExcitation``, ``Linear`` + ``NewmarkExplicit 0.5``, one
  ``analyze(1)`` per step), in a child process with openseespy's libraries, best of
  ``--repeats``; model building not timed;
* ``core_over_opensees``: their ratio;
* ``python_loop_us_per_step``, ``python_loop_over_opensees``: the interpreter's own floor — the
  same Newmark explicit steps and EPP spring written as one plain Python loop over floats (no
  session, no protocol, no checks, no arrays), best of ``--repeats``: no loop of Python code
  per step, however lean, runs faster than this.

The three peak displacements are printed (they must agree). Merged into ``bench/results.json``.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import textwrap
import time
from collections import deque
from pathlib import Path
from typing import Any

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(Path(__file__).resolve().parent))

from _results import merge_results  # noqa: E402

RECORD = REPO / 'src' / 'pd_integrator' / 'data' / 'ground_motions' / (
    'elcentro_1940_ns_chopra.csv')
MASS, STIFFNESS, DAMPING, YIELD_DISPLACEMENT, DT = 1.0, 39.478, 0.251, 0.025, 0.02

OPENSEES_SCRIPT = textwrap.dedent('''\
    import json, sys, time
    import openseespy.opensees as ops
    spec = json.loads(sys.stdin.read())
    best, peak = None, 0.0
    for _ in range(spec['repeats']):
        ops.wipe()
        ops.model('basic', '-ndm', 1, '-ndf', 1)
        ops.node(0, 0.0)
        ops.fix(0, 1)
        ops.node(1, 0.0)
        ops.mass(1, spec['m'])
        ops.uniaxialMaterial('ElasticPP', 1, spec['k'], spec['uy'])
        ops.element('zeroLength', 1, 0, 1, '-mat', 1, '-dir', 1, '-doRayleigh', 1)
        ops.timeSeries('Path', 1, '-dt', spec['dt'], '-values', *spec['record'])
        ops.pattern('UniformExcitation', 1, 1, '-accel', 1)
        ops.rayleigh(0.0, 0.0, spec['c'] / spec['k'], 0.0)
        ops.constraints('Plain')
        ops.numberer('Plain')
        ops.system('FullGeneral')
        ops.algorithm('Linear')
        ops.integrator('NewmarkExplicit', 0.5)
        ops.analysis('Transient')
        steps, dt, peak = spec['steps'], spec['dt'], 0.0
        analyze, disp = ops.analyze, ops.nodeDisp
        start = time.perf_counter()
        for _ in range(steps):
            if analyze(1, dt) != 0:
                sys.exit('analysis failed')
            x = disp(1, 1)
            if abs(x) > peak:
                peak = abs(x)
        elapsed = time.perf_counter() - start
        best = elapsed if best is None else min(best, elapsed)
    print(json.dumps({'seconds': best, 'steps': steps, 'peak': peak}))
''')


def ground_acceleration() -> list[float]:
    """The record at Δt [m/s²], as ``bench/iterations_table.py`` reads it."""
    from pd_core.dynamics.record_readers import read_ground_motion

    return [float(a) for a in read_ground_motion(RECORD).resampled(DT).acceleration]


def definition(record: list[float]) -> Any:
    """The EPP SDOF test (simulated specimen at the default site)."""
    from pd_core.run.test_file import from_dict

    raw = {
        'test': {'id': 'core-vs-opensees', 'scheme': 'newmark_explicit', 'dt': DT},
        'structure': {'dof_names': ['x'], 'mass': MASS, 'damping': {'coefficient': DAMPING},
                      'initial_stiffness': STIFFNESS, 'influence': [1.0]},
        'ground_motion': {'inline': {'dt': DT, 'acceleration': record}, 'units': 'm/s2'},
        'specimen': {'topology': 'independent', 'elements': [
            {'model': 'epp', 'stiffness': STIFFNESS,
             'yield_force': STIFFNESS * YIELD_DISPLACEMENT}]},
    }
    return from_dict(raw, source='core_vs_opensees.yaml', base_dir=REPO)


def core_loop(test: Any) -> tuple[float, int, float]:
    """One session loop as ``run_offline`` runs it, no recorder: (seconds, steps, peak |x|)."""
    import numpy as np

    from pd_common.protocol import Command, TestState
    from pd_core.run.loop.dispatch import StepDispatcher
    from pd_core.run.loop.session import TestSession
    from pd_core.run.runner import serve_queue, site_servers

    servers = site_servers(test)
    session = TestSession(test)
    queue: deque[tuple[str, Command]] = deque()

    def send(site: str, command: Command) -> None:
        queue.append((site, command))

    dispatcher = StepDispatcher(session, send, None)
    start = time.perf_counter()
    dispatcher.start()
    serve_queue(queue, servers, dispatcher)
    elapsed = time.perf_counter() - start
    if session.state is not TestState.FINISHED:
        msg = f'stopped at step {session.committed_step}: {session.message}'
        raise RuntimeError(msg)
    peak = float(np.max(np.abs(session.history.displacement)))
    return elapsed, session.committed_step, peak


def python_loop(record: list[float]) -> tuple[float, int, float]:
    """The system as one plain Python loop (Newmark explicit, gamma 1/2; EPP spring; Chopra's
    sign convention p = -m a_g): (seconds, steps, peak |x|)."""
    m, k, c, dt = MASS, STIFFNESS, DAMPING, DT
    yield_force = k * YIELD_DISPLACEMENT
    x = v = 0.0
    r_committed = x_committed = 0.0
    a = -record[0]  # (p0 - c v0 - r0) / m with v0 = x0 = 0
    half, effective = 0.5 * dt, m + 0.5 * dt * c
    peak = 0.0
    start = time.perf_counter()
    for ground in record[1:]:
        x = x + dt * v + half * dt * a
        r = r_committed + k * (x - x_committed)
        if r > yield_force:
            r = yield_force
        elif r < -yield_force:
            r = -yield_force
        r_committed, x_committed = r, x
        v_predicted = v + half * a
        a = (-m * ground - r - c * v_predicted) / effective
        v = v_predicted + half * a
        if abs(x) > peak:
            peak = abs(x)
    return time.perf_counter() - start, len(record) - 1, peak


def opensees_loop(record: list[float], repeats: int) -> tuple[float, int, float]:
    """openseespy in a child process: (best seconds, steps, peak |x|)."""
    from pd_actuator_bridge.opensees_site import opensees_environment

    spec = {'m': MASS, 'k': STIFFNESS, 'c': DAMPING, 'uy': YIELD_DISPLACEMENT, 'dt': DT,
            'record': record, 'steps': len(record) - 1, 'repeats': repeats}
    done = subprocess.run([sys.executable, '-c', OPENSEES_SCRIPT], input=json.dumps(spec),
                          capture_output=True, text=True, env=opensees_environment(),
                          timeout=300, check=False)
    lines = [line for line in done.stdout.splitlines() if line.startswith('{')]
    if done.returncode != 0 or not lines:
        msg = f'openseespy failed ({done.returncode}): {done.stderr.strip()[-300:]}'
        raise RuntimeError(msg)
    result = json.loads(lines[-1])
    return float(result['seconds']), int(result['steps']), float(result['peak'])


def main(argv: list[str] | None = None) -> int:
    """Entry point."""
    parser = argparse.ArgumentParser(prog='bench_core', description=__doc__.splitlines()[0])
    parser.add_argument('--repeats', type=int, default=5, help='runs of each loop (best kept)')
    parser.add_argument('--quick', action='store_true', help='3 runs of each loop')
    parser.add_argument('--no-save', action='store_true', help='do not write results.json')
    args, _unknown = parser.parse_known_args(argv)  # ./pd bench passes every bench's options
    repeats = 3 if args.quick else max(1, args.repeats)
    record = ground_acceleration()
    test = definition(record)
    core = [core_loop(test) for _ in range(repeats)]
    seconds, steps, core_peak = min(core)
    core_us = seconds / steps * 1e6
    try:
        os_seconds, os_steps, os_peak = opensees_loop(record, repeats)
    except (RuntimeError, OSError, subprocess.TimeoutExpired) as err:
        print(f'core: {core_us:.1f} us/step ({steps} steps, peak {core_peak:.8f} m); '
              f'openseespy: {err}')
        return 1
    os_us = os_seconds / os_steps * 1e6
    ratio = core_us / os_us
    plain_seconds, plain_steps, plain_peak = min(python_loop(record) for _ in range(repeats))
    plain_us = plain_seconds / plain_steps * 1e6
    print(f'EPP SDOF (m {MASS:g} kg, k {STIFFNESS:g} N/m, c {DAMPING:g} N·s/m, u_y '
          f'{YIELD_DISPLACEMENT:g} m), El Centro NS, dt {DT:g} s, Newmark explicit; '
          f'best of {repeats}')
    print(f'  core (TestSession+StepDispatcher+SpecimenServer, no recorder): '
          f'{core_us:8.2f} us/step  {steps} steps  peak {core_peak:.8f} m')
    print(f'  openseespy (NewmarkExplicit, ElasticPP, analyze(1) per step): '
          f'{os_us:8.2f} us/step  {os_steps} steps  peak {os_peak:.8f} m')
    print(f'  plain Python loop (same steps, no protocol):                   '
          f'{plain_us:8.2f} us/step  {plain_steps} steps  peak {plain_peak:.8f} m')
    print(f'  core_over_opensees {ratio:.2f}   (peaks differ by {abs(core_peak - os_peak):.2e} m)')
    print(f'  python_loop_over_opensees {plain_us / os_us:.2f}   (the interpreter\'s floor; '
          f'peak differs from the core\'s by {abs(core_peak - plain_peak):.2e} m)')
    if not args.no_save:
        merge_results({'core_us_per_step': round(core_us, 2),
                       'opensees_us_per_step': round(os_us, 2),
                       'core_over_opensees': round(ratio, 3),
                       'core_peak_displacement_m': core_peak,
                       'python_loop_us_per_step': round(plain_us, 3),
                       'python_loop_over_opensees': round(plain_us / os_us, 3),
                       'opensees_peak_displacement_m': os_peak})
    return 0


if __name__ == '__main__':
    sys.exit(main())

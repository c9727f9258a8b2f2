"""Benchmark of real-time hybrid simulation in wall-clock time (issue 12, the vRTHS benchmark).

Run inside the sourced workspace (``. scripts/env.sh``)::

    python bench/bench_rths.py [--quick] [--domain-id 179] [--no-graph] [--no-save]

A measurement, not a test: it asserts nothing. The benchmark (case 1, El Centro × 0.4 with the
benchmark's 5 s of zeros before and after, the benchmark plant with its sensor noise and
quantisation, the default compensator (``DEFAULT_COMPENSATOR``), 4096 Hz, Δt_int = 1/1024 s:
four controller ticks a step) in real time, the actuator ticked against
``time.perf_counter`` deadlines (:class:`pd_common.rths.realtime.RealtimeLoop`):

1. **in process** — the integrator (the native loop's :class:`TestSession` and step dispatcher)
   answers each measurement in the ticking thread and sets the next target at once;
2. **through the graph** — ``run_test --site bridge`` with the bridge's ``transfer_system``
   driver on ``clock: realtime`` (integrator and bridge separate processes over DDS); its
   statistics from the run folder's ``rths-lab1.json`` (written by the driver). Twice: with
   the processes placed as a real-time test should be, ``--cpus integrator=0 --cpus
   bridge=1`` (the bridge's ticking thread alone on its CPU, never waiting to be woken; on a
   machine with two CPUs or more), and left to the scheduler.

A *missed deadline* is a tick started more than one controller period late; the *slow-down
fraction* the share of ticks at less than the full rate (the target of the step was late: the
actuator braked, :mod:`pd_common.rths.continuous`). ``--quick``: the first 5 s of the record
and 1 s of zeros.

Figures (printed, and merged into ``bench/results.json``; other keys are kept):
``rths_inprocess_p99_tick_us``, ``rths_inprocess_missed_deadlines``,
``rths_inprocess_slowdown_fraction``, ``rths_graph_p99_step_ms``,
``rths_graph_missed_deadlines``, ``rths_graph_missed_fraction``, ``rths_graph_slowdown_fraction``
(placed, as a real-time test runs), ``rths_graph_unplaced_*`` (the same, not placed);
``*_cpu_latency_held``: whether the loop held the CPUs' shallow idle states while it ticked
(:mod:`pd_common.rths.cpu_latency`: root only; a line ending "idle CPUs not kept awake" ran
without, as an unprivileged user's run does).
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
import yaml

from _results import RESULTS, merge_results
from bench_loop import REPO, machine_header, remove_stale_segments, shm_snapshot, stop_process
from pd_common.protocol import Command, Feedback, FeedbackStatus, TestState
from pd_common.rths import (
    BENCHMARK_CAPACITY,
    BENCHMARK_NOISE,
    BENCHMARK_QUANTUM,
    BENCHMARK_SPECIMEN,
    ContinuousMeasurement,
    ContinuousSiteServer,
)
from pd_common.rths.compensation import DEFAULT_COMPENSATOR
from pd_common.rths.realtime import RealtimeLoop, RealtimeStatistics
from pd_core.dynamics.record_readers import read_ground_motion
from pd_core.run.loop.dispatch import StepDispatcher
from pd_core.run.loop.session import TestSession
from pd_core.run.runner import site_servers
from pd_core.run.test_file import from_dict
from pd_rths_benchmark.core.native_loop import SITE, native_test_file, run_native_loop
from pd_rths_benchmark.core.problem import benchmark_case

RECORD = REPO / 'src' / 'pd_integrator' / 'data' / 'ground_motions' / (
    'elcentro_1940_ns_chopra.csv')
LAUNCHER = REPO / 'ros2_ws' / 'install' / 'pd_bringup' / 'lib' / 'pd_bringup' / 'run_test'
DT_INT = 1.0 / 1024.0
#: How a real-time test places its processes (two CPUs or more): the bridge's ticking thread
#: alone on CPU 1, the integrator on CPU 0.
PLACED = ('integrator=0', 'bridge=1')
PADDING, QUICK_PADDING, QUICK_SECONDS = 5.0, 1.0, 5.0


def benchmark_file(quick: bool, *, clock: str = 'simulated') -> dict[str, Any]:
    """The benchmark's test file (lab1 behind a ``transfer_system`` bridge on ``clock``)."""
    record = read_ground_motion(RECORD, units='g')
    acceleration = record.acceleration
    if quick:
        acceleration = acceleration[:round(QUICK_SECONDS / record.dt)]
    padding = QUICK_PADDING if quick else PADDING
    noise = BENCHMARK_NOISE
    return native_test_file(
        benchmark_case(1), acceleration, record.dt, padding_samples=round(padding / record.dt),
        intensity=0.4, integration_dt=DT_INT,
        transfer_system={
            'plant': {'model': 'benchmark'}, 'compensator': {'name': DEFAULT_COMPENSATOR},
            'noise': {'displacement_power': noise.displacement_power,
                      'force_power': noise.force_power, 'seed': 1},
            'quantum': BENCHMARK_QUANTUM, 'capacity': BENCHMARK_CAPACITY},
        specimen=BENCHMARK_SPECIMEN, test_id='vrths-realtime',
        bridge={'driver': 'transfer_system', 'clock': clock})


def in_process(raw: dict[str, Any]) -> tuple[RealtimeStatistics, TestSession, float]:
    """The integrator and the actuator in this process, in real time; the statistics, the
    session and the wall time."""
    definition = from_dict(raw, source='bench_rths')
    server = site_servers(definition)[SITE]
    assert isinstance(server, ContinuousSiteServer)
    session = TestSession(definition)
    loop = RealtimeLoop(server.actuator, cpu_latency=server.actuator.config.cpu_latency)
    at_once: deque[Command] = deque()
    pending: list[Command] = []

    def send(site: str, command: Command) -> None:
        if command.step == 0:
            at_once.append(command)  # the reading at rest: answered before the ticking
        else:
            pending.append(command)
            loop.set_next_target(command.target_displacement[0])

    dispatcher = StepDispatcher(session, send)

    def on_measurement(measurement: ContinuousMeasurement) -> None:
        command = pending.pop()
        status, message = FeedbackStatus.OK, ''
        if measurement.capacity_exceeded:
            status, message = FeedbackStatus.FAULT, 'the actuator reached its capacity'
        dispatcher.on_feedback(SITE, Feedback(
            test_id=command.test_id, step=command.step,
            measured_displacement=(measurement.displacement,),
            restoring_force=(measurement.force,), status=status, message=message))
        if session.state is not TestState.RUNNING:
            loop.stop(wait=False)

    loop.on_measurement = on_measurement
    dispatcher.start()
    while at_once:
        command = at_once.popleft()
        answer = server.handle(command.test_id, command.step, command.target_displacement)
        assert answer is not None
        dispatcher.on_feedback(SITE, answer)
    start = time.perf_counter()
    loop.run()
    return loop.statistics(), session, time.perf_counter() - start


def graph(raw: dict[str, Any], domain_id: int, directory: Path, timeout: float,
          cpus: tuple[str, ...] = ()) -> tuple[dict[str, Any] | None, dict[str, Any] | None, str]:
    """``run_test --site bridge`` with the realtime driver; (report, summary, log tail).

    ``cpus``: ``--cpus`` options of ``run_test``.
    """
    test_file = directory / 'vrths_realtime.yaml'
    test_file.write_text(yaml.safe_dump(raw), encoding='utf-8')
    out = directory / 'graph'
    log = directory / 'graph.log'
    env = dict(os.environ, ROS_DOMAIN_ID=str(domain_id))
    env.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')
    before = shm_snapshot()
    with log.open('wb') as sink:
        process = subprocess.Popen(
            [str(LAUNCHER), str(test_file), '--site', 'bridge', '--out', str(out),
             '--no-figures', *(option for item in cpus for option in ('--cpus', item))],
            stdout=sink, stderr=subprocess.STDOUT, env=env,
            start_new_session=True)
        try:
            process.wait(timeout=timeout)
        except subprocess.TimeoutExpired:
            stop_process(process)
        finally:
            if process.poll() is None:
                stop_process(process)
    remove_stale_segments(before, domain_id)
    tail = '\n'.join(log.read_text(errors='replace').strip().splitlines()[-5:])
    report_file, summary_file = out / f'rths-{SITE}.json', out / 'summary.json'
    report = json.loads(report_file.read_text(encoding='utf-8')) if report_file.is_file() else None
    summary = (json.loads(summary_file.read_text(encoding='utf-8'))
               if summary_file.is_file() else None)
    return report, summary, tail


def _line(label: str, values: dict[str, Any]) -> str:
    return (f'{label:<12} {values["ticks"]:>9,} ticks {values["steps"]:>7,} steps  missed '
            f'{values["missed_deadlines"]:>6,}  max late {values["max_lateness_us"]:>9.0f} µs  '
            f'slowed {100 * values["slowdown_fraction"]:6.2f} %  tick p50/p99/max '
            f'{values["tick_p50_us"]:.1f}/{values["tick_p99_us"]:.1f}/'
            f'{values["tick_max_us"]:.0f} µs  step p50/p99/max {values["step_p50_ms"]:.3f}/'
            f'{values["step_p99_ms"]:.3f}/{values["step_max_ms"]:.2f} ms '
            f'(nominal {values["nominal_step_ms"]:.3f})  target latency p50/p99 '
            f'{values.get("target_latency_p50_us", float("nan")):.0f}/'
            f'{values.get("target_latency_p99_us", float("nan")):.0f} µs'
            f'{"" if values.get("cpu_latency_held") else "  (idle CPUs not kept awake)"}')


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--quick', action='store_true',
                        help=f'the first {QUICK_SECONDS:g} s of the record, '
                             f'{QUICK_PADDING:g} s of zeros')
    parser.add_argument('--domain-id', type=int, default=179,
                        help='ROS_DOMAIN_ID of the graph run (default 179)')
    parser.add_argument('--no-graph', action='store_true', help='only the in-process run')
    parser.add_argument('--no-save', action='store_true', help='do not write results.json')
    args, _ = parser.parse_known_args()  # ./pd bench passes every bench the same options
    print(machine_header(args.domain_id))
    raw = benchmark_file(args.quick)
    duration = raw['test']['duration']
    print(f'rths: vRTHS case 1, El Centro x0.4 ({"quick: " if args.quick else ""}{duration:.2f}'
          f' s), benchmark plant + noise + quantum, {DEFAULT_COMPENSATOR}, 4096 Hz, '
          'dt_int 1/1024 s')
    statistics, session, wall = in_process(raw)
    values = statistics.as_dict()
    print(_line('in process', values) + f'  wall {wall:.2f} s, {session.state.name.lower()}')
    simulated = run_native_loop(raw)
    committed = session.history.n_committed
    same = bool(np.array_equal(np.array(session.history.restoring_force[:committed, 0]),
                               simulated.restoring_force[:committed]))
    print(f'{"":<12} restoring forces {"identical to" if same else "differ from"} the '
          'simulated-time run')
    figures: dict[str, object] = {
        'rths_inprocess_p99_tick_us': round(statistics.tick_p99_us, 2),
        'rths_inprocess_missed_deadlines': statistics.missed_deadlines,
        'rths_inprocess_slowdown_fraction': round(statistics.slowdown_fraction, 6),
        'rths_inprocess_cpu_latency_held': statistics.cpu_latency_held,
    }
    placed = PLACED if len(os.sched_getaffinity(0)) >= 2 else ()
    runs = [('graph', 'rths_graph', placed), ('unplaced', 'rths_graph_unplaced', ())]
    for label, prefix, cpus in runs if not args.no_graph else ():
        with tempfile.TemporaryDirectory(prefix='bench_rths_') as temporary:
            report, summary, tail = graph(benchmark_file(args.quick, clock='realtime'),
                                          args.domain_id, Path(temporary),
                                          timeout=duration * 4 + 120.0, cpus=cpus)
        if report is None or 'ticks' not in report:
            print(f'{label}: no realtime report; the run said:\n{tail}')
            continue
        state = summary.get('state', '?') if summary else 'no summary'
        where = ' '.join(f'--cpus {item}' for item in cpus) or 'not placed'
        print(_line(label, report) + f'  {state}; {where}')
        figures.update({
            f'{prefix}_p99_step_ms': round(float(report['step_p99_ms']), 4),
            f'{prefix}_missed_deadlines': int(report['missed_deadlines']),
            f'{prefix}_missed_fraction': round(int(report['missed_deadlines'])
                                               / max(int(report['ticks']), 1), 6),
            f'{prefix}_slowdown_fraction': round(float(report['slowdown_fraction']), 6),
            f'{prefix}_cpu_latency_held': bool(report.get('cpu_latency_held')),
        })
    for key, value in figures.items():
        print(f'{key} = {value}')
    if not args.no_save:
        merge_results(figures)
        print(f'merged into {RESULTS.relative_to(REPO)}')


if __name__ == '__main__':
    sys.exit(main())

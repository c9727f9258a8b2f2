"""The vRTHS benchmark in simulated time through the node graph (issue 12).

The benchmark's native test file (:func:`pd_rths_benchmark.core.native_loop.native_test_file`:
the numerical substructure, the specimen at site ``lab1`` behind its ``transfer_system``: the
benchmark plant with seeded sensor noise and quantisation, the PI-P compensator, Δt_int =
1/1024 s at 4096 Hz) runs integrator ↔ bridge as separate processes (``run_test --site
bridge``, the bridge's ``transfer_system`` driver: no specimen simulator) and gives the
ROS-free run's response float for float; with ``clock: realtime`` the bridge ticks it
against the wall clock and reports its deadlines.
"""

from __future__ import annotations

import json
import os
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml
from graph_support import REPO, Processes, drain, worker_index
from test_graph import RUN_TIMEOUT, run_launcher, wait_exit

from pd_common.rths import (
    BENCHMARK_CAPACITY,
    BENCHMARK_NOISE,
    BENCHMARK_QUANTUM,
    BENCHMARK_SPECIMEN,
)
from pd_core.dynamics.record_readers import read_ground_motion
from pd_core.run.record.outputs import read_response_csv
from pd_core.run.runner import run_offline
from pd_core.run.test_file import load_test_file
from pd_rths_benchmark.core.native_loop import native_test_file
from pd_rths_benchmark.core.problem import benchmark_case

pytestmark = pytest.mark.graph

RECORD = REPO / 'src' / 'pd_integrator' / 'data' / 'ground_motions' / (
    'elcentro_1940_ns_chopra.csv')
#: The first seconds of El Centro, and the zeros before and after them.
SECONDS, PADDING = 2.0, 0.5


@pytest.fixture
def domain_id() -> int:
    """This module's ROS domains: 170-179 (one per xdist worker)."""
    return 170 + worker_index() % 10


def benchmark_file(path: Path, *, clock: str = 'simulated', seconds: float = SECONDS) -> Path:
    """The benchmark (case 1, El Centro at 0.4) as a test file whose lab1 is the bridge's."""
    record = read_ground_motion(RECORD, units='g')
    acceleration = record.acceleration[:round(seconds / record.dt)]
    noise = BENCHMARK_NOISE
    raw = native_test_file(
        benchmark_case(1), acceleration, record.dt, padding_samples=round(PADDING / record.dt),
        intensity=0.4, integration_dt=1.0 / 1024.0,
        transfer_system={
            'plant': {'model': 'benchmark'}, 'compensator': {'name': 'pi_p'},
            'noise': {'displacement_power': noise.displacement_power,
                      'force_power': noise.force_power, 'seed': 7},
            'quantum': BENCHMARK_QUANTUM, 'capacity': BENCHMARK_CAPACITY},
        specimen=BENCHMARK_SPECIMEN, test_id='vrths-graph',
        bridge={'driver': 'transfer_system', 'clock': clock})
    path.write_text(yaml.safe_dump(raw), encoding='utf-8')
    return path


def test_benchmark_through_the_bridge_equals_the_ros_free_run(
        processes: Processes, tmp_path: Path) -> None:
    test_file = benchmark_file(tmp_path / 'vrths.yaml')
    offline = run_offline(load_test_file(test_file), tmp_path / 'offline', figures=False)
    assert offline.summary['state'] == 'finished'

    out = tmp_path / 'graph'
    launcher = run_launcher(processes, 'run_test', [str(test_file), '--site', 'bridge',
                                                    '--out', str(out), '--no-figures'])
    code = wait_exit(launcher, RUN_TIMEOUT, lambda: processes.log('run_test'))
    log = processes.log('run_test')
    assert code == 0, log[-3000:]
    summary = json.loads((out / 'summary.json').read_text(encoding='utf-8'))
    assert summary['state'] == 'finished'
    # The bridge drives the actuator itself: no specimen simulator was started.
    plan = json.loads((out / 'launch.json').read_text(encoding='utf-8'))
    kinds = [child['kind'] for child in plan['children']]
    assert kinds == ['bridge'], kinds
    assert 'pd_specimen_sim' not in log
    assert 'integrator_cpu_latency' not in summary  # simulated time: nothing asked of the host

    graph = np.genfromtxt(out / 'response.csv', delimiter=',', names=True)
    reference = np.genfromtxt(tmp_path / 'offline' / 'response.csv', delimiter=',', names=True)
    assert graph.dtype.names == reference.dtype.names
    assert len(graph) > (SECONDS + PADDING) * 1024  # every step (Δt_int 1/1024 s)
    for name in reference.dtype.names or ():
        assert np.array_equal(graph[name], reference[name]), name
    assert (out / 'response.csv').read_bytes() == (
        tmp_path / 'offline' / 'response.csv').read_bytes()
    assert np.max(np.abs(reference['x_x1'])) > 1e-3  # the specimen moved (mm)


def test_benchmark_in_wall_clock_time_through_the_bridge(
        processes: Processes, observer: Any, tmp_path: Path) -> None:
    """``clock: realtime``: the bridge ticks the actuator at 4096 Hz against the wall clock and
    reports its deadlines, which run_test adds to summary.json (no timing is asserted: the
    machine decides). The tracking monitor runs on every step (its messages go out only
    while someone subscribes): the last sample an observer gets is the run's tracking.csv."""
    from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
    from std_msgs.msg import Float64MultiArray

    received: list[Any] = []
    observer.create_subscription(
        Float64MultiArray, '/pd/lab1/monitor/tracking', received.append,
        QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=10000,
                   reliability=ReliabilityPolicy.RELIABLE))
    test_file = benchmark_file(tmp_path / 'vrths-rt.yaml', clock='realtime', seconds=1.0)
    out = tmp_path / 'graph'
    launcher = run_launcher(processes, 'run_test', [str(test_file), '--site', 'bridge',
                                                    '--out', str(out), '--no-figures'])
    deadline = time.monotonic() + RUN_TIMEOUT
    while launcher.poll() is None and time.monotonic() < deadline:
        observer.executor_for_test.spin_once(timeout_sec=0.05)
    code = wait_exit(launcher, 1.0, lambda: processes.log('run_test'))
    assert code == 0, processes.log('run_test')[-3000:]
    drain(observer, received)  # the last samples may still be on their way
    tracking = read_response_csv(out / 'tracking.csv')
    assert len(received) >= 100, len(received)  # (the observer may miss the first steps)
    assert list(received[-1].data) == pytest.approx(
        [tracking['error_x1'][-1], tracking['indicator_x1'][-1]], rel=1e-12, abs=1e-20)
    summary = json.loads((out / 'summary.json').read_text(encoding='utf-8'))
    assert summary['state'] == 'finished'
    report = json.loads((out / 'rths-lab1.json').read_text(encoding='utf-8'))
    steps = load_test_file(test_file).n_steps
    assert report['clock'] == 'realtime' and report['steps'] == steps
    assert report['ticks'] >= 4 * steps and report['controller_rate'] == 4096.0
    assert 0.0 <= report['slowdown_fraction'] < 1.0
    assert report['step_p50_ms'] >= 0.9 * report['nominal_step_ms']
    # run_test puts the same statistics into summary.json and prints them
    assert summary['realtime'] == {'lab1': report}
    assert 'lab1 in real time:' in processes.log('run_test')
    # while it ticked, the bridge kept idle CPUs awake where it may (root), and says which
    allowed = os.access('/dev/cpu_dma_latency', os.W_OK)
    assert report['cpu_latency_held'] is allowed
    # ... and so did the integrator on its own host (here the same machine): a bridge beside
    # the controller covers only its own
    assert summary['integrator_cpu_latency']['held'] is allowed
    assert (summary['integrator_cpu_latency']['note'] == '') is allowed
    assert (', idle CPUs kept awake' if allowed else ', idle CPUs not kept awake (') in (
        processes.log('run_test'))

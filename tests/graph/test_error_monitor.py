"""Experimental errors and the tracking monitor through the node graph (separate processes).

A test file with ``specimen.errors`` (5 % undershoot, seeded noise and a force bias) run
integrator → bridge → simulator gives the same ``response.csv`` and ``tracking.csv`` as the
ROS-free run, float for float, and the bridge's ``/pd/monitor/tracking`` topic publishes, step by
step, the tracking error and indicator that the outputs rebuild afterwards.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml
from graph_support import REPO, Processes, drain, executable

from pd_core.run.record.outputs import read_response_csv
from pd_core.run.runner import run_offline
from pd_core.run.test_file import load_test_file
from support.paths import DEFAULT_TEST

pytestmark = pytest.mark.graph

RECORD = REPO / 'src' / 'pd_integrator' / 'data' / 'ground_motions' / (
    'elcentro_1940_ns_chopra.csv')
RUN_TIMEOUT = 120.0
ERRORS = {'systematic': -0.05, 'displacement_noise': 1.0e-5, 'force_noise': 5.0,
          'force_bias': 2.0, 'seed': 5}


def test_errors_and_tracking_monitor_through_the_graph(processes: Processes, observer: object,
                                                        tmp_path: Path) -> None:
    from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
    from std_msgs.msg import Float64MultiArray

    raw = yaml.safe_load(DEFAULT_TEST.read_text(encoding='utf-8'))
    raw['ground_motion']['file'] = str(RECORD)
    raw['test'].update({'id': 'graph-errors', 'duration': 2.0})
    raw['specimen']['errors'] = ERRORS
    test_file = tmp_path / 'errors.yaml'
    test_file.write_text(yaml.safe_dump(raw), encoding='utf-8')
    offline = run_offline(load_test_file(test_file), tmp_path / 'offline', figures=False)

    received: list[Float64MultiArray] = []
    subscription = observer.create_subscription(  # type: ignore[attr-defined]
        Float64MultiArray, '/pd/monitor/tracking', received.append,
        QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1000,
                   reliability=ReliabilityPolicy.RELIABLE))
    executor = observer.executor_for_test  # type: ignore[attr-defined]
    bridge_params = REPO / 'src' / 'pd_actuator_bridge' / 'config' / 'bridge.yaml'
    processes.start('specimen', [executable('pd_specimen_sim'), '--ros-args', '-r',
                                 '__ns:=/pd/specimen', '-p', f'test_file:={test_file}'])
    processes.start('bridge', [executable('pd_actuator_bridge'), '--ros-args',
                               '--params-file', str(bridge_params)])
    # The observer must know the bridge before the (short) test starts.
    limit = RUN_TIMEOUT
    while subscription.get_publisher_count() == 0 and limit > 0:
        executor.spin_once(timeout_sec=0.05)
        limit -= 0.05
    assert subscription.get_publisher_count() > 0, processes.log('bridge')[-2000:]
    out = tmp_path / 'graph'
    launcher = processes.start('integrator', [
        executable('pd_integrator'), '--ros-args', '-p', f'test_file:={test_file}',
        '-p', f'output_dir:={out}', '-p', 'figures:=false'])
    limit = RUN_TIMEOUT
    while launcher.poll() is None and limit > 0:
        executor.spin_once(timeout_sec=0.05)
        limit -= 0.05
    assert launcher.poll() == 0, processes.log('integrator')[-3000:]
    drain(observer, received)  # the last samples may still be on their way

    # The graph injects the same, deterministic errors as the ROS-free run.
    for name in ('response.csv', 'tracking.csv'):
        assert (out / name).read_bytes() == (offline.directory / name).read_bytes(), name
    tracking = read_response_csv(out / 'tracking.csv')
    assert tracking['indicator_top'][-1] < 0.0  # undershoot: energy added

    # The live monitor: one sample per answered step, the values of tracking.csv.
    assert len(received) >= 200, len(received)
    message = received[-1]
    assert [d.size for d in message.layout.dim] == [2, 1]
    samples = np.array([list(m.data) for m in received])
    rows = np.column_stack([tracking['error_top'], tracking['indicator_top']])
    np.testing.assert_allclose(samples, rows[-len(received):], rtol=1e-12, atol=1e-20)

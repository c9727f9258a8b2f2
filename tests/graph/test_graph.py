"""The node graph as real separate processes over DDS.

* a short test through integrator → bridge → simulator (and integrator → simulator) completes
  and its history equals the ROS-free run of the same test file, float for float;
* the bag reads back with rosbags and its replay reproduces ``response.csv``;
* a command past a bridge limit never reaches the specimen: the bridge holds and reports, the
  integrator holds, an operator abort ends the test with its outputs written;
* a specimen killed mid-test leads the integrator to HOLDING after its re-sends, with every
  committed step still right.
"""

from __future__ import annotations

import json
import signal
import subprocess
import time
from collections import Counter
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml
from graph_support import (
    REPO,
    Processes,
    drain,
    executable,
    send_control,
    shm_segments,
    stale_segments,
)
from rosbags.highlevel import AnyReader

from pd_common.protocol import Command, Feedback, FeedbackStatus
from pd_core.run.record.bag import read_bag
from pd_core.run.runner import rebuild_outputs, run_offline
from pd_core.run.test_file import load_test_file
from support.paths import DEFAULT_TEST

pytestmark = pytest.mark.graph

RECORD = REPO / 'src' / 'pd_integrator' / 'data' / 'ground_motions' / (
    'elcentro_1940_ns_chopra.csv')
RUN_TIMEOUT = 120.0


def write_test_file(path: Path, **changes: Any) -> Path:
    """The default test with ``section.key`` changes (e.g. ``test__duration=2.0``)."""
    raw = yaml.safe_load(DEFAULT_TEST.read_text(encoding='utf-8'))
    raw['ground_motion']['file'] = str(RECORD)
    for dotted, value in changes.items():
        section, key = dotted.split('__')
        raw[section][key] = value
    path.write_text(yaml.safe_dump(raw), encoding='utf-8')
    return path


def write_bridge_params(path: Path, **limits: float) -> Path:
    """A bridge parameter file with the default limits and ``limits`` changed."""
    params = {'driver': 'sim_servo', 'autostart': True, 'specimen_namespace': 'specimen',
              'driver_timeout': 5.0,
              'max_displacement': 0.25, 'max_increment': 0.02, 'max_force': 1.0e5,
              'max_velocity': 0.0, 'step_duration': 0.0}
    params.update(limits)
    path.write_text(yaml.safe_dump({'/**': {'ros__parameters': params}}), encoding='utf-8')
    return path


def run_launcher(processes: Processes, name: str, arguments: list[str]
                 ) -> subprocess.Popen[bytes]:
    """Start ``run_test`` (which starts the nodes as its own children)."""
    return processes.start(name, [executable('pd_bringup', 'run_test'), *arguments])


def wait_exit(process: subprocess.Popen[bytes], timeout: float, log: Callable[[], str]) -> int:
    """Wait for ``process``; fail with its log on a timeout."""
    try:
        return process.wait(timeout=timeout)
    except subprocess.TimeoutExpired:
        pytest.fail(f'process did not finish within {timeout} s; its log:\n{log()[-3000:]}')
    raise AssertionError  # unreachable


def spin_until(observer: Any, predicate: Callable[[], bool], timeout: float,
               what: str | Callable[[], str]) -> None:
    """Spin the observer node until ``predicate()`` or fail (``what()``: said when failing)."""
    deadline = time.monotonic() + timeout
    while not predicate():
        if time.monotonic() > deadline:
            said = what() if callable(what) else what
            pytest.fail(f'timed out after {timeout} s waiting for {said}')
        observer.executor_for_test.spin_once(timeout_sec=0.05)


def latched_qos() -> Any:
    """QoS of the latched status topics."""
    from rclpy.qos import (
        DurabilityPolicy,
        HistoryPolicy,
        QoSProfile,
        ReliabilityPolicy,
    )

    return QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1,
                      reliability=ReliabilityPolicy.RELIABLE,
                      durability=DurabilityPolicy.TRANSIENT_LOCAL)


@pytest.fixture(scope='module')
def short_test(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The default test cut to 2 s (200 steps)."""
    directory = tmp_path_factory.mktemp('short')
    return write_test_file(directory / 'short.yaml', test__duration=2.0, test__id='graph-short')


@pytest.fixture(scope='module')
def offline_run(short_test: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The ROS-free run of the short test."""
    out = tmp_path_factory.mktemp('offline') / 'run'
    run_offline(load_test_file(short_test), out, figures=False)
    return out


@pytest.mark.parametrize('site', ['bridge', 'direct'])
def test_graph_run_matches_ros_free_run(site: str, short_test: Path, offline_run: Path,
                                        processes: Processes, observer: Any,
                                        tmp_path: Path) -> None:
    from pd_common.protocol import decode_command
    from pd_common.ros import STEP_QOS
    from pd_msgs.msg import StepCommand

    # The bridge's moves to the specimen, each step once.
    moves: list[bytes] = []
    if site == 'bridge':
        observer.create_subscription(StepCommand, '/pd/specimen/step_command', moves.append,
                                     STEP_QOS, raw=True)
    out = tmp_path / 'graph'
    segments = shm_segments()
    # (direct: the integrator's own parameters as the docs give them, integers included)
    extra = ['-p', 'sync_interval:=0', '-p', 'progress_interval:=1'] if site == 'direct' else []
    launcher = run_launcher(processes, 'run_test', [str(short_test), '--site', site,
                                                    '--out', str(out), '--no-figures', *extra])
    spin_until(observer, lambda: launcher.poll() is not None, RUN_TIMEOUT,
               lambda: 'run_test to end; its log:\n' + processes.log('run_test')[-3000:])
    code = wait_exit(launcher, 1.0, lambda: processes.log('run_test'))
    assert code == 0, processes.log('run_test')[-3000:]
    if site == 'bridge':
        drain(observer, moves)
    # Every node process took its Fast DDS shared memory with it.
    assert not stale_segments(segments), sorted(stale_segments(segments))
    graph_csv = (out / 'response.csv').read_bytes()
    assert graph_csv == (offline_run / 'response.csv').read_bytes()
    summary = json.loads((out / 'summary.json').read_text(encoding='utf-8'))
    assert summary['state'] == 'finished'
    assert summary['steps'] == 200
    assert summary['mode'] == 'graph'
    assert summary['step_round_trip']['count'] >= 201

    # The bag reads back with plain rosbags and holds the whole test.
    with AnyReader([out / 'bag']) as reader:
        counts = {c.topic: c.msgcount for c in reader.connections}
        types = {c.topic: c.msgtype for c in reader.connections}
    assert counts['/pd/step_command'] >= 201
    assert counts['/pd/step_feedback'] >= 201
    assert counts['/pd/test_definition'] == 1
    assert types['/pd/step_feedback'] == 'pd_msgs/msg/StepFeedback'
    run = read_bag(out / 'bag')
    assert run.statuses[-1][1].state.name == 'FINISHED'
    if site == 'bridge':
        assert any(status.message.startswith('active') for _, status in run.bridge_statuses)
        # A move goes to the specimen as often as its command came (a late answer's re-send
        # asks again), not twice for one command.
        sent = Counter(item.key for _, item in run.events if isinstance(item, Command))
        keys = Counter(decode_command(data).record.key for data in moves)
        assert len(keys) >= 20, len(keys)  # (the observer may miss the first steps)
        assert all(count <= sent[key] for key, count in keys.items()), [
            (key, count, sent[key]) for key, count in keys.items() if count > sent[key]][:3]

    # The replay rebuilds response.csv from the bag alone.
    replay = rebuild_outputs(out / 'bag', tmp_path / 'replay', figures=False)
    assert (replay.directory / 'response.csv').read_bytes() == graph_csv


def test_graph_figures_equal_the_ros_free_ones(short_test: Path, processes: Processes,
                                               tmp_path: Path) -> None:
    """With figures on, the integrator's figure worker draws the same files as an
    in-process run (the worker's lifetime: tests/pd_core/test_figure_worker.py)."""
    from pd_core.run.record.outputs import FIGURES

    offline = tmp_path / 'offline'
    run_offline(load_test_file(short_test), offline)
    out = tmp_path / 'graph'
    launcher = run_launcher(processes, 'run_test', [str(short_test), '--site', 'direct',
                                                    '--out', str(out)])
    code = wait_exit(launcher, RUN_TIMEOUT, lambda: processes.log('run_test'))
    log = processes.log('run_test')
    assert code == 0, log[-3000:]
    assert 'figure worker' not in log  # (its failure is logged, and then drawn in-process)
    assert (out / 'response.csv').read_bytes() == (offline / 'response.csv').read_bytes()
    for name in FIGURES:
        assert (out / name).read_bytes() == (offline / name).read_bytes(), name


def test_bridge_limit_holds_and_never_reaches_the_specimen(
        rig_key: Any, processes: Processes, observer: Any, tmp_path: Path) -> None:

    from pd_msgs.msg import StepCommand, TestStatus

    limit = 0.01  # m; the column reaches ~0.049 m under El Centro
    test_file = write_test_file(tmp_path / 'limit.yaml', test__duration=6.0,
                                test__id='graph-limit')
    params = write_bridge_params(tmp_path / 'bridge.yaml', max_displacement=limit)
    forwarded: list[float] = []
    statuses: list[Any] = []
    bridge_statuses: list[Any] = []
    observer.create_subscription(StepCommand, '/pd/specimen/step_command',
                                 lambda m: forwarded.extend(m.target_displacement), 100)
    observer.create_subscription(TestStatus, '/pd/test_status', statuses.append, latched_qos())
    observer.create_subscription(TestStatus, '/pd/bridge/status', bridge_statuses.append,
                                 latched_qos())

    out = tmp_path / 'run'
    launcher = run_launcher(processes, 'run_test', [str(test_file), '--site', 'bridge',
                                                    '--out', str(out), '--no-figures',
                                                    '--bridge-params', str(params)])
    spin_until(observer, lambda: any(s.state == TestStatus.STATE_HOLDING for s in statuses),
               RUN_TIMEOUT, 'the integrator to hold')
    holding = next(s for s in statuses if s.state == TestStatus.STATE_HOLDING)
    assert 'max_displacement' in holding.message
    assert 'limit' in holding.message
    spin_until(observer, lambda: any(s.state == TestStatus.STATE_HOLDING
                                     for s in bridge_statuses), 10.0, 'the bridge status')
    time.sleep(0.5)  # nothing moves while holding
    send_control(observer, rig_key, 'abort')
    code = wait_exit(launcher, 30.0, lambda: processes.log('run_test'))
    assert code == 1

    # What reached the specimen: everything the observer saw on its command topic (it may
    # have joined late) and every position the specimen reported back through the bridge.
    assert all(abs(x) <= limit for x in forwarded)
    summary = json.loads((out / 'summary.json').read_text(encoding='utf-8'))
    assert summary['state'] == 'aborted'
    run = read_bag(out / 'bag')
    refused = [item for _, item in run.events
               if isinstance(item, Feedback) and item.status is FeedbackStatus.LIMIT]
    assert refused
    commands = {item.step: item for _, item in run.events
                if isinstance(item, Command) and item.test_id == 'graph-limit'}
    assert abs(commands[refused[0].step].target_displacement[0]) > limit
    committed = summary['steps']
    assert committed == refused[0].step - 1
    assert summary['dofs']['top']['peaks']['displacement']['abs'] <= limit
    measured = [abs(x) for _, item in run.events if isinstance(item, Feedback)
                for x in item.measured_displacement]
    assert len(measured) > committed
    assert max(measured) <= limit


def test_a_command_re_sent_while_its_move_is_in_flight_asks_the_specimen_again(
        processes: Processes, observer: Any, tmp_path: Path) -> None:
    """The specimen stalls (SIGSTOP) past step 50: the integrator's command times out and is
    re-sent; the bridge, whose move is in flight, asks the specimen again (``driver.repeat``)
    instead of moving anew or ignoring it. Resumed (SIGCONT), the specimen answers the move
    and each repeat (from its last answer, without moving): the test finishes, equal to the
    ROS-free run."""
    from pd_common.protocol import decode_command
    from pd_common.ros import STEP_QOS
    from pd_msgs.msg import StepCommand

    test_file = write_test_file(tmp_path / 'stall.yaml', test__id='graph-stall',
                                test__duration=30.0, protocol__feedback_timeout=0.3,
                                protocol__max_retries=20)
    moves: list[bytes] = []
    subscription = observer.create_subscription(
        StepCommand, '/pd/specimen/step_command', moves.append, STEP_QOS, raw=True)

    def keys() -> Counter[Any]:
        return Counter(decode_command(data).record.key for data in moves)

    specimen = processes.start('specimen', [
        executable('pd_specimen_sim'), '--ros-args', '-r', '__ns:=/pd/specimen',
        '-p', f'test_file:={test_file}'])
    processes.start('bridge', [executable('pd_actuator_bridge'), '--ros-args', '--params-file',
                               str(write_bridge_params(tmp_path / 'bridge.yaml'))])
    # The observer must hear the bridge's moves from the first (the test takes seconds).
    spin_until(observer, lambda: subscription.get_publisher_count() > 0, RUN_TIMEOUT,
               lambda: 'the bridge\'s move publisher; its log:\n' + processes.log('bridge'))
    out = tmp_path / 'run'
    integrator = processes.start('integrator', [
        executable('pd_integrator'), '--ros-args', '-p', f'test_file:={test_file}',
        '-p', f'output_dir:={out}', '-p', 'figures:=false'])
    spin_until(observer, lambda: any(key.step >= 50 for key in keys()), RUN_TIMEOUT,
               lambda: 'the bridge to move the specimen past step 50; its log:\n'
                       + processes.log('bridge')[-2000:] + '\nthe integrator\'s:\n'
                       + processes.log('integrator')[-2000:])
    Processes.signal(specimen, signal.SIGSTOP)
    try:
        spin_until(observer, lambda: max(keys().values()) >= 2, 30.0,
                   'the bridge to ask the stalled specimen again')
    finally:
        Processes.signal(specimen, signal.SIGCONT)
    code = wait_exit(integrator, RUN_TIMEOUT, lambda: processes.log('integrator'))
    assert code == 0, processes.log('integrator')[-3000:]
    summary = json.loads((out / 'summary.json').read_text(encoding='utf-8'))
    assert summary['state'] == 'finished' and summary['retries'] >= 1
    repeated = [key for key, count in keys().items() if count > 1]
    sent = Counter(item.key for _, item in read_bag(out / 'bag').events
                   if isinstance(item, Command))
    assert repeated and all(sent[key] > 1 for key in repeated), (repeated, sent.most_common(3))
    offline = tmp_path / 'offline'
    run_offline(load_test_file(test_file), offline, figures=False)
    assert (out / 'response.csv').read_bytes() == (offline / 'response.csv').read_bytes()


def test_specimen_killed_mid_test_leads_to_holding(
        rig_key: Any, processes: Processes, observer: Any, tmp_path: Path) -> None:

    from pd_msgs.msg import TestStatus

    test_file = write_test_file(tmp_path / 'kill.yaml', test__id='graph-kill',
                                protocol__feedback_timeout=0.5, protocol__max_retries=2)
    statuses: list[Any] = []
    observer.create_subscription(TestStatus, '/pd/test_status', statuses.append, latched_qos())
    out = tmp_path / 'run'
    integrator = processes.start('integrator', [
        executable('pd_integrator'), '--ros-args', '-p', f'test_file:={test_file}',
        '-p', f'output_dir:={out}', '-p', 'figures:=false', '-p', 'progress_interval:=0.05'])
    # The observer must hear the integrator before the specimen appears: on a quiet machine
    # the whole test takes about two seconds.
    spin_until(observer, lambda: bool(statuses), RUN_TIMEOUT, 'the integrator status')
    specimen = processes.start('specimen', [
        executable('pd_specimen_sim'), '--ros-args', '-p', f'test_file:={test_file}'])
    spin_until(observer, lambda: any(s.step >= 100 for s in statuses), RUN_TIMEOUT,
               'the test to pass step 100')
    Processes.signal(specimen, signal.SIGKILL)
    specimen.wait(timeout=10)
    spin_until(observer, lambda: any(s.state == TestStatus.STATE_HOLDING for s in statuses),
               30.0, 'the integrator to hold')
    holding = next(s for s in statuses if s.state == TestStatus.STATE_HOLDING)
    assert 'no feedback for step' in holding.message
    assert holding.retries >= 2
    send_control(observer, rig_key, 'abort')
    code = wait_exit(integrator, 30.0, lambda: processes.log('integrator'))
    assert code == 1

    summary = json.loads((out / 'summary.json').read_text(encoding='utf-8'))
    assert summary['state'] == 'aborted'
    assert summary['retries'] == holding.retries  # (a slow step before the kill may add one)
    steps = summary['steps']
    assert steps >= 100
    assert steps == holding.step
    # Every committed step is right: it equals the ROS-free run of the same test.
    offline = tmp_path / 'offline'
    run_offline(load_test_file(test_file), offline, figures=False)
    graph_rows = (out / 'response.csv').read_text(encoding='utf-8').splitlines()
    offline_rows = (offline / 'response.csv').read_text(encoding='utf-8').splitlines()
    assert len(graph_rows) == steps + 2  # header + steps 0..k-1
    assert graph_rows == offline_rows[:steps + 2]
    # The pending step was re-sent and never committed.
    run = read_bag(out / 'bag')
    pending = [item for _, item in run.events
               if isinstance(item, Command) and item.step == steps + 1
               and item.test_id == 'graph-kill']
    assert len(pending) == 3  # first send + 2 re-sends
    assert np.isfinite(np.loadtxt(out / 'response.csv', delimiter=',', skiprows=1)).all()


def test_invalid_test_file_is_refused_before_anything_moves(
        processes: Processes, tmp_path: Path) -> None:
    unstable = write_test_file(tmp_path / 'unstable.yaml', test__dt=0.2)
    launcher = run_launcher(processes, 'run_test', [str(unstable), '--out',
                                                    str(tmp_path / 'run')])
    code = wait_exit(launcher, 30.0, lambda: processes.log('run_test'))
    log = processes.log('run_test')
    assert code == 2
    assert 'dt' in log
    assert not (tmp_path / 'run').exists()


@pytest.mark.parametrize('case', ['probe_unstable_dt', 'bad_backbone_csv', 'yaml_alias'])
def test_bad_input_is_one_line_and_starts_nothing(
        case: str, processes: Processes, tmp_path: Path) -> None:
    """Checked before any process starts (so before the probe or anything else moves)."""
    arguments: list[str]
    if case == 'probe_unstable_dt':
        test_file = write_test_file(tmp_path / 'probe.yaml')
        arguments = ['-p', 'initial_stiffness:=probe', '-p', 'dt:=0.5']
        expected = ("probe.yaml: structure.initial_stiffness: probe: with the simulated "
                    "specimen's initial stiffness the test is unstable")
    elif case == 'bad_backbone_csv':
        (tmp_path / 'backbone.csv').write_text('0,0\n0.01,abc\n', encoding='utf-8')
        raw = yaml.safe_load(DEFAULT_TEST.read_text(encoding='utf-8'))
        raw['ground_motion']['file'] = str(RECORD)
        raw['specimen']['elements'][0]['backbone'] = {'csv': str(tmp_path / 'backbone.csv')}
        test_file = tmp_path / 'backbone.yaml'
        test_file.write_text(yaml.safe_dump(raw), encoding='utf-8')
        arguments = []
        expected = 'backbone.yaml: specimen.elements[0].backbone.csv:'
    else:
        text = write_test_file(tmp_path / 'x.yaml').read_text(encoding='utf-8')
        test_file = tmp_path / 'alias.yaml'
        test_file.write_text('bomb: &a [1, 2, 3]\n' + text.replace(
            'dof_names:\n  - top', 'dof_names: *a'), encoding='utf-8')
        arguments = []
        expected = 'alias.yaml: line 31: structure.dof_names: YAML aliases'
    out = tmp_path / 'run'
    launcher = run_launcher(processes, 'run_test', [str(test_file), '--out', str(out),
                                                    *arguments])
    code = wait_exit(launcher, 30.0, lambda: processes.log('run_test'))
    lines = [line for line in processes.log('run_test').splitlines()
             if not line.startswith('run_test: key ')]
    assert code == 2
    assert len(lines) == 1, lines
    assert lines[0].startswith(f'run_test: error: {expected}'), lines
    assert 'Traceback' not in lines[0]
    assert not out.exists()


def call_service(observer: Any, service_type: Any, name: str, request: Any) -> Any:
    """Call a service from the observer node and wait for the answer."""
    client = observer.create_client(service_type, name)
    spin_until(observer, client.service_is_ready, 20.0, f'service {name}')
    # Fast DDS may drop the first response while the client's reply reader is still being
    # matched ("failed to send response"): give discovery a moment and retry.
    deadline = time.monotonic() + 0.5
    while time.monotonic() < deadline:
        observer.executor_for_test.spin_once(timeout_sec=0.05)
    for _ in range(4):
        future = client.call_async(request)
        limit = time.monotonic() + 5.0
        while not future.done() and time.monotonic() < limit:
            observer.executor_for_test.spin_once(timeout_sec=0.05)
        if future.done():
            return future.result()
        client.remove_pending_request(future)
    pytest.fail(f'no answer from {name}')
    raise AssertionError  # unreachable


def test_bridge_lifecycle_and_latched_emergency_stop(
        rig_key: Any, processes: Processes, observer: Any, tmp_path: Path) -> None:
    from lifecycle_msgs.msg import Transition
    from lifecycle_msgs.srv import ChangeState, GetState
    from std_srvs.srv import Trigger

    from pd_msgs.msg import TestStatus

    # Long (free vibration after the record): the emergency stop must come while it runs.
    test_file = write_test_file(tmp_path / 'life.yaml', test__duration=600.0,
                                test__id='graph-life')
    params = write_bridge_params(tmp_path / 'bridge.yaml', autostart=False)
    statuses: list[Any] = []
    bridge_statuses: list[Any] = []
    observer.create_subscription(TestStatus, '/pd/test_status', statuses.append, latched_qos())
    observer.create_subscription(TestStatus, '/pd/bridge/status', bridge_statuses.append,
                                 latched_qos())
    processes.start('specimen', [executable('pd_specimen_sim'), '--ros-args', '-r',
                                 '__ns:=/pd/specimen', '-p', f'test_file:={test_file}'])
    processes.start('bridge', [executable('pd_actuator_bridge'), '--ros-args',
                               '--params-file', str(params)])
    out = tmp_path / 'run'
    integrator = processes.start('integrator', [
        executable('pd_integrator'), '--ros-args', '-p', f'test_file:={test_file}',
        '-p', f'output_dir:={out}', '-p', 'figures:=false', '-p', 'progress_interval:=0.05'])
    node = '/pd/pd_actuator_bridge'
    state = call_service(observer, GetState, f'{node}/get_state', GetState.Request())
    assert state.current_state.label == 'unconfigured'
    # An unconfigured/inactive bridge does not answer: the integrator waits, nothing moves.
    time.sleep(1.0)
    assert not any(s.state == TestStatus.STATE_RUNNING for s in statuses)
    # With a key the lifecycle service cannot be authenticated: refused; the owner's signed
    # controls move it.
    request = ChangeState.Request()
    request.transition.id = Transition.TRANSITION_CONFIGURE
    assert not call_service(observer, ChangeState, f'{node}/change_state', request).success
    assert call_service(observer, GetState, f'{node}/get_state',
                        GetState.Request()).current_state.label == 'unconfigured'
    for transition in ('configure', 'activate'):
        send_control(observer, rig_key, transition, topic='/pd/bridge/control')
    spin_until(observer, lambda: any(s.step >= 50 for s in statuses), RUN_TIMEOUT,
               'the test to pass step 50')

    answer = call_service(observer, Trigger, '/pd/bridge/emergency_stop', Trigger.Request())
    assert answer.success
    spin_until(observer, lambda: any(s.state == TestStatus.STATE_HOLDING for s in statuses),
               20.0, 'the integrator to hold after the emergency stop')
    assert any('EMERGENCY STOP' in s.message for s in bridge_statuses)
    # Nobody clears an emergency stop without the key: the services cannot be authenticated.
    refused = call_service(observer, Trigger, '/pd/bridge/reset', Trigger.Request())
    assert not refused.success
    unsigned = call_service(observer, Trigger, '/pd/bridge/reset_emergency_stop',
                            Trigger.Request())
    assert not unsigned.success and 'signed control' in unsigned.message
    # A plain (signed) reset does not clear it either; a signed reset_emergency_stop does.
    refusal = send_control(observer, rig_key, 'reset', topic='/pd/bridge/control',
                           expect='refused')
    assert 'EMERGENCY STOP' in refusal.outcome
    send_control(observer, rig_key, 'reset_emergency_stop', topic='/pd/bridge/control')
    spin_until(observer, lambda: any('reset by operator test' in s.message
                                     for s in bridge_statuses), 10.0, 'the e-stop to clear')
    assert any('unsigned: 3' in s.refused_by_reason for s in bridge_statuses)
    Processes.signal(integrator, signal.SIGINT)
    assert wait_exit(integrator, 30.0, lambda: processes.log('integrator')) == 1
    summary = json.loads((out / 'summary.json').read_text(encoding='utf-8'))
    assert summary['state'] == 'interrupted'  # a signal interrupts: the run can be resumed
    assert 'emergency' in json.dumps(summary).lower() or summary['steps'] >= 50


def test_emulator_driver_records_the_actuator_trajectory(
        processes: Processes, tmp_path: Path) -> None:
    """With a key: the bridge signs each trajectory and the integrator records it."""
    from pd_common.auth import generate_key

    key = tmp_path / 'rig.key'
    generate_key(key)
    test_file = write_test_file(tmp_path / 'emulator.yaml', test__duration=0.2,
                                test__id='graph-emulator')
    params = write_bridge_params(tmp_path / 'bridge.yaml', driver='emulator',
                                 test_file=str(test_file))
    out = tmp_path / 'run'
    launcher = run_launcher(processes, 'run_test', [str(test_file), '--site', 'none',
                                                    '--out', str(out), '--no-figures',
                                                    '--key', str(key)])
    processes.start('bridge', [executable('pd_actuator_bridge'), '--ros-args',
                               '--params-file', str(params), '-p', f'key_file:={key}'])
    code = wait_exit(launcher, RUN_TIMEOUT, lambda: processes.log('run_test'))
    assert code == 0, processes.log('run_test')[-2000:] + processes.log('bridge')[-2000:]
    run = read_bag(out / 'bag')
    assert len(run.trajectories) >= 21  # step 0 and 20 integration steps
    trajectory = run.trajectories[-1][1]
    samples = len(trajectory.time)
    assert trajectory.rate >= 1000.0
    assert len(trajectory.command) == samples * trajectory.n_dof
    assert trajectory.node == '/pd/pd_actuator_bridge' and len(trajectory.signature.mac) == 32
    summary = json.loads((out / 'summary.json').read_text(encoding='utf-8'))
    assert summary['state'] == 'finished'
    assert 'bridge_trajectory' not in summary['authentication']['refused_messages']
    # The emulated actuator settles close to the target, not exactly on it.
    error = summary['dofs']['top']['max_measurement_error']
    assert 0.0 < error < 1e-4

"""Only the owner changes the rig, every control is bound to its purpose, and stops arrive.

Separate processes over DDS; the observer node plays the rogue (no key, or a key of its own)
and the operator (the test's key). Each test attacks the rig the way a finding of the security
review did, and checks that nothing the attack aimed at happened.
"""

from __future__ import annotations

import json
import time
from pathlib import Path
from typing import Any

import pytest
from graph_support import Processes, executable, send_control
from test_graph import (
    RUN_TIMEOUT,
    latched_qos,
    spin_until,
    wait_exit,
    write_bridge_params,
    write_test_file,
)

pytestmark = pytest.mark.graph

LABS = ('lab1', 'lab3')


def start_bridges(processes: Processes, tmp_path: Path) -> None:
    """Two sites' bridges (unconfigured: an emergency stop and its reset need no more)."""
    params = write_bridge_params(tmp_path / 'bridge.yaml', autostart=False)
    for lab in LABS:
        processes.start(lab, [executable('pd_actuator_bridge'), '--ros-args', '--params-file',
                              str(params), '-r', f'__ns:=/pd/{lab}',
                              '-p', f'record_file:={tmp_path / lab}.jsonl'])


def bridge_statuses(observer: Any) -> dict[str, list[Any]]:
    from pd_msgs.msg import TestStatus

    seen: dict[str, list[Any]] = {lab: [] for lab in LABS}
    for lab, statuses in seen.items():
        observer.create_subscription(TestStatus, f'/pd/{lab}/bridge/status', statuses.append,
                                     latched_qos())
    return seen


def test_a_control_for_one_bridge_never_clears_another_and_stops_are_confirmed(
        rig_key: Any, processes: Processes, observer: Any, ros_env: dict[str, str],
        tmp_path: Path) -> None:
    from rclpy.node import Node

    from pd_msgs.msg import Control as ControlMessage

    start_bridges(processes, tmp_path)
    seen = bridge_statuses(observer)
    spin_until(observer, lambda: all(seen.values()), 30.0, 'both bridges\' statuses')

    # -- ./pd control estop: every bridge listening confirms it holds ------------------------
    control = processes.start('estop', [executable('pd_bringup', 'control'), 'estop',
                                        '--reason', 'hands off'])
    assert wait_exit(control, 40.0, lambda: processes.log('estop')) == 0, \
        processes.log('estop')
    said = processes.log('estop')
    assert 'holding: /pd/lab1/pd_actuator_bridge, /pd/lab3/pd_actuator_bridge' in said, said
    spin_until(observer, lambda: all(s[-1].emergency_stop for s in seen.values()), 10.0,
               'both bridges to latch the stop')

    # -- a signed reset for lab1, republished to lab3: lab3 stays stopped --------------------
    captured: list[Any] = []
    observer.create_subscription(ControlMessage, '/pd/lab1/bridge/control', captured.append,
                                 10)
    send_control(observer, rig_key, 'reset_emergency_stop', topic='/pd/lab1/bridge/control')
    spin_until(observer, lambda: not seen['lab1'][-1].emergency_stop and bool(captured), 10.0,
               'lab1 to clear its stop')
    to_lab3 = observer.create_publisher(ControlMessage, '/pd/lab3/bridge/control', 10)
    spin_until(observer, lambda: to_lab3.get_subscription_count() > 0, 10.0, 'lab3')
    for _ in range(3):
        to_lab3.publish(captured[-1])
        observer.executor_for_test.spin_once(timeout_sec=0.1)
    spin_until(observer, lambda: 'misdirected' in seen['lab3'][-1].refused_by_reason, 10.0,
               'lab3 to refuse the control meant for lab1')
    assert seen['lab3'][-1].emergency_stop
    # ... nor does a replay to lab1 clear its next stop.
    control = processes.start('estop2', [executable('pd_bringup', 'control'), 'estop'])
    assert wait_exit(control, 40.0, lambda: processes.log('estop2')) == 0
    spin_until(observer, lambda: seen['lab1'][-1].emergency_stop, 10.0, 'lab1 stopped again')
    to_lab1 = observer.create_publisher(ControlMessage, '/pd/lab1/bridge/control', 10)
    spin_until(observer, lambda: to_lab1.get_subscription_count() > 0, 10.0, 'lab1')
    to_lab1.publish(captured[-1])
    spin_until(observer, lambda: 'replayed' in seen['lab1'][-1].refused_by_reason, 10.0,
               'lab1 to refuse the replay')
    assert seen['lab1'][-1].emergency_stop

    # -- a listener that calls itself a bridge but never holds: named, exit 1 ----------------
    # (and a rogue copies lab1's genuine, signed "holding" status onto the impostor's status
    # topic as it comes: a status is believed only on its own node's topic, so the copy
    # confirms nothing)
    from pd_msgs.msg import TestStatus

    impostor = Node('pd_actuator_bridge', namespace='/pd/lab9', context=observer.context)
    from std_msgs.msg import String
    impostor.create_subscription(String, '/pd/emergency_stop', lambda _: None, 10)
    copies = impostor.create_publisher(TestStatus, '/pd/lab9/bridge/status', latched_qos())
    observer.executor_for_test.add_node(impostor)
    copied: list[Any] = []
    control = processes.start('estop3', [executable('pd_bringup', 'control'), 'estop',
                                         '--timeout', '4'])
    while control.poll() is None:
        if seen['lab1'][-1].emergency_stop and (not copied or copied[-1] is not seen['lab1'][-1]):
            copied.append(seen['lab1'][-1])
            copies.publish(copied[-1])
        observer.executor_for_test.spin_once(timeout_sec=0.1)
    assert copied
    said = processes.log('estop3')
    assert control.returncode == 1, said
    assert 'not confirmed by /pd/lab9/pd_actuator_bridge' in said
    assert 'lab1' not in said.split('not confirmed by')[1]  # the real bridges confirmed
    observer.executor_for_test.remove_node(impostor)
    impostor.destroy_node()


def test_a_control_of_one_test_is_refused_by_the_next(
        rig_key: Any, key_file: Path, processes: Processes, observer: Any,
        tmp_path: Path) -> None:
    """A signed resume captured from test A, replayed at once to test B (same test file, same
    rig key) leaves B paused; ``./pd control`` with one more listener on the control topic
    still reaches the integrator and says what it did."""
    from pd_msgs.msg import Control as ControlMessage
    from pd_msgs.msg import TestStatus

    test_file = write_test_file(tmp_path / 'twice.yaml', test__duration=600.0,
                                test__id='graph-twice')
    statuses: list[Any] = []
    observer.create_subscription(TestStatus, '/pd/test_status', statuses.append, latched_qos())
    captured: list[Any] = []  # one more listener on the control topic
    observer.create_subscription(ControlMessage, '/pd/test_control', captured.append, 10)

    # One simulator for both runs (a rig started by hand): the second run of the same test
    # file is a new run to it, not stale steps of the first.
    processes.start('specimen', [executable('pd_specimen_sim'), '--ros-args',
                                 '-p', f'test_file:={test_file}'])

    def run(name: str) -> Any:
        integrator = processes.start(name, [
            executable('pd_integrator'), '--ros-args', '-p', f'test_file:={test_file}',
            '-p', f'output_dir:={tmp_path / name}', '-p', 'figures:=false',
            '-p', 'progress_interval:=0.2'])
        spin_until(observer, lambda: bool(statuses) and statuses[-1].state == 1
                   and statuses[-1].step > 20, RUN_TIMEOUT, f'test {name} to run')
        return integrator

    first = run('first')
    # The CLI waits for its receiver (the integrator), not for every listener: on a loaded
    # machine this observer may match the short-lived CLI too late to capture the resume; the
    # cycle is repeated (every try must still be confirmed) until one is captured.
    reason = 'foreign_session'  # B never saw the CLI's signing session
    for attempt in range(3):
        for command in ('pause', 'resume', 'pause'):
            name = f'cli-{command}-{attempt}'
            cli = processes.start(name, [executable('pd_bringup', 'control'), command,
                                         '--reason', 'graph test'])
            while cli.poll() is None:
                observer.executor_for_test.spin_once(timeout_sec=0.1)
            said = processes.log(name)
            assert cli.returncode == 0, said
            assert f'control: {command} taken by /pd/pd_integrator (test \'graph-twice\'): ok' \
                in said
        if any(m.command == 'resume' for m in captured):
            break
    else:  # never matched in time: a resume of test A signed here is as genuine a capture
        reason = 'replayed'  # (B will have seen this sender's later controls)
        send_control(observer, rig_key, 'resume')
        send_control(observer, rig_key, 'pause')
        spin_until(observer, lambda: any(m.command == 'resume' for m in captured), 10.0,
                   'the resume to be captured')
    resume = next(m for m in reversed(captured) if m.command == 'resume')
    send_control(observer, rig_key, 'abort')
    assert wait_exit(first, 30.0, lambda: processes.log('first')) == 1
    statuses.clear()

    second = run('second')
    send_control(observer, rig_key, 'pause')
    spin_until(observer, lambda: statuses[-1].state == TestStatus.STATE_PAUSED, 20.0,
               'the second test to pause')
    replay = observer.create_publisher(ControlMessage, '/pd/test_control', 10)
    spin_until(observer, lambda: replay.get_subscription_count() > 0, 10.0, 'the integrator')
    replay.publish(resume)  # within its 30 s window, signed with the rig's key
    spin_until(observer, lambda: 'foreign_session' in statuses[-1].refused_by_reason
               or 'replayed' in statuses[-1].refused_by_reason, 10.0,
               'the second test to refuse the first test\'s resume')
    deadline = time.monotonic() + 1.0
    while time.monotonic() < deadline:
        observer.executor_for_test.spin_once(timeout_sec=0.05)
    assert statuses[-1].state == TestStatus.STATE_PAUSED
    send_control(observer, rig_key, 'abort')
    assert wait_exit(second, 30.0, lambda: processes.log('second')) == 1
    summary = json.loads((tmp_path / 'second' / 'summary.json').read_text(encoding='utf-8'))
    assert reason in summary['authentication']['refused_messages']['test_control']


def test_text_on_the_open_channels_is_bounded(
        rig_key: Any, processes: Processes, observer: Any, tmp_path: Path) -> None:
    """Megabyte reasons on the emergency stop and a megabyte control: the stop holds, the
    records and logs stay small, the control is refused as malformed."""
    from std_msgs.msg import String

    from pd_msgs.msg import Control as ControlMessage
    from pd_msgs.msg import TestStatus

    test_file = write_test_file(tmp_path / 'bounds.yaml', test__duration=600.0,
                                test__id='graph-bounds')
    params = write_bridge_params(tmp_path / 'bridge.yaml')
    processes.start('specimen', [executable('pd_specimen_sim'), '--ros-args', '-r',
                                 '__ns:=/pd/specimen', '-p', f'test_file:={test_file}'])
    processes.start('bridge', [executable('pd_actuator_bridge'), '--ros-args', '--params-file',
                               str(params), '-p', f'record_file:={tmp_path / "bridge.jsonl"}'])
    out = tmp_path / 'run'
    integrator = processes.start('integrator', [
        executable('pd_integrator'), '--ros-args', '-p', f'test_file:={test_file}',
        '-p', f'output_dir:={out}', '-p', 'figures:=false'])
    statuses: list[Any] = []
    bridge: list[Any] = []
    observer.create_subscription(TestStatus, '/pd/test_status', statuses.append, latched_qos())
    observer.create_subscription(TestStatus, '/pd/bridge/status', bridge.append, latched_qos())
    spin_until(observer, lambda: bool(statuses) and statuses[-1].step > 50, RUN_TIMEOUT,
               'the test to run')
    huge = 'X' * (8 << 20)
    stops = [observer.create_publisher(String, topic, 10)
             for topic in ('/pd/emergency_stop', '/pd/bridge/emergency_stop')]
    controls = observer.create_publisher(ControlMessage, '/pd/bridge/control', 10)
    spin_until(observer, lambda: all(p.get_subscription_count() > 0 for p in stops)
               and controls.get_subscription_count() > 0, 10.0, 'the listeners')
    for _ in range(5):
        for publisher in stops:
            publisher.publish(String(data=huge))
        big = ControlMessage()
        big.command = 'reset_emergency_stop'
        big.reason = huge[:1 << 20]
        controls.publish(big)
        observer.executor_for_test.spin_once(timeout_sec=0.2)
    spin_until(observer, lambda: bridge[-1].emergency_stop and statuses[-1].emergency_stop
               and 'malformed' in bridge[-1].refused_by_reason, 30.0,
               'the stop to hold and the big control to be refused')
    assert len(bridge[-1].message) < 400 and len(statuses[-1].message) < 400
    send_control(observer, rig_key, 'abort')
    assert wait_exit(integrator, 60.0, lambda: processes.log('integrator')) == 1
    # Nothing the rogue wrote was kept longer than the bound: not in the run folder (journal,
    # bag, summary), the bridge's record or a log.
    kept = [*(path for path in out.rglob('*') if path.is_file()), tmp_path / 'bridge.jsonl',
            tmp_path / 'bridge.log', tmp_path / 'integrator.log']
    for path in kept:
        assert b'X' * 300 not in path.read_bytes(), path
    assert (tmp_path / 'bridge.jsonl').stat().st_size < 10_000

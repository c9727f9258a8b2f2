"""A stop stays a stop: no crash, restart or supervisor clears a person's pause or an
emergency stop, and a physical rig's bridges outlive everything but an explicit shutdown.

Each test kills processes of a running ``./pd run`` (SIGKILL, SIGSTOP, SIGHUP) and checks that
nothing moves until a person's signed control says so, and that the finished test is the
uninterrupted ROS-free run byte for byte.
"""

from __future__ import annotations

import json
import os
import signal
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
from graph_support import Processes, send_control
from test_crash_resume import child_of, children, command_line, wait_for_step
from test_graph import (
    RUN_TIMEOUT,
    latched_qos,
    run_launcher,
    spin_until,
    wait_exit,
    write_bridge_params,
    write_test_file,
)

from pd_core.run.runner import run_offline
from pd_core.run.test_file import load_test_file
from support import journals

pytestmark = pytest.mark.graph

BRIDGE_CONTROL = '/pd/bridge/control'


@pytest.fixture(scope='module')
def long_test(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The default test cut to 60 s (6,000 steps): long enough to stop it several times, with
    seconds to spare after step 300 on a fast machine (it steps at about 2,000 a second)."""
    directory = tmp_path_factory.mktemp('holds')
    return write_test_file(directory / 'holds.yaml', test__duration=60.0,
                           test__id='graph-holds')


@pytest.fixture(scope='module')
def long_reference(long_test: Path, tmp_path_factory: pytest.TempPathFactory) -> bytes:
    out = tmp_path_factory.mktemp('holds-reference') / 'run'
    run_offline(load_test_file(long_test), out, figures=False)
    return (out / 'response.csv').read_bytes()


def committed_steps(out: Path) -> int:
    """Steps committed so far: the OK feedback in the journal (a refusal, such as an
    emergency stop's fault, commits nothing)."""
    return journals.committed_steps(out / 'journal.pdj', ok_only=True)


class Watch:
    """The latest genuine status of the integrator and of the bridge, as the observer hears
    them."""

    def __init__(self, observer: Any) -> None:
        from pd_msgs.msg import TestStatus

        self.observer = observer
        self.test: list[Any] = []
        self.bridge: list[Any] = []
        observer.create_subscription(TestStatus, '/pd/test_status', self.test.append,
                                     latched_qos())
        observer.create_subscription(TestStatus, '/pd/bridge/status', self.bridge.append,
                                     latched_qos())

    def until(self, predicate: Callable[[], bool], what: str, timeout: float = 30.0) -> None:
        """Spin until ``predicate()`` (an IndexError: no status yet, not true yet)."""
        def holds() -> bool:
            try:
                return predicate()
            except IndexError:
                return False

        spin_until(self.observer, holds, timeout, lambda: f'{what}; last statuses: '
                   f'test {self._last(self.test)}, bridge {self._last(self.bridge)}')

    @staticmethod
    def _last(statuses: list[Any]) -> str:
        if not statuses:
            return 'none'
        s = statuses[-1]
        return (f'(state {s.state}, {s.message!r}, estop {s.emergency_stop}, '
                f'person {s.operator_hold}, session {s.session[:6]})')

    def still(self, out: Path, seconds: float = 1.5) -> None:
        """Nothing is committed for ``seconds`` (the test holds)."""
        held = committed_steps(out)
        deadline = time.monotonic() + seconds
        while time.monotonic() < deadline:
            self.observer.executor_for_test.spin_once(timeout_sec=0.05)
        assert committed_steps(out) == held, 'the test moved on while a person held it'


def restarted(launcher: Any, kind: str, victim: int, timeout: float = 30.0) -> int:
    """Wait until run_test has a new child of ``kind`` (not ``victim``); its pid."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        try:
            pid = child_of(launcher, kind)
        except pytest.fail.Exception:
            pid = victim
        if pid != victim:
            return pid
        time.sleep(0.1)
    pytest.fail(f'run_test did not restart the {kind}')
    raise AssertionError  # unreachable


def test_a_crash_never_clears_a_pause_or_an_emergency_stop(
        long_test: Path, long_reference: bytes, rig_key: Any, processes: Processes,
        observer: Any, tmp_path: Path) -> None:
    from std_msgs.msg import String

    watch = Watch(observer)
    out = tmp_path / 'run'
    launcher = run_launcher(processes, 'run_test', [str(long_test), '--out', str(out),
                                                    '--no-figures'])  # restart policy
    wait_for_step(out, 300, launcher, processes)

    # -- a person pauses; every process of the test is killed in turn ------------------------
    send_control(observer, rig_key, 'pause', reason='lunch')
    watch.until(lambda: bool(watch.test) and watch.test[-1].operator_hold, 'the pause')
    for kind in ('simulator', 'bridge', 'integrator'):
        victim = child_of(launcher, kind)
        before = watch.test[-1].session
        os.kill(victim, signal.SIGKILL)
        restarted(launcher, kind, victim)
        if kind == 'integrator':  # the restarted integrator restores the person's pause
            watch.until(lambda before=before: watch.test[-1].session != before
                        and watch.test[-1].operator_hold, 'the restarted integrator, paused')
        else:
            time.sleep(3.0)  # (run_test sees it back and decides)
        watch.still(out)
        assert watch.test[-1].operator_hold, f'the {kind} restart cleared the pause'
    log = processes.log('run_test')
    assert 'the test stays held: a person holds it' in log, log[-2000:]
    assert 'resuming the test' not in log

    # -- an emergency stop; the bridge is killed: its restart still holds it ----------------
    stops = observer.create_publisher(String, '/pd/emergency_stop', 10)
    deadline = time.monotonic() + 20.0
    while not (watch.bridge and watch.bridge[-1].emergency_stop):
        assert time.monotonic() < deadline, 'the bridge did not latch the emergency stop'
        stops.publish(String(data='a person in the cell'))
        observer.executor_for_test.spin_once(timeout_sec=0.2)
    victim = child_of(launcher, 'bridge')
    os.kill(victim, signal.SIGKILL)
    restarted(launcher, 'bridge', victim)
    watch.until(lambda: watch.bridge[-1].emergency_stop and 'a person in the cell'
                in watch.bridge[-1].message and bool(watch.bridge[-1].session)
                and child_of(launcher, 'bridge') != victim,
                'the restarted bridge to hold the latched emergency stop')
    # A person's resume of the test does not clear the bridge's stop: nothing moves.
    send_control(observer, rig_key, 'resume')
    watch.still(out, 2.0)
    assert watch.bridge[-1].emergency_stop

    # -- a person clears the stop and resumes: the test ends as if nothing happened ---------
    send_control(observer, rig_key, 'reset_emergency_stop', topic=BRIDGE_CONTROL)
    send_control(observer, rig_key, 'resume')
    code = wait_exit(launcher, RUN_TIMEOUT, lambda: processes.log('run_test'))
    assert code == 0, processes.log('run_test')[-3000:]
    assert (out / 'response.csv').read_bytes() == long_reference
    # The audit trail: who did what, in the journal and in the bridge's record.
    summary = json.loads((out / 'summary.json').read_text(encoding='utf-8'))
    controls = [(e['command'], e['sender'], e['outcome']) for e in summary['run_events']
                if e['what'] == 'control']
    assert ('pause', 'operator test (graph test)', 'ok') in controls
    assert any(c == 'auto_hold' and s == 'run_test' for c, s, _ in controls)
    record = [json.loads(line) for line in
              (out / 'bridge.record.jsonl').read_text(encoding='utf-8').splitlines()]
    whats = [event['what'] for event in record]
    assert 'emergency_stop' in whats and 'holds_cleared' in whats
    cleared = next(event for event in record if event['what'] == 'holds_cleared')
    assert cleared['by'] == 'operator test (graph test)' and cleared['emergency']


def test_an_emergency_stop_of_a_paused_test_is_no_replay(
        long_test: Path, rig_key: Any, processes: Processes, observer: Any,
        tmp_path: Path) -> None:
    """Paused, nothing is in flight: the bridge that latches an emergency stop answers its last
    command again, as a fault (signed for the same request). The integrator takes it as the
    bridge's word, not as a replay: no "refused ... replayed" alarm, none in the summary's
    authentication record (it was, before: every such stop read as an attack)."""
    from std_msgs.msg import String

    watch = Watch(observer)
    out = tmp_path / 'run'
    launcher = run_launcher(processes, 'run_test', [str(long_test), '--out', str(out),
                                                    '--no-figures'])
    wait_for_step(out, 300, launcher, processes)
    send_control(observer, rig_key, 'pause', reason='nothing in flight')
    watch.until(lambda: watch.test[-1].operator_hold, 'the pause')
    time.sleep(0.5)  # (the step in flight when the pause came is answered and committed)
    watch.still(out, 0.5)
    stops = observer.create_publisher(String, '/pd/emergency_stop', 10)
    deadline = time.monotonic() + 20.0
    while not (watch.bridge and watch.bridge[-1].emergency_stop
               and watch.test[-1].emergency_stop):
        assert time.monotonic() < deadline, 'the emergency stop did not latch'
        stops.publish(String(data='a person in the cell'))
        observer.executor_for_test.spin_once(timeout_sec=0.2)
    watch.still(out, 1.0)  # (the bridge's fault answer has arrived by now)
    assert 'replayed' not in watch.test[-1].refused_by_reason, watch.test[-1].refused_by_reason
    send_control(observer, rig_key, 'abort')
    assert wait_exit(launcher, RUN_TIMEOUT, lambda: processes.log('run_test')) != 0
    summary = json.loads((out / 'summary.json').read_text(encoding='utf-8'))
    assert summary['state'] == 'aborted'
    refused = summary['authentication']['refused_messages']
    assert 'feedback[default]' not in refused, refused
    assert 'refused message on /pd/step_feedback' not in processes.log('run_test')


def test_a_physical_rig_keeps_its_bridge_up_through_every_crash(
        long_test: Path, long_reference: bytes, rig_key: Any, processes: Processes,
        observer: Any, tmp_path: Path) -> None:
    """Under ``--on-child-exit hold``: the integrator dies (restarted from its journal, held),
    run_test gets SIGHUP (goes on), run_test is killed (the bridge stays up, holding), and
    ``./pd run --resume`` adopts the live bridge; one bridge process from start to end."""
    watch = Watch(observer)
    out = tmp_path / 'run'
    launcher = run_launcher(processes, 'run_test', [str(long_test), '--out', str(out),
                                                    '--no-figures', '--on-child-exit', 'hold'])
    wait_for_step(out, 300, launcher, processes)
    bridge = child_of(launcher, 'bridge')

    os.kill(child_of(launcher, 'integrator'), signal.SIGKILL)
    watch.until(lambda: watch.test[-1].state == 3 and 'holds' in watch.test[-1].message
                and 'restored' in watch.test[-1].message, 'the restarted integrator to hold')
    watch.still(out)
    assert Path(f'/proc/{bridge}').exists() and child_of(launcher, 'bridge') == bridge
    send_control(observer, rig_key, 'resume')
    wait_for_step(out, 900, launcher, processes)

    os.kill(launcher.pid, signal.SIGHUP)  # the operator's terminal is closed
    wait_for_step(out, 1200, launcher, processes)
    assert launcher.poll() is None
    assert 'the terminal hung up (SIGHUP)' in (out / 'run_test.log').read_text(encoding='utf-8')

    os.kill(launcher.pid, signal.SIGKILL)  # and then run_test itself dies
    launcher.wait(timeout=10)
    time.sleep(2.0)
    assert Path(f'/proc/{bridge}').exists() and 'pd_actuator_bridge' in command_line(bridge)
    resumed = run_launcher(processes, 'resume', ['--resume', str(out)])
    watch.until(lambda: resumed.poll() is not None or (bool(watch.test) and watch.test[-1]
                                                       .state == 3), 'the resumed run')
    if resumed.poll() is None and watch.test[-1].state == 3:
        send_control(observer, rig_key, 'resume')
    code = wait_exit(resumed, RUN_TIMEOUT, lambda: processes.log('resume'))
    assert code == 0, processes.log('resume')[-3000:]
    assert 'adopted, not started again' in processes.log('resume')
    assert bridge not in children(resumed.pid)
    assert (out / 'response.csv').read_bytes() == long_reference
    deadline = time.monotonic() + 15.0  # the explicit shutdown: the adopted bridge goes last
    while Path(f'/proc/{bridge}').exists() and command_line(bridge):
        assert time.monotonic() < deadline, 'the adopted bridge was not shut down'
        time.sleep(0.1)


def test_a_hung_process_is_found_and_restarted(
        long_test: Path, long_reference: bytes, processes: Processes, tmp_path: Path) -> None:
    out = tmp_path / 'run'
    launcher = run_launcher(processes, 'run_test', [str(long_test), '--out', str(out),
                                                    '--no-figures', '--hung-timeout', '3'])
    wait_for_step(out, 300, launcher, processes)
    victim = child_of(launcher, 'simulator')
    os.kill(victim, signal.SIGSTOP)  # alive, but answers nothing
    code = wait_exit(launcher, RUN_TIMEOUT, lambda: processes.log('run_test'))
    log = processes.log('run_test')
    # (all of run_test's lines from the stop on: its supervisor's and every node's)
    assert code == 0, log[log.find('stopped answering') - 3000:][-20000:]
    assert 'pd_specimen_sim stopped answering: nothing from it for' in log
    assert (out / 'response.csv').read_bytes() == long_reference


def test_a_hung_simulator_whose_bridge_timed_out_first_is_restarted_and_the_test_goes_on(
        long_test: Path, long_reference: bytes, processes: Processes, tmp_path: Path) -> None:
    """The bridge's driver gives up on the hung simulator (its timeout, 1 s) before run_test
    finds it hung (3 s): the bridge already holds for its own reason when the supervisor's
    hold arrives. That hold is the supervisor's from then on (the driver timed out waiting for
    the very process it restarts), so the restart ends the hold and the test goes on, bit for
    bit (it used to wait 30 s and leave the test held for a person)."""
    params = write_bridge_params(tmp_path / 'bridge.yaml', driver_timeout=1.0)
    out = tmp_path / 'run'
    launcher = run_launcher(processes, 'run_test', [
        str(long_test), '--out', str(out), '--no-figures', '--hung-timeout', '3',
        '--bridge-params', str(params)])
    wait_for_step(out, 300, launcher, processes)
    os.kill(child_of(launcher, 'simulator'), signal.SIGSTOP)
    code = wait_exit(launcher, RUN_TIMEOUT, lambda: processes.log('run_test'))
    log = processes.log('run_test')
    tail = log[log.find('stopped answering') - 3000:][-20000:]
    assert code == 0, tail
    timed_out = log.find('holding: actuator did not reach step')
    assert 0 <= timed_out < log.find('pd_specimen_sim stopped answering'), tail
    assert 'pd_specimen_sim is back; resuming the test' in log, tail
    assert 'did not come back' not in log and 'a person resets it' not in log, tail
    assert (out / 'response.csv').read_bytes() == long_reference


def test_finished_and_interrupted_runs_print_no_traceback(
        processes: Processes, tmp_path: Path) -> None:
    """The demo's end, several times: the nodes' teardown (a bridge's last check of its
    driver after the context is down, a log line after rclpy shut down) prints nothing but its
    lines: no traceback, no rosout failure."""
    short = write_test_file(tmp_path / 'short.yaml', test__duration=2.0, test__id='graph-end')
    logs = []
    for run in range(3):
        name = f'run{run}'
        launcher = run_launcher(processes, name, [str(short), '--out', str(tmp_path / name),
                                                  '--no-figures'])
        assert wait_exit(launcher, RUN_TIMEOUT, lambda name=name: processes.log(name)) == 0
        logs.append(processes.log(name))
    long = write_test_file(tmp_path / 'long.yaml', test__duration=600.0, test__id='graph-int')
    launcher = run_launcher(processes, 'interrupted', [str(long), '--out',
                                                      str(tmp_path / 'interrupted'),
                                                      '--no-figures'])
    wait_for_step(tmp_path / 'interrupted', 300, launcher, processes)
    Processes.signal(launcher, signal.SIGINT)
    assert wait_exit(launcher, 60.0, lambda: processes.log('interrupted')) != 0
    logs.append(processes.log('interrupted'))
    for log in logs:
        assert 'Traceback' not in log, log[-3000:]
        assert 'Failed to publish log message' not in log, log[-3000:]
        assert 'RCLError' not in log, log[-3000:]


def test_a_full_disk_ends_the_test_in_one_line(processes: Processes, tmp_path: Path) -> None:
    """The integrator's journal cannot grow (a file-size limit: the disk is full for it): the
    test ends with one line naming the journal and ./pd recover, exit 1, no traceback."""
    from graph_support import executable

    test_file = write_test_file(tmp_path / 'full.yaml', test__duration=60.0,
                                test__id='graph-full')
    processes.start('specimen', [executable('pd_specimen_sim'), '--ros-args',
                                 '-p', f'test_file:={test_file}'])
    out = tmp_path / 'run'
    integrator = processes.start('integrator', [
        'bash', '-c', 'ulimit -f 200 && exec "$@"', 'integrator', executable('pd_integrator'),
        '--ros-args', '-p', f'test_file:={test_file}', '-p', f'output_dir:={out}',
        '-p', 'figures:=false'])
    assert wait_exit(integrator, RUN_TIMEOUT, lambda: processes.log('integrator')) == 1
    log = processes.log('integrator')
    assert 'Traceback' not in log and 'FATAL' not in log, log[-3000:]
    errors = [line for line in log.splitlines() if '[ERROR]' in line]
    assert len(errors) == 1 and 'journal.pdj: cannot write the journal' in errors[0]
    assert f'./pd recover {out}' in errors[0]

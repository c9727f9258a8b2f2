"""Crashes in the middle of a test, with real processes over DDS.

Every process of ``./pd run`` is SIGKILLed at a step drawn at random (seeded, printed), and
the test must end exactly as the uninterrupted ROS-free run of the same test file ends:
``response.csv`` byte for byte.

* integrator, simulator or bridge killed: run_test restarts it with its state (journal,
  specimen state file, actuator position) and the test resumes on its own;
* ``--on-child-exit hold``: the test holds instead, and ``./pd run --resume`` finishes it;
* run_test itself killed: its children die with it (no orphan keeps moving a specimen), and
  ``--resume`` finishes the test from the run folder alone;
* a simulator restarted *without* its state (a fresh specimen) is refused: the test holds and
  commits nothing it answers.
"""

from __future__ import annotations

import json
import os
import random
import resource
import signal
import subprocess
import time
from pathlib import Path
from typing import Any

import pytest
from graph_support import Processes, executable, send_control
from test_graph import (
    RUN_TIMEOUT,
    latched_qos,
    run_launcher,
    spin_until,
    wait_exit,
    write_test_file,
)

from pd_core.run.runner import run_offline
from pd_core.run.test_file import load_test_file
from support import journals

pytestmark = pytest.mark.graph

STEPS = 600
_LIB = {'integrator': 'lib/pd_integrator/main', 'simulator': 'lib/pd_specimen_sim/main',
        'bridge': 'lib/pd_actuator_bridge/main'}


@pytest.fixture(scope='module')
def crash_test(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The default test cut to 6 s (600 steps, through the yielding of the column)."""
    directory = tmp_path_factory.mktemp('crash')
    return write_test_file(directory / 'crash.yaml', test__duration=STEPS / 100,
                           test__id='graph-crash')


@pytest.fixture(scope='module')
def reference(crash_test: Path, tmp_path_factory: pytest.TempPathFactory) -> bytes:
    """``response.csv`` of the ROS-free run of the crash test."""
    out = tmp_path_factory.mktemp('reference') / 'run'
    run_offline(load_test_file(crash_test), out, figures=False)
    return (out / 'response.csv').read_bytes()


def children(pid: int) -> list[int]:
    """The live child processes of ``pid``."""
    path = Path(f'/proc/{pid}/task/{pid}/children')
    try:
        return [int(p) for p in path.read_text().split()]
    except OSError:
        return []


def command_line(pid: int) -> str:
    try:
        return Path(f'/proc/{pid}/cmdline').read_bytes().replace(b'\0', b' ').decode()
    except OSError:
        return ''


def child_of(launcher: subprocess.Popen[bytes], kind: str) -> int:
    """The pid of run_test's child of ``kind``."""
    for pid in children(launcher.pid):
        if _LIB[kind] in command_line(pid):
            return pid
    pytest.fail(f'run_test has no {kind} child')
    raise AssertionError  # unreachable


def committed_steps(out: Path) -> int:
    """Steps whose feedback is in the journal so far (the file as a crash would leave it)."""
    return journals.committed_steps(out / 'journal.pdj')


def wait_for_step(out: Path, step: int, launcher: subprocess.Popen[bytes],
                  processes: Processes) -> None:
    deadline = time.monotonic() + RUN_TIMEOUT
    while committed_steps(out) < step:
        if launcher.poll() is not None or time.monotonic() > deadline:
            pytest.fail(f'the test never reached step {step}:\n'
                        f'{processes.log("run_test")[-3000:]}')
        time.sleep(0.02)


def kill_step(label: str) -> int:
    """A step to kill at: drawn at random, seeded by the case (printed on a failure)."""
    step = random.Random(f'crash-{label}').randint(60, STEPS - 150)
    print(f'killing at step {step} ({label})')
    return step


def summary(out: Path) -> dict[str, Any]:
    return dict(json.loads((out / 'summary.json').read_text(encoding='utf-8')))


@pytest.mark.parametrize('kind', ['integrator', 'simulator', 'bridge'])
def test_a_killed_process_is_restarted_with_its_state_and_the_test_is_unchanged(
        kind: str, crash_test: Path, reference: bytes, processes: Processes,
        tmp_path: Path) -> None:
    out = tmp_path / 'run'
    launcher = run_launcher(processes, 'run_test', [str(crash_test), '--out', str(out),
                                                    '--no-figures'])
    wait_for_step(out, kill_step(kind), launcher, processes)
    victim = child_of(launcher, kind)
    os.kill(victim, signal.SIGKILL)
    code = wait_exit(launcher, RUN_TIMEOUT, lambda: processes.log('run_test'))
    log = processes.log('run_test')
    assert code == 0, log[-3000:]
    assert 'SIGKILL' in log and 'restart' in log
    assert (out / 'response.csv').read_bytes() == reference
    result = summary(out)
    assert result['state'] == 'finished'
    assert result['steps'] == STEPS
    assert result['restarts'] == 1
    events = [event['what'] for event in result['run_events']]
    assert ('resumed' if kind == 'integrator' else 'restart') in events
    if kind == 'simulator':
        assert 'restored the specimen from' in log
    if kind == 'bridge':
        # The restarted bridge starts from the specimen's position, not from zero.
        ready = [line.split('actuator at [')[1].split(']')[0] for line in log.splitlines()
                 if 'ready: actuator at [' in line]
        assert len(ready) == 2, ready
        assert float(ready[0]) == 0.0 and abs(float(ready[1])) > 1e-4


def test_a_simulator_whose_disk_fills_ends_in_one_line_and_is_restarted_with_its_state(
        crash_test: Path, reference: bytes, processes: Processes, tmp_path: Path) -> None:
    """The simulator's state file cannot grow any more (a full disk: its process may write
    no file past a few more lines, RLIMIT_FSIZE): the move it cannot record is not answered,
    the simulator ends with one line naming its state file, and run_test restarts it from the
    file; the test ends as the uninterrupted one."""
    out = tmp_path / 'run'
    launcher = run_launcher(processes, 'run_test', [str(crash_test), '--out', str(out),
                                                    '--no-figures'])
    wait_for_step(out, kill_step('full disk'), launcher, processes)
    victim = child_of(launcher, 'simulator')
    [state] = out.glob('specimen*.state.jsonl')
    limit = state.stat().st_size + 600  # (a few lines more: write(2) fails with EFBIG then)
    # (the limit binds every file the simulator writes: its log, run_test's, must stay below
    # it for the error line to be written)
    assert (tmp_path / 'run_test.log').stat().st_size < limit - 2000
    resource.prlimit(victim, resource.RLIMIT_FSIZE, (limit, limit))
    code = wait_exit(launcher, RUN_TIMEOUT, lambda: processes.log('run_test'))
    log = processes.log('run_test')
    assert code == 0, log[-3000:]
    errors = [line for line in log.splitlines() if 'pd_specimen_sim: error:' in line]
    assert len(errors) == 1, log[-3000:]
    assert f'{state}: cannot write the specimen state file (File too large)' in errors[0]
    assert 'Traceback' not in log  # nor the executor's report of an escaped exception
    assert 'Exception in' not in log and 'Error occurred at' not in log
    assert 'restored the specimen from' in log
    assert (out / 'response.csv').read_bytes() == reference
    result = summary(out)
    assert (result['state'], result['steps'], result['restarts']) == ('finished', STEPS, 1)


def counted_as_a_persons_resume(out: Path, log: str) -> None:
    """A person's resume, not a restart run_test made: said so by run_test, counted so."""
    result = summary(out)
    assert (result['restarts'], result['resumes']) == (0, 1)
    assert log.rstrip().splitlines()[-1].endswith(f'steps in {result["wall_time"]:.2f} s, '
                                                  f'1 resume(s); outputs in {out}')


def test_hold_on_child_exit_then_resume_from_the_run_folder(
        crash_test: Path, reference: bytes, processes: Processes, observer: Any,
        tmp_path: Path) -> None:
    from pd_msgs.msg import TestStatus

    statuses: list[Any] = []
    observer.create_subscription(TestStatus, '/pd/test_status', statuses.append, latched_qos())
    out = tmp_path / 'run'
    launcher = run_launcher(processes, 'run_test', [str(crash_test), '--out', str(out),
                                                    '--no-figures', '--on-child-exit', 'hold'])
    wait_for_step(out, kill_step('hold'), launcher, processes)
    os.kill(child_of(launcher, 'simulator'), signal.SIGKILL)
    spin_until(observer, lambda: any(s.state == TestStatus.STATE_HOLDING for s in statuses),
               30.0, 'the test to hold')
    held = committed_steps(out)
    time.sleep(1.0)
    assert committed_steps(out) == held  # nothing is committed while it holds
    Processes.signal(launcher, signal.SIGINT)  # the operator stops it for the night
    assert wait_exit(launcher, 30.0, lambda: processes.log('run_test')) != 0
    assert summary(out)['state'] == 'interrupted'

    resumed = run_launcher(processes, 'resume', ['--resume', str(out)])
    code = wait_exit(resumed, RUN_TIMEOUT, lambda: processes.log('resume'))
    log = processes.log('resume')
    assert code == 0, log[-3000:]
    assert (out / 'response.csv').read_bytes() == reference
    counted_as_a_persons_resume(out, log)
    assert summary(out)['state'] == 'finished'


def test_killed_launcher_leaves_no_orphan_and_the_run_resumes(
        crash_test: Path, reference: bytes, processes: Processes, tmp_path: Path) -> None:
    out = tmp_path / 'run'
    launcher = run_launcher(processes, 'run_test', [str(crash_test), '--out', str(out),
                                                    '--no-figures'])
    wait_for_step(out, kill_step('launcher'), launcher, processes)
    orphans = children(launcher.pid)
    assert len(orphans) == 3
    os.kill(launcher.pid, signal.SIGKILL)
    launcher.wait(timeout=10)
    deadline = time.monotonic() + 20.0  # (an integrator closing its bag on a loaded machine)
    while any(Path(f'/proc/{pid}').exists() and command_line(pid) for pid in orphans):
        assert time.monotonic() < deadline, [command_line(pid) for pid in orphans]
        time.sleep(0.1)
    assert not (out / 'response.csv').exists() or (out / 'response.csv').read_bytes() != reference

    resumed = run_launcher(processes, 'resume', ['--resume', str(out)])
    code = wait_exit(resumed, RUN_TIMEOUT, lambda: processes.log('resume'))
    log = processes.log('resume')
    assert code == 0, log[-3000:]
    assert (out / 'response.csv').read_bytes() == reference
    counted_as_a_persons_resume(out, log)


def test_a_fresh_specimen_in_mid_test_is_refused(
        crash_test: Path, reference: bytes, rig_key: Any, processes: Processes,
        observer: Any, tmp_path: Path) -> None:
    """A simulator started again by hand without its state file is another specimen: the
    integrator holds, and an operator's resume does not make it commit anything."""
    from pd_msgs.msg import TestStatus

    statuses: list[Any] = []
    observer.create_subscription(TestStatus, '/pd/test_status', statuses.append, latched_qos())
    out = tmp_path / 'run'
    test_file = write_test_file(tmp_path / 'fresh.yaml', test__duration=STEPS / 100,
                                test__id='graph-crash', protocol__feedback_timeout=0.5,
                                protocol__max_retries=2)
    integrator = processes.start('integrator', [
        executable('pd_integrator'), '--ros-args', '-p', f'test_file:={test_file}',
        '-p', f'output_dir:={out}', '-p', 'figures:=false'])
    spin_until(observer, lambda: bool(statuses), RUN_TIMEOUT, 'the integrator status')
    specimen = processes.start('specimen', [
        executable('pd_specimen_sim'), '--ros-args', '-p', f'test_file:={test_file}'])
    wait_for_step(out, kill_step('fresh'), integrator, processes)
    Processes.signal(specimen, signal.SIGKILL)
    specimen.wait(timeout=10)
    fresh = processes.start('fresh', [
        executable('pd_specimen_sim'), '--ros-args', '-p', f'test_file:={test_file}'])
    spin_until(observer, lambda: any(s.state == TestStatus.STATE_HOLDING and 'fresh' in
                                     s.message for s in statuses), 30.0,
               'the integrator to refuse the fresh specimen')
    held = committed_steps(out)
    send_control(observer, rig_key, 'resume')
    time.sleep(1.5)
    assert committed_steps(out) == held
    assert fresh.poll() is None
    assert statuses[-1].state == TestStatus.STATE_HOLDING
    send_control(observer, rig_key, 'abort')
    assert wait_exit(integrator, 30.0, lambda: processes.log('integrator')) == 1
    result = summary(out)
    assert result['state'] == 'aborted'
    assert any(event['what'] == 'epoch_change' for event in result['run_events'])
    # What was committed is right: the uninterrupted run's first steps.
    rows = (out / 'response.csv').read_bytes().splitlines()
    assert rows == reference.splitlines()[:len(rows)]
    assert len(rows) == result['steps'] + 2


def test_a_restarted_bridge_limits_increments_from_the_measured_position(
        rig_key: Any, processes: Processes, observer: Any, tmp_path: Path) -> None:
    """The owner walks the actuator to +0.04 m, the bridge is SIGKILLed and started again: a
    command to −0.015 m (0.015 m from zero, within max_increment 0.02 m of an assumed zero, but
    0.055 m from where the actuator is) is refused and never reaches the specimen."""
    from test_graph import write_bridge_params

    from pd_common.auth import Signer
    from pd_common.protocol import Command, FeedbackStatus
    from pd_common.protocol.convert import feedback_from_message
    from pd_common.ros import SessionSender
    from pd_msgs.msg import StepCommand, StepFeedback

    test_file = write_test_file(tmp_path / 'walk.yaml', test__id='graph-walk')
    params = write_bridge_params(tmp_path / 'bridge.yaml', max_increment=0.02)
    bridge_command = [executable('pd_actuator_bridge'), '--ros-args', '--params-file',
                      str(params)]
    processes.start('specimen', [
        executable('pd_specimen_sim'), '--ros-args', '-r', '__ns:=/pd/specimen',
        '-p', f'test_file:={test_file}', '-p', f'state_file:={tmp_path / "state.jsonl"}'])
    bridge = processes.start('bridge', bridge_command)
    moves: list[float] = []
    answers: list[Any] = []
    observer.create_subscription(StepCommand, '/pd/specimen/step_command',
                                 lambda m: moves.extend(m.target_displacement), 100)
    observer.create_subscription(StepFeedback, '/pd/step_feedback',
                                 lambda m: answers.append(feedback_from_message(m)), 100)
    commands = observer.create_publisher(StepCommand, '/pd/step_command', 100)
    sender = SessionSender(observer, 'pd/', Signer(rig_key), rig_key)

    def open_session(not_challenge: str = '') -> str:
        spin_until(observer, lambda: sender.offer is not None and bool(sender.offer.challenge)
                   and sender.offer.challenge != not_challenge, 30.0, 'a bridge offer')
        spin_until(observer, lambda: (sender.open('graph-walk'), sender.opened)[1], 10.0,
                   'the session to open')
        spin_until(observer, lambda: commands.get_subscription_count() > 0, 10.0, 'the bridge')
        return str(sender.offer.challenge)

    def move(step: int, target: float) -> Any:
        command = Command(test_id='graph-walk', step=step, test_time=0.0, dof_names=('top',),
                          target_displacement=(target,))
        commands.publish(sender.encode(command, time.time_ns())[0])
        spin_until(observer, lambda: any(a.step == step for a in answers), 15.0,
                   f'the answer to step {step}')
        return next(a for a in answers if a.step == step)

    challenge = open_session()
    for step, target in enumerate((0.0, 0.01, 0.02, 0.03, 0.04)):
        assert move(step, target).status is FeedbackStatus.OK
    # (the forwarded command may reach the observer after the answer it led to)
    spin_until(observer, lambda: bool(moves) and moves[-1] == 0.04, 10.0,
               lambda: f'the forwarded walk to 0.04 m (heard {moves})')

    Processes.signal(bridge, signal.SIGKILL)
    bridge.wait(timeout=10)
    processes.start('bridge2', bridge_command)
    open_session(not_challenge=challenge)
    assert list(sender.offer.position) == pytest.approx([0.04], abs=1e-9)
    heard = len(moves)
    answer = move(5, -0.015)
    assert answer.status is FeedbackStatus.LIMIT, answer
    assert 'max_increment' in answer.message
    assert answer.measured_displacement == pytest.approx((0.04,), abs=1e-9)
    time.sleep(0.5)
    assert moves[heard:] == []  # nothing reached the specimen
    assert 'ready: actuator at [0.04] m' in processes.log('bridge2')

    # The supervisor's automatic controls, signed with the test's key, take no limit's hold
    # over: only a person leaves it.
    send_control(observer, rig_key, 'auto_hold', topic='/pd/bridge/control')
    ack = send_control(observer, rig_key, 'auto_reset', topic='/pd/bridge/control',
                       expect='refused')
    assert 'holds for another reason' in ack.outcome and 'max_increment' in ack.outcome
    again = move(6, 0.04)  # (where it is: within every limit, yet refused while it holds)
    assert again.status is not FeedbackStatus.OK, again
    time.sleep(0.5)
    assert moves[heard:] == []


def test_killed_integrator_without_restart_then_resume_by_hand(
        crash_test: Path, reference: bytes, processes: Processes, tmp_path: Path) -> None:
    """The literal recipe: SIGKILL the integrator, ``./pd run --resume RUN_DIR`` (under
    ``abort``: the launcher ends with it; under ``hold`` it would restart it held)."""
    out = tmp_path / 'run'
    launcher = run_launcher(processes, 'run_test', [str(crash_test), '--out', str(out),
                                                    '--no-figures', '--on-child-exit', 'abort'])
    wait_for_step(out, kill_step('by-hand'), launcher, processes)
    os.kill(child_of(launcher, 'integrator'), signal.SIGKILL)
    assert wait_exit(launcher, 30.0, lambda: processes.log('run_test')) == 1
    assert f'./pd run --resume {out}' in processes.log('run_test')
    assert not (out / 'response.csv').exists()

    resumed = run_launcher(processes, 'resume', ['--resume', str(out)])
    code = wait_exit(resumed, RUN_TIMEOUT, lambda: processes.log('resume'))
    log = processes.log('resume')
    assert code == 0, log[-3000:]
    assert (out / 'response.csv').read_bytes() == reference
    counted_as_a_persons_resume(out, log)
    result = summary(out)
    assert result['state'] == 'finished' and result['steps'] == STEPS
    assert [event['what'] for event in result['run_events']].count('resumed') == 1

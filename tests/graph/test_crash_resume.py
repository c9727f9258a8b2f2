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

from pd_integrator.core.run.runner import run_offline
from pd_integrator.core.run.test_file import load_test_file

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
    try:
        return (out / 'journal.jsonl').read_bytes().count(b'"k":"fb"')
    except OSError:
        return 0


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
    assert code == 0, processes.log('resume')[-3000:]
    assert (out / 'response.csv').read_bytes() == reference
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
    deadline = time.monotonic() + 10.0
    while any(Path(f'/proc/{pid}').exists() and command_line(pid) for pid in orphans):
        assert time.monotonic() < deadline, [command_line(pid) for pid in orphans]
        time.sleep(0.1)
    assert not (out / 'response.csv').exists() or (out / 'response.csv').read_bytes() != reference

    resumed = run_launcher(processes, 'resume', ['--resume', str(out)])
    code = wait_exit(resumed, RUN_TIMEOUT, lambda: processes.log('resume'))
    assert code == 0, processes.log('resume')[-3000:]
    assert (out / 'response.csv').read_bytes() == reference


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

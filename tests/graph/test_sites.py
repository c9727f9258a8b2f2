"""Substructured tests through the node graph: two sites, each its own processes and namespace.

The integrator commands ``/pd/lab1`` and ``/pd/lab3`` (a simulator each, or a bridge in front of
a simulator each) and advances when both answered; the history equals the ROS-free run of the
same file float for float, the bag holds each site's stream, and the replay rebuilds the run.
"""

from __future__ import annotations

import json
import subprocess
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml
from graph_support import REPO, Processes, executable, send_control
from rosbags.highlevel import AnyReader
from test_graph import RUN_TIMEOUT, latched_qos, run_launcher, spin_until, wait_exit

from pd_core.run.bridge_limits import site_limits
from pd_core.run.record.bag import read_bag
from pd_core.run.runner import rebuild_outputs, run_offline
from pd_core.run.test_file import load_test_file

pytestmark = pytest.mark.graph

RECORD = REPO / 'src' / 'pd_integrator' / 'data' / 'ground_motions' / (
    'elcentro_1940_ns_chopra.csv')


EXAMPLE = REPO / 'src' / 'pd_integrator' / 'config' / 'three_story_two_sites.yaml'
#: The shipped example (stories 1 and 3 at sites lab1 and lab3), cut to 300 steps.
DURATION = 1.5


@pytest.fixture(scope='module')
def site_test(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """The two-site example and its ROS-free run (cut to ``DURATION``)."""
    directory = tmp_path_factory.mktemp('sites')
    test_file = EXAMPLE
    out = directory / 'offline'
    result = run_offline(load_test_file(test_file, {'duration': DURATION}), out, figures=False)
    assert result.summary['state'] == 'finished'
    return test_file, out


@pytest.mark.parametrize('site', ['direct', 'bridge'])
def test_two_sites_through_the_graph_match_the_ros_free_run(
        site: str, site_test: tuple[Path, Path], processes: Processes, tmp_path: Path) -> None:
    test_file, offline = site_test
    out = tmp_path / 'graph'
    launcher = run_launcher(processes, 'run_test', [str(test_file), '--site', site,
                                                    '--out', str(out), '--no-figures',
                                                    '-p', f'duration:={DURATION}'])
    code = wait_exit(launcher, RUN_TIMEOUT, lambda: processes.log('run_test'))
    log = processes.log('run_test')
    assert code == 0, log[-3000:]
    assert (out / 'response.csv').read_bytes() == (offline / 'response.csv').read_bytes()
    summary = json.loads((out / 'summary.json').read_text(encoding='utf-8'))
    assert summary['state'] == 'finished'
    assert summary['sites'] == ['lab1', 'lab3']
    assert set(summary['site_protocol']) == {'lab1', 'lab3'}
    assert 'modal analysis' in log and 'sites: lab1, lab3' in log

    run = read_bag(out / 'bag')
    assert set(run.site_events) == {'lab1', 'lab3'}
    for events in run.site_events.values():
        commands = [item for _, item in events if type(item).__name__ == 'Command']
        assert len(commands) >= 301
    with AnyReader([out / 'bag']) as reader:
        counts = {c.topic: c.msgcount for c in reader.connections}
    for lab in ('lab1', 'lab3'):
        assert counts[f'/pd/{lab}/step_feedback'] >= 301
        if site == 'bridge':  # each site's bridge status, recorded on its own topic
            assert counts[f'/pd/{lab}/bridge/status'] >= 1
    assert counts['/pd/structure/step_command'] >= 301
    if site == 'bridge':
        assert any(status.message.startswith('active') for _, status in run.bridge_statuses)
    replay = rebuild_outputs(out / 'bag', tmp_path / 'replay', figures=False)
    assert (replay.directory / 'response.csv').read_bytes() == (
        out / 'response.csv').read_bytes()


def test_two_sites_on_three_hosts_match_the_one_host_run(
        site_test: tuple[Path, Path], netns_hub: Any, ros_env: dict[str, str],
        tmp_path: Path) -> None:
    """Integrator and two sites in three network namespaces (veth links, UDP only)."""
    test_file, offline = site_test
    ns = netns_hub('integrator', 'lab1', 'lab3')
    before = {name: ns.link_bytes(name) for name in ns.names}
    logs = {}
    started = []
    for lab, names in (('lab1', ['u1']), ('lab3', ['u3-u2'])):
        logs[lab] = (tmp_path / f'{lab}.log').open('wb')
        started.append(ns.popen(lab, [
            executable('pd_specimen_sim'), '--ros-args', '-r', f'__ns:=/pd/{lab}',
            '-p', f'test_file:={test_file}', '-p', f'site:={lab}',
            '-p', f'dof_names:={json.dumps(names)}'], ns.env(lab, ros_env),
            stdout=logs[lab], stderr=subprocess.STDOUT))
    out = tmp_path / 'multi-host'
    log_path = tmp_path / 'integrator.log'
    with log_path.open('wb') as log:
        integrator = ns.popen('integrator', [
            executable('pd_integrator'), '--ros-args', '-p', f'test_file:={test_file}',
            '-p', f'output_dir:={out}', '-p', 'figures:=false', '-p', f'duration:={DURATION}'],
            ns.env('integrator', ros_env), stdout=log, stderr=subprocess.STDOUT)
        code = wait_exit(integrator, RUN_TIMEOUT,
                         lambda: log_path.read_text(encoding='utf-8', errors='replace'))
    text = log_path.read_text(encoding='utf-8', errors='replace')
    assert code == 0, text[-3000:]
    assert (out / 'response.csv').read_bytes() == (offline / 'response.csv').read_bytes()
    # Every step crossed the links: each site's veth carried its commands and answers.
    for lab in ('lab1', 'lab3'):
        grown = {way: ns.link_bytes(lab)[way] - before[lab][way] for way in ('rx', 'tx')}
        assert grown['rx'] > 301 * 100 and grown['tx'] > 301 * 100, (lab, grown)
    assert all(process.poll() is None for process in started)  # the sites are still serving
    for handle in logs.values():
        handle.close()


def test_opensees_substructure_is_a_site(processes: Processes, tmp_path: Path) -> None:
    """An EPP spring modelled in OpenSees behind its adapter element, as the site of a test
    (run_test starts opensees_site and the site's bridge with the opensees_adapter driver),
    gives the response of the same spring simulated by pd_specimen_sim."""
    pytest.importorskip('openseespy.opensees', reason='openseespy cannot be imported')
    stiffness, yield_force = 312559.0, 10000.0
    raw = {
        'test': {'id': 'opensees-site', 'dt': 0.01, 'duration': 3.0},
        'structure': {'dof_names': ['top'], 'mass': 2543.4, 'damping': {'ratio': 0.05},
                      'elements': [{'type': 'experimental', 'name': 'column', 'site': 'ops',
                                    'dofs': ['top'], 'initial_stiffness': stiffness}]},
        'ground_motion': {'file': str(RECORD)},
        'sites': {'ops': {
            # what the graph run uses: OpenSees behind its adapter element
            'opensees': {'model': 'epp', 'stiffness': stiffness, 'yield_force': yield_force},
            'bridge': {'driver_timeout': 10.0},
            # what the ROS-free reference run uses: the same spring in pd_specimen_sim
            'specimen': {'elements': [
                {'model': 'epp', 'stiffness': stiffness, 'yield_force': yield_force}]}}},
        'protocol': {'start_timeout': 60.0, 'feedback_timeout': 5.0},
    }
    test_file = tmp_path / 'opensees_site.yaml'
    test_file.write_text(yaml.safe_dump(raw), encoding='utf-8')
    reference = run_offline(load_test_file(test_file), tmp_path / 'offline', figures=False)

    out = tmp_path / 'graph'
    launcher = run_launcher(processes, 'run_test', [str(test_file), '--out', str(out),
                                                    '--no-figures'])
    code = wait_exit(launcher, RUN_TIMEOUT, lambda: processes.log('run_test'))
    assert code == 0, processes.log('run_test')[-3000:]

    history = reference.session.history
    x_ref = history.displacement[:, 0]
    data = np.genfromtxt(out / 'response.csv', delimiter=',', names=True)
    assert 'opensees_site' in processes.log('run_test')
    x_ops = data['x_top']
    force_ops = data['fs_top']
    assert np.max(np.abs(history.restoring_force[:, 0])) == pytest.approx(yield_force,
                                                                          rel=1e-6)
    assert np.max(np.abs(x_ref)) > 1.3 * yield_force / stiffness  # it yielded
    # The adapter's node lags the command by force/penalty (penalty = 1e6 K): relative 1e-6.
    np.testing.assert_allclose(x_ops, x_ref, rtol=0.0, atol=1e-5 * np.max(np.abs(x_ref)))
    np.testing.assert_allclose(force_ops, history.restoring_force[:, 0], rtol=0.0,
                               atol=1e-5 * yield_force)


def test_a_limit_at_one_site_holds_the_whole_test(
        rig_key: Any, processes: Processes, observer: Any, tmp_path: Path) -> None:
    """lab1's bridge refuses a command past its limit: the integrator holds naming lab1, the
    other site is not driven further, and an abort ends the test with its outputs."""

    from pd_common.protocol import Command, Feedback, FeedbackStatus
    from pd_msgs.msg import StepCommand, TestStatus

    limit = 0.004  # m; story 1 reaches ~0.013 m
    raw = yaml.safe_load(EXAMPLE.read_text(encoding='utf-8'))
    raw['ground_motion']['file'] = str(RECORD)
    raw['test'].update(duration=4.0, id='site-limit')
    raw['sites']['lab1']['bridge']['max_displacement'] = limit
    test_file = tmp_path / 'limit.yaml'
    test_file.write_text(yaml.safe_dump(raw), encoding='utf-8')

    forwarded: list[float] = []
    statuses: list[Any] = []
    observer.create_subscription(StepCommand, '/pd/lab1/specimen/step_command',
                                 lambda m: forwarded.extend(m.target_displacement), 100)
    observer.create_subscription(TestStatus, '/pd/test_status', statuses.append,
                                 latched_qos())
    out = tmp_path / 'run'
    launcher = run_launcher(processes, 'run_test', [str(test_file), '--site', 'bridge',
                                                    '--out', str(out), '--no-figures'])
    spin_until(observer, lambda: any(s.state == TestStatus.STATE_HOLDING for s in statuses),
               RUN_TIMEOUT, 'the integrator to hold')
    holding = next(s for s in statuses if s.state == TestStatus.STATE_HOLDING)
    assert 'site lab1' in holding.message and 'max_displacement' in holding.message
    time.sleep(0.5)  # nothing moves while holding
    send_control(observer, rig_key, 'abort')
    code = wait_exit(launcher, 30.0, lambda: processes.log('run_test'))
    assert code == 1
    assert all(abs(x) <= limit for x in forwarded)

    summary = json.loads((out / 'summary.json').read_text(encoding='utf-8'))
    assert summary['state'] == 'aborted'
    run = read_bag(out / 'bag')
    refused = [item for _, item in run.site_events['lab1']
               if isinstance(item, Feedback) and item.status is FeedbackStatus.LIMIT]
    assert refused
    held_step = refused[0].step
    assert summary['steps'] == held_step - 1
    lab3_steps = [item.step for _, item in run.site_events['lab3'] if isinstance(item, Command)]
    assert max(lab3_steps) == held_step  # the other site got the held step, nothing after
    lab1_commands = {item.step: item for _, item in run.site_events['lab1']
                     if isinstance(item, Command)}
    assert abs(lab1_commands[held_step].target_displacement[0]) > limit
    # The ROS-free rehearsal with the sites' bridge limits holds at the same step, the same way.
    definition = load_test_file(test_file)
    offline = run_offline(definition, tmp_path / 'offline', figures=False,
                          limits=site_limits(definition))
    held = offline.summary['bridge_limits']['held']
    assert offline.summary['state'] == 'held'
    assert (held['site'], held['step'], held['limit']) == ('lab1', held_step, 'max_displacement')
    assert held['message'] == refused[0].message
    assert offline.summary['message'] == holding.message


def test_pd_control_estop_reaches_every_listener(processes: Processes, observer: Any) -> None:
    """``./pd control estop`` waits for all the lab's listeners, then repeats the stop."""
    from std_msgs.msg import String

    from pd_common.ros import EMERGENCY_STOP_REPEATS

    heard: list[list[str]] = [[], []]
    for seen in heard:  # two listeners, as two sites' bridges are
        observer.create_subscription(String, '/pd/emergency_stop',
                                     lambda message, seen=seen: seen.append(message.data), 10)
    control = processes.start('control', [executable('pd_bringup', 'control'), 'estop',
                                          '--reason', 'hands off the column'])
    spin_until(observer, lambda: control.poll() is not None and all(
        len(seen) == EMERGENCY_STOP_REPEATS for seen in heard), 30.0,
        lambda: f'the e-stop burst ({[len(seen) for seen in heard]}): '
                f'{processes.log("control")}')
    assert control.returncode == 0
    assert '(2 listening)' in processes.log('control')
    assert all(set(seen) == {'hands off the column'} for seen in heard)


def test_pd_control_estop_without_listeners_says_so(processes: Processes) -> None:
    control = processes.start('control', [executable('pd_bringup', 'control'), 'estop',
                                          '--timeout', '1'])
    assert control.wait(30.0) == 1
    lines = processes.log('control').strip().splitlines()
    assert lines == [('control: error: nobody listens on /pd/emergency_stop (is the test '
                      'running? same ROS_DOMAIN_ID?)')]


def test_the_lab_wide_emergency_stop_holds_every_site(
        rig_key: Any, processes: Processes, observer: Any, tmp_path: Path) -> None:
    from std_msgs.msg import String

    from pd_common.ros import repeat_emergency_stop
    from pd_msgs.msg import TestStatus

    raw = yaml.safe_load(EXAMPLE.read_text(encoding='utf-8'))
    raw['ground_motion']['file'] = str(RECORD)
    raw['test'].update(duration=60.0, id='site-estop')
    test_file = tmp_path / 'estop.yaml'
    test_file.write_text(yaml.safe_dump(raw), encoding='utf-8')
    statuses: list[Any] = []
    bridges: dict[str, list[Any]] = {'lab1': [], 'lab3': []}
    observer.create_subscription(TestStatus, '/pd/test_status', statuses.append,
                                 latched_qos())
    for lab, seen in bridges.items():
        observer.create_subscription(TestStatus, f'/pd/{lab}/bridge/status', seen.append,
                                     latched_qos())
    stop = observer.create_publisher(String, '/pd/emergency_stop', 10)
    out = tmp_path / 'run'
    launcher = run_launcher(processes, 'run_test', [str(test_file), '--site', 'bridge',
                                                    '--out', str(out), '--no-figures'])
    spin_until(observer, lambda: any(s.state == TestStatus.STATE_RUNNING and s.step > 50
                                     for s in statuses), RUN_TIMEOUT, 'the test to run')
    # The integrator and both bridges listen; the stop is sent as ./pd control estop sends
    # it (repeated for a second), so a bridge still matching the observer gets it too.
    spin_until(observer, lambda: stop.get_subscription_count() >= 3, 10.0,
               'the integrator and both bridges on /pd/emergency_stop')
    burst = repeat_emergency_stop(
        lambda: stop.publish(String(data='operator pressed the lab e-stop')), background=True)
    for lab, seen in bridges.items():
        spin_until(observer, lambda seen=seen: any(
            'operator pressed the lab e-stop' in s.message for s in seen), 10.0,
            f'{lab} to hold on the e-stop')
    assert burst is not None
    burst.join(5.0)
    spin_until(observer, lambda: any(s.state == TestStatus.STATE_HOLDING for s in statuses),
               30.0, 'the integrator to hold')
    holding = next(s for s in statuses if s.state == TestStatus.STATE_HOLDING)
    # Its own e-stop subscription, or a site's e-stop hold reply, whichever arrives first.
    assert 'operator pressed the lab e-stop' in holding.message
    send_control(observer, rig_key, 'abort')
    assert wait_exit(launcher, 30.0, lambda: processes.log('run_test')) == 1
    summary = json.loads((out / 'summary.json').read_text(encoding='utf-8'))
    assert summary['state'] == 'aborted'
    assert summary['steps'] < 12000


def test_a_message_copied_from_one_site_to_another_is_refused(
        site_test: tuple[Path, Path], processes: Processes, observer: Any,
        tmp_path: Path) -> None:
    """A rogue copies every signed command and feedback of lab1 onto lab3's topics as they
    travel. Each site's hop is signed in a session of its own, so every copy is of a foreign
    session at lab3 — its simulator moves to none of lab1's targets and the integrator takes
    none of lab1's answers as lab3's (with one session for both hops a copy whose sequence
    happened to be next passed as lab3's) — and the test ends as the ROS-free run."""
    from pd_common.ros import STEP_QOS
    from pd_msgs.msg import StepCommand, StepFeedback

    test_file, offline = site_test
    out = tmp_path / 'graph'
    launcher = run_launcher(processes, 'run_test', [str(test_file), '--site', 'direct',
                                                    '--out', str(out), '--no-figures',
                                                    '-p', f'duration:={DURATION}'])
    copied = {'command': 0, 'feedback': 0}
    for kind, message_type in (('command', StepCommand), ('feedback', StepFeedback)):
        publisher = observer.create_publisher(message_type, f'/pd/lab3/step_{kind}', STEP_QOS)

        def copy(data: bytes, publisher: Any = publisher, kind: str = kind) -> None:
            publisher.publish(data)
            copied[kind] += 1

        observer.create_subscription(message_type, f'/pd/lab1/step_{kind}', copy, STEP_QOS,
                                     raw=True)
    deadline = time.monotonic() + RUN_TIMEOUT
    while launcher.poll() is None:
        assert time.monotonic() < deadline, processes.log('run_test')[-3000:]
        observer.executor_for_test.spin_once(timeout_sec=0.05)
    assert launcher.returncode == 0, processes.log('run_test')[-3000:]
    assert copied['command'] >= 250 and copied['feedback'] >= 250, copied
    assert (out / 'response.csv').read_bytes() == (offline / 'response.csv').read_bytes()
    refused = json.loads((out / 'summary.json').read_text(encoding='utf-8'))[
        'authentication']['refused_messages']
    assert refused['feedback[lab3]'].get('foreign_session', 0) >= 250, refused
    assert 'feedback[lab1]' not in refused, refused
    assert 'refused command on /pd/lab3/step_command: foreign_session' in processes.log(
        'run_test')

"""Only the test's owner moves the actuator: a rogue process on the same ROS domain, with
well-formed messages, replays and forgeries, moves nothing and changes nothing.

Integrator, bridge and simulator run as separate processes with the test's key; the observer
node plays the rogue (no key, or a key of its own). The test's ``response.csv`` must equal the
ROS-free run's byte for byte, and every refused attempt must be counted by reason.
"""

from __future__ import annotations

import dataclasses
import json
import os
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
from graph_support import Processes, executable, send_control
from test_graph import (
    RUN_TIMEOUT,
    call_service,
    latched_qos,
    spin_until,
    wait_exit,
    write_bridge_params,
    write_test_file,
)

from pd_common.auth import WIRE_COMMAND, WIRE_FEEDBACK, Key, Signer, control_payload, new_key
from pd_common.protocol import (
    Command,
    Control,
    Feedback,
    decode_command,
    encode_command,
    encode_feedback,
)
from pd_common.ros import (
    command_message,
    control_message,
    feedback_message,
    now_stamp,
    sign_trajectory,
)
from pd_core.run.record.bag import read_bag
from pd_core.run.record.journal import read_journal
from pd_core.run.record.signatures import ForeignKeyError, check_signatures
from pd_core.run.runner import run_offline
from pd_core.run.test_file import load_test_file

pytestmark = pytest.mark.graph


def rogue_commands(signer: Signer | None, test_id: str, start: float, count: int,
                   step: int = 0) -> list[Any]:
    """``count`` well-formed commands walking by 0.02 m (the increment limit) from ``start``."""
    messages = []
    for i in range(count):
        command = Command(test_id=test_id, step=step + i, test_time=0.0, dof_names=('top',),
                          target_displacement=(start + 0.02 * (i + 1),))
        messages.append(command_message(command) if signer is None
                        else signed_bytes(signer, command))
    return messages


def signed_bytes(signer: Signer, item: Command | Feedback) -> bytes:
    """``item`` as its sender would send it, signed with ``signer``'s key (bytes to publish)."""
    if isinstance(item, Command):
        return signer.sign_wire(WIRE_COMMAND,
                                lambda bare: encode_command(item, time.time_ns(), bare))[0]
    return signer.sign_wire(WIRE_FEEDBACK,
                            lambda bare: encode_feedback(item, time.time_ns(), bare))[0]


def repeat_until(observer: Any, send: Callable[[], None], predicate: Callable[[], bool],
                 what: str | Callable[[], str], attempts: int = 5, each: float = 4.0) -> None:
    """``send()`` and spin until ``predicate()``; send again (up to ``attempts`` times) if it
    does not hold within ``each`` s, else fail saying ``what``."""
    for _ in range(attempts):
        send()
        deadline = time.monotonic() + each
        while time.monotonic() < deadline:
            if predicate():
                return
            observer.executor_for_test.spin_once(timeout_sec=0.05)
    said = what() if callable(what) else what
    pytest.fail(f'timed out after {attempts} sends waiting for {said}')


def test_a_rogue_on_the_domain_moves_nothing_and_changes_nothing(
        processes: Processes, observer: Any, rig_key: Any, tmp_path: Path) -> None:
    from lifecycle_msgs.msg import Transition
    from lifecycle_msgs.srv import ChangeState
    from rcl_interfaces.msg import Parameter, ParameterType, ParameterValue
    from rcl_interfaces.srv import GetParameters, SetParameters
    from std_srvs.srv import Trigger

    from pd_common.protocol import Offer, Status, TestState
    from pd_common.ros import offer_message, status_message
    from pd_msgs.msg import (
        ActuatorTrajectory,
        SessionOffer,
        SessionStart,
        StepCommand,
        StepFeedback,
        TestStatus,
    )
    from pd_msgs.msg import Control as ControlMessage

    test_file = write_test_file(tmp_path / 'secure.yaml', test__id='graph-secure',
                                test__duration=40.0)
    reference = run_offline(load_test_file(test_file), tmp_path / 'offline', figures=False)
    rogue = Signer(new_key())  # a key of its own: well-formed signatures, the wrong key
    # a key id that is no key id (not ASCII: hmac.compare_digest raised on it, and one such
    # message stopped the node that read it)
    alien = Signer(Key(key_id='é' * 16, secret=os.urandom(32)))
    moves: list[tuple[float, ...]] = []
    statuses: list[Any] = []
    bridge_statuses: list[Any] = []
    genuine_commands: list[Any] = []
    genuine_feedback: list[Any] = []
    observer.create_subscription(StepCommand, '/pd/specimen/step_command',
                                 lambda m: moves.append(tuple(m.target_displacement)), 1000)
    # (the genuine messages as their bytes: what a rogue on the domain records and replays)
    observer.create_subscription(StepCommand, '/pd/step_command', genuine_commands.append, 1000,
                                 raw=True)
    observer.create_subscription(StepFeedback, '/pd/step_feedback', genuine_feedback.append,
                                 1000, raw=True)
    observer.create_subscription(TestStatus, '/pd/test_status', statuses.append, latched_qos())
    observer.create_subscription(TestStatus, '/pd/bridge/status', bridge_statuses.append,
                                 latched_qos())
    commands = observer.create_publisher(StepCommand, '/pd/step_command', 100)
    feedback = observer.create_publisher(StepFeedback, '/pd/step_feedback', 100)
    starts = observer.create_publisher(SessionStart, '/pd/session/start', 10)
    test_control = observer.create_publisher(ControlMessage, '/pd/test_control', 10)
    bridge_control = observer.create_publisher(ControlMessage, '/pd/bridge/control', 10)
    # (latched, as the nodes publish them: a volatile writer never matches their readers)
    offers = {topic: observer.create_publisher(SessionOffer, topic, latched_qos())
              for topic in ('/pd/session/offer', '/pd/specimen/session/offer')}
    forged_statuses = {topic: observer.create_publisher(TestStatus, topic, latched_qos())
                       for topic in ('/pd/test_status', '/pd/bridge/status')}
    # (recorded by the integrator only as its bridge signed them; bytes that are no trajectory
    # would make the run unreadable: counted as malformed and never recorded)
    trajectories = observer.create_publisher(ActuatorTrajectory, '/pd/bridge/trajectory', 100)

    processes.start('specimen', [executable('pd_specimen_sim'), '--ros-args', '-r',
                                 '__ns:=/pd/specimen', '-p', f'test_file:={test_file}'])
    params = write_bridge_params(tmp_path / 'bridge.yaml', autostart=False)
    processes.start('bridge', [executable('pd_actuator_bridge'), '--ros-args',
                               '--params-file', str(params)])

    # -- the idle bridge: the rogue drives its lifecycle and walks it, well within the limits
    node = '/pd/pd_actuator_bridge'
    spin_until(observer, lambda: observer.count_publishers('/pd/specimen/step_feedback') > 0
               and observer.count_subscribers('/pd/step_command') > 0, 20.0,
               'the specimen and the bridge')
    time.sleep(0.5)  # and the bridge has discovered the specimen
    # The rogue cannot move the lifecycle (the service cannot be authenticated) ...
    for transition in (Transition.TRANSITION_CONFIGURE, Transition.TRANSITION_ACTIVATE):
        request = ChangeState.Request()
        request.transition.id = transition
        assert not call_service(observer, ChangeState, f'{node}/change_state', request).success
    # ... the owner does, with signed controls; the rogue then walks the active bridge.
    for transition in ('configure', 'activate'):
        send_control(observer, rig_key, transition, topic='/pd/bridge/control')
    spin_until(observer, lambda: commands.get_subscription_count() > 0, 20.0, 'the bridge')
    start = SessionStart()
    start.test_id = 'rogue'
    for service in ('/pd/bridge/reset', '/pd/bridge/reset_emergency_stop'):
        assert not call_service(observer, Trigger, service, Trigger.Request()).success

    def walk() -> None:
        starts.publish(start)  # an unsigned session start
        for message in (rogue_commands(None, 'rogue', 0.0, 12)
                        + rogue_commands(rogue, 'rogue', 0.0, 12)):
            commands.publish(message)
        for signer in (None, rogue):
            control = Control(command='reset_emergency_stop', stamp=time.time())
            signature = signer.sign(control_payload(control)) if signer is not None else None
            bridge_control.publish(control_message(control, signature) if signature
                                   else control_message(control))

    # (a burst sent just as the bridge's new subscription is matched may be lost in part:
    # the rogue sends it again until the bridge has counted its 24 commands and 2 controls)
    repeat_until(observer, walk, lambda: any(s.refused_messages >= 26 for s in bridge_statuses),
                 'the bridge to count the rogue messages')
    assert moves == []  # nothing reached the specimen

    # -- the owner's test runs; the rogue replays, forges and hijacks during it -------------
    out = tmp_path / 'run'
    integrator = processes.start('integrator', [
        executable('pd_integrator'), '--ros-args', '-p', f'test_file:={test_file}',
        '-p', f'output_dir:={out}', '-p', 'figures:=false', '-p', 'progress_interval:=0.05'])
    spin_until(observer, lambda: any(s.step > 150 for s in statuses), RUN_TIMEOUT,
               'the test to pass step 150')
    # The owner pauses the test, so the rogue acts while the session is open (a test that had
    # finished meanwhile would refuse the replays as 'no_session' instead).
    send_control(observer, rig_key, 'pause')
    spin_until(observer, lambda: statuses[-1].state == TestStatus.STATE_PAUSED, 20.0,
               'the owner\'s pause')
    captured_commands = list(genuine_commands[-5:])
    captured_feedback = list(genuine_feedback[-5:])
    last = decode_command(captured_commands[-1]).record
    hijack = Command(test_id=last.test_id, step=last.step + 1, test_time=0.0,
                     dof_names=('top',),
                     target_displacement=(float(last.target_displacement[0]) + 0.015,))

    def attack() -> None:
        for message in captured_commands * 3:  # replays of genuine signed commands
            commands.publish(message)
        commands.publish(command_message(hijack))
        commands.publish(signed_bytes(rogue, hijack))
        commands.publish(signed_bytes(alien, hijack))
        feedback.publish(signed_bytes(alien, Feedback(
            test_id=last.test_id, step=last.step + 1, measured_displacement=(0.0,),
            restoring_force=(0.0,))))
        for step in range(last.step + 1, last.step + 11):  # forged forces for the next steps
            forged = Feedback(test_id=last.test_id, step=step, measured_displacement=(0.0,),
                              restoring_force=(0.0,))
            feedback.publish(feedback_message(forged))
            feedback.publish(signed_bytes(rogue, forged))
        for message in captured_feedback * 2:  # replays of genuine signed feedback
            feedback.publish(message)
        # malformed: a test id beyond its bound (the raw readers refuse it as the conversion
        # did, counted, never taken nor crashing the node)
        commands.publish(command_message(dataclasses.replace(hijack, test_id='x' * 1000)))
        feedback.publish(feedback_message(Feedback(test_id='x' * 1000, step=last.step + 1,
                                                   measured_displacement=(0.0,),
                                                   restoring_force=(0.0,))))
        trajectories.publish(b'\x00\x01\x00\x00' + bytes(range(7)))
        ragged = ActuatorTrajectory(test_id=last.test_id, step=last.step, n_dof=1,
                                    time=[0.0, 0.001], command=[0.0])  # 1 value, 2 samples
        trajectories.publish(ragged)
        # well-formed, as the bridge's node: unsigned, and signed with the rogue's key
        for signer in (None, rogue, alien):
            forged_trajectory = ActuatorTrajectory(
                test_id=last.test_id, step=last.step, n_dof=1, rate=1000.0,
                time=[0.0, 0.001], command=[0.2, 0.2], measured_displacement=[0.2, 0.2],
                measured_force=[1e6, 1e6])
            forged_trajectory.header.stamp = now_stamp()
            sign_trajectory(forged_trajectory, signer, '/pd/pd_actuator_bridge')
            trajectories.publish(forged_trajectory)
        for command in ('abort', 'pause', 'resume'):
            for signer in (None, rogue, alien):
                control = Control(command=command, stamp=time.time())
                signature = (signer.sign(control_payload(control)) if signer is not None
                             else None)
                test_control.publish(control_message(control, signature) if signature
                                     else control_message(control))

    def pause() -> None:
        end = time.monotonic() + 0.2
        while time.monotonic() < end:
            observer.executor_for_test.spin_once(timeout_sec=0.05)

    def forge() -> None:
        """A fresh specimen far away, a bridge offering a foreign session, a bridge and a
        test that say they hold: unsigned, and signed with the rogue's key."""
        for publisher in offers.values():
            offer = Offer(stamp_ns=time.time_ns(), node='/pd/pd_actuator_bridge',
                          challenge='f' * 32, active_session='e' * 32, authenticated=True,
                          epoch='0' * 16, state_origin=0, restored=('', 0, 0), position=(0.2,),
                          force=(0.0,), configuration='{"driver": "emulator"}')
            publisher.publish(offer_message(offer))
            pause()  # (a latched reader keeps one: each must be taken before the next)
            publisher.publish(offer_message(offer, rogue))
            pause()
            publisher.publish(offer_message(offer, alien))
            pause()
        for publisher in forged_statuses.values():
            status = Status(test_id='graph-secure', state=TestState.HOLDING, step=0,
                            total_steps=0, omega_dt=0.0, message='rogue status',
                            node='/pd/pd_actuator_bridge', session='e' * 32)
            publisher.publish(status_message(status))
            pause()
            publisher.publish(status_message(status, signer=rogue))
            pause()
            publisher.publish(status_message(status, signer=alien))
            pause()

    # Nobody without the key reconfigures the active bridge: its parameters are sealed and its
    # lifecycle moves only on the owner's signed controls.
    setting = SetParameters.Request()
    for name, value in (('max_displacement', 10.0), ('max_increment', 1.0),
                        ('max_force', 1.0e9)):
        setting.parameters.append(Parameter(name=name, value=ParameterValue(
            type=ParameterType.PARAMETER_DOUBLE, double_value=value)))
    setting.parameters.append(Parameter(name='driver', value=ParameterValue(
        type=ParameterType.PARAMETER_STRING, string_value='emulator')))
    results = call_service(observer, SetParameters, f'{node}/set_parameters', setting).results
    assert results and not any(result.successful for result in results)
    assert all('sealed' in result.reason for result in results)
    for transition in (Transition.TRANSITION_ACTIVATE, Transition.TRANSITION_DEACTIVATE,
                       Transition.TRANSITION_CLEANUP):
        request = ChangeState.Request()
        request.transition.id = transition
        assert not call_service(observer, ChangeState, f'{node}/change_state', request).success
    in_force = call_service(observer, GetParameters, f'{node}/get_parameters',
                            GetParameters.Request(names=['max_displacement', 'driver'])).values
    assert in_force[0].double_value == 0.25 and in_force[1].string_value == 'sim_servo'
    # Nor the integrator's or the simulator's: a rogue's hold_on_resume:=false would let a
    # restarted integrator of a held (physical) test move without a person's resume.
    simulator = '/pd/specimen/pd_specimen_sim'
    for target, name, value in (('/pd/pd_integrator', 'hold_on_resume', False),
                                ('/pd/pd_integrator', 'confirm_resume', True),
                                (simulator, 'state_file', str(tmp_path / 'rogue.state'))):
        setting = SetParameters.Request()
        kind = (ParameterValue(type=ParameterType.PARAMETER_BOOL, bool_value=value)
                if isinstance(value, bool) else
                ParameterValue(type=ParameterType.PARAMETER_STRING, string_value=value))
        setting.parameters.append(Parameter(name=name, value=kind))
        results = call_service(observer, SetParameters, f'{target}/set_parameters',
                               setting).results
        assert results and not results[0].successful and 'sealed' in results[0].reason, results

    repeat_until(observer, attack,
                 lambda: all(reason in bridge_statuses[-1].refused_by_reason
                             for reason in ('unsigned', 'wrong_key', 'replayed', 'malformed')),
                 lambda: 'the bridge to name every refusal; its statuses said '
                 + repr([(s.state, s.message, s.refused_by_reason)
                         for s in bridge_statuses[-4:]]))
    deadline = time.monotonic() + 0.5  # the rogue's resume, had it been obeyed, shows by now
    while time.monotonic() < deadline:
        observer.executor_for_test.spin_once(timeout_sec=0.05)
    assert statuses[-1].state == TestStatus.STATE_PAUSED  # nor did the rogue resume it
    # (the observer hears its own forgeries on the status topics too: they are left out)
    def genuine(heard: list[Any]) -> list[Any]:
        return [s for s in heard if s.message != 'rogue status']

    before = (genuine(statuses)[-1].refused_messages,
              genuine(bridge_statuses)[-1].refused_messages)

    def refused_forgeries() -> bool:
        # a round refuses 4 at the integrator (2 offers, 2 bridge statuses) and 2 at the
        # bridge (the specimen's offers)
        return (genuine(statuses)[-1].refused_messages >= before[0] + 4
                and genuine(bridge_statuses)[-1].refused_messages >= before[1] + 2)

    repeat_until(observer, forge, refused_forgeries,
                 'the integrator and the bridge to refuse the forged offers and statuses')
    assert genuine(statuses)[-1].state == TestStatus.STATE_PAUSED  # nor did a forged offer
    send_control(observer, rig_key, 'resume')

    assert wait_exit(integrator, RUN_TIMEOUT, lambda: processes.log('integrator')) == 0
    assert (out / 'response.csv').read_bytes() == (
        reference.directory / 'response.csv').read_bytes()
    summary = json.loads((out / 'summary.json').read_text(encoding='utf-8'))
    assert summary['state'] == 'finished'
    refused = summary['authentication']['refused_messages']
    assert {'unsigned', 'wrong_key'} <= set(refused['session_offer[default]'])
    assert {'unsigned', 'wrong_key'} <= set(refused['bridge_status'])
    # The forged statuses never entered the record as the bridge's (or the test's) own, and
    # the summary names the driver and the limits actually in force.
    assert b'rogue status' not in (out / 'journal.pdj').read_bytes()
    side = summary['specimen_side']['default']
    assert side['driver'] == 'sim_servo' and side['limits']['max_displacement'] == 0.25
    assert side['node'] == '/pd/pd_actuator_bridge'
    assert {'unsigned', 'wrong_key', 'replayed'} <= set(refused['feedback[default]'])
    assert refused['feedback[default]']['unsigned'] >= 10
    assert refused['malformed']['malformed'] >= 3  # (the feedback, the two trajectories)
    run = read_journal(out / 'journal.pdj')  # readable: no trajectory of the rogue's in it
    assert run.trajectories == [] and run.notes == []
    assert {'unsigned', 'wrong_key'} <= set(refused['bridge_trajectory'])
    assert {'unsigned', 'wrong_key', 'sealed'} <= set(refused['test_control'])
    # Every move that reached the specimen (that the observer heard) was a target the
    # owner's integrator sent (its bag); none of the rogue's.
    sent = {item.target_displacement for item in read_bag(out / 'bag').commands}
    assert moves and set(moves) <= sent
    assert not {(0.015 + float(last.target_displacement[0]),)} & set(moves)
    # Every command and feedback in the bag carries the owner's MAC over its recorded bytes
    # (the rogue's were refused, never recorded): `./pd replay --key` verifies them all.
    check = check_signatures(read_bag(out / 'bag'), rig_key)
    assert check.failed == check.unsigned == 0 and check.verified > 2 * 150
    with pytest.raises(ForeignKeyError):
        check_signatures(read_bag(out / 'bag'), rogue.key)


def test_a_readable_key_file_is_refused_in_one_line(processes: Processes,
                                                     tmp_path: Path) -> None:
    from pd_common.auth import generate_key

    key = tmp_path / 'open.key'
    generate_key(key)
    os.chmod(key, 0o644)
    test_file = write_test_file(tmp_path / 'open.yaml', test__duration=0.2)
    for name, command in (
            ('run_test', [executable('pd_bringup', 'run_test'), str(test_file), '--key',
                          str(key), '--out', str(tmp_path / 'run')]),
            ('bridge', [executable('pd_actuator_bridge'), '--ros-args', '-p',
                        f'key_file:={key}']),
            ('specimen', [executable('pd_specimen_sim'), '--ros-args', '-p',
                          f'test_file:={test_file}', '-p', f'key_file:={key}'])):
        process = processes.start(name, command)
        assert wait_exit(process, 30.0, lambda name=name: processes.log(name)) == 2
        lines = [line for line in processes.log(name).splitlines() if line.strip()]
        errors = [line for line in lines if 'error:' in line]
        assert len(errors) == 1 and 'mode 0644' in errors[0] and str(key) in errors[0], lines
        assert 'Traceback' not in processes.log(name)
    assert not (tmp_path / 'run' / 'bag').exists()  # nothing started


def test_a_node_with_the_wrong_key_refuses_every_message_and_says_so_once(
        processes: Processes, observer: Any, tmp_path: Path) -> None:
    from pd_common.auth import generate_key, load_key

    other = tmp_path / 'other.key'
    generate_key(other)
    test_file = write_test_file(tmp_path / 'wrong.yaml', test__duration=0.5,
                                protocol__start_timeout=5.0, test__id='graph-wrong-key')
    specimen = processes.start('specimen', [executable('pd_specimen_sim'), '--ros-args',
                                            '-p', f'test_file:={test_file}',
                                            '-p', f'key_file:={other}'])
    integrator = processes.start('integrator', [
        executable('pd_integrator'), '--ros-args', '-p', f'test_file:={test_file}',
        '-p', f'output_dir:={tmp_path / "run"}', '-p', 'figures:=false'])
    assert wait_exit(integrator, 60.0, lambda: processes.log('integrator')) == 1
    # The integrator believes none of the specimen's offers (signed with another key): it
    # opens no session, moves nothing, and says why once.
    assert 'its session offers are refused: wrong_key' in processes.log('integrator')
    assert specimen.poll() is None
    refusals = [line for line in processes.log('integrator').splitlines()
                if 'refusing every' in line]
    assert len(refusals) == 1 and 'wrong key file' in refusals[0]
    # ... naming the key that signed the offers (the specimen's), and its own
    assert f'signed with key {load_key(other).key_id}: this node has key' in refusals[0]
    summary = json.loads((tmp_path / 'run' / 'summary.json').read_text(encoding='utf-8'))
    assert summary['state'] == 'aborted' and summary['steps'] == 0

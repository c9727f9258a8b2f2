"""The simulated specimen node (``ros2 run pd_specimen_sim main``).

A thin shell around :class:`pd_common.specimen.SpecimenServer`: it answers every
``step_command`` with a ``step_feedback`` holding the restoring force of its hysteresis model.
It speaks the same step protocol as the actuator bridge, so the integrator cannot tell (and does
not care) which one answers: swapping them is a launch-time choice (the namespace).

Topics (relative; namespace ``/pd`` by default, ``/pd/specimen`` behind a bridge):
``step_command`` (subscribed) and ``step_feedback`` (published), both reliable.

Parameters: ``test_file`` — the YAML test file; its ``specimen`` section and
``structure.dof_names`` define the specimen, and the optional ``specimen.errors`` mapping the
experimental errors injected into every step (see :mod:`pd_common.specimen.server`).
``state_file`` — the specimen's own record (see :mod:`pd_common.specimen.served`): every
command served as a new move is appended to it before the answer goes out; a simulator
started with an existing state file replays it first, so a restarted simulator is the *same*
specimen (its offer and answers say ``restored``), never a silently new one. Without it the
state is ``fresh`` (the integrator refuses a fresh specimen that replaces the one it drove).
Mixed control: a command's ``control_mode`` / ``target_force`` go to the server (force-controlled
actuators hold their forces, ramped by ``sites.<site>.bridge.max_force_increment``; the site's
setup comes from its experimental element in ``structure.elements``; see
:mod:`pd_common.specimen.server`); a command whose ``control_error()`` is not ``None`` is
answered by a FAULT of one line (nothing moves), and the state file records modes and forces.
``site`` — in a substructured test, the site this node simulates: the specimen is then
``sites.<site>.specimen`` and the node runs in the namespace ``/pd/<site>`` (``-r
__ns:=/pd/<site>``; ``/pd/<site>/specimen`` behind that site's bridge). ``dof_names`` — the
names of the specimen's DOFs (the site's actuators; default: ``structure.dof_names``, or
``a1, a2, ...`` for a site). ``key_file``, ``authentication`` — the key (see
:mod:`pd_common.ros.keys`): with it, the node obeys only commands of the session a signed
``session/start`` opened (its ``session/offer`` is latched) and signs every answer.
"""

from __future__ import annotations

import sys
import time
from typing import Any

import rclpy
from rcl_interfaces.msg import ParameterDescriptor
from rclpy.executors import Executor
from rclpy.node import Node

from pd_common.auth import AuthError, Refusal
from pd_common.dds import use_discovery_profile
from pd_common.protocol import (
    FeedbackStatus,
    RunTags,
    Signature,
    StateOrigin,
    StepKey,
    amended,
    decode_command,
    signed_from_bytes,
)
from pd_common.ros import (
    OFFER_REFRESH_S,
    STEP_QOS,
    TEARDOWN_TIMEOUT,
    RefusalLog,
    SessionReceiver,
    declare_key,
    new_epoch,
    quiet_at_shutdown,
    run_node,
    seal_parameters,
    spin_until_shutdown,
)
from pd_common.specimen import (
    ServedRecord,
    SpecimenError,
    StateFileError,
    load_site_server,
    restore_served,
    specimen_fingerprint,
)
from pd_msgs.msg import StepCommand, StepFeedback


class SpecimenSimNode(Node):
    """Answers step commands with a simulated specimen."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__('pd_specimen_sim', namespace='pd', **kwargs)
        self.declare_parameter('test_file', '', ParameterDescriptor(
            description='YAML test file whose specimen section defines the specimen'))
        self.declare_parameter('site', '', ParameterDescriptor(
            description='site of a substructured test (its specimen: sites.<site>.specimen)'))
        self.declare_parameter('dof_names', [''], ParameterDescriptor(
            description='names of the specimen DOFs (default: from the test file)'))
        self.declare_parameter('state_file', '', ParameterDescriptor(
            description='the specimen\'s own record: appended per served move; restored '
                        'from at start when it exists (a restarted simulator is the same '
                        'specimen)'))
        test_file = self.get_parameter('test_file').value
        if not test_file:
            msg = 'parameter test_file: a YAML test file is required'
            raise SpecimenError(msg)
        site = str(self.get_parameter('site').value)
        given = [name for name in self.get_parameter('dof_names').value if name]
        self.server, section, dof_names = load_site_server(test_file, site, given or None)
        self.key = declare_key(self)
        self.epoch = new_epoch()
        origin, restored, self.record = self._restore(section, list(dof_names))
        #: A move the state file could not take (see :meth:`_on_command`).
        self.state_error: StateFileError | None = None
        self._refusal_log = RefusalLog(self.get_logger().warning, self.key, 'command')
        self.receiver = SessionReceiver(self, self.key, len(dof_names), self.epoch,
                                        origin, on_refused=self._refusal_log)
        self.receiver.restored = restored
        self.receiver.set_state(self.server.position, self.server.force)
        self.receiver.publish_offer()
        self.create_timer(OFFER_REFRESH_S, quiet_at_shutdown(self, self.receiver.refresh))
        self._feedback_pub = self.create_publisher(StepFeedback, 'step_feedback', STEP_QOS)
        # The hot topics travel as CDR bytes (pd_common.protocol.cdr): no message objects.
        self.create_subscription(StepCommand, 'step_command',
                                 quiet_at_shutdown(self, self._on_command), STEP_QOS, raw=True)
        self._runs = RunTags()
        if self.key is not None:
            seal_parameters(self, 'the simulator', 'restart it', self.receiver.gate.refused)
        self.get_logger().info(f'simulated specimen ready: {len(dof_names)} DOF '
                               f'({", ".join(dof_names)}) on '
                               f'{self.resolve_topic_name("step_command")}')
        errors = self.server.errors
        if errors is not None and not errors.is_ideal:
            self.get_logger().warning(f'injecting experimental errors: {errors}')

    def _restore(self, section: Any, dof_names: list[str]
                 ) -> tuple[StateOrigin, tuple[str, StepKey] | None, ServedRecord | None]:
        """Replay the state file, if any, into the new specimen; open it for appending."""
        state_file = str(self.get_parameter('state_file').value)
        if not state_file:
            return StateOrigin.FRESH, None, None
        fingerprint = specimen_fingerprint(section, dof_names, self.server.geometry)
        restored = restore_served(state_file, self.server, fingerprint)
        # (its once-a-second fsync in a thread of its own: no move waits for the disk)
        record = ServedRecord(state_file, fingerprint, sync_in_background=True)
        if restored is None:
            return StateOrigin.FRESH, None, record
        test_id, key = restored
        self.get_logger().warning(
            f'restored the specimen from {state_file}: {self.server.steps_served} moves '
            f'replayed, through step {key.step} (iteration {key.iteration}) of {test_id}; at '
            f'{list(self.server.position)} m')
        return StateOrigin.RESTORED, restored, record

    def close(self) -> None:
        """Close the state file.

        A failed ``fsync`` (now, or one in the background that failed after the last move) is
        one error line: the process still tears down its node and participant.
        """
        if self.record is not None:
            try:
                self.record.close()
            except OSError as err:
                self.get_logger().error(
                    f'{self.record.path}: cannot sync the specimen state file '
                    f'({err.strerror or err}): the moves after its last good fsync may not '
                    'survive a power loss')

    def _on_command(self, data: bytes) -> None:
        """A step command: served, on record, answered.

        A move the state file cannot take is kept in :attr:`state_error` for :func:`serve`
        (one line and the end of the process) instead of escaping into the executor (a FATAL
        log with the frames); from then on no command is served.
        """
        if self.state_error is not None:
            return
        try:
            self._serve_command(data)
        except StateFileError as err:
            self.state_error = err

    def _serve_command(self, data: bytes) -> None:
        decoded = signed_from_bytes(decode_command, data)
        if decoded is None:  # malformed: counted and reported, nothing moves, no answer
            self.receiver.gate.refused[Refusal.MALFORMED.value] += 1
            self._refusal_log(Refusal.MALFORMED, Signature(),
                              self.resolve_topic_name('step_command'))
            return
        command, signature = decoded.record, decoded.signature
        reason = self.receiver.admit(decoded)
        if reason is not None:  # not obeyed: nothing moves, no answer
            self._refusal_log(reason, signature, self.resolve_topic_name('step_command'))
            return
        before = self.server.last
        # (the same test file run again by a new integrator: a new run, not stale steps)
        run = self._runs.tag(command.test_id, command.key, signature.session)
        # The server checks the modes and forces with command.control_error() itself: an
        # inconsistent command is a FAULT of one line and moves nothing.
        answer = self.server.handle(run, command.step, command.target_displacement,
                                    iteration=command.iteration,
                                    control_mode=command.control_mode,
                                    target_force=command.target_force)
        if answer is None:
            return
        if answer is not before and self.record is not None:  # a new move: on record first
            self.record.add(run, command.step, command.iteration,
                            command.target_displacement, command.control_mode,
                            command.target_force)
        answer = amended(answer, test_id=command.test_id, epoch=self.epoch,
                         state_origin=self.receiver.origin)
        self.receiver.set_state(answer.measured_displacement, answer.restoring_force)
        self._feedback_pub.publish(self.receiver.encode_reply(answer, time.time_ns(),
                                                              signature))
        if answer.status is not FeedbackStatus.OK:
            self.get_logger().error(f'step {answer.step}: {answer.message}')


def serve(node: SpecimenSimNode, executor: Executor) -> int:
    """Answer commands until shut down; 1 if the state file failed (one line on stderr).

    A move the state file could not take is not answered: the process ends, and its restart
    (``run_test``'s supervisor) replays the file up to the last move on record.
    """
    def check() -> None:
        if node.state_error is not None:
            raise node.state_error

    try:
        spin_until_shutdown(executor, 0.1, check)
    except StateFileError as err:
        print(f'pd_specimen_sim: error: {err}; stopping (a restart resumes from the file)',
              file=sys.stderr, flush=True)
        return 1
    return 0


def main(args: list[str] | None = None) -> int:
    """Entry point of ``ros2 run pd_specimen_sim main``."""
    use_discovery_profile()
    rclpy.init(args=args)
    return run_node('pd_specimen_sim', SpecimenSimNode, (SpecimenError, AuthError), serve,
                    cleanup=SpecimenSimNode.close, teardown_timeout=TEARDOWN_TIMEOUT)


if __name__ == '__main__':
    sys.exit(main())

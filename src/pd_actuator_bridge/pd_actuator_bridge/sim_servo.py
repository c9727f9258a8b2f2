"""The ``sim_servo`` driver: a simulated servo that forwards each checked move to a specimen node.

A shell-side driver (it needs ``rclpy``): each move goes out as a ``StepCommand`` on
``<specimen_namespace>/step_command`` and the specimen node's ``StepFeedback`` on
``<specimen_namespace>/step_feedback`` is the measurement. Importing this module registers it
(:data:`SIM_SERVO`); the node imports it. It is an asynchronous driver and fills the node's
neutral hooks (:class:`~pd_actuator_bridge.core.ActuatorDriver`): the node keys its moves by
the command's run tag (:meth:`SimServoDriver.set_test_id`), enforces ``driver_timeout`` on the
move in flight (:meth:`SimServoDriver.waiting_since`), re-sends the move for a re-sent command
(:meth:`SimServoDriver.repeat`), keeps the session open (:meth:`SimServoDriver.poll`) and waits
for :meth:`SimServoDriver.ready` before offering a session.

With a key, the driver opens a signed session with the specimen node (as the integrator does
with the bridge), signs every move (a re-sent move gets a new signature) and takes only the
specimen's signed answers; it reads the specimen's position from the offer the specimen
publishes once it obeys the driver's session (its state now), so a restarted bridge starts
from where the specimen is.

Force control (``docs/force_control.md``): the bridge sends a mixed command's force ramp one
sub-step at a time (:meth:`SimServoDriver.command_force`); each goes out with the command's
``control_mode`` and the sub-step's ``target_force``, keyed for the specimen as a command of
its own: sub-step ``s`` of the integrator's ``(step, iteration)`` is the specimen's
``(step, iteration * SUBSTEP_STRIDE + s)``. So the specimen (which answers a repeat of its last
key with the same answer and ignores older keys) sees every sub-step as a new command, in
order (a ramp-down at deactivation continues the numbering), and the answer to the last one
is reported for the integrator's ``(step, iteration)``. Plain (displacement-only) commands
keep the integrator's key. The specimen ramps each sub-step itself with the same
``max_force_increment``; every bridge sub-step is within it, so it executes each as one state.
"""

from __future__ import annotations

import os
import time
from collections import Counter
from collections.abc import Callable, Sequence
from typing import Any

from rclpy.node import Node

from pd_common.auth import Key, Signer
from pd_common.protocol import (
    Command,
    FeedbackStatus,
    StateOrigin,
    decode_feedback,
    signed_from_bytes,
)
from pd_common.ros import STEP_QOS, SessionSender
from pd_msgs.msg import StepCommand, StepFeedback

from .core import (
    ActuatorDriver,
    ActuatorMeasurement,
    BridgeConfigError,
    DriverContext,
    DriverError,
    DriverParameter,
    DriverSpec,
    register_driver,
)
from .core.drivers.base import force_substep_key


class SimServoDriver(ActuatorDriver):
    """A simulated servo actuator: forwards each move to a specimen node over ROS 2.

    Each move goes out as a ``StepCommand`` keyed like the command it executes (the test id the
    bridge was sent, :meth:`set_test_id`, and its ``(step, iteration)``), in the driver's own
    signed session (``bridge-<pid>``). So the specimen's repeat handling applies: :meth:`repeat`
    re-sends the move in flight and the specimen answers it without moving, and a *restarted*
    bridge that forwards a re-sent command the specimen already executed gets the specimen's
    answer to it, not a second motion (nor a second noise draw).

    Attributes:
        on_fault: Receives the message of a specimen fault (the bridge then holds).
    """

    def __init__(self, node: Node, n_dof: int, namespace: str, key: Key | None = None) -> None:
        """Create the publisher and subscription under ``namespace`` on ``node``."""
        super().__init__()
        self._sender = SessionSender(node, f'{namespace}/', Signer(key) if key else None, key)
        self._positioned = False
        self._specimen_epoch: str | None = None
        self._specimen_origin = StateOrigin.FRESH
        self._node = node
        self._namespace = namespace
        self._n_dof = n_dof
        self._session = f'bridge-{os.getpid()}'
        self._publisher = node.create_publisher(StepCommand, f'{namespace}/step_command',
                                                STEP_QOS)
        self._subscription = node.create_subscription(
            StepFeedback, f'{namespace}/step_feedback', self._on_feedback, STEP_QOS, raw=True)
        self._position = [0.0] * n_dof
        self._offered_force: list[float] | None = None
        self._in_flight: tuple[Any, tuple[str, int, int]] | None = None  # (step, move key)
        self._move_test_id = ''
        self._move: Command | None = None
        self._sent_at = 0.0
        self.on_fault: Callable[[str], None] | None = None

    driver_name = 'sim_servo'

    @property
    def n_dof(self) -> int:
        """Number of actuated DOF."""
        return self._n_dof

    def force_control_problem(self) -> str | None:
        """None: the simulated specimen takes force-controlled actuators."""
        return None

    def ready(self) -> bool:
        """Whether a specimen node listens, talks back and obeys this driver's session.

        Opens the session when the specimen offers one; takes the specimen's position (and
        its state's epoch) from its offer the first time — the offer it publishes once it obeys
        this driver's session, which carries its state *now* (an older latched offer may carry
        the position of an earlier session's start).
        """
        sender = self._sender
        sender.open(self._session)
        offer = sender.offer
        if (offer is not None and sender.opened and len(offer.position) == self._n_dof
                and (not self._positioned or offer.epoch != self._specimen_epoch)):
            # The first offer, or a restarted specimen node: it is where it says it is.
            self._position = [float(x) for x in offer.position]
            self._offered_force = ([float(f) for f in offer.force]
                                   if len(offer.force) == self._n_dof else None)
            self._specimen_epoch = offer.epoch
            self._specimen_origin = StateOrigin.of(offer.state_origin)  # (unsigned: any)
            self._positioned = True
        return self.connected() and sender.opened

    def waiting_for(self) -> str:
        """The specimen node, on its step command topic."""
        topic = self._node.resolve_topic_name(f'{self._namespace}/step_command')
        return f'the specimen node on {topic}'

    @property
    def carried_force(self) -> list[float] | None:
        """The force per DOF the specimen node offered with its position.

        What it carries now; ``None`` before its offer: a restarted bridge holds it (the load a
        column carries).
        """
        return None if self._offered_force is None else list(self._offered_force)

    def poll(self) -> None:
        """Keep the session with the specimen node open (called by the bridge's loop).

        A specimen node that restarted offers a new challenge: the session is re-opened and
        the move in flight re-sent at once (the specimen answers it from its restored record,
        or moves if it never got it).
        """
        was_open = self._sender.opened
        if self.ready() and not was_open and self._in_flight is not None:
            self.repeat()

    def connected(self) -> bool:
        """Whether a specimen node listens and talks back (its session may not be open yet)."""
        return (self._publisher.get_subscription_count() > 0
                and self._subscription.get_publisher_count() > 0)

    @property
    def state_epoch(self) -> str | None:
        """The specimen node's epoch (from its offer and its answers)."""
        return self._specimen_epoch

    def refusals(self) -> dict[str, dict[str, int]]:
        """The specimen's answers and offers refused by authentication.

        By reason (source ``specimen/step_feedback``).
        """
        counts = Counter(self._sender.reply_gate.refused)
        counts.update(self._sender.offer_gate.refused)
        return {'specimen/step_feedback': dict(counts)}

    def set_test_id(self, test_id: str) -> None:
        """Key the moves that follow by ``test_id`` (the command's run tag), as the command."""
        self._move_test_id = test_id

    def waiting_since(self) -> float | None:
        """``time.monotonic()`` of the last (re-)sent move still waiting for its answer.

        ``time.monotonic()`` of the last (re-)sent move while it waits for the specimen's
        answer; ``None`` when no move is in flight.
        """
        return self._sent_at if self._in_flight is not None else None

    def command(self, step: Any, target: Sequence[float]) -> None:
        """Forward a checked move to the specimen, keyed like the command it executes."""
        number, iteration = (int(step[0]), int(step[1])) if isinstance(step, tuple) else (
            int(step), 0)
        self._send(step, number, iteration, target)

    def command_force(self, step: Any, target: Sequence[float],
                      control_mode: Sequence[int], target_force: Sequence[float]) -> None:
        """Forward one force sub-step ``step = (*key, s)``.

        Keyed :func:`~pd_actuator_bridge.core.drivers.base.force_substep_key` for the specimen
        (``(step, iteration * SUBSTEP_STRIDE + s)``, see the module docstring).

        Raises:
            DriverError: A sub-step number or an iteration the key scheme cannot carry.
        """
        try:
            number, iteration = force_substep_key(step)
        except DriverError as err:
            msg = f'driver sim_servo: {err}'
            raise DriverError(msg) from err
        self._send(step, number, iteration, target,
                   tuple(int(mode) for mode in control_mode),
                   tuple(float(force) for force in target_force))

    def _send(self, step: Any, number: int, iteration: int, target: Sequence[float],
              control_mode: tuple[int, ...] = (), target_force: tuple[float, ...] = ()
              ) -> None:
        """Send a move keyed ``(test id, number, iteration)``, reported for ``step``."""
        test_id = self._move_test_id or self._session
        self._move = Command(test_id=test_id, step=number, test_time=0.0,
                             dof_names=tuple(f'dof{i}' for i in range(self._n_dof)),
                             target_displacement=tuple(float(value) for value in target),
                             iteration=iteration, control_mode=control_mode,
                             target_force=target_force)
        self._in_flight = (step, (test_id, number, iteration))
        self.repeat()

    def repeat(self) -> None:
        """Re-send the move in flight, signed anew (the specimen answers it without moving)."""
        if self._move is not None and self._in_flight is not None:
            self._sent_at = time.monotonic()
            self._publisher.publish(self._sender.encode(self._move, time.time_ns())[0])

    def hold(self) -> None:
        """Stop: forget the move in flight; the specimen stays where it is."""
        self._in_flight = None

    @property
    def state_origin(self) -> StateOrigin:
        """Where the specimen node's state comes from (its offer, then its answers)."""
        return self._specimen_origin

    def position(self) -> list[float]:
        """Last measured displacement."""
        return list(self._position)

    def close(self) -> None:
        """Release the topics."""
        self._in_flight = None
        self._node.destroy_publisher(self._publisher)
        self._node.destroy_subscription(self._subscription)

    def _on_feedback(self, data: bytes) -> None:
        """Report the specimen's answer to the move in flight (ignore anything else)."""
        decoded = signed_from_bytes(decode_feedback, data)
        if self._in_flight is None or decoded is None:  # (malformed: not an answer)
            return
        feedback = decoded.record
        if (feedback.test_id, feedback.step, feedback.iteration) != self._in_flight[1]:
            return
        if self._sender.admit(decoded) is not None:
            return  # not the specimen's genuine answer (counted): the move stays in flight
        self._specimen_epoch = feedback.epoch
        self._specimen_origin = feedback.state_origin
        step = self._in_flight[0]
        self._in_flight = None
        if feedback.status is not FeedbackStatus.OK:
            if self.on_fault is not None:
                self.on_fault(f'specimen fault at step {step}: {feedback.message}')
            return
        self._position = list(feedback.measured_displacement)
        self._emit(ActuatorMeasurement(step, tuple(feedback.measured_displacement),
                                       tuple(feedback.restoring_force)))


def make_sim_servo_driver(context: DriverContext) -> SimServoDriver:
    """The ``sim_servo`` driver on ``context.host`` (the node), faults to ``context.on_fault``.

    Raises:
        BridgeConfigError: If ``context.host`` is not an ``rclpy`` node.
    """
    if not isinstance(context.host, Node):
        msg = (f'driver sim_servo: needs the rclpy node as DriverContext.host, got '
               f'{type(context.host).__name__}')
        raise BridgeConfigError(msg)
    driver = SimServoDriver(context.host, context.n_dof, context.parameters['specimen_namespace'],
                            context.key)
    driver.on_fault = context.on_fault
    return driver


SIM_SERVO = DriverSpec(
    name='sim_servo',
    factory=make_sim_servo_driver,
    parameters=(
        DriverParameter('specimen_namespace', 'specimen', 'namespace of the specimen node'),
        DriverParameter('driver_timeout', 5.0,
                        'seconds one move may take before the bridge holds'),
    ),
    description='simulated servo: forwards each checked move to a pd_specimen_sim node '
                '(<specimen_namespace>/step_command) and returns its measurement',
)
register_driver(SIM_SERVO)

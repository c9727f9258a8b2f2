"""The actuator bridge node (``ros2 run pd_actuator_bridge main``): a managed (lifecycle) node.

The boundary between the test loop and the hardware. It answers the integrator's
``step_command`` with ``step_feedback`` like a specimen does, but every command first passes the
bridge's own safety limits (:class:`pd_actuator_bridge.core.ActuatorBridge`): a NaN, a jump or a
target beyond a limit never reaches the driver; the actuator holds position, the command is
answered with a limit/fault status and the reason is published on ``bridge/status``. A hold is
latched until an operator sends ``reset`` on ``bridge/control`` (or calls ``bridge/reset``).

Lifecycle (``ros2 lifecycle set /pd/pd_actuator_bridge <transition>``):

* ``configure`` builds and opens the driver and reads the actuator's position and force;
* ``activate`` starts listening on ``step_command`` and, once the driver is ready, offers a
  new session: motion then needs the owner's signed session start (the integrator waits);
* ``deactivate`` ramps force-controlled actuators down to 0 N (the force ramp's sub-steps,
  never a jump; :meth:`~pd_actuator_bridge.core.ActuatorBridge.ramp_down`, logged and on
  ``bridge/status``), holds position and stops listening;
* ``cleanup`` / ``shutdown`` release the hardware.

With ``autostart: true`` (the simulated set-up) the node configures and activates itself.

Tracking monitor: for every step answered OK, ``monitor/tracking`` (``/pd/monitor/tracking``,
``std_msgs/Float64MultiArray``) carries the tracking error ``measured - commanded`` [m] of each
DOF followed by the running tracking indicator [m²] of each DOF (positive = energy removed,
negative = energy added; :class:`pd_common.experimental.TrackingMonitor`, restarted for each
test id). The integrator's outputs rebuild the same values from the bag
(``tracking.csv``); this topic is for watching a test while it runs, published while
something subscribes to it (the indicator runs on every step regardless).

Emergency stop, from any state, latched until ``reset_emergency_stop``: a message on the
``bridge/emergency_stop`` topic (``std_msgs/String``, the reason) or on the lab-wide
``/pd/emergency_stop`` topic (every bridge of every site listens to it), or a call of the
``bridge/emergency_stop`` service (``std_srvs/Trigger``). Anyone may stop the machine; clearing
the stop, like every other control, is authenticated.

Authentication (parameters ``key_file``, ``authentication``; see :mod:`pd_common.ros.keys`):
the bridge obeys step commands only in the session a signed ``session/start`` opened while it
is active (its ``session/offer`` is latched and signed; activating or deactivating ends the
session, so a lifecycle transition alone never enables motion), signs every answer, its
offers and its statuses, and obeys ``bridge/control`` (``pd_msgs/Control``: ``reset``,
``reset_emergency_stop``, ``hold``, the lifecycle transitions ``configure``, ``activate``,
``deactivate``, ``cleanup``, and the supervisor's ``auto_hold`` / ``auto_reset``) only when
signed, bound to this node, its instance session and its test, fresh and new; its status
acknowledges the last one taken. The ``bridge/reset`` and ``bridge/reset_emergency_stop``
services cannot be authenticated: with a key they refuse and say so. Refused messages are
counted by reason on ``bridge/status``.

Sealed configuration: with a key, the bridge's parameters are fixed when it starts (a
``set_parameters`` call is refused: restart the bridge with a new parameter file) and its
lifecycle moves only on the owner's signed controls (the ROS ``change_state`` service
cannot be authenticated: with a key every transition it asks for is refused). The driver and
the limits in force are in every session offer (``configuration``), so the integrator's
summary names them.

Durable holds (parameter ``record_file``; ``run_test`` gives each bridge one in the run
folder, a bridge started by hand keeps one under ``$XDG_STATE_HOME/pd/bridges``): an
emergency stop, a person's hold and every control taken are appended to the record and put on
disk before the bridge answers anything else; a restarted bridge replays the record first, so
a crash or a restart never clears an emergency stop or a person's hold (only a person's signed
reset does), nor lets a control be replayed. An emergency stop's reason is cut to 256
characters; stops that arrive while one is latched are counted, not logged one by one.

Drivers (parameter ``driver``): any name registered in
:mod:`pd_actuator_bridge.core.drivers.registry`. ``driver_names()`` lists them and
``driver_spec(name)`` gives each one's description and parameters, which the node declares after
its own. :mod:`pd_actuator_bridge.core.drivers` registers the pure drivers (one module each),
:mod:`pd_actuator_bridge.sim_servo` the ``sim_servo`` driver; ``docs/actuator_bridge.md``
explains how to connect each. The node names no driver class: it drives each one through the
neutral hooks of :class:`~pd_actuator_bridge.core.ActuatorDriver` (``ready``, ``poll``,
``set_test_id``, ``repeat``, ``waiting_since``, ``last_force``, ``carried_force``,
``refusals``) and publishes the core's :class:`pd_common.protocol.Feedback` as it is, with the
test id untagged and the epoch and state origin stamped.
"""

from __future__ import annotations

import dataclasses
import json
import os
import sys
import time
from pathlib import Path
from typing import Any, TypeVar

import rclpy
from rcl_interfaces.msg import ParameterDescriptor
from rclpy.executors import Executor
from rclpy.lifecycle import LifecycleNode, LifecycleState, TransitionCallbackReturn
from std_msgs.msg import Float64MultiArray, MultiArrayDimension, String
from std_srvs.srv import Trigger

from pd_common.auth import (
    AuthError,
    ControlGate,
    Refusal,
    Signer,
    describe_refusals,
    merge_refusals,
)
from pd_common.dds import use_discovery_profile
from pd_common.experimental import TrackingMonitor
from pd_common.experimental.limits import LIMIT_PARAMETERS, limits_from_parameters
from pd_common.jsonl import EventFile
from pd_common.protocol import (
    GLOBAL_EMERGENCY_STOP,
    LIFECYCLE_CONTROLS,
    Acknowledgements,
    Feedback,
    FeedbackStatus,
    PersonHolds,
    RunTags,
    Signature,
    Status,
    StepKey,
    TestState,
    amended,
    clip_reason,
    control_from_message,
    decode_command,
    signed_from_bytes,
    signed_from_message,
    untag,
)
from pd_common.ros import (
    CONTROL_DEPTH,
    HEARTBEAT_S,
    LATCHED_QOS,
    MONITOR_QOS,
    OFFER_REFRESH_S,
    STEP_QOS,
    TEARDOWN_TIMEOUT,
    Announcer,
    RefusalLog,
    SessionReceiver,
    declare_key,
    new_epoch,
    now_stamp,
    quiet_at_shutdown,
    run_node,
    seal_parameters,
    settle_collector,
    sign_trajectory,
    spin_until_shutdown,
)
from pd_msgs.msg import ActuatorTrajectory, StepCommand, StepFeedback, TestStatus
from pd_msgs.msg import Control as ControlMessage

from . import sim_servo  # noqa: F401 - importing it registers the sim_servo driver
from .core import (
    ActuatorBridge,
    ActuatorDriver,
    BridgeConfigError,
    BridgeError,
    DriverContext,
    SafetyLimits,
    driver_names,
    driver_parameters,
    driver_spec,
    make_driver,
)

Signed = TypeVar('Signed')  # a message read with its signature
SUCCESS = TransitionCallbackReturn.SUCCESS
FAILURE = TransitionCallbackReturn.FAILURE
#: Seconds between two log lines about emergency stops received while one is latched.
ESTOP_LOG_INTERVAL_S = 10.0
#: Least seconds between two :meth:`ActuatorBridgeNode.check_driver` (its driver timeout,
#: watchdog and session checks) while messages flow, not one after every message (~20 µs
#: each, twice a step); when they stop, the next comes after one spin timeout (50 ms).
CHECK_INTERVAL_S = 0.01


def default_record_file(node_name: str) -> Path:
    """Where a bridge started without ``record_file`` keeps its record.

    Per ROS domain and node, under ``$XDG_STATE_HOME/pd/bridges`` (``~/.local/state``).
    """
    base = os.environ.get('XDG_STATE_HOME') or str(Path.home() / '.local' / 'state')
    domain = os.environ.get('ROS_DOMAIN_ID', '0') or '0'
    name = node_name.strip('/').replace('/', '.') or 'pd_actuator_bridge'
    return Path(base) / 'pd' / 'bridges' / f'domain{domain}' / f'{name}.jsonl'


class ActuatorBridgeNode(LifecycleNode):
    """Enforces the bridge's limits between the integrator and the actuator driver."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__('pd_actuator_bridge', namespace='pd', **kwargs)
        describe = ParameterDescriptor
        for name, default, description in (
            ('driver', 'sim_servo', f'actuator driver: {", ".join(driver_names())}'),
            ('dof_names', ['top'], 'one name per actuator DOF'),
            ('autostart', False, 'configure and activate at start (simulated set-ups)'),
            ('max_displacement', LIMIT_PARAMETERS['max_displacement'],
             'absolute displacement limit of every DOF [m]'),
            ('max_increment', LIMIT_PARAMETERS['max_increment'],
             'largest displacement change in one step [m]'),
            ('max_force', LIMIT_PARAMETERS['max_force'], 'absolute measured force limit [N]'),
            ('max_velocity', 0.0, 'velocity limit [m/s] (0 = off; needs step_duration)'),
            ('step_duration', 0.0, 'time the actuator takes for one step [s] (0 = off)'),
            ('tracking_tolerance', 0.0, '|measured - commanded| limit [m] (0 = off)'),
            ('watchdog_timeout', 0.0, 'hold after this long without a command [s] (0 = off)'),
            ('max_force_increment', 0.0,
             ("largest change of a force-controlled actuator's force in one sub-step [N]: a "
              'force change is ramped in sub-steps of at most this, each checked (0 = no ramp; '
              'docs/force_control.md)')),
            ('on_limit', 'hold', "'hold' (default) or 'saturate' (quasi-static moves only)"),
            ('record_file', '', ('the bridge\'s durable record (emergency stops, holds, '
                                 'controls); '
                                 'default: $XDG_STATE_HOME/pd/bridges/domain<id>/<node>.jsonl')),
        ):
            self.declare_parameter(name, default, describe(description=description))
        # Then the parameters of every registered driver (one ROS parameter per name, whichever
        # drivers share it).
        for parameter, drivers in driver_parameters():
            self.declare_parameter(parameter.name, parameter.default, describe(
                description=f'{"/".join(drivers)}: {parameter.description}'))
        self.key = declare_key(self)
        self.epoch = new_epoch()
        self.announcer = Announcer(self, self.key)
        self._trajectory_signer = Signer(self.key) if self.key is not None else None
        self._refusal_log = RefusalLog(self.get_logger().warning, self.key, 'message')
        self._control_gate = ControlGate(self.key, self.announcer.identity,
                                         self.announcer.session)
        self._malformed = 0  # messages beyond their bounds (refused before anything else)
        self.record = self._open_record()
        # The holds a person made survive a crash: replayed before anything is answered.
        self.holds = PersonHolds.replay(self.record.events)
        for event in self.record.events:
            if event.get('what') == 'control' and event.get('session'):
                self._control_gate.remember(str(event['session']), int(event['sequence']))
        self._acknowledged = Acknowledgements()
        self._runs = RunTags()
        self._estop_logged_at = 0.0
        self._estop_repeats_logged = 0
        # Lifecycle transitions: with a key, only the owner's signed controls (or the node's
        # own autostart) may move the lifecycle; the ROS service cannot be authenticated.
        self._transition_allowed = self.key is None
        self.receiver = SessionReceiver(self, self.key, len(self.get_parameter('dof_names').value),
                                        self.epoch, on_refused=self._on_refused_start,
                                        accepting=False,  # sessions only while active
                                        announcer=self.announcer)
        self.create_timer(OFFER_REFRESH_S, quiet_at_shutdown(self, self.receiver.refresh))
        self._request = Signature()  # the signature of the command being answered
        self._accept_when_ready = False
        self._ramping_down = False  # a deactivation's force ramp-down still executing
        self.bridge: ActuatorBridge | None = None
        self.driver: ActuatorDriver | None = None
        self.limits: SafetyLimits | None = None
        self._command_sub: Any = None
        self._feedback_pub: Any = None
        self._test_id = ''
        self._step = 0
        self._last_status: tuple[int, str] = (TestStatus.STATE_IDLE, 'unconfigured')
        self._status_at = 0.0
        self._status_pub = self.create_publisher(TestStatus, 'bridge/status', LATCHED_QOS)
        self._trajectory_pub = self.create_publisher(ActuatorTrajectory, 'bridge/trajectory',
                                                     STEP_QOS)
        self._monitor_pub: Any = self.create_publisher(Float64MultiArray, 'monitor/tracking',
                                                       MONITOR_QOS)
        self._monitor: TrackingMonitor | None = None
        self._monitor_message = Float64MultiArray()  # its layout set for each test
        self._monitor_key: tuple[str, int] | None = None  # (test id, DOF count) monitored
        self._monitored: tuple[str, Any] | None = None  # (test id, key) of the last sample
        self._target: tuple[str, Any, tuple[float, ...]] | None = None  # last command
        self.create_subscription(ControlMessage, 'bridge/control',
                                 quiet_at_shutdown(self, self._on_control), CONTROL_DEPTH)
        self.create_subscription(String, 'bridge/emergency_stop',
                                 quiet_at_shutdown(self, self._on_emergency_topic), CONTROL_DEPTH)
        # The lab-wide emergency stop: one message holds every site's bridge at once.
        self.create_subscription(String, GLOBAL_EMERGENCY_STOP,
                                 quiet_at_shutdown(self, self._on_emergency_topic), CONTROL_DEPTH)
        self.create_service(Trigger, 'bridge/emergency_stop', self._on_emergency_service)
        self.create_service(Trigger, 'bridge/reset', self._on_reset_service)
        self.create_service(Trigger, 'bridge/reset_emergency_stop', self._on_reset_emergency)
        self.create_timer(HEARTBEAT_S, quiet_at_shutdown(self, self._heartbeat))
        if self.key is not None:  # sealed: the parameters given at start are the ones in force
            seal_parameters(self, 'the bridge', 'restart it with a new parameter file',
                            self._control_gate.refused)
        if self.holds.emergency is not None:
            self.get_logger().error(f'EMERGENCY STOP latched before a restart, still in force '
                                    f'({self.holds.emergency}); only a signed '
                                    'reset_emergency_stop clears it')
        if self.holds.operator is not None:
            self.get_logger().warning(f'{self.holds.operator} before a restart, still in force; '
                                      'only a signed reset clears it')
        self.publish_status(TestStatus.STATE_HOLDING if self._latched() else TestStatus.STATE_IDLE,
                            self._latched() or 'unconfigured')

    # -- record and sealing ---------------------------------------------------------------
    def _open_record(self) -> EventFile:
        """The bridge's durable record (replayed at start, appended to after)."""
        given = str(self.get_parameter('record_file').value)
        path = Path(given) if given else default_record_file(self.get_fully_qualified_name())
        try:
            return EventFile(path)
        except (OSError, ValueError) as err:
            msg = (f'parameter record_file: {err}; the bridge does not start without knowing '
                   'whether an emergency stop is latched')
            raise BridgeConfigError(msg) from None

    def _latched(self) -> str:
        """What a person latched ('' if nothing): the emergency stop first."""
        if self.holds.emergency is not None:
            return f'EMERGENCY STOP: {self.holds.emergency}'
        return self.holds.operator or ''

    def _transition(self, name: str) -> bool:
        """Whether a lifecycle transition may run now (else it is refused and logged)."""
        if self._transition_allowed:
            return True
        self.get_logger().warning(
            f'refused lifecycle {name}: a key is in use and the change_state service cannot be '
            f'authenticated; send the signed control instead (./pd control {name} --bridge)')
        self._control_gate.refused['unsigned'] += 1
        state, message = self._last_status
        self.publish_status(state, message)
        return False

    def trigger(self, name: str) -> bool:
        """Run lifecycle transition ``name`` as the node itself (autostart, a signed control).

        Whether it succeeded.
        """
        self._transition_allowed = True
        try:
            result = getattr(self, f'trigger_{name}')()
        finally:
            self._transition_allowed = self.key is None
        return bool(result == SUCCESS)

    # -- lifecycle ------------------------------------------------------------------------
    def on_configure(self, state: LifecycleState) -> TransitionCallbackReturn:
        """Build and open the driver; read the actuator's position and force."""
        if not self._transition('configure'):
            return FAILURE
        try:
            self._configure()
        except (BridgeError, ValueError) as err:
            self.get_logger().error(f'configure failed: {err}')
            self.publish_status(TestStatus.STATE_IDLE, f'configure failed: {err}')
            self._release()
            return FAILURE
        return SUCCESS

    def on_activate(self, state: LifecycleState) -> TransitionCallbackReturn:
        """Enable motion: start answering the integrator."""
        if not self._transition('activate'):
            return FAILURE
        driver = self.driver
        if driver is not None and not driver.ready():
            # Active, but no session is offered (so nothing can move) until it is.
            self.get_logger().info(f'active; waiting for {driver.waiting_for()}')
        self._feedback_pub = self.create_publisher(StepFeedback, 'step_feedback', STEP_QOS)
        # The hot topics travel as CDR bytes (pd_common.protocol.cdr): no message objects.
        self._command_sub = self.create_subscription(
            StepCommand, 'step_command', quiet_at_shutdown(self, self._on_command), STEP_QOS,
            raw=True)
        self._accept_when_ready = True  # check_driver offers a session once the driver is
        limits = self.limits
        assert limits is not None
        text = (
            f'active ({self.get_parameter("driver").value}): |x| <= {limits.max_displacement} '
            f'm, |dx| <= {limits.max_increment} m per step, |f| <= {limits.max_force} N'
            + (f', force ramp <= {limits.max_force_increment} N per sub-step'
               if limits.max_force_increment > 0.0 else ''))
        latched = self._latched()
        if latched:
            self.publish_status(TestStatus.STATE_HOLDING, f'{text}; holding: {latched}')
        else:
            self.publish_status(TestStatus.STATE_RUNNING, text)
        settle_collector()  # what configure built (the driver) is not walked again in motion
        return super().on_activate(state)

    def on_deactivate(self, state: LifecycleState) -> TransitionCallbackReturn:
        """Ramp force-controlled actuators down to 0 N.

        Hold position and stop answering the integrator.
        """
        if not self._transition('deactivate'):
            return FAILURE
        note = self.bridge.ramp_down() if self.bridge is not None else ''
        self._stop_answering()
        self._accept_when_ready = False
        self.receiver.set_accepting(False)
        if self.bridge is not None and self.bridge.ramping_down:
            # An asynchronous driver: check_driver holds once the ramp-down has ended.
            self._ramping_down = True
            self.get_logger().warning(f'deactivating: {note}')
            self.publish_status(TestStatus.STATE_IDLE, f'inactive: {note}')
            return super().on_deactivate(state)
        self._hold_driver()
        if note:
            done = self.bridge.ramp_down_note if self.bridge is not None else note
            self.get_logger().warning(f'deactivating: {done}')
            self.publish_status(TestStatus.STATE_IDLE, f'inactive: {done}; holding position')
        else:
            self.publish_status(TestStatus.STATE_IDLE, 'inactive: holding position')
        return super().on_deactivate(state)

    def _check_ramp_down(self, bridge: ActuatorBridge) -> None:
        """Hold once a deactivation's force ramp-down has ended, and say how it ended."""
        if not self._ramping_down or bridge.ramping_down:
            return
        self._ramping_down = False
        self._hold_driver()
        note = bridge.ramp_down_note
        if bridge.state == 'holding':
            self.get_logger().error(note)
        else:
            self.get_logger().warning(note)
        self.publish_status(TestStatus.STATE_IDLE, f'inactive: {note}; holding position')

    def on_cleanup(self, state: LifecycleState) -> TransitionCallbackReturn:
        """Release the driver."""
        if not self._transition('cleanup'):
            return FAILURE
        self._release()
        self.publish_status(TestStatus.STATE_IDLE, 'unconfigured')
        return SUCCESS

    def on_shutdown(self, state: LifecycleState) -> TransitionCallbackReturn:
        """Hold and release the hardware."""
        if not self._transition('shutdown'):
            return FAILURE
        self.receiver.set_accepting(False)
        self._hold_driver()
        self._stop_answering()
        self._release()
        return SUCCESS

    def on_error(self, state: LifecycleState) -> TransitionCallbackReturn:
        """Hold on any error in a transition."""
        self._hold_driver()
        return SUCCESS

    def _configure(self) -> None:
        value = self.get_parameter
        names = list(value('dof_names').value)
        # (the rule the ROS-free rehearsals apply to the same parameters: 0 = off)
        self.limits = limits_from_parameters(
            {key: value(key).value for key in LIMIT_PARAMETERS},
            source='pd_actuator_bridge parameters')
        if len(names) != len(self.receiver.position):
            msg = 'parameter dof_names: changed after the node started (restart it)'
            raise BridgeConfigError(msg)
        self.driver = self._make_driver(value('driver').value, len(names))
        self.driver.open()
        self.bridge = ActuatorBridge(self.driver, self.limits, names,
                                     on_limit=value('on_limit').value)
        self.bridge.set_reply_callback(self._publish_reply)
        if self.holds.emergency is not None:
            self.bridge.emergency_stop(self._latched())
        elif self.holds.operator is not None:
            self.bridge.handle_fault(self.holds.operator)
        driver_name = str(value('driver').value)
        self.receiver.configuration = json.dumps(
            {'driver': driver_name, 'limits': _limits_in_force(self.limits),
             'on_limit': str(value('on_limit').value)}, sort_keys=True)
        self.record.append({'what': 'configured', 'driver': driver_name,
                            'limits': _limits_in_force(self.limits)})
        if not self.driver.ready():
            text = f'configured: position read from {self.driver.waiting_for()} once it answers'
        else:
            text = f'configured: position [{_positions(self.driver.position())}] m'
        self.get_logger().info(text)
        self.publish_status(TestStatus.STATE_IDLE, text)

    def _make_driver(self, name: str, n_dof: int) -> ActuatorDriver:
        """Build the registered driver ``name`` with its declared parameters' values."""
        parameters = {key: self.get_parameter(key).value
                      for key in driver_spec(name).parameter_names}
        return make_driver(name, DriverContext(
            n_dof, parameters, on_trajectory=self._publish_trajectory,
            on_fault=self._on_driver_fault, host=self, key=self.key))

    def _offer_state(self) -> None:
        """The specimen state behind the bridge, for its offer: epoch, origin, position."""
        driver = self.driver
        if driver is None:
            return
        self.receiver.epoch = driver.state_epoch or self.epoch
        self.receiver.origin = driver.state_origin
        force = driver.last_force
        position = driver.position()
        self.receiver.set_state(position, force if force is not None else [0.0] * len(position))

    def _hold_driver(self) -> None:
        if self.driver is not None:
            try:
                self.driver.hold()
            except BridgeError as err:
                self.get_logger().error(f'hold failed: {err}')

    def _stop_answering(self) -> None:
        if self._command_sub is not None:
            self.destroy_subscription(self._command_sub)
            self._command_sub = None
        if self._feedback_pub is not None:
            self.destroy_publisher(self._feedback_pub)
            self._feedback_pub = None

    def _release(self) -> None:
        if self.driver is not None:
            try:
                self.driver.close()
            except BridgeError as err:
                self.get_logger().error(f'close failed: {err}')
        self.driver = None
        self.bridge = None

    # -- status and replies -------------------------------------------------------------------
    def publish_status(self, state: int, message: str) -> None:
        """Publish the bridge's latched status (signed; again every second as a heartbeat)."""
        refused = merge_refusals(self.refusals().values())
        status = Status(test_id=self._test_id, state=TestState(state), step=int(self._step),
                        total_steps=0, omega_dt=0.0, message=message,
                        refused_messages=sum(refused.values()),
                        refused_by_reason=describe_refusals(refused),
                        emergency_stop=self.holds.emergency is not None,
                        operator_hold=self.holds.operator is not None,
                        acknowledged=self._acknowledged.text)
        self._status_pub.publish(self.announcer.status(status))
        self._last_status = (state, message)
        self._status_at = time.monotonic()

    def _heartbeat(self) -> None:
        """The last status again if none went out for a second (a live bridge is heard)."""
        if time.monotonic() - self._status_at >= HEARTBEAT_S * 0.9:
            state, message = self._last_status
            self.publish_status(state, message)

    def refusals(self) -> dict[str, dict[str, int]]:
        """Messages refused by authentication, by source and reason."""
        counts = {'step_command': dict(self.receiver.gate.refused),
                  'bridge/control': dict(self._control_gate.refused)}
        if self._malformed:
            counts['malformed'] = {Refusal.MALFORMED.value: self._malformed}
        if self.driver is not None:
            counts.update(self.driver.refusals())
        return {source: count for source, count in counts.items() if count}

    def _refused(self, reason: Any, signature: Signature, source: str) -> None:
        """Count-and-report path of a refused message: one log line per kind, a status."""
        self._refusal_log(reason, signature, self.resolve_topic_name(source))
        state, message = self._last_status
        self.publish_status(state, message)

    def _well_formed(self, signed: Signed | None, source: str) -> Signed | None:
        """A message's item and signature, read; ``None`` is counted and reported (malformed)."""
        if signed is None:
            self._malformed += 1
            self._refused(Refusal.MALFORMED, Signature(), source)
        return signed

    def _on_refused_start(self, reason: Any, signature: Signature) -> None:
        self._refused(reason, signature, 'session/start')

    def _publish_reply(self, reply: Feedback) -> None:
        """Publish the bridge's answer, stamped and signed.

        Publish the bridge's answer (test id untagged, the specimen state's epoch and
        origin stamped), signed.
        """
        if self._feedback_pub is None:
            return
        # The command answered, read before the answer goes out: in real time the driver's
        # ticking thread answers, and the next command may arrive before the monitor runs.
        target = self._target
        driver = self.driver
        feedback = amended(
            reply, test_id=untag(reply.test_id),
            epoch=(driver.state_epoch if driver is not None else None) or self.epoch,
            state_origin=driver.state_origin if driver is not None else self.receiver.origin)
        self._feedback_pub.publish(self.receiver.encode_reply(feedback, time.time_ns(),
                                                              self._request))
        if reply.status is FeedbackStatus.OK:
            self.receiver.set_state(reply.measured_displacement, reply.restoring_force)
            # The state behind the bridge (a restarted specimen node's epoch) for its offer.
            self.receiver.epoch, self.receiver.origin = feedback.epoch, feedback.state_origin
        if reply.status is FeedbackStatus.OK and self._monitor_pub is not None:
            try:
                self._publish_monitor(reply, target)
            except Exception as err:  # noqa: BLE001 - a monitor must never stop the bridge
                self.get_logger().error(f'tracking monitor disabled: {err!r}')
                self._monitor_pub = None
        if reply.message.startswith('saturated'):
            self.get_logger().warning(reply.message)
            self.publish_status(TestStatus.STATE_RUNNING, reply.message)
        elif reply.status is not FeedbackStatus.OK:
            self.publish_status(TestStatus.STATE_HOLDING, reply.message)

    def _publish_monitor(self, reply: Feedback,
                         target: tuple[str, Any, tuple[float, ...]] | None) -> None:
        """Add an answered step to the tracking monitor and publish its error and indicator.

        ``target``: the command it answers (run, step key, target displacement).
        """
        key = reply.key
        if target is None or (target[0], target[1]) != (reply.test_id, key):
            return
        if self._monitored == (reply.test_id, key):
            return  # the same step answered again (a re-sent command): no new sample
        n = len(target[2])
        if self._monitor is None or self._monitor_key != (reply.test_id, n):
            self._monitor = TrackingMonitor(n, keep_history=False)  # a new test: a new indicator
            self._monitor_key = (reply.test_id, n)
            self._monitor_message.layout.dim = [
                MultiArrayDimension(label='error[m],indicator[m2]', size=2, stride=2 * n),
                MultiArrayDimension(label='dof', size=n, stride=n),
            ]
        try:
            sample = self._monitor.update(target[2], reply.measured_displacement)
        except ValueError:
            return  # a malformed measurement: the bridge's own checks report it
        self._monitored = (reply.test_id, key)
        # The indicator runs on every step; the message is made only for someone to read it
        # (its message object and publish cost the step loop ~60 us: the real-time loop feels it).
        if self._monitor_pub.get_subscription_count() == 0:
            return
        message = self._monitor_message
        message.data = [*sample.error.tolist(), *sample.indicator.tolist()]
        self._monitor_pub.publish(message)

    def _publish_trajectory(self, step: Any, execution: Any) -> None:
        message = ActuatorTrajectory()
        message.header.stamp = now_stamp()
        message.test_id = self._test_id
        number, iteration = step if isinstance(step, tuple) else (step, 0)
        message.step = int(number)
        message.iteration = int(iteration)
        times = execution.time
        message.rate = float(1.0 / (times[1] - times[0])) if len(times) > 1 else 0.0
        message.n_dof = int(execution.command.shape[1])
        message.time = times.astype(float).tolist()
        message.command = execution.command.reshape(-1).tolist()
        message.measured_displacement = execution.measured_displacement.reshape(-1).tolist()
        message.measured_force = execution.measured_force.reshape(-1).tolist()
        # (signed by a signer of its own: statuses are signed from other callbacks)
        sign_trajectory(message, self._trajectory_signer, self.announcer.identity)
        self._trajectory_pub.publish(message)

    # -- callbacks ----------------------------------------------------------------------------
    def _on_command(self, data: bytes) -> None:
        bridge = self.bridge
        if bridge is None:
            return
        decoded = self._well_formed(signed_from_bytes(decode_command, data), 'step_command')
        if decoded is None:
            return
        command, signature = decoded.record, decoded.signature
        reason = self.receiver.admit(decoded)
        if reason is not None:  # never moves on a message it cannot authenticate
            self._refused(reason, signature, 'step_command')
            return
        self._request = signature
        renamed = command.test_id != self._test_id
        self._test_id, self._step = command.test_id, command.step
        if renamed:  # controls are bound to the test its status names: name the new one now
            state, text = self._last_status
            self.publish_status(state, text)
        key = StepKey(command.step, command.iteration)  # the bridge core orders steps by it
        # (the same test file run again by a new integrator: a new run, not stale steps)
        run = self._runs.tag(command.test_id, key, signature.session)
        self._target = (run, key, command.target_displacement)
        was_holding = bridge.state == 'holding'
        resent = bridge.in_flight == (run, key)  # (its move went out already)
        driver = self.driver
        if driver is not None:
            driver.set_test_id(run)  # a forwarding driver keys its moves like the command
        reply = bridge.handle_command(
            run, key, command.target_displacement, control_mode=command.control_mode,
            target_force=command.target_force)
        if resent and reply is None and driver is not None and bridge.in_flight == (run, key):
            # A re-sent command: ask the controller again, no new motion (a new command's
            # move was sent by handle_command: not twice).
            driver.repeat()
        if reply is not None:
            self._publish_reply(reply)
            if reply.status is not FeedbackStatus.OK and not was_holding:
                self.get_logger().error(f'holding: {reply.message}')

    def _on_driver_fault(self, message: str, *, timeout: bool = False) -> None:
        if self.bridge is None:
            return
        reply = self.bridge.handle_fault(message, timeout=timeout)
        if reply is not None:
            self.get_logger().error(f'holding: {message}')
            self._publish_reply(reply)

    def check_driver(self) -> None:
        """Offer a session once an active bridge's driver is ready.

        Hold if the driver did not answer in time, or if the command watchdog expired.
        """
        bridge, driver = self.bridge, self.driver
        if bridge is None or driver is None:
            return
        self._check_ramp_down(bridge)
        if not self._accept_when_ready:
            driver.poll()  # e.g. a restarted specimen node: re-open the session with it
        if self._accept_when_ready and driver.ready():
            self._accept_when_ready = False
            self._offer_state()
            measured = driver.carried_force
            if (measured is not None and bridge.adopt_held_force(measured)
                    and any(force != 0.0 for force in bridge.held_force)):
                self.get_logger().info(
                    f'holding the measured forces [{_positions(bridge.held_force)}] N (a force '
                    'change ramps from them)')
            self.get_logger().info(f'ready: actuator at [{_positions(self.receiver.position)}] '
                                   'm (measured; every limit starts from it)')
            self.receiver.set_accepting(True)  # a new challenge: motion needs a signed start
        timeout = float(self.get_parameter('driver_timeout').value)
        sent_at = driver.waiting_since()
        if (sent_at is not None and bridge.state == 'busy'
                and time.monotonic() - sent_at > timeout):
            self._on_driver_fault(f'actuator did not reach step {self._step} within '
                                  f'{timeout} s', timeout=True)
        if self._command_sub is not None:
            reply = bridge.check_watchdog()
            if reply is not None:
                self.get_logger().error(f'holding: {reply.message}')
                self._publish_reply(reply)

    def emergency_stop(self, reason: str) -> None:
        """Hold at once, from any state.

        Latched (and on disk) until a signed ``reset_emergency_stop``. Anyone may stop: the reason
        is cut to 256 characters, and a stop that arrives while one is latched is counted, not
        logged or recorded.
        """
        self._hold_driver()  # first: nothing about the record may delay the stop
        reason = clip_reason(reason) or 'no reason given'
        event = self.holds.emergency_stop(reason)
        if event is None:  # latched already
            if self.bridge is not None:
                self.bridge.emergency_stop(self._latched())
            self._log_repeated_stops()
            return
        self.record.append(event)
        text = self._latched()
        if self.bridge is not None:
            reply = self.bridge.emergency_stop(text)
            if reply is not None:
                self._publish_reply(reply)
        self.get_logger().error(text)
        self.publish_status(TestStatus.STATE_HOLDING, text)

    def _log_repeated_stops(self) -> None:
        """At most one line per ``ESTOP_LOG_INTERVAL_S`` about stops while one is latched."""
        now = time.monotonic()
        if now - self._estop_logged_at < ESTOP_LOG_INTERVAL_S:
            return
        count = self.holds.repeats - self._estop_repeats_logged
        self._estop_logged_at, self._estop_repeats_logged = now, self.holds.repeats
        self.get_logger().warning(f'{count} more emergency stop(s) while one is latched '
                                  '(counted; the first one\'s reason stands)')

    def _on_emergency_topic(self, message: String) -> None:
        self.emergency_stop(message.data[:4 * 256])

    def _on_emergency_service(self, request: Trigger.Request, response: Trigger.Response
                              ) -> Trigger.Response:
        self.emergency_stop('service call')
        response.success = True
        response.message = 'holding (latched until reset_emergency_stop)'
        return response

    def reset(self, *, clear_emergency: bool = False, by: str = 'operator') -> tuple[bool, str]:
        """Leave a latched hold (a person's action); an e-stop needs ``clear_emergency``."""
        if self.holds.emergency is not None and not clear_emergency:
            return False, f'refused: {self._latched()} (use reset_emergency_stop)'
        if self.bridge is not None and not self.bridge.reset(clear_emergency=clear_emergency):
            return False, 'refused by the bridge'
        event = self.holds.clear(emergency=clear_emergency, by=by)
        if event is not None:
            self.record.append(event)
        what = 'emergency stop and hold' if clear_emergency else 'hold'
        message = f'{what} reset by {clip_reason(by, 80)}'
        self.get_logger().warning(message)
        active = self._command_sub is not None
        self.publish_status(TestStatus.STATE_RUNNING if active else TestStatus.STATE_IDLE,
                            message)
        return True, message

    def _unauthenticated_reset(self, response: Trigger.Response) -> Trigger.Response:
        """A reset service call cannot be authenticated: refused while a key is in use."""
        response.success = False
        response.message = ('refused: authentication is on; send a signed control instead '
                            '(./pd control reset or reset_emergency_stop)')
        self._control_gate.refused['unsigned'] += 1
        state, message = self._last_status
        self.publish_status(state, message)
        return response

    def _on_reset_service(self, request: Trigger.Request, response: Trigger.Response
                          ) -> Trigger.Response:
        if self.key is not None:
            return self._unauthenticated_reset(response)
        response.success, response.message = self.reset(by='the bridge/reset service')
        return response

    def _on_reset_emergency(self, request: Trigger.Request, response: Trigger.Response
                            ) -> Trigger.Response:
        if self.key is not None:
            return self._unauthenticated_reset(response)
        response.success, response.message = self.reset(
            clear_emergency=True, by='the bridge/reset_emergency_stop service')
        return response

    def _on_control(self, message: Any) -> None:
        signed = self._well_formed(signed_from_message(control_from_message, message),
                                   'bridge/control')
        if signed is None:
            return
        control, signature = signed
        reason = self._control_gate.admit(control, signature, self._test_id)
        if reason is not None:
            self._refused(reason, signature, 'bridge/control')
            return
        request = control.command.strip().lower()
        sender = clip_reason(control.sender or 'an unnamed sender', 120)
        outcome = self._obey(request, sender, clip_reason(control.reason))
        self._acknowledged.add(signature, request, outcome)
        # The audit trail, and the replay memory a restarted bridge starts from.
        self.record.append({'what': 'control', 'command': clip_reason(request, 40),
                            'sender': sender, 'reason': clip_reason(control.reason),
                            'session': signature.session, 'sequence': signature.sequence,
                            'outcome': outcome})
        if outcome != 'ok':
            self.get_logger().warning(f'bridge/control {request} from {sender}: {outcome}')
        state, text = self._last_status
        self.publish_status(state, text)

    def _obey(self, request: str, sender: str, reason: str) -> str:
        """Carry out an admitted control; ``'ok'`` or ``'refused: why'``."""
        why = f' ({reason})' if reason else ''
        if request == 'reset':
            ok, text = self.reset(by=sender)
        elif request == 'reset_emergency_stop':
            ok, text = self.reset(clear_emergency=True, by=sender)
        elif request == 'hold':
            held = f'held by {sender}{why}'
            self.record.append(self.holds.operator_hold(held))
            self._on_driver_fault(held)  # (a hold the supervisor held is a person's now)
            self.publish_status(TestStatus.STATE_HOLDING, held)
            return 'ok'
        elif request == 'auto_hold':  # the supervisor: a process of the test died or hung
            holding = self.bridge is not None and self.bridge.state == 'holding'
            held = f'held by {sender}{why}'
            if self.bridge is not None and not self._latched():
                reply = self.bridge.hold_for_supervisor(held)
                if reply is not None:
                    self.get_logger().error(f'holding: {held}')
                    self._publish_reply(reply)
            else:  # (an e-stop or a person's hold: theirs, whatever the supervisor says)
                self._on_driver_fault(held)
            if not holding:
                self.publish_status(TestStatus.STATE_HOLDING, held)
            return 'ok'
        elif request == 'auto_reset':  # the supervisor, after the restart it held for
            blocked = self.holds.blocks_automatic
            if blocked is not None:
                return f'refused: {blocked}; a person resets it'
            if (self.bridge is not None and self.bridge.state == 'holding'
                    and not self.bridge.held_by_supervisor):
                return (f'refused: the bridge holds for another reason '
                        f'({self.bridge.hold_reason}); a person resets it')
            ok, text = self.reset(by=sender)
        elif request in LIFECYCLE_CONTROLS:
            if not self.trigger(request):
                return (f'refused: the {request} transition failed (state '
                        f'{self._state_machine.current_state[1]})')
            return 'ok'
        else:
            return (f'refused: unknown request {request!r} (reset, reset_emergency_stop, hold, '
                    f'{", ".join(LIFECYCLE_CONTROLS)})')
        return 'ok' if ok else text if text.startswith('refused') else f'refused: {text}'


def _limits_in_force(limits: SafetyLimits) -> dict[str, float]:
    """The limits as a mapping of the ones set (for the record and the offer)."""
    return {name: value for name, value in dataclasses.asdict(limits).items()
            if value is not None}


def _positions(values: Any) -> str:
    return ', '.join(f'{float(x):.6g}' for x in values)


def _autostart(node: ActuatorBridgeNode, executor: Executor) -> None:
    """Configure, wait for the driver, activate (simulated set-ups)."""
    if not node.trigger('configure'):
        return
    driver = node.driver
    while rclpy.ok() and driver is not None and not driver.ready():
        executor.spin_once(timeout_sec=0.05)
    node.trigger('activate')



def main(args: list[str] | None = None) -> int:
    """Entry point of ``ros2 run pd_actuator_bridge main``."""
    use_discovery_profile()
    rclpy.init(args=args)

    def body(node: ActuatorBridgeNode, executor: Executor) -> None:
        if node.get_parameter('autostart').value:
            _autostart(node, executor)
        spin_until_shutdown(executor, 0.05, node.check_driver, every=CHECK_INTERVAL_S)

    def cleanup(node: ActuatorBridgeNode) -> None:
        node._hold_driver()
        node._release()
        node.record.close()

    return run_node('pd_actuator_bridge', ActuatorBridgeNode, (AuthError, BridgeError), body,
                    cleanup=cleanup, teardown_timeout=TEARDOWN_TIMEOUT)


if __name__ == '__main__':
    sys.exit(main())

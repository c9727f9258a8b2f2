"""The integrator node (``ros2 run pd_integrator main``): a thin shell around ``TestSession``.

Topics (relative to the node namespace, ``/pd`` by default; a substructured test has one set
of ``step_command``/``step_feedback``/``bridge/...`` topics per site, under ``<site>/``):

* publishes ``step_command`` (``pd_msgs/StepCommand``, reliable), ``test_status``
  (``pd_msgs/TestStatus``, reliable, transient local = latched) and ``test_definition``
  (``std_msgs/String``, latched: the resolved test as JSON);
* subscribes ``/pd/emergency_stop`` (``std_msgs/String``: hold at once, as every bridge does),
  ``step_feedback`` (``pd_msgs/StepFeedback``, reliable), ``bridge/status`` (the
  actuator bridge's latched status) and ``bridge/trajectory`` (its sub-step trajectories),
  both recorded in the bag, and ``test_control``
  (``std_msgs/String``: ``pause``, ``resume``, ``abort``).

Parameters: ``test_file`` (YAML test file), ``output_dir`` (run folder; default
``runs/<test_id>-<UTC time>``), ``figures``, ``progress_interval``, and overrides of the test
file (``mass``, ``damping_ratio``, ``damping_coefficient``, ``initial_stiffness`` (a value or
``'probe'``), ``ground_motion_file``, ``scale_factor``, ``direction``, ``dt``, ``scheme``, ...;
see ``pd_core.run.definition.PARAMETER_PATHS``).

Exit codes: 0 finished, 1 aborted or held when stopped, 2 invalid test (nothing was moved).
"""

from __future__ import annotations

import dataclasses
import json
import shutil
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any, NoReturn, TypeVar

import numpy as np
from rcl_interfaces.msg import ParameterDescriptor
from rclpy.executors import Executor
from rclpy.node import Node
from rclpy.publisher import Publisher
from rclpy.subscription import Subscription
from std_msgs.msg import String

from pd_common.auth import (
    DEFAULT_CONTROL_WINDOW,
    AuthError,
    ControlGate,
    Refusal,
    Signer,
    StatusGate,
    describe_refusals,
    merge_refusals,
)
from pd_common.errors import RthsError
from pd_common.protocol import (
    GLOBAL_EMERGENCY_STOP,
    Acknowledgements,
    Command,
    Signature,
    StateOrigin,
    Status,
    TestState,
    clip_reason,
    control_from_message,
    decode_feedback,
    definition_digest,
    signature_from_message,
    signed_from_bytes,
    signed_from_message,
    site_topic,
    site_topic_name,
)
from pd_common.ros import (
    CONTROL_DEPTH,
    HEARTBEAT_S,
    LATCHED_QOS,
    STEP_QOS,
    TEARDOWN_TIMEOUT,
    TRAJECTORY_TOPIC,
    Announcer,
    RefusalLog,
    SessionSender,
    admit_trajectory,
    declare_key,
    exit_process,
    init_with_stop_flag,
    now_stamp,
    read_status,
    remember_trajectory,
    run_node,
    seal_parameters,
    settle_collector,
)
from pd_common.rths import CpuLatencyRequest, wall_clock_cpu_latency
from pd_common.signals import StopFlag
from pd_core.errors import BagError, IntegratorError, PdIntegratorError
from pd_core.run.loop.dispatch import Sent, StepDispatcher
from pd_core.run.loop.progress import ProgressMeter
from pd_core.run.loop.session import PROBE_SUFFIX, TestSession
from pd_core.run.loop.steering import Steering
from pd_core.run.record.bag import RecordedRun, read_trajectory, typestore
from pd_core.run.record.continuations import count_continuations
from pd_core.run.record.figure_worker import FigureWorker
from pd_core.run.record.journal import (
    JOURNAL_FILE,
    Journal,
    RecordWriteError,
    journal_to_bag,
)
from pd_core.run.resume import (
    ResumeAction,
    SiteState,
    check_sites,
    decide_resume,
    last_measured,
    load_resumable,
)
from pd_core.run.runner import (
    BAG_DIRECTORY,
    DEFINITION_JSON,
    default_run_directory,
    finish_outputs,
    prepare_run_directory,
    restore_dispatcher,
)
from pd_core.run.test_file import PARAMETER_PATHS, load_test_file, run_parameter
from pd_msgs.msg import ActuatorTrajectory, StepCommand, StepFeedback, TestStatus
from pd_msgs.msg import Control as ControlMessage

Signed = TypeVar('Signed')  # a message read with its signature

#: Seconds between two checks of the feedback timeout and of the sites' sessions in the run
#: loop (a few steps' time; the timeouts themselves are seconds).
CHECK_INTERVAL_S = 0.01
#: Seconds between two log lines about emergency stops received while one is latched.
ESTOP_LOG_INTERVAL_S = 10.0

_OVERRIDE_DESCRIPTIONS = {
    'test_id': 'identifier of the test (letters, digits, _ - .)',
    'scheme': 'integration scheme, e.g. newmark_explicit',
    'dt': 'integration time step [s]',
    'duration': 'test duration [s] (longer than the record adds free vibration)',
    'mass': 'mass [kg]: scalar, diagonal list, or flattened matrix',
    'damping_ratio': 'viscous damping ratio of the initial-stiffness frequency',
    'damping_coefficient': 'viscous damping coefficient [N s/m] (instead of a ratio)',
    'initial_stiffness': "initial stiffness [N/m], or 'probe' to measure it through the loop",
    'ground_motion_file': 'ground motion record (csv/txt two-column, single, multi, .AT2)',
    'ground_motion_format': 'auto, two_column, single_column, multi_column or at2',
    'ground_motion_units': "g or m/s2",
    'ground_motion_dt': 'record time step [s] for single/multi-column files',
    'scale_factor': 'scale factor applied to the record',
    'direction': '+1 or -1: sign of the excitation',
    'feedback_timeout': 'seconds without feedback before the command is re-sent',
    'max_retries': 're-sends before the integrator holds',
}


class RoundTrips:
    """The command → feedback round trips of a test [s], in an array allocated at the start.

    Sized for one round trip a step (and written at once, so no page is first touched during
    the test); iterations beyond that double it. A list of floats grew by 32 bytes a step.
    """

    def __init__(self, capacity: int) -> None:
        self._values = np.full(max(int(capacity), 16), 0.0)
        self.count = 0

    def add(self, seconds: float) -> None:
        """Record one round trip."""
        if self.count == self._values.size:
            self._values = np.concatenate([self._values, np.full(self._values.size, 0.0)])
        self._values[self.count] = seconds
        self.count += 1

    def statistics(self) -> dict[str, float]:
        """Median, p99 and max of the round trips [ms] (re-sends included)."""
        if not self.count:
            return {'count': 0}
        values = self._values[:self.count] * 1e3
        return {'count': int(values.size), 'median_ms': float(np.median(values)),
                'p99_ms': float(np.percentile(values, 99)), 'max_ms': float(values.max())}


class IntegratorNode(Node):
    """Runs one pseudo-dynamic test through the ROS graph.

    Raises:
        PdIntegratorError: the test definition is invalid or unstable (raised before anything
            is published).
    """

    def __init__(self, **kwargs: Any) -> None:
        super().__init__('pd_integrator', namespace='pd', **kwargs)
        self.declare_parameter('test_file', '', ParameterDescriptor(
            description='YAML test file (see config/default_test.yaml)'))
        self.declare_parameter('output_dir', '', ParameterDescriptor(
            description='run folder (default: runs/<test_id>-<UTC time>)'))
        self.declare_parameter('figures', True, ParameterDescriptor(
            description='write PNG figures at the end of the test'))
        self.declare_parameter('progress_interval', 2.0, ParameterDescriptor(
            description='seconds between progress lines on the console',
            dynamic_typing=True))  # (-p progress_interval:=1 is an integer)
        self.declare_parameter('resume_from', '', ParameterDescriptor(
            description='run folder of a stopped run to continue from its last committed step '
                        '(its test, its record; test_file and output_dir are not used)'))
        self.declare_parameter('sync_interval', 1.0, ParameterDescriptor(
            description='most seconds between two fsync of the journal (0: every step)',
            dynamic_typing=True))
        self.declare_parameter('confirm_resume', False, ParameterDescriptor(
            description='resume_from with a physical site: move without waiting for the '
                        "operator's signed resume (the gap and positions are still reported)"))
        self.declare_parameter('resume_note', '', ParameterDescriptor(
            description='why the run is resumed (recorded; run_test notes its restarts)'))
        self.declare_parameter('hold_on_resume', False, ParameterDescriptor(
            description="resume_from: restore the run and hold until a person's signed resume "
                        '(run_test restarts a dead integrator so under --on-child-exit hold)'))
        # (checked before anything is made: a bad one leaves no run folder)
        progress_interval = run_parameter(
            'progress_interval', self.get_parameter('progress_interval').value)
        sync_interval = run_parameter('sync_interval', self.get_parameter('sync_interval').value)
        overrides: dict[str, Any] = {}
        for name in PARAMETER_PATHS:
            self.declare_parameter(name, None, ParameterDescriptor(
                description=_OVERRIDE_DESCRIPTIONS.get(name, ''), dynamic_typing=True))
            value = self.get_parameter(name).value
            if value is not None:
                overrides[name] = list(value) if isinstance(value, (list, tuple)) else value
        resume_from = str(self.get_parameter('resume_from').value)
        # (the resume policy as given at start: read here, not when the sites answer)
        self._resume_note = str(self.get_parameter('resume_note').value)
        self._hold_on_resume = bool(self.get_parameter('hold_on_resume').value)
        self._confirm_resume = bool(self.get_parameter('confirm_resume').value)
        self.record: RecordedRun | None = None
        if resume_from:
            try:
                self.directory, definition, self.record = load_resumable(resume_from)
            except PdIntegratorError as err:
                msg = f'parameter resume_from: {err}'
                raise PdIntegratorError(msg) from None
        else:
            test_file = self.get_parameter('test_file').value
            if not test_file:
                msg = 'parameter test_file: a YAML test file is required'
                raise PdIntegratorError(msg)
            definition = load_test_file(test_file, overrides)
        self.session = TestSession(definition)  # refuses an unstable test before any motion
        try:  # (the test file's schema checked the latencies: this names one it did not see)
            latency = wall_clock_cpu_latency(definition.sites)
        except RthsError as err:
            raise PdIntegratorError(str(err)) from None
        #: A wall-clock test keeps this host's idle CPUs awake while the integrator runs (the
        #: bridge's request covers its own machine only): held from here to :meth:`finish`.
        self.cpu_latency = CpuLatencyRequest(latency) if latency is not None else None
        if self.cpu_latency is not None and not self.cpu_latency.acquire():
            self.get_logger().warning(f'idle CPUs not kept awake: {self.cpu_latency.reason}')
        self.key = declare_key(self)  # refuses a missing or readable key before any output
        if not resume_from:
            output = self.get_parameter('output_dir').value
            self.directory = prepare_run_directory(
                Path(output) if output else default_run_directory('runs', definition.test_id))
        self.figures = bool(self.get_parameter('figures').value)
        self.meter = ProgressMeter(definition.n_steps, progress_interval)

        #: The run's record could not be written (a full disk): the test ends with one line.
        self.record_error: RecordWriteError | None = None
        self.announcer = Announcer(self, self.key)
        self._control_gate = ControlGate(self.key, self.announcer.identity,
                                         self.announcer.session)
        self._status_gate = StatusGate(self.key)  # the bridges' statuses
        self._trajectory_gate = StatusGate(self.key)  # the bridges' actuator trajectories
        # (stamped before this start less the clocks' 30 s: a recording, not this run's)
        self._trajectories_since_ns = time.time_ns() - int(DEFAULT_CONTROL_WINDOW * 1e9)
        for _, trajectory in self.record.trajectories if self.record is not None else ():
            remember_trajectory(self._trajectory_gate, trajectory)  # (never taken again)
        self._bridge_statuses: dict[str, Status] = {}  # the last one recorded, per topic
        self._malformed = 0
        self._acknowledged = Acknowledgements()
        self._estop_logged = (0.0, 0)  # (when, repeats) of the last line about repeats
        self._last_status_message: Any = None
        self._status_at = 0.0
        self._configurations: dict[str, str] = {}  # site -> its offer's configuration
        self._refusal_log = RefusalLog(self.get_logger().warning, self.key, 'message')
        self._resume_requested = False
        self._offers_refused: set[str] = set()
        self._session_lost: set[str] = set()
        self.owed: list[tuple[str, Command]] = []
        self._gap = 0.0

        # The interval's fsync in a thread of its own: a slow disk holds up no step.
        self.bag = Journal(self.directory / JOURNAL_FILE, append=bool(resume_from),
                           sync_interval=sync_interval,
                           sync_in_background=True).open()
        self.dispatcher = StepDispatcher(self.session, self._seal_command, self.bag,
                                         deliver=self._publish_command)
        self.steering = Steering(self.session, self._record_event)
        if self.record is not None:  # what a person held before the restart still holds
            self.steering.restore(self.record.run_events)
            for event in self.record.run_events:
                if event.get('what') == 'control' and event.get('session'):
                    self._control_gate.remember(str(event['session']), int(event['sequence']))
        # One signer, so one session and one sequence, per site: a command or a reply signed for
        # one site is of a foreign session at another (a copy between sites is refused).
        self.senders = {site: SessionSender(
            self, f'{site}/' if site else '', Signer(self.key) if self.key is not None else None,
            self.key, on_refused=self._on_refused_offer) for site in self.dispatcher.sites}
        # pd_msgs has no type information: the message type parameter is Any.
        self._command_pubs: dict[str, Publisher[Any]] = {}
        self._feedback_subs: dict[str, Subscription[Any]] = {}
        typestore()  # (the bridges' trajectories' decoder, made now: not in the first step, 80 ms)
        for site in self.dispatcher.sites:
            self._command_pubs[site] = self.create_publisher(
                StepCommand, site_topic(site, 'step_command'), STEP_QOS)
            # The hot topics travel as CDR bytes (pd_common.protocol.cdr): no message objects.
            self._feedback_subs[site] = self.create_subscription(
                StepFeedback, site_topic(site, 'step_feedback'),
                self._guard(lambda data, site=site: self._on_feedback(site, data)),
                STEP_QOS, raw=True)
            status_topic = site_topic_name(site, 'bridge/status')  # (as recorded)
            # (as resolved here: where the bridge's node must publish a status it signed)
            status_source = self.resolve_topic_name(site_topic(site, 'bridge/status'))
            trajectory_topic = site_topic_name(site, TRAJECTORY_TOPIC)  # (as recorded)
            trajectory_source = self.resolve_topic_name(site_topic(site, TRAJECTORY_TOPIC))
            self.create_subscription(
                TestStatus, site_topic(site, 'bridge/status'),
                self._guard(lambda message, topic=status_topic, source=status_source:
                            self._on_bridge_status(message, topic, source)), LATCHED_QOS)
            self.create_subscription(
                ActuatorTrajectory, site_topic(site, TRAJECTORY_TOPIC),
                self._guard(lambda data, topic=trajectory_topic, source=trajectory_source:
                            self._on_trajectory(data, topic, source)), STEP_QOS, raw=True)
        self._status_pub = self.create_publisher(TestStatus, 'test_status', LATCHED_QOS)
        self._definition_pub = self.create_publisher(String, 'test_definition', LATCHED_QOS)
        self.create_subscription(ControlMessage, 'test_control', self._guard(self._on_control),
                                 CONTROL_DEPTH)
        # The lab-wide emergency stop (every bridge holds on it too): hold at once.
        self.create_subscription(String, GLOBAL_EMERGENCY_STOP,
                                 self._guard(self._on_emergency_stop), CONTROL_DEPTH)

        text = definition.to_json()
        #: What every status names: a reader believes the definition published with this digest.
        self._definition_digest = definition_digest(text)
        if self.record is None:
            (self.directory / DEFINITION_JSON).write_text(text, encoding='utf-8')
            self.bag.write_definition(text, time.time_ns())
        else:  # the step loop as it was when the run stopped (nothing is sent)
            self.owed = self._restore(self.record)
            last_t = max((t for _, t, _, _ in self.record.ordered), default=time.time_ns())
            self._gap = max(0.0, (time.time_ns() - last_t) / 1e9)
            for note in self.record.notes:  # (what reading the record left out)
                self.get_logger().warning(f'resuming {self.directory}: {note}')
            self.get_logger().warning(
                f'resuming {self.directory}: restored up to step {self.session.committed_step} '
                f'({self.session.state.name.lower()}: {self.session.message}); '
                f'{self._gap:.1f} s since the last record')
        self.bag.flush()
        self._definition_pub.publish(String(data=text))
        self._sent_at = 0.0
        # s, step sent -> its (assembled) feedback accepted
        self._round_trips = RoundTrips(len(self.session.history.ground_acceleration))
        self._last_state: TestState | None = None
        self._started = 0.0
        self._figure_worker: FigureWorker | None = None
        heartbeat = self._guard(self._heartbeat)
        # (a timer's callback takes no argument: rclpy would hand ``*args`` a TimerInfo)
        self.create_timer(HEARTBEAT_S, lambda: heartbeat())
        element = self.session.served_element
        if element is not None:  # waiting for OpenSees blocks the executor: beat meanwhile
            element.idle = heartbeat
        if self.key is not None:  # (a rogue's hold_on_resume:=false would move a held rig)
            seal_parameters(self, 'the integrator', 'restart it (./pd run --resume)',
                            self._control_gate.refused)
        self.publish_status()

    # -- helpers ------------------------------------------------------------------------------
    def _restore(self, record: RecordedRun) -> list[tuple[str, Command]]:
        """The step loop as the record leaves it (nothing is sent); what it still owes.

        A served run's OpenSees model is re-run from its beginning: it connects again and its
        trials are checked against the record and answered from it.
        """
        element = self.session.served_element
        if element is None:
            return restore_dispatcher(record, self.dispatcher, str(self.directory))
        port = element.open().port
        self.get_logger().warning(
            f'resuming a served run: start the OpenSees model again, from its beginning '
            f'(port {port}): the steps on record are answered from the journal and '
            'nothing moves before the first step past it')
        try:
            element.connect()
            return restore_dispatcher(record, self.dispatcher, str(self.directory))
        except IntegratorError as err:
            msg = f'parameter resume_from: {err}'
            raise PdIntegratorError(msg) from None
        except BagError as err:
            element.close()
            msg = (f'parameter resume_from: the OpenSees model that connected is not this '
                   f'run\'s: {err}')
            raise PdIntegratorError(msg) from None

    def refusals(self) -> dict[str, dict[str, int]]:
        """Messages refused by authentication, by source and reason (for the summary)."""
        counts = {f'feedback[{site or "default"}]': dict(sender.reply_gate.refused)
                  for site, sender in self.senders.items()}
        counts.update({f'session_offer[{site or "default"}]': dict(sender.offer_gate.refused)
                       for site, sender in self.senders.items()})
        counts['bridge_status'] = dict(self._status_gate.refused)
        counts['bridge_trajectory'] = dict(self._trajectory_gate.refused)
        counts['test_control'] = dict(self._control_gate.refused)
        if self._malformed:
            counts['malformed'] = {Refusal.MALFORMED.value: self._malformed}
        return {source: count for source, count in counts.items() if count}

    def status(self) -> Status:
        """The dispatcher's status with refused messages and a person's holds.

        The dispatcher's status with the refused messages counted and the holds a person
        made.
        """
        status = self.dispatcher.status()
        refused = merge_refusals(self.refusals().values())
        holds = self.steering.holds
        return dataclasses.replace(status, refused_messages=sum(refused.values()),
                                   refused_by_reason=describe_refusals(refused),
                                   emergency_stop=holds.emergency is not None,
                                   operator_hold=holds.operator is not None,
                                   acknowledged=self._acknowledged.text,
                                   definition_digest=self._definition_digest)

    def publish_status(self) -> None:
        """Publish (signed) and record the session's status."""
        status = self.status()
        self._last_status_message = self.announcer.status(status, now_stamp())
        self._status_pub.publish(self._last_status_message)
        self._status_at = time.monotonic()
        self.bag.write_status(status, time.time_ns())
        if status.state is not self._last_state:
            self._last_state = status.state
            line = f'{status.state.name.lower()}: {status.message}'
            if status.state in (TestState.HOLDING, TestState.ABORTED):
                self.get_logger().warning(line)
            else:
                self.get_logger().info(line)

    def _guard(self, callback: Callable[..., None]) -> Callable[..., None]:
        """``callback`` for the executor.

        A record it cannot write (a full disk) is kept in :attr:`record_error` for the run loop
        (one line and the end of the test) instead of escaping into the executor (a FATAL log and a
        traceback); nothing more is done.
        """
        def guarded(*args: Any) -> None:
            if self.record_error is not None:
                return
            try:
                callback(*args)
            except RecordWriteError as err:
                self.record_error = err

        return guarded

    def _heartbeat(self) -> None:
        """The status again (signed anew, not recorded again) if none went out for a second.

        The supervisor hears a live integrator.
        """
        if time.monotonic() - self._status_at < HEARTBEAT_S * 0.9:
            return
        self._last_status_message = self.announcer.status(self.status(), now_stamp())
        self._status_pub.publish(self._last_status_message)
        self._status_at = time.monotonic()

    def _record_event(self, event: dict[str, Any]) -> None:
        """One event of the steering (a hold, a control) in the journal, on disk now."""
        info = {key: value for key, value in event.items() if key != 'what'}
        self.bag.write_event(str(event['what']), time.time_ns(), **info)
        self.bag.persist()

    def _well_formed(self, signed: Signed | None, topic: str) -> Signed | None:
        """A message's item and signature, read; ``None`` is counted and reported (malformed)."""
        if signed is None:
            self._malformed += 1
            self._refusal_log(Refusal.MALFORMED, Signature(), self.resolve_topic_name(topic))
            self.publish_status()
        return signed

    def _on_refused_offer(self, reason: Refusal, signature: Signature, topic: str) -> None:
        self._refusal_log(reason, signature, topic)

    def _seal_command(self, site: str, command: Command) -> Sent:
        """One site command signed: the bytes the journal records, then publishes."""
        # (stamped as the dispatcher records it: the record holds the bytes that go out)
        data, signature = self.senders[site].encode(command, self.dispatcher.send_stamp_ns)
        return Sent(signature, data)

    def _publish_command(self, site: str, sent: Sent) -> None:
        """Publish a sealed site command (its record written); restart the feedback timer."""
        self._command_pubs[site].publish(sent.data)
        self._sent_at = time.monotonic()

    def _site_ready(self, site: str) -> bool:
        """Whether ``site`` listens, talks back and obeys this test's signed session."""
        return (self._command_pubs[site].get_subscription_count() > 0
                and self._feedback_subs[site].get_publisher_count() > 0
                and self.senders[site].opened)

    def peers_ready(self) -> bool:
        """Whether every site is ready; opens the signed sessions not opened yet."""
        for sender in self.senders.values():
            sender.open(self.session.definition.test_id)
        return all(self._site_ready(site) for site in self.dispatcher.sites)

    def missing_sites(self) -> list[str]:
        """The sites not ready, and why (for the start-up error)."""
        missing = []
        for site in self.dispatcher.sites:
            if self._site_ready(site):
                continue
            topic = self.resolve_topic_name(site_topic(site, 'step_command'))
            sender = self.senders[site]
            refused = describe_refusals(sender.offer_gate.refused)
            why = sender.mismatch or ('no session opened' if sender.receiver_ready()
                                      else f'its session offers are refused: {refused}'
                                      if refused else 'no session offer')
            missing.append(f'{topic} ({why})')
        return missing

    def check_sessions(self) -> None:
        """Hold when a site no longer obeys this test's session; re-open it on resume."""
        lost = {site for site, sender in self.senders.items() if not sender.opened}
        if lost - self._session_lost and self.session.state is TestState.RUNNING:
            names = ', '.join(site or 'default' for site in sorted(lost))
            self.session.hold(f'site {names}: the signed session was lost (the receiver '
                              'restarted or was re-activated); a signed resume re-opens it')
            self.publish_status()
        self._session_lost = lost
        refused = self._check_offers()
        if not self._resume_requested:
            return
        if refused:
            self._resume_requested = False
            self.get_logger().warning('resume refused: ' + '; '.join(refused))
            self.publish_status()
            return
        for site in lost:
            self.senders[site].open(self.session.definition.test_id)
        if not lost:
            self._resume_requested = False
            self.dispatcher.resume()
            self.publish_status()

    def _check_offers(self) -> list[str]:
        """Why the sites' announced states may not be driven, once the test has started.

        Why the sites' announced states may not be driven (a fresh specimen state in the
        middle of the test), once the test has started.
        """
        if not self._started:
            return []
        refused = []
        for site, sender in self.senders.items():
            offer = sender.offer
            if offer is not None and offer.configuration and (
                    self._configurations.get(site) != offer.configuration):
                self._configurations[site] = offer.configuration
                self._record_event({'what': 'specimen_side', 'site': site, 'node': offer.node,
                                    'configuration': offer.configuration})
            if offer is None or not (offer.challenge or offer.active_session):
                # It offers no session (a bridge not active yet): it announces no state that
                # could be driven (a restarted bridge knows its specimen's once it is ready).
                continue
            was = self.session.state
            reason = self.dispatcher.on_offer(site, str(offer.epoch),
                                              StateOrigin.of(offer.state_origin))
            if reason is not None:
                refused.append(reason)
                if reason not in self._offers_refused:
                    self._offers_refused.add(reason)
                    if self.session.state is was:  # else publish_status logs the new state
                        self.get_logger().error(f'{was.name.lower()}: {reason}')
                    self.publish_status()
        return refused

    def start(self) -> None:
        """Send the first command (a resumed run: check the sites, then what it owes)."""
        settle_collector()  # what the set-up made is not walked again while the test steps
        self._started = time.perf_counter()
        if self.figures and self._figure_worker is None:
            # Prepares (imports matplotlib) at a low priority while the test runs, and draws
            # the figures while the bag and the CSV files are written (core.run.figure_worker).
            self._figure_worker = FigureWorker.start()
        self.meter = ProgressMeter(self.session.total_steps, self.meter.interval,
                                   first_step=max(self.session.committed_step, 0))
        if self.record is None:
            self.dispatcher.start()
        else:
            self._start_resumed()
        self.publish_status()

    def _start_resumed(self) -> None:
        """Compare every site with the record; go on, or hold for the operator, or refuse."""
        session = self.session
        structured = not self.dispatcher.coordinator.passthrough
        sites = {site: SiteState(epoch=str(sender.offer.epoch),
                                 origin=StateOrigin.of(sender.offer.state_origin),
                                 position=tuple(float(x) for x in sender.offer.position))
                 for site, sender in self.senders.items() if sender.offer is not None}
        check = check_sites(sites, self.dispatcher.epochs,
                            last_measured(self.record, structured) if self.record else {},
                            self.owed, session.definition.protocol.tracking_tolerance)
        note = self._resume_note
        self.bag.write_event('resumed', time.time_ns(), committed_step=session.committed_step,
                             recorded_state=session.state.name.lower(), gap_s=self._gap,
                             sites=check.report, refused=check.refused, confirm=check.confirm,
                             note=note)
        for line in check.report:
            self.get_logger().info(f'resume: {line}')
        decision = decide_resume(session.state, check,
                                 person_hold=self.steering.holds.blocks_automatic,
                                 hold_on_resume=self._hold_on_resume,
                                 confirm_resume=self._confirm_resume,
                                 note=note, gap_s=self._gap)
        session.state = decision.state
        if decision.action is ResumeAction.REFUSE:
            session.hold(decision.message or '')
        if decision.message is not None:
            session.message = decision.message
        if decision.action is ResumeAction.GO_ON:
            self.dispatcher.resume()

    # -- callbacks ----------------------------------------------------------------------------
    def _on_feedback(self, site: str, data: bytes) -> None:
        received = time.monotonic()
        sent_at = self._sent_at
        committed = self.session.history.n_committed
        pending = self.session.protocol.pending
        decoded = self._well_formed(signed_from_bytes(decode_feedback, data),
                                    site_topic(site, 'step_feedback'))
        if decoded is None:
            return
        feedback, signature = decoded.record, decoded.signature
        reason = self.senders[site].admit(decoded)
        if reason is not None:  # unsigned, forged, replayed or of another session: not taken
            self._refusal_log(reason, signature, self.resolve_topic_name(
                site_topic(site, 'step_feedback')))
            self.publish_status()
            return
        was = self.session.state
        self.dispatcher.on_feedback(site, feedback, signature, decoded.stamp_ns, data)
        self.steering.after_feedback(feedback, was)
        if (self.session.history.n_committed != committed
                or (pending is not None and self.session.protocol.pending is not pending)):
            self._round_trips.add(received - sent_at)
        if self.session.state is not TestState.RUNNING:
            self.publish_status()
        elif (line := self.meter.update(max(self.session.committed_step, 0))) is not None:
            self.get_logger().info(line)
            self.publish_status()

    def _on_bridge_status(self, message: TestStatus, topic: str, source: str) -> None:
        """A bridge's status on ``source`` (as resolved: where its node must publish it).

        Recorded under ``topic``.
        """
        status, reason = read_status(self._status_gate, source, message)
        if status is None:  # not the bridge's word: never recorded as its own
            if reason is not None:
                self._refusal_log(reason, signature_from_message(message.signature)
                                  if reason is not Refusal.MALFORMED else Signature(), topic)
            return
        last = self._bridge_statuses.get(topic)
        if last == status:
            return  # a heartbeat: the same status again (recorded once)
        self._bridge_statuses[topic] = status
        self.bag.write_status(status, time.time_ns(), topic=topic)

    def _on_trajectory(self, data: bytes, topic: str, source: str) -> None:
        """A bridge's actuator trajectory on ``source`` (as resolved), recorded under ``topic``.

        What the run's reader could not read back is not recorded (one message would make the
        run unreadable: counted as malformed); with a key, nor is one its topic's bridge did
        not sign (forged, replayed, or another bridge's copied here).
        """
        try:
            trajectory = read_trajectory(data, typestore())
        except ValueError:
            self._malformed += 1
            self._refusal_log(Refusal.MALFORMED, Signature(), topic)
            return
        test_id = self.session.definition.test_id  # (and its probe's moves: the same test)
        reason = admit_trajectory(self._trajectory_gate, source, trajectory,
                                  (test_id, test_id + PROBE_SUFFIX), self._trajectories_since_ns)
        if reason is not None:
            self._refusal_log(reason, signature_from_message(trajectory.signature)
                              if reason is not Refusal.MALFORMED else Signature(), topic)
            return
        self.bag.write_raw(topic, time.time_ns(), data)

    def _on_emergency_stop(self, message: String) -> None:
        if self.steering.emergency_stop(message.data[:1024]):
            self.get_logger().error(f'EMERGENCY STOP: {self.steering.holds.emergency}')
        else:
            when, logged = self._estop_logged
            now = time.monotonic()
            if now - when >= ESTOP_LOG_INTERVAL_S:
                repeats = self.steering.holds.repeats
                self._estop_logged = (now, repeats)
                self.get_logger().warning(f'{repeats - logged} more emergency stop(s) while '
                                          'one is latched (counted)')
                self.publish_status()
            return
        self.publish_status()

    def _on_control(self, message: Any) -> None:
        signed = self._well_formed(signed_from_message(control_from_message, message),
                                   'test_control')
        if signed is None:
            return
        control, signature = signed
        reason = self._control_gate.admit(control, signature, self.session.definition.test_id)
        if reason is not None:
            self._refusal_log(reason, signature, self.resolve_topic_name('test_control'))
            self.publish_status()
            return
        request = control.command.strip().lower()
        sender = clip_reason(control.sender or 'an unnamed sender', 120)
        decision = self.steering.control(request, sender, control.reason)
        if decision.restarted:  # run_test restarted a process of the test
            for sender_ in self.senders.values():
                sender_.reopen()  # no motion before every site offers itself anew
            self.bag.write_event('restart', time.time_ns(), process=clip_reason(control.reason),
                                 step=self.session.committed_step)
            self.get_logger().warning(f'restarted: {clip_reason(control.reason)}')
        self._acknowledged.add(signature, request, decision.outcome)
        # The audit trail (who did what), and the replay memory of a restarted integrator.
        self._record_event({'what': 'control', 'command': clip_reason(request, 40),
                            'sender': sender, 'reason': clip_reason(control.reason),
                            'session': signature.session, 'sequence': signature.sequence,
                            'outcome': decision.outcome})
        if decision.outcome != 'ok':
            self.get_logger().warning(f'test_control {request} from {sender}: '
                                      f'{decision.outcome}')
        if decision.resume:
            self._resume_requested = True
            self.check_sessions()
        self.publish_status()

    def check_timeout(self) -> None:
        """Re-send or hold when the pending command's feedback is late."""
        session = self.session
        if (session.state is not TestState.RUNNING or session.protocol.pending is None
                or time.monotonic() - self._sent_at
                < session.definition.protocol.feedback_timeout):
            return
        step = session.protocol.pending.step
        if self.dispatcher.on_timeout():
            self.get_logger().warning(f'no feedback for step {step}: re-sending '
                                      f'({session.protocol.attempts}/'
                                      f'{session.protocol.max_retries})')
        else:
            self._sent_at = time.monotonic()
        self.publish_status()

    def finish(self) -> dict[str, Any]:
        """Close the bag and write the run's outputs."""
        if self.session.state not in (TestState.FINISHED, TestState.ABORTED,
                                      TestState.INTERRUPTED):
            reason = f'stopped while {self.session.state.name.lower()}: {self.session.message}'
            self.session.abort(reason)
        self.publish_status()
        self.bag.close()
        cpu_latency: dict[str, Any] = {}
        if self.cpu_latency is not None:
            cpu_latency['integrator_cpu_latency'] = {'held': self.cpu_latency.held,
                                                     'note': self.cpu_latency.reason or ''}
            self.cpu_latency.release()
        wall_time = time.perf_counter() - self._started if self._started else 0.0
        events = [*(self.record.run_events if self.record is not None else []),
                  *self.bag.events]
        worker, self._figure_worker = self._figure_worker, None
        restarts, resumes = count_continuations(events)
        try:
            summary = finish_outputs(
                self.session, self.directory, wall_time=wall_time, figures=self.figures,
                mode='graph', figure_worker=worker, before_summary=self._journal_to_bag,
                run_events=events, restarts=restarts, resumes=resumes,
                step_round_trip=self._round_trips.statistics(),
                site_protocol=self.dispatcher.coordinator.summary(),
                authentication={'enabled': self.key is not None,
                                'key_id': self.key.key_id if self.key else None,
                                'refused_messages': self.refusals()},
                specimen_side=self.specimen_side(), **cpu_latency)
        finally:  # (also when the outputs fail: the worker does not wait for its parent's end)
            if worker is not None:
                worker.close()
        if worker is not None and worker.error is not None:
            self.get_logger().warning(f'{worker.error}; figures drawn by the integrator')
        self.get_logger().info(f'run folder: {self.directory}')
        return summary

    def specimen_side(self) -> dict[str, Any]:
        """Per site, the node that answered and what it had in force.

        A bridge: its driver and limits, from its signed session offers.
        """
        sides: dict[str, Any] = {}
        for site, sender in self.senders.items():
            offer = sender.offer
            if offer is None:
                continue
            origin = StateOrigin.of(offer.state_origin)
            side: dict[str, Any] = {'node': offer.node, 'state_origin': origin.name.lower()}
            configuration = self._configurations.get(site) or offer.configuration
            if configuration:
                try:
                    side.update(json.loads(configuration))
                except ValueError:
                    side['configuration'] = configuration
            sides[site or 'default'] = side
        return sides

    def _journal_to_bag(self) -> None:
        """The run's bag from its journal.

        A bag of an earlier recovery is replaced: the journal has all of it now.
        """
        bag = self.directory / BAG_DIRECTORY
        if bag.exists():
            shutil.rmtree(bag)
        journal_to_bag(self.directory / JOURNAL_FILE, bag)


def _describe(node: IntegratorNode) -> None:
    stability = node.session.stability
    logger = node.get_logger()
    definition = node.session.definition
    logger.info(f'test {definition.test_id}: {definition.n_steps} steps of {definition.dt} s, '
                f'scheme {definition.scheme}, {definition.n_dof} DOF')
    if definition.site_names:
        logger.info(f'sites: {", ".join(definition.site_names)} (namespaces '
                    f'{", ".join("/pd/" + site for site in definition.site_names)})')
    for warning in definition.warnings:
        logger.warning(warning)
    if report := definition.modal_report():
        logger.info('modal analysis (initial stiffness):\n' + report)
    if stability is not None:
        logger.info(stability.message)
    else:
        logger.info('initial stiffness: measured by a probe before the test')


def run(node: IntegratorNode, executor: Executor, stop: StopFlag) -> int:
    """Wait for the specimen side, run the test, write the outputs; returns the exit code.

    ``stop`` (set by SIGINT/SIGTERM) interrupts the test cleanly: the final status is
    published and the outputs so far are written while the node is still alive; the run can be
    resumed (``./pd run --resume``). A record that cannot be written (a full disk) ends the
    test with one line (the journal's, naming the file and ``./pd recover``), exit code 1.
    """
    try:
        return _run(node, executor, stop)
    except RecordWriteError as err:
        node.get_logger().error(str(err))
        return 1


def _spin(node: IntegratorNode, executor: Executor, timeout_sec: float) -> None:
    """One turn of the executor; a record a callback could not write ends the run."""
    executor.spin_once(timeout_sec=timeout_sec)
    if node.record_error is not None:
        raise node.record_error


def _run(node: IntegratorNode, executor: Executor, stop: StopFlag) -> int:
    _describe(node)
    deadline = time.monotonic() + node.session.definition.protocol.start_timeout
    # A resumed run is never aborted for want of its specimen side: it stays resumable.
    end = node.session.interrupt if node.record is not None else node.session.abort
    while not node.peers_ready():
        if stop.is_set():
            end('interrupted before the test started')
            node.finish()
            return 1
        _spin(node, executor, 0.05)
        if time.monotonic() > deadline:
            end('no specimen side (bridge or simulator) answered on '
                f'{", ".join(node.missing_sites())} within '
                f'{node.session.definition.protocol.start_timeout} s')
            node.finish()
            return 1
    node.start()
    probing = node.session.probing
    next_check = 0.0
    while node.session.state not in (TestState.FINISHED, TestState.ABORTED,
                                     TestState.INTERRUPTED):
        if stop.is_set():
            node.session.interrupt(f'interrupted (signal) while '
                                   f'{node.session.state.name.lower()}: {node.session.message}; '
                                   'resume with ./pd run --resume')
            break
        _spin(node, executor, 0.05)
        now = time.monotonic()
        if now >= next_check:  # not after every message: a step is a fraction of this
            next_check = now + CHECK_INTERVAL_S
            node.check_timeout()
            node.check_sessions()
        if probing and not node.session.probing:
            probing = False
            _describe(node)
    node.finish()
    return 0 if node.session.state is TestState.FINISHED else 1


def main(args: list[str] | None = None) -> int:
    """Entry point of ``ros2 run pd_integrator main``."""
    # SIGINT/SIGTERM only set a flag: the test is then aborted cleanly by the run loop (final
    # status published, bag closed, outputs written) instead of interrupting a bag write.
    stop = init_with_stop_flag(args)

    def interrupted(node: IntegratorNode | None) -> int:
        if node is not None:
            node.session.interrupt('interrupted (SIGINT); resume with ./pd run --resume')
            node.finish()
        return 1

    return run_node('pd_integrator', IntegratorNode, (PdIntegratorError, AuthError, OSError),
                    lambda node, executor: run(node, executor, stop), on_interrupt=interrupted,
                    teardown_timeout=TEARDOWN_TIMEOUT)


def process_main() -> NoReturn:
    """The console entry point (``ros2 run pd_integrator main``).

    :func:`main`, then the process ends at once (:func:`pd_common.ros.exit_process`).
    """
    exit_process(main)


if __name__ == '__main__':
    process_main()

"""Recording a test to a rosbag2 (MCAP) file and reading it back, with ``rosbags`` (no ROS).

Topics of a run's bag:

=========================  ==========================  ======================================
topic                      type                        content
=========================  ==========================  ======================================
``/pd/test_definition``    ``std_msgs/msg/String``     the resolved test definition (JSON)
``/pd/step_command``       ``pd_msgs/msg/StepCommand`` every command sent, re-sends included
``/pd/step_feedback``      ``pd_msgs/msg/StepFeedback`` every feedback received, ignored ones too
``/pd/test_status``        ``pd_msgs/msg/TestStatus``  every status published by the integrator
``/pd/bridge/status``      ``pd_msgs/msg/TestStatus``  the actuator bridge's status (if any)
``/pd/bridge/trajectory``  ``ActuatorTrajectory``      sub-step actuator trajectories (if any)
``/pd/run_events``         ``std_msgs/msg/String``     events of the run as JSON: resumed, a
                                                       process restarted, a state epoch changed
=========================  ==========================  ======================================

A substructured test (``structure.elements`` with experimental elements at named sites) has
instead, per site, ``/pd/<site>/step_command`` and ``/pd/<site>/step_feedback`` (what went to
and came from that site, in actuator DOFs) and ``/pd/<site>/bridge/status`` (and
``.../bridge/trajectory``) when a bridge serves it, plus the structure-level stream the
integrator's session saw, ``/pd/structure/step_command`` and ``/pd/structure/step_feedback``
(structure DOFs, total restoring force incl. the numerical elements).

Messages are written in the order the integrator saw them, so replaying the bag through the
same step protocol reproduces the run exactly (see :mod:`.replay`). The ``pd_msgs`` message
definitions are read from the installed ``pd_msgs`` package (or the source tree), so there is
one definition for ROS and for the bag.
"""

from __future__ import annotations

import functools
import json
import os
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol, cast

from rosbags.highlevel import AnyReader
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

from pd_common.protocol import (
    CdrEncodeError,
    Command,
    Feedback,
    Signature,
    Status,
    command_from_message,
    encode_command,
    encode_feedback,
    encode_status,
    feedback_from_message,
    signature_from_message,
    stamp_ns_of,
    status_from_message,
)

from ...errors import BagError
from .bag_writer import BagWriter, Topic

_UNSIGNED = Signature()

if TYPE_CHECKING:
    from rosbags.typesys.store import Typestore

TOPIC_DEFINITION = '/pd/test_definition'
TOPIC_COMMAND = '/pd/step_command'
TOPIC_FEEDBACK = '/pd/step_feedback'
TOPIC_STATUS = '/pd/test_status'
TOPIC_BRIDGE_STATUS = '/pd/bridge/status'
TOPIC_TRAJECTORY = '/pd/bridge/trajectory'
TOPIC_STRUCTURE_COMMAND = '/pd/structure/step_command'
TOPIC_STRUCTURE_FEEDBACK = '/pd/structure/step_feedback'
TOPIC_EVENTS = '/pd/run_events'

MSG_COMMAND = 'pd_msgs/msg/StepCommand'
MSG_FEEDBACK = 'pd_msgs/msg/StepFeedback'
MSG_STATUS = 'pd_msgs/msg/TestStatus'
MSG_TRAJECTORY = 'pd_msgs/msg/ActuatorTrajectory'
MSG_STRING = 'std_msgs/msg/String'
MSG_SIGNATURE = 'pd_msgs/msg/Signature'

#: The fixed topics, the step's first: the writer looks a message's connection up in a list.
_TOPICS = {
    TOPIC_COMMAND: MSG_COMMAND,
    TOPIC_FEEDBACK: MSG_FEEDBACK,
    TOPIC_STATUS: MSG_STATUS,
    TOPIC_DEFINITION: MSG_STRING,
    TOPIC_BRIDGE_STATUS: MSG_STATUS,
    TOPIC_TRAJECTORY: MSG_TRAJECTORY,
    TOPIC_EVENTS: MSG_STRING,
}


class _StringMessage(Protocol):
    """A deserialised ``std_msgs/msg/String``."""

    data: str


def _message_type(topic: str) -> str | None:
    """The message type of a bag topic (fixed ones, or per-site ones by their last part)."""
    if topic in _TOPICS:
        return _TOPICS[topic]
    for suffix, msgtype in (('/step_command', MSG_COMMAND), ('/step_feedback', MSG_FEEDBACK),
                            ('/bridge/status', MSG_STATUS),
                            ('/bridge/trajectory', MSG_TRAJECTORY)):
        if topic.startswith('/pd/') and topic.endswith(suffix):
            return msgtype
    return None


def is_trajectory_topic(topic: str) -> bool:
    """Whether ``topic`` is a run's actuator trajectory topic (the default site's or a site's)."""
    return _message_type(topic) == MSG_TRAJECTORY


def msg_directory() -> Path:
    """The directory holding the ``pd_msgs`` ``.msg`` files.

    Looks in the ament prefixes (``AMENT_PREFIX_PATH``), then in the source tree.

    Raises:
        BagError: no ``pd_msgs`` definitions were found.
    """
    candidates = [Path(prefix) / 'share' / 'pd_msgs' / 'msg'
                  for prefix in os.environ.get('AMENT_PREFIX_PATH', '').split(os.pathsep)
                  if prefix]
    candidates.append(Path(__file__).resolve().parents[4] / 'pd_msgs' / 'msg')
    for candidate in candidates:
        if (candidate / 'StepCommand.msg').is_file():
            return candidate
    msg = 'pd_msgs message definitions not found (build the workspace or set AMENT_PREFIX_PATH)'
    raise BagError(msg)


@functools.cache
def bag_topic(topic: str, msgtype: str) -> Topic:
    """A bag topic with its type's definition and hash (from :func:`typestore`)."""
    store = typestore()
    definition, _ = store.generate_msgdef(msgtype, ros_version=2)
    return Topic(topic, msgtype, definition, store.hash_rihs01(msgtype))


@functools.cache
def typestore() -> Typestore:
    """A ROS 2 Kilted typestore with the ``pd_msgs`` types registered."""
    store = get_typestore(Stores.ROS2_KILTED)
    directory = msg_directory()
    types: dict[str, Any] = {}
    for name in ('Signature', 'StepCommand', 'StepFeedback', 'TestStatus', 'ActuatorTrajectory'):
        text = (directory / f'{name}.msg').read_text(encoding='utf-8')
        types.update(get_types_from_msg(text, f'pd_msgs/msg/{name}'))
    store.register(types)
    return store


class BagRecorder:
    """Writes a run's messages to a rosbag2 MCAP bag (context manager).

    Args:
        path: the bag directory to create (must not exist).
    """

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)
        self._writer: BagWriter | None = None
        self._channels: dict[str, int] = {}
        self._store = typestore()

    def open(self) -> BagRecorder:
        """Create the bag.

        Raises:
            BagError: the path exists or cannot be written.
        """
        if self._writer is not None:
            return self
        if self.path.exists():
            msg = f'{self.path}: bag exists already, not overwriting'
            raise BagError(msg)
        writer = BagWriter(self.path)
        try:
            writer.open()
        except OSError as err:
            msg = f'{self.path}: cannot create the bag ({err.strerror or type(err).__name__})'
            raise BagError(msg) from None
        self._writer = writer
        for topic, msgtype in _TOPICS.items():
            self._channels[topic] = writer.add_topic(bag_topic(topic, msgtype))
        return self

    def close(self) -> None:
        """Finish the bag (writes its summary and its metadata)."""
        writer, self._writer = self._writer, None
        if writer is not None:
            writer.close()

    def __enter__(self) -> BagRecorder:
        """Open the bag."""
        return self.open()

    def flush(self, *, sync: bool = True) -> None:
        """Nothing to do: the writer buffers until :meth:`close` (the journal is durable)."""

    def __exit__(self, *exc: object) -> None:
        """Close the bag."""
        self.close()

    @property
    def writer(self) -> BagWriter:
        """The bag's writer (to copy many messages: ``writer.write_many(messages)``)."""
        if self._writer is None:
            msg = f'{self.path}: bag is not open'
            raise BagError(msg)
        return self._writer

    def channel(self, topic: str) -> int:
        """The channel of ``topic`` (per-site topics are added on first use).

        Raises:
            BagError: the bag is not open, or ``topic`` is not one of a run's bag.
        """
        channel = self._channels.get(topic)
        if channel is not None:
            return channel
        msgtype = _message_type(topic)
        if msgtype is None:
            msg = f'{self.path}: {topic}: not a topic of a run bag'
            raise BagError(msg)
        channel = self._channels[topic] = self.writer.add_topic(bag_topic(topic, msgtype))
        return channel

    def _write(self, topic: str, t_ns: int, message: Any) -> None:
        msgtype = _message_type(topic)
        assert msgtype is not None
        self.write_raw(topic, t_ns, self._store.serialize_cdr(message, msgtype))

    def write_raw(self, topic: str, t_ns: int, data: bytes | memoryview) -> None:
        """Record an already serialized (CDR) message of one of the bag's topics."""
        self.writer.write(self.channel(topic), t_ns, data)

    def write_definition(self, text: str, t_ns: int) -> None:
        """Record the resolved test definition (JSON)."""
        self._write(TOPIC_DEFINITION, t_ns, self._store.types[MSG_STRING](data=text))

    def write_event(self, what: str, t_ns: int, **info: Any) -> None:
        """Record an event of the run (JSON text on ``/pd/run_events``)."""
        text = json.dumps({'what': what, **info}, sort_keys=True)
        self._write(TOPIC_EVENTS, t_ns, self._store.types[MSG_STRING](data=text))

    def _write_encoded(self, topic: str, t_ns: int, encode: Callable[[], bytes]) -> None:
        """Record a message the protocol's codec encodes (the bytes rclpy and rosbags make)."""
        try:
            data = encode()
        except CdrEncodeError as err:
            msg = f'{self.path}: {topic}: {err}'
            raise BagError(msg) from None
        self.write_raw(topic, t_ns, data)

    def write_command(self, command: Command, t_ns: int, topic: str = TOPIC_COMMAND,
                      signature: Signature | None = None, stamp_ns: int | None = None,
                      data: bytes | None = None) -> None:
        """Record a step command: its bytes as they went out (``data``), else encoded.

        Encoded with the signature it went out with, if any, and ``stamp_ns``, its header
        stamp (default ``t_ns``): with the one it went out with, the bag holds the bytes that
        went out.
        """
        if data is not None:
            self.write_raw(topic, t_ns, data)
            return
        self._write_encoded(topic, t_ns, lambda: encode_command(
            command, t_ns if stamp_ns is None else stamp_ns, signature or _UNSIGNED))

    def write_feedback(self, feedback: Feedback, t_ns: int, topic: str = TOPIC_FEEDBACK,
                       signature: Signature | None = None, stamp_ns: int | None = None,
                       data: bytes | None = None) -> None:
        """Record a step feedback: its bytes as they arrived (``data``), else encoded.

        Encoded with the signature and header stamp it came with.
        """
        if data is not None:
            self.write_raw(topic, t_ns, data)
            return
        self._write_encoded(topic, t_ns, lambda: encode_feedback(
            feedback, t_ns if stamp_ns is None else stamp_ns, signature or _UNSIGNED))

    def write_status(self, status: Status, t_ns: int, *, topic: str = TOPIC_STATUS) -> None:
        """Record a test status (the integrator's, or the bridge's on its own topic)."""
        self._write_encoded(topic, t_ns, lambda: encode_status(status, t_ns))


@dataclass
class RecordedRun:
    """What a run's bag holds, in log-time order.

    Attributes:
        definition_json: the resolved test definition.
        events: ``(t_ns, item)`` with item a :class:`Command` or :class:`Feedback`, in the order
            the integrator sent and received them.
        statuses: the integrator's statuses.
        bridge_statuses: the bridge's statuses.
        trajectories: the actuator's sub-step trajectories (``ActuatorTrajectory`` messages).
        site_events: per site of a substructured test, ``(t_ns, item)`` of its own stream.
        signatures: the signature of each item of ``events`` (unsigned ones empty).
        site_signatures: the same for ``site_events``.
        stamps: the header stamp of each item of ``events`` (what its signature covers).
        site_stamps: the same for ``site_events``.
        ordered: every command, feedback and integrator status as ``(topic, t_ns, item,
            signature)``, in recorded order across all topics (what a resume re-runs).
        notes: what reading found worth saying (e.g. a journal's last record cut short).
        run_events: the run's events (``/pd/run_events``: resumed, restarted, epoch changes),
            each a mapping with ``what`` and ``t_ns``.
    """

    definition_json: str
    events: list[tuple[int, Command | Feedback]] = field(default_factory=list)
    statuses: list[tuple[int, Status]] = field(default_factory=list)
    bridge_statuses: list[tuple[int, Status]] = field(default_factory=list)
    trajectories: list[tuple[int, Any]] = field(default_factory=list)
    site_events: dict[str, list[tuple[int, Command | Feedback]]] = field(default_factory=dict)
    signatures: list[Signature] = field(default_factory=list)
    site_signatures: dict[str, list[Signature]] = field(default_factory=dict)
    stamps: list[int] = field(default_factory=list)
    site_stamps: dict[str, list[int]] = field(default_factory=dict)
    ordered: list[tuple[str, int, Command | Feedback | Status, Signature]] = field(
        default_factory=list)
    notes: list[str] = field(default_factory=list)
    run_events: list[dict[str, Any]] = field(default_factory=list)

    @property
    def commands(self) -> list[Command]:
        """The commands, in order."""
        return [item for _, item in self.events if isinstance(item, Command)]

    @property
    def feedback(self) -> list[Feedback]:
        """The feedback messages, in order."""
        return [item for _, item in self.events if isinstance(item, Feedback)]


class RunIndex:
    """Sorts a run's recorded messages into a :class:`RecordedRun` (bag or journal alike)."""

    def __init__(self) -> None:
        self._definition: str | None = None
        self._run = RecordedRun(definition_json='')
        self._messages: list[tuple[str, int, Command | Feedback, Signature, int]] = []

    def definition(self, text: str) -> None:
        """The recorded definition (the first one counts)."""
        self._definition = self._definition or text

    def message(self, topic: str, t_ns: int, item: Command | Feedback,
                signature: Signature, stamp_ns: int | None = None) -> None:
        """A command or feedback on ``topic`` (``stamp_ns``: its header stamp, default t)."""
        self._messages.append((topic, t_ns, item, signature,
                               t_ns if stamp_ns is None else stamp_ns))
        self._run.ordered.append((topic, t_ns, item, signature))

    def status(self, topic: str, t_ns: int, status: Status) -> None:
        """A status: the integrator's on ``/pd/test_status``, a bridge's on its own topic."""
        if topic == TOPIC_STATUS:
            self._run.statuses.append((t_ns, status))
            self._run.ordered.append((topic, t_ns, status, _UNSIGNED))
        else:
            self._run.bridge_statuses.append((t_ns, status))

    def trajectory(self, t_ns: int, message: Any) -> None:
        """An actuator trajectory."""
        self._run.trajectories.append((t_ns, message))

    def event(self, t_ns: int, event: dict[str, Any]) -> None:
        """An event of the run."""
        self._run.run_events.append({**event, 't_ns': t_ns})

    def result(self, source: str) -> RecordedRun:
        """The run.

        Raises:
            BagError: no definition was recorded.
        """
        if self._definition is None:
            msg = f'{source}: no {TOPIC_DEFINITION} record (not a run record?)'
            raise BagError(msg)
        run = self._run
        run.definition_json = self._definition
        structured = any(topic == TOPIC_STRUCTURE_COMMAND for topic, *_ in self._messages)
        main_topics = ((TOPIC_STRUCTURE_COMMAND, TOPIC_STRUCTURE_FEEDBACK) if structured
                       else (TOPIC_COMMAND, TOPIC_FEEDBACK))
        for topic, t_ns, item, signature, stamp_ns in self._messages:
            if topic in main_topics:
                run.events.append((t_ns, item))
                run.signatures.append(signature)
                run.stamps.append(stamp_ns)
            else:
                site = site_of(topic)
                run.site_events.setdefault(site, []).append((t_ns, item))
                run.site_signatures.setdefault(site, []).append(signature)
                run.site_stamps.setdefault(site, []).append(stamp_ns)
        return run


def site_of(topic: str) -> str:
    """The site of a per-site topic (``/pd/lab1/step_command`` → ``lab1``; ``/pd/...`` → '')."""
    head = topic.removeprefix('/pd/').rsplit('/', 1)[0]
    return '' if head in ('step_command', 'step_feedback') else head


def read_trajectory(data: bytes, store: Any) -> Any:
    """The ``ActuatorTrajectory`` message of CDR bytes (``store``: :func:`~.bag.typestore`).

    What a run's reader decodes a trajectory record with: its recorder checks each with this
    before it is recorded (the topic is not signed: bytes that are no trajectory never enter
    the record, where they would make the run unreadable).

    Raises:
        ValueError: the bytes are not such a message, or its arrays do not fit its samples.
    """
    try:
        message = store.deserialize_cdr(data, MSG_TRAJECTORY)
        samples, n_dof = len(message.time), int(message.n_dof)
        lengths = {name: len(getattr(message, name))
                   for name in ('command', 'measured_displacement', 'measured_force')}
    except Exception as err:
        reason = ' '.join(str(err).split()) or type(err).__name__
        msg = f'not an actuator trajectory ({reason})'
        raise ValueError(msg) from err
    for name, length in lengths.items():
        if length != samples * n_dof:
            msg = (f'not an actuator trajectory ({name}: {length} values for {samples} '
                   f'samples of {n_dof} DOFs)')
            raise ValueError(msg)
    return message


class LeftOut:
    """Trajectories a reader left out, said in one note (however many there are)."""

    def __init__(self, what: str) -> None:
        self.what = what  # 'record' (a journal's) or 'message' (a bag's)
        self.count = 0
        self.first = ''

    def add(self, topic: str, t_ns: int, err: Exception) -> None:
        """One more left out (the first is described)."""
        self.count += 1
        if self.count == 1:
            self.first = f'{topic} at log time {t_ns} ns: {err}'

    def notes(self) -> list[str]:
        """The note (none if nothing was left out)."""
        if not self.count:
            return []
        plural = '' if self.count == 1 else 's'
        return [f'left out {self.count} trajectory {self.what}{plural} (first: {self.first})']


def read_bag(path: str | Path) -> RecordedRun:
    """Read a run's bag (any rosbag2 reader-compatible bag with the topics above).

    Raises:
        BagError: the bag cannot be read or has no test definition.
    """
    path = Path(path)
    index = RunIndex()
    left_out = LeftOut('message')
    try:
        with AnyReader([path], default_typestore=typestore()) as reader:
            connections = [c for c in reader.connections if _message_type(c.topic) is not None]
            for connection, t_ns, raw in reader.messages(connections=connections):
                if connection.msgtype == MSG_TRAJECTORY:
                    try:  # (informative: one that is no trajectory is left out, noted;
                        # decoded with the bag's own message definitions, as the rest)
                        index.trajectory(t_ns, read_trajectory(raw, reader.typestore))
                    except ValueError as err:
                        left_out.add(connection.topic, t_ns, err)
                    continue
                message = reader.deserialize(raw, connection.msgtype)
                topic = connection.topic
                msgtype = connection.msgtype
                if topic == TOPIC_EVENTS:
                    index.event(t_ns, json.loads(cast('_StringMessage', message).data))
                elif topic == TOPIC_DEFINITION:
                    # rosbags types a deserialised message as ``object``; the definition topic
                    # carries a std_msgs/msg/String (the resolved test as JSON text).
                    index.definition(cast('_StringMessage', message).data)
                elif msgtype in (MSG_COMMAND, MSG_FEEDBACK):
                    item = (command_from_message(message) if msgtype == MSG_COMMAND
                            else feedback_from_message(message))
                    signature = signature_from_message(
                        message.signature)  # type: ignore[attr-defined]  # rosbags: ``object``
                    index.message(topic, t_ns, item, signature,
                                  stamp_ns_of(message))
                else:
                    index.status(topic, t_ns, status_from_message(message))
    except BagError:
        raise
    except Exception as err:
        reason = ' '.join(str(err).split())  # (one line: a YAML error's own spans several)
        msg = f'{path}: cannot read the bag ({reason})'
        raise BagError(msg) from err
    run = index.result(str(path))
    run.notes = left_out.notes()
    return run

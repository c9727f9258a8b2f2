"""The CDR codec of the step protocol against rclpy and against rosbags, bit for bit.

Property tests (hypothesis, derandomized) over every message kind with a record: random
records with every field drawn (empty arrays, NaN with any payload, ±0.0, ±inf, subnormals,
extreme uint64/uint32, long and non-ASCII strings, signed and unsigned), each checked four
ways:

(a) ``encode`` against rclpy's ``serialize_message`` of the message :mod:`pd_common.ros.messages`
    builds: the same bytes everywhere but where ours holds 0 and rclpy's does not (rclpy leaves
    the alignment padding uninitialised: its bytes there are whatever the allocator held), and
    rclpy reading our bytes gives back the record, stamp and signature (so every differing byte
    is padding rclpy does not read). rclpy's bytes may run on past the message's end (it sizes
    its buffer by an estimate: a 4-byte DOF name before a non-empty ``control_mode`` leaves 8
    bytes more); rclpy and rosbags ignore them, and so does ``decode``; the length of ours is
    rosbags' exactly;
(b) ``decode`` of rclpy's bytes equals the existing ``*_from_message`` conversion of the message;
(c) ``encode`` equals the bytes of ``rosbags``' independent CDR serializer exactly (it zeroes its
    padding), and rosbags reads our bytes into a message that converts to the same record;
(d) ``decode(encode(x)) == x``.

Floats are compared by their bits (NaN payloads, the sign of zero). Then: hand-computed bytes
of one command (the layout documented in docs/explanation/step-protocol.md), and malformed
bytes (every truncation, random damage, lying counts, bad strings, bools, encapsulations) all
refused with :class:`MalformedMessageError`, never another exception.
"""

from __future__ import annotations

import dataclasses
import math
import os
import struct
from collections.abc import Callable
from typing import Any

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from pd_common.protocol import (
    Command,
    Control,
    Feedback,
    FeedbackStatus,
    MalformedMessageError,
    Offer,
    SessionStart,
    Signature,
    StateOrigin,
    Status,
    cdr,
    command_from_message,
    control_from_message,
    feedback_from_message,
    offer_from_message,
    signature_from_message,
    signed_from_bytes,
    signed_from_message,
    stamp_ns_of,
    status_from_message,
)
from pd_common.protocol import TestState as State
from support.cdr_bits import bits, pd_msgs_typestore

# serialization needs no graph; should anything reach one, it stays on this host and domain
os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')
os.environ.setdefault('ROS_DOMAIN_ID', '217')
rclpy_serialization = pytest.importorskip('rclpy.serialization')
pd_msgs = pytest.importorskip('pd_msgs.msg')
ros_messages = pytest.importorskip('pd_common.ros.messages')

serialize_message = rclpy_serialization.serialize_message
deserialize_message = rclpy_serialization.deserialize_message

SETTINGS = settings(max_examples=150, deadline=None, derandomize=True, database=None,
                    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])


STORE = pd_msgs_typestore()


# -- strategies -----------------------------------------------------------------------------

UINT64 = st.one_of(st.sampled_from([0, 1, 2**32 - 1, 2**32, 2**63, 2**64 - 1]),
                   st.integers(0, 2**64 - 1))
UINT32 = st.one_of(st.sampled_from([0, 1, 2**31, 2**32 - 1]), st.integers(0, 2**32 - 1))
UINT8 = st.integers(0, 255)
#: Any float64: NaNs (with payloads), ±inf, ±0.0, subnormals, extremes.
FLOAT = st.one_of(
    st.sampled_from([0.0, -0.0, math.inf, -math.inf, math.nan, -math.nan, 5e-324, -5e-324,
                     1.7976931348623157e308, -1.7976931348623157e308]),
    st.integers(0, 2**64 - 1).map(lambda raw: struct.unpack('<d', struct.pack('<Q', raw))[0]),
    st.floats(allow_nan=True, allow_infinity=True))
CHARS = st.characters(blacklist_categories=('Cs',), blacklist_characters='\x00')


def text(limit: int) -> st.SearchStrategy[str]:
    """Strings of at most ``limit`` characters: short, ASCII, non-ASCII, and up to the bound."""
    return st.one_of(
        st.text(CHARS, max_size=12),
        st.text(st.characters(max_codepoint=127, blacklist_characters='\x00'), max_size=40),
        st.builds(lambda seed, n: (seed * limit)[:n], st.text(CHARS, min_size=1, max_size=8),
                  st.integers(0, limit)))


NAME = text(256)
LONG_TEXT = text(8192)
FLOATS = st.lists(FLOAT, max_size=12).map(tuple)
STAMP = st.one_of(st.sampled_from([0, -1, -2**31 * 10**9, (2**31 - 1) * 10**9 + 999_999_999]),
                  st.integers(-2**31 * 10**9, (2**31 - 1) * 10**9 + 999_999_999))
SIGNATURE = st.one_of(
    st.just(Signature()),
    st.builds(Signature, key_id=NAME, session=NAME, sequence=UINT64,
              mac=st.binary(max_size=64)))


@st.composite
def commands(draw: st.DrawFn) -> Command:
    """Any command: DOF names, targets, modes and forces of independent lengths."""
    return Command(test_id=draw(NAME), step=draw(UINT64), test_time=draw(FLOAT),
                   dof_names=tuple(draw(st.lists(NAME, max_size=6))),
                   target_displacement=draw(FLOATS), iteration=draw(UINT32),
                   control_mode=tuple(draw(st.lists(UINT8, max_size=8))),
                   target_force=draw(FLOATS))


FEEDBACKS = st.builds(Feedback, test_id=NAME, step=UINT64, measured_displacement=FLOATS,
                      restoring_force=FLOATS, status=st.sampled_from(FeedbackStatus),
                      message=LONG_TEXT, iteration=UINT32, epoch=NAME,
                      state_origin=st.sampled_from(StateOrigin))
STATUSES = st.builds(Status, test_id=NAME, state=st.sampled_from(State), step=UINT64,
                     total_steps=UINT64, omega_dt=FLOAT, retries=UINT32,
                     ignored_messages=UINT32, message=LONG_TEXT, refused_messages=UINT32,
                     refused_by_reason=LONG_TEXT, node=NAME, session=NAME,
                     emergency_stop=st.booleans(), operator_hold=st.booleans(),
                     acknowledged=LONG_TEXT, definition_digest=NAME)
OFFERS = st.builds(Offer, stamp_ns=STAMP, node=NAME, challenge=NAME, active_session=NAME,
                   authenticated=st.booleans(), epoch=NAME, state_origin=UINT8,
                   restored=st.tuples(NAME, UINT64, UINT32), position=FLOATS, force=FLOATS,
                   configuration=LONG_TEXT)
CONTROLS = st.builds(Control, command=NAME, target=NAME, reason=text(256), stamp=FLOAT,
                     test_id=NAME, session=NAME, sender=NAME)
STARTS = st.builds(SessionStart, test_id=NAME, challenge=NAME)


# -- the message kinds: record -> rclpy message, rclpy message -> record, the codec -----------

def _stamped(message: Any, stamp_ns: int) -> Any:
    message.header.stamp = ros_messages.stamp_from_ns(stamp_ns)
    return message


def _signed(message: Any, signature: Signature) -> Any:
    ros_messages.fill_signature(message.signature, signature)
    return message


def _start_message(start: SessionStart, stamp_ns: int, signature: Signature) -> Any:
    message = pd_msgs.SessionStart()  # as pd_common.ros.session.SessionSender builds it
    message.test_id, message.challenge = start.test_id, start.challenge
    return _signed(_stamped(message, stamp_ns), signature)


def _start_from_message(message: Any) -> SessionStart:
    return SessionStart(test_id=message.test_id, challenge=message.challenge)


@dataclasses.dataclass(frozen=True)
class Kind:
    """One message kind: how the existing conversions and the codec handle it."""

    typename: str
    message_type: Any
    to_message: Callable[[Any, int, Signature], Any]
    from_message: Callable[[Any], Any]
    encode: Callable[[Any, int, Signature], bytes]
    decode: Callable[[bytes], cdr.Decoded[Any]]


KINDS = {
    'command': Kind(
        'pd_msgs/msg/StepCommand', pd_msgs.StepCommand,
        lambda r, t, s: ros_messages.command_message(
            r, ros_messages.stamp_from_ns(t), signature=s),
        command_from_message, cdr.encode_command, cdr.decode_command),
    'feedback': Kind(
        'pd_msgs/msg/StepFeedback', pd_msgs.StepFeedback,
        lambda r, t, s: ros_messages.feedback_message(
            r, ros_messages.stamp_from_ns(t), signature=s),
        feedback_from_message, cdr.encode_feedback, cdr.decode_feedback),
    'status': Kind(
        'pd_msgs/msg/TestStatus', pd_msgs.TestStatus,
        lambda r, t, s: _signed(ros_messages.status_message(
            r, ros_messages.stamp_from_ns(t)), s),
        status_from_message, cdr.encode_status, cdr.decode_status),
    'offer': Kind(
        'pd_msgs/msg/SessionOffer', pd_msgs.SessionOffer,
        lambda r, t, s: _signed(ros_messages.offer_message(r), s),
        offer_from_message, lambda r, t, s: cdr.encode_offer(r, s), cdr.decode_offer),
    'control': Kind(
        'pd_msgs/msg/Control', pd_msgs.Control,
        lambda r, t, s: _stamped(ros_messages.control_message(r, s), t),
        control_from_message, cdr.encode_control, cdr.decode_control),
    'session_start': Kind(
        'pd_msgs/msg/SessionStart', pd_msgs.SessionStart, _start_message,
        _start_from_message, cdr.encode_session_start, cdr.decode_session_start),
}


def to_rosbags(message: Any) -> Any:
    """The rosbags message of an rclpy message (field by field, independent of the codec)."""
    module = type(message).__module__.split('.')[0]
    cls = STORE.types[f'{module}/msg/{type(message).__name__}']
    values: dict[str, Any] = {}
    for name, kind in message.get_fields_and_field_types().items():
        value = getattr(message, name)
        if hasattr(value, 'get_fields_and_field_types'):
            values[name] = to_rosbags(value)
        elif kind == 'sequence<double>':
            values[name] = np.array(value, dtype=np.float64)
        elif kind == 'sequence<uint8>':
            values[name] = np.array(value, dtype=np.uint8)
        else:
            values[name] = list(value) if kind.startswith('sequence<') else value
    return cls(**values)


def check_kind(kind: Kind, record: Any, stamp_ns: int, signature: Signature) -> None:
    """(a), (b), (c) and (d) for one record."""
    message = kind.to_message(record, stamp_ns, signature)
    stamp_ns = stamp_ns_of(message)  # an offer carries its own
    expected = bits((kind.from_message(message), stamp_ns, signature))
    ours = kind.encode(record, stamp_ns, signature)
    assert isinstance(ours, bytes)
    # (a) rclpy: the same bytes but its uninitialised padding, which it does not read
    theirs = serialize_message(message)
    assert len(theirs) >= len(ours)  # rclpy may run on past the end: see the module docstring
    differing = [i for i in range(len(ours)) if ours[i] != theirs[i]]
    assert all(ours[i] == 0 for i in differing), differing
    back = deserialize_message(ours, kind.message_type)
    assert bits((kind.from_message(back), stamp_ns_of(back),
                 signature_from_message(back.signature))) == expected
    # (b) decoding rclpy's bytes is the existing conversion of the message
    decoded = kind.decode(theirs)
    assert bits(tuple(decoded)[:3]) == expected
    # (c) rosbags' serializer: exactly our bytes; its reading of ours converts the same
    assert bytes(STORE.serialize_cdr(to_rosbags(message), kind.typename)) == ours
    read = STORE.deserialize_cdr(ours, kind.typename)
    assert bits((kind.from_message(read), stamp_ns_of(read),
                 signature_from_message(read.signature))) == expected
    # (d) the round trip
    assert bits(tuple(kind.decode(ours))[:3]) == bits((record, stamp_ns, signature))
    # (e) the bytes a MAC covers: everything through the sequence, the MAC closes them
    unsigned = kind.encode(record, stamp_ns, dataclasses.replace(signature, mac=b''))
    assert cdr.seal(cdr.covered_part(unsigned), signature.mac) == ours
    assert kind.decode(ours).covered == cdr.covered_part(unsigned)


@SETTINGS
@given(record=commands(), stamp_ns=STAMP, signature=SIGNATURE)
def test_command_bit_for_bit(record: Command, stamp_ns: int, signature: Signature) -> None:
    """StepCommand: rclpy, rosbags, the existing conversion and the round trip agree."""
    check_kind(KINDS['command'], record, stamp_ns, signature)


@SETTINGS
@given(record=FEEDBACKS, stamp_ns=STAMP, signature=SIGNATURE)
def test_feedback_bit_for_bit(record: Feedback, stamp_ns: int, signature: Signature) -> None:
    """StepFeedback: rclpy, rosbags, the existing conversion and the round trip agree."""
    check_kind(KINDS['feedback'], record, stamp_ns, signature)


@SETTINGS
@given(record=STATUSES, stamp_ns=STAMP, signature=SIGNATURE)
def test_status_bit_for_bit(record: Status, stamp_ns: int, signature: Signature) -> None:
    """TestStatus: rclpy, rosbags, the existing conversion and the round trip agree."""
    check_kind(KINDS['status'], record, stamp_ns, signature)


@SETTINGS
@given(record=OFFERS, signature=SIGNATURE)
def test_offer_bit_for_bit(record: Offer, signature: Signature) -> None:
    """SessionOffer: rclpy, rosbags, the existing conversion and the round trip agree."""
    check_kind(KINDS['offer'], record, record.stamp_ns, signature)


@SETTINGS
@given(record=CONTROLS, stamp_ns=STAMP, signature=SIGNATURE)
def test_control_bit_for_bit(record: Control, stamp_ns: int, signature: Signature) -> None:
    """Control: rclpy, rosbags, the existing conversion and the round trip agree."""
    check_kind(KINDS['control'], record, stamp_ns, signature)


@SETTINGS
@given(record=STARTS, stamp_ns=STAMP, signature=SIGNATURE)
def test_session_start_bit_for_bit(record: SessionStart, stamp_ns: int,
                                   signature: Signature) -> None:
    """SessionStart: rclpy, rosbags, the session's conversion and the round trip agree."""
    check_kind(KINDS['session_start'], record, stamp_ns, signature)


@SETTINGS
@given(signature=SIGNATURE)
def test_signature_message_bit_for_bit(signature: Signature) -> None:
    """A Signature message by itself: rclpy, rosbags and the round trip agree."""
    message = pd_msgs.Signature()
    ros_messages.fill_signature(message, signature)
    ours = cdr.encode_signature(signature)
    theirs = serialize_message(message)
    assert len(theirs) >= len(ours)
    assert all(ours[i] == 0 for i in range(len(ours)) if ours[i] != theirs[i])
    assert signature_from_message(deserialize_message(ours, pd_msgs.Signature)) == signature
    assert cdr.decode_signature(theirs) == signature_from_message(message) == signature
    assert bytes(STORE.serialize_cdr(to_rosbags(message), 'pd_msgs/msg/Signature')) == ours
    assert cdr.decode_signature(ours) == signature


def test_feedback_arrays_may_be_numpy() -> None:
    """A feedback holding read-only numpy arrays encodes as its tuples do."""
    values = np.array([1.5, -0.0, math.nan])
    values.flags.writeable = False
    as_array = Feedback('t', 1, values, values * 2)
    as_tuple = Feedback('t', 1, tuple(values.tolist()), tuple((values * 2).tolist()))
    assert cdr.encode_feedback(as_array, 5) == cdr.encode_feedback(as_tuple, 5)


def test_unknown_codes_read_as_the_conversion_reads_them() -> None:
    """An unknown feedback status is a fault, an unknown origin fresh, an unknown state idle."""
    message = ros_messages.feedback_message(Feedback('t', 1, (), ()),
                                            ros_messages.stamp_from_ns(0))
    message.status, message.state_origin = 7, 9
    decoded = cdr.decode_feedback(serialize_message(message)).record
    assert decoded == feedback_from_message(message)
    assert (decoded.status, decoded.state_origin) == (FeedbackStatus.FAULT, StateOrigin.FRESH)
    status = ros_messages.status_message(Status('t', State.RUNNING, 1, 2, 0.1),
                                         ros_messages.stamp_from_ns(0))
    status.state = 42
    assert cdr.decode_status(serialize_message(status)).record.state is State.IDLE


def test_header_frame_id_is_read_and_dropped() -> None:
    """A sender's frame id (the records carry none) is skipped like the conversion skips it."""
    command = Command('t', 3, 0.25, ('top',), (0.01,))
    message = ros_messages.command_message(command, ros_messages.stamp_from_ns(7))
    message.header.frame_id = 'wörld'
    assert cdr.decode_command(serialize_message(message))[:3] == (command, 7, Signature())


# -- the documented layout, by hand -------------------------------------------------------------

def test_command_layout_by_hand() -> None:
    """The bytes of one command as docs/explanation/step-protocol.md lays them out."""
    command = Command(test_id='ab', step=5, test_time=0.5, dof_names=('x',),
                      target_displacement=(1.0,))
    signature = Signature(key_id='k', session='s', sequence=3, mac=b'\xaa\xbb')
    expected = bytes.fromhex(''.join((              # offset after the encapsulation: field
        '00010000',                                  # encapsulation: plain CDR, little-endian
        '01000000 02000000',                       # 0: stamp sec 1, 4: nanosec 2
        '01000000 00',                             # 8: frame_id '' (length 1: its NUL)
        '000000 03000000 616200',                # 13: pad 3, 16: test_id 'ab'
        '00 0500000000000000',                     # 23: pad 1, 24: step
        '00000000',                                  # 32: iteration
        '00000000 000000000000e03f',               # 36: pad 4, 40: test_time 0.5
        '01000000 02000000 7800',                # 48: dof_names: 1, 52: 'x'
        '0000 01000000',                           # 58: pad 2, 60: target_displacement: 1
        '000000000000f03f',                          # 64: 1.0
        '00000000',                                  # 72: control_mode: 0
        '00000000',                                  # 76: target_force: 0 (no pad when empty)
        '02000000 6b00',                           # 80: signature.key_id 'k'
        '0000 02000000 7300',                    # 86: pad 2, 88: signature.session 's'
        '0000 0300000000000000',                   # 94: pad 2, 96: signature.sequence 3
        '02000000 aabb',                           # 104: signature.mac (2 bytes): 110 bytes
    )))
    assert cdr.encode_command(command, 1_000_000_002, signature) == expected
    assert cdr.decode_command(expected)[:3] == (command, 1_000_000_002, signature)


def test_feedback_layout_by_hand() -> None:
    """The bytes of one unsigned feedback as docs/explanation/step-protocol.md lays them out."""
    feedback = Feedback(test_id='ab', step=5, measured_displacement=(1.0,),
                        restoring_force=(-2.0,), status=FeedbackStatus.LIMIT, message='m',
                        iteration=1, epoch='', state_origin=StateOrigin.HARDWARE)
    expected = bytes.fromhex(''.join((
        '00010000',
        '00000000 00000000',                       # 0: stamp 0
        '01000000 00',                             # 8: frame_id ''
        '000000 03000000 616200',                # 13: pad 3, 16: test_id 'ab'
        '00 0500000000000000',                     # 23: pad 1, 24: step
        '01000000',                                  # 32: iteration 1
        '01000000 000000000000f03f',               # 36: measured_displacement: 1, 40: 1.0
        '01000000 00000000',                       # 48: restoring_force: 1, 52: pad 4
        '00000000000000c0',                          # 56: -2.0
        '01',                                        # 64: status LIMIT
        '000000 02000000 6d00',                  # 65: pad 3, 68: message 'm'
        '0000 01000000 00',                      # 74: pad 2, 76: epoch ''
        '02',                                        # 81: state_origin HARDWARE
        '0000 01000000 00',                      # 82: pad 2, 84: signature.key_id ''
        '000000 01000000 00',                    # 89: pad 3, 92: signature.session ''
        '00000000000000 0000000000000000',         # 97: pad 7, 104: signature.sequence 0
        '00000000',                                  # 112: signature.mac: 0 (116 bytes)
    )))
    assert cdr.encode_feedback(feedback, 0) == expected
    assert cdr.decode_feedback(expected)[:3] == (feedback, 0, Signature())


# -- refusals -------------------------------------------------------------------------------

SAMPLES = {
    'command': Command('tést', 2**64 - 1, -0.0, ('top', 'bé'), (math.nan, -math.inf),
                       2**32 - 1, (0, 1), (0.0, 5e3)),
    'feedback': Feedback('tést', 9, (1.0, 2.0), (-0.0, math.inf), FeedbackStatus.FAULT,
                         'ünreachable', 2, 'ep', StateOrigin.RESTORED),
    'status': Status('t', State.HOLDING, 3, 10, 0.3, 1, 2, 'msg', 4, 'forged: 4', 'n',
                     's', True, False, 'ack'),
    'offer': Offer(12, 'node', 'ch', 'as', True, 'ep', 1, ('t', 3, 1), (1.0,), (2.0,), '{}'),
    'control': Control('pause', 'n', 'why', 1.5, 't', 's', 'operator'),
    'session_start': SessionStart('t', 'challenge'),
}
SIGNED = Signature('0123456789abcdef', 'f' * 32, 77, bytes(range(32)))


@pytest.mark.parametrize('name', sorted(SAMPLES))
def test_every_truncation_is_refused(name: str) -> None:
    """Every proper prefix of a message is refused as malformed bytes."""
    kind = KINDS[name]
    data = kind.encode(SAMPLES[name], 5, SIGNED)
    kind.decode(data)
    for end in range(len(data)):
        with pytest.raises(cdr.CdrDecodeError):
            kind.decode(data[:end])
    with pytest.raises(cdr.CdrDecodeError):
        cdr.decode_signature(cdr.encode_signature(SIGNED)[:-1])


@pytest.mark.parametrize('name', sorted(SAMPLES))
def test_damaged_bytes_decode_or_are_refused(name: str) -> None:
    """Any byte set to any value: the message decodes, or MalformedMessageError, nothing else."""
    kind = KINDS[name]
    data = kind.encode(SAMPLES[name], 5, SIGNED)
    for index in range(len(data)):
        for value in (0x00, 0x01, 0x7f, 0x80, 0xfe, 0xff):
            damaged = bytearray(data)
            damaged[index] = value
            try:
                kind.decode(bytes(damaged))
            except MalformedMessageError:
                pass


@SETTINGS
@given(data=st.binary(max_size=300), name=st.sampled_from(sorted(SAMPLES)))
def test_random_bytes_decode_or_are_refused(data: bytes, name: str) -> None:
    """Random bytes (behind a valid encapsulation or not): decoded or refused, nothing else."""
    for candidate in (data, cdr.ENCAPSULATION + data):
        try:
            KINDS[name].decode(candidate)
        except MalformedMessageError:
            pass


def _command_bytes() -> bytes:
    return cdr.encode_command(Command('t', 1, 0.0, ('a',), (1.0,)), 0)


# offsets in the bytes (the encapsulation header included) of _command_bytes()
_DOF_COUNT, _DISPLACEMENT_COUNT = 4 + 48, 4 + 60


def _patched(data: bytes, offset: int, value: int) -> bytes:
    return data[:offset] + struct.pack('<I', value) + data[offset + 4:]


def test_counts_beyond_the_bytes_are_refused_before_allocating() -> None:
    """A count larger than the bytes left, or than the bound, is refused by its field."""
    data = _command_bytes()
    assert struct.unpack_from('<I', data, _DOF_COUNT)[0] == 1
    assert struct.unpack_from('<I', data, _DISPLACEMENT_COUNT)[0] == 1
    with pytest.raises(cdr.CdrDecodeError, match='dof_names: 50 entries where'):
        cdr.decode_command(_patched(data, _DOF_COUNT, 50))
    with pytest.raises(MalformedMessageError, match=r'dof_names: 4294967295 entries \(at most'):
        cdr.decode_command(_patched(data, _DOF_COUNT, 2**32 - 1))
    with pytest.raises(cdr.CdrDecodeError, match='target_displacement: 9 entries where'):
        cdr.decode_command(_patched(data, _DISPLACEMENT_COUNT, 9))
    with pytest.raises(MalformedMessageError, match='target_displacement: 4097 entries'):
        cdr.decode_command(_patched(data, _DISPLACEMENT_COUNT, 4097))
    with pytest.raises(cdr.CdrDecodeError, match='test_id: string of 4294967295 bytes'):
        cdr.decode_command(_patched(data, 4 + 16, 2**32 - 1))


def test_bad_strings_bools_and_encapsulations_are_refused() -> None:
    """Invalid UTF-8, a missing or inner NUL, a zero length, a bool of 2, big-endian CDR."""
    data = _command_bytes()  # test_id 't' at offset 4 + 16: length 2, 't', NUL
    for body, match in ((b'\xff\x00', 'malformed CDR'), (b'tt', 'not terminated'),
                        (b'\x00\x00', 'not terminated')):
        with pytest.raises(cdr.CdrDecodeError, match=match):
            cdr.decode_command(data[:4 + 20] + body + data[4 + 22:])
    with pytest.raises(cdr.CdrDecodeError, match='string of 0 bytes'):
        cdr.decode_command(_patched(data, 4 + 16, 0))
    with pytest.raises(cdr.CdrDecodeError, match='not little-endian'):
        cdr.decode_command(b'\x00\x00' + data[2:])
    assert cdr.decode_command(data + b'\x01' * 9) == cdr.decode_command(data)  # ignored
    status = bytearray(cdr.encode_status(SAMPLES['status'], 0))
    position = status.index(b'\x02\x00\x00\x00s\x00') + 6  # after session 's': the two bools
    assert status[position:position + 2] == b'\x01\x00'
    status[position] = 2
    with pytest.raises(cdr.CdrDecodeError, match='emergency_stop: bool byte 2'):
        cdr.decode_status(bytes(status))


def test_bounds_are_those_of_the_conversion() -> None:
    """A field beyond its bound is refused as the message conversion refuses it."""
    long_id = Command('x' * 257, 1, 0.0, (), ())
    with pytest.raises(MalformedMessageError, match=r'test_id: 257 characters \(at most 256\)'):
        cdr.decode_command(cdr.encode_command(long_id, 0))
    with pytest.raises(MalformedMessageError, match='test_id: 257 characters'):
        command_from_message(ros_messages.command_message(long_id))
    huge = Command('é' * 5000, 1, 0.0, (), ())  # 10,000 bytes: refused before decoding
    with pytest.raises(MalformedMessageError, match=r'test_id: 10000 bytes \(at most 256'):
        cdr.decode_command(cdr.encode_command(huge, 0))
    long_mac = Signature('k', 's', 1, bytes(65))
    with pytest.raises(MalformedMessageError, match=r'signature\.mac: 65 entries'):
        cdr.decode_session_start(cdr.encode_session_start(SessionStart('t', 'c'), 0, long_mac))
    at_bound = Feedback('t', 1, (0.0,) * 4096, (), message='ü' * 8192)
    assert cdr.decode_feedback(cdr.encode_feedback(at_bound, 0)).record == at_bound


@pytest.mark.parametrize(('record', 'stamp_ns', 'match'), [
    (Command('t', -1, 0.0, (), ()), 0, 'StepCommand: cannot encode'),
    (Command('t', 2**64, 0.0, (), ()), 0, 'StepCommand: cannot encode'),
    (Command('t', 1, 0.0, (), (), iteration=2**32), 0, 'StepCommand: cannot encode'),
    (Command('t', 1, 0.0, (), (), control_mode=(256,)), 0, 'StepCommand: cannot encode'),
    (Command('a\x00b', 1, 0.0, (), ()), 0, 'NUL character'),
    (Command('t', 1, 0.0, ('\ud800',), ()), 0, 'StepCommand: cannot encode'),
    (Command('t', 1, 0.0, (), ()), 2**31 * 10**9, 'StepCommand: cannot encode'),
    (Feedback('t', 1, (), (), status=256), 0, 'StepFeedback: cannot encode'),  # type: ignore[arg-type]
])
def test_what_cdr_cannot_carry_is_refused(record: Any, stamp_ns: int, match: str) -> None:
    """Out-of-range integers, NUL characters, surrogates: CdrEncodeError, nothing written."""
    encode = cdr.encode_command if isinstance(record, Command) else cdr.encode_feedback
    with pytest.raises(cdr.CdrEncodeError, match=match):
        encode(record, stamp_ns)


@pytest.mark.parametrize('name', ['command', 'feedback'])
def test_signed_from_bytes_is_the_raw_subscriptions_reading(name: str) -> None:
    """A raw subscription's reading of rclpy's bytes is signed_from_message's of the message;
    bytes beyond a bound or truncated read as malformed (``None``), never raise."""
    kind = KINDS[name]
    decode = cdr.decode_command if name == 'command' else cdr.decode_feedback
    message = kind.to_message(SAMPLES[name], 5, SIGNED)
    data = serialize_message(message)
    read = signed_from_bytes(decode, data)
    assert read is not None
    assert bits((read.record, read.signature)) == bits(
        signed_from_message(kind.from_message, message))
    too_long = dataclasses.replace(SAMPLES[name], test_id='x' * 1000)
    long_message = kind.to_message(too_long, 5, SIGNED)
    assert signed_from_message(kind.from_message, long_message) is None
    assert signed_from_bytes(decode, serialize_message(long_message)) is None
    end = len(kind.encode(SAMPLES[name], 5, SIGNED))  # (rclpy's bytes may run on past it)
    assert signed_from_bytes(decode, data[:end - 3]) is None


def test_only_bytes_encoded_with_an_empty_mac_can_be_signed() -> None:
    """covered_part needs the empty MAC's count at the end: signed bytes are not signed again."""
    with pytest.raises(cdr.CdrEncodeError, match='empty MAC'):
        cdr.covered_part(cdr.encode_command(SAMPLES['command'], 5, SIGNED))
    unsigned = cdr.encode_command(SAMPLES['command'], 5)
    assert cdr.covered_part(unsigned) == unsigned[:-4]


def test_a_string_read_before_is_checked_again_where_it_does_not_fit() -> None:
    """The decoder keeps the strings it read (a test's id, a session come in every message):
    the same bytes declared longer than what is left, or read under a tighter limit, are
    refused as if never seen."""
    get_string, error = cdr._get_string, cdr.CdrDecodeError  # (the decoder's string reader)
    assert get_string(b'\x02\x00\x00\x00a\x00', 0, 'f', 10) == ('a', 6)
    assert get_string(b'\x02\x00\x00\x00a\x00', 0, 'f', 10) == ('a', 6)  # (kept)
    with pytest.raises(error, match='string of 5 bytes where 2 are left'):
        get_string(b'\x05\x00\x00\x00a\x00', 0, 'f', 10)
    six = b'\x07\x00\x00\x00abcdef\x00'
    assert get_string(six, 0, 'f', 10) == ('abcdef', 11)
    with pytest.raises(MalformedMessageError, match=r'6 characters \(at most 3\)'):
        get_string(six, 0, 'f', 3)
    with pytest.raises(error, match='not terminated'):
        get_string(b'\x02\x00\x00\x00ab', 0, 'f', 10)

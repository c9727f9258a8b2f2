"""Step messages encoded and read by their shape's compiled layout, against independent codecs.

A command's or a feedback's strings, array lengths and modes (its shape) stay the same from
step to step; the codec compiles each shape's layout once and then packs and unpacks only the
numbers. Checked here: every message of a shape seen before is encoded exactly as ``rosbags``'
serializer encodes it and read exactly as the full reader reads it; a message that differs from
its shape's anywhere but in its numbers (every byte changed, in turn, to other values) is read
as the full reader reads it, or refused as the full reader refuses it; shapes of the same length
(two sites' feedback) are told apart; and values out of their field's range are still refused.
"""

from __future__ import annotations

import dataclasses
import math
import os
import struct
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from pd_common.protocol import (
    Command,
    Feedback,
    FeedbackStatus,
    MalformedMessageError,
    Signature,
    StateOrigin,
    cdr,
    cdr_shapes,
)
from support.cdr_bits import bits, pd_msgs_typestore

os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')
ros_messages = pytest.importorskip('pd_common.ros.messages')
rclpy_serialization = pytest.importorskip('rclpy.serialization')

SETTINGS = settings(max_examples=60, deadline=None, derandomize=True, database=None,
                    suppress_health_check=[HealthCheck.too_slow])
FLOAT = st.one_of(st.floats(allow_nan=True, allow_infinity=True),
                  st.integers(0, 2**64 - 1).map(
                      lambda raw: struct.unpack('<d', struct.pack('<Q', raw))[0]))
SIGNED = Signature('0123456789abcdef', 'f' * 32, 77, bytes(range(32)))


STORE = pd_msgs_typestore()


def rosbags_bytes(record: Command | Feedback, stamp_ns: int, signature: Signature) -> bytes:
    """The bytes of ``record`` by rosbags' serializer (of the rclpy message made of it)."""
    stamp = ros_messages.stamp_from_ns(stamp_ns)
    if isinstance(record, Command):
        message, typename = ros_messages.command_message(record, stamp, signature=signature), \
            'pd_msgs/msg/StepCommand'
    else:
        message, typename = ros_messages.feedback_message(record, stamp, signature=signature), \
            'pd_msgs/msg/StepFeedback'
    return bytes(STORE.serialize_cdr(STORE.deserialize_cdr(_rclpy_bytes(message), typename),
                                     typename))


def _rclpy_bytes(message: Any) -> bytes:
    return bytes(rclpy_serialization.serialize_message(message))


def full_read(name: str, data: bytes) -> Any:
    """The full reader's reading of ``data`` (no layout), or the type of what it raised."""
    parse = cdr._parse_command if name == 'command' else cdr._parse_feedback
    try:
        return bits(tuple(cdr._decoding(name, data, parse)))
    except MalformedMessageError:
        return MalformedMessageError


def read(name: str, data: bytes) -> Any:
    decode = cdr.decode_command if name == 'command' else cdr.decode_feedback
    try:
        return bits(tuple(decode(data)))
    except MalformedMessageError:
        return MalformedMessageError


COMMAND = Command('tést', 41, 0.41, ('top', 'bé'), (0.0123, -0.5), 0, (0, 1), (0.0, 5e3))
FEEDBACK = Feedback('tést', 41, (0.0123, -0.5), (-3859.05, 1.0), FeedbackStatus.OK, '', 0,
                    '0123456789abcdef', StateOrigin.FRESH)


@SETTINGS
@given(steps=st.lists(st.tuples(st.integers(0, 2**64 - 1), st.integers(0, 2**32 - 1), FLOAT,
                                st.lists(FLOAT, min_size=2, max_size=2),
                                st.lists(FLOAT, min_size=2, max_size=2),
                                st.integers(0, 2**64 - 1), st.binary(min_size=32, max_size=32),
                                st.integers(-2**31 * 10**9, 2**31 * 10**9 - 1)),
                      min_size=2, max_size=6))
def test_a_commands_shape_is_encoded_and_read_as_the_independent_codecs_do(
        steps: list[tuple[Any, ...]]) -> None:
    for step, iteration, time, displacement, force, sequence, mac, stamp in steps:
        command = dataclasses.replace(COMMAND, step=step, iteration=iteration, test_time=time,
                                      target_displacement=tuple(displacement),
                                      target_force=tuple(force))
        signature = dataclasses.replace(SIGNED, sequence=sequence, mac=mac)
        data = cdr.encode_command(command, stamp, signature)
        assert data == rosbags_bytes(command, stamp, signature)
        assert read('command', data) == full_read('command', data)
        decoded = cdr.decode_command(data)
        assert bits((decoded.record, decoded.stamp_ns, decoded.signature)) == bits(
            (command, stamp, signature))
        assert decoded.covered == data[:-36]  # through the sequence: the MAC's count and MAC


@SETTINGS
@given(steps=st.lists(st.tuples(st.integers(0, 2**64 - 1), st.integers(0, 2**32 - 1),
                                st.lists(FLOAT, min_size=2, max_size=2),
                                st.lists(FLOAT, min_size=2, max_size=2),
                                st.sampled_from(FeedbackStatus), st.sampled_from(StateOrigin),
                                st.integers(0, 2**64 - 1), st.binary(min_size=32, max_size=32),
                                st.integers(-2**31 * 10**9, 2**31 * 10**9 - 1)),
                      min_size=2, max_size=6))
def test_a_feedbacks_shape_is_encoded_and_read_as_the_independent_codecs_do(
        steps: list[tuple[Any, ...]]) -> None:
    for step, iteration, displacement, force, status, origin, sequence, mac, stamp in steps:
        feedback = dataclasses.replace(FEEDBACK, step=step, iteration=iteration,
                                       measured_displacement=tuple(displacement),
                                       restoring_force=tuple(force), status=status,
                                       state_origin=origin)
        signature = dataclasses.replace(SIGNED, sequence=sequence, mac=mac)
        data = cdr.encode_feedback(feedback, stamp, signature)
        assert data == rosbags_bytes(feedback, stamp, signature)
        assert read('feedback', data) == full_read('feedback', data)
        assert bits(cdr.decode_feedback(data).record) == bits(feedback)


@pytest.mark.parametrize('name', ['command', 'feedback'])
def test_every_byte_changed_is_read_as_the_full_reader_reads_it(name: str) -> None:
    """Whatever byte differs from a learned shape's message, and however: read as the full reader.

    The same record, stamp, signature and covered bytes, or the same refusal.
    """
    record: Any = COMMAND if name == 'command' else FEEDBACK
    encode = cdr.encode_command if name == 'command' else cdr.encode_feedback
    data = encode(record, 1_796_000_000_123_456_789, SIGNED)
    assert read(name, data) == full_read(name, data)  # (the shape learned)
    assert read(name, data) == full_read(name, data)  # (read by its layout)
    layout_read = 0
    for index in range(len(data)):
        for value in (0x00, 0x01, 0x02, 0x7f, 0x80, 0xfe, 0xff, data[index] ^ 0x20):
            if value == data[index]:
                continue
            damaged = bytearray(data)
            damaged[index] = value
            damaged_bytes = bytes(damaged)
            expected = full_read(name, damaged_bytes)
            readers = (cdr_shapes._COMMAND_READERS if name == 'command'
                       else cdr_shapes._FEEDBACK_READERS)
            by_layout = any(reader.read(damaged_bytes) is not None
                            for reader in readers.get(len(damaged_bytes), ()))
            layout_read += by_layout
            assert read(name, damaged_bytes) == expected, (index, value)
            if by_layout:
                assert expected is not MalformedMessageError
    assert layout_read > 100  # the numbers' bytes were read by the layout


def test_two_shapes_of_one_length_are_told_apart() -> None:
    """Two sites' feedback: the same length, another epoch and test id of the same size."""
    other = dataclasses.replace(FEEDBACK, test_id='tÉst', epoch='fedcba9876543210')
    first = cdr.encode_feedback(FEEDBACK, 5, SIGNED)
    second = cdr.encode_feedback(other, 5, SIGNED)
    assert len(first) == len(second)
    for _ in range(3):
        assert bits(cdr.decode_feedback(first).record) == bits(FEEDBACK)
        assert bits(cdr.decode_feedback(second).record) == bits(other)


@pytest.mark.parametrize(('record', 'stamp_ns'), [
    (dataclasses.replace(COMMAND, step=2**64), 0),
    (dataclasses.replace(COMMAND, iteration=-1), 0),
    (dataclasses.replace(COMMAND, test_time='x'), 0),
    (COMMAND, 2**31 * 10**9),
    (dataclasses.replace(FEEDBACK, step=-1), 0),
    (dataclasses.replace(FEEDBACK, status=256), 0),
    (FEEDBACK, -2**31 * 10**9 - 1),
])
def test_a_learned_shape_still_refuses_what_cdr_cannot_carry(record: Any,
                                                             stamp_ns: int) -> None:
    encode = cdr.encode_command if isinstance(record, Command) else cdr.encode_feedback
    good = COMMAND if isinstance(record, Command) else FEEDBACK
    encode(good, 5, SIGNED)  # the shape is known
    encode(good, 6, SIGNED)
    with pytest.raises(cdr.CdrEncodeError, match='cannot encode'):
        encode(record, stamp_ns, SIGNED)


def test_nan_and_signed_zero_survive_a_layout() -> None:
    command = dataclasses.replace(COMMAND, target_displacement=(math.nan, -0.0))
    for stamp in (1, 2, 3):
        data = cdr.encode_command(command, stamp, SIGNED)
        assert data == rosbags_bytes(command, stamp, SIGNED)
        assert bits(cdr.decode_command(data).record) == bits(command)


def test_a_record_holding_lists_is_encoded_as_with_tuples() -> None:
    """Lists where a record holds tuples have no shape: the full encoder writes the same bytes."""
    listed = dataclasses.replace(COMMAND, dof_names=list(COMMAND.dof_names),
                                 control_mode=list(COMMAND.control_mode))
    for stamp in (1, 2):
        assert cdr.encode_command(listed, stamp, SIGNED) == cdr.encode_command(COMMAND, stamp,
                                                                               SIGNED)

"""The step protocol's messages as CDR bytes, without rclpy: the bytes that travel.

Encodes a record (:class:`~.messages.Command`, :class:`~.messages.Feedback`, ...) with its
header stamp and :class:`~.signature.Signature` into exactly the bytes rclpy's
``serialize_message`` makes of the ``pd_msgs`` message that :mod:`pd_common.ros.messages`
builds from it, and decodes such bytes into the records :mod:`.convert` makes of the message
(the same bounds, the same readings of unknown codes). The layouts are precompiled
(:class:`struct.Struct` for the fixed parts and for ``float64[]`` of each length in use: the
records hold tuples, which struct packs and unpacks 2-7 times faster than numpy converts them up
to 64 values; a numpy array in a record is written with numpy). A step command's and a step
feedback's whole layout is compiled per *shape* (their strings, array lengths and modes, the
same step after step): see :mod:`.cdr_shapes`.

The format is plain CDR (XCDR1), little-endian: a 4-byte encapsulation header
``00 01 00 00``, then the fields in the order of the ``.msg`` file. Each primitive is aligned
to its size (8 for ``float64`` and ``uint64``) relative to the first byte after the
encapsulation header; a string is a ``uint32`` byte count including a NUL terminator, its
UTF-8 bytes and the NUL; a sequence is a ``uint32`` element count and its elements (an empty
sequence of ``float64`` is not padded); a ``bool`` is one byte, 0 or 1. The header is
``int32 sec``, ``uint32 nanosec``, ``string frame_id`` (always empty here); the signature
closes every signed message: ``string key_id``, ``string session``, ``uint64 sequence``,
``uint8[] mac``. The layouts byte by byte are in ``docs/explanation/step-protocol.md``.

Bytes that are truncated, carry a count beyond what they hold, an invalid UTF-8 string, a
string without its terminator or with a NUL inside, a ``bool`` other than 0 or 1, or an
encapsulation other than little-endian CDR raise :class:`CdrDecodeError` (a
:class:`~.bounds.MalformedMessageError`, refused as ``malformed``); a field beyond its bound
(:mod:`.bounds`) raises :class:`~.bounds.MalformedMessageError` as the message conversion does.
Counts are checked against the bytes left before anything is allocated. Bytes after the
message's end are ignored, as rclpy and rosbags ignore them (rclpy's ``serialize_message``
itself leaves some at times: it sizes its buffer by an estimate). A record CDR cannot carry (an
integer out of its field's range, a string with a NUL character or a lone surrogate) raises
:class:`CdrEncodeError`.
"""

from __future__ import annotations

import functools
import struct
from collections.abc import Callable, Sequence
from typing import Any, TypeVar

import numpy as np

from . import cdr_shapes
from .bounds import MAX_ARRAY, MAX_NAME, MAX_REASON, MAX_TEXT, MalformedMessageError
from .cdr_parts import (
    ENCAPSULATION,
    FEEDBACK_STATUS,
    NS,
    PAD,
    STATE_ORIGIN,
    STEP,
    STEP_TIME,
    U32,
    CdrDecodeError,
    CdrEncodeError,
    Decoded,
    Item,
    string_bytes,
)
from .messages import (
    Command,
    Control,
    Feedback,
    FeedbackStatus,
    Offer,
    SessionStart,
    StateOrigin,
    Status,
    TestState,
)
from .signature import Signature

__all__ = [
    'ENCAPSULATION',
    'CdrDecodeError',
    'CdrEncodeError',
    'Decoded',
    'covered_part',
    'decode_command',
    'decode_control',
    'decode_feedback',
    'decode_offer',
    'decode_session_start',
    'decode_signature',
    'decode_status',
    'encode_command',
    'encode_control',
    'encode_feedback',
    'encode_offer',
    'encode_session_start',
    'encode_signature',
    'encode_status',
    'seal',
    'signed_from_bytes',
]

#: Bytes of a MAC array accepted (as :func:`~.convert.signature_from_message`).
_MAX_MAC = 64

Result = TypeVar('Result')

_UNSIGNED = Signature()

# Fixed parts, each starting at its own alignment (the comments give their fields).
_U64 = struct.Struct('<Q')
_F64 = struct.Struct('<d')
_HEADER_EMPTY_FRAME = struct.Struct('<iII')   # sec, nanosec, frame_id length 1 (then its NUL)
_TIME = struct.Struct('<iI')                  # sec, nanosec
_STATUS_COUNTS = struct.Struct('<QQdII')      # TestStatus: step .. ignored_messages
_RESTORED = struct.Struct('<QI')              # SessionOffer: restored_step, restored_iteration
_BYTE = struct.Struct('<B')

_TEST_STATE = {int(state): state for state in TestState}


# -- encoding -------------------------------------------------------------------------------
# The buffer holds the encapsulation header (4 bytes) first: alignment 4 is the same relative to
# the buffer or to the payload, alignment 8 needs (4 - len) & 7 bytes.

def _start(stamp_ns: int) -> bytearray:
    buffer = bytearray(ENCAPSULATION)
    buffer += _HEADER_EMPTY_FRAME.pack(stamp_ns // NS, stamp_ns % NS, 1)
    buffer.append(0)
    return buffer


def _put_string(buffer: bytearray, text: str) -> None:
    buffer += PAD[-len(buffer) & 3]
    buffer += string_bytes(text)


def _put_strings(buffer: bytearray, texts: Sequence[str]) -> None:
    buffer += PAD[-len(buffer) & 3]
    buffer += U32.pack(len(texts))
    for text in texts:
        _put_string(buffer, text)


@functools.lru_cache(maxsize=64)
def _doubles(count: int) -> struct.Struct:
    """The layout of ``count`` float64 (one per array length in use)."""
    return struct.Struct(f'<{count}d')


def _put_doubles(buffer: bytearray, values: Sequence[float] | np.ndarray) -> None:
    count = len(values)
    buffer += PAD[-len(buffer) & 3]
    buffer += U32.pack(count)
    if count:
        buffer += PAD[(4 - len(buffer)) & 7]
        if isinstance(values, np.ndarray):
            buffer += np.ascontiguousarray(values, dtype='<f8').tobytes()
        else:  # a tuple: struct packs it 3-4 times faster than numpy converts it
            buffer += _doubles(count).pack(*values)


def _put_octets(buffer: bytearray, values: Sequence[int] | bytes) -> None:
    buffer += PAD[-len(buffer) & 3]
    buffer += U32.pack(len(values))
    buffer += bytes(values)


def _put_aligned8(buffer: bytearray, layout: struct.Struct, *values: object) -> None:
    buffer += PAD[(4 - len(buffer)) & 7]
    buffer += layout.pack(*values)


def _put_signature(buffer: bytearray, signature: Signature) -> None:
    _put_string(buffer, signature.key_id)
    _put_string(buffer, signature.session)
    _put_aligned8(buffer, _U64, signature.sequence)
    _put_octets(buffer, signature.mac)


def _encoding(kind: str, build: Callable[[], bytearray]) -> bytes:
    try:
        return bytes(build())
    except CdrEncodeError:
        raise
    except (struct.error, UnicodeEncodeError, OverflowError, TypeError, ValueError) as err:
        msg = f'{kind}: cannot encode as CDR ({err})'
        raise CdrEncodeError(msg) from err


def encode_command(command: Command, stamp_ns: int, signature: Signature = _UNSIGNED) -> bytes:
    """The CDR bytes of the ``StepCommand`` of ``command`` stamped ``stamp_ns``.

    Raises:
        CdrEncodeError: a field cannot be carried (an integer out of range, a NUL).
    """
    def build() -> bytearray:
        buffer = _start(stamp_ns)
        _put_string(buffer, command.test_id)
        _put_aligned8(buffer, STEP_TIME, command.step, command.iteration,
                      float(command.test_time))
        _put_strings(buffer, command.dof_names)
        _put_doubles(buffer, command.target_displacement)
        _put_octets(buffer, command.control_mode)
        _put_doubles(buffer, command.target_force)
        _put_signature(buffer, signature)
        return buffer
    return cdr_shapes.encode_command(command, stamp_ns, signature,
                                     lambda: _encoding('StepCommand', build))


def encode_feedback(feedback: Feedback, stamp_ns: int,
                    signature: Signature = _UNSIGNED) -> bytes:
    """The CDR bytes of the ``StepFeedback`` of ``feedback`` stamped ``stamp_ns``.

    Raises:
        CdrEncodeError: a field cannot be carried.
    """
    def build() -> bytearray:
        buffer = _start(stamp_ns)
        _put_string(buffer, feedback.test_id)
        _put_aligned8(buffer, STEP, feedback.step, feedback.iteration)
        _put_doubles(buffer, feedback.measured_displacement)
        _put_doubles(buffer, feedback.restoring_force)
        buffer.append(int(feedback.status))
        _put_string(buffer, feedback.message)
        _put_string(buffer, feedback.epoch)
        buffer.append(int(feedback.state_origin))
        _put_signature(buffer, signature)
        return buffer
    return cdr_shapes.encode_feedback(feedback, stamp_ns, signature,
                                      lambda: _encoding('StepFeedback', build))


def encode_status(status: Status, stamp_ns: int, signature: Signature = _UNSIGNED) -> bytes:
    """The CDR bytes of the ``TestStatus`` of ``status`` stamped ``stamp_ns``.

    Raises:
        CdrEncodeError: a field cannot be carried.
    """
    def build() -> bytearray:
        buffer = _start(stamp_ns)
        _put_string(buffer, status.test_id)
        buffer.append(int(status.state))
        _put_aligned8(buffer, _STATUS_COUNTS, status.step, status.total_steps,
                      float(status.omega_dt), status.retries, status.ignored_messages)
        _put_string(buffer, status.message)
        buffer += PAD[-len(buffer) & 3]
        buffer += U32.pack(status.refused_messages)
        for text in (status.refused_by_reason, status.node, status.session):
            _put_string(buffer, text)
        buffer.append(1 if status.emergency_stop else 0)
        buffer.append(1 if status.operator_hold else 0)
        _put_string(buffer, status.acknowledged)
        _put_string(buffer, status.definition_digest)
        _put_signature(buffer, signature)
        return buffer
    return _encoding('TestStatus', build)


def encode_offer(offer: Offer, signature: Signature = _UNSIGNED) -> bytes:
    """The CDR bytes of the ``SessionOffer`` of ``offer`` (stamped ``offer.stamp_ns``).

    Raises:
        CdrEncodeError: a field cannot be carried.
    """
    def build() -> bytearray:
        buffer = _start(offer.stamp_ns)
        for text in (offer.node, offer.challenge, offer.active_session):
            _put_string(buffer, text)
        buffer.append(1 if offer.authenticated else 0)
        _put_string(buffer, offer.epoch)
        buffer.append(int(offer.state_origin))
        _put_string(buffer, offer.restored[0])
        _put_aligned8(buffer, _RESTORED, offer.restored[1], offer.restored[2])
        _put_doubles(buffer, offer.position)
        _put_doubles(buffer, offer.force)
        _put_string(buffer, offer.configuration)
        _put_signature(buffer, signature)
        return buffer
    return _encoding('SessionOffer', build)


def encode_control(control: Control, stamp_ns: int, signature: Signature = _UNSIGNED) -> bytes:
    """The CDR bytes of the ``Control`` of ``control`` stamped ``stamp_ns``.

    Raises:
        CdrEncodeError: a field cannot be carried.
    """
    def build() -> bytearray:
        buffer = _start(stamp_ns)
        for text in (control.command, control.target, control.test_id, control.session,
                     control.sender, control.reason):
            _put_string(buffer, text)
        _put_aligned8(buffer, _F64, float(control.stamp))
        _put_signature(buffer, signature)
        return buffer
    return _encoding('Control', build)


def encode_session_start(start: SessionStart, stamp_ns: int,
                         signature: Signature = _UNSIGNED) -> bytes:
    """The CDR bytes of the ``SessionStart`` of ``start`` stamped ``stamp_ns``.

    Raises:
        CdrEncodeError: a field cannot be carried.
    """
    def build() -> bytearray:
        buffer = _start(stamp_ns)
        _put_string(buffer, start.test_id)
        _put_string(buffer, start.challenge)
        _put_signature(buffer, signature)
        return buffer
    return _encoding('SessionStart', build)


def encode_signature(signature: Signature) -> bytes:
    """The CDR bytes of a ``pd_msgs/Signature`` message by itself.

    Raises:
        CdrEncodeError: a field cannot be carried.
    """
    def build() -> bytearray:
        buffer = bytearray(ENCAPSULATION)
        _put_signature(buffer, signature)
        return buffer
    return _encoding('Signature', build)


# -- decoding -------------------------------------------------------------------------------
# Positions count from the start of the bytes (the encapsulation header included), so the same
# alignment arithmetic as in encoding holds. Each reader returns its value and the next position.

#: Per character limit, the strings read already (their bytes, NUL included): a test's id,
#: DOF names, epoch, key id and session come in every message. Bounded: emptied when full.
_READ_STRINGS: dict[int, dict[bytes, str]] = {}
_READ_STRINGS_MAX = 256


def _get_string(data: bytes, pos: int, field: str, limit: int) -> tuple[str, int]:
    pos += -pos & 3
    (size,) = U32.unpack_from(data, pos)
    pos += 4
    end = pos + size
    raw = data[pos:end]
    known = _READ_STRINGS.get(limit)
    if known is None:
        known = _READ_STRINGS.setdefault(limit, {})
    text = known.get(raw)
    if text is not None and len(raw) == size:  # the same bytes passed the checks below
        return text, end
    text = _checked_string(data, pos, end, size, field, limit)
    if len(known) >= _READ_STRINGS_MAX:
        known.clear()
    known[raw] = text
    return text, end


def _checked_string(data: bytes, pos: int, end: int, size: int, field: str,
                    limit: int) -> str:
    """The string of ``size`` bytes at ``pos`` (NUL included), checked."""
    if size == 0 or end > len(data):
        msg = f'{field}: string of {size} bytes where {len(data) - pos} are left'
        raise CdrDecodeError(msg)
    if size - 1 > 4 * limit:  # more bytes than `limit` characters can take: never decoded
        msg = f'{field}: {size - 1} bytes (at most {limit} characters)'
        raise MalformedMessageError(msg)
    if data[end - 1] != 0 or data.find(b'\x00', pos, end - 1) >= 0:
        msg = f'{field}: string not terminated by its one NUL'
        raise CdrDecodeError(msg)
    text = data[pos:end - 1].decode('utf-8')
    if len(text) > limit:
        msg = f'{field}: {len(text)} characters (at most {limit})'
        raise MalformedMessageError(msg)
    return text


def _get_count(data: bytes, pos: int, field: str, size: int, limit: int) -> tuple[int, int]:
    """A sequence's count (at ``pos``, aligned 4) if ``size`` bytes per element fit."""
    pos += -pos & 3
    (count,) = U32.unpack_from(data, pos)
    pos += 4
    if count > limit:
        msg = f'{field}: {count} entries (at most {limit})'
        raise MalformedMessageError(msg)
    if count * size > len(data) - pos:
        msg = f'{field}: {count} entries where {len(data) - pos} bytes are left'
        raise CdrDecodeError(msg)
    return count, pos


def _get_strings(data: bytes, pos: int, field: str, limit: int
                 ) -> tuple[tuple[str, ...], int]:
    count, pos = _get_count(data, pos, field, 5, MAX_ARRAY)  # a string takes >= 5 bytes
    texts = []
    for _ in range(count):
        text, pos = _get_string(data, pos, field, limit)
        texts.append(text)
    return tuple(texts), pos


def _get_doubles(data: bytes, pos: int, field: str) -> tuple[tuple[float, ...], int]:
    count, pos = _get_count(data, pos, field, 8, MAX_ARRAY)
    if not count:
        return (), pos
    pos += (4 - pos) & 7
    end = pos + 8 * count
    if end > len(data):
        msg = f'{field}: {count} float64 where {len(data) - pos} bytes are left'
        raise CdrDecodeError(msg)
    return _doubles(count).unpack_from(data, pos), end


def _get_octets(data: bytes, pos: int, field: str, limit: int) -> tuple[bytes, int]:
    count, pos = _get_count(data, pos, field, 1, limit)
    return data[pos:pos + count], pos + count


def _get_byte(data: bytes, pos: int) -> int:
    if pos >= len(data):
        msg = 'message: truncated'
        raise CdrDecodeError(msg)
    return data[pos]


def _get_bool(data: bytes, pos: int, field: str) -> bool:
    value = _get_byte(data, pos)
    if value > 1:
        msg = f'{field}: bool byte {value} (0 or 1)'
        raise CdrDecodeError(msg)
    return value == 1


def _get_aligned8(data: bytes, pos: int, layout: struct.Struct) -> tuple[tuple[Any, ...], int]:
    pos += (4 - pos) & 7
    return layout.unpack_from(data, pos), pos + layout.size


def _get_header(data: bytes) -> tuple[int, int]:
    """The header stamp (ns) and the position after the header."""
    if data[:2] != ENCAPSULATION[:2]:
        msg = f'encapsulation: {bytes(data[:4]).hex()} is not little-endian plain CDR (0001....)'
        raise CdrDecodeError(msg)
    sec, nanosec = _TIME.unpack_from(data, 4)
    _, pos = _get_string(data, 12, 'header.frame_id', MAX_NAME)
    return sec * NS + nanosec, pos


def _get_signature(data: bytes, pos: int) -> tuple[Signature, int]:
    key_id, pos = _get_string(data, pos, 'signature.key_id', MAX_NAME)
    session, pos = _get_string(data, pos, 'signature.session', MAX_NAME)
    (sequence,), pos = _get_aligned8(data, pos, _U64)
    mac, _ = _get_octets(data, pos, 'signature.mac', _MAX_MAC)
    # (the position of the MAC's count: where the bytes a MAC covers end)
    return Signature(key_id=key_id, session=session, sequence=int(sequence), mac=mac), pos


def _decoding(kind: str, data: bytes, parse: Callable[[bytes], Result]) -> Result:
    try:
        return parse(data)
    except (struct.error, UnicodeDecodeError, IndexError) as err:
        msg = f'{kind}: malformed CDR ({err})'
        raise CdrDecodeError(msg) from err


def _parse_command(data: bytes) -> Decoded[Command]:
    stamp_ns, pos = _get_header(data)
    test_id, pos = _get_string(data, pos, 'test_id', MAX_NAME)
    (step, iteration, test_time), pos = _get_aligned8(data, pos, STEP_TIME)
    dof_names, pos = _get_strings(data, pos, 'dof_names', MAX_NAME)
    displacement, pos = _get_doubles(data, pos, 'target_displacement')
    modes, pos = _get_octets(data, pos, 'control_mode', MAX_ARRAY)
    force, pos = _get_doubles(data, pos, 'target_force')
    signature, signed_end = _get_signature(data, pos)
    command = Command(test_id=test_id, step=int(step),
                      test_time=float(test_time),
                      dof_names=dof_names, target_displacement=displacement,
                      iteration=int(iteration),
                      control_mode=tuple(modes), target_force=force)
    return Decoded(command, stamp_ns, signature, data[:signed_end])


def decode_command(data: bytes) -> Decoded[Command]:
    """The :class:`Command`, stamp and signature of ``StepCommand`` CDR bytes.

    Raises:
        MalformedMessageError: the bytes are malformed (:class:`CdrDecodeError`) or a field is
            beyond its bound.
    """
    return cdr_shapes.decode_command(
        data, lambda raw: _decoding('StepCommand', raw, _parse_command))


def _parse_feedback(data: bytes) -> Decoded[Feedback]:
    stamp_ns, pos = _get_header(data)
    test_id, pos = _get_string(data, pos, 'test_id', MAX_NAME)
    (step, iteration), pos = _get_aligned8(data, pos, STEP)
    displacement, pos = _get_doubles(data, pos, 'measured_displacement')
    force, pos = _get_doubles(data, pos, 'restoring_force')
    status = FEEDBACK_STATUS.get(_get_byte(data, pos), FeedbackStatus.FAULT)
    message, pos = _get_string(data, pos + 1, 'message', MAX_TEXT)
    epoch, pos = _get_string(data, pos, 'epoch', MAX_NAME)
    origin = STATE_ORIGIN.get(_get_byte(data, pos), StateOrigin.FRESH)
    signature, signed_end = _get_signature(data, pos + 1)
    feedback = Feedback(test_id=test_id, step=int(step),
                        measured_displacement=displacement, restoring_force=force,
                        status=status, message=message,
                        iteration=int(iteration),
                        epoch=epoch, state_origin=origin)
    return Decoded(feedback, stamp_ns, signature, data[:signed_end])


def decode_feedback(data: bytes) -> Decoded[Feedback]:
    """The :class:`Feedback`, stamp and signature of ``StepFeedback`` CDR bytes.

    An unknown status reads as a fault, an unknown state origin as fresh (as
    :func:`~.convert.feedback_from_message`).

    Raises:
        MalformedMessageError: the bytes are malformed (:class:`CdrDecodeError`) or a field is
            beyond its bound.
    """
    return cdr_shapes.decode_feedback(
        data, lambda raw: _decoding('StepFeedback', raw, _parse_feedback))


def _parse_status(data: bytes) -> Decoded[Status]:
    stamp_ns, pos = _get_header(data)
    test_id, pos = _get_string(data, pos, 'test_id', MAX_NAME)
    state = _TEST_STATE.get(_get_byte(data, pos), TestState.IDLE)
    counts, pos = _get_aligned8(data, pos + 1, _STATUS_COUNTS)
    message, pos = _get_string(data, pos, 'message', MAX_TEXT)
    pos += -pos & 3
    (refused,) = U32.unpack_from(data, pos)
    refused_by_reason, pos = _get_string(data, pos + 4, 'refused_by_reason', MAX_TEXT)
    node, pos = _get_string(data, pos, 'node', MAX_NAME)
    session, pos = _get_string(data, pos, 'session', MAX_NAME)
    emergency_stop = _get_bool(data, pos, 'emergency_stop')
    operator_hold = _get_bool(data, pos + 1, 'operator_hold')
    acknowledged, pos = _get_string(data, pos + 2, 'acknowledged', MAX_TEXT)
    digest, pos = _get_string(data, pos, 'definition_digest', MAX_NAME)
    signature, signed_end = _get_signature(data, pos)
    step, total_steps, omega_dt, retries, ignored = counts
    status = Status(test_id=test_id, state=state, step=int(step),
                    total_steps=int(total_steps),
                    omega_dt=float(omega_dt),
                    retries=int(retries),
                    ignored_messages=int(ignored),
                    message=message, refused_messages=int(refused),
                    refused_by_reason=refused_by_reason, node=node, session=session,
                    emergency_stop=emergency_stop, operator_hold=operator_hold,
                    acknowledged=acknowledged, definition_digest=digest)
    return Decoded(status, stamp_ns, signature, data[:signed_end])


def decode_status(data: bytes) -> Decoded[Status]:
    """The :class:`Status`, stamp and signature of ``TestStatus`` CDR bytes.

    An unknown state reads as idle (as :func:`~.convert.status_from_message`).

    Raises:
        MalformedMessageError: the bytes are malformed (:class:`CdrDecodeError`) or a field is
            beyond its bound.
    """
    return _decoding('TestStatus', data, _parse_status)


def _parse_offer(data: bytes) -> Decoded[Offer]:
    stamp_ns, pos = _get_header(data)
    node, pos = _get_string(data, pos, 'node', MAX_NAME)
    challenge, pos = _get_string(data, pos, 'challenge', MAX_NAME)
    active_session, pos = _get_string(data, pos, 'active_session', MAX_NAME)
    authenticated = _get_bool(data, pos, 'authenticated')
    epoch, pos = _get_string(data, pos + 1, 'epoch', MAX_NAME)
    origin = _get_byte(data, pos)
    restored_test_id, pos = _get_string(data, pos + 1, 'restored_test_id', MAX_NAME)
    (restored_step, restored_iteration), pos = _get_aligned8(data, pos, _RESTORED)
    position, pos = _get_doubles(data, pos, 'position')
    force, pos = _get_doubles(data, pos, 'force')
    configuration, pos = _get_string(data, pos, 'configuration', MAX_TEXT)
    signature, signed_end = _get_signature(data, pos)
    offer = Offer(stamp_ns=stamp_ns, node=node, challenge=challenge,
                  active_session=active_session, authenticated=authenticated, epoch=epoch,
                  state_origin=origin,
                  restored=(restored_test_id, int(restored_step),
                            int(restored_iteration)),
                  position=position, force=force, configuration=configuration)
    return Decoded(offer, stamp_ns, signature, data[:signed_end])


def decode_offer(data: bytes) -> Decoded[Offer]:
    """The :class:`Offer` (its stamp in it too) and signature of ``SessionOffer`` CDR bytes.

    Raises:
        MalformedMessageError: the bytes are malformed (:class:`CdrDecodeError`) or a field is
            beyond its bound.
    """
    return _decoding('SessionOffer', data, _parse_offer)


def _parse_control(data: bytes) -> Decoded[Control]:
    stamp_ns, pos = _get_header(data)
    texts = []
    for field in ('command', 'target', 'test_id', 'session', 'sender'):
        text, pos = _get_string(data, pos, field, MAX_NAME)
        texts.append(text)
    reason, pos = _get_string(data, pos, 'reason', MAX_REASON)
    (stamp,), pos = _get_aligned8(data, pos, _F64)
    signature, signed_end = _get_signature(data, pos)
    command, target, test_id, session, sender = texts
    control = Control(command=command, target=target, reason=reason,
                      stamp=float(stamp),
                      test_id=test_id, session=session, sender=sender)
    return Decoded(control, stamp_ns, signature, data[:signed_end])


def decode_control(data: bytes) -> Decoded[Control]:
    """The :class:`Control`, stamp and signature of ``Control`` CDR bytes.

    Raises:
        MalformedMessageError: the bytes are malformed (:class:`CdrDecodeError`) or a field is
            beyond its bound.
    """
    return _decoding('Control', data, _parse_control)


def _parse_session_start(data: bytes) -> Decoded[SessionStart]:
    stamp_ns, pos = _get_header(data)
    test_id, pos = _get_string(data, pos, 'test_id', MAX_NAME)
    challenge, pos = _get_string(data, pos, 'challenge', MAX_NAME)
    signature, signed_end = _get_signature(data, pos)
    return Decoded(SessionStart(test_id=test_id, challenge=challenge), stamp_ns, signature,
                   data[:signed_end])


def decode_session_start(data: bytes) -> Decoded[SessionStart]:
    """The :class:`SessionStart`, stamp and signature of ``SessionStart`` CDR bytes.

    Raises:
        MalformedMessageError: the bytes are malformed (:class:`CdrDecodeError`) or a field is
            beyond its bound.
    """
    return _decoding('SessionStart', data, _parse_session_start)


def _parse_signature(data: bytes) -> Signature:
    if data[:2] != ENCAPSULATION[:2]:
        msg = f'encapsulation: {bytes(data[:4]).hex()} is not little-endian plain CDR (0001....)'
        raise CdrDecodeError(msg)
    signature, _ = _get_signature(data, 4)
    return signature


def decode_signature(data: bytes) -> Signature:
    """The :class:`Signature` of ``pd_msgs/Signature`` CDR bytes (a message by itself).

    Raises:
        MalformedMessageError: the bytes are malformed (:class:`CdrDecodeError`) or a field is
            beyond its bound.
    """
    return _decoding('Signature', data, _parse_signature)


_EMPTY_MAC = U32.pack(0)


def covered_part(unsigned: bytes) -> bytes:
    """The bytes a MAC covers of a message encoded with an empty MAC.

    Everything but the empty MAC's count (the last four bytes): the encapsulation header, the
    header stamp, every field, and the signature's key id, session and sequence. A decoded
    message's :attr:`Decoded.covered` is the same part of the bytes that arrived.

    Raises:
        CdrEncodeError: the bytes do not end with an empty MAC.
    """
    if unsigned[-4:] != _EMPTY_MAC:
        msg = 'a message to sign must be encoded with an empty MAC'
        raise CdrEncodeError(msg)
    return unsigned[:-4]


def seal(covered: bytes, mac: bytes) -> bytes:
    """The whole message: its covered part (:func:`covered_part`) closed by ``mac``."""
    return b''.join((covered, U32.pack(len(mac)), mac))


def signed_from_bytes(decode: Callable[[bytes], Decoded[Item]], data: bytes
                      ) -> Decoded[Item] | None:
    """A signed message read from its CDR bytes (``decode(data)``).

    Its record, stamp, signature and the bytes its MAC covers.

    Or ``None`` when the bytes are malformed or a field is beyond its bound: what
    :func:`~.convert.signed_from_message` answers for the message rclpy would have made of them
    (a raw subscription's reading of a hot topic).
    """
    try:
        return decode(data)
    except MalformedMessageError:
        return None

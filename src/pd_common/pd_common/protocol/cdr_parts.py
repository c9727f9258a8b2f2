"""The CDR format's parts shared by the codec and its compiled layouts.

The encapsulation, padding, fixed layouts, strings and codes that :mod:`.cdr` and
:mod:`.cdr_shapes` both use.
"""

from __future__ import annotations

import functools
import struct
from typing import Generic, NamedTuple, TypeVar

from .bounds import MalformedMessageError
from .messages import FeedbackStatus, StateOrigin
from .signature import Signature

__all__ = ['ENCAPSULATION', 'FEEDBACK_STATUS', 'NS', 'PAD', 'STATE_ORIGIN', 'STEP', 'STEP_TIME',
           'U32', 'CdrDecodeError', 'CdrEncodeError', 'Decoded', 'string_bytes']

#: The encapsulation header of plain CDR, little-endian (what rclpy writes).
ENCAPSULATION = b'\x00\x01\x00\x00'
NS = 1_000_000_000
PAD = tuple(bytes(size) for size in range(8))  #: alignment padding of 0..7 bytes
U32 = struct.Struct('<I')
STEP_TIME = struct.Struct('<QI4xd')  #: StepCommand: step, iteration, test_time
STEP = struct.Struct('<QI')          #: StepFeedback: step, iteration

#: A status and a state origin by their codes.
FEEDBACK_STATUS = {int(status): status for status in FeedbackStatus}
STATE_ORIGIN = {int(origin): origin for origin in StateOrigin}

Item = TypeVar('Item')


class CdrEncodeError(ValueError):
    """A record holds a value its CDR field cannot carry (out of range, a NUL, a surrogate)."""


class CdrDecodeError(MalformedMessageError):
    """Bytes that are not a well-formed CDR message of the expected type."""


class Decoded(NamedTuple, Generic[Item]):
    """A decoded message: its record, its header stamp, its signature and the signed bytes.

    Attributes:
        record: the protocol's record (as :mod:`.convert` makes it of the message).
        stamp_ns: the header stamp, ns since the epoch.
        signature: the message's signature (unsigned: an empty key id and MAC).
        covered: the bytes a MAC over the message covers (:func:`~.cdr.covered_part`): from
            the first byte through the signature's ``sequence``, as they arrived.
    """

    record: Item
    stamp_ns: int
    signature: Signature
    covered: bytes = b''


@functools.lru_cache(maxsize=256)
def string_bytes(text: str) -> bytes:
    """A string's CDR bytes after its alignment: length (NUL included), UTF-8, NUL.

    Cached: a test's id, DOF names, epoch, key id and session are in every message.

    Raises:
        CdrEncodeError: the text holds a NUL character.
    """
    data = text.encode('utf-8')
    if b'\x00' in data:
        msg = f'a string holds a NUL character, which CDR cannot carry: {text[:40]!r}'
        raise CdrEncodeError(msg)
    return U32.pack(len(data) + 1) + data + b'\x00'

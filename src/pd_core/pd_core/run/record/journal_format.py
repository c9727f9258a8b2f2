r"""The journal's file format: length-prefixed records, each with a CRC-32, after a header.

A journal (``journal.pdj``) is a 16-byte header and the records one after another, nothing
between them (all integers little-endian):

========  ======  ==============================================================================
offset    size    content
========  ======  ==============================================================================
0         8       magic ``89 50 44 4A 0D 0A 1A 0A`` (``\x89PDJ\r\n\x1a\n``)
8         4       format version (u32): :data:`VERSION`
12        4       0 (u32, reserved)
========  ======  ==============================================================================

Each record:

========  ======  ==============================================================================
offset    size    content
========  ======  ==============================================================================
0         4       ``L``: the length of the body (u32), at least 12
4         4       CRC-32 of the body (u32; ``zlib.crc32``: ISO-HDLC, as gzip and PNG)
8         1       kind (u8; :class:`RecordKind`)
9         1       0 (reserved)
10        2       ``T``: the length of the topic (u16)
12        8       the record's time [ns since the epoch] (i64): the bag's log time
20        T       the topic (UTF-8; empty for a definition or an event)
20 + T    L-12-T  the payload
========  ======  ==============================================================================

Payloads: a definition and an event are UTF-8 JSON text (the test definition; an event's
object with its ``what``); a command, a feedback, a status and a raw record are the CDR bytes
of the topic's message (``pd_msgs/msg/StepCommand``, ``StepFeedback``, ``TestStatus``,
``ActuatorTrajectory``), with their 4-byte encapsulation header: for a step message, the
bytes that travelled, signature included.

Only the end of a journal can be torn (a process killed mid-write, a power loss that left
the file's last blocks unwritten or zero-filled): a last record short of its length, or whose
CRC fails with nothing (or only zero bytes) after it, is ignored and reported; a damaged
record with records after it is an error naming its offset.
"""

from __future__ import annotations

import struct
import zlib
from collections.abc import Iterator
from enum import IntEnum
from pathlib import Path
from typing import BinaryIO, NamedTuple

from pd_common.config import open_regular_file

from ...errors import BagError

__all__ = ['HEADER', 'MAGIC', 'MAX_RECORD_BYTES', 'VERSION', 'Frame', 'RecordKind', 'frame',
           'iter_frames', 'records_end']

MAGIC = b'\x89PDJ\r\n\x1a\n'
VERSION = 2
_HEADER = struct.Struct('<8sII')
HEADER = _HEADER.pack(MAGIC, VERSION, 0)
_PREFIX = struct.Struct('<II')     # body length, CRC-32 of the body
_BODY = struct.Struct('<BxHq')     # kind, reserved, topic length, t_ns
#: The longest record read back (the definition's record holds the whole test, inlined: a few
#: MB for the longest; a longer one is no record of this project's).
MAX_RECORD_BYTES = 256 * 2**20
_ZERO_CHUNK = 1 << 20


class RecordKind(IntEnum):
    """What a record holds."""

    DEFINITION = 1  #: the resolved test definition (JSON)
    COMMAND = 2     #: a step command sent (CDR)
    FEEDBACK = 3    #: a step feedback received (CDR)
    STATUS = 4      #: a status (CDR)
    RAW = 5         #: another serialised message of the topic (CDR)
    EVENT = 6       #: an event of the run (JSON object)


_KINDS = {int(kind): kind for kind in RecordKind}


class Frame(NamedTuple):
    """One record as it is on disk."""

    kind: RecordKind
    t_ns: int
    topic: str
    payload: bytes
    offset: int  #: of the record in the file
    end: int     #: the byte after it
    number: int  #: 1 for the first record


def frame(kind: RecordKind, t_ns: int, topic: bytes, payload: bytes) -> bytes:
    """One record's bytes (``topic``: UTF-8, at most 65,535 bytes)."""
    body = _BODY.pack(kind, len(topic), t_ns) + topic + payload
    return _PREFIX.pack(len(body), zlib.crc32(body)) + body


def _only_zeros(file: BinaryIO) -> bool:
    """Whether the file holds nothing but zero bytes from where it stands."""
    while chunk := file.read(_ZERO_CHUNK):
        if chunk.count(0) != len(chunk):
            return False
    return True


def iter_frames(path: str | Path, notes: list[str] | None = None) -> Iterator[Frame]:
    """A journal's complete records, in order (a torn last one described in ``notes``).

    Raises:
        BagError: the file cannot be read, is not a journal, or has a damaged record before
            its end.
    """
    path = Path(path)
    try:
        with open_regular_file(path) as file:
            yield from _frames(file, path, notes)
    except OSError as err:
        msg = f'{path}: cannot read the journal ({err.strerror or type(err).__name__})'
        raise BagError(msg) from None


def _frames(file: BinaryIO, path: Path, notes: list[str] | None) -> Iterator[Frame]:
    read = file.read
    head = read(_HEADER.size)
    if len(head) < _HEADER.size and HEADER.startswith(head):
        if head and notes is not None:  # killed while it wrote its header
            notes.append(f'ignored the header of {path.name}, cut short ({len(head)} bytes)')
        return
    magic, version, _ = _HEADER.unpack(head) if len(head) == _HEADER.size else (b'', 0, 0)
    if magic != MAGIC:
        what = ('a JSON-lines journal of an earlier version' if head.startswith(b'{')
                else 'no journal header')
        msg = f'{path}: not a journal of this version ({what})'
        raise BagError(msg)
    if version != VERSION:
        msg = f'{path}: journal format version {version}; this version reads {VERSION}'
        raise BagError(msg)
    offset = _HEADER.size
    number = 0
    topics: dict[bytes, str] = {}
    while prefix := read(_PREFIX.size):
        number += 1
        fault = ''
        body = b''
        if len(prefix) < _PREFIX.size:
            fault = 'cut short'
        else:
            length, crc = _PREFIX.unpack(prefix)
            if length < _BODY.size or length > MAX_RECORD_BYTES:
                fault = f'a length of {length} bytes'
            else:
                body = read(length)
                if len(body) < length:
                    fault = 'cut short'
                elif zlib.crc32(body) != crc:
                    fault = 'CRC mismatch'
        if fault:
            if fault == 'cut short' or _only_zeros(file):
                if notes is not None:
                    notes.append(f'ignored the last record of {path.name}, {fault} (byte '
                                 f'{offset}: {len(prefix) + len(body)} bytes)')
                return
            msg = f'{path}: record {number} at byte {offset}: damaged ({fault})'
            raise BagError(msg)
        kind_code, topic_length, t_ns = _BODY.unpack_from(body)
        kind = _KINDS.get(kind_code)
        end = _BODY.size + topic_length
        if kind is None or end > len(body):
            what = f'kind {kind_code}' if kind is None else f'a topic of {topic_length} bytes'
            msg = f'{path}: record {number} at byte {offset}: malformed ({what})'
            raise BagError(msg)
        raw_topic = body[_BODY.size:end]
        topic = topics.get(raw_topic)
        if topic is None:
            try:
                topic = topics[raw_topic] = raw_topic.decode('utf-8')
            except UnicodeDecodeError:
                msg = f'{path}: record {number} at byte {offset}: malformed (topic not UTF-8)'
                raise BagError(msg) from None
        following = offset + _PREFIX.size + len(body)
        yield Frame(kind, t_ns, topic, body[end:], offset, following, number)
        offset = following


def records_end(path: str | Path, notes: list[str] | None = None) -> int:
    """The byte after a journal's last complete record (0: not even its header is complete).

    Raises:
        BagError: as :func:`iter_frames`.
    """
    end = 0
    for record in iter_frames(path, notes):
        end = record.end
    if end:
        return end
    try:
        with open_regular_file(Path(path)) as file:  # no record: the header alone, if whole
            return _HEADER.size if file.read(_HEADER.size) == HEADER else 0
    except OSError as err:
        msg = f'{path}: cannot read the journal ({err.strerror or type(err).__name__})'
        raise BagError(msg) from None

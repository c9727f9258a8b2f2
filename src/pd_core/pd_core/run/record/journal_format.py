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

__all__ = ['HEADER', 'MAGIC', 'MAX_RECORD_BYTES', 'VERSION', 'Block', 'Frame', 'RecordKind',
           'frame', 'iter_blocks', 'iter_frames', 'records_end']

MAGIC = b'\x89PDJ\r\n\x1a\n'
#: 3: a status's CDR carries ``definition_digest`` (a version-2 journal's statuses have not, so
#: this version refuses it in one line rather than misread them).
VERSION = 3
_HEADER = struct.Struct('<8sII')
HEADER = _HEADER.pack(MAGIC, VERSION, 0)
_PREFIX = struct.Struct('<II')     # body length, CRC-32 of the body
_BODY = struct.Struct('<BxHq')     # kind, reserved, topic length, t_ns
#: The longest record read back (the definition's record holds the whole test, inlined: a few
#: MB for the longest; a longer one is no record of this project's).
MAX_RECORD_BYTES = 256 * 2**20
_ZERO_CHUNK = 1 << 20
_BLOCK = 1 << 20  # read at a time


class RecordKind(IntEnum):
    """What a record holds."""

    DEFINITION = 1  #: the resolved test definition (JSON)
    COMMAND = 2     #: a step command sent (CDR)
    FEEDBACK = 3    #: a step feedback received (CDR)
    STATUS = 4      #: a status (CDR)
    RAW = 5         #: another serialised message of the topic (CDR)
    EVENT = 6       #: an event of the run (JSON object)


_BY_CODE = {int(kind): kind for kind in RecordKind}
_KIND_CODES: tuple[RecordKind | None, ...] = tuple(_BY_CODE.get(code) for code in range(256))
_FIXED = _PREFIX.size + _BODY.size  # bytes before a record's topic
_HEAD = struct.Struct('<IIBxHq')  # the prefix and the body's fixed fields, read at once


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


class Block(NamedTuple):
    """Records read at once, each whole, CRC-checked and of a known kind.

    Each of ``records`` is ``(start, end, kind, t_ns, topic, payload)``: the record is
    ``data[start:end]`` and its payload ``data[payload:end]``; the first is record ``number`` of
    the journal, and ``data[0]`` is byte ``base`` of the file.
    """

    data: bytes
    base: int
    number: int
    records: list[tuple[int, int, RecordKind, int, str, int]]


def iter_frames(path: str | Path, notes: list[str] | None = None) -> Iterator[Frame]:
    """A journal's complete records, in order (a torn last one described in ``notes``).

    Raises:
        BagError: the file cannot be read, is not a journal, or has a damaged record before
            its end.
    """
    new = tuple.__new__  # a NamedTuple's own __new__ is a Python function
    for data, base, number, records in iter_blocks(path, notes):
        for start, end, kind, t_ns, topic, payload in records:
            yield new(Frame, (kind, t_ns, topic, data[payload:end], base + start, base + end,
                              number))
            number += 1


def iter_blocks(path: str | Path, notes: list[str] | None = None) -> Iterator[Block]:
    """A journal's complete records, in order, a block at a time (see :func:`iter_frames`).

    What copies many records (the bag written from a journal) reads them so: a record costs
    it no object of its own.

    Raises:
        BagError: as :func:`iter_frames`.
    """
    path = Path(path)
    try:
        with open_regular_file(path) as file:
            yield from _blocks(file, path, notes)
    except OSError as err:
        msg = f'{path}: cannot read the journal ({err.strerror or type(err).__name__})'
        raise BagError(msg) from None


def _blocks(file: BinaryIO, path: Path, notes: list[str] | None) -> Iterator[Block]:
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
    yield from _records(file, path, notes)


def _records(file: BinaryIO, path: Path, notes: list[str] | None) -> Iterator[Block]:
    """The records after the header, read a block at a time.

    The loop is the reading's cost: what is rare (a block's end, a fault, a new topic) is out
    of its way, and a record's number is counted only when one is named (the block's first
    plus the records before it). A block's records are handed on before anything wrong after
    them is reported.
    """
    read = file.read
    unpack_head = _HEAD.unpack_from
    crc32 = zlib.crc32
    kinds = _KIND_CODES
    topics: dict[bytes, str] = {}
    prefix, smallest, largest, fixed = _PREFIX.size, _BODY.size, MAX_RECORD_BYTES, _FIXED
    base = _HEADER.size  # the file offset of buf[0]
    buf = b''
    view = memoryview(buf)
    size = pos = 0
    block = Block(buf, base, 1, [])
    records = block.records
    add = records.append
    while True:
        if size - pos >= fixed:  # (no record is shorter)
            length, crc, kind_code, topic_length, t_ns = unpack_head(buf, pos)
            end = pos + prefix + length
        else:
            length = end = -1
        if end > size or length < smallest or length > largest:
            # a block's end, or a fault: hand on the block's records, read on, look again
            number = block.number + len(records)
            if records:
                yield block
            if size - pos >= prefix:
                length, _ = _PREFIX.unpack_from(buf, pos)
            missing = prefix + length - (size - pos) if smallest <= length <= largest else 0
            base += pos
            buf = buf[pos:] + read(max(_BLOCK, missing))
            view = memoryview(buf)
            size = len(buf)
            pos = 0
            block = Block(buf, base, number, [])
            records = block.records
            add = records.append
            if not buf:
                return
            if _fault(buf, file, path, base, number, notes):
                return
            length, crc, kind_code, topic_length, t_ns = unpack_head(buf, pos)
            end = prefix + length
        if crc32(view[pos + prefix:end]) != crc:
            number = block.number + len(records)
            if records:
                yield block
            _torn_or_damaged('CRC mismatch', end - pos, buf[end:], file, path, base + pos,
                             number, notes)
            return
        payload_start = pos + fixed + topic_length
        topic = topics.get(buf[pos + fixed:payload_start])
        kind = kinds[kind_code]
        if topic is None or kind is None or payload_start > end:
            number = block.number + len(records)
            if records:  # (the records before a malformed one are handed on first)
                yield block
                block = Block(buf, base, number, [])
                records = block.records
                add = records.append
            kind, topic = _kind_and_topic(buf, pos, topics, f'{path}: record {number} at '
                                                            f'byte {base + pos}: malformed')
        add((pos, end, kind, t_ns, topic, payload_start))
        pos = end


def _fault(buf: bytes, file: BinaryIO, path: Path, offset: int, number: int,
           notes: list[str] | None) -> bool:
    """Whether the record at the start of ``buf`` is torn or damaged (a torn one noted).

    ``buf`` holds all that is left of the file if the record is cut short.

    Raises:
        BagError: the record is damaged and not the journal's last.
    """
    if len(buf) >= _PREFIX.size:
        length, _ = _PREFIX.unpack_from(buf)
        if length < _BODY.size or length > MAX_RECORD_BYTES:
            _torn_or_damaged(f'a length of {length} bytes', _PREFIX.size, buf[_PREFIX.size:],
                             file, path, offset, number, notes)
            return True
        if len(buf) >= _PREFIX.size + length:
            return False
    _torn_or_damaged('cut short', len(buf), b'', file, path, offset, number, notes)
    return True


def _torn_or_damaged(what: str, size: int, after: bytes, file: BinaryIO, path: Path,
                     offset: int, number: int, notes: list[str] | None) -> None:
    """Note a torn end, or raise for a damaged record.

    A record cut short, or with nothing but zero bytes after it (``after``, then the rest of
    ``file``) is a torn end, reported in ``notes``; another is damaged.

    Raises:
        BagError: the record is damaged.
    """
    if what == 'cut short' or (after.count(0) == len(after) and _only_zeros(file)):
        if notes is not None:
            notes.append(f'ignored the last record of {path.name}, {what} (byte {offset}: '
                         f'{size} bytes)')
        return
    msg = f'{path}: record {number} at byte {offset}: damaged ({what})'
    raise BagError(msg)


def _kind_and_topic(buf: bytes, pos: int, topics: dict[bytes, str],
                    malformed: str) -> tuple[RecordKind, str]:
    """The kind and topic of the (whole, CRC-checked) record at ``pos``.

    A new topic is decoded and remembered in ``topics``.

    Raises:
        BagError: an unknown kind, a topic longer than the record, or not UTF-8.
    """
    length, _ = _PREFIX.unpack_from(buf, pos)
    kind_code, topic_length, _ = _BODY.unpack_from(buf, pos + _PREFIX.size)
    kind = _KIND_CODES[kind_code]
    if kind is None or _BODY.size + topic_length > length:
        what = f'kind {kind_code}' if kind is None else f'a topic of {topic_length} bytes'
        msg = f'{malformed} ({what})'
        raise BagError(msg)
    raw = buf[pos + _FIXED:pos + _FIXED + topic_length]
    try:
        topic = topics[raw] = raw.decode('utf-8')
    except UnicodeDecodeError:
        msg = f'{malformed} (topic not UTF-8)'
        raise BagError(msg) from None
    return kind, topic


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

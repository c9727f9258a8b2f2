"""A run's journal read and cut by its documented layout (``docs/reference/run-folder.md``).

Independent of :mod:`pd_core.run.record.journal_format`: the tests check the journal the
integrator writes against the documentation, and make the journals a crash leaves.
"""

from __future__ import annotations

import struct
import zlib
from pathlib import Path
from typing import Any, NamedTuple

from pd_common.protocol import FeedbackStatus, decode_command, decode_feedback, decode_status

MAGIC = b'\x89PDJ\r\n\x1a\n'
HEADER = MAGIC + struct.pack('<II', 3, 0)
KIND_NAMES = {1: 'def', 2: 'cmd', 3: 'fb', 4: 'st', 5: 'raw', 6: 'ev'}
_DECODE = {'cmd': decode_command, 'fb': decode_feedback, 'st': decode_status}


class Record(NamedTuple):
    """One record: ``kind`` (``def``, ``cmd``, ...), time, topic, payload, its bytes' span."""

    kind: str
    t_ns: int
    topic: str
    payload: bytes
    offset: int
    end: int

    @property
    def item(self) -> Any:
        """A command's, feedback's or status's record (the codec's), else the payload."""
        decode = _DECODE.get(self.kind)
        return self.payload if decode is None else decode(self.payload).record


def records(path: Path, *, torn_end: bool = False) -> list[Record]:
    """A journal's records, each CRC checked.

    ``torn_end``: a journal being written or a crash left (an incomplete last record is
    left out); else the whole file must be records.
    """
    data = path.read_bytes()
    if torn_end and len(data) < len(HEADER):
        return []
    assert data[:len(HEADER)] == HEADER, f'{path}: no journal header'
    out = []
    offset = len(HEADER)
    while offset < len(data):
        if torn_end and offset + 8 > len(data):
            break
        length, crc = struct.unpack_from('<II', data, offset)
        body = data[offset + 8:offset + 8 + length]
        if torn_end and (len(body) < length or zlib.crc32(body) != crc):
            break
        assert len(body) == length and length >= 12, f'{path}: record at {offset} cut short'
        assert zlib.crc32(body) == crc, f'{path}: record at {offset}: CRC'
        kind, reserved, topic_length, t_ns = struct.unpack_from('<BBHq', body)
        assert reserved == 0
        topic = body[12:12 + topic_length].decode('utf-8')
        end = offset + 8 + length
        out.append(Record(KIND_NAMES[kind], t_ns, topic, body[12 + topic_length:], offset, end))
        offset = end
    return out


def committed_steps(path: Path, *, ok_only: bool = False) -> int:
    """Feedback records in a journal so far (``ok_only``: those with an OK status), as a
    crash would leave it (0 with no journal yet)."""
    try:
        found = [record for record in records(path, torn_end=True) if record.kind == 'fb']
    except OSError:
        return 0
    if ok_only:
        return sum(record.item.status is FeedbackStatus.OK for record in found)
    return len(found)


def cut(source: Path, target: Path, keep: int, partial: int = 0) -> None:
    """``target``: the header and first ``keep`` records of ``source``, then ``partial``
    bytes of the next record (a record a crash tore)."""
    data = source.read_bytes()
    kept = records(source)
    end = kept[keep - 1].end if keep else len(HEADER)
    target.write_bytes(data[:end] + data[end:end + partial])


def frame(kind: int, t_ns: int, topic: bytes, payload: bytes) -> bytes:
    """One record's bytes, by the documented layout."""
    body = struct.pack('<BBHq', kind, 0, len(topic), t_ns) + topic + payload
    return struct.pack('<II', len(body), zlib.crc32(body)) + body


def write(target: Path, kept: list[Record]) -> None:
    """A journal of ``kept`` (records of another, some perhaps altered), by the layout."""
    codes = {name: code for code, name in KIND_NAMES.items()}
    target.write_bytes(HEADER + b''.join(
        frame(codes[record.kind], record.t_ns, record.topic.encode('utf-8'), record.payload)
        for record in kept))

"""Writing a rosbag2 bag: one MCAP file and its ``metadata.yaml``, messages as given bytes.

A bag is a folder ``<name>/`` holding ``<name>.mcap`` and ``metadata.yaml`` (rosbag2 format
version 9, the ``mcap`` storage), as ``ros2 bag record`` and ``rosbags`` write it. The MCAP file
(`specification <https://mcap.dev/spec>`_, profile ``ros2``) holds the header, every schema and
channel, the messages in uncompressed chunks of about 1 MiB, each followed by its message
indexes, then the summary: schemas, channels, chunk indexes, the ``rosbag2`` metadata record,
statistics and summary offsets, and the footer. Each chunk's CRC and the summary's are filled
in, so a reader that checks them checks the messages and the index (the data section's CRC is
0, "not available", as the ``mcap`` library's writer leaves it by default: it would read every
byte a second time).

This writer exists for speed: a run's bag is written from its journal after the test, and a
message costs about a microsecond here against several in a general writer, whose fixed cost
(its YAML emitter) alone is milliseconds. It is checked against the readers of ``rosbags`` and
of the ``mcap`` library, with CRC checks, and against ``rosbags``' writer message by message.
"""

from __future__ import annotations

import struct
import textwrap
import zlib
from array import array
from collections.abc import Iterable
from pathlib import Path
from typing import Any, BinaryIO, NamedTuple

import numpy as np
import yaml

__all__ = ['CHUNK_BYTES', 'BagWriter', 'Topic']

MAGIC = b'\x89MCAP0\r\n'
#: A chunk is closed once its records reach this size (as ``rosbags`` and ``ros2 bag`` do).
CHUNK_BYTES = 1 << 20
VERSION = 9  # of rosbag2's metadata
LIBRARY = 'pd_core'
QOS_PROFILES = '[]'  # offered QoS profiles: none recorded

_OP_HEADER, _OP_FOOTER, _OP_SCHEMA, _OP_CHANNEL, _OP_MESSAGE = 0x01, 0x02, 0x03, 0x04, 0x05
_OP_CHUNK, _OP_MESSAGE_INDEX, _OP_CHUNK_INDEX = 0x06, 0x07, 0x08
_OP_STATISTICS, _OP_METADATA, _OP_METADATA_INDEX = 0x0B, 0x0C, 0x0D
_OP_SUMMARY_OFFSET, _OP_DATA_END = 0x0E, 0x0F

_MESSAGE = struct.Struct('<BQHIQQ')  # opcode, length, channel, sequence, log and publish time
_MESSAGE_FIXED = _MESSAGE.size - 9   # the record's content before the data
_HEAD_BYTES = np.arange(9, 23)       # a message record's channel, sequence and log time
_RECORD = struct.Struct('<BQ')
_U16 = struct.Struct('<H')
_U32 = struct.Struct('<I')
_U64 = struct.Struct('<Q')
_NO_TIME = 2**63 - 1
_DUMPER: Any = getattr(yaml, 'CSafeDumper', yaml.SafeDumper)


class Topic(NamedTuple):
    """A topic of the bag and its message type."""

    name: str
    msgtype: str     #: e.g. ``pd_msgs/msg/StepCommand``
    definition: str  #: the type's ``ros2msg`` text with its dependencies (the MCAP schema)
    type_hash: str   #: ``RIHS01_…``: the type description hash


def _string(text: str) -> bytes:
    data = text.encode('utf-8')
    return _U32.pack(len(data)) + data


def _record(opcode: int, content: bytes) -> bytes:
    return _RECORD.pack(opcode, len(content)) + content


def _string_map(items: dict[str, str]) -> bytes:
    body = b''.join(_string(key) + _string(value) for key, value in items.items())
    return _U32.pack(len(body)) + body


class BagWriter:
    """Writes one rosbag2 bag (folder, MCAP file, ``metadata.yaml``); a context manager.

    Args:
        path: the bag's folder, which must not exist.
    """

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)
        self.file_path = self.path / f'{self.path.name}.mcap'
        self._file: BinaryIO | None = None
        self._topics: list[Topic] = []
        self._schemas: dict[str, int] = {}   # msgtype: schema id
        self._channel_of: dict[str, int] = {}
        self.counts: list[int] = [0]          # messages per channel id (0: none), closed chunks
        self._offset = 0
        self._chunk: list[bytes | memoryview] = []
        self._chunk_size = 0
        self._starts = array('q')  # where each of the chunk's messages starts in it
        self._chunk_indexes: list[bytes] = []
        self._start = _NO_TIME
        self._end = 0

    # -- the file -------------------------------------------------------------------------
    def open(self) -> BagWriter:
        """Create the folder and the MCAP file.

        Raises:
            OSError: the folder exists or cannot be created.
        """
        self.path.mkdir()
        self._file = self.file_path.open('xb')
        self._emit(MAGIC + _record(_OP_HEADER, _string('ros2') + _string(LIBRARY)))
        return self

    def __enter__(self) -> BagWriter:
        """Open the bag."""
        return self.open()

    def __exit__(self, *exc: object) -> None:
        """Close the bag (its summary and metadata written), or only its file on an error."""
        if exc[0] is None:
            self.close()
        elif self._file is not None:
            self._file.close()
            self._file = None

    def _emit(self, data: bytes) -> None:
        assert self._file is not None
        self._file.write(data)
        self._offset += len(data)

    # -- topics and messages --------------------------------------------------------------
    def add_topic(self, topic: Topic) -> int:
        """Add a topic (its schema once per type); its channel id."""
        if self._file is None:
            msg = f'{self.path}: bag is not open'
            raise ValueError(msg)
        if topic.name in self._channel_of:
            return self._channel_of[topic.name]
        schema = self._schemas.get(topic.msgtype)
        records = b''
        if schema is None:
            schema = self._schemas[topic.msgtype] = len(self._schemas) + 1
            records += _record(_OP_SCHEMA, self._schema_content(schema, topic))
        channel = len(self._topics) + 1
        records += _record(_OP_CHANNEL, self._channel_content(channel, topic))
        self._chunk.append(records)
        self._chunk_size += len(records)
        self._topics.append(topic)
        self._channel_of[topic.name] = channel
        self.counts.append(0)
        return channel

    @staticmethod
    def _schema_content(schema: int, topic: Topic) -> bytes:
        definition = topic.definition.encode('utf-8')
        return (_U16.pack(schema) + _string(topic.msgtype) + _string('ros2msg')
                + _U32.pack(len(definition)) + definition)

    def _channel_content(self, channel: int, topic: Topic) -> bytes:
        return (_U16.pack(channel) + _U16.pack(self._schemas[topic.msgtype])
                + _string(topic.name) + _string('cdr')
                + _string_map({'offered_qos_profiles': QOS_PROFILES}))

    def write(self, channel: int, t_ns: int, data: bytes | memoryview) -> None:
        """Add one message (its CDR bytes) to a channel, logged and published at ``t_ns``."""
        self.write_many(((channel, t_ns, data),))

    def write_many(self, messages: Iterable[tuple[int, int, bytes | memoryview]]) -> None:
        """Add messages ``(channel, t_ns, data)`` in order, as :meth:`write` adds each."""
        pack, opcode, fixed, head = _MESSAGE.pack, _OP_MESSAGE, _MESSAGE_FIXED, _MESSAGE.size
        add, start = self._chunk.append, self._starts.append
        offset = self._chunk_size
        for channel, t_ns, data in messages:
            size = len(data)
            start(offset)
            # (sequence 0, as rosbags and rosbag2 record it: the log time orders a channel)
            add(pack(opcode, fixed + size, channel, 0, t_ns, t_ns))
            add(data)
            offset += head + size
            if offset >= CHUNK_BYTES:
                self._chunk_size = offset
                self._close_chunk()
                add, start = self._chunk.append, self._starts.append
                offset = 0
        self._chunk_size = offset

    def _close_chunk(self) -> None:
        """Write the chunk in progress and its message indexes; index it."""
        records = b''.join(self._chunk)
        # each message's channel and log time, read back from its header (as it was packed)
        starts = np.frombuffer(self._starts, dtype=np.int64)
        heads = np.frombuffer(records, dtype=np.uint8)[starts[:, None] + _HEAD_BYTES]
        channels = heads[:, :2].copy().view('<u2')[:, 0].astype(np.int64)
        times = heads[:, 6:].copy().view('<i8')[:, 0]
        start, end = (int(times.min()), int(times.max())) if len(times) else (0, 0)
        chunk_offset = self._offset
        head = (struct.pack('<QQQI', start, end, len(records), zlib.crc32(records))
                + _string('') + _U64.pack(len(records)))
        self._emit(_RECORD.pack(_OP_CHUNK, len(head) + len(records)) + head)
        self._emit(records)
        chunk_length = self._offset - chunk_offset
        offsets = b''
        counts = np.bincount(channels, minlength=len(self.counts))
        for channel in np.flatnonzero(counts):
            offsets += _U16.pack(channel) + _U64.pack(self._offset)
            mine = channels == channel
            body = np.column_stack((times[mine], starts[mine])).astype('<u8').tobytes()
            self._emit(_record(_OP_MESSAGE_INDEX,
                               _U16.pack(channel) + _U32.pack(len(body)) + body))
            self.counts[channel] += int(counts[channel])
        self._chunk_indexes.append(
            struct.pack('<QQQQ', start, end, chunk_offset, chunk_length)
            + _U32.pack(len(offsets)) + offsets
            + _U64.pack(self._offset - chunk_offset - chunk_length) + _string('')
            + struct.pack('<QQ', len(records), len(records)))
        if len(times):
            self._start = min(self._start, start)
            self._end = max(self._end, end)
        self._chunk = []
        self._chunk_size = 0
        self._starts = array('q')

    # -- the end --------------------------------------------------------------------------
    def close(self) -> None:
        """Write the last chunk, the summary, the footer and ``metadata.yaml``."""
        if self._file is None:
            return
        if self._chunk:
            self._close_chunk()
        info = self._information()
        serialized = yaml.dump(info, Dumper=_DUMPER, default_flow_style=False).strip()
        metadata_offset = self._offset
        self._emit(_record(_OP_METADATA, _string('rosbag2')
                           + _string_map({'serialized_metadata': serialized})))
        metadata_length = self._offset - metadata_offset
        self._emit(_record(_OP_DATA_END, _U32.pack(0)))  # 0: no CRC of the data section

        summary_start = self._offset
        groups: list[tuple[int, bytes]] = [
            (_OP_SCHEMA, b''.join(
                _record(_OP_SCHEMA, self._schema_content(self._schemas[msgtype], topic))
                for msgtype, topic in self._first_topic_of_types().items())),
            (_OP_CHANNEL, b''.join(
                _record(_OP_CHANNEL, self._channel_content(channel, topic))
                for channel, topic in enumerate(self._topics, start=1))),
            (_OP_CHUNK_INDEX, b''.join(_record(_OP_CHUNK_INDEX, index)
                                       for index in self._chunk_indexes)),
            (_OP_METADATA_INDEX, _record(_OP_METADATA_INDEX, struct.pack(
                '<QQ', metadata_offset, metadata_length) + _string('rosbag2'))),
            (_OP_STATISTICS, _record(_OP_STATISTICS, self._statistics())),
        ]
        summary = b''
        offsets = b''
        for opcode, group in groups:
            if group:
                offsets += _record(_OP_SUMMARY_OFFSET, struct.pack(
                    '<BQQ', opcode, summary_start + len(summary), len(group)))
                summary += group
        summary_offset_start = summary_start + len(summary)
        summary += offsets
        footer_head = struct.pack('<BQQQ', _OP_FOOTER, 20, summary_start, summary_offset_start)
        crc = zlib.crc32(footer_head, zlib.crc32(summary))
        file = self._file
        file.write(summary + footer_head + _U32.pack(crc) + MAGIC)
        file.close()  # not synced: the run's journal is its durable record, the bag a copy
        self._file = None
        tmp = self.path / 'metadata.yaml.tmp'
        tmp.write_text('rosbag2_bagfile_information:\n' + textwrap.indent(serialized, '  ')
                       + '\n', encoding='utf-8')
        tmp.replace(self.path / 'metadata.yaml')

    def _first_topic_of_types(self) -> dict[str, Topic]:
        first: dict[str, Topic] = {}
        for topic in self._topics:
            first.setdefault(topic.msgtype, topic)
        return first

    def _statistics(self) -> bytes:
        counts = b''.join(_U16.pack(channel) + _U64.pack(self.counts[channel])
                          for channel in range(1, len(self._topics) + 1))
        start, end = self._times()
        return (struct.pack('<QHIIII', sum(self.counts), len(self._schemas), len(self._topics),
                            0, 1, len(self._chunk_indexes))
                + struct.pack('<QQ', start, end) + _U32.pack(len(counts)) + counts)

    def _times(self) -> tuple[int, int]:
        """The first and last log time (0, 0 without messages)."""
        return (0, 0) if self._start == _NO_TIME else (self._start, self._end)

    def _information(self) -> dict[str, Any]:
        """rosbag2's ``rosbag2_bagfile_information`` of the bag."""
        start, end = self._times()
        count = sum(self.counts)
        name = self.file_path.name
        return {
            'version': VERSION,
            'storage_identifier': 'mcap',
            'relative_file_paths': [name],
            'duration': {'nanoseconds': end - start},
            'starting_time': {'nanoseconds_since_epoch': start},
            'message_count': count,
            'topics_with_message_count': [
                {'topic_metadata': {'name': topic.name, 'type': topic.msgtype,
                                    'serialization_format': 'cdr',
                                    'offered_qos_profiles': [],
                                    'type_description_hash': topic.type_hash},
                 'message_count': self.counts[channel]}
                for channel, topic in enumerate(self._topics, start=1)],
            'compression_format': '',
            'compression_mode': '',
            'files': [{'path': name, 'starting_time': {'nanoseconds_since_epoch': start},
                       'duration': {'nanoseconds': end - start}, 'message_count': count}],
            'custom_data': None,
            'ros_distro': 'kilted',
        }



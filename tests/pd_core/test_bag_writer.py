"""The bag writer against two independent implementations: ``rosbags``' writer (the same
messages written by both, read back by ``rosbags``) and the ``mcap`` library's readers (with
their CRC checks); the MCAP index records checked against the messages they index."""

from __future__ import annotations

import random
import struct
import zlib
from pathlib import Path

import pytest
import yaml
from mcap.reader import make_reader
from mcap.records import Chunk, MessageIndex
from mcap.stream_reader import StreamReader
from rosbags.highlevel import AnyReader
from rosbags.rosbag2 import StoragePlugin, Writer

from pd_core.run.record.bag import bag_topic, typestore
from pd_core.run.record.bag_writer import CHUNK_BYTES, BagWriter

TOPICS = [('/pd/step_command', 'pd_msgs/msg/StepCommand'),
          ('/pd/step_feedback', 'pd_msgs/msg/StepFeedback'),
          ('/pd/test_status', 'pd_msgs/msg/TestStatus'),
          ('/pd/test_definition', 'std_msgs/msg/String'),
          ('/pd/run_events', 'std_msgs/msg/String'),
          ('/pd/left/step_command', 'pd_msgs/msg/StepCommand')]


def _messages(seed: int, count: int, *, ordered: bool) -> list[tuple[int, int, bytes]]:
    """(topic index, log time, bytes): sizes from empty to beyond a chunk, times increasing
    (or not), one topic left without messages."""
    rng = random.Random(seed)
    sizes = [0, 1, 7, CHUNK_BYTES + 13] + [rng.choice((24, 150, 400, 5000))
                                           for _ in range(count)]
    t_ns = 1_700_000_000 * 10**9
    out = []
    for size in sizes:
        t_ns += rng.randrange(1, 10**6) if ordered else rng.randrange(-10**6, 10**6)
        out.append((rng.randrange(len(TOPICS) - 1), t_ns, rng.randbytes(size)))
    return out


def _ours(path: Path, messages: list[tuple[int, int, bytes]]) -> Path:
    with BagWriter(path) as writer:
        channels = [writer.add_topic(bag_topic(name, msgtype)) for name, msgtype in TOPICS]
        for index, t_ns, data in messages:
            writer.write(channels[index], t_ns, data)
    return path


def _rosbags(path: Path, messages: list[tuple[int, int, bytes]]) -> Path:
    with Writer(path, version=9, storage_plugin=StoragePlugin.MCAP) as writer:
        connections = [writer.add_connection(name, msgtype, typestore=typestore())
                       for name, msgtype in TOPICS]
        for index, t_ns, data in messages:
            writer.write(connections[index], t_ns, data)
    return path


def _read(path: Path) -> tuple[list[tuple[str, str, str, str, int]], list[tuple[str, int, bytes]]]:
    with AnyReader([path], default_typestore=typestore()) as reader:
        connections = [(c.topic, c.msgtype, c.msgdef.data, c.digest, c.msgcount)
                       for c in reader.connections]
        messages = [(c.topic, t_ns, bytes(data)) for c, t_ns, data in reader.messages()]
    return connections, messages


@pytest.mark.parametrize('seed', [1, 2])
def test_rosbags_reads_what_its_own_writer_would_have_written(tmp_path: Path,
                                                              seed: int) -> None:
    messages = _messages(seed, 600, ordered=True)
    ours = _read(_ours(tmp_path / 'ours', messages))
    theirs = _read(_rosbags(tmp_path / 'theirs', messages))
    assert ours == theirs
    assert len(ours[1]) == len(messages)
    assert sum(count for *_, count in ours[0]) == len(messages)


def test_the_metadata_is_rosbags_metadata_but_for_the_names(tmp_path: Path) -> None:
    messages = _messages(3, 50, ordered=True)
    ours = yaml.safe_load((_ours(tmp_path / 'x', messages) / 'metadata.yaml').read_text())
    (tmp_path / 'x').rename(tmp_path / 'ours')
    theirs = yaml.safe_load((_rosbags(tmp_path / 'x', messages) / 'metadata.yaml').read_text())
    info, expected = ours['rosbag2_bagfile_information'], theirs['rosbag2_bagfile_information']
    assert info.pop('ros_distro') == 'kilted'
    expected.pop('ros_distro')
    assert info == expected
    assert info['message_count'] == len(messages)


def test_the_mcap_library_reads_it_with_its_crc_checks(tmp_path: Path) -> None:
    messages = _messages(4, 900, ordered=False)
    bag = _ours(tmp_path / 'b', messages)
    file = bag / 'b.mcap'
    with file.open('rb') as stream:
        reader = make_reader(stream, validate_crcs=True)
        summary = reader.get_summary()
        assert summary is not None
        read = [(channel.topic, message.log_time, message.publish_time, message.data)
                for _, channel, message in reader.iter_messages(log_time_order=False)]
        assert reader.get_header().profile == 'ros2'
        (metadata,) = list(reader.iter_metadata())
    assert read == [(TOPICS[i][0], t, t, data) for i, t, data in messages]
    stats = summary.statistics
    assert stats is not None
    assert stats.message_count == len(messages)
    assert stats.chunk_count == len(summary.chunk_indexes) >= 2
    assert stats.message_start_time == min(t for _, t, _ in messages)
    assert stats.message_end_time == max(t for _, t, _ in messages)
    assert stats.channel_message_counts == {
        channel: sum(1 for i, _, _ in messages if i == channel - 1)
        for channel in range(1, len(TOPICS) + 1)}
    assert [schema.name for schema in summary.schemas.values()] == list(
        dict.fromkeys(msgtype for _, msgtype in TOPICS))
    assert metadata.name == 'rosbag2'
    assert yaml.safe_load(metadata.metadata['serialized_metadata'])['message_count'] == len(
        messages)
    with file.open('rb') as stream:  # every record in file order, each chunk's CRC checked
        records = list(StreamReader(stream, validate_crcs=True).records)
    with file.open('rb') as stream:
        chunks = [record for record in StreamReader(stream, emit_chunks=True).records
                  if isinstance(record, Chunk)]
    assert len(chunks) == stats.chunk_count
    assert sum(record.__class__.__name__ == 'Message' for record in records) == len(messages)


def test_each_message_index_points_at_its_messages(tmp_path: Path) -> None:
    messages = _messages(5, 700, ordered=False)
    bag = _ours(tmp_path / 'b', messages)
    with (bag / 'b.mcap').open('rb') as stream:
        records = list(StreamReader(stream, emit_chunks=True).records)
    indexed = []
    chunk: Chunk | None = None
    for record in records:
        if isinstance(record, Chunk):
            chunk = record
        elif isinstance(record, MessageIndex):
            assert chunk is not None
            for log_time, offset in record.records:
                opcode, _, channel, _, stamp = struct.unpack_from('<BQHIQ', chunk.data, offset)
                assert (opcode, channel, stamp) == (0x05, record.channel_id, log_time)
                indexed.append((chunk.message_start_time, offset))
    assert len(indexed) == len(messages)


def test_the_footer_crc_covers_the_summary(tmp_path: Path) -> None:
    data = (_ours(tmp_path / 'b', _messages(6, 20, ordered=True)) / 'b.mcap').read_bytes()
    footer = data[-8 - 29:-8]
    opcode, length, summary_start, _, crc = struct.unpack('<BQQQI', footer)
    assert (opcode, length) == (0x02, 20)
    assert crc == zlib.crc32(footer[:-4], zlib.crc32(data[summary_start:-8 - 29]))
    assert data[:8] == data[-8:] == b'\x89MCAP0\r\n'


def test_an_empty_bag_is_a_bag(tmp_path: Path) -> None:
    bag = _ours(tmp_path / 'e', [])
    connections, messages = _read(bag)
    assert [topic for topic, *_ in connections] == [name for name, _ in TOPICS]
    assert messages == []


def test_a_bag_is_never_written_over(tmp_path: Path) -> None:
    (tmp_path / 'b').mkdir()
    with pytest.raises(FileExistsError):
        BagWriter(tmp_path / 'b').open()


@pytest.mark.parametrize('seed', [3, 4])
def test_write_many_writes_the_bytes_write_writes(tmp_path: Path, seed: int) -> None:
    """Messages given in batches of every size (empty, one, across a chunk's end, a message
    longer than a chunk) make the same bag, byte for byte, as one ``write`` each."""
    messages = _messages(seed, 3000, ordered=True)
    rng = random.Random(seed)
    (tmp_path / 'many').mkdir()
    (tmp_path / 'one').mkdir()
    with BagWriter(tmp_path / 'many' / 'bag') as writer:
        channels = [writer.add_topic(bag_topic(name, msgtype)) for name, msgtype in TOPICS]
        done = 0
        while done < len(messages):
            size = rng.choice((0, 1, 2, 17, 400, 2500))
            writer.write_many([(channels[index], t_ns, memoryview(data)) for index, t_ns, data
                               in messages[done:done + size]])
            done += size
    _ours(tmp_path / 'one' / 'bag', messages)
    for name in ('bag.mcap', 'metadata.yaml'):
        assert (tmp_path / 'many' / 'bag' / name).read_bytes() == (
            tmp_path / 'one' / 'bag' / name).read_bytes()

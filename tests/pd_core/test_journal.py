"""The run's journal: durable per step, read back exactly, cut or corrupted, turned into a bag.

The references are independent of the journal's own output: the live session of the run that
wrote it, and an uninterrupted :func:`run_offline` of the same test (its ``response.csv``
bytes and its history arrays).
"""

from __future__ import annotations

import errno
import gc
import json
import math
import shutil
import struct
import threading
import zlib
from collections import deque
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from mcap.reader import make_reader
from rclpy.serialization import serialize_message
from rosbags.highlevel import AnyReader

from pd_common.auth import WIRE_COMMAND, WIRE_FEEDBACK, Signer, new_key, sign_wire_reply
from pd_common.durable import STUCK_SYNC_S
from pd_common.protocol import (
    Command,
    Feedback,
    FeedbackStatus,
    Signature,
    StateOrigin,
    Status,
    decode_command,
    decode_feedback,
    encode_command,
    encode_feedback,
    encode_status,
)
from pd_common.protocol import TestState as State
from pd_core.errors import BagError
from pd_core.run.loop.dispatch import Sent, StepDispatcher
from pd_core.run.loop.session import TestSession as Session  # not a test class
from pd_core.run.record import journal as journal_module
from pd_core.run.record.bag import (
    TOPIC_COMMAND,
    TOPIC_FEEDBACK,
    TOPIC_STATUS,
    read_bag,
    read_trajectory,
    typestore,
)
from pd_core.run.record.journal import (
    JOURNAL_FILE,
    Journal,
    RecordWriteError,
    journal_to_bag,
    read_journal,
    read_journal_records,
)
from pd_core.run.runner import (
    load_run,
    rebuild_outputs,
    recover_run,
    replay_run,
    run_offline,
    serve_queue,
    site_servers,
)
from pd_core.run.test_file import load_test_file
from pd_msgs.msg import ActuatorTrajectory
from support import journals
from support.paths import DEFAULT_TEST

DURATION = 3.0  # 300 steps: the specimen yields at step 180 (its state matters)
STEPS = 300


def by_the_doc(path: Path) -> list[tuple[str, int, str, bytes, int]]:
    """A journal's records parsed from its documented layout (each CRC checked):
    ``(kind, t_ns, topic, payload, offset)``."""
    return [(r.kind, r.t_ns, r.topic, r.payload, r.offset) for r in journals.records(path)]


def kinds(path: Path) -> list[str]:
    return [kind for kind, *_ in by_the_doc(path)]


def records_by_the_doc(path: Path, kind: str) -> list[Any]:
    """The commands (``cmd``) or feedback (``fb``) of a journal, decoded by the codec."""
    decode = {'cmd': decode_command, 'fb': decode_feedback}[kind]
    return [decode(payload).record for name, _, _, payload, _ in by_the_doc(path)
            if name == kind]


def assert_same_history(a: Any, b: Any, rows: int | None = None) -> None:
    """Two histories equal bit for bit (the first ``rows`` committed rows)."""
    n = a.n_committed if rows is None else rows
    assert b.n_committed >= n
    for name in ('displacement', 'velocity', 'acceleration', 'restoring_force',
                 'measured_displacement'):
        assert np.array_equal(getattr(a, name)[:n], getattr(b, name)[:n]), name


@pytest.fixture(scope='module')
def offline(tmp_path_factory: pytest.TempPathFactory) -> Any:
    """The uninterrupted reference run (300 steps of the default test)."""
    definition = load_test_file(DEFAULT_TEST, overrides={'duration': DURATION})
    return run_offline(definition, tmp_path_factory.mktemp('journal') / 'run', figures=False)


# -- records ----------------------------------------------------------------------------------
def test_records_round_trip_exactly(tmp_path: Path) -> None:
    path = tmp_path / JOURNAL_FILE
    awkward = (0.1 + 0.2, -0.0, 5e-324, 1.0 / 3.0, -1.7976931348623157e308)
    command = Command(test_id='t', step=7, test_time=0.07, dof_names=('a', 'b', 'c', 'd', 'e'),
                      target_displacement=awkward, iteration=2)
    signature = Signature(key_id='lab', session='ab' * 16, sequence=41, mac=bytes(range(32)))
    feedback = Feedback(test_id='t', step=7, measured_displacement=awkward,
                        restoring_force=(1.5, -2.25, 3.0, 0.0, 1e300),
                        status=FeedbackStatus.LIMIT, message='max_force: 1e6 N', iteration=2,
                        epoch='e-42', state_origin=StateOrigin.RESTORED)
    status = Status(test_id='t', state=State.HOLDING, step=6, total_steps=10,
                    omega_dt=0.1108, retries=2, ignored_messages=3, message='holding',
                    refused_messages=4, refused_by_reason='bad mac: 4')
    with Journal(path) as journal:
        journal.write_definition('{"x": 1}', 10)
        journal.write_command(command, 11, signature=signature)
        journal.write_feedback(feedback, 12, topic='/pd/lab1/step_feedback')
        journal.write_status(status, 13)
        journal.write_status(status, 14, topic='/pd/bridge/status')
        journal.write_raw('/pd/bridge/trajectory', 15, b'\x00\x01\xffraw')
        journal.write_event('resumed', 16, committed_step=6, sites=['site default: ok'])
        assert journal.records == 7
    records, note = read_journal_records(path)
    assert note == ''
    assert [r.kind for r in records] == ['def', 'cmd', 'fb', 'st', 'st', 'raw', 'ev']
    assert [r.t_ns for r in records] == [10, 11, 12, 13, 14, 15, 16]
    # On disk as documented: each message's CDR bytes, the rest JSON text.
    assert [(kind, t_ns, topic) for kind, t_ns, topic, *_ in by_the_doc(path)] == [
        ('def', 10, ''), ('cmd', 11, TOPIC_COMMAND), ('fb', 12, '/pd/lab1/step_feedback'),
        ('st', 13, TOPIC_STATUS), ('st', 14, '/pd/bridge/status'),
        ('raw', 15, '/pd/bridge/trajectory'), ('ev', 16, '')]
    payloads = [payload for *_, payload, _ in by_the_doc(path)]
    assert payloads[:6] == [b'{"x": 1}', encode_command(command, 11, signature),
                            encode_feedback(feedback, 12), encode_status(status, 13),
                            encode_status(status, 14), b'\x00\x01\xffraw']
    assert json.loads(payloads[6]) == {'what': 'resumed', 'committed_step': 6,
                                       'sites': ['site default: ok']}
    assert [r.data for r in records] == payloads
    assert records[0].item == '{"x": 1}'
    assert records[1].item == command
    assert records[1].topic == TOPIC_COMMAND
    assert records[1].signature == signature
    assert math.copysign(1.0, records[1].item.target_displacement[1]) == -1.0
    assert records[2].item == feedback
    assert records[2].topic == '/pd/lab1/step_feedback'
    assert records[2].signature == Signature()
    assert records[3].item == status
    assert records[3].topic == TOPIC_STATUS
    assert records[4].topic == '/pd/bridge/status'
    assert records[5].item == b'\x00\x01\xffraw'
    assert records[6].item['what'] == 'resumed'
    assert records[6].item['committed_step'] == 6


def test_non_finite_values_round_trip(tmp_path: Path) -> None:
    path = tmp_path / JOURNAL_FILE
    feedback = Feedback(test_id='t', step=1, measured_displacement=(math.nan, math.inf),
                        restoring_force=(-math.inf, 0.0))
    with Journal(path) as journal:
        journal.write_feedback(feedback, 1)
    (record,), _ = read_journal_records(path)
    assert math.isnan(record.item.measured_displacement[0])
    assert record.item.measured_displacement[1] == math.inf
    assert record.item.restoring_force == (-math.inf, 0.0)


def test_unsigned_signature_is_not_recorded(tmp_path: Path) -> None:
    path = tmp_path / JOURNAL_FILE
    command = Command(test_id='t', step=0, test_time=0.0, dof_names=('a',),
                      target_displacement=(0.0,))
    with Journal(path) as journal:
        journal.write_command(command, 1, signature=Signature(key_id='lab'))  # no mac
    (record,), _ = read_journal_records(path)
    assert record.signature == Signature()
    assert record.data == encode_command(command, 1)


def test_events_kept_and_read_back(tmp_path: Path) -> None:
    path = tmp_path / JOURNAL_FILE
    with Journal(path) as journal:
        journal.write_definition('{}', 1)
        journal.write_event('epoch_change', 5, site='lab1', accepted=True)
        journal.write_event('resumed', 9, note='after a crash')
        assert journal.events == [
            {'what': 'epoch_change', 'site': 'lab1', 'accepted': True, 't_ns': 5},
            {'what': 'resumed', 'note': 'after a crash', 't_ns': 9}]
    run = read_journal(path)
    assert run.run_events == [
        {'what': 'epoch_change', 'site': 'lab1', 'accepted': True, 't_ns': 5},
        {'what': 'resumed', 'note': 'after a crash', 't_ns': 9}]
    assert journal_to_bag(path, tmp_path / 'bag') == 3
    assert read_bag(tmp_path / 'bag').run_events == run.run_events


def test_journal_without_definition_is_not_a_run(tmp_path: Path) -> None:
    path = tmp_path / JOURNAL_FILE
    with Journal(path) as journal:
        journal.write_event('resumed', 1)
    with pytest.raises(BagError, match='no /pd/test_definition record'):
        read_journal(path)


# -- the file -----------------------------------------------------------------------------------
def test_open_refuses_an_existing_journal(tmp_path: Path) -> None:
    path = tmp_path / JOURNAL_FILE
    with Journal(path) as journal:
        journal.write_definition('{}', 1)
    before = path.read_bytes()
    with pytest.raises(BagError) as error:
        Journal(path).open()
    assert str(error.value).startswith(str(path))
    assert 'a journal exists already' in str(error.value)
    assert '\n' not in str(error.value)
    assert path.read_bytes() == before


def test_open_reports_an_unwritable_path(tmp_path: Path) -> None:
    path = tmp_path / 'missing' / JOURNAL_FILE
    with pytest.raises(BagError, match='cannot write the journal'):
        Journal(path).open()


def test_append_continues_without_a_second_header(tmp_path: Path) -> None:
    path = tmp_path / JOURNAL_FILE
    with Journal(path) as journal:
        journal.write_definition('{}', 1)
        journal.write_event('first', 2)
    with Journal(path, append=True) as journal:
        journal.write_event('resumed', 3)
    assert kinds(path) == ['def', 'ev', 'ev']
    assert path.read_bytes().count(b'PDJ') == 1
    records, note = read_journal_records(path)
    assert note == ''
    assert [r.item['what'] for r in records if r.kind == 'ev'] == ['first', 'resumed']


def test_append_to_a_missing_journal_creates_it(tmp_path: Path) -> None:
    path = tmp_path / JOURNAL_FILE
    with Journal(path, append=True) as journal:
        journal.write_event('resumed', 3)
    assert kinds(path) == ['ev']


def test_a_journal_cut_in_its_header_is_begun_again_on_append(tmp_path: Path) -> None:
    path = tmp_path / JOURNAL_FILE
    path.write_bytes(b'\x89PDJ\r')  # killed as the run began
    records, note = read_journal_records(path)
    assert records == []
    assert note == f'ignored the header of {JOURNAL_FILE}, cut short (5 bytes)'
    with Journal(path, append=True) as journal:
        journal.write_event('resumed', 3)
    assert kinds(path) == ['ev']


def test_no_record_reaches_the_file_before_a_flush(tmp_path: Path) -> None:
    path = tmp_path / JOURNAL_FILE
    journal = Journal(path).open()
    try:
        journal.write_definition('{}', 1)
        assert path.read_bytes() == b'\x89PDJ\r\n\x1a\n' + struct.pack('<II', 3, 0)
        journal.flush()
        assert kinds(path) == ['def']
        journal.write_event('x', 2)
        assert kinds(path) == ['def']
        journal.flush()
        assert kinds(path) == ['def', 'ev']
    finally:
        journal.close()


def test_fsync_at_most_sync_interval_apart(tmp_path: Path,
                                           monkeypatch: pytest.MonkeyPatch) -> None:
    synced: list[float] = []
    now = [100.0]
    monkeypatch.setattr(journal_module.os, 'fsync', lambda fd: synced.append(now[0]))
    journal = Journal(tmp_path / JOURNAL_FILE, sync_interval=1.0, clock=lambda: now[0]).open()
    for t in (100.2, 100.9, 101.0, 101.5, 101.99, 102.0, 105.0):
        now[0] = t
        journal.write_event('step', 0)
        journal.flush()
        # Every flush hands its records to the operating system at once.
        assert kinds(journal.path)[-1] == 'ev'
    assert synced == [101.0, 102.0, 105.0]
    now[0] = 107.0
    journal.flush()  # nothing pending: no write, no sync
    assert synced == [101.0, 102.0, 105.0]
    now[0] = 107.1
    journal.close()  # always synced when closed
    assert synced == [101.0, 102.0, 105.0, 107.1]
    journal.close()  # twice: nothing more
    assert len(synced) == 4


def test_sync_interval_zero_syncs_every_flush(tmp_path: Path,
                                              monkeypatch: pytest.MonkeyPatch) -> None:
    synced: list[int] = []
    monkeypatch.setattr(journal_module.os, 'fsync', lambda fd: synced.append(fd))
    journal = Journal(tmp_path / JOURNAL_FILE, sync_interval=0.0, clock=lambda: 5.0).open()
    for _ in range(3):
        journal.write_event('step', 0)
        journal.flush()
    assert len(synced) == 3
    journal.close()


def _first_step_synced_in_background(tmp_path: Path) -> tuple[Journal, list[float]]:
    """A journal syncing in the background (interval 1 s, a clock set by hand: ``now[0]``)
    whose first step, at 1 s, has just asked for an fsync."""
    now = [0.0]
    journal = Journal(tmp_path / JOURNAL_FILE, sync_interval=1.0, clock=lambda: now[0],
                      sync_in_background=True).open()
    now[0] = 1.0
    journal.write_event('step', 0)
    journal.flush()
    return journal, now


def test_a_slow_fsync_in_the_background_holds_up_no_step_within_its_interval(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The interval's fsync runs in its own thread: the steps after it go on while the disk
    syncs. One that lasts a whole interval (a stuck disk) is waited for by the step that asks
    for the next, so no record stays unsynced for long without the test noticing; close
    waits for it, then syncs."""
    release = threading.Event()
    started = threading.Event()
    synced: list[str] = []

    def slow_fsync(fd: int) -> None:
        started.set()
        assert release.wait(30.0)  # a disk that never answers, until released
        synced.append(threading.current_thread().name)

    monkeypatch.setattr(journal_module.os, 'fsync', slow_fsync)
    journal, now = _first_step_synced_in_background(tmp_path)  # returns while it hangs
    assert started.wait(30.0)
    for step in range(1, 10):  # 1.1 .. 1.9 s: the steps go on, each on the OS at once
        now[0] = 1.0 + 0.1 * step
        journal.write_event('step', step)
        journal.flush()
        assert kinds(journal.path).count('ev') == step + 1
    assert synced == []
    now[0] = 2.0  # the next fsync is due while the first still hangs: this step waits
    journal.write_event('step', 10)
    waiting = threading.Thread(target=journal.flush)
    waiting.start()
    waiting.join(0.5)
    assert waiting.is_alive() and synced == []
    release.set()
    waiting.join(30.0)
    assert not waiting.is_alive() and synced[:1] == ['journal-fsync']
    journal.close()
    # The one asked at 1.0, the one asked at 2.0 (unless close came first), the caller's.
    assert synced[-1] == threading.current_thread().name
    assert synced[:-1] == ['journal-fsync'] * (len(synced) - 1) and len(synced) in (2, 3)
    assert not [thread for thread in threading.enumerate() if thread.name == 'journal-fsync']


def test_a_stuck_fsync_is_waited_for_with_a_short_interval_too(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """An interval shorter than STUCK_SYNC_S (10 ms) asks for an fsync at every step: steps go
    on while the first hangs, until it has been under way for STUCK_SYNC_S; then the step
    waits for it (a stuck disk does not leave a second of records unsynced unnoticed)."""
    release, started = threading.Event(), threading.Event()

    def slow_fsync(fd: int) -> None:
        if threading.current_thread().name == 'journal-fsync':
            started.set()
            assert release.wait(30.0)

    monkeypatch.setattr(journal_module.os, 'fsync', slow_fsync)
    now = [0.0]
    journal = Journal(tmp_path / JOURNAL_FILE, sync_interval=0.01, clock=lambda: now[0],
                      sync_in_background=True).open()
    for step in range(1, 100):  # 10 ms .. 990 ms: each step asks, none waits
        now[0] = 0.01 * step
        journal.write_event('step', step)
        journal.flush()
        if step == 1:
            assert started.wait(30.0)
    now[0] = 0.01 + STUCK_SYNC_S  # the first has hung for STUCK_SYNC_S: this step waits
    journal.write_event('step', 100)
    waiting = threading.Thread(target=journal.flush)
    waiting.start()
    waiting.join(0.5)
    assert waiting.is_alive()
    release.set()
    waiting.join(30.0)
    assert not waiting.is_alive()
    journal.close()


def test_a_failed_background_fsync_stops_the_run_at_the_next_step(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """An fsync that fails (EIO: what reached the disk is unknown) ends the journal at the
    next flush in one line, as a failed write does; nothing is written after it."""
    failed = threading.Event()

    def failing_fsync(fd: int) -> None:
        failed.set()
        raise OSError(errno.EIO, 'Input/output error')

    monkeypatch.setattr(journal_module.os, 'fsync', failing_fsync)
    journal, _ = _first_step_synced_in_background(tmp_path)
    assert failed.wait(30.0)
    thread = next((thread for thread in threading.enumerate()
                   if thread.name == 'journal-fsync'), None)
    if thread is not None:
        thread.join(30.0)
    written = kinds(journal.path)
    journal.write_event('step', 1)
    with pytest.raises(RecordWriteError) as raised:
        journal.flush()
    assert str(raised.value).count('\n') == 0
    assert 'Input/output error' in str(raised.value) and './pd recover' in str(raised.value)
    assert kinds(journal.path) == written  # nothing after the failed sync
    journal.close()  # closed already: nothing more


@pytest.mark.parametrize('background', [False, True])
def test_sync_interval_zero_syncs_in_the_step_even_in_the_background_mode(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch, background: bool) -> None:
    """An fsync per committed step (interval 0) is done before flush returns: never deferred."""
    synced: list[str] = []
    monkeypatch.setattr(journal_module.os, 'fsync',
                        lambda fd: synced.append(threading.current_thread().name))
    journal = Journal(tmp_path / JOURNAL_FILE, sync_interval=0.0, clock=lambda: 5.0,
                      sync_in_background=background).open()
    for count in range(1, 4):
        journal.write_event('step', 0)
        journal.flush()
        assert synced == [threading.current_thread().name] * count
    journal.persist()  # an emergency stop's record: in the caller too
    assert len(synced) == 4 and 'journal-fsync' not in synced
    journal.close()


def test_sync_interval_zero_is_one_fsync_per_committed_step_before_its_next_command(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    definition = load_test_file(DEFAULT_TEST, overrides={'duration': DURATION})
    server = site_servers(definition)['']
    session = Session(definition)
    journal = Journal(tmp_path / JOURNAL_FILE, sync_interval=0.0).open()
    events: list[str] = []
    monkeypatch.setattr(journal_module.os, 'fsync', lambda fd: events.append('fsync'))
    queue: deque[tuple[str, Command]] = deque()

    def seal(site: str, command: Command) -> Sent:  # (what the node signs)
        return Sent(Signature(), encode_command(command, dispatcher.send_stamp_ns, Signature()))

    def deliver(site: str, sent: Sent) -> None:  # (what the node publishes)
        events.append('send')
        queue.append((site, decode_command(sent.data).record))

    dispatcher = StepDispatcher(session, seal, journal, deliver=deliver)
    dispatcher.start()
    events.clear()
    assert serve_queue(queue, {'': server}, dispatcher)
    journal.close()
    assert session.state is State.FINISHED
    steps = definition.n_steps
    # Each answer (and the command it leads to) synced, then that command sent; the last
    # answer, then the close.
    assert events == ['fsync', 'send'] * steps + ['fsync', 'fsync']


def test_a_command_and_the_answer_before_it_are_on_disk_before_it_leaves(
        tmp_path: Path) -> None:
    """The record never lags what a specimen was sent (write-ahead): when a command leaves
    (the dispatcher's ``deliver``), its own record, with the bytes that leave, and the answer
    that led to it are already in the file; a kill between the two leaves a journal whose owed
    command the resumed run re-sends."""
    definition = load_test_file(DEFAULT_TEST, overrides={'duration': DURATION})
    server = site_servers(definition)['']
    session = Session(definition)
    path = tmp_path / JOURNAL_FILE
    journal = Journal(path, sync_interval=3600.0).open()
    queue: deque[tuple[str, Command]] = deque()
    on_disk_when_sent: list[tuple[int, int, bool]] = []

    def seal(site: str, command: Command) -> Sent:  # (what the node signs)
        return Sent(Signature(), encode_command(command, dispatcher.send_stamp_ns, Signature()))

    def deliver(site: str, sent: Sent) -> None:  # (what the node publishes)
        records = by_the_doc(path)
        answered = [decode_feedback(payload).record.step
                    for kind, _, _, payload, _ in records if kind == 'fb']
        command = decode_command(sent.data).record
        on_disk_when_sent.append((command.step, answered[-1] if answered else -1,
                                  records[-1][0] == 'cmd' and records[-1][3] == sent.data))
        queue.append((site, command))

    dispatcher = StepDispatcher(session, seal, journal, deliver=deliver)
    dispatcher.start()
    try:
        assert serve_queue(queue, {'': server}, dispatcher)
    finally:
        journal.close()
    assert session.state is State.FINISHED
    assert on_disk_when_sent[0] == (0, -1, True)
    assert on_disk_when_sent[1:] == [(step, step - 1, True)
                                     for step in range(1, len(on_disk_when_sent))]


def test_nothing_is_delivered_that_the_journal_could_not_write(tmp_path: Path) -> None:
    """A record that cannot be written (a full disk) raises before the command leaves."""
    definition = load_test_file(DEFAULT_TEST, overrides={'duration': DURATION})
    server = site_servers(definition)['']
    session = Session(definition)
    journal = Journal(tmp_path / JOURNAL_FILE, sync_interval=3600.0).open()
    delivered: list[int] = []
    queue: deque[tuple[str, Command]] = deque()

    def seal(site: str, command: Command) -> Sent:
        return Sent(Signature(), encode_command(command, dispatcher.send_stamp_ns, Signature()))

    def deliver(site: str, sent: Sent) -> None:
        command = decode_command(sent.data).record
        delivered.append(command.step)
        queue.append((site, command))

    dispatcher = StepDispatcher(session, seal, journal, deliver=deliver)
    dispatcher.start()
    for _ in range(5):
        site, command = queue.popleft()
        answer = server.handle(command.test_id, command.step, command.target_displacement)
        assert answer is not None
        dispatcher.on_feedback(site, answer)
    assert delivered == [0, 1, 2, 3, 4, 5]

    class FullDisk:  # the journal's file, on a disk that just filled up
        def __init__(self, file: Any) -> None:
            self.file = file

        def write(self, data: bytes) -> int:
            raise OSError(errno.ENOSPC, 'No space left on device')

        def __getattr__(self, name: str) -> Any:
            return getattr(self.file, name)

    journal._file = FullDisk(journal._file)  # type: ignore[assignment]
    site, command = queue.popleft()
    answer = server.handle(command.test_id, command.step, command.target_displacement)
    assert answer is not None
    with pytest.raises(RecordWriteError, match='No space left'):
        dispatcher.on_feedback(site, answer)
    assert delivered == [0, 1, 2, 3, 4, 5]  # step 6 computed, not sent
    assert session.protocol.pending is not None
    assert session.protocol.pending.step == 6


def test_every_committed_step_is_on_disk_while_the_writer_runs(tmp_path: Path,
                                                               offline: Any) -> None:
    """A copy of the live journal taken after any step (what a SIGKILL leaves) holds it."""
    definition = load_test_file(DEFAULT_TEST, overrides={'duration': DURATION})
    server = site_servers(definition)['']
    session = Session(definition)
    queue: deque[tuple[str, Command]] = deque()
    path = tmp_path / JOURNAL_FILE
    journal = Journal(path, sync_interval=3600.0).open()  # durability must not need fsync
    dispatcher = StepDispatcher(session, lambda site, command: queue.append((site, command)),
                                journal)
    journal.write_definition(definition.to_json(), 1)
    dispatcher.start()
    checked = 0
    try:
        while queue:
            site, command = queue.popleft()
            answer = server.handle(command.test_id, command.step, command.target_displacement)
            assert answer is not None
            dispatcher.on_feedback(site, answer)
            step = session.committed_step
            # A second reader, while the writer is alive and the file still open: the
            # feedback that committed the step, then the next command (one flush).
            tail = by_the_doc(path)[-2:]
            written = tail[-2] if session.protocol.pending is not None else tail[-1]
            assert written[0] == 'fb'
            assert decode_feedback(written[3]).record == answer
            if session.protocol.pending is not None:
                assert tail[-1][0] == 'cmd'
                assert decode_command(tail[-1][3]).record == session.protocol.pending
                assert session.protocol.pending.step == step + 1
            if step in (0, 150, 181, 240):  # a killed run: the copy replays to its last step
                copy = tmp_path / f'copy-{step}.pdj'
                shutil.copyfile(path, copy)
                replayed = replay_run(read_journal(copy), str(copy))
                assert replayed.committed_step == step
                assert_same_history(offline.session.history, replayed.history, step + 1)
                checked += 1
    finally:
        journal.close()
    assert checked == 4
    assert session.committed_step == STEPS
    assert_same_history(offline.session.history, session.history)


# -- cut and corrupted journals ---------------------------------------------------------------
def _small_journal(path: Path) -> None:
    with Journal(path) as journal:
        journal.write_definition('{}', 1)
        for step in range(5):
            journal.write_command(Command(test_id='t', step=step, test_time=0.01 * step,
                                          dof_names=('a',),
                                          target_displacement=(0.001 * step,)), 10 + step)


def _last_record_size(path: Path) -> int:
    *_, (_, _, _, _, offset) = by_the_doc(path)
    return path.stat().st_size - offset


def _rewrite_record(path: Path, number: int, body: bytes | None = None, *,
                    crc: int | None = None, length: int | None = None) -> int:
    """Replace record ``number`` (1: the first) with ``body`` (its CRC recomputed unless
    given); its offset."""
    data = bytearray(path.read_bytes())
    offset = by_the_doc(path)[number - 1][4]
    old_length = struct.unpack_from('<I', data, offset)[0]
    body = bytes(data[offset + 8:offset + 8 + old_length]) if body is None else body
    prefix = struct.pack('<II', len(body) if length is None else length,
                         zlib.crc32(body) if crc is None else crc)
    data[offset:offset + 8 + old_length] = prefix + body
    path.write_bytes(bytes(data))
    return offset


@pytest.mark.parametrize('cut', [1, 5, 8, 9, 17, 40])
def test_a_torn_last_record_is_ignored_and_reported(tmp_path: Path, cut: int) -> None:
    path = tmp_path / JOURNAL_FILE
    _small_journal(path)
    size = _last_record_size(path)
    assert size > cut
    with path.open('r+b') as stream:
        stream.truncate(path.stat().st_size - cut)
    records, note = read_journal_records(path)
    assert [r.item.step for r in records if r.kind == 'cmd'] == [0, 1, 2, 3]
    assert note == (f'ignored the last record of {JOURNAL_FILE}, cut short (byte '
                    f'{path.stat().st_size - size + cut}: {size - cut} bytes)')
    run = read_journal(path)
    assert run.notes == [note]
    assert [c.step for c in run.commands] == [0, 1, 2, 3]


@pytest.mark.parametrize('tail', ['zeros', 'flipped'])
def test_a_last_record_a_power_loss_left_unwritten_is_ignored(tmp_path: Path,
                                                              tail: str) -> None:
    """A power loss can leave a file's last blocks zero-filled, or hold old bytes: the last
    record's CRC fails with nothing but zeros after it."""
    path = tmp_path / JOURNAL_FILE
    _small_journal(path)
    data = bytearray(path.read_bytes())
    size = _last_record_size(path)
    if tail == 'zeros':
        data[len(data) - size + 8:] = bytes(size - 8) + bytes(4096)
    else:
        data[-3] ^= 0x10
    path.write_bytes(bytes(data))
    records, note = read_journal_records(path)
    assert [r.item.step for r in records if r.kind == 'cmd'] == [0, 1, 2, 3]
    assert note.startswith(f'ignored the last record of {JOURNAL_FILE}, CRC mismatch (byte ')


def _damage(path: Path, how: str) -> int:
    """Record 4 (the third command) damaged ``how``; its offset."""
    if how == 'flipped byte':
        data = bytearray(path.read_bytes())
        offset = by_the_doc(path)[3][4]
        data[offset + 30] ^= 0x01
        path.write_bytes(bytes(data))
        return offset
    if how == 'bad length':
        return _rewrite_record(path, 4, length=3)
    if how == 'unknown kind':
        return _rewrite_record(path, 4, struct.pack('<BBHq', 9, 0, 0, 13) + b'x')
    if how == 'topic past its end':
        return _rewrite_record(path, 4, struct.pack('<BBHq', 2, 0, 500, 13) + b'x')
    if how == 'not a command':  # CRC right, bytes no StepCommand
        return _rewrite_record(path, 4, struct.pack('<BBHq', 2, 0, 0, 13) + b'\x00\x01\x00')
    assert how == 'event not JSON'
    return _rewrite_record(path, 4, struct.pack('<BBHq', 6, 0, 0, 13) + b'{"what"')


@pytest.mark.parametrize(('how', 'reason'), [
    ('flipped byte', 'damaged (CRC mismatch)'),
    ('bad length', 'damaged (a length of 3 bytes)'),
    ('unknown kind', 'malformed (kind 9)'),
    ('topic past its end', 'malformed (a topic of 500 bytes)'),
    ('not a command', 'malformed cmd record ('),
    ('event not JSON', 'malformed ev record ('),
])
def test_a_damaged_record_before_the_end_is_an_error_naming_it(tmp_path: Path, how: str,
                                                               reason: str) -> None:
    path = tmp_path / JOURNAL_FILE
    _small_journal(path)
    offset = _damage(path, how)
    with pytest.raises(BagError) as error:
        read_journal_records(path)
    message = str(error.value)
    assert message.startswith(f'{path}: record 4 at byte {offset}: {reason}')
    assert '\n' not in message
    with pytest.raises(BagError, match=f'record 4 at byte {offset}'):
        load_run(path)
    if 'malformed (' in reason or 'damaged' in reason:  # framing: no append after it
        before = path.read_bytes()
        with pytest.raises(BagError, match='record 4'):
            Journal(path, append=True).open()
        assert path.read_bytes() == before


@pytest.mark.parametrize(('content', 'reason'), [
    (b'{"k":"journal","version":1}\n',
     'not a journal of this version (a JSON-lines journal of an earlier version)'),
    (b'PK\x03\x04' + bytes(40), 'not a journal of this version (no journal header)'),
    (b'\x89PDJ\r\n\x1a\n' + struct.pack('<II', 4, 0),
     'journal format version 4; this version reads 3'),
    (b'\x89PDJ\r\n\x1a\n' + struct.pack('<II', 2, 0),  # (statuses without their digest)
     'journal format version 2; this version reads 3'),
])
def test_a_file_that_is_no_journal_of_this_version_is_one_line(tmp_path: Path, content: bytes,
                                                               reason: str) -> None:
    path = tmp_path / JOURNAL_FILE
    path.write_bytes(content)
    with pytest.raises(BagError) as error:
        read_journal_records(path)
    assert str(error.value) == f'{path}: {reason}'


def test_a_run_folder_with_an_earlier_versions_journal_says_so(tmp_path: Path) -> None:
    (tmp_path / 'journal.jsonl').write_text('{"k":"journal","version":1}\n', encoding='utf-8')
    for read in (load_run, recover_run):
        with pytest.raises(BagError, match=r'journal\.jsonl\) is of an earlier version'):
            read(tmp_path)


def test_an_unreadable_journal_is_an_error(tmp_path: Path) -> None:
    path = tmp_path / JOURNAL_FILE
    with pytest.raises(BagError, match='cannot read the journal'):
        read_journal_records(path)


@pytest.mark.parametrize('cut', [9, 1, 'zeros'])
def test_appending_to_a_torn_journal_keeps_it_readable(tmp_path: Path,
                                                       cut: int | str) -> None:
    """A resumed run appends to a journal a crash tore at its end: the torn record goes."""
    path = tmp_path / JOURNAL_FILE
    _small_journal(path)
    if cut == 'zeros':
        with path.open('ab') as stream:
            stream.write(bytes(8192))
    else:
        with path.open('r+b') as stream:
            stream.truncate(path.stat().st_size - int(cut))
    with Journal(path, append=True) as journal:
        journal.write_event('resumed', 99)
    records, note = read_journal_records(path)
    assert note == ''
    steps = [0, 1, 2, 3, 4] if cut == 'zeros' else [0, 1, 2, 3]
    assert [r.item.step for r in records if r.kind == 'cmd'] == steps
    assert records[-1].kind == 'ev'
    assert records[-1].item['what'] == 'resumed'


# -- the bag ----------------------------------------------------------------------------------
def test_offline_journal_holds_the_whole_run(offline: Any) -> None:
    path = offline.directory / JOURNAL_FILE
    assert kinds(path)[:2] == ['def', 'st']
    run = read_journal(path)
    assert run.notes == []
    assert [c.step for c in run.commands] == list(range(STEPS + 1))
    assert [f.step for f in run.feedback] == list(range(STEPS + 1))
    assert np.array_equal(np.array([f.restoring_force for f in run.feedback]),
                          offline.session.history.restoring_force)
    assert run.statuses[-1][1].state is State.FINISHED
    assert json.loads(run.definition_json) == json.loads(
        (offline.directory / 'test_definition.json').read_text(encoding='utf-8'))


def test_journal_to_bag_replays_to_the_offline_response(tmp_path: Path, offline: Any) -> None:
    journal = offline.directory / JOURNAL_FILE
    bag = tmp_path / 'bag'
    count = journal_to_bag(journal, bag)
    assert count == len(by_the_doc(journal))
    assert (bag / 'metadata.yaml').is_file()
    from_bag = load_run(bag)
    from_journal = load_run(journal)
    assert from_bag.events == from_journal.events
    assert [s for _, s in from_bag.statuses] == [s for _, s in from_journal.statuses]
    assert from_bag.definition_json == from_journal.definition_json
    session = replay_run(from_bag, str(bag))
    assert session.state is State.FINISHED
    assert_same_history(offline.session.history, session.history)
    assert session.history.n_committed == STEPS + 1
    # The outputs rebuilt from the converted bag: the offline run's response, byte for byte.
    rebuilt = rebuild_outputs(bag, tmp_path / 'rebuilt', figures=False)
    assert (rebuilt.directory / 'response.csv').read_bytes() == (
        offline.directory / 'response.csv').read_bytes()
    assert rebuilt.summary['steps'] == STEPS


def test_journal_to_bag_refuses_an_existing_bag(tmp_path: Path, offline: Any) -> None:
    with pytest.raises(BagError, match='bag exists already'):
        journal_to_bag(offline.directory / JOURNAL_FILE, offline.directory / 'bag')


@pytest.mark.parametrize('running', [True, False])
def test_the_conversion_leaves_the_garbage_collector_as_it_found_it(tmp_path: Path,
                                                                   offline: Any,
                                                                   running: bool) -> None:
    # It pauses the collector while it copies: running again afterwards (if it ran), also
    # after a journal it cannot read; never switched on by it.
    source = offline.directory / JOURNAL_FILE
    damaged = tmp_path / 'damaged.pdj'
    data = bytearray(source.read_bytes())
    data[len(data) // 2] ^= 0xFF  # a record in the middle: damaged, not torn
    damaged.write_bytes(bytes(data))
    was = gc.isenabled()
    try:
        (gc.enable if running else gc.disable)()
        assert journal_to_bag(source, tmp_path / 'bag') > 2 * STEPS
        assert gc.isenabled() is running
        with pytest.raises(BagError, match='damaged'):
            journal_to_bag(damaged, tmp_path / 'bag-of-damaged')
        assert gc.isenabled() is running
        assert not (tmp_path / 'bag-of-damaged').exists()
    finally:
        (gc.enable if was else gc.disable)()


def test_load_run_reads_the_journal_of_a_folder_without_a_bag(tmp_path: Path,
                                                              offline: Any) -> None:
    folder = tmp_path / 'killed'
    folder.mkdir()
    shutil.copyfile(offline.directory / JOURNAL_FILE, folder / JOURNAL_FILE)
    (folder / 'bag').mkdir()  # a bag the crash left without its metadata
    run = load_run(folder)
    assert [c.step for c in run.commands] == list(range(STEPS + 1))
    assert_same_history(offline.session.history, replay_run(run).history)
    with pytest.raises(BagError, match='no complete bag and no journal'):
        load_run(tmp_path / 'empty')


def test_a_cut_journal_converts_and_replays_up_to_its_last_step(tmp_path: Path,
                                                               offline: Any) -> None:
    source = offline.directory / JOURNAL_FILE
    records = by_the_doc(source)
    # The feedback of step 200 and the command of step 201 (one flush), then half a record.
    index = next(i for i, (kind, _, _, payload, _) in enumerate(records)
                 if kind == 'fb' and decode_feedback(payload).record.step == 200)
    path = tmp_path / JOURNAL_FILE
    path.write_bytes(source.read_bytes()[:records[index + 2][4] + 25])
    run = read_journal(path)
    assert len(run.notes) == 1
    assert journal_to_bag(path, tmp_path / 'bag') == index + 2
    session = replay_run(load_run(tmp_path / 'bag'))
    assert session.committed_step == 200
    assert session.protocol.pending is not None
    assert session.protocol.pending.step == 201
    assert_same_history(offline.session.history, session.history, 201)
    assert TOPIC_FEEDBACK in {topic for topic, *_ in run.ordered}


def test_the_bag_holds_each_step_message_as_the_bytes_that_travelled(tmp_path: Path) -> None:
    """A signed command and feedback journalled with their header stamps: the bag written from
    the journal holds exactly the bytes the codec sent (rosbags reads them back), and a record
    CDR cannot carry (a NUL in a damaged journal's message) is a one-line BagError."""
    key = new_key()
    command = Command('t', 4, 0.04, ('top',), (0.0125,))
    feedback = Feedback('t', 4, (0.0124,), (-3859.05,), epoch='ab' * 8)
    sent, signature = Signer(key).sign_wire(
        WIRE_COMMAND, lambda bare: encode_command(command, 1_000, bare))
    answer, reply = sign_wire_reply(
        key, WIRE_FEEDBACK, lambda bare: encode_feedback(feedback, 1_500, bare), signature)
    # As it arrived: a sender's own padding bytes (covered by its MAC) are kept.
    arrived = bytearray(answer)
    arrived[-1] = 0x5A  # the CDR's trailing padding: no field reads it
    assert decode_feedback(bytes(arrived)).record == feedback
    path = tmp_path / JOURNAL_FILE
    with Journal(path) as journal:
        journal.write_definition('{}', 500)
        journal.write_command(command, 1_000, signature=signature)
        journal.write_feedback(feedback, 2_000, signature=reply, stamp_ns=1_500)
        journal.write_feedback(feedback, 2_500, signature=reply, stamp_ns=1_500,
                               data=bytes(arrived))
    assert [payload for kind, *_, payload, _ in by_the_doc(path) if kind != 'def'] == [
        sent, answer, bytes(arrived)]
    journal_to_bag(path, tmp_path / 'bag')
    with AnyReader([tmp_path / 'bag']) as reader:
        stored = [(connection.topic, t_ns, bytes(data))
                  for connection, t_ns, data in reader.messages()
                  if connection.topic in (TOPIC_COMMAND, TOPIC_FEEDBACK)]
    assert stored == [(TOPIC_COMMAND, 1_000, sent), (TOPIC_FEEDBACK, 2_000, answer),
                      (TOPIC_FEEDBACK, 2_500, bytes(arrived))]


def test_a_journal_of_many_blocks_converts_record_for_record_in_order(tmp_path: Path) -> None:
    """A journal of several MB (read a block at a time): records straddling the blocks' ends,
    one longer than a block, events and a definition between the messages. The bag holds,
    in the journal's order, each message's bytes and time as the documented layout reads them,
    and each event in its place (the mcap library reads it with its CRC checks)."""
    rng = np.random.default_rng(33)
    path = tmp_path / JOURNAL_FILE
    # (raw bytes: the copy's mechanics; on a trajectory's topic they would be checked)
    topics = (TOPIC_COMMAND, TOPIC_FEEDBACK, TOPIC_STATUS, '/pd/lab1/bridge/status')
    with Journal(path) as journal:
        journal.write_definition('{"test": {"id": "blocks"}}', 1)
        for t_ns in range(2, 40_002):
            if t_ns % 997 == 0:
                journal.write_event('note', t_ns, at=t_ns)
            elif t_ns == 20_000:  # longer than the block read at a time
                journal.write_raw(topics[3], t_ns, rng.bytes(3 * 2**20 // 2))
            else:
                size = int(rng.integers(0, 400))
                journal.write_raw(topics[t_ns % 3], t_ns, rng.bytes(size))
    expected = by_the_doc(path)
    assert path.stat().st_size > 4 * 2**20
    assert journal_to_bag(path, tmp_path / 'bag') == len(expected)
    (mcap_file,) = (tmp_path / 'bag').glob('*.mcap')
    with mcap_file.open('rb') as stream:
        stored = [(channel.topic, message.log_time, message.data) for _, channel, message
                  in make_reader(stream, validate_crcs=True).iter_messages(
                      log_time_order=False)]
    names = {'def': '/pd/test_definition', 'ev': '/pd/run_events'}
    assert [(topic, t_ns) for topic, t_ns, _ in stored] == [
        (names.get(kind, topic), t_ns) for kind, t_ns, topic, _, _ in expected]
    assert [data for (_, _, data), (kind, *_) in zip(stored, expected, strict=True)
            if kind not in names] == [payload for kind, _, _, payload, _ in expected
                                      if kind not in names]
    # A record damaged in a later block is named by its number and byte, as the layout counts.
    number, (*_, offset) = next((n, record) for n, record in enumerate(expected, 1)
                                if record[4] > 3 * 2**20)
    data = bytearray(path.read_bytes())
    data[offset + 30] ^= 0x01
    damaged = tmp_path / 'damaged.pdj'
    damaged.write_bytes(bytes(data))
    with pytest.raises(BagError, match=f'record {number} at byte {offset}: damaged'):
        journal_to_bag(damaged, tmp_path / 'damaged-bag')
    assert not (tmp_path / 'damaged-bag').exists()


def test_a_record_cdr_cannot_carry_is_one_line_and_nothing_written(tmp_path: Path) -> None:
    path = tmp_path / JOURNAL_FILE
    command = Command('t\x00x', 4, 0.04, ('top',), (0.0125,))  # a NUL in a CDR string
    with Journal(path) as journal:
        journal.write_definition('{}', 500)
        with pytest.raises(BagError, match='step_command') as info:
            journal.write_command(command, 1_000)
        assert '\n' not in str(info.value)
    assert kinds(path) == ['def']


def test_the_bag_is_read_by_the_mcap_library_with_its_checks(offline: Any) -> None:
    """An independent MCAP reader (the format's reference library) validates the bag's CRCs
    and summary and finds every message the journal holds, bytes identical."""
    journal = [(topic, t_ns, payload) for kind, t_ns, topic, payload, _ in
               by_the_doc(offline.directory / JOURNAL_FILE) if kind in ('cmd', 'fb', 'st')]
    (mcap_file,) = (offline.directory / 'bag').glob('*.mcap')
    with mcap_file.open('rb') as stream:
        reader = make_reader(stream, validate_crcs=True)
        stored = [(channel.topic, message.log_time, message.data)
                  for _, channel, message in reader.iter_messages(log_time_order=False)
                  if channel.topic in (TOPIC_COMMAND, TOPIC_FEEDBACK, TOPIC_STATUS)]
        summary = reader.get_summary()
    assert stored == journal
    assert summary is not None
    assert summary.statistics is not None
    assert summary.statistics.message_count >= len(journal)


def test_the_dispatcher_journals_each_command_as_the_bytes_it_went_out_as(
        tmp_path: Path) -> None:
    """A sender that returns what it sent (:class:`Sent`): the journal keeps those bytes,
    not an encoding of its own (its header stamp, 7 ns, is not the record's time: an
    encoding of the journal's own would hold the record's time)."""
    definition = load_test_file(DEFAULT_TEST, overrides={'duration': 0.05})
    server = site_servers(definition)['']
    session = Session(definition)
    queue: deque[tuple[str, Command]] = deque()
    went: list[bytes] = []

    def send(site: str, command: Command) -> Sent:
        data = encode_command(command, 7)
        went.append(data)
        queue.append((site, command))
        return Sent(Signature(), data)

    path = tmp_path / JOURNAL_FILE
    with Journal(path) as journal:
        dispatcher = StepDispatcher(session, send, journal)
        dispatcher.start()
        assert serve_queue(queue, {'': server}, dispatcher)
    kept = [(t_ns, payload) for kind, t_ns, _, payload, _ in by_the_doc(path) if kind == 'cmd']
    assert len(kept) == 6
    assert [payload for _, payload in kept] == went
    assert all(t_ns > 7 for t_ns, _ in kept)


def _trajectory_bytes(samples: int, n_dof: int, values: int | None = None) -> bytes:
    """An ``ActuatorTrajectory``'s CDR bytes, serialised by rclpy (not by the reader)."""
    count = samples * n_dof if values is None else values
    message = ActuatorTrajectory(test_id='t', step=3, iteration=0, rate=1000.0, n_dof=n_dof,
                                 time=[i / 1000 for i in range(samples)],
                                 command=[0.001] * count, measured_displacement=[0.002] * count,
                                 measured_force=[5.0] * count)
    return bytes(serialize_message(message))


def test_a_trajectory_is_read_only_as_one(tmp_path: Path) -> None:
    """The recorder's check: bytes that are no trajectory (garbage, arrays that do not fit
    the samples) are refused in one line; a journal holding one anyway (written before the
    check) is still read, that record left out with a note."""
    store = typestore()
    good = _trajectory_bytes(4, 2)
    message = read_trajectory(good, store)
    assert (message.n_dof, len(message.time), list(message.measured_force)) == (2, 4, [5.0] * 8)
    with pytest.raises(ValueError, match=r'^not an actuator trajectory \('):
        read_trajectory(b'\x00\x01\x00\x00' + bytes(range(7)), store)
    with pytest.raises(ValueError, match=r'command: 3 values for 4 samples of 2 DOFs'):
        read_trajectory(_trajectory_bytes(4, 2, values=3), store)
    path = tmp_path / JOURNAL_FILE
    with Journal(path) as journal:
        journal.write_definition('{"test": {"id": "t"}}', 1)
        journal.write_raw('/pd/bridge/trajectory', 2, good)
        journal.write_raw('/pd/bridge/trajectory', 3, b'\x00\x01\xffraw')
        journal.write_raw('/pd/bridge/trajectory', 4, _trajectory_bytes(4, 2, values=3))
    run = read_journal(path)
    assert [t_ns for t_ns, _ in run.trajectories] == [2]
    # (one note however many: the first described)
    assert run.notes == [run.notes[0]] and run.notes[0].startswith(
        'left out 2 trajectory records (first: /pd/bridge/trajectory at log time 3 ns: not an '
        'actuator trajectory (')
    # Its bag (a copy of the records' bytes) leaves them out too: no message in it that its
    # own definition of the type does not read (the run is not lost to it).
    assert journal_to_bag(path, tmp_path / 'bag') == 2  # the definition and the trajectory
    bag = read_bag(tmp_path / 'bag')
    assert [t_ns for t_ns, _ in bag.trajectories] == [2] and bag.notes == []

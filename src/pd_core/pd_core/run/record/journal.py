"""The run's journal: an append-only record, on disk step by step, that survives a crash.

A pseudo-dynamic test on a real specimen cannot be repeated, so its record must not depend on
the recording process ending well. While a test runs, everything the bag will hold (the
definition, every command sent and feedback received with their signatures, every status,
the actuator trajectories) is appended to ``journal.pdj`` in the run folder, one record per
message, in the order the integrator saw it:

* after every step (the feedback that committed it and the next command) the new records are
  written to the operating system: a process killed at any moment (SIGKILL) loses nothing
  that was committed;
* at most every ``sync_interval`` seconds (default 1 s) the file is also ``fsync``-ed: a power
  loss loses at most that window. With ``sync_in_background`` (the integrator node's journal)
  that ``fsync`` runs in a thread of its own, so the step that asks for it does not wait for
  the disk (a real-time test's loop); the window grows by the time one ``fsync`` takes, and
  should one last a whole interval and at least :data:`pd_common.durable.STUCK_SYNC_S` (a
  stuck disk) the step
  that asks for the next waits for it, as it would for an ``fsync`` of its own. A failed one
  stops the run at the next step, as a failed write does. An interval of 0 (an ``fsync`` per
  committed step, before its next command), an emergency stop's or a hold's record
  (:meth:`Journal.persist`) and the last ``fsync`` at close always run in the caller.

A record holds a message as it travels: a step command or feedback is its CDR bytes, signature
included (the feedback as it arrived), a status its CDR bytes; the definition and the events
are JSON text. Each record is length-prefixed, with a CRC-32 (:mod:`.journal_format` gives the
layout byte by byte). When the test ends the journal is converted to the run's rosbag2 (MCAP)
bag (:func:`journal_to_bag`) as a copy of those bytes; after a crash ``./pd recover RUN`` (or
``./pd replay`` and ``./pd run --resume``, which read the journal directly) does the same. A
journal and its bag give the same history bit for bit. A last record torn by the crash is
ignored (and reported).

Reading a journal ends with its records or one line (:class:`~..errors.BagError`) naming the
file and the record: only a regular file is read (a FIFO or a device is refused before), a
record is at most :data:`~.journal_format.MAX_RECORD_BYTES`, and a record whose CRC fails
before the end, or whose bytes are not a message of its kind, is an error. A journal or bag
that cannot be written (a full disk) raises :class:`RecordWriteError`: one line with what to
do (``./pd recover``); the journal is closed, what reached the disk stays readable, and no
half-written bag is left.

Record kinds: ``def`` (the resolved definition), ``cmd``, ``fb``, ``st`` (a status), ``raw``
(another serialised message, as an actuator trajectory), ``ev`` (an event: resumed,
restarted, ...).
"""

from __future__ import annotations

import contextlib
import gc
import json
import os
import shutil
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import IO, Any, Protocol

from pd_common.durable import IntervalSync
from pd_common.protocol import (
    CdrDecodeError,
    CdrEncodeError,
    Command,
    Feedback,
    Signature,
    Status,
    decode_command,
    decode_feedback,
    decode_status,
    encode_command,
    encode_feedback,
    encode_status,
)

from ...errors import BagError
from .bag import (
    TOPIC_COMMAND,
    TOPIC_FEEDBACK,
    TOPIC_STATUS,
    BagRecorder,
    LeftOut,
    RecordedRun,
    RunIndex,
    is_trajectory_topic,
    read_trajectory,
    typestore,
)
from .journal_format import (
    HEADER,
    Frame,
    RecordKind,
    frame,
    iter_blocks,
    iter_frames,
    records_end,
)

__all__ = ['JOURNAL_FILE', 'LEGACY_JOURNAL_FILE', 'Journal', 'JournalRecord',
           'RecordWriteError', 'RunRecorder', 'iter_journal_records', 'journal_to_bag',
           'read_journal', 'read_journal_records']

#: The journal's file name in a run folder.
JOURNAL_FILE = 'journal.pdj'
#: The journal of a run recorded by an earlier version (JSON lines; not read by this one).
LEGACY_JOURNAL_FILE = 'journal.jsonl'
_UNSIGNED = Signature()
_MAX_TOPIC_BYTES = 0xFFFF
_KIND_NAMES = {RecordKind.DEFINITION: 'def', RecordKind.COMMAND: 'cmd',
               RecordKind.FEEDBACK: 'fb', RecordKind.STATUS: 'st', RecordKind.RAW: 'raw',
               RecordKind.EVENT: 'ev'}
#: The bytes a bag records as they are in the journal.
_COPIED = frozenset((RecordKind.COMMAND, RecordKind.FEEDBACK, RecordKind.STATUS))


class RunRecorder(Protocol):
    """What records a run (the journal during a test; a bag when converting)."""

    def write_definition(self, text: str, t_ns: int) -> None:
        """Record the test definition."""

    def write_command(self, command: Command, t_ns: int, topic: str = TOPIC_COMMAND,
                      signature: Signature | None = None, stamp_ns: int | None = None,
                      data: bytes | None = None) -> None:
        """Record a command sent to a site (``stamp_ns``: its header stamp, if not ``t_ns``).

        ``data``: its CDR bytes as they went out (else encoded of the rest).
        """

    def write_feedback(self, feedback: Feedback, t_ns: int,
                       topic: str = TOPIC_FEEDBACK,
                       signature: Signature | None = None, stamp_ns: int | None = None,
                       data: bytes | None = None) -> None:
        """Record a site's feedback (``stamp_ns``: its header stamp, if not ``t_ns``).

        ``data``: its CDR bytes as they arrived (else encoded of the rest).
        """

    def write_status(self, status: Status, t_ns: int, *,
                     topic: str = TOPIC_STATUS) -> None:
        """Record a status."""

    def write_raw(self, topic: str, t_ns: int, data: bytes) -> None:
        """Record a serialized message of ``topic``."""

    def write_event(self, what: str, t_ns: int, **info: Any) -> None:
        """Record an event of the run."""

    def flush(self, *, sync: bool = True) -> None:
        """Hand the records to the operating system (and ``fsync`` with ``sync``)."""

    def close(self) -> None:
        """Write what is pending and close."""


class RecordWriteError(BagError):
    """The run's record (its journal, or the bag made of it) cannot be written.

    A full disk, a file system gone read-only. One line naming the file, the reason and what to do.
    """


def _signed(signature: Signature | None) -> Signature:
    """A message's signature as recorded: none unless it has a MAC."""
    return signature if signature is not None and signature.signed else _UNSIGNED


class Journal:
    """Appends a run's records to ``journal.pdj``; durable per step (see the module).

    Args:
        path: the journal file (created, or appended to when ``append``).
        sync_interval: most seconds between two ``fsync`` calls (0: every flush).
        append: continue an existing journal (a resumed run): a record a crash tore at its
            end is cut off first.
        clock: monotonic clock for the sync interval.
        sync_in_background: the interval's ``fsync`` in a thread of its own
            (:class:`pd_common.durable.BackgroundSync`), not in the step that asks for it.
    """

    def __init__(self, path: str | Path, *, sync_interval: float = 1.0, append: bool = False,
                 clock: Callable[[], float] = time.monotonic,
                 sync_in_background: bool = False) -> None:
        self.path = Path(path)
        self.sync_interval = sync_interval
        self._append = append
        self._clock = clock
        self._sync_in_background = sync_in_background
        self._sync: IntervalSync | None = None
        self._file: IO[bytes] | None = None
        self._pending: list[bytes] = []
        self._topics: dict[str, bytes] = {}
        self.records = 0
        self.events: list[dict[str, Any]] = []

    def open(self) -> Journal:
        """Create (or reopen for appending) the journal.

        Raises:
            BagError: it exists (and ``append`` is false), is damaged before its end (when
                appending), or cannot be written.
        """
        if self._file is not None:
            return self
        try:
            if self._append and self.path.exists():
                self._file = self._reopen()
            else:
                self._file = self.path.open('xb')
                self._file.write(HEADER)
                self._file.flush()  # a journal on disk is one from its first byte
        except FileExistsError:
            msg = f'{self.path}: a journal exists already (resume the run, or use a new folder)'
            raise BagError(msg) from None
        except OSError as err:
            msg = f'{self.path}: cannot write the journal ({err.strerror})'
            raise BagError(msg) from None
        self._sync = IntervalSync(self._file.fileno(), self.sync_interval,
                                  background=self._sync_in_background, clock=self._clock,
                                  name='journal-fsync')
        return self

    def _reopen(self) -> IO[bytes]:
        """The journal opened at the end of its last complete record (a torn one cut off)."""
        end = records_end(self.path)
        file = self.path.open('r+b')
        try:
            if end == 0:  # not even its header: a run killed as it began
                file.truncate(0)
                file.write(HEADER)
            elif file.seek(0, os.SEEK_END) > end:
                file.truncate(end)
            file.seek(0, os.SEEK_END)
        except BaseException:
            file.close()
            raise
        return file

    def __enter__(self) -> Journal:
        """Open the journal."""
        return self.open()

    def __exit__(self, *exc: object) -> None:
        """Close the journal."""
        self.close()

    def _add(self, kind: RecordKind, t_ns: int, topic: str, payload: bytes) -> None:
        raw_topic = self._topics.get(topic)
        if raw_topic is None:
            raw_topic = topic.encode('utf-8')
            if len(raw_topic) > _MAX_TOPIC_BYTES:
                msg = f'{self.path}: a topic name of {len(raw_topic)} bytes: too long to record'
                raise BagError(msg)
            self._topics[topic] = raw_topic
        self._pending.append(frame(kind, t_ns, raw_topic, payload))
        self.records += 1

    def _cdr(self, topic: str, encode: Callable[[], bytes]) -> bytes:
        """A message's CDR bytes (a value CDR cannot carry: one line naming the topic)."""
        try:
            return encode()
        except CdrEncodeError as err:
            msg = f'{self.path}: {topic}: {err}'
            raise BagError(msg) from None

    # -- records --------------------------------------------------------------------------
    def write_definition(self, text: str, t_ns: int) -> None:
        """Record the resolved test definition (JSON text)."""
        self._add(RecordKind.DEFINITION, t_ns, '', text.encode('utf-8'))

    def write_command(self, command: Command, t_ns: int, topic: str = TOPIC_COMMAND,
                      signature: Signature | None = None, stamp_ns: int | None = None,
                      data: bytes | None = None) -> None:
        """Record a command: the CDR bytes it went out as (``data``), else encoded.

        Encoded of the record, its signature and its header stamp (default ``t_ns``) when
        ``data`` is not given (a run in one process): the bytes the integrator would send, as
        it stamps what it sends with the time the dispatcher records
        (:attr:`.StepDispatcher.send_stamp_ns`).
        """
        if data is None:
            stamp = t_ns if stamp_ns is None else stamp_ns
            data = self._cdr(topic, lambda: encode_command(command, stamp, _signed(signature)))
        self._add(RecordKind.COMMAND, t_ns, topic, data)

    def write_feedback(self, feedback: Feedback, t_ns: int, topic: str = TOPIC_FEEDBACK,
                       signature: Signature | None = None, stamp_ns: int | None = None,
                       data: bytes | None = None) -> None:
        """Record a feedback: the CDR bytes it arrived as (``data``), else encoded.

        Encoded of the record, its signature and its header stamp (default ``t_ns``) when
        ``data`` is not given (a run in one process). Either way the bytes a signature
        covers: ``./pd replay --key`` checks them.
        """
        if data is None:
            stamp = t_ns if stamp_ns is None else stamp_ns
            data = self._cdr(topic, lambda: encode_feedback(feedback, stamp,
                                                            _signed(signature)))
        self._add(RecordKind.FEEDBACK, t_ns, topic, data)

    def write_status(self, status: Status, t_ns: int, *, topic: str = TOPIC_STATUS) -> None:
        """Record a status (the integrator's, or a bridge's on its topic)."""
        self._add(RecordKind.STATUS, t_ns, topic,
                  self._cdr(topic, lambda: encode_status(status, t_ns)))

    def write_raw(self, topic: str, t_ns: int, data: bytes) -> None:
        """Record an already serialised (CDR) message (e.g. an actuator trajectory)."""
        self._add(RecordKind.RAW, t_ns, topic, bytes(data))

    def write_event(self, what: str, t_ns: int, **info: Any) -> None:
        """Record an event of the run (resumed, a process restarted, ...).

        Kept in :attr:`events` too.
        """
        text = json.dumps({'what': what, **info}, sort_keys=True)
        self._add(RecordKind.EVENT, t_ns, '', text.encode('utf-8'))
        self.events.append({'what': what, **info, 't_ns': t_ns})

    # -- durability ---------------------------------------------------------------------------
    def flush(self, *, sync: bool = True) -> None:
        """Hand the new records to the operating system.

        ``fsync`` if the interval is over (and ``sync``: records a crash may lose, as a command the
        resumed run recomputes, need no ``fsync`` of their own).

        Raises:
            RecordWriteError: the records cannot be written (the file is closed then).
        """
        file, policy = self._file, self._sync
        if file is None or policy is None or not self._pending:
            return
        try:
            policy.check()  # the last interval's fsync failed: nothing more is written
            file.write(b''.join(self._pending))
            self._pending.clear()
            file.flush()
            if sync:
                policy.written()
        except OSError as err:
            raise self._write_failed(err) from None

    def persist(self) -> None:
        """Hand the new records to the operating system and ``fsync`` now.

        An emergency stop, a person's hold: on disk before the node answers anything else.

        Raises:
            RecordWriteError: the records cannot be written (the file is closed then).
        """
        self.flush(sync=False)
        if self._sync is not None and self._file is not None:
            try:
                self._sync.sync_now()
            except OSError as err:
                raise self._write_failed(err) from None

    def close(self) -> None:
        """Write and sync what is pending.

        Close the file (a journal whose writing failed is only closed: its error was raised
        already).

        Raises:
            RecordWriteError: what was pending cannot be written (the file is closed).
        """
        if self._file is None:
            return
        self.flush()
        if self._file is None:
            return
        try:
            if self._sync is not None:
                self._sync.close()  # (a background fsync's failure raised first)
            self._file.close()
        except OSError as err:
            raise self._write_failed(err) from None
        self._file = None

    def _write_failed(self, err: OSError) -> RecordWriteError:
        """Close the file after a failed write and return the error to raise.

        Close the file after a failed write (what it still buffers is dropped) and return
        the error to raise.
        """
        self._pending.clear()
        if self._sync is not None:
            self._sync.stop()
        file, self._file = self._file, None
        if file is not None:
            try:
                file.close()  # flushes its buffer again (and fails again): closed all the same
            except OSError:
                pass
        reason = err.strerror or type(err).__name__
        msg = (f'{self.path}: cannot write the journal ({reason}); the run stops, its record '
               f'ends at the last step on disk: once there is room, ./pd recover '
               f'{self.path.parent} rebuilds its outputs')
        return RecordWriteError(msg)


@dataclass(frozen=True)
class JournalRecord:
    """One record read back: its kind, and the item it holds.

    Attributes:
        kind: ``def``, ``cmd``, ``fb``, ``st``, ``raw`` or ``ev``.
        t_ns: its time [ns since the epoch] (the bag's log time).
        topic: its topic ('' for a definition or an event).
        item: a :class:`Command`, :class:`Feedback`, :class:`Status`, the definition's JSON
            text, an event's object (with its ``what``) or a raw record's bytes.
        signature: a command's or feedback's signature (unsigned for the rest).
        stamp_ns: a command's or feedback's header stamp (``t_ns`` for the rest).
        data: the record's payload as it is on disk (a message's CDR bytes; JSON text).
    """

    kind: str
    t_ns: int
    topic: str
    item: Any
    signature: Signature
    stamp_ns: int = 0
    data: bytes = b''


def _record(record: Frame) -> JournalRecord:
    """One record of its frame.

    Raises:
        CdrDecodeError, ValueError, TypeError, RecursionError: not a record of its kind.
    """
    kind, t_ns, payload = record.kind, record.t_ns, record.payload
    signature, stamp_ns = _UNSIGNED, t_ns
    item: Any
    if kind is RecordKind.COMMAND:
        item, stamp_ns, signature, _ = decode_command(payload)
    elif kind is RecordKind.FEEDBACK:
        item, stamp_ns, signature, _ = decode_feedback(payload)
    elif kind is RecordKind.STATUS:
        item = decode_status(payload).record
    elif kind is RecordKind.DEFINITION:
        item = payload.decode('utf-8')
    elif kind is RecordKind.EVENT:
        item = json.loads(payload.decode('utf-8'))
        if not isinstance(item, dict) or not isinstance(item.get('what'), str):
            msg = 'not an event: a JSON object with its "what"'
            raise TypeError(msg)
    else:
        item = payload
    return JournalRecord(kind=_KIND_NAMES[kind], t_ns=t_ns, topic=record.topic, item=item,
                         signature=signature, stamp_ns=stamp_ns, data=payload)


def iter_journal_records(path: str | Path, notes: list[str] | None = None
                         ) -> Iterator[JournalRecord]:
    """The complete records of a journal.

    One at a time (a long run's journal is never held in memory whole); a last record a
    crash tore is skipped and described in ``notes``.

    Raises:
        BagError: the file cannot be read, is not a journal, or a record before its end is
            damaged or malformed.
    """
    for record in iter_frames(path, notes):
        yield _decoded(record, path)


def _decoded(record: Frame, path: str | Path) -> JournalRecord:
    """:func:`_record`, or one line naming the journal and the record.

    Raises:
        BagError: the record's bytes are not a record of its kind.
    """
    try:
        return _record(record)
    except (CdrDecodeError, ValueError, TypeError, RecursionError) as err:
        reason = 'JSON nested too deep' if isinstance(err, RecursionError) else str(err)
        msg = (f'{path}: record {record.number} at byte {record.offset}: malformed '
               f'{_KIND_NAMES[record.kind]} record ({reason})')
        raise BagError(msg) from None


def read_journal_records(path: str | Path) -> tuple[list[JournalRecord], str]:
    """Every complete record of a journal, and a note ('' or what was ignored at its end).

    Raises:
        BagError: as :func:`iter_journal_records`.
    """
    notes: list[str] = []
    records = list(iter_journal_records(path, notes))
    return records, notes[0] if notes else ''


def read_journal(path: str | Path) -> RecordedRun:
    """The run a journal records (the same structure :func:`.bag.read_bag` returns).

    Raises:
        BagError: unreadable, or no test definition in it.
    """
    notes: list[str] = []
    left_out = LeftOut('record')
    index = RunIndex()
    store = typestore()
    for record in iter_journal_records(path, notes):
        if record.kind == 'def':
            index.definition(record.item)
        elif record.kind in ('cmd', 'fb'):
            index.message(record.topic, record.t_ns, record.item, record.signature,
                          record.stamp_ns)
        elif record.kind == 'st':
            index.status(record.topic, record.t_ns, record.item)
        elif record.kind == 'raw' and is_trajectory_topic(record.topic):
            try:  # (informative: one that is no trajectory is left out, the run still read)
                index.trajectory(record.t_ns, read_trajectory(record.item, store))
            except ValueError as err:
                left_out.add(record.topic, record.t_ns, err)
        elif record.kind == 'ev':
            index.event(record.t_ns, dict(record.item))
    run = index.result(str(path))
    run.notes = notes + left_out.notes()
    return run


def journal_to_bag(journal: str | Path, bag: str | Path) -> int:
    """Write the rosbag2 bag of a journal (what the recorder would have written); its records.

    The bag is written in a folder beside it (``.<bag>.partial/<bag>``) and moved to its place
    once complete: a journal that turns out unreadable, or a disk that fills up, leaves no bag
    behind.

    Raises:
        BagError: unreadable journal; a :class:`RecordWriteError` if the bag cannot be written.
    """
    bag = Path(bag)
    if bag.exists():
        msg = f'{bag}: bag exists already, not overwriting'
        raise BagError(msg)
    partial = bag.parent / f'.{bag.name}.partial'
    try:
        if partial.exists():  # left by a process killed while it converted
            shutil.rmtree(partial)
        partial.mkdir()
        count = _write_bag(journal, partial / bag.name)
        (partial / bag.name).rename(bag)
    except OSError as err:
        msg = (f'{bag}: cannot write the bag ({err.strerror or type(err).__name__}); once '
               f'there is room, ./pd recover {bag.parent} writes it from the journal')
        raise RecordWriteError(msg) from None
    finally:
        shutil.rmtree(partial, ignore_errors=True)
    return count


@contextlib.contextmanager
def _collector_paused() -> Iterator[None]:
    """Python's cyclic garbage collector paused (if it runs) while many records are copied.

    A copy allocates a few tuples per record and no cycle (reference counting frees them all);
    left running, the collector would pass over the block's records every 700 allocations
    (about 7 % of the conversion's time here). It runs again afterwards, whatever happened.
    """
    running = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if running:
            gc.enable()


def _readable(record: Frame) -> bool:
    """Whether a raw record is a message the run's reader reads (a trajectory's, checked)."""
    if not is_trajectory_topic(record.topic):
        return True
    try:
        read_trajectory(record.payload, typestore())
    except ValueError:
        return False
    return True


def _write_bag(journal: str | Path, bag: Path) -> int:
    """:func:`journal_to_bag` into ``bag`` (created); the records written.

    A message's bytes are copied as they are (the record's CRC vouches for them), a block of
    the journal at a time; the definition and the events become ``std_msgs/msg/String``
    messages, in their place among the messages. A trajectory the run's reader cannot read
    (one recorded before trajectories were signed, or no trajectory at all) is left out, as
    :func:`read_journal` leaves it out: the bag's definition of the type would not fit it.
    """
    count = 0
    with _collector_paused(), BagRecorder(bag) as recorder:
        write_many, channel = recorder.writer.write_many, recorder.channel

        def copy(data: bytes, rows: list[tuple[int, int, RecordKind, int, str, int]]) -> None:
            # (slices of bytes: each a small copy, cheaper here to make and to join than views)
            write_many([(channel(topic), t_ns, data[payload:end])
                        for _, end, _, t_ns, topic, payload in rows])

        for data, base, number, records in iter_blocks(journal):
            done = 0
            for index in [i for i, row in enumerate(records) if row[2] not in _COPIED]:
                copy(data, records[done:index])
                start, end, kind, t_ns, topic, payload = records[index]
                record = Frame(kind, t_ns, topic, data[payload:end], base + start, base + end,
                               number + index)
                if kind is RecordKind.DEFINITION:
                    recorder.write_definition(_decoded(record, journal).item, t_ns)
                elif kind is RecordKind.RAW:
                    if _readable(record):
                        copy(data, [records[index]])
                    else:
                        count -= 1  # (left out)
                else:
                    event = dict(_decoded(record, journal).item)
                    recorder.write_event(event.pop('what'), t_ns, **event)
                done = index + 1
            copy(data, records[done:])
            count += len(records)
    return count

"""The run's journal: an append-only record, on disk step by step, that survives a crash.

A pseudo-dynamic test on a real specimen cannot be repeated, so its record must not depend on
the recording process ending well. While a test runs, everything the bag will hold (the
definition, every command sent and feedback received with their signatures, every status,
the actuator trajectories) is appended to ``journal.jsonl`` in the run folder, one JSON record
per line, in the order the integrator saw it:

* after every step (the feedback that committed it and the next command) the new records are
  written to the operating system: a process killed at any moment (SIGKILL) loses nothing
  that was committed;
* at most every ``sync_interval`` seconds (default 1 s) the file is also ``fsync``-ed: a power
  loss loses at most that window.

When the test ends the journal is converted to the run's rosbag2 (MCAP) bag
(:func:`journal_to_bag`); after a crash ``./pd recover RUN`` (or ``./pd replay`` and
``./pd run --resume``, which read the journal directly) does the same. The floats are written
with ``repr`` (exact round trip): a journal and its bag give the same history bit for bit. A
last line cut by the crash is ignored (and reported).

Reading a journal ends with its records or one line (:class:`~..errors.BagError`) naming the
file and the line: only a regular file is read (a FIFO or a device is refused before), a line
is at most :data:`MAX_LINE_BYTES`, and a line that is not UTF-8, not JSON (or JSON nested
deeper than its decoder recurses), not an object or not a record of its kind is malformed. A
journal or bag that cannot be written (a full disk) raises :class:`RecordWriteError`: one
line with what to do (``./pd recover``); the journal is closed, what reached the disk stays
readable, and no half-written bag is left.

Record kinds (``k``): ``def`` (the resolved definition), ``cmd``, ``fb``, ``st`` (a status),
``raw`` (a serialised message, base64), ``ev`` (an event: resumed, restarted, ...).
"""

from __future__ import annotations

import base64
import json
import os
import shutil
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import IO, Any, Protocol

from pd_common.config import open_regular_file
from pd_common.jsonl import end_last_line
from pd_common.protocol import (
    Command,
    Feedback,
    FeedbackStatus,
    Signature,
    StateOrigin,
    Status,
    TestState,
)

from ...errors import BagError
from .bag import (
    MSG_TRAJECTORY,
    TOPIC_COMMAND,
    TOPIC_FEEDBACK,
    TOPIC_STATUS,
    BagRecorder,
    RecordedRun,
    RunIndex,
    typestore,
)

__all__ = ['JOURNAL_FILE', 'MAX_LINE_BYTES', 'Journal', 'JournalRecord', 'RecordWriteError',
           'RunRecorder', 'iter_journal_records', 'journal_to_bag', 'read_journal',
           'read_journal_records']

#: The journal's file name in a run folder.
JOURNAL_FILE = 'journal.jsonl'
#: The longest line read back (the definition's line holds the whole record, inlined: a few
#: MB for the longest records; a longer line is no record of this project's).
MAX_LINE_BYTES = 256 * 2**20
_VERSION = 1
#: One encoder for every record (``json.dumps`` with these options builds one per call).
_ENCODE = json.JSONEncoder(separators=(',', ':'), allow_nan=True).encode


class RunRecorder(Protocol):
    """What records a run (the journal during a test; a bag when converting)."""

    def write_definition(self, text: str, t_ns: int) -> None:
        """Record the test definition."""

    def write_command(self, command: Command, t_ns: int, topic: str = TOPIC_COMMAND,
                      signature: Signature | None = None, stamp_ns: int | None = None) -> None:
        """Record a command sent to a site (``stamp_ns``: its header stamp, if not ``t_ns``)."""

    def write_feedback(self, feedback: Feedback, t_ns: int,
                       topic: str = TOPIC_FEEDBACK,
                       signature: Signature | None = None, stamp_ns: int | None = None) -> None:
        """Record a site's feedback (``stamp_ns``: its header stamp, if not ``t_ns``)."""

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


def _signature(signature: Signature | None) -> list[Any] | None:
    if signature is None or not signature.signed:
        return None
    return [signature.key_id, signature.session, signature.sequence, signature.mac.hex()]


def _unsignature(value: Any) -> Signature:
    if not value:
        return Signature()
    key_id, session, sequence, mac = value
    return Signature(key_id=key_id, session=session, sequence=int(sequence),
                     mac=bytes.fromhex(mac))


def _floats(values: Any) -> list[float]:
    return [float(x) for x in values]


class Journal:
    """Appends a run's records to ``journal.jsonl``; durable per step (see the module).

    Args:
        path: the journal file (created, or appended to when ``append``).
        sync_interval: most seconds between two ``fsync`` calls (0: every flush).
        append: continue an existing journal (a resumed run).
        clock: monotonic clock for the sync interval.
    """

    def __init__(self, path: str | Path, *, sync_interval: float = 1.0, append: bool = False,
                 clock: Callable[[], float] = time.monotonic) -> None:
        self.path = Path(path)
        self.sync_interval = sync_interval
        self._append = append
        self._clock = clock
        self._file: IO[str] | None = None
        self._pending: list[str] = []
        self._synced = 0.0
        self.records = 0
        self.events: list[dict[str, Any]] = []

    def open(self) -> Journal:
        """Create (or reopen for appending) the journal.

        Raises:
            BagError: it exists (and ``append`` is false), or cannot be written.
        """
        if self._file is not None:
            return self
        try:
            if self._append:
                end_last_line(self.path)
                self._file = self.path.open('a', encoding='utf-8')
            else:
                self._file = self.path.open('x', encoding='utf-8')
                self._add({'k': 'journal', 'version': _VERSION})
        except FileExistsError:
            msg = f'{self.path}: a journal exists already (resume the run, or use a new folder)'
            raise BagError(msg) from None
        except OSError as err:
            msg = f'{self.path}: cannot write the journal ({err.strerror})'
            raise BagError(msg) from None
        self._synced = self._clock()
        return self

    def __enter__(self) -> Journal:
        """Open the journal."""
        return self.open()

    def __exit__(self, *exc: object) -> None:
        """Close the journal."""
        self.close()

    def _add(self, record: dict[str, Any]) -> None:
        self._pending.append(_ENCODE(record))
        self.records += 1

    # -- records --------------------------------------------------------------------------
    def write_definition(self, text: str, t_ns: int) -> None:
        """Record the resolved test definition (JSON text)."""
        self._add({'k': 'def', 't': t_ns, 'json': text})

    def write_command(self, command: Command, t_ns: int, topic: str = TOPIC_COMMAND,
                      signature: Signature | None = None, stamp_ns: int | None = None) -> None:
        """Record a command (with its signature; its header stamp ``hs`` if not ``t_ns``)."""
        record = {'k': 'cmd', 't': t_ns, 'topic': topic, 'id': command.test_id,
                  'step': command.step, 'it': command.iteration,
                  'time': float(command.test_time), 'dofs': list(command.dof_names),
                  'x': _floats(command.target_displacement), 'sig': _signature(signature)}
        if command.control_mode or command.target_force:  # mixed control only
            record['mode'] = [int(mode) for mode in command.control_mode]
            record['fx'] = _floats(command.target_force)
        if stamp_ns is not None and stamp_ns != t_ns:
            record['hs'] = stamp_ns
        self._add(record)

    def write_feedback(self, feedback: Feedback, t_ns: int, topic: str = TOPIC_FEEDBACK,
                       signature: Signature | None = None, stamp_ns: int | None = None) -> None:
        """Record a feedback (with its signature; its header stamp ``hs`` if not ``t_ns``).

        The header stamp is the sender's (the bytes a signature covers hold it): with it the
        bag holds the message as it arrived, and ``./pd replay --key`` checks it.
        """
        record = {'k': 'fb', 't': t_ns, 'topic': topic, 'id': feedback.test_id,
                  'step': feedback.step, 'it': feedback.iteration,
                  'xm': _floats(feedback.measured_displacement),
                  'r': _floats(feedback.restoring_force), 'status': int(feedback.status),
                  'msg': feedback.message, 'epoch': feedback.epoch,
                  'origin': int(feedback.state_origin), 'sig': _signature(signature)}
        if stamp_ns is not None and stamp_ns != t_ns:
            record['hs'] = stamp_ns
        self._add(record)

    def write_status(self, status: Status, t_ns: int, *, topic: str = TOPIC_STATUS) -> None:
        """Record a status (the integrator's, or a bridge's on its topic)."""
        self._add({'k': 'st', 't': t_ns, 'topic': topic, 'id': status.test_id,
                   'state': int(status.state), 'step': status.step,
                   'total': status.total_steps, 'omega_dt': float(status.omega_dt),
                   'retries': status.retries, 'ignored': status.ignored_messages,
                   'msg': status.message, 'refused': status.refused_messages,
                   'refused_by': status.refused_by_reason, **_status_extras(status)})

    def write_raw(self, topic: str, t_ns: int, data: bytes) -> None:
        """Record an already serialised (CDR) message (e.g. an actuator trajectory)."""
        self._add({'k': 'raw', 't': t_ns, 'topic': topic,
                   'cdr': base64.b64encode(data).decode('ascii')})

    def write_event(self, what: str, t_ns: int, **info: Any) -> None:
        """Record an event of the run (resumed, a process restarted, ...).

        Kept in :attr:`events` too.
        """
        self._add({'k': 'ev', 't': t_ns, 'what': what, **info})
        self.events.append({'what': what, **info, 't_ns': t_ns})

    # -- durability ---------------------------------------------------------------------------
    def flush(self, *, sync: bool = True) -> None:
        """Hand the new records to the operating system.

        ``fsync`` if the interval is over (and ``sync``: records a crash may lose, as a command the
        resumed run recomputes, need no ``fsync`` of their own).

        Raises:
            RecordWriteError: the records cannot be written (the file is closed then).
        """
        file = self._file
        if file is None or not self._pending:
            return
        try:
            file.write('\n'.join(self._pending) + '\n')
            self._pending.clear()
            file.flush()
            if not sync:
                return
            now = self._clock()
            if now - self._synced >= self.sync_interval:
                os.fsync(file.fileno())
                self._synced = now
        except OSError as err:
            raise self._write_failed(err) from None

    def persist(self) -> None:
        """Hand the new records to the operating system and ``fsync`` now.

        An emergency stop, a person's hold: on disk before the node answers anything else.

        Raises:
            RecordWriteError: the records cannot be written (the file is closed then).
        """
        self.flush(sync=False)
        if self._file is not None:
            try:
                os.fsync(self._file.fileno())
            except OSError as err:
                raise self._write_failed(err) from None
            self._synced = self._clock()

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
            os.fsync(self._file.fileno())
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
    """One record read back: its kind, and the item it holds."""

    kind: str
    t_ns: int
    topic: str
    item: Any
    signature: Signature
    stamp_ns: int = 0  # a command's or feedback's header stamp (t_ns unless recorded apart)


def _status(record: dict[str, Any]) -> Status:
    try:
        state = TestState(record['state'])
    except ValueError:
        state = TestState.IDLE
    return Status(test_id=record['id'], state=state, step=record['step'],
                  total_steps=record['total'], omega_dt=record['omega_dt'],
                  retries=record['retries'], ignored_messages=record['ignored'],
                  message=record['msg'], refused_messages=record.get('refused', 0),
                  refused_by_reason=record.get('refused_by', ''), node=record.get('node', ''),
                  session=record.get('session', ''),
                  emergency_stop=bool(record.get('estop', False)),
                  operator_hold=bool(record.get('oper', False)),
                  acknowledged=record.get('ack', ''))


def _status_extras(status: Status) -> dict[str, Any]:
    """The fields of a node's status that only some statuses set (kept out of the rest)."""
    extras: dict[str, Any] = {}
    for name, value in (('node', status.node), ('session', status.session),
                        ('estop', status.emergency_stop), ('oper', status.operator_hold),
                        ('ack', status.acknowledged)):
        if value:
            extras[name] = value
    return extras


def _text(value: Any, name: str) -> str:
    """A record's string field (a ``TypeError`` otherwise: the record is malformed)."""
    if not isinstance(value, str):
        msg = f'{name} is not a string'
        raise TypeError(msg)
    return value


def _integer(value: Any, name: str) -> int:
    """A record's integer field (a ``TypeError`` otherwise: the record is malformed)."""
    if isinstance(value, bool) or not isinstance(value, int):
        msg = f'{name} is not an integer'
        raise TypeError(msg)
    return value


def _record(raw: Any) -> JournalRecord:
    """One record of its JSON object.

    Raises:
        ValueError, KeyError, TypeError, ArithmeticError: not a record of its kind.
    """
    if not isinstance(raw, dict):
        msg = f'a JSON {type(raw).__name__}, not an object'
        raise TypeError(msg)
    kind = _text(raw['k'], 'k')
    t_ns = int(raw.get('t', 0))
    topic = _text(raw.get('topic', ''), 'topic')
    signature = _unsignature(raw.get('sig'))
    item: Any
    if kind == 'cmd':
        item = Command(test_id=_text(raw['id'], 'id'), step=_integer(raw['step'], 'step'),
                       test_time=float(raw['time']),
                       dof_names=tuple(_text(name, 'dofs') for name in raw['dofs']),
                       target_displacement=tuple(_floats(raw['x'])),
                       iteration=_integer(raw['it'], 'it'),
                       control_mode=tuple(_integer(mode, 'mode') for mode in raw.get('mode', ())),
                       target_force=tuple(_floats(raw.get('fx', ()))))
    elif kind == 'fb':
        item = Feedback(test_id=_text(raw['id'], 'id'), step=_integer(raw['step'], 'step'),
                        measured_displacement=tuple(_floats(raw['xm'])),
                        restoring_force=tuple(_floats(raw['r'])),
                        status=FeedbackStatus(raw['status']), message=_text(raw['msg'], 'msg'),
                        iteration=_integer(raw['it'], 'it'),
                        epoch=_text(raw.get('epoch', ''), 'epoch'),
                        state_origin=StateOrigin(raw.get('origin', 0)))
    elif kind == 'st':
        item = _status(raw)
    elif kind == 'def':
        item = _text(raw['json'], 'json')
    elif kind == 'raw':
        item = base64.b64decode(_text(raw['cdr'], 'cdr'), validate=True)
    else:
        item = raw
    return JournalRecord(kind=kind, t_ns=t_ns, topic=topic, item=item, signature=signature,
                         stamp_ns=_integer(raw.get('hs', t_ns), 'hs'))


def iter_journal_records(path: str | Path, notes: list[str] | None = None
                         ) -> Iterator[JournalRecord]:
    """The complete records of a journal.

    One at a time (a long run's journal is never held in memory whole); a last line a crash cut
    short is skipped and described in ``notes``.

    Raises:
        BagError: the file cannot be read, or a complete line is malformed.
    """
    path = Path(path)
    try:
        with open_regular_file(path) as file:
            number = 0
            while data := file.readline(MAX_LINE_BYTES + 1):
                number += 1
                if len(data) > MAX_LINE_BYTES:
                    msg = (f'{path}: line {number}: longer than {MAX_LINE_BYTES // 2**20} MiB: '
                           'not a journal record')
                    raise BagError(msg)
                cut = not data.endswith(b'\n')  # only the very last line can lack it
                data = data.rstrip(b'\n')
                if not data:
                    continue
                try:
                    line = data.decode('utf-8')
                    raw = json.loads(line)
                    if isinstance(raw, dict) and raw.get('k') == 'journal':
                        continue
                    record = _record(raw)
                except (ValueError, KeyError, TypeError, ArithmeticError,
                        RecursionError) as err:
                    if cut:  # the line a crash cut short
                        if notes is not None:
                            notes.append(f'ignored the last record of {path.name}, cut short '
                                         f'({len(data)} bytes)')
                        return
                    msg = f'{path}: line {number}: malformed journal record ({_reason(err)})'
                    raise BagError(msg) from None
                yield record
    except OSError as err:
        msg = f'{path}: cannot read the journal ({err.strerror or type(err).__name__})'
        raise BagError(msg) from None


def _reason(err: Exception) -> str:
    """Why a line is not a record, in a few words."""
    if isinstance(err, UnicodeDecodeError):
        return f'not UTF-8 text: byte 0x{err.object[err.start]:02x} at column {err.start + 1}'
    if isinstance(err, RecursionError):
        return 'JSON nested too deep'
    if isinstance(err, KeyError):
        return f'no {err}'
    return str(err)


def read_journal_records(path: str | Path) -> tuple[list[JournalRecord], str]:
    """Every complete record of a journal, and a note ('' or what was ignored at its end).

    Raises:
        BagError: the file cannot be read, or a record before the last line is malformed.
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
        elif record.kind == 'raw' and record.topic.endswith('/bridge/trajectory'):
            index.trajectory(record.t_ns, _trajectory(store, record, path))
        elif record.kind == 'ev':
            index.event(record.t_ns, _event(record.item))
    run = index.result(str(path))
    run.notes = notes
    return run


def _trajectory(store: Any, record: JournalRecord, path: str | Path) -> Any:
    """An actuator trajectory's message from its serialised record.

    Raises:
        BagError: the bytes are not such a message.
    """
    try:
        return store.deserialize_cdr(record.item, MSG_TRAJECTORY)
    except Exception as err:
        msg = f'{path}: a {record.topic} record is not an actuator trajectory ({err})'
        raise BagError(msg) from err


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


def _write_bag(journal: str | Path, bag: Path) -> int:
    """:func:`journal_to_bag` into ``bag`` (created); the records written."""
    count = 0
    with BagRecorder(bag) as recorder:
        for record in iter_journal_records(journal):
            count += 1
            if record.kind == 'def':
                recorder.write_definition(record.item, record.t_ns)
            elif record.kind == 'cmd':
                recorder.write_command(record.item, record.t_ns, record.topic, record.signature,
                                       record.stamp_ns)
            elif record.kind == 'fb':
                recorder.write_feedback(record.item, record.t_ns, record.topic,
                                        record.signature, record.stamp_ns)
            elif record.kind == 'st':
                recorder.write_status(record.item, record.t_ns, topic=record.topic)
            elif record.kind == 'raw':
                recorder.write_raw(record.topic, record.t_ns, record.item)
            elif record.kind == 'ev':
                event = _event(record.item)
                recorder.write_event(event.pop('what', 'event'), record.t_ns, **event)
    return count


def _event(raw: dict[str, Any]) -> dict[str, Any]:
    """An event record's content (its kind and time stamp left out)."""
    return {key: value for key, value in raw.items() if key not in ('k', 't')}

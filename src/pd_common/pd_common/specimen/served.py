"""A simulated specimen's own record: the commands it served, to restore it after a restart.

The models are displacement-driven: driving a new specimen through the same sequence of
served commands (the same ``(test id, step, iteration)`` and targets, in the same order) gives
the same state bit for bit — the injected errors' random draws included. The simulator
appends every command it serves as a new move (not a repeat answered from the last reply, not
a stale one it ignored) to a JSON-lines *state file*, handed to the operating system before
the answer is published; a restarted simulator given the same file replays it into its fresh
server before it answers anything, and declares its state restored through the last command
(never a silently new specimen).

The file's first line names the specimen (a fingerprint of its definition, with the site's
setup and force ramp when it has them): a state file of another specimen is refused. A line
is ``[test id, step, iteration, targets]``, and for a command with control modes also its
``modes`` and ``forces``: ``[test id, step, iteration, targets, modes, forces]`` (a mixed
command replays exactly; plain lines are as before).
"""

from __future__ import annotations

import errno
import functools
import hashlib
import json
import math
from collections.abc import Sequence
from pathlib import Path
from typing import IO, Any

from ..durable import IntervalSync
from ..errors import SpecimenError, StateFileError
from ..jsonl import end_last_line
from ..protocol.messages import StepKey
from .server import SpecimenServer

__all__ = ['ServedRecord', 'restore_served', 'specimen_fingerprint']

_KIND = 'pd-specimen-state'
#: One encoder for every line (``json.dumps`` with options builds a new one per call).
_ENCODE = json.JSONEncoder(separators=(',', ':')).encode
#: A test id as JSON text (a run has one, or a few: each encoded once).
_json_text = functools.lru_cache(maxsize=16)(_ENCODE)


def specimen_fingerprint(section: Any, dof_names: list[str], geometry: Any = None) -> str:
    """A short fingerprint of a specimen definition.

    Its section and DOF names, and the server's :attr:`~pd_common.specimen.SpecimenServer.geometry`
    when not ``None``.
    """
    value = [section, dof_names] if geometry is None else [section, dof_names, geometry]
    text = json.dumps(value, sort_keys=True, default=str)
    return hashlib.sha256(text.encode('utf-8')).hexdigest()[:16]


class ServedRecord:
    """Appends the commands a server served as new moves (one JSON line each).

    Each line is handed to the operating system before :meth:`add` returns; the ``fsync``
    comes at most every ``sync_interval`` seconds (:class:`pd_common.durable.IntervalSync`):
    with ``sync_in_background`` (the simulator node's record) in a thread of its own, so the
    move that falls due does not wait for the disk before it is answered. A failed background
    ``fsync`` is raised by the next :meth:`add`, before its line is written.

    Args:
        path: the state file (appended to; created with its header if missing or empty).
        fingerprint: the specimen's :func:`specimen_fingerprint`.
        sync_interval: most seconds between two ``fsync`` calls (0: every line).
        sync_in_background: the interval's ``fsync`` in a thread of its own.
    """

    def __init__(self, path: str | Path, fingerprint: str, *, sync_interval: float = 1.0,
                 sync_in_background: bool = False) -> None:
        self.path = Path(path)
        try:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            end_last_line(self.path)
            # unbuffered: a line is one write(2), handed to the OS at once
            self._file: IO[bytes] = self.path.open('ab', buffering=0)
        except OSError as err:
            msg = f'{self.path}: cannot write the specimen state file ({err.strerror})'
            raise SpecimenError(msg) from None
        self._sync = IntervalSync(self._file.fileno(), sync_interval,
                                  background=sync_in_background, name='state-fsync')
        if self._file.tell() == 0:
            try:
                self._write({'k': _KIND, 'specimen': fingerprint})
            except OSError as err:
                self._sync.stop()
                self._file.close()
                msg = f'{self.path}: cannot write the specimen state file ({err.strerror})'
                raise SpecimenError(msg) from None

    def _write(self, value: Any) -> None:
        self._write_line(_ENCODE(value) + '\n')

    def _write_line(self, line: str) -> None:
        self._sync.check()  # (a failed background fsync: nothing more is written)
        data = memoryview(line.encode('utf-8'))
        while data:  # (a short write, as a full disk may make: the rest, or its error)
            written = self._file.write(data)
            if not written:
                raise OSError(errno.EIO, 'nothing written', str(self.path))
            data = data[written:]
        self._sync.written()

    def add(self, test_id: str, step: int, iteration: int, target: Sequence[float],
            control_mode: Sequence[int] = (), target_force: Sequence[float] = ()) -> None:
        """Record one served command (handed to the operating system at once).

        Raises:
            StateFileError: the line could not be written, or an earlier background ``fsync``
                failed (one line naming the file): the move is not on record.
        """
        targets = [float(x) for x in target]
        try:
            if not (control_mode or target_force) and all(map(math.isfinite, targets)):
                # A plain move (every one of a displacement-controlled test, once per step
                # before its answer): the line JSON would make, without the encoder's walk.
                self._write_line(f'[{_json_text(test_id)},{int(step)},{int(iteration)},'
                                 f'[{",".join(map(float.__repr__, targets))}]]\n')
                return
            line: list[Any] = [test_id, step, iteration, targets]
            if control_mode or target_force:
                line += [[int(mode) for mode in control_mode],
                         [float(force) for force in target_force]]
            self._write(line)
        except OSError as err:
            msg = (f'{self.path}: cannot write the specimen state file '
                   f'({err.strerror or err}): step {int(step)} (iteration {int(iteration)}) '
                   'is not safely on record, so it is not answered')
            raise StateFileError(msg) from None

    def close(self) -> None:
        """Sync and close the file."""
        if not self._file.closed:
            try:
                self._sync.close()
            finally:
                self._file.close()


def restore_served(path: str | Path, server: SpecimenServer, fingerprint: str
                   ) -> tuple[str, StepKey] | None:
    """Drive ``server`` (a new specimen) through the commands recorded in ``path``.

    Returns:
        The last command replayed, ``(test id, (step, iteration))``; ``None`` if none (no
        file, or an empty one).

    Raises:
        SpecimenError: the file cannot be read, belongs to another specimen, or a line before
            the last is malformed (a last line cut by a crash is ignored: that move was not
            answered).
    """
    path = Path(path)
    if not path.exists():
        return None
    try:
        lines = path.read_text(encoding='utf-8').split('\n')
    except OSError as err:
        msg = f'{path}: cannot read the specimen state file ({err.strerror})'
        raise SpecimenError(msg) from None
    last: tuple[str, StepKey] | None = None
    final = len(lines) - 1
    for number, line in enumerate(lines):
        if not line:
            continue
        try:
            value = json.loads(line)
            if number > 0:
                test_id, step, iteration, target, *control = value
                values = tuple(float(x) for x in target)
                modes, forces = control if control else ((), ())
                modes = tuple(int(mode) for mode in modes)
                forces = tuple(float(force) for force in forces)
        except (ValueError, TypeError) as err:
            if number == final and number > 0:
                break  # the line a crash cut short: that move was not answered
            msg = f'{path}: line {number + 1}: malformed specimen state record ({err})'
            raise SpecimenError(msg) from None
        if number == 0:
            _check_header(path, value, fingerprint)
            continue
        server.handle(str(test_id), int(step), values, iteration=int(iteration),
                      control_mode=modes, target_force=forces)
        last = (str(test_id), StepKey(int(step), int(iteration)))
    return last


def _check_header(path: Path, value: Any, fingerprint: str) -> None:
    if not isinstance(value, dict) or value.get('k') != _KIND:
        msg = f'{path}: not a specimen state file (no header line)'
        raise SpecimenError(msg)
    if value.get('specimen') != fingerprint:
        msg = (f'{path}: the state file belongs to another specimen (its definition '
               'changed): refusing to restore from it')
        raise SpecimenError(msg)

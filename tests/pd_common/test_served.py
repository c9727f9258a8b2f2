"""A simulated specimen's state file: recorded while serving, restored after a restart.

The reference is always an uninterrupted server of the same test file answering the same
commands: a restored server must answer the moves that follow bit for bit like it.
"""

from __future__ import annotations

import copy
import errno
import json
import math
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st

from pd_common import durable
from pd_common.errors import SpecimenError, StateFileError
from pd_common.protocol import Feedback, FeedbackStatus, StepKey
from pd_common.specimen import (
    ServedRecord,
    SpecimenServer,
    load_site_server,
    restore_served,
    specimen_fingerprint,
)
from support.sections import INLINE_GROUND_MOTION, ONE_DOF_STRUCTURE

REPO = Path(__file__).resolve().parents[2]
TWO_SITES = REPO / 'src' / 'pd_integrator' / 'config' / 'three_story_two_sites.yaml'
K = 312559.0
SPECIMEN: dict[str, Any] = {
    'topology': 'independent',
    'elements': [{'model': 'pushover', 'backbone': {'bilinear': {
        'stiffness': K, 'yield_force': 10000.0, 'hardening_ratio': 0.01,
        'max_displacement': 0.5}}, 'beyond_last_point': 'extrapolate'}],
}
ERRORS = {'systematic': -0.05, 'delay_steps': 2, 'displacement_noise': 2.0e-5,
          'force_noise': 15.0, 'force_bias': 40.0, 'seed': 11}
TEST_ID = 'served'
N_MOVES = 160


def write_test_file(folder: Path, specimen: dict[str, Any], name: str = 'test.yaml') -> Path:
    """A test file holding ``specimen`` (only the simulator's sections matter here)."""
    path = folder / name
    raw = {'test': {'id': TEST_ID, 'dt': 0.01},
           'structure': {'dof_names': ['top'], 'mass': 2543.4,
                         'damping': {'ratio': 0.05}, 'initial_stiffness': K},
           'ground_motion': INLINE_GROUND_MOTION, 'specimen': specimen}
    path.write_text(yaml.safe_dump(raw, sort_keys=False), encoding='utf-8')
    return path


def with_errors(errors: dict[str, Any]) -> dict[str, Any]:
    specimen = copy.deepcopy(SPECIMEN)
    specimen['errors'] = dict(errors)
    return specimen


def target(step: int) -> float:
    """A growing cycle: ±65 mm at the end, past the yield (32 mm) both ways."""
    return 0.065 * (step / N_MOVES) * math.sin(2.0 * math.pi * step / 40.0)


def serve(server: SpecimenServer, steps: range, record: ServedRecord | None = None
          ) -> list[Feedback]:
    """Answer the commands of ``steps`` as the simulator node does (new moves on record)."""
    answers = []
    for step in steps:
        before = server.last
        answer = server.handle(TEST_ID, step, (target(step),))
        assert answer is not None
        if answer is not before and record is not None:
            record.add(TEST_ID, step, 0, (target(step),))
        answers.append(answer)
    return answers


def loaded(path: Path) -> tuple[SpecimenServer, str]:
    server, section, names = load_site_server(path)
    return server, specimen_fingerprint(section, names)


def cut(path: Path, count: int) -> None:
    with path.open('r+b') as stream:
        stream.truncate(path.stat().st_size - count)


def lines_of(path: Path) -> list[str]:
    return path.read_text(encoding='utf-8').split('\n')


# -- SpecimenServer.last ------------------------------------------------------------------------
def serve_recorded(server: SpecimenServer, steps: range, state: Path, fingerprint: str) -> None:
    """Serve ``steps`` with a simulator that appends them to its state file, then stops."""
    record = ServedRecord(state, fingerprint)
    serve(server, steps, record)
    record.close()


def first_hundred_moves(tmp_path: Path) -> tuple[Path, list[Feedback], Path, str]:
    """A test file, every answer of an uninterrupted run, and the state file of 100 moves."""
    path = write_test_file(tmp_path, SPECIMEN)
    reference, _ = loaded(path)
    expected = serve(reference, range(N_MOVES + 1))
    first, fingerprint = loaded(path)
    state = tmp_path / 'specimen.jsonl'
    serve_recorded(first, range(100), state, fingerprint)
    return path, expected, state, fingerprint


def test_last_is_the_answer_a_repeat_gets(tmp_path: Path) -> None:
    server, _ = loaded(write_test_file(tmp_path, SPECIMEN))
    assert server.last is None
    first = server.handle(TEST_ID, 0, (0.0,))
    second = server.handle(TEST_ID, 1, (0.01,))
    assert server.last is second
    assert second is not None
    assert second.restoring_force == (K * 0.01,)
    assert server.handle(TEST_ID, 1, (0.02,)) is second  # a re-send: no motion
    assert server.repeated == 1
    assert server.handle(TEST_ID, 0, (0.0,)) is None  # stale: ignored
    assert server.ignored == 1
    assert server.last is second
    assert first is not None and first.step == 0
    assert server.steps_served == 2


def test_a_fault_is_the_last_answer_and_nothing_moves(tmp_path: Path) -> None:
    server, _ = loaded(write_test_file(tmp_path, SPECIMEN))
    server.handle(TEST_ID, 0, (0.004,))
    answer = server.handle(TEST_ID, 1, (math.nan,))
    assert answer is not None
    assert answer.status is FeedbackStatus.FAULT
    assert server.last is answer
    assert server.position == (0.004,)
    assert server.steps_served == 1


# -- load_site_server and the fingerprint -------------------------------------------------------
def test_load_site_server_of_the_test_and_of_a_site(tmp_path: Path) -> None:
    server, section, names = load_site_server(write_test_file(tmp_path, SPECIMEN))
    assert names == ['top']
    assert section == SPECIMEN
    assert server.specimen.n_dof == 1
    lab1, lab1_section, lab1_names = load_site_server(TWO_SITES, 'lab1')
    assert lab1_names == ['a1']
    assert lab1_section['elements'][0]['model'] == 'bilinear'
    answer = lab1.handle('t', 0, (0.001,))
    assert answer is not None
    assert answer.restoring_force == pytest.approx((4.0e4,), rel=1e-12)
    _, _, named = load_site_server(TWO_SITES, 'lab3', dof_names=['u3-u2'])
    assert named == ['u3-u2']
    with pytest.raises(SpecimenError) as error:
        load_site_server(TWO_SITES, 'lab2')
    assert str(error.value) == (f'{TWO_SITES.name}: sites.lab2.specimen: section is required '
                                "for the simulated specimen of site 'lab2'")


def test_load_site_server_names_the_site_in_its_errors(tmp_path: Path) -> None:
    path = tmp_path / 'sites.yaml'
    path.write_text(yaml.safe_dump({
        'test': {'dt': 0.01}, 'structure': ONE_DOF_STRUCTURE,
        'ground_motion': INLINE_GROUND_MOTION, 'sites': {'lab1': {'specimen': {
            'elements': [{'model': 'elastic'}]}}}}), encoding='utf-8')
    with pytest.raises(SpecimenError) as error:
        load_site_server(path, 'lab1')
    assert str(error.value).startswith('sites.yaml: sites.lab1.specimen')
    assert '\n' not in str(error.value)


def test_fingerprint_names_one_specimen() -> None:
    base = specimen_fingerprint(SPECIMEN, ['top'])
    assert len(base) == 16
    assert int(base, 16) >= 0
    reordered = dict(reversed(list(SPECIMEN.items())))
    assert specimen_fingerprint(reordered, ['top']) == base
    assert specimen_fingerprint(copy.deepcopy(SPECIMEN), ['top']) == base
    assert specimen_fingerprint(SPECIMEN, ['x']) != base
    changed = copy.deepcopy(SPECIMEN)
    changed['elements'][0]['backbone']['bilinear']['yield_force'] = 10000.5
    assert specimen_fingerprint(changed, ['top']) != base
    assert specimen_fingerprint(with_errors(ERRORS), ['top']) != base


# -- record and restore -------------------------------------------------------------------------
@pytest.mark.parametrize('specimen', [SPECIMEN, with_errors(ERRORS)], ids=['ideal', 'errors'])
@pytest.mark.parametrize('served', [1, 57, 121])
def test_restored_server_answers_like_an_uninterrupted_one(tmp_path: Path,
                                                           specimen: dict[str, Any],
                                                           served: int) -> None:
    path = write_test_file(tmp_path, specimen)
    reference, _ = loaded(path)
    expected = serve(reference, range(N_MOVES + 1))
    assert max(abs(a.restoring_force[0]) for a in expected) > 10000.0  # it yielded
    first, fingerprint = loaded(path)
    state = tmp_path / 'state' / 'specimen.jsonl'  # the folder is created
    record = ServedRecord(state, fingerprint, sync_interval=3600.0)
    try:
        got = serve(first, range(served), record)
        # A re-sent command (answered from the last reply) and a stale one: not new moves.
        assert first.handle(TEST_ID, served - 1, (target(served - 1),)) is first.last
        assert first.handle(TEST_ID, max(served - 2, 0), (0.0,)) in (None, first.last)
        # The process dies here: the state file is read while the record is still open.
        restored, _ = loaded(path)
        last = restore_served(state, restored, fingerprint)
    finally:
        record.close()
    assert got == expected[:served]
    assert last == (TEST_ID, StepKey(served - 1, 0))
    assert restored.steps_served == served
    assert restored.last == first.last
    assert restored.position == first.position
    assert restored.imposed == first.imposed
    # A repeat of the last command gets the same answer without moving, then the next moves
    # give bit-identical forces (and measured displacements) to the uninterrupted server.
    assert restored.handle(TEST_ID, served - 1, (target(served - 1),)) == expected[served - 1]
    assert serve(restored, range(served, N_MOVES + 1)) == expected[served:]


def test_restore_after_two_restarts(tmp_path: Path) -> None:
    """A restored server appends to the same file; the next restart replays all of it."""
    path = write_test_file(tmp_path, with_errors(ERRORS))
    reference, _ = loaded(path)
    expected = serve(reference, range(N_MOVES + 1))
    state = tmp_path / 'specimen.jsonl'
    first, fingerprint = loaded(path)
    serve_recorded(first, range(50), state, fingerprint)
    second, _ = loaded(path)
    assert restore_served(state, second, fingerprint) == (TEST_ID, StepKey(49, 0))
    serve_recorded(second, range(50, 110), state, fingerprint)
    assert sum(1 for line in lines_of(state) if line.startswith('{')) == 1  # one header
    third, _ = loaded(path)
    assert restore_served(state, third, fingerprint) == (TEST_ID, StepKey(109, 0))
    assert serve(third, range(110, N_MOVES + 1)) == expected[110:]


def test_unseeded_noise_restores_the_physical_state(tmp_path: Path) -> None:
    """Without a seed the noise draws differ, but the specimen's imposed path does not."""
    errors = {key: value for key, value in ERRORS.items() if key != 'seed'}
    path = write_test_file(tmp_path, with_errors(errors))
    state = tmp_path / 'specimen.jsonl'
    first, fingerprint = loaded(path)
    serve_recorded(first, range(90), state, fingerprint)
    restored, _ = loaded(path)
    restore_served(state, restored, fingerprint)
    assert restored.imposed == first.imposed
    for step in range(90, 100):
        a = first.handle(TEST_ID, step, (target(step),))
        b = restored.handle(TEST_ID, step, (target(step),))
        assert a is not None and b is not None
        assert first.imposed == restored.imposed


def test_the_record_holds_only_new_moves(tmp_path: Path) -> None:
    path = write_test_file(tmp_path, SPECIMEN)
    server, fingerprint = loaded(path)
    state = tmp_path / 'specimen.jsonl'
    record = ServedRecord(state, fingerprint)
    serve(server, range(3), record)
    serve(server, range(2, 4), record)  # step 2 again (a re-send), then step 3
    record.close()
    record.close()  # twice: nothing more
    lines = lines_of(state)
    assert lines[-1] == ''
    assert json.loads(lines[0]) == {'k': 'pd-specimen-state', 'specimen': fingerprint}
    assert [json.loads(line)[:3] for line in lines[1:-1]] == [
        [TEST_ID, step, 0] for step in range(4)]
    assert json.loads(lines[2])[3] == [target(1)]


def test_targets_are_recorded_exactly(tmp_path: Path) -> None:
    path = write_test_file(tmp_path, SPECIMEN)
    _, fingerprint = loaded(path)
    state = tmp_path / 'specimen.jsonl'
    values = (0.1 + 0.2, 1.0 / 3.0, -5e-324)
    record = ServedRecord(state, fingerprint)
    record.add('t', 1, 2, values)
    record.close()
    assert tuple(json.loads(lines_of(state)[1])[3]) == values


def test_no_file_or_an_empty_one_restores_nothing(tmp_path: Path) -> None:
    path = write_test_file(tmp_path, SPECIMEN)
    server, fingerprint = loaded(path)
    assert restore_served(tmp_path / 'missing.jsonl', server, fingerprint) is None
    empty = tmp_path / 'empty.jsonl'
    empty.write_text('', encoding='utf-8')
    assert restore_served(empty, server, fingerprint) is None
    assert server.steps_served == 0
    # A record opened on an empty file starts it with its header.
    ServedRecord(empty, fingerprint).close()
    assert json.loads(lines_of(empty)[0])['specimen'] == fingerprint
    assert restore_served(empty, server, fingerprint) is None


def test_a_state_file_of_another_specimen_is_refused(tmp_path: Path) -> None:
    path = write_test_file(tmp_path, SPECIMEN)
    server, fingerprint = loaded(path)
    state = tmp_path / 'specimen.jsonl'
    serve_recorded(server, range(20), state, fingerprint)
    other = copy.deepcopy(SPECIMEN)
    other['elements'][0]['backbone']['bilinear']['yield_force'] = 12000.0
    fresh, other_fingerprint = loaded(write_test_file(tmp_path, other, 'other.yaml'))
    assert other_fingerprint != fingerprint
    with pytest.raises(SpecimenError) as error:
        restore_served(state, fresh, other_fingerprint)
    assert str(error.value) == (f'{state}: the state file belongs to another specimen (its '
                                'definition changed): refusing to restore from it')
    assert fresh.steps_served == 0  # nothing was replayed


def test_a_file_without_the_header_is_refused(tmp_path: Path) -> None:
    server, fingerprint = loaded(write_test_file(tmp_path, SPECIMEN))
    state = tmp_path / 'specimen.jsonl'
    state.write_text('["served", 0, 0, [0.0]]\n', encoding='utf-8')
    with pytest.raises(SpecimenError) as error:
        restore_served(state, server, fingerprint)
    assert str(error.value) == f'{state}: not a specimen state file (no header line)'


@pytest.mark.parametrize('count', [2, 9, 20])
def test_a_cut_last_line_is_tolerated(tmp_path: Path, count: int) -> None:
    path, expected, state, fingerprint = first_hundred_moves(tmp_path)
    assert len(lines_of(state)[-2]) > count
    cut(state, count)
    restored, _ = loaded(path)
    # That move was not answered: the simulator is restored through the move before it, and
    # is commanded it again.
    assert restore_served(state, restored, fingerprint) == (TEST_ID, StepKey(98, 0))
    assert serve(restored, range(99, N_MOVES + 1)) == expected[99:]


def test_a_cut_state_file_stays_readable_after_more_moves(tmp_path: Path) -> None:
    """The restarted simulator appends to the file a crash cut in the middle of a line."""
    path, expected, state, fingerprint = first_hundred_moves(tmp_path)
    cut(state, 7)
    second, _ = loaded(path)
    assert restore_served(state, second, fingerprint) == (TEST_ID, StepKey(98, 0))
    serve_recorded(second, range(99, 130), state, fingerprint)
    third, _ = loaded(path)
    assert restore_served(state, third, fingerprint) == (TEST_ID, StepKey(129, 0))
    assert serve(third, range(130, N_MOVES + 1)) == expected[130:]


def test_a_last_line_missing_only_its_newline_is_a_move(tmp_path: Path) -> None:
    path, expected, state, fingerprint = first_hundred_moves(tmp_path)
    cut(state, 1)
    second, _ = loaded(path)
    assert restore_served(state, second, fingerprint) == (TEST_ID, StepKey(99, 0))
    serve_recorded(second, range(100, 120), state, fingerprint)
    third, _ = loaded(path)
    assert restore_served(state, third, fingerprint) == (TEST_ID, StepKey(119, 0))
    assert serve(third, range(120, N_MOVES + 1)) == expected[120:]


@pytest.mark.parametrize('bad', ['["served", 3, 0]', 'not json', '["served", 3, 0, ["x"]]'])
def test_a_malformed_middle_line_is_an_error_naming_it(tmp_path: Path, bad: str) -> None:
    path = write_test_file(tmp_path, SPECIMEN)
    server, fingerprint = loaded(path)
    state = tmp_path / 'specimen.jsonl'
    serve_recorded(server, range(10), state, fingerprint)
    lines = lines_of(state)
    lines[4] = bad
    state.write_text('\n'.join(lines), encoding='utf-8')
    with pytest.raises(SpecimenError) as error:
        restore_served(state, loaded(path)[0], fingerprint)
    message = str(error.value)
    assert message.startswith(f'{state}: line 5: malformed specimen state record (')
    assert '\n' not in message


def test_record_reports_an_unwritable_file(tmp_path: Path) -> None:
    blocker = tmp_path / 'file'
    blocker.write_text('', encoding='utf-8')
    with pytest.raises(SpecimenError) as error:
        ServedRecord(blocker / 'specimen.jsonl', 'f')
    assert str(error.value).startswith(f'{blocker / "specimen.jsonl"}: cannot write the '
                                       'specimen state file (')


@settings(max_examples=300, deadline=None)
@given(test_id=st.text(max_size=40), step=st.integers(0, 2**62), iteration=st.integers(0, 2**31),
       target=st.lists(st.floats(allow_nan=True, allow_infinity=True), max_size=6))
def test_a_plain_move_is_the_line_json_makes(tmp_path_factory: pytest.TempPathFactory,
                                             test_id: str, step: int, iteration: int,
                                             target: list[float]) -> None:
    """The fast line of a plain move is byte for byte JSON's (any id, ±0, subnormals, the
    extremes; a non-finite target is JSON's NaN/Infinity: written by the general path)."""
    state = tmp_path_factory.mktemp('line') / 'specimen.jsonl'
    record = ServedRecord(state, 'f')
    record.add(test_id, step, iteration, target)
    record.close()
    line = state.read_bytes().split(b'\n')[1]
    expected = json.dumps([test_id, step, iteration, target], separators=(',', ':'))
    assert line == expected.encode('utf-8')


def _threads_named(name: str) -> list[threading.Thread]:
    return [thread for thread in threading.enumerate() if thread.name == name]


def _first_move_synced_in_background(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch, fsync: Callable[[int], None]
        ) -> tuple[ServedRecord, SpecimenServer, Path]:
    """A simulator's record syncing in the background (interval 1 ms) whose first move has
    just asked for an fsync, ``fsync`` from then on; the server that made the move and the
    state file (its header written before, so that the first fsync asked is the move's)."""
    path = write_test_file(tmp_path, SPECIMEN)
    server, fingerprint = loaded(path)
    state = tmp_path / 'specimen.jsonl'
    ServedRecord(state, fingerprint).close()
    record = ServedRecord(state, fingerprint, sync_interval=0.001, sync_in_background=True)
    monkeypatch.setattr(durable.os, 'fsync', fsync)
    time.sleep(0.002)
    serve(server, range(1), record)
    return record, server, state


def test_a_slow_fsync_in_the_background_holds_up_no_move(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The simulator's record (``sync_in_background``): the move whose interval is over asks
    for an fsync and is answered while the disk syncs; every line is on the OS at once all
    the same, and close waits for the fsync under way, then syncs in the caller."""
    release, started = threading.Event(), threading.Event()
    synced: list[str] = []

    def slow_fsync(fd: int) -> None:
        if threading.current_thread().name == 'state-fsync':
            started.set()
            assert release.wait(30.0)  # a disk that never answers, until released
        synced.append(threading.current_thread().name)

    record, server, state = _first_move_synced_in_background(tmp_path, monkeypatch,
                                                             slow_fsync)  # (it hangs)
    assert started.wait(30.0)
    serve(server, range(1, 20), record)  # (well within STUCK_SYNC_S of it)
    assert len(lines_of(state)) == 1 + 20 + 1 and synced == []
    closing = threading.Thread(target=record.close)
    closing.start()
    closing.join(0.2)
    assert closing.is_alive() and synced == []  # close waits for the fsync under way
    release.set()
    closing.join(30.0)
    assert synced == ['state-fsync', closing.name]  # (the other requests: not after a stop)
    assert not _threads_named('state-fsync')


def test_a_failed_background_fsync_is_raised_before_the_next_move_is_written(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """An fsync that fails (EIO) in the background: the next move's ``add`` raises it before
    writing its line (the simulator then answers nothing: a restarted one serves that move
    anew from the file)."""
    failed = threading.Event()

    def failing_fsync(fd: int) -> None:
        if threading.current_thread().name == 'state-fsync':
            failed.set()
            raise OSError(errno.EIO, 'Input/output error')

    record, _, state = _first_move_synced_in_background(tmp_path, monkeypatch, failing_fsync)
    assert failed.wait(30.0)
    for thread in _threads_named('state-fsync'):
        thread.join(30.0)
    written = lines_of(state)
    with pytest.raises(StateFileError) as error:
        record.add(TEST_ID, 1, 0, (target(1),))
    assert str(error.value) == (f'{state}: cannot write the specimen state file (Input/output '
                                'error): step 1 (iteration 0) is not safely on record, so it '
                                'is not answered')
    assert lines_of(state) == written
    with pytest.raises(OSError, match='Input/output error'):
        record.close()  # the failure again; the file is closed all the same
    record.close()


class _FullDisk:
    """A state file's file object on a disk that fills after ``room`` more bytes: writes
    are cut short there (as write(2) does), then fail with ENOSPC."""

    def __init__(self, file: Any, room: int) -> None:
        self.file, self.room = file, room

    def write(self, data: memoryview) -> int:
        if not self.room:
            raise OSError(errno.ENOSPC, 'No space left on device')
        written = self.file.write(data[:self.room])
        self.room -= written
        return int(written)

    def __getattr__(self, name: str) -> Any:
        return getattr(self.file, name)


def test_a_move_a_full_disk_cannot_take_is_one_line_and_the_file_restores_before_it(
        tmp_path: Path) -> None:
    """The disk fills in the middle of a move's line: ``add`` raises a StateFileError of one
    line naming the file and the step (the simulator answers nothing and ends), and a new
    specimen restored from the file stands where the last whole move left it."""
    path = write_test_file(tmp_path, SPECIMEN)
    server, fingerprint = loaded(path)
    state = tmp_path / 'specimen.jsonl'
    record = ServedRecord(state, fingerprint)
    serve(server, range(1, 6), record)
    record._file = _FullDisk(record._file, 10)  # (the next line is cut after 10 bytes)
    server.handle(TEST_ID, 6, (target(6),))
    with pytest.raises(StateFileError) as error:
        record.add(TEST_ID, 6, 0, (target(6),))
    assert str(error.value) == (f'{state}: cannot write the specimen state file (No space left '
                                'on device): step 6 (iteration 0) is not safely on record, so '
                                'it is not answered')
    record.close()
    assert len(state.read_bytes().rsplit(b'\n', 1)[-1]) == 10  # the torn line
    fresh, _ = loaded(path)
    assert restore_served(state, fresh, fingerprint) == (TEST_ID, StepKey(5, 0))
    reference, _ = loaded(path)
    for step in range(1, 6):
        reference.handle(TEST_ID, step, (target(step),))
    assert list(fresh.position) == list(reference.position)
    assert list(fresh.force) == list(reference.force)


def test_a_header_that_cannot_be_synced_is_one_line(tmp_path: Path,
                                                    monkeypatch: pytest.MonkeyPatch) -> None:
    """A new state file whose header's fsync fails (an fsync per line): the simulator does not
    start, with one line naming the file, and leaves no thread behind."""
    def failing_fsync(fd: int) -> None:
        raise OSError(errno.EIO, 'Input/output error')

    monkeypatch.setattr(durable.os, 'fsync', failing_fsync)
    state = tmp_path / 'specimen.jsonl'
    with pytest.raises(SpecimenError) as error:
        ServedRecord(state, 'f', sync_interval=0.0, sync_in_background=True)
    assert str(error.value) == (f'{state}: cannot write the specimen state file '
                                '(Input/output error)')
    assert not _threads_named('state-fsync')


# -- mixed control (a column site: setup, force ramp) ------------------------------------------
COLUMN_LOAD = 24950.0


def write_column_file(folder: Path, vertical_length: float = 2.0) -> Path:
    """A column site: its setup in structure.elements, its ramp in its bridge settings."""
    path = folder / 'column.yaml'
    raw = {'test': {'id': TEST_ID, 'dt': 0.01},
           'structure': {'dof_names': ['u'], 'mass': [2543.4], 'elements': [{
               'type': 'experimental', 'name': 'column', 'site': 'lab', 'dofs': ['u', None],
               'setup': {'type': 'column', 'horizontal_length': 1.5,
                         'vertical_length': vertical_length},
               'actuators': ['horizontal', 'vertical'],
               'initial_stiffness': [[1.0e6, 0.0], [0.0, 1.0e9]]}]},
           'sites': {'lab': {
               'specimen': {'column': {'height': 3.0, 'axial_stiffness': 1.0e9, 'lateral': {
                   'model': 'bilinear', 'stiffness': 1.0e6, 'yield_force': 1.5e4,
                   'hardening_ratio': -0.02}}},
               'bridge': {'max_force_increment': 2500.0}}},
           'ground_motion': INLINE_GROUND_MOTION}
    path.write_text(yaml.safe_dump(raw, sort_keys=False), encoding='utf-8')
    return path


def column_command(step: int) -> tuple[tuple[float, float], tuple[int, int], tuple[float, float]]:
    """Step 0 ramps the axial load up; then a growing lateral cycle past yield, with the
    load raised by 20 % at step 60 (another ramp)."""
    load = COLUMN_LOAD * (1.2 if step >= 60 else 1.0)
    lateral = 0.04 * (step / N_MOVES) * math.sin(2.0 * math.pi * step / 40.0)
    return (lateral, -1.0e-5), (0, 1), (0.0, load)


def serve_column(server: SpecimenServer, steps: range, record: ServedRecord | None = None
                 ) -> list[Feedback]:
    """As the simulator node serves mixed commands: modes and forces to the server and on
    record."""
    answers = []
    for step in steps:
        target, modes, forces = column_command(step)
        before = server.last
        answer = server.handle(TEST_ID, step, target, control_mode=modes, target_force=forces)
        assert answer is not None and answer.status is FeedbackStatus.OK, answer
        if answer is not before and record is not None:
            record.add(TEST_ID, step, 0, target, modes, forces)
        answers.append(answer)
    return answers


def loaded_site(path: Path) -> tuple[SpecimenServer, str]:
    server, section, names = load_site_server(path, 'lab')
    return server, specimen_fingerprint(section, names, server.geometry)


@pytest.mark.parametrize('served', [1, 37, 61, 120])
def test_a_restored_mixed_server_equals_an_unbroken_one(tmp_path: Path, served: int) -> None:
    path = write_column_file(tmp_path)
    reference, _ = loaded_site(path)
    expected = serve_column(reference, range(N_MOVES + 1))
    assert max(abs(a.restoring_force[0]) for a in expected) > 1.0e4  # past yield
    assert reference.ramp_substeps == 10 + 2                         # both ramps
    first, fingerprint = loaded_site(path)
    state = tmp_path / 'specimen.jsonl'
    record = ServedRecord(state, fingerprint)
    got = serve_column(first, range(served), record)
    record.close()
    assert got == expected[:served]
    mixed = [json.loads(line) for line in lines_of(state)[1:-1]]
    assert all(len(line) == 6 and line[4] == [0, 1] for line in mixed)
    restored, _ = loaded_site(path)
    assert restore_served(state, restored, fingerprint) == (TEST_ID, StepKey(served - 1, 0))
    for attribute in ('position', 'force', 'basic', 'held', 'last', 'ramp_substeps',
                      'steps_served'):
        assert getattr(restored, attribute) == getattr(first, attribute), attribute
    np.testing.assert_array_equal(restored.specimen.committed_restoring_force(),
                                  first.specimen.committed_restoring_force())
    assert serve_column(restored, range(served, N_MOVES + 1)) == expected[served:]


def test_the_site_geometry_is_part_of_the_fingerprint(tmp_path: Path) -> None:
    plain, _ = loaded(write_test_file(tmp_path, SPECIMEN))
    assert plain.geometry is None  # a plain specimen's fingerprint is as before
    _, base = loaded_site(write_column_file(tmp_path))
    _, longer = loaded_site(write_column_file(tmp_path, vertical_length=2.5))
    assert base != longer

"""Continuing a stopped run: the epoch guard, the resume checks, and the restored step loop.

The reference of every resumed or recovered run is an uninterrupted :func:`run_offline` of
the same test: its ``response.csv`` bytes (17 significant digits: the floats exactly).
"""

from __future__ import annotations

import dataclasses
import json
import shutil
import time
from collections import deque
from pathlib import Path
from typing import Any

import pytest

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
)
from pd_common.protocol import TestState as State
from pd_common.specimen import SpecimenServer
from pd_core.errors import BagError, ConfigError, NothingToRecoverError, PdIntegratorError
from pd_core.run.loop.dispatch import StepDispatcher
from pd_core.run.loop.epochs import EpochChange, EpochGuard
from pd_core.run.loop.protocol import Verdict
from pd_core.run.loop.session import TestSession as Session  # not a test class
from pd_core.run.record.bag import TOPIC_STATUS, RecordedRun, site_of
from pd_core.run.record.continuations import RESTART_NOTE, count_continuations
from pd_core.run.record.journal import JOURNAL_FILE, Journal, journal_to_bag
from pd_core.run.resume import (
    RESUMABLE,
    SiteState,
    check_sites,
    last_measured,
    load_resumable,
)
from pd_core.run.runner import (
    DEFINITION_JSON,
    finish_outputs,
    load_run,
    rebuild_outputs,
    recover_run,
    replay_run,
    restore_dispatcher,
    run_offline,
    serve_queue,
    site_servers,
)
from pd_core.run.test_file import load_test_file
from support import journals
from support.paths import CONFIG

DEFAULT_TEST = CONFIG / 'default_test.yaml'
TWO_SITES = CONFIG / 'three_story_two_sites.yaml'
STRUCTURE = '/pd/structure/'


# -- helpers ----------------------------------------------------------------------------------
def journal_lines(directory: Path) -> list[journals.Record]:
    """The records of a run's journal (read by its documented layout)."""
    return journals.records(directory / JOURNAL_FILE)


def line_index(lines: list[journals.Record], kind: str, step: int, topic: str | None = None,
               test_id_suffix: str = '') -> int:
    """The index of the record of ``kind`` for ``step`` (on ``topic``, if given)."""
    for index, record in enumerate(lines):
        if record.kind != kind:
            continue
        item = record.item
        if (item.step == step and item.test_id.endswith(test_id_suffix)
                and (topic is None or record.topic == topic)):
            return index
    raise AssertionError(f'no {kind} record for step {step}')


def cut_run(reference: Path, folder: Path, keep: int, partial: int = 0) -> Path:
    """A run folder as a crash leaves it: the first ``keep`` journal records, then
    ``partial`` bytes of the next one (a record torn); no bag, no outputs."""
    folder.mkdir(parents=True)
    shutil.copyfile(reference / DEFINITION_JSON, folder / DEFINITION_JSON)
    journals.cut(reference / JOURNAL_FILE, folder / JOURNAL_FILE, keep, partial)
    return folder


def served(lines: list[journals.Record]) -> dict[str, list[Command]]:
    """Per site, the commands a specimen served (what its state file would hold)."""
    out: dict[str, list[Command]] = {}
    for record in lines:
        if record.kind != 'cmd' or record.topic.startswith(STRUCTURE):
            continue
        out.setdefault(site_of(record.topic), []).append(record.item)
    return out


def restored_servers(definition: Any, commands: dict[str, list[Command]]
                     ) -> dict[str, SpecimenServer]:
    """Fresh simulated specimens driven through ``commands`` (a restored simulator)."""
    servers = site_servers(definition)
    for site, site_commands in commands.items():
        for command in site_commands:
            servers[site].handle(command.test_id, command.step, command.target_displacement,
                                 iteration=command.iteration)
    return servers


def resume(folder: Path, servers: dict[str, SpecimenServer]
           ) -> tuple[Session, list[tuple[str, Command]]]:
    """Resume a stopped run as the integrator node does (restore, check, resume, run)."""
    directory, definition, record = load_resumable(folder)
    session = Session(definition)
    queue: deque[tuple[str, Command]] = deque()
    with Journal(directory / JOURNAL_FILE, append=True) as journal:
        dispatcher = StepDispatcher(session, lambda s, c: queue.append((s, c)), journal)
        owed = restore_dispatcher(record, dispatcher, str(directory))
        assert not queue  # nothing is sent while restoring
        structured = not dispatcher.coordinator.passthrough
        sites = {site: SiteState(epoch='', origin=StateOrigin.RESTORED,
                                 position=server.position) for site, server in servers.items()}
        check = check_sites(sites, dispatcher.epochs, last_measured(record, structured), owed,
                            definition.protocol.tracking_tolerance)
        assert check.refused == []
        assert check.confirm == []
        journal.write_event('resumed', time.time_ns(), committed_step=session.committed_step)
        if session.state in (State.RUNNING, State.INTERRUPTED):
            session.state = State.HOLDING
        dispatcher.resume()
        assert serve_queue(queue, servers, dispatcher)
        journal.write_status(dispatcher.status(), time.time_ns())
    finish_outputs(session, directory, wall_time=0.0, figures=False)
    return session, owed


def response_lines(directory: Path) -> list[bytes]:
    return (directory / 'response.csv').read_bytes().split(b'\n')


@pytest.fixture(scope='module')
def reference(tmp_path_factory: pytest.TempPathFactory) -> Any:
    """The uninterrupted default test, 300 steps (the specimen yields from step 180)."""
    definition = load_test_file(DEFAULT_TEST, overrides={'duration': 3.0})
    return run_offline(definition, tmp_path_factory.mktemp('resume') / 'run', figures=False)


@pytest.fixture(scope='module')
def two_sites(tmp_path_factory: pytest.TempPathFactory) -> Any:
    """The uninterrupted two-site substructured test, 100 steps."""
    definition = load_test_file(TWO_SITES, overrides={'duration': 0.5})
    return run_offline(definition, tmp_path_factory.mktemp('resume2') / 'run', figures=False)


def feedback(step: int, epoch: str = '', origin: StateOrigin = StateOrigin.FRESH,
             x: float = 0.0) -> Feedback:
    return Feedback(test_id='t', step=step, measured_displacement=(x,), restoring_force=(0.0,),
                    epoch=epoch, state_origin=origin)


# -- EpochGuard -------------------------------------------------------------------------------
def test_feedback_without_an_epoch_is_not_checked() -> None:
    guard = EpochGuard()
    assert guard.check('', feedback(0)) is None
    assert guard.epochs == {}
    assert guard.changes == []


def test_first_epoch_per_site_is_the_tests() -> None:
    guard = EpochGuard()
    assert guard.check('lab1', feedback(0, 'a1')) is None
    assert guard.check('lab3', feedback(0, 'b1')) is None
    assert guard.check('lab1', feedback(1, 'a1')) is None
    assert guard.epochs == {'lab1': 'a1', 'lab3': 'b1'}
    assert guard.changes == []


def test_a_fresh_state_that_replaced_the_epoch_is_refused() -> None:
    guard = EpochGuard()
    guard.check('', feedback(0, 'old'))
    reason = guard.check('', feedback(5, 'new', StateOrigin.FRESH))
    assert reason is not None
    assert reason.startswith('site default: answered from a fresh specimen state (epoch new;'
                             ' it was old)')
    assert 'state_file' in reason
    assert '\n' not in reason
    assert guard.epochs == {'': 'old'}  # the test's epoch stays
    assert guard.changes == [EpochChange('', 5, 'old', 'new', StateOrigin.FRESH, False)]
    # Every answer of that state is refused, the change recorded once.
    assert guard.check('', feedback(6, 'new', StateOrigin.FRESH)) == reason
    assert len(guard.changes) == 1
    assert guard.accepted_changes == []
    # The old state still answers.
    assert guard.check('', feedback(6, 'old')) is None


@pytest.mark.parametrize('origin', [StateOrigin.RESTORED, StateOrigin.HARDWARE])
def test_a_restored_or_hardware_state_is_taken(origin: StateOrigin) -> None:
    guard = EpochGuard()
    guard.check('lab1', feedback(0, 'old'))
    assert guard.check('lab1', feedback(9, 'new', origin)) is None
    assert guard.epochs == {'lab1': 'new'}
    change = EpochChange('lab1', 9, 'old', 'new', origin, True)
    assert guard.changes == [change]
    assert guard.accepted_changes == [change]
    assert guard.check('lab1', feedback(10, 'new', StateOrigin.FRESH)) is None  # now its own
    assert guard.check('lab1', feedback(11, 'old', StateOrigin.FRESH)) is not None


def test_epoch_change_as_dict() -> None:
    change = EpochChange('', 7, 'e1', 'e2', StateOrigin.RESTORED, True)
    assert change.as_dict() == {'site': 'default', 'step': 7, 'old_epoch': 'e1',
                                'new_epoch': 'e2', 'origin': 'restored', 'accepted': True}
    assert EpochChange('lab3', 1, 'a', 'b', StateOrigin.FRESH, False).as_dict() == {
        'site': 'lab3', 'step': 1, 'old_epoch': 'a', 'new_epoch': 'b', 'origin': 'fresh',
        'accepted': False}


def test_dispatcher_holds_on_a_fresh_state_and_records_it(tmp_path: Path) -> None:
    definition = load_test_file(DEFAULT_TEST, overrides={'duration': 0.2})
    session = Session(definition)
    sent: list[Command] = []
    with Journal(tmp_path / JOURNAL_FILE) as journal:
        journal.write_definition(definition.to_json(), 1)
        dispatcher = StepDispatcher(session, lambda site, command: sent.append(command),
                                    journal)
        dispatcher.start()

        def answer(command: Command, epoch: str, origin: StateOrigin) -> Feedback:
            return Feedback(test_id=command.test_id, step=command.step,
                            measured_displacement=command.target_displacement,
                            restoring_force=(312559.0 * command.target_displacement[0],),
                            epoch=epoch, state_origin=origin)

        for _ in range(3):
            assert dispatcher.on_feedback('', answer(sent[-1], 'e1', StateOrigin.FRESH)) is (
                Verdict.ACCEPTED)
        assert session.committed_step == 2
        pending = sent[-1]
        verdict = dispatcher.on_feedback('', answer(pending, 'e2', StateOrigin.FRESH))
        assert verdict is Verdict.REFUSED
        assert session.state is State.HOLDING
        assert session.committed_step == 2
        assert 'fresh specimen state (epoch e2' in session.message
        assert session.protocol.ignored == {Verdict.REFUSED: 1}
        assert journal.events[-1]['what'] == 'epoch_change'
        assert journal.events[-1]['accepted'] is False
        # The same specimen, restored: taken after the operator resumes.
        dispatcher.resume()
        assert sent[-1] == pending  # the held step is re-sent
        verdict = dispatcher.on_feedback('', answer(pending, 'e3', StateOrigin.RESTORED))
        assert verdict is Verdict.ACCEPTED
        assert session.committed_step == 3
        assert journal.events[-1] == {'what': 'epoch_change', 'site': 'default', 'step': 3,
                                      'old_epoch': 'e1', 'new_epoch': 'e3',
                                      'origin': 'restored', 'accepted': True,
                                      't_ns': journal.events[-1]['t_ns']}
    # The replay refuses the fresh state's answer the same way (the record stays true).
    replayed = replay_run(load_run(tmp_path / JOURNAL_FILE))
    assert replayed.committed_step == 3
    assert replayed.protocol.ignored == {Verdict.REFUSED: 1}


# -- load_resumable -----------------------------------------------------------------------------
def _one_line(error: pytest.ExceptionInfo[Exception]) -> str:
    message = str(error.value)
    assert '\n' not in message
    return message


def test_load_resumable_refuses_what_is_not_a_run(tmp_path: Path) -> None:
    with pytest.raises(ConfigError) as error:
        load_resumable(tmp_path / 'nothing')
    assert _one_line(error) == (f'{tmp_path / "nothing"}: not a run folder (no '
                                f'{DEFINITION_JSON})')
    folder = tmp_path / 'old'
    folder.mkdir()
    (folder / DEFINITION_JSON).write_text('{}', encoding='utf-8')
    with pytest.raises(ConfigError) as error:
        load_resumable(folder)
    assert _one_line(error).startswith(f'{folder}: no {JOURNAL_FILE} (')


def test_load_resumable_refuses_a_finished_run(reference: Any) -> None:
    with pytest.raises(ConfigError) as error:
        load_resumable(reference.directory)
    message = _one_line(error)
    assert message.startswith(f'{reference.directory}: the test is finished (')
    assert message.endswith('nothing to resume')


def test_load_resumable_refuses_an_aborted_run(tmp_path: Path, reference: Any) -> None:
    lines = journal_lines(reference.directory)
    folder = cut_run(reference.directory, tmp_path / 'aborted',
                     line_index(lines, 'fb', 50) + 2)
    with Journal(folder / JOURNAL_FILE, append=True) as journal:
        journal.write_status(Status(test_id='thesis-5.1-elcentro', state=State.ABORTED,
                                    step=50, total_steps=300, omega_dt=0.11, retries=0,
                                    ignored_messages=0, message='operator abort'), 5)
    with pytest.raises(ConfigError) as error:
        load_resumable(folder)
    assert _one_line(error) == (f'{folder}: the test is aborted (operator abort); nothing to '
                                'resume')
    assert State.ABORTED not in RESUMABLE
    assert State.FINISHED not in RESUMABLE


def test_load_resumable_errors_name_the_file(tmp_path: Path, reference: Any) -> None:
    lines = journal_lines(reference.directory)
    folder = cut_run(reference.directory, tmp_path / 'bad-def', 20)
    (folder / DEFINITION_JSON).write_text('{"test": ', encoding='utf-8')
    with pytest.raises(ConfigError) as error:
        load_resumable(folder)
    assert _one_line(error).startswith(f'{DEFINITION_JSON}: test definition is not valid JSON')
    folder = cut_run(reference.directory, tmp_path / 'bad-journal', 20)
    damaged = bytearray((folder / JOURNAL_FILE).read_bytes())
    damaged[lines[5].offset + 30] ^= 0x01
    (folder / JOURNAL_FILE).write_bytes(bytes(damaged))
    with pytest.raises(PdIntegratorError) as failure:
        load_resumable(folder)
    assert _one_line(failure).startswith(
        f'{folder / JOURNAL_FILE}: record 6 at byte {lines[5].offset}: damaged (CRC mismatch)')


def test_load_resumable_takes_a_killed_run(tmp_path: Path, reference: Any) -> None:
    lines = journal_lines(reference.directory)
    folder = cut_run(reference.directory, tmp_path / 'killed', line_index(lines, 'fb', 120) + 2,
                     partial=30)
    directory, definition, record = load_resumable(folder)
    assert directory == folder
    assert definition.to_json() == reference.session.definition.to_json()
    assert len(record.notes) == 1
    assert 'cut short' in record.notes[0]
    assert record.statuses[-1][1].state is State.IDLE  # the run's first status only
    assert [c.step for c in record.commands] == list(range(122))


# -- check_sites --------------------------------------------------------------------------------
def _guard(**epochs: str) -> EpochGuard:
    return EpochGuard(epochs={'' if site == 'default' else site: epoch
                              for site, epoch in epochs.items()})


def _owed(site: str, x: tuple[float, ...]) -> tuple[str, Command]:
    return site, Command(test_id='t', step=8, test_time=0.08, dof_names=('a',) * len(x),
                         target_displacement=x)


def test_same_process_at_the_recorded_position_is_accepted() -> None:
    check = check_sites({'': SiteState('e1', StateOrigin.FRESH, (0.0125,))},
                        _guard(default='e1'), {'': (0.0125,)}, [], 0.005)
    assert check.refused == []
    assert check.confirm == []
    assert check.report == [('site default: same process state, at [0.0125] m, 0 m from the '
                             'record')]


def test_a_fresh_specimen_state_is_refused() -> None:
    check = check_sites({'lab1': SiteState('e2', StateOrigin.FRESH, (0.0,))},
                        _guard(lab1='e1'), {'lab1': (0.0,)}, [], 0.005)
    assert len(check.refused) == 1
    assert check.refused[0].startswith('site lab1: a fresh specimen state (epoch e2, the '
                                       'record has e1)')
    assert check.report == ['site lab1: fresh state, at [0] m, 0 m from the record']


@pytest.mark.parametrize('epoch', ['', 'e1'])
def test_no_epoch_on_either_side_is_not_a_change(epoch: str) -> None:
    guard = _guard(default='e1') if not epoch else EpochGuard()
    check = check_sites({'': SiteState(epoch, StateOrigin.FRESH, (0.0,))}, guard,
                        {'': (0.0,)}, [], 0.005)
    assert check.refused == []


def test_position_within_the_tolerance_is_accepted_beyond_refused() -> None:
    measured = {'': (0.010, -0.002)}
    guard = _guard(default='e1')
    near = check_sites({'': SiteState('e9', StateOrigin.RESTORED, (0.0149, -0.002))}, guard,
                       measured, [], 0.005)
    assert near.refused == []
    assert near.report == [('site default: restored state, at [0.0149, -0.002] m, 0.0049 m '
                            'from the record')]
    far = check_sites({'': SiteState('e9', StateOrigin.RESTORED, (0.010, -0.0071))}, guard,
                      measured, [], 0.005)
    assert far.refused == [('site default: at [0.01, -0.0071] m, 0.0051 m from where the record '
                            'leaves it (tolerance 0.005 m): not the state the test left')]
    # tolerance 0: not checked
    off = check_sites({'': SiteState('e9', StateOrigin.RESTORED, (1.0, 1.0))}, guard,
                      measured, [], 0.0)
    assert off.refused == []
    assert off.report[0].endswith(', 1 m from the record')


def test_the_owed_target_counts_as_where_the_record_leaves_the_specimen() -> None:
    """The specimen may have executed the command in flight before the crash."""
    sites = {'': SiteState('', StateOrigin.RESTORED, (0.020,))}
    assert check_sites(sites, EpochGuard(), {'': (0.010,)}, [], 0.005).refused != []
    check = check_sites(sites, EpochGuard(), {'': (0.010,)}, [_owed('', (0.020,))], 0.005)
    assert check.refused == []
    assert check.report[0].endswith('0 m from the record')
    # Another site's owed target does not count.
    other = check_sites(sites, EpochGuard(), {'': (0.010,)}, [_owed('lab1', (0.020,))], 0.005)
    assert other.refused != []


def test_a_position_of_the_wrong_length_is_refused() -> None:
    check = check_sites({'': SiteState('', StateOrigin.RESTORED, (0.0, 0.0))}, EpochGuard(),
                        {'': (0.0,)}, [], 0.005)
    assert len(check.refused) == 1
    assert 'inf m from where the record leaves it' in check.refused[0]


def test_a_site_without_a_record_is_reported_not_checked() -> None:
    check = check_sites({'lab9': SiteState('x', StateOrigin.RESTORED, (3.0,))}, EpochGuard(),
                        {}, [], 0.005)
    assert check.refused == []
    assert check.report == ['site lab9: same process state, at [3] m']


def test_a_physical_site_needs_confirmation() -> None:
    check = check_sites({'lab1': SiteState('hw2', StateOrigin.HARDWARE, (0.001,)),
                         'lab3': SiteState('s1', StateOrigin.FRESH, (0.0,))},
                        _guard(lab1='hw1', lab3='s1'), {'lab1': (0.0012,), 'lab3': (0.0,)},
                        [], 0.005)
    assert check.refused == []
    assert check.confirm == [('site lab1: physical specimen, hardware state, at [0.001] m, '
                              '0.0002 m from the record')]
    assert len(check.report) == 2
    # Beyond the tolerance it is refused as well.
    far = check_sites({'lab1': SiteState('hw2', StateOrigin.HARDWARE, (0.01,))},
                      _guard(lab1='hw1'), {'lab1': (0.0,)}, [], 0.005)
    assert len(far.refused) == 1
    assert len(far.confirm) == 1


# -- last_measured ------------------------------------------------------------------------------
def test_last_measured_of_a_record(reference: Any) -> None:
    run = load_run(reference.directory / JOURNAL_FILE)
    history = reference.session.history
    assert last_measured(run, structured=False) == {
        '': tuple(history.measured_displacement[history.n_committed - 1])}


def test_last_measured_skips_refused_feedback_and_the_structure_stream() -> None:
    def fb(x: tuple[float, ...], status: FeedbackStatus = FeedbackStatus.OK) -> Feedback:
        return Feedback(test_id='t', step=1, measured_displacement=x,
                        restoring_force=(0.0,) * len(x), status=status)

    unsigned = Signature()
    status = Status(test_id='t', state=State.RUNNING, step=1, total_steps=2, omega_dt=0.1,
                    retries=0, ignored_messages=0, message='')
    run = RecordedRun(definition_json='{}', ordered=[
        ('/pd/step_feedback', 1, fb((0.001,)), unsigned),
        ('/pd/step_feedback', 2, fb((0.009,), FeedbackStatus.FAULT), unsigned),
        (TOPIC_STATUS, 3, status, unsigned),
    ])
    assert last_measured(run, structured=False) == {'': (0.001,)}
    structured = RecordedRun(definition_json='{}', ordered=[
        ('/pd/lab1/step_feedback', 1, fb((0.001,)), unsigned),
        ('/pd/lab3/step_feedback', 2, fb((0.002,)), unsigned),
        ('/pd/structure/step_feedback', 3, fb((0.1, 0.2, 0.3)), unsigned),
        ('/pd/lab1/step_feedback', 4, fb((0.004,)), unsigned),
        ('/pd/lab3/step_feedback', 5, fb((0.7,), FeedbackStatus.LIMIT), unsigned),
    ])
    assert last_measured(structured, structured=True) == {'lab1': (0.004,), 'lab3': (0.002,)}


# -- restore_dispatcher, resumed and recovered runs ---------------------------------------------
@pytest.mark.parametrize(('extra', 'partial', 'ahead'), [
    (0, 0, False),   # killed after the step's feedback, before the next command was recorded
    (1, 0, False),   # after the step (its feedback and the next command: one flush)
    (1, 0, True),    # ... and the specimen executed that next command before the crash
    (1, 40, True),   # ... its answer being written when the crash cut the line
])
def test_resumed_run_gives_the_uninterrupted_response(tmp_path: Path, reference: Any,
                                                      extra: int, partial: int,
                                                      ahead: bool) -> None:
    # Past the first yield (the specimen's hysteretic state matters), before the largest
    # increment of the test: 5.14 mm from step 205 to 206, beyond the 5 mm tolerance, so a
    # specimen that executed command 206 is where the record leaves it only through it.
    step = 205
    lines = journal_lines(reference.directory)
    keep = line_index(lines, 'fb', step) + 1 + extra
    folder = cut_run(reference.directory, tmp_path / 'run', keep, partial)
    commands = served(lines[:keep])
    if ahead:
        commands[''].append(served([lines[line_index(lines, 'cmd', step + 1)]])[''][0])
    servers = restored_servers(reference.session.definition, commands)
    session, owed = resume(folder, servers)
    # The command in flight is owed, whether its record made it to the journal or not.
    expected = served([lines[line_index(lines, 'cmd', step + 1)]])['']
    assert owed == [('', expected[0])]
    assert session.state is State.FINISHED
    assert (folder / 'response.csv').read_bytes() == (
        reference.directory / 'response.csv').read_bytes()
    # The journal, appended across the stop, is a complete record of the run.
    record = load_run(folder / JOURNAL_FILE)
    assert record.notes == []
    assert [event['what'] for event in record.run_events] == ['resumed']
    replayed = replay_run(record, str(folder))
    assert replayed.state is State.FINISHED
    histories = [replayed.history]
    if partial:  # (one case is enough for the bag)
        assert journal_to_bag(folder / JOURNAL_FILE, folder / 'bag') > 0
        histories.append(replay_run(load_run(folder / 'bag')).history)
    for history in histories:
        assert history.n_committed == 301
        assert (history.restoring_force == reference.session.history.restoring_force).all()
        assert (history.displacement == reference.session.history.displacement).all()


def test_resume_from_inside_the_stiffness_probe(tmp_path: Path) -> None:
    definition = load_test_file(DEFAULT_TEST, overrides={'duration': 0.5,
                                                         'initial_stiffness': 'probe'})
    reference = run_offline(definition, tmp_path / 'reference', figures=False)
    lines = journal_lines(reference.directory)
    keep = line_index(lines, 'fb', 1, test_id_suffix=':probe') + 2
    folder = cut_run(reference.directory, tmp_path / 'run', keep)
    servers = restored_servers(definition, served(lines[:keep]))
    session, owed = resume(folder, servers)
    assert owed[0][1].test_id.endswith(':probe')
    assert owed[0][1].step == 2
    assert session.state is State.FINISHED
    assert session.probe_stiffness is not None
    assert (folder / 'response.csv').read_bytes() == (
        reference.directory / 'response.csv').read_bytes()


def test_resumed_two_site_run_gives_the_uninterrupted_response(tmp_path: Path,
                                                               two_sites: Any) -> None:
    """Cut after lab1 answered step 60 and before lab3 did: only lab3 is owed."""
    lines = journal_lines(two_sites.directory)
    keep = line_index(lines, 'fb', 60, topic='/pd/lab1/step_feedback') + 1
    assert lines[keep].topic == '/pd/lab3/step_feedback'
    folder = cut_run(two_sites.directory, tmp_path / 'run', keep)
    commands = served(lines[:keep])
    servers = restored_servers(two_sites.session.definition, commands)
    session, owed = resume(folder, servers)
    assert [site for site, _ in owed] == ['lab3']
    assert owed[0][1] == commands['lab3'][-1]
    assert owed[0][1].step == 60
    assert session.state is State.FINISHED
    assert (folder / 'response.csv').read_bytes() == (
        two_sites.directory / 'response.csv').read_bytes()
    replayed = replay_run(load_run(folder / JOURNAL_FILE))
    assert (replayed.history.restoring_force == two_sites.session.history.restoring_force).all()


def test_restore_dispatcher_sends_nothing_and_returns_the_loop_where_it_stopped(
        reference: Any) -> None:
    run = load_run(reference.directory / JOURNAL_FILE)
    # The whole record: finished, nothing owed.
    session = Session(reference.session.definition)
    sent: list[Any] = []
    dispatcher = StepDispatcher(session, lambda site, command: sent.append(command), None)
    assert restore_dispatcher(run, dispatcher) == []
    assert sent == []
    assert session.state is State.FINISHED
    assert session.history.n_committed == 301
    assert (session.history.velocity == reference.session.history.velocity).all()


def _altered(reference: Any, tmp_path: Path, kind: str, step: int, key: str,
             delta: float) -> Path:
    lines = journal_lines(reference.directory)
    index = line_index(lines, kind, step)
    record = lines[index]
    decoded = (decode_command if kind == 'cmd' else decode_feedback)(record.payload)
    value = getattr(decoded.record, key)
    altered = dataclasses.replace(decoded.record, **{key: (value[0] + delta, *value[1:])})
    encode = encode_command if kind == 'cmd' else encode_feedback
    lines[index] = record._replace(payload=encode(altered, decoded.stamp_ns,  # type: ignore[arg-type]
                                                  decoded.signature))
    path = tmp_path / f'{kind}-{step}.pdj'
    journals.write(path, lines[:line_index(lines, 'fb', 150) + 2])
    return path


@pytest.mark.parametrize(('kind', 'key', 'delta'), [('cmd', 'target_displacement', 1e-15),
                                                   ('fb', 'restoring_force', 1e-6)])
def test_restore_dispatcher_refuses_a_record_that_does_not_recompute(
        tmp_path: Path, reference: Any, kind: str, key: str, delta: float) -> None:
    path = _altered(reference, tmp_path, kind, 100, key, delta)
    dispatcher = StepDispatcher(Session(reference.session.definition), lambda s, c: None)
    with pytest.raises(BagError) as error:
        restore_dispatcher(load_run(path), dispatcher, 'killed-run')
    step = 100 if kind == 'cmd' else 101
    assert str(error.value).startswith(f"killed-run: recorded command for step {step} of "
                                       "'thesis-5.1-elcentro' differs from the recomputed one")


def test_restore_dispatcher_refuses_a_command_nothing_owes(tmp_path: Path,
                                                           reference: Any) -> None:
    lines = journal_lines(reference.directory)
    path = tmp_path / JOURNAL_FILE
    journals.write(path, [*lines, lines[line_index(lines, 'cmd', 300)]])
    dispatcher = StepDispatcher(Session(reference.session.definition), lambda s, c: None)
    with pytest.raises(BagError, match=r'step 300 .* is not one the restored run owes'):
        restore_dispatcher(load_run(path), dispatcher, 'x')


def test_restore_dispatcher_sets_send_deliver_and_bag_back(tmp_path: Path,
                                                           reference: Any) -> None:
    def send(site: str, command: Command) -> None:
        raise AssertionError('sent while restoring')

    def deliver(site: str, sent: Any) -> None:  # (the node's: publish)
        raise AssertionError('delivered while restoring')

    with Journal(tmp_path / JOURNAL_FILE) as journal:
        dispatcher = StepDispatcher(Session(reference.session.definition), send, journal,
                                    deliver=deliver)
        restore_dispatcher(load_run(reference.directory / JOURNAL_FILE), dispatcher)
        assert dispatcher.send is send
        assert dispatcher.deliver is deliver
        assert dispatcher.bag is journal
        assert journal.records == 0  # nothing recorded while restoring


def test_restore_dispatcher_gives_its_outlets_back_after_a_record_it_refuses(
        tmp_path: Path, reference: Any) -> None:
    path = _altered(reference, tmp_path, 'cmd', 100, 'target_displacement', 1e-15)

    def send(site: str, command: Command) -> None:
        raise AssertionError('sent while restoring')

    def deliver(site: str, sent: Any) -> None:
        raise AssertionError('delivered while restoring')

    with Journal(tmp_path / JOURNAL_FILE) as journal:
        dispatcher = StepDispatcher(Session(reference.session.definition), send, journal,
                                    deliver=deliver)
        with pytest.raises(BagError, match='differs from the recomputed one'):
            restore_dispatcher(load_run(path), dispatcher, 'killed-run')
        assert (dispatcher.send, dispatcher.deliver, dispatcher.bag) == (send, deliver, journal)
        assert journal.records == 0


def test_recover_run_writes_the_outputs_so_far(tmp_path: Path, reference: Any) -> None:
    lines = journal_lines(reference.directory)
    step = 210
    keep = line_index(lines, 'fb', step) + 2
    folder = cut_run(reference.directory, tmp_path / 'run', keep, partial=50)
    (folder / 'bag').mkdir()  # the bag the crash left unfinished
    (folder / 'bag' / 'half.mcap').write_bytes(b'\x89MCAP')
    result = recover_run(folder, figures=False)
    assert (folder / 'bag' / 'metadata.yaml').is_file()
    assert not (folder / 'bag' / 'half.mcap').exists()
    got = response_lines(folder)
    want = response_lines(reference.directory)
    assert got[:-1] == want[:step + 2]  # the header and steps 0..210, byte for byte
    assert got[-1] == b''
    summary = json.loads((folder / 'summary.json').read_text(encoding='utf-8'))
    assert summary['recovered'] is True
    assert summary['partial'] is True
    assert summary['steps'] == step
    assert summary['state'] == 'interrupted'  # the record stops mid-test: killed, resumable
    assert 'after step 210' in summary['message']
    assert len(summary['record_notes']) == 1
    assert 'cut short' in summary['record_notes'][0]
    assert result.session.committed_step == step
    # Recovered, it can still be resumed, to the uninterrupted response.
    servers = restored_servers(reference.session.definition, served(lines[:keep]))
    session, _ = resume(folder, servers)
    assert session.state is State.FINISHED
    assert (folder / 'response.csv').read_bytes() == (
        reference.directory / 'response.csv').read_bytes()


def _files(folder: Path) -> dict[Path, bytes]:
    return {path.relative_to(folder): path.read_bytes()
            for path in sorted(folder.rglob('*')) if path.is_file()}


def test_recover_leaves_a_run_that_ended_whole_as_it_is(tmp_path: Path, reference: Any) -> None:
    """A run that ended wrote its bag and a summary with what only the live run knew: a
    recovery would replace that summary with a poorer one. Nothing is written; once the
    run's own summary is gone (killed before it), the folder is recovered, and again."""
    folder = tmp_path / 'run'
    shutil.copytree(reference.directory, folder)
    summary = json.loads((folder / 'summary.json').read_text(encoding='utf-8'))
    summary['only_the_live_run_knew'] = 1
    (folder / 'summary.json').write_text(json.dumps(summary), encoding='utf-8')
    before = _files(folder)
    with pytest.raises(NothingToRecoverError,
                       match=rf'^{folder}: nothing to recover: the run ended \(finished\) and '
                             rf'wrote its bag and outputs; ./pd replay {folder} --out DIR'):
        recover_run(folder, figures=False)
    assert _files(folder) == before
    (folder / 'summary.json').unlink()
    recover_run(folder, figures=False)
    recovered = json.loads((folder / 'summary.json').read_text(encoding='utf-8'))
    assert recovered['recovered'] is True and recovered['state'] == 'finished'
    assert 'only_the_live_run_knew' not in recovered
    assert (folder / 'response.csv').read_bytes() == before[Path('response.csv')]
    recover_run(folder, figures=False)  # a recovered folder: recovered again, the same
    assert json.loads((folder / 'summary.json').read_text(encoding='utf-8')) == recovered


def test_recover_run_needs_a_journal(tmp_path: Path) -> None:
    with pytest.raises(BagError, match=r'no journal\.pdj: nothing to recover from'):
        recover_run(tmp_path)


def test_last_measured_matches_the_restored_position(tmp_path: Path, reference: Any) -> None:
    lines = journal_lines(reference.directory)
    keep = line_index(lines, 'fb', 240) + 1
    run = load_run(cut_run(reference.directory, tmp_path / 'run', keep) / JOURNAL_FILE)
    servers = restored_servers(reference.session.definition, served(lines[:keep]))
    measured = last_measured(run, structured=False)
    assert measured == {'': servers[''].position}
    assert measured[''][0] == reference.session.history.displacement[240, 0]
    assert measured[''][0] != reference.session.history.displacement[239, 0]


# -- run_test's restarts and a person's resumes --------------------------------------------
def test_restarts_and_resumes_are_told_apart_by_the_restart_note() -> None:
    events = [{'what': 'restart', 'process': 'pd_specimen_sim exited (signal SIGKILL)'},
              {'what': 'resumed', 'note': f'{RESTART_NOTE}: pd_integrator died (code 1)'},
              {'what': 'resumed', 'note': 'after a crash'},  # a person's ./pd run --resume
              {'what': 'resumed'},  # (no note: a person's too)
              {'what': 'control', 'command': 'resume'},  # a resume of a paused test: neither
              {'what': 'epoch_change', 'note': RESTART_NOTE}]
    assert count_continuations(events) == (2, 2)
    assert count_continuations([]) == (0, 0)


def test_a_recovered_summary_counts_restarts_and_resumes_apart(tmp_path: Path) -> None:
    """./pd recover (rebuild_outputs of the journal's bag) writes both counts of the run's
    events: a person's resume is not counted as a restart."""
    definition = load_test_file(DEFAULT_TEST, overrides={'duration': 0.2})
    run = run_offline(definition, tmp_path / 'run', figures=False)
    with Journal(run.directory / JOURNAL_FILE, append=True) as journal:
        journal.write_event('restart', 1, process='pd_specimen_sim exited')
        journal.write_event('resumed', 2, note='after a crash', committed_step=3)
        journal.write_event('resumed', 3, note=f'{RESTART_NOTE}: pd_integrator died',
                            committed_step=5)
    journal_to_bag(run.directory / JOURNAL_FILE, tmp_path / 'bag')
    summary = rebuild_outputs(tmp_path / 'bag', tmp_path / 'out', figures=False).summary
    assert (summary['restarts'], summary['resumes']) == (2, 1)

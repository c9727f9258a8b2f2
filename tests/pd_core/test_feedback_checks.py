"""Feedback that cannot be right is never committed; stale and duplicate answers are counted.

A measured displacement that is not finite, of the wrong length, or farther than
``protocol.tracking_tolerance`` from the command holds the test with the reason; the step stays
pending and a resumed test continues exactly as if the bad answer had never come (the
reference is a session that never saw it).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from pd_common.protocol import Command, Feedback, FeedbackStatus
from pd_common.protocol import TestState as State
from pd_core.errors import ConfigError
from pd_core.run.loop.dispatch import StepDispatcher
from pd_core.run.loop.protocol import StepProtocol, Verdict
from pd_core.run.loop.session import TestSession as Session  # not a test class
from pd_core.run.record.journal import JOURNAL_FILE, Journal
from pd_core.run.runner import load_run, replay_run
from pd_core.run.test_file import from_dict, from_json, load_test_file
from support import journals
from support.paths import REPO, TWO_SITES

M = 2543.4
K = 312559.0
C = 2819.5
# A short inline record (m/s2): 20 steps of 0.01 s after resampling.
RECORD = [0.35, -0.8, 1.2, 0.4, -1.5, 0.9, 0.1, -0.3, 0.6, -0.2, 0.0]
TOLERANCE = 0.005


def definition(n_dof: int = 1, **protocol: Any) -> Any:
    """An elastic test on the short inline record (SDOF, or ``n_dof`` uncoupled DOFs)."""
    names = ['top'] if n_dof == 1 else [f'u{i + 1}' for i in range(n_dof)]
    raw: dict[str, Any] = {
        'test': {'id': 'checks', 'dt': 0.01},
        'structure': {'dof_names': names, 'mass': [M] * n_dof,
                      'damping': {'coefficient': np.diag([C] * n_dof).tolist()},
                      'initial_stiffness': np.diag([K] * n_dof).tolist(),
                      'influence': [1.0] * n_dof},
        'ground_motion': {'inline': {'dt': 0.02, 'acceleration': RECORD}, 'units': 'm/s2'},
        'protocol': {'max_retries': 2, **protocol},
        'specimen': {'elements': [{'model': 'elastic', 'stiffness': K}] * n_dof},
    }
    return from_dict(raw, source='checks-test')


def answer(command: Command, measured: tuple[float, ...] | None = None,
           force: tuple[float, ...] | None = None, step: int | None = None,
           status: FeedbackStatus = FeedbackStatus.OK, test_id: str | None = None) -> Feedback:
    """The answer of an elastic specimen (r = K x), with what is given replaced."""
    x = command.target_displacement
    return Feedback(test_id=command.test_id if test_id is None else test_id,
                    step=command.step if step is None else step,
                    measured_displacement=x if measured is None else measured,
                    restoring_force=tuple(K * value for value in x) if force is None else force,
                    status=status, message='actuator limit' if status is not FeedbackStatus.OK
                    else '')


def run_to(session: Session, step: int) -> Command:
    """Commit steps up to ``step - 1``; return the (pending) command of ``step``."""
    command = session.next_command()
    assert command is not None
    while command.step < step:
        assert session.on_feedback(answer(command)) is Verdict.ACCEPTED
        command = session.next_command()
        assert command is not None
    return command


def finish(session: Session, command: Command | None) -> None:
    while command is not None:
        assert session.on_feedback(answer(command)) is Verdict.ACCEPTED
        command = session.next_command()
    assert session.state is State.FINISHED


@pytest.fixture(scope='module')
def uninterrupted() -> Session:
    session = Session(definition())
    finish(session, session.next_command())
    return session


def assert_same_history(a: Session, b: Session) -> None:
    assert a.history.n_committed == b.history.n_committed
    for name in ('displacement', 'velocity', 'acceleration', 'restoring_force',
                 'measured_displacement'):
        assert np.array_equal(getattr(a.history, name), getattr(b.history, name)), name


def assert_held_not_committed(session: Session, pending: Command, committed: int,
                              reason: str) -> None:
    assert session.state is State.HOLDING
    assert session.message == reason
    assert session.committed_step == committed
    assert session.history.n_committed == committed + 1
    assert session.protocol.pending is pending
    assert session.next_command() is None  # nothing more is commanded while holding
    assert session.status().state is State.HOLDING
    assert session.status().message == reason


# -- measured displacement ---------------------------------------------------------------------
@pytest.mark.parametrize('measured', [(math.nan,), (math.inf,), (-math.inf,), (), (0.0, 0.0)])
def test_an_invalid_measured_displacement_holds_and_is_not_committed(
        measured: tuple[float, ...], uninterrupted: Session) -> None:
    session = Session(definition())
    pending = run_to(session, 7)
    verdict = session.on_feedback(answer(pending, measured=measured))
    assert verdict is Verdict.REFUSED
    assert_held_not_committed(session, pending, 6,
                              f'step 7: invalid measured displacement {list(measured)!r} (a '
                              'fault of the measurement): not committed')
    assert session.protocol.ignored_total == 0
    # The right answer while holding is not taken either.
    assert session.on_feedback(answer(pending)) is Verdict.UNEXPECTED
    assert session.committed_step == 6
    # Resumed: the same step is re-sent, answered, committed; as if nothing had happened.
    assert session.resume() is pending
    assert session.on_feedback(answer(pending)) is Verdict.ACCEPTED
    assert session.committed_step == 7
    finish(session, session.next_command())
    assert_same_history(session, uninterrupted)


def test_an_invalid_measured_displacement_is_refused_with_the_check_off() -> None:
    session = Session(definition(tracking_tolerance=0.0))
    pending = run_to(session, 3)
    assert session.on_feedback(answer(pending, measured=(math.nan,))) is Verdict.REFUSED
    assert session.state is State.HOLDING
    assert session.committed_step == 2


def test_a_measured_displacement_beyond_the_tolerance_holds(uninterrupted: Session) -> None:
    session = Session(definition())
    assert session.definition.protocol.tracking_tolerance == TOLERANCE  # the default
    pending = run_to(session, 12)
    target = pending.target_displacement[0]
    measured = target + 0.0051
    verdict = session.on_feedback(answer(pending, measured=(measured,)))
    assert verdict is Verdict.REFUSED
    assert_held_not_committed(
        session, pending, 11,
        f'step 12: measured displacement of top {measured:.6g} m is 0.0051 m from the '
        f'commanded {target:.6g} m (protocol.tracking_tolerance 0.005 m): not committed; '
        'check the actuator, then resume (or abort)')
    assert session.resume() is pending
    finish(session, pending)
    assert_same_history(session, uninterrupted)


@pytest.mark.parametrize('error', [-0.0051, 0.0051])
def test_both_directions_count(error: float) -> None:
    session = Session(definition())
    pending = run_to(session, 4)
    measured = pending.target_displacement[0] + error
    assert session.on_feedback(answer(pending, measured=(measured,))) is Verdict.REFUSED
    assert 'is 0.0051 m from the commanded' in session.message


def test_a_measured_displacement_within_the_tolerance_is_committed_as_measured() -> None:
    session = Session(definition())
    pending = run_to(session, 5)
    measured = pending.target_displacement[0] - 0.0049
    assert session.on_feedback(answer(pending, measured=(measured,))) is Verdict.ACCEPTED
    assert session.state is State.RUNNING
    assert session.committed_step == 5
    assert session.history.measured_displacement[5, 0] == measured
    assert session.history.displacement[5, 0] == pending.target_displacement[0]


def test_the_worst_dof_is_named() -> None:
    session = Session(definition(n_dof=3))
    pending = run_to(session, 6)
    x = pending.target_displacement
    measured = (x[0] + 0.004, x[1] - 0.009, x[2] + 0.006)
    assert session.on_feedback(answer(pending, measured=measured)) is Verdict.REFUSED
    assert session.message.startswith(f'step 6: measured displacement of u2 {measured[1]:.6g} m'
                                      f' is 0.009 m from the commanded {x[1]:.6g} m')
    assert session.committed_step == 5


def test_a_custom_tolerance_is_used() -> None:
    session = Session(definition(tracking_tolerance=1.0e-4))
    pending = run_to(session, 3)
    measured = pending.target_displacement[0] + 2.0e-4
    assert session.on_feedback(answer(pending, measured=(measured,))) is Verdict.REFUSED
    assert '(protocol.tracking_tolerance 0.0001 m)' in session.message


def test_tolerance_zero_disables_the_check() -> None:
    session = Session(definition(tracking_tolerance=0.0))
    pending = run_to(session, 9)
    far = pending.target_displacement[0] + 0.5
    assert session.on_feedback(answer(pending, measured=(far,))) is Verdict.ACCEPTED
    assert session.state is State.RUNNING
    assert session.committed_step == 9
    assert session.history.measured_displacement[9, 0] == far


def test_tracking_tolerance_in_the_test_file() -> None:
    assert definition().protocol.tracking_tolerance == 0.005
    assert definition(tracking_tolerance=0.002).protocol.tracking_tolerance == 0.002
    with pytest.raises(ConfigError) as error:
        definition(tracking_tolerance=-0.001)
    assert 'tracking_tolerance' in str(error.value)
    assert str(error.value).startswith('checks-test: protocol.tracking_tolerance')
    default = load_test_file(REPO / 'src' / 'pd_integrator' / 'config' / 'default_test.yaml',
                             overrides={'duration': 0.1, 'tracking_tolerance': 0.003})
    assert default.protocol.tracking_tolerance == 0.003


def test_a_record_from_before_the_check_replays_without_it() -> None:
    """A resolved definition without the key (recorded before the check) ran without it."""
    text = definition(tracking_tolerance=0.002).to_json()
    assert from_json(text).protocol.tracking_tolerance == 0.002
    old = text.replace('"tracking_tolerance": 0.002', '"x": 0').replace(', "x": 0', '')
    assert 'tracking_tolerance' not in old
    assert from_json(old).protocol.tracking_tolerance == 0.0


# -- restoring force and status -----------------------------------------------------------------
@pytest.mark.parametrize('force', [(math.nan,), (), (1.0, 2.0)])
def test_an_invalid_restoring_force_holds(force: tuple[float, ...]) -> None:
    session = Session(definition())
    pending = run_to(session, 2)
    assert session.on_feedback(answer(pending, force=force)) is Verdict.REFUSED
    assert_held_not_committed(session, pending, 1,
                              f'step 2: invalid restoring force {list(force)!r}')


def test_a_limit_reported_by_the_specimen_side_holds() -> None:
    session = Session(definition())
    pending = run_to(session, 4)
    assert session.on_feedback(answer(pending, status=FeedbackStatus.LIMIT)) is Verdict.REFUSED
    assert_held_not_committed(session, pending, 3,
                              'step 4: limit reported by the specimen side: actuator limit')


# -- stale, duplicate and other ignored feedback ------------------------------------------------
def test_stale_and_duplicate_feedback_are_counted_apart() -> None:
    session = Session(definition())
    answers: list[Feedback] = []
    command = session.next_command()
    assert command is not None
    for _ in range(4):  # steps 0..3 accepted
        answers.append(answer(command))
        assert session.on_feedback(answers[-1]) is Verdict.ACCEPTED
        command = session.next_command()
        assert command is not None
    pending = command
    assert pending.step == 4
    history = session.history.displacement[:4].copy()
    assert session.on_feedback(answers[3]) is Verdict.DUPLICATE  # the last accepted, again
    assert session.on_feedback(answers[1]) is Verdict.STALE  # an older, answered step
    assert session.on_feedback(answers[0]) is Verdict.STALE
    assert session.on_feedback(answers[3]) is Verdict.DUPLICATE
    assert session.protocol.ignored == {Verdict.DUPLICATE: 2, Verdict.STALE: 2}
    assert session.protocol.ignored_total == 4
    assert session.status().ignored_messages == 4
    assert session.summary_info()['ignored_by_reason'] == {'duplicate': 2, 'stale': 2}
    # None of them changed anything.
    assert session.state is State.RUNNING
    assert session.protocol.pending is pending
    assert session.committed_step == 3
    assert np.array_equal(session.history.displacement[:4], history)
    assert session.on_feedback(answer(pending)) is Verdict.ACCEPTED
    # Now step 3 is an older answered step: stale, and step 4 the duplicate.
    assert session.on_feedback(answers[3]) is Verdict.STALE
    assert session.on_feedback(answer(pending)) is Verdict.DUPLICATE
    assert session.protocol.ignored == {Verdict.DUPLICATE: 3, Verdict.STALE: 3}


def test_foreign_and_unexpected_feedback_are_counted() -> None:
    session = Session(definition())
    pending = run_to(session, 2)
    assert session.on_feedback(answer(pending, test_id='other')) is Verdict.FOREIGN
    assert session.on_feedback(answer(pending, step=5)) is Verdict.UNEXPECTED
    assert session.protocol.ignored == {Verdict.FOREIGN: 1, Verdict.UNEXPECTED: 1}
    assert session.protocol.pending is pending
    assert session.committed_step == 1


def test_a_refused_answer_is_not_an_answered_step() -> None:
    """After a refused (implausible) answer the right one is accepted, not a duplicate."""
    session = Session(definition())
    pending = run_to(session, 3)
    assert session.on_feedback(answer(pending, measured=(1.0,))) is Verdict.REFUSED
    session.resume()
    assert session.on_feedback(answer(pending)) is Verdict.ACCEPTED
    assert session.protocol.ignored == {}


def test_step_protocol_stale_versus_duplicate() -> None:
    protocol = StepProtocol(max_retries=1)

    def command(step: int, iteration: int = 0) -> Command:
        return Command(test_id='t', step=step, test_time=0.0, dof_names=('a',),
                       target_displacement=(0.0,), iteration=iteration)

    def feedback(step: int, iteration: int = 0) -> Feedback:
        return Feedback(test_id='t', step=step, measured_displacement=(0.0,),
                        restoring_force=(0.0,), iteration=iteration)

    protocol.send(command(0))
    assert protocol.classify(feedback(0)) is Verdict.ACCEPTED
    protocol.send(command(1))
    assert protocol.classify(feedback(1)) is Verdict.ACCEPTED
    protocol.send(command(2, 0))
    assert protocol.classify(feedback(2, 0)) is Verdict.ACCEPTED
    protocol.send(command(2, 1))  # an implicit scheme's next iteration
    assert protocol.verdict(feedback(2, 0)) is Verdict.DUPLICATE
    assert protocol.verdict(feedback(1)) is Verdict.STALE
    assert protocol.verdict(feedback(0)) is Verdict.STALE
    assert protocol.verdict(feedback(2, 2)) is Verdict.UNEXPECTED
    assert protocol.ignored == {}  # verdict() changes nothing
    assert protocol.classify(feedback(0)) is Verdict.STALE
    assert protocol.classify(feedback(2, 0)) is Verdict.DUPLICATE
    assert protocol.ignored == {Verdict.STALE: 1, Verdict.DUPLICATE: 1}
    assert protocol.pending == command(2, 1)
    assert protocol.classify(feedback(2, 1)) is Verdict.ACCEPTED
    assert protocol.pending is None
    assert protocol.classify(feedback(2, 1)) is Verdict.DUPLICATE
    assert protocol.classify(feedback(2, 0)) is Verdict.STALE


def test_sites_count_stale_and_duplicate_answers_apart() -> None:
    definition_ = load_test_file(TWO_SITES, overrides={'duration': 0.05})
    session = Session(definition_)
    sent: list[tuple[str, Command]] = []
    dispatcher = StepDispatcher(session, lambda site, command: sent.append((site, command)))
    dispatcher.start()
    answered: dict[str, list[Feedback]] = {'lab1': [], 'lab3': []}
    for _ in range(3):  # steps 0..2, both sites
        batch, sent[:] = list(sent), []
        for site, command in batch:
            answered[site].append(answer(command, force=(0.0,)))
            dispatcher.on_feedback(site, answered[site][-1])
    assert session.committed_step == 2
    assert dispatcher.on_feedback('lab1', answered['lab1'][2]) is Verdict.DUPLICATE
    assert dispatcher.on_feedback('lab1', answered['lab1'][0]) is Verdict.STALE
    assert dispatcher.on_feedback('lab3', answered['lab3'][1]) is Verdict.STALE
    protocols = dispatcher.coordinator.protocols
    assert protocols['lab1'].ignored == {Verdict.DUPLICATE: 1, Verdict.STALE: 1}
    assert protocols['lab3'].ignored == {Verdict.STALE: 1}
    assert dispatcher.status().ignored_messages == 3
    assert session.committed_step == 2
    assert session.state is State.RUNNING


# -- through the step loop and its record --------------------------------------------------------
def test_a_refused_answer_is_recorded_and_replays_the_same(tmp_path: Path,
                                                           uninterrupted: Session) -> None:
    session = Session(definition())
    sent: list[Command] = []
    path = tmp_path / JOURNAL_FILE
    with Journal(path) as journal:
        journal.write_definition(session.definition.to_json(), 1)
        dispatcher = StepDispatcher(session, lambda site, command: sent.append(command),
                                    journal)
        dispatcher.start()
        while sent[-1].step < 8:
            assert dispatcher.on_feedback('', answer(sent[-1])) is Verdict.ACCEPTED
        pending = sent[-1]
        far = (pending.target_displacement[0] + 0.01,)
        assert dispatcher.on_feedback('', answer(pending, measured=far)) is Verdict.REFUSED
        assert session.state is State.HOLDING
        assert session.committed_step == 7
        assert len(sent) == 9  # nothing new was sent
        reason = session.message
        dispatcher.resume()
        assert sent[-1] == pending  # the held step, again
        while session.state is not State.FINISHED:
            assert dispatcher.on_feedback('', answer(sent[-1])) is Verdict.ACCEPTED
        journal.write_status(dispatcher.status(), 2)
    assert_same_history(session, uninterrupted)
    record = load_run(path)
    refused = [f for f in record.feedback if f.measured_displacement == far]
    assert len(refused) == 1  # on record, as received
    replayed = replay_run(record)
    assert replayed.state is State.FINISHED
    assert_same_history(replayed, uninterrupted)
    # Cut right after the refused answer, the record replays to the hold and its reason.
    records = journals.records(path)
    index = next(i for i, record in enumerate(records)
                 if record.kind == 'fb' and record.item.measured_displacement == far)
    cut = tmp_path / 'cut.pdj'
    journals.cut(path, cut, index + 1)
    held = replay_run(load_run(cut))
    assert held.state is State.HOLDING
    assert held.message == reason
    assert held.committed_step == 7

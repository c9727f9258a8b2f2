"""The step protocol and the test session, driven by hand with Feedback objects."""

from __future__ import annotations

import math
import re
from typing import TYPE_CHECKING, Any

import numpy as np
import pytest

from pd_common.protocol import Command, Feedback, FeedbackStatus
from pd_common.protocol import TestState as State
from pd_common.specimen import SpecimenServer, specimen_from_config
from pd_core.errors import ProtocolError, StabilityError
from pd_core.run.loop.protocol import StepProtocol, TimeoutAction, Verdict
from pd_core.run.loop.session import TestSession as Session
from pd_core.run.test_file import from_dict, load_test_file
from support.paths import DEFAULT_TEST

if TYPE_CHECKING:
    from pd_core.run.definition import TestDefinition


M = 2543.4
K = 312559.0
C = 2819.5
DT = 0.01
# A short inline record (m/s2) with a non-zero first sample, so that a0 != 0.
RECORD = [0.35, -0.8, 1.2, 0.4, -1.5, 0.9, 0.1, -0.3, 0.6, -0.2, 0.0]


def definition(**changes: Any) -> TestDefinition:
    """An SDOF test on the short inline record; ``changes`` replace top-level keys."""
    raw: dict[str, Any] = {
        'test': {'id': 'sess', 'dt': DT},
        'structure': {'dof_names': ['top'], 'mass': M, 'damping': {'coefficient': C},
                      'initial_stiffness': K},
        'ground_motion': {'inline': {'dt': 0.02, 'acceleration': RECORD}, 'units': 'm/s2'},
        'protocol': {'max_retries': 2},
        'probe': {'amplitude': 2.0e-3},
        'specimen': {'elements': [{'model': 'elastic', 'stiffness': K}]},
    }
    for key, value in changes.items():
        section, _, name = key.partition('__')
        if name:
            raw[section][name] = value
        else:
            raw[section] = value
    return from_dict(raw, source='session-test')


def ok(command: Command, force: float | tuple[float, ...], test_id: str | None = None,
       step: int | None = None) -> Feedback:
    forces = force if isinstance(force, tuple) else (force,)
    return Feedback(test_id=command.test_id if test_id is None else test_id,
                    step=command.step if step is None else step,
                    measured_displacement=command.target_displacement, restoring_force=forces)


def elastic(command: Command, k: float = K, offset: float = 0.0) -> Feedback:
    """The feedback of a linear-elastic SDOF specimen (r = k x + offset)."""
    return ok(command, k * command.target_displacement[0] + offset)


def newmark_explicit_reference(m: float, c: float, k: float, dt: float, ag: list[float],
                               offset: float = 0.0) -> tuple[list[float], list[float],
                                                             list[float]]:
    """Thesis eqs. 3.20-3.22 for a linear SDOF, in the MATLAB code's operation order."""
    n = len(ag) - 1
    x = [0.0] * (n + 1)
    v = [0.0] * (n + 1)
    a = [0.0] * (n + 1)
    p0 = -m * ag[0]
    fs0 = k * x[0] + offset
    a[0] = (p0 - c * v[0] - fs0) / m
    for i in range(n):
        x[i + 1] = x[i] + dt * v[i] + a[i] * dt * dt * 0.5
        fs = k * x[i + 1] + offset
        p = -m * ag[i + 1]
        a[i + 1] = (p - fs - c * v[i] - dt * 0.5 * c * a[i]) / (m + dt * 0.5 * c)
        v[i + 1] = v[i] + dt * 0.5 * (a[i] + a[i + 1])
    return x, v, a


# -- StepProtocol -----------------------------------------------------------------------------
def command(step: int, test_id: str = 't') -> Command:
    return Command(test_id=test_id, step=step, test_time=step * 0.01, dof_names=('top',),
                   target_displacement=(0.0,))


def feedback(step: int, test_id: str = 't') -> Feedback:
    return Feedback(test_id=test_id, step=step, measured_displacement=(0.0,),
                    restoring_force=(0.0,))


def test_protocol_verdicts_are_counted_by_reason() -> None:
    protocol = StepProtocol(max_retries=3)
    assert protocol.classify(feedback(0)) is Verdict.UNEXPECTED  # nothing pending
    protocol.send(command(3))
    assert protocol.classify(feedback(3, 'other')) is Verdict.FOREIGN
    assert protocol.classify(feedback(3, 't:probe')) is Verdict.FOREIGN
    assert protocol.classify(feedback(2)) is Verdict.STALE
    assert protocol.classify(feedback(4)) is Verdict.UNEXPECTED
    assert protocol.pending == command(3)
    assert protocol.classify(feedback(3)) is Verdict.ACCEPTED
    assert protocol.pending is None
    assert protocol.classify(feedback(3)) is Verdict.DUPLICATE
    protocol.send(command(4))
    assert protocol.classify(feedback(3)) is Verdict.DUPLICATE  # answered before: not stale
    assert protocol.classify(feedback(4)) is Verdict.ACCEPTED
    assert protocol.ignored == {Verdict.UNEXPECTED: 2, Verdict.FOREIGN: 2, Verdict.STALE: 1,
                                Verdict.DUPLICATE: 2}
    assert protocol.ignored_total == 7


def test_protocol_verdict_does_not_change_state() -> None:
    protocol = StepProtocol(max_retries=1)
    protocol.send(command(0))
    assert protocol.verdict(feedback(0)) is Verdict.ACCEPTED
    assert protocol.verdict(feedback(1)) is Verdict.UNEXPECTED
    assert protocol.pending == command(0)
    assert protocol.ignored_total == 0


def test_protocol_timeout_resends_then_holds() -> None:
    protocol = StepProtocol(max_retries=3)
    protocol.send(command(5))
    assert [protocol.on_timeout() for _ in range(3)] == [TimeoutAction.RESEND] * 3
    assert protocol.on_timeout() is TimeoutAction.HOLD
    assert protocol.on_timeout() is TimeoutAction.HOLD
    assert protocol.retries == 3
    assert protocol.pending == command(5)
    # A new step starts a fresh count of attempts (the total of re-sends is kept).
    assert protocol.classify(feedback(5)) is Verdict.ACCEPTED
    protocol.send(command(6))
    assert protocol.on_timeout() is TimeoutAction.RESEND
    assert protocol.retries == 4


def test_protocol_zero_retries_holds_at_once() -> None:
    protocol = StepProtocol(max_retries=0)
    protocol.send(command(0))
    assert protocol.on_timeout() is TimeoutAction.HOLD
    assert protocol.retries == 0


def test_protocol_sending_while_pending_raises() -> None:
    protocol = StepProtocol(max_retries=3)
    protocol.send(command(1))
    with pytest.raises(ProtocolError, match='step 1'):
        protocol.send(command(2))
    assert protocol.pending == command(1)


def test_protocol_timeout_without_pending_raises() -> None:
    with pytest.raises(ProtocolError):
        StepProtocol(max_retries=3).on_timeout()


# -- TestSession: the protocol ----------------------------------------------------------------
def test_step_zero_commands_zeros() -> None:
    session = Session(definition())
    assert session.state is State.IDLE
    first = session.next_command()
    assert first is not None
    assert first.test_id == 'sess'
    assert first.step == 0
    assert first.test_time == 0.0
    assert first.dof_names == ('top',)
    assert first.target_displacement == (0.0,)
    assert session.state is State.RUNNING
    assert session.next_command() is None  # one pending


def test_other_steps_and_test_ids_are_ignored() -> None:
    session = Session(definition())
    first = session.next_command()
    assert first is not None
    assert session.on_feedback(elastic(first)) is Verdict.ACCEPTED
    second = session.next_command()
    assert second is not None
    assert second.step == 1
    committed = session.history.n_committed
    assert committed == 1
    wrong = [(ok(second, 1.0, test_id='other'), Verdict.FOREIGN),
             (ok(second, 1.0, test_id='sess:probe'), Verdict.FOREIGN),
             (ok(second, 1.0, step=2), Verdict.UNEXPECTED),
             (ok(second, 1.0, step=7), Verdict.UNEXPECTED),
             (ok(second, 1.0, step=0), Verdict.DUPLICATE)]
    for message, verdict in wrong:
        assert session.on_feedback(message) is verdict
        assert session.history.n_committed == committed
        assert session.next_command() is None
        assert session.protocol.pending is second
        assert session.state is State.RUNNING
    assert session.status().ignored_messages == len(wrong)
    assert session.on_feedback(elastic(second)) is Verdict.ACCEPTED
    assert session.history.n_committed == 2


@pytest.mark.parametrize('status', [FeedbackStatus.LIMIT, FeedbackStatus.FAULT])
def test_refused_step_holds_and_resumes(status: FeedbackStatus) -> None:
    session = Session(definition())
    for _ in range(2):
        cmd = session.next_command()
        assert cmd is not None
        session.on_feedback(elastic(cmd))
    pending = session.next_command()
    assert pending is not None
    assert pending.step == 2
    refused = Feedback(test_id='sess', step=2, measured_displacement=(0.0,),
                       restoring_force=(123.0,), status=status,
                       message='stroke beyond 0.1 m')
    assert session.on_feedback(refused) is Verdict.REFUSED
    assert session.state is State.HOLDING
    assert 'stroke beyond 0.1 m' in session.message
    assert status.name.lower() in session.message
    assert 'step 2' in session.message
    assert session.history.n_committed == 2
    assert session.next_command() is None
    assert session.status().state is State.HOLDING
    # Feedback while holding is ignored.
    assert session.on_feedback(elastic(pending)) is Verdict.UNEXPECTED
    assert session.history.n_committed == 2
    assert session.resume() is pending
    assert session.state is State.RUNNING
    assert session.on_feedback(elastic(pending)) is Verdict.ACCEPTED
    assert session.history.n_committed == 3
    # The refused force was never used: the response equals the independent loop's.
    ag = [float(value) for value in session.definition.ground_acceleration]
    x, v, a = newmark_explicit_reference(M, C, K, DT, ag[:3])
    assert session.history.displacement[:3, 0].tolist() == x
    assert session.history.velocity[:3, 0].tolist() == v
    assert session.history.acceleration[:3, 0].tolist() == a
    assert session.history.restoring_force[2, 0] != 123.0
    nxt = session.next_command()
    assert nxt is not None
    assert nxt.step == 3


@pytest.mark.parametrize('force', [(math.nan,), (math.inf,), (1.0, 2.0), ()])
def test_invalid_force_holds_and_is_never_used(force: tuple[float, ...]) -> None:
    session = Session(definition())
    first = session.next_command()
    assert first is not None
    session.on_feedback(elastic(first))
    pending = session.next_command()
    assert pending is not None
    assert session.on_feedback(ok(pending, force)) is Verdict.REFUSED
    assert session.state is State.HOLDING
    assert 'invalid restoring force' in session.message
    assert session.history.n_committed == 1
    assert session.protocol.pending is pending
    assert session.resume() is pending
    assert session.on_feedback(elastic(pending)) is Verdict.ACCEPTED
    ag = [float(value) for value in session.definition.ground_acceleration]
    x, v, a = newmark_explicit_reference(M, C, K, DT, ag[:2])
    assert session.history.displacement[:2, 0].tolist() == x
    assert session.history.velocity[:2, 0].tolist() == v
    assert session.history.acceleration[:2, 0].tolist() == a


def test_timeout_resends_the_same_command_then_holds() -> None:
    session = Session(definition())  # max_retries 2
    assert session.on_timeout() is None  # nothing pending
    first = session.next_command()
    assert first is not None
    session.on_feedback(elastic(first))
    pending = session.next_command()
    assert pending is not None
    assert session.on_timeout() is pending
    assert session.on_timeout() is pending
    assert session.state is State.RUNNING
    assert session.on_timeout() is None
    assert session.state is State.HOLDING
    assert 'step 1' in session.message
    assert '2 re-sends' in session.message
    assert session.status().retries == 2
    assert session.on_timeout() is None
    assert session.next_command() is None
    # The operator resumes: the same command goes out again, with a fresh retry budget.
    assert session.resume() is pending
    assert session.on_timeout() is pending
    assert session.on_feedback(elastic(pending)) is Verdict.ACCEPTED
    assert session.history.n_committed == 2
    assert session.status().retries == 3


def test_abort_stops_commands() -> None:
    session = Session(definition())
    first = session.next_command()
    assert first is not None
    session.abort('operator stop')
    assert session.state is State.ABORTED
    assert session.message == 'operator stop'
    assert session.next_command() is None
    assert session.on_feedback(elastic(first)) is Verdict.UNEXPECTED
    assert session.history.n_committed == 0
    assert session.on_timeout() is None
    assert session.resume() is None
    assert session.next_command() is None


def test_session_finishes_after_n_steps() -> None:
    session = Session(definition())
    n = session.definition.n_steps
    assert n == 20  # 11 samples of 0.02 s: 0.2 s, 20 steps of 0.01 s
    commands = []
    while (cmd := session.next_command()) is not None:
        commands.append(cmd)
        session.on_feedback(elastic(cmd))
    assert [cmd.step for cmd in commands] == list(range(n + 1))
    assert [cmd.test_time for cmd in commands] == [step * DT for step in range(n + 1)]
    assert session.state is State.FINISHED
    assert session.committed_step == n
    assert session.history.n_committed == n + 1
    session.abort('too late')
    assert session.state is State.FINISHED


# -- TestSession: integration against an independent loop ------------------------------------
@pytest.mark.parametrize('offset', [0.0, 150.0])
def test_linear_sdof_matches_independent_newmark_explicit_loop(offset: float) -> None:
    """A load-cell offset r0 != 0 included: a0 = (p0 - c v0 - r0)/m."""
    session = Session(definition())
    ag = [float(value) for value in session.definition.ground_acceleration]
    assert ag[0] == 0.35
    x, v, a = newmark_explicit_reference(M, C, K, DT, ag, offset)
    targets = []
    while (cmd := session.next_command()) is not None:
        targets.append(cmd.target_displacement[0])
        assert session.on_feedback(elastic(cmd, offset=offset)) is Verdict.ACCEPTED
    assert session.state is State.FINISHED
    assert targets == x
    history = session.history
    assert history.displacement[:, 0].tolist() == x
    assert history.velocity[:, 0].tolist() == v
    assert history.acceleration[:, 0].tolist() == a
    assert history.restoring_force[:, 0].tolist() == [K * value + offset for value in x]
    assert history.measured_displacement[:, 0].tolist() == x
    # Hand-checked first step: a0 = (-m*ag0 - r0)/m, x1 = a0*dt*dt/2.
    a0 = (-M * 0.35 - offset) / M
    assert a[0] == pytest.approx(a0, rel=1e-15)
    assert x[1] == pytest.approx(a0 * DT * DT / 2.0, rel=1e-15)


def test_el_centro_sdof_matches_independent_loop() -> None:
    d = load_test_file(DEFAULT_TEST, overrides={'duration': 5.0})
    session = Session(d)
    c = float(d.damping[0, 0])
    assert c == pytest.approx(2.0 * 0.05 * math.sqrt(K * M), rel=1e-12)
    ag = [float(value) for value in d.ground_acceleration]
    assert len(ag) == 501
    x, v, a = newmark_explicit_reference(M, c, K, 0.01, ag)
    while (cmd := session.next_command()) is not None:
        session.on_feedback(elastic(cmd))
    assert session.state is State.FINISHED
    assert session.history.displacement[:, 0].tolist() == x
    assert session.history.velocity[:, 0].tolist() == v
    assert session.history.acceleration[:, 0].tolist() == a
    assert max(abs(value) for value in x) > 0.01  # a real response, not zeros


# -- the stiffness probe ----------------------------------------------------------------------
def run_probe(session: Session, server: SpecimenServer) -> list[Command]:
    """Answer commands with the simulated specimen until the probe is over."""
    commands = []
    while session.probe_stiffness is None:
        cmd = session.next_command()
        if cmd is None:
            break
        commands.append(cmd)
        answer = server.handle(cmd.test_id, cmd.step, cmd.target_displacement)
        assert answer is not None
        session.on_feedback(answer)
    return commands


def sdof_probe_definition(k: float) -> TestDefinition:
    return definition(structure={'dof_names': ['top'], 'mass': M, 'damping': {'ratio': 0.05},
                                 'initial_stiffness': 'probe'},
                      specimen={'elements': [{'model': 'elastic', 'stiffness': k}]})


def server_for(d: TestDefinition) -> SpecimenServer:
    specimen = specimen_from_config(d.specimen, base_dir=d.base_dir, source=d.source,
                                    dof_names=d.dof_names)
    return SpecimenServer(specimen)


def test_sdof_probe_measures_k_then_runs_the_test() -> None:
    d = sdof_probe_definition(K)
    assert d.needs_probe
    session = Session(d)
    assert session.probing
    assert math.isnan(session.omega_dt)
    server = server_for(d)
    commands = run_probe(session, server)
    assert [cmd.test_id for cmd in commands] == ['sess:probe'] * 3
    assert [cmd.step for cmd in commands] == [0, 1, 2]
    assert [cmd.target_displacement for cmd in commands] == [(0.0,), (2.0e-3,), (0.0,)]
    assert session.probe_stiffness is not None
    assert session.probe_stiffness.shape == (1, 1)
    assert session.probe_stiffness[0, 0] == pytest.approx(K, rel=1e-9)
    assert not session.probing
    assert session.history.n_committed == 0  # the probe is not part of the response
    measured = session.definition.initial_stiffness
    assert measured is not None
    assert measured[0, 0] == pytest.approx(K, rel=1e-9)
    c = float(session.definition.damping[0, 0])
    assert c == pytest.approx(2.0 * 0.05 * math.sqrt(K * M), rel=1e-9)
    assert session.omega_dt == pytest.approx(math.sqrt(K / M) * DT, rel=1e-9)
    # The test proper: test id '<id>', step 0 at rest, and the linear response.
    ag = [float(value) for value in session.definition.ground_acceleration]
    x, v, _a = newmark_explicit_reference(M, c, K, DT, ag)
    first = session.next_command()
    assert first is not None
    assert first.test_id == 'sess'
    assert first.step == 0
    assert first.target_displacement == (0.0,)
    session.on_feedback(elastic(first))
    while (cmd := session.next_command()) is not None:
        assert cmd.test_id == 'sess'
        session.on_feedback(elastic(cmd))
    assert session.state is State.FINISHED
    assert session.history.displacement[:, 0].tolist() == x
    assert session.history.velocity[:, 0].tolist() == v
    assert session.summary_info()['initial_stiffness_probed'] is True


def test_shear_building_probe_measures_the_stiffness_matrix() -> None:
    k1, k2 = 4.0e5, 2.5e5
    d = definition(
        structure={'dof_names': ['first', 'roof'], 'mass': [[2000.0, 0.0], [0.0, 1500.0]],
                   'damping': {'ratio': 0.05}, 'initial_stiffness': 'probe'},
        specimen={'topology': 'shear_building',
                  'elements': [{'model': 'elastic', 'stiffness': k1},
                               {'model': 'elastic', 'stiffness': k2}]})
    session = Session(d)
    commands = run_probe(session, server_for(d))
    amp = 2.0e-3
    assert [cmd.test_id for cmd in commands] == ['sess:probe'] * 5
    assert [cmd.step for cmd in commands] == [0, 1, 2, 3, 4]
    assert [cmd.target_displacement for cmd in commands] == [
        (0.0, 0.0), (amp, 0.0), (0.0, 0.0), (0.0, amp), (0.0, 0.0)]
    expected = np.array([[k1 + k2, -k2], [-k2, k2]])
    assert session.probe_stiffness is not None
    np.testing.assert_allclose(session.probe_stiffness, expected, rtol=1e-9, atol=1e-9 * k1)
    first = session.next_command()
    assert first is not None
    assert first.test_id == 'sess'
    assert first.target_displacement == (0.0, 0.0)
    # The Rayleigh damping that follows gives 5 % in both modes.
    structure = session.definition.structure()
    mass = np.diag([2000.0, 1500.0])
    eigenvalues = np.sort(np.linalg.eigvals(np.linalg.solve(mass, expected)).real)
    omegas = np.sqrt(eigenvalues)
    # C = a0 M + a1 K with zeta_j = a0/(2 w_j) + a1 w_j / 2.
    a1 = 2.0 * 0.05 / (omegas[0] + omegas[1])
    a0 = a1 * omegas[0] * omegas[1]
    np.testing.assert_allclose(structure.damping, a0 * mass + a1 * expected, rtol=1e-9)


def test_probe_that_finds_an_unstable_stiffness_aborts() -> None:
    k = 2.0e8  # omega = 280 rad/s: omega*dt = 2.8 > 2
    d = sdof_probe_definition(k)
    session = Session(d)
    server = server_for(d)
    commands = []
    while (cmd := session.next_command()) is not None:
        commands.append(cmd)
        answer = server.handle(cmd.test_id, cmd.step, cmd.target_displacement)
        assert answer is not None
        session.on_feedback(ok(cmd, answer.restoring_force))
        assert len(commands) <= 3
    assert [cmd.test_id for cmd in commands] == ['sess:probe'] * 3
    assert session.state is State.ABORTED
    assert 'dt' in session.message
    assert 'probe' in session.message
    limit = 2.0 / math.sqrt(k / M)
    found = re.search(r'dt ≤ ([0-9.e+-]+) s', session.message)
    assert found is not None
    assert float(found.group(1)) == pytest.approx(limit, rel=1e-5)
    assert session.next_command() is None
    assert session.history.n_committed == 0
    assert server.specimen.committed_restoring_force()[0] == 0.0  # brought back to zero


# -- stability --------------------------------------------------------------------------------
def test_unstable_definition_raises_before_anything_is_commanded() -> None:
    d = load_test_file(DEFAULT_TEST, overrides={'dt': 0.2})
    omega = math.sqrt(K / M)
    assert omega * 0.2 == pytest.approx(2.2171, abs=1e-4)
    with pytest.raises(StabilityError, match=r'dt') as info:
        Session(d)
    message = str(info.value)
    found = re.search(r'dt ≤ ([0-9.e+-]+) s', message)
    assert found is not None
    assert float(found.group(1)) == pytest.approx(2.0 / omega, rel=1e-5)
    assert '0.2' in message


def test_stable_limit_dt_is_accepted() -> None:
    omega = math.sqrt(K / M)
    dt = 0.99 * 2.0 / omega  # 0.1786 s: stable, just
    d = load_test_file(DEFAULT_TEST, overrides={'dt': dt, 'duration': 2.0})
    session = Session(d)
    assert session.omega_dt == pytest.approx(0.99 * 2.0, rel=1e-12)


def test_protocol_orders_feedback_by_step_and_iteration() -> None:
    protocol = StepProtocol(max_retries=1)
    command = Command(test_id='t', step=5, test_time=0.05, dof_names=('u',),
                      target_displacement=(0.1,), iteration=2)
    protocol.send(command)

    def answer(step: int, iteration: int) -> Feedback:
        return Feedback(test_id='t', step=step, measured_displacement=(0.1,),
                        restoring_force=(1.0,), iteration=iteration)

    assert protocol.verdict(answer(5, 1)) is Verdict.STALE
    assert protocol.verdict(answer(4, 7)) is Verdict.STALE
    assert protocol.verdict(answer(5, 3)) is Verdict.UNEXPECTED
    assert protocol.verdict(answer(5, 0)) is Verdict.STALE
    assert protocol.classify(answer(5, 2)) is Verdict.ACCEPTED
    assert protocol.classify(answer(5, 2)) is Verdict.DUPLICATE


# -- numerical failure: the session reverts and holds ----------------------------------------
def test_a_non_finite_trial_reverts_to_the_last_step_and_holds() -> None:
    # A light structure (1e-10 kg, 1e-9 N/m: omega = 3.2 rad/s): a finite force of 1e300 N
    # gives an infinite trial acceleration.
    session = Session(definition(structure={'dof_names': ['top'], 'mass': 1.0e-10,
                                            'damping': {'coefficient': 0.0},
                                            'initial_stiffness': 1.0e-9}))
    for _ in range(3):  # step 0 and two integration steps, elastic
        command = session.next_command()
        assert command is not None
        session.on_feedback(elastic(command, k=1.0e-9))
    committed = session.committed_step
    x_committed = session.history.displacement[committed].copy()
    command = session.next_command()
    assert command is not None and command.step == committed + 1
    # A finite but absurd force: the trial acceleration overflows to infinity.
    verdict = session.on_feedback(ok(command, 1.0e300))
    assert verdict is Verdict.ACCEPTED
    assert session.state is State.HOLDING
    assert f'step {command.step}: numerical failure' in session.message
    assert f'reverted to step {committed}' in session.message
    assert session.failure is not None
    assert session.committed_step == committed
    np.testing.assert_array_equal(session.history.displacement[committed], x_committed)
    integrator = session._integrator
    assert integrator is not None
    assert integrator.phase == 'committed' and integrator.status == 'running'
    assert integrator.step == committed
    # Nothing more is commanded, and resume cannot undo a divergence: abort.
    assert session.next_command() is None
    assert session.resume() is None
    assert session.state is State.HOLDING and 'cannot resume' in session.message
    session.abort('operator')
    assert session.state is State.ABORTED
    assert session.summary_info()['failure'] == session.failure

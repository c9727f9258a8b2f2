"""OpenSees models served by the ``opensees_element`` scheme, against their numerical twins.

Unmodified openseespy is the client (a child process running ``examples/opensees/``): each
model with a ``genericClient`` element, served by this project's test against its simulated
specimen (``run_offline``: the same session, journal, bag and run folder as ``./pd run``, the
bridge's limits applied), must equal the same OpenSees model with the element's law
(``zeroLength``/``ElasticPP``) in place of ``genericClient``, to round-off.
"""

from __future__ import annotations

import json
import socket
import threading
import time
from collections import deque
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from pd_common.protocol import Command
from pd_common.protocol import TestState as State
from pd_core.errors import BagError
from pd_core.run.bridge_limits import site_limits
from pd_core.run.loop.dispatch import StepDispatcher
from pd_core.run.loop.session import TestSession as Session  # not a test class
from pd_core.run.record.journal import JOURNAL_FILE, Journal
from pd_core.run.resume import load_resumable
from pd_core.run.runner import (
    RunResult,
    finish_outputs,
    restore_dispatcher,
    run_offline,
    serve_queue,
    site_servers,
)
from pd_core.run.test_file import load_test_file
from support import journals
from support.element_client import (
    committed_steps,
    free_port,
    listening,
    run_example,
    start_example,
)
from support.opensees_material import opensees_available
from support.paths import CONFIG

pytestmark = pytest.mark.skipif(not opensees_available(),
                                reason='openseespy cannot be imported')

SERVE_EPP = CONFIG / 'serve_epp.yaml'
SERVE_TWO_STORY = CONFIG / 'serve_two_story.yaml'
SERVE_ONE_BAY = CONFIG / 'serve_one_bay_frame.yaml'
STEPS = '500'


def serve(test_file: Path, port: int, out: Path, **parameters: object) -> tuple[
        threading.Thread, dict[str, RunResult | BaseException]]:
    """Run the served test in a thread (``run_offline``) on ``port``; returns it and its box."""
    definition = load_test_file(test_file)
    definition = replace(definition, scheme_parameters={
        **definition.scheme_parameters, 'port': float(port), **parameters})
    box: dict[str, RunResult | BaseException] = {}

    def target() -> None:
        try:
            box['result'] = run_offline(definition, out, figures=False,
                                        limits=site_limits(definition, None))
        except BaseException as err:  # reported by the test
            box['error'] = err

    thread = threading.Thread(target=target, daemon=True)
    thread.start()
    return thread, box


def wait_port(port: int, thread: threading.Thread) -> None:
    deadline = time.monotonic() + 30
    while not listening(port):
        assert thread.is_alive(), 'the server ended before listening'
        assert time.monotonic() < deadline, f'nothing listens on {port}'
        time.sleep(0.02)


def served_and_twin(tmp_path: Path, script: str, test_file: Path, *args: str
                    ) -> tuple[np.ndarray, np.ndarray, RunResult]:
    port = free_port()
    thread, box = serve(test_file, port, tmp_path / 'run')
    wait_port(port, thread)
    served = run_example(script, tmp_path / 'served.txt', '--element', 'generic', '--port',
                         str(port), '--steps', STEPS, *args)
    thread.join(60)
    assert 'error' not in box, box.get('error')
    twin = run_example(script, tmp_path / 'twin.txt', '--element', 'numerical', '--steps',
                       STEPS, *args)
    result = box['result']
    assert isinstance(result, RunResult)
    return served, twin, result


@pytest.mark.parametrize('integrator', ['explicit', 'newton'])
def test_sdof_equals_its_elastic_pp_twin(tmp_path: Path, integrator: str) -> None:
    served, twin, result = served_and_twin(tmp_path, 'sdof_epp.py', SERVE_EPP,
                                           '--integrator', integrator)
    assert served.shape == twin.shape == (int(STEPS), 3)
    assert np.abs(twin[:, 1]).max() > 0.032  # the column yields (d_y = 32 mm)
    np.testing.assert_allclose(served, twin, rtol=0, atol=1e-9 * 4e4)
    np.testing.assert_allclose(served[:, 1], twin[:, 1], rtol=0, atol=1e-12)
    summary = result.summary
    assert summary['state'] == 'finished'
    # The run folder is ./pd run's: the record holds every committed step, OpenSees's values.
    response = np.genfromtxt(result.directory / 'response.csv', delimiter=',', names=True)
    assert len(response) == int(STEPS) + 1
    np.testing.assert_array_equal(response[response.dtype.names[2]][1:], served[:, 1])
    assert (result.directory / 'journal.pdj').exists()
    assert (result.directory / 'bag').is_dir()
    json.loads((result.directory / 'summary.json').read_text())


def test_two_story_shear_with_storey_one_physical_equals_its_twin(tmp_path: Path) -> None:
    served, twin, _ = served_and_twin(tmp_path, 'two_story_shear.py', SERVE_TWO_STORY,
                                      '--scale', '2.0')
    assert np.abs(twin[:, 1]).max() > 6.0e4 / 4.0e6  # storey 1 yields
    np.testing.assert_allclose(served[:, 1:3], twin[:, 1:3], rtol=0, atol=1e-12)
    np.testing.assert_allclose(served[:, 3], twin[:, 3], rtol=0, atol=1e-6)


@pytest.mark.parametrize('integrator', ['explicit', 'newton'])
def test_one_bay_frame_with_both_columns_in_one_element_equals_its_twin(
        tmp_path: Path, integrator: str) -> None:
    """OpenFresco's OneBayFrame: one two-DOF genericClient (both column tops) served against
    two independent simulated columns (bilinear, elastic) equals the twin's twoNodeLinks with
    Steel01 and Elastic, 500 steps: displacements to 1e-12 m, forces to 1e-6 N (measured
    4.9e-17 m and 2.0e-11 N with NewmarkExplicit, 1.2e-14 m and 4.3e-9 N with Newton; peaks
    55 mm and 17 kN)."""
    served, twin, result = served_and_twin(tmp_path, 'one_bay_frame.py', SERVE_ONE_BAY,
                                           '--integrator', integrator)
    assert served.shape == twin.shape == (int(STEPS), 5)  # t, u3, u4, column 1, column 2
    yield_force = 1.5 * 4448.2216152605
    assert np.abs(twin[:, 1]).max() > 3 * yield_force / (2.8 * 4448.2216152605 / 0.0254)
    assert np.abs(twin[:, 3]).max() > 1.02 * yield_force  # column 1 yields and hardens
    np.testing.assert_allclose(served[:, 1:3], twin[:, 1:3], rtol=0, atol=1e-12)
    np.testing.assert_allclose(served[:, 3:5], twin[:, 3:5], rtol=0, atol=1e-6)
    assert result.summary['state'] == 'finished'
    response = np.genfromtxt(result.directory / 'response.csv', delimiter=',', names=True)
    assert len(response) == int(STEPS) + 1


def drop_client(tmp_path: Path, at: int) -> tuple[Path, int, RunResult]:
    """Serve the SDOF test and kill openseespy once step ``at`` is on record.

    Returns the run folder, the port and the run's result (the server ended by itself).
    """
    port = free_port()
    out = tmp_path / 'run'
    thread, box = serve(SERVE_EPP, port, out)
    wait_port(port, thread)
    client = start_example('sdof_epp.py', tmp_path / 'first.txt', '--element', 'generic',
                           '--port', str(port), '--steps', STEPS)
    deadline = time.monotonic() + 60
    while committed_steps(out) < at:
        assert client.poll() is None and time.monotonic() < deadline, f'no step {at}'
        time.sleep(0.01)
    client.kill()
    client.wait(10)
    thread.join(60)
    assert not thread.is_alive()
    assert 'error' not in box, box.get('error')
    result = box['result']
    assert isinstance(result, RunResult)
    return out, port, result


def test_a_dropped_client_holds_the_test_with_a_complete_record(tmp_path: Path) -> None:
    """openseespy killed mid-test: the test holds with the reason, nothing more is commanded,
    the record holds every committed step (the twin's first steps), a reconnect is refused."""
    out, port, result = drop_client(tmp_path, 150)
    summary = result.summary
    assert summary['state'] == 'holding', summary
    assert "OpenSees element: the element's connection failed" in summary['message'] or (
        'OpenSees element: the element closed its connection without DIE' in summary['message'])
    with pytest.raises(ConnectionRefusedError), socket.create_connection(('127.0.0.1', port), 2):
        pass  # the listener is closed: a reconnect is refused
    measured = committed_steps(out)  # step 0 at rest, then one per step (the last may be
    assert measured >= 151           # measured but not committed by OpenSees)
    twin = run_example('sdof_epp.py', tmp_path / 'twin.txt', '--element', 'numerical',
                       '--steps', STEPS)
    response = np.genfromtxt(out / 'response.csv', delimiter=',', names=True)
    steps = len(response) - 1
    assert steps in (measured - 1, measured - 2)
    np.testing.assert_allclose(response[response.dtype.names[2]][1:], twin[:steps, 1],
                               rtol=0, atol=1e-12)


def resume_served(folder: Path) -> tuple[threading.Thread, dict[str, object]]:
    """Resume a stopped served run as the integrator node does, in a thread.

    The simulated specimen is restored from the commands on record (a restored simulator);
    the scheme waits for the model (started again from its beginning), the record is re-run
    with it, then the operator's resume sends what the run owes and the test goes on.
    """
    box: dict[str, object] = {}

    def target() -> None:
        try:
            directory, definition, record = load_resumable(folder)
            servers = site_servers(definition)
            for _, item in record.events:
                if isinstance(item, Command):
                    servers[''].handle(item.test_id, item.step, item.target_displacement,
                                       iteration=item.iteration)
            session = Session(definition)
            element = session.served_element
            assert element is not None
            box['port'] = element.open().port
            queue: deque[tuple[str, Command]] = deque()
            with Journal(directory / JOURNAL_FILE, append=True) as journal:
                dispatcher = StepDispatcher(session, lambda s, c: queue.append((s, c)), journal)
                element.connect()
                box['owed'] = restore_dispatcher(record, dispatcher, str(directory))
                box['sent_while_restoring'] = len(queue)
                box['restored'] = (session.state, session.committed_step)
                dispatcher.resume()  # the operator's resume (the record ends held)
                serve_queue(queue, servers, dispatcher)
                journal.write_status(dispatcher.status(), time.time_ns())
            finish_outputs(session, directory, wall_time=0.0, figures=False)
            box['session'] = session
        except BaseException as err:  # reported by the test
            box['error'] = err
        finally:
            if 'session' in locals() and session.served_element is not None:
                session.served_element.close()

    thread = threading.Thread(target=target, daemon=True)
    thread.start()
    return thread, box


def dropped_run(tmp_path: Path, at: int) -> Path:
    """A served SDOF run whose OpenSees process was killed after step ``at`` (it holds)."""
    out, _, result = drop_client(tmp_path, at)
    assert result.summary['state'] == 'holding'
    assert '--resume' in result.summary['message']  # the way on is named
    return out


def resumed_port(thread: threading.Thread, box: dict[str, object]) -> int:
    """The port the resumed run (:func:`resume_served`) listens on, once it listens."""
    deadline = time.monotonic() + 30
    while 'port' not in box:
        assert thread.is_alive() and time.monotonic() < deadline, box.get('error')
        time.sleep(0.01)
    port = box['port']
    assert isinstance(port, int)
    wait_port(port, thread)
    return port


def test_a_model_started_again_resumes_from_the_journal_and_ends_as_its_twin(
        tmp_path: Path) -> None:
    """openseespy killed mid-test, then started again from its beginning against the resumed
    run: its steps on record are answered from the journal (nothing is commanded), the test
    goes on from the last committed step, and the whole response is the twin's to round-off."""
    out = dropped_run(tmp_path, 200)
    recorded = committed_steps(out)
    thread, box = resume_served(out)
    port = resumed_port(thread, box)
    again = run_example('sdof_epp.py', tmp_path / 'again.txt', '--element', 'generic',
                        '--port', str(port), '--steps', STEPS)
    thread.join(60)
    assert 'error' not in box, box.get('error')
    assert box['sent_while_restoring'] == 0
    state, committed = box['restored']  # type: ignore[misc]
    assert state is State.HOLDING and committed >= recorded - 3
    owed = box['owed']
    assert isinstance(owed, list) and len(owed) == 1
    assert owed[0][1].step == committed + 1  # the first step past the record, not before
    session = box['session']
    assert isinstance(session, Session) and session.state is State.FINISHED
    twin = run_example('sdof_epp.py', tmp_path / 'twin.txt', '--element', 'numerical',
                       '--steps', STEPS)
    assert np.abs(twin[:, 1]).max() > 0.032  # the column yields (d_y = 32 mm)
    np.testing.assert_allclose(again[:, 1], twin[:, 1], rtol=0, atol=1e-12)
    response = np.genfromtxt(out / 'response.csv', delimiter=',', names=True)
    assert len(response) == int(STEPS) + 1
    np.testing.assert_array_equal(response[response.dtype.names[2]][1:], again[:, 1])
    # Every step was commanded once, but for the one owed at the drop (sent again).
    steps = [record.item.step for record in journals.records(out / JOURNAL_FILE)
             if record.kind == 'cmd']
    assert len(steps) - len(set(steps)) <= 1
    assert sorted(set(steps)) == list(range(int(STEPS) + 1))


def test_another_model_is_refused_at_its_first_trial_off_the_record(tmp_path: Path) -> None:
    """A model that is not the run's (the record scaled by 1.5) reconnecting to a resumed run:
    refused at its first trial that differs, nothing commanded, the journal unchanged."""
    out = dropped_run(tmp_path, 120)
    before = (out / JOURNAL_FILE).read_bytes()
    thread, box = resume_served(out)
    port = resumed_port(thread, box)
    other = start_example('sdof_epp.py', tmp_path / 'other.txt', '--element', 'generic',
                          '--port', str(port), '--steps', STEPS, '--scale', '1.5')
    thread.join(60)
    other.kill()
    other.wait(10)
    error = box.get('error')
    assert isinstance(error, BagError), error
    assert 'differs from the recomputed one' in str(error)
    assert 'sent_while_restoring' not in box
    assert (out / JOURNAL_FILE).read_bytes() == before

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
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from pd_core.run.bridge_limits import site_limits
from pd_core.run.runner import RunResult, run_offline
from pd_core.run.test_file import load_test_file
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
    assert (result.directory / 'journal.jsonl').exists()
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


def test_a_dropped_client_holds_the_test_with_a_complete_record(tmp_path: Path) -> None:
    """openseespy killed mid-test: the test holds with the reason, nothing more is commanded,
    the record holds every committed step (the twin's first steps), a reconnect is refused."""
    port = free_port()
    out = tmp_path / 'run'
    thread, box = serve(SERVE_EPP, port, out)
    wait_port(port, thread)
    client = start_example('sdof_epp.py', tmp_path / 'served.txt', '--element', 'generic',
                           '--port', str(port), '--steps', STEPS)
    deadline = time.monotonic() + 60
    while committed_steps(out) < 150:
        assert client.poll() is None and time.monotonic() < deadline, 'no step 150'
        time.sleep(0.01)
    client.kill()
    client.wait(10)
    thread.join(60)
    assert not thread.is_alive()
    assert 'error' not in box, box.get('error')
    result = box['result']
    assert isinstance(result, RunResult)
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

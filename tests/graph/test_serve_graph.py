"""``./pd serve`` through the node graph, with unmodified openseespy as the client.

The shipped ``serve_epp.yaml`` is served by ``element_server`` (which runs ``run_test``: the
integrator serves the element, the bridge drives the simulated specimen over DDS) and
``examples/opensees/sdof_epp.py`` is the model:

* run to its end, its response equals its all-numerical twin (``zeroLength``/``ElasticPP``)
  to round-off, and the run folder is ``./pd run``'s (bag, journal, ``response.csv``,
  ``summary.json``);
* the integrator (the element's server) SIGKILLed mid-test: nothing more reaches the specimen;
  run_test restarts it from its journal, OpenSees started again from its beginning is answered
  from the journal (the specimen hears nothing twice) and the test ends as the twin.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml
from graph_support import Processes, executable
from test_crash_resume import child_of, committed_steps
from test_graph import RUN_TIMEOUT, spin_until, wait_exit

from pd_bringup.supervisor import HUNG_TIMEOUT
from support.element_client import (
    free_port,
    run_example,
    start_example,
    wait_listening,
)
from support.opensees_material import opensees_available
from support.paths import CONFIG, GROUND_MOTIONS

pytestmark = [pytest.mark.graph,
              pytest.mark.skipif(not opensees_available(), reason='openseespy cannot be imported')]

STEPS = 300
KILL_AT = 120


def served_test(directory: Path, port: int) -> Path:
    """The shipped serve_epp.yaml on ``port`` (its record path made absolute)."""
    raw = yaml.safe_load((CONFIG / 'serve_epp.yaml').read_text(encoding='utf-8'))
    raw['test']['scheme_parameters']['port'] = port
    raw['test']['duration'] = STEPS / 100 + 1.0
    raw['ground_motion']['file'] = str(GROUND_MOTIONS / 'at_rest.csv')
    path = directory / 'serve.yaml'
    path.write_text(yaml.safe_dump(raw), encoding='utf-8')
    return path


def start_server(processes: Processes, tmp_path: Path) -> tuple[subprocess.Popen[bytes], int,
                                                                   Path]:
    """``element_server FILE --out RUN --no-figures`` listening; returns it, port, run."""
    port = free_port()
    out = tmp_path / 'run'
    server = processes.start('serve', [executable('pd_actuator_bridge', 'element_server'),
                                       str(served_test(tmp_path, port)), '--out', str(out),
                                       '--no-figures'])
    wait_listening(port, server)  # type: ignore[arg-type]
    return server, port, out


def twin(tmp_path: Path) -> np.ndarray:
    return run_example('sdof_epp.py', tmp_path / 'twin.txt', '--element', 'numerical',
                       '--steps', str(STEPS))


def top_displacement(run: Path) -> np.ndarray:
    response = np.genfromtxt(run / 'response.csv', delimiter=',', names=True)
    column: np.ndarray = response[response.dtype.names[2]]
    return column


def test_served_through_the_graph_equals_the_twin(processes: Processes, tmp_path: Path) -> None:
    """The model starts later than run_test's hung timeout after the server (a large model
    takes that long to build): the integrator's heartbeat goes on while it waits for the
    element, it is not taken for hung, and the run equals the twin."""
    server, port, out = start_server(processes, tmp_path)
    time.sleep(HUNG_TIMEOUT + 1.5)
    assert server.poll() is None, processes.log('serve')[-3000:]
    served = run_example('sdof_epp.py', tmp_path / 'served.txt', '--element', 'generic',
                         '--port', str(port), '--steps', str(STEPS))
    assert wait_exit(server, RUN_TIMEOUT, lambda: processes.log('serve')) == 0, \
        processes.log('serve')[-3000:]
    reference = twin(tmp_path)
    assert np.abs(reference[:, 1]).max() > 0.032  # the column yields (d_y = 32 mm)
    np.testing.assert_allclose(served, reference, rtol=0, atol=1e-9 * 4e4)
    np.testing.assert_allclose(served[:, 1], reference[:, 1], rtol=0, atol=1e-12)
    # The run folder is ./pd run's.
    assert (out / 'bag').is_dir() and (out / 'journal.pdj').is_file()
    summary = json.loads((out / 'summary.json').read_text(encoding='utf-8'))
    assert summary['state'] == 'finished', summary
    assert summary['steps'] == STEPS
    np.testing.assert_array_equal(top_displacement(out)[1:], served[:, 1])
    assert 'stopped answering' not in processes.log('serve')


def test_killed_server_is_restarted_from_its_journal_and_the_model_started_again_ends_as_the_twin(
        processes: Processes, observer: Any, tmp_path: Path) -> None:
    """The integrator (the element's server) SIGKILLed mid-test: nothing moves; run_test
    restarts it from its journal and it waits for the model; OpenSees started again from its
    beginning is answered from the journal (the specimen hears nothing it already did) and the
    test ends as the all-numerical twin, every step on record once."""
    from pd_msgs.msg import StepCommand

    heard: list[int] = []
    observer.create_subscription(StepCommand, '/pd/specimen/step_command',
                                 lambda m: heard.append(int(m.step)), 1000)
    server, port, out = start_server(processes, tmp_path)
    spin_until(observer, lambda: observer.count_publishers('/pd/specimen/step_command') > 0,
               RUN_TIMEOUT, 'the bridge')
    client = start_example('sdof_epp.py', tmp_path / 'first.txt', '--element', 'generic',
                           '--port', str(port), '--steps', str(STEPS))
    try:
        deadline = time.monotonic() + RUN_TIMEOUT
        while committed_steps(out) < KILL_AT:
            assert client.poll() is None and server.poll() is None, processes.log('serve')
            assert time.monotonic() < deadline, 'the served test never reached the kill step'
            observer.executor_for_test.spin_once(timeout_sec=0.01)
        os.kill(child_of(server, 'integrator'), signal.SIGKILL)  # type: ignore[arg-type]
        deadline = time.monotonic() + RUN_TIMEOUT
        while 'resuming a served run' not in processes.log('serve'):
            assert server.poll() is None, processes.log('serve')[-3000:]
            assert time.monotonic() < deadline, processes.log('serve')[-3000:]
            observer.executor_for_test.spin_once(timeout_sec=0.05)
    finally:  # OpenSees's genericClient does not notice a lost server: it waits on its socket
        client.kill()
        client.wait()
    committed = committed_steps(out) - 1  # step 0 at rest first
    assert committed >= KILL_AT - 1
    end = time.monotonic() + 1.0
    while time.monotonic() < end:
        observer.executor_for_test.spin_once(timeout_sec=0.05)
    # Nothing moved meanwhile: the specimen heard no step beyond the one owed at the kill.
    assert heard and max(heard) <= committed + 1, (max(heard), committed)
    before = len(heard)

    wait_listening(port, server)  # type: ignore[arg-type]
    again = run_example('sdof_epp.py', tmp_path / 'again.txt', '--element', 'generic',
                        '--port', str(port), '--steps', str(STEPS))
    assert wait_exit(server, RUN_TIMEOUT, lambda: processes.log('serve')) == 0, \
        processes.log('serve')[-3000:]
    log = processes.log('serve')
    assert 'pd_integrator died' in log and 'restarting it from its journal' in log, log[-3000:]
    end = time.monotonic() + 1.0
    while time.monotonic() < end:
        observer.executor_for_test.spin_once(timeout_sec=0.05)
    # The steps on record were answered from the journal: the specimen heard none again.
    assert heard[before:] and min(heard[before:]) >= committed, (heard[before:][:5], committed)
    reference = twin(tmp_path)
    np.testing.assert_allclose(again[:, 1], reference[:, 1], rtol=0, atol=1e-12)
    summary = json.loads((out / 'summary.json').read_text(encoding='utf-8'))
    assert summary['state'] == 'finished', summary
    assert summary['steps'] == STEPS
    np.testing.assert_array_equal(top_displacement(out)[1:], again[:, 1])

"""The figure worker: a second process draws a run's figures, the same files as in-process.

* its figures are byte-identical to those ``run_offline`` draws itself;
* ``finish_outputs`` runs ``before_summary`` before ``summary.json`` is written, and both before
  the figures are waited for;
* a child that is never asked (closed by its parent, or its parent killed) ends without drawing;
* a child that fails or is gone leaves the drawing to the caller, with the reason.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from pd_core.run.record.figure_worker import FigureWorker
from pd_core.run.record.outputs import FIGURES, tracking_history
from pd_core.run.runner import RunResult, finish_outputs, run_offline
from pd_core.run.test_file import from_dict

SHORT = {
    'test': {'id': 'figure-worker', 'scheme': 'newmark_explicit', 'dt': 0.01, 'duration': 1.0},
    'structure': {'dof_names': ['top'], 'mass': 2543.4, 'damping': {'ratio': 0.02},
                  'initial_stiffness': 312559.0, 'influence': [1.0]},
    'ground_motion': {'inline': {'dt': 0.02, 'acceleration': [
        0.0, 0.5, 1.0, -0.5, -1.5, 0.3, 2.0, -2.0, 1.0, 0.0] * 5}, 'units': 'm/s2'},
    'specimen': {'topology': 'independent', 'elements': [
        {'model': 'epp', 'stiffness': 312559.0, 'yield_force': 3000.0}]},
}


def _run(directory: Path, *, figures: bool) -> RunResult:
    return run_offline(from_dict(SHORT, source='short.yaml'), directory, figures=figures)


@pytest.fixture(scope='module')
def in_process(tmp_path_factory: pytest.TempPathFactory) -> RunResult:
    """The short test run ROS-free, its figures drawn in-process."""
    return _run(tmp_path_factory.mktemp('in_process') / 'run', figures=True)


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    return True


def test_worker_figures_are_byte_identical(in_process: RunResult, tmp_path: Path) -> None:
    result = _run(tmp_path / 'run', figures=False)
    (result.directory / 'summary.json').unlink()  # (run_offline's): written again below
    worker = FigureWorker.start()
    assert worker is not None
    seen: list[bool] = []

    def before_summary() -> None:  # the figures are the worker's, still being drawn
        seen.append((result.directory / 'summary.json').is_file())

    finish_outputs(result.session, result.directory, wall_time=0.0, figures=True,
                   figure_worker=worker, before_summary=before_summary, mode='offline')
    assert worker.error is None
    assert seen == [False]
    for name in FIGURES:
        drawn = (result.directory / name).read_bytes()
        assert drawn == (in_process.directory / name).read_bytes(), name
    worker.close()
    assert worker._process.returncode == 0


def test_worker_answers_with_the_paths_it_wrote(in_process: RunResult, tmp_path: Path
                                                ) -> None:
    worker = FigureWorker.start()
    assert worker is not None
    history = in_process.session.history
    assert worker.submit(history, tmp_path, title='t', tracking=tracking_history(history))
    written = worker.wait()
    assert written is not None
    assert sorted(path.name for path in written) == sorted(
        name for name in FIGURES if name != 'energy.png')
    assert all(path.is_file() for path in written)
    assert not worker.submit(history, tmp_path)  # one request per worker


def test_worker_never_asked_exits_without_drawing(tmp_path: Path) -> None:
    worker = FigureWorker.start()
    assert worker is not None
    worker.close()
    assert worker._process.returncode is not None  # ended, without drawing
    assert worker.wait() is None
    assert list(tmp_path.iterdir()) == []


def test_worker_exits_when_its_parent_is_killed() -> None:
    script = ('import time; from pd_core.run.record.figure_worker import FigureWorker; '
              'worker = FigureWorker.start(); print(worker.pid, flush=True); time.sleep(120)')
    parent = subprocess.Popen([sys.executable, '-c', script], stdout=subprocess.PIPE, text=True)
    try:
        assert parent.stdout is not None
        child = int(parent.stdout.readline())
        assert _alive(child)
    finally:
        parent.send_signal(signal.SIGKILL)
        parent.wait()
    deadline = time.monotonic() + 30.0
    while _alive(child):  # a zombie until init reaps it: its state then says so
        state = Path(f'/proc/{child}/stat')
        if not state.exists() or state.read_text().split(') ')[-1].startswith('Z'):
            break
        assert time.monotonic() < deadline, 'the figure worker outlived its parent'
        time.sleep(0.05)


def test_worker_failure_is_reported(in_process: RunResult, tmp_path: Path) -> None:
    worker = FigureWorker.start()
    assert worker is not None
    assert worker.submit(in_process.session.history, tmp_path / 'missing' / 'folder')
    assert worker.wait() is None
    assert worker.error is not None
    assert 'FileNotFoundError' in worker.error


def test_finish_outputs_draws_itself_when_the_worker_is_gone(in_process: RunResult,
                                                            tmp_path: Path) -> None:
    result = _run(tmp_path / 'run', figures=False)
    worker = FigureWorker.start()
    assert worker is not None
    worker._process.kill()
    worker._process.wait()
    finish_outputs(result.session, result.directory, wall_time=0.0, figures=True,
                   figure_worker=worker, mode='offline')
    assert worker.error is not None
    for name in FIGURES:
        assert (result.directory / name).read_bytes() == (
            in_process.directory / name).read_bytes(), name

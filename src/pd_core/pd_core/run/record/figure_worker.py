"""A run's figures drawn by a second process while the run's process writes its other outputs.

Drawing the six figures of a run takes 1.2–1.7 s of CPU, and importing matplotlib 0.45 s more,
all after the last step. :class:`FigureWorker` starts a child interpreter early (the node graph's
integrator starts it with the first step): at a lower scheduling priority (``nice`` +10) it
imports numpy, matplotlib and the figure code while the test runs, then waits on its standard
input. At the end the run hands it the committed history (pickled through the pipe, parent to
its own child only) and converts the journal to the bag and writes the CSV files and the
summary while the child draws. The figures are the same functions and the same data as in
:func:`.outputs.draw_run_figures` in-process, so the files are identical.

The child never outlives its parent's intent: standard input closed without a request (the
parent ended, normally or killed) makes it exit without drawing. A child that cannot be started,
dies or times out leaves the drawing to the caller (:meth:`FigureWorker.wait` returns
``None`` and :attr:`FigureWorker.error` says why).

Run as ``python -m pd_core.run.record.figure_worker`` by
:meth:`FigureWorker.start` only.
"""

from __future__ import annotations

import contextlib
import json
import os
import pickle
import subprocess
import sys
from pathlib import Path
from typing import IO, TYPE_CHECKING, Any, cast

if TYPE_CHECKING:
    from .energy import EnergyHistory
    from .history import ResponseHistory
    from .outputs import TrackingHistory

#: The child's niceness increment: its imports use what the test's processes leave idle.
NICENESS = 10
#: Most seconds :meth:`FigureWorker.wait` waits for the figures (a long MDOF test's included).
WAIT_TIMEOUT_S = 600.0
_MODULE = 'pd_core.run.record.figure_worker'


class FigureWorker:
    """A child process that draws a run's figures on request (see the module)."""

    def __init__(self, process: subprocess.Popen[bytes]) -> None:
        self._process = process
        self._submitted = False
        self.error: str | None = None

    @classmethod
    def start(cls) -> FigureWorker | None:
        """Start the child (it prepares at once); ``None`` if it cannot be started."""
        try:
            process = subprocess.Popen([sys.executable, '-m', _MODULE], stdin=subprocess.PIPE,
                                       stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                       env=dict(os.environ, PYTHONUNBUFFERED='1'))
        except OSError:
            return None
        return cls(process)

    @property
    def pid(self) -> int:
        """The child's process id."""
        return self._process.pid

    def submit(self, history: ResponseHistory, directory: str | Path, *, title: str = '',
               energy: EnergyHistory | None = None, tracking: TrackingHistory | None = None
               ) -> bool:
        """Hand the child what to draw; whether it took it (else draw in-process)."""
        if self._submitted or self.error is not None:
            return False
        self._submitted = True
        payload = pickle.dumps({'history': history, 'directory': str(directory),
                                'title': title, 'energy': energy, 'tracking': tracking},
                               protocol=pickle.HIGHEST_PROTOCOL)
        stdin = cast('IO[bytes]', self._process.stdin)
        try:
            stdin.write(payload)
            stdin.close()
        except OSError as err:  # the child is gone (BrokenPipeError among them)
            self.error = f'figure worker: not taken ({err.strerror or err})'
            self._reap()
            return False
        return True

    def wait(self, timeout: float = WAIT_TIMEOUT_S) -> list[Path] | None:
        """The figures the child wrote, once it has; ``None`` (and :attr:`error`) if it failed."""
        if not self._submitted or self.error is not None:
            return None
        self._process.stdin = None  # closed by submit: communicate only reads
        try:
            out, err = self._process.communicate(timeout=timeout)
        except subprocess.TimeoutExpired:
            self.error = f'figure worker: no figures within {timeout:g} s'
            self._reap()
            return None
        if self._process.returncode != 0:
            lines = err.decode('utf-8', 'replace').strip().splitlines()
            why = lines[-1] if lines else f'exit code {self._process.returncode}'
            self.error = f'figure worker: {why}'
            return None
        try:
            return [Path(path) for path in json.loads(out.decode('utf-8'))]
        except (ValueError, TypeError):
            self.error = 'figure worker: no list of figures in its answer'
            return None

    def close(self) -> None:
        """End the child; one never given work is stopped at once (it may still be preparing)."""
        if not self._submitted:
            self._submitted = True
            self.error = 'figure worker: closed'
            with contextlib.suppress(OSError):
                self._process.kill()
        self._reap()

    def _reap(self) -> None:
        process = self._process
        with contextlib.suppress(OSError, ValueError):
            if process.stdin is not None and not process.stdin.closed:
                process.stdin.close()
        try:
            process.wait(timeout=2.0)
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait()
        for stream in (process.stdout, process.stderr):
            if stream is not None:
                stream.close()


def _serve(stdin: IO[bytes]) -> list[str] | None:
    """Prepare, wait for one request and draw it; ``None`` if none came."""
    with contextlib.suppress(OSError):
        os.nice(NICENESS)
    from .outputs import draw_run_figures, prepare_figures  # noqa: PLC0415 - after nice

    prepare_figures()
    data = stdin.read()
    if not data:
        return None
    request: dict[str, Any] = pickle.loads(data)  # from the parent process only
    written = draw_run_figures(request['history'], Path(request['directory']),
                               title=request['title'], energy=request['energy'],
                               tracking=request['tracking'])
    return [str(path) for path in written]


def main() -> int:
    """The child: exit 0 with the figures' paths as JSON on stdout (nothing if not asked)."""
    try:
        written = _serve(sys.stdin.buffer)
    except Exception as err:  # noqa: BLE001 - reported to the parent, which draws itself
        print(f'{type(err).__name__}: {err}', file=sys.stderr)
        return 1
    if written is not None:
        print(json.dumps(written))
    return 0


if __name__ == '__main__':
    sys.exit(main())

"""Run OpenSees models served by the ``opensees_element`` scheme (openseespy as the client).

The server (``./pd offline`` or ``./pd run`` on a test with ``scheme: opensees_element``)
binds its port when the test starts; :func:`wait_listening` waits for that without
connecting (a probe connection would be taken for the element), from ``/proc/net/tcp``.
"""

from __future__ import annotations

import os
import socket
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from pd_actuator_bridge.opensees_site import opensees_environment

from . import journals
from .paths import REPO

EXAMPLES = REPO / 'examples' / 'opensees'
LISTEN = '0A'


def free_port() -> int:
    """A port nobody listens on now (the OS's choice)."""
    with socket.socket() as sock:
        sock.bind(('127.0.0.1', 0))
        port: int = sock.getsockname()[1]
        return port


def listening(port: int) -> bool:
    """Whether some socket listens on ``port`` (IPv4), read from ``/proc/net/tcp``."""
    for line in Path('/proc/net/tcp').read_text().splitlines()[1:]:
        fields = line.split()
        if int(fields[1].split(':')[1], 16) == port and fields[3] == LISTEN:
            return True
    return False


def wait_listening(port: int, server: subprocess.Popen[str], timeout: float = 60.0) -> None:
    """Wait until ``port`` listens; fail early if ``server`` exited."""
    deadline = time.monotonic() + timeout
    while not listening(port):
        if server.poll() is not None:
            out = server.stdout.read() if server.stdout else ''
            raise AssertionError(f'the server exited ({server.returncode}): {out}')
        if time.monotonic() > deadline:
            raise AssertionError(f'nothing listens on port {port} after {timeout} s')
        time.sleep(0.05)


def start_example(script: str, out: Path, *args: str) -> subprocess.Popen[str]:
    """Start ``examples/opensees/<script>`` with ``args`` (its output in ``out``)."""
    env = opensees_environment(dict(os.environ))
    return subprocess.Popen([sys.executable, str(EXAMPLES / script), '--out', str(out), *args],
                            env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                            text=True)


def committed_steps(run: Path) -> int:
    """Steps whose feedback is in the run's journal so far (as a crash would leave it)."""
    return journals.committed_steps(run / 'journal.pdj')


def run_example(script: str, out: Path, *args: str, timeout: float = 120.0
                ) -> np.ndarray:
    """Run ``examples/opensees/<script>`` with ``args``; return its output table."""
    env = opensees_environment(dict(os.environ))
    done = subprocess.run([sys.executable, str(EXAMPLES / script), '--out', str(out), *args],
                          check=False, timeout=timeout, env=env, capture_output=True, text=True)
    assert done.returncode == 0, f'{script}: exit {done.returncode}: {done.stderr[-2000:]}'
    table: np.ndarray = np.loadtxt(out, ndmin=2)
    return table

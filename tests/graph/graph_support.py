"""Helpers for graph tests: nodes as separate processes over DDS, isolated and cleaned up.

Every test gets its own ``ROS_DOMAIN_ID`` (passed to the children and to the test's own rclpy
context), discovery stays on this host, every started process is stopped (SIGINT to its
process group, then SIGKILL), and Fast DDS shared-memory segments left by killed processes are
removed.
"""

from __future__ import annotations

import itertools
import os
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import pytest

from support.paths import REPO as REPO  # (re-exported: the graph tests import it from here)

sys.path.insert(0, str(REPO / 'scripts'))
import clean_shm

DOMAINS = itertools.count()


def worker_index() -> int:
    worker = os.environ.get('PYTEST_XDIST_WORKER', 'gw0')
    return int(worker[2:]) if worker.startswith('gw') else 0


def install_prefix(package: str) -> Path:
    """The install prefix of ``package`` in the ament index, or fail with set-up advice."""
    for prefix in os.environ.get('AMENT_PREFIX_PATH', '').split(os.pathsep):
        if prefix and (Path(prefix) / 'share/ament_index/resource_index/packages'
                       / package).is_file():
            return Path(prefix)
    pytest.fail(f'{package} is not built/sourced: run the tests with ./pd test '
                '(it builds the workspace and sources scripts/env.sh)')
    raise AssertionError  # unreachable


def executable(package: str, name: str = 'main') -> str:
    """Path of ``lib/<package>/<name>`` (what ``ros2 run`` runs)."""
    return str(install_prefix(package) / 'lib' / package / name)


class Processes:
    """Starts processes in their own sessions and always stops them."""

    def __init__(self, env: dict[str, str], logdir: Path) -> None:
        self.env = env
        self.logdir = logdir
        self.started: list[tuple[str, subprocess.Popen[bytes]]] = []

    def start(self, name: str, command: list[str]) -> subprocess.Popen[bytes]:
        """Start ``command``; stdout/stderr go to ``<logdir>/<name>.log``."""
        log = (self.logdir / f'{name}.log').open('wb')
        process = subprocess.Popen(command, env=self.env, stdout=log, stderr=subprocess.STDOUT,
                                   start_new_session=True)
        self.started.append((name, process))
        return process

    def log(self, name: str) -> str:
        """What a process printed so far."""
        path = self.logdir / f'{name}.log'
        return path.read_text(encoding='utf-8', errors='replace') if path.exists() else ''

    @staticmethod
    def signal(process: subprocess.Popen[bytes], sig: int) -> None:
        """Send ``sig`` to the process group (ignores processes already gone)."""
        try:
            os.killpg(process.pid, sig)
        except ProcessLookupError:
            pass

    def stop_all(self) -> None:
        """SIGINT every live process group, then SIGKILL what is left."""
        for _, process in reversed(self.started):
            if process.poll() is None:
                self.signal(process, signal.SIGINT)
        deadline = time.monotonic() + 10.0
        for _, process in self.started:
            try:
                process.wait(timeout=max(0.1, deadline - time.monotonic()))
            except subprocess.TimeoutExpired:
                self.signal(process, signal.SIGKILL)
                process.wait()


def shm_segments() -> set[str]:
    shm = Path('/dev/shm')
    return {path.name for path in shm.glob('fastdds_*')} if shm.is_dir() else set()


def stale_segments(before: set[str]) -> set[str]:
    """Fast DDS segments created since ``before`` that no live process uses (left behind)."""
    new = shm_segments() - before
    return new - clean_shm.in_use() if new else set()


def remove_stale_segments(before: set[str]) -> None:
    """Remove Fast DDS segments created during the test that no live process uses."""
    for name in stale_segments(before):
        try:
            (Path('/dev/shm') / name).unlink()
        except OSError:
            pass


def drain(observer: Any, received: list[Any], *, quiet: float = 0.5,
          timeout: float = 60.0) -> None:
    """Spin the observer until ``received`` has not grown for ``quiet`` seconds: the samples a
    run sent before it exited, still queued for an observer that had too little CPU to keep
    up with it (a fixed number of spins dropped the tail on a loaded machine)."""
    deadline = time.monotonic() + timeout
    count, last_growth = len(received), time.monotonic()
    while time.monotonic() - last_growth < quiet and time.monotonic() < deadline:
        observer.executor_for_test.spin_once(timeout_sec=0.05)
        if len(received) != count:
            count, last_growth = len(received), time.monotonic()


def status_topic_of(topic: str) -> str:
    """The status topic where the receiver of control ``topic`` acknowledges."""
    if topic.endswith('/bridge/control'):
        return topic[:-len('control')] + 'status'
    return topic[:-len('test_control')] + 'test_status'


def control_sender(observer: Any, key: Any) -> Any:
    """The observer's :class:`pd_common.ros.ControlSender` for ``key`` (made once)."""
    from pd_common.ros import ControlSender

    senders = observer.__dict__.setdefault('control_senders', {})
    if id(key) not in senders:
        senders[id(key)] = ControlSender(observer, key, 'operator test (graph test)')
    return senders[id(key)]


def send_control(observer: Any, key: Any, command: str, *, topic: str = '/pd/test_control',
                 reason: str = '', timeout: float = 10.0, expect: str | None = 'ok') -> Any:
    """Send a signed control bound to its receiver (as ``./pd control`` does) and wait for its
    acknowledgement; fail unless its outcome starts with ``expect`` (``None``: any outcome).
    Returns the acknowledgement."""
    sender = control_sender(observer, key)
    status_topic = status_topic_of(topic)
    sender.watch(status_topic)
    deadline = time.monotonic() + timeout
    while not sender.ready(topic, status_topic):
        if time.monotonic() > deadline:
            pytest.fail(f'no receiver for {command} on {topic} (statuses refused: '
                        f'{dict(sender.gate.refused)})')
        observer.executor_for_test.spin_once(timeout_sec=0.05)
    sent = sender.send(command, topic, status_topic, reason)
    assert sent is not None
    while time.monotonic() < deadline:
        ack = sender.acknowledgement(sent)
        if ack is not None:
            if expect is not None and not ack.outcome.startswith(expect):
                pytest.fail(f'{command} on {topic}: {ack.outcome}')
            return ack
        if time.monotonic() - sent.sent_at > 1.0:
            sent = sender.resend(sent)
        observer.executor_for_test.spin_once(timeout_sec=0.05)
    pytest.fail(f'{command} on {topic}: not acknowledged within {timeout} s')

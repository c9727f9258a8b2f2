"""The stop flag set from signal handlers: no lock, so a storm of signals cannot hang a process."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
import time

from pd_common.signals import StopFlag, restore_handlers, stop_on_signals

# A process that waits on its flag in short slices (as the launcher's and the nodes' loops do)
# while its parent sends SIGTERM after SIGTERM. With ``threading.Event`` a handler calling
# ``set()`` while the main thread is inside ``wait()`` waits for the lock its own thread holds.
_LOOP = textwrap.dedent('''
    import signal
    from pd_common.signals import StopFlag, stop_on_signals
    flag = StopFlag()
    stop_on_signals(flag)
    print('ready', flush=True)
    while not flag.wait(0.0002):
        pass
    signal.signal(signal.SIGTERM, signal.SIG_IGN)  # (the storm goes on: not to end in it)
    print('stopped', flag.signal_number, flush=True)
''')


def _storm(process: subprocess.Popen[str], seconds: float) -> None:
    end = time.monotonic() + seconds
    while time.monotonic() < end and process.poll() is None:
        try:
            os.kill(process.pid, signal.SIGTERM)
        except ProcessLookupError:
            return


def test_a_storm_of_sigterms_stops_every_process_and_hangs_none() -> None:
    hung = []
    for _ in range(12):
        process = subprocess.Popen([sys.executable, '-c', _LOOP], stdout=subprocess.PIPE,
                                   text=True)
        assert process.stdout is not None
        assert process.stdout.readline().strip() == 'ready'
        _storm(process, 0.3)
        try:
            out, _ = process.communicate(timeout=10)
        except subprocess.TimeoutExpired:
            hung.append(process.pid)
            process.kill()
            process.communicate()
            continue
        assert process.returncode == 0, out
        assert out.split() == ['stopped', str(int(signal.SIGTERM))]
    assert hung == [], f'{len(hung)} of 12 processes hung under a SIGTERM storm'


def test_wait_returns_false_after_its_timeout_and_true_once_set() -> None:
    flag = StopFlag()
    start = time.monotonic()
    assert flag.wait(0.05) is False
    assert time.monotonic() - start >= 0.05
    assert flag.wait(0.0) is False
    flag.set()
    assert flag.is_set() and flag.wait(10.0) is True
    flag.clear()
    assert not flag.is_set() and flag.signal_number is None


def test_the_handlers_are_put_back() -> None:
    before = signal.getsignal(signal.SIGUSR1)
    flag = StopFlag()
    previous = stop_on_signals(flag, (signal.SIGUSR1,))
    try:
        os.kill(os.getpid(), signal.SIGUSR1)
        assert flag.wait(5.0)
        assert flag.signal_number == signal.SIGUSR1
    finally:
        restore_handlers(previous)
    assert signal.getsignal(signal.SIGUSR1) is before


def test_wait_without_timeout_returns_when_set_from_a_signal() -> None:
    flag = StopFlag()
    previous = stop_on_signals(flag, (signal.SIGALRM,))
    try:
        signal.setitimer(signal.ITIMER_REAL, 0.05)
        assert flag.wait() is True
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        restore_handlers(previous)

"""Supervising a test's processes: a death holds the test, a restart restores and resumes it.

``run_test`` starts every process of a test through :class:`Supervisor`. When one exits
unexpectedly, what happens is the ``--on-child-exit`` policy (default ``restart`` for a simulated
specimen, ``hold`` for a physical one):

* ``restart`` — the test is held (a signed ``hold``), the process is started again *with its
  state* (the integrator continues from its journal, ``resume_from``; a simulator replays its
  state file; a bridge reads the actuator's position back), and once it is up the launcher
  resets a bridge it held and resumes the test (signed ``restarted`` and ``resume``); each
  restart is in the run's record, its status and ``summary.json``. A process that cannot come
  back with its state (an OpenSees site), or one that died ``max_restarts`` times, is not
  restarted: the test holds.
* ``hold`` — the test holds and waits for the operator (who restarts the process, then
  ``./pd control resume``, or ``./pd control abort``).
* ``abort`` — the test is aborted (its outputs are written) and everything stops.

Children die with the launcher (``PR_SET_PDEATHSIG``): no orphan keeps a specimen side alive
with nobody supervising it. The integrator gets SIGTERM then: it interrupts the test cleanly
(resumable with ``./pd run --resume``).

Once the integrator has written its ``summary.json`` (the test is over: its last step is
committed, or it ended otherwise) the specimen side is stopped at once, while the integrator
still writes its figures, and ``on_outputs`` is called (``run_test`` prints its summary then);
:meth:`Supervisor.run` still returns only when the integrator has exited, so the run folder is
complete by then. An integrator that dies after its summary is not restarted: its test ended.
"""

from __future__ import annotations

import contextlib
import ctypes
import json
import os
import signal
import subprocess
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field

from .operator import Operator
from .plan import Child, LaunchPlan

__all__ = ['POLICIES', 'Supervisor']

POLICIES = ('restart', 'hold', 'abort')
STOP_TIMEOUT = 10.0
READY_TIMEOUT = 30.0
_PR_SET_PDEATHSIG = 1
#: Integrator exit codes of a test that ended on its own (finished; aborted, held or
#: interrupted; invalid): anything else (a signal, a crash) is a death.
_ENDED = (0, 1, 2)
_HOLDING = 3


def _die_with_parent(parent: int) -> Callable[[], None]:
    """A ``preexec_fn``: SIGTERM when the launcher dies (Linux), or exit if it already did."""
    def setup() -> None:
        try:
            libc = ctypes.CDLL('libc.so.6', use_errno=True)
            libc.prctl(_PR_SET_PDEATHSIG, signal.SIGTERM)
        except OSError:
            return
        if os.getppid() != parent:
            os._exit(1)

    return setup


@dataclass
class _Running:
    child: Child
    process: subprocess.Popen[bytes]
    started: float
    restarts: int = 0
    down: bool = False  # dead and not restarted (the test holds for it)
    spawned_at: float = 0.0  # time.time() at the start (file times are wall-clock times)


@dataclass
class _Restart:
    """A restart waiting for its process to be up again."""

    running: _Running
    since: float
    epoch: str
    code: int
    held_bridges: list[Child] = field(default_factory=list)
    reset_sent: float = 0.0


class Supervisor:
    """Starts, watches and restarts the processes of a test (see the module).

    Args:
        plan: the test's processes.
        policy: ``restart``, ``hold`` or ``abort``.
        env: the processes' environment.
        operator: the launcher's signed controls and view of the graph (``None``: no
            supervision beyond stopping everything when the integrator ends).
        spin: lets the operator's node take its messages (``spin(seconds)``).
        max_restarts: restarts of one process before the test is left holding.
        log: where progress lines go.
        on_outputs: called once the integrator has written its summary and the specimen side
            is stopped (the integrator may still be writing its figures).
    """

    def __init__(self, plan: LaunchPlan, policy: str, env: Mapping[str, str],
                 operator: Operator | None, spin: Callable[[float], None], *,
                 max_restarts: int = 3, log: Callable[[str], None] = print,
                 on_outputs: Callable[[], None] | None = None) -> None:
        self.plan = plan
        self.policy = policy
        self.env = dict(env)
        self.operator = operator
        self._spin = spin
        self.max_restarts = max_restarts
        self._log = log
        self._on_outputs = on_outputs
        self.outputs_written = False  # the integrator wrote its summary: the test is over
        self.children: list[_Running] = []
        self.integrator: _Running | None = None
        self._restart: _Restart | None = None
        self.restarts = 0
        if operator is not None:
            for child in plan.children:
                if child.namespace:
                    operator.watch_offer(child.namespace)
                if child.kind == 'bridge':
                    operator.watch_status(f'{child.namespace}/bridge/status')
            operator.watch_status('/pd/test_status')

    # -- processes --------------------------------------------------------------------------
    def _spawn(self, command: list[str]) -> subprocess.Popen[bytes]:
        return subprocess.Popen(command, start_new_session=True, env=self.env,
                                preexec_fn=_die_with_parent(os.getpid()))

    def start(self, *, resume: bool, note: str = '', confirm: bool = False) -> None:
        """Start the specimen side, then the integrator (a new run, or continuing)."""
        for child in self.plan.children:
            self.children.append(_Running(child, self._spawn(child.command), time.monotonic()))
        self._start_integrator(resume=resume, note=note, confirm=confirm)

    def _start_integrator(self, *, resume: bool, note: str = '', confirm: bool = False,
                          restarts: int = 0) -> None:
        command = self.plan.integrator_command(resume=resume, note=note, confirm=confirm)
        child = Child('pd_integrator', 'integrator', '', '/pd', command)
        spawned_at = time.time()
        self.integrator = _Running(child, self._spawn(command), time.monotonic(), restarts,
                                   spawned_at=spawned_at)

    def stop(self) -> None:
        """Stop everything: the integrator first (it writes the outputs), then the rest."""
        if self.integrator is not None:
            _stop([self.integrator], self._log)
        self.stop_children()

    def stop_children(self) -> None:
        """Stop the specimen side's processes, all at once (SIGTERM to each, then the waits)."""
        _stop(list(reversed(self.children)), self._log)

    def _summary_written(self, integrator: _Running) -> bool:
        """Whether this integrator process has written its run's ``summary.json`` (complete:
        it parses; written after the process started, so not an earlier run's)."""
        path = self.plan.out / 'summary.json'
        try:
            if path.stat().st_mtime < integrator.spawned_at:
                return False
            json.loads(path.read_text(encoding='utf-8'))
        except (OSError, ValueError):
            return False
        return True

    # -- the loop ---------------------------------------------------------------------------
    def run(self) -> int:
        """Supervise until the integrator ends; its exit code."""
        assert self.integrator is not None
        while True:
            integrator = self.integrator
            if self.outputs_written:  # only its exit is awaited now: notice it at once
                self._spin(0.0)
                with contextlib.suppress(subprocess.TimeoutExpired):
                    integrator.process.wait(timeout=0.1)
            else:
                self._spin(0.1)
            code = integrator.process.poll()
            if code is not None:
                if self.outputs_written:  # its test ended: nothing to continue
                    if code not in _ENDED:
                        self._log(f'run_test: pd_integrator died after writing its summary '
                                  f'({_describe_exit(code)}); some figures may be missing '
                                  f'(./pd replay {self.plan.out / "bag"} writes them)')
                    return int(code) if code in _ENDED else 1
                if code in _ENDED or not self._revive_integrator(integrator, code):
                    return int(code) if code in _ENDED else 1
                continue
            if self.outputs_written:
                continue
            if self._restart is None and self._summary_written(integrator):
                self.outputs_written = True
                self.stop_children()  # while the integrator writes its figures
                if self._on_outputs is not None:
                    self._on_outputs()
                continue
            for item in self.children:
                if (not item.down and item.process.poll() is not None
                        and (self._restart is None or self._restart.running is not item)
                        and self._child_died(item)):
                    return self._abort_and_wait()
            if self._restart is not None:
                self._advance_restart(self._restart)

    def _revive_integrator(self, integrator: _Running, code: int) -> bool:
        """The integrator died: continue it from its journal (policy restart)."""
        what = f'pd_integrator died ({_describe_exit(code)})'
        if self.policy != 'restart' or integrator.restarts >= self.max_restarts:
            self._log(f'run_test: {what}; the record is intact up to its last committed step: '
                      f'resume with ./pd run --resume {self.plan.out}')
            return False
        self.restarts += 1
        self._log(f'run_test: {what}; restarting it from its journal '
                  f'({integrator.restarts + 1}/{self.max_restarts})')
        self._start_integrator(resume=True, note=f'restarted by run_test: {what}',
                               restarts=integrator.restarts + 1)
        return True

    def _child_died(self, item: _Running) -> bool:
        """A specimen-side process died; ``True`` when the test must be aborted."""
        code = item.process.returncode
        what = f'{item.child.name} exited ({_describe_exit(code)})'
        if self.policy == 'abort':
            self._log(f'run_test: {what}; aborting the test (--on-child-exit abort)')
            return True
        self._send('hold', reason=what)
        if (self.policy == 'hold' or not item.child.restorable
                or item.restarts >= self.max_restarts or self.operator is None):
            item.down = True
            why = ('--on-child-exit hold' if self.policy == 'hold' else
                   'it cannot be restarted with its state' if not item.child.restorable else
                   f'restarted {item.restarts} times already' if self.operator is not None
                   else 'no supervision')
            self._log(f'run_test: {what}; the test holds ({why}). Restart it, then '
                      './pd control resume (or ./pd control abort). Its command line: '
                      + ' '.join(item.child.command))
            return False
        held = []
        if item.child.kind == 'simulator':  # hold its bridge too: a clean, known state
            for bridge in self._bridges(item.child.site):
                self._send('hold', bridge_site=bridge.site, reason=what)
                held.append(bridge)
        epoch = (self.operator.offers[item.child.namespace].epoch
                 if item.child.namespace in self.operator.offers else '')
        self._log(f'run_test: {what}; the test holds; restarting it with its state '
                  f'({item.restarts + 1}/{self.max_restarts})')
        item.process = self._spawn(item.child.command)
        item.restarts += 1
        item.started = time.monotonic()
        self.restarts += 1
        self._restart = _Restart(item, time.monotonic(), epoch, code, held)
        return False

    def _bridges(self, site: str) -> list[Child]:
        return [child for child in self.plan.children
                if child.kind == 'bridge' and child.site == site]

    def _advance_restart(self, restart: _Restart) -> None:
        """Once the restarted process is up: reset the bridges held, resume the test."""
        operator = self.operator
        assert operator is not None
        item = restart.running
        now = time.monotonic()
        if item.process.poll() is not None:
            self._restart = None  # it died again: the loop takes it as a new death
            return
        if now - restart.since > READY_TIMEOUT:
            self._restart = None
            item.down = True
            self._log(f'run_test: {item.child.name} did not come back within {READY_TIMEOUT} '
                      's; the test holds (./pd control resume once it is up, or abort)')
            return
        if not self._is_up(item.child, restart):
            return
        for bridge in restart.held_bridges:
            topic = f'{bridge.namespace}/bridge/status'
            if operator.status_state(topic) == _HOLDING:
                if now - restart.reset_sent > 2.0:
                    if 'EMERGENCY' in operator.status_message(topic):
                        self._restart = None
                        self._log(f'run_test: {bridge.name} holds an emergency stop; the test '
                                  'holds (clear it, then ./pd control resume)')
                        return
                    self._send('reset', bridge_site=bridge.site, reason='restart')
                    restart.reset_sent = now
                return
        what = (f'{item.child.name} (it exited: {_describe_exit(restart.code)}) '
                'restarted with its state')
        self._send('restarted', reason=what)
        self._send('resume', reason=f'{item.child.name} restarted')
        self._log(f'run_test: {item.child.name} is back; resuming the test')
        self._restart = None

    def _is_up(self, child: Child, restart: _Restart) -> bool:
        """Whether a restarted receiver offers itself again (and, behind a bridge, the
        bridge re-opened its session with it)."""
        assert self.operator is not None
        offer = self.operator.offers.get(child.namespace)
        if offer is None or offer.at < restart.since:
            return False
        if child.kind == 'simulator':
            if restart.epoch and offer.epoch == restart.epoch:
                return False
            if self._bridges(child.site) and offer.authenticated:
                return bool(offer.active_session)  # the bridge drives it again
            return True
        return bool(offer.challenge) or not offer.authenticated

    def _send(self, command: str, *, bridge_site: str | None = None, reason: str = '') -> None:
        if self.operator is None:
            return
        if not self.operator.send(command, bridge_site=bridge_site, reason=reason):
            target = f'bridge {bridge_site or "default"}' if bridge_site is not None else \
                'the integrator'
            self._log(f'run_test: could not send {command} to {target} (not listening)')
        self._spin(0.05)

    def _abort_and_wait(self) -> int:
        self._send('abort', reason='a process of the test died (--on-child-exit abort)')
        assert self.integrator is not None
        deadline = time.monotonic() + STOP_TIMEOUT
        while self.integrator.process.poll() is None and time.monotonic() < deadline:
            self._spin(0.1)
        return 1


def _describe_exit(code: int) -> str:
    if code < 0:
        try:
            return f'signal {signal.Signals(-code).name}'
        except ValueError:
            return f'signal {-code}'
    return f'code {code}'


def _stop(items: list[_Running], log: Callable[[str], None]) -> None:
    """SIGTERM to each process group (a clean stop for every node), in order and without
    waiting in between; then each is waited for (``STOP_TIMEOUT`` in all) and killed if it is
    still there."""
    signalled = []
    for item in items:
        if item.process.poll() is not None:
            continue
        try:
            os.killpg(item.process.pid, signal.SIGTERM)
        except ProcessLookupError:
            continue
        signalled.append(item)
    deadline = time.monotonic() + STOP_TIMEOUT
    for item in signalled:
        try:
            item.process.wait(timeout=max(0.0, deadline - time.monotonic()))
        except subprocess.TimeoutExpired:
            log(f'run_test: {item.child.name} did not stop on SIGTERM; killing it')
            try:
                os.killpg(item.process.pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
            item.process.wait()

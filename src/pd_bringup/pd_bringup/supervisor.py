"""Supervising a test's processes: a death holds the test, a restart restores and resumes it.

``run_test`` starts every process of a test through :class:`Supervisor`. When one exits
unexpectedly, what happens is the ``--on-child-exit`` policy (default ``restart`` for a simulated
specimen, ``hold`` for a physical one):

* ``restart`` — the test is held (a signed ``auto_hold``), the process is started again *with
  its state* (the integrator continues from its journal, ``resume_from``; a simulator replays
  its state file; a bridge reads the actuator's position back and its record's latched holds),
  and once it is up the launcher leaves the hold it made at a bridge (``auto_reset``) and
  continues the test (signed ``restarted`` and ``auto_resume``); each restart is in the run's
  record, its status and ``summary.json``. A process that cannot come back with its state (an
  OpenSees site), or one that died ``max_restarts`` times, is not restarted: the test holds.
* ``hold`` (a physical specimen) — the test holds and waits for the operator (who restarts
  the process, then ``./pd control resume``, or ``./pd control abort``). A dead integrator is
  restarted from its journal *held*: nothing moves before a person's signed ``resume``; every
  bridge stays up, holding its actuator.
* ``abort`` — the test is aborted (its outputs are written) and everything stops.

The supervisor never undoes a person's stop: a bridge or an integrator refuses ``auto_reset``
and ``auto_resume`` while an emergency stop or a person's pause or hold is latched (durable in
their records, so a restart does not clear it either), and the supervisor does not even send
them then: it says who holds the test and waits.

Every node says it is alive at least once a second (its signed status or session offer); a
process that is alive but silent for ``hung_timeout`` s has stopped answering: it is reported,
the test held, and under ``restart`` the process is killed and restarted with its state.

Children die with the launcher (``PR_SET_PDEATHSIG``), except, under ``hold``, the specimen
side: a bridge holding a physical actuator outlives its launcher (and ``./pd run --resume``
adopts it rather than starting a second one); it stops only on an explicit shutdown. The
integrator gets SIGTERM then: it interrupts the test cleanly (resumable with
``./pd run --resume``).

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
from pathlib import Path
from typing import Any, Protocol

from pd_common.config.files import read_text
from pd_core.errors import PdIntegratorError
from pd_core.run.resume import load_resumable

from .operator import Operator, control_topics
from .plan import RESTART_NOTE, Child, LaunchPlan

__all__ = ['HUNG_TIMEOUT', 'POLICIES', 'PROCESSES_FILE', 'Supervisor', 'recorded_processes']

POLICIES = ('restart', 'hold', 'abort')
STOP_TIMEOUT = 10.0
READY_TIMEOUT = 30.0
#: Seconds a live node may stay silent (no status, no offer) before it is reported as hung.
HUNG_TIMEOUT = 10.0
#: The run folder's record of the processes run_test started (what ``--resume`` adopts).
PROCESSES_FILE = 'processes.json'
_PR_SET_PDEATHSIG = 1
#: Integrator exit codes of a test that ended on its own (finished; aborted, held or
#: interrupted; invalid): anything else (a signal, a crash) is a death.
_ENDED = (0, 1, 2)
_HOLDING = 3
#: States after which an integrator says nothing more (finished, aborted, interrupted).
_FINAL_STATES = (4, 5, 6)


class _Process(Protocol):
    """What the supervisor needs of a process: a child's ``Popen``, or an adopted one."""

    pid: int
    returncode: int | None

    def poll(self) -> int | None: ...

    def wait(self, timeout: float | None = None) -> int: ...


def _start_ticks(pid: int) -> int | None:
    """The start time of process ``pid`` in clock ticks since boot (``None``: no such process).

    With the pid, it names one process (pids are reused, start times are not).
    """
    try:
        text = Path(f'/proc/{pid}/stat').read_text(encoding='ascii', errors='replace')
    except OSError:
        return None
    fields = text[text.rfind(')') + 2:].split()
    if not fields or fields[0] in ('Z', 'X'):  # a zombie has ended (its parent did not reap)
        return None
    try:
        return int(fields[19])
    except (IndexError, ValueError):
        return None


class _Adopted:
    """A process a previous launcher started and left running.

    A bridge holding its actuator under ``hold``: watched by its pid and start time, stopped by
    signals.
    """

    def __init__(self, pid: int, ticks: int) -> None:
        self.pid = pid
        self._ticks = ticks
        self.returncode: int | None = None

    def poll(self) -> int | None:
        if self.returncode is None and _start_ticks(self.pid) != self._ticks:
            self.returncode = -1  # gone (its parent, not this launcher, reaped it)
        return self.returncode

    def wait(self, timeout: float | None = None) -> int:
        deadline = None if timeout is None else time.monotonic() + timeout
        while self.poll() is None:
            if deadline is not None and time.monotonic() > deadline:
                raise subprocess.TimeoutExpired(str(self.pid), timeout or 0.0)
            time.sleep(0.05)
        assert self.returncode is not None
        return self.returncode


def recorded_processes(run_dir: Path) -> dict[str, Any]:
    """The run folder's ``processes.json`` (``{}`` if there is none, or it is unreadable).

    ``policy`` (the child-exit policy) and ``processes`` (name: pid, start ticks, command).
    """
    try:  # (a regular file of bounded size only: a FIFO there must not hang a resume)
        data = json.loads(read_text(run_dir / PROCESSES_FILE, limit=1 << 20))
    except (OSError, ValueError, RecursionError):
        return {}
    return data if isinstance(data, dict) else {}


def _child_setup(parent: int | None, cpus: list[int] | None) -> Callable[[], None] | None:
    """A ``preexec_fn``: the child on ``cpus``, and it ends with the launcher ``parent``.

    On ``cpus`` if given: set before the node starts, so every thread it makes runs on them.
    Unless ``parent`` is ``None``: SIGTERM when the launcher dies (Linux), or exit if it
    already did. ``None`` when there is nothing to do.
    """
    if parent is None and not cpus:
        return None

    def setup() -> None:
        if cpus:
            os.sched_setaffinity(0, cpus)
        if parent is None:
            return
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
    process: _Process
    started: float
    restarts: int = 0
    down: bool = False  # dead and not restarted (the test holds for it)
    spawned_at: float = 0.0  # time.time() at the start (file times are wall-clock times)
    hung: bool = False  # reported as not answering (once)


@dataclass
class _Restart:
    """A restart waiting for its process to be up again."""

    running: _Running
    since: float
    epoch: str
    code: int
    held_bridges: list[Child] = field(default_factory=list)
    reset_sent: float = 0.0
    #: The control topics of held bridges whose auto_hold went unanswered: sent again before
    #: their reset (a bridge that holds for a timeout of its own takes the supervisor's hold
    #: over only when it gets it).
    holds_lost: set[str] = field(default_factory=set)


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
                 on_outputs: Callable[[], None] | None = None,
                 hung_timeout: float = HUNG_TIMEOUT) -> None:
        self.plan = plan
        self.policy = policy
        self.hung_timeout = hung_timeout
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
    def _spawn(self, command: list[str], kind: str, *, outlive: bool = False
               ) -> subprocess.Popen[bytes]:
        """Start ``command`` (a process of ``kind``) in a session of its own.

        On the CPUs the plan gives its kind, if any. It dies with the launcher unless
        ``outlive`` (the specimen side under ``hold``).
        """
        setup = _child_setup(None if outlive else os.getpid(), self.plan.cpus.get(kind))
        return subprocess.Popen(command, start_new_session=True, env=self.env,
                                preexec_fn=setup)

    @property
    def _outlive(self) -> bool:
        """Whether the specimen side outlives the launcher (``hold``: a physical rig)."""
        return self.policy == 'hold'

    def start(self, *, resume: bool, note: str = '', confirm: bool = False) -> None:
        """Start the specimen side (adopting what a previous launcher left running).

        Then the integrator (a new run, or continuing).
        """
        adopted = self._adoptable() if resume else {}
        for child in self.plan.children:
            process = adopted.get(child.name)
            if process is not None:
                self._log(f'run_test: {child.name} is still running (pid {process.pid}): '
                          'adopted, not started again')
            self.children.append(_Running(
                child, process or self._spawn(child.command, child.kind,
                                              outlive=self._outlive),
                time.monotonic()))
        self._save_processes()
        self._start_integrator(resume=resume, note=note, confirm=confirm)

    def _adoptable(self) -> dict[str, _Process]:
        """The specimen-side processes a previous launcher left running.

        By the run folder's ``processes.json``: same pid, start time and command line.
        """
        recorded = recorded_processes(self.plan.out).get('processes')
        found: dict[str, _Process] = {}
        commands = {child.name: child.command for child in self.plan.children}
        for name, entry in recorded.items() if isinstance(recorded, dict) else ():
            try:
                pid, ticks, command = int(entry['pid']), int(entry['ticks']), entry['command']
            except (KeyError, TypeError, ValueError):
                continue
            if commands.get(name) == command and _start_ticks(pid) == ticks:
                found[name] = _Adopted(pid, ticks)
        return found

    def _save_processes(self) -> None:
        """Record the specimen side's processes in the run folder (for ``--resume``)."""
        entries: dict[str, Any] = {}
        for item in self.children:
            ticks = _start_ticks(item.process.pid)
            if ticks is not None:
                entries[item.child.name] = {'pid': item.process.pid, 'ticks': ticks,
                                            'command': item.child.command}
        data = {'policy': self.policy, 'processes': entries}
        with contextlib.suppress(OSError):
            (self.plan.out / PROCESSES_FILE).write_text(json.dumps(data, indent=1) + '\n',
                                                        encoding='utf-8')

    def _start_integrator(self, *, resume: bool, note: str = '', confirm: bool = False,
                          restarts: int = 0, held: bool = False) -> None:
        command = self.plan.integrator_command(resume=resume, note=note, confirm=confirm,
                                               held=held)
        child = Child('pd_integrator', 'integrator', '', '/pd', command)
        spawned_at = time.time()
        self.integrator = _Running(child, self._spawn(command, 'integrator'), time.monotonic(),
                                   restarts,
                                   spawned_at=spawned_at)

    def stop(self) -> None:
        """Stop everything: the integrator first (it writes the outputs).

        Then the rest (the explicit shutdown: the bridges go last).
        """
        if self.integrator is not None:
            _stop([self.integrator], self._log)
        self.stop_children()

    def stop_children(self) -> None:
        """Stop the specimen side's processes.

        The bridges last (SIGTERM to each group, then the waits): a bridge holds its actuator until
        the very end.
        """
        ordered = list(reversed(self.children))
        _stop([item for item in ordered if item.child.kind != 'bridge'], self._log)
        _stop([item for item in ordered if item.child.kind == 'bridge'], self._log)

    def _summary_written(self, integrator: _Running) -> bool:
        """Whether this integrator process has written its run's ``summary.json``.

        Complete: it parses; written after the process started, so not an earlier run's.
        """
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
                if code in _ENDED:
                    return int(code)
                if not self._revive_integrator(integrator, code):
                    if self._outlive:  # a physical rig: the bridges hold until told to stop
                        self._hold_until_shutdown()
                    return 1
                continue
            if self.outputs_written:
                continue
            if self._restart is None and self._summary_written(integrator):
                self.outputs_written = True
                self.stop_children()  # while the integrator writes its figures
                if self._on_outputs is not None:
                    self._on_outputs()
                continue
            self._check_controls()
            self._check_hung()
            for item in self.children:
                if (not item.down and item.process.poll() is not None
                        and (self._restart is None or self._restart.running is not item)
                        and self._child_died(item)):
                    return self._abort_and_wait()
            if self._restart is not None:
                self._advance_restart(self._restart)

    def _hold_until_shutdown(self) -> None:
        """Keep the specimen side up (every bridge holding) until run_test is told to stop."""
        self._log('run_test: every bridge holds its actuator and stays up; stop run_test '
                  '(Ctrl-C, or SIGTERM) to shut them down, or resume it later with '
                  './pd run --resume')
        while True:
            self._spin(0.5)

    def _revive_integrator(self, integrator: _Running, code: int) -> bool:
        """The integrator died: continue it from its journal (``restart``).

        Or restore it held (``hold``: nothing moves before a person's resume).
        """
        what = f'pd_integrator died ({_describe_exit(code)})'
        try:  # a run that cannot resume (a served OpenSees model) is not restarted
            load_resumable(self.plan.out)
        except PdIntegratorError as err:
            self._log(f'run_test: {what}; not restarted: {err}')
            return False
        if self.policy == 'abort' or integrator.restarts >= self.max_restarts:
            self._log(f'run_test: {what}; the record is intact up to its last committed step: '
                      f'resume with ./pd run --resume {self.plan.out}')
            return False
        self.restarts += 1
        held = self.policy == 'hold'
        self._log(f'run_test: {what}; restarting it from its journal '
                  f'({integrator.restarts + 1}/{self.max_restarts})'
                  + ('; it holds until ./pd control resume (--on-child-exit hold)'
                     if held else ''))
        self._start_integrator(resume=True, note=f'{RESTART_NOTE}: {what}',
                               restarts=integrator.restarts + 1, held=held)
        return True

    def _child_died(self, item: _Running) -> bool:
        """A specimen-side process died; ``True`` when the test must be aborted."""
        code = item.process.returncode
        what = f'{item.child.name} exited ({_describe_exit(code) if code is not None else "?"})'
        if self.policy == 'abort':
            self._log(f'run_test: {what}; aborting the test (--on-child-exit abort)')
            return True
        self._send('auto_hold', reason=what)
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
                self._send('auto_hold', bridge_site=bridge.site, reason=what)
                held.append(bridge)
        epoch = (self.operator.offers[item.child.namespace].epoch
                 if item.child.namespace in self.operator.offers else '')
        self._log(f'run_test: {what}; the test holds; restarting it with its state '
                  f'({item.restarts + 1}/{self.max_restarts})')
        item.process = self._spawn(item.child.command, item.child.kind, outlive=self._outlive)
        item.restarts += 1
        item.started = time.monotonic()
        item.hung = False
        self.restarts += 1
        self._save_processes()
        self._restart = _Restart(item, time.monotonic(), epoch,
                                 code if code is not None else -1, held)
        return False

    def _bridges(self, site: str) -> list[Child]:
        return [child for child in self.plan.children
                if child.kind == 'bridge' and child.site == site]

    def _person_holds(self, topic: str) -> str:
        """Who holds the node of status ``topic``, if a person does ('' if not)."""
        assert self.operator is not None
        status = self.operator.statuses.get(topic)
        if status is None:
            return ''
        if status.emergency_stop:
            return f'an emergency stop is latched ({status.message})'
        if status.operator_hold:
            return f'a person holds it ({status.message})'
        return ''

    def _advance_restart(self, restart: _Restart) -> None:
        """Leave the holds of a restarted process once it is up and continue the test.

        Once the restarted process is up: leave the holds it made at the bridges, and
        continue the test, unless a person holds it.
        """
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
        if not self._is_up(item.child, restart) or self._holds_unanswered():
            return
        for bridge in restart.held_bridges:
            topic = f'{bridge.namespace}/bridge/status'
            if operator.status_state(topic) == _HOLDING:
                control_topic = control_topics(bridge.site)[0]
                if control_topic in restart.holds_lost:  # first the hold it never answered
                    restart.holds_lost.discard(control_topic)
                    self._send('auto_hold', bridge_site=bridge.site,
                               reason=f'{item.child.name} restarted')
                    return
                held_by = self._person_holds(topic)
                if held_by:
                    self._end_restart_held(restart, f'{bridge.name} is back, but {held_by}')
                    return
                if now - restart.reset_sent > 2.0:
                    self._send('auto_reset', bridge_site=bridge.site, reason='restart')
                    restart.reset_sent = now
                return
        what = (f'{item.child.name} (it exited: {_describe_exit(restart.code)}) '
                'restarted with its state')
        self._send('restarted', reason=what)
        self._restart = None
        held_by = self._person_holds('/pd/test_status')
        if held_by:
            self._log(f'run_test: {item.child.name} is back; the test stays held: {held_by} '
                      '(./pd control resume goes on)')
            return
        self._send('auto_resume', reason=f'{item.child.name} restarted')
        self._log(f'run_test: {item.child.name} is back; resuming the test')

    def _end_restart_held(self, restart: _Restart, why: str) -> None:
        """The restarted process is back, but a hold only a person leaves stands.

        The restart is recorded (``restarted``: a run event, the integrator's sessions
        re-opened), the test left held for a person.
        """
        self._restart = None
        self._send('restarted', reason=f'{restart.running.child.name} (it exited: '
                   f'{_describe_exit(restart.code)}) restarted with its state')
        self._log(f'run_test: {why}: the test holds (a person resets it: ./pd control reset '
                  '--bridge, then ./pd control resume)')

    def _holds_unanswered(self) -> bool:
        """Whether a hold the supervisor sent is not acknowledged yet.

        It is sent again, bound anew, until it is (or given up): left unanswered, a hold
        refused once (bound to a test its receiver's status had not named yet) could land
        after the test was resumed, and hold it with no one to leave the hold.
        """
        assert self.operator is not None
        return any(sent.control.command == 'auto_hold' for sent in self.operator.pending)

    def _is_up(self, child: Child, restart: _Restart) -> bool:
        """Whether a restarted receiver offers itself again.

        Behind a bridge, also whether the bridge re-opened its session with it.
        """
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
        if child.kind == 'bridge':  # its status (and so its session) is known again
            status = self.operator.statuses.get(f'{child.namespace}/bridge/status')
            if status is None or self.operator.controls.heard.get(
                    f'{child.namespace}/bridge/status', 0.0) < restart.since:
                return False
        return bool(offer.challenge) or not offer.authenticated

    # -- controls and liveness --------------------------------------------------------------
    def _send(self, command: str, *, bridge_site: str | None = None, reason: str = '') -> None:
        if self.operator is None:
            return
        if self.operator.send(command, bridge_site=bridge_site, reason=reason) is None:
            target = f'bridge {bridge_site or "default"}' if bridge_site is not None else \
                'the integrator'
            self._log(f'run_test: could not send {command} to {target} (not listening, or its '
                      'status is not known)')
        self._spin(0.05)

    def _check_controls(self) -> None:
        """Report controls a receiver refused, or never acknowledged."""
        if self.operator is None:
            return
        for sent, ack in self.operator.check():
            command = sent.control.command
            if ack is None:
                self._log(f'run_test: {command} was not acknowledged by {sent.control.target} '
                          f'after {sent.attempts} sends')
                if command == 'auto_hold' and self._restart is not None:
                    self._restart.holds_lost.add(sent.topic)
            elif not ack.ok:
                self._log(f'run_test: {sent.control.target} did not take {command}: '
                          f'{ack.outcome}')
                if command == 'auto_reset' and self._restart is not None:
                    # A hold that is not the supervisor's to leave: waiting changes nothing.
                    self._end_restart_held(self._restart, (
                        f'{self._restart.running.child.name} is back, but '
                        f'{sent.control.target} holds for a reason of its own'))

    def _statement_topic(self, item: _Running) -> tuple[str, str] | None:
        """Where a process says it is alive: ``('status'|'offer', topic or namespace)``."""
        kind = item.child.kind
        if kind == 'integrator':
            return 'status', '/pd/test_status'
        if kind == 'bridge':
            return 'status', f'{item.child.namespace}/bridge/status'
        if kind == 'simulator':
            return 'offer', item.child.namespace
        return None

    def _check_hung(self) -> None:
        """A live process that has said nothing for ``hung_timeout`` s stopped answering.

        Report it (once), hold the test, and under ``restart`` kill it (it is then restarted with
        its state like any process that died).
        """
        if self.operator is None or self.hung_timeout <= 0.0:
            return
        now = time.monotonic()
        items = [item for item in (self.integrator, *self.children) if item is not None]
        for item in items:
            where = self._statement_topic(item)
            if where is None or item.hung or item.down or item.process.poll() is not None:
                continue
            if where[0] == 'status':
                heard = self.operator.controls.heard.get(where[1])
                status = self.operator.statuses.get(where[1])
                if item.child.kind == 'integrator' and status is not None and int(
                        status.state) in _FINAL_STATES:
                    continue  # writing its outputs: it says nothing more
            else:
                offer = self.operator.offers.get(where[1])
                heard = offer.at if offer is not None else None
            if heard is None or heard < item.started or now - heard < self.hung_timeout:
                continue
            item.hung = True
            self._log(f'run_test: {item.child.name} stopped answering: nothing from it for '
                      f'{now - heard:.0f} s (pid {item.process.pid}, alive); the test holds')
            if item.child.kind != 'integrator':
                self._send('auto_hold', reason=f'{item.child.name} stopped answering')
            if self.policy == 'restart':
                self._log(f'run_test: killing {item.child.name} to restart it with its state')
                with contextlib.suppress(ProcessLookupError):
                    os.killpg(item.process.pid, signal.SIGKILL)

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
    """SIGTERM to each process group (a clean stop for every node).

    In order and without waiting in between; then each is waited for (``STOP_TIMEOUT`` in all) and
    killed if it is still there.
    """
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

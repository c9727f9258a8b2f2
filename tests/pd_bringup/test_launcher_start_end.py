"""run_test's start and end: the specimen side
stopped (and the summary printed) once the integrator has written its summary, while it still
writes its figures."""

from __future__ import annotations

import contextlib
import json
import subprocess
import sys
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from types import SimpleNamespace
from typing import Any

from pd_bringup.plan import Child, LaunchPlan
from pd_bringup.supervisor import Supervisor, _Restart, _Running


def _python(code: str) -> list[str]:
    return [sys.executable, '-c', code]


def _plan(tmp_path: Path, integrator: str) -> LaunchPlan:
    children = [Child(name, 'simulator', '', '', _python('import time; time.sleep(60)'))
                for name in ('specimen', 'bridge')]
    return LaunchPlan(test_id='t', n_steps=1, out=tmp_path, site_mode='bridge', physical=False,
                      key_file=None, environment={}, children=children,
                      integrator=_python(integrator))


def test_the_specimen_side_stops_once_the_summary_is_written(tmp_path: Path) -> None:
    # An "integrator" that writes its summary, then takes 1.5 s for its figures.
    integrator = ('import json, pathlib, time; time.sleep(0.3); '
                  f'pathlib.Path({str(tmp_path)!r}, "summary.json").write_text(json.dumps('
                  '{"steps": 1})); time.sleep(1.5); '
                  f'pathlib.Path({str(tmp_path)!r}, "figure.png").write_text("x")')
    (tmp_path / 'summary.json').write_text(json.dumps({'steps': 0}))  # an earlier run's
    time.sleep(0.05)
    seen: list[tuple[bool, list[int | None], bool]] = []

    def on_outputs() -> None:
        assert supervisor.integrator is not None
        seen.append((supervisor.integrator.process.poll() is None,
                     [item.process.poll() for item in supervisor.children],
                     (tmp_path / 'figure.png').exists()))

    supervisor = Supervisor(_plan(tmp_path, integrator), 'restart', {}, None, time.sleep,
                            log=lambda line: None, on_outputs=on_outputs)
    supervisor.start(resume=False)
    try:
        code = supervisor.run()
    finally:
        supervisor.stop()
    assert code == 0
    # Called once, with the integrator still at its figures and the specimen side stopped.
    assert len(seen) == 1
    integrator_alive, children_codes, figure_written = seen[0]
    assert integrator_alive and not figure_written
    assert all(code is not None for code in children_codes)
    assert (tmp_path / 'figure.png').exists()  # run() returned after the integrator ended


def _sent(command: str) -> Any:
    """A control the operator waits on (only its command is read)."""
    return SimpleNamespace(control=SimpleNamespace(command=command))


class _Operator:
    """The supervisor's view of the graph, set by hand: a restarted simulator is up again."""

    def __init__(self) -> None:
        self.sent: list[tuple[str, str | None]] = []
        self.pending: list[Any] = []
        self.offers: dict[str, Any] = {}
        self.statuses: dict[str, Any] = {}
        self.states: dict[str, int] = {}

    def watch_offer(self, namespace: str) -> None:
        pass

    def watch_status(self, topic: str) -> None:
        pass

    def send(self, command: str, *, bridge_site: str | None = None, reason: str = '') -> Any:
        self.sent.append((command, bridge_site))
        sent = _sent(command)
        self.pending.append(sent)
        return sent

    def status_state(self, topic: str) -> int | None:
        return self.states.get(topic)


@contextlib.contextmanager
def _restarting(tmp_path: Path, log: Callable[[str], None] = lambda line: None
                ) -> Iterator[tuple[Supervisor, _Operator, _Restart]]:
    """A supervisor restarting a simulator (a live stand-in process) behind one bridge, its
    view of the graph set by hand (the simulator offers itself again), and the restart."""
    simulator = Child('pd_specimen_sim', 'simulator', '', '/pd/specimen', ['true'])
    bridge = Child('pd_actuator_bridge', 'bridge', '', '', ['true'])
    plan = LaunchPlan(test_id='t', n_steps=1, out=tmp_path, site_mode='bridge', physical=False,
                      key_file=None, environment={}, children=[simulator, bridge],
                      integrator=['true'])
    operator = _Operator()
    supervisor = Supervisor(plan, 'restart', {}, operator, lambda seconds: None,  # type: ignore[arg-type]
                            log=log)
    process = subprocess.Popen(_python('import time; time.sleep(30)'))
    try:
        restart = _Restart(_Running(simulator, process, time.monotonic()), time.monotonic(),
                           'old-epoch', -9, [bridge])
        operator.offers['/pd/specimen'] = SimpleNamespace(
            at=time.monotonic() + 1, epoch='new-epoch', challenge='c', active_session='s',
            authenticated=True)
        supervisor._restart = restart
        yield supervisor, operator, restart
    finally:
        process.kill()
        process.wait()


def test_a_restart_never_resumes_before_its_holds_are_answered(tmp_path: Path) -> None:
    """A hold a bridge has not acknowledged (refused once: bound to a test its status had not
    named yet) is sent again until it is; resuming before that would let it land afterwards
    and hold the test with no one to leave the hold."""
    with _restarting(tmp_path) as (supervisor, operator, restart):
        operator.pending.append(_sent('auto_hold'))  # the bridge's, unanswered
        supervisor._advance_restart(restart)
        assert operator.sent == [] and supervisor._restart is restart  # it waits
        operator.pending.clear()  # acknowledged: the bridge holds
        operator.states['/bridge/status'] = 3
        supervisor._advance_restart(restart)
        assert operator.sent == [('auto_reset', '')]
        operator.pending.clear()
        operator.states['/bridge/status'] = 2  # it left the hold
        supervisor._advance_restart(restart)
        assert [command for command, _ in operator.sent] == ['auto_reset', 'restarted',
                                                              'auto_resume']
        assert supervisor._restart is None


def test_a_refused_automatic_reset_ends_the_restart_with_who_must_act(tmp_path: Path) -> None:
    """The bridge refuses the supervisor's auto_reset (it holds for a reason of its own, a
    person's to clear): run_test says so at once and leaves the test held, instead of sending
    it again for 30 s and then calling the restarted process lost."""
    lines: list[str] = []
    with _restarting(tmp_path, lines.append) as (supervisor, operator, restart):
        operator.states['/bridge/status'] = 3  # holding
        supervisor._advance_restart(restart)
        assert operator.sent == [('auto_reset', '')]
        refused = SimpleNamespace(control=SimpleNamespace(
            command='auto_reset', target='/pd/pd_actuator_bridge'))
        outcome = ('refused: the bridge holds for another reason (max_increment); a person '
                   'resets it')
        operator.check = lambda: [(refused, SimpleNamespace(ok=False, outcome=outcome))]
        supervisor._check_controls()
        assert supervisor._restart is None
        assert lines[-1] == ('run_test: pd_specimen_sim is back, but /pd/pd_actuator_bridge '
                             'holds for a reason of its own: the test holds (a person resets '
                             'it: ./pd control reset --bridge, then ./pd control resume)')
        # The restart is on record (the integrator's event), the test not resumed.
        assert operator.sent == [('auto_reset', ''), ('restarted', None)]


def test_a_bridges_hold_that_went_unanswered_is_sent_again_before_its_reset(
        tmp_path: Path) -> None:
    """The supervisor's hold of a bridge was given up (unanswered after its sends): the bridge
    may hold for its own driver timeout, which it leaves to the supervisor only once it has
    the supervisor's hold. So the hold is sent again, and answered, before the reset."""
    with _restarting(tmp_path) as (supervisor, operator, restart):
        lost = SimpleNamespace(topic='/pd/bridge/control', attempts=5, control=SimpleNamespace(
            command='auto_hold', target='/pd/pd_actuator_bridge'))
        operator.check = lambda: [(lost, None)]  # given up
        supervisor._check_controls()
        operator.states['/bridge/status'] = 3  # holding (its own driver timeout)
        supervisor._advance_restart(restart)
        assert operator.sent == [('auto_hold', '')]  # the hold again, not the reset
        supervisor._advance_restart(restart)
        assert operator.sent == [('auto_hold', '')]  # it waits for the answer
        operator.pending.clear()  # answered
        supervisor._advance_restart(restart)
        assert operator.sent == [('auto_hold', ''), ('auto_reset', '')]

"""``spin_until_shutdown``: a node's loop of ``spin_once`` calls and its periodic check.

The check (``between``) runs after a ``spin_once`` at most every ``every`` seconds, never once
the context is down; a failure while shutting down ends the loop quietly, one while the context
is up is raised. A fake executor and clock: nothing of ROS runs.
"""

from __future__ import annotations

import pytest

from pd_common.ros import executor as executor_module
from pd_common.ros import spin_until_shutdown


class FakeContext:
    def __init__(self) -> None:
        self.up = True

    def ok(self) -> bool:
        return self.up


class FakeExecutor:
    """Each ``spin_once`` handles one message ``step`` seconds after the last; the context goes
    down during spin number ``spins``."""

    def __init__(self, spins: int, step: float, clock: list[float]) -> None:
        self.context = FakeContext()
        self.spins, self.step, self.clock = spins, step, clock
        self.count = 0

    def spin_once(self, timeout_sec: float) -> None:
        assert timeout_sec == 0.05
        self.count += 1
        self.clock[0] += self.step
        if self.count == self.spins:
            self.context.up = False


@pytest.fixture
def clock(monkeypatch: pytest.MonkeyPatch) -> list[float]:
    now = [100.0]
    monkeypatch.setattr(executor_module, 'monotonic', lambda: now[0])
    return now


def test_the_check_runs_after_every_spin_by_default(clock: list[float]) -> None:
    executor = FakeExecutor(spins=50, step=0.001, clock=clock)
    calls: list[float] = []
    spin_until_shutdown(executor, 0.05, lambda: calls.append(clock[0]))  # type: ignore[arg-type]
    assert executor.count == 50
    assert len(calls) == 49  # not after the spin during which the context went down


def test_the_check_runs_at_most_every_interval(clock: list[float]) -> None:
    """A message every millisecond for a second: the check every 10 ms (the first at once)."""
    executor = FakeExecutor(spins=1000, step=0.001, clock=clock)
    calls: list[float] = []
    spin_until_shutdown(executor, 0.05, lambda: calls.append(clock[0]),  # type: ignore[arg-type]
                        every=0.01)
    assert calls[0] == pytest.approx(100.001)
    gaps = [later - earlier for earlier, later in zip(calls, calls[1:], strict=False)]
    assert all(gap == pytest.approx(0.01) for gap in gaps), gaps[:5]
    assert len(calls) == 100


def test_an_idle_node_checks_after_each_timeout(clock: list[float]) -> None:
    """No message: each spin_once returns after its timeout, longer than the interval."""
    executor = FakeExecutor(spins=20, step=0.05, clock=clock)
    calls: list[float] = []
    spin_until_shutdown(executor, 0.05, lambda: calls.append(clock[0]),  # type: ignore[arg-type]
                        every=0.01)
    assert len(calls) == 19


def test_a_failure_is_raised_while_up_and_quiet_at_shutdown(clock: list[float]) -> None:
    executor = FakeExecutor(spins=1000, step=0.001, clock=clock)

    def failing() -> None:
        raise RuntimeError('a check that fails')

    with pytest.raises(RuntimeError, match='a check that fails'):
        spin_until_shutdown(executor, 0.05, failing)  # type: ignore[arg-type]

    def shut_down_then_fail() -> None:  # (a publish after a signal shut the context down)
        executor.context.up = False
        raise RuntimeError("publisher's context is invalid")

    executor.context.up = True
    spin_until_shutdown(executor, 0.05, shut_down_then_fail)  # type: ignore[arg-type]
    assert not executor.context.ok()

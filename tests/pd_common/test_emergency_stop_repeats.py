"""The lab-wide emergency stop is sent so that a listener matched late still gets it."""

from __future__ import annotations

import threading

import pytest

from pd_common.ros.estop import (
    EMERGENCY_STOP_INTERVAL,
    EMERGENCY_STOP_REPEATS,
    repeat_emergency_stop,
    settle_listeners,
)


class FakeClock:
    """A monotonic clock that only moves when the code under test waits."""

    def __init__(self) -> None:
        self.now = 0.0

    def __call__(self) -> float:
        return self.now

    def wait(self, seconds: float) -> None:
        self.now += seconds


def test_the_stop_is_published_at_once_and_repeated_for_a_second() -> None:
    clock = FakeClock()
    sent: list[float] = []
    assert repeat_emergency_stop(lambda: sent.append(clock.now), sleep=clock.wait) is None
    assert len(sent) == EMERGENCY_STOP_REPEATS
    assert sent[0] == 0.0
    gaps = [b - a for a, b in zip(sent, sent[1:], strict=False)]
    assert gaps == pytest.approx([EMERGENCY_STOP_INTERVAL] * (EMERGENCY_STOP_REPEATS - 1))
    # A listener that matches up to (repeats - 1) * interval after the first send still gets one.
    assert sent[-1] == pytest.approx(0.9)


def test_in_the_background_the_first_is_sent_before_the_call_returns() -> None:
    release = threading.Event()
    sent: list[int] = []
    thread = repeat_emergency_stop(lambda: sent.append(1), repeats=3, interval=0.0,
                                   background=True, sleep=lambda _s: release.wait(5.0))
    assert sent == [1]  # the repeats wait for the (held) sleep
    assert thread is not None
    release.set()
    thread.join(5.0)
    assert sent == [1, 1, 1]


def test_a_sender_destroyed_during_the_burst_ends_it_quietly() -> None:
    sent: list[int] = []

    def publish() -> None:
        if sent:
            msg = 'cannot use Destroyable because destruction was requested'
            raise RuntimeError(msg)
        sent.append(1)

    thread = repeat_emergency_stop(publish, repeats=3, interval=0.0, background=True)
    assert thread is not None
    thread.join(5.0)
    assert not thread.is_alive()
    assert sent == [1]


def test_the_first_publication_fails_loudly() -> None:
    def publish() -> None:
        msg = 'no publisher'
        raise RuntimeError(msg)

    with pytest.raises(RuntimeError, match='no publisher'):
        repeat_emergency_stop(publish, background=True)


@pytest.mark.parametrize(('repeats', 'interval'), [(0, 0.1), (3, -0.1), (3, float('nan'))])
def test_a_stop_that_would_never_be_sent_is_refused(repeats: int, interval: float) -> None:
    sent: list[int] = []
    with pytest.raises(ValueError, match='at least once'):
        repeat_emergency_stop(lambda: sent.append(1), repeats=repeats, interval=interval)
    assert sent == []


def test_settling_waits_for_every_listener_discovered_one_by_one() -> None:
    clock = FakeClock()
    # The integrator at 0.2 s, one bridge at 0.4 s, the other at 0.9 s.
    def count() -> int:
        return sum(clock.now >= t for t in (0.2, 0.4, 0.9))

    found = settle_listeners(count, timeout=10.0, settle=0.5, wait=clock.wait, clock=clock)
    assert found == 3
    assert clock.now >= 0.9 + 0.5 - 1e-9  # not sent at the first listener


def test_without_settling_the_first_listener_is_enough() -> None:
    clock = FakeClock()

    def count() -> int:  # a control's receiver at 0.3 s, a second listener at 0.5 s
        return sum(clock.now >= t for t in (0.3, 0.5))

    assert settle_listeners(count, timeout=10.0, settle=0.0, wait=clock.wait, clock=clock) == 1
    assert 0.3 <= clock.now < 0.4


def test_settling_gives_up_without_listeners() -> None:
    clock = FakeClock()
    assert settle_listeners(lambda: 0, timeout=2.0, wait=clock.wait, clock=clock) == 0
    assert 2.0 <= clock.now < 2.1


def test_settling_ends_even_if_listeners_keep_coming() -> None:
    clock = FakeClock()
    found = settle_listeners(lambda: int(clock.now * 100), timeout=1.0, settle=0.5,
                             wait=clock.wait, clock=clock)
    assert found > 0
    assert clock.now < 1.6  # at most timeout + settle

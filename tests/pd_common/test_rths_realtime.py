"""The real-time loop of a continuous actuator (:mod:`pd_common.rths.realtime`).

A fake clock (each reading advances it by 0.1 µs; a sleep advances it by what is asked) makes
the counts exact: no test depends on the machine's timing.
"""

from __future__ import annotations

import math
import sys
import time

import pytest

from pd_common.errors import RthsError
from pd_common.rths import ContinuousActuator, ContinuousMeasurement, continuous_from_config
from pd_common.rths.realtime import TIMER_SLACK, RealtimeLoop, set_timer_slack

RATE = 4096.0
DT = 4.0 / RATE  # four ticks a step
PERIOD = 1.0 / RATE
SECTION = {'plant': {'model': 'benchmark'}, 'compensator': {'name': 'pi_p'},
           'noise': {'displacement_power': 6.25e-14, 'force_power': 1.16e-3, 'seed': 5},
           'quantum': 2.0 ** -18}


class FakeClock:
    """Monotonic seconds that advance 0.1 µs per reading and by every sleep."""

    def __init__(self) -> None:
        self.now = 100.0
        self.sleeps = 0

    def __call__(self) -> float:
        self.now += 1e-7
        return self.now

    def sleep(self, seconds: float) -> None:
        assert seconds >= 0.0
        self.sleeps += 1
        self.now += seconds


def actuator() -> ContinuousActuator:
    return ContinuousActuator(continuous_from_config(SECTION, 'test'), DT)


def target(step: int) -> float:
    return 2e-3 * math.sin(2 * math.pi * 3.0 * step * DT)


def loop_with(clock: FakeClock) -> RealtimeLoop:
    return RealtimeLoop(actuator(), clock=clock, sleep=clock.sleep)


def test_targets_in_time_give_the_simulated_floats_and_no_missed_deadline() -> None:
    clock = FakeClock()
    loop = loop_with(clock)
    measured: list[ContinuousMeasurement] = []

    def on_measurement(measurement: ContinuousMeasurement) -> None:
        measured.append(measurement)
        loop.set_next_target(target(measurement.step + 1))  # at once: phase 0

    loop.on_measurement = on_measurement
    loop.set_next_target(target(1))
    loop.run(ticks=400)
    twin = actuator()
    expected = [twin.step(target(step)) for step in range(1, 101)]
    assert [m.displacement for m in measured] == [m.displacement for m in expected]
    assert [m.force for m in measured] == [m.force for m in expected]
    statistics = loop.statistics()
    assert statistics.ticks == 400 and statistics.steps == 100
    assert statistics.missed_deadlines == 0
    assert statistics.slowdown_fraction == 0.0 and statistics.predicted_samples == 0
    assert statistics.max_lateness_us < 1.0
    assert statistics.nominal_step_ms == pytest.approx(DT * 1e3)
    # Every step took four periods of the fake clock (within its reading increments).
    assert statistics.step_p50_ms == pytest.approx(DT * 1e3, abs=2e-3)
    assert statistics.step_max_ms == pytest.approx(DT * 1e3, abs=2e-3)
    assert 0.0 < statistics.tick_p50_us <= statistics.tick_p99_us <= statistics.tick_max_us < 1.0
    assert clock.sleeps == 399  # slept before every tick but the first (then spun)


@pytest.mark.parametrize(('stall_periods', 'missed'), [(0.5, 0), (1.9, 0), (3.0, 1), (9.5, 1)])
def test_a_stall_longer_than_a_period_is_one_missed_deadline(stall_periods: float,
                                                              missed: int) -> None:
    """A stall of s periods after a tick starts the next one (s - 1) periods late."""
    clock = FakeClock()
    loop = loop_with(clock)

    def on_measurement(measurement: ContinuousMeasurement) -> None:
        if measurement.step == 10:
            clock.now += stall_periods * PERIOD  # the integrator took that long
        loop.set_next_target(target(measurement.step + 1))

    loop.on_measurement = on_measurement
    loop.set_next_target(target(1))
    loop.run(ticks=200)
    statistics = loop.statistics()
    assert statistics.missed_deadlines == missed
    late = max(0.0, stall_periods - 1.0) * PERIOD * 1e6
    assert statistics.max_lateness_us == pytest.approx(late, abs=1.0)
    assert statistics.ticks == 200  # re-anchored: the missed ticks are not run in a burst


def test_the_target_latency_is_the_time_from_a_measurement_to_the_next_target() -> None:
    """The integrator's round trip as the actuator sees it: each step's reply delay, measured."""
    clock = FakeClock()
    loop = loop_with(clock)
    delays = [0.0, 0.3, 0.6]  # periods the integrator takes, in turn

    def on_measurement(measurement: ContinuousMeasurement) -> None:
        clock.now += delays[measurement.step % 3] * PERIOD
        loop.set_next_target(target(measurement.step + 1))

    loop.on_measurement = on_measurement
    loop.set_next_target(target(1))  # before the ticking: no measurement to wait for
    loop.run(ticks=120)  # 30 steps, 30 replies (the last one's step not ticked yet)
    statistics = loop.statistics()
    assert statistics.steps == 30
    # Ten replies of each delay, each a few readings of the fake clock (0.1 µs) longer.
    assert statistics.target_latency_p50_us == pytest.approx(0.3 * PERIOD * 1e6, abs=1.0)
    assert statistics.target_latency_max_us == pytest.approx(0.6 * PERIOD * 1e6, abs=1.0)
    assert statistics.target_latency_p99_us <= statistics.target_latency_max_us
    assert statistics.slowdown_fraction == 0.0  # 0.6 of a period is early enough


def test_no_target_latency_without_a_measured_step() -> None:
    loop = loop_with(FakeClock())
    loop.set_next_target(target(1))
    assert math.isnan(loop.statistics().target_latency_p50_us)


def test_a_missing_target_slows_the_actuator_down_to_a_hold() -> None:
    clock = FakeClock()
    loop = loop_with(clock)

    def on_measurement(measurement: ContinuousMeasurement) -> None:
        if measurement.step < 20:
            loop.set_next_target(target(measurement.step + 1))

    loop.on_measurement = on_measurement
    loop.set_next_target(target(1))
    loop.run(ticks=100)  # 20 steps (80 ticks), then 20 ticks without the target
    statistics = loop.statistics()
    counters = loop.actuator.counters
    assert statistics.steps == 20 and statistics.ticks == 100
    assert statistics.predicted_samples == counters.predicted_samples == 20
    assert statistics.slowed_samples == counters.slowed_samples > 0
    assert statistics.held_samples == counters.held_samples > 0
    assert statistics.slowdowns == 1
    assert statistics.slowdown_fraction == counters.slowed_samples / 100
    assert loop.actuator.phase == pytest.approx(0.8 * 4)  # held at hold_at
    # The target arrives late: the step completes, the rate recovers.
    loop.set_next_target(target(21))
    loop.run(ticks=20)
    assert loop.statistics().steps == 21
    assert loop.actuator.completed_steps == 21


def test_start_and_stop_a_ticking_thread() -> None:
    clock = FakeClock()
    loop = loop_with(clock)
    loop.set_next_target(target(1))
    loop.start()
    deadline = time.monotonic() + 10.0
    while loop.ticks < 50 and time.monotonic() < deadline:
        time.sleep(0.001)
    loop.stop()
    assert not loop.running and loop.error is None
    assert loop.ticks >= 50
    ticks = loop.ticks
    loop.start()
    loop.stop()
    assert loop.ticks >= ticks and not loop.running
    assert loop.statistics().as_dict()['ticks'] == loop.ticks


def test_a_bad_spin_is_refused() -> None:
    with pytest.raises(RthsError, match='realtime spin'):
        RealtimeLoop(actuator(), spin=-1.0)


@pytest.mark.parametrize('slack', [-1e-6, math.nan, math.inf])
def test_a_bad_timer_slack_is_refused(slack: float) -> None:
    with pytest.raises(RthsError, match='realtime timer_slack'):
        RealtimeLoop(actuator(), timer_slack=slack)


@pytest.mark.skipif(not sys.platform.startswith('linux'), reason='prctl timer slack: Linux')
def test_the_ticking_thread_sleeps_with_a_fine_timer_slack_and_gives_its_own_back() -> None:
    """While ticking, its sleeps may end 1 µs late (not 50 µs); afterwards, as before."""
    was = set_timer_slack(37e-6)  # this thread's, as a caller might have set it
    assert was is not None
    seen: list[float | None] = []

    def sleep(seconds: float) -> None:
        probe = set_timer_slack(1e-6)  # reads the slack in force (and sets the same again)
        seen.append(probe)

    loop = RealtimeLoop(actuator(), sleep=sleep)
    loop.set_next_target(target(1))
    loop.run(ticks=3)
    assert seen and all(value == pytest.approx(TIMER_SLACK) for value in seen)
    assert set_timer_slack(was) == pytest.approx(37e-6)  # given back after the ticks
    untouched = RealtimeLoop(actuator(), sleep=sleep, timer_slack=None)
    set_timer_slack(37e-6)
    seen.clear()
    untouched.run(ticks=3)
    assert seen and seen[0] == pytest.approx(37e-6)
    set_timer_slack(was)

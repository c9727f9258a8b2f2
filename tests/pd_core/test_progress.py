"""The console progress line: rate and ETA, also of a resumed run."""

from __future__ import annotations

from pd_core.run.loop.progress import ProgressMeter


class _Clock:
    def __init__(self) -> None:
        self.now = 100.0

    def __call__(self) -> float:
        return self.now


def test_rate_and_eta_count_the_steps_since_the_meter_started() -> None:
    clock = _Clock()
    meter = ProgressMeter(1000, interval=1.0, clock=clock)
    clock.now += 2.0
    line = meter.line(200)
    assert '100 steps/s' in line and 'ETA    8.0 s' in line and '( 20.0 %)' in line


def test_a_resumed_run_counts_from_its_first_step_not_from_zero() -> None:
    clock = _Clock()
    meter = ProgressMeter(1000, interval=1.0, clock=clock, first_step=600)
    clock.now += 2.0
    line = meter.line(700)  # 100 steps in 2 s since the resume
    assert '50 steps/s' in line and 'ETA    6.0 s' in line


def test_lines_at_most_every_interval_and_always_at_the_end() -> None:
    clock = _Clock()
    meter = ProgressMeter(10, interval=1.0, clock=clock)
    assert meter.update(1) is not None
    clock.now += 0.5
    assert meter.update(2) is None
    assert meter.update(10) is not None

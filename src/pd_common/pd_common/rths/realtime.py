"""Wall-clock real time: a continuous actuator ticked against controller deadlines.

:class:`RealtimeLoop` calls :meth:`~.continuous.ContinuousActuator.tick` once per controller
period, tick ``k`` due at ``t_0 + k / rate`` on a monotonic clock (``time.perf_counter``).
It sleeps until ``spin`` seconds before the deadline, then spins on the clock (``sleep`` is
coarse; spinning alone would hold the GIL that the thread delivering the targets needs). On
Linux the ticking thread's timer slack is set to ``timer_slack`` while it ticks (``prctl``; the
kernel's default lets a sleep end up to 50 µs late), so a short spin suffices and the GIL is
free for the rest of the period. While it ticks the loop also asks for the CPUs' shallowest
idle states (``cpu_latency``, :mod:`.cpu_latency`: a PM QoS request, machine-wide, root only),
so that a process woken by a message or a deadline starts at once. The
targets arrive from another thread or callback (:meth:`RealtimeLoop.set_next_target`); while
a step's target is missing the actuator follows the predictor and slows down smoothly
(:mod:`.continuous`). The measurement of a completed step goes to ``on_measurement``, called
in the ticking thread outside the loop's lock (it may set the next target at once).

A tick that starts more than one period after its deadline is a *missed deadline*: counted,
and the deadlines are re-anchored on that tick (the controller does not run the ticks it
missed in a burst: the actuator's time falls behind the wall clock by the stall). The
statistics (:class:`RealtimeStatistics`): ticks, missed deadlines, the largest lateness, the
actuator's slow-down counters (:class:`~.continuous.ActuatorCounters`), and percentiles of
the tick time (the duration of :meth:`~.continuous.ContinuousActuator.tick`), of the step
time (the wall time between two completed steps; the first from the start of the ticking) and
of the target latency (from a step's measurement, at the end of its tick, to the next step's
target: the integrator's round trip as the actuator sees it).

The clock and the sleep are injected: a fake clock makes every count exact in tests.
"""

from __future__ import annotations

import ctypes
import math
import sys
import threading
import time
from array import array
from collections.abc import Callable
from dataclasses import asdict, dataclass, replace
from typing import Any

import numpy as np

from ..errors import RthsError
from .continuous import ContinuousActuator, ContinuousMeasurement
from .cpu_latency import CPU_LATENCY, CpuLatencyRequest

__all__ = ['TIMER_SLACK', 'RealtimeLoop', 'RealtimeStatistics', 'set_timer_slack']

#: The ticking thread's timer slack, s: a sleep ends within about a microsecond of its time
#: (plus the machine's wake-up latency) instead of the kernel's default 50 µs.
TIMER_SLACK = 1.0e-6
_PR_SET_TIMERSLACK, _PR_GET_TIMERSLACK = 29, 30  # <linux/prctl.h>


def set_timer_slack(seconds: float) -> float | None:
    """Set the calling thread's timer slack; the one it had, s (``None``: not set, not Linux).

    The slack is how much later than asked the kernel may end the thread's sleeps (it groups
    wake-ups to save power; 50 µs by default). ``seconds`` is rounded to whole nanoseconds,
    at least one (0 would restore the thread's default).
    """
    if not sys.platform.startswith('linux'):
        return None
    try:
        prctl = ctypes.CDLL(None, use_errno=True).prctl
    except (OSError, AttributeError):
        return None
    was = int(prctl(_PR_GET_TIMERSLACK, 0, 0, 0, 0))
    if was < 0 or prctl(_PR_SET_TIMERSLACK, max(1, round(seconds * 1e9)), 0, 0, 0) != 0:
        return None
    return was * 1e-9


MeasurementHandler = Callable[[ContinuousMeasurement], None]
"""``handler(measurement)``: a step completed (called in the ticking thread)."""


@dataclass(frozen=True)
class RealtimeStatistics:
    """How a real-time run kept its deadlines.

    Attributes:
        controller_rate: The tick rate, Hz.
        ticks: Ticks run.
        steps: Steps completed.
        missed_deadlines: Ticks started more than one period after their deadline.
        max_lateness_us: The largest start after a deadline, µs.
        slowdown_fraction: Slowed ticks over all ticks (the actuator's counters).
        slowed_samples, held_samples, predicted_samples, slowdowns: The actuator's counters.
        tick_p50_us, tick_p99_us, tick_max_us: Tick time percentiles, µs.
        step_p50_ms, step_p99_ms, step_max_ms: Step time percentiles, ms.
        target_latency_p50_us, target_latency_p99_us, target_latency_max_us: Percentiles of
            the time from a step's measurement to the next step's target, µs (NaN: none).
        nominal_step_ms: Δt_int, ms (what a step takes when every deadline is kept).
        cpu_latency_held: Whether the CPUs' wake-up latency request was in force while it
            ticked (:mod:`.cpu_latency`).
        cpu_latency_note: Why it was not ('' when held or not asked for).
    """

    controller_rate: float
    ticks: int
    steps: int
    missed_deadlines: int
    max_lateness_us: float
    slowdown_fraction: float
    slowed_samples: int
    held_samples: int
    predicted_samples: int
    slowdowns: int
    tick_p50_us: float
    tick_p99_us: float
    tick_max_us: float
    step_p50_ms: float
    step_p99_ms: float
    step_max_ms: float
    nominal_step_ms: float
    target_latency_p50_us: float = math.nan
    target_latency_p99_us: float = math.nan
    target_latency_max_us: float = math.nan
    cpu_latency_held: bool = False
    cpu_latency_note: str = ''

    def as_dict(self) -> dict[str, Any]:
        """The fields as a JSON-ready mapping."""
        return asdict(self)


def _percentiles(values: array[float], scale: float) -> tuple[float, float, float]:
    if not values:
        return math.nan, math.nan, math.nan
    data = np.frombuffer(values, dtype=np.float64) * scale
    p50, p99 = np.percentile(data, [50.0, 99.0])
    return float(p50), float(p99), float(data.max())


class RealtimeLoop:
    """Ticks one actuator at its controller rate against the wall clock.

    Args:
        actuator: The actuator (at rest, or where a previous loop left it).
        on_measurement: Receives each completed step's measurement.
        clock: Monotonic seconds (default ``time.perf_counter``).
        sleep: Sleeps a number of seconds (default ``time.sleep``).
        spin: Seconds before a deadline at which sleeping gives way to spinning.
        switch_interval: The interpreter's thread switch interval to set while ticking, s
            (``sys.setswitchinterval``: a thread holding the GIL gives it up after that
            long; the default 5 ms would let the ROS thread delay many ticks); ``None``:
            leave it.
        timer_slack: The ticking thread's timer slack while it ticks, s (how late the kernel
            may end a sleep; Linux only); ``None``: leave it.
        cpu_latency: The CPUs' wake-up latency to request while it ticks, s
            (:class:`~.cpu_latency.CpuLatencyRequest`; held only where permitted, see
            :attr:`cpu_latency`); ``None``: request nothing.

    Attributes:
        cpu_latency: The request (``None``: none); its ``reason`` says why it was not held.

    Raises:
        RthsError: ``spin``, ``timer_slack`` or ``cpu_latency`` negative or not a number.
    """

    def __init__(self, actuator: ContinuousActuator, *,
                 on_measurement: MeasurementHandler | None = None,
                 clock: Callable[[], float] = time.perf_counter,
                 sleep: Callable[[float], None] = time.sleep, spin: float = 1.0e-4,
                 switch_interval: float | None = None,
                 timer_slack: float | None = TIMER_SLACK,
                 cpu_latency: float | None = CPU_LATENCY) -> None:
        """Build the loop (not ticking)."""
        if not (math.isfinite(spin) and spin >= 0.0):
            msg = f'realtime spin: must be a number of seconds >= 0, got {spin!r}'
            raise RthsError(msg)
        if timer_slack is not None and not (math.isfinite(timer_slack) and timer_slack >= 0.0):
            msg = f'realtime timer_slack: must be a number of seconds >= 0, got {timer_slack!r}'
            raise RthsError(msg)
        self.actuator = actuator
        self.on_measurement = on_measurement
        #: Receives what stopped the ticking thread (:meth:`start`), if it failed.
        self.on_error: Callable[[BaseException], None] | None = None
        self.period = actuator.controller_dt
        self._clock = clock
        self._sleep = sleep
        self._spin = float(spin)
        self._switch_interval = switch_interval
        self._timer_slack = timer_slack
        self.cpu_latency = None if cpu_latency is None else CpuLatencyRequest(cpu_latency)
        self._latency_held = False
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._error: BaseException | None = None
        self.ticks = 0
        self.missed_deadlines = 0
        self.max_lateness = 0.0
        self._tick_times: array[float] = array('d')
        self._step_times: array[float] = array('d')
        self._latencies: array[float] = array('d')
        self._measured_at: float | None = None  # a step measured, the next target awaited

    # -- targets -------------------------------------------------------------------------------
    def set_next_target(self, target: float) -> None:
        """The current step's target has arrived (any thread).

        Raises:
            RthsError: What :meth:`ContinuousActuator.set_next_target` refuses.
        """
        with self._lock:
            self.actuator.set_next_target(target)
            measured_at = self._measured_at
            if measured_at is not None:
                self._latencies.append(self._clock() - measured_at)
                self._measured_at = None

    # -- the loop ------------------------------------------------------------------------------
    @property
    def running(self) -> bool:
        """Whether the ticking thread runs."""
        thread = self._thread
        return thread is not None and thread.is_alive()

    @property
    def error(self) -> BaseException | None:
        """What stopped the ticking thread, if it failed."""
        return self._error

    def run(self, ticks: int | None = None) -> None:
        """Tick in this thread: ``ticks`` ticks, or until :meth:`stop` (``None``).

        Raises:
            RthsError: What the actuator raises (e.g. braking that does not fit).
        """
        clock, sleep, spin, period = self._clock, self._sleep, self._spin, self.period
        actuator, lock = self.actuator, self._lock
        tick_times, step_times = self._tick_times, self._step_times
        stop = self._stop
        previous = sys.getswitchinterval()
        if self._switch_interval is not None:
            sys.setswitchinterval(self._switch_interval)
        slack = None if self._timer_slack is None else set_timer_slack(self._timer_slack)
        request = self.cpu_latency
        if request is not None and request.acquire():
            self._latency_held = True
        try:
            deadline = clock()
            last_step = deadline
            count = 0
            while not stop.is_set() and (ticks is None or count < ticks):
                remaining = deadline - clock()
                if remaining > spin:
                    sleep(remaining - spin)
                while clock() < deadline:
                    pass
                start = clock()
                lateness = start - deadline
                if lateness > period:
                    deadline = start  # re-anchored: no burst of the missed ticks
                with lock:
                    if lateness > period:
                        self.missed_deadlines += 1
                    self.max_lateness = max(self.max_lateness, lateness)
                    measurement = actuator.tick()
                    end = clock()
                    tick_times.append(end - start)
                    self.ticks += 1
                    if measurement is not None:
                        step_times.append(end - last_step)
                        last_step = end
                        self._measured_at = end
                count += 1
                deadline += period
                if measurement is not None:
                    handler = self.on_measurement
                    if handler is not None:
                        handler(measurement)
        finally:
            if self._switch_interval is not None:
                sys.setswitchinterval(previous)
            if slack is not None:
                set_timer_slack(slack)
            if request is not None:
                request.release()

    def start(self) -> None:
        """Start ticking in a daemon thread (nothing if it runs already)."""
        thread = self._thread
        if thread is not None and thread.is_alive():
            if not self._stop.is_set() or thread is threading.current_thread():
                return
            thread.join()  # stopping: let it end, then tick again
        self._stop.clear()
        self._error = None

        def body() -> None:
            try:
                self.run()
            except Exception as error:  # noqa: BLE001 - kept and passed to the owner
                self._error = error
                if self.on_error is not None:
                    self.on_error(error)

        self._thread = threading.Thread(target=body, name='rths-realtime', daemon=True)
        self._thread.start()

    def stop(self, *, wait: bool = True) -> None:
        """Stop the ticking thread (``wait``: until it has ended; never from inside it)."""
        self._stop.set()
        thread = self._thread
        if wait and thread is not None and thread is not threading.current_thread():
            thread.join()

    # -- statistics ----------------------------------------------------------------------------
    def statistics(self) -> RealtimeStatistics:
        """The deadline statistics so far."""
        with self._lock:  # a snapshot: the ticking thread appends under the lock
            counters = replace(self.actuator.counters)
            tick_times, step_times = array('d', self._tick_times), array('d', self._step_times)
            latencies = array('d', self._latencies)
            ticks, missed, lateness = self.ticks, self.missed_deadlines, self.max_lateness
        tick = _percentiles(tick_times, 1.0e6)
        step = _percentiles(step_times, 1.0e3)
        latency = _percentiles(latencies, 1.0e6)
        return RealtimeStatistics(
            controller_rate=1.0 / self.period, ticks=ticks, steps=len(step_times),
            missed_deadlines=missed, max_lateness_us=lateness * 1.0e6,
            slowdown_fraction=counters.slowdown_fraction,
            slowed_samples=counters.slowed_samples, held_samples=counters.held_samples,
            predicted_samples=counters.predicted_samples, slowdowns=counters.slowdowns,
            tick_p50_us=tick[0], tick_p99_us=tick[1], tick_max_us=tick[2],
            step_p50_ms=step[0], step_p99_ms=step[1], step_max_ms=step[2],
            nominal_step_ms=self.actuator.integration_dt * 1.0e3,
            target_latency_p50_us=latency[0], target_latency_p99_us=latency[1],
            target_latency_max_us=latency[2], cpu_latency_held=self._latency_held,
            cpu_latency_note='' if self._latency_held or self.cpu_latency is None
            else self.cpu_latency.reason or '')

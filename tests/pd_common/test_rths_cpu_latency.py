"""The CPUs' wake-up latency request of the real-time loop (:mod:`pd_common.rths.cpu_latency`).

Most tests give the request an ordinary file for the kernel's ``/dev/cpu_dma_latency`` and
check what is written and when it is open; the last ones use the kernel's own file where this
process may write it (root), and read the machine-wide value back from it.
"""

from __future__ import annotations

import math
import os
import signal
import struct
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from pd_common.errors import RthsError
from pd_common.rths import BENCHMARK_SPECIMEN, ContinuousActuator, continuous_from_config
from pd_common.rths.cpu_latency import (
    CPU_LATENCY_DEVICE,
    CpuLatencyRequest,
    wall_clock_cpu_latency,
)
from pd_common.rths.realtime import RealtimeLoop
from pd_core.run.test_file import from_dict
from pd_rths_benchmark.core.native_loop import native_test_file
from pd_rths_benchmark.core.problem import benchmark_case

RATE = 4096.0
DT = 4.0 / RATE  # four ticks a step
SECTION = {'plant': {'model': 'benchmark'}, 'compensator': {'name': 'pi_p'},
           'quantum': 2.0 ** -18}


def actuator() -> ContinuousActuator:
    return ContinuousActuator(continuous_from_config(SECTION, 'test'), DT)


def open_descriptors() -> set[str]:
    """Where this process's open file descriptors point."""
    found = set()
    for entry in Path('/proc/self/fd').iterdir():
        try:
            found.add(os.readlink(entry))
        except OSError:
            continue  # closed while listing (the listing's own descriptor)
    return found


def test_the_request_writes_its_latency_in_microseconds_and_holds_the_file_open(
        tmp_path: Path) -> None:
    device = tmp_path / 'cpu_dma_latency'
    device.write_bytes(b'')
    request = CpuLatencyRequest(25e-6, device=device)
    assert not request.held and request.latency_us == 25
    assert request.acquire() and request.held and request.reason is None
    assert str(device) in open_descriptors()
    assert request.acquire()  # held already: nothing more written
    assert struct.unpack('=i', device.read_bytes()) == (25,)
    request.release()
    assert not request.held and str(device) not in open_descriptors()
    request.release()  # nothing held: nothing to do
    with CpuLatencyRequest(device=device) as zero:
        assert zero.held and zero.latency_us == 0
    assert not zero.held


def test_without_permission_nothing_is_held_and_the_reason_is_kept(tmp_path: Path) -> None:
    request = CpuLatencyRequest(device=tmp_path / 'absent' / 'cpu_dma_latency')
    assert not request.acquire()
    assert not request.held
    assert request.reason is not None and 'absent/cpu_dma_latency' in request.reason


@pytest.mark.parametrize('latency', [-1e-6, math.nan, math.inf, 1e6])
def test_a_bad_latency_is_refused_in_one_line(latency: float) -> None:
    with pytest.raises(RthsError, match='realtime cpu_latency') as caught:
        CpuLatencyRequest(latency)
    assert '\n' not in str(caught.value)
    with pytest.raises(RthsError, match='realtime cpu_latency'):
        RealtimeLoop(actuator(), cpu_latency=latency)


def loop_with(device: Path, seen: list[bool]) -> RealtimeLoop:
    """A loop whose request goes to ``device``; its sleeps note whether it is held."""
    loop = RealtimeLoop(actuator(), sleep=lambda seconds: seen.append(bool(
        loop.cpu_latency is not None and loop.cpu_latency.held)))
    loop.cpu_latency = CpuLatencyRequest(device=device)
    return loop


def test_the_loop_holds_the_request_while_it_ticks_and_only_then(tmp_path: Path) -> None:
    device = tmp_path / 'cpu_dma_latency'
    device.write_bytes(b'')
    seen: list[bool] = []
    loop = loop_with(device, seen)
    loop.set_next_target(1e-4)
    loop.run(ticks=6)
    assert seen and all(seen)
    assert loop.cpu_latency is not None and not loop.cpu_latency.held
    assert str(device) not in open_descriptors()
    statistics = loop.statistics()
    assert statistics.cpu_latency_held and statistics.cpu_latency_note == ''
    assert statistics.as_dict()['cpu_latency_held'] is True


def test_a_loop_that_may_not_hold_it_ticks_as_before_and_says_why(tmp_path: Path) -> None:
    seen: list[bool] = []
    loop = loop_with(tmp_path / 'absent' / 'cpu_dma_latency', seen)
    loop.set_next_target(1e-4)
    loop.run(ticks=6)
    assert loop.ticks == 6 and seen and not any(seen)
    statistics = loop.statistics()
    assert not statistics.cpu_latency_held
    assert 'absent/cpu_dma_latency' in statistics.cpu_latency_note
    assert not RealtimeLoop(loop.actuator, cpu_latency=None).statistics().cpu_latency_held


def test_a_failing_tick_still_ends_the_request(tmp_path: Path) -> None:
    device = tmp_path / 'cpu_dma_latency'
    device.write_bytes(b'')
    loop = loop_with(device, [])

    def broken() -> None:
        raise RthsError('the actuator broke')

    loop.actuator.tick = broken  # type: ignore[method-assign]
    with pytest.raises(RthsError, match='broke'):
        loop.run(ticks=3)
    assert loop.cpu_latency is not None and not loop.cpu_latency.held
    assert str(device) not in open_descriptors()


# -- the kernel's own file (root only) --------------------------------------------------------
needs_device = pytest.mark.skipif(
    not sys.platform.startswith('linux') or not os.access(CPU_LATENCY_DEVICE, os.W_OK),
    reason=f'{CPU_LATENCY_DEVICE}: not writable here (root only)')


def machine_latency_us() -> int:
    """The CPUs' wake-up latency in force now (the least of every process's requests), µs."""
    return int(struct.unpack('=i', CPU_LATENCY_DEVICE.read_bytes()[:4])[0])


@needs_device
def test_while_the_loop_ticks_the_machine_keeps_its_cpus_awake() -> None:
    seen: list[int] = []
    loop = RealtimeLoop(actuator(), sleep=lambda seconds: seen.append(machine_latency_us()))
    loop.set_next_target(1e-4)
    loop.run(ticks=6)
    assert seen and all(value == 0 for value in seen)
    assert loop.statistics().cpu_latency_held


@needs_device
def test_a_killed_process_leaves_no_request_behind() -> None:
    """The request ends with its process, however it ends: no crash leaves CPUs spinning."""
    before = machine_latency_us()
    unique = 123  # µs: distinguishable from every other request unless one is lower
    script = ('import sys, time; from pd_common.rths.cpu_latency import CpuLatencyRequest; '
              f'request = CpuLatencyRequest({unique}e-6); '
              'print(request.acquire(), flush=True); time.sleep(60)')
    child = subprocess.Popen([sys.executable, '-c', script], stdout=subprocess.PIPE, text=True)
    try:
        assert child.stdout is not None and child.stdout.readline().strip() == 'True'
        assert machine_latency_us() <= unique
    finally:
        child.send_signal(signal.SIGKILL)
        child.wait(timeout=10)
    if before > unique:  # nobody else held a lower request when the test began
        deadline = time.monotonic() + 5.0
        while machine_latency_us() != before and time.monotonic() < deadline:
            time.sleep(0.01)
        assert machine_latency_us() == before


# -- the integrator's host: what a test file's wall-clock sites ask for --------------------
def _benchmark_sites(**site: Any) -> dict[str, Any]:
    """The benchmark's test file (case 1) through the test-file loader: its ``sites`` as the
    integrator's definition holds them, lab1 updated with ``site``."""
    raw = native_test_file(benchmark_case(1), np.zeros(20), 0.02, padding_samples=0,
                           intensity=1.0, integration_dt=1.0 / 1024.0,
                           transfer_system={'plant': {'model': 'benchmark'}},
                           specimen=BENCHMARK_SPECIMEN,
                           bridge={'driver': 'transfer_system', 'clock': 'realtime'})
    for key, value in site.items():
        if value is None:
            raw['sites']['lab1'].pop(key, None)
        else:
            raw['sites']['lab1'][key] = value
    sites = from_dict(raw, source='test').sites
    assert sites is not None
    return sites


def test_a_wall_clock_site_asks_its_latency_of_the_integrators_host_too() -> None:
    assert wall_clock_cpu_latency(_benchmark_sites()) == 0.0  # the default: poll
    asked = _benchmark_sites(transfer_system={'plant': {'model': 'benchmark'},
                                              'realtime': {'cpu_latency': 5e-5}})
    assert wall_clock_cpu_latency(asked) == 5e-5
    nothing = _benchmark_sites(transfer_system={'plant': {'model': 'benchmark'},
                                                'realtime': {'cpu_latency': None}})
    assert wall_clock_cpu_latency(nothing) is None  # null: ask nothing
    simulated = _benchmark_sites(bridge={'driver': 'transfer_system', 'clock': 'simulated'})
    assert wall_clock_cpu_latency(simulated) is None  # simulated time: no deadline
    assert wall_clock_cpu_latency(None) is None and wall_clock_cpu_latency({}) is None


def test_of_several_wall_clock_sites_the_smallest_latency_is_asked() -> None:
    def site(clock: str, latency: object) -> dict[str, Any]:
        return {'bridge': {'driver': 'transfer_system', 'clock': clock},
                'transfer_system': {'realtime': {'cpu_latency': latency}}}

    sites = {'a': site('realtime', 2e-5), 'b': site('realtime', 1e-5),
             'c': site('simulated', 0.0), 'd': site('realtime', None)}
    assert wall_clock_cpu_latency(sites) == 1e-5
    with pytest.raises(RthsError, match=r'^sites\.e\.transfer_system\.realtime\.cpu_latency: '):
        wall_clock_cpu_latency({**sites, 'e': site('realtime', -1.0)})

"""A CPU wake-up latency request: the shallow idle states while a real-time loop runs.

An idle CPU enters an idle state (on a virtual machine: it halts, and the hypervisor takes it
back); waking it from a deep one takes tens to hundreds of microseconds, which a step's round
trip through two processes pays at every hop. Linux's PM QoS interface lets a process ask
for a largest acceptable wake-up latency: while the file ``/dev/cpu_dma_latency`` is held
open with a 32-bit value written to it (µs), the idle governor chooses no state slower to
leave than that; ``0`` keeps idle CPUs polling. The request is machine-wide (every CPU, every
process) and ends when the file is closed, by :meth:`CpuLatencyRequest.release` or by the
process's exit, however it exits: a crash cannot leave it behind.

This is what real-time Linux tools do while they run (``cyclictest`` holds ``0`` by default).
The price is power: idle CPUs spin instead of sleeping, for as long as the request is held.
Opening the file needs root (or a udev rule granting it); without it nothing is requested
and the reason is kept (:attr:`CpuLatencyRequest.reason`): the loop runs as before.
"""

from __future__ import annotations

import os
import struct
from collections.abc import Mapping
from pathlib import Path
from types import TracebackType
from typing import Any

from ..errors import RthsError

__all__ = ['CPU_LATENCY', 'CPU_LATENCY_DEVICE', 'LARGEST_CPU_LATENCY', 'CpuLatencyRequest',
           'check_cpu_latency', 'wall_clock_cpu_latency']

#: The latency a real-time loop asks for by default, s: none (idle CPUs poll).
CPU_LATENCY = 0.0
#: Linux's PM QoS request file for the CPUs' wake-up latency.
CPU_LATENCY_DEVICE = Path('/dev/cpu_dma_latency')
#: The largest request, s: the kernel's "no constraint" (PM_QOS_DEFAULT_VALUE, 2e9 µs).
LARGEST_CPU_LATENCY = 2000.0


def check_cpu_latency(latency: object, where: str) -> float:
    """``latency`` as a number of seconds a request may ask for.

    Raises:
        RthsError: not a number (a bool is not one), negative, NaN or beyond the kernel's
            range: one line starting with ``where``.
    """
    if (isinstance(latency, bool) or not isinstance(latency, int | float)
            or not 0.0 <= latency <= LARGEST_CPU_LATENCY):
        msg = (f'{where}: must be a number of seconds in [0, {LARGEST_CPU_LATENCY:g}], '
               f'got {latency!r}')
        raise RthsError(msg)
    return float(latency)


def wall_clock_cpu_latency(sites: Mapping[str, Any] | None) -> float | None:
    """The wake-up latency a test's own host asks for while the test runs, s.

    The smallest ``transfer_system.realtime.cpu_latency`` (default :data:`CPU_LATENCY`) of the
    sites whose bridge ticks against the wall clock (``sites.<site>.bridge.clock: realtime``),
    as the test file's ``sites`` section writes them; ``None`` when no site does, or every one
    asks nothing (``null``). A bridge holds its own site's request on its machine while it
    ticks; the integrator holds this one on its own, which is another machine when the bridge
    runs beside the actuator's controller.

    Raises:
        RthsError: a latency the request cannot ask for, naming its key.
    """
    asked: list[float] = []
    for name, site in (sites or {}).items():
        if not isinstance(site, Mapping):
            continue
        bridge = site.get('bridge')
        if not isinstance(bridge, Mapping) or bridge.get('clock') != 'realtime':
            continue
        transfer = site.get('transfer_system')
        realtime = transfer.get('realtime') if isinstance(transfer, Mapping) else None
        latency = (realtime.get('cpu_latency', CPU_LATENCY) if isinstance(realtime, Mapping)
                   else CPU_LATENCY)
        if latency is not None:
            asked.append(check_cpu_latency(
                latency, f'sites.{name}.transfer_system.realtime.cpu_latency'))
    return min(asked) if asked else None


class CpuLatencyRequest:
    """Holds a request for CPU wake-ups within ``latency`` seconds (while acquired).

    Args:
        latency: The largest acceptable wake-up latency, s (rounded to whole µs).
        device: The PM QoS file (tests: any writable file).

    Attributes:
        latency_us: The request, µs.
        held: Whether the request is in force.
        reason: Why the last :meth:`acquire` held nothing (``None``: held, or not tried).

    Raises:
        RthsError: ``latency`` negative, not a number or beyond the kernel's range.
    """

    def __init__(self, latency: float = CPU_LATENCY, *,
                 device: Path | str = CPU_LATENCY_DEVICE) -> None:
        """Prepare the request (nothing is held yet)."""
        self.latency_us = round(check_cpu_latency(latency, 'realtime cpu_latency') * 1e6)
        self.device = Path(device)
        self.reason: str | None = None
        self._fd: int | None = None

    @property
    def held(self) -> bool:
        """Whether the request is in force (its file open)."""
        return self._fd is not None

    def acquire(self) -> bool:
        """Hold the request (nothing if held already); whether it is in force."""
        if self._fd is not None:
            return True
        try:
            fd = os.open(self.device, os.O_WRONLY | os.O_CLOEXEC)
        except OSError as error:
            self.reason = f'{self.device}: {error.strerror or error}'
            return False
        try:
            os.write(fd, struct.pack('=i', self.latency_us))
        except OSError as error:
            os.close(fd)
            self.reason = f'{self.device}: {error.strerror or error}'
            return False
        self._fd, self.reason = fd, None
        return True

    def release(self) -> None:
        """End the request (nothing if not held)."""
        fd, self._fd = self._fd, None
        if fd is not None:
            os.close(fd)

    def __enter__(self) -> CpuLatencyRequest:
        """Acquire (whether it held: :attr:`held`)."""
        self.acquire()
        return self

    def __exit__(self, kind: type[BaseException] | None, error: BaseException | None,
                 trace: TracebackType | None) -> None:
        """Release."""
        self.release()

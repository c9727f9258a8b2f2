"""Sending the lab-wide emergency stop so that no listener misses it.

A reliable, volatile DDS writer delivers a message only to the readers it has matched when it
publishes; a bridge whose discovery of the sender is still under way (a sender that has just
started, a lost announcement on a loaded machine) would never see a single e-stop. Every
receiver latches the stop and a repeat changes nothing, so the sender publishes it
:data:`EMERGENCY_STOP_REPEATS` times, :data:`EMERGENCY_STOP_INTERVAL` s apart: a listener that
matches within that second still gets it. Used by ``./pd control estop`` and the console,
which also wait for a signed control's receiver with :func:`settle_listeners`.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable

__all__ = [
    'EMERGENCY_STOP_INTERVAL',
    'EMERGENCY_STOP_REPEATS',
    'repeat_emergency_stop',
    'settle_listeners',
]

#: How many times one emergency stop is published (the first at once).
EMERGENCY_STOP_REPEATS = 10
#: Seconds between two publications of the same emergency stop.
EMERGENCY_STOP_INTERVAL = 0.1


def repeat_emergency_stop(publish: Callable[[], None], *,
                          repeats: int = EMERGENCY_STOP_REPEATS,
                          interval: float = EMERGENCY_STOP_INTERVAL,
                          background: bool = False,
                          sleep: Callable[[float], None] = time.sleep) -> threading.Thread | None:
    """Publish an emergency stop now and again ``repeats - 1`` times, ``interval`` s apart.

    Args:
        publish: Publishes the stop once (e.g. ``lambda: publisher.publish(message)``).
        repeats: Publications in all, at least 1.
        interval: Seconds between two publications.
        background: Publish the first at once and the repeats from a daemon thread (returned),
            so a caller that must answer (a web request) is not held for the burst. A repeat
            that fails (the publisher was destroyed meanwhile) ends the burst quietly; the
            first publication's error, if any, reaches the caller.
        sleep: The wait between two publications.

    Raises:
        ValueError: ``repeats`` below 1 or a negative ``interval``.
    """
    if repeats < 1 or not interval >= 0.0:
        msg = (f'an emergency stop is published at least once, >= 0 s apart (got {repeats}, '
               f'{interval})')
        raise ValueError(msg)
    publish()

    def rest() -> None:
        for _ in range(repeats - 1):
            sleep(interval)
            publish()

    if not background:
        rest()
        return None

    def rest_quietly() -> None:
        try:
            rest()
        except Exception:  # noqa: BLE001 - the sender was destroyed: the first stop went out
            return

    thread = threading.Thread(target=rest_quietly, name='emergency-stop-repeats', daemon=True)
    thread.start()
    return thread


def settle_listeners(count: Callable[[], int], *, timeout: float, settle: float = 0.5,
                     wait: Callable[[float], None] = time.sleep,
                     clock: Callable[[], float] = time.monotonic) -> int:
    """Wait until a topic has listeners and their number has not grown for ``settle`` s.

    A sender that has just started learns of its listeners one by one; waiting for the first
    one alone would send an emergency stop to part of the lab. ``settle=0`` returns at the
    first listener (a signed control, which has one receiver).

    Args:
        count: The number of matched listeners now (``publisher.get_subscription_count``).
        timeout: Seconds to wait for the first listener; the settling may add ``settle``.
        settle: Seconds the count must stay unchanged (0: the first listener is enough).
        wait: Waits (or spins) for the given seconds.
        clock: Monotonic seconds.

    Returns:
        The number of listeners (0 if none came within ``timeout``).
    """
    deadline = clock() + timeout
    seen, since = count(), clock()
    while True:
        now = clock()
        if seen == 0:
            if now >= deadline:
                return 0
        elif now - since >= settle or now >= deadline + settle:
            return seen
        wait(0.05)
        current = count()
        if current != seen:
            seen, since = current, clock()

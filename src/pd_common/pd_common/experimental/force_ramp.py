"""The force ramp of a force-controlled actuator: never a jump.

A force-controlled actuator (e.g. a column's vertical actuator holding its axial load) goes
from the force it holds to a new target in equal sub-steps of at most ``max_increment``; the
bridge executes them one after the other (checking its stroke limits after each), and a
ROS-free run applies the same sub-steps to its simulated specimen, so both see the same
sequence of targets, bit for bit.
"""

from __future__ import annotations

import math

__all__ = ['RELATIVE_TOLERANCE', 'force_ramp']

#: A change within ``max_increment · (1 + RELATIVE_TOLERANCE)`` is one sub-step.
RELATIVE_TOLERANCE = 1e-9


def force_ramp(held: float, target: float, max_increment: float) -> list[float]:
    """The successive force targets from ``held`` to ``target`` [N], ``target`` last.

    ``n = ceil(|target − held| / max_increment)`` sub-steps ``held + k (target − held) / n``
    (k = 1..n, the last one exactly ``target``); ``[target]`` when ``max_increment`` is 0
    (no ramp) or the change is within it (to 1e-9 relative, so that one sub-step of a ramp,
    ramped again, is one step: a bridge's sub-steps sent to a simulator that ramps too give
    the same targets), ``[]`` when ``target == held``.

    Raises:
        ValueError: a non-finite force or a negative or non-finite ``max_increment``.
    """
    if not (math.isfinite(held) and math.isfinite(target)):
        msg = f'force ramp: forces must be finite, got {held!r} -> {target!r}'
        raise ValueError(msg)
    if not math.isfinite(max_increment) or max_increment < 0.0:
        msg = f'force ramp: max_increment must be >= 0 N, got {max_increment!r}'
        raise ValueError(msg)
    change = target - held
    if change == 0.0:
        return []
    if max_increment == 0.0 or abs(change) <= max_increment * (1.0 + RELATIVE_TOLERANCE):
        return [target]
    n = math.ceil(abs(change) / max_increment)
    return [held + change * k / n for k in range(1, n)] + [target]

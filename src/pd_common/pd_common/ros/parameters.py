"""Sealed parameters: with a key in use, a node's parameters are the ones it started with.

Anyone on the ROS domain can call a node's ``set_parameters`` service, and DDS cannot say who
did (no DDS-Security here). A node that authenticates its commands must not let that service
change what it does: the bridge's limits and driver, the integrator's resume policy
(``hold_on_resume``: a restarted integrator of a physical test waits for a person's signed
resume), the simulator's specimen. So every change after start is refused and counted (the
bridge's and the integrator's counts are in their statuses and the run's summary), and logged
without flooding the log; to change a parameter, the owner restarts the node.
"""

from __future__ import annotations

import math
import time
from collections import Counter
from typing import Any

from rcl_interfaces.msg import SetParametersResult
from rclpy.node import Node
from rclpy.parameter import Parameter

__all__ = ['LOG_EVERY_S', 'SEALED', 'seal_parameters']

#: The refusal's reason, as counted and reported.
SEALED = 'sealed'
#: Seconds between two log lines about refused calls after the first (a rogue's flood of
#: calls is counted, not logged one by one).
LOG_EVERY_S = 10.0


def seal_parameters(node: Node, who: str, instead: str, refused: Counter[str], *,
                    because: str = 'a key is in use') -> None:
    """Refuse every later ``set_parameters`` on ``node``.

    Each refused call is counted in ``refused[SEALED]``; the first is logged in one line, later
    ones at most every :data:`LOG_EVERY_S` seconds with the count so far. Call it once the node
    has declared its parameters: rclpy runs the callback on later declarations too.

    Args:
        node: the node to seal.
        who: the node as the log line and the reason name it (e.g. ``'the bridge'``).
        instead: what its owner does to change a parameter (e.g. ``'restart it with a new
            parameter file'``).
        refused: the node's refusal counts (by reason).
        because: why it is sealed, for the log line and the reason.
    """
    logged_at = -math.inf

    def sealed(parameters: list[Parameter[Any]]) -> SetParametersResult:
        nonlocal logged_at
        refused[SEALED] += 1
        now = time.monotonic()
        if now - logged_at >= LOG_EVERY_S:
            logged_at = now
            names = ', '.join(parameter.name for parameter in parameters)
            node.get_logger().warning(
                f'refused set_parameters ({names}): {who} is sealed ({because}); '
                f'{instead} ({refused[SEALED]} refused so far)')
        return SetParametersResult(successful=False, reason=(
            f'{SEALED}: the parameters of {who} are fixed at start ({because}); {instead}'))

    node.add_on_set_parameters_callback(sealed)

"""The executor of every node: rclpy's EventsExecutor, spun with ``spin_once`` loops.

``EventsExecutor().spin()`` does not return on shutdown with the wheels of this workspace, so
the nodes spin it with ``spin_once(timeout_sec=...)`` in loops of their own (which also lets
them poll timeouts and stop flags between events).
"""

from __future__ import annotations

import signal
import threading
from collections.abc import Callable
from typing import TYPE_CHECKING

import rclpy
from rclpy.experimental.events_executor import EventsExecutor
from rclpy.signals import SignalHandlerOptions

if TYPE_CHECKING:
    from rclpy.executors import Executor
    from rclpy.node import Node

__all__ = ['events_executor', 'init_with_stop_flag', 'spin_until_shutdown']


def events_executor(node: Node) -> Executor:
    """A new EventsExecutor with ``node`` added."""
    executor = EventsExecutor()
    executor.add_node(node)
    return executor


def spin_until_shutdown(executor: Executor, timeout_sec: float,
                        between: Callable[[], None] | None = None) -> None:
    """Spin ``executor`` until the context shuts down (SIGINT/SIGTERM), calling ``between``
    after every ``spin_once``.

    A callback that was running when a signal shut the context down fails to publish
    ("publisher's context is invalid"): that is the shutdown, not an error, and ends the loop
    quietly; the same failure while the context is still up is raised.
    """
    while rclpy.ok():
        try:
            executor.spin_once(timeout_sec=timeout_sec)
        except Exception:
            if rclpy.ok():
                raise
            return
        if between is not None:
            between()


def init_with_stop_flag(args: list[str] | None = None) -> threading.Event:
    """``rclpy.init`` without rclpy's signal handlers: SIGINT and SIGTERM only set the returned
    flag, so a node that must end cleanly (write its record, publish its final status) does so
    from its own loop instead of being interrupted in the middle of a write."""
    rclpy.init(args=args, signal_handler_options=SignalHandlerOptions.NO)
    stop = threading.Event()
    for number in (signal.SIGINT, signal.SIGTERM):
        signal.signal(number, lambda *_: stop.set())
    return stop

"""The executor of every node: rclpy's EventsExecutor, spun with ``spin_once`` loops.

``EventsExecutor().spin()`` does not return on shutdown with the wheels of this workspace, so
the nodes spin it with ``spin_once(timeout_sec=...)`` in loops of their own (which also lets
them poll timeouts and stop flags between events).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from rclpy.experimental.events_executor import EventsExecutor

if TYPE_CHECKING:
    from rclpy.executors import Executor
    from rclpy.node import Node

__all__ = ['events_executor']


def events_executor(node: Node) -> Executor:
    """A new EventsExecutor with ``node`` added."""
    executor = EventsExecutor()
    executor.add_node(node)
    return executor

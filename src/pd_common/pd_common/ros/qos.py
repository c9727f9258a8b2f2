"""The QoS profiles of the step protocol: one definition for every node."""

from __future__ import annotations

from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

__all__ = ['CONTROL_DEPTH', 'LATCHED_QOS', 'MONITOR_QOS', 'STEP_QOS']

#: Commands and feedback: reliable, keep-all: every message must arrive, in order.
STEP_QOS = QoSProfile(history=HistoryPolicy.KEEP_ALL, reliability=ReliabilityPolicy.RELIABLE,
                      durability=DurabilityPolicy.VOLATILE)
#: Statuses and the test definition: latched, a late joiner gets the last one.
LATCHED_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1,
                         reliability=ReliabilityPolicy.RELIABLE,
                         durability=DurabilityPolicy.TRANSIENT_LOCAL)
#: Live monitors: reliable, the last 100 samples for a slow subscriber.
MONITOR_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=100,
                         reliability=ReliabilityPolicy.RELIABLE,
                         durability=DurabilityPolicy.VOLATILE)
#: Queue depth of the operator topics (controls, emergency stops).
CONTROL_DEPTH = 10

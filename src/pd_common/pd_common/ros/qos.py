"""The QoS profiles of the step protocol: one definition for every node."""

from __future__ import annotations

from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

__all__ = ['CONTROL_DEPTH', 'LATCHED_QOS', 'LATCHED_READER_QOS', 'MONITOR_QOS', 'STEP_DEPTH',
           'STEP_QOS']

#: Commands and feedback: reliable and in order. Keep-last with a depth far above the
#: stop-and-wait protocol's few messages in flight, not keep-all: a reader that was killed stays
#: matched until its lease expires, and a keep-all writer then fills its history with samples
#: the dead reader never acknowledges until ``publish`` fails; keep-last never blocks.
STEP_DEPTH = 256
STEP_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=STEP_DEPTH,
                      reliability=ReliabilityPolicy.RELIABLE,
                      durability=DurabilityPolicy.VOLATILE)
#: Statuses and the test definition: latched, a late joiner gets the last one.
LATCHED_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1,
                         reliability=ReliabilityPolicy.RELIABLE,
                         durability=DurabilityPolicy.TRANSIENT_LOCAL)
#: A reader of a latched topic published once (the test definition), on which others may
#: publish too: each writer's latched sample is kept until taken, not only the last to arrive,
#: so a rogue's sample arriving with the genuine one cannot drop it (LATCHED_QOS's writers).
LATCHED_READER_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=16,
                                reliability=ReliabilityPolicy.RELIABLE,
                                durability=DurabilityPolicy.TRANSIENT_LOCAL)
#: Live monitors: reliable, the last 100 samples for a slow subscriber.
MONITOR_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=100,
                         reliability=ReliabilityPolicy.RELIABLE,
                         durability=DurabilityPolicy.VOLATILE)
#: Queue depth of the operator topics (controls, emergency stops).
CONTROL_DEPTH = 10

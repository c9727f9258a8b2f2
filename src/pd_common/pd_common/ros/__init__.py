"""The one part of pd_common that imports rclpy: QoS profiles and ``pd_msgs`` conversion."""

from __future__ import annotations

from .executor import events_executor
from .messages import command_message, feedback_message, now_stamp, stamp_from_ns, status_message
from .qos import CONTROL_DEPTH, LATCHED_QOS, MONITOR_QOS, STEP_QOS

__all__ = [
    'CONTROL_DEPTH',
    'LATCHED_QOS',
    'MONITOR_QOS',
    'STEP_QOS',
    'command_message',
    'events_executor',
    'feedback_message',
    'now_stamp',
    'stamp_from_ns',
    'status_message',
]

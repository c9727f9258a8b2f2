"""The one part of pd_common that imports rclpy: QoS profiles and ``pd_msgs`` conversion."""

from __future__ import annotations

from .controls import RESEND_S, ControlSender, Sent, emergency_stop_receivers, listens
from .estop import (
    EMERGENCY_STOP_INTERVAL,
    EMERGENCY_STOP_REPEATS,
    repeat_emergency_stop,
    settle_listeners,
)
from .executor import (
    TEARDOWN_TIMEOUT,
    events_executor,
    exit_process,
    init_with_stop_flag,
    quiet_at_shutdown,
    run_node,
    settle_collector,
    spin_until_shutdown,
)
from .keys import declare_key
from .messages import (
    command_message,
    control_message,
    feedback_message,
    fill_signature,
    now_stamp,
    offer_message,
    signed_control,
    stamp_from_ns,
    status_message,
)
from .parameters import SEALED, seal_parameters
from .qos import CONTROL_DEPTH, LATCHED_QOS, LATCHED_READER_QOS, MONITOR_QOS, STEP_QOS
from .session import OFFER_REFRESH_S, RefusalLog, SessionReceiver, SessionSender, new_epoch
from .statements import (
    HEARTBEAT_S,
    TRAJECTORY_TOPIC,
    Announcer,
    admit_trajectory,
    read_offer,
    read_status,
    remember_trajectory,
    sign_trajectory,
)

__all__ = [
    'CONTROL_DEPTH',
    'EMERGENCY_STOP_INTERVAL',
    'EMERGENCY_STOP_REPEATS',
    'HEARTBEAT_S',
    'LATCHED_QOS',
    'LATCHED_READER_QOS',
    'MONITOR_QOS',
    'OFFER_REFRESH_S',
    'RESEND_S',
    'SEALED',
    'STEP_QOS',
    'TEARDOWN_TIMEOUT',
    'TRAJECTORY_TOPIC',
    'Announcer',
    'ControlSender',
    'RefusalLog',
    'Sent',
    'SessionReceiver',
    'SessionSender',
    'admit_trajectory',
    'command_message',
    'control_message',
    'declare_key',
    'emergency_stop_receivers',
    'events_executor',
    'exit_process',
    'feedback_message',
    'fill_signature',
    'init_with_stop_flag',
    'listens',
    'new_epoch',
    'now_stamp',
    'offer_message',
    'quiet_at_shutdown',
    'read_offer',
    'read_status',
    'remember_trajectory',
    'repeat_emergency_stop',
    'run_node',
    'seal_parameters',
    'settle_collector',
    'settle_listeners',
    'sign_trajectory',
    'signed_control',
    'spin_until_shutdown',
    'stamp_from_ns',
    'status_message',
]

"""The step protocol's data types, conversions and topic names, shared by every package."""

from __future__ import annotations

from .answers import KeyedAnswers
from .convert import (
    command_from_message,
    control_from_message,
    feedback_from_message,
    signature_from_message,
    status_from_message,
)
from .messages import (
    Command,
    Control,
    ControlMode,
    Feedback,
    FeedbackStatus,
    SessionStart,
    StateOrigin,
    Status,
    StepKey,
    TestState,
)
from .signature import MAC_BYTES, Signature
from .topics import (
    DEFAULT_SITE,
    GLOBAL_EMERGENCY_STOP,
    NAMESPACE,
    site_topic,
    site_topic_name,
)

__all__ = [
    'DEFAULT_SITE',
    'GLOBAL_EMERGENCY_STOP',
    'MAC_BYTES',
    'NAMESPACE',
    'Command',
    'Control',
    'ControlMode',
    'Feedback',
    'FeedbackStatus',
    'KeyedAnswers',
    'SessionStart',
    'Signature',
    'StateOrigin',
    'Status',
    'StepKey',
    'TestState',
    'command_from_message',
    'control_from_message',
    'feedback_from_message',
    'signature_from_message',
    'site_topic',
    'site_topic_name',
    'status_from_message',
]

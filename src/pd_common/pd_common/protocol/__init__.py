"""The step protocol's data types, conversions and topic names, shared by every package."""

from __future__ import annotations

from .convert import command_from_message, feedback_from_message, status_from_message
from .messages import Command, Feedback, FeedbackStatus, Status, StepKey, TestState
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
    'NAMESPACE',
    'Command',
    'Feedback',
    'FeedbackStatus',
    'Status',
    'StepKey',
    'TestState',
    'command_from_message',
    'feedback_from_message',
    'site_topic',
    'site_topic_name',
    'status_from_message',
]

"""The step protocol's data types, conversions and topic names, shared by every package."""

from __future__ import annotations

from .answers import KeyedAnswers
from .bounds import MAX_REASON, MalformedMessageError, clip_reason
from .controls import (
    ACKNOWLEDGED,
    BRIDGE_CONTROLS,
    LIFECYCLE_CONTROLS,
    SUPERVISOR,
    SUPERVISOR_BRIDGE_CONTROLS,
    SUPERVISOR_TEST_CONTROLS,
    TEST_CONTROLS,
    Acknowledgement,
    Acknowledgements,
    acknowledgement,
    find_acknowledgement,
    operator_name,
    parse_acknowledgement,
)
from .convert import (
    command_from_message,
    control_from_message,
    feedback_from_message,
    offer_from_message,
    signature_from_message,
    stamp_ns_of,
    status_from_message,
)
from .holds import PersonHolds
from .messages import (
    Command,
    Control,
    ControlMode,
    Feedback,
    FeedbackStatus,
    Offer,
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
    'ACKNOWLEDGED',
    'BRIDGE_CONTROLS',
    'DEFAULT_SITE',
    'GLOBAL_EMERGENCY_STOP',
    'LIFECYCLE_CONTROLS',
    'MAC_BYTES',
    'MAX_REASON',
    'NAMESPACE',
    'SUPERVISOR',
    'SUPERVISOR_BRIDGE_CONTROLS',
    'SUPERVISOR_TEST_CONTROLS',
    'TEST_CONTROLS',
    'Acknowledgement',
    'Acknowledgements',
    'Command',
    'Control',
    'ControlMode',
    'Feedback',
    'FeedbackStatus',
    'KeyedAnswers',
    'MalformedMessageError',
    'Offer',
    'PersonHolds',
    'SessionStart',
    'Signature',
    'StateOrigin',
    'Status',
    'StepKey',
    'TestState',
    'acknowledgement',
    'clip_reason',
    'command_from_message',
    'control_from_message',
    'feedback_from_message',
    'find_acknowledgement',
    'offer_from_message',
    'operator_name',
    'parse_acknowledgement',
    'signature_from_message',
    'site_topic',
    'site_topic_name',
    'stamp_ns_of',
    'status_from_message',
]

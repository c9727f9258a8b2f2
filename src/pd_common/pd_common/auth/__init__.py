"""Authentication of commands, feedback and controls (HMAC-SHA256 with a per-rig key).

The Fast DDS of the wheels has no DDS-Security, so the application authenticates what moves
an actuator or changes a test: see docs/security.md for the threat model.

* :mod:`.keys` — key files (made by ``./pd keygen`` or ``run_test``; owner-only);
* :mod:`.signing` — signatures: key id, session nonce, sequence, MAC;
* :mod:`.payloads` — the fields each message kind authenticates;
* :mod:`.gates` — who may be obeyed: sessions for step messages, freshness for controls.
"""

from __future__ import annotations

from .errors import AuthError, KeyFileError
from .gates import (
    DEFAULT_CONTROL_WINDOW,
    CommandGate,
    ControlGate,
    ReplyGate,
    StatusGate,
    WatchGate,
    describe_refusals,
    merge_refusals,
)
from .keys import (
    KEY_BYTES,
    KEY_FILE_ENV,
    Key,
    default_rig_key,
    generate_key,
    load_key,
    new_key,
    operator_key_path,
)
from .payloads import (
    command_payload,
    control_payload,
    feedback_payload,
    offer_payload,
    session_start_payload,
    status_payload,
    trajectory_payload,
)
from .signing import (
    WIRE_COMMAND,
    WIRE_FEEDBACK,
    Refusal,
    Signer,
    WirePayload,
    canonical,
    mac_of,
    new_session,
    sign_wire_reply,
    verify_mac,
    wire_mac,
)

__all__ = [
    'DEFAULT_CONTROL_WINDOW',
    'KEY_BYTES',
    'KEY_FILE_ENV',
    'WIRE_COMMAND',
    'WIRE_FEEDBACK',
    'AuthError',
    'CommandGate',
    'ControlGate',
    'Key',
    'KeyFileError',
    'Refusal',
    'ReplyGate',
    'Signer',
    'StatusGate',
    'WatchGate',
    'WirePayload',
    'canonical',
    'command_payload',
    'control_payload',
    'default_rig_key',
    'describe_refusals',
    'feedback_payload',
    'generate_key',
    'load_key',
    'mac_of',
    'merge_refusals',
    'new_key',
    'new_session',
    'offer_payload',
    'operator_key_path',
    'session_start_payload',
    'sign_wire_reply',
    'status_payload',
    'trajectory_payload',
    'verify_mac',
    'wire_mac',
]

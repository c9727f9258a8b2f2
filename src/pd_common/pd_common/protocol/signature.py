"""The authentication carried by a signed message (made and checked by :mod:`pd_common.auth`)."""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ['MAC_BYTES', 'Signature']

#: Length of a MAC (HMAC-SHA256), bytes.
MAC_BYTES = 32


@dataclass(frozen=True)
class Signature:
    """The authentication of one message.

    Attributes:
        key_id: id of the key that signed it ('' = unsigned).
        session: the sender's session nonce (32 hex digits).
        sequence: strictly increasing within the session, from 1.
        mac: HMAC-SHA256 of the canonical encoding (32 bytes).
    """

    key_id: str = ''
    session: str = ''
    sequence: int = 0
    mac: bytes = b''

    @property
    def signed(self) -> bool:
        """Whether the message carries a signature at all."""
        return bool(self.key_id) and len(self.mac) == MAC_BYTES

"""Message authentication codes (HMAC-SHA256, Python's ``hmac``).

Every signed message carries a :class:`Signature`: the key id, a *session* nonce (random, per
sender and run), a strictly increasing *sequence* number within that session, and the MAC.
Changing anything the MAC covers (a target, a force, a status, the step, the session or the
sequence) invalidates it.

The step messages (command and feedback, the hot path) are signed as the bytes that travel: the
MAC covers a tag naming the message type and the message's CDR bytes from the first byte through
the signature's sequence (:class:`WirePayload`, :func:`pd_common.protocol.cdr.covered_part`),
one HMAC over one buffer, nothing encoded again; a receiver checks the bytes that arrived.

The other signed messages (controls, session starts and offers, statuses) are signed over a
canonical encoding of their kind and the fields that matter, then the key id, session and
sequence (:func:`canonical`). It is unambiguous: each value is tagged and length-prefixed,
integers are 64-bit, floats are their exact IEEE-754 bits (``-0.0`` and ``0.0`` differ, NaN is
its bits).
"""

from __future__ import annotations

import functools
import hashlib
import hmac
import secrets
import struct
from collections.abc import Callable, Iterable, Sequence
from enum import Enum
from typing import NamedTuple, SupportsFloat

from ..protocol.cdr import covered_part, seal
from ..protocol.frozen import signature_of
from ..protocol.signature import Signature
from .keys import Key

__all__ = ['WIRE_COMMAND', 'WIRE_FEEDBACK', 'Refusal', 'Signer', 'WirePayload', 'canonical',
           'mac_of', 'new_session', 'sign_wire_reply', 'verify_mac', 'wire_mac']

#: The message types signed as their bytes (:class:`WirePayload`'s ``kind``).
WIRE_COMMAND = 'pd_msgs/msg/StepCommand'
WIRE_FEEDBACK = 'pd_msgs/msg/StepFeedback'

Value = str | int | float | bytes | Sequence[str] | Sequence[float] | Sequence[int]


class Refusal(Enum):
    """Why a message was refused (the counters on a node's status use these names)."""

    UNSIGNED = 'unsigned'              # no signature at all
    WRONG_KEY = 'wrong_key'            # signed with another key (key id differs)
    FORGED = 'forged'                  # the MAC does not match the fields
    REPLAYED = 'replayed'              # the sequence does not increase (a copy of an old one)
    FOREIGN_SESSION = 'foreign_session'  # signed, but not in the session this node accepted
    NO_SESSION = 'no_session'          # a command before any signed session start
    STALE = 'stale'                    # a control whose time stamp is too old or in the future
    MISDIRECTED = 'misdirected'        # a control signed for another node
    FOREIGN_TEST = 'foreign_test'      # a control signed for another test
    MALFORMED = 'malformed'            # a field beyond its bound (pd_common.protocol.bounds)


def new_session() -> str:
    """A new random session nonce (128 bits, hex)."""
    return secrets.token_hex(16)


_PACK_INT = struct.Struct('>q').pack
_PACK_FLOAT = struct.Struct('>d').pack
_PACK_LENGTH = struct.Struct('>I').pack


def _encode_float(value: float) -> bytes:
    return b'f' + _PACK_FLOAT(value)


@functools.lru_cache(maxsize=256)
def _encode_str(value: str) -> bytes:
    # ids, names, sessions and messages repeat from message to message
    data = value.encode('utf-8')
    return b's' + _PACK_LENGTH(len(data)) + data


def _encode(value: Value, out: list[bytes]) -> None:
    kind = type(value)
    # the common exact types first; subclasses (bool, numpy scalars, enums) by isinstance
    if kind is float:
        out.append(b'f' + _PACK_FLOAT(value))
    elif kind is str:
        out.append(_encode_str(value))
    elif kind is int:
        out.append(b'i' + _PACK_INT(value))
    elif kind is tuple and all(type(item) is float for item in value):  # type: ignore[union-attr]
        out.append(b'l' + _PACK_LENGTH(len(value)))  # type: ignore[arg-type]
        out.extend(map(_encode_float, value))  # type: ignore[arg-type]
    elif isinstance(value, bool):
        out.append(b'b' + (b'\x01' if value else b'\x00'))
    elif isinstance(value, int):
        out.append(b'i' + _PACK_INT(value))
    elif isinstance(value, float):
        out.append(b'f' + _PACK_FLOAT(value))
    elif isinstance(value, str):  # a str subclass: its characters, not its str()
        data = value.encode('utf-8')
        out.append(b's' + _PACK_LENGTH(len(data)) + data)
    elif isinstance(value, bytes):
        out.append(b'y' + _PACK_LENGTH(len(value)) + value)
    else:
        items: list[SupportsFloat | str] = list(value)
        out.append(b'l' + _PACK_LENGTH(len(items)))
        for item in items:
            # numpy scalars (np.float64, np.int64) are encoded as the Python numbers they are
            _encode(item if isinstance(item, (str, int, float)) else float(item), out)


class WirePayload(NamedTuple):
    """What the MAC of a message signed as its bytes covers.

    Attributes:
        kind: the message type (:data:`WIRE_COMMAND`, :data:`WIRE_FEEDBACK`): a MAC made for
            one type never passes for another.
        covered: the message's CDR bytes from the first byte through the signature's sequence
            (key id, session and sequence are inside: nothing is appended).
    """

    kind: str
    covered: bytes


_BLOCK = 64  # SHA-256's block, bytes
_IPAD = bytes(x ^ 0x36 for x in range(256))
_OPAD = bytes(x ^ 0x5C for x in range(256))


class _Pads(NamedTuple):
    inner: hashlib._Hash  # SHA-256 after the key's inner pad (and the type tag)
    outer: hashlib._Hash  # ... after its outer pad


@functools.lru_cache(maxsize=16)
def _wire_keyed(secret: bytes, kind: str) -> _Pads:
    # HMAC (RFC 2104) spelled out over hashlib's SHA-256: the key's pads and the type tag
    # hashed once; per message two copies of a state, no hmac.HMAC object (0.9 against 1.5 µs)
    if len(secret) > _BLOCK:
        secret = hashlib.sha256(secret).digest()
    secret = secret.ljust(_BLOCK, b'\x00')
    inner = hashlib.sha256(secret.translate(_IPAD))
    inner.update(b'pd-wire\x00' + kind.encode('ascii') + b'\x00')
    return _Pads(inner, hashlib.sha256(secret.translate(_OPAD)))


def wire_mac(key: Key, payload: WirePayload) -> bytes:
    """The MAC of a message signed as its bytes: HMAC-SHA256 of its type tag and bytes."""
    pads = _wire_keyed(key.secret, payload.kind)
    inner = pads.inner.copy()
    inner.update(payload.covered)
    outer = pads.outer.copy()
    outer.update(inner.digest())
    return outer.digest()


def canonical(kind: str, fields: Iterable[Value]) -> bytes:
    """The unambiguous byte string of a message ``kind`` and its ``fields``, in order."""
    out: list[bytes] = [_encode_str(kind)]
    for value in fields:
        _encode(value, out)
    return b''.join(out)


def _authenticated(payload: bytes, key_id: str, session: str, sequence: int) -> bytes:
    return b''.join((payload, _encode_str(key_id), _encode_str(session),
                     b'i' + _PACK_INT(sequence)))


@functools.lru_cache(maxsize=16)
def _keyed(secret: bytes) -> hmac.HMAC:
    # HMAC-SHA256 with the key's pads already hashed: a copy per message skips that work
    return hmac.new(secret, digestmod='sha256')


def mac_of(key: Key, payload: bytes, session: str, sequence: int) -> bytes:
    """The MAC of ``payload`` (a :func:`canonical` encoding) with its session and sequence."""
    mac = _keyed(key.secret).copy()
    mac.update(_authenticated(payload, key.key_id, session, sequence))
    return mac.digest()


def verify_mac(key: Key, payload: bytes | WirePayload, signature: Signature) -> Refusal | None:
    """``None`` if ``signature`` authenticates ``payload`` with ``key``; else why not.

    ``payload``: a :func:`canonical` encoding, or the bytes of a message signed as its bytes
    (whose key id, session and sequence are inside them).
    """
    if not signature.signed:
        return Refusal.UNSIGNED
    # (a key id is hex: any other text is another key's, and compare_digest raises on a str
    # that is not ASCII: one rogue message would have stopped the node reading it)
    if not signature.key_id.isascii() or not hmac.compare_digest(signature.key_id, key.key_id):
        return Refusal.WRONG_KEY
    if isinstance(payload, WirePayload):
        expected = wire_mac(key, payload)
    else:
        expected = mac_of(key, payload, signature.session, signature.sequence)
    if not hmac.compare_digest(expected, signature.mac):
        return Refusal.FORGED
    return None


class Signer:
    """Signs the messages of one sender's session: a fixed nonce, an increasing sequence.

    Args:
        key: the key.
        session: the session nonce (default: a new random one).
    """

    def __init__(self, key: Key, session: str | None = None) -> None:
        self.key = key
        self.session = session or new_session()
        self.sequence = 0

    def sign(self, payload: bytes) -> Signature:
        """The signature of the next message (the sequence advances)."""
        self.sequence += 1
        return Signature(key_id=self.key.key_id, session=self.session, sequence=self.sequence,
                         mac=mac_of(self.key, payload, self.session, self.sequence))

    def sign_wire(self, kind: str, encode: Callable[[Signature], bytes]
                  ) -> tuple[bytes, Signature]:
        """The bytes of the next message signed as its bytes, and its signature.

        ``encode(signature)`` makes the message's CDR bytes with ``signature`` (its MAC empty);
        the MAC over them (:class:`WirePayload`) then closes them. The sequence advances.
        """
        self.sequence += 1
        return _sign_wire(self.key, kind, encode, self.session, self.sequence)


def _sign_wire(key: Key, kind: str, encode: Callable[[Signature], bytes], session: str,
               sequence: int) -> tuple[bytes, Signature]:
    covered = covered_part(encode(signature_of(key.key_id, session, sequence, b'')))
    mac = wire_mac(key, WirePayload(kind, covered))
    return seal(covered, mac), signature_of(key.key_id, session, sequence, mac)


def sign_wire_reply(key: Key, kind: str, encode: Callable[[Signature], bytes],
                    request: Signature) -> tuple[bytes, Signature]:
    """The bytes of a reply signed as its bytes, and its signature.

    A reply (step feedback) is bound to the command it answers: signed in the requester's
    session with the request's sequence, the requester admits it only in its own session and
    only with a sequence higher than any reply it took before, so a recorded reply cannot be
    played again, and a forged one cannot be made without the key.
    """
    return _sign_wire(key, kind, encode, request.session, request.sequence)

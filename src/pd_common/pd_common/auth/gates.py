"""Who may be obeyed: sessions for step messages, freshness for operator controls.

* :class:`CommandGate` — the receiver of step commands (a bridge, a simulator). It offers a
  random *challenge*; a signed *session start* that quotes the current challenge opens a
  session (and draws a new challenge, so a recorded start cannot be replayed); from then on
  only commands signed in that session, with increasing sequence numbers, are admitted.
* :class:`ReplyGate` — the sender's side (the integrator, a bridge driving a simulator): only
  replies signed for its own session, with increasing sequence numbers, are admitted.
* :class:`ControlGate` — operator controls (resume, abort, reset, ...): signed, stamped within
  a time window of the receiver's clock, and never twice (session and sequence remembered).

Each gate counts what it refused, by :class:`~.signing.Refusal`. A gate without a key admits
everything (authentication off: a test on an isolated machine that asked for it).
"""

from __future__ import annotations

import time
from collections import Counter
from collections.abc import Callable, Iterable, Mapping

from ..protocol.signature import Signature
from .keys import Key
from .signing import Refusal, new_session, verify_mac

__all__ = ['DEFAULT_CONTROL_WINDOW', 'CommandGate', 'ControlGate', 'ReplyGate',
           'describe_refusals', 'merge_refusals']

#: Largest difference between a control's stamp and the receiver's clock, s.
DEFAULT_CONTROL_WINDOW = 30.0


class _Gate:
    """Counting refusals; the key (``None``: authentication off)."""

    def __init__(self, key: Key | None) -> None:
        self.key = key
        self.refused: Counter[str] = Counter()
        self.last_refusal: tuple[Refusal, str] | None = None

    @property
    def enabled(self) -> bool:
        """Whether messages are authenticated."""
        return self.key is not None

    @property
    def refused_total(self) -> int:
        """Messages refused so far."""
        return sum(self.refused.values())

    def _refuse(self, reason: Refusal, signature: Signature) -> Refusal:
        self.refused[reason.value] += 1
        self.last_refusal = (reason, signature.key_id)
        return reason

    def _check_mac(self, payload: bytes, signature: Signature) -> Refusal | None:
        assert self.key is not None
        reason = verify_mac(self.key, payload, signature)
        return self._refuse(reason, signature) if reason is not None else None


class CommandGate(_Gate):
    """Admits step commands only in the session a signed start opened (receiver side)."""

    def __init__(self, key: Key | None) -> None:
        super().__init__(key)
        self.challenge = new_session()
        self.session: str | None = None
        self.last_sequence = 0

    def start(self, payload: bytes, challenge: str, signature: Signature) -> Refusal | None:
        """A session start quoting ``challenge``: open its session, or say why not.

        ``payload`` is the start's canonical encoding (it includes the challenge).
        """
        if self.key is None:
            self.session = signature.session
            self.last_sequence = signature.sequence
            return None
        reason = self._check_mac(payload, signature)
        if reason is not None:
            return reason
        if challenge != self.challenge:  # a start for an earlier offer: a replay
            return self._refuse(Refusal.REPLAYED, signature)
        self.session = signature.session
        self.last_sequence = signature.sequence
        self.challenge = new_session()
        return None

    def close(self) -> None:
        """End the session (deactivation, restart): a new signed start is needed."""
        self.session = None
        self.last_sequence = 0
        self.challenge = new_session()

    def admit(self, payload: bytes, signature: Signature) -> Refusal | None:
        """``None`` if the command may be obeyed; else why not (counted)."""
        if self.key is None:
            return None
        reason = self._check_mac(payload, signature)
        if reason is not None:
            return reason
        if self.session is None:
            return self._refuse(Refusal.NO_SESSION, signature)
        if signature.session != self.session:
            return self._refuse(Refusal.FOREIGN_SESSION, signature)
        if signature.sequence <= self.last_sequence:
            return self._refuse(Refusal.REPLAYED, signature)
        self.last_sequence = signature.sequence
        return None


class ReplyGate(_Gate):
    """Admits replies signed for the sender's own session, sequence increasing."""

    def __init__(self, key: Key | None, session: str) -> None:
        super().__init__(key)
        self.session = session
        self.last_sequence = 0

    def admit(self, payload: bytes, signature: Signature) -> Refusal | None:
        """``None`` if the reply is genuine and new; else why not (counted)."""
        if self.key is None:
            return None
        reason = self._check_mac(payload, signature)
        if reason is not None:
            return reason
        if signature.session != self.session:
            return self._refuse(Refusal.FOREIGN_SESSION, signature)
        if signature.sequence <= self.last_sequence:
            return self._refuse(Refusal.REPLAYED, signature)
        self.last_sequence = signature.sequence
        return None


class ControlGate(_Gate):
    """Admits signed operator controls stamped within ``window`` s, each at most once."""

    def __init__(self, key: Key | None, window: float = DEFAULT_CONTROL_WINDOW,
                 clock: Callable[[], float] = time.time) -> None:
        super().__init__(key)
        self.window = window
        self._clock = clock
        self._sessions: dict[str, tuple[int, float]] = {}  # session -> (last sequence, seen at)

    def admit(self, payload: bytes, signature: Signature, stamp: float) -> Refusal | None:
        """``None`` if the control may be obeyed; else why not (counted).

        Args:
            payload: the control's canonical encoding (it includes ``stamp``).
            signature: its signature.
            stamp: when it was issued, s since the epoch.
        """
        if self.key is None:
            return None
        reason = self._check_mac(payload, signature)
        if reason is not None:
            return reason
        now = self._clock()
        if abs(now - stamp) > self.window:
            return self._refuse(Refusal.STALE, signature)
        self._forget_before(now - 2.0 * self.window)
        last = self._sessions.get(signature.session)
        if last is not None and signature.sequence <= last[0]:
            return self._refuse(Refusal.REPLAYED, signature)
        self._sessions[signature.session] = (signature.sequence, now)
        return None

    def _forget_before(self, limit: float) -> None:
        """Sessions last seen before ``limit`` (their stamps are stale anyway)."""
        for session in [s for s, (_, seen) in self._sessions.items() if seen < limit]:
            del self._sessions[session]


def merge_refusals(counts: Iterable[Mapping[str, int]]) -> Counter[str]:
    """The refusals of several gates added up, by reason."""
    total: Counter[str] = Counter()
    for count in counts:
        total.update(count)
    return total


def describe_refusals(counts: Mapping[str, int]) -> str:
    """``'forged: 4, replayed: 1'`` (reasons sorted; '' when nothing was refused)."""
    return ', '.join(f'{reason}: {n}' for reason, n in sorted(counts.items()) if n)

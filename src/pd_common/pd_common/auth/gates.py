"""Who may be obeyed: sessions for step messages, freshness for operator controls.

* :class:`CommandGate` — the receiver of step commands (a bridge, a simulator). It offers a
  random *challenge*; a signed *session start* that quotes the current challenge opens a
  session (and draws a new challenge, so a recorded start cannot be replayed); from then on
  only commands signed in that session, with increasing sequence numbers, are admitted.
* :class:`ReplyGate` — the sender's side (the integrator, a bridge driving a simulator): only
  replies signed for its own session, with increasing sequence numbers, are admitted.
* :class:`ControlGate` — operator controls (resume, abort, reset, ...): signed, bound to the
  receiving node, its instance session and its test, stamped within a time window of the
  receiver's clock, and never twice (session and sequence remembered; the memory is seeded
  from the receiver's record after a restart, :meth:`ControlGate.remember`).
* :class:`StatusGate` — what a node says of itself (its status, its session offer): signed by
  a key holder, and never older than what the same publisher said before (sequence within a
  process, publication time across processes), so a recorded status or offer cannot be
  replayed as the node's word.

* :class:`WatchGate` — an observer of a hop's step messages (the console): it obeys
  nothing, but shows only what the two ends signed in the session the receiver's genuine
  offer names as active, each kind's sequence increasing, so a forged or replayed command or
  feedback never reaches a person's screen as the test's.

Each gate counts what it refused, by :class:`~.signing.Refusal`. A gate without a key admits
everything (authentication off: a test on an isolated machine that asked for it).
"""

from __future__ import annotations

import time
from collections import Counter, OrderedDict
from collections.abc import Callable, Iterable, Mapping

from ..protocol.messages import Control
from ..protocol.signature import Signature
from .keys import Key
from .payloads import control_payload
from .signing import WIRE_FEEDBACK, Refusal, WirePayload, new_session, verify_mac

__all__ = ['DEFAULT_CONTROL_WINDOW', 'CommandGate', 'ControlGate', 'ReplyGate', 'StatusGate',
           'WatchGate', 'describe_refusals', 'merge_refusals']

#: Largest difference between a control's stamp and the receiver's clock, s.
DEFAULT_CONTROL_WINDOW = 30.0


class _Latest:
    """The last sequence admitted from one signer, and the MACs admitted at it.

    A higher sequence is new. The same sequence again is new only where a second message may
    share it — a reply (a bridge that holds answers the command it last answered again, as a
    fault: another message, signed for the same request) — and only as another message: the
    same bytes again are a replay.
    """

    __slots__ = ('mac', 'others', 'sequence')

    def __init__(self, sequence: int = 0) -> None:
        self.sequence = sequence          # (a session start's: its commands follow it)
        self.mac = b''                    # the first MAC admitted at it
        self.others: set[bytes] = set()   # any later ones (rare: kept off the common path)

    def take(self, signature: Signature, *, repeatable: bool) -> bool:
        """Whether ``signature`` is new (it is then remembered)."""
        if signature.sequence > self.sequence:
            self.sequence, self.mac = signature.sequence, signature.mac
            if self.others:
                self.others = set()
            return True
        if (repeatable and signature.sequence == self.sequence > 0
                and signature.mac != self.mac and signature.mac not in self.others):
            self.others.add(signature.mac)
            return True
        return False


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

    def _check_mac(self, payload: bytes | WirePayload, signature: Signature) -> Refusal | None:
        assert self.key is not None
        reason = verify_mac(self.key, payload, signature)
        return self._refuse(reason, signature) if reason is not None else None

    def _admit_step(self, payload: WirePayload, signature: Signature, session: str | None,
                    latest: _Latest | None, *, repeatable: bool) -> Refusal | None:
        """A step message's admission: ``None``, or why not (counted).

        Its MAC, then ``session`` (``None``: none open), then its sequence against ``latest``
        (the last admitted in that session; ``repeatable``: see :class:`_Latest`). Without a
        key, everything.
        """
        if self.key is None:
            return None
        reason = self._check_mac(payload, signature)
        if reason is not None:
            return reason
        if session is None or latest is None:
            return self._refuse(Refusal.NO_SESSION, signature)
        if signature.session != session:
            return self._refuse(Refusal.FOREIGN_SESSION, signature)
        if not latest.take(signature, repeatable=repeatable):
            return self._refuse(Refusal.REPLAYED, signature)
        return None


class CommandGate(_Gate):
    """Admits step commands only in the session a signed start opened (receiver side)."""

    def __init__(self, key: Key | None) -> None:
        super().__init__(key)
        self.challenge = new_session()
        self.session: str | None = None
        self._latest = _Latest()

    def start(self, payload: bytes, challenge: str, signature: Signature) -> Refusal | None:
        """A session start quoting ``challenge``: open its session, or say why not.

        ``payload`` is the start's canonical encoding (it includes the challenge).
        """
        if self.key is None:
            self.session = signature.session
            self._latest = _Latest(signature.sequence)
            return None
        reason = self._check_mac(payload, signature)
        if reason is not None:
            return reason
        if challenge != self.challenge:  # a start for an earlier offer: a replay
            return self._refuse(Refusal.REPLAYED, signature)
        self.session = signature.session
        self._latest = _Latest(signature.sequence)
        self.challenge = new_session()
        return None

    def close(self) -> None:
        """End the session (deactivation, restart): a new signed start is needed."""
        self.session = None
        self._latest = _Latest()
        self.challenge = new_session()

    def admit(self, payload: WirePayload, signature: Signature) -> Refusal | None:
        """``None`` if the command may be obeyed; else why not (counted)."""
        return self._admit_step(payload, signature, self.session, self._latest,
                                repeatable=False)


class ReplyGate(_Gate):
    """Admits replies signed for the sender's own session, sequence increasing.

    A reply whose sequence is that of the last one admitted is new when it is another message
    (:class:`_Latest`): a bridge's hold answers its last command again, as a fault.
    """

    def __init__(self, key: Key | None, session: str) -> None:
        super().__init__(key)
        self.session = session
        self._latest = _Latest()

    def admit(self, payload: WirePayload, signature: Signature) -> Refusal | None:
        """``None`` if the reply is genuine and new; else why not (counted)."""
        return self._admit_step(payload, signature, self.session, self._latest,
                                repeatable=True)


class ControlGate(_Gate):
    """Admits signed operator controls bound to this receiver, fresh, each at most once.

    A control is obeyed only if its MAC is right, it names this node (``identity``), this
    node's instance ``session`` and the test it serves now, it is stamped within ``window`` s
    of the receiver's clock, and its ``(session, sequence)`` was never admitted before.

    Args:
        key: the key (``None``: authentication off, everything is admitted).
        identity: the receiving node's fully qualified name.
        session: the receiving node's instance session (random per process start).
        window: largest difference between a control's stamp and the clock, s.
        clock: the receiver's clock (s since the epoch).
    """

    def __init__(self, key: Key | None, identity: str = '', session: str = '',
                 window: float = DEFAULT_CONTROL_WINDOW,
                 clock: Callable[[], float] = time.time) -> None:
        super().__init__(key)
        self.identity = identity
        self.session = session
        self.window = window
        self._clock = clock
        self._seen: dict[str, int] = {}  # sender session -> last sequence admitted

    def admit(self, control: Control, signature: Signature, test_id: str) -> Refusal | None:
        """``None`` if ``control`` may be obeyed by this node serving ``test_id``.

        Else why not (counted).
        """
        if self.key is None:
            return None
        reason = self._check_mac(control_payload(control), signature)
        if reason is not None:
            return reason
        last = self._seen.get(signature.session)
        if last is not None and signature.sequence <= last:
            return self._refuse(Refusal.REPLAYED, signature)
        if control.target != self.identity:
            return self._refuse(Refusal.MISDIRECTED, signature)
        if control.session != self.session:
            return self._refuse(Refusal.FOREIGN_SESSION, signature)
        if control.test_id != test_id:
            return self._refuse(Refusal.FOREIGN_TEST, signature)
        if abs(self._clock() - control.stamp) > self.window:
            return self._refuse(Refusal.STALE, signature)
        self._seen[signature.session] = signature.sequence
        return None

    def remember(self, session: str, sequence: int) -> None:
        """A control admitted before (from the receiver's record): never admitted again."""
        if sequence > self._seen.get(session, 0):
            self._seen[session] = sequence


class StatusGate(_Gate):
    """Admits what nodes say of themselves (statuses, session offers) only as they signed it.

    Per ``source`` (a topic) it remembers the publisher's session, last sequence and
    publication time: within a session the sequence must increase; a new session (a
    restarted node) must not be older than the one it replaces. So a recording of an earlier
    status or offer is refused, and a forged one cannot be made without the key.
    """

    def __init__(self, key: Key | None) -> None:
        super().__init__(key)
        self._last: dict[str, tuple[str, int, int]] = {}  # source -> (session, sequence, ns)

    def admit(self, source: str, payload: bytes, signature: Signature, stamp_ns: int,
              where: Callable[[], Refusal | None] | None = None) -> Refusal | None:
        """``None`` if the statement published on ``source`` at ``stamp_ns`` is genuine and new.

        Else why not (counted). ``where``: why a genuine statement does not belong here,
        asked once its MAC is good and before anything of it is remembered.
        """
        if self.key is None:
            return None
        reason = self._check_mac(payload, signature)
        if reason is None and where is not None and (reason := where()) is not None:
            return self._refuse(reason, signature)
        if reason is not None:
            return reason
        if not self._newer(source, signature, stamp_ns):
            return self._refuse(Refusal.REPLAYED, signature)
        self._last[source] = (signature.session, signature.sequence, stamp_ns)
        return None

    def remember(self, source: str, signature: Signature, stamp_ns: int) -> None:
        """A statement on ``source`` taken before (a resumed reader's record), as if admitted.

        From now on only newer ones are admitted on ``source``.
        """
        if self._newer(source, signature, stamp_ns):
            self._last[source] = (signature.session, signature.sequence, stamp_ns)

    def _newer(self, source: str, signature: Signature, stamp_ns: int) -> bool:
        """Whether a statement is newer than the last on ``source``.

        Newer: a higher sequence in its session, or a new session not older than the last one.
        """
        last = self._last.get(source)
        if last is None:
            return True
        session, sequence, stamp = last
        return (signature.sequence > sequence if signature.session == session
                else stamp_ns >= stamp)


class WatchGate(_Gate):
    """Admits a hop's step messages for an observer that obeys none of them (see the module).

    :meth:`follow` is given the ``active_session`` of each genuine session offer of the hop's
    receiver (read through a :class:`StatusGate`); a command or a feedback is admitted when its
    MAC is good, it is signed in that session (a feedback is signed in its command's session)
    and its sequence is higher than the last of its kind admitted in that session — remembered
    across the receiver's restarts (its offer goes from the session to none and back), so a
    recording cannot be shown again then. A feedback may share its sequence with the one before
    when it is another message, as :class:`ReplyGate` admits it.
    """

    #: Sessions whose last sequences are remembered (the latest ones followed).
    SESSIONS_KEPT = 8

    def __init__(self, key: Key | None) -> None:
        super().__init__(key)
        self.session: str | None = None
        self._last: OrderedDict[str, dict[str, _Latest]] = OrderedDict()  # session -> kind

    def follow(self, active_session: str) -> None:
        """The receiver now obeys ``active_session`` ('' = none): the hop's messages follow it."""
        self.session = active_session or None
        if self.session is not None:
            self._last.setdefault(self.session, {})
            self._last.move_to_end(self.session)
            while len(self._last) > self.SESSIONS_KEPT:
                self._last.popitem(last=False)

    def admit(self, payload: WirePayload, signature: Signature) -> Refusal | None:
        """``None`` if the message may be shown as the hop's; else why not (counted)."""
        # (:meth:`follow` keeps the session followed: never the one dropped)
        latest = (self._last[self.session].setdefault(payload.kind, _Latest())
                  if self.session is not None else None)
        return self._admit_step(payload, signature, self.session, latest,
                                repeatable=payload.kind == WIRE_FEEDBACK)


def merge_refusals(counts: Iterable[Mapping[str, int]]) -> Counter[str]:
    """The refusals of several gates added up, by reason."""
    total: Counter[str] = Counter()
    for count in counts:
        total.update(count)
    return total


def describe_refusals(counts: Mapping[str, int]) -> str:
    """``'forged: 4, replayed: 1'`` (reasons sorted; '' when nothing was refused)."""
    return ', '.join(f'{reason}: {n}' for reason, n in sorted(counts.items()) if n)
